"""The audit log: who read or changed which resident's data.

Entries are added to the caller's session and committed with the change they describe, so a
change and its audit entry are stored together or not at all.
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from service.db.models import AuditEntry


def record(
    session: Session,
    *,
    actor: str,
    action: str,
    target: str,
    resident_id: int | None = None,
    detail: str | None = None,
) -> AuditEntry:
    """Add an audit entry to ``session`` (the caller commits).

    Parameters
    ----------
    actor : str
        Who: ``"key:<id>:<name>"`` for an API key, ``"cli:<user>"`` for the command line.
    action : str
        ``read``, ``create``, ``update``, ``erase``, ``ingest``, ``acknowledge``, ``resolve``...
    target : str
        What was touched (an API path or an object name); truncated to 300 characters.
    resident_id : int, optional
        The resident whose data it was (kept after the resident is erased).
    detail : str, optional
        Free text without health data.
    """
    entry = AuditEntry(
        actor=actor[:120],
        action=action[:40],
        target=target[:300],
        resident_id=resident_id,
        detail=detail,
    )
    session.add(entry)
    return entry
