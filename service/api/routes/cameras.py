"""``/cameras``: the cameras of the residents' homes and their status."""

from __future__ import annotations

import datetime as dt

from fastapi import APIRouter, status
from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError

from service.api.deps import (
    AdminDep,
    ItemId,
    PageDep,
    PrincipalDep,
    SessionDep,
    SettingsDep,
)
from service.api.errors import ApiError, not_found, responses
from service.api.schemas import CameraCreate, CameraOut, CameraUpdate, PageOut
from service.api.security import Principal
from service.db import audit
from service.db.models import Camera, Resident, utcnow

router = APIRouter(prefix="/cameras", tags=["cameras"])


def camera_status(cam: Camera, offline_after_s: float, now: dt.datetime | None = None) -> str:
    """``disabled``, ``unknown`` (never heard from), ``online`` or ``offline``."""
    if not cam.enabled:
        return "disabled"
    if cam.last_seen_at is None:
        return "unknown"
    now = now or utcnow()
    return "online" if (now - cam.last_seen_at).total_seconds() <= offline_after_s else "offline"


def _dict(cam: Camera, offline_after_s: float) -> dict:  # type: ignore[type-arg]
    return {
        "id": cam.id,
        "name": cam.name,
        "resident_id": cam.resident_id,
        "location": cam.location,
        "enabled": cam.enabled,
        "last_seen_at": cam.last_seen_at,
        "status": camera_status(cam, offline_after_s),
    }


def _visible(session, principal: Principal, camera_id: int) -> Camera:  # type: ignore[no-untyped-def]
    cam = session.get(Camera, camera_id)
    if cam is None or not (
        principal.is_admin or (cam.resident_id is not None and principal.may_see(cam.resident_id))
    ):
        raise not_found(f"camera {camera_id}")
    return cam


@router.get("", response_model=PageOut[CameraOut], responses=responses(401, 422))
def list_cameras(
    session: SessionDep, principal: PrincipalDep, page: PageDep, settings: SettingsDep
):
    """Cameras of the residents this key may see (every camera for admin keys)."""
    q = select(Camera)
    if not principal.is_admin:
        q = q.where(Camera.resident_id.in_(principal.resident_ids or {-1}))
    total = session.scalar(select(func.count()).select_from(q.subquery()))
    cams = session.scalars(q.order_by(Camera.id).limit(page.limit).offset(page.offset)).all()
    items = [_dict(c, settings.camera_offline_after_s) for c in cams]
    return {"items": items, "total": total, "limit": page.limit, "offset": page.offset}


@router.get("/{camera_id}", response_model=CameraOut, responses=responses(401, 404, 422))
def get_camera(
    camera_id: ItemId, session: SessionDep, principal: PrincipalDep, settings: SettingsDep
):
    """One camera and its status."""
    return _dict(_visible(session, principal, camera_id), settings.camera_offline_after_s)


def _check_resident(session, resident_id: int | None) -> None:  # type: ignore[no-untyped-def]
    if resident_id is not None and session.get(Resident, resident_id) is None:
        raise ApiError(422, f"body.resident_id: no resident {resident_id}")


@router.post(
    "",
    response_model=CameraOut,
    status_code=status.HTTP_201_CREATED,
    responses=responses(401, 403, 409, 422),
)
def create_camera(
    body: CameraCreate, session: SessionDep, principal: AdminDep, settings: SettingsDep
):
    """Register a camera (admin keys only). Names are unique."""
    _check_resident(session, body.resident_id)
    cam = Camera(**body.model_dump())
    session.add(cam)
    try:
        session.flush()
    except IntegrityError:
        session.rollback()
        raise ApiError(409, f"a camera named {body.name!r} already exists") from None
    audit.record(
        session,
        actor=principal.actor,
        action="create",
        target=f"camera:{cam.id}",
        resident_id=cam.resident_id,
    )
    session.commit()
    return _dict(cam, settings.camera_offline_after_s)


@router.patch("/{camera_id}", response_model=CameraOut, responses=responses(401, 403, 404, 422))
def update_camera(
    camera_id: ItemId,
    body: CameraUpdate,
    session: SessionDep,
    principal: AdminDep,
    settings: SettingsDep,
):
    """Assign a camera to a resident, move or disable it (admin keys only)."""
    cam = _visible(session, principal, camera_id)
    changes = body.model_dump(exclude_unset=True)
    if "enabled" in changes and changes["enabled"] is None:
        raise ApiError(422, "body.enabled: may not be null")
    _check_resident(session, changes.get("resident_id"))
    for k, v in changes.items():
        setattr(cam, k, v)
    audit.record(
        session,
        actor=principal.actor,
        action="update",
        target=f"camera:{cam.id}",
        resident_id=cam.resident_id,
    )
    session.commit()
    return _dict(cam, settings.camera_offline_after_s)


@router.post(
    "/{camera_id}/heartbeat", response_model=CameraOut, responses=responses(401, 403, 404, 422)
)
def camera_heartbeat(
    camera_id: ItemId, session: SessionDep, principal: AdminDep, settings: SettingsDep
):
    """The capture process reports the camera alive (admin keys: the capture service's key)."""
    cam = _visible(session, principal, camera_id)
    cam.last_seen_at = utcnow()
    session.commit()
    return _dict(cam, settings.camera_offline_after_s)
