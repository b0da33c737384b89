"""Exhaustive first-frame and re-initialisation search (issue 3).

When there is no track (first frame, or after the track was lost) the tracker weighs a grid of
plausible configurations:

* body configurations: standing, ``walking_phases`` phases of a walking cycle (hip and knee
  flexion of both legs half a cycle apart, arms swinging opposite), ``flexed_phases`` phases of
  a flexed walk (crouch gait, a stooped elderly walk: the walking cycle with the hips, knees,
  ankles and trunk flexed further, :data:`FLEXED_OFFSETS_DEG`), and seated when the joint
  limits allow it (a chair's seat and a low one, :data:`SEATED_KNEE_DEG`, each upright and
  leaning, :data:`SEATED_LEAN_DEG`; placed by their feet, not their pelvis); each clamped to
  the limits; the root height of each is set so that the lowest foot point is on the floor;
* positions: a square grid of ``position_step_m`` within ``position_radius_m`` of the floor point
  under the silhouette (the bottom of each camera's silhouette back-projected to the floor with
  ``Camera.pixel_to_floor``; median over the cameras);
* headings: ``headings`` values over the full circle.

The best few (``refine_best``) are refined by the origin search with wide ranges. The result is
every candidate sorted by weight, to seed the filter (:meth:`tracker.filters.Filter.initialise`).
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np

from gaitwatch.conventions import L_HEEL, L_TOE, R_HEEL, R_TOE
from tracker.config import TrackerConfig
from tracker.dof import DOF, N_DOF, clamp
from tracker.filters.base import Likelihood, select_distinct
from tracker.origin import search_origin
from tracker.raster import numba_threads

_FEET = [L_HEEL, R_HEEL, L_TOE, R_TOE]


@dataclass(frozen=True)
class InitResult:
    """Outcome of :func:`initial_search`.

    Attributes
    ----------
    poses : ndarray, shape (K, 31)
        Every weighed candidate (refined ones included), heaviest first.
    weights : ndarray, shape (K,)
    floor_xy : ndarray, shape (2,)
        The floor point the position grid was centred on.
    evaluations : int
    """

    poses: np.ndarray
    weights: np.ndarray
    floor_xy: np.ndarray
    evaluations: int

    @property
    def best(self) -> np.ndarray:
        return self.poses[0]

    @property
    def best_weight(self) -> float:
        return float(self.weights[0])


#: Flexion added to the walking phases for a flexed walk (degrees): crouch gait keeps the knees
#: 30-80 deg flexed through the cycle with the hips flexed 20-60 deg (shared/data/opensim
#: angles-crouch*.mot); the ankle dorsiflexes by the shank's extra lean (knee minus hip) so the
#: stance foot stays flat, and the trunk leans forward over the flexed hips.
FLEXED_OFFSETS_DEG: dict[str, float] = {
    "hip_flexion": 20.0,
    "knee_flexion": 40.0,
    "ankle_flexion": 20.0,
    "trunk_flexion": 15.0,
}


#: Trunk flexion of the seated configurations (degrees; clamped to the limits): upright, and
#: leaning forward as one does while sitting down, before rising, or resting the forearms on
#: the knees.
SEATED_LEAN_DEG: tuple[float, ...] = (0.0, 25.0, 50.0)
#: Knee flexion of the seated configurations (degrees): a chair's seat (about 0.45 m, knees at
#: a right angle) and a low one (a sofa or a low stool: the feet drawn back under the knees).
SEATED_KNEE_DEG: tuple[float, float] = (90.0, 120.0)


def walking_phase_angles(phase: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Approximate sagittal hip and knee flexion (degrees) over a gait cycle.

    ``phase`` in [0, 1), heel strike at 0: hip flexion 32 deg at heel strike to -12 deg in late
    stance; knee with the loading-response bump (~20 deg) and the swing peak (~60 deg).
    """
    p = np.asarray(phase, dtype=np.float64) % 1.0
    hip = 10.0 + 22.0 * np.cos(2 * np.pi * p)
    knee = (
        5.0
        + 15.0 * np.exp(-(((p - 0.15) / 0.08) ** 2))
        + 55.0 * np.exp(-(((p - 0.72) / 0.12) ** 2))
    )
    return hip, knee


def body_configurations(
    body, config: TrackerConfig, limits: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, list[str]]:
    """Candidate body configurations at x = y = 0, heading 0, feet on the floor. The seated
    ones have their feet's mid-point at x = y = 0, their pelvis behind it.

    Returns
    -------
    poses : ndarray, shape (K, 31)
    labels : list of str
        "standing", "walking-<phase>", "flexed-<phase>", "seated[-low][-lean<deg>]".
    """
    low, high = limits
    base = np.asarray(body.neutral_pose(0.0, 0.0, 0.0), dtype=np.float64)
    poses = [base.copy()]
    labels = ["standing"]
    families = (
        ("walking", config.init.walking_phases, None),
        ("flexed", config.init.flexed_phases, FLEXED_OFFSETS_DEG),
    )
    for family, n, offsets in families:
        for k in range(n):
            ph = k / n
            hl, kl = walking_phase_angles(np.array([ph]))
            hr, kr = walking_phase_angles(np.array([ph + 0.5]))
            p = base.copy()
            p[DOF["l_hip_flexion"]] = np.radians(hl[0])
            p[DOF["l_knee_flexion"]] = np.radians(kl[0])
            p[DOF["r_hip_flexion"]] = np.radians(hr[0])
            p[DOF["r_knee_flexion"]] = np.radians(kr[0])
            p[DOF["l_shoulder_flexion"]] = np.radians(-0.6 * (hr[0] - 10.0))
            p[DOF["r_shoulder_flexion"]] = np.radians(-0.6 * (hl[0] - 10.0))
            p[DOF["l_elbow_flexion"]] = np.radians(20.0)
            p[DOF["r_elbow_flexion"]] = np.radians(20.0)
            if offsets is not None:
                p[DOF["trunk_flexion"]] += np.radians(offsets["trunk_flexion"])
                for side in ("l", "r"):
                    for joint in ("hip_flexion", "knee_flexion", "ankle_flexion"):
                        p[DOF[f"{side}_{joint}"]] += np.radians(offsets[joint])
            poses.append(p)
            labels.append(f"{family}-{ph:.3f}")
    seat = np.radians(85.0)
    hip, knee = DOF["l_hip_flexion"], DOF["l_knee_flexion"]
    if config.init.seated and high[hip] >= seat and high[knee] >= seat:
        trunk = DOF["trunk_flexion"]
        leans = sorted(
            {float(np.clip(np.radians(d), low[trunk], high[trunk])) for d in SEATED_LEAN_DEG}
        )
        for knee_deg, name in zip(SEATED_KNEE_DEG, ("seated", "seated-low"), strict=True):
            for lean in leans:
                p = base.copy()
                for side in ("l", "r"):
                    p[DOF[f"{side}_hip_flexion"]] = np.radians(90.0)
                    p[DOF[f"{side}_knee_flexion"]] = np.radians(knee_deg)
                    # the foot flat: dorsiflexed by the shank's lean back from the vertical
                    p[DOF[f"{side}_ankle_flexion"]] = np.radians(knee_deg - 90.0)
                    p[DOF[f"{side}_elbow_flexion"]] = np.radians(60.0)
                p[trunk] = lean
                poses.append(p)
                labels.append(name if lean == 0.0 else f"{name}-lean{np.degrees(lean):.0f}")
    out = clamp(np.stack(poses), low, high)
    # Root height so that the lowest foot point touches the floor.
    out[:, DOF["root_z"]] = 0.0
    joints = np.asarray(body.forward(out))
    out[:, DOF["root_z"]] = -joints[:, _FEET, 2].min(axis=1)
    # A seated body's feet stand a thigh's length ahead of its pelvis, and the searches place
    # a configuration at the floor point under the silhouette (its feet): so seated
    # configurations are moved to have their feet, not their pelvis, at x = y = 0
    # (initial_search turns that offset with the heading).
    seated = np.array([lab.startswith("seated") for lab in labels])
    if seated.any():
        feet = joints[seated][:, _FEET, :2].mean(axis=1)
        out[seated, DOF["root_x"]] -= feet[:, 0]
        out[seated, DOF["root_y"]] -= feet[:, 1]
    return clamp(out, low, high), labels


def floor_point(cameras: Sequence, masks: Sequence[np.ndarray]) -> np.ndarray | None:
    """Floor point (x, y) under the silhouettes: bottom of each mask back-projected to z = 0.

    Parameters
    ----------
    cameras : sequence of Camera
        At the masks' resolution.
    masks : sequence of bool ndarray (H, W)

    Returns
    -------
    ndarray, shape (2,), or None when no camera sees a silhouette whose bottom meets the floor.
    """
    points = []
    for cam, mask in zip(cameras, masks, strict=True):
        p = camera_floor_point(cam, mask)
        if p is not None:
            points.append(p)
    if not points:
        return None
    return np.median(np.stack(points), axis=0)


def camera_floor_point(camera, mask: np.ndarray) -> np.ndarray | None:
    """One camera's floor point (x, y): the middle of the silhouette's lowest rows
    back-projected to z = 0; None without a silhouette or when the ray misses the floor."""
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return None
    bottom = rows[-1]
    band = mask[max(0, bottom - 2) : bottom + 1]
    cols = np.flatnonzero(band.any(axis=0))
    px = np.array([[float(cols.mean()), float(bottom)]])
    p = camera.pixel_to_floor(px, 0.0)[0]
    return p[:2] if np.all(np.isfinite(p)) else None


def initial_search(
    likelihood: Likelihood,
    body,
    cameras: Sequence,
    masks: Sequence[np.ndarray],
    config: TrackerConfig,
    *,
    limits: tuple[np.ndarray, np.ndarray],
    dt: float = 0.05,
    floor_xy: np.ndarray | None = None,
    headings: np.ndarray | None = None,
    configs: np.ndarray | None = None,
    threads: int | None = None,
) -> InitResult | None:
    """Weigh the grid of plausible configurations; ``None`` when no floor point is found.

    Parameters
    ----------
    likelihood : Likelihood
        With the silhouettes of this frame set.
    body : tracker.body.BodyModel
    cameras, masks
        Cameras at likelihood resolution and this frame's silhouettes (for the floor point).
    config : TrackerConfig
    limits : (low, high)
    dt : float
        Frame interval (s), for the refinement's ranges.
    floor_xy : ndarray (2,), optional
        Use this floor point instead of the silhouettes'.
    headings : ndarray, optional
        Headings (radians) to try instead of ``config.init.headings`` values over the circle.
    configs : ndarray (K, 31), optional
        ``body_configurations(body, config, limits)[0]`` when the caller keeps them (they are
        the same every frame).
    threads : int, optional
        numba threads for weighing the grid (one batch of hundreds or thousands of poses); the
        refinement's batches of a few poses then run on one thread. Default: every batch on the
        threads the caller set.
    """
    ic = config.init
    if floor_xy is None:
        floor_xy = floor_point(cameras, masks)
    if floor_xy is None:
        return None
    low, high = limits
    if configs is None:
        configs, _ = body_configurations(body, config, limits)
    r = ic.position_radius_m
    k = int(np.floor(r / ic.position_step_m + 1e-9))
    offs = np.arange(-k, k + 1) * ic.position_step_m
    gx, gy = np.meshgrid(offs, offs, indexing="ij")
    keep = gx**2 + gy**2 <= r**2 + 1e-9
    xy = np.stack([gx[keep], gy[keep]], axis=1) + floor_xy
    if headings is None:
        yaws = -np.pi + (np.arange(ic.headings) + 0.5) * (2 * np.pi / ic.headings)
    else:
        yaws = np.asarray(headings, dtype=np.float64).ravel()
    # (configs, positions, headings) grid, thinned deterministically to max_candidates.
    nc, npos, nh = configs.shape[0], xy.shape[0], yaws.size
    total = nc * npos * nh
    idx = np.arange(total)
    if total > ic.max_candidates:
        idx = np.linspace(0, total - 1, ic.max_candidates).round().astype(np.intp)
    ci, pi, hi = np.unravel_index(idx, (nc, npos, nh))
    cand = configs[ci].copy()
    # A configuration's own root x, y (heading 0) is its offset from the grid position: zero
    # but for the seated ones, whose feet are placed there (body_configurations).
    ox, oy = cand[:, DOF["root_x"]].copy(), cand[:, DOF["root_y"]].copy()
    cy, sy = np.cos(yaws[hi]), np.sin(yaws[hi])
    cand[:, DOF["root_x"]] = xy[pi, 0] + cy * ox - sy * oy
    cand[:, DOF["root_y"]] = xy[pi, 1] + sy * ox + cy * oy
    cand[:, DOF["root_yaw"]] = yaws[hi]
    clamp(cand, low, high)
    weights = np.empty(cand.shape[0])
    chunk = 4096
    with nullcontext() if threads is None else numba_threads(threads):
        for s in range(0, cand.shape[0], chunk):
            weights[s : s + chunk] = likelihood.weights(cand[s : s + chunk])
    evaluations = cand.shape[0]
    refined, refined_w = [], []
    for i in select_distinct(cand, weights, ic.refine_best):
        with nullcontext() if threads is None else numba_threads(1):
            res = search_origin(
                likelihood,
                cand[i],
                config.origin.model_copy(update={"levels": max(3, config.origin.levels)}),
                limits=limits,
                dt=dt,
                reference_dt=config.reference_dt_s,
                range_scale=max(1.0, ic.position_step_m / max(config.origin.range_xy_m, 1e-9)),
                weight=float(weights[i]),
            )
        evaluations += res.evaluations
        refined.append(res.pose)
        refined_w.append(res.weight)
    if refined:
        cand = np.concatenate([np.stack(refined), cand])
        weights = np.concatenate([np.asarray(refined_w), weights])
    order = np.argsort(-weights, kind="stable")
    return InitResult(
        poses=cand[order].reshape(-1, N_DOF),
        weights=weights[order],
        floor_xy=np.asarray(floor_xy, dtype=np.float64),
        evaluations=evaluations,
    )
