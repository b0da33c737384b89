"""Schema versions: Alembic driven from code, the start-up check, upgrade after a backup.

The Alembic configuration is built programmatically (no ``alembic.ini``) with
``script_location`` at the ``migrations`` package, so this works from an installed package.
"""

from __future__ import annotations

import datetime as dt
import logging
from dataclasses import dataclass
from pathlib import Path

from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import Engine

import migrations
from gaitwatch.errors import InputError
from service.db.backup import backup_sqlite
from service.db.session import make_engine, sqlite_path

log = logging.getLogger(__name__)
# Alembic announces its context on every connection at INFO; keep the CLI output readable.
logging.getLogger("alembic.runtime.migration").setLevel(logging.WARNING)

# ``__path__`` works for a regular package and for a (stale editable-install) namespace one.
MIGRATIONS_DIR = Path(next(iter(migrations.__path__))).resolve()


class SchemaOutOfDateError(InputError):
    """The database schema is not the one this version of gaitwatch needs."""


def alembic_config(url: str) -> Config:
    """An Alembic ``Config`` for the database at ``url`` and the packaged migrations."""
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    # ConfigParser interpolation: a literal % in a URL (encoded password) must be doubled.
    cfg.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    return cfg


def head_revision() -> str:
    """The newest migration shipped with this package."""
    head = ScriptDirectory(str(MIGRATIONS_DIR)).get_current_head()
    assert head is not None
    return head


def current_revision(engine: Engine) -> str | None:
    """The revision the database is at (None for an empty database)."""
    with engine.connect() as conn:
        return MigrationContext.configure(conn).get_current_revision()


@dataclass(frozen=True)
class SchemaStatus:
    """Where the database stands compared with the code."""

    current: str | None
    head: str

    @property
    def up_to_date(self) -> bool:
        return self.current == self.head


def schema_status(engine: Engine) -> SchemaStatus:
    """Current and wanted revision of the database behind ``engine``."""
    return SchemaStatus(current_revision(engine), head_revision())


def require_current_schema(engine: Engine) -> None:
    """Refuse to go on unless the schema is at the head revision.

    Raises
    ------
    SchemaOutOfDateError
        With the revisions and the two ways out (``gaitwatch db upgrade`` or ``--upgrade``).
    """
    st = schema_status(engine)
    if st.up_to_date:
        return
    where = "empty (no schema)" if st.current is None else f"at revision {st.current}"
    raise SchemaOutOfDateError(
        f"database {engine.url.render_as_string(hide_password=True)} is {where}, but this "
        f"gaitwatch needs revision {st.head}; run `gaitwatch db upgrade` (a backup copy is made "
        "first) or start the service with --upgrade (GAITWATCH_AUTO_UPGRADE=1)"
    )


def upgrade(url: str, *, backup_dir: Path | None = None, revision: str = "head") -> Path | None:
    """Upgrade the database at ``url`` to ``revision``, copying a SQLite file first.

    Parameters
    ----------
    url : str
        SQLAlchemy URL.
    backup_dir : Path, optional
        Where the pre-upgrade copy goes (default: beside the database file).
    revision : str
        Target revision.

    Returns
    -------
    Path or None
        The backup copy, when one was made (a SQLite file that already existed).
    """
    path = sqlite_path(url)
    existed = path is not None and path.is_file() and path.stat().st_size > 0
    engine = make_engine(url, pool_size=1)
    try:
        st = schema_status(engine)
        if st.current == st.head and revision == "head":
            log.info("database already at revision %s", st.head)
            return None
        copy = None
        if path is not None and existed:
            stamp = dt.datetime.now(dt.UTC).strftime("%Y%m%dT%H%M%S.%fZ")
            folder = backup_dir or path.parent
            copy = folder / f"{path.stem}.pre-upgrade-{st.current or 'empty'}-{stamp}{path.suffix}"
            backup_sqlite(engine, copy)
            log.info("backup of %s written to %s", path, copy)
        with engine.begin() as conn:
            cfg = alembic_config(url)
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, revision)
        log.info("database upgraded from %s to %s", st.current, revision)
        return copy
    finally:
        engine.dispose()
