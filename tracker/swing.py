"""Which way a walker faces, from how the feet swing: the swing foot moves forward.

Seen from the front or the back a silhouette looks alike, and where the person travels the
heading check follows the walking direction. Walking on a treadmill, or stepping on the
spot, nobody travels; the feet still tell the way. In every step the swing foot is lifted and
carried forward past the body, while the stance foot stands (overground) or is carried back
by the belt (treadmill): relative to the pelvis, a raised foot moves the way the person faces.

:func:`swing_direction` sums each ankle's horizontal velocity relative to the sacrum weighted
by the ankle's height above its lowest over the window (zero in stance, largest mid-swing),
and reports the direction of that sum and how consistent the motion was (the sum's length
over the sum of the lengths). Pure computation on key-point positions (world metres, z up).
"""

from __future__ import annotations

import numpy as np

__all__ = ["swing_direction"]


def swing_direction(
    times: np.ndarray, sacrum: np.ndarray, left_ankle: np.ndarray, right_ankle: np.ndarray
) -> tuple[float, float] | None:
    """The horizontal direction the raised feet move in relative to the sacrum.

    Parameters
    ----------
    times : (T,) seconds, increasing
    sacrum, left_ankle, right_ankle : (T, 3) world positions (metres, z up)

    Returns
    -------
    (angle, consistency) or None
        ``angle``: radians, counter-clockwise from the world x axis (``atan2(y, x)``, the
        convention of the heading ``root_yaw``). ``consistency``: the weighted velocities'
        sum's length over the sum of their lengths, 0..1 (1: every raised foot moved the same
        way). None with fewer than three frames, non-increasing times, non-finite positions or
        no foot ever above its lowest.
    """
    t = np.asarray(times, dtype=np.float64)
    s = np.asarray(sacrum, dtype=np.float64)
    ankles = (np.asarray(left_ankle, dtype=np.float64), np.asarray(right_ankle, dtype=np.float64))
    if t.ndim != 1 or t.size < 3 or not np.all(np.diff(t) > 0):
        return None
    if not all(a.shape == (t.size, 3) for a in (s, *ankles)):
        raise ValueError("sacrum and ankles must be (T, 3) with T = len(times)")
    if not (np.isfinite(s).all() and all(np.isfinite(a).all() for a in ankles)):
        return None
    dt = np.diff(t)[:, None]
    total = np.zeros(2)
    lengths = 0.0
    for a in ankles:
        rel = a[:, :2] - s[:, :2]
        v = np.diff(rel, axis=0) / dt  # between consecutive frames
        z = 0.5 * (a[1:, 2] + a[:-1, 2])
        w = np.clip(z - a[:, 2].min(), 0.0, None)
        total += (v * w[:, None]).sum(axis=0)
        lengths += float((np.hypot(v[:, 0], v[:, 1]) * w).sum())
    if lengths <= 0.0:
        return None
    return float(np.arctan2(total[1], total[0])), float(np.hypot(*total) / lengths)
