"""Malformed and hostile requests: the right error answer, and nothing stored changes."""

from __future__ import annotations

import pytest

from service.db.ingest import ingest
from tests.service_helpers import *  # noqa: F403  (fixtures)
from tests.service_helpers import World, data_snapshot, recording, result

SQLI = "1; DROP TABLE residents; --"


@pytest.fixture(scope="module")
def filled(shared_world: World) -> World:
    """One world for the module: every test checks that it changes nothing."""
    with shared_world.sessions() as s:
        ingest(s, recording(shared_world.r1), result(1, falls=[{"time_s": 5.0}]))
    return shared_world


def _check(w: World, method: str, path: str, status: int, headers=None, **kw) -> dict:
    engine = w.client.app.state.engine
    before = data_snapshot(engine)
    r = w.client.request(method, path, headers=headers or w.admin, **kw)
    assert r.status_code == status, r.text
    body = r.json()
    assert set(body) == {"error"} and body["error"]["status"] == status
    assert body["error"]["message"]
    assert data_snapshot(engine) == before
    return body["error"]


@pytest.mark.parametrize(
    ("method", "path", "kw", "status"),
    [
        # wrong types
        ("get", "/residents/abc", {}, 422),
        ("get", "/residents/1.5", {}, 422),
        ("get", "/residents/-1", {}, 422),
        ("get", "/residents/99999999999999999999999999", {}, 422),
        ("get", "/residents/1/trends?from=yesterday", {}, 422),
        ("get", "/residents/1/trends?from=2026-02-01&to=2026-01-01", {}, 422),
        ("get", "/residents/1/trends?from=1900-01-01&to=2026-01-01", {}, 422),
        ("get", "/residents/1/trends?bucket=year", {}, 422),
        ("get", "/residents/1/bouts?min_speed=fast", {}, 422),
        ("post", "/residents", {"json": {"display_name": 42, "height_m": "tall"}}, 422),
        ("post", "/residents", {"content": b"{not json", "headers": None}, 422),
        ("post", "/residents", {"json": ["a", "list"]}, 422),
        # huge pages
        ("get", "/residents?limit=100000", {}, 422),
        ("get", "/residents/1/bouts?limit=501", {}, 422),
        ("get", "/residents?offset=-5", {}, 422),
        ("get", "/residents?limit=0", {}, 422),
        ("get", f"/residents?offset={2**70}", {}, 422),
        # SQL-looking strings
        ("get", f"/residents/{SQLI}", {}, 422),
        ("get", f"/residents/1/trends?metric={SQLI}", {}, 422),
        ("get", f"/alerts?state={SQLI}", {}, 422),
        ("get", "/alerts?kind=fall' OR '1'='1", {}, 422),
        ("get", "/residents/1/transfers?kind=x%27%3B--", {}, 422),
        # unknown fields
        ("post", "/residents", {"json": {"display_name": "X", "is_admin": True}}, 422),
        ("patch", "/residents/1", {"json": {"id": 7}}, 422),
        ("post", "/alerts/1/acknowledge", {"json": {"note": "x", "state": "resolved"}}, 422),
        ("post", "/api-keys", {"json": {"name": "k", "role": "root"}}, 422),
        (
            "post",
            "/api-keys",
            {"json": {"name": "k", "role": "caregiver", "resident_ids": [424242]}},
            422,
        ),
        ("patch", "/residents/1", {"json": {"display_name": None}}, 422),
        (
            "post",
            "/residents",
            {"json": {"display_name": "X", "timezone": "../../etc/passwd"}},
            422,
        ),
        # path tricks
        ("get", "/residents/1/../../api-keys", {}, 403),  # client normalises: still gated
        ("get", "/residents/%2e%2e/api-keys", {}, 404),
        ("get", "/residents/1/bouts/..%2f..%2fetc%2fpasswd", {}, 404),
        ("get", "/static/../../etc/passwd", {}, 404),
        ("delete", "/residents", {}, 405),
    ],
)
def test_bad_requests_answer_and_change_nothing(filled: World, method, path, kw, status):
    headers = kw.pop("headers", filled.admin) or {
        **filled.admin,
        "content-type": "application/json",
    }
    if "../../api-keys" in path:
        headers = filled.care_a
    err = _check(filled, method, path, status, headers=headers, **kw)
    if status == 422:
        assert err["code"] == "validation_error"
        assert SQLI not in err["message"]  # rejected input is not echoed back


def test_sql_looking_names_are_stored_as_plain_text(world: World) -> None:
    c, h = world.client, world.admin
    name = "Robert'); DROP TABLE residents;--"
    r = c.post("/residents", json={"display_name": name}, headers=h)
    assert r.status_code == 201
    assert c.get(f"/residents/{r.json()['id']}", headers=h).json()["display_name"] == name
    assert c.get("/residents", headers=h).json()["total"] == 3
    assert c.get("/residents?limit=1&offset=2", headers=h).json()["items"][0]["display_name"] == (
        name
    )


def test_another_caregivers_resident_cannot_be_changed(filled: World) -> None:
    alert = filled.client.get("/alerts", headers=filled.admin).json()["items"][0]
    for method, path, kw in [
        ("post", f"/alerts/{alert['id']}/acknowledge", {"json": {"note": "x"}}),
        ("post", f"/alerts/{alert['id']}/resolve", {"json": {"note": "x"}}),
        ("get", f"/residents/{filled.r1}/bouts", {}),
        ("get", f"/residents/{filled.r1}/trends?bucket=week", {}),
    ]:
        _check(filled, method, path, 404, headers=filled.care_b, **kw)


@pytest.mark.parametrize(
    "recording_patch",
    [
        {"pose_log_path": "../../../etc/passwd"},
        {"pose_log_path": "/etc/passwd"},
        {"sha256": "0" * 63 + "g"},
        {"started_at": "2026-03-02T09:00:00"},  # no zone
        {"resident_id": 2},  # another resident than the path says
        {"evil": 1},
    ],
)
def test_hostile_ingest_is_refused(filled: World, recording_patch: dict) -> None:
    rec = {k: v for k, v in recording(filled.r1, 9).items() if k != "resident_id"}
    rec["started_at"] = "2026-03-02T09:00:00Z"
    rec.update(recording_patch)
    body = {"recording": rec, "result": result(2)}
    _check(filled, "post", f"/residents/{filled.r1}/recordings", 422, json=body)


def test_oversized_result_is_refused(filled: World) -> None:
    rec = {k: v for k, v in recording(filled.r1, 10).items() if k != "resident_id"}
    rec["started_at"] = "2026-03-02T09:00:00Z"
    res = result(3)
    res["bouts"] = res["bouts"] * 3400  # more than 10 000 bouts
    _check(
        filled,
        "post",
        f"/residents/{filled.r1}/recordings",
        422,
        json={"recording": rec, "result": res},
    )
