"""Fixtures and helpers of the storage and API tests (imported by tests/test_db_*, test_api_*).

A migrated SQLite file is built once per session and copied for each test, so each test gets
a real, empty, current database quickly.

With ``GAITWATCH_TEST_POSTGRES_URL`` set to a PostgreSQL server URL whose user may create
databases (e.g. ``postgresql+psycopg://gw@/postgres?host=/tmp/pg&port=55432``), the same tests
run on PostgreSQL instead: the template is a migrated database and each test gets a copy made
with ``CREATE DATABASE ... TEMPLATE``, dropped afterwards (``scripts/test-postgres.sh`` starts a
throw-away server and does this). Tests of SQLite-only features are marked ``sqlite_only`` and
skip there.
"""

from __future__ import annotations

import datetime as dt
import os
import shutil
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, create_engine, make_url, select, text
from sqlalchemy.orm import Session, sessionmaker

from service.api.app import create_app
from service.api.security import create_api_key
from service.config import Settings
from service.db.migrate import upgrade
from service.db.models import Base, Resident
from service.db.session import make_engine, make_sessionmaker
from service.db.synthetic import fake_gait_result

# Fixtures, for ``from tests.service_helpers import *`` in the test modules.
__all__ = [
    "data_dir",
    "db_url",
    "engine",
    "migrated_template",
    "sessions",
    "settings",
    "shared_world",
    "world",
]

T0 = dt.datetime(2026, 3, 2, 9, 0, tzinfo=dt.UTC)


POSTGRES_ENV = "GAITWATCH_TEST_POSTGRES_URL"


def postgres_url() -> str | None:
    """The PostgreSQL server URL the storage tests run on, or None for SQLite."""
    return os.environ.get(POSTGRES_ENV) or None


@dataclass
class Template:
    """A migrated, empty database that each test copies: a SQLite file or a PostgreSQL database."""

    sqlite_path: Path | None = None
    server_url: str | None = None
    name: str = ""

    def url_of(self, database: str) -> str:
        assert self.server_url is not None
        return make_url(self.server_url).set(database=database).render_as_string(False)

    def _admin(self, sql: str) -> None:
        e = create_engine(self.server_url, isolation_level="AUTOCOMMIT")
        try:
            with e.connect() as c:
                c.execute(text(sql))
        finally:
            e.dispose()

    @contextmanager
    def copy(self, data: Path) -> Iterator[str]:
        """A fresh copy for one test: its URL, dropped (PostgreSQL) when the block ends."""
        if self.sqlite_path is not None:
            path = data / "gaitwatch.sqlite3"
            shutil.copy(self.sqlite_path, path)
            yield f"sqlite:///{path}"
            return
        name = f"gw_{uuid.uuid4().hex[:12]}"
        self._admin(f'CREATE DATABASE "{name}" TEMPLATE "{self.name}"')
        try:
            yield self.url_of(name)
        finally:
            self._admin(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@pytest.fixture(scope="session")
def migrated_template(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Template]:
    server = postgres_url()
    if server is None:
        path = tmp_path_factory.mktemp("template") / "template.sqlite3"
        upgrade(f"sqlite:///{path}")
        yield Template(sqlite_path=path)
        return
    tpl = Template(server_url=server, name=f"gw_template_{os.getpid()}")
    tpl._admin(f'DROP DATABASE IF EXISTS "{tpl.name}" WITH (FORCE)')
    tpl._admin(f'CREATE DATABASE "{tpl.name}"')
    try:
        upgrade(tpl.url_of(tpl.name))
        yield tpl
    finally:
        tpl._admin(f'DROP DATABASE IF EXISTS "{tpl.name}" WITH (FORCE)')


@pytest.fixture
def data_dir(tmp_path: Path) -> Path:
    d = tmp_path / "data"
    d.mkdir()
    return d


@pytest.fixture
def db_url(migrated_template: Template, data_dir: Path) -> Iterator[str]:
    with migrated_template.copy(data_dir) as url:
        yield url


@pytest.fixture
def settings(db_url: str, data_dir: Path) -> Settings:
    return Settings(data_dir=data_dir, database_url=db_url)


@pytest.fixture
def engine(db_url: str) -> Iterator[Engine]:
    e = make_engine(db_url, pool_size=2)
    yield e
    e.dispose()


@pytest.fixture
def sessions(engine: Engine) -> sessionmaker[Session]:
    return make_sessionmaker(engine)


@dataclass
class World:
    """Two residents; an admin key; caregiver A sees resident 1, caregiver B resident 2."""

    client: TestClient
    sessions: sessionmaker[Session]
    r1: int
    r2: int
    admin: dict[str, str]
    care_a: dict[str, str]
    care_b: dict[str, str]


def bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


@contextmanager
def build_world(data: Path, template: Template) -> Iterator[World]:
    """A migrated database copied from ``template`` into ``data``, the app, residents, keys."""
    data.mkdir(parents=True, exist_ok=True)
    with template.copy(data) as url:
        yield from _world(Settings(data_dir=data, database_url=url))


def _world(settings: Settings) -> Iterator[World]:
    app = create_app(settings)
    sm = app.state.sessionmaker
    with sm() as s:
        a = Resident(display_name="Resident One", height_m=1.7, timezone="UTC")
        b = Resident(display_name="Resident Two", height_m=1.6, timezone="Europe/Paris")
        s.add_all([a, b])
        s.flush()
        _, admin = create_api_key(s, name="admin", role="admin")
        _, ca = create_api_key(s, name="carer a", role="caregiver", resident_ids=[a.id])
        _, cb = create_api_key(s, name="carer b", role="caregiver", resident_ids=[b.id])
        s.commit()
        r1, r2 = a.id, b.id
    try:
        with TestClient(app) as client:
            yield World(client, sm, r1, r2, bearer(admin), bearer(ca), bearer(cb))
    finally:
        app.state.engine.dispose()


@pytest.fixture
def world(tmp_path: Path, migrated_template: Template) -> Iterator[World]:
    """A fresh world per test (for tests that change data)."""
    with build_world(tmp_path / "world", migrated_template) as w:
        yield w


@pytest.fixture(scope="module")
def shared_world(
    tmp_path_factory: pytest.TempPathFactory, migrated_template: Template
) -> Iterator[World]:
    """One world per test module, for tests that must not change anything."""
    with build_world(tmp_path_factory.mktemp("shared") / "world", migrated_template) as w:
        yield w


def recording(resident_id: int, n: int = 0, *, start: dt.datetime = T0, duration_s: float = 600):
    """Recording info with a distinct hash per ``n``."""
    return {
        "resident_id": resident_id,
        "cameras": ["living-room"],
        "pose_log_path": None,
        "sha256": f"{resident_id:08x}{n:056x}",
        "started_at": start,
        "duration_s": duration_s,
    }


def result(seed: int = 0, **kw: Any) -> dict[str, Any]:
    return fake_gait_result(np.random.default_rng(seed), **kw)


def snapshot(engine: Engine) -> dict[str, list[tuple]]:
    """Every row of every table, for 'nothing stored changed' checks."""
    out: dict[str, list[tuple]] = {}
    with engine.connect() as conn:
        for name, table in sorted(Base.metadata.tables.items()):
            out[name] = sorted(map(tuple, conn.execute(select(table)).all()), key=repr)
    return out


def data_snapshot(engine: Engine) -> dict[str, list[tuple]]:
    """:func:`snapshot` without the audit log (reads are audited, so it grows on purpose)."""
    snap = snapshot(engine)
    snap.pop("audit_log", None)
    return snap
