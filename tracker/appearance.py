"""An appearance (colour) cue for the likelihood: each body part keeps its colour over time.

The silhouette cannot tell where the waist is, whether an arm lies over the trunk or where the
shoes are; the frame's colours can, once the tracker knows what colour each part of this person
is. :class:`ColourCue` learns a reference colour per body part (head, trunk, pelvis, upper arms,
forearms, hands, thighs, shanks, feet; left and right share one reference by default) from the
person themselves, and scores poses by how well the image colour along each capsule's projected
axis agrees with its part's reference.

Colour space
    CIE Lab of the frame scaled to the cue's working resolution (area averaging smooths sensor
    noise), with the lightness scaled by ``lightness_weight`` (shading and lighting change the
    lightness much more than the chroma).

Learning (:meth:`ColourCue.update`, after each estimate)
    Only from frames whose estimate fits the silhouettes well (``min_weight``). For the estimate,
    points along and beside each capsule's axis (away from the joints) are projected; points
    outside the silhouette or covered by a capsule nearer the camera are dropped. Per part the
    frame's colour is the median of its points and its spread the median absolute deviation.
    Over the first ``learn_frames`` accepted frames the reference is the median of the frames'
    colours; afterwards it follows slowly (``rate``). A part is scored once ``min_frames``
    frames taught it.

Scoring (:meth:`ColourCue.scores`, :meth:`ColourCue.scores_factored`)
    Per pose and camera: for every capsule of a learned part, ``samples`` points along its
    projected axis between ``axis_margin`` and ``1 - axis_margin``; a point inside the silhouette
    scores ``exp(-d^2 / 2 s^2)`` (``d`` the Lab distance to the part's reference, ``s^2`` the
    part's spread squared plus ``sigma**2``), a point outside it scores 0. The score is the mean
    over the points of every scored capsule, then over the cameras. There is no occlusion
    reasoning, so the score is a sum over capsules and factors over the legs exactly like the
    silhouette counts. The likelihood multiplies its silhouette weight by
    ``(score / typical) ** beta`` where ``typical`` is the score of recent estimates, so weights
    stay on the silhouette's scale and the ranking within a frame is the product's.

The hot path is a numba kernel over the poses (``parallel=True``, chunks like
:mod:`tracker.raster`).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numba as nb
import numpy as np

from tracker import raster
from tracker.body import CAPSULE_NAMES, HEM_CAPSULE_NAMES, BodyModel
from tracker.camera import Camera
from tracker.segmentation import downscale_mask

#: Body parts of the colour cue and the capsules that show them (left and right separately;
#: ``merge_sides`` pools the two sides).
PART_CAPSULES: dict[str, tuple[str, ...]] = {
    "head": ("neck", "head"),
    "trunk": ("trunk_left", "trunk_right", "trunk_spine", "left_clavicle", "right_clavicle"),
    "pelvis": ("pelvis",),
    "left_upper_arm": ("left_upper_arm",),
    "right_upper_arm": ("right_upper_arm",),
    "left_forearm": ("left_forearm",),
    "right_forearm": ("right_forearm",),
    "left_hand": ("left_hand",),
    "right_hand": ("right_hand",),
    "left_thigh": ("left_thigh",),
    "right_thigh": ("right_thigh",),
    "left_shank": ("left_shank",),
    "right_shank": ("right_shank",),
    "left_foot": ("left_foot",),
    "right_foot": ("right_foot",),
}


def part_table(merge_sides: bool) -> tuple[tuple[str, ...], np.ndarray]:
    """Part names and the part index of every capsule ``(C,)`` int64 (-1: not scored).

    ``C`` counts the hem capsules too (``tracker.body.HEM_CAPSULE_NAMES``, after the others):
    they are not scored (their axis is the thigh's)."""
    names: list[str] = []
    of_cap = np.full(len(CAPSULE_NAMES) + len(HEM_CAPSULE_NAMES), -1, dtype=np.int64)
    for part, caps in PART_CAPSULES.items():
        name = part.removeprefix("left_").removeprefix("right_") if merge_sides else part
        if name not in names:
            names.append(name)
        for c in caps:
            of_cap[CAPSULE_NAMES.index(c)] = names.index(name)
    return tuple(names), of_cap


def lab_image(frame: np.ndarray, size: tuple[int, int], lightness_weight: float) -> np.ndarray:
    """A BGR uint8 frame ``(H, W, 3)`` -> Lab float32 ``(h, w, 3)`` at ``size`` = (w, h).

    Bilinear resampling to the working size; L (0..100) is multiplied by ``lightness_weight``, a and
    b are the Lab chroma (-128..127).
    """
    f = np.asarray(frame)
    if f.ndim == 2:
        f = cv2.cvtColor(f, cv2.COLOR_GRAY2BGR)
    if f.ndim != 3 or f.shape[2] != 3:
        raise ValueError(f"frame must be (H, W, 3) BGR or (H, W) grey, got {f.shape}")
    small = (
        f if f.shape[1::-1] == tuple(size) else cv2.resize(f, size, interpolation=cv2.INTER_LINEAR)
    )
    # 8-bit Lab (OpenCV: L * 255 / 100, a + 128, b + 128; within 1 unit of the float
    # conversion and ten times faster)
    lab = cv2.cvtColor(small, cv2.COLOR_BGR2Lab).astype(np.float32)
    lab -= np.array([0.0, 128.0, 128.0], dtype=np.float32)
    lab[..., 0] *= np.float32(lightness_weight * 100.0 / 255.0)
    return np.ascontiguousarray(lab)


@nb.njit(cache=True, nogil=True)
def score_maps_kernel(
    img: np.ndarray, mask: np.ndarray, ref: np.ndarray, inv2s2: np.ndarray, on: np.ndarray
) -> np.ndarray:
    """Per-pixel agreement with every part's reference -> ``(K, n_parts, H, W)`` float32.

    ``exp(-|img - ref[p]|^2 * inv2s2[p])`` inside the silhouette ``mask`` (K, H, W), 0 outside
    and for parts with ``on[p]`` False. ``img`` (K, H, W, 3) float32 Lab.
    """
    nk, h, w = mask.shape
    npart = ref.shape[0]
    out = np.zeros((nk, npart, h, w), dtype=np.float32)
    for k in range(nk):
        for y in range(h):
            for x in range(w):
                if not mask[k, y, x]:
                    continue
                c0 = img[k, y, x, 0]
                c1 = img[k, y, x, 1]
                c2 = img[k, y, x, 2]
                for p in range(npart):
                    if on[p]:
                        d0 = c0 - ref[p, 0]
                        d1 = c1 - ref[p, 1]
                        d2 = c2 - ref[p, 2]
                        out[k, p, y, x] = np.exp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv2s2[p])
    return out


@nb.njit(cache=True, nogil=True)
def _sums_range(
    lo: int,
    hi: int,
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    cap_part: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    maps: np.ndarray,
    ts: np.ndarray,
    out: np.ndarray,
) -> None:
    for i in range(lo, hi):
        for k in range(cams.shape[0]):
            h = cam_hw[k, 0]
            w = cam_hw[k, 1]
            acc = 0.0
            for j in range(sel.shape[0]):
                c = sel[j]
                p = cap_part[c]
                ua, va, _, ub, vb, _, ok = raster.project_capsule(pts, i, cap_ab, c, cams, k)
                if not ok:
                    continue
                for s in range(ts.shape[0]):
                    t = ts[s]
                    x = int(np.floor(ua + t * (ub - ua) + 0.5))
                    y = int(np.floor(va + t * (vb - va) + 0.5))
                    if x >= 0 and y >= 0 and x < w and y < h:
                        acc += maps[k, p, y, x]
            out[i, k] = acc


@nb.njit(cache=True, nogil=True)
def _colour_sums_serial(
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    cap_part: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    maps: np.ndarray,
    ts: np.ndarray,
) -> np.ndarray:
    """:func:`colour_sums_kernel` on one thread (small batches: no parallel dispatch)."""
    out = np.zeros((pts.shape[0], cams.shape[0]), dtype=np.float64)
    _sums_range(0, pts.shape[0], pts, sel, cap_ab, cap_part, cams, cam_hw, maps, ts, out)
    return out


@nb.njit(cache=True, nogil=True)
def _factors_serial(
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    cap_part: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    maps: np.ndarray,
    ts: np.ndarray,
    scale: float,
    beta: float,
) -> np.ndarray:
    """``(mean over cameras of the sums * scale) ** beta`` per pose, on one thread."""
    nk = cams.shape[0]
    out = np.zeros((pts.shape[0], nk), dtype=np.float64)
    _sums_range(0, pts.shape[0], pts, sel, cap_ab, cap_part, cams, cam_hw, maps, ts, out)
    f = np.empty(pts.shape[0], dtype=np.float64)
    for i in range(pts.shape[0]):
        acc = 0.0
        for k in range(nk):
            acc += out[i, k]
        f[i] = (acc / nk * scale) ** beta
    return f


#: Batches smaller than this are scored by the serial kernel.
SERIAL_BELOW = 64


@nb.njit(cache=True, parallel=True, nogil=True)
def colour_sums_kernel(
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    cap_part: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    maps: np.ndarray,
    ts: np.ndarray,
    nchunks: int,
) -> np.ndarray:
    """Summed sample scores of capsules ``sel`` per pose and camera -> ``(N, K)`` float64.

    Parameters
    ----------
    pts : (N, P, 3) model points (``BodyModel.points``), metres.
    sel : (S,) int64 capsules to score; cap_ab : (C, 2) point indices of the capsule ends.
    cap_part : (C,) int64 part of each capsule.
    cams : (K, 32) packed cameras (:func:`tracker.raster.pack_camera`); cam_hw : (K, 2) int64.
    maps : (K, n_parts, H, W) float32 per-pixel agreement (:func:`score_maps_kernel`).
    ts : (n_samples,) positions along the projected axis (0 = end a, 1 = end b).
    nchunks : work units shared by the threads.
    """
    n = pts.shape[0]
    out = np.zeros((n, cams.shape[0]), dtype=np.float64)
    nchunks = max(1, min(n, nchunks))
    for ch in nb.prange(nchunks):
        _sums_range(
            ch * n // nchunks,
            (ch + 1) * n // nchunks,
            pts,
            sel,
            cap_ab,
            cap_part,
            cams,
            cam_hw,
            maps,
            ts,
            out,
        )
    return out


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, ...]:
    """Distance of 2-D points ``p (S, 2)`` to segments ``a, b (C, 2)`` -> ``(S, C)``, and the
    parameter ``t (S, C)`` of the nearest segment point."""
    ab = b - a
    L2 = np.maximum((ab * ab).sum(axis=1), 1e-12)
    t = np.clip(((p[:, None, :] - a[None]) * ab[None]).sum(axis=2) / L2, 0.0, 1.0)
    q = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None, :] - q, axis=2), t


class CapsuleSumsCue:
    """What the image cues scored along capsules share (the colour cue, :mod:`tracker.edges`):
    a score per pose and camera that sums over the selected capsules, so it factors over the
    legs like the silhouette counts.

    A subclass sets ``_on`` (bool per capsule, hem capsules included) and ``_sel_cache = {}``,
    and defines ``_sums(body, pts, group)`` (summed scores ``(N, K)`` of the capsules of
    ``group``: 0 base, 1 left leg, 2 right leg, None all) and ``_norm(body)`` (the number of
    points a score sums over)."""

    def _sel(self, body: BodyModel, group: int | None) -> np.ndarray:
        n = len(body.capsule_groups)
        sel = self._sel_cache.get((group, n))
        if sel is None:
            on = self._on[:n]
            if group is not None:
                on = on & (body.capsule_groups == group)
            sel = self._sel_cache[(group, n)] = np.flatnonzero(on).astype(np.int64)
        return sel

    def scores(self, body: BodyModel, pts: np.ndarray) -> np.ndarray:
        """Scores ``(N,)`` in [0, 1] of poses given their model points ``(N, P, 3)``: the mean
        over the points and the cameras."""
        return self._sums(body, pts, None).mean(axis=1) / self._norm(body)

    def scores_factored(
        self, body: BodyModel, pts_base: np.ndarray, pts_left: np.ndarray, pts_right: np.ndarray
    ) -> np.ndarray:
        """Scores ``(M, A, B)`` of every leg combination (see
        ``SilhouetteLikelihood.weights_factored``) from the points of the base poses ``(M, P,
        3)`` and of the leg variants ``(M * A, P, 3)``, ``(M * B, P, 3)``; equal to
        :meth:`scores` of the combined poses."""
        m = pts_base.shape[0]
        sb = self._sums(body, pts_base, 0)
        sl = self._sums(body, pts_left, 1).reshape(m, -1, sb.shape[1])
        sr = self._sums(body, pts_right, 2).reshape(m, -1, sb.shape[1])
        tot = sb[:, None, None, :] + sl[:, :, None, :] + sr[:, None, :, :]
        return tot.mean(axis=3) / self._norm(body)


class ColourCue(CapsuleSumsCue):
    """Per-part reference colours of one person and the colour score of poses.

    Parameters
    ----------
    cameras : sequence of Camera
        At the cue's working resolution (``config.size``), one per tracker camera.
    config : tracker.config.AppearanceConfig
    """

    def __init__(self, cameras: Sequence[Camera], config) -> None:
        self.config = config
        self.cameras = list(cameras)
        self.cams, self.cam_hw = raster.pack_cameras(self.cameras)
        self.part_names, self.cap_part = part_table(config.merge_sides)
        unknown = set(config.parts or ()) - set(self.part_names)
        if unknown:
            raise ValueError(f"appearance.parts: unknown part(s) {', '.join(sorted(unknown))}")
        n = len(self.part_names)
        self.ref = np.zeros((n, 3))
        self.spread = np.zeros(n)
        self.frames_learned = np.zeros(n, dtype=np.int64)
        self._history: list[list[np.ndarray]] = [[] for _ in range(n)]
        self._spreads: list[list[float]] = [[] for _ in range(n)]
        m = config.axis_margin
        self.ts = np.linspace(m, 1.0 - m, config.samples)
        hmax, wmax = int(self.cam_hw[:, 0].max()), int(self.cam_hw[:, 1].max())
        self.img = np.zeros((len(self.cameras), hmax, wmax, 3), dtype=np.float32)
        self.mask = np.zeros((len(self.cameras), hmax, wmax), dtype=np.bool_)
        self.has_frame = False
        #: Per camera, bool (H, W) pixels behind a known static occluder (or None).
        self.occluded: list[np.ndarray | None] = [None] * len(self.cameras)
        #: The colour score of recent estimates (the normaliser of the factor), None at first.
        self.typical: float | None = None
        self._maps: np.ndarray | None = None
        self._calls = 0
        self._update_tables()

    # -- frame ------------------------------------------------------------------------------
    def set_frame(self, frames: Sequence[np.ndarray], silhouettes: Sequence[np.ndarray]) -> None:
        """The current frames (BGR uint8, any size) and silhouettes (bool ``(H, W)``, any size:
        majority-downscaled or nearest-upscaled to the working size)."""
        if len(frames) != len(self.cameras) or len(silhouettes) != len(self.cameras):
            raise ValueError(
                f"expected {len(self.cameras)} frames and silhouettes, "
                f"got {len(frames)} and {len(silhouettes)}"
            )
        lw = self.config.lightness_weight
        for k, (f, s, cam) in enumerate(zip(frames, silhouettes, self.cameras, strict=True)):
            size = (cam.width, cam.height)
            self.img[k, : cam.height, : cam.width] = lab_image(f, size, lw)
            s = np.asarray(s, dtype=bool)
            if s.shape[0] >= cam.height:
                s = downscale_mask(s, size)
            else:
                s = cv2.resize(s.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST) > 0
            self.mask[k, : cam.height, : cam.width] = s
        self.has_frame = True
        self._maps = None

    def frame_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The current frame at the working size (a copy; None without one), for
        :meth:`restore_frame`: about 0.25 MB per camera at 160x120, where raw frames take
        megabytes."""
        if not self.has_frame:
            return None
        return self.img.copy(), self.mask.copy()

    def restore_frame(self, state: tuple[np.ndarray, np.ndarray] | None) -> None:
        """Make a frame kept by :meth:`frame_state` the current one (None: no frame)."""
        if state is None:
            self.clear_frame()
            return
        self.img[...] = state[0]
        self.mask[...] = state[1]
        self.has_frame = True
        self._maps = None

    def set_occlusion(self, occluded: Sequence[np.ndarray | None] | None) -> None:
        """Pixels behind known static occluders, one bool mask (any size, resized to the
        working size) or None per camera; None clears all. A sample that falls there outside
        the silhouette scores the typical score of recent estimates instead of 0: a hidden part
        is neither rewarded nor penalised."""
        out: list[np.ndarray | None] = [None] * len(self.cameras)
        if occluded is not None:
            if len(occluded) != len(self.cameras):
                raise ValueError(
                    f"expected {len(self.cameras)} occlusion masks, got {len(occluded)}"
                )
            for k, (o, cam) in enumerate(zip(occluded, self.cameras, strict=True)):
                if o is None or not np.any(o):
                    continue
                o = np.asarray(o, dtype=np.uint8)
                o = cv2.resize(o, (cam.width, cam.height), interpolation=cv2.INTER_NEAREST) > 0
                out[k] = o
        self.occluded = out
        self._maps = None

    def clear_frame(self) -> None:
        """No frame for this time step: the cue does not score until the next one is set."""
        self.has_frame = False

    # -- scoring ----------------------------------------------------------------------------
    @property
    def active(self) -> bool:
        """True when a frame is set and some part is learned (the cue then scores)."""
        return self.has_frame and self._n_scored > 0

    def _update_tables(self) -> None:
        learned = self.frames_learned >= self.config.min_frames
        on = (self.cap_part >= 0) & learned[np.maximum(self.cap_part, 0)]
        if self.config.parts is not None:
            scored = np.array([n in self.config.parts for n in self.part_names])
            on &= scored[np.maximum(self.cap_part, 0)]
        self._on = on
        self._part_on = np.zeros(len(self.part_names), dtype=np.bool_)
        self._part_on[self.cap_part[on]] = True
        s2 = self.spread**2 + self.config.sigma**2
        self.inv2s2 = 0.5 / s2
        self._n_scored = int(on.sum())
        self._maps = None
        self._sel_cache: dict[tuple[int | None, int], np.ndarray] = {}

    def _score_maps(self) -> np.ndarray:
        """This frame's per-part score maps (computed at the first scoring of the frame)."""
        if self._maps is None:
            self._maps = score_maps_kernel(
                self.img, self.mask, self.ref, self.inv2s2, self._part_on
            )
            typ = self.typical if self.typical else 0.0
            scored = np.flatnonzero(self._part_on)
            for k, occ in enumerate(self.occluded):
                if occ is None or typ <= 0.0:
                    continue
                h, w = occ.shape
                ys, xs = np.nonzero(occ & ~self.mask[k, :h, :w])
                self._maps[k, scored[:, None], ys, xs] = typ
        return self._maps

    def _sums(self, body: BodyModel, pts: np.ndarray, group: int | None) -> np.ndarray:
        maps = self._score_maps()
        args = (pts, self._sel(body, group), body.cap_ab, self.cap_part, self.cams, self.cam_hw)
        if pts.shape[0] < SERIAL_BELOW or nb.get_num_threads() == 1:
            return _colour_sums_serial(*args, maps, self.ts)
        return colour_sums_kernel(*args, maps, self.ts, 4 * nb.get_num_threads())

    def _norm(self, body: BodyModel) -> float:
        return float(self._n_scored * self.ts.size)

    def weight_factors(self, body: BodyModel, pts: np.ndarray) -> np.ndarray:
        """``factor(scores(body, pts))`` ``(N,)``; small batches in one kernel call."""
        if pts.shape[0] >= SERIAL_BELOW and nb.get_num_threads() > 1:
            return self.factor(self.scores(body, pts))
        typ = self.typical if self.typical else 1.0
        return _factors_serial(
            pts,
            self._sel(body, None),
            body.cap_ab,
            self.cap_part,
            self.cams,
            self.cam_hw,
            self._score_maps(),
            self.ts,
            1.0 / (self._norm(body) * typ),
            float(self.config.beta),
        )

    def factor(self, scores: np.ndarray) -> np.ndarray:
        """The multiplier of the silhouette weight: ``(scores / typical) ** beta``."""
        typ = self.typical if self.typical else 1.0
        return (np.maximum(scores, 0.0) / typ) ** self.config.beta

    # -- learning ---------------------------------------------------------------------------
    def sample_estimate(self, body: BodyModel, pose: np.ndarray) -> list[np.ndarray]:
        """Lab colours of the visible points of every part of one pose: list of ``(n_i, 3)``.

        Points along the capsule axes and beside them (``0.4`` of the projected radius either
        side), between ``axis_margin`` and ``1 - axis_margin``; kept when inside the
        silhouette and not covered by a capsule nearer the camera.
        """
        pts = body.points(np.asarray(pose, dtype=np.float64)[None])[0]
        a3, b3 = pts[body.cap_a], pts[body.cap_b]
        ts = np.linspace(self.config.axis_margin, 1.0 - self.config.axis_margin, 7)
        n_caps = len(body.capsule_names)
        caps = np.flatnonzero(self.cap_part[:n_caps] >= 0)
        part = self.cap_part[:n_caps]
        colours: list[np.ndarray] = []
        parts: list[np.ndarray] = []
        for k, cam in enumerate(self.cameras):
            R, t = cam.R, np.asarray(cam.t, dtype=np.float64).ravel()
            za = a3 @ R[2] + t[2]
            zb = b3 @ R[2] + t[2]
            if np.any(za < raster.Z_NEAR) or np.any(zb < raster.Z_NEAR):
                continue
            ua, ub = cam.project(a3), cam.project(b3)
            f = 0.5 * (cam.K[0, 0] + cam.K[1, 1])
            ra, rb = body.radii[:, 0] * f / za, body.radii[:, 1] * f / zb
            # points along and beside the axis of every scored capsule: (len(caps), 3 T, 2)
            d = (ub - ua)[caps]
            n = np.linalg.norm(d, axis=1, keepdims=True)
            perp = np.where(
                n > 1e-9, np.stack([-d[:, 1], d[:, 0]], axis=1) / np.maximum(n, 1e-9), 0
            )
            rr = ra[caps, None] + ts[None] * (rb - ra)[caps, None]
            axis = ua[caps, None] + ts[None, :, None] * d[:, None]
            off = 0.4 * rr[..., None] * perp[:, None]
            cand = np.concatenate([axis, axis + off, axis - off], axis=1).reshape(-1, 2)
            owner = np.repeat(caps, 3 * ts.size)
            zc = np.tile(za[caps, None] + ts[None] * (zb - za)[caps, None], (1, 3)).ravel()
            # covered by a capsule of another part nearer the camera (by a radius at least)?
            dist, tt = _segment_distance(cand, ua, ub)
            rad = ra[None] + tt * (rb - ra)[None]
            zz = za[None] + tt * (zb - za)[None]
            margin = 0.5 * (body.radii[owner, 0] + body.radii[owner, 1])
            cover = (dist <= rad) & (zz < (zc - margin)[:, None])
            cover &= part[None] != part[owner][:, None]
            xy = np.floor(cand + 0.5).astype(np.int64)
            ok = ~cover.any(axis=1) & (xy[:, 0] >= 0) & (xy[:, 1] >= 0)
            ok &= (xy[:, 0] < cam.width) & (xy[:, 1] < cam.height)
            ok[ok] = self.mask[k, xy[ok, 1], xy[ok, 0]]
            colours.append(self.img[k, xy[ok, 1], xy[ok, 0]].astype(np.float64))
            parts.append(part[owner[ok]])
        if not colours:
            return [np.zeros((0, 3)) for _ in self.part_names]
        col, prt = np.concatenate(colours), np.concatenate(parts)
        return [col[prt == p] for p in range(len(self.part_names))]

    def wants_update(self) -> bool:
        """Whether :meth:`update` would learn from this frame: every frame until every part has
        ``learn_frames`` frames, then every ``learn_every``-th frame (counted by this call)."""
        if not self.has_frame:
            return False
        self._calls += 1
        if self.frames_learned.min() < self.config.learn_frames:
            return True
        return self._calls % self.config.learn_every == 0

    def update(self, body: BodyModel, pose: np.ndarray, silhouette_weight: float) -> bool:
        """Learn from one estimate (after the frame was set); returns True when it was used."""
        c = self.config
        if not self.has_frame or not silhouette_weight >= c.min_weight:
            return False
        pts = body.points(np.asarray(pose, dtype=np.float64)[None])
        # the estimate's score with the references this frame was searched with
        before = float(self.scores(body, pts)[0]) if self.active else None
        samples = self.sample_estimate(body, pose)
        for p, s in enumerate(samples):
            if s.shape[0] < c.min_points:
                continue
            med = np.median(s, axis=0)
            spread = float(1.4826 * np.median(np.linalg.norm(s - med, axis=1)))
            if self.frames_learned[p] < c.learn_frames:
                self._history[p].append(med)
                self._spreads[p].append(spread)
                self.ref[p] = np.median(np.stack(self._history[p]), axis=0)
                self.spread[p] = float(np.median(self._spreads[p]))
            else:
                self.ref[p] += c.rate * (med - self.ref[p])
                self.spread[p] += c.rate * (spread - self.spread[p])
            self.frames_learned[p] += 1
        self._update_tables()
        if before is None and self.active:  # just became active: score with the new references
            before = float(self.scores(body, pts)[0])
        if before is not None and before > 0:
            self.typical = (
                before if self.typical is None else self.typical + 0.2 * (before - self.typical)
            )
        return True

    def reset(self) -> None:
        """Forget everything learned (another person); the scene's occluders stay."""
        occluded = self.occluded
        self.__init__(self.cameras, self.config)  # type: ignore[misc]
        self.occluded = occluded


__all__ = [
    "PART_CAPSULES",
    "CapsuleSumsCue",
    "ColourCue",
    "colour_sums_kernel",
    "lab_image",
    "part_table",
    "score_maps_kernel",
]
