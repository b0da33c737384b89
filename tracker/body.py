"""The articulated body model: anthropometry, forward kinematics and the fleshed-out volumes.

Skeleton
    19 key points (``gaitwatch.conventions.KEYPOINTS``) on 17 rigid segments: pelvis, trunk,
    head, and per side clavicle, upper arm, forearm, hand, thigh, shank, foot. They hang on 13
    moving frames (pelvis = body origin near the lumbosacral joint, trunk, head, and per side
    upper arm, forearm, thigh, shank, foot); clavicles move with the trunk and hands with the
    forearms. The sacrum and neck key points are landmarks near, not at, the pelvis's and the
    head's pivots (docs/body-model.md). The four kinematic chains (two arms from the trunk, two
    legs from the pelvis) and the trunk and head are driven by the 31 DOF of :mod:`tracker.dof`
    (order, units and signs are defined there; the table is in ``docs/body-model.md``).

Anthropometry
    Segment lengths are fractions of the standing height ``H`` from the table of Drillis &
    Contini (1966) as reproduced in D. A. Winter, *Biomechanics and Motor Control of Human
    Movement*, 4th ed., Wiley 2009, Fig. 4.1: greater trochanter (hip joint centre) 0.530 H,
    knee 0.285 H, ankle 0.039 H, shoulder 0.818 H, elbow 0.630 H, wrist 0.485 H, hand 0.108 H,
    foot length 0.152 H, shoulder width 0.259 H, hip width 0.191 H, chest width 0.174 H. Where
    the table has no entry (sacrum and C7 offsets, hip-joint-centre separation, volume radii) the
    values are typical adult proportions, documented next to each constant.

Volumes
    Each segment carries one or more tapered capsules (cone-spheres: the convex hull of two
    spheres of radii ``r_a`` and ``r_b``). The trunk is three overlapping capsules (left, right,
    spine) so that its silhouette is wide. Radii scale with the height, with ``girth`` and with
    a factor per body part (``part_girths``: trunk, head, arms, thighs, shanks, feet), which the
    tracker estimates from the silhouettes (clothes and builds differ most on the limbs).

Kinematics
    ``BodyModel.forward`` is a numba kernel (``parallel=True``) over the batch of poses; the only
    loop in it per pose is over the 13 frames and the model points.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Final, Literal

import numba as nb
import numpy as np

from gaitwatch.conventions import KEYPOINTS, N_KEYPOINTS
from tracker.dof import DOF, N_DOF

# -- anthropometry (fractions of the standing height H) --------------------------------------
# Winter (2009), Fig. 4.1, after Drillis & Contini (1966):
HIP_HEIGHT: Final = 0.530  # greater trochanter ~ hip joint centre
KNEE_HEIGHT: Final = 0.285
ANKLE_HEIGHT: Final = 0.039
SHOULDER_HEIGHT: Final = 0.818
ELBOW_HEIGHT: Final = 0.630
WRIST_HEIGHT: Final = 0.485
HAND_LENGTH: Final = 0.108
FOOT_LENGTH: Final = 0.152
SHOULDER_WIDTH: Final = 0.259  # biacromial
HIP_WIDTH: Final = 0.191  # bitrochanteric: outer width of the hips (used for the pelvis volume)
CHEST_WIDTH: Final = 0.174
HEAD_CENTRE_HEIGHT: Final = 0.936  # eye level, taken as the centre of the head
# Not in the table (typical adult values, see docs/body-model.md):
# Hip joint centres are ~36 % of the ASIS width (~0.145 H) either side of the midline
# (Bell, Pedersen & Brand 1990): separation 0.72 * 0.145 H ~ 0.105 H (0.18 m at 1.70 m).
HIP_JOINT_SEPARATION: Final = 0.105
# The pelvis frame's origin (the body's root and the trunk's pivot, near the lumbosacral joint)
# lies above and behind the hip joint centres; the body's volumes are built around it.
SACRUM_ABOVE_HIP: Final = 0.045
SACRUM_BEHIND_HIP: Final = 0.055
# The sacrum key point of CONVENTIONS (mid-point of the posterior iliac spines, on the skin)
# lies further back and higher: 0.062-0.103 H behind and 0.045-0.089 H above the hip centres in
# the shared recordings (mean over the four sources 0.084 and 0.069 H), so 0.029 H behind and
# 0.024 H above the pelvis frame's origin (docs/body-model.md).
SACRUM_KEYPOINT_BEHIND_ROOT: Final = 0.029
SACRUM_KEYPOINT_ABOVE_ROOT: Final = 0.024
# The head's pivot (the cervical joint, at the C7 spinous process) lies above the acromion
# level and behind the shoulder joint centres.
NECK_ABOVE_SHOULDER: Final = 0.025
SHOULDER_FORWARD_OF_NECK: Final = 0.035
# The neck key point of CONVENTIONS (the base of the neck at C7 level) lies further forward: in
# the shared recordings 0.017 H behind to 0.014 H ahead of the shoulder joint centres' mid-point
# (C7 or the mid-acromion markers, or the skeleton's C7-level joint), so 0.030 H ahead of the
# head's pivot, 0.005 H behind the shoulder centres (docs/body-model.md).
NECK_KEYPOINT_FORWARD_OF_PIVOT: Final = 0.030
# Glenohumeral joint centres lie medial of the acromion tips (0.1295 H): 0.110 H from the midline.
SHOULDER_JOINT_HALF_WIDTH: Final = 0.110
HEAD_FORWARD_OF_NECK: Final = 0.040
HEEL_BEHIND_ANKLE: Final = 0.030  # back of the heel behind the ankle centre
TOE_AHEAD_OF_ANKLE: Final = 0.080  # head of the 2nd metatarsal ahead of the ankle centre

#: Range of ``BodyModel(leg_length=...)``: hip-to-ankle length relative to the table's at the
#: same standing height (adults differ by about +-8 %; the shared recordings span 0.90-1.09).
LEG_LENGTH_RANGE: Final = (0.8, 1.2)


def vertical_scales(leg_length: float) -> dict[str, float]:
    """Vertical (frame z) scale per frame name for a relative leg length.

    Thighs and shanks are ``leg_length`` times the table's; the pelvis, trunk and head frames
    are scaled so that the standing height stays the same (the ankle height, the feet and the
    arms are kept).
    """
    upper = (1.0 - ANKLE_HEIGHT - (HIP_HEIGHT - ANKLE_HEIGHT) * leg_length) / (1.0 - HIP_HEIGHT)
    scales = dict.fromkeys(("left_thigh", "left_shank", "right_thigh", "right_shank"), leg_length)
    scales.update(dict.fromkeys(("pelvis", "trunk", "head"), upper))
    return scales


# -- frames ---------------------------------------------------------------------------------
FRAME_NAMES: Final[tuple[str, ...]] = (
    "pelvis",
    "trunk",
    "head",
    "left_upper_arm",
    "left_forearm",
    "right_upper_arm",
    "right_forearm",
    "left_thigh",
    "left_shank",
    "left_foot",
    "right_thigh",
    "right_shank",
    "right_foot",
)
_F = {n: i for i, n in enumerate(FRAME_NAMES)}
_X, _Y, _Z = 0, 1, 2

# Per frame: parent, then up to three elementary rotations (axis, DOF name, sign) applied in
# this order (intrinsic: R_frame = R_parent @ R1 @ R2 @ R3). Signs map tracker.dof's anatomical
# signs onto right-handed rotations about the body axes (x forward, y left, z up). A limb that
# hangs down flexes forward with a negative rotation about y; internal rotation of a left limb
# is a negative rotation about z, of a right limb a positive one.
_JOINTS: Final[tuple[tuple[str, str | None, tuple[tuple[int, str, float], ...]], ...]] = (
    ("pelvis", None, ((_Z, "root_yaw", 1.0), (_Y, "root_pitch", 1.0), (_X, "root_roll", 1.0))),
    (
        "trunk",
        "pelvis",
        ((_Y, "trunk_flexion", 1.0), (_X, "trunk_lateral", -1.0), (_Z, "trunk_rotation", 1.0)),
    ),
    ("head", "trunk", ((_Y, "neck_flexion", 1.0), (_Z, "neck_rotation", 1.0))),
    (
        "left_upper_arm",
        "trunk",
        (
            (_Y, "l_shoulder_flexion", -1.0),
            (_X, "l_shoulder_abduction", 1.0),
            (_Z, "l_shoulder_rotation", -1.0),
        ),
    ),
    ("left_forearm", "left_upper_arm", ((_Y, "l_elbow_flexion", -1.0),)),
    (
        "right_upper_arm",
        "trunk",
        (
            (_Y, "r_shoulder_flexion", -1.0),
            (_X, "r_shoulder_abduction", -1.0),
            (_Z, "r_shoulder_rotation", 1.0),
        ),
    ),
    ("right_forearm", "right_upper_arm", ((_Y, "r_elbow_flexion", -1.0),)),
    (
        "left_thigh",
        "pelvis",
        ((_Y, "l_hip_flexion", -1.0), (_X, "l_hip_abduction", 1.0), (_Z, "l_hip_rotation", -1.0)),
    ),
    ("left_shank", "left_thigh", ((_Y, "l_knee_flexion", 1.0),)),
    ("left_foot", "left_shank", ((_Z, "l_ankle_rotation", -1.0), (_Y, "l_ankle_flexion", -1.0))),
    (
        "right_thigh",
        "pelvis",
        ((_Y, "r_hip_flexion", -1.0), (_X, "r_hip_abduction", -1.0), (_Z, "r_hip_rotation", 1.0)),
    ),
    ("right_shank", "right_thigh", ((_Y, "r_knee_flexion", 1.0),)),
    (
        "right_foot",
        "right_shank",
        ((_Z, "r_ankle_rotation", 1.0), (_Y, "r_ankle_flexion", -1.0)),
    ),
)

SEGMENT_NAMES: Final[tuple[str, ...]] = (
    "pelvis",
    "trunk",
    "head",
    "left_clavicle",
    "right_clavicle",
    "left_upper_arm",
    "right_upper_arm",
    "left_forearm",
    "right_forearm",
    "left_hand",
    "right_hand",
    "left_thigh",
    "right_thigh",
    "left_shank",
    "right_shank",
    "left_foot",
    "right_foot",
)
# The frame each segment moves with.
SEGMENT_FRAME: Final[dict[str, str]] = {
    "pelvis": "pelvis",
    "trunk": "trunk",
    "head": "head",
    "left_clavicle": "trunk",
    "right_clavicle": "trunk",
    "left_upper_arm": "left_upper_arm",
    "right_upper_arm": "right_upper_arm",
    "left_forearm": "left_forearm",
    "right_forearm": "right_forearm",
    "left_hand": "left_forearm",
    "right_hand": "right_forearm",
    "left_thigh": "left_thigh",
    "right_thigh": "right_thigh",
    "left_shank": "left_shank",
    "right_shank": "right_shank",
    "left_foot": "left_foot",
    "right_foot": "right_foot",
}


@dataclass(frozen=True)
class Capsule:
    """A tapered capsule: the convex hull of two spheres, fixed in one frame.

    ``a`` and ``b`` are the sphere centres in the frame (metres), ``ra`` and ``rb`` their radii
    before the girth factor, all as fractions of the height.
    """

    name: str
    segment: str
    a: tuple[float, float, float]
    b: tuple[float, float, float]
    ra: float
    rb: float


def _capsule_table() -> tuple[Capsule, ...]:
    """The volumes, in fractions of H (frame coordinates: x forward, y left, z up at zero)."""
    ua = SHOULDER_HEIGHT - ELBOW_HEIGHT
    fa = ELBOW_HEIGHT - WRIST_HEIGHT
    th = HIP_HEIGHT - KNEE_HEIGHT
    sh = KNEE_HEIGHT - ANKLE_HEIGHT
    hip_y = HIP_JOINT_SEPARATION / 2
    hx = SACRUM_BEHIND_HIP
    hz = -SACRUM_ABOVE_HIP
    neck_z = SHOULDER_HEIGHT + NECK_ABOVE_SHOULDER - (HIP_HEIGHT + SACRUM_ABOVE_HIP)
    shoulder_z = neck_z - NECK_ABOVE_SHOULDER
    caps = [
        # pelvis: one wide capsule across the hips; outer width ~ HIP_WIDTH, back at the sacrum
        Capsule(
            "pelvis",
            "pelvis",
            (0.050, 0.040, hz + 0.005),
            (0.050, -0.040, hz + 0.005),
            0.055,
            0.055,
        ),
        # trunk (frame origin at the sacrum): left and right flanks plus the spine/belly, so the
        # chest is ~CHEST_WIDTH wide and ~0.12 H deep
        Capsule("trunk_left", "trunk", (0.060, 0.030, 0.020), (0.055, 0.036, 0.200), 0.052, 0.056),
        Capsule(
            "trunk_right", "trunk", (0.060, -0.030, 0.020), (0.055, -0.036, 0.200), 0.052, 0.056
        ),
        Capsule("trunk_spine", "trunk", (0.050, 0.0, 0.030), (0.045, 0.0, 0.215), 0.055, 0.050),
        # neck (C7 to below the head centre) and head (chin ~0.870 H to crown ~1.000 H)
        Capsule("neck", "head", (0.012, 0.0, 0.000), (0.030, 0.0, 0.055), 0.030, 0.028),
        Capsule(
            "head",
            "head",
            (HEAD_FORWARD_OF_NECK, 0.0, 0.066),
            (HEAD_FORWARD_OF_NECK - 0.004, 0.0, 0.114),
            0.046,
            0.047,
        ),
        # clavicles / shoulder girdle with the deltoids
        Capsule(
            "left_clavicle",
            "left_clavicle",
            (SHOULDER_FORWARD_OF_NECK * 0.5, 0.03, neck_z),
            (SHOULDER_FORWARD_OF_NECK, SHOULDER_JOINT_HALF_WIDTH, shoulder_z),
            0.035,
            0.030,
        ),
        Capsule(
            "right_clavicle",
            "right_clavicle",
            (SHOULDER_FORWARD_OF_NECK * 0.5, -0.03, neck_z),
            (SHOULDER_FORWARD_OF_NECK, -SHOULDER_JOINT_HALF_WIDTH, shoulder_z),
            0.035,
            0.030,
        ),
        # arms
        Capsule("left_upper_arm", "left_upper_arm", (0, 0, 0), (0, 0, -ua), 0.028, 0.022),
        Capsule("right_upper_arm", "right_upper_arm", (0, 0, 0), (0, 0, -ua), 0.028, 0.022),
        Capsule("left_forearm", "left_forearm", (0, 0, 0), (0, 0, -fa), 0.021, 0.016),
        Capsule("right_forearm", "right_forearm", (0, 0, 0), (0, 0, -fa), 0.021, 0.016),
        Capsule(
            "left_hand", "left_hand", (0, 0, -fa), (0, 0, -fa - 0.6 * HAND_LENGTH), 0.016, 0.013
        ),
        Capsule(
            "right_hand", "right_hand", (0, 0, -fa), (0, 0, -fa - 0.6 * HAND_LENGTH), 0.016, 0.013
        ),
        # legs
        Capsule("left_thigh", "left_thigh", (0, 0, 0), (0, 0, -th), 0.046, 0.031),
        Capsule("right_thigh", "right_thigh", (0, 0, 0), (0, 0, -th), 0.046, 0.031),
        Capsule("left_shank", "left_shank", (0, 0, 0), (0, 0, -sh), 0.032, 0.020),
        Capsule("right_shank", "right_shank", (0, 0, 0), (0, 0, -sh), 0.032, 0.020),
        # feet: resting on the sole (z = -ANKLE_HEIGHT in the foot frame) from heel to toes
        Capsule(
            "left_foot",
            "left_foot",
            (-HEEL_BEHIND_ANKLE + 0.018, 0.0, -ANKLE_HEIGHT + 0.018),
            (FOOT_LENGTH - HEEL_BEHIND_ANKLE - 0.013, 0.0, -ANKLE_HEIGHT + 0.013),
            0.018,
            0.013,
        ),
        Capsule(
            "right_foot",
            "right_foot",
            (-HEEL_BEHIND_ANKLE + 0.018, 0.0, -ANKLE_HEIGHT + 0.018),
            (FOOT_LENGTH - HEEL_BEHIND_ANKLE - 0.013, 0.0, -ANKLE_HEIGHT + 0.013),
            0.018,
            0.013,
        ),
    ]
    del hip_y, hx
    return tuple(caps)


CAPSULES: Final[tuple[Capsule, ...]] = _capsule_table()

#: Body parts of ``BodyModel(part_girths=...)``: the segments whose capsules each factor scales.
GIRTH_PARTS: Final[dict[str, tuple[str, ...]]] = {
    "trunk": ("pelvis", "trunk", "left_clavicle", "right_clavicle"),
    "head": ("head",),
    "arms": (
        "left_upper_arm",
        "right_upper_arm",
        "left_forearm",
        "right_forearm",
        "left_hand",
        "right_hand",
    ),
    "thighs": ("left_thigh", "right_thigh"),
    "shanks": ("left_shank", "right_shank"),
    "feet": ("left_foot", "right_foot"),
}
CAPSULE_NAMES: Final[tuple[str, ...]] = tuple(c.name for c in CAPSULES)
N_CAPSULES: Final[int] = len(CAPSULES)
#: Hem volumes (``BodyModel(hem=...)``), one per thigh after :data:`CAPSULES`.
HEM_CAPSULE_NAMES: Final[tuple[str, ...]] = ("left_hem", "right_hem")
#: Allowed hem lengths (fraction of the thigh) and hem radii (fraction of the height).
HEM_LENGTH_RANGE: Final[tuple[float, float]] = (0.2, 1.5)
HEM_RADIUS_RANGE: Final[tuple[float, float]] = (0.02, 0.2)


def hem_capsules(length: float, radius: float) -> tuple[Capsule, ...]:
    """The hem of a skirt, dress or coat as one flared volume per thigh.

    From the hip joint (the thigh's own radius) down the thigh to ``length`` times its length,
    where the radius is ``radius`` (fractions of the height, before the girth). The union of
    the two spans the knees' spread plus a margin, like a hem that follows the legs; each
    moves with its thigh, so the legs' factorisation of the likelihood stays exact.
    """
    th = (HIP_HEIGHT - KNEE_HEIGHT) * length
    thigh = next(c for c in CAPSULES if c.name == "left_thigh")
    return tuple(
        Capsule(f"{side}_hem", f"{side}_thigh", (0, 0, 0), (0, 0, -th), thigh.ra, radius)
        for side in ("left", "right")
    )


def _keypoint_table() -> dict[str, tuple[str, tuple[float, float, float]]]:
    """Key point -> (frame, local position as fractions of H)."""
    ua = SHOULDER_HEIGHT - ELBOW_HEIGHT
    fa = ELBOW_HEIGHT - WRIST_HEIGHT
    th = HIP_HEIGHT - KNEE_HEIGHT
    sh = KNEE_HEIGHT - ANKLE_HEIGHT
    hip_y = HIP_JOINT_SEPARATION / 2
    neck_z = SHOULDER_HEIGHT + NECK_ABOVE_SHOULDER - (HIP_HEIGHT + SACRUM_ABOVE_HIP)
    shoulder_z = neck_z - NECK_ABOVE_SHOULDER
    head_z = HEAD_CENTRE_HEIGHT - (SHOULDER_HEIGHT + NECK_ABOVE_SHOULDER)
    sh_x = SHOULDER_FORWARD_OF_NECK
    table = {
        "head": ("head", (HEAD_FORWARD_OF_NECK, 0.0, head_z)),
        "neck": ("trunk", (NECK_KEYPOINT_FORWARD_OF_PIVOT, 0.0, neck_z)),
        "sacrum": ("pelvis", (-SACRUM_KEYPOINT_BEHIND_ROOT, 0.0, SACRUM_KEYPOINT_ABOVE_ROOT)),
        "left_shoulder": ("trunk", (sh_x, SHOULDER_JOINT_HALF_WIDTH, shoulder_z)),
        "right_shoulder": ("trunk", (sh_x, -SHOULDER_JOINT_HALF_WIDTH, shoulder_z)),
        "left_elbow": ("left_upper_arm", (0.0, 0.0, -ua)),
        "right_elbow": ("right_upper_arm", (0.0, 0.0, -ua)),
        "left_wrist": ("left_forearm", (0.0, 0.0, -fa)),
        "right_wrist": ("right_forearm", (0.0, 0.0, -fa)),
        "left_hip": ("pelvis", (SACRUM_BEHIND_HIP, hip_y, -SACRUM_ABOVE_HIP)),
        "right_hip": ("pelvis", (SACRUM_BEHIND_HIP, -hip_y, -SACRUM_ABOVE_HIP)),
        "left_knee": ("left_thigh", (0.0, 0.0, -th)),
        "right_knee": ("right_thigh", (0.0, 0.0, -th)),
        "left_ankle": ("left_shank", (0.0, 0.0, -sh)),
        "right_ankle": ("right_shank", (0.0, 0.0, -sh)),
        "left_heel": ("left_foot", (-HEEL_BEHIND_ANKLE, 0.0, -ANKLE_HEIGHT)),
        "right_heel": ("right_foot", (-HEEL_BEHIND_ANKLE, 0.0, -ANKLE_HEIGHT)),
        "left_toe": ("left_foot", (TOE_AHEAD_OF_ANKLE, 0.0, -ANKLE_HEIGHT)),
        "right_toe": ("right_foot", (TOE_AHEAD_OF_ANKLE, 0.0, -ANKLE_HEIGHT)),
    }
    assert tuple(table) == KEYPOINTS
    return table


_KEYPOINT_TABLE: Final = _keypoint_table()
#: Where each joint sits (frame, local position as fractions of H): the key points, and the
#: trunk's pivot (the pelvis frame's origin) and the head's (at C7), which are not key points.
_JOINT_POINTS: Final = {
    **_KEYPOINT_TABLE,
    "lumbosacral": ("pelvis", (0.0, 0.0, 0.0)),
    "cervical": (
        "trunk",
        (0.0, 0.0, SHOULDER_HEIGHT + NECK_ABOVE_SHOULDER - (HIP_HEIGHT + SACRUM_ABOVE_HIP)),
    ),
}

# Frame origins in their parent frame (fractions of H): where each joint sits.
_FRAME_OFFSET: Final[dict[str, tuple[str, tuple[float, float, float]]]] = {
    "pelvis": ("", (0.0, 0.0, 0.0)),
    "trunk": ("lumbosacral", (0.0, 0.0, 0.0)),
    "head": ("cervical", (0.0, 0.0, 0.0)),
    "left_upper_arm": ("left_shoulder", (0.0, 0.0, 0.0)),
    "left_forearm": ("left_elbow", (0.0, 0.0, 0.0)),
    "right_upper_arm": ("right_shoulder", (0.0, 0.0, 0.0)),
    "right_forearm": ("right_elbow", (0.0, 0.0, 0.0)),
    "left_thigh": ("left_hip", (0.0, 0.0, 0.0)),
    "left_shank": ("left_knee", (0.0, 0.0, 0.0)),
    "left_foot": ("left_ankle", (0.0, 0.0, 0.0)),
    "right_thigh": ("right_hip", (0.0, 0.0, 0.0)),
    "right_shank": ("right_knee", (0.0, 0.0, 0.0)),
    "right_foot": ("right_ankle", (0.0, 0.0, 0.0)),
}

# Capsule groups for the factored likelihood: volumes moved only by the root and one leg's DOFs.
LEFT_LEG_SEGMENTS: Final[tuple[str, ...]] = ("left_thigh", "left_shank", "left_foot")
RIGHT_LEG_SEGMENTS: Final[tuple[str, ...]] = ("right_thigh", "right_shank", "right_foot")
#: Volumes moved by one arm's DOFs (shoulder flexion, abduction, rotation, elbow flexion).
ARM_SEGMENTS: Final[dict[str, tuple[str, ...]]] = {
    "l": ("left_upper_arm", "left_forearm", "left_hand"),
    "r": ("right_upper_arm", "right_forearm", "right_hand"),
}


# -- the numba kernel -------------------------------------------------------------------------
# The kernels index the arrays they are given instead of taking views of them: in numba every
# view costs an atomic reference-count update, which threads working on the same arrays would
# fight over.
# sin and cos together, polynomials of fdlibm's __kernel_sin / __kernel_cos (minimax on
# [-pi/4, pi/4], error < 1 ulp) after a Cody-Waite reduction by pi/2: about 3x faster than two
# libm calls, which dominate the forward kinematics.
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_HI = 1.57079632673412561417e00  # first 33 bits of pi/2
_PIO2_LO = 6.07710050650619224932e-11  # pi/2 - _PIO2_HI


@nb.njit(cache=True, inline="always")
def sincos(x: float) -> tuple[float, float]:
    """(sin x, cos x) to about 1 ulp; falls back to libm for |x| > 1e5 and non-finite x."""
    if not abs(x) <= 1e5:
        return np.sin(x), np.cos(x)
    q = np.floor(x * _INV_PIO2 + 0.5)
    r = (x - q * _PIO2_HI) - q * _PIO2_LO
    z = r * r
    sr = r + r * z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    cr = 1.0 - 0.5 * z + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    quadrant = int(q) & 3
    if quadrant == 0:
        return sr, cr
    if quadrant == 1:
        return cr, -sr
    if quadrant == 2:
        return -sr, -cr
    return -cr, sr


@nb.njit(cache=True, inline="always")
def _rot_apply(rots: np.ndarray, f: int, axis: int, angle: float) -> None:
    """rots[f] <- rots[f] @ Rot_axis(angle), in place."""
    s, c = sincos(angle)
    if axis == 0:  # columns 1, 2
        for i in range(3):
            r1 = rots[f, i, 1]
            r2 = rots[f, i, 2]
            rots[f, i, 1] = r1 * c + r2 * s
            rots[f, i, 2] = -r1 * s + r2 * c
    elif axis == 1:  # columns 0, 2
        for i in range(3):
            r0 = rots[f, i, 0]
            r2 = rots[f, i, 2]
            rots[f, i, 0] = r0 * c - r2 * s
            rots[f, i, 2] = r0 * s + r2 * c
    else:  # columns 0, 1
        for i in range(3):
            r0 = rots[f, i, 0]
            r1 = rots[f, i, 1]
            rots[f, i, 0] = r0 * c + r1 * s
            rots[f, i, 1] = -r0 * s + r1 * c


@nb.njit(cache=True, nogil=True)
def _fk_range(
    lo: int,
    hi: int,
    poses: np.ndarray,
    parent: np.ndarray,
    offset: np.ndarray,
    rot_axis: np.ndarray,
    rot_dof: np.ndarray,
    rot_sign: np.ndarray,
    pt_frame: np.ndarray,
    pt_local: np.ndarray,
    frame_on: np.ndarray,
    pt_on: np.ndarray,
    out: np.ndarray,
) -> None:
    """Forward kinematics of poses lo..hi-1 (N, 31) into ``out`` (N, P, 3).

    Only frames with ``frame_on`` and points with ``pt_on`` are computed (the other points are
    NaN); a point's frame and its ancestors must be on.
    """
    nf = parent.shape[0]
    rots = np.empty((nf, 3, 3))
    origins = np.empty((nf, 3))
    for n in range(lo, hi):
        for f in range(nf):
            if not frame_on[f]:
                continue
            p = parent[f]
            if p < 0:
                for i in range(3):
                    origins[f, i] = poses[n, i]
                    for j in range(3):
                        rots[f, i, j] = 1.0 if i == j else 0.0
            else:
                for i in range(3):
                    origins[f, i] = (
                        origins[p, i]
                        + rots[p, i, 0] * offset[f, 0]
                        + rots[p, i, 1] * offset[f, 1]
                        + rots[p, i, 2] * offset[f, 2]
                    )
                    for j in range(3):
                        rots[f, i, j] = rots[p, i, j]
            for k in range(rot_axis.shape[1]):
                ax = rot_axis[f, k]
                if ax >= 0:
                    _rot_apply(rots, f, ax, rot_sign[f, k] * poses[n, rot_dof[f, k]])
        for q in range(pt_frame.shape[0]):
            if not pt_on[q]:
                for i in range(3):
                    out[n, q, i] = np.nan
                continue
            f = pt_frame[q]
            for i in range(3):
                out[n, q, i] = (
                    origins[f, i]
                    + rots[f, i, 0] * pt_local[q, 0]
                    + rots[f, i, 1] * pt_local[q, 1]
                    + rots[f, i, 2] * pt_local[q, 2]
                )


@nb.njit(cache=True, parallel=True, nogil=True)
def _fk_batch(
    poses: np.ndarray,
    parent: np.ndarray,
    offset: np.ndarray,
    rot_axis: np.ndarray,
    rot_dof: np.ndarray,
    rot_sign: np.ndarray,
    pt_frame: np.ndarray,
    pt_local: np.ndarray,
    frame_on: np.ndarray,
    pt_on: np.ndarray,
    nchunks: int,
) -> np.ndarray:
    """Forward kinematics of poses (N, 31) -> model points (N, P, 3), parallel over poses.

    ``nchunks`` work units share the batch (numba.get_num_threads() in here would stop the
    cache from working, so the caller passes a multiple of it).
    """
    n = poses.shape[0]
    out = np.empty((n, pt_frame.shape[0], 3))
    nchunks = max(1, min(n, nchunks))
    for c in nb.prange(nchunks):
        _fk_range(
            c * n // nchunks,
            (c + 1) * n // nchunks,
            poses,
            parent,
            offset,
            rot_axis,
            rot_dof,
            rot_sign,
            pt_frame,
            pt_local,
            frame_on,
            pt_on,
            out,
        )
    return out


class BodyModel:
    """A person of a given height: 19 key points on 17 segments, 31 DOF, fleshed with capsules.

    Parameters
    ----------
    height_m : float
        Standing height in metres (0.5 to 2.5).
    girth : float
        Factor on every volume radius (1.0 = average build; 1.2 for a heavier build).
    part_girths : mapping of str to float, optional
        Further factor on the radii of a body part (:data:`GIRTH_PARTS`: ``"trunk"``,
        ``"head"``, ``"arms"``, ``"thighs"``, ``"shanks"``, ``"feet"``), 0.5 to 3.0; parts not
        named keep 1.0.

    Attributes
    ----------
    segment_lengths : dict[str, float]
        Bone lengths in metres (``"thigh"``, ``"shank"``, ``"upper_arm"``, ...).
    root_height : float
        Height of the body origin (``root_z``, the pelvis frame's origin: not the sacrum key
        point, which lies higher) when standing upright with the feet flat, metres.
    radii : np.ndarray
        ``(C, 2)`` capsule radii in metres (end a, end b), girth applied.
    """

    def __init__(
        self,
        height_m: float = 1.70,
        girth: float = 1.0,
        part_girths: Mapping[str, float] | None = None,
        leg_length: float = 1.0,
        hem: tuple[float, float] | None = None,
    ) -> None:
        if not np.isfinite(height_m) or not 0.5 <= height_m <= 2.5:
            raise ValueError(f"height_m must be between 0.5 and 2.5 metres, not {height_m}")
        if (
            not np.isfinite(leg_length)
            or not LEG_LENGTH_RANGE[0] <= leg_length <= LEG_LENGTH_RANGE[1]
        ):
            raise ValueError(
                f"leg_length must be between {LEG_LENGTH_RANGE[0]} and {LEG_LENGTH_RANGE[1]}, "
                f"not {leg_length}"
            )
        if not np.isfinite(girth) or not 0.5 <= girth <= 2.0:
            raise ValueError(f"girth must be between 0.5 and 2.0, not {girth}")
        parts = dict(part_girths or {})
        for name, f in parts.items():
            if name not in GIRTH_PARTS:
                raise ValueError(
                    f"unknown body part {name!r} in part_girths (one of {', '.join(GIRTH_PARTS)})"
                )
            if not np.isfinite(f) or not 0.5 <= f <= 3.0:
                raise ValueError(f"part_girths[{name!r}] must be between 0.5 and 3.0, not {f}")
        if hem is not None:
            hl, hr = (float(v) for v in hem)
            if not (
                HEM_LENGTH_RANGE[0] <= hl <= HEM_LENGTH_RANGE[1]
                and HEM_RADIUS_RANGE[0] <= hr <= HEM_RADIUS_RANGE[1]
            ):
                raise ValueError(
                    f"hem must be (length {HEM_LENGTH_RANGE[0]}-{HEM_LENGTH_RANGE[1]} thighs, "
                    f"radius {HEM_RADIUS_RANGE[0]}-{HEM_RADIUS_RANGE[1]} heights), not {hem}"
                )
            hem = (hl, hr)
        #: Hem of a skirt or coat (length in thighs, radius in heights), or None.
        self.hem: tuple[float, float] | None = hem
        caps = CAPSULES + (hem_capsules(*hem) if hem is not None else ())
        self.height_m = float(height_m)
        self.girth = float(girth)
        self.leg_length = float(leg_length)
        # Vertical scale of each frame's local coordinates: thighs and shanks by leg_length, the
        # pelvis, trunk and head by what keeps the standing height (arms and feet as they are).
        zs = vertical_scales(self.leg_length)
        fscale = np.array([zs.get(n, 1.0) for n in FRAME_NAMES])
        #: Factor per body part (every part of GIRTH_PARTS, 1.0 when not given).
        self.part_girths: dict[str, float] = {n: float(parts.get(n, 1.0)) for n in GIRTH_PARTS}
        H = self.height_m
        kp = _KEYPOINT_TABLE

        nf = len(FRAME_NAMES)
        self._parent = np.full(nf, -1, dtype=np.int64)
        self._offset = np.zeros((nf, 3))
        self._rot_axis = np.full((nf, 3), -1, dtype=np.int64)
        self._rot_dof = np.zeros((nf, 3), dtype=np.int64)
        self._rot_sign = np.zeros((nf, 3))
        for f, (name, parent, rots) in enumerate(_JOINTS):
            assert FRAME_NAMES[f] == name
            if parent is not None:
                self._parent[f] = _F[parent]
                joint_kp = _FRAME_OFFSET[name][0]
                kframe, local = _JOINT_POINTS[joint_kp]
                # a joint point lives in the parent frame (or at the parent's origin)
                if kframe != parent:
                    raise AssertionError(f"{name}: joint {joint_kp} not in parent {parent}")
                self._offset[f] = np.asarray(local) * H
                self._offset[f, 2] *= fscale[_F[parent]]
            for k, (ax, dof, sign) in enumerate(rots):
                self._rot_axis[f, k] = ax
                self._rot_dof[f, k] = DOF[dof]
                self._rot_sign[f, k] = sign

        # model points: 19 key points, then both ends of every capsule
        frames, local = [], []
        for name in KEYPOINTS:
            fr, loc = kp[name]
            frames.append(_F[fr])
            local.append(loc)
        cap_a, cap_b = [], []
        for cap in caps:
            fr = _F[SEGMENT_FRAME[cap.segment]]
            cap_a.append(len(frames))
            frames.append(fr)
            local.append(cap.a)
            cap_b.append(len(frames))
            frames.append(fr)
            local.append(cap.b)
        self._pt_frame = np.asarray(frames, dtype=np.int64)
        self._pt_local = np.asarray(local, dtype=np.float64) * H
        self._pt_local[:, 2] *= fscale[self._pt_frame]
        self.cap_a = np.asarray(cap_a, dtype=np.int64)
        self.cap_b = np.asarray(cap_b, dtype=np.int64)
        part_of = {seg: n for n, segs in GIRTH_PARTS.items() for seg in segs}
        factor = np.array([self.part_girths[part_of[c.segment]] for c in caps])
        self.radii = np.array([[c.ra, c.rb] for c in caps]) * H * self.girth * factor[:, None]
        if hem is not None:  # the hem's radius is the clothing's, not the thigh's
            self.radii[N_CAPSULES:, 1] = hem[1] * H * self.girth
        self.capsule_names = tuple(c.name for c in caps)
        seg_of = [c.segment for c in caps]
        self.left_leg_capsules = np.array(
            [i for i, s in enumerate(seg_of) if s in LEFT_LEG_SEGMENTS], dtype=np.int64
        )
        self.right_leg_capsules = np.array(
            [i for i, s in enumerate(seg_of) if s in RIGHT_LEG_SEGMENTS], dtype=np.int64
        )
        #: capsule indices of each arm ("l", "r"): :data:`ARM_SEGMENTS`
        self.arm_capsules: dict[str, np.ndarray] = {
            side: np.array([i for i, s in enumerate(seg_of) if s in segs], dtype=np.int64)
            for side, segs in ARM_SEGMENTS.items()
        }
        legs = set(self.left_leg_capsules.tolist()) | set(self.right_leg_capsules.tolist())
        self.base_capsules = np.array(
            [i for i in range(len(caps)) if i not in legs], dtype=np.int64
        )
        # (C, 2) point indices of the capsule ends; (C,) 0 = base, 1 = left leg, 2 = right leg
        self.cap_ab = np.ascontiguousarray(np.stack([self.cap_a, self.cap_b], axis=1))
        self.capsule_groups = np.zeros(len(caps), dtype=np.int64)
        self.capsule_groups[self.left_leg_capsules] = 1
        self.capsule_groups[self.right_leg_capsules] = 2
        # frame and point masks of points(group=...): groups 0, 1, 2, and -1 = everything
        self._masks: dict[int, tuple[np.ndarray, np.ndarray]] = {
            -1: (np.ones(nf, dtype=np.bool_), np.ones(self._pt_frame.size, dtype=np.bool_))
        }
        for g in (0, 1, 2):
            caps = np.flatnonzero(self.capsule_groups == g)
            frames = set(self._pt_frame[self.cap_ab[caps].ravel()].tolist())
            for f in list(frames):
                while self._parent[f] >= 0:
                    f = int(self._parent[f])
                    frames.add(f)
            frame_on = np.zeros(nf, dtype=np.bool_)
            frame_on[sorted(frames)] = True
            pt_on = frame_on[self._pt_frame].copy()
            self._masks[g] = (frame_on, pt_on)

        legs, upper = zs["left_thigh"], zs["pelvis"]
        self.root_height = (
            ANKLE_HEIGHT + (HIP_HEIGHT - ANKLE_HEIGHT) * legs + SACRUM_ABOVE_HIP * upper
        ) * H
        head = np.asarray(kp["head"][1]) * H
        head[2] *= upper
        self.segment_lengths: dict[str, float] = {
            "hip_separation": HIP_JOINT_SEPARATION * H,
            "shoulder_separation": 2 * SHOULDER_JOINT_HALF_WIDTH * H,
            "sacrum_to_neck": (
                SHOULDER_HEIGHT + NECK_ABOVE_SHOULDER - HIP_HEIGHT - SACRUM_ABOVE_HIP
            )
            * H
            * upper,
            "neck_to_head": float(np.linalg.norm(head)),
            "upper_arm": (SHOULDER_HEIGHT - ELBOW_HEIGHT) * H,
            "forearm": (ELBOW_HEIGHT - WRIST_HEIGHT) * H,
            "hand": HAND_LENGTH * H,
            "thigh": (HIP_HEIGHT - KNEE_HEIGHT) * H * legs,
            "shank": (KNEE_HEIGHT - ANKLE_HEIGHT) * H * legs,
            "foot": FOOT_LENGTH * H,
            "heel_to_toe": (HEEL_BEHIND_ANKLE + TOE_AHEAD_OF_ANKLE) * H,
            "ankle_height": ANKLE_HEIGHT * H,
        }

    @property
    def n_points(self) -> int:
        """Number of model points per pose: 19 key points then 2 per capsule."""
        return int(self._pt_frame.shape[0])

    def _check(self, poses: np.ndarray) -> np.ndarray:
        p = np.asarray(poses, dtype=np.float64)
        if p.ndim == 1:
            p = p[None]
        if p.ndim != 2 or p.shape[1] != N_DOF:
            raise ValueError(f"poses must have shape (N, {N_DOF}), got {np.shape(poses)}")
        return np.ascontiguousarray(p)

    def points(self, poses: np.ndarray, group: int | None = None) -> np.ndarray:
        """All model points of a batch of poses.

        Parameters
        ----------
        poses : np.ndarray
            ``(N, 31)`` (or ``(31,)``) poses, tracker.dof order and units.
        group : {None, 0, 1, 2}
            Compute only the capsule ends of one capsule group (``capsule_groups``: 0 upper body
            and pelvis, 1 left leg, 2 right leg) and the key points of the same frames; the
            other points are NaN. The computed points are bit-identical to a full call.

        Returns
        -------
        np.ndarray
            ``(N, P, 3)`` world positions in metres: the 19 key points, then the ends a and b of
            every capsule (indices ``cap_a``, ``cap_b``).
        """
        p = self._check(poses)
        frame_on, pt_on = self._masks[-1 if group is None else group]
        return _fk_batch(
            p,
            self._parent,
            self._offset,
            self._rot_axis,
            self._rot_dof,
            self._rot_sign,
            self._pt_frame,
            self._pt_local,
            frame_on,
            pt_on,
            4 * nb.get_num_threads(),
        )

    def forward(self, poses: np.ndarray) -> np.ndarray:
        """Forward kinematics: poses ``(N, 31)`` -> key points ``(N, 19, 3)`` in metres."""
        return np.ascontiguousarray(self.points(poses)[:, :N_KEYPOINTS])

    def capsules(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Capsule end centres ``(N, C, 3)``, ``(N, C, 3)`` in metres; radii are ``self.radii``."""
        pts = self.points(poses)
        return pts[:, self.cap_a], pts[:, self.cap_b]

    def neutral_pose(self, x: float = 0.0, y: float = 0.0, yaw: float = 0.0) -> np.ndarray:
        """Standing upright, arms hanging, feet flat with the heels at z = 0; shape (31,).

        ``yaw`` in radians (0 faces +x).
        """
        pose = np.zeros(N_DOF)
        pose[DOF["root_x"]] = x
        pose[DOF["root_y"]] = y
        pose[DOF["root_z"]] = self.root_height
        pose[DOF["root_yaw"]] = yaw
        return pose

    def with_shape(
        self,
        girth: float | None = None,
        part_girths: Mapping[str, float] | None = None,
        leg_length: float | None = None,
        hem: tuple[float, float] | None | Literal["keep"] = "keep",
    ) -> BodyModel:
        """The same person (height) with another girth, part factors, leg length and/or hem
        (the others kept; ``hem=None`` removes the hem)."""
        parts = dict(self.part_girths)
        parts.update(part_girths or {})
        return type(self)(
            height_m=self.height_m,
            girth=self.girth if girth is None else girth,
            part_girths=parts,
            leg_length=self.leg_length if leg_length is None else leg_length,
            hem=self.hem if hem == "keep" else hem,
        )

    @property
    def shape_key(self) -> tuple[float, ...]:
        """Girth, the part factors (GIRTH_PARTS order), the leg length, then the hem (length and
        radius, 0 for none): equal keys, equal bodies."""
        return (self.girth, *self.part_girths.values(), self.leg_length, *(self.hem or (0.0, 0.0)))

    def __repr__(self) -> str:
        parts = {n: f for n, f in self.part_girths.items() if f != 1.0}
        extra = f", part_girths={parts}" if parts else ""
        if self.leg_length != 1.0:
            extra += f", leg_length={self.leg_length}"
        if self.hem is not None:
            extra += f", hem={self.hem}"
        return f"BodyModel(height_m={self.height_m}, girth={self.girth}{extra})"
