"""Personal baselines: the resident's own usual value of a metric.

The baseline of a metric on reference day ``D`` is the median of the resident's daily medians
over the ``window`` days ending ``gap`` days before ``D`` (days ``[D - gap - window, D - gap)``),
provided at least ``min_days`` of them have data. Leaving out the most recent ``gap`` days lets
a recent decline show against the baseline instead of dragging it along.

The same rule gives the stored current baseline (``D`` = the latest day with data) used by the
alert rules, and the baseline of each trend point (``D`` = the first day of the bucket).
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from service.db.models import AGGREGATE_METRICS, Aggregate, Baseline, utcnow


@dataclass(frozen=True)
class BaselineRule:
    """Window of the baseline in days (see module docstring)."""

    window: int = 56
    gap: int = 7
    min_days: int = 7


def rolling_baselines(
    day_ordinals: np.ndarray, medians: np.ndarray, ref_ordinals: np.ndarray, rule: BaselineRule
) -> tuple[np.ndarray, np.ndarray]:
    """Baseline at each reference day, vectorised.

    Parameters
    ----------
    day_ordinals : ndarray, shape (N,), int
        Days with data (``date.toordinal()``), any order, unique.
    medians : ndarray, shape (N,), float
        Daily median of the metric on those days.
    ref_ordinals : ndarray, shape (M,), int
        Reference days.
    rule : BaselineRule

    Returns
    -------
    baseline : ndarray, shape (M,), float
        Median of the daily medians in each window; NaN where fewer than ``min_days`` days.
    n_days : ndarray, shape (M,), int
        Days with data in each window.
    """
    ref = np.asarray(ref_ordinals, dtype=np.int64)
    out = np.full(ref.shape, np.nan)
    n_out = np.zeros(ref.shape, dtype=np.int64)
    days = np.asarray(day_ordinals, dtype=np.int64)
    if days.size == 0 or ref.size == 0:
        return out, n_out
    lo = int(min(days.min(), ref.min() - rule.gap - rule.window))
    hi = int(max(days.max(), ref.max()))
    dense = np.full(hi - lo + 1 + rule.window, np.nan)
    dense[days - lo] = np.asarray(medians, dtype=np.float64)
    # windows[k] covers dense[k : k + window]; the window of ref day D starts at D - gap - window.
    windows = sliding_window_view(dense, rule.window)
    starts = ref - rule.gap - rule.window - lo
    valid = (starts >= 0) & (starts < windows.shape[0])
    if not valid.any():
        return out, n_out
    w = np.sort(windows[starts[valid]], axis=1)  # NaNs sort last
    n = np.sum(~np.isnan(w), axis=1)
    lo = np.maximum((n - 1) // 2, 0)[:, None]
    hi = np.maximum(n // 2, 0)[:, None]
    med = 0.5 * (np.take_along_axis(w, lo, 1)[:, 0] + np.take_along_axis(w, hi, 1)[:, 0])
    med[n < rule.min_days] = np.nan
    out[valid] = med
    n_out[valid] = n
    return out, n_out


def update_baselines(
    session: Session, resident_id: int, rule: BaselineRule, metrics: tuple[str, ...] = ()
) -> dict[str, Baseline]:
    """Recompute and store the resident's current baselines from the daily aggregates.

    Parameters
    ----------
    session : Session
        Open session; the caller commits.
    resident_id : int
    rule : BaselineRule
    metrics : tuple of str
        Metrics to update (default: all aggregated metrics).

    Returns
    -------
    dict
        Metric -> stored :class:`Baseline` (metrics without enough data are absent and their
        old baseline removed).
    """
    metrics = metrics or AGGREGATE_METRICS
    rows = session.execute(
        select(Aggregate.metric, Aggregate.start, Aggregate.median).where(
            Aggregate.resident_id == resident_id,
            Aggregate.period == "day",
            Aggregate.metric.in_(metrics),
        )
    ).all()
    by_metric: dict[str, list[tuple[int, float]]] = {}
    for metric, day, median in rows:
        by_metric.setdefault(metric, []).append((day.toordinal(), median))
    session.execute(
        delete(Baseline).where(Baseline.resident_id == resident_id, Baseline.metric.in_(metrics))
    )
    stored: dict[str, Baseline] = {}
    now = utcnow()
    for metric, pairs in by_metric.items():
        arr = np.array(pairs, dtype=np.float64)
        days = arr[:, 0].astype(np.int64)
        ref = int(days.max())
        lo_day, hi_day = ref - rule.gap - rule.window, ref - rule.gap
        sel = (days >= lo_day) & (days < hi_day)
        vals = arr[sel, 1]
        if vals.size < rule.min_days:
            continue
        q1, med, q3 = np.percentile(vals, [25, 50, 75])
        b = Baseline(
            resident_id=resident_id,
            metric=metric,
            value=float(med),
            q1=float(q1),
            q3=float(q3),
            n_days=int(vals.size),
            window_start=dt.date.fromordinal(lo_day),
            window_end=dt.date.fromordinal(hi_day - 1),
            computed_at=now,
        )
        session.add(b)
        stored[metric] = b
    return stored
