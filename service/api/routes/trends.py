"""``/residents/{id}/trends``: a metric over time with the personal baseline."""

from __future__ import annotations

import datetime as dt
from typing import Annotated

from fastapi import APIRouter, Query, Response
from fastapi.concurrency import run_in_threadpool
from sqlalchemy import select

from service.api.deps import (
    AuditDep,
    PrincipalDep,
    ResidentId,
    SessionDep,
    SettingsDep,
    check_resident,
)
from service.api.errors import ApiError, responses
from service.api.schemas import BaselineOut, Bucket, Metric, TrendOut, TrendPoint
from service.db.baselines import BaselineRule
from service.db.models import Baseline
from service.db.trends import trend, unit_of

router = APIRouter(tags=["trends"])

MAX_SPAN_DAYS = 3700


@router.get(
    "/residents/{resident_id}/trends",
    response_model=TrendOut,
    response_model_by_alias=True,
    responses=responses(401, 404, 422),
)
async def get_trend(
    resident_id: ResidentId,
    session: SessionDep,
    principal: PrincipalDep,
    settings: SettingsDep,
    audit_log: AuditDep,
    metric: Annotated[Metric, Query(description="Gait metric.")] = "walking_speed_m_s",
    from_: Annotated[
        dt.date | None, Query(alias="from", description="First day (default: `to` - 89 days).")
    ] = None,
    to: Annotated[dt.date | None, Query(description="Last day (default: today, UTC).")] = None,
    bucket: Annotated[Bucket, Query(description="Bucket size.")] = "day",
):
    """Median, quartiles and count of ``metric`` per bucket, each with the personal baseline
    in effect at the bucket's start and the change from it."""
    to = to or dt.datetime.now(dt.UTC).date()
    from_ = from_ or to - dt.timedelta(days=89)
    if from_ > to:
        raise ApiError(422, "query.from: must not be after `to`")
    if (to - from_).days > MAX_SPAN_DAYS:
        raise ApiError(422, f"query.from: at most {MAX_SPAN_DAYS} days per request")
    rule = BaselineRule(
        settings.baseline_window_days, settings.baseline_gap_days, settings.baseline_min_days
    )
    # All database work in one thread-pool hop; the model is validated once and serialised
    # here (returning a Response skips FastAPI's second validation of the same data).
    out = await run_in_threadpool(
        _trend, session, principal, audit_log, resident_id, metric, from_, to, bucket, rule
    )
    return Response(out.model_dump_json(by_alias=True), media_type="application/json")


def _trend(session, principal, audit_log, resident_id, metric, from_, to, bucket, rule) -> TrendOut:  # type: ignore[no-untyped-def]
    try:
        check_resident(session, principal, resident_id)
        points = trend(session, resident_id, metric, from_, to, bucket, rule)
        base = session.execute(
            select(
                Baseline.value,
                Baseline.q1,
                Baseline.q3,
                Baseline.n_days,
                Baseline.window_start,
                Baseline.window_end,
            ).where(Baseline.resident_id == resident_id, Baseline.metric == metric)
        ).first()
    finally:
        session.close()  # give the connection back in this thread, not later on the loop
    audit_log.add(
        actor=principal.actor,
        action="read",
        target=f"trends:{metric}:{bucket}:{from_}:{to}",
        resident_id=resident_id,
    )
    return TrendOut(
        resident_id=resident_id,
        metric=metric,
        unit=unit_of(metric),
        bucket=bucket,
        **{"from": from_},
        to=to,
        baseline=BaselineOut(**base._mapping) if base is not None else None,
        points=[TrendPoint(**p.__dict__) for p in points],
    )
