"""Typed dependencies: each route states what it needs in its signature.

``SessionDep`` (a database session), ``PrincipalDep`` (any valid key), ``AdminDep`` (an admin
key), ``SettingsDep``; plus ``visible_resident`` which answers 404 for residents that do not
exist *or* are not assigned to a caregiver key, so a caregiver cannot even learn they exist.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Annotated

from fastapi import Depends, Path, Query, Request
from fastapi.security import APIKeyHeader, HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy import select
from sqlalchemy.orm import Session

from service.api.errors import ApiError, forbidden, not_found
from service.api.security import Principal, authenticate
from service.config import Settings
from service.db.audit import AuditBuffer
from service.db.models import Resident

MAX_ID = 2**62
_bearer = HTTPBearer(auto_error=False, description="`Authorization: Bearer gw_...`")
_header = APIKeyHeader(name="X-API-Key", auto_error=False, description="`X-API-Key: gw_...`")


# Cheap dependencies are ``async def`` on purpose: FastAPI runs plain ``def`` dependencies in
# the thread pool, and a thread hop per dependency costs more than the work itself. Database
# work in them is a short indexed read (in WAL mode readers never wait for writers).


async def get_settings(request: Request) -> Settings:
    return request.app.state.settings


async def get_session(request: Request) -> AsyncIterator[Session]:
    """A session per request, closed (rolled back if uncommitted) afterwards."""
    session = request.app.state.sessionmaker()
    try:
        yield session
    finally:
        session.close()


async def get_audit(request: Request) -> AuditBuffer:
    """The app's read-audit buffer (``service.db.audit.AuditBuffer``)."""
    return request.app.state.audit


SettingsDep = Annotated[Settings, Depends(get_settings)]
AuditDep = Annotated[AuditBuffer, Depends(get_audit)]
SessionDep = Annotated[Session, Depends(get_session)]


async def get_principal(
    request: Request,
    bearer: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
    header: Annotated[str | None, Depends(_header)],
) -> Principal:
    """The caller behind the presented API key; 401 when there is none or it is not valid."""
    token = header or (bearer.credentials if bearer else None)
    if not token:
        raise ApiError(
            401,
            "an API key is required (Authorization: Bearer <key> or X-API-Key)",
            headers={"WWW-Authenticate": "Bearer"},
        )
    principal = None
    if len(token) <= 200:
        with request.app.state.auth_sessionmaker() as session:
            principal = authenticate(session, token)
    if principal is None:
        raise ApiError(401, "invalid or revoked API key", headers={"WWW-Authenticate": "Bearer"})
    return principal


PrincipalDep = Annotated[Principal, Depends(get_principal)]


async def require_admin(principal: PrincipalDep) -> Principal:
    """403 unless the key is an admin key."""
    if not principal.is_admin:
        raise forbidden("this needs an admin key")
    return principal


AdminDep = Annotated[Principal, Depends(require_admin)]

ResidentId = Annotated[int, Path(ge=1, le=MAX_ID, description="Resident id.", examples=[1])]
ItemId = Annotated[int, Path(ge=1, le=MAX_ID, description="Item id.")]


def visible_resident(session: Session, principal: Principal, resident_id: int) -> Resident:
    """The resident, or 404 if unknown or not assigned to this caregiver key."""
    if not principal.may_see(resident_id):
        raise not_found(f"resident {resident_id}")
    resident = session.get(Resident, resident_id)
    if resident is None:
        raise not_found(f"resident {resident_id}")
    return resident


def check_resident(session: Session, principal: Principal, resident_id: int) -> None:
    """Like :func:`visible_resident` without loading the row (one indexed lookup)."""
    if (
        not principal.may_see(resident_id)
        or session.scalar(select(Resident.id).where(Resident.id == resident_id)) is None
    ):
        raise not_found(f"resident {resident_id}")


class Page:
    """``limit`` / ``offset`` of a list request."""

    def __init__(self, limit: int, offset: int) -> None:
        self.limit = limit
        self.offset = offset


async def get_page(
    request: Request,
    limit: Annotated[int, Query(ge=1, le=2**31, description="Items per page (capped).")] = 50,
    offset: Annotated[int, Query(ge=0, le=MAX_ID, description="Items to skip.")] = 0,
) -> Page:
    """``limit`` / ``offset`` query parameters, ``limit`` capped by the settings (422 above)."""
    cap = request.app.state.settings.max_page_size
    if limit > cap:
        raise ApiError(422, f"query.limit: at most {cap} items per page (asked for {limit})")
    return Page(limit, offset)


PageDep = Annotated[Page, Depends(get_page)]
