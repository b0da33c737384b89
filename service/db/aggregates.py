"""Daily aggregates per resident and metric: median, quartiles and count of the day's values.

Each walking bout contributes one value per gait metric (bouts are the unit caregivers see);
each timed-up-and-go contributes one ``tug_time_s``. The day is the resident's local calendar
day (``Resident.timezone``). Quartiles are numpy's default (linear interpolation) percentiles.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable

import numpy as np
from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from service.db.models import BOUT_METRICS, TUG_METRIC, Bout, DailyAggregate, Transfer


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


def recompute_days(session: Session, resident_id: int, days: Iterable[dt.date]) -> int:
    """Rebuild the daily aggregates of ``resident_id`` for ``days`` from the stored measurements.

    Parameters
    ----------
    session : Session
        Open session; the caller commits.
    resident_id : int
    days : iterable of date
        Local days to rebuild (days without values lose their rows).

    Returns
    -------
    int
        Rows written.
    """
    days = sorted(set(days))
    if not days:
        return 0
    session.execute(
        delete(DailyAggregate).where(
            DailyAggregate.resident_id == resident_id, DailyAggregate.day.in_(days)
        )
    )
    cols = [getattr(Bout, m) for m in BOUT_METRICS]
    bout_rows = session.execute(
        select(Bout.day, *cols).where(Bout.resident_id == resident_id, Bout.day.in_(days))
    ).all()
    tug_rows = session.execute(
        select(Transfer.day, Transfer.tug_time_s).where(
            Transfer.resident_id == resident_id,
            Transfer.day.in_(days),
            Transfer.tug_time_s.is_not(None),
        )
    ).all()
    sources: list[tuple[str, np.ndarray, np.ndarray]] = []
    if bout_rows:
        arr = np.array(
            [[d.toordinal(), *(np.nan if v is None else v for v in r)] for d, *r in bout_rows],
            dtype=np.float64,
        )
        for j, metric in enumerate(BOUT_METRICS):
            sources.append((metric, arr[:, 0], arr[:, j + 1]))
    if tug_rows:
        arr = np.array([[d.toordinal(), v] for d, v in tug_rows], dtype=np.float64)
        sources.append((TUG_METRIC, arr[:, 0], arr[:, 1]))
    written = 0
    for metric, keys, values in sources:
        uniq, med, q1, q3, cnt = grouped_quantiles(keys.astype(np.int64), values)
        session.add_all(
            DailyAggregate(
                resident_id=resident_id,
                metric=metric,
                day=dt.date.fromordinal(int(k)),
                median=float(m),
                q1=float(a),
                q3=float(b),
                count=int(c),
            )
            for k, m, a, b, c in zip(uniq, med, q1, q3, cnt, strict=True)
        )
        written += len(uniq)
    return written
