"""Hierarchical search of the body origin, one dimension at a time (issue 3).

Before the body parts of each frame, the root DOFs (sacrum x, y, z and heading, then pitch and
roll) are re-estimated holding the previous frame's body-part configuration: for each dimension
in turn a small grid of ``steps`` values around the current value (range stated for 20 Hz footage
and scaled with ``dt / 0.05``) is weighed with the likelihood, the best value is kept, and the
range shrinks by ``shrink`` for the next refinement. x and y may first be moved by a damped
constant-velocity prediction.

Cost: ``passes * 6 * levels * steps`` likelihood evaluations per frame (84 with the defaults),
less one per grid after the first: its zero offset is the current best, whose weight is known (a
caller that knows the start pose's weight on this frame's silhouettes saves the first one too).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tracker.config import OriginSearchConfig
from tracker.dof import DOF, clamp
from tracker.filters.base import Likelihood

#: Search order: position and heading first, then the remaining root rotations.
ORIGIN_ORDER: tuple[str, ...] = (
    "root_x",
    "root_y",
    "root_z",
    "root_yaw",
    "root_pitch",
    "root_roll",
)


@dataclass(frozen=True)
class OriginResult:
    """Outcome of :func:`search_origin`.

    Attributes
    ----------
    pose : ndarray, shape (31,)
        The input pose with its root DOFs replaced by the best values found.
    weight : float
        Likelihood weight of ``pose``.
    evaluations : int
        Poses weighed.
    """

    pose: np.ndarray
    weight: float
    evaluations: int


def _ranges(config: OriginSearchConfig, scale: float) -> dict[str, float]:
    tilt = np.radians(config.range_tilt_deg) * scale
    return {
        "root_x": config.range_xy_m * scale,
        "root_y": config.range_xy_m * scale,
        "root_z": config.range_z_m * scale,
        "root_yaw": np.radians(config.range_yaw_deg) * scale,
        "root_pitch": tilt,
        "root_roll": tilt,
    }


def search_origin(
    likelihood: Likelihood,
    pose: np.ndarray,
    config: OriginSearchConfig,
    *,
    limits: tuple[np.ndarray, np.ndarray],
    dt: float = 0.05,
    reference_dt: float = 0.05,
    velocity_xy: np.ndarray | None = None,
    range_scale: float = 1.0,
    weight: float | None = None,
) -> OriginResult:
    """Re-estimate the root DOFs of ``pose`` (31,) one dimension at a time.

    Parameters
    ----------
    likelihood : Likelihood
        Weighs poses (N, 31) -> (N,).
    pose : ndarray, shape (31,)
        Previous estimate; its body-part DOFs are held fixed.
    config : OriginSearchConfig
    limits : (low (31,), high (31,))
        Metres / radians.
    dt, reference_dt : float
        Frame interval and the interval the configured ranges are stated for (s).
    velocity_xy : ndarray, shape (2,), optional
        Recent root velocity in m/s for the damped constant-velocity prediction of x, y.
    range_scale : float
        Extra factor on every range (e.g. larger when refining an initialisation candidate).
    weight : float, optional
        ``likelihood.weights(pose)`` on the current silhouettes when the caller has it. The
        result is the same with or without it, with one evaluation fewer when the first grid's
        zero offset is ``pose`` itself (no velocity prediction, inside the limits).

    Notes
    -----
    Each grid's zero offset is the current best pose (its root value plus ``0 * r``, clamped):
    when it equals the pose weighed before bit for bit, that weight is reused instead of
    weighing it again. The likelihood is deterministic, so the poses and weights are the same,
    bit for bit, as weighing every grid value.
    """
    low, high = limits
    best = np.array(pose, dtype=np.float64).copy()
    if velocity_xy is not None and config.velocity_damping > 0:
        best[[DOF["root_x"], DOF["root_y"]]] += (
            config.velocity_damping * np.asarray(velocity_xy) * dt
        )
    clamp(best[None], low, high)
    # A pose whose weight is known: the caller's start pose, then each grid's best.
    known_pose = np.array(pose, dtype=np.float64)
    ranges = _ranges(config, (dt / reference_dt) * range_scale)
    offsets = np.linspace(-1.0, 1.0, config.steps)
    # Ties go to the value closest to the current one: order candidates by |offset|.
    order = np.argsort(np.abs(offsets), kind="stable")
    offsets = offsets[order]
    # The zero offset (first after the sort, when the number of steps is odd) is best itself.
    zero_first = bool(offsets[0] == 0.0)
    known_weight = weight
    evaluations = 0
    w = np.empty(offsets.size)
    for _ in range(config.passes):
        for name in ORIGIN_ORDER:
            r = ranges[name]
            if r <= 0:
                continue
            j = DOF[name]
            for _level in range(config.levels):
                cand = np.repeat(best[None], offsets.size, axis=0)
                cand[:, j] = best[j] + offsets * r
                clamp(cand, low, high)
                if zero_first and known_weight is not None and np.array_equal(cand[0], known_pose):
                    w[0] = known_weight
                    w[1:] = likelihood.weights(cand[1:])
                    evaluations += cand.shape[0] - 1
                else:
                    w[:] = likelihood.weights(cand)
                    evaluations += cand.shape[0]
                k = int(np.argmax(w))
                best = cand[k].copy()
                known_pose = best
                known_weight = weight = float(w[k])
                r *= config.shrink
    if weight is None or not np.array_equal(best, known_pose):
        weight = float(np.asarray(likelihood.weights(best[None]))[0])
        evaluations += 1
    return OriginResult(pose=best, weight=weight, evaluations=evaluations)
