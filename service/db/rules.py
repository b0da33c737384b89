"""The alert rules, all in one place: pure functions from what was just ingested to alerts.

Rules (thresholds in :class:`service.config.AlertRules`):

- ``fall``: every detected fall raises a high-severity alert; a long lie (time on the floor at
  least ``long_lie_s``) says so in the message.
- ``slow_gait``: the recording's walking speed is below ``slow_speed_m_s`` (0.8 m/s).
- ``speed_decline``: the day's median walking speed is more than ``baseline_drop_pct`` per cent
  below the resident's personal baseline (``service.db.baselines``).
- ``slow_tug``: a timed-up-and-go of at least ``tug_slow_s`` (13.5 s).

Except for falls (each is its own event), a rule does not raise a second alert of the same kind
while one is still open or acknowledged for that resident.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field

from service.config import AlertRules


@dataclass(frozen=True)
class FallFact:
    """A fall just ingested."""

    at: dt.datetime
    lie_duration_s: float | None
    long_lie: bool


@dataclass(frozen=True)
class RuleInput:
    """What the rules look at after one recording was ingested."""

    recording_speed_m_s: float | None
    day: dt.date | None = None
    day_median_speed_m_s: float | None = None
    baseline_speed_m_s: float | None = None
    falls: list[FallFact] = field(default_factory=list)
    tug_times_s: list[tuple[dt.datetime, float]] = field(default_factory=list)
    recording_start: dt.datetime | None = None


@dataclass(frozen=True)
class AlertDraft:
    """An alert to store. ``unique_open``: skip it if one of that kind is still open."""

    kind: str
    severity: str
    message: str
    occurred_at: dt.datetime | None
    unique_open: bool = True


def evaluate(inp: RuleInput, cfg: AlertRules) -> list[AlertDraft]:
    """Alerts raised by the rules for one ingested recording (see module docstring)."""
    out: list[AlertDraft] = []
    for f in inp.falls:
        long_lie = f.long_lie or (
            f.lie_duration_s is not None and f.lie_duration_s >= cfg.long_lie_s
        )
        msg = f"fall detected at {f.at.isoformat(timespec='seconds')}"
        if long_lie:
            lie = f" ({f.lie_duration_s:.0f} s on the floor)" if f.lie_duration_s else ""
            msg += f"; long lie{lie}"
        out.append(AlertDraft("fall", "high", msg, f.at, unique_open=False))
    v = inp.recording_speed_m_s
    if v is not None and v < cfg.slow_speed_m_s:
        out.append(
            AlertDraft(
                "slow_gait",
                "medium",
                f"walking speed {v:.2f} m/s is below {cfg.slow_speed_m_s:.2f} m/s",
                inp.recording_start,
            )
        )
    med, base = inp.day_median_speed_m_s, inp.baseline_speed_m_s
    if med is not None and base is not None and base > 0:
        drop = 100.0 * (base - med) / base
        if drop > cfg.baseline_drop_pct:
            out.append(
                AlertDraft(
                    "speed_decline",
                    "medium",
                    f"median walking speed on {inp.day} is {med:.2f} m/s, {drop:.0f}% below the "
                    f"personal baseline of {base:.2f} m/s",
                    inp.recording_start,
                )
            )
    for at, tug in inp.tug_times_s:
        if tug >= cfg.tug_slow_s:
            out.append(
                AlertDraft(
                    "slow_tug",
                    "medium",
                    f"timed up and go took {tug:.1f} s (>= {cfg.tug_slow_s:.1f} s)",
                    at,
                )
            )
            break
    return out
