"""Consistent copies of the database while the service runs.

SQLite: the sqlite3 online backup API, which copies a consistent snapshot page by page while
other connections keep reading and writing. Other databases have their own tools (``pg_dump``
for PostgreSQL); asking for a backup of one is a clear error.
"""

from __future__ import annotations

import logging
import sqlite3
from pathlib import Path

from sqlalchemy import Engine

from gaitwatch.errors import InputError
from service.db.session import sqlite_path

log = logging.getLogger(__name__)


class BackupError(InputError):
    """A backup that cannot be made (wrong database kind, existing target...)."""


def backup_database(url: str, out: Path, *, overwrite: bool = False) -> Path:
    """Back up the database at ``url`` (SQLite only; other URLs get a clear error)."""
    if sqlite_path(url) is None:
        raise BackupError(
            f"database {_safe(url)}: `gaitwatch db backup` copies SQLite files only; back up "
            "this database with its own tool (e.g. pg_dump for PostgreSQL)"
        )
    from service.db.session import make_engine

    engine = make_engine(url, pool_size=1)
    try:
        return backup_sqlite(engine, out, overwrite=overwrite)
    finally:
        engine.dispose()


def _safe(url: str) -> str:
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True)
    except Exception:
        return "(unparsable URL)"


def backup_sqlite(engine: Engine, out: Path, *, overwrite: bool = False) -> Path:
    """Copy the SQLite database behind ``engine`` to ``out`` (a consistent snapshot).

    Parameters
    ----------
    engine : Engine
        Engine of a SQLite file database.
    out : Path
        Target file; its folder is created. Written to a temporary name and renamed, so a
        failed backup never leaves a half-written file under ``out``.
    overwrite : bool
        Replace an existing ``out``.

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    BackupError
        Not a SQLite file database, or ``out`` exists (without ``overwrite``) or is the
        database itself.
    """
    url = engine.url.render_as_string(hide_password=False)
    src_path = sqlite_path(url)
    if src_path is None:
        raise BackupError(
            f"database {engine.url.render_as_string(hide_password=True)}: `gaitwatch db backup` "
            "copies SQLite files only; back up this database with its own tool "
            "(e.g. pg_dump for PostgreSQL)"
        )
    if not src_path.is_file():
        raise BackupError(f"database file {src_path} does not exist")
    out = Path(out)
    if out.resolve() == src_path.resolve():
        raise BackupError(f"backup target {out} is the database itself")
    if out.exists() and not overwrite:
        raise BackupError(f"backup target {out} already exists (choose another name)")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".partial")
    tmp.unlink(missing_ok=True)
    src = sqlite3.connect(src_path, timeout=30)
    try:
        dst = sqlite3.connect(tmp)
        try:
            src.backup(dst, pages=1024)
        finally:
            dst.close()
    finally:
        src.close()
    tmp.replace(out)
    log.info("backup of %s written to %s", src_path, out)
    return out
