"""Deterministic local refinement of a whole pose after the filter (coordinate search by parts).

The filter explores only its "interesting" DOFs on a grid; the other DOFs get one white-noise
draw per group, so the likelihood often prefers poses the filter does not reach (hip abduction
and rotation, ankles, trunk, arms). This stage searches around the filter's estimate, one body
part at a time, with no random draws:

* **Stages** in order: both legs together, then the upper body (trunk, head, arms), then
  (optionally) the root. In a stage every DOF is moved alone to ``offsets`` of its range
  (``+-range``, ``+-range/2`` ...) and all those single-DOF moves are weighed in one batch.
* **Legs**: the left-leg moves (plus "no move") and the right-leg moves (plus "no move") are
  weighed as every combination in one ``weights_factored`` call (when the likelihood offers it),
  so the best pair of one left-leg and one right-leg move is found from A + B leg renderings.
* **Combination**: the best improving move of each body part (thigh, shank, foot, trunk, head,
  each arm, root) is applied together and weighed once more; the heaviest of the current pose,
  the best single move and the combination is kept. Only improvements are accepted, so the
  weight never decreases.
* **Levels**: the ranges shrink by ``shrink`` per level; ``sweeps`` repeat the stages.

Cost per level with k offsets: legs ``(6 k + 1)^2`` combinations counted (``12 k + 2`` leg
renderings), upper body ``13 k + 1`` and root ``6 k + 1`` poses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tracker.config import RefineConfig
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, clamp
from tracker.filters.base import Likelihood

#: Body parts whose best moves are combined (DOF names); every searched DOF belongs to one.
PARTS: dict[str, tuple[str, ...]] = {
    "root_position": ("root_x", "root_y", "root_z"),
    "root_rotation": ("root_yaw", "root_pitch", "root_roll"),
    "trunk": ("trunk_flexion", "trunk_lateral", "trunk_rotation"),
    "head": ("neck_flexion", "neck_rotation"),
    "l_arm": (
        "l_shoulder_flexion",
        "l_shoulder_abduction",
        "l_shoulder_rotation",
        "l_elbow_flexion",
    ),
    "r_arm": (
        "r_shoulder_flexion",
        "r_shoulder_abduction",
        "r_shoulder_rotation",
        "r_elbow_flexion",
    ),
    "l_thigh": ("l_hip_flexion", "l_hip_abduction", "l_hip_rotation"),
    "l_shank": ("l_knee_flexion",),
    "l_foot": ("l_ankle_flexion", "l_ankle_rotation"),
    "r_thigh": ("r_hip_flexion", "r_hip_abduction", "r_hip_rotation"),
    "r_shank": ("r_knee_flexion",),
    "r_foot": ("r_ankle_flexion", "r_ankle_rotation"),
}
_PART_OF = np.full(N_DOF, -1, dtype=np.intp)
for _k, _names in enumerate(PARTS.values()):
    for _n in _names:
        _PART_OF[DOF[_n]] = _k


@dataclass(frozen=True)
class RefineResult:
    """Outcome of :func:`refine_pose`.

    Attributes
    ----------
    pose : ndarray, shape (31,)
        The refined pose (the input pose when nothing weighed more).
    weight : float
        Its likelihood weight (never below the input weight).
    evaluations : int
        Poses weighed (factored combinations counted one each).
    """

    pose: np.ndarray
    weight: float
    evaluations: int


def dof_ranges(config: RefineConfig, scale: float = 1.0) -> np.ndarray:
    """Search half-range per DOF (31,), metres / radians; 0 = not searched.

    ``scale`` multiplies every range (e.g. ``dt / reference_dt``).
    """
    r = np.zeros(N_DOF)
    ang = np.radians
    r[list(LEFT_LEG) + list(RIGHT_LEG)] = ang(config.range_leg_deg)
    for side in ("l", "r"):
        r[DOF[f"{side}_hip_flexion"]] = ang(config.range_flexion_deg)
        r[DOF[f"{side}_knee_flexion"]] = ang(config.range_flexion_deg)
    if config.upper_body:
        r[6:19] = ang(config.range_upper_deg)
    if config.root:
        r[0:3] = config.range_root_m
        r[3:6] = ang(config.range_root_deg)
    for name, deg in config.range_overrides.items():
        j = DOF[name]
        r[j] = deg if j < 3 else ang(deg)
    return r * scale


def _stages(config: RefineConfig) -> list[np.ndarray]:
    legs = np.array(LEFT_LEG + RIGHT_LEG, dtype=np.intp)
    stages = [legs]
    if config.upper_body:
        stages.append(np.arange(6, 19, dtype=np.intp))
    if config.root:
        stages.append(np.arange(0, 6, dtype=np.intp))
    return stages


def _offsets(config: RefineConfig) -> np.ndarray:
    k = config.offsets
    half = np.arange(1, k // 2 + 1) / (k // 2)  # (k/2,) in (0, 1]
    return np.concatenate([-half[::-1], half])  # e.g. k=4: -1, -0.5, 0.5, 1


def _moves(pose: np.ndarray, dofs: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Poses (len(dofs) * k, 31): ``pose`` with one DOF set to each of its ``values`` (d, k)."""
    d, k = values.shape
    out = np.repeat(pose[None], d * k, axis=0)
    out[np.arange(d * k), np.repeat(dofs, k)] = values.ravel()
    return out


def _combine(
    pose: np.ndarray, cand: np.ndarray, w: np.ndarray, moved: np.ndarray, weight: float
) -> np.ndarray:
    """``pose`` with the best improving move of each body part applied (parts independent)."""
    out = pose.copy()
    parts = _PART_OF[moved]
    for p in np.unique(parts):
        sel = np.flatnonzero((parts == p) & (w > weight))
        if sel.size:
            best = sel[int(np.argmax(w[sel]))]
            out[moved[best]] = cand[best, moved[best]]
    return out


def refine_pose(
    likelihood: Likelihood,
    pose: np.ndarray,
    weight: float | None,
    config: RefineConfig,
    *,
    limits: tuple[np.ndarray, np.ndarray],
    scale: float = 1.0,
) -> RefineResult:
    """Coordinate search of ``pose`` (31,) by body parts; see the module docstring.

    Parameters
    ----------
    likelihood : Likelihood
        ``weights(poses (N, 31)) -> (N,)``; ``weights_factored`` is used for the legs when
        present and ``config.factored``.
    pose : ndarray, shape (31,)
        Start pose (metres, radians).
    weight : float or None
        Its weight if known (else weighed here).
    config : RefineConfig
    limits : (low (31,), high (31,))
        Joint limits, metres / radians; every candidate is clamped.
    scale : float
        Factor on every range (e.g. ``dt / reference_dt``).

    Returns
    -------
    RefineResult
    """
    low, high = limits
    best = clamp(np.array(pose, dtype=np.float64)[None].copy(), low, high)[0]
    evaluations = 0
    if weight is None or not np.array_equal(best, pose):
        weight = float(np.asarray(likelihood.weights(best[None]))[0])
        evaluations += 1
    weight = float(weight)
    ranges = dof_ranges(config, scale)
    offsets = _offsets(config)
    factored = getattr(likelihood, "weights_factored", None) if config.factored else None
    stages = _stages(config)
    for _sweep in range(config.sweeps):
        r = ranges.copy()
        for _level in range(config.levels):
            for dofs in stages:
                dofs = dofs[r[dofs] > 0]
                if dofs.size == 0:
                    continue
                is_legs = np.all(np.isin(dofs, LEFT_LEG + RIGHT_LEG))
                if is_legs and factored is not None:
                    cand, w, marg, moved = _weigh_legs(factored, best, dofs, r, offsets, low, high)
                    evaluations += w.size
                    single = marg  # several parts of one leg improving alone: combine them
                else:
                    vals = best[dofs, None] + r[dofs, None] * offsets[None, :]
                    cand = clamp(_moves(best, dofs, vals), low, high)
                    w = np.asarray(likelihood.weights(cand), dtype=np.float64)
                    evaluations += w.size
                    moved = np.repeat(dofs, offsets.size)
                    single = (cand, w)
                if np.count_nonzero(single[1] > weight) > 1:
                    comb = clamp(_combine(best, *single, moved, weight)[None], low, high)
                    wc = float(np.asarray(likelihood.weights(comb))[0])
                    evaluations += 1
                    cand = np.concatenate([cand, comb])
                    w = np.append(w, wc)
                k = int(np.argmax(w))
                if w[k] > weight:
                    best, weight = cand[k].copy(), float(w[k])
            r *= config.shrink
    return RefineResult(pose=best, weight=weight, evaluations=evaluations)


def refine_top(
    likelihood: Likelihood,
    filt,
    pose: np.ndarray,
    weight: float,
    config,
    *,
    limits: tuple[np.ndarray, np.ndarray],
    dt: float,
) -> RefineResult:
    """Refine the estimate and the ``refine.top_k - 1`` heaviest other distinct particles.

    Parameters
    ----------
    likelihood : Likelihood
    filt : tracker.filters.Filter
        Its ``particles`` / ``weights`` supply the extra starts.
    pose : ndarray, shape (31,)
        The estimate; ``weight`` its weight.
    config : TrackerConfig
        ``config.refine`` and ``config.reference_dt_s`` are used.
    limits : (low (31,), high (31,))
    dt : float
        Frame interval, s (ranges scale with it when ``refine.scale_with_dt``).

    Returns
    -------
    RefineResult
        The heaviest refined pose; ``evaluations`` summed over the starts.
    """
    from tracker.filters.base import select_distinct

    rc = config.refine
    scale = dt / config.reference_dt_s if rc.scale_with_dt else 1.0
    starts = [(np.asarray(pose, dtype=np.float64), float(weight))]
    if rc.top_k > 1 and filt.particles.shape[0]:
        idx = select_distinct(filt.particles, filt.weights, rc.top_k + 1)
        for i in idx:
            if len(starts) >= rc.top_k:
                break
            if not np.array_equal(filt.particles[i], starts[0][0]):
                starts.append((filt.particles[i].copy(), float(filt.weights[i])))
    best: RefineResult | None = None
    total = 0
    for p, w in starts:
        res = refine_pose(likelihood, p, w, rc, limits=limits, scale=scale)
        total += res.evaluations
        if best is None or res.weight > best.weight:
            best = res
    assert best is not None
    return RefineResult(pose=best.pose, weight=best.weight, evaluations=total)


def _weigh_legs(
    factored,
    best: np.ndarray,
    dofs: np.ndarray,
    r: np.ndarray,
    offsets: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Every (left move or none) x (right move or none) pair in one factored call.

    Returns
    -------
    cand : ndarray, shape (A * B, 31)
    w : ndarray, shape (A * B,)
    marginal : (ndarray (S, 31), ndarray (S,))
        The S single-DOF moves (the other leg unmoved) and their weights.
    moved : ndarray of int, shape (S,)
        The DOF each single move changes.
    """
    legs, singles, moved = [], [], []
    for side in (LEFT_LEG, RIGHT_LEG):
        d = dofs[np.isin(dofs, side)]
        vals = best[d, None] + r[d, None] * offsets[None, :]
        poses = clamp(_moves(best, d, vals), low, high)
        singles.append(poses)
        moved.append(np.repeat(d, offsets.size))
        legs.append(np.concatenate([best[None, list(side)], poses[:, list(side)]]))  # 0: none
    left, right = legs
    w = np.asarray(factored(best[None], left[None], right[None]), dtype=np.float64)[0]
    a, b = left.shape[0], right.shape[0]
    cand = np.repeat(best[None], a * b, axis=0)
    cand[:, list(LEFT_LEG)] = np.repeat(left, b, axis=0)
    cand[:, list(RIGHT_LEG)] = np.tile(right, (a, 1))
    marginal = (np.concatenate(singles), np.concatenate([w[1:, 0], w[0, 1:]]))
    return cand, w.ravel(), marginal, np.concatenate(moved)


__all__ = ["PARTS", "RefineResult", "dof_ranges", "refine_pose", "refine_top"]
