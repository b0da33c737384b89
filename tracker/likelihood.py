"""The silhouette likelihood of a batch of poses: project the fleshed body model into every
camera, compare with the silhouettes, weight.

Per camera the counts are ``Nc`` (pixels in both the silhouette and the model), ``Ns``
(silhouette only) and ``Nm`` (model only). The method's weight is ``Nc / (Ns + Nm)``. That ratio
is unbounded (a perfect match divides by zero), so the default weight is its bounded monotone
transform, the intersection over union::

    w_cam = Nc / (Nc + Ns + Nm) = r / (1 + r),  r = Nc / (Ns + Nm)

which ranks the poses of one camera exactly as the ratio does, lies in [0, 1] (1 = perfect
match) and is 0 when nothing is seen anywhere (``Nc + Ns + Nm = 0``). ``measure="ratio"`` gives
the method's ratio with the denominator floored at one pixel, ``Nc / max(Ns + Nm, 1)`` (a
perfect match scores Nc). The weight of a pose is the mean of ``w_cam`` over the cameras.

The counting runs in numba (:mod:`tracker.raster`): capsules become row spans OR-ed into
bit-packed uint64 rows, counted with popcount against the bit-packed silhouette, in parallel
over the poses. :mod:`tracker.render_ref` is the slow OpenCV reference.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numba as nb
import numpy as np

from tracker import raster
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.dof import LEFT_LEG, N_DOF, RIGHT_LEG

Measure = Literal["iou", "ratio"]


def weight_from_counts(counts: np.ndarray, measure: Measure = "iou") -> np.ndarray:
    """Weights from counts ``(..., K, 3)`` (Nc, Ns, Nm) -> ``(...)`` float64, mean over cameras.

    See the module docstring for ``measure``.
    """
    if measure not in ("iou", "ratio"):
        raise ValueError(f"measure must be 'iou' or 'ratio', not {measure!r}")
    c = np.asarray(counts)
    if (
        np.issubdtype(c.dtype, np.integer)
        and c.ndim >= 2
        and c.shape[-1] == 3
        and 1 <= c.shape[-2] <= _KERNEL_MAX_CAMERAS
    ):
        flat = np.ascontiguousarray(c.reshape(-1, c.shape[-2], 3), dtype=np.int64)
        return _weights_kernel(flat, measure == "ratio").reshape(c.shape[:-2])
    c = c.astype(np.float64, copy=False)
    nc, ns, nm = c[..., 0], c[..., 1], c[..., 2]
    if measure == "iou":
        den = nc + ns + nm
        w = np.divide(nc, den, out=np.zeros_like(nc), where=den > 0)
    else:
        w = nc / np.maximum(ns + nm, 1.0)
    return w.mean(axis=-1)


#: Up to this many cameras :func:`weight_from_counts` runs in numba. Its mean adds the cameras'
#: weights in order, as numpy's mean does below 8 of them (beyond, numpy adds pairwise); the
#: weights are then bit-identical to numpy's.
_KERNEL_MAX_CAMERAS = 7


@nb.njit(cache=True, nogil=True)
def _weights_kernel(counts: np.ndarray, ratio: bool) -> np.ndarray:
    """(R, K, 3) int64 counts -> (R,) weights: :func:`weight_from_counts` in one pass."""
    n, k = counts.shape[0], counts.shape[1]
    out = np.empty(n)
    for i in range(n):
        s = 0.0
        for j in range(k):
            nc = float(counts[i, j, 0])
            ns = float(counts[i, j, 1])
            nm = float(counts[i, j, 2])
            if ratio:
                w = nc / max(ns + nm, 1.0)
            else:
                den = nc + ns + nm
                w = nc / den if den > 0 else 0.0
            s = w if j == 0 else s + w
        out[i] = s / k
    return out


def warm_up() -> float:
    """Compile (or load from numba's cache) every likelihood kernel now; returns seconds taken.

    The first call of each kernel in a fresh environment compiles it (tens of seconds on a busy
    2-core machine); with ``cache=True`` later processes load it in well under a second.
    """
    import time

    t = time.perf_counter()
    body = BodyModel()
    cam = Camera.look_at(name="warm-up", position=[4, 0, 1.5], target=[0, 0, 0.9])
    lik = SilhouetteLikelihood(body, [cam.scaled(64, 48)])
    pose = body.neutral_pose()
    lik.set_silhouettes([lik.render_mask(pose, 0)])
    lik.weights(pose)
    lik.weights_factored(pose[None], np.zeros((1, 1, 6)), np.zeros((1, 1, 6)))
    return time.perf_counter() - t


class SilhouetteLikelihood:
    """Weights of poses against binary silhouettes seen by calibrated cameras.

    Parameters
    ----------
    body : BodyModel
        The fleshed body model.
    cameras : list of Camera
        Cameras at the likelihood resolution (e.g. ``cam.scaled(160, 120)``); each silhouette
        must have that camera's ``(height, width)``.
    measure : {"iou", "ratio"}
        Per-camera weight (module docstring). Keyword only.
    """

    def __init__(
        self, body: BodyModel, cameras: Sequence[Camera], *, measure: Measure = "iou"
    ) -> None:
        if not cameras:
            raise ValueError("SilhouetteLikelihood needs at least one camera")
        if measure not in ("iou", "ratio"):
            raise ValueError(f"measure must be 'iou' or 'ratio', not {measure!r}")
        self.body = body
        self.cameras = list(cameras)
        self.measure: Measure = measure
        k = len(self.cameras)
        self.cams, self.cam_hw = raster.pack_cameras(self.cameras)
        self._hmax = int(self.cam_hw[:, 0].max())
        self._words = int((self.cam_hw[:, 1].max() + 63) // 64)
        self._sil: np.ndarray | None = None
        #: Bit mask of the pixels where model pixels count (all set: no occluder).
        self._vis_all = np.full((k, self._hmax, self._words), np.uint64(0xFFFFFFFFFFFFFFFF))
        self._vis = self._vis_all
        self._vis_on = np.zeros(k, dtype=np.bool_)
        self._sil_total = np.zeros(k, dtype=np.int64)
        #: Per camera, bool (H, W) pixels behind a known static occluder, or None.
        self._occluded: list[np.ndarray | None] = [None] * k
        #: Optional colour cue (tracker.appearance.ColourCue): multiplies the weights when active.
        self.appearance = None
        #: Optional edge cue (tracker.edges.EdgeCue): multiplies the weights when active.
        self.edges = None
        #: Optional 2D key-point cue (tracker.keypoints2d.KeypointCue): multiplies the weights
        #: when active.
        self.keypoints = None
        #: Optional non-penetration prior (tracker.collision.CollisionPrior): multiplies the
        #: weights.
        self.collision = None

    @property
    def n_cameras(self) -> int:
        return len(self.cameras)

    def set_silhouettes(self, silhouettes: Sequence[np.ndarray]) -> None:
        """Set the current frame's silhouettes: one bool ``(H, W)`` array per camera."""
        if len(silhouettes) != self.n_cameras:
            raise ValueError(
                f"expected {self.n_cameras} silhouettes (one per camera), got {len(silhouettes)}"
            )
        sil = np.zeros((self.n_cameras, self._hmax, self._words), dtype=np.uint64)
        vis = self._vis_all.copy() if any(o is not None for o in self._occluded) else None
        total = np.zeros(self.n_cameras, dtype=np.int64)
        for i, (s, cam) in enumerate(zip(silhouettes, self.cameras, strict=True)):
            s = np.asarray(s)
            if s.shape != (cam.height, cam.width):
                raise ValueError(
                    f"silhouette {i} has shape {s.shape}, camera {cam.name!r} expects "
                    f"{(cam.height, cam.width)} (height, width)"
                )
            s = s.astype(bool, copy=False)
            sil[i, : cam.height] = raster.pack_rows(s, self._words)
            total[i] = int(np.count_nonzero(s))
            occ = self._occluded[i]
            if occ is not None:
                vis[i, : cam.height] = raster.pack_rows(~occ | s, self._words)
        self._sil = sil
        self._vis = self._vis_all if vis is None else vis
        self._vis_on = np.array([o is not None for o in self._occluded], dtype=np.bool_)
        self._sil_total = total

    def set_occlusion(self, occluded: Sequence[np.ndarray | None] | None) -> None:
        """Pixels behind known static occluders (furniture), one bool ``(H, W)`` or None per
        camera; None clears all. From the next :meth:`set_silhouettes` on, model pixels there
        do not count as model-only (``Nm``): a hidden limb is neither rewarded nor penalised.
        Silhouette pixels always count.
        """
        if occluded is None:
            self._occluded = [None] * self.n_cameras
            return
        if len(occluded) != self.n_cameras:
            raise ValueError(
                f"expected {self.n_cameras} occlusion masks (one per camera), got {len(occluded)}"
            )
        out: list[np.ndarray | None] = []
        for i, (o, cam) in enumerate(zip(occluded, self.cameras, strict=True)):
            if o is None:
                out.append(None)
                continue
            o = np.asarray(o, dtype=bool)
            if o.shape != (cam.height, cam.width):
                raise ValueError(
                    f"occlusion mask {i} has shape {o.shape}, camera {cam.name!r} expects "
                    f"{(cam.height, cam.width)} (height, width)"
                )
            out.append(o.copy() if o.any() else None)
        self._occluded = out

    @property
    def occluded(self) -> list[np.ndarray | None]:
        """The occlusion masks set by :meth:`set_occlusion` (None: nothing occluded)."""
        return list(self._occluded)

    def _require_silhouettes(self) -> np.ndarray:
        if self._sil is None:
            raise RuntimeError("call set_silhouettes() before counts() or weights()")
        return self._sil

    def _poses(self, poses: np.ndarray) -> np.ndarray:
        p = np.asarray(poses, dtype=np.float64)
        if p.ndim == 1:
            p = p[None]
        if p.ndim != 2 or p.shape[1] != N_DOF:
            raise ValueError(f"poses must have shape (N, {N_DOF}), got {np.shape(poses)}")
        return np.ascontiguousarray(p)

    def counts(self, poses: np.ndarray) -> np.ndarray:
        """Pixel counts of poses ``(N, 31)`` -> ``(N, n_cams, 3)`` int64: Nc, Ns, Nm."""
        return self._counts(self.body.points(self._poses(poses)))

    def _counts(self, pts: np.ndarray) -> np.ndarray:
        sil = self._require_silhouettes()
        b = self.body
        return raster.counts_kernel(
            pts,
            b.cap_ab,
            b.radii,
            self.cams,
            self.cam_hw,
            sil,
            self._vis,
            self._vis_on,
            self._sil_total,
            4 * nb.get_num_threads(),
        )

    def _image_cues(self) -> list:
        """The cues multiplying the weights now, in this order: the colour cue, the edge cue
        when it scores every weight, the 2D key-point cue (each only while active)."""
        cues = []
        if self.appearance is not None and self.appearance.active:
            cues.append(self.appearance)
        if self.edges is not None and self.edges.active and self.edges.everywhere:
            cues.append(self.edges)
        if self.keypoints is not None and self.keypoints.active:
            cues.append(self.keypoints)
        return cues

    def weights(self, poses: np.ndarray) -> np.ndarray:
        """Weights of poses ``(N, 31)`` -> ``(N,)`` float64, mean over cameras."""
        pts = self.body.points(self._poses(poses))
        w = weight_from_counts(self._counts(pts), self.measure)
        for cue in self._image_cues():
            w = w * cue.weight_factors(self.body, pts)
        if self.collision is not None:
            w = w * self.collision.factors(self.body, pts)
        return w

    def counts_factored(
        self, base: np.ndarray, left_leg: np.ndarray, right_leg: np.ndarray
    ) -> np.ndarray:
        """Counts of every leg combination -> ``(M, A, B, n_cams, 3)``; see weights_factored."""
        return self._counts_factored(*self._factored_points(base, left_leg, right_leg))

    def _factored_points(
        self, base: np.ndarray, left_leg: np.ndarray, right_leg: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
        """Model points of the base poses and of every leg variant, and the variant counts."""
        base = self._poses(base)
        m = base.shape[0]
        left = np.asarray(left_leg, dtype=np.float64)
        right = np.asarray(right_leg, dtype=np.float64)
        if left.ndim != 3 or left.shape[0] != m or left.shape[2] != len(LEFT_LEG):
            raise ValueError(f"left_leg must have shape ({m}, A, 6), got {left.shape}")
        if right.ndim != 3 or right.shape[0] != m or right.shape[2] != len(RIGHT_LEG):
            raise ValueError(f"right_leg must have shape ({m}, B, 6), got {right.shape}")
        na, nb_ = left.shape[1], right.shape[1]
        pl = np.repeat(base[:, None, :], na, axis=1)
        pl[:, :, list(LEFT_LEG)] = left
        pr = np.repeat(base[:, None, :], nb_, axis=1)
        pr[:, :, list(RIGHT_LEG)] = right
        b = self.body
        pts_base = b.points(base, group=0)
        pts_left = b.points(pl.reshape(-1, N_DOF), group=1)
        pts_right = b.points(pr.reshape(-1, N_DOF), group=2)
        return pts_base, pts_left, pts_right, na, nb_

    def _counts_factored(
        self,
        pts_base: np.ndarray,
        pts_left: np.ndarray,
        pts_right: np.ndarray,
        na: int,
        nb_: int,
        groups: np.ndarray | None = None,
    ) -> np.ndarray:
        """``groups``: which capsules each part supplies (default the legs', ``capsule_groups``)."""
        sil = self._require_silhouettes()
        b = self.body
        return raster.counts_factored_kernel(
            pts_base,
            pts_left,
            pts_right,
            na,
            nb_,
            b.capsule_groups if groups is None else groups,
            b.cap_ab,
            b.radii,
            self.cams,
            self.cam_hw,
            sil,
            self._vis,
            self._vis_on,
            self._sil_total,
            4 * nb.get_num_threads(),
        )

    def weights_factored(
        self, base: np.ndarray, left_leg: np.ndarray, right_leg: np.ndarray
    ) -> np.ndarray:
        """Weights of every combination of left-leg and right-leg variants of base poses.

        Parameters
        ----------
        base : np.ndarray
            ``(M, 31)`` poses.
        left_leg : np.ndarray
            ``(M, A, 6)`` values of the DOFs ``tracker.dof.LEFT_LEG`` (indices 19..24).
        right_leg : np.ndarray
            ``(M, B, 6)`` values of ``tracker.dof.RIGHT_LEG`` (25..30).

        Returns
        -------
        np.ndarray
            ``(M, A, B)`` float64: the weight of ``base[m]`` with its left-leg DOFs replaced by
            ``left_leg[m, a]`` and its right-leg DOFs by ``right_leg[m, b]``; equal to
            :meth:`weights` of those poses. The upper body is rendered once per m and each leg
            variant once, then the A*B combinations are OR-ed and counted.
        """
        pts = self._factored_points(base, left_leg, right_leg)
        w = weight_from_counts(self._counts_factored(*pts), self.measure)
        for cue in self._image_cues():
            w = w * cue.factor(cue.scores_factored(self.body, *pts[:3]))
        if self.collision is not None:  # the pairs lie in the base (upper body and pelvis)
            w = w * self.collision.factors(self.body, pts[0])[:, None, None]
        return w

    def weights_moving(
        self, base: np.ndarray, poses: np.ndarray, capsules: np.ndarray
    ) -> np.ndarray:
        """Weights ``(N,)`` of poses ``(N, 31)`` that differ from ``base`` ``(31,)`` only in DOFs
        moving the given capsules (indices into the body's capsules, e.g. one arm's).

        The rest of the body is rendered once from ``base`` and each pose's moving capsules
        alone, then OR-ed and counted (``raster.counts_factored_kernel`` with those capsules as
        the only varying group), so a batch costs little more than rendering those capsules.
        Equal to :meth:`weights` of ``poses`` when they differ from ``base`` only so; the
        caller guarantees it (other differences are ignored for the silhouette counts).
        """
        b = self.body
        p = self._poses(poses)
        pts_base = b.points(self._poses(base)[:1])
        pts = b.points(p)
        groups = np.zeros(len(b.radii), dtype=np.int64)
        groups[np.asarray(capsules, dtype=np.int64)] = 1  # group 2 (the "right" part): empty
        counts = self._counts_factored(pts_base, pts, pts_base, p.shape[0], 1, groups)[0, :, 0]
        w = weight_from_counts(counts, self.measure)
        for cue in self._image_cues():
            w = w * cue.weight_factors(b, pts)
        if self.collision is not None:
            w = w * self.collision.factors(b, pts)
        return w

    def render_mask(self, pose: np.ndarray, camera_index: int) -> np.ndarray:
        """The model's silhouette of one pose (31,) in one camera: bool ``(H, W)``."""
        cam = self.cameras[camera_index]
        k = camera_index
        pts = self.body.points(self._poses(pose)[:1])
        b = self.body
        bits = raster.render_one_kernel(pts, b.cap_ab, b.radii, self.cams, k, cam.height, cam.width)
        return raster.unpack_rows(bits, cam.width)
