"""Gait events (heel strike, toe off) from key-point coordinates.

Method: Zeni, Richards & Higginson (2008), *Two simple methods for determining gait events
during treadmill and overground walking using kinematic data*, Gait & Posture 27:710-714.
Heel strike is a maximum of the heel's forward distance from the sacrum, toe off a minimum of
the toe's forward distance from the sacrum, "forward" being the walking direction of each frame
(:func:`gait.geometry.heading`), so the method also works on curved paths and treadmills. The
extremum is located to a fraction of a frame by a parabola through the three samples around it.

Zeni's heel strike is the instant the heel stops moving forward relative to the sacrum, which on
the laboratory recordings comes 10-40 ms before the force-plate contact. It is therefore refined:
from the Zeni peak on, heel strike is the first instant the heel moves backward relative to the
sacrum at ``hs_velocity_fraction`` of the stance foot's backward speed (which equals the walking
speed over ground and the belt speed on a treadmill, so no ground reference is needed).
Toe off can be refined the same way (``to_velocity_fraction``; off by default, on for tracked
key points, see :data:`gait.analysis.TO_VELOCITY_FRACTION`): from the Zeni minimum on, the first
instant the toe moves forward relative to the sacrum at that fraction of its late-stance
backward speed. Missing heel or toe key points fall back to the ankle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from gait.filtering import Prepared
from gaitwatch.conventions import SACRUM, side_index

EVENT_TYPES = ("heel_strike", "toe_off")


@dataclass(frozen=True)
class EventSettings:
    """Peak picking for the Zeni curves. Times in seconds, distances in metres."""

    min_stride_s: float = 0.6
    """Two events of one type and side are at least this far apart (half is used as peak
    distance, so fast strides still pass)."""
    min_prominence_m: float = 0.06
    """Minimum prominence of an extremum of the foot-to-sacrum forward distance."""
    min_excursion_m: float = 0.15
    """Minimum distance between a heel strike's heel and the neighbouring toe off's toe along
    the walking direction (rejects weight shifts while standing)."""
    hs_velocity_fraction: float = 0.4
    """Heel strike refinement: fraction of the stance foot's backward speed relative to the
    sacrum reached at contact (0 gives Zeni's original heel strike)."""
    to_velocity_fraction: float = 0.0
    """Toe off refinement: from Zeni's toe off on, the first instant the toe moves forward
    relative to the sacrum at this fraction of its late-stance backward speed (0, the default,
    gives Zeni's toe off; tracked key points use more, see ``gait.analysis``)."""


@dataclass(frozen=True)
class GaitEvent:
    """One detected or laboratory event."""

    side: str
    type: str
    time_s: float
    frame: float = float("nan")
    """Fractional index on the prepared uniform grid."""


def _foot_point(prep: Prepared, side: str, which: str) -> np.ndarray:
    pts = prep.positions[:, side_index(side, which)]
    ankle = prep.positions[:, side_index(side, "ankle")]
    return np.where(np.isfinite(pts), pts, ankle)


def zeni_curves(prep: Prepared, forward: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray]:
    """Forward distance (m) of heel and toe from the sacrum, shape (N,) each."""
    sac = prep.positions[:, SACRUM]
    heel = np.einsum("ij,ij->i", _foot_point(prep, side, "heel") - sac, forward)
    toe = np.einsum("ij,ij->i", _foot_point(prep, side, "toe") - sac, forward)
    return heel, toe


def _subframe(y: np.ndarray, i: np.ndarray) -> np.ndarray:
    """Parabolic refinement of extrema at integer indices ``i`` of ``y``; returns float indices."""
    out = i.astype(np.float64)
    inner = (i > 0) & (i < y.size - 1)
    j = i[inner]
    a, b, c = y[j - 1], y[j], y[j + 1]
    den = a - 2 * b + c
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(np.abs(den) > 1e-12, 0.5 * (a - c) / den, 0.0)
    d = np.clip(np.nan_to_num(d), -0.5, 0.5)
    out[inner] = j + d
    return out


def _peaks(y: np.ndarray, fps: float, s: EventSettings) -> np.ndarray:
    """Indices of maxima of ``y`` (NaN-safe: peaks never touch a NaN sample)."""
    ok = np.isfinite(y)
    if ok.sum() < 3:
        return np.empty(0, dtype=np.int64)
    yy = np.where(ok, y, -np.inf)
    idx, _ = find_peaks(
        np.nan_to_num(yy, neginf=np.nanmin(y) - 1.0),
        distance=max(1, int(s.min_stride_s * fps / 2)),
        prominence=s.min_prominence_m,
    )
    keep = ok[idx] & ok[np.clip(idx - 1, 0, None)] & ok[np.clip(idx + 1, None, y.size - 1)]
    # An extremum on the first or last sample is a cut, not an event.
    keep &= (idx > 0) & (idx < y.size - 1)
    return idx[keep]


def detect_events(
    prep: Prepared, forward: np.ndarray, settings: EventSettings | None = None
) -> list[GaitEvent]:
    """Heel strikes and toe offs of both feet, sorted by time.

    Parameters
    ----------
    prep : Prepared
        Filtered positions on a uniform grid.
    forward : ndarray, shape (N, 3)
        Walking direction per frame (unit, horizontal).
    settings : EventSettings, optional

    Returns
    -------
    list of GaitEvent
        Alternating heel strike / toe off per side; an event whose partner on the same side is
        implausible (no foot excursion) is dropped.
    """
    s = settings or EventSettings()
    events: list[GaitEvent] = []
    for side in ("left", "right"):
        heel, toe = zeni_curves(prep, forward, side)
        hs = _peaks(heel, prep.fps, s)
        to = _peaks(-toe, prep.fps, s)
        seq = sorted(
            [
                (float(f), "heel_strike", heel[i])
                for f, i in zip(_subframe(heel, hs), hs, strict=True)
            ]
            + [(float(f), "toe_off", toe[i]) for f, i in zip(_subframe(-toe, to), to, strict=True)]
        )
        seq = _alternate(seq, s.min_excursion_m)
        for f, typ, _ in seq:
            if typ == "heel_strike" and s.hs_velocity_fraction > 0:
                f = _refine_heel_strike(heel, prep.fps, f, s.hs_velocity_fraction)
            elif typ == "toe_off" and s.to_velocity_fraction > 0:
                f = _refine_toe_off(toe, prep.fps, f, s.to_velocity_fraction)
            events.append(GaitEvent(side, typ, _time_at(prep.times, f), f))
    events.sort(key=lambda e: e.time_s)
    return events


def _refine_heel_strike(r: np.ndarray, fps: float, frame: float, fraction: float) -> float:
    """Move a Zeni heel strike to where the heel's backward speed relative to the sacrum
    reaches ``fraction`` of its early-stance value.

    Parameters
    ----------
    r : ndarray, shape (N,)
        Forward distance of the heel from the sacrum, metres.
    frame : float
        Fractional index of the Zeni peak.

    Returns
    -------
    float
        Fractional index of the refined heel strike (the Zeni peak when refinement is not
        possible, e.g. at the end of the recording).
    """
    k = int(np.floor(frame))
    # Local derivative only (from k - 1), so the cost does not grow with the recording.
    lo = max(k - 1, 0)
    local = r[lo : k + int(round(0.3 * fps)) + 2]
    if local.size < 2:
        return frame
    rv = np.gradient(local, 1.0 / fps)
    off = k - lo  # index of frame k in rv
    stance = rv[off + max(1, int(round(0.1 * fps))) : off + int(round(0.3 * fps)) + 1]
    if stance.size == 0 or not np.isfinite(stance).any():
        return frame
    v_walk = -float(np.nanmedian(stance))
    if not v_walk > 0:
        return frame
    # The backward speed rising to the fraction: the negated velocity rising past it.
    seg = -rv[off : off + int(round(0.3 * fps)) + 1]
    return _first_rise(seg, fraction * v_walk, k, frame)


def _refine_toe_off(r: np.ndarray, fps: float, frame: float, fraction: float) -> float:
    """Move a Zeni toe off to where the toe's forward speed relative to the sacrum reaches
    ``fraction`` of its late-stance backward speed (the mirror of
    :func:`_refine_heel_strike`).

    Parameters
    ----------
    r : ndarray, shape (N,)
        Forward distance of the toe from the sacrum, metres.
    frame : float
        Fractional index of the Zeni minimum.

    Returns
    -------
    float
        Fractional index of the refined toe off (the Zeni minimum when refinement is not
        possible, e.g. at either end of the recording).
    """
    k = int(np.floor(frame))
    n_late, n_near = int(round(0.3 * fps)), max(1, int(round(0.1 * fps)))
    # Local derivative only, so the cost does not grow with the recording.
    lo = max(k - n_late - 1, 0)
    local = r[lo : k + n_late + 2]
    if local.size < 3:
        return frame
    rv = np.gradient(local, 1.0 / fps)
    off = k - lo  # index of frame k in rv
    stance = rv[max(off - n_late, 0) : max(off - n_near + 1, 0)]
    if stance.size == 0 or not np.isfinite(stance).any():
        return frame
    v_walk = -float(np.nanmedian(stance))
    if not v_walk > 0:
        return frame
    return _first_rise(rv[off : off + n_late + 1], fraction * v_walk, k, frame)


def _first_rise(seg: np.ndarray, thr: float, k: int, frame: float) -> float:
    """Fractional index ``k + i`` where ``seg`` (samples from frame k on) first reaches ``thr``,
    linearly interpolated between the samples around it; ``frame`` when it never does or
    already does at k."""
    with np.errstate(invalid="ignore"):
        above = np.flatnonzero(seg >= thr)
    if above.size == 0 or above[0] == 0:
        return frame
    i = int(above[0])
    a, b = seg[i - 1], seg[i]
    if not (np.isfinite(a) and np.isfinite(b)) or a == b:
        return float(k + i)
    return float(k + i - 1 + (thr - a) / (b - a))


def _alternate(
    seq: list[tuple[float, str, float]], min_excursion: float
) -> list[tuple[float, str, float]]:
    """Keep heel strikes and toe offs alternating; of two in a row keep the more extreme one.

    Each remaining heel strike must be at least ``min_excursion`` ahead of a neighbouring toe
    off (forward distances from the sacrum), else both are weight shifts, not steps.
    """
    out: list[tuple[float, str, float]] = []
    for ev in seq:
        if out and out[-1][1] == ev[1]:
            prev = out[-1]
            better = ev[2] > prev[2] if ev[1] == "heel_strike" else ev[2] < prev[2]
            if better:
                out[-1] = ev
            continue
        out.append(ev)
    keep = []
    for k, ev in enumerate(out):
        nb = [out[j] for j in (k - 1, k + 1) if 0 <= j < len(out)]
        if not nb:
            continue
        if ev[1] == "heel_strike":
            ok = any(ev[2] - n[2] >= min_excursion for n in nb)
        else:
            ok = any(n[2] - ev[2] >= min_excursion for n in nb)
        if ok:
            keep.append(ev)
    return keep


def _time_at(times: np.ndarray, f: float) -> float:
    """Time at fractional index ``f`` of a uniform grid."""
    if times.size < 2:
        return float(times[0])
    dt = (times[-1] - times[0]) / (times.size - 1)
    return float(times[0] + f * dt)
