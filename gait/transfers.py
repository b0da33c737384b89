"""Sit-to-stand and stand-to-sit transfers, and Timed-Up-and-Go-like sequences.

Transfers are found on the sacrum height normalised by the standing sacrum height
(:func:`gait.bouts.standing_height`): seated below ``sit_fraction``, standing above
``stand_fraction``. A transfer is a passage from one state to the other; it starts when the
height leaves the first state's level by ``onset_fraction`` of the height change and ends when it
is within ``onset_fraction`` of the second state's level, so its duration covers the movement of
the pelvis (trunk flexion before seat-off is not seen by this definition).

A TUG-like sequence is a sit-to-stand followed, within ``tug_max_s``, by a stand-to-sit, with
the sacrum walking at least ``tug_min_walk_m`` in between; it is timed from the start of the
rise to the end of the sit (Podsiadlo & Richardson 1991).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gait.filtering import fill_short_gaps, lowpass, nan_runs
from gait.geometry import body_forward, heading_angle
from gaitwatch.conventions import SACRUM


@dataclass(frozen=True)
class TransferSettings:
    """Thresholds as fractions of the standing sacrum height, times in seconds."""

    sit_fraction: float = 0.7
    stand_fraction: float = 0.85
    onset_fraction: float = 0.05
    min_state_s: float = 0.3
    max_transfer_s: float = 6.0
    tug_max_s: float = 60.0
    tug_min_walk_m: float = 2.0
    tug_turn_deg: float = 150.0


@dataclass
class TransferCalc:
    type: str
    start_s: float
    end_s: float


def _states(h: np.ndarray, s: TransferSettings, fps: float) -> list[tuple[str, int, int]]:
    """Runs of 'sit' / 'stand' (index ranges), short runs dropped."""
    lab = np.full(h.size, "", dtype=object)
    with np.errstate(invalid="ignore"):
        lab[h < s.sit_fraction] = "sit"
        lab[h > s.stand_fraction] = "stand"
    runs = []
    for name in ("sit", "stand"):
        for a, b in nan_runs(lab == name):
            if (b - a) / fps >= s.min_state_s:
                runs.append((name, a, b))
    runs.sort(key=lambda r: r[1])
    merged: list[tuple[str, int, int]] = []
    for r in runs:
        if merged and merged[-1][0] == r[0]:
            merged[-1] = (r[0], merged[-1][1], r[2])
        else:
            merged.append(r)
    return merged


def detect_transfers(
    positions: np.ndarray,
    times: np.ndarray,
    fps: float,
    stand_height: float,
    settings: TransferSettings | None = None,
) -> list[TransferCalc]:
    """Sit-to-stand and stand-to-sit transfers.

    Parameters
    ----------
    positions : ndarray, shape (N, 19, 3)
        Filtered positions on a uniform grid, metres.
    times : ndarray, shape (N,)
    fps : float
    stand_height : float
        Standing sacrum height, metres.
    """
    s = settings or TransferSettings()
    if not np.isfinite(stand_height) or stand_height <= 0:
        return []
    z = lowpass(fill_short_gaps(positions[:, SACRUM, 2], int(round(0.5 * fps))), fps, 2.0)
    h = z / stand_height
    runs = _states(h, s, fps)
    out: list[TransferCalc] = []
    for (la, a0, a1), (lb, b0, b1) in zip(runs[:-1], runs[1:], strict=True):
        if la == lb:
            continue
        seg = h[a1 - 1 : b0 + 1]
        if not np.isfinite(seg).all():
            continue
        lvl_a = float(np.nanmedian(h[a0:a1]))
        lvl_b = float(np.nanmedian(h[b0:b1]))
        rng = lvl_b - lvl_a
        # Search back into the first state and forward into the second for the movement limits.
        lo = max(a0, a1 - int(s.max_transfer_s * fps))
        hi = min(b1, b0 + int(s.max_transfer_s * fps))
        mid = a1 + int(np.argmin(np.abs(h[a1 : b0 + 1] - (lvl_a + rng / 2))))
        d = (h - lvl_a) / rng
        with np.errstate(invalid="ignore"):
            before = np.flatnonzero(d[lo:mid] <= s.onset_fraction)
            after = np.flatnonzero(d[mid:hi] >= 1 - s.onset_fraction)
        start = lo + int(before[-1]) if before.size else a1
        end = mid + int(after[0]) if after.size else b0
        typ = "sit_to_stand" if la == "sit" else "stand_to_sit"
        if (end - start) / fps > s.max_transfer_s:
            continue
        out.append(TransferCalc(typ, float(times[start]), float(times[end])))
    return out


@dataclass
class TUGCalc:
    start_s: float
    end_s: float
    walk_m: float
    turn_deg: float


def detect_tug(
    transfers: list[TransferCalc],
    positions: np.ndarray,
    times: np.ndarray,
    settings: TransferSettings | None = None,
) -> list[TUGCalc]:
    """TUG-like sequences: rise, walk (>= ``tug_min_walk_m``), sit, within ``tug_max_s``."""
    s = settings or TransferSettings()
    out = []
    sac = positions[:, SACRUM, :2]
    ang = heading_angle(body_forward(positions))
    for a, b in zip(transfers[:-1], transfers[1:], strict=True):
        if a.type != "sit_to_stand" or b.type != "stand_to_sit":
            continue
        if b.end_s - a.start_s > s.tug_max_s:
            continue
        sel = (times >= a.end_s) & (times <= b.start_s)
        p = sac[sel]
        p = p[np.isfinite(p).all(axis=1)]
        walk = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) if len(p) > 1 else 0.0
        if walk < s.tug_min_walk_m:
            continue
        aa = ang[sel]
        aa = aa[np.isfinite(aa)]
        turn = float(np.degrees(np.ptp(aa))) if aa.size else float("nan")
        out.append(TUGCalc(a.start_s, b.end_s, walk, turn))
    return out
