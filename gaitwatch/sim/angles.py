"""A walk of the 19 key points from joint angles (an OpenSim ``.mot`` angle table).

Gait laboratories publish joint-angle curves more often than marker positions: one averaged
gait cycle of pelvis, hip, knee and ankle angles, as OpenSim's gait2392 coordinates
(``hip_flexion_r``, ``knee_angle_r`` ...; ``shared/data/opensim/angles-*.mot`` holds a normal
cycle and four crouch gaits). :func:`angle_walk` turns such a cycle into a walk that the scene
synthesiser can render, so that the tracker can be measured on pathological gait:

* **Skeleton.** The segment proportions of :mod:`gaitwatch.sim.motion` (Drillis and Contini,
  fractions of the stature). The pelvis frame's origin is the mid-point of the hip joint
  centres; the thighs hang from the hips, the shanks from the knees, the foot's sole lies
  ``ANKLE_H`` below the ankle from the heel to the second metatarsal head. All angles zero is
  standing upright with the feet flat.
* **Angles** (gait2392 conventions, OpenSim frame x forward, y up, z right; degrees):
  pelvis ``pelvis_tilt`` (about z; negative tilts the pelvis forward), ``pelvis_list``
  (about x), ``pelvis_rotation`` (about y), applied in that order, body-fixed; hip
  ``hip_flexion`` (z, positive forward), ``hip_adduction`` (x), ``hip_rotation`` (y; the left
  side's two axes mirrored, so positive is adduction and internal rotation on both sides);
  ``knee_angle`` (z, negative is flexion); ``ankle_angle`` (z, positive is dorsiflexion);
  trunk ``lumbar_extension``, ``lumbar_bending``, ``lumbar_rotation`` relative to the pelvis.
  Only the hip flexions, knee angles and ankle angles are required; a missing column is 0.
* **Progression.** The table has no pelvis translation worth trusting (an averaged cycle), so
  the walk is made by foot contact: in every frame the foot whose sole is lowest stands still
  on the floor and the pelvis moves over it (no foot sliding), and the whole body is lifted so
  the lowest sole point touches the floor (z = 0). The pelvis never moves backwards: where the
  angles would drag it back over the stance foot, the foot slides instead. The table is one
  cycle, its last row closing it (a mismatch with the first row is taken out linearly over the
  cycle), repeated ``cycles`` times.
* **Arms.** The table has no arm angles: the arms hang 8 degrees out from the trunk, elbows
  bent 20 degrees, and swing with half the opposite hip's flexion about its mean.
* **Events.** A foot's contact starts (heel strike) when its lowest sole point comes within
  ``contact_m`` of the floor and ends (toe off) when it leaves it.

The subject's standing height is known (``height_m``) and carried as the trajectory's
``stature_m``: a crouched walker's head height would understate it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

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
)
from gaitwatch.sim.motion import (
    ANKLE_H,
    FOREARM,
    HEEL_BACK,
    HIP_HALF,
    HIP_TO_NECK,
    NECK_TO_HEAD,
    SACRUM_BACK,
    SACRUM_UP,
    SHANK,
    SHOULDER_HALF,
    THIGH,
    TOE_FWD,
    UPPER_ARM,
    MotionError,
)
from gaitwatch.trajectory import Trajectory

#: Columns an angle table must have (degrees).
REQUIRED = tuple(f"{j}_{s}" for j in ("hip_flexion", "knee_angle", "ankle_angle") for s in "rl")
#: Columns used when present (degrees; 0 when absent).
OPTIONAL = (
    "pelvis_tilt",
    "pelvis_list",
    "pelvis_rotation",
    "hip_adduction_r",
    "hip_adduction_l",
    "hip_rotation_r",
    "hip_rotation_l",
    "lumbar_extension",
    "lumbar_bending",
    "lumbar_rotation",
)

#: A stance foot whose lowest sole point rises more than this fraction of the stature above the
#: other's has left the floor (about 2 cm); a quarter of it is a touch-down.
CONTACT_BAND = 0.012

# OpenSim frame (x forward, y up, z right) -> world (x forward, y left, z up)
_TO_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class AngleWalkParams:
    """Settings of :func:`angle_walk` (SI units)."""

    height_m: float = 1.70
    #: Duration of one gait cycle; None: the table's own time span.
    cycle_s: float | None = None
    #: Number of cycles (a fraction ends part-way).
    cycles: float = 3.0
    fps: float = 100.0
    #: A foot within this height of the floor is in contact (events only).
    contact_m: float = 0.01


def _euler(seq: str, *deg: np.ndarray) -> np.ndarray:
    """Rotations (n, 3, 3) of the body-fixed (intrinsic) axis sequence ``seq`` ("ZXY": about z,
    then the new x, then the new y), one angle series (degrees, shape (n,)) per axis."""
    angles = np.column_stack([np.asarray(d, dtype=float) for d in deg])
    return Rotation.from_euler(seq, angles, degrees=True).as_matrix()


def _apply(R: np.ndarray, v) -> np.ndarray:
    """Rotate one vector (3,) or one per frame (n, 3) by R (n, 3, 3)."""
    v = np.asarray(v, dtype=float)
    if v.ndim == 1:
        return R @ v
    return np.einsum("nij,nj->ni", R, v)


def _debounce(on: np.ndarray, min_frames: int) -> np.ndarray:
    """``on`` with inner runs shorter than ``min_frames`` merged into their neighbours (a toe
    grazing the floor in swing is not a step)."""
    on = on.copy()
    edges = np.flatnonzero(on[1:] != on[:-1]) + 1
    bounds = np.concatenate([[0], edges, [on.size]])
    for a, b in zip(bounds[1:-2], bounds[2:-1], strict=True):
        if b - a < min_frames:
            on[a:b] = on[a - 1]
    return on


def _cycle(table, params: AngleWalkParams) -> tuple[dict[str, np.ndarray], np.ndarray, float]:
    """The angle columns resampled over the walk's frames, the frame times, the cycle time."""
    cols = {c.lower(): i for i, c in enumerate(table.columns)}
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        raise MotionError(f"angle table: no column {', '.join(missing)} (gait2392 names)")
    if "time" not in cols:
        raise MotionError("angle table: no 'time' column")
    if str(table.header.get("inDegrees", "yes")).strip().lower() == "no":
        raise MotionError("angle table: angles in radians (inDegrees=no) are not supported")
    t = table.data[:, cols["time"]]
    if t.size < 3 or not np.all(np.diff(t) > 0):
        raise MotionError("angle table: needs three or more rows with increasing times")
    names = [c for c in REQUIRED + OPTIONAL if c in cols]
    vals = np.stack([table.data[:, cols[c]] for c in names], axis=1)
    if not np.isfinite(vals).all():
        raise MotionError("angle table: a value is not a number")
    period = float(t[-1] - t[0])
    # One cycle from the first row to the last, which should repeat the first. An averaged
    # cycle rarely closes exactly (crouch4's knee: 6 degrees apart): the mismatch is taken out
    # linearly over the cycle, so that repeating it makes no jump.
    phase_src = (t - t[0]) / period
    vals = vals - np.outer(phase_src, vals[-1] - vals[0])
    vals, phase_src = vals[:-1], phase_src[:-1]
    phase_src = np.append(phase_src, 1.0)
    vals = np.vstack([vals, vals[:1]])
    cycle_s = params.cycle_s if params.cycle_s is not None else period
    if not cycle_s > 0 or not params.cycles > 0 or not params.fps > 0:
        raise MotionError("angle walk: cycle_s, cycles and fps must be positive")
    n = int(math.floor(params.cycles * cycle_s * params.fps + 1e-9)) + 1
    times = np.arange(n) / params.fps
    phase = (times / cycle_s) % 1.0
    out = {c: np.interp(phase, phase_src, vals[:, k]) for k, c in enumerate(names)}
    for c in OPTIONAL:
        out.setdefault(c, np.zeros(n))
    return out, times, cycle_s


def angle_walk(table, params: AngleWalkParams | None = None, source: str = "") -> Trajectory:
    """The walk of a joint-angle table (a :class:`gaitwatch.mocap.mot.MotTable`); see the
    module docstring.

    Raises
    ------
    MotionError
        For a table without the required columns, with radians, or too short.
    """
    p = params or AngleWalkParams()
    if not (0.8 <= p.height_m <= 2.4):
        raise MotionError(f"angle walk: height_m {p.height_m} outside 0.8..2.4 m")
    a, times, cycle_s = _cycle(table, p)
    n, S = times.size, p.height_m
    pelvis = _euler("ZXY", a["pelvis_tilt"], a["pelvis_list"], a["pelvis_rotation"])
    pos = np.zeros((n, N_KEYPOINTS, 3))
    sole = {}
    for side, sgn, (ih, ik, ia, ihe, ito) in (
        ("r", 1.0, (R_HIP, R_KNEE, R_ANKLE, R_HEEL, R_TOE)),
        ("l", -1.0, (L_HIP, L_KNEE, L_ANKLE, L_HEEL, L_TOE)),
    ):
        hip = _apply(pelvis, [0.0, 0.0, sgn * HIP_HALF * S])
        thigh = pelvis @ _euler(
            "ZXY",
            a[f"hip_flexion_{side}"],
            sgn * a[f"hip_adduction_{side}"],
            sgn * a[f"hip_rotation_{side}"],
        )
        knee = hip + _apply(thigh, [0.0, -THIGH * S, 0.0])
        shank = thigh @ _euler("Z", a[f"knee_angle_{side}"])
        ankle = knee + _apply(shank, [0.0, -SHANK * S, 0.0])
        foot = shank @ _euler("Z", a[f"ankle_angle_{side}"])
        heel = ankle + _apply(foot, [-HEEL_BACK * S, -ANKLE_H * S, 0.0])
        toe = ankle + _apply(foot, [TOE_FWD * S, -ANKLE_H * S, 0.0])
        pos[:, ih], pos[:, ik], pos[:, ia], pos[:, ihe], pos[:, ito] = hip, knee, ankle, heel, toe
        sole[side] = (ihe, ito)
    pos[:, SACRUM] = _apply(pelvis, [-SACRUM_BACK * S, SACRUM_UP * S, 0.0])
    trunk = pelvis @ _euler("ZXY", a["lumbar_extension"], a["lumbar_bending"], a["lumbar_rotation"])
    neck = _apply(trunk, [0.02 * S, HIP_TO_NECK * S, 0.0])
    pos[:, NECK] = neck
    pos[:, HEAD] = neck + _apply(trunk, [0.015 * S, NECK_TO_HEAD * S, 0.0])
    for sgn, other, (i_sh, i_el, i_wr) in (
        (1.0, "l", (R_SHOULDER, R_ELBOW, R_WRIST)),
        (-1.0, "r", (L_SHOULDER, L_ELBOW, L_WRIST)),
    ):
        sh = neck + _apply(trunk, [0.0, -0.015 * S, sgn * SHOULDER_HALF * S])
        hip_flex = a[f"hip_flexion_{other}"]
        swing = 0.5 * (hip_flex - hip_flex.mean()) + 3.0
        upper = trunk @ _euler("ZX", swing, np.full(n, -sgn * 8.0))
        el = sh + _apply(upper, [0.0, -UPPER_ARM * S, 0.0])
        fore = upper @ _euler("Z", np.full(n, 20.0))
        pos[:, i_sh], pos[:, i_el], pos[:, i_wr] = sh, el, el + _apply(fore, [0.0, -FOREARM * S, 0])
    pos = pos @ _TO_WORLD.T  # world axes; the pelvis still at the origin

    # Progression: the stance foot stands still and the body moves over it. The stance foot
    # changes when it leaves the floor (its lowest sole point more than CONTACT_BAND above the
    # other's) or when the other foot, having left the floor, comes down (within a quarter of
    # that) moving backwards relative to the pelvis (a touch-down, not a swing foot grazing the
    # floor). The lowest foot alone is not always the stance foot: a stance foot on its toes, a
    # dropped swing foot.
    soles = {s: pos[:, list(ix)] for s, ix in sole.items()}  # (n, 2, 3) heel, toe
    low = {s: soles[s][:, :, 2].min(axis=1) for s in soles}
    band = CONTACT_BAND * S
    shift = np.zeros((n, 3))
    anchor = "r" if low["r"][0] <= low["l"][0] else "l"
    was_up = {"r": False, "l": False}

    def step(foot: str, k: int) -> np.ndarray:
        j = int(np.argmin(soles[foot][k, :, 2]))
        return soles[foot][k, j] - soles[foot][k - 1, j]

    for k in range(1, n):
        floor = min(low["r"][k], low["l"][k])
        other = "l" if anchor == "r" else "r"
        if low[other][k] > floor + band:
            was_up[other] = True
        lifted = low[anchor][k] > floor + band
        landed = was_up[other] and low[other][k] <= floor + 0.25 * band and step(other, k)[0] <= 0
        if lifted or landed:
            anchor, was_up[other], was_up[anchor] = other, False, False
        d = step(anchor, k)
        # never backwards: where an averaged cycle on a generic skeleton would drag the pelvis
        # back over the stance foot (crouch4's pre-swing), the stance foot slides instead
        shift[k, 0] = shift[k - 1, 0] + max(-d[0], 0.0)
        shift[k, 1] = shift[k - 1, 1] - d[1]
    pos[:, :, :2] += shift[:, None, :2]
    lowest = np.minimum(low["r"], low["l"])
    pos[:, :, 2] -= lowest[:, None]
    travel = shift[-1, :2]
    if np.linalg.norm(travel) < 0.1:
        raise MotionError(
            "angle walk: the feet do not carry the body forward (is it a gait cycle?)"
        )
    ang = -math.atan2(travel[1], travel[0])  # walk along +x from the origin
    c, s_ = math.cos(ang), math.sin(ang)
    Rz = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
    start = pos[0, SACRUM].copy()
    start[2] = 0.0
    pos = (pos - start) @ Rz.T

    events = []
    for side, name in (("r", "right"), ("l", "left")):
        foot_low = pos[:, list(sole[side]), 2].min(axis=1)
        on = _debounce(foot_low <= p.contact_m, max(2, round(0.05 * cycle_s * p.fps)))
        for k in np.flatnonzero(on[1:] != on[:-1]) + 1:
            kind = "heel_strike" if on[k] else "toe_off"
            events.append({"side": name, "type": kind, "time_s": float(times[k])})
    events.sort(key=lambda e: e["time_s"])
    return Trajectory(
        positions=pos,
        times=times,
        fps=p.fps,
        source=source or "joint-angle walk",
        events=events,
        stature_m=S,
    )


def load_angle_walk(path: str | Path, params: AngleWalkParams | None = None) -> Trajectory:
    """:func:`angle_walk` of an OpenSim ``.mot`` joint-angle file."""
    from gaitwatch.mocap.mot import read_mot_table

    path = Path(path)
    return angle_walk(read_mot_table(path), params, source=str(path))
