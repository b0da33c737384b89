"""Preparing trajectories for gait analysis: a uniform time grid, gap filling, low-pass filtering.

Every cut-off and gap length is in seconds or hertz, never in frames, so the same settings work
from 15 to 240 Hz. Missing frames (gaps in ``Trajectory.frames``) become NaN rows on the uniform
grid; short NaN runs are filled by linear interpolation, long ones stay NaN and split the
recording into separately filtered pieces.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, filtfilt

from gaitwatch.conventions import (
    L_ANKLE,
    L_HEEL,
    L_HIP,
    L_KNEE,
    L_TOE,
    R_ANKLE,
    R_HEEL,
    R_HIP,
    R_KNEE,
    R_TOE,
)
from gaitwatch.errors import InputError
from gaitwatch.trajectory import Trajectory

MAX_GRID_FRAMES = 20_000_000
"""Refuse a frame-number span that would make an absurdly large uniform grid."""


class GaitInputError(InputError):
    """A trajectory that gait analysis cannot use (names the source and the reason)."""


@dataclass
class Prepared:
    """A trajectory on a uniform time grid, gaps filled and low-pass filtered.

    Attributes
    ----------
    positions : ndarray, shape (N, 19, 3)
        Filtered positions in metres (NaN where unknown after gap filling).
    raw : ndarray, shape (N, 19, 3)
        Unfiltered positions on the same grid (after left/right swap repair), metres.
    times : ndarray, shape (N,)
        Seconds, uniform step ``1 / fps``.
    present : ndarray of bool, shape (N,)
        True where the source had the frame.
    fps : float
        Frame rate of the grid in Hz.
    source : str
        Where the data came from, for messages.
    """

    positions: np.ndarray
    raw: np.ndarray
    times: np.ndarray
    present: np.ndarray
    fps: float
    source: str = ""

    @property
    def n(self) -> int:
        return int(self.times.shape[0])


def quiet_nanmean(x: np.ndarray, axis: int | None = None) -> np.ndarray:
    """``np.nanmean`` without the warning for all-NaN slices (which give NaN)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(x, axis=axis)


def quiet_nanmedian(x: np.ndarray, axis: int | None = None) -> np.ndarray:
    """``np.nanmedian`` without the warning for all-NaN slices (which give NaN)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmedian(x, axis=axis)


def uniform_grid(traj: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Place the frames of ``traj`` on a uniform grid of frame numbers.

    Returns
    -------
    positions : ndarray, shape (N, 19, 3)
        NaN rows for missing frames.
    times : ndarray, shape (N,)
        Seconds.
    present : ndarray of bool, shape (N,)
    fps : float
    """
    if len(traj) < 2:
        raise GaitInputError(f"{traj.source or 'trajectory'}: fewer than two frames")
    try:
        fps = traj.estimated_fps()
    except ValueError as err:
        raise GaitInputError(f"{traj.source or 'trajectory'}: {err}") from None
    if not np.isfinite(fps) or fps <= 0:
        raise GaitInputError(f"{traj.source or 'trajectory'}: frame rate {fps} is not positive")
    frames = np.asarray(traj.frames, dtype=np.int64)
    if np.any(np.diff(frames) <= 0):
        # Frame numbers unusable: derive them from the time stamps.
        frames = np.rint((traj.times - traj.times[0]) * fps).astype(np.int64)
        if np.any(np.diff(frames) <= 0):
            raise GaitInputError(
                f"{traj.source or 'trajectory'}: time stamps closer than one frame at {fps:g} Hz"
            )
    span = int(frames[-1] - frames[0]) + 1
    if span > MAX_GRID_FRAMES:
        raise GaitInputError(
            f"{traj.source or 'trajectory'}: frame numbers span {span} frames, too many"
        )
    idx = frames - frames[0]
    positions = np.full((span, traj.positions.shape[1], 3), np.nan)
    positions[idx] = traj.positions
    present = np.zeros(span, dtype=bool)
    present[idx] = True
    times = traj.times[0] + np.arange(span) / fps
    return positions, times, present, fps


def nan_runs(valid: np.ndarray) -> list[tuple[int, int]]:
    """Half-open ``[start, stop)`` index runs where ``valid`` (1-D bool) is True."""
    v = np.concatenate([[False], np.asarray(valid, dtype=bool), [False]])
    d = np.diff(v.astype(np.int8))
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def fill_short_gaps(x: np.ndarray, max_gap: int) -> np.ndarray:
    """Linearly interpolate interior NaN runs of at most ``max_gap`` samples.

    Parameters
    ----------
    x : ndarray, shape (N, ...)
        Samples along axis 0; every trailing column is treated independently.
    max_gap : int
        Longest NaN run (in samples) to fill. Leading and trailing NaN stay NaN.

    Returns
    -------
    ndarray, same shape as ``x``.
    """
    out = np.array(x, dtype=np.float64, copy=True)
    flat = out.reshape(out.shape[0], -1)
    n = flat.shape[0]
    idx = np.arange(n)
    for c in range(flat.shape[1]):
        col = flat[:, c]
        ok = np.isfinite(col)
        if ok.all() or ok.sum() < 2:
            continue
        interp = np.interp(idx, idx[ok], col[ok])
        for a, b in nan_runs(~ok):
            if a > 0 and b < n and (b - a) <= max_gap:
                col[a:b] = interp[a:b]
    return out


def lowpass(x: np.ndarray, fps: float, cutoff_hz: float, order: int = 2) -> np.ndarray:
    """Zero-lag Butterworth low-pass (``scipy.signal.filtfilt``) along axis 0, NaN-aware.

    Each finite run of each column is filtered on its own; runs too short to filter are left
    unchanged. The cut-off is clipped to 0.8 x Nyquist so the filter stays valid at low rates.

    Parameters
    ----------
    x : ndarray, shape (N, ...)
    fps : float
        Sampling rate in Hz.
    cutoff_hz : float
        -3 dB cut-off of the two-pass filter in Hz.
    order : int
        Order of the single-pass design.
    """
    out = np.array(x, dtype=np.float64, copy=True)
    nyq = fps / 2.0
    wn = min(cutoff_hz, 0.8 * nyq) / nyq
    b, a = butter(order, wn)
    flat = out.reshape(out.shape[0], -1)
    default_pad = 3 * max(len(a), len(b))
    for c in range(flat.shape[1]):
        col = flat[:, c]
        for s, e in nan_runs(np.isfinite(col)):
            if e - s < 4:
                continue
            pad = min(default_pad, e - s - 1)
            col[s:e] = filtfilt(b, a, col[s:e], padlen=pad)
    return out


_LEG = {
    "left": np.array([L_HIP, L_KNEE, L_ANKLE, L_HEEL, L_TOE]),
    "right": np.array([R_HIP, R_KNEE, R_ANKLE, R_HEEL, R_TOE]),
}


def repair_swaps(positions: np.ndarray, ratio: float = 0.5, min_jump_m: float = 0.1) -> np.ndarray:
    """Undo left/right leg swaps, as a tracker makes them, by frame-to-frame consistency.

    A swap toggles at frame t when assigning the legs crosswise to frame t-1 is much cheaper
    (``ratio``) than keeping them, and the straight assignment jumps by more than
    ``min_jump_m`` on average per key point. The leg chain (hip, knee, ankle, heel, toe) is
    swapped as a whole from that frame on, until the next toggle.

    Parameters
    ----------
    positions : ndarray, shape (N, 19, 3)
        Metres, on a uniform grid (NaN rows allowed).

    Returns
    -------
    ndarray, shape (N, 19, 3)
    """
    p = np.array(positions, copy=True)
    if p.shape[0] < 2:
        return p
    lft = p[:, _LEG["left"]]
    rgt = p[:, _LEG["right"]]
    with np.errstate(invalid="ignore"):
        same = (
            quiet_nanmean(
                np.linalg.norm(lft[1:] - lft[:-1], axis=-1)
                + np.linalg.norm(rgt[1:] - rgt[:-1], axis=-1),
                axis=1,
            )
            / 2
        )
        cross = (
            quiet_nanmean(
                np.linalg.norm(lft[1:] - rgt[:-1], axis=-1)
                + np.linalg.norm(rgt[1:] - lft[:-1], axis=-1),
                axis=1,
            )
            / 2
        )
    toggle = np.zeros(p.shape[0], dtype=bool)
    with np.errstate(invalid="ignore"):
        toggle[1:] = (cross < ratio * same) & (same > min_jump_m)
    if not toggle.any():
        return p
    swapped = (np.cumsum(toggle) % 2).astype(bool)
    li, ri = _LEG["left"], _LEG["right"]
    tmp = p[swapped][:, li].copy()
    sel = np.flatnonzero(swapped)
    p[np.ix_(sel, li)] = p[np.ix_(sel, ri)]
    p[np.ix_(sel, ri)] = tmp
    return p


def prepare(
    traj: Trajectory,
    cutoff_hz: float = 6.0,
    max_gap_s: float = 0.25,
    fix_swaps: bool = True,
) -> Prepared:
    """Uniform grid, left/right swap repair, short-gap filling and low-pass filtering.

    Parameters
    ----------
    traj : Trajectory
        Positions in metres, z up.
    cutoff_hz : float
        Butterworth cut-off in Hz (6 Hz after Winter, *Biomechanics and Motor Control of Human
        Movement*, for walking kinematics).
    max_gap_s : float
        Longest gap (missing frames or NaN key points) filled by interpolation, in seconds.
    fix_swaps : bool
        Repair left/right leg swaps first.
    """
    positions, times, present, fps = uniform_grid(traj)
    if fix_swaps:
        positions = repair_swaps(positions)
    max_gap = max(1, int(round(max_gap_s * fps)))
    raw = fill_short_gaps(positions, max_gap)
    filt = lowpass(raw, fps, cutoff_hz)
    return Prepared(
        positions=filt, raw=raw, times=times, present=present, fps=fps, source=traj.source
    )
