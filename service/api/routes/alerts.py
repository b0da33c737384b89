"""``/alerts``: list and filter, acknowledge and resolve with a note."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request
from sqlalchemy import func, select

from service.api.deps import MAX_ID, AuditDep, ItemId, PageDep, PrincipalDep, SessionDep
from service.api.errors import ApiError, not_found, responses
from service.api.schemas import AlertAction, AlertOut, AlertStateName, PageOut
from service.api.security import Principal
from service.db import alerts as alert_states
from service.db import audit
from service.db.models import Alert, Resident

router = APIRouter(prefix="/alerts", tags=["alerts"])


@router.get("", response_model=PageOut[AlertOut], responses=responses(401, 404, 422))
def list_alerts(
    session: SessionDep,
    principal: PrincipalDep,
    page: PageDep,
    request: Request,
    audit_log: AuditDep,
    state: Annotated[AlertStateName | None, Query(description="Only this state.")] = None,
    resident_id: Annotated[
        int | None, Query(ge=1, le=MAX_ID, description="Only this resident.")
    ] = None,
    kind: Annotated[str | None, Query(pattern="^[a-z][a-z0-9_]{0,39}$", examples=["fall"])] = None,
):
    """Alerts of the residents this key may see, newest first."""
    q = select(Alert)
    if resident_id is not None:
        if not principal.may_see(resident_id) or session.get(Resident, resident_id) is None:
            raise not_found(f"resident {resident_id}")
        q = q.where(Alert.resident_id == resident_id)
    elif not principal.is_admin:
        q = q.where(Alert.resident_id.in_(principal.resident_ids or {-1}))
    if state is not None:
        q = q.where(Alert.state == state)
    if kind is not None:
        q = q.where(Alert.kind == kind)
    total = session.scalar(select(func.count()).select_from(q.subquery()))
    items = session.scalars(
        q.order_by(Alert.raised_at.desc(), Alert.id.desc()).limit(page.limit).offset(page.offset)
    ).all()
    audit_log.add(
        actor=principal.actor,
        action="list",
        target=str(request.url)[:300],
        resident_id=resident_id,
    )
    return {"items": items, "total": total, "limit": page.limit, "offset": page.offset}


def _visible_alert(session, principal: Principal, alert_id: int) -> Alert:  # type: ignore[no-untyped-def]
    a = session.get(Alert, alert_id)
    if a is None or not principal.may_see(a.resident_id):
        raise not_found(f"alert {alert_id}")
    return a


@router.get("/{alert_id}", response_model=AlertOut, responses=responses(401, 404, 422))
def get_alert(alert_id: ItemId, session: SessionDep, principal: PrincipalDep, audit_log: AuditDep):
    """One alert."""
    a = _visible_alert(session, principal, alert_id)
    audit_log.add(
        actor=principal.actor,
        action="read",
        target=f"alert:{a.id}",
        resident_id=a.resident_id,
    )
    return a


def _act(action: str, alert_id: int, body: AlertAction | None, session, principal: Principal):  # type: ignore[no-untyped-def]
    a = _visible_alert(session, principal, alert_id)
    try:
        alert_states.apply(a, action, who=principal.actor, note=body.note if body else None)
    except alert_states.AlertTransitionError as err:
        raise ApiError(409, str(err)) from None
    audit.record(
        session,
        actor=principal.actor,
        action=action,
        target=f"alert:{a.id}",
        resident_id=a.resident_id,
    )
    session.commit()
    return a


@router.post(
    "/{alert_id}/acknowledge", response_model=AlertOut, responses=responses(401, 404, 409, 422)
)
def acknowledge_alert(
    alert_id: ItemId, session: SessionDep, principal: PrincipalDep, body: AlertAction | None = None
):
    """Open -> acknowledged: someone is looking into it."""
    return _act("acknowledge", alert_id, body, session, principal)


@router.post(
    "/{alert_id}/resolve", response_model=AlertOut, responses=responses(401, 404, 409, 422)
)
def resolve_alert(
    alert_id: ItemId, session: SessionDep, principal: PrincipalDep, body: AlertAction | None = None
):
    """Open or acknowledged -> resolved, with a note of what was done."""
    return _act("resolve", alert_id, body, session, principal)
