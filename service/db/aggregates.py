"""Aggregates per resident, metric and period: median, quartiles and count of the values.

Each walking bout contributes one value per gait metric (bouts are the unit caregivers see);
each timed-up-and-go contributes one ``tug_time_s``. Days are the resident's local calendar
days (``Resident.timezone``); weeks are ISO weeks (from Monday); months are calendar months.
Week and month rows pool the values of their days (exact quantiles, not a median of medians).
Quartiles are numpy's default (linear interpolation) percentiles.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable

import numpy as np
from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from service.db.models import BOUT_METRICS, PERIODS, TUG_METRIC, Aggregate, Bout, Transfer


def quantiles(values: np.ndarray) -> tuple[float, float, float, int]:
    """``(median, q1, q3, count)`` of the finite values; NaNs for no values.

    Parameters
    ----------
    values : ndarray, shape (N,)
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return float("nan"), float("nan"), float("nan"), 0
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return float(med), float(q1), float(q3), int(v.size)


def grouped_quantiles(
    keys: np.ndarray, values: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Median, quartiles and count of ``values`` per distinct key (NaN values ignored).

    Parameters
    ----------
    keys : ndarray, shape (N,), int
        Group of each value (e.g. a day ordinal or bucket start).
    values : ndarray, shape (N,), float

    Returns
    -------
    uniq, median, q1, q3, count : ndarrays, shape (G,)
        Groups with at least one finite value, in ascending key order.
    """
    keys = np.asarray(keys, dtype=np.int64)
    values = np.asarray(values, dtype=np.float64)
    ok = np.isfinite(values)
    keys, values = keys[ok], values[ok]
    if keys.size == 0:
        e = np.empty(0)
        return np.empty(0, dtype=np.int64), e, e, e, np.empty(0, dtype=np.int64)
    order = np.lexsort((values, keys))
    keys, values = keys[order], values[order]
    uniq, start, count = np.unique(keys, return_index=True, return_counts=True)

    def pct(p: float) -> np.ndarray:
        # numpy "linear" percentile within each sorted group, vectorised over groups.
        pos = start + (count - 1) * p
        lo = np.floor(pos).astype(np.int64)
        hi = np.minimum(lo + 1, start + count - 1)
        frac = pos - lo
        return values[lo] * (1 - frac) + values[hi] * frac

    return uniq, pct(0.5), pct(0.25), pct(0.75), count


def bucket_start(ordinals: np.ndarray, period: str) -> np.ndarray:
    """First day (ordinal) of the period (day, ISO week, month) of each day ordinal.

    Parameters
    ----------
    ordinals : ndarray, shape (N,), int
        ``date.toordinal()`` values.
    period : {"day", "week", "month"}
    """
    o = np.asarray(ordinals, dtype=np.int64)
    if period == "day":
        return o
    if period == "week":
        # date.fromordinal(1) is a Monday; ISO weeks start on Monday.
        return o - (o - 1) % 7
    if period == "month":
        epoch = dt.date(1970, 1, 1).toordinal()
        months = (o - epoch).astype("datetime64[D]").astype("datetime64[M]")
        return months.astype("datetime64[D]").astype(np.int64) + epoch
    raise ValueError(f"period must be day, week or month, not {period!r}")


def period_end(start: dt.date, period: str) -> dt.date:
    """Last day (inclusive) of the period starting on ``start``."""
    if period == "day":
        return start
    if period == "week":
        return start + dt.timedelta(days=6)
    nxt = dt.date(start.year + (start.month == 12), start.month % 12 + 1, 1)
    return nxt - dt.timedelta(days=1)


def recompute_days(session: Session, resident_id: int, days: Iterable[dt.date]) -> int:
    """Rebuild the aggregates of ``resident_id`` for ``days`` and their weeks and months.

    Parameters
    ----------
    session : Session
        Open session; the caller commits.
    resident_id : int
    days : iterable of date
        Local days whose values changed (periods left without values lose their rows).

    Returns
    -------
    int
        Rows written.
    """
    ords = np.array(sorted({d.toordinal() for d in days}), dtype=np.int64)
    if ords.size == 0:
        return 0
    written = 0
    for period in PERIODS:
        starts = np.unique(bucket_start(ords, period))
        start_dates = [dt.date.fromordinal(int(k)) for k in starts]
        lo = start_dates[0]
        hi = period_end(start_dates[-1], period)
        session.execute(
            delete(Aggregate).where(
                Aggregate.resident_id == resident_id,
                Aggregate.period == period,
                Aggregate.start.in_(start_dates),
            )
        )
        for metric, keys, values in _values(session, resident_id, lo, hi):
            k = bucket_start(keys, period)
            keep = np.isin(k, starts)
            uniq, med, q1, q3, cnt = grouped_quantiles(k[keep], values[keep])
            session.add_all(
                Aggregate(
                    resident_id=resident_id,
                    metric=metric,
                    period=period,
                    start=dt.date.fromordinal(int(u)),
                    median=float(m),
                    q1=float(a),
                    q3=float(b),
                    count=int(c),
                )
                for u, m, a, b, c in zip(uniq, med, q1, q3, cnt, strict=True)
            )
            written += len(uniq)
    return written


def _values(
    session: Session, resident_id: int, lo: dt.date, hi: dt.date
) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``(metric, day ordinals, values)`` of every aggregated metric on days ``lo..hi``."""
    cols = [getattr(Bout, m) for m in BOUT_METRICS]
    bout_rows = session.execute(
        select(Bout.day, *cols).where(
            Bout.resident_id == resident_id, Bout.day >= lo, Bout.day <= hi
        )
    ).all()
    tug_rows = session.execute(
        select(Transfer.day, Transfer.tug_time_s).where(
            Transfer.resident_id == resident_id,
            Transfer.day >= lo,
            Transfer.day <= hi,
            Transfer.tug_time_s.is_not(None),
        )
    ).all()
    out: list[tuple[str, np.ndarray, np.ndarray]] = []
    if bout_rows:
        arr = np.array(
            [[d.toordinal(), *(np.nan if v is None else v for v in r)] for d, *r in bout_rows],
            dtype=np.float64,
        )
        keys = arr[:, 0].astype(np.int64)
        out.extend((m, keys, arr[:, j + 1]) for j, m in enumerate(BOUT_METRICS))
    if tug_rows:
        arr = np.array([[d.toordinal(), v] for d, v in tug_rows], dtype=np.float64)
        out.append((TUG_METRIC, arr[:, 0].astype(np.int64), arr[:, 1]))
    return out
