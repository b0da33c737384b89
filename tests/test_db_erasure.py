"""Right to erasure and consistent backups."""

from __future__ import annotations

import datetime as dt
import hashlib
import sqlite3
import threading
from pathlib import Path

import pytest
from sqlalchemy import func, select

from service.db.backup import BackupError, backup_database, backup_sqlite
from service.db.ingest import ingest
from service.db.models import (
    AuditEntry,
    Base,
    Camera,
    Resident,
)
from service.db.session import make_engine
from tests.service_helpers import *  # noqa: F403  (fixtures)
from tests.service_helpers import T0, World, recording, result


def _poselog(tmp: Path, name: str, content: bytes) -> tuple[Path, str]:
    p = tmp / name
    p.write_bytes(content)
    return p, hashlib.sha256(content).hexdigest()


def _rows_of(world: World, resident_id: int) -> dict[str, list[tuple]]:
    with world.sessions() as s:
        return {
            t.name: sorted(
                map(tuple, s.execute(select(t).where(t.c.resident_id == resident_id))), key=repr
            )
            for t in Base.metadata.sorted_tables
            if "resident_id" in t.c and t.name != "audit_log"
        }


def test_delete_resident_erases_measurements_and_pose_logs(world: World, tmp_path: Path):
    keep, keep_hash = _poselog(tmp_path, "other.mcap", b"resident two")
    mine, mine_hash = _poselog(tmp_path, "mine.mcap", b"resident one")
    swapped, _ = _poselog(tmp_path, "swapped.mcap", b"changed after ingest")
    with world.sessions() as s:
        for n, (path, digest) in enumerate(
            [(mine, mine_hash), (swapped, "ab" * 32), (tmp_path / "gone.mcap", "cd" * 32)]
        ):
            info = recording(world.r1, n, start=T0 + dt.timedelta(days=n))
            info.update(pose_log_path=str(path), sha256=digest)
            ingest(
                s,
                info,
                result(
                    n,
                    falls=[{"time_s": 3.0}],
                    transfers=[{"type": "tug", "start_s": 1, "duration_s": 15}],
                ),
            )
        info = recording(world.r2, 9)
        info.update(pose_log_path=str(keep), sha256=keep_hash, cameras=["kitchen"])
        ingest(s, info, result(9))
    r2_before = _rows_of(world, world.r2)
    r = world.client.delete(f"/residents/{world.r1}", headers=world.admin)
    assert r.status_code == 200
    rep = r.json()
    assert rep["rows"]["bouts"] == 9 and rep["rows"]["recordings"] == 3
    assert (rep["files_deleted"], rep["files_kept"], rep["files_missing"]) == (1, 1, 1)
    assert not mine.exists() and swapped.exists() and keep.exists()
    # Nothing of resident 1 is left in any table that holds a resident_id, but the audit log.
    with world.sessions() as s:
        for table in Base.metadata.sorted_tables:
            if "resident_id" in table.c and table.name not in ("audit_log", "cameras"):
                n = s.scalar(
                    select(func.count()).select_from(table).where(table.c.resident_id == world.r1)
                )
                assert n == 0, table.name
        assert s.get(Resident, world.r1) is None
        cam = s.scalar(select(Camera).where(Camera.name == "living-room"))
        assert cam.resident_id is None  # the camera stays with the home
        erase = s.scalars(select(AuditEntry).where(AuditEntry.action == "erase")).all()
        assert len(erase) == 1 and erase[0].resident_id == world.r1
        assert "Resident One" not in (erase[0].detail or "")
    # Resident 2 untouched.
    assert r2_before["bouts"] and _rows_of(world, world.r2) == r2_before
    assert world.client.get(f"/residents/{world.r1}", headers=world.admin).status_code == 404
    assert world.client.delete(f"/residents/{world.r1}", headers=world.admin).status_code == 404
    # The caregiver key of resident 1 now sees nothing.
    assert world.client.get("/residents", headers=world.care_a).json()["total"] == 0


@pytest.mark.sqlite_only
def test_backup_is_consistent_while_writing(world: World, tmp_path: Path) -> None:
    engine = world.client.app.state.engine
    stop = threading.Event()
    errors: list[Exception] = []

    def writer() -> None:
        n = 100
        try:
            while not stop.is_set():
                with world.sessions() as s:
                    ingest(
                        s,
                        recording(world.r1, n, start=T0 + dt.timedelta(hours=n)),
                        result(n, n_bouts=2),
                    )
                n += 1
        except Exception as err:  # pragma: no cover - reported below
            errors.append(err)

    t = threading.Thread(target=writer)
    t.start()
    try:
        outs = [backup_sqlite(engine, tmp_path / f"copy{i}.sqlite3") for i in range(3)]
    finally:
        stop.set()
        t.join()
    assert not errors
    for out in outs:
        con = sqlite3.connect(out)
        assert con.execute("PRAGMA integrity_check").fetchone() == ("ok",)
        n_rec, n_bouts = con.execute(
            "SELECT (SELECT count(*) FROM recordings), (SELECT count(*) FROM bouts)"
        ).fetchone()
        assert n_bouts == 2 * n_rec  # never half an ingest
        con.close()


@pytest.mark.sqlite_only
def test_backup_refuses_bad_targets(world: World, tmp_path: Path) -> None:
    engine = world.client.app.state.engine
    out = backup_sqlite(engine, tmp_path / "b.sqlite3")
    with pytest.raises(BackupError, match="already exists"):
        backup_sqlite(engine, out)
    db_file = Path(engine.url.database)
    with pytest.raises(BackupError, match="is the database itself"):
        backup_sqlite(engine, db_file, overwrite=True)
    with pytest.raises(BackupError, match="pg_dump"):
        backup_database("postgresql://u:secret@db/gw", tmp_path / "pg.sqlite3")
    mem = make_engine("sqlite://")
    with pytest.raises(BackupError, match="SQLite files only"):
        backup_sqlite(mem, tmp_path / "m.sqlite3")
