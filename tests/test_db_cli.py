"""The database commands: db upgrade/current/backup, resident, apikey, ingest, serve refusal."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from service.api.security import authenticate
from service.cli import main
from service.db.session import make_engine, make_sessionmaker
from service.db.synthetic import fake_gait_result


@pytest.fixture
def db(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.setenv("GAITWATCH_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.delenv("GAITWATCH_DATABASE_URL", raising=False)
    return f"sqlite:///{tmp_path / 'gw.sqlite3'}"


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_schema_commands_and_serve_refusal(db: str, capsys) -> None:
    code, out, _ = run(capsys, "db", "current", "--db", db)
    assert code == 1 and "OUT OF DATE" in out
    code, _, err = run(capsys, "serve", "--db", db, "--port", "1")
    assert code == 2
    assert err.startswith("gaitwatch: error: ") and "gaitwatch db upgrade" in err
    assert len(err.strip().splitlines()) == 1
    code, out, _ = run(capsys, "db", "upgrade", "--db", db)
    assert code == 0 and "schema at revision 0001" in out
    code, out, _ = run(capsys, "db", "current", "--db", db)
    assert code == 0 and "up to date" in out


def test_keys_residents_ingest_backup(db: str, tmp_path: Path, capsys) -> None:
    assert run(capsys, "db", "upgrade", "--db", db)[0] == 0
    code, out, _ = run(capsys, "resident", "add", "Mr T", "--height", "1.8", "--db", db)
    rid = int(out.strip())
    code, out, _ = run(
        capsys,
        "apikey",
        "create",
        "--role",
        "caregiver",
        "--resident",
        str(rid),
        "--name",
        "day nurse",
        "--db",
        db,
    )
    token = out.splitlines()[0]
    assert code == 0 and token.startswith("gw_")
    engine = make_engine(db, pool_size=1)
    try:
        with make_sessionmaker(engine)() as s:
            p = authenticate(s, token)
            assert p is not None and p.role == "caregiver" and p.resident_ids == {rid}
    finally:
        engine.dispose()
    code, _, err = run(
        capsys, "apikey", "create", "--role", "caregiver", "--resident", "77", "--db", db
    )
    assert code == 2 and "no resident with id 77" in err
    code, _, err = run(
        capsys, "apikey", "create", "--role", "admin", "--resident", str(rid), "--db", db
    )
    assert code == 2 and "admin key" in err
    code, out, _ = run(capsys, "apikey", "list", "--db", db)
    assert "day nurse" in out and token not in out and token[3:11] in out
    assert run(capsys, "apikey", "revoke", "1", "--db", db)[0] == 0
    assert "revoked" in run(capsys, "apikey", "list", "--db", db)[1]

    res = tmp_path / "result.json"
    res.write_text(json.dumps(fake_gait_result(np.random.default_rng(0))))
    log = tmp_path / "poses.mcap"
    log.write_bytes(b"pretend mcap")
    args = [
        "ingest",
        str(res),
        "--resident",
        str(rid),
        "--poselog",
        str(log),
        "--start",
        "2026-03-02T09:00:00+01:00",
        "--duration",
        "600",
        "--camera",
        "hall",
        "--db",
        db,
    ]
    code, out, _ = run(capsys, *args)
    assert code == 0 and "3 bouts" in out
    code, out, _ = run(capsys, *args)
    assert code == 0 and "already stored" in out
    bad = tmp_path / "bad.json"
    bad.write_text('{"bouts": [], "events": []}')
    code, _, err = run(capsys, "ingest", str(bad), *args[2:])
    assert code == 2 and "summary" in err

    out_file = tmp_path / "backup.sqlite3"
    assert run(capsys, "db", "backup", str(out_file), "--db", db)[0] == 0
    con = sqlite3.connect(out_file)
    assert con.execute("SELECT count(*) FROM bouts").fetchone() == (3,)
    con.close()
    code, _, err = run(capsys, "db", "backup", str(out_file), "--db", db)
    assert code == 2 and "already exists" in err
    code, _, err = run(capsys, "db", "backup", "x.sqlite3", "--db", "postgresql://u@h/d")
    assert code == 2 and "pg_dump" in err

    code, _, err = run(capsys, "resident", "erase", str(rid), "--db", db)
    assert code == 2 and "--yes" in err
    code, out, _ = run(capsys, "resident", "erase", str(rid), "--yes", "--db", db)
    assert code == 0 and "pose logs deleted 1" in out and not log.exists()


def test_serve_answers_on_loopback_and_stops(db: str, tmp_path: Path) -> None:
    import os
    import socket
    import subprocess
    import sys
    import time

    import httpx

    assert main(["db", "upgrade", "--db", db]) == 0
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "service.cli",
            "-q",
            "serve",
            "--db",
            db,
            "--port",
            str(port),
            "--log-level",
            "warning",
        ],
        env={**os.environ, "GAITWATCH_DATA_DIR": str(tmp_path / "data")},
    )
    try:
        deadline = time.monotonic() + 60
        while True:
            assert proc.poll() is None, "server exited"
            try:
                r = httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1)
                break
            except httpx.HTTPError:
                assert time.monotonic() < deadline, "server did not answer"
                time.sleep(0.2)
        assert r.json()["database"] == "ok"
        assert httpx.get(f"http://127.0.0.1:{port}/residents").status_code == 401
    finally:
        proc.terminate()
        proc.wait(timeout=20)
