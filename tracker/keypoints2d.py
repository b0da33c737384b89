"""The 2D key-point cue: the model's key points against a 2D pose detector's (on by default).

The silhouette cannot tell which of two basins of nearly the same weight the pose lies in
(``bench/likelihood_ceiling.py``: the truth's basin and the tracker's, both climbed, weigh the
same on half the frames). A 2D human-pose detector run on the frame sees the knees, ankles and
feet inside the silhouette. This module scores poses against such detections; it does not run
a detector: :mod:`tracker.detector2d` is the built-in one, which ``Tracker.process`` runs on each
frame it is given no key points for, or the caller passes each frame's detected key points per
camera to ``Tracker.process(..., keypoints=...)``.

* **Detections** of one frame: per camera an array ``(19, 3)`` in the CONVENTIONS key-point
  order, ``(u, v, confidence)`` in that camera's image pixels (the camera file's image size),
  NaN where the detector has no such point; ``None`` for a camera with no detection. Points
  less confident than ``min_confidence`` are unused.
* **Score** of a pose: each key point of the model's scored parts (:data:`PARTS`: the legs' knee,
  ankle, heel and toe; by default with one camera also the hip joint centres, with two cameras or
  more the arms' shoulder, elbow and wrist) is projected into each camera with a detection and
  scores ``exp(-d^2 / 2 s^2)``, ``s`` = ``sigma_fraction`` x the detected person's height in the
  image (at least ``min_sigma_px``), ``d`` to the detector's point of that kind on the side the
  model's limb is assigned to, less ``tolerance_fraction`` x that height (opt-in, 0 by default:
  distances within it score as a match, so the detector's own small errors do not pull the pose).
  Detectors confuse the sides of a person seen from the side or the back, so per camera and part the
  better of the two assignments (the model's left limb to the detected left one and right to right,
  or exchanged) counts: both model legs can never settle on one detected leg. The pose's score is
  the mean over the detected points and the cameras. Each leg's sums against either detected side
  depend on that leg only and the arms and hips lie in the base poses, so the score of every leg
  combination follows from per-leg sums (``scores_factored``) and the IPF's factored weights stay
  exact.
* **Heatmaps** (config ``score`` with one camera, ``score_multi_camera`` with more; by default
  with two cameras or more): besides its points, the built-in detector gives per landmark a
  heatmap, how likely each place of its crop holds it (:class:`KeypointHeatmaps`). A model
  point then scores that heatmap's value where it projects (bilinear, 0 outside the map) in
  place of the Gaussian of its distance to one detected point: the map keeps what the single
  point loses, a second place the landmark may be and how sure the detector is around it.
  Everything else is as above (the detected points that are confident enough, the better
  assignment of the sides, the mean), but the factor's exponent is ``heatmap_beta`` (0.5):
  a heatmap falls off within a few hundredths of the person's height, where the points'
  Gaussian spreads over 8 %. Key points given by the caller come without heatmaps and are
  scored as points.
* **Combination**: ``SilhouetteLikelihood.keypoints`` multiplies every weight by ``(score /
  typical) ** beta``, ``typical`` the running score of the estimates (``update``), so weights
  keep the IoU scale. The cue is inactive until the first estimate gives the typical score,
  and in a frame without detections. With ``initial`` (opt-in) the first initial search scores
  its candidates too, with a provisional typical (:meth:`KeypointCue.begin_initial`): the
  detector sees which way the legs bend and the feet point, which a silhouette cannot tell.
* **Facing** (:meth:`KeypointCue.facing`, :func:`facing_evidence`): the weight does not use
  the detected nose, but the heading check does (``heading_check.facing_s``): seen in profile,
  the nose lies ahead of the shoulders, which tells front from back where a silhouette cannot.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numba as nb
import numpy as np

from gaitwatch.conventions import (
    HEAD,
    L_HIP,
    L_SHOULDER,
    N_KEYPOINTS,
    NECK,
    R_HIP,
    R_SHOULDER,
)
from tracker import raster
from tracker.body import BodyModel
from tracker.camera import Camera

#: The scored key points of each leg (CONVENTIONS indices): knee, ankle, heel, toe.
LEFT_POINTS: tuple[int, ...] = (11, 13, 15, 17)
RIGHT_POINTS: tuple[int, ...] = (12, 14, 16, 18)
#: The scored parts (config ``parts``): their left and right key points. The legs vary in the
#: IPF's factored weights; the arms (shoulder, elbow, wrist) and the hips lie in the base poses.
PARTS: dict[str, tuple[tuple[int, ...], tuple[int, ...]]] = {
    "legs": (LEFT_POINTS, RIGHT_POINTS),
    "arms": ((3, 5, 7), (4, 6, 8)),
    "hips": ((9,), (10,)),
}


@dataclass(frozen=True)
class KeypointHeatmaps:
    """A detector's heatmaps of one camera and frame: per CONVENTIONS key point a map of how
    likely each place holds it.

    Attributes
    ----------
    maps : ndarray ``(19, H, W)``
        Probabilities in [0, 1] in the CONVENTIONS key-point order (zeros for a key point the
        detector has no map of).
    to_map : ndarray ``(2, 3)``
        The affine map from the camera's image pixels to the maps' cells: cell ``(row, col)``
        lies at ``to_map @ (u, v, 1) = (col, row)``.
    """

    maps: np.ndarray
    to_map: np.ndarray

    def __post_init__(self) -> None:
        maps = np.asarray(self.maps)
        to_map = np.asarray(self.to_map, dtype=np.float64)
        if maps.ndim != 3 or maps.shape[0] != N_KEYPOINTS or min(maps.shape[1:]) < 2:
            raise ValueError(
                f"heatmaps must have shape ({N_KEYPOINTS}, H, W) with H, W >= 2, got {maps.shape}"
            )
        if to_map.shape != (2, 3) or not np.isfinite(to_map).all():
            raise ValueError(f"to_map must be a finite (2, 3) affine map, got {to_map.shape}")
        object.__setattr__(self, "to_map", to_map)


def sample_maps(maps: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Bilinear samples of maps ``(2, h, H, W)`` at cell positions ``cells`` ``(N, h, 2)``
    (col, row): ``(2, N, h)``, the j-th position sampled on each side's j-th map; 0 outside the
    maps and at NaN. A numba kernel: numpy's gathers took ten times the points' Gaussian."""
    maps = np.ascontiguousarray(maps, dtype=np.float32)
    cells = np.ascontiguousarray(cells, dtype=np.float64)
    if maps.ndim != 4 or maps.shape[0] != 2 or min(maps.shape[2:]) < 2:
        raise ValueError(f"maps must have shape (2, h, H >= 2, W >= 2), got {maps.shape}")
    if cells.ndim != 3 or cells.shape[1:] != (maps.shape[1], 2):
        raise ValueError(f"cells must have shape (N, {maps.shape[1]}, 2), got {cells.shape}")
    out = np.empty((2, cells.shape[0], cells.shape[1]))
    _sample_maps(maps, cells, out)
    return out


@nb.njit(cache=True, inline="always")
def _bilinear(m, x: float, y: float) -> float:  # pragma: no cover - numba
    """Map ``m`` ``(H, W)`` sampled bilinearly at column ``x``, row ``y``; 0 outside and at
    NaN."""
    rows, cols = m.shape
    if not (x >= 0.0 and x <= cols - 1 and y >= 0.0 and y <= rows - 1):  # NaN: outside
        return 0.0
    x0 = min(int(x), cols - 2)
    y0 = min(int(y), rows - 2)
    fx, fy = x - x0, y - y0
    top = m[y0, x0] + (m[y0, x0 + 1] - m[y0, x0]) * fx
    bottom = m[y0 + 1, x0] + (m[y0 + 1, x0 + 1] - m[y0 + 1, x0]) * fx
    return top + (bottom - top) * fy


@nb.njit(cache=True, nogil=True)
def _sample_maps(maps, cells, out) -> None:  # pragma: no cover - numba
    for n in range(cells.shape[0]):
        for j in range(cells.shape[1]):
            for s in range(2):
                out[s, n, j] = _bilinear(maps[s, j], cells[n, j, 0], cells[n, j, 1])


@nb.njit(cache=True, nogil=True)
def _cue_sums(
    pts, cols, cams, k, filled, valid, part_of, sigma, tol, maps, to_map, use_maps, out
) -> None:  # pragma: no cover - numba
    """Adds to ``out`` ``(sides, parts, 2 detected sides, N)`` each pose's point scores through
    packed camera ``k``: pose ``n``'s model point ``cols[s, j]`` (``pts`` ``(N, P, 3)``) against
    the detected point ``j`` of either side (``filled`` ``(2, H, 2)``, where ``valid``), into
    the slot of its part ``part_of[j]``; the Gaussian of the distance (less ``tol``) of spread
    ``sigma``, or with ``use_maps`` the detected side's map ``maps[d, j]`` sampled bilinearly
    where ``to_map`` puts the pixel (0 outside). A point behind the camera scores 0."""
    for n in range(pts.shape[0]):
        for s in range(cols.shape[0]):
            for j in range(cols.shape[1]):
                q = cols[s, j]
                u, v, ok = raster.project_uv(pts[n, q, 0], pts[n, q, 1], pts[n, q, 2], cams, k)
                if not ok:
                    continue
                slot = part_of[j]
                if use_maps:
                    x = to_map[0, 0] * u + to_map[0, 1] * v + to_map[0, 2]
                    y = to_map[1, 0] * u + to_map[1, 1] * v + to_map[1, 2]
                    for d in range(2):
                        if valid[d, j]:
                            out[s, slot, d, n] += _bilinear(maps[d, j], x, y)
                else:
                    for d in range(2):
                        if valid[d, j]:
                            du = u - filled[d, j, 0]
                            dv = v - filled[d, j, 1]
                            dist = np.sqrt(du * du + dv * dv)
                            if tol > 0.0:
                                dist = max(dist - tol, 0.0)
                            r = dist / sigma
                            out[s, slot, d, n] += np.exp(-0.5 * r * r)


_NO_MAPS = np.zeros((2, 1, 2, 2), dtype=np.float32)
_NO_MAP = np.zeros((2, 3))


class KeypointCue:
    """Detected 2D key points of the current frame and the key-point score of poses.

    Parameters
    ----------
    cameras : sequence of Camera
        The tracker's cameras at the resolution the detections are given in.
    config : tracker.config.KeypointConfig
        ``parts`` are scored with one camera, ``parts_multi_camera`` with more.
    """

    def __init__(self, cameras: Sequence[Camera], config) -> None:
        self.config = config
        self.cameras = list(cameras)
        self._cams = raster.pack_cameras(self.cameras)[0]  # for the scores' kernel
        multi = len(self.cameras) > 1 and config.parts_multi_camera is not None
        self.parts = tuple(config.parts_multi_camera if multi else config.parts)
        #: How points are scored: "point" or "heatmap" (with the detector's heatmaps).
        self.score_mode = config.score_for(len(self.cameras))
        unknown = set(self.parts) - set(PARTS)
        if unknown:
            raise ValueError(f"unknown key-point parts {sorted(unknown)}: among {sorted(PARTS)}")
        #: Running score of recent estimates (None until the first estimate with detections).
        self.typical: float | None = None
        #: Per camera None or, per part, the detected (2 sides, points, 2) pixels (NaN: none).
        self._det: list[dict[str, np.ndarray] | None] | None = None
        self._sigma: np.ndarray | None = None  # per camera (K,)
        self._tol: np.ndarray | None = None  # per camera (K,), pixels
        #: Per camera None or the detector's heatmaps (config ``score = "heatmap"``).
        self._heat: list[KeypointHeatmaps | None] | None = None
        #: Per group of parts its per-camera entries for this frame (:meth:`_group`).
        self._groups: dict[tuple[str, ...], list[tuple | None]] = {}
        #: Per camera None or the detected nose and shoulders in units of the person's height
        #: (:func:`_face_points`), for :meth:`facing`; None without any.
        self._face: list[np.ndarray | None] | None = None
        #: Per camera None or all 19 detected points ``(19, 2)`` in pixels, NaN where not
        #: confident enough (:attr:`points`); None without any.
        self._uv: list[np.ndarray | None] | None = None

    # -- the frame -------------------------------------------------------------------------
    def set_frame(
        self,
        detections: Sequence[np.ndarray | None] | None,
        heatmaps: Sequence[KeypointHeatmaps | None] | None = None,
    ) -> None:
        """This frame's detections (module docstring); None or no usable point: no frame.
        ``heatmaps``, per camera the detector's :class:`KeypointHeatmaps` (or None), score the
        detected points by their maps when the config's ``score`` is ``"heatmap"``."""
        if detections is None:
            self.clear_frame()
            return
        if len(detections) != len(self.cameras):
            raise ValueError(
                f"expected key points for {len(self.cameras)} cameras, got {len(detections)}"
            )
        if heatmaps is not None and len(heatmaps) != len(self.cameras):
            raise ValueError(
                f"expected heatmaps for {len(self.cameras)} cameras, got {len(heatmaps)}"
            )
        if self.score_mode != "heatmap" or heatmaps is None or all(h is None for h in heatmaps):
            heatmaps = None
        elif any(hm is not None and not isinstance(hm, KeypointHeatmaps) for hm in heatmaps):
            raise ValueError("heatmaps must be KeypointHeatmaps or None per camera")
        det: list[dict[str, np.ndarray] | None] = []
        face: list[np.ndarray | None] = []
        points: list[np.ndarray | None] = []
        sigma = np.zeros(len(self.cameras))
        tol = np.zeros(len(self.cameras))
        c = self.config
        for i, d in enumerate(detections):
            if d is None:
                det.append(None)
                face.append(None)
                points.append(None)
                continue
            a = np.asarray(d, dtype=np.float64)
            if a.shape != (N_KEYPOINTS, 3):
                raise ValueError(
                    f"key points of camera {i} must have shape ({N_KEYPOINTS}, 3), got {a.shape}"
                )
            ok = np.isfinite(a).all(axis=1) & (a[:, 2] >= c.min_confidence)
            uv = np.where(ok[:, None], a[:, :2], np.nan)
            height = float(np.nanmax(uv[:, 1]) - np.nanmin(uv[:, 1])) if ok.sum() >= 2 else 0.0
            face.append(_face_points(uv, height))
            points.append(uv)
            parts = {p: np.stack([uv[list(lr)] for lr in PARTS[p]]) for p in self.parts}
            if ok.sum() < 2 or not any(np.isfinite(x).any() for x in parts.values()):
                det.append(None)
                continue
            sigma[i] = max(c.sigma_fraction * height, c.min_sigma_px)
            tol[i] = c.tolerance_fraction * height
            det.append(parts)
        if all(d is None for d in det):
            self.clear_frame()
        else:
            self._det, self._sigma, self._tol = det, sigma, tol
            self._heat = None if heatmaps is None else list(heatmaps)
            self._groups = {}
        self._face = face if any(f is not None for f in face) else None
        self._uv = points if any(p is not None for p in points) else None

    def clear_frame(self) -> None:
        """No detections this frame: the cue does not score it."""
        self._det = self._sigma = self._tol = None
        self._groups = {}
        self._heat = None
        self._face = None
        self._uv = None

    @property
    def points(self) -> list[np.ndarray | None] | None:
        """This frame's detected points per camera: None or ``(19, 2)`` pixels, NaN where a
        point was not found or less confident than ``min_confidence``; None without any
        (for :func:`tracker.triangulation.fuse_detections` and
        :func:`~tracker.triangulation.fuse_along_rays`)."""
        return self._uv

    @property
    def has_frame(self) -> bool:
        return self._det is not None

    @property
    def scores_heatmaps(self) -> bool:
        """True when this frame's points are scored by the detector's heatmaps."""
        return self._heat is not None

    @property
    def active(self) -> bool:
        """True when a frame is set and an estimate gave the typical score."""
        return self.has_frame and self.typical is not None

    def frame_state(self) -> tuple | None:
        """This frame's detections, for :meth:`restore_frame` (the backward pass)."""
        if self._det is None and self._face is None and self._uv is None:
            return None
        if self._det is None:
            return None, None, None, self._face, None, self._uv
        heat = None if self._heat is None else list(self._heat)
        return list(self._det), self._sigma.copy(), self._tol.copy(), self._face, heat, self._uv

    def restore_frame(self, state: tuple | None) -> None:
        """Set the frame kept by :meth:`frame_state` (None: no frame)."""
        self.clear_frame()
        if state is None:
            return
        if state[0] is not None:
            self._det, self._sigma, self._tol = list(state[0]), state[1].copy(), state[2].copy()
            self._heat = state[4]
            self._groups = {}
        self._face = state[3]
        self._uv = state[5]

    # -- facing ----------------------------------------------------------------------------
    def facing(self, joints: np.ndarray, min_profile: float) -> float | None:
        """Whether this frame's detections show the face on the side the body ``joints``
        (19, 3) face: the detected nose's offset from the detected shoulders' midpoint along the
        image direction the body faces, as a fraction of the detected person's height,
        averaged over the cameras that see the body at least ``min_profile`` in profile
        (:func:`facing_evidence`) and weighted by how much. Positive: the detections agree;
        negative: the body faces the other way. None: no camera tells (no frame, no nose or
        shoulders detected, or every camera sees the body from the front or the back)."""
        if self._face is None:
            return None
        total = weight = 0.0
        for cam, face in zip(self.cameras, self._face, strict=True):
            if face is None:
                continue
            ev = facing_evidence(cam, face, joints)
            if ev is None or ev[1] < min_profile:
                continue
            total += ev[0] * ev[1]
            weight += ev[1]
        return total / weight if weight > 0 else None

    # -- scores ----------------------------------------------------------------------------
    def _group(self, parts: tuple[str, ...]) -> list[tuple | None]:
        """Per camera None (no detected point of ``parts``) or the detected points of ``parts``
        laid side by side, so one pass of :func:`_cue_sums` scores them all: the model's point
        indices ``(sides, H)`` per tuple of sides (``(0,)``, ``(1,)``, ``(0, 1)``), the detected
        points ``(2, H, 2)``, which are there ``(2, H)``, the slot in ``parts`` of the part each
        of the ``H`` columns belongs to, each part's number of detected points
        ``(len(parts),)``, and the heatmaps ``(2, H, rows, cols)`` with their map (or None).
        Built once per frame and group."""
        cached = self._groups.get(parts)
        if cached is not None:
            return cached
        group: list[tuple | None] = []
        heat = self._heat or [None] * len(self.cameras)
        for det, hm in zip(self._det or (), heat, strict=False):
            sels: tuple[list[int], list[int]] = ([], [])
            filled, valid, part_of = [], [], []
            counts = np.zeros(len(parts))
            for slot, part in enumerate(parts):
                pts = None if det is None else det.get(part)  # (2, points, 2), NaN: none
                if pts is None:
                    continue
                found = np.isfinite(pts).all(axis=2)  # (2, points)
                have = np.flatnonzero(found.any(axis=0))  # a point of either side
                for side in (0, 1):
                    sels[side].extend(PARTS[part][side][j] for j in have)
                filled.append(np.where(found[:, have, None], pts[:, have], 0.0))
                valid.append(found[:, have])
                part_of += [slot] * len(have)
                counts[slot] = found.sum()
            if not part_of:
                group.append(None)
                continue
            cols = {
                sides: np.array([sels[side] for side in sides], dtype=np.int64)
                for sides in ((0,), (1,), (0, 1))
            }
            maps = None
            if hm is not None:  # the model's point indices are the landmarks' of each side
                grids = np.asarray(hm.maps, dtype=np.float32)[cols[(0, 1)]]  # (2, H, rows, cols)
                maps = (np.ascontiguousarray(grids), np.ascontiguousarray(hm.to_map))
            group.append(
                (
                    cols,
                    np.ascontiguousarray(np.concatenate(filled, axis=1), dtype=np.float64),
                    np.ascontiguousarray(np.concatenate(valid, axis=1)),
                    np.array(part_of, dtype=np.int64),
                    counts,
                    maps,
                )
            )
        self._groups[parts] = group
        return group

    def _side_sums(
        self, pts: np.ndarray, parts: tuple[str, ...], sides: tuple[int, ...]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per side in ``sides`` (0 left, 1 right) and part of ``parts`` the summed point scores
        of poses given their model points ``(N, P, 3)`` against the detector's left and right
        points of the part: ``(len(sides), len(parts), 2 detected sides, N, K)``; and the number
        of each part's detected points per camera ``(len(parts), K)`` (each is scored once under
        either assignment of the sides). One pass of the numba kernel :func:`_cue_sums` per
        camera serves every part and side asked for."""
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        n, n_cams = pts.shape[0], len(self.cameras)
        out = np.zeros((len(sides), len(parts), 2, n, n_cams))
        counts = np.zeros((len(parts), n_cams))
        for k, entry in enumerate(self._group(parts)):
            if entry is None:
                continue
            cols, filled, valid, part_of, count, maps = entry
            sums = np.zeros((len(sides), len(parts), 2, n))
            grids, to_map = maps if maps is not None else (_NO_MAPS, _NO_MAP)
            _cue_sums(
                pts, cols[sides], self._cams, k, filled, valid, part_of,
                float(self._sigma[k]), float(self._tol[k]), grids, to_map, maps is not None, sums,
            )  # fmt: skip
            out[..., k] = sums
            counts[:, k] = count
        return out, counts

    def _best(
        self, pts_left: np.ndarray, pts_right: np.ndarray, parts: tuple[str, ...], shape=None
    ):
        """Per camera the summed score of ``parts``, each part under the better of the two
        assignments of the model's sides to the detected ones ``(..., K)``, and their detected
        points ``(K,)``; the left side's sums are taken from ``pts_left``, the right's from
        ``pts_right``, reshaped to ``shape`` (left) and the broadcasting shape of the right
        when given."""
        if pts_left is pts_right:
            (sl, sr), counts = self._side_sums(pts_left, parts, (0, 1))
        else:
            (sl,), counts = self._side_sums(pts_left, parts, (0,))
            (sr,), _ = self._side_sums(pts_right, parts, (1,))
        if shape is not None:
            k = sl.shape[-1]
            sl = sl.reshape(len(parts), 2, shape[0], -1, 1, k)
            sr = sr.reshape(len(parts), 2, shape[0], 1, -1, k)
        best = np.maximum(sl[:, 0] + sr[:, 1], sl[:, 1] + sr[:, 0])  # per part
        return best.sum(axis=0), counts.sum(axis=0)

    def _mean(self, total: np.ndarray, counts: np.ndarray) -> np.ndarray:
        """The mean point score over the cameras with detections: ``total`` (..., K)."""
        on = counts > 0
        return (total[..., on] / counts[on]).mean(axis=-1)

    def scores(self, body: BodyModel, pts: np.ndarray) -> np.ndarray:
        """Scores ``(N,)`` in [0, 1] of poses given their model points ``(N, P, 3)``."""
        total, counts = self._best(pts, pts, self.parts)
        return self._mean(total, counts)

    def scores_factored(
        self, body: BodyModel, pts_base: np.ndarray, pts_left: np.ndarray, pts_right: np.ndarray
    ) -> np.ndarray:
        """Scores ``(M, A, B)`` of every leg combination (see
        ``SilhouetteLikelihood.weights_factored``) from the points of the base poses ``(M, P,
        3)`` and of the leg variants ``(M * A, P, 3)``, ``(M * B, P, 3)``; equal to
        :meth:`scores` of the combined poses (the arms and hips lie in the base)."""
        m = pts_base.shape[0]
        total = np.zeros((m, 1, 1, len(self.cameras)))
        counts = np.zeros(len(self.cameras))
        if "legs" in self.parts:
            best, cnt = self._best(pts_left, pts_right, ("legs",), shape=(m,))
            total, counts = total + best, counts + cnt
        base = tuple(p for p in self.parts if p != "legs")
        if base:
            best, cnt = self._best(pts_base, pts_base, base)
            total, counts = total + best[:, None, None, :], counts + cnt
        return self._mean(total, counts)

    def factor(self, scores: np.ndarray) -> np.ndarray:
        """The multiplier of the silhouette weight: ``(scores / typical) ** beta``
        (``heatmap_beta`` when this frame's points are scored by heatmaps)."""
        typ = self.typical if self.typical else 1.0
        beta = self.config.heatmap_beta if self.scores_heatmaps else self.config.beta
        return (np.maximum(scores, 1e-6) / typ) ** beta

    def weight_factors(self, body: BodyModel, pts: np.ndarray) -> np.ndarray:
        """``factor(scores(body, pts))`` ``(N,)``."""
        return self.factor(self.scores(body, pts))

    def begin_initial(self) -> bool:
        """Let the first initial search see the cue, before any estimate gave the typical
        score (``initial``): a provisional typical of 1, which ranks the candidates as any
        typical would. True when it was set; :meth:`end_initial` then takes the search's best.
        """
        if not self.config.initial or self.typical is not None or not self.has_frame:
            return False
        self.typical = 1.0
        return True

    def end_initial(self, body: BodyModel, pose: np.ndarray) -> float:
        """After the search :meth:`begin_initial` opened: the typical score becomes ``pose``'s
        (the search's best), as :meth:`update` would set it. Returns the multiplier that puts
        the search's weights on that scale (rankings unchanged). A best that scores nothing
        leaves the cue inactive, as before the search."""
        beta = self.config.heatmap_beta if self.scores_heatmaps else self.config.beta
        s = float(self.scores(body, body.points(np.asarray(pose, dtype=np.float64)[None]))[0])
        if s <= 0:
            self.typical = None
            return float(1e-6**-beta)
        self.typical = s
        return float(s**-beta)

    def update(self, body: BodyModel, pose: np.ndarray) -> None:
        """Follow the estimates' score (the typical score of the factor); no frame: nothing."""
        if not self.has_frame:
            return
        s = float(self.scores(body, body.points(np.asarray(pose, dtype=np.float64)[None]))[0])
        if s <= 0:
            return
        r = self.config.rate
        self.typical = s if self.typical is None else self.typical + r * (s - self.typical)


def _face_points(uv: np.ndarray, height: float) -> np.ndarray | None:
    """The detected nose, left and right shoulder of one camera ``(3, 2)``, in units of the
    detected person's height in the image (pixels / ``height``); None unless all three were
    found (``uv`` (19, 2) pixels, NaN where missing) and the height is positive."""
    pts = uv[[HEAD, L_SHOULDER, R_SHOULDER]]
    if not (np.isfinite(pts).all() and height > 0):
        return None
    return pts / height


def facing_evidence(
    camera: Camera, face: np.ndarray, joints: np.ndarray
) -> tuple[float, float] | None:
    """How one camera's detected face agrees with the way a body faces.

    A silhouette looks alike from the front and from the back; the detector sees the face. The
    body's facing direction is the horizontal perpendicular of its shoulders' and hips'
    left-to-right direction (from ``joints`` (19, 3), world metres, z up). At the neck it is
    projected into the camera, its component along the image's projected vertical removed:
    the image direction the face should lie in from the shoulders. The evidence is the
    detected nose's offset from the detected shoulders' midpoint along it, as a fraction of the
    detected person's height (``face``: nose, left and right shoulder in image pixels divided
    by that height, as :func:`_face_points` keeps them). Seen in profile, the nose lies a few
    hundredths of the height ahead of the shoulders; from the front or the back the facing
    direction points along the line of sight and the image shows nothing of it.

    Returns
    -------
    (evidence, profile) or None
        ``evidence`` positive when the face is where the body faces; ``profile`` = |sin| of
        the horizontal angle between the facing direction and the camera's line of sight to
        the neck (1 in profile, 0 seen from the front or back). None for a degenerate body or
        a neck behind the camera.
    """
    j = np.asarray(joints, dtype=np.float64)
    lr = (j[L_SHOULDER] - j[R_SHOULDER]) + (j[L_HIP] - j[R_HIP])
    lr[2] = 0.0
    n = float(np.hypot(lr[0], lr[1]))
    if not np.isfinite(n) or n < 1e-6:
        return None
    fwd = np.array([lr[1], -lr[0], 0.0]) / n  # left x up: the way the body faces
    neck = j[NECK]
    sight = neck - camera.center
    sight[2] = 0.0
    s = float(np.hypot(sight[0], sight[1]))
    if s < 1e-6 or float(camera.depth(neck[None])[0]) <= 0:
        return None
    profile = abs(fwd[0] * sight[1] - fwd[1] * sight[0]) / s
    p = camera.project(np.stack([neck, neck + 0.3 * fwd, neck + np.array([0.0, 0.0, 0.3])]))
    ahead, up = p[1] - p[0], p[2] - p[0]
    nu = float(np.hypot(*up))
    if nu < 1e-9:
        return None
    up /= nu
    ahead = ahead - float(ahead @ up) * up
    na = float(np.hypot(*ahead))
    if na < 1e-9:
        return None
    nose, left, right = face
    return float((nose - 0.5 * (left + right)) @ ahead) / na, float(profile)


__all__ = [
    "LEFT_POINTS",
    "PARTS",
    "RIGHT_POINTS",
    "KeypointCue",
    "KeypointHeatmaps",
    "facing_evidence",
    "sample_maps",
]
