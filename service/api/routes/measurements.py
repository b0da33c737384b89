"""``/residents/{id}/bouts``, ``/transfers``, ``/falls``: measurements, filtered and paged."""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request
from sqlalchemy import Select, func, select
from sqlalchemy.orm import Session

from service.api.deps import PageDep, PrincipalDep, ResidentId, SessionDep, visible_resident
from service.api.errors import ApiError, responses
from service.api.schemas import BoutOut, FallOut, PageOut, TransferOut
from service.api.security import Principal
from service.db.models import Bout, Fall, Transfer

router = APIRouter(tags=["measurements"])

DateFrom = Annotated[dt.datetime | None, Query(alias="from", description="From this time.")]
DateTo = Annotated[dt.datetime | None, Query(description="Before this time.")]
Order = Annotated[str, Query(pattern="^(asc|desc)$", description="By start time.")]


def _aware(t: dt.datetime | None, name: str) -> dt.datetime | None:
    if t is None:
        return None
    if t.tzinfo is None:
        return t.replace(tzinfo=dt.UTC)
    return t.astimezone(dt.UTC)


def _page(
    session: Session,
    principal: Principal,
    request: Request,
    resident_id: int,
    q: Select[Any],
    model: Any,
    page: Any,
    order: str,
) -> dict[str, Any]:
    total = session.scalar(select(func.count()).select_from(q.subquery()))
    col = model.started_at.asc() if order == "asc" else model.started_at.desc()
    items = session.scalars(q.order_by(col, model.id).limit(page.limit).offset(page.offset)).all()
    request.app.state.audit.add(
        actor=principal.actor,
        action="read",
        target=request.url.path,
        resident_id=resident_id,
    )
    return {"items": items, "total": total, "limit": page.limit, "offset": page.offset}


def _span(q: Select[Any], model: Any, start: dt.datetime | None, end: dt.datetime | None):
    start, end = _aware(start, "from"), _aware(end, "to")
    if start and end and start > end:
        raise ApiError(422, "query.from: must not be after `to`")
    if start:
        q = q.where(model.started_at >= start)
    if end:
        q = q.where(model.started_at < end)
    return q


@router.get(
    "/residents/{resident_id}/bouts",
    response_model=PageOut[BoutOut],
    responses=responses(401, 404, 422),
)
def list_bouts(
    resident_id: ResidentId,
    session: SessionDep,
    principal: PrincipalDep,
    page: PageDep,
    request: Request,
    from_: DateFrom = None,
    to: DateTo = None,
    min_speed: Annotated[float | None, Query(ge=0, le=20, description="m/s")] = None,
    max_speed: Annotated[float | None, Query(ge=0, le=20, description="m/s")] = None,
    order: Order = "desc",
):
    """Walking bouts with their gait parameters."""
    visible_resident(session, principal, resident_id)
    q = _span(select(Bout).where(Bout.resident_id == resident_id), Bout, from_, to)
    if min_speed is not None:
        q = q.where(Bout.walking_speed_m_s >= min_speed)
    if max_speed is not None:
        q = q.where(Bout.walking_speed_m_s <= max_speed)
    return _page(session, principal, request, resident_id, q, Bout, page, order)


@router.get(
    "/residents/{resident_id}/transfers",
    response_model=PageOut[TransferOut],
    responses=responses(401, 404, 422),
)
def list_transfers(
    resident_id: ResidentId,
    session: SessionDep,
    principal: PrincipalDep,
    page: PageDep,
    request: Request,
    from_: DateFrom = None,
    to: DateTo = None,
    kind: Annotated[
        str | None, Query(pattern="^[a-z][a-z0-9_]{0,39}$", examples=["sit_to_stand"])
    ] = None,
    order: Order = "desc",
):
    """Transfers (sit-to-stand, stand-to-sit) and timed-up-and-go sequences."""
    visible_resident(session, principal, resident_id)
    q = _span(select(Transfer).where(Transfer.resident_id == resident_id), Transfer, from_, to)
    if kind is not None:
        q = q.where(Transfer.kind == kind)
    return _page(session, principal, request, resident_id, q, Transfer, page, order)


@router.get(
    "/residents/{resident_id}/falls",
    response_model=PageOut[FallOut],
    responses=responses(401, 404, 422),
)
def list_falls(
    resident_id: ResidentId,
    session: SessionDep,
    principal: PrincipalDep,
    page: PageDep,
    request: Request,
    from_: DateFrom = None,
    to: DateTo = None,
    long_lie: Annotated[bool | None, Query(description="Only long lies (or only not).")] = None,
    order: Order = "desc",
):
    """Detected falls."""
    visible_resident(session, principal, resident_id)
    q = _span(select(Fall).where(Fall.resident_id == resident_id), Fall, from_, to)
    if long_lie is not None:
        q = q.where(Fall.long_lie == long_lie)
    return _page(session, principal, request, resident_id, q, Fall, page, order)
