"""Grid search of each arm after the filter (``TrackerConfig.arms``).

The filter explores only the hips' and knees' flexion on a grid; the arms get one white-noise
draw per group. Walking swings them by tens of degrees a second, and an arm the filter loses
tends to stay hidden inside the trunk's silhouette: a model arm there costs no model-only pixels,
so no small random move pays until one lands on the real arm. On two-camera footage of the
tracker's own body fitted to the recordings the estimate's elbows were 20 degrees too straight
and the shoulders 10 to 14 degrees too adducted on average, and the wrists were off by 15-19 cm
(``docs/tracker.md``, "Arm search").

This stage searches each arm in turn on a deterministic grid around its current values, the rest
of the pose held: shoulder flexion on ``flexion_values`` values over ``+-range_flexion_deg``, and
shoulder abduction, shoulder rotation and elbow flexion on three values each (``-r, 0, +r``; a
range of 0 leaves that DOF out). With the defaults that is 7 x 3 x 3 x 3 = 189 poses per arm,
weighed in one batch. The best pose is kept only when it outweighs the current one; ``levels``
(default 1) repeat the search with the ranges halved (``shrink``). The weight never decreases.

Cost: ``levels * 2 * grid`` likelihood evaluations (378 with the defaults). An arm's variants
differ from the pose only in that arm's three volumes (upper arm, forearm, hand), so when the
likelihood offers ``weights_moving`` the rest of the body is rendered once and each variant's
arm alone (the same weights, bit for bit). On by default with two cameras or more, never
through one (``ArmSearchConfig.min_cameras``; ``docs/tracker.md``, "Arm search").
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from tracker.config import ArmSearchConfig
from tracker.dof import DOF, clamp
from tracker.filters.base import Likelihood

SIDES: tuple[str, ...] = ("l", "r")


@dataclass(frozen=True)
class ArmSearchResult:
    """Outcome of :func:`search_arms`: the pose (the input when nothing weighed more), its
    weight (never below the input weight) and the poses weighed."""

    pose: np.ndarray
    weight: float
    evaluations: int


def arm_grid(config: ArmSearchConfig) -> tuple[list[str], np.ndarray]:
    """The searched DOF suffixes and the grid of offsets (G, d) in radians, at level 0.

    The zero offset (the current pose) is always one of the rows. Cached per set of ranges (the
    pipeline asks for it on every frame).
    """
    names, grid = _grid(
        config.flexion_values,
        config.range_flexion_deg,
        config.range_abduction_deg,
        config.range_rotation_deg,
        config.range_elbow_deg,
    )
    return list(names), grid.copy()


@lru_cache(maxsize=8)
def _grid(
    n_flexion: int, flexion: float, abduction: float, rotation: float, elbow: float
) -> tuple[tuple[str, ...], np.ndarray]:
    axes: list[tuple[str, np.ndarray]] = [
        ("shoulder_flexion", np.linspace(-flexion, flexion, n_flexion))
    ]
    for name, r in (
        ("shoulder_abduction", abduction),
        ("shoulder_rotation", rotation),
        ("elbow_flexion", elbow),
    ):
        if r > 0:
            axes.append((name, np.array([-r, 0.0, r])))
    grid = np.stack(np.meshgrid(*[v for _, v in axes], indexing="ij"), axis=-1)
    return tuple(n for n, _ in axes), np.radians(grid.reshape(-1, len(axes)))


def search_arms(
    likelihood: Likelihood,
    pose: np.ndarray,
    weight: float,
    config: ArmSearchConfig,
    *,
    limits: tuple[np.ndarray, np.ndarray],
    rank=None,
) -> ArmSearchResult:
    """Search the left arm, then the right arm, on the grid of :func:`arm_grid`, ``levels``
    times with ranges shrinking by ``shrink``; see the module docstring.

    ``weight`` is ``pose``'s weight on the likelihood's current silhouettes. ``rank``, when
    given, maps poses ``(N, 31)`` to factors ``(N,)`` that multiply the weights for choosing
    (the edge cue with ``edges.scope = "arm_search"``); the result's weight stays the
    likelihood's.
    """
    names, grid = arm_grid(config)
    low, high = limits
    # One arm's variants differ from the pose only in that arm's volumes: render the rest once.
    moving = getattr(likelihood, "weights_moving", None)
    body = getattr(likelihood, "body", None)
    if body is None or not hasattr(body, "arm_capsules"):
        moving = None
    best = np.asarray(pose, dtype=np.float64).copy()
    best_w = float(weight)
    best_r = best_w if rank is None else best_w * float(rank(best[None])[0])
    evaluations = 0
    for level in range(config.levels):
        offsets = grid * config.shrink**level
        for side in SIDES:
            idx = [DOF[f"{side}_{n}"] for n in names]
            cand = np.repeat(best[None], len(offsets), axis=0)
            cand[:, idx] += offsets
            clamp(cand, low, high)
            if moving is not None:
                w = np.asarray(moving(best, cand, body.arm_capsules[side]), dtype=np.float64)
            else:
                w = np.asarray(likelihood.weights(cand), dtype=np.float64)
            evaluations += len(cand)
            r = w if rank is None else w * np.asarray(rank(cand), dtype=np.float64)
            i = int(np.argmax(r))
            if r[i] > best_r:
                best, best_w, best_r = cand[i].copy(), float(w[i]), float(r[i])
    return ArmSearchResult(pose=best, weight=best_w, evaluations=evaluations)
