"""Falls and long lies from the heights of the sacrum and the head.

A fall is a fast descent (the head or the sacrum going down faster than
``descent_speed_m_s``, after Bourke et al. 2008 who used 1.3 m/s of trunk vertical velocity as
a pre-impact threshold) that ends near the floor (sacrum below ``floor_sacrum_m`` and head below
``floor_head_m`` within ``settle_s``). The person is on the floor until the sacrum rises above
``up_sacrum_m`` again; frames where nobody was tracked in between count as on the floor (a
person lying on the floor is often lost by the tracker). A long lie is an on-floor time of at
least ``long_lie_s`` (configurable; the clinical definition is one hour, Fleming & Brayne 2008,
but an alert should come much sooner).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gait.filtering import fill_short_gaps, lowpass, nan_runs
from gaitwatch.conventions import HEAD, SACRUM


@dataclass(frozen=True)
class FallSettings:
    """Speeds in m/s, heights in metres, times in seconds."""

    descent_speed_m_s: float = 1.3
    floor_sacrum_m: float = 0.35
    floor_head_m: float = 0.9
    up_sacrum_m: float = 0.6
    settle_s: float = 2.0
    long_lie_s: float = 60.0


@dataclass
class FallCalc:
    start_s: float
    impact_s: float
    peak_speed_m_s: float
    on_floor_s: float
    long_lie: bool
    got_up: bool


def _vz(z: np.ndarray, fps: float) -> np.ndarray:
    zz = lowpass(fill_short_gaps(z, int(round(0.2 * fps))), fps, 8.0)
    return np.gradient(zz, 1.0 / fps) if zz.size > 1 else np.zeros_like(zz)


def detect_falls(
    positions: np.ndarray, times: np.ndarray, fps: float, settings: FallSettings | None = None
) -> list[FallCalc]:
    """Falls in a recording on a uniform grid.

    Parameters
    ----------
    positions : ndarray, shape (N, 19, 3)
        Positions in metres on the uniform grid (unfiltered is best: the filter is applied
        here with a higher cut-off than for gait, so that fast descents keep their speed).
    times : ndarray, shape (N,)
    fps : float
    """
    s = settings or FallSettings()
    sac = positions[:, SACRUM, 2]
    head = positions[:, HEAD, 2]
    if not np.isfinite(sac).any():
        return []
    v_s, v_h = _vz(sac, fps), _vz(head, fps)
    with np.errstate(invalid="ignore"):
        down = np.fmax(-v_s, -v_h)
        fast = down > s.descent_speed_m_s
    out: list[FallCalc] = []
    n = times.size
    settle = int(round(s.settle_s * fps))
    resume = 0
    for i, j in nan_runs(fast):  # runs of fast descent
        if i < resume:
            continue
        peak = int(i + np.nanargmax(down[i:j]))
        # Start: where the descent began (downward speed above 0.3 m/s).
        with np.errstate(invalid="ignore"):
            slow = np.flatnonzero(~(down[:peak] > 0.3))
        k = int(slow[-1]) + 1 if slow.size else 0
        lim = min(n, j + settle)
        with np.errstate(invalid="ignore"):
            floor = (sac[j:lim] < s.floor_sacrum_m) & ~(head[j:lim] > s.floor_head_m)
        hit = np.flatnonzero(floor)
        if hit.size == 0:
            continue
        impact = j + int(hit[0])
        # On the floor until the sacrum is up again (NaN frames count as on the floor).
        with np.errstate(invalid="ignore"):
            up = np.flatnonzero(sac[impact:] > s.up_sacrum_m)
        got_up = up.size > 0
        stop = impact + int(up[0]) if got_up else n - 1
        on_floor = float(times[stop] - times[impact])
        out.append(
            FallCalc(
                start_s=float(times[k]),
                impact_s=float(times[impact]),
                peak_speed_m_s=float(down[peak]),
                on_floor_s=on_floor,
                long_lie=on_floor >= s.long_lie_s,
                got_up=got_up,
            )
        )
        resume = max(stop, j) + 1
    return out
