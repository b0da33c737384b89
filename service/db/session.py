"""Engine and session factory.

SQLite gets WAL journaling, foreign keys, a busy timeout and ``synchronous=NORMAL`` in its
connect hook; that hook is the only SQLite-specific code. Other URLs (PostgreSQL) are used as
they are.
"""

from __future__ import annotations

import logging
from pathlib import Path

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, NoSuchModuleError
from sqlalchemy.orm import Session, sessionmaker

from gaitwatch.errors import InputError

log = logging.getLogger(__name__)


class DatabaseURLError(InputError):
    """A database URL that SQLAlchemy cannot use."""


def sqlite_path(url: str) -> Path | None:
    """The file of a SQLite URL, or None for other databases and in-memory SQLite."""
    u = make_url(url)
    if u.get_backend_name() != "sqlite" or not u.database or u.database == ":memory:":
        return None
    return Path(u.database)


def make_engine(url: str, *, pool_size: int = 20, busy_timeout_ms: int = 10_000) -> Engine:
    """Create an engine for ``url``; for a SQLite file, create its folder and set the pragmas.

    Raises
    ------
    DatabaseURLError
        The URL is malformed or its driver is not installed.
    """
    try:
        u = make_url(url)
    except ArgumentError as err:
        raise DatabaseURLError(f"database URL {url!r}: {err}") from None
    kwargs: dict[str, object] = {}
    is_sqlite = u.get_backend_name() == "sqlite"
    path = sqlite_path(url)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        kwargs.update(pool_size=pool_size, max_overflow=pool_size, pool_timeout=30)
        kwargs["connect_args"] = {"check_same_thread": False, "timeout": busy_timeout_ms / 1000}
    elif not is_sqlite:
        kwargs.update(pool_size=pool_size, max_overflow=pool_size, pool_pre_ping=True)
    try:
        engine = create_engine(u, **kwargs)  # type: ignore[arg-type]
    except (NoSuchModuleError, ModuleNotFoundError, ImportError) as err:
        raise DatabaseURLError(f"database URL {u!r}: driver not available ({err})") from None
    if is_sqlite:
        _install_sqlite_pragmas(engine, busy_timeout_ms, wal=path is not None)
    return engine


def _install_sqlite_pragmas(engine: Engine, busy_timeout_ms: int, *, wal: bool) -> None:
    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_conn, _record):  # type: ignore[no-untyped-def]
        cur = dbapi_conn.cursor()
        try:
            if wal:
                cur.execute("PRAGMA journal_mode=WAL")
                cur.execute("PRAGMA synchronous=NORMAL")
            cur.execute("PRAGMA foreign_keys=ON")
            cur.execute(f"PRAGMA busy_timeout={int(busy_timeout_ms)}")
        finally:
            cur.close()


def make_sessionmaker(engine: Engine) -> sessionmaker[Session]:
    """Session factory; objects stay readable after commit."""
    return sessionmaker(engine, expire_on_commit=False)
