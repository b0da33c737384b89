"""Tracking accuracy against a ground truth: position, angle, swap and loss metrics.

Compares an estimated :class:`~gaitwatch.trajectory.Trajectory` (the tracker's output) with the
ground truth of the same footage (a synthetic scene's ``JOINTS.csv``) and returns
:class:`TrackingMetrics`:

* **Alignment**: truth and estimate frames are matched by frame number (default) or by time
  (nearest estimate within half a truth frame). Truth frames without an estimate, or whose
  estimate is entirely NaN, are **lost**: they are counted, not scored as errors.
* **Position errors** (mm): the Euclidean distance between estimated and true key points,
  averaged over every (frame, key point) pair that is known in both: all 19 key points
  (MPJPE), the lower limbs (:data:`LOWER_LIMB`: hips, knees, ankles, heels, toes) and the
  groups of :data:`JOINT_GROUPS`.
* **Angle errors** (degrees): hip and knee flexion computed identically from the truth's and the
  estimate's key points with :func:`gait.kinematics.hip_flexion` / :func:`knee_flexion`; the
  sagittal plane of hip flexion is the truth's walking direction
  (:func:`gait.geometry.heading`) for both, so a heading error shows in the positions, not
  twice. RMSE pooled over both sides and all scored frames.
* **Left/right leg swaps**: a scored frame counts as swapped when exchanging the estimate's
  left and right leg key points would lower its lower-limb error by more than
  ``swap_relative`` (30 %) of it *and* by more than ``swap_absolute_mm`` (50 mm).
* **Flat-foot stance** (a diagnostic, :func:`stance_bias`): the mean signed knee flexion and
  foot pitch errors over the frames where the true foot stands flat on the floor.
* **Constant and varying error** (a diagnostic, :func:`offset_split`): each key point's mean
  offset over the run (what a fixed correction per person could remove: the body's
  proportions, where its joint centres are defined, a lasting lean) against what is left
  once it is removed.
* **Speed**: ms/frame and likelihood evaluations/frame come from the harness that ran the
  tracker (they are not measured here).

Nothing in the package imports this module; ``bench/accuracy.py`` and the tests do.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Literal

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
    N_KEYPOINTS,
    NECK,
    R_ANKLE,
    R_ELBOW,
    R_HEEL,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_TOE,
    R_WRIST,
    SACRUM,
    side_index,
)
from gaitwatch.trajectory import Trajectory

LEFT_LEG: tuple[int, ...] = (L_HIP, L_KNEE, L_ANKLE, L_HEEL, L_TOE)
RIGHT_LEG: tuple[int, ...] = (R_HIP, R_KNEE, R_ANKLE, R_HEEL, R_TOE)
LOWER_LIMB: tuple[int, ...] = tuple(sorted(LEFT_LEG + RIGHT_LEG))
"""Hips, knees, ankles, heels and toes of both legs (10 key points)."""

JOINT_GROUPS: dict[str, tuple[int, ...]] = {
    "head_neck": (HEAD, NECK),
    "trunk": (SACRUM, L_SHOULDER, R_SHOULDER),
    "arms": (L_ELBOW, R_ELBOW, L_WRIST, R_WRIST),
    "hips": (L_HIP, R_HIP),
    "knees": (L_KNEE, R_KNEE),
    "ankles_feet": (L_ANKLE, R_ANKLE, L_HEEL, R_HEEL, L_TOE, R_TOE),
}
"""Key-point groups of the per-group errors (they partition the 19 key points)."""

LEG_SWAP_PERMUTATION: np.ndarray = np.arange(N_KEYPOINTS)
LEG_SWAP_PERMUTATION[list(LEFT_LEG)] = RIGHT_LEG
LEG_SWAP_PERMUTATION[list(RIGHT_LEG)] = LEFT_LEG
LEG_SWAP_PERMUTATION.setflags(write=False)
"""Index array exchanging the left and right leg key points (upper body unchanged)."""

_SIDES = ("left", "right")


def swap_legs(positions: np.ndarray) -> np.ndarray:
    """Exchange the left and right leg key points.

    Parameters
    ----------
    positions : ndarray, shape (..., 19, 3)

    Returns
    -------
    ndarray, shape (..., 19, 3)
        A copy with hips, knees, ankles, heels and toes of the two sides exchanged.
    """
    return np.asarray(positions)[..., LEG_SWAP_PERMUTATION, :]


def align(
    truth: Trajectory,
    estimate: Trajectory,
    match: Literal["frame", "time"] = "frame",
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of matching frames.

    Parameters
    ----------
    truth, estimate : Trajectory
    match : {"frame", "time"}
        ``frame``: equal frame numbers. ``time``: for each truth frame the estimate frame
        nearest in time, if within half the truth's frame interval.

    Returns
    -------
    idx_truth, idx_estimate : ndarray of int, shape (K,)
        Row indices into ``truth`` and ``estimate``; truth rows in increasing order. Estimate
        frames whose key points are all NaN are not matched (they count as lost).
    """
    valid = np.isfinite(estimate.positions).any(axis=(1, 2)) if len(estimate) else np.zeros(0, bool)
    est_rows = np.flatnonzero(valid)
    if est_rows.size == 0 or len(truth) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    if match == "frame":
        lookup = {int(estimate.frames[i]): int(i) for i in est_rows}
        pairs = [(i, lookup[int(f)]) for i, f in enumerate(truth.frames) if int(f) in lookup]
    elif match == "time":
        et = estimate.times[est_rows]
        dt = 1.0 / truth.estimated_fps() if len(truth) > 1 or truth.fps else math.inf
        pos = np.clip(np.searchsorted(et, truth.times), 1, max(et.size - 1, 1))
        lo = np.clip(pos - 1, 0, et.size - 1)
        hi = np.clip(pos, 0, et.size - 1)
        near = np.where(np.abs(et[lo] - truth.times) <= np.abs(et[hi] - truth.times), lo, hi)
        ok = np.abs(et[near] - truth.times) <= 0.5 * dt + 1e-9
        pairs = [(int(i), int(est_rows[near[i]])) for i in np.flatnonzero(ok)]
    else:
        raise ValueError(f"match must be 'frame' or 'time', not {match!r}")
    if not pairs:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    it, ie = np.asarray(pairs, dtype=np.int64).T
    return it, ie


def joint_errors_mm(truth_pos: np.ndarray, est_pos: np.ndarray) -> np.ndarray:
    """Per-key-point position errors.

    Parameters
    ----------
    truth_pos, est_pos : ndarray, shape (K, 19, 3)
        Metres, matched frames.

    Returns
    -------
    ndarray, shape (K, 19)
        Euclidean distance in millimetres; NaN where either side is unknown.
    """
    return np.linalg.norm(np.asarray(est_pos) - np.asarray(truth_pos), axis=-1) * 1000.0


def _nanmean(a: np.ndarray) -> float:
    a = np.asarray(a, dtype=np.float64)
    ok = np.isfinite(a)
    return float(a[ok].mean()) if ok.any() else math.nan


def leg_swaps(
    truth_pos: np.ndarray,
    est_pos: np.ndarray,
    *,
    relative: float = 0.3,
    absolute_mm: float = 50.0,
) -> np.ndarray:
    """Frames where the estimate has the legs the wrong way round.

    Parameters
    ----------
    truth_pos, est_pos : ndarray, shape (K, 19, 3)
        Metres, matched frames.
    relative : float
        Minimum reduction of the frame's lower-limb error, as a fraction of it.
    absolute_mm : float
        Minimum reduction in millimetres.

    Returns
    -------
    ndarray of bool, shape (K,)
        True where swapping the estimate's left and right leg key points lowers the mean
        lower-limb error by more than both margins.
    """
    legs = list(LOWER_LIMB)
    e = joint_errors_mm(truth_pos, est_pos)[:, legs]
    es = joint_errors_mm(truth_pos, swap_legs(est_pos))[:, legs]
    with np.errstate(invalid="ignore"), _quiet():
        m = np.nanmean(e, axis=1)
        ms = np.nanmean(es, axis=1)
    gain = m - ms
    return np.isfinite(gain) & (gain > relative * m) & (gain > absolute_mm)


def foot_pitch_deg(positions: np.ndarray, side: str) -> np.ndarray:
    """Pitch of the foot's heel-to-toe line above the horizontal, degrees (toe up positive).

    ``positions`` (K, 19, 3) metres, z up; ``side`` "left" or "right". NaN where a point is
    unknown.
    """
    v = positions[:, side_index(side, "toe")] - positions[:, side_index(side, "heel")]
    with np.errstate(invalid="ignore"):
        return np.degrees(np.arctan2(v[:, 2], np.hypot(v[:, 0], v[:, 1])))


def stance_bias(
    truth_pos: np.ndarray,
    est_pos: np.ndarray,
    *,
    heel_max_m: float = 0.04,
    toe_max_m: float = 0.06,
) -> dict[str, float]:
    """Knee and foot errors while the true foot stands flat on the floor (a diagnostic).

    A (frame, side) pair counts when the truth's heel is below ``heel_max_m`` and its toe below
    ``toe_max_m`` (z up, floor at 0). Over those pairs, pooled over both sides:
    ``knee_deg``, the mean signed knee flexion error (estimate - truth; positive: the estimate
    bends the knee more, :func:`gait.kinematics.knee_flexion`); ``pitch_deg``, the mean signed
    foot pitch error (:func:`foot_pitch_deg`; negative: the estimate's toe points down);
    ``share``, the share of (frame, side) pairs that count. NaN where none count.

    Parameters
    ----------
    truth_pos, est_pos : ndarray, shape (K, 19, 3)
        Metres, matched frames.
    """
    from gait.kinematics import knee_flexion

    knee, pitch, flat_all = [], [], []
    for side in _SIDES:
        heel, toe = side_index(side, "heel"), side_index(side, "toe")
        with np.errstate(invalid="ignore"):
            flat = (truth_pos[:, heel, 2] < heel_max_m) & (truth_pos[:, toe, 2] < toe_max_m)
            knee.append((knee_flexion(est_pos, side) - knee_flexion(truth_pos, side))[flat])
        pitch.append((foot_pitch_deg(est_pos, side) - foot_pitch_deg(truth_pos, side))[flat])
        flat_all.append(flat)
    share = float(np.mean(np.concatenate(flat_all))) if truth_pos.shape[0] else math.nan
    return {
        "knee_deg": _nanmean(np.concatenate(knee)),
        "pitch_deg": _nanmean(np.concatenate(pitch)),
        "share": share,
    }


def offset_split(truth_pos: np.ndarray, est_pos: np.ndarray) -> dict[str, float]:
    """The position error split into each key point's constant offset and what varies.

    Per key point the offset is its mean error vector (estimate - truth) over the frames where
    both are known. ``constant_mm``: the mean over the key points of the offsets' lengths;
    ``varying_mm``: the mean over every known (frame, key point) pair of the error left after
    subtracting its key point's offset, which is what a fixed correction per run cannot
    remove. An estimate that is the truth moved by a fixed vector per key point has
    ``varying_mm`` 0 and ``constant_mm`` the mean length of those vectors. NaN where nothing
    is known.

    Parameters
    ----------
    truth_pos, est_pos : ndarray, shape (K, 19, 3)
        Metres, matched frames.
    """
    err = (np.asarray(est_pos, dtype=np.float64) - np.asarray(truth_pos, dtype=np.float64)) * 1e3
    known = np.isfinite(err).all(axis=-1)  # (K, 19)
    if not known.any():
        return {"constant_mm": math.nan, "varying_mm": math.nan}
    with _quiet():
        offset = np.nanmean(np.where(known[..., None], err, np.nan), axis=0)  # (19, 3)
        constant = float(np.nanmean(np.linalg.norm(offset, axis=-1)))
        varying = float(np.nanmean(np.linalg.norm(err - offset, axis=-1)[known]))
    return {"constant_mm": constant, "varying_mm": varying}


class _quiet:
    """Silence numpy's "Mean of empty slice" warnings inside a block."""

    def __enter__(self) -> None:
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", category=RuntimeWarning)

    def __exit__(self, *exc) -> None:
        self._w.__exit__(*exc)


def truth_forward(truth: Trajectory) -> np.ndarray:
    """Walking direction per truth frame, the sagittal reference of hip flexion.

    :func:`gait.geometry.heading` (smoothed sacrum velocity, else the facing direction from
    the hip and shoulder lines), the same direction ``gait`` uses for its angles.

    Returns
    -------
    ndarray, shape (T, 3)
        Unit horizontal vectors (NaN where unknown).
    """
    from gait.geometry import body_forward, heading

    if len(truth) < 2:
        return body_forward(truth.positions)
    fwd, _ = heading(truth.positions, truth.estimated_fps())
    bad = ~np.isfinite(fwd).all(axis=1)
    if bad.any():
        fwd[bad] = body_forward(truth.positions[bad])
    return fwd


def flexion_angles(positions: np.ndarray, forward: np.ndarray) -> dict[str, np.ndarray]:
    """Hip and knee flexion of both legs (gait.kinematics), degrees.

    Parameters
    ----------
    positions : ndarray, shape (K, 19, 3)
    forward : ndarray, shape (K, 3)
        Horizontal unit walking direction per frame.

    Returns
    -------
    dict
        ``{"hip_left", "hip_right", "knee_left", "knee_right"}`` -> ndarray (K,) in degrees.
    """
    from gait.kinematics import hip_flexion, knee_flexion

    out = {}
    with np.errstate(invalid="ignore"):
        for s in _SIDES:
            out[f"hip_{s}"] = hip_flexion(positions, forward, s)
            out[f"knee_{s}"] = knee_flexion(positions, s)
    return out


@dataclass
class TrackingMetrics:
    """Accuracy of one tracked clip against its truth.

    Attributes
    ----------
    n_truth_frames : int
        Frames of the ground truth.
    n_tracked : int
        Truth frames with an estimate (the scored frames).
    frames_lost : int
        Truth frames without an estimate.
    mpjpe_mm : float
        Mean per-joint position error over the 19 key points, millimetres.
    lower_limb_mm : float
        Mean over :data:`LOWER_LIMB`, millimetres.
    group_mm : dict of str to float
        Mean per :data:`JOINT_GROUPS` group, millimetres.
    per_joint_mm : ndarray, shape (19,)
        Mean per key point, millimetres.
    hip_flexion_rmse_deg, knee_flexion_rmse_deg : float
        RMSE over both sides and the scored frames, degrees.
    angle_rmse_deg : dict of str to float
        Per side: ``hip_left``, ``hip_right``, ``knee_left``, ``knee_right``.
    swap_frames : int
        Scored frames with the legs swapped (see :func:`leg_swaps`).
    ms_per_frame : float
        Tracker time per frame, from the harness (NaN when not given).
    evaluations_per_frame : float
        Likelihood evaluations per frame, from the harness (NaN when not given).
    n_angle_samples : dict of str to int
        Finite samples behind each RMSE (for pooling).
    n_position_samples : int
        Finite (frame, key point) pairs behind ``mpjpe_mm`` (for pooling).
    """

    n_truth_frames: int
    n_tracked: int
    frames_lost: int
    mpjpe_mm: float
    lower_limb_mm: float
    group_mm: dict[str, float]
    per_joint_mm: np.ndarray
    hip_flexion_rmse_deg: float
    knee_flexion_rmse_deg: float
    angle_rmse_deg: dict[str, float]
    swap_frames: int
    ms_per_frame: float = math.nan
    evaluations_per_frame: float = math.nan
    n_angle_samples: dict[str, int] = field(default_factory=dict)
    n_position_samples: int = 0

    @property
    def lost_fraction(self) -> float:
        """Lost truth frames / truth frames (NaN for an empty truth)."""
        return self.frames_lost / self.n_truth_frames if self.n_truth_frames else math.nan

    @property
    def swap_rate(self) -> float:
        """Swapped frames / scored frames (NaN when nothing was scored)."""
        return self.swap_frames / self.n_tracked if self.n_tracked else math.nan

    def to_row(self) -> dict[str, float | int]:
        """One flat table row: errors in mm, RMSE in degrees, rates as fractions."""
        row: dict[str, float | int] = {
            "all_mm": self.mpjpe_mm,
            "lower_mm": self.lower_limb_mm,
        }
        for g in JOINT_GROUPS:
            row[f"{g}_mm"] = self.group_mm.get(g, math.nan)
        row.update(
            {
                "hip_rmse_deg": self.hip_flexion_rmse_deg,
                "knee_rmse_deg": self.knee_flexion_rmse_deg,
                "swap_rate": self.swap_rate,
                "frames_lost": self.frames_lost,
                "frames": self.n_truth_frames,
                "lost_fraction": self.lost_fraction,
                "ms_per_frame": self.ms_per_frame,
                "evals_per_frame": self.evaluations_per_frame,
            }
        )
        return row


def _rmse(a: np.ndarray, b: np.ndarray) -> tuple[float, int]:
    d = np.asarray(a) - np.asarray(b)
    d = d[np.isfinite(d)]
    return (float(np.sqrt(np.mean(d**2))) if d.size else math.nan), int(d.size)


def evaluate(
    truth: Trajectory,
    estimate: Trajectory,
    *,
    match: Literal["frame", "time"] = "frame",
    ms_per_frame: float = math.nan,
    evaluations_per_frame: float = math.nan,
    swap_relative: float = 0.3,
    swap_absolute_mm: float = 50.0,
) -> TrackingMetrics:
    """Score an estimated trajectory against the truth.

    Parameters
    ----------
    truth : Trajectory
        Ground truth (metres, world frame).
    estimate : Trajectory
        The tracker's output; frames it lacks are lost.
    match : {"frame", "time"}
        How frames are paired (:func:`align`).
    ms_per_frame, evaluations_per_frame : float
        Timing and likelihood-evaluation figures measured by the caller, carried into the row.
    swap_relative, swap_absolute_mm : float
        Margins of the leg-swap test (:func:`leg_swaps`).

    Returns
    -------
    TrackingMetrics
    """
    it, ie = align(truth, estimate, match)
    n_truth = len(truth)
    tp = truth.positions[it]
    ep = estimate.positions[ie]
    err = joint_errors_mm(tp, ep)
    with _quiet():
        per_joint = np.nanmean(err, axis=0) if err.size else np.full(N_KEYPOINTS, np.nan)
    groups = {g: _nanmean(err[:, list(idx)]) for g, idx in JOINT_GROUPS.items()}
    rmse: dict[str, float] = {}
    counts: dict[str, int] = {}
    if it.size:
        fwd = truth_forward(truth)[it]
        at = flexion_angles(tp, fwd)
        ae = flexion_angles(ep, fwd)
        for k in at:
            rmse[k], counts[k] = _rmse(ae[k], at[k])
        hip_d = np.concatenate([ae[f"hip_{s}"] - at[f"hip_{s}"] for s in _SIDES])
        knee_d = np.concatenate([ae[f"knee_{s}"] - at[f"knee_{s}"] for s in _SIDES])
        hip_rmse, _ = _rmse(hip_d, 0.0)
        knee_rmse, _ = _rmse(knee_d, 0.0)
        swaps = int(leg_swaps(tp, ep, relative=swap_relative, absolute_mm=swap_absolute_mm).sum())
    else:
        for s in _SIDES:
            for j in ("hip", "knee"):
                rmse[f"{j}_{s}"], counts[f"{j}_{s}"] = math.nan, 0
        hip_rmse = knee_rmse = math.nan
        swaps = 0
    return TrackingMetrics(
        n_truth_frames=n_truth,
        n_tracked=int(it.size),
        frames_lost=n_truth - int(it.size),
        mpjpe_mm=_nanmean(err),
        lower_limb_mm=_nanmean(err[:, list(LOWER_LIMB)]),
        group_mm=groups,
        per_joint_mm=per_joint,
        hip_flexion_rmse_deg=hip_rmse,
        knee_flexion_rmse_deg=knee_rmse,
        angle_rmse_deg=rmse,
        swap_frames=swaps,
        ms_per_frame=float(ms_per_frame),
        evaluations_per_frame=float(evaluations_per_frame),
        n_angle_samples=counts,
        n_position_samples=int(np.isfinite(err).sum()),
    )


def pool(metrics: Iterable[TrackingMetrics]) -> TrackingMetrics:
    """Combine the metrics of several clips as if they were one clip.

    Errors are weighted by their scored frames (per key point by scored frames too), RMSE by
    their angle samples (root of the pooled mean square), counts are summed, ms/frame and
    evaluations/frame are weighted by the truth frames.

    Parameters
    ----------
    metrics : iterable of TrackingMetrics

    Returns
    -------
    TrackingMetrics
    """
    ms = list(metrics)
    if not ms:
        raise ValueError("nothing to pool")
    w = np.array([m.n_tracked for m in ms], dtype=np.float64)

    def wmean(values: Iterable[float], weights: np.ndarray) -> float:
        v = np.asarray(list(values), dtype=np.float64)
        ok = np.isfinite(v) & (weights > 0)
        return float(np.sum(v[ok] * weights[ok]) / np.sum(weights[ok])) if ok.any() else math.nan

    def wrmse(values: Iterable[float], weights: Iterable[int]) -> float:
        v = np.asarray(list(values), dtype=np.float64)
        ww = np.asarray(list(weights), dtype=np.float64)
        ok = np.isfinite(v) & (ww > 0)
        return (
            float(np.sqrt(np.sum(v[ok] ** 2 * ww[ok]) / np.sum(ww[ok]))) if ok.any() else math.nan
        )

    keys = ("hip_left", "hip_right", "knee_left", "knee_right")
    rmse = {k: wrmse((m.angle_rmse_deg.get(k, math.nan) for m in ms),
                     (m.n_angle_samples.get(k, 0) for m in ms)) for k in keys}  # fmt: skip
    counts = {k: sum(m.n_angle_samples.get(k, 0) for m in ms) for k in keys}

    def side_pool(j: str) -> float:
        names = (f"{j}_left", f"{j}_right")
        return wrmse((rmse[n] for n in names), (counts[n] for n in names))

    frames = np.array([m.n_truth_frames for m in ms], dtype=np.float64)
    per_joint = np.array([wmean((m.per_joint_mm[j] for m in ms), w) for j in range(N_KEYPOINTS)])
    return TrackingMetrics(
        n_truth_frames=int(frames.sum()),
        n_tracked=int(w.sum()),
        frames_lost=sum(m.frames_lost for m in ms),
        mpjpe_mm=wmean((m.mpjpe_mm for m in ms), w),
        lower_limb_mm=wmean((m.lower_limb_mm for m in ms), w),
        group_mm={g: wmean((m.group_mm.get(g, math.nan) for m in ms), w) for g in JOINT_GROUPS},
        per_joint_mm=per_joint,
        hip_flexion_rmse_deg=side_pool("hip"),
        knee_flexion_rmse_deg=side_pool("knee"),
        angle_rmse_deg=rmse,
        swap_frames=sum(m.swap_frames for m in ms),
        ms_per_frame=wmean((m.ms_per_frame for m in ms), frames),
        evaluations_per_frame=wmean((m.evaluations_per_frame for m in ms), frames),
        n_angle_samples=counts,
        n_position_samples=sum(m.n_position_samples for m in ms),
    )


def format_row(row: Mapping[str, float | int], keys: Iterable[str]) -> list[str]:
    """Table cells of :meth:`TrackingMetrics.to_row` values: mm and ms as integers, degrees
    with one decimal, rates as percentages, NaN as ``-``."""
    cells = []
    for k in keys:
        v = row[k]
        if isinstance(v, float) and not math.isfinite(v):
            cells.append("-")
        elif k in ("swap_rate", "lost_fraction"):
            cells.append(f"{100 * float(v):.0f}%")
        elif k.endswith("_deg"):
            cells.append(f"{float(v):.1f}")
        else:
            cells.append(f"{float(v):.0f}")
    return cells


__all__ = [
    "JOINT_GROUPS",
    "LEFT_LEG",
    "LEG_SWAP_PERMUTATION",
    "LOWER_LIMB",
    "RIGHT_LEG",
    "TrackingMetrics",
    "align",
    "evaluate",
    "flexion_angles",
    "format_row",
    "joint_errors_mm",
    "leg_swaps",
    "offset_split",
    "pool",
    "swap_legs",
    "truth_forward",
]
