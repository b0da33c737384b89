"""Synthetic gait results and bulk-filled databases, for tests, benchmarks and demos.

Nothing here is used by the service itself. Every random draw comes from the injected
``numpy.random.Generator``.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

import numpy as np
from sqlalchemy.orm import Session
from tqdm import tqdm

from gaitwatch.conventions import GAIT_JSON_FIELDS
from service.db.aggregates import bucket_start, grouped_quantiles
from service.db.baselines import BaselineRule, update_baselines
from service.db.models import BOUT_METRICS, PERIODS, Aggregate, Bout, Recording, Resident

# Typical older-adult values and between-bout spread of each CONVENTIONS field.
TYPICAL: dict[str, tuple[float, float]] = {
    "walking_speed_m_s": (1.05, 0.08),
    "cadence_steps_min": (105.0, 5.0),
    "stride_length_m": (1.2, 0.07),
    "step_length_m": (0.6, 0.035),
    "step_width_m": (0.11, 0.015),
    "stride_time_s": (1.14, 0.05),
    "stance_pct": (62.0, 1.5),
    "swing_pct": (38.0, 1.5),
    "double_support_pct": (24.0, 2.0),
    "stride_time_cv_pct": (3.0, 0.8),
}
assert tuple(TYPICAL) == GAIT_JSON_FIELDS


def fake_metrics(rng: np.random.Generator, speed: float | None = None) -> dict[str, float]:
    """One set of plausible gait parameters (``walking_speed_m_s`` = ``speed`` if given)."""
    out = {k: float(rng.normal(m, s)) for k, (m, s) in TYPICAL.items()}
    if speed is not None:
        out["walking_speed_m_s"] = float(speed)
    return out


def fake_gait_result(
    rng: np.random.Generator,
    *,
    n_bouts: int = 3,
    speed: float = 1.05,
    duration_s: float = 600.0,
    falls: list[dict[str, Any]] | None = None,
    transfers: list[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """A CONVENTIONS ``gait --json`` object with ``n_bouts`` bouts inside ``duration_s``.

    Bout speeds scatter around ``speed``; the summary is the bouts' mean.
    """
    bouts = []
    slot = duration_s / max(n_bouts, 1)
    for i in range(n_bouts):
        m = fake_metrics(rng, speed=float(rng.normal(speed, 0.03)))
        bouts.append({"start_s": i * slot + 1.0, "end_s": i * slot + min(slot - 1.0, 20.0), **m})
    summary = {
        k: float(np.mean([b[k] for b in bouts])) if bouts else None for k in GAIT_JSON_FIELDS
    }
    events = [
        {"side": side, "type": "heel_strike", "time_s": b["start_s"] + 0.5 * j}
        for b in bouts
        for j, side in enumerate(("left", "right"))
    ]
    return {
        "bouts": bouts,
        "events": events,
        "summary": summary,
        "transfers": transfers or [],
        "falls": falls or [],
        "risk": {"level": "low", "reasons": []},
    }


def populate(
    session: Session,
    rng: np.random.Generator,
    *,
    n_residents: int = 100,
    days: int = 730,
    bouts_per_day: int = 4,
    end_day: dt.date | None = None,
    rule: BaselineRule | None = None,
    progress: bool = True,
) -> list[int]:
    """Bulk-fill residents with ``days`` of daily recordings, bouts and aggregates.

    Much faster than ingesting recording by recording; aggregates and baselines are computed
    with the same functions as ingest. Speeds drift slowly per resident. Commits.

    Returns
    -------
    list of int
        The new residents' ids.
    """
    end_day = end_day or dt.datetime.now(dt.UTC).date()
    first = end_day - dt.timedelta(days=days - 1)
    rule = rule or BaselineRule()
    ids: list[int] = []
    for r_i in tqdm(range(n_residents), desc="residents", disable=not progress):
        res = Resident(display_name=f"Synthetic {r_i + 1}", height_m=1.6 + 0.2 * rng.random())
        session.add(res)
        session.flush()
        ids.append(res.id)
        base_speed = rng.uniform(0.8, 1.3)
        drift = rng.normal(0, 0.1)
        recs = []
        for d in range(days):
            day = first + dt.timedelta(days=d)
            t0 = dt.datetime.combine(day, dt.time(9, 0), tzinfo=dt.UTC)
            recs.append(
                {
                    "resident_id": res.id,
                    "sha256": f"{res.id:016x}{d:016x}".ljust(64, "0"),
                    "pose_log_path": None,
                    "started_at": t0,
                    "ended_at": t0 + dt.timedelta(hours=8),
                    "duration_s": 8 * 3600.0,
                    "summary": {},
                    "ingested_at": t0,
                }
            )
        session.execute(Recording.__table__.insert(), recs)
        rec_ids = dict(
            session.execute(
                Recording.__table__.select()
                .with_only_columns(Recording.sha256, Recording.id)
                .where(Recording.resident_id == res.id)
            ).all()
        )
        n = days * bouts_per_day
        day_idx = np.repeat(np.arange(days), bouts_per_day)
        trend = base_speed + drift * day_idx / max(days, 1)
        values = {k: rng.normal(m, s, n) for k, (m, s) in TYPICAL.items()}
        values["walking_speed_m_s"] = trend + rng.normal(0, 0.06, n)
        bouts = []
        for i in range(n):
            d = int(day_idx[i])
            day = first + dt.timedelta(days=d)
            s = dt.datetime.combine(day, dt.time(9, 0), tzinfo=dt.UTC) + dt.timedelta(
                minutes=30 * (i % bouts_per_day)
            )
            bouts.append(
                {
                    "recording_id": rec_ids[recs[d]["sha256"]],
                    "resident_id": res.id,
                    "day": day,
                    "started_at": s,
                    "ended_at": s + dt.timedelta(seconds=20),
                    "start_s": 1800.0 * (i % bouts_per_day),
                    "end_s": 1800.0 * (i % bouts_per_day) + 20,
                    "extra": {},
                    **{k: float(values[k][i]) for k in BOUT_METRICS},
                }
            )
        session.execute(Bout.__table__.insert(), bouts)
        keys = day_idx + first.toordinal()
        aggs = []
        for period in PERIODS:
            pkeys = bucket_start(keys, period)
            for metric in BOUT_METRICS:
                uniq, med, q1, q3, cnt = grouped_quantiles(pkeys, values[metric])
                aggs.extend(
                    {
                        "resident_id": res.id,
                        "metric": metric,
                        "period": period,
                        "start": dt.date.fromordinal(int(k)),
                        "median": float(a),
                        "q1": float(b),
                        "q3": float(c),
                        "count": int(e),
                    }
                    for k, a, b, c, e in zip(uniq, med, q1, q3, cnt, strict=True)
                )
        session.execute(Aggregate.__table__.insert(), aggs)
        update_baselines(session, res.id, rule)
        session.commit()
    return ids
