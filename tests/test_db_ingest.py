"""Ingest of gait results: validation, idempotence, aggregates, baselines, alert rules."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest
from sqlalchemy import func, select

from service.config import AlertRules
from service.db.baselines import BaselineRule, rolling_baselines
from service.db.ingest import IngestError, ingest
from service.db.models import (
    Aggregate,
    Alert,
    Baseline,
    Bout,
    Camera,
    Fall,
    Recording,
    Resident,
    Transfer,
)
from service.db.rules import FallFact, RuleInput, evaluate
from tests.service_helpers import *  # noqa: F403  (fixtures)
from tests.service_helpers import T0, recording, result, snapshot


@pytest.fixture
def rid(sessions) -> int:
    with sessions() as s:
        r = Resident(display_name="R", timezone="America/New_York")
        s.add(r)
        s.commit()
        return r.id


def test_ingest_stores_bouts_extras_and_cameras(sessions, rid) -> None:
    res = result(1, n_bouts=3)
    res["bouts"][0]["symmetry_index"] = 0.93
    res["summary"]["walking_speed_m_s"] = float("nan")  # NaN from the analysis -> null
    with sessions() as s:
        out = ingest(s, recording(rid), res)
    assert out.created and out.bouts == 3
    with sessions() as s:
        bouts = s.scalars(select(Bout).order_by(Bout.start_s)).all()
        assert [b.walking_speed_m_s for b in bouts] == pytest.approx(
            [b["walking_speed_m_s"] for b in res["bouts"]]
        )
        assert bouts[0].extra == {"symmetry_index": 0.93}
        assert bouts[0].started_at == T0 + dt.timedelta(seconds=res["bouts"][0]["start_s"])
        rec = s.scalar(select(Recording))
        assert rec.summary["summary"]["walking_speed_m_s"] is None
        assert rec.summary["extra"]["risk"] == {"level": "low", "reasons": []}
        assert rec.ended_at - rec.started_at == dt.timedelta(seconds=600)
        cam = s.scalar(select(Camera))
        assert cam.name == "living-room" and cam.resident_id == rid
        assert cam.last_seen_at == rec.ended_at


def test_same_hash_twice_changes_nothing(sessions, engine, rid) -> None:
    with sessions() as s:
        first = ingest(s, recording(rid, 5), result(2))
    before = snapshot(engine)
    with sessions() as s:
        again = ingest(s, recording(rid, 5), result(3, n_bouts=7))
    assert not again.created and again.recording_id == first.recording_id
    assert snapshot(engine) == before


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda r: r["summary"].pop("cadence_steps_min"), "summary.cadence_steps_min"),
        (lambda r: r["bouts"][0].update(walking_speed_m_s="fast"), "bouts.0.walking_speed_m_s"),
        (lambda r: r["bouts"][1].update(end_s=0.5), "ends"),
        (
            lambda r: r["bouts"][0].update(start_s=9e3, end_s=9e3 + 9),
            "after the end of the recording",
        ),
        (lambda r: r.update(bouts="all of them"), "bouts"),
        (lambda r: r["falls"].append({"lie_duration_s": 3}), "falls.0"),
    ],
)
def test_bad_results_are_refused_and_store_nothing(sessions, engine, rid, mutate, message):
    res = result(4)
    mutate(res)
    before = snapshot(engine)
    with sessions() as s, pytest.raises(IngestError, match=message):
        ingest(s, recording(rid), res)
    assert snapshot(engine) == before


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("sha256", "xyz", "sha256"),
        ("started_at", dt.datetime(2026, 1, 1), "started_at"),  # naive: no zone
        ("duration_s", -1, "duration_s"),
        ("resident_id", 999, "no resident 999"),
        ("pose_log_path", "a\x00b", "pose_log_path"),
    ],
)
def test_bad_recording_info_is_refused(sessions, engine, rid, field, value, message):
    info = recording(rid)
    info[field] = value
    before = snapshot(engine)
    with sessions() as s, pytest.raises(IngestError, match=message):
        ingest(s, info, result(5))
    assert snapshot(engine) == before


def test_daily_aggregates_are_median_and_quartiles_of_the_local_day(sessions, rid) -> None:
    # 23:30 New York on 2 March is 04:30 UTC on 3 March: the bouts belong to 2 March locally.
    start = dt.datetime(2026, 3, 3, 4, 30, tzinfo=dt.UTC)
    speeds = []
    for n in range(3):
        res = result(10 + n, n_bouts=4)
        speeds += [b["walking_speed_m_s"] for b in res["bouts"]]
        with sessions() as s:
            ingest(s, recording(rid, n, start=start + dt.timedelta(minutes=n)), res)
    with sessions() as s:
        aggs = {
            a.period: a
            for a in s.scalars(select(Aggregate).where(Aggregate.metric == "walking_speed_m_s"))
        }
        assert set(aggs) == {"day", "week", "month"}
        agg = aggs["day"]
        assert agg.start == dt.date(2026, 3, 2)
        assert aggs["week"].start == dt.date(2026, 3, 2)  # a Monday
        assert aggs["month"].start == dt.date(2026, 3, 1)
        assert aggs["week"].median == agg.median
        q1, med, q3 = np.percentile(speeds, [25, 50, 75])
        assert (agg.median, agg.q1, agg.q3, agg.count) == pytest.approx((med, q1, q3, 12))
        n_metrics = s.scalar(select(func.count(func.distinct(Aggregate.metric))))
        assert n_metrics == 10


def test_tug_transfers_and_falls_are_stored(sessions, rid) -> None:
    res = result(
        6,
        transfers=[
            {"type": "sit_to_stand", "start_s": 5.0, "end_s": 7.5},
            {"type": "tug", "start_s": 30.0, "duration_s": 14.2},
        ],
        falls=[{"time_s": 100.0, "lie_duration_s": 120.0}],
    )
    with sessions() as s:
        out = ingest(s, recording(rid), res)
    assert (out.transfers, out.falls) == (2, 1)
    with sessions() as s:
        tr = {t.kind: t for t in s.scalars(select(Transfer))}
        assert tr["sit_to_stand"].duration_s == pytest.approx(2.5)
        assert tr["tug"].tug_time_s == pytest.approx(14.2)
        fall = s.scalar(select(Fall))
        assert fall.long_lie and fall.lie_duration_s == 120.0
        kinds = sorted(a.kind for a in s.scalars(select(Alert)))
        assert kinds == ["fall", "slow_tug"]
        tug_agg = s.scalar(
            select(Aggregate).where(Aggregate.metric == "tug_time_s", Aggregate.period == "day")
        )
        assert tug_agg.median == pytest.approx(14.2) and tug_agg.count == 1


def test_speed_decline_against_baseline_raises_one_alert(sessions, rid) -> None:
    rule = BaselineRule(window=14, gap=3, min_days=7)
    for d in range(20):
        with sessions() as s:
            ingest(
                s,
                recording(rid, d, start=T0 + dt.timedelta(days=d)),
                result(d, speed=1.2),
                baseline_rule=rule,
            )
    with sessions() as s:
        assert s.scalar(select(func.count(Alert.id))) == 0
        base = s.get(Baseline, (rid, "walking_speed_m_s"))
        assert base.value == pytest.approx(1.2, abs=0.05) and base.n_days == 14
    for d in (20, 21):  # two slow days (0.9 m/s: 25% below, above the 0.8 floor)
        with sessions() as s:
            ingest(
                s,
                recording(rid, d, start=T0 + dt.timedelta(days=d)),
                result(d, speed=0.9),
                baseline_rule=rule,
            )
    with sessions() as s:
        alerts = s.scalars(select(Alert)).all()
        assert [a.kind for a in alerts] == ["speed_decline"]  # not repeated while open
        assert "below the personal baseline" in alerts[0].message


def test_rules_are_pure_and_use_thresholds() -> None:
    cfg = AlertRules(slow_speed_m_s=0.8, baseline_drop_pct=15, tug_slow_s=13.5, long_lie_s=60)
    at = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)
    assert evaluate(RuleInput(recording_speed_m_s=0.81), cfg) == []
    assert [a.kind for a in evaluate(RuleInput(recording_speed_m_s=0.79), cfg)] == ["slow_gait"]
    inp = RuleInput(
        recording_speed_m_s=1.0,
        day_median_speed_m_s=0.84,
        baseline_speed_m_s=1.0,
        falls=[FallFact(at, 75.0, False)],
        tug_times_s=[(at, 13.4)],
    )
    kinds = [a.kind for a in evaluate(inp, cfg)]
    assert kinds == ["fall", "speed_decline"]
    assert "long lie" in evaluate(inp, cfg)[0].message
    inp2 = RuleInput(recording_speed_m_s=1.0, day_median_speed_m_s=0.86, baseline_speed_m_s=1.0)
    assert evaluate(inp2, cfg) == []


def test_rolling_baselines_match_a_direct_computation() -> None:
    rng = np.random.default_rng(0)
    days = np.sort(rng.choice(np.arange(1000, 1300), 200, replace=False))
    med = rng.normal(1.0, 0.1, days.size)
    rule = BaselineRule(window=28, gap=5, min_days=10)
    ref = np.arange(1000, 1320, 7)
    got, n = rolling_baselines(days, med, ref, rule)
    for r, g, k in zip(ref, got, n, strict=True):
        sel = (days >= r - 33) & (days < r - 5)
        assert k == sel.sum()
        if sel.sum() >= 10:
            assert g == pytest.approx(np.median(med[sel]))
        else:
            assert math.isnan(g)


def test_ingest_accepts_a_real_gait_report(sessions, rid) -> None:
    """The GaitReport of gait.analysis (task E) goes in as it is, object or JSON dict."""
    analysis = pytest.importorskip("gait.analysis")
    synthetic = pytest.importorskip("gait.synthetic")
    traj = synthetic.synthetic_walk(speed_m_s=1.1, n_strides=8, fps=50.0)
    report = analysis.analyse(traj)
    with sessions() as s:
        out = ingest(s, recording(rid, 1, duration_s=60), report)
        assert out.created and out.bouts == len(report.bouts)
    with sessions() as s:
        out2 = ingest(s, recording(rid, 2, duration_s=60), report.to_json_dict())
        assert out2.created
        speeds = s.scalars(select(Bout.walking_speed_m_s)).all()
    assert len(report.bouts) >= 1
    expected = sorted([b.walking_speed_m_s for b in report.bouts] * 2)
    assert sorted(speeds) == pytest.approx(expected)
    assert expected[0] == pytest.approx(1.1, rel=0.1)


def test_tug_list_of_a_gait_report_becomes_tug_transfers(sessions, rid) -> None:
    res = result(7)
    res["tug"] = [{"start_s": 10.0, "end_s": 24.5, "duration_s": 14.5, "includes_turn": True}]
    with sessions() as s:
        ingest(s, recording(rid), res)
        t = s.scalar(select(Transfer))
    assert (t.kind, t.tug_time_s, t.extra) == ("tug", 14.5, {"includes_turn": True})
