"""API keys: creation, hashing, lookup; the caller's identity and role.

A key looks like ``gw_<prefix>_<secret>``: 8 random characters of prefix (stored in clear, for
lookup) and 32 bytes of random secret. Only the SHA-256 of the whole key is stored; the key is
shown once, at creation. Keys carry far more entropy than passwords, so a fast hash is the
right choice (a slow password hash would only add latency to every request).

Roles: ``admin`` sees and manages everything; ``caregiver`` sees only the residents assigned to
its key and may acknowledge and resolve their alerts.
"""

from __future__ import annotations

import hashlib
import hmac
import re
import secrets
from collections.abc import Iterable
from dataclasses import dataclass

from sqlalchemy import select
from sqlalchemy.orm import Session

from gaitwatch.errors import InputError
from service.db.models import ApiKey, Resident, Role, api_key_residents, utcnow

KEY_RE = re.compile(r"^gw_([A-Za-z0-9]{8})_([A-Za-z0-9_-]{20,100})$")


class ApiKeyError(InputError):
    """A key request that cannot be fulfilled (bad role, unknown resident, unknown key)."""


def hash_key(token: str) -> str:
    """SHA-256 hex digest of a whole API key."""
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def generate_key() -> tuple[str, str]:
    """A new random key and its prefix: ``(token, prefix)``."""
    alphabet = "ABCDEFGHJKLMNPQRSTUVWXYZabcdefghijkmnopqrstuvwxyz23456789"
    prefix = "".join(secrets.choice(alphabet) for _ in range(8))
    return f"gw_{prefix}_{secrets.token_urlsafe(32)}", prefix


@dataclass(frozen=True)
class Principal:
    """Who is calling: the key's id, name and role, and (caregivers) the residents it may see."""

    key_id: int
    name: str
    role: Role
    resident_ids: frozenset[int]

    @property
    def is_admin(self) -> bool:
        return self.role is Role.admin

    @property
    def actor(self) -> str:
        """How the audit log names this caller."""
        return f"key:{self.key_id}:{self.name}"

    def may_see(self, resident_id: int) -> bool:
        """Admins see every resident; caregivers their assigned ones."""
        return self.is_admin or resident_id in self.resident_ids


def authenticate(session: Session, token: str) -> Principal | None:
    """The principal of a presented key, or None when it is malformed, unknown or revoked."""
    m = KEY_RE.match(token.strip())
    if m is None:
        return None
    row = session.execute(
        select(ApiKey.id, ApiKey.key_hash, ApiKey.name, ApiKey.role, ApiKey.revoked_at).where(
            ApiKey.prefix == m.group(1)
        )
    ).first()
    if row is None or row.revoked_at is not None:
        return None
    if not hmac.compare_digest(row.key_hash, hash_key(token.strip())):
        return None
    role = Role(row.role)
    ids: frozenset[int] = frozenset()
    if role is Role.caregiver:
        ids = frozenset(
            session.scalars(
                select(api_key_residents.c.resident_id).where(
                    api_key_residents.c.api_key_id == row.id
                )
            )
        )
    return Principal(key_id=row.id, name=row.name, role=role, resident_ids=ids)


def create_api_key(
    session: Session, *, name: str, role: str, resident_ids: Iterable[int] = ()
) -> tuple[ApiKey, str]:
    """Create a key (caller commits). Returns the stored row and the key, shown only once.

    Raises
    ------
    ApiKeyError
        Unknown role, an admin key with residents, or an unknown resident id.
    """
    try:
        r = Role(role)
    except ValueError:
        raise ApiKeyError(f"role must be admin or caregiver, not {role!r}") from None
    ids = sorted(set(resident_ids))
    if r is Role.admin and ids:
        raise ApiKeyError("an admin key sees every resident: do not pass --resident")
    name = name.strip()
    if not name or len(name) > 120:
        raise ApiKeyError("key name must be 1 to 120 characters")
    residents = list(session.scalars(select(Resident).where(Resident.id.in_(ids)))) if ids else []
    missing = sorted(set(ids) - {x.id for x in residents})
    if missing:
        raise ApiKeyError(f"resident: no resident with id {', '.join(map(str, missing))}")
    while True:
        token, prefix = generate_key()
        if session.scalar(select(ApiKey.id).where(ApiKey.prefix == prefix)) is None:
            break
    key = ApiKey(prefix=prefix, key_hash=hash_key(token), name=name, role=r.value)
    key.residents = residents
    session.add(key)
    session.flush()
    return key, token


def revoke_api_key(session: Session, key_id: int) -> ApiKey:
    """Mark a key revoked (caller commits). Raises :class:`ApiKeyError` for an unknown id."""
    key = session.get(ApiKey, key_id)
    if key is None:
        raise ApiKeyError(f"no API key with id {key_id}")
    if key.revoked_at is None:
        key.revoked_at = utcnow()
    return key
