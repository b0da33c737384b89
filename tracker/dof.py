"""The 31 degrees of freedom of the body model, their order, units, signs and joint limits.

A pose is a float64 vector of 31 values in the order of :data:`DOF_NAMES`: the body origin
(the pelvis frame's origin near the lumbosacral joint, in metres, world frame; the sacrum key
point lies 0.029 H behind and 0.024 H above it; then heading, pitch and roll in radians), then
joint angles in radians. Batches of poses are ``(N, 31)`` arrays.

Frames and signs (the subject's own left and right; world z up):

* At zero pose the body stands upright, facing the world +x axis, its left towards +y.
* ``root_yaw`` (heading) turns the body about the world z axis, counter-clockwise seen from above;
  ``root_pitch`` leans the pelvis forward (positive) about the body's left-right axis;
  ``root_roll`` raises the pelvis's left side (positive) about the body's forward axis. The root
  rotation is ``Rz(yaw) @ Ry(pitch) @ Rx(roll)`` in the body frame (x forward, y left, z up).
* ``*_flexion`` is positive for flexion: thigh forward at the hip, heel towards the buttock at the
  knee (knee flexion >= 0), trunk and head bent forward, arm raised forward at the shoulder, hand
  towards the shoulder at the elbow, toes up (dorsiflexion) at the ankle.
* ``*_abduction`` and ``trunk_lateral`` are positive away from the midline (for the trunk: towards
  the subject's left); ``*_rotation`` is positive for internal rotation of a limb and for
  turning the trunk or head to the left.

Limits are data: :class:`JointLimits` holds ``[low, high]`` per DOF (degrees for angles, metres for
positions) and :data:`LIMIT_PROFILES` gives a profile per activity. Change them per activity with
``JointLimits.profile("walking").with_overrides({"l_knee_flexion": (0, 90)})``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Final

import numpy as np
from pydantic import BaseModel, ConfigDict, field_validator

DOF_NAMES: Final[tuple[str, ...]] = (
    # body origin
    "root_x",
    "root_y",
    "root_z",
    "root_yaw",
    "root_pitch",
    "root_roll",
    # trunk (lumbar/thoracic, about the sacrum) and head (about the neck)
    "trunk_flexion",
    "trunk_lateral",
    "trunk_rotation",
    "neck_flexion",
    "neck_rotation",
    # left arm
    "l_shoulder_flexion",
    "l_shoulder_abduction",
    "l_shoulder_rotation",
    "l_elbow_flexion",
    # right arm
    "r_shoulder_flexion",
    "r_shoulder_abduction",
    "r_shoulder_rotation",
    "r_elbow_flexion",
    # left leg
    "l_hip_flexion",
    "l_hip_abduction",
    "l_hip_rotation",
    "l_knee_flexion",
    "l_ankle_flexion",
    "l_ankle_rotation",
    # right leg
    "r_hip_flexion",
    "r_hip_abduction",
    "r_hip_rotation",
    "r_knee_flexion",
    "r_ankle_flexion",
    "r_ankle_rotation",
)
N_DOF: Final[int] = len(DOF_NAMES)
DOF: Final[dict[str, int]] = {n: i for i, n in enumerate(DOF_NAMES)}
assert N_DOF == 31

ROOT_POSITION: Final[tuple[int, int, int]] = (0, 1, 2)
ROOT_ROTATION: Final[tuple[int, int, int]] = (3, 4, 5)
ROOT_DOFS: Final[tuple[int, ...]] = ROOT_POSITION + ROOT_ROTATION
ANGLE_MASK: Final[np.ndarray] = np.array([i >= 3 for i in range(N_DOF)])
LEFT_LEG: Final[tuple[int, ...]] = tuple(range(19, 25))
RIGHT_LEG: Final[tuple[int, ...]] = tuple(range(25, 31))
UPPER_BODY: Final[tuple[int, ...]] = tuple(range(6, 19))

# The "interesting" DOFs of Interval Particle Filtering: both hips' and both knees' flexion.
INTERESTING_DEFAULT: Final[tuple[str, ...]] = (
    "l_hip_flexion",
    "r_hip_flexion",
    "l_knee_flexion",
    "r_knee_flexion",
)

# [low, high] per DOF: metres for root_x/y/z, degrees for the rest.
_GENERAL: dict[str, tuple[float, float]] = {
    "root_x": (-50.0, 50.0),
    "root_y": (-50.0, 50.0),
    "root_z": (0.05, 1.40),
    "root_yaw": (-180.0, 180.0),
    "root_pitch": (-30.0, 90.0),
    "root_roll": (-90.0, 90.0),
    "trunk_flexion": (-25.0, 80.0),
    "trunk_lateral": (-35.0, 35.0),
    "trunk_rotation": (-45.0, 45.0),
    "neck_flexion": (-45.0, 60.0),
    "neck_rotation": (-70.0, 70.0),
    "l_shoulder_flexion": (-60.0, 170.0),
    "l_shoulder_abduction": (-10.0, 150.0),
    "l_shoulder_rotation": (-60.0, 90.0),
    "l_elbow_flexion": (0.0, 150.0),
    "r_shoulder_flexion": (-60.0, 170.0),
    "r_shoulder_abduction": (-10.0, 150.0),
    "r_shoulder_rotation": (-60.0, 90.0),
    "r_elbow_flexion": (0.0, 150.0),
    "l_hip_flexion": (-30.0, 125.0),
    "l_hip_abduction": (-25.0, 45.0),
    "l_hip_rotation": (-40.0, 40.0),
    "l_knee_flexion": (0.0, 140.0),
    "l_ankle_flexion": (-45.0, 30.0),
    "l_ankle_rotation": (-30.0, 30.0),
    "r_hip_flexion": (-30.0, 125.0),
    "r_hip_abduction": (-25.0, 45.0),
    "r_hip_rotation": (-40.0, 40.0),
    "r_knee_flexion": (0.0, 140.0),
    "r_ankle_flexion": (-45.0, 30.0),
    "r_ankle_rotation": (-30.0, 30.0),
}

# Walking: the physiological ranges of gait (hip flexion -30..60 degrees, knee 0..80, ...).
_WALKING: dict[str, tuple[float, float]] = {
    **_GENERAL,
    "root_z": (0.50, 1.40),
    "root_pitch": (-20.0, 30.0),
    "root_roll": (-20.0, 20.0),
    "trunk_flexion": (-15.0, 30.0),
    "trunk_lateral": (-20.0, 20.0),
    "trunk_rotation": (-30.0, 30.0),
    "l_shoulder_flexion": (-60.0, 90.0),
    "r_shoulder_flexion": (-60.0, 90.0),
    "l_shoulder_abduction": (-10.0, 60.0),
    "r_shoulder_abduction": (-10.0, 60.0),
    "l_hip_flexion": (-30.0, 60.0),
    "r_hip_flexion": (-30.0, 60.0),
    "l_hip_abduction": (-15.0, 25.0),
    "r_hip_abduction": (-15.0, 25.0),
    "l_hip_rotation": (-30.0, 30.0),
    "r_hip_rotation": (-30.0, 30.0),
    "l_knee_flexion": (0.0, 80.0),
    "r_knee_flexion": (0.0, 80.0),
    "l_ankle_flexion": (-35.0, 25.0),
    "r_ankle_flexion": (-35.0, 25.0),
}

LIMIT_PROFILES: Final[dict[str, dict[str, tuple[float, float]]]] = {
    "general": _GENERAL,  # daily life: walking, sitting, rising, bending, lying
    "walking": _WALKING,
}

#: The DOFs a seated body needs beyond the walking ranges (a low pelvis tilted back, the trunk
#: leaning over flexed hips, knees and ankles): the tracker's seated mode widens them to the
#: general profile's ranges (``TrackerConfig.seated_limits``).
SEATED_DOFS: Final[tuple[str, ...]] = (
    "root_z",
    "root_pitch",
    "trunk_flexion",
    "l_hip_flexion",
    "r_hip_flexion",
    "l_knee_flexion",
    "r_knee_flexion",
    "l_ankle_flexion",
    "r_ankle_flexion",
)


class JointLimits(BaseModel):
    """``[low, high]`` per DOF, degrees for angles and metres for the root position."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    ranges: dict[str, tuple[float, float]]

    @field_validator("ranges")
    @classmethod
    def _complete_and_ordered(
        cls, v: dict[str, tuple[float, float]]
    ) -> dict[str, tuple[float, float]]:
        unknown = sorted(set(v) - set(DOF_NAMES))
        if unknown:
            raise ValueError(f"unknown DOF(s): {', '.join(unknown)}")
        missing = [n for n in DOF_NAMES if n not in v]
        if missing:
            raise ValueError(f"missing DOF(s): {', '.join(missing)}")
        for name, (lo, hi) in v.items():
            if not lo <= hi:
                raise ValueError(f"{name}: low {lo} is above high {hi}")
        return {n: (float(v[n][0]), float(v[n][1])) for n in DOF_NAMES}

    @classmethod
    def profile(cls, name: str = "walking") -> JointLimits:
        try:
            return cls(ranges=LIMIT_PROFILES[name])
        except KeyError:
            raise ValueError(
                f"unknown joint-limit profile {name!r}; known: {', '.join(LIMIT_PROFILES)}"
            ) from None

    def with_overrides(self, overrides: Mapping[str, tuple[float, float]]) -> JointLimits:
        return JointLimits(ranges={**self.ranges, **overrides})

    def widened(self, other: JointLimits, names: Sequence[str]) -> JointLimits:
        """These limits with the ``names`` DOFs' ranges stretched to cover ``other``'s too."""
        r = dict(self.ranges)
        for n in names:
            (a, b), (c, d) = r[n], other.ranges[n]
            r[n] = (min(a, c), max(b, d))
        return JointLimits(ranges=r)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` as (31,) arrays in internal units (metres, radians)."""
        lo = np.array([self.ranges[n][0] for n in DOF_NAMES], dtype=np.float64)
        hi = np.array([self.ranges[n][1] for n in DOF_NAMES], dtype=np.float64)
        lo[ANGLE_MASK] = np.radians(lo[ANGLE_MASK])
        hi[ANGLE_MASK] = np.radians(hi[ANGLE_MASK])
        return lo, hi


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def clamp(poses: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Clamp a batch of poses (N, 31) to the limits in place and return it.

    The heading (``root_yaw``) is wrapped to [-pi, pi) rather than clamped when its range is the
    full circle.
    """
    yaw = DOF["root_yaw"]
    if high[yaw] - low[yaw] >= 2 * np.pi - 1e-9:
        poses[..., yaw] = wrap_angle(poses[..., yaw])
    np.clip(poses, low, high, out=poses)
    return poses
