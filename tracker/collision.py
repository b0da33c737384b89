"""Non-penetration prior: a pose whose limbs pass through the trunk is not a body's pose.

The silhouette cannot see an arm in front of or behind the trunk, and an arm hidden inside the
trunk's volume costs the model nothing (its pixels are covered anyway) while an arm beside the
trunk risks model-only pixels. So, unchecked, the likelihood lets the arms sink into the trunk
and the pelvis whenever the silhouette of the real arm merges with the body's, and the estimated
wrists end up at the midline. Like the joint limits, this prior rules out what a body cannot do:
the weight of a pose is multiplied by a factor that falls from 1 to 0 as a capsule pair
interpenetrates further than it does standing at rest.

For each pair ``(a, b)`` of capsules (:data:`ARM_TRUNK_PAIRS` by default) the penetration depth
is ``ra(s) + rb(t) - |A(s) - B(t)|`` at the closest points of the two capsule axes (the radii of
the tapered capsules interpolated there). The allowance of a pair is its depth in the body's
neutral pose (arms hanging, legs straight) plus ``tolerance_m``; the factor of a pose is::

    f = max(0, 1 - excess / softness_m) ** 2,  excess = max over pairs of (depth - allowance)+

so poses within the allowance keep their weight and a limb sunk ``softness_m`` deeper than
allowed weighs nothing.
"""

from __future__ import annotations

from typing import Final

import numba as nb
import numpy as np

from tracker.body import (
    CAPSULE_NAMES,
    CAPSULES,
    GIRTH_PARTS,
    LEFT_LEG_SEGMENTS,
    RIGHT_LEG_SEGMENTS,
    BodyModel,
)

_TRUNK: Final[tuple[str, ...]] = tuple(c.name for c in CAPSULES if c.segment in ("pelvis", "trunk"))
_ARM: Final[tuple[str, ...]] = tuple(c.name for c in CAPSULES if c.segment in GIRTH_PARTS["arms"])
#: Every arm capsule against every capsule of the trunk and pelvis.
ARM_TRUNK_PAIRS: Final[tuple[tuple[str, str], ...]] = tuple((a, t) for a in _ARM for t in _TRUNK)


@nb.njit(cache=True, nogil=True)
def _segment_closest(p0, p1, q0, q1) -> tuple[float, float, float]:  # pragma: no cover (numba)
    """Closest points of segments p0-p1 and q0-q1 (3-vectors): (s, t, distance), s and t in
    [0, 1] along each; a zero-length segment is a point (Ericson, Real-Time Collision Detection,
    5.1.9)."""
    eps = 1e-12
    d1x, d1y, d1z = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d2x, d2y, d2z = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    rx, ry, rz = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    s = 0.0
    t = 0.0
    if a <= eps and e <= eps:
        pass
    elif a <= eps:
        t = min(max(f / e, 0.0), 1.0)
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= eps:
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = d1x * d2x + d1y * d2y + d1z * d2z
            denom = a * e - b * b
            if denom > eps:
                s = min(max((b * f - c * e) / denom, 0.0), 1.0)
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    dx = rx + d1x * s - d2x * t
    dy = ry + d1y * s - d2y * t
    dz = rz + d1z * s - d2z * t
    return s, t, np.sqrt(dx * dx + dy * dy + dz * dz)


@nb.njit(cache=True, parallel=True, nogil=True)
def _depths_kernel(pts, cap_ab, radii, ia, ib):  # pragma: no cover (numba)
    n, npair = pts.shape[0], ia.shape[0]
    out = np.empty((n, npair))
    for i in nb.prange(n):
        for k in range(npair):
            ca, cb = ia[k], ib[k]
            s, t, d = _segment_closest(
                pts[i, cap_ab[ca, 0]],
                pts[i, cap_ab[ca, 1]],
                pts[i, cap_ab[cb, 0]],
                pts[i, cap_ab[cb, 1]],
            )
            ra = radii[ca, 0] + (radii[ca, 1] - radii[ca, 0]) * s
            rb = radii[cb, 0] + (radii[cb, 1] - radii[cb, 0]) * t
            out[i, k] = ra + rb - d
    return out


class CollisionPrior:
    """Weight factors that rule out interpenetrating limbs (module docstring).

    Parameters
    ----------
    pairs : sequence of (str, str)
        Capsule names (:data:`tracker.body.CAPSULE_NAMES`) that must not interpenetrate.
    tolerance_m : float
        Depth allowed beyond the pair's depth in the neutral pose, metres.
    softness_m : float
        Further depth over which the factor falls from 1 to 0, metres (> 0).
    """

    def __init__(
        self,
        pairs: tuple[tuple[str, str], ...] = ARM_TRUNK_PAIRS,
        *,
        tolerance_m: float = 0.01,
        softness_m: float = 0.03,
    ) -> None:
        index = {n: i for i, n in enumerate(CAPSULE_NAMES)}
        unknown = sorted({n for p in pairs for n in p} - set(index))
        if unknown:
            raise ValueError(f"unknown capsule names {unknown}; known: {list(CAPSULE_NAMES)}")
        if not pairs:
            raise ValueError("CollisionPrior needs at least one capsule pair")
        legs = sorted(
            {n for p in pairs for n in p}
            & {c.name for c in CAPSULES if c.segment in LEFT_LEG_SEGMENTS + RIGHT_LEG_SEGMENTS}
        )
        if legs:  # the factored likelihood varies the legs apart from the rest of the pose
            raise ValueError(f"leg capsules {legs} are not supported: upper body and pelvis only")
        if tolerance_m < 0 or softness_m <= 0:
            raise ValueError("tolerance_m must be >= 0 and softness_m > 0")
        self.pairs = tuple(pairs)
        self.ia = np.array([index[a] for a, _ in pairs], dtype=np.intp)
        self.ib = np.array([index[b] for _, b in pairs], dtype=np.intp)
        self.tolerance_m = float(tolerance_m)
        self.softness_m = float(softness_m)
        self._allowance: dict[tuple[float, ...], np.ndarray] = {}

    def depths(self, body: BodyModel, pts: np.ndarray) -> np.ndarray:
        """Penetration depth ``(N, P)`` of every pair, metres (negative: apart), from model
        points ``(N, n_points, 3)`` (``body.points(poses)``)."""
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        if pts.ndim != 3 or pts.shape[2] != 3:
            raise ValueError(f"pts must have shape (N, n_points, 3), got {pts.shape}")
        return _depths_kernel(pts, body.cap_ab, body.radii, self.ia, self.ib)

    def allowance(self, body: BodyModel) -> np.ndarray:
        """Depth ``(P,)`` allowed per pair for this body: its depth at rest plus the tolerance."""
        key = (body.height_m, *body.shape_key)
        if key not in self._allowance:
            rest = self.depths(body, body.points(body.neutral_pose()[None]))[0]
            self._allowance[key] = np.maximum(rest, 0.0) + self.tolerance_m
        return self._allowance[key]

    def factors(self, body: BodyModel, pts: np.ndarray) -> np.ndarray:
        """Weight factor ``(N,)`` in [0, 1] of poses given by their model points
        ``(N, n_points, 3)``."""
        excess = (self.depths(body, pts) - self.allowance(body)).max(axis=1)
        return np.clip(1.0 - np.maximum(excess, 0.0) / self.softness_m, 0.0, 1.0) ** 2


__all__ = ["ARM_TRUNK_PAIRS", "CollisionPrior"]
