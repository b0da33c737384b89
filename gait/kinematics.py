"""Joint angles from the 19 key points, per-stride curves and knee/hip/trunk indicators.

Angles are in degrees. Conventions:

- Knee flexion: the angle between the thigh (hip -> knee) and the shank (knee -> ankle);
  0 with the leg straight, positive when bent (3D, unsigned).
- Hip flexion: in the sagittal plane (walking direction, vertical), the thigh's angle from the
  trunk's downward axis, positive with the thigh in front of the trunk. The key points carry no
  pelvis orientation, so the reference is the trunk (sacrum -> neck), not the pelvis as in
  laboratory models: values are offset from Plug-in Gait hip angles by the pelvic tilt. Without
  an upper body (lower-limb laboratory files) the reference is the vertical.
- Trunk lean: sacrum -> neck from vertical; forward (sagittal) and sideways (frontal, positive
  to the subject's left).

:func:`knee_indicators` works on any knee-flexion curve, so joint-angle files (for example
OpenSim ``.mot`` ``knee_angle_r``, where flexion is negative: pass ``-knee_angle_r``) are
summarised with the same code as key-point trajectories.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gait.geometry import left_of, unit
from gaitwatch.conventions import L_SHOULDER, NECK, R_SHOULDER, SACRUM, side_index

N_CURVE = 101
"""Samples of a stride-normalised curve (0, 1, ..., 100 % of the stride)."""
SWING_PEAK_FRACTION = 0.72
"""Typical timing of peak knee flexion in swing, fraction of the cycle (Perry & Burnfield)."""
TOE_OFF_FRACTION = 0.6
"""Typical toe off, fraction of the cycle (Perry & Burnfield)."""


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle in degrees between vectors along the last axis."""
    ua, ub = unit(a), unit(b)
    c = np.clip(np.einsum("...i,...i->...", ua, ub), -1.0, 1.0)
    return np.degrees(np.arccos(c))


def trunk_vector(positions: np.ndarray, vertical_fallback: bool = False) -> np.ndarray:
    """Sacrum -> neck (mid-shoulder when the neck is unknown), shape (N, 3).

    With ``vertical_fallback`` frames without an upper body get a vertical unit vector (for
    lower-body laboratory recordings: hip angles then refer to the vertical).
    """
    neck = positions[:, NECK]
    mid = 0.5 * (positions[:, L_SHOULDER] + positions[:, R_SHOULDER])
    top = np.where(np.isfinite(neck), neck, mid)
    t = top - positions[:, SACRUM]
    if vertical_fallback:
        t = np.where(np.isfinite(t).all(axis=1, keepdims=True), t, np.array([0.0, 0.0, 1.0]))
    return t


def knee_flexion(positions: np.ndarray, side: str) -> np.ndarray:
    """Knee flexion in degrees, shape (N,)."""
    hip = positions[:, side_index(side, "hip")]
    knee = positions[:, side_index(side, "knee")]
    ankle = positions[:, side_index(side, "ankle")]
    return _angle_between(knee - hip, ankle - knee)


def _sagittal(v: np.ndarray, forward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.einsum("ij,ij->i", v, forward), v[:, 2]


def hip_flexion(positions: np.ndarray, forward: np.ndarray, side: str) -> np.ndarray:
    """Hip flexion (thigh relative to trunk, sagittal plane) in degrees, shape (N,).

    Where the upper body is unknown the trunk is taken as vertical.
    """
    ta, tb = _sagittal(trunk_vector(positions, vertical_fallback=True), forward)
    thigh = positions[:, side_index(side, "knee")] - positions[:, side_index(side, "hip")]
    ha, hb = _sagittal(thigh, forward)
    return np.degrees(np.arctan2(ha, -hb) + np.arctan2(ta, tb))


def trunk_lean(positions: np.ndarray, forward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward and leftward trunk lean from vertical in degrees, each shape (N,)."""
    t = trunk_vector(positions)
    lat = left_of(forward)
    ap = np.degrees(np.arctan2(np.einsum("ij,ij->i", t, forward), t[:, 2]))
    ml = np.degrees(np.arctan2(np.einsum("ij,ij->i", t, lat), t[:, 2]))
    return ap, ml


def stride_curve(angle: np.ndarray, f0: float, f1: float) -> np.ndarray:
    """Resample ``angle`` (N,) between fractional frames f0 and f1 to 101 points.

    Samples whose two neighbouring frames are not both known are NaN.
    """
    if f0 < 0 or f1 > angle.size - 1 or not f1 > f0:
        return np.full(N_CURVE, np.nan)
    a = int(np.floor(f0))
    b = min(int(np.ceil(f1)) + 1, angle.size)
    seg = angle[a:b]
    idx = np.linspace(f0, f1, N_CURVE) - a
    lo = np.clip(np.floor(idx).astype(int), 0, seg.size - 1)
    hi = np.clip(lo + 1, 0, seg.size - 1)
    w = idx - lo
    return (1 - w) * seg[lo] + w * seg[hi]


@dataclass
class KneeIndicators:
    """Knee-flexion indicators of one gait cycle (degrees)."""

    peak_swing_flexion_deg: float
    min_stance_flexion_deg: float
    flexion_at_heel_strike_deg: float
    rom_deg: float
    mean_flexion_deg: float


def knee_indicators(
    knee_flexion_deg: np.ndarray, toe_off_fraction: float | None = None
) -> KneeIndicators:
    """Indicators of one gait cycle of knee flexion (heel strike to heel strike).

    Parameters
    ----------
    knee_flexion_deg : ndarray, shape (M,)
        Knee flexion over one cycle, degrees, positive = flexed, starting at heel strike.
    toe_off_fraction : float, optional
        Toe off as a fraction of the cycle; when unknown, the stance/swing split is taken at
        the start of the rise to the largest flexion peak (the swing peak), or 0.6.

    Returns
    -------
    KneeIndicators
    """
    k = np.asarray(knee_flexion_deg, dtype=np.float64)
    ok = np.isfinite(k)
    if ok.sum() < 3:
        nan = float("nan")
        return KneeIndicators(nan, nan, nan, nan, nan)
    m = k.size
    if toe_off_fraction is None:
        toe_off_fraction = TOE_OFF_FRACTION
    split = int(np.clip(round(toe_off_fraction * (m - 1)), 1, m - 1))
    stance, swing = k[:split], k[split:]
    return KneeIndicators(
        peak_swing_flexion_deg=float(np.nanmax(swing)) if np.isfinite(swing).any() else np.nan,
        min_stance_flexion_deg=float(np.nanmin(stance)) if np.isfinite(stance).any() else np.nan,
        flexion_at_heel_strike_deg=float(k[0]),
        rom_deg=float(np.nanmax(k) - np.nanmin(k)),
        mean_flexion_deg=float(np.nanmean(k)),
    )


def cycles_from_events(
    times: np.ndarray, heel_strikes_s: Sequence[float], toe_offs_s: Sequence[float] = ()
) -> list[tuple[float, float, float | None]]:
    """Gait cycles ``(start_s, end_s, toe_off_fraction)`` from one side's events."""
    hs = sorted(heel_strikes_s)
    out = []
    for a, b in zip(hs[:-1], hs[1:], strict=True):
        if a < times[0] or b > times[-1]:
            continue
        to = [t for t in toe_offs_s if a < t < b]
        out.append((a, b, (to[0] - a) / (b - a) if to else None))
    return out


def knee_indicators_series(
    times: np.ndarray,
    knee_flexion_deg: np.ndarray,
    heel_strikes_s: Sequence[float] | None = None,
    toe_offs_s: Sequence[float] = (),
) -> KneeIndicators:
    """Knee indicators of a knee-flexion time series, averaged over its cycles.

    Parameters
    ----------
    times : ndarray, shape (M,)
        Seconds.
    knee_flexion_deg : ndarray, shape (M,)
        Degrees, positive = flexed.
    heel_strikes_s : sequence of float, optional
        Heel strikes of this leg. Without them the whole series is taken as one complete gait
        cycle of unknown phase (as in the OpenSim one-cycle angle files, where only one leg's
        cycle starts at heel strike): the curve is rotated so that its largest flexion, the
        swing peak, falls at ``SWING_PEAK_FRACTION`` of the cycle, and toe off is taken at
        ``TOE_OFF_FRACTION``.
    toe_offs_s : sequence of float
        Toe offs of this leg, to split stance and swing.
    """
    times = np.asarray(times, dtype=np.float64)
    k = np.asarray(knee_flexion_deg, dtype=np.float64)
    if heel_strikes_s is None:
        if not np.isfinite(k).any():
            return knee_indicators(k)
        grid = np.linspace(times[0], times[-1], N_CURVE)
        cyc = np.interp(grid, times, k)[:-1]  # periodic: drop the repeated end sample
        shift = int(round(SWING_PEAK_FRACTION * cyc.size)) - int(np.nanargmax(cyc))
        cyc = np.roll(cyc, shift)
        return knee_indicators(np.append(cyc, cyc[0]), TOE_OFF_FRACTION)
    res = []
    for a, b, tof in cycles_from_events(times, heel_strikes_s, toe_offs_s):
        grid = np.linspace(a, b, N_CURVE)
        res.append(knee_indicators(np.interp(grid, times, k), tof))
    if not res:
        nan = float("nan")
        return KneeIndicators(nan, nan, nan, nan, nan)
    return KneeIndicators(
        *[float(np.nanmean([getattr(r, f) for r in res])) for f in KneeIndicators.__annotations__]
    )
