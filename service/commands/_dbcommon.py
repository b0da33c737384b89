"""Shared plumbing of the database commands: settings, an engine with the schema checked."""

from __future__ import annotations

import argparse
import getpass
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # heavy imports wait until a command runs (keeps `gaitwatch --help` fast)
    from sqlalchemy.orm import Session

    from service.config import Settings


def add_db_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--db",
        metavar="URL",
        help="SQLAlchemy database URL (default: $GAITWATCH_DATABASE_URL or the SQLite file in "
        "the data folder)",
    )


def settings_from(args: argparse.Namespace, **extra: object) -> Settings:
    from service.config import load_settings

    return load_settings(database_url=getattr(args, "db", None), **extra)


def cli_actor() -> str:
    """How the audit log names the person at the command line."""
    try:
        return f"cli:{getpass.getuser()}"
    except Exception:  # no user name in some containers
        return "cli"


@contextmanager
def open_session(settings: Settings) -> Iterator[Session]:
    """A session on the configured database, after checking its schema is current."""
    from service.db.migrate import require_current_schema
    from service.db.session import make_engine, make_sessionmaker

    engine = make_engine(settings.db_url, pool_size=2)
    try:
        require_current_schema(engine)
        with make_sessionmaker(engine)() as session:
            yield session
    finally:
        engine.dispose()
