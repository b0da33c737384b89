"""``/residents``: create, read, update, list, and erase (right to erasure)."""

from __future__ import annotations

from fastapi import APIRouter, Request, status
from sqlalchemy import func, select
from sqlalchemy.orm import selectinload

from service.api.deps import (
    AdminDep,
    AuditDep,
    PageDep,
    PrincipalDep,
    ResidentId,
    SessionDep,
    visible_resident,
)
from service.api.errors import ApiError, not_found, responses
from service.api.schemas import (
    ErasureOut,
    PageOut,
    ResidentCreate,
    ResidentOut,
    ResidentUpdate,
)
from service.db import audit
from service.db.erasure import erase_resident
from service.db.models import Resident

router = APIRouter(prefix="/residents", tags=["residents"])


@router.get("", response_model=PageOut[ResidentOut], responses=responses(401, 422))
def list_residents(session: SessionDep, principal: PrincipalDep, page: PageDep, request: Request):
    """Residents this key may see (all for admin keys), by id."""
    q = select(Resident)
    if not principal.is_admin:
        q = q.where(Resident.id.in_(principal.resident_ids or {-1}))
    total = session.scalar(select(func.count()).select_from(q.subquery()))
    items = session.scalars(
        q.options(selectinload(Resident.cameras))
        .order_by(Resident.id)
        .limit(page.limit)
        .offset(page.offset)
    ).all()
    request.app.state.audit.add(actor=principal.actor, action="list", target=request.url.path)
    return {"items": items, "total": total, "limit": page.limit, "offset": page.offset}


@router.post(
    "",
    response_model=ResidentOut,
    status_code=status.HTTP_201_CREATED,
    responses=responses(401, 403, 422),
)
def create_resident(body: ResidentCreate, session: SessionDep, principal: AdminDep):
    """Add a resident (admin keys only)."""
    r = Resident(**body.model_dump())
    r.cameras = []
    session.add(r)
    session.flush()
    audit.record(
        session,
        actor=principal.actor,
        action="create",
        target=f"resident:{r.id}",
        resident_id=r.id,
    )
    session.commit()
    return r


@router.get("/{resident_id}", response_model=ResidentOut, responses=responses(401, 404, 422))
def get_resident(
    resident_id: ResidentId, session: SessionDep, principal: PrincipalDep, audit_log: AuditDep
):
    """One resident with the cameras of their home."""
    r = visible_resident(session, principal, resident_id)
    audit_log.add(
        actor=principal.actor,
        action="read",
        target=f"resident:{r.id}",
        resident_id=r.id,
    )
    return r


@router.patch("/{resident_id}", response_model=ResidentOut, responses=responses(401, 403, 404, 422))
def update_resident(
    resident_id: ResidentId, body: ResidentUpdate, session: SessionDep, principal: AdminDep
):
    """Change a resident's name, height or time zone (admin keys only)."""
    r = session.get(Resident, resident_id)
    if r is None:
        raise not_found(f"resident {resident_id}")
    changes = body.model_dump(exclude_unset=True)
    for k in ("display_name", "timezone"):
        if k in changes and changes[k] is None:
            raise ApiError(422, f"body.{k}: may not be null")
    for k, v in changes.items():
        setattr(r, k, v)
    audit.record(
        session,
        actor=principal.actor,
        action="update",
        target=f"resident:{r.id}",
        resident_id=r.id,
        detail="fields: " + ", ".join(sorted(changes)),
    )
    session.commit()
    return r


@router.delete("/{resident_id}", response_model=ErasureOut, responses=responses(401, 403, 404, 422))
def delete_resident(resident_id: ResidentId, session: SessionDep, principal: AdminDep):
    """Erase a resident: every measurement, alert and pose-log file (admin keys only).

    Only an audit entry remains. Pose-log files whose content no longer matches the hash
    recorded at ingest are not deleted and are counted in ``files_kept``.
    """
    if session.get(Resident, resident_id) is None:
        raise not_found(f"resident {resident_id}")
    rep = erase_resident(session, resident_id, actor=principal.actor)
    return ErasureOut(
        resident_id=resident_id,
        rows=rep.rows,
        files_deleted=len(rep.files_deleted),
        files_missing=len(rep.files_missing),
        files_kept=len(rep.files_kept),
    )
