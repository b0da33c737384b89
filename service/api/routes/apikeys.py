"""``/api-keys``: create, list and revoke API keys (admin keys only)."""

from __future__ import annotations

from fastapi import APIRouter, status
from sqlalchemy import func, select
from sqlalchemy.orm import selectinload

from service.api.deps import AdminDep, ItemId, PageDep, SessionDep
from service.api.errors import ApiError, not_found, responses
from service.api.schemas import ApiKeyCreate, ApiKeyCreated, ApiKeyOut, PageOut
from service.api.security import ApiKeyError, create_api_key, revoke_api_key
from service.db import audit
from service.db.models import ApiKey

router = APIRouter(prefix="/api-keys", tags=["api keys"])


def _out(key: ApiKey) -> dict:  # type: ignore[type-arg]
    return {
        "id": key.id,
        "name": key.name,
        "role": key.role,
        "prefix": key.prefix,
        "created_at": key.created_at,
        "revoked_at": key.revoked_at,
        "resident_ids": sorted(r.id for r in key.residents),
    }


@router.get("", response_model=PageOut[ApiKeyOut], responses=responses(401, 403, 422))
def list_keys(session: SessionDep, principal: AdminDep, page: PageDep):
    """Every key (never the key itself, which is not stored)."""
    total = session.scalar(select(func.count(ApiKey.id)))
    keys = session.scalars(
        select(ApiKey)
        .options(selectinload(ApiKey.residents))
        .order_by(ApiKey.id)
        .limit(page.limit)
        .offset(page.offset)
    ).all()
    return {
        "items": [_out(k) for k in keys],
        "total": total,
        "limit": page.limit,
        "offset": page.offset,
    }


@router.post(
    "",
    response_model=ApiKeyCreated,
    status_code=status.HTTP_201_CREATED,
    responses=responses(401, 403, 422),
)
def create_key(body: ApiKeyCreate, session: SessionDep, principal: AdminDep):
    """Create a key; the answer holds the key itself, shown this once."""
    try:
        key, token = create_api_key(
            session, name=body.name, role=body.role, resident_ids=body.resident_ids
        )
    except ApiKeyError as err:
        session.rollback()
        raise ApiError(422, str(err)) from None
    audit.record(
        session,
        actor=principal.actor,
        action="apikey_create",
        target=f"api_key:{key.id}",
        detail=f"role={key.role} residents={sorted(body.resident_ids)}",
    )
    session.commit()
    return {**_out(key), "key": token}


@router.delete("/{key_id}", response_model=ApiKeyOut, responses=responses(401, 403, 404, 422))
def revoke_key(key_id: ItemId, session: SessionDep, principal: AdminDep):
    """Revoke a key: it stops working at once."""
    try:
        key = revoke_api_key(session, key_id)
    except ApiKeyError:
        raise not_found(f"API key {key_id}") from None
    audit.record(session, actor=principal.actor, action="apikey_revoke", target=f"api_key:{key.id}")
    session.commit()
    return _out(key)
