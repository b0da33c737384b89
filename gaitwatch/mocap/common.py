"""Shared pieces of the motion-capture readers: errors, the vertical axis, the floor, events.

Every reader turns a laboratory recording into the project's world frame (CONVENTIONS: metres,
right-handed, z up, floor at z = 0). The laboratory's vertical axis is detected from where the
upper-body markers sit relative to the foot markers, and the frame is turned by a proper
rotation (determinant +1) that maps that axis onto +z while keeping the laboratory's first
remaining horizontal axis as x. Nothing here reads files.
"""

from __future__ import annotations

import logging
import re
import warnings
from collections.abc import Callable, Iterable

import numpy as np
from scipy.spatial.transform import Rotation

from gaitwatch.errors import InputError

log = logging.getLogger(__name__)

EVENT_TYPES = ("heel_strike", "toe_off")


class MocapFormatError(InputError):
    """A motion-capture file that cannot be used; the message names the file and the field."""


def up_rotation(axis: int, sign: int) -> np.ndarray:
    """Rotation matrix that maps the laboratory axis ``sign * e_axis`` onto +z.

    Parameters
    ----------
    axis : int
        0, 1 or 2: the laboratory axis (x, y, z) that points up or down.
    sign : int
        +1 if that axis points up, -1 if it points down.

    Returns
    -------
    ndarray, shape (3, 3)
        Proper rotation ``R`` (``det R = +1``); apply as ``p_world = p_lab @ R.T``. Its rows are
        the new x, y, z axes in laboratory coordinates: x is the first laboratory axis other than
        ``axis``, z is ``sign * e_axis``, y completes a right-handed frame. A y-up laboratory
        frame (OpenSim, CMU BVH) becomes ``(x, -z, y)``.
    """
    if axis not in (0, 1, 2) or sign not in (1, -1):
        raise ValueError(f"axis must be 0, 1 or 2 and sign +-1, got {axis}, {sign}")
    up = np.zeros(3)
    up[axis] = sign
    first = np.zeros(3)
    first[min(a for a in range(3) if a != axis)] = 1.0
    second = np.cross(up, first)
    return np.stack([first, second, up])


def detect_vertical(
    upper: Iterable[np.ndarray], lower: Iterable[np.ndarray], source: str = ""
) -> tuple[int, int]:
    """Laboratory vertical axis and its sign, from points known to be high and low on the body.

    Parameters
    ----------
    upper : iterable of ndarray, each shape (T, 3)
        Trajectories of markers that sit high when the person is upright (head, shoulders,
        C7, pelvis markers). NaN where missing.
    lower : iterable of ndarray, each shape (T, 3)
        Trajectories of foot markers (heel, toe, ankle).
    source : str
        For the error message.

    Returns
    -------
    axis, sign : int, int
        The axis along which the upper markers are furthest from the lower ones (median over
        frames), and +1 if the upper markers have the larger coordinate.
    """
    up = [np.asarray(p, float) for p in upper]
    lo = [np.asarray(p, float) for p in lower]
    if not up or not lo:
        raise MocapFormatError(
            f"{source}: cannot detect the vertical axis: need both upper-body or pelvis markers "
            "and foot markers"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # frames where all are missing
        u = np.nanmean(np.stack(up), axis=0)  # (T, 3)
        lw = np.nanmean(np.stack(lo), axis=0)
        d = np.nanmedian(u - lw, axis=0)
    if not np.all(np.isfinite(d)):
        raise MocapFormatError(
            f"{source}: cannot detect the vertical axis: upper and foot markers never seen together"
        )
    axis = int(np.argmax(np.abs(d)))
    return axis, int(np.sign(d[axis]) or 1)


def to_z_up(points: np.ndarray, axis: int, sign: int) -> np.ndarray:
    """Rotate points (..., 3) from a laboratory frame whose vertical is ``sign * e_axis``."""
    return np.asarray(points, float) @ up_rotation(axis, sign).T


def estimate_floor(foot_z: Iterable[np.ndarray], percentile: float = 1.0) -> float:
    """Height of the floor in a z-up frame, from foot-marker heights.

    Gait laboratories calibrate with the origin on the floor, so when the lowest foot markers
    (``percentile`` of their heights over the recording) sit between 0 and 60 mm above the
    laboratory's z = 0, the floor is taken to be z = 0 exactly. Otherwise the floor is that low
    percentile minus 12 mm (a 14 mm marker's radius plus about 5 mm of skin or shoe).

    Parameters
    ----------
    foot_z : iterable of ndarray
        Heights (metres, z up) of foot markers, any shapes, NaN where missing.
    percentile : float
        The low percentile that stands for "the lowest" while ignoring outliers.

    Returns
    -------
    float
        The floor height in the same frame (metres).
    """
    vals = np.concatenate([np.ravel(np.asarray(z, float)) for z in foot_z] or [np.array([])])
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return 0.0
    low = float(np.percentile(vals, percentile))
    if 0.0 <= low <= 0.06:
        return 0.0
    return low - 0.012


#: Bin width (m) along the walk for the floor's lower envelope (:func:`floor_levelling`).
FLOOR_BIN_M = 0.3
#: Shortest walk (m along its main direction) over which a floor slope is estimated.
FLOOR_MIN_TRAVEL_M = 1.0
#: A floor whose height changes by less than this (m) over the walk is left as it is.
FLOOR_MIN_RISE_M = 0.015
#: Steeper than this (degrees) is no calibration error (a ramp, stairs): left as it is.
FLOOR_MAX_TILT_DEG = 5.0


def floor_levelling(
    foot: Iterable[np.ndarray],
) -> tuple[Callable[[np.ndarray], np.ndarray] | None, float]:
    """The rotation that makes a slightly tilted laboratory floor level, from the feet.

    In a walk the lowest foot point of each frame rests on the floor for most of the gait cycle,
    so the low envelope of those points along the walk traces the floor. Some recordings' vertical
    axis is a little off (CMU 07_04 and 07_06: the standing foot rises about 55 mm over the walk,
    a 1.1 degree tilt), which would leave a walker floating above or sinking into a level floor.

    The lowest foot point per frame is binned by its position along the walk's main horizontal
    direction (:data:`FLOOR_BIN_M` bins, at least 5 frames each); each bin's 10th-percentile
    height is its floor sample. A line (a plane when the walk and its samples also spread 1 m
    and 0.5 m across) fitted to the samples gives the slope. The rotation turns about the
    laboratory's origin, which calibration puts on the floor, as :func:`estimate_floor` then
    assumes. Nothing is changed (``None``) when the walk is shorter than
    :data:`FLOOR_MIN_TRAVEL_M`, the floor rises less than :data:`FLOOR_MIN_RISE_M` over it, or it
    is steeper than :data:`FLOOR_MAX_TILT_DEG` (a ramp or stairs, not a calibration error).

    Parameters
    ----------
    foot : iterable of ndarray, shape (T, 3)
        Foot points (markers or joints) in a z-up frame, metres, NaN where missing.

    Returns
    -------
    (levelling, tilt_deg)
        A function that turns points (..., 3) level (the proper rotation about the origin that
        maps the floor's normal onto +z), or None; and the floor's tilt in degrees (0.0 when
        not measured).
    """
    arrs = [np.asarray(f, float) for f in foot]
    if not arrs:
        return None, 0.0
    stack = np.stack(arrs, axis=1)  # (T, K, 3)
    z = np.where(np.isfinite(stack).all(axis=2), stack[..., 2], np.inf)
    k = np.argmin(z, axis=1)
    low = stack[np.arange(len(stack)), k]
    low = low[np.isfinite(low).all(axis=1)]
    if len(low) < 20:
        return None, 0.0
    xy = low[:, :2] - low[:, :2].mean(axis=0)
    _, _, vt = np.linalg.svd(xy, full_matrices=False)
    u = xy @ vt[0]
    v = xy @ vt[1]
    extent = float(u.max() - u.min())
    if extent < FLOOR_MIN_TRAVEL_M:
        return None, 0.0
    edges = np.arange(u.min(), u.max() + FLOOR_BIN_M, FLOOR_BIN_M)
    which = np.digitize(u, edges)
    rows = []
    for b in np.unique(which):
        sel = which == b
        if sel.sum() < 5:
            continue
        zb = low[sel, 2]
        h = float(np.percentile(zb, 10))
        near = zb <= h + 1e-9
        rows.append((float(np.median(u[sel][near])), float(np.median(v[sel][near])), h))
    if len(rows) < 3:
        return None, 0.0
    ru, rv, rz = np.array(rows).T
    across = float(v.max() - v.min()) >= FLOOR_MIN_TRAVEL_M and np.ptp(rv) >= 0.5
    a_mat = np.column_stack([ru, rv, np.ones_like(ru)] if across else [ru, np.ones_like(ru)])
    coef = np.linalg.lstsq(a_mat, rz, rcond=None)[0]
    su, sv = float(coef[0]), float(coef[1]) if across else 0.0
    # Slope (dz per metre) along the lab's x and y, then the floor's unit normal.
    grad = su * vt[0] + sv * vt[1]
    tilt = float(np.degrees(np.arctan(np.hypot(*grad))))
    rise = float(np.hypot(*grad)) * extent
    if rise < FLOOR_MIN_RISE_M:
        return None, tilt
    if tilt > FLOOR_MAX_TILT_DEG:
        log.warning(
            "the floor under the feet slopes by %.1f degrees: taken for a ramp, not levelled", tilt
        )
        return None, tilt
    # The shortest rotation that takes the floor's normal onto +z.
    normal = np.array([-grad[0], -grad[1], 1.0])
    rot = Rotation.align_vectors([[0.0, 0.0, 1.0]], [normal])[0].as_matrix()

    def level(points: np.ndarray) -> np.ndarray:
        return np.asarray(points, float) @ rot.T

    return level, tilt


def low_height(z: np.ndarray, percentile: float = 2.0) -> float:
    """A robust minimum (low percentile) of heights, NaN-aware; NaN if nothing is finite."""
    z = np.asarray(z, float)
    z = z[np.isfinite(z)]
    return float(np.percentile(z, percentile)) if z.size else float("nan")


def align_walking_to_x(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotate key points about the vertical so that the overall walking direction is +x.

    The direction is the horizontal displacement of the sacrum (or of the mean of the hips)
    from the first to the last frame where it is known; the rotation is about the world z axis
    through the origin, so heights and the floor are unchanged.

    Parameters
    ----------
    positions : ndarray, shape (T, 19, 3)
        Key points, world frame.

    Returns
    -------
    rotated : ndarray, shape (T, 19, 3)
    R : ndarray, shape (3, 3)
        The rotation applied (``rotated = positions @ R.T``); identity when the subject does not
        travel (less than 0.2 m).
    """
    from gaitwatch.conventions import L_HIP, R_HIP, SACRUM

    root = positions[:, SACRUM, :2]
    if np.isfinite(root).all(axis=1).sum() < 2:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            root = np.nanmean(positions[:, [L_HIP, R_HIP], :2], axis=1)
    ok = np.flatnonzero(np.isfinite(root).all(axis=1))
    R = np.eye(3)
    if ok.size >= 2:
        d = root[ok[-1]] - root[ok[0]]
        if np.hypot(*d) >= 0.2:
            a = -np.arctan2(d[1], d[0])
            c, s = np.cos(a), np.sin(a)
            R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return positions @ R.T, R


_SIDE_WORDS = {"left": "left", "l": "left", "right": "right", "r": "right"}
_TYPE_WORDS = {
    "foot strike": "heel_strike",
    "foot contact": "heel_strike",
    "heel strike": "heel_strike",
    "initial contact": "heel_strike",
    "foot off": "toe_off",
    "toe off": "toe_off",
}
_SHORT = re.compile(r"^([LR])\.?(HS|FS|IC|TO|FO)$", re.IGNORECASE)


def parse_event_label(label: str, context: str = "") -> tuple[str, str] | None:
    """(side, type) of a laboratory gait event, or None for other events.

    Understands the Vicon form (label "Foot Strike" / "Foot Off" with context "Left" /
    "Right") and the short Motion Analysis form ("LHS", "RHS", "LTO", "RTO", also "LFS",
    "RFO", "LIC"), wherever it appears (some files put it in the context field).
    """
    label = " ".join(label.strip().split()).lower()
    context = context.strip().lower()
    for text in (label, context):
        m = _SHORT.match(text)
        if m:
            side = "left" if m.group(1).upper() == "L" else "right"
            kind = "toe_off" if m.group(2).upper() in ("TO", "FO") else "heel_strike"
            return side, kind
    kind = _TYPE_WORDS.get(label)
    side = _SIDE_WORDS.get(context)
    if kind and side:
        return side, kind
    return None


def sort_events(events: list[dict]) -> list[dict]:
    """Events sorted by time, then side, then type; duplicates (same side, type, time) dropped."""
    seen = set()
    out = []
    for e in sorted(events, key=lambda e: (e["time_s"], e["side"], e["type"])):
        key = (e["side"], e["type"], round(e["time_s"], 6))
        if key not in seen:
            seen.add(key)
            out.append(e)
    return out
