"""bench/gait_video.py's comparison: known error in, same error out."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from gait.analysis import GaitConfig
from gait.synthetic import synthetic_walk
from gaitwatch.trajectory import Trajectory

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def gait_video():
    spec = importlib.util.spec_from_file_location(
        "bench_gait_video", REPO / "bench" / "gait_video.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_gait_video"] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop("bench_gait_video", None)


@pytest.fixture(scope="module")
def walk() -> Trajectory:
    return synthetic_walk(speed_m_s=1.2, cadence_steps_min=110.0, n_strides=6, fps=20.0)


#: Both sides analysed alike (the true key points' calibration for the video's too).
SAME = GaitConfig(source="markers")


def test_same_trajectory_gives_no_error(gait_video, walk):
    r = gait_video.compare(walk, walk, SAME)
    assert not r.error
    assert r.all_mm == pytest.approx(0.0, abs=1e-9)
    assert r.strides_truth == r.strides_video == r.matched >= 8
    assert (r.missed, r.extra) == (0, 0)
    assert r.hs_ms == pytest.approx(0.0, abs=1e-6) and r.to_ms == pytest.approx(0.0, abs=1e-6)
    assert all(v == pytest.approx(0.0, abs=1e-9) for v in r.pct.values())
    assert all(v == pytest.approx(0.0, abs=1e-9) for v in r.diff.values())


def test_truth_is_analysed_as_markers_and_the_video_as_tracked(gait_video, walk):
    """By default the true key points get the markers' event calibration and the tracked ones
    the video's: on the same clean walk the video's heel strikes come earlier and its toe offs
    later, and an explicit reference config is used as given."""
    r = gait_video.compare(walk, walk, GaitConfig())
    assert r.hs_bias_ms < -5.0 and r.to_bias_ms > 1.0
    assert r.diff["stance"] > 0.5  # earlier heel strikes, later toe offs: longer stance
    same = gait_video.compare(walk, walk, GaitConfig(), reference=GaitConfig())
    assert same.hs_ms == pytest.approx(0.0, abs=1e-6)


def test_known_scale_error_comes_out(gait_video, walk):
    """Every horizontal distance 10 % longer, timing unchanged: speed, stride length and step
    width +10 %, cadence, stance and knee angles unchanged."""
    pos = walk.positions.copy()
    start = pos[0, 2, :2].copy()
    pos[..., :2] = start + 1.1 * (pos[..., :2] - start)
    video = walk.with_positions(pos)
    r = gait_video.compare(walk, video, SAME)
    assert r.matched >= 8
    assert r.pct["speed"] == pytest.approx(10.0, abs=0.5)
    assert r.pct["stride length"] == pytest.approx(10.0, abs=0.5)
    assert r.pct["cadence"] == pytest.approx(0.0, abs=0.5)
    assert r.diff["step width"] == pytest.approx(12.0, abs=2.0)  # 0.12 m x 10 %, in mm
    assert r.diff["stance"] == pytest.approx(0.0, abs=1.0)
    assert r.all_mm > 50.0


def test_empty_video_is_reported_not_raised(gait_video, walk):
    empty = Trajectory(positions=np.zeros((0, 19, 3)), times=np.zeros(0), frames=[], fps=20.0)
    r = gait_video.compare(walk, empty, GaitConfig())
    assert r.error == "no pose"
    table = gait_video.pooled_table([r])
    assert "1 (0)" in table  # one scene, none with matched strides


def test_transfers_matched_by_type_and_start(gait_video):
    from gait.result import Transfer

    def t(kind, start, dur):
        return Transfer(type=kind, start_s=start, end_s=start + dur, duration_s=dur)

    truth = [t("stand_to_sit", 1.0, 0.8), t("sit_to_stand", 3.0, 1.0), t("stand_to_sit", 6.0, 1)]
    video = [
        t("stand_to_sit", 1.3, 0.6),  # 300 ms late, 200 ms short
        t("stand_to_sit", 1.1, 0.9),  # nearer: this one matches (100 ms, 100 ms)
        t("stand_to_sit", 3.1, 1.0),  # wrong type for the rise at 3.0
        t("sit_to_stand", 4.5, 1.0),  # too late (1.5 s)
    ]
    r = gait_video.SceneResult("75_19", "oblique")
    gait_video.compare_transfers(truth, video, r)
    assert (r.transfers_truth, r.transfers_video, r.transfers_matched) == (3, 4, 1)
    assert r.transfer_start_ms == pytest.approx(100.0)
    assert r.transfer_duration_ms == pytest.approx(100.0)
    assert r.gait == "transfers"
    gait_video.compare_transfers(truth, [], r)
    assert r.transfers_matched == 0 and np.isnan(r.transfer_start_ms)
    table = gait_video.scene_table([r])
    assert "3 / 0 (0)" in table


def test_sit_and_rise_trajectory_matches_itself(gait_video):
    from gait.synthetic import sitting_pose, standing_pose, synthetic_pose_sequence

    stand, sit = standing_pose(), sitting_pose()
    keys = [(0.0, stand), (1.0, stand), (2.0, sit), (4.0, sit), (5.0, stand), (7.0, stand)]
    tr = synthetic_pose_sequence(keys, fps=20.0)
    r = gait_video.compare(tr, tr, GaitConfig())
    assert r.transfers_truth == r.transfers_video == r.transfers_matched == 2
    assert r.transfer_start_ms == pytest.approx(0.0, abs=1e-6)


@pytest.fixture(scope="module")
def gait_repeat(gait_video):
    spec = importlib.util.spec_from_file_location(
        "bench_gait_repeat", REPO / "bench" / "gait_repeat.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_gait_repeat"] = module
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop("bench_gait_repeat", None)


def test_repeat_spread_known_values(gait_repeat):
    """Bias over every run; within: pooled sd of the footage run twice or more; between: sd of
    their means. A footage run once and NaN runs count in the bias only."""
    s = gait_repeat.spread(
        {"a": [1.0, 3.0], "b": [5.0, 7.0, float("nan")], "c": [10.0], "d": [float("nan")]}
    )
    assert s.runs == 5
    assert s.bias == pytest.approx((1 + 3 + 5 + 7 + 10) / 5)
    assert s.footage == 2
    assert s.sd_within == pytest.approx(np.sqrt((2 + 2) / 2))  # each footage: var 2, 1 dof
    assert s.sd_between == pytest.approx(np.std([2.0, 6.0], ddof=1))
    lone = gait_repeat.spread({"a": [1.0]})
    assert lone.runs == 1 and np.isnan(lone.sd_within) and np.isnan(lone.sd_between)


def test_repeat_reads_kept_folders(gait_repeat, walk, tmp_path):
    """Two folders of the same footage: a run equal to the truth and one 10 % faster give a
    speed bias of +5 % and a within-footage sd of about 7 %."""
    import dataclasses

    from gaitwatch.trajectory import write_joints_csv

    fast = dataclasses.replace(walk, times=walk.times / 1.1)
    for i, video in enumerate((walk, fast)):
        d = tmp_path / f"gv{i}"
        d.mkdir()
        write_joints_csv(walk, d / "07_04_side-frontal_truth.csv")
        write_joints_csv(video, d / "07_04_side-frontal_video.csv")
    assert gait_repeat.main([str(tmp_path / "gv0"), str(tmp_path / "x")]) == 2
    results = gait_repeat.load([tmp_path / "gv0", tmp_path / "gv1"], GaitConfig())
    (rs,) = results.values()
    assert [r.recording for r in rs] == ["07_04", "07_04"] and rs[0].ncams == 2
    rows = gait_repeat.table(results)
    speed = next(r for r in rows if "| speed" in r).split("|")
    assert speed[1].strip() == "walk" and speed[2].strip() == "2"
    assert float(speed[6]) == pytest.approx(5.0, abs=0.5)
    assert float(speed[7]) == pytest.approx(7.07, abs=0.7)


def test_fps_option(gait_video, capsys):
    assert gait_video.parse_args([]).fps == 20.0
    assert gait_video.parse_args(["--fps", "30"]).fps == 30.0
    with pytest.raises(SystemExit):
        gait_video.parse_args(["--fps", "500"])
    assert "--fps must be within 1..240" in capsys.readouterr().err
