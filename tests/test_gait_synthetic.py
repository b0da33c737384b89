"""Gait analysis on synthetic recordings with known events and parameters."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gait.analysis import HS_VELOCITY_FRACTION, TO_VELOCITY_FRACTION, GaitConfig, analyse
from gait.evaluation import add_noise, match_events
from gait.events import GaitEvent
from gait.filtering import GaitInputError, fill_short_gaps, lowpass, prepare, repair_swaps
from gait.geometry import heading, heading_angle
from gait.parameters import StrideSettings, compute_strides
from gait.result import GaitReport, Summary
from gait.risk import assess
from gait.synthetic import (
    lying_pose,
    sitting_pose,
    standing_pose,
    synthetic_pose_sequence,
    synthetic_walk,
)
from gaitwatch.conventions import GAIT_JSON_FIELDS, KP, L_ANKLE, L_HEEL, L_TOE, R_HEEL
from gaitwatch.trajectory import Trajectory


def _truth(speed: float, cadence: float) -> dict[str, float]:
    return {
        "walking_speed_m_s": speed,
        "cadence_steps_min": cadence,
        "stride_length_m": speed * 120.0 / cadence,
    }


@pytest.mark.parametrize("fps", [15.0, 20.0, 50.0, 120.0, 240.0])
def test_events_and_parameters_at_any_frame_rate(fps: float) -> None:
    traj = synthetic_walk(speed_m_s=1.1, cadence_steps_min=108, n_strides=6, fps=fps)
    rep = analyse(traj, GaitConfig(source="markers"))  # clean, as laboratory markers are
    m = match_events(rep.events, traj.events)
    assert sum(m.missed.values()) <= 2
    assert m.median_abs_ms("heel_strike") <= 20.0
    assert m.median_abs_ms("toe_off") <= 20.0
    assert len(rep.bouts) == 1
    for k, v in _truth(1.1, 108).items():
        assert getattr(rep.summary, k) == pytest.approx(v, rel=0.02), k
    assert rep.summary.step_width_m == pytest.approx(0.12, abs=0.01)
    # Stance 60 % of the stride: double support 2 x 10 %.
    assert rep.summary.stance_pct == pytest.approx(60, abs=4)
    assert rep.summary.double_support_pct == pytest.approx(20, abs=7)


def test_the_key_points_source_sets_the_event_calibration() -> None:
    """Tracked key points ("video", the default) place heel strike at a smaller fraction of the
    stance foot's backward speed than laboratory markers, and refine toe off past Zeni's
    minimum, so on the same clean walk their heel strikes come earlier and their toe offs later;
    explicit fractions win over the source."""
    traj = synthetic_walk(speed_m_s=1.1, cadence_steps_min=108, n_strides=6, fps=100)
    markers = analyse(traj, GaitConfig(source="markers"))
    video = analyse(traj)
    assert GaitConfig().source == "video"
    assert GaitConfig().heel_strike_fraction == HS_VELOCITY_FRACTION["video"]
    assert GaitConfig().toe_off_fraction == TO_VELOCITY_FRACTION["video"] > 0
    assert GaitConfig(source="markers").heel_strike_fraction == HS_VELOCITY_FRACTION["markers"]
    assert GaitConfig(source="markers").toe_off_fraction == TO_VELOCITY_FRACTION["markers"] == 0
    assert HS_VELOCITY_FRACTION["video"] < HS_VELOCITY_FRACTION["markers"]
    m = match_events(video.events, [e.model_dump() for e in markers.events], tolerance_s=0.1)
    assert sum(m.missed.values()) == 0
    hs_shift, to_shift = np.array(m.errors["heel_strike"]), np.array(m.errors["toe_off"])
    assert np.all(hs_shift < -0.005) and np.all(hs_shift > -0.06)
    assert np.all(to_shift > 0.001) and np.all(to_shift < 0.04)
    same = analyse(
        traj,
        GaitConfig(
            hs_velocity_fraction=HS_VELOCITY_FRACTION["markers"],
            to_velocity_fraction=TO_VELOCITY_FRACTION["markers"],
        ),
    )
    assert [e.time_s for e in same.events] == [e.time_s for e in markers.events]
    with pytest.raises(ValueError):
        GaitConfig(source="imu")


def _strides(traj: Trajectory, events: list[dict] | None = None, **settings) -> list:
    """``compute_strides`` on ``events`` (default: the walk's own, exact ones)."""
    prep = prepare(traj, cutoff_hz=6.0, max_gap_s=0.25, fix_swaps=False)
    forward, _ = heading(prep.positions, prep.fps)
    events = [
        GaitEvent(e["side"], e["type"], e["time_s"], (e["time_s"] - prep.times[0]) * prep.fps)
        for e in (traj.events if events is None else events)
    ]
    return compute_strides(
        prep, events, forward, heading_angle(forward), StrideSettings(**settings)
    )


def test_double_support_ends_with_the_other_foots_toe_off_before_its_strike() -> None:
    """Initial double support ends at the other foot's toe off between this heel strike and
    the other foot's strike. A toe off of the other foot read after its strike (a spurious
    event in tracked key points) belongs to its next cycle: the stride then has no double
    support instead of one longer than the stride."""
    traj = synthetic_walk(speed_m_s=1.1, cadence_steps_min=108, n_strides=6, fps=50)
    clean = _strides(traj)
    assert all(s.values["double_support_pct"] == pytest.approx(20, abs=3) for s in clean)
    st = clean[len(clean) // 2]
    other = "right" if st.side == "left" else "left"
    proper = [
        e
        for e in traj.events
        if (e["side"], e["type"]) == (other, "toe_off") and st.t0 < e["time_s"] < st.contra_strike
    ]
    assert len(proper) == 1
    spurious = {"side": other, "type": "toe_off", "time_s": (st.contra_strike + st.toe_off) / 2}
    events = [e for e in traj.events if e is not proper[0]] + [spurious]
    again = {(s.side, round(s.t0, 3)): s for s in _strides(traj, events)}
    same = again[(st.side, round(st.t0, 3))]
    assert same.contra_toe_off is None and "double_support_pct" not in same.values
    assert all(s.values.get("double_support_pct", 0) <= 100 for s in again.values())


def test_a_stride_must_be_as_long_as_the_body_moved() -> None:
    """A heel strike read where the foot is not (tracked legs out of phase) places that foot
    half a metre off: the two strides it bounds are not as long as the sacrum travelled over
    them and are left out; every other stride, and every stride of a clean walk, stays."""
    traj = synthetic_walk(speed_m_s=1.1, cadence_steps_min=108, n_strides=6, fps=50)
    clean = _strides(traj)
    assert len(clean) == len(_strides(traj, length_ratio=(0.0, np.inf))) >= 10
    left_hs = [
        e["time_s"] for e in traj.events if e["side"] == "left" and e["type"] == "heel_strike"
    ]
    t = left_hs[len(left_hs) // 2]
    pos = traj.positions.copy()
    # The left foot's placement window after that heel strike, moved 0.5 m back.
    win = (traj.times >= t - 0.05) & (traj.times <= t + 0.35)
    for kp in (L_HEEL, L_ANKLE, L_TOE):
        pos[win, kp, 0] -= 0.5
    bad = traj.with_positions(pos)
    kept = _strides(bad)
    unchecked = _strides(bad, length_ratio=(0.0, np.inf))
    gone = {(s.side, round(s.t0, 3)) for s in unchecked} - {(s.side, round(s.t0, 3)) for s in kept}
    assert len(unchecked) == len(clean)
    assert len(gone) == 2 and all(side == "left" for side, _ in gone)
    assert sorted(t0 for _, t0 in gone)[1] == pytest.approx(t, abs=0.02)
    stride_m = 1.1 * 120.0 / 108
    assert all(s.values["stride_length_m"] == pytest.approx(stride_m, rel=0.05) for s in kept)
    # On a treadmill the sacrum stays put; the belt's displacement counts as travel.
    still = traj.positions.copy()
    shift = 1.1 * (traj.times - traj.times[0])
    still[..., 0] -= shift[:, None]
    tread = traj.with_positions(still)
    assert len(_strides(tread, treadmill_speed_m_s=1.1)) == len(clean)
    # Walking on the spot without a known belt: too little travel to check, nothing dropped.
    assert len(_strides(tread)) == len(_strides(tread, length_ratio=(0.0, np.inf)))


def test_a_missed_heel_strike_does_not_make_a_double_stride() -> None:
    """A heel strike missing (a foot mislabelled or hidden for a step in tracked footage):
    the span between its neighbours holds two heel strikes of the other foot and is two
    strides, so it is left out instead of being reported as one stride twice as long."""
    traj = synthetic_walk(speed_m_s=1.1, cadence_steps_min=108, n_strides=6, fps=50)
    left_hs = [e for e in traj.events if e["side"] == "left" and e["type"] == "heel_strike"]
    missing = left_hs[len(left_hs) // 2]
    events = [e for e in traj.events if e is not missing]
    full = analyse(traj, events=traj.events)
    rep = analyse(traj, events=events)
    stride_s = 120.0 / 108
    assert all(s.stride_time_s < 1.2 * stride_s for s in rep.strides)
    # Gone, and nothing else: the two left strides around the missing strike (one span with
    # two right strikes inside) and the right stride that had it inside.
    assert len(rep.strides) == len(full.strides) - 3
    assert rep.summary.cadence_steps_min == pytest.approx(108, rel=0.02)
    assert rep.summary.stride_length_m == pytest.approx(1.1 * stride_s, rel=0.02)


@pytest.mark.parametrize("heading", [0.0, 75.0, 200.0])
def test_walking_direction_does_not_matter(heading: float) -> None:
    traj = synthetic_walk(speed_m_s=0.7, cadence_steps_min=95, fps=30, heading_deg=heading)
    rep = analyse(traj)
    assert rep.summary.walking_speed_m_s == pytest.approx(0.7, rel=0.02)
    assert rep.summary.cadence_steps_min == pytest.approx(95, rel=0.02)


def test_noise_and_low_rate_like_tracker_output() -> None:
    traj = synthetic_walk(speed_m_s=0.9, cadence_steps_min=100, n_strides=8, fps=25)
    noisy = add_noise(traj, 0.02, np.random.default_rng(7))
    rep = analyse(noisy)
    m = match_events(rep.events, traj.events)
    assert m.median_abs_ms("heel_strike") <= 40.0  # 1 frame at 25 Hz
    assert m.median_abs_ms("toe_off") <= 40.0
    for k, v in _truth(0.9, 100).items():
        assert getattr(rep.summary, k) == pytest.approx(v, rel=0.03), k


def test_missing_frames_and_nan_keypoints() -> None:
    traj = synthetic_walk(speed_m_s=1.0, cadence_steps_min=105, n_strides=8, fps=30)
    rng = np.random.default_rng(3)
    keep = np.ones(len(traj), dtype=bool)
    keep[rng.choice(len(traj), size=len(traj) // 10, replace=False)] = False  # 10 % dropped
    pos = traj.positions[keep].copy()
    pos[rng.random(pos.shape[:2]) < 0.05] = np.nan  # 5 % of key points unknown
    holed = Trajectory(
        positions=pos, times=traj.times[keep], frames=traj.frames[keep], fps=30, events=traj.events
    )
    rep = analyse(holed)
    m = match_events(rep.events, traj.events)
    assert m.median_abs_ms("heel_strike") <= 34.0
    assert rep.summary.walking_speed_m_s == pytest.approx(1.0, rel=0.03)
    assert rep.summary.cadence_steps_min == pytest.approx(105, rel=0.03)


def test_left_right_swaps_are_repaired() -> None:
    traj = synthetic_walk(speed_m_s=1.0, cadence_steps_min=105, n_strides=6, fps=30)
    legs_l = [KP[f"left_{j}"] for j in ("hip", "knee", "ankle", "heel", "toe")]
    legs_r = [KP[f"right_{j}"] for j in ("hip", "knee", "ankle", "heel", "toe")]
    pos = traj.positions.copy()
    sl = slice(60, 110)
    pos[sl, legs_l], pos[sl, legs_r] = traj.positions[sl][:, legs_r], traj.positions[sl][:, legs_l]
    fixed = repair_swaps(pos)
    np.testing.assert_allclose(fixed, traj.positions)
    swapped = Trajectory(positions=pos, times=traj.times, fps=30)
    rep = analyse(swapped)
    assert rep.summary.stride_length_m == pytest.approx(1.0 * 120 / 105, rel=0.02)


def test_gap_longer_than_fill_splits_bouts() -> None:
    traj = synthetic_walk(speed_m_s=1.0, cadence_steps_min=105, n_strides=10, fps=30)
    keep = np.ones(len(traj), dtype=bool)
    keep[150:200] = False  # 1.7 s without anybody tracked
    holed = Trajectory(
        positions=traj.positions[keep], times=traj.times[keep], frames=traj.frames[keep], fps=30
    )
    rep = analyse(holed)
    assert len(rep.bouts) == 2
    gap_t0, gap_t1 = traj.times[150], traj.times[199]
    for b in rep.bouts:
        assert b.end_s <= gap_t0 or b.start_s >= gap_t1
    assert all(s.stride_time_s < 1.3 for s in rep.strides)


def test_standing_still_gives_no_walking() -> None:
    rng = np.random.default_rng(1)
    pose = standing_pose()
    traj = synthetic_pose_sequence([(0.0, pose), (10.0, pose)], fps=20, rng=rng, noise_m=0.01)
    rep = analyse(traj)
    assert rep.bouts == [] and rep.strides == []
    assert rep.summary.walking_speed_m_s is None
    assert rep.risk.level == "unknown"
    assert [a.type for a in rep.activities] == ["standing"]
    json.dumps(rep.to_json_dict(), allow_nan=False)


def test_stepping_on_the_spot_is_not_walking() -> None:
    # A treadmill-like walk seen without its belt: the feet cycle, the body does not progress.
    traj = synthetic_walk(speed_m_s=1.0, cadence_steps_min=105, fps=30)
    belt = 1.0 * (traj.times - traj.times[0])
    pos = traj.positions.copy()
    pos[..., 0] -= belt[:, None]
    rep = analyse(Trajectory(positions=pos, times=traj.times, fps=30))
    assert len(rep.events) > 10 and rep.bouts == []
    assert rep.risk.level == "unknown"
    tread = analyse(
        Trajectory(positions=pos, times=traj.times, fps=30), GaitConfig(treadmill_speed_m_s=1.0)
    )
    assert len(tread.bouts) == 1
    assert tread.summary.walking_speed_m_s == pytest.approx(1.0, rel=0.02)


def test_a_single_step_is_not_a_bout() -> None:
    traj = synthetic_walk(n_strides=1, fps=30, lead_in_s=0.1)
    rep = analyse(traj)
    assert rep.bouts == []
    assert rep.summary.n_strides == 0


def test_all_nan_and_too_short_inputs() -> None:
    pos = np.full((50, 19, 3), np.nan)
    rep = analyse(Trajectory(positions=pos, times=np.arange(50) / 20.0, fps=20))
    assert rep.events == [] and rep.bouts == []
    with pytest.raises(GaitInputError, match="fewer than two frames"):
        analyse(Trajectory(positions=standing_pose()[None], times=np.zeros(1), fps=20))


def test_missing_heels_fall_back_to_ankles() -> None:
    traj = synthetic_walk(speed_m_s=1.2, cadence_steps_min=110, fps=50)
    traj.positions[:, [L_HEEL, R_HEEL]] = np.nan
    rep = analyse(traj)
    assert rep.summary.walking_speed_m_s == pytest.approx(1.2, rel=0.02)


def test_report_json_has_the_conventions_fields_and_no_nan() -> None:
    traj = synthetic_walk(fps=30)
    d = analyse(traj).to_json_dict()
    assert set(d) >= {"bouts", "events", "summary"}
    for obj in [d["summary"], *d["bouts"]]:
        assert set(GAIT_JSON_FIELDS) <= set(obj)
    assert {tuple(sorted(e)) for e in d["events"]} == {("side", "time_s", "type")}
    text = json.dumps(d, allow_nan=False)
    assert "NaN" not in text
    back = GaitReport.model_validate_json(text)
    assert back.summary.walking_speed_m_s == pytest.approx(d["summary"]["walking_speed_m_s"])
    assert Summary(walking_speed_m_s=math.nan).walking_speed_m_s is None


def test_knee_curves_and_indicators() -> None:
    rep = analyse(synthetic_walk(fps=60))
    k = rep.summary.kinematics
    assert len(k.knee_curve_left_deg) == 101
    # Swing peak well above stance minimum; the synthetic stance leg is straight.
    assert k.knee_peak_swing_flexion_deg > 40
    assert k.knee_min_stance_flexion_deg < 10
    assert rep.summary.balance.n_steps > 0
    assert rep.summary.balance.mos_ml_mean_m > 0


def test_lowpass_keeps_nan_and_handles_low_rates() -> None:
    t = np.arange(0, 2, 1 / 15)
    x = np.sin(2 * np.pi * 1.0 * t)
    x[10:13] = np.nan
    y = lowpass(x, 15.0, 6.0)  # cut-off above 0.8 x Nyquist is clipped, not an error
    assert np.isnan(y[10:13]).all() and np.isfinite(y[:10]).all()
    z = fill_short_gaps(x, 3)
    assert np.isfinite(z).all()


def _pose_seq(keys, fps=20.0):
    return synthetic_pose_sequence(keys, fps=fps, rng=np.random.default_rng(0), noise_m=0.003)


def test_sit_to_stand_and_stand_to_sit() -> None:
    st, si = standing_pose(), sitting_pose()
    traj = _pose_seq([(0, st), (2, st), (3.5, si), (6, si), (7.5, st), (10, st)])
    rep = analyse(traj)
    types = [t.type for t in rep.transfers]
    assert types == ["stand_to_sit", "sit_to_stand"]
    down, up = rep.transfers
    assert 1.9 <= down.start_s <= 2.4 and 3.1 <= down.end_s <= 3.6
    assert 5.9 <= up.start_s <= 6.4 and 7.1 <= up.end_s <= 7.6
    assert "sitting" in [a.type for a in rep.activities]
    assert rep.falls == []


def _seated_leg_swings(fps: float = 20.0, seconds: float = 8.0) -> Trajectory:
    """Seated on a chair, both feet swinging forward and back by 0.2 m (in antiphase, 1.1 s
    a cycle) and lifting 5 cm: what a tracker whose legs slip makes of someone seated."""
    t = np.arange(0.0, seconds, 1.0 / fps)
    pos = np.repeat(sitting_pose()[None], t.size, axis=0)
    for k, side in enumerate(("left", "right")):
        ph = 2 * np.pi * (t / 1.1 + 0.5 * k)
        for part in ("ankle", "heel", "toe"):
            i = KP[f"{side}_{part}"]
            pos[:, i, 0] += 0.2 * np.sin(ph)
            pos[:, i, 2] += 0.05 * np.clip(np.cos(ph), 0.0, None)
    return Trajectory(positions=pos, times=t, fps=fps, source="seated leg swings")


def test_no_steps_while_seated(monkeypatch) -> None:
    import gait.analysis as ga

    traj = _seated_leg_swings()
    rep = analyse(traj)
    assert rep.events == [] and rep.strides == []
    assert [a.type for a in rep.activities] == ["sitting"]
    # the same feet with the seated frames not recognised give heel strikes and strides
    monkeypatch.setattr(ga, "seated_frames", lambda prep, h, s: np.zeros(prep.n, dtype=bool))
    rep = analyse(traj)
    assert len(rep.events) >= 10 and len(rep.strides) >= 5
    # and the walk's strides are unchanged by it
    walk = synthetic_walk(speed_m_s=1.0, cadence_steps_min=100, n_strides=5, fps=20.0)
    monkeypatch.undo()
    a = analyse(walk)
    monkeypatch.setattr(ga, "seated_frames", lambda prep, h, s: np.zeros(prep.n, dtype=bool))
    b = analyse(walk)
    assert len(a.strides) == len(b.strides) >= 6
    assert [s.start_s for s in a.strides] == [s.start_s for s in b.strides]


def test_tug_like_sequence_is_timed() -> None:
    si, st = sitting_pose(), standing_pose()
    far = standing_pose(xy=(3.0, 0.0))
    far_back = standing_pose(xy=(3.0, 0.0), heading_deg=180)
    home = standing_pose(heading_deg=180)
    home_seat = sitting_pose(heading_deg=180)
    traj = _pose_seq(
        [
            (0, si),
            (2, si),
            (3.5, st),
            (7, far),
            (8.5, far_back),
            (12, home),
            (13.5, home_seat),
            (16, home_seat),
        ]
    )
    rep = analyse(traj)
    assert len(rep.tug) == 1
    tug = rep.tug[0]
    assert tug.duration_s == pytest.approx(11.5, abs=0.6)
    assert tug.includes_turn
    assert tug.walk_distance_m == pytest.approx(6.0, abs=0.5)
    # 11.5 s is under the 13.5 s threshold: not a reason.
    assert all(r.indicator != "tug_s" for r in rep.risk.reasons)


def test_fall_and_long_lie() -> None:
    st, lie = standing_pose(), lying_pose(xy=(0.6, 0.0))
    traj = _pose_seq([(0, st), (3, st), (3.6, lie), (80, lie)], fps=15)
    rep = analyse(traj, GaitConfig(long_lie_s=60))
    assert len(rep.falls) == 1
    f = rep.falls[0]
    assert 2.9 <= f.start_s <= 3.4 and 3.2 <= f.impact_s <= 4.2
    assert f.long_lie and not f.got_up and f.on_floor_s > 70
    assert rep.risk.level == "high"
    assert any(r.indicator == "falls" for r in rep.risk.reasons)
    short = analyse(traj, GaitConfig(long_lie_s=120))
    assert not short.falls[0].long_lie


def test_sitting_down_or_lying_down_slowly_is_not_a_fall() -> None:
    st, si, lie = standing_pose(), sitting_pose(), lying_pose()
    assert analyse(_pose_seq([(0, st), (2, st), (3.5, si), (6, si)])).falls == []
    # Lying down over 4 s is slow, not a fall.
    assert analyse(_pose_seq([(0, st), (2, st), (6, lie), (9, lie)])).falls == []


def test_fall_while_tracking_is_lost_on_the_floor() -> None:
    st, lie = standing_pose(), lying_pose(xy=(0.6, 0.0))
    traj = _pose_seq([(0, st), (3, st), (3.6, lie), (90, lie)], fps=15)
    keep = np.ones(len(traj), dtype=bool)
    keep[80:1200] = False  # the tracker loses the person lying on the floor
    holed = Trajectory(
        positions=traj.positions[keep], times=traj.times[keep], frames=traj.frames[keep], fps=15
    )
    rep = analyse(holed)
    assert len(rep.falls) == 1 and rep.falls[0].long_lie


def test_risk_thresholds() -> None:
    slow = Summary(walking_speed_m_s=0.75, n_strides=6, stride_time_cv_pct=1.0)
    r = assess(slow, [], [])
    assert r.level == "high"
    assert [x.indicator for x in r.reasons] == ["walking_speed_m_s"]
    assert r.reasons[0].threshold == 0.8
    mid = assess(Summary(walking_speed_m_s=0.95, n_strides=6, stride_time_cv_pct=4.0), [], [])
    assert mid.level == "moderate" and len(mid.reasons) == 2
    ok = assess(Summary(walking_speed_m_s=1.3, n_strides=6, stride_time_cv_pct=1.5), [], [])
    assert ok.level == "low" and ok.reasons == []
    # Too few strides: variability is not evaluated.
    few = assess(Summary(walking_speed_m_s=1.3, n_strides=2, stride_time_cv_pct=9.0), [], [])
    assert "stride_time_cv_pct" not in few.evaluated
    assert assess(Summary(), [], []).level == "unknown"


def test_slow_walk_raises_the_risk_level() -> None:
    rep = analyse(synthetic_walk(speed_m_s=0.6, cadence_steps_min=90, fps=30))
    assert rep.summary.walking_speed_m_s == pytest.approx(0.6, rel=0.03)
    assert rep.risk.level == "high"
    assert rep.risk.reasons[0].indicator == "walking_speed_m_s"
