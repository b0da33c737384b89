"""Residents, trends, measurements, alerts, cameras, health and metrics through the real app."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from sqlalchemy import select

from service.db.ingest import ingest
from service.db.models import AuditEntry, Camera
from tests.service_helpers import *  # noqa: F403  (fixtures)
from tests.service_helpers import T0, World, recording, result


def test_resident_create_read_update_list(world: World) -> None:
    c, h = world.client, world.admin
    r = c.post(
        "/residents",
        json={"display_name": "  Mrs P  ", "height_m": 1.58, "timezone": "Europe/Paris"},
        headers=h,
    )
    assert r.status_code == 201
    new = r.json()
    assert new["display_name"] == "Mrs P" and new["timezone"] == "Europe/Paris"
    got = c.get(f"/residents/{new['id']}", headers=h).json()
    assert got == new
    upd = c.patch(f"/residents/{new['id']}", json={"height_m": 1.6}, headers=h).json()
    assert upd["height_m"] == 1.6 and upd["display_name"] == "Mrs P"
    page = c.get("/residents?limit=2&offset=1", headers=h).json()
    assert page["total"] == 3 and page["limit"] == 2 and len(page["items"]) == 2
    assert [x["id"] for x in page["items"]] == [world.r2, new["id"]]
    assert world.client.app.state.audit.flush() >= 2  # reads are audited in batches
    with world.sessions() as s:
        actions = [(e.action, e.resident_id) for e in s.scalars(select(AuditEntry))]
    assert ("create", new["id"]) in actions and ("update", new["id"]) in actions
    assert ("read", new["id"]) in actions and ("list", None) in actions


def test_trends_day_week_month_with_baseline(world: World) -> None:
    speeds: dict[dt.date, list[float]] = {}
    start = dt.datetime(2026, 1, 1, 10, tzinfo=dt.UTC)
    with world.sessions() as s:
        for d in range(70):
            res = result(d, n_bouts=3, speed=1.2 if d < 60 else 0.95)
            day = (start + dt.timedelta(days=d)).date()
            speeds[day] = [b["walking_speed_m_s"] for b in res["bouts"]]
            ingest(s, recording(world.r1, d, start=start + dt.timedelta(days=d)), res)
    c, h = world.client, world.care_a
    q = f"/residents/{world.r1}/trends?metric=walking_speed_m_s&from=2026-01-01&to=2026-03-11"
    day = c.get(q + "&bucket=day", headers=h).json()
    assert day["unit"] == "m/s" and day["from"] == "2026-01-01" and len(day["points"]) == 70
    p = day["points"][65]
    vals = speeds[dt.date.fromisoformat(p["start"])]
    assert p["median"] == pytest.approx(np.median(vals)) and p["count"] == 3
    assert p["q1"] == pytest.approx(np.percentile(vals, 25))
    # baseline: median of daily medians over [D-63, D-7): days 3..57 of the data -> ~1.2
    assert p["baseline"] == pytest.approx(1.2, abs=0.03)
    assert p["change_pct"] == pytest.approx(100 * (p["median"] - p["baseline"]) / p["baseline"])
    assert day["points"][0]["baseline"] is None  # no history yet
    assert day["baseline"]["n_days"] >= 7

    week = c.get(q + "&bucket=week", headers=h).json()
    first = week["points"][0]  # 2026-01-01 is a Thursday: its ISO week starts on 29 December
    assert first["start"] == "2025-12-29" and first["end"] == "2026-01-04"
    pooled = [v for d, vs in speeds.items() if d <= dt.date(2026, 1, 4) for v in vs]
    assert first["count"] == 12 and first["median"] == pytest.approx(np.median(pooled))
    assert first["q3"] == pytest.approx(np.percentile(pooled, 75))
    assert week["points"][1]["start"] == "2026-01-05"  # Monday
    assert len(week["points"]) == 11

    assert world.client.app.state.audit.flush() >= 2  # trend reads are audited in batches
    with world.sessions() as s:
        reads = s.scalars(
            select(AuditEntry).where(
                AuditEntry.action == "read", AuditEntry.resident_id == world.r1
            )
        ).all()
    assert any(e.target.startswith("trends:walking_speed_m_s:week") for e in reads)
    assert all(e.actor.endswith("carer a") for e in reads)

    month = c.get(q + "&bucket=month", headers=h).json()
    assert [m["start"] for m in month["points"]] == ["2026-01-01", "2026-02-01", "2026-03-01"]
    assert [m["count"] for m in month["points"]] == [93, 84, 33]
    assert month["points"][2]["change_pct"] < -10  # the decline shows against the baseline


def test_bouts_filter_and_paginate(world: World) -> None:
    with world.sessions() as s:
        for d in range(5):
            ingest(
                s,
                recording(world.r1, d, start=T0 + dt.timedelta(days=d)),
                result(d, n_bouts=4, speed=0.9 + 0.1 * d),
            )
    c, h = world.client, world.admin
    all_ = c.get(f"/residents/{world.r1}/bouts?limit=500", headers=h).json()
    assert all_["total"] == 20
    times = [b["started_at"] for b in all_["items"]]
    assert times == sorted(times, reverse=True)
    fast = c.get(f"/residents/{world.r1}/bouts?min_speed=1.15", headers=h).json()
    assert fast["total"] == sum(b["walking_speed_m_s"] >= 1.15 for b in all_["items"])
    span = c.get(
        f"/residents/{world.r1}/bouts?from=2026-03-03T00:00:00Z&to=2026-03-05T00:00:00Z"
        "&order=asc&limit=3&offset=2",
        headers=h,
    ).json()
    assert span["total"] == 8 and len(span["items"]) == 3
    assert span["items"][0]["started_at"].startswith("2026-03-03")


def test_transfers_falls_and_alert_lifecycle(world: World) -> None:
    res = result(
        1,
        transfers=[{"type": "sit_to_stand", "start_s": 3, "end_s": 5.5}],
        falls=[{"time_s": 200.0, "lie_duration_s": 90.0}],
    )
    with world.sessions() as s:
        ingest(s, recording(world.r1), res)
    c, h = world.client, world.care_a
    tr = c.get(f"/residents/{world.r1}/transfers?kind=sit_to_stand", headers=h).json()
    assert tr["total"] == 1 and tr["items"][0]["duration_s"] == pytest.approx(2.5)
    falls = c.get(f"/residents/{world.r1}/falls?long_lie=true", headers=h).json()
    assert falls["total"] == 1 and falls["items"][0]["lie_duration_s"] == 90.0
    alerts = c.get("/alerts?state=open&kind=fall", headers=h).json()
    assert alerts["total"] == 1
    aid = alerts["items"][0]["id"]
    ack = c.post(f"/alerts/{aid}/acknowledge", json={"note": "on my way"}, headers=h).json()
    assert ack["state"] == "acknowledged" and ack["acknowledge_note"] == "on my way"
    assert ack["acknowledged_by"].endswith("carer a") and ack["acknowledged_at"]
    again = c.post(f"/alerts/{aid}/acknowledge", headers=h)
    assert again.status_code == 409 and again.json()["error"]["code"] == "conflict"
    done = c.post(f"/alerts/{aid}/resolve", json={"note": "bruise only"}, headers=h).json()
    assert done["state"] == "resolved" and done["resolve_note"] == "bruise only"
    assert c.post(f"/alerts/{aid}/resolve", headers=h).status_code == 409
    assert c.get("/alerts?state=open", headers=h).json()["total"] == 0
    assert c.get("/alerts?state=resolved", headers=h).json()["total"] == 1


def test_cameras_and_their_status(world: World) -> None:
    c, h = world.client, world.admin
    cam = c.post(
        "/cameras", json={"name": "hall", "resident_id": world.r1, "location": "hall"}, headers=h
    )
    assert cam.status_code == 201 and cam.json()["status"] == "unknown"
    cid = cam.json()["id"]
    assert c.post("/cameras", json={"name": "hall"}, headers=h).status_code == 409
    assert c.post(f"/cameras/{cid}/heartbeat", headers=h).json()["status"] == "online"
    with world.sessions() as s:
        s.get(Camera, cid).last_seen_at = dt.datetime.now(dt.UTC) - dt.timedelta(hours=2)
        s.commit()
    assert c.get(f"/cameras/{cid}", headers=world.care_a).json()["status"] == "offline"
    assert c.get(f"/cameras/{cid}", headers=world.care_b).status_code == 404
    off = c.patch(f"/cameras/{cid}", json={"enabled": False}, headers=h).json()
    assert off["status"] == "disabled"


def test_ingest_through_the_api_and_metrics(world: World) -> None:
    c, h = world.client, world.admin
    body = {
        "recording": {k: v for k, v in recording(world.r2).items() if k != "resident_id"},
        "result": result(3),
    }
    body["recording"]["started_at"] = T0.isoformat()
    body["recording"]["pose_log_path"] = "2026/03/poses.mcap"
    first = c.post(f"/residents/{world.r2}/recordings", json=body, headers=h)
    assert first.status_code == 201 and first.json()["created"]
    second = c.post(f"/residents/{world.r2}/recordings", json=body, headers=h)
    assert second.status_code == 200 and not second.json()["created"]
    recs = c.get(f"/residents/{world.r2}/recordings", headers=h).json()
    assert recs["total"] == 1 and recs["items"][0]["camera_names"] == ["living-room"]
    text = c.get("/metrics", headers=h).text
    assert 'gaitwatch_ingest_total{outcome="created"} 1' in text
    assert 'gaitwatch_ingest_total{outcome="duplicate"} 1' in text
    assert 'route="/residents/{resident_id}/recordings",status="201"} 1' in text
    assert "gaitwatch_http_request_duration_seconds_bucket" in text
    assert "gaitwatch_recordings 1" in text


def test_healthz_reports_unreachable_database(world: World) -> None:
    assert world.client.get("/healthz").json() == {
        "status": "ok",
        "database": "ok",
        "schema_revision": "0001",
    }
    world.client.app.state.engine.dispose()
    world.client.app.state.engine = _broken_engine()
    r = world.client.get("/healthz")
    assert r.status_code == 503 and r.json()["database"] == "unreachable"


def _broken_engine():
    from sqlalchemy import create_engine

    return create_engine("sqlite:////nonexistent-dir/for/sure/db.sqlite3")


def test_openapi_documents_errors_and_examples(world: World) -> None:
    spec = world.client.get("/openapi.json", headers=world.care_a).json()
    trends = spec["paths"]["/residents/{resident_id}/trends"]["get"]
    assert {"401", "404", "422"} <= set(trends["responses"])
    schemas = spec["components"]["schemas"]
    assert "ErrorBody" in schemas and "examples" in schemas["ResidentCreate"]
    params = {p["name"] for p in trends["parameters"]}
    assert {"metric", "from", "to", "bucket"} <= params


def test_public_docs_setting_serves_the_schema_without_a_key(tmp_path) -> None:
    from fastapi.testclient import TestClient

    from service.api.app import create_app
    from service.config import Settings
    from service.db.migrate import upgrade

    url = f"sqlite:///{tmp_path / 'db.sqlite3'}"
    upgrade(url)
    app = create_app(Settings(database_url=url, data_dir=tmp_path, public_docs=True))
    with TestClient(app) as client:
        assert client.get("/openapi.json").status_code == 200
        assert client.get("/docs").status_code == 200
        assert client.get("/residents").status_code == 401
