"""Body-fixed directions from key points: walking direction (heading), lateral axis, angles.

All positions in metres, world frame, z up. Directions are unit vectors in the floor plane.
"""

from __future__ import annotations

import numpy as np

from gait.filtering import fill_short_gaps, lowpass, quiet_nanmean
from gaitwatch.conventions import L_HIP, L_SHOULDER, R_HIP, R_SHOULDER, SACRUM

UP = np.array([0.0, 0.0, 1.0])


def unit(v: np.ndarray) -> np.ndarray:
    """Normalise vectors along the last axis (zero vectors become NaN)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 1e-9, v / n, np.nan)


def horizontal(v: np.ndarray) -> np.ndarray:
    """The floor-plane part of vectors ``(..., 3)``: z set to 0."""
    out = np.array(v, dtype=np.float64, copy=True)
    out[..., 2] = 0.0
    return out


def left_of(forward: np.ndarray) -> np.ndarray:
    """The subject's left for a horizontal forward direction, ``z x forward``, (..., 3)."""
    return np.cross(UP, forward)


def body_forward(positions: np.ndarray) -> np.ndarray:
    """Facing direction from the hip and shoulder lines, ``(left - right) x z``, shape (N, 3).

    Parameters
    ----------
    positions : ndarray, shape (N, 19, 3)
    """
    hips = positions[:, L_HIP] - positions[:, R_HIP]
    shoulders = positions[:, L_SHOULDER] - positions[:, R_SHOULDER]
    lines = np.stack([unit(horizontal(hips)), unit(horizontal(shoulders))])
    with np.errstate(invalid="ignore"):
        lateral = quiet_nanmean(lines, axis=0)
    fwd = np.cross(lateral, UP)
    return unit(horizontal(fwd))


def sacrum_velocity(positions: np.ndarray, fps: float, cutoff_hz: float = 1.0) -> np.ndarray:
    """Horizontal sacrum velocity in m/s, shape (N, 3), smoothed below ``cutoff_hz``.

    The low cut-off averages out the within-stride oscillation of the pelvis.
    """
    s = lowpass(fill_short_gaps(positions[:, SACRUM], int(round(0.5 * fps))), fps, cutoff_hz)
    v = np.gradient(s, 1.0 / fps, axis=0) if s.shape[0] > 1 else np.zeros_like(s)
    return horizontal(v)


def heading(
    positions: np.ndarray, fps: float, min_speed_m_s: float = 0.15
) -> tuple[np.ndarray, np.ndarray]:
    """Walking direction per frame and the horizontal sacrum speed.

    Where the sacrum moves faster than ``min_speed_m_s`` the heading is the direction of its
    (smoothed) horizontal velocity; elsewhere (standing, turning on the spot, treadmill) it is
    the facing direction from the hip and shoulder lines, smoothed at 1 Hz.

    Parameters
    ----------
    positions : ndarray, shape (N, 19, 3)
        Filtered positions, metres.
    fps : float
        Hz.

    Returns
    -------
    forward : ndarray, shape (N, 3)
        Unit horizontal vectors (NaN where nothing is known).
    speed : ndarray, shape (N,)
        Horizontal sacrum speed in m/s.
    """
    v = sacrum_velocity(positions, fps)
    speed = np.linalg.norm(v, axis=-1)
    body = body_forward(positions)
    body = unit(horizontal(lowpass(fill_short_gaps(body, int(round(0.5 * fps))), fps, 1.0)))
    fwd = np.where((speed > min_speed_m_s)[:, None], unit(v), body)
    return fwd, speed


def heading_angle(forward: np.ndarray) -> np.ndarray:
    """Unwrapped heading angle in radians from horizontal unit vectors ``(N, 3)`` (NaN kept)."""
    ang = np.arctan2(forward[:, 1], forward[:, 0])
    ok = np.isfinite(ang)
    out = np.full_like(ang, np.nan)
    if ok.any():
        out[ok] = np.unwrap(ang[ok])
    return out
