"""The rendered person: a triangle mesh of generalised cylinders built on the 19 key points.

Every body part is a *tube*: rings of a superellipse cross-section (half-widths ``a`` across the
body and ``b`` front-back) placed along an axis between two key points, closed at both ends by
rings shrinking to a point. The trunk's width and depth vary with height (buttocks, iliac crest,
waist, chest, shoulders) and its cross-section turns from the hip line to the shoulder line;
the head is an ellipsoid with hair on top and at the back; the limbs taper with a calf bulge;
the feet are rounded boxes (superellipse exponent 4) from the heel to beyond the toe. Sizes are
fractions of stature, widened by ``girth``, ``belly`` and the clothing style (loose shirts and
trousers, flared trouser hems, a skirt or coat hem that follows the spread of the knees).

This is deliberately unrelated to the tracker's body model (tapered capsules): the tracker must
not be scored on its own image of itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitwatch.conventions import (
    HEAD,
    L_ANKLE,
    L_ELBOW,
    L_HEEL,
    L_HIP,
    L_KNEE,
    L_SHOULDER,
    L_TOE,
    L_WRIST,
    NECK,
    R_ANKLE,
    R_ELBOW,
    R_HEEL,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_TOE,
    R_WRIST,
)
from gaitwatch.sim.scene import ResolvedBody

UP = np.array([0.0, 0.0, 1.0])
N_AROUND = 16


@dataclass
class Mesh:
    """A triangle mesh in the world frame.

    Attributes
    ----------
    vertices : ndarray (V, 3), metres
    normals : ndarray (V, 3), unit outward vertex normals
    albedo : ndarray (V, 3), RGB reflectance in [0, 1]
    triangles : ndarray (F, 3), int64 vertex indices
    texcoords : ndarray (V, 3) or None
        Per vertex: metres along its part's axis, and ``r cos(theta)``, ``r sin(theta)`` around
        it (r the mean half-width of the ring), for cloth patterns.
    patterned : ndarray (V,) or None
        1.0 where the cloth pattern applies (the shirt or coat), else 0.0.
    """

    vertices: np.ndarray
    normals: np.ndarray
    albedo: np.ndarray
    triangles: np.ndarray
    texcoords: np.ndarray | None = None
    patterned: np.ndarray | None = None


@dataclass
class _Tube:
    p0: np.ndarray  # (3,)
    p1: np.ndarray  # (3,)
    u_ref: np.ndarray  # (R, 3) lateral reference per ring
    s: np.ndarray  # (R,) fraction of |p1 - p0| along the axis
    extra: np.ndarray  # (R,) metres added along the axis
    a: np.ndarray  # (R,) half-width along u
    b: np.ndarray  # (R,) half-width along v
    v_off: np.ndarray  # (R,) ring centre shift along v
    colour: np.ndarray  # (R, 3) or (R, N, 3)
    exponent: float = 2.0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _grid_triangles(n_rings: int, n_around: int) -> np.ndarray:
    """Triangles of a closed-around ring grid, wound so cross(e1, e2) points outwards."""
    k, j = np.meshgrid(np.arange(n_rings - 1), np.arange(n_around), indexing="ij")
    k, j = k.ravel(), j.ravel()
    j1 = (j + 1) % n_around
    a = k * n_around + j
    b = k * n_around + j1
    c = (k + 1) * n_around + j1
    d = (k + 1) * n_around + j
    return np.concatenate([np.stack([a, b, d], 1), np.stack([b, c, d], 1)])


def _tube_vertices(t: _Tube, cos_t: np.ndarray, sin_t: np.ndarray) -> np.ndarray:
    axis = t.p1 - t.p0
    length = float(np.linalg.norm(axis))
    w = axis / max(length, 1e-9)
    u = t.u_ref - (t.u_ref @ w)[:, None] * w
    bad = np.linalg.norm(u, axis=1) < 1e-6
    if bad.any():  # lateral reference along the axis: pick any perpendicular
        alt = np.cross(w, [1.0, 0.0, 0.0] if abs(w[0]) < 0.9 else [0.0, 1.0, 0.0])
        u[bad] = alt
    u = _unit(u)
    v = np.cross(w, u)
    centres = t.p0 + (t.s * length + t.extra)[:, None] * w + t.v_off[:, None] * v
    e = 2.0 / t.exponent
    cx = np.sign(cos_t) * np.abs(cos_t) ** e
    cy = np.sign(sin_t) * np.abs(sin_t) ** e
    return (
        centres[:, None, :]
        + (t.a[:, None] * cx[None, :])[..., None] * u[:, None, :]
        + (t.b[:, None] * cy[None, :])[..., None] * v[:, None, :]
    )


def _caps(
    s: list[float], extra: list[float], a: list[float], b: list[float], cap0: float, cap1: float
) -> tuple[list[float], list[float], list[float], list[float]]:
    """Add rounded end caps (two rings shrinking to a point) of lengths cap0/cap1 metres."""
    s2 = [s[0]] * 3 + list(s) + [s[-1]] * 3
    ang = np.radians([0.0, 50.0, 75.0])
    ex0 = [extra[0] - cap0 * np.cos(x) for x in ang]
    ex1 = [extra[-1] + cap1 * np.cos(x) for x in ang[::-1]]
    f0 = [np.sin(x) for x in ang]
    f1 = f0[::-1]
    return (
        s2,
        ex0 + list(extra) + ex1,
        [a[0] * f for f in f0] + list(a) + [a[-1] * f for f in f1],
        [b[0] * f for f in f0] + list(b) + [b[-1] * f for f in f1],
    )


class BodyModel:
    """A clothed body of a given build, posed by the 19 key points frame by frame.

    Parameters
    ----------
    body : ResolvedBody
        Stature (m), girth, belly, clothing style and colours.
    n_around : int
        Vertices per cross-section ring.
    """

    def __init__(self, body: ResolvedBody, n_around: int = N_AROUND) -> None:
        self.body = body
        self.n_around = n_around
        th = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
        self._cos, self._sin = np.cos(th), np.sin(th)
        self.colours = {
            k: np.asarray(getattr(body, k), dtype=float) / 255.0
            for k in ("shirt", "trousers", "skin", "shoes", "hair")
        }
        self._topology: tuple[np.ndarray, np.ndarray] | None = None

    # -- parts ------------------------------------------------------------------------------
    def _parts(self, kp: np.ndarray) -> list[_Tube]:
        S = self.body.stature_m
        g = self.body.girth
        style = self.body.style
        col = self.colours
        shirt_extra = {"fitted": 0.004, "loose": 0.012, "skirt": 0.004, "coat": 0.02}[style] * S
        trouser_extra = {"fitted": 0.004, "loose": 0.012, "skirt": 0.0, "coat": 0.006}[style] * S
        lower_col = col["trousers"]
        shank_col = col["skin"] if style == "skirt" else col["trousers"]
        sleeve_col = self._coat_colour if style == "coat" else col["shirt"]
        if style == "coat":
            lower_col = col["trousers"]
        parts: list[_Tube] = []

        lp = _unit(kp[L_HIP] - kp[R_HIP])
        ls = _unit(kp[L_SHOULDER] - kp[R_SHOULDER])
        mid_hip = 0.5 * (kp[L_HIP] + kp[R_HIP])
        fwd = _unit(np.cross(lp, UP))

        def tube(p0, p1, u_ref, s, extra, a, b, colour, v_off=None, exponent=2.0) -> _Tube:
            r = len(s)
            u_ref = np.broadcast_to(np.asarray(u_ref, dtype=float), (r, 3)).copy()
            colour = np.asarray(colour, dtype=float)
            if colour.ndim == 1:
                colour = np.broadcast_to(colour, (r, 3)).copy()
            return _Tube(
                np.asarray(p0, float),
                np.asarray(p1, float),
                u_ref,
                np.asarray(s, float),
                np.asarray(extra, float),
                np.asarray(a, float),
                np.asarray(b, float),
                np.zeros(r) if v_off is None else np.asarray(v_off, float),
                colour,
                exponent,
            )

        # Trunk: mid-hip -> neck. v = w x u points backwards for an upright trunk.
        belly = self.body.belly
        ts = [0.0, 0.0, 0.2, 0.42, 0.65, 0.85, 0.95, 1.0]
        tex = [-0.06 * S, 0, 0, 0, 0, 0, 0, 0.012 * S]
        ta = np.array([0.08, 0.095, 0.088, 0.080, 0.090, 0.095, 0.080, 0.045]) * S * g
        tb = np.array([0.06, 0.066, 0.062, 0.058, 0.064, 0.060, 0.050, 0.038]) * S * g
        tb[2:5] *= [1 + 0.3 * (belly - 1), belly, 1 + 0.4 * (belly - 1)]
        voff = np.zeros(len(ts))
        voff[2:5] = -(tb[2:5] - np.array([0.062, 0.058, 0.064]) * S * g) * 0.8  # belly in front
        wear = np.array(
            [trouser_extra] * 2 + [0.5 * (trouser_extra + shirt_extra)] + [shirt_extra] * 5
        )
        ta, tb = ta + wear, tb + wear
        ts, tex, ta, tb = _caps(ts, tex, list(ta), list(tb), 0.03 * S, 0.02 * S)
        voff = np.concatenate([[voff[0]] * 3, voff, [voff[-1]] * 3])
        n_r = len(ts)
        s_arr = np.asarray(ts)
        trunk_col = np.where((s_arr < 0.3)[:, None], lower_col, col["shirt"])
        if style == "coat":
            trunk_col = np.broadcast_to(self._coat_colour, (n_r, 3))
        u_ref = _unit((1 - s_arr)[:, None] * lp + s_arr[:, None] * ls)
        parts.append(tube(mid_hip, kp[NECK], u_ref, ts, tex, ta, tb, trunk_col, v_off=voff))

        # Neck and head.
        head_axis = _unit(kp[HEAD] - kp[NECK])
        parts.append(
            tube(
                kp[NECK] - 0.01 * S * head_axis,
                kp[HEAD],
                ls,
                *_caps(
                    [0.0, 0.6],
                    [0.0, 0.0],
                    [0.028 * S * g**0.5] * 2,
                    [0.03 * S * g**0.5] * 2,
                    0.005 * S,
                    0.005 * S,
                ),
                col["skin"],
            )  # fmt: skip
        )
        lat = np.radians(np.linspace(-90, 90, 11))
        ha, hb, hc = 0.046 * S, 0.055 * S, 0.064 * S
        head_col = np.broadcast_to(col["skin"], (len(lat), self.n_around, 3)).copy()
        # v points backwards: sin > 0 is the back of the head.
        hair = (lat[:, None] > np.radians(25)) | (
            (lat[:, None] > np.radians(-20)) & (self._sin[None, :] > 0.2)
        )
        head_col[hair] = col["hair"]
        parts.append(
            tube(
                kp[HEAD],
                kp[HEAD] + head_axis,
                ls,
                np.zeros(len(lat)),
                hc * np.sin(lat),
                ha * np.cos(lat),
                hb * np.cos(lat),
                head_col,
            )  # fmt: skip
        )

        # Arms and hands.
        for sh, el, wr in ((L_SHOULDER, L_ELBOW, L_WRIST), (R_SHOULDER, R_ELBOW, R_WRIST)):
            ua = tube(kp[sh], kp[el], ls, *_caps(
                [0.0, 0.5, 1.0], [0.0, 0.0, 0.0],
                list(np.array([0.033, 0.029, 0.024]) * S * g + shirt_extra),
                list(np.array([0.035, 0.030, 0.025]) * S * g + shirt_extra),
                0.03 * S, 0.012 * S), sleeve_col)  # fmt: skip
            fa_col = sleeve_col if self.body.long_sleeves or style == "coat" else col["skin"]
            fa_extra = shirt_extra * (1.0 if self.body.long_sleeves else 0.0)
            fa = tube(kp[el], kp[wr], ls, *_caps(
                [0.0, 0.4, 1.0], [0.0, 0.0, 0.0],
                list(np.array([0.024, 0.023, 0.017]) * S * g + fa_extra),
                list(np.array([0.025, 0.024, 0.018]) * S * g + fa_extra),
                0.012 * S, 0.006 * S), fa_col)  # fmt: skip
            d = _unit(kp[wr] - kp[el])
            hand = tube(kp[wr], kp[wr] + d * 0.1 * S, ls, *_caps(
                [0.0, 0.5, 0.9], [0.0, 0.0, 0.0],
                list(np.array([0.012, 0.013, 0.010]) * S),
                list(np.array([0.020, 0.025, 0.018]) * S),
                0.005 * S, 0.012 * S), col["skin"])  # fmt: skip
            parts += [ua, fa, hand]

        # Legs and shoes.
        for hip, kn, an, he, to in (
            (L_HIP, L_KNEE, L_ANKLE, L_HEEL, L_TOE),
            (R_HIP, R_KNEE, R_ANKLE, R_HEEL, R_TOE),
        ):
            th_a = np.array([0.058, 0.052, 0.040, 0.033]) * S * g + trouser_extra
            th_b = np.array([0.060, 0.055, 0.042, 0.035]) * S * g + trouser_extra
            parts.append(
                tube(
                    kp[hip],
                    kp[kn],
                    lp,
                    *_caps(
                        [0.0, 0.3, 0.75, 1.0],
                        [-0.03 * S, 0.0, 0.0, 0.0],
                        list(th_a),
                        list(th_b),
                        0.02 * S,
                        0.02 * S,
                    ),
                    lower_col,
                )  # fmt: skip
            )
            sh_a = np.array([0.033, 0.035, 0.026, 0.020]) * S * g**0.7
            sh_b = np.array([0.034, 0.039, 0.028, 0.021]) * S * g**0.7
            if style == "loose":
                sh_a = np.maximum(sh_a + trouser_extra, [0.0, 0.0, 0.040 * S, 0.046 * S])
                sh_b = np.maximum(sh_b + trouser_extra, [0.0, 0.0, 0.040 * S, 0.046 * S])
            elif style != "skirt":
                sh_a, sh_b = sh_a + trouser_extra, sh_b + trouser_extra
            parts.append(
                tube(
                    kp[kn],
                    kp[an],
                    lp,
                    *_caps(
                        [0.0, 0.3, 0.7, 1.0],
                        [0.0, 0.0, 0.0, 0.0],
                        list(sh_a),
                        list(sh_b),
                        0.015 * S,
                        0.012 * S,
                    ),
                    shank_col,
                )  # fmt: skip
            )
            # Shoe: sole along heel -> toe, box-like section raised above the sole line.
            axis = _unit(kp[to] - kp[he])
            u_sh = _unit(np.cross(UP, axis))
            if not np.isfinite(u_sh).all() or np.linalg.norm(np.cross(UP, axis)) < 1e-6:
                u_sh = lp
            fs = [0.0, 0.0, 0.3, 0.65, 1.0, 1.0]
            fex = [-0.012 * S, -0.006 * S, 0.0, 0.0, 0.02 * S, 0.03 * S]
            fh = np.array([0.03, 0.05, 0.05, 0.032, 0.022, 0.012]) * S
            fw = np.array([0.016, 0.022, 0.025, 0.030, 0.026, 0.014]) * S * g**0.3
            parts.append(
                tube(
                    kp[he],
                    kp[to],
                    u_sh,
                    fs,
                    fex,
                    fw,
                    fh / 2,
                    col["shoes"],
                    v_off=fh / 2 - 0.006,  # sole just below heel and toe points
                    exponent=4.0,
                )  # fmt: skip
            )

        # Skirt or coat hem: a flared tube that follows the spread of the knees.
        if style in ("skirt", "coat"):
            knee_mid = 0.5 * (kp[L_KNEE] + kp[R_KNEE])
            if style == "skirt":
                top = mid_hip + 0.25 * (kp[NECK] - mid_hip)
                bottom = knee_mid - 0.04 * S * UP
                colour = col["trousers"]
            else:
                top = mid_hip + 0.45 * (kp[NECK] - mid_hip)
                bottom = mid_hip + 0.5 * (knee_mid - mid_hip)
                colour = self._coat_colour
            sep = kp[L_KNEE] - kp[R_KNEE]
            a_top = 0.088 * S * g + shirt_extra + 0.004 * S
            b_top = 0.066 * S * g * belly + shirt_extra + 0.004 * S
            # the hem flares a little and opens with the knees' spread (legs stay inside)
            a_hem = max(1.15 * a_top, 0.5 * abs(sep @ lp) + 0.05 * S * g**0.5)
            b_hem = max(1.1 * b_top, 0.5 * abs(sep @ fwd) + 0.05 * S * g**0.5)
            parts.append(
                tube(top, bottom, lp, [0.0, 0.0, 0.35, 1.0, 1.0], [0.0] * 5,
                     [0.0, a_top, 0.6 * a_top + 0.4 * a_hem, a_hem, 0.96 * a_hem],
                     [0.0, b_top, 0.6 * b_top + 0.4 * b_hem, b_hem, 0.96 * b_hem], colour)
            )  # fmt: skip
        return parts

    # -- mesh -------------------------------------------------------------------------------
    def mesh(self, kp: np.ndarray) -> Mesh:
        """The posed body for one frame of key points (19, 3), metres."""
        kp = np.asarray(kp, dtype=float)
        if not np.isfinite(kp).all():
            raise ValueError("BodyModel.mesh needs all 19 key points finite")
        parts = self._parts(kp)
        verts, cols, tris, tex = [], [], [], []
        offset = 0
        n = self.n_around
        for p in parts:
            v = _tube_vertices(p, self._cos, self._sin)
            r = v.shape[0]
            c = p.colour if p.colour.ndim == 3 else np.broadcast_to(p.colour[:, None], v.shape)
            verts.append(v.reshape(-1, 3))
            cols.append(np.asarray(c).reshape(-1, 3))
            tris.append(_grid_triangles(r, n) + offset)
            axial = p.s * float(np.linalg.norm(p.p1 - p.p0)) + p.extra
            rad = 0.5 * (p.a + p.b)
            tex.append(
                np.stack(
                    [
                        np.repeat(axial, n),
                        (rad[:, None] * self._cos[None]).ravel(),
                        (rad[:, None] * self._sin[None]).ravel(),
                    ],
                    1,
                )
            )
            offset += r * n
        vertices = np.concatenate(verts)
        triangles = np.concatenate(tris)
        albedo = np.concatenate(cols)
        patterned = np.all(np.abs(albedo - self.colours["shirt"]) < 1e-9, axis=1)
        if self.body.style == "coat":
            patterned |= np.all(np.abs(albedo - self._coat_colour) < 1e-9, axis=1)
        return Mesh(
            vertices,
            vertex_normals(vertices, triangles),
            albedo,
            triangles,
            np.concatenate(tex),
            patterned.astype(np.float64),
        )

    @property
    def _coat_colour(self) -> np.ndarray:
        return self.colours["trousers"] * 0.6 + 0.4 * self.colours["shirt"]

    def pattern(self, texcoords: np.ndarray) -> np.ndarray:
        """Reflectance factor (N,) of the shirt's pattern at interpolated texcoords (N, 3)."""
        kind = self.body.pattern
        f = np.ones(len(texcoords))
        if kind == "plain":
            return f
        period = self.body.pattern_period_m
        band = np.floor(texcoords[:, 0] / (0.5 * period)).astype(np.int64) % 2
        if kind == "checks":
            theta = np.arctan2(texcoords[:, 2], texcoords[:, 1])
            arc = theta * np.hypot(texcoords[:, 1], texcoords[:, 2])
            band ^= np.floor(arc / (0.5 * period)).astype(np.int64) % 2
        return np.where(band == 1, 0.55, 1.0)


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (V, 3) from outward-wound triangles (F, 3)."""
    p = vertices[triangles]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n = np.zeros_like(vertices)
    for k in range(3):
        for c in range(3):
            n[:, c] += np.bincount(triangles[:, k], weights=fn[:, c], minlength=len(vertices))
    return _unit(n)
