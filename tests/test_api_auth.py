"""Authentication and roles through the real app on a real SQLite file."""

from __future__ import annotations

import pytest

from service.db.ingest import ingest
from tests.service_helpers import *  # noqa: F403  (fixtures)
from tests.service_helpers import World, bearer, recording, result


def _with_fall(w: World, resident_id: int, n: int = 0) -> None:
    with w.sessions() as s:
        ingest(s, recording(resident_id, n), result(n, falls=[{"time_s": 10.0}]))


@pytest.mark.parametrize(
    "path",
    [
        "/residents",
        "/residents/1",
        "/residents/1/trends",
        "/residents/1/bouts",
        "/alerts",
        "/cameras",
        "/api-keys",
        "/metrics",
        "/openapi.json",
        "/docs",
    ],
)
def test_no_key_reads_nothing_but_healthz(shared_world: World, path: str) -> None:
    r = shared_world.client.get(path)
    if path == "/docs":  # no interactive page unless the documentation is made public
        assert r.status_code == 404
        return
    assert r.status_code == 401
    assert r.json()["error"]["code"] == "unauthorized"
    assert r.headers["www-authenticate"] == "Bearer"
    assert shared_world.client.get("/healthz").json()["database"] == "ok"


@pytest.mark.parametrize(
    "headers",
    [
        {"Authorization": "Bearer gw_AAAAAAAA_" + "x" * 43},
        {"X-API-Key": "not-a-key"},
        {"Authorization": "Basic dXNlcjpwYXNz"},
        {"X-API-Key": "gw_" + "A" * 5000},
        {"X-API-Key": "' OR 1=1 --"},
    ],
)
def test_bad_keys_are_401(shared_world: World, headers: dict[str, str]) -> None:
    assert shared_world.client.get("/residents", headers=headers).status_code == 401


def test_key_with_right_prefix_but_wrong_secret_is_401(shared_world: World) -> None:
    token = shared_world.admin["Authorization"].split()[1]
    forged = token[:-4] + ("AAAA" if not token.endswith("AAAA") else "BBBB")
    assert shared_world.client.get("/residents", headers=bearer(forged)).status_code == 401
    assert shared_world.client.get("/residents", headers={"X-API-Key": token}).status_code == 200


def test_revoked_key_stops_working_at_once(world: World) -> None:
    c = world.client
    r = c.post(
        "/api-keys",
        json={"name": "temp", "role": "caregiver", "resident_ids": [world.r1]},
        headers=world.admin,
    )
    assert r.status_code == 201
    key = r.json()
    assert c.get(f"/residents/{world.r1}", headers=bearer(key["key"])).status_code == 200
    assert c.delete(f"/api-keys/{key['id']}", headers=world.admin).json()["revoked_at"]
    assert c.get(f"/residents/{world.r1}", headers=bearer(key["key"])).status_code == 401
    listed = c.get("/api-keys", headers=world.admin).json()["items"]
    assert all("key" not in k for k in listed)  # the key itself is never shown again


@pytest.mark.parametrize(
    ("method", "path", "body"),
    [
        ("post", "/residents", {"display_name": "X"}),
        ("patch", "/residents/{r1}", {"display_name": "X"}),
        ("delete", "/residents/{r1}", None),
        ("post", "/api-keys", {"name": "mine", "role": "admin"}),
        ("get", "/api-keys", None),
        ("delete", "/api-keys/1", None),
        ("post", "/cameras", {"name": "x"}),
        ("get", "/metrics", None),
        ("post", "/residents/{r1}/recordings", {"recording": {}, "result": {}}),
    ],
)
def test_caregiver_may_not_administer(shared_world: World, method, path, body) -> None:
    before = shared_world.client.get("/residents", headers=shared_world.admin).json()
    kw = {"json": body} if body is not None else {}
    r = getattr(shared_world.client, method)(
        path.format(r1=shared_world.r1), headers=shared_world.care_a, **kw
    )
    assert r.status_code == 403, r.text
    assert r.json()["error"]["code"] == "forbidden"
    assert shared_world.client.get("/residents", headers=shared_world.admin).json() == before


@pytest.mark.parametrize(
    "path",
    [
        "/residents/{r}",
        "/residents/{r}/trends",
        "/residents/{r}/bouts",
        "/residents/{r}/transfers",
        "/residents/{r}/falls",
        "/residents/{r}/recordings",
        "/alerts?resident_id={r}",
    ],
)
def test_other_caregivers_resident_is_404_like_a_missing_one(
    shared_world: World, path: str
) -> None:
    other = shared_world.client.get(path.format(r=shared_world.r2), headers=shared_world.care_a)
    missing = shared_world.client.get(path.format(r=987654), headers=shared_world.care_a)
    assert other.status_code == missing.status_code == 404
    assert other.json()["error"]["code"] == "not_found"
    assert (
        shared_world.client.get(
            path.format(r=shared_world.r1), headers=shared_world.care_a
        ).status_code
        == 200
    )
    assert (
        shared_world.client.get(
            path.format(r=shared_world.r2), headers=shared_world.admin
        ).status_code
        == 200
    )


def test_caregiver_lists_only_assigned_residents_alerts_and_cameras(world: World) -> None:
    _with_fall(world, world.r1, 1)
    _with_fall(world, world.r2, 2)
    c = world.client
    res_a = c.get("/residents", headers=world.care_a).json()
    assert [r["id"] for r in res_a["items"]] == [world.r1] and res_a["total"] == 1
    assert c.get("/residents", headers=world.admin).json()["total"] == 2
    alerts_a = c.get("/alerts", headers=world.care_a).json()["items"]
    assert {a["resident_id"] for a in alerts_a} == {world.r1}
    assert len(c.get("/alerts", headers=world.admin).json()["items"]) == 2
    cams = c.get("/cameras", headers=world.care_a).json()
    assert cams["total"] == 1 and cams["items"][0]["resident_id"] == world.r1


def test_caregiver_cannot_touch_another_residents_alert(world: World) -> None:
    _with_fall(world, world.r2, 3)
    alert = world.client.get("/alerts", headers=world.care_b).json()["items"][0]
    for action in ("acknowledge", "resolve"):
        r = world.client.post(
            f"/alerts/{alert['id']}/{action}", json={"note": "x"}, headers=world.care_a
        )
        assert r.status_code == 404
    assert world.client.get(f"/alerts/{alert['id']}", headers=world.care_a).status_code == 404
    after = world.client.get(f"/alerts/{alert['id']}", headers=world.care_b).json()
    assert after["state"] == "open" and after["acknowledged_by"] is None
