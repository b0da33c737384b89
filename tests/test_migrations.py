"""Migrations: from empty to head, models and migrations agree, start-up refusal and upgrade."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext
from sqlalchemy import inspect

from service.api.app import create_app
from service.config import Settings
from service.db.migrate import (
    SchemaOutOfDateError,
    alembic_config,
    current_revision,
    head_revision,
    upgrade,
)
from service.db.models import Base
from service.db.session import make_engine
from tests.service_helpers import *  # noqa: F403  (fixtures)
from tests.service_helpers import postgres_url


def test_upgrade_from_empty_matches_models(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'db.sqlite3'}"
    assert upgrade(url) is None  # a new file: nothing to back up
    engine = make_engine(url, pool_size=1)
    try:
        assert current_revision(engine) == head_revision()
        tables = set(inspect(engine).get_table_names())
        assert set(Base.metadata.tables) <= tables
        with engine.connect() as conn:
            diff = compare_metadata(
                MigrationContext.configure(conn, opts={"compare_type": True}), Base.metadata
            )
            mode = conn.exec_driver_sql("PRAGMA journal_mode").scalar()
            fks = conn.exec_driver_sql("PRAGMA foreign_keys").scalar()
        assert diff == [], f"models and migrations differ: {diff}"
        assert mode == "wal" and fks == 1
    finally:
        engine.dispose()


def test_downgrade_to_base_and_up_again(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'db.sqlite3'}"
    upgrade(url)
    command.downgrade(alembic_config(url), "base")
    engine = make_engine(url, pool_size=1)
    try:
        assert current_revision(engine) is None
        assert set(inspect(engine).get_table_names()) <= {"alembic_version"}
    finally:
        engine.dispose()
    backup = upgrade(url, backup_dir=tmp_path / "backups")
    assert backup is not None and backup.is_file()  # an existing file is copied first
    engine = make_engine(url, pool_size=1)
    try:
        assert current_revision(engine) == head_revision()
    finally:
        engine.dispose()


def test_service_refuses_out_of_date_schema(tmp_path: Path) -> None:
    db = tmp_path / "old.sqlite3"
    con = sqlite3.connect(db)
    con.execute("CREATE TABLE keepme (x INTEGER)")
    con.execute("INSERT INTO keepme VALUES (42)")
    con.commit()
    con.close()
    settings = Settings(data_dir=tmp_path, database_url=f"sqlite:///{db}")
    with pytest.raises(SchemaOutOfDateError, match=r"gaitwatch db upgrade.*--upgrade"):
        create_app(settings)
    # Refusing changed nothing.
    con = sqlite3.connect(db)
    assert con.execute("SELECT x FROM keepme").fetchall() == [(42,)]
    assert con.execute(
        "SELECT count(*) FROM sqlite_master WHERE name='alembic_version'"
    ).fetchone() == (0,)
    con.close()


def test_auto_upgrade_backs_up_then_upgrades(tmp_path: Path) -> None:
    db = tmp_path / "old.sqlite3"
    con = sqlite3.connect(db)
    con.execute("CREATE TABLE keepme (x INTEGER)")
    con.execute("INSERT INTO keepme VALUES (7)")
    con.commit()
    con.close()
    settings = Settings(data_dir=tmp_path, database_url=f"sqlite:///{db}", auto_upgrade=True)
    app = create_app(settings)
    try:
        assert current_revision(app.state.engine) == head_revision()
    finally:
        app.state.engine.dispose()
    copies = list(settings.backup_dir.glob("old.pre-upgrade-*.sqlite3"))
    assert len(copies) == 1
    con = sqlite3.connect(copies[0])
    assert con.execute("SELECT x FROM keepme").fetchall() == [(7,)]
    assert con.execute("SELECT count(*) FROM sqlite_master WHERE name='residents'").fetchone() == (
        0,
    )
    con.close()


def test_offline_sql_names_no_sqlite_only_features(tmp_path: Path, capsys) -> None:
    """The migration renders for PostgreSQL too (offline mode: SQL text, no server)."""
    cfg = alembic_config("postgresql://user@localhost/gaitwatch")
    command.upgrade(cfg, "head", sql=True)
    sql = capsys.readouterr().out
    assert "CREATE TABLE residents" in sql
    assert "TIMESTAMP WITHOUT TIME ZONE" in sql
    assert "PRAGMA" not in sql and "AUTOINCREMENT" not in sql


@pytest.mark.skipif(
    postgres_url() is None, reason="PostgreSQL only (set GAITWATCH_TEST_POSTGRES_URL)"
)
def test_postgres_schema_matches_models_and_round_trips(db_url: str) -> None:
    """On PostgreSQL: the migrated schema equals the models (types too), and the migration
    goes down to empty and up again."""
    engine = make_engine(db_url, pool_size=1)
    try:
        assert engine.dialect.name == "postgresql"
        assert current_revision(engine) == head_revision()
        with engine.connect() as conn:
            diff = compare_metadata(
                MigrationContext.configure(conn, opts={"compare_type": True}), Base.metadata
            )
        assert diff == [], f"models and migrations differ on PostgreSQL: {diff}"
        command.downgrade(alembic_config(db_url), "base")
        assert set(inspect(engine).get_table_names()) <= {"alembic_version"}
        assert upgrade(db_url) is None  # nothing to back up on a server database
        assert current_revision(engine) == head_revision()
        assert set(Base.metadata.tables) <= set(inspect(engine).get_table_names())
    finally:
        engine.dispose()
