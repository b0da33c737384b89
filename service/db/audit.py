"""The audit log: who read or changed which resident's data.

Changes are audited with :func:`record`, in the caller's session, so a change and its audit
entry are committed together or not at all.

Reads are audited through an :class:`AuditBuffer`: entries are queued and written by one
background thread in small batches (at most ``flush_interval_s`` later), so a read request
never waits for the database's write lock. Entries still queued when the process is killed
hard (not on a normal shutdown, which flushes) can be lost; that window is at most
``flush_interval_s``.
"""

from __future__ import annotations

import logging
import queue
import threading
from typing import Any

from sqlalchemy import insert
from sqlalchemy.orm import Session, sessionmaker

from service.db.models import AuditEntry, utcnow

log = logging.getLogger(__name__)


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
        ``read``, ``list``, ``create``, ``update``, ``erase``, ``ingest``, ``acknowledge``...
    target : str
        What was touched (an API path or an object name); truncated to 300 characters.
    resident_id : int, optional
        The resident whose data it was (kept after the resident is erased).
    detail : str, optional
        Free text without health data.
    """
    entry = AuditEntry(**_row(actor, action, target, resident_id, detail))
    session.add(entry)
    return entry


def _row(
    actor: str, action: str, target: str, resident_id: int | None, detail: str | None
) -> dict[str, Any]:
    return {
        "at": utcnow(),
        "actor": actor[:120],
        "action": action[:40],
        "target": target[:300],
        "resident_id": resident_id,
        "detail": detail,
    }


class AuditBuffer:
    """Queue of read-audit entries written in batches by a background thread.

    Parameters
    ----------
    sessions : sessionmaker
        Where to write.
    flush_interval_s : float
        Longest time an entry waits in the queue.
    """

    def __init__(self, sessions: sessionmaker[Session], flush_interval_s: float = 0.5) -> None:
        self._sessions = sessions
        self._interval = flush_interval_s
        self._queue: queue.SimpleQueue[dict[str, Any] | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    def add(
        self,
        *,
        actor: str,
        action: str,
        target: str,
        resident_id: int | None = None,
        detail: str | None = None,
    ) -> None:
        """Queue one entry (time-stamped now); starts the writer thread on first use."""
        self._queue.put(_row(actor, action, target, resident_id, detail))
        if self._thread is None:
            with self._lock:
                if self._thread is None:
                    self._thread = threading.Thread(
                        target=self._run, name="gaitwatch-audit", daemon=True
                    )
                    self._thread.start()

    def flush(self) -> int:
        """Write every queued entry now; returns how many were written."""
        rows: list[dict[str, Any]] = []
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item is not None:
                rows.append(item)
        if rows:
            try:
                with self._sessions() as s:
                    s.execute(insert(AuditEntry), rows)
                    s.commit()
            except Exception:
                log.exception("could not write %d audit entries", len(rows))
                for r in rows:  # keep them for the next attempt
                    self._queue.put(r)
                return 0
        return len(rows)

    def close(self) -> None:
        """Stop the writer thread and write what is left."""
        self._stop.set()
        self._queue.put(None)
        if self._thread is not None:
            self._thread.join(timeout=10)
        self.flush()

    def _run(self) -> None:
        while not self._stop.wait(self._interval):
            self.flush()
