"""Right to erasure: delete a resident with every measurement and their pose-log files.

What remains is one audit entry (``action="erase"``, the resident's id, counts, no health
data) plus the earlier audit entries, which name only ids. Cameras stay (they belong to the
home) but lose their link to the resident.

Pose-log files are deleted only when their content still has the SHA-256 recorded at ingest, so
a path that was changed or points at an unrelated file is never deleted (it is reported).
"""

from __future__ import annotations

import hashlib
import logging
from dataclasses import dataclass, field
from pathlib import Path

from sqlalchemy import delete, select, update
from sqlalchemy.orm import Session

from gaitwatch.errors import InputError
from service.db import audit
from service.db.models import (
    Aggregate,
    Alert,
    Baseline,
    Bout,
    Camera,
    Fall,
    Recording,
    Resident,
    Transfer,
    api_key_residents,
    recording_cameras,
)

log = logging.getLogger(__name__)


class ResidentNotFoundError(InputError):
    """No resident with that id."""


@dataclass
class ErasureReport:
    """What an erasure removed."""

    resident_id: int
    rows: dict[str, int] = field(default_factory=dict)
    files_deleted: list[str] = field(default_factory=list)
    files_missing: list[str] = field(default_factory=list)
    files_kept: list[str] = field(default_factory=list)


def file_sha256(path: Path, chunk: int = 1 << 20) -> str:
    """SHA-256 hex digest of a file's content."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            h.update(block)
    return h.hexdigest()


def erase_resident(session: Session, resident_id: int, *, actor: str) -> ErasureReport:
    """Erase ``resident_id``: rows first (committed), then the pose-log files.

    Parameters
    ----------
    session : Session
        A session with no pending work; this function commits.
    resident_id : int
    actor : str
        Who asked, for the audit entry.

    Returns
    -------
    ErasureReport

    Raises
    ------
    ResidentNotFoundError
        No such resident (nothing changes).
    """
    if session.get(Resident, resident_id) is None:
        raise ResidentNotFoundError(f"no resident {resident_id}")
    files = session.execute(
        select(Recording.pose_log_path, Recording.sha256).where(
            Recording.resident_id == resident_id
        )
    ).all()
    rec_ids = select(Recording.id).where(Recording.resident_id == resident_id)
    report = ErasureReport(resident_id=resident_id)
    try:
        steps = [
            ("bouts", delete(Bout).where(Bout.resident_id == resident_id)),
            ("transfers", delete(Transfer).where(Transfer.resident_id == resident_id)),
            ("falls", delete(Fall).where(Fall.resident_id == resident_id)),
            (
                "aggregates",
                delete(Aggregate).where(Aggregate.resident_id == resident_id),
            ),
            ("baselines", delete(Baseline).where(Baseline.resident_id == resident_id)),
            ("alerts", delete(Alert).where(Alert.resident_id == resident_id)),
            (
                "recording_cameras",
                delete(recording_cameras).where(recording_cameras.c.recording_id.in_(rec_ids)),
            ),
            ("recordings", delete(Recording).where(Recording.resident_id == resident_id)),
            (
                "api_key_assignments",
                delete(api_key_residents).where(api_key_residents.c.resident_id == resident_id),
            ),
        ]
        for name, stmt in steps:
            report.rows[name] = session.execute(stmt).rowcount or 0
        session.execute(
            update(Camera).where(Camera.resident_id == resident_id).values(resident_id=None)
        )
        report.rows["residents"] = (
            session.execute(delete(Resident).where(Resident.id == resident_id)).rowcount or 0
        )
        audit.record(
            session,
            actor=actor,
            action="erase",
            target=f"resident:{resident_id}",
            resident_id=resident_id,
            detail=", ".join(f"{k}={v}" for k, v in report.rows.items()),
        )
        session.commit()
    except Exception:
        session.rollback()
        raise
    session.expunge_all()
    for path_s, digest in files:
        if not path_s:
            continue
        path = Path(path_s)
        if not path.is_file():
            report.files_missing.append(path_s)
            continue
        try:
            if file_sha256(path) != digest:
                log.warning("pose log %s does not match its recorded hash: not deleted", path)
                report.files_kept.append(path_s)
                continue
            path.unlink()
            report.files_deleted.append(path_s)
        except OSError as err:
            log.error("could not delete pose log %s: %s", path, err)
            report.files_kept.append(path_s)
    return report
