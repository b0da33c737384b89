"""The binding conventions of ``shared/CONVENTIONS.md``, as code.

World frame: right-handed, metres, z up, the floor is the plane z = 0. Left and right are the
subject's own. The 19 key points below, in this order, index every ``(..., 19, 3)`` array of
joint positions in the project.
"""

from __future__ import annotations

from typing import Final

KEYPOINTS: Final[tuple[str, ...]] = (
    "head",
    "neck",
    "sacrum",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
    "left_heel",
    "right_heel",
    "left_toe",
    "right_toe",
)
N_KEYPOINTS: Final[int] = len(KEYPOINTS)
KP: Final[dict[str, int]] = {name: i for i, name in enumerate(KEYPOINTS)}

# Named indices, for readable indexing: positions[:, HEAD], positions[:, L_HEEL] ...
HEAD, NECK, SACRUM = 0, 1, 2
L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_WRIST, R_WRIST = 3, 4, 5, 6, 7, 8
L_HIP, R_HIP, L_KNEE, R_KNEE, L_ANKLE, R_ANKLE = 9, 10, 11, 12, 13, 14
L_HEEL, R_HEEL, L_TOE, R_TOE = 15, 16, 17, 18
#: The key-point order with every left point exchanged for its right one (a mirrored person).
SIDES_EXCHANGED: Final[tuple[int, ...]] = tuple(
    KP[n.replace("left_", "right_")]
    if n.startswith("left_")
    else KP[n.replace("right_", "left_")]
    if n.startswith("right_")
    else i
    for i, n in enumerate(KEYPOINTS)
)

# The skeleton's 18 bones as (parent, child) key-point pairs: the tree that joins the 19 key points,
# rooted at the sacrum. For drawing and for bone-length checks; the body model
# (``tracker.body``) defines which bones move together as rigid segments.
BONES: Final[tuple[tuple[str, str], ...]] = (
    ("sacrum", "neck"),
    ("neck", "head"),
    ("neck", "left_shoulder"),
    ("neck", "right_shoulder"),
    ("left_shoulder", "left_elbow"),
    ("right_shoulder", "right_elbow"),
    ("left_elbow", "left_wrist"),
    ("right_elbow", "right_wrist"),
    ("sacrum", "left_hip"),
    ("sacrum", "right_hip"),
    ("left_hip", "left_knee"),
    ("right_hip", "right_knee"),
    ("left_knee", "left_ankle"),
    ("right_knee", "right_ankle"),
    ("left_ankle", "left_heel"),
    ("right_ankle", "right_heel"),
    ("left_ankle", "left_toe"),
    ("right_ankle", "right_toe"),
)
BONE_INDICES: Final[tuple[tuple[int, int], ...]] = tuple((KP[a], KP[b]) for a, b in BONES)

SIDES: Final[tuple[str, str]] = ("left", "right")


def side_index(side: str, joint: str) -> int:
    """Index of ``f"{side}_{joint}"``, e.g. ``side_index("left", "heel") == 15``."""
    if side not in SIDES:
        raise ValueError(f"side must be 'left' or 'right', not {side!r}")
    return KP[f"{side}_{joint}"]


# Columns of JOINTS.csv, one row per frame and key point.
JOINTS_CSV_COLUMNS: Final[tuple[str, ...]] = ("frame", "time_s", "joint", "x", "y", "z")

# Fields every bout and the summary of ``gaitwatch gait --json`` carry at least.
GAIT_JSON_FIELDS: Final[tuple[str, ...]] = (
    "walking_speed_m_s",
    "cadence_steps_min",
    "stride_length_m",
    "step_length_m",
    "step_width_m",
    "stride_time_s",
    "stance_pct",
    "swing_pct",
    "double_support_pct",
    "stride_time_cv_pct",
)
