"""Per-resident trends of one metric by day, week (ISO, from Monday) or month.

Every bucket is a whole calendar period overlapping the requested range, read from the
precomputed aggregates (``service.db.aggregates``): week and month points pool the underlying
values (one per bout, or per TUG) for exact medians and quartiles. Every point carries the
personal baseline in effect at the start of the bucket (``service.db.baselines``) and its
change.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import String, select, type_coerce
from sqlalchemy.orm import Session

from service.db.aggregates import bucket_start, period_end
from service.db.baselines import BaselineRule, rolling_baselines
from service.db.models import Aggregate

UNITS = {"_m_s": "m/s", "_steps_min": "steps/min", "_pct": "%", "_m": "m", "_s": "s"}
_EPOCH = dt.date(1970, 1, 1).toordinal()


def unit_of(metric: str) -> str:
    """Unit from the metric's name suffix (``walking_speed_m_s`` -> ``m/s``)."""
    for suffix, unit in UNITS.items():
        if metric.endswith(suffix):
            return unit
    return ""


def _ordinals(values: list[Any]) -> np.ndarray:
    """Day ordinals of ISO date strings or date objects (whatever the driver returns)."""
    if not values:
        return np.empty(0, dtype=np.int64)
    return np.array(values, dtype="datetime64[D]").astype(np.int64) + _EPOCH


@dataclass(frozen=True)
class TrendPointData:
    start: dt.date
    end: dt.date
    median: float
    q1: float
    q3: float
    count: int
    baseline: float | None
    change: float | None
    change_pct: float | None


def _rows(
    session: Session,
    resident_id: int,
    metric: str,
    period: str,
    lo: dt.date,
    hi: dt.date,
    stats: bool,
) -> tuple[np.ndarray, np.ndarray]:
    # The date is read as text (ISO on SQLite) and parsed by numpy in one go: much faster than
    # a date object per row. Drivers that return date objects work too.
    cols = [type_coerce(Aggregate.start, String), Aggregate.median]
    if stats:
        cols += [Aggregate.q1, Aggregate.q3, Aggregate.count]
    # Core execution on the session's connection: no ORM row processing for plain columns.
    rows = (
        session.connection()
        .execute(
            select(*cols)
            .where(
                Aggregate.resident_id == resident_id,
                Aggregate.metric == metric,
                Aggregate.period == period,
                Aggregate.start >= lo,
                Aggregate.start <= hi,
            )
            .order_by(Aggregate.start)
        )
        .all()
    )
    if not rows:
        return np.empty(0, dtype=np.int64), np.empty((0, 4 if stats else 1))
    keys = _ordinals([r[0] for r in rows])
    vals = np.array([r[1:] for r in rows], dtype=np.float64)
    return keys, vals


def trend(
    session: Session,
    resident_id: int,
    metric: str,
    start: dt.date,
    end: dt.date,
    bucket: str,
    rule: BaselineRule,
) -> list[TrendPointData]:
    """Points of the trend of ``metric`` for the buckets overlapping ``start..end``."""
    first = int(bucket_start(np.array([start.toordinal()]), bucket)[0])
    lo_base = dt.date.fromordinal(first - rule.gap - rule.window)
    days, day_vals = _rows(session, resident_id, metric, "day", lo_base, end, bucket == "day")
    if bucket == "day":
        sel = days >= start.toordinal()
        keys, stats = days[sel], day_vals[sel]
    else:
        keys, stats = _rows(
            session, resident_id, metric, bucket, dt.date.fromordinal(first), end, True
        )
    base, _n = rolling_baselines(days, day_vals[:, 0], keys, rule)
    points: list[TrendPointData] = []
    for i, k in enumerate(keys.tolist()):
        b = float(base[i])
        has_b = bool(np.isfinite(b))
        m, q1, q3, cnt = stats[i].tolist()
        s_day = dt.date.fromordinal(k)
        points.append(
            TrendPointData(
                start=s_day,
                end=period_end(s_day, bucket),
                median=m,
                q1=q1,
                q3=q3,
                count=int(cnt),
                baseline=b if has_b else None,
                change=m - b if has_b else None,
                change_pct=100.0 * (m - b) / b if has_b and b != 0 else None,
            )
        )
    return points
