"""An edge cue for the likelihood: the outlines of the limbs lie on image edges.

The silhouette counts only say which pixels the body covers. Inside the silhouette they are
blind: an arm held over the trunk, a knee bent in front of the other leg or a thigh swung
towards the camera cover the same pixels as other poses. The frame's edges are not: a limb
in front of the trunk or of the other leg shows its outline there (shading and clothing change
across it). :class:`EdgeCue` scores a pose by how well the projected outlines of its limbs'
capsules agree with the image's edges.

Edge maps (:meth:`EdgeCue.set_frame`, once per frame and camera)
    The frame at the cue's working size in Lab (lightness weighted by ``lightness_weight``),
    Gaussian-smoothed (``blur_px``), its Sobel gradient per channel ``(gx, gy)``, set to zero
    outside the silhouette grown by ``margin_px`` (the room's texture is not the person's), and
    divided by a robust scale of the gradient magnitude inside the silhouette (its
    ``scale_percentile``-th percentile, at least ``min_scale``), so the score depends little
    on contrast or lighting.

Scoring (:meth:`EdgeCue.scores`, :meth:`EdgeCue.scores_factored`)
    Per pose and camera, for every scored capsule (the limbs by default): ``samples`` points
    along its projected axis between ``axis_margin`` and ``1 - axis_margin``, each moved to
    either side by the capsule's projected radius there. A point scores the gradient's
    component across the outline (along the normal of the projected axis),
    ``min(1, sqrt(sum over channels of (g . n)^2))``: edges along the outline count, texture
    across it does not. The score is the mean over the points, then over the cameras. There is
    no occlusion reasoning (like the colour cue), so the score is a sum over capsules and
    factors over the legs exactly like the silhouette counts. The likelihood multiplies its
    weight by ``(score / typical) ** beta``, ``typical`` the score of recent estimates (weights
    stay on the silhouette's scale).

Where it applies (``config.scope``): ``all``, every weight of the likelihood; ``arm_search``,
only the arm search's choice among its grid (:mod:`tracker.arms`); ``output``, only the arms
of the written pose (the pipeline's ``Tracker._output_arms``). Nothing is learned about the
person: the cue is active from the first estimate on (it needs ``typical``). The hot path is
a numba kernel over the poses (``parallel=True``, chunks like :mod:`tracker.raster`).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numba as nb
import numpy as np

from tracker import raster
from tracker.appearance import SERIAL_BELOW, CapsuleSumsCue, lab_image
from tracker.body import CAPSULE_NAMES, HEM_CAPSULE_NAMES, BodyModel
from tracker.camera import Camera

#: Parts the edge cue can score and their capsules (left and right together).
EDGE_PARTS: dict[str, tuple[str, ...]] = {
    "upper_arm": ("left_upper_arm", "right_upper_arm"),
    "forearm": ("left_forearm", "right_forearm"),
    "thigh": ("left_thigh", "right_thigh"),
    "shank": ("left_shank", "right_shank"),
    "foot": ("left_foot", "right_foot"),
    "head": ("head",),
    "trunk": ("trunk_left", "trunk_right"),
}

#: Channels of an edge map: (gx, gy) of L, a, b.
N_CHANNELS = 6


def capsules_of(parts: Sequence[str]) -> np.ndarray:
    """Bool ``(C,)`` (hem capsules included, never scored): the capsules of ``parts``."""
    unknown = set(parts) - set(EDGE_PARTS)
    if unknown:
        raise ValueError(
            f"edges.parts: unknown part(s) {', '.join(sorted(unknown))}; "
            f"known: {', '.join(EDGE_PARTS)}"
        )
    on = np.zeros(len(CAPSULE_NAMES) + len(HEM_CAPSULE_NAMES), dtype=np.bool_)
    for p in parts:
        for c in EDGE_PARTS[p]:
            on[CAPSULE_NAMES.index(c)] = True
    return on


def edge_map(
    frame: np.ndarray, silhouette: np.ndarray, size: tuple[int, int], **options
) -> np.ndarray:
    """One camera's edge map ``(h, w, 6)`` float32 at ``size`` = (w, h); ``options`` and the
    map's definition as in :func:`edge_map_crop`, which computes its non-zero box (everything
    outside it is zero)."""
    w, h = size
    out = np.zeros((h, w, N_CHANNELS), dtype=np.float32)
    crop = edge_map_crop(frame, silhouette, size, **options)
    if crop is not None:
        y0, x0, m = crop
        out[y0 : y0 + m.shape[0], x0 : x0 + m.shape[1]] = m
    return out


def edge_map_crop(
    frame: np.ndarray,
    silhouette: np.ndarray,
    size: tuple[int, int],
    *,
    lightness_weight: float = 1.0,
    blur_px: float = 1.0,
    margin_px: int = 2,
    scale_percentile: float = 90.0,
    min_scale: float = 2.0,
    interior_px: int = 0,
) -> tuple[int, int, np.ndarray] | None:
    """The non-zero part of one camera's edge map at ``size`` = (w, h): ``(y0, x0, map)``,
    ``map`` float32 ``(rows, cols, 6)`` holding the edge map's rows ``y0:y0 + rows`` and columns
    ``x0:x0 + cols``; None when the silhouette has no pixel (the whole map is zero).

    The edge map is the Lab gradient ``(gx, gy)`` per channel, zero outside the silhouette
    grown by ``margin_px``, in units of the ``scale_percentile``-th percentile of its magnitude
    inside the silhouette, or of ``min_scale`` (Lab units per pixel) if that is larger (a plain
    person in a clean image has few edges; sensor noise must not score). ``interior_px`` > 0
    keeps only the edges inside the silhouette eroded by that many pixels (the outline against
    the room is the silhouette term's; the interior is what it cannot see). ``silhouette`` is
    a bool mask of any size (resized to ``size``, nearest).

    The Lab conversion, smoothing and gradient run on the silhouette's bounding box grown by
    ``margin_px`` plus the Gaussian's and the Sobel kernel's reach, so every pixel kept sees
    the same neighbourhood as over the whole frame (14-25 % of its area on 16 frames of the
    benchmark's scenes)."""
    w, h = size
    s = np.asarray(silhouette, dtype=np.uint8)
    if s.shape != (h, w):
        s = cv2.resize(s, size, interpolation=cv2.INTER_NEAREST)
    bx, by, bw, bh = cv2.boundingRect(s)
    if bw == 0 or bh == 0:
        return None
    # the Gaussian's half-width (OpenCV's kernel for a float image: 8 sigma + 1 taps), the
    # Sobel's 1 pixel, 1 spare
    reach = int(margin_px) + (int(round(4.0 * blur_px)) if blur_px > 0 else 0) + 2
    x0, y0 = max(0, bx - reach), max(0, by - reach)
    x1, y1 = min(w, bx + bw + reach), min(h, by + bh + reach)
    small = cv2.resize(np.asarray(frame), size, interpolation=cv2.INTER_LINEAR)[y0:y1, x0:x1]
    lab = lab_image(small, (x1 - x0, y1 - y0), lightness_weight)  # checks the frame's shape
    if blur_px > 0:
        lab = cv2.GaussianBlur(lab, (0, 0), blur_px)
    s = s[y0:y1, x0:x1]
    out = np.empty((y1 - y0, x1 - x0, N_CHANNELS), dtype=np.float32)
    inside = s > 0
    near = inside
    if margin_px > 0:
        k = 2 * int(margin_px) + 1
        near = cv2.dilate(s, np.ones((k, k), np.uint8)) > 0
    for c in range(3):
        # Sobel's 3x3 kernel sums 4 differences over 2 pixels: / 8 gives units per pixel
        out[..., 2 * c] = cv2.Sobel(lab[..., c], cv2.CV_32F, 1, 0, ksize=3) / 8.0
        out[..., 2 * c + 1] = cv2.Sobel(lab[..., c], cv2.CV_32F, 0, 1, ksize=3) / 8.0
    out[~near] = 0.0
    mag = np.sqrt((out[inside] ** 2).sum(axis=1))
    if interior_px > 0:
        k = 2 * int(interior_px) + 1
        # inside the frame the crop's edge lies beyond a band of background: the same result
        out[cv2.erode(s, np.ones((k, k), np.uint8)) == 0] = 0.0
    scale = max(float(np.percentile(mag, scale_percentile)), float(min_scale), 1e-6)
    out /= np.float32(scale)
    return y0, x0, out


@nb.njit(cache=True, nogil=True)
def _edge_sums_range(
    lo: int,
    hi: int,
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
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
                ua, va, sa, ub, vb, sb, ok = raster.project_capsule(pts, i, cap_ab, c, cams, k)
                if not ok:
                    continue
                du = ub - ua
                dv = vb - va
                n = np.sqrt(du * du + dv * dv)
                if n < 1e-9:
                    continue
                nx = -dv / n  # unit normal of the projected axis
                ny = du / n
                ra = radii[c, 0] * sa
                rb = radii[c, 1] * sb
                for s in range(ts.shape[0]):
                    t = ts[s]
                    cx = ua + t * du
                    cy = va + t * dv
                    r = ra + t * (rb - ra)
                    for side in range(2):
                        sg = 1.0 if side == 0 else -1.0
                        x = int(np.floor(cx + sg * r * nx + 0.5))
                        y = int(np.floor(cy + sg * r * ny + 0.5))
                        if x < 0 or y < 0 or x >= w or y >= h:
                            continue
                        e2 = 0.0
                        for ch in range(3):
                            g = maps[k, y, x, 2 * ch] * nx + maps[k, y, x, 2 * ch + 1] * ny
                            e2 += g * g
                        acc += min(1.0, np.sqrt(e2))
            out[i, k] = acc


@nb.njit(cache=True, nogil=True)
def _edge_sums_serial(
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    maps: np.ndarray,
    ts: np.ndarray,
) -> np.ndarray:
    """:func:`edge_sums_kernel` on one thread (small batches: no parallel dispatch)."""
    out = np.zeros((pts.shape[0], cams.shape[0]), dtype=np.float64)
    _edge_sums_range(0, pts.shape[0], pts, sel, cap_ab, radii, cams, cam_hw, maps, ts, out)
    return out


@nb.njit(cache=True, parallel=True, nogil=True)
def edge_sums_kernel(
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    maps: np.ndarray,
    ts: np.ndarray,
    nchunks: int,
) -> np.ndarray:
    """Summed outline-point edge scores of capsules ``sel`` per pose and camera -> ``(N, K)``.

    Parameters
    ----------
    pts : (N, P, 3) model points (``BodyModel.points``), metres.
    sel : (S,) int64 capsules to score; cap_ab : (C, 2) point indices of the capsule ends.
    radii : (C, 2) capsule radii at the ends, metres.
    cams : (K, 32) packed cameras (:func:`tracker.raster.pack_camera`); cam_hw : (K, 2) int64.
    maps : (K, H, W, 6) float32 edge maps (:func:`edge_map`).
    ts : (n_samples,) positions along the projected axis (0 = end a, 1 = end b).
    nchunks : work units shared by the threads.
    """
    n = pts.shape[0]
    out = np.zeros((n, cams.shape[0]), dtype=np.float64)
    nchunks = max(1, min(n, nchunks))
    for ch in nb.prange(nchunks):
        _edge_sums_range(
            ch * n // nchunks,
            (ch + 1) * n // nchunks,
            pts,
            sel,
            cap_ab,
            radii,
            cams,
            cam_hw,
            maps,
            ts,
            out,
        )
    return out


class EdgeCue(CapsuleSumsCue):
    """The edge score of poses: their limbs' projected outlines against the frame's edges.

    Parameters
    ----------
    cameras : sequence of Camera
        At the cue's working resolution (``config.size``), one per tracker camera.
    config : tracker.config.EdgeConfig
    """

    def __init__(self, cameras: Sequence[Camera], config) -> None:
        self.config = config
        self.cameras = list(cameras)
        self.cams, self.cam_hw = raster.pack_cameras(self.cameras)
        self._on = capsules_of(config.parts)
        m = config.axis_margin
        self.ts = np.linspace(m, 1.0 - m, config.samples)
        hmax, wmax = int(self.cam_hw[:, 0].max()), int(self.cam_hw[:, 1].max())
        self.maps = np.zeros((len(self.cameras), hmax, wmax, N_CHANNELS), dtype=np.float32)
        self.has_frame = False
        self._crops: list[tuple[int, int, np.ndarray] | None] = []  # the maps' boxes
        #: The edge score of recent estimates (the normaliser of the factor), None at first.
        self.typical: float | None = None
        self._sel_cache: dict[tuple[int | None, int], np.ndarray] = {}

    # -- frame ------------------------------------------------------------------------------
    def set_frame(self, frames: Sequence[np.ndarray], silhouettes: Sequence[np.ndarray]) -> None:
        """The current frames (BGR uint8, any size) and silhouettes (bool ``(H, W)``, any
        size)."""
        if len(frames) != len(self.cameras) or len(silhouettes) != len(self.cameras):
            raise ValueError(
                f"expected {len(self.cameras)} frames and silhouettes, "
                f"got {len(frames)} and {len(silhouettes)}"
            )
        c = self.config
        crops = [
            edge_map_crop(
                f,
                s,
                (cam.width, cam.height),
                lightness_weight=c.lightness_weight,
                blur_px=c.blur_px,
                margin_px=c.margin_px,
                scale_percentile=c.scale_percentile,
                min_scale=c.min_scale,
                interior_px=c.interior_px,
            )
            for f, s, cam in zip(frames, silhouettes, self.cameras, strict=True)
        ]
        self._paste(crops)

    def _paste(self, crops: list[tuple[int, int, np.ndarray] | None]) -> None:
        self._clear_boxes()
        for k, crop in enumerate(crops):
            if crop is not None:
                y0, x0, m = crop
                self.maps[k, y0 : y0 + m.shape[0], x0 : x0 + m.shape[1]] = m
        self._crops = crops
        self.has_frame = True

    def _clear_boxes(self) -> None:
        """Zero the maps where the last frame wrote (the rest is zero already)."""
        for k, crop in enumerate(self._crops):
            if crop is not None:
                y0, x0, m = crop
                self.maps[k, y0 : y0 + m.shape[0], x0 : x0 + m.shape[1]] = 0.0
        self._crops = []

    def frame_state(self) -> list | None:
        """The current edge maps' non-zero boxes (None without a frame), for
        :meth:`restore_frame`: the silhouette's bounding box (grown by the kernels' reach) per
        camera, instead of the whole maps."""
        return list(self._crops) if self.has_frame else None

    def restore_frame(self, state: list | None) -> None:
        """Make maps kept by :meth:`frame_state` the current ones (None: no frame)."""
        if state is None:
            self.clear_frame()
            return
        self._paste(list(state))

    def clear_frame(self) -> None:
        """No frame for this time step: the cue does not score until the next one is set."""
        self.has_frame = False

    # -- scoring ----------------------------------------------------------------------------
    @property
    def everywhere(self) -> bool:
        """True when the likelihood applies the cue to every weight (``scope = "all"``);
        otherwise only the arm search ranks with it."""
        return self.config.scope == "all"

    @property
    def active(self) -> bool:
        """True when a frame is set and an estimate gave the typical score."""
        return self.has_frame and self.typical is not None

    def _sums(self, body: BodyModel, pts: np.ndarray, group: int | None) -> np.ndarray:
        args = (pts, self._sel(body, group), body.cap_ab, body.radii, self.cams, self.cam_hw)
        if pts.shape[0] < SERIAL_BELOW or nb.get_num_threads() == 1:
            return _edge_sums_serial(*args, self.maps, self.ts)
        return edge_sums_kernel(*args, self.maps, self.ts, 4 * nb.get_num_threads())

    def _norm(self, body: BodyModel) -> float:
        return float(2 * self._sel(body, None).size * self.ts.size)

    def weight_factors(self, body: BodyModel, pts: np.ndarray) -> np.ndarray:
        """``factor(scores(body, pts))`` ``(N,)``."""
        return self.factor(self.scores(body, pts))

    def factor(self, scores: np.ndarray) -> np.ndarray:
        """The multiplier of the silhouette weight: ``(scores / typical) ** beta``."""
        typ = self.typical if self.typical else 1.0
        return (np.maximum(scores, 0.0) / typ) ** self.config.beta

    # -- after each estimate ----------------------------------------------------------------
    def update(self, body: BodyModel, pose: np.ndarray) -> None:
        """Follow the score of the estimates (the factor's normaliser) with this frame's."""
        if not self.has_frame:
            return
        pts = body.points(np.asarray(pose, dtype=np.float64)[None])
        s = float(self.scores(body, pts)[0])
        if not s > 0:
            return
        r = self.config.rate
        self.typical = s if self.typical is None else self.typical + r * (s - self.typical)

    def reset(self) -> None:
        """Forget the typical score (another person)."""
        self.typical = None


__all__ = ["EDGE_PARTS", "EdgeCue", "capsules_of", "edge_map", "edge_map_crop", "edge_sums_kernel"]
