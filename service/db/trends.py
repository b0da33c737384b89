"""Per-resident trends of one metric by day, week (ISO, from Monday) or month.

Day buckets come straight from the daily aggregates. Week and month buckets pool the
underlying values (one per bout, or per TUG) and take their exact median and quartiles, so a
busy day does not count the same as a day with one short walk. Every point carries the personal
baseline in effect at the start of the bucket (``service.db.baselines``) and its change.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from service.db.aggregates import grouped_quantiles
from service.db.baselines import BaselineRule, rolling_baselines
from service.db.models import TUG_METRIC, Bout, DailyAggregate, Transfer

UNITS = {"_m_s": "m/s", "_steps_min": "steps/min", "_pct": "%", "_m": "m", "_s": "s"}


def unit_of(metric: str) -> str:
    """Unit from the metric's name suffix (``walking_speed_m_s`` -> ``m/s``)."""
    for suffix, unit in UNITS.items():
        if metric.endswith(suffix):
            return unit
    return ""


def bucket_start(ordinals: np.ndarray, bucket: str) -> np.ndarray:
    """First day (ordinal) of the bucket of each day ordinal.

    Parameters
    ----------
    ordinals : ndarray, shape (N,), int
        ``date.toordinal()`` values.
    bucket : {"day", "week", "month"}
    """
    o = np.asarray(ordinals, dtype=np.int64)
    if bucket == "day":
        return o
    if bucket == "week":
        # date.fromordinal(1) is a Monday; ISO weeks start on Monday.
        return o - (o - 1) % 7
    if bucket == "month":
        days = (o - dt.date(1970, 1, 1).toordinal()).astype("datetime64[D]")
        months = days.astype("datetime64[M]").astype("datetime64[D]")
        return months.astype(np.int64) + dt.date(1970, 1, 1).toordinal()
    raise ValueError(f"bucket must be day, week or month, not {bucket!r}")


def bucket_end(start: int, bucket: str) -> dt.date:
    """Last day (inclusive) of the bucket starting on ordinal ``start``."""
    d = dt.date.fromordinal(start)
    if bucket == "day":
        return d
    if bucket == "week":
        return d + dt.timedelta(days=6)
    nxt = dt.date(d.year + (d.month == 12), d.month % 12 + 1, 1)
    return nxt - dt.timedelta(days=1)


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


def trend(
    session: Session,
    resident_id: int,
    metric: str,
    start: dt.date,
    end: dt.date,
    bucket: str,
    rule: BaselineRule,
) -> list[TrendPointData]:
    """Points of the trend of ``metric`` between ``start`` and ``end`` (inclusive days).

    Buckets are clipped to ``[start, end]``: a week bucket holds only the days in range.
    """
    lo_base = start - dt.timedelta(days=rule.gap + rule.window)
    agg = session.execute(
        select(
            DailyAggregate.day,
            DailyAggregate.median,
            DailyAggregate.q1,
            DailyAggregate.q3,
            DailyAggregate.count,
        )
        .where(
            DailyAggregate.resident_id == resident_id,
            DailyAggregate.metric == metric,
            DailyAggregate.day >= lo_base,
            DailyAggregate.day <= end,
        )
        .order_by(DailyAggregate.day)
    ).all()
    if agg:
        a = np.array([(d.toordinal(), m, q1, q3, c) for d, m, q1, q3, c in agg], dtype=np.float64)
    else:
        a = np.empty((0, 5))
    days = a[:, 0].astype(np.int64)
    in_range = days >= start.toordinal()
    if bucket == "day":
        keys = days[in_range]
        med, q1, q3, cnt = (a[in_range, j] for j in (1, 2, 3, 4))
    else:
        if metric == TUG_METRIC:
            col, table, rid, day_col = (
                Transfer.tug_time_s,
                Transfer,
                Transfer.resident_id,
                Transfer.day,
            )
        else:
            col, table, rid, day_col = getattr(Bout, metric), Bout, Bout.resident_id, Bout.day
        rows = session.execute(
            select(day_col, col)
            .select_from(table)
            .where(rid == resident_id, day_col >= start, day_col <= end, col.is_not(None))
        ).all()
        v = np.array([(d.toordinal(), x) for d, x in rows], dtype=np.float64).reshape(-1, 2)
        keys, med, q1, q3, cnt = grouped_quantiles(
            bucket_start(v[:, 0].astype(np.int64), bucket), v[:, 1]
        )
    keys = np.asarray(keys, dtype=np.int64)
    # Baseline at the start of each bucket (the first day in range for a clipped bucket).
    ref = np.maximum(keys, start.toordinal())
    base, _n = rolling_baselines(days, a[:, 1], ref, rule)
    points: list[TrendPointData] = []
    for i, k in enumerate(keys):
        b = float(base[i])
        has_b = np.isfinite(b)
        m = float(med[i])
        s_day = dt.date.fromordinal(int(ref[i]))
        e_day = min(bucket_end(int(k), bucket), end)
        points.append(
            TrendPointData(
                start=s_day,
                end=e_day,
                median=m,
                q1=float(q1[i]),
                q3=float(q3[i]),
                count=int(cnt[i]),
                baseline=b if has_b else None,
                change=m - b if has_b else None,
                change_pct=100.0 * (m - b) / b if has_b and b != 0 else None,
            )
        )
    return points
