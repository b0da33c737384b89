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


def test_same_trajectory_gives_no_error(gait_video, walk):
    r = gait_video.compare(walk, walk, GaitConfig())
    assert not r.error
    assert r.all_mm == pytest.approx(0.0, abs=1e-9)
    assert r.strides_truth == r.strides_video == r.matched >= 8
    assert (r.missed, r.extra) == (0, 0)
    assert r.hs_ms == pytest.approx(0.0, abs=1e-6) and r.to_ms == pytest.approx(0.0, abs=1e-6)
    assert all(v == pytest.approx(0.0, abs=1e-9) for v in r.pct.values())
    assert all(v == pytest.approx(0.0, abs=1e-9) for v in r.diff.values())


def test_known_scale_error_comes_out(gait_video, walk):
    """Every horizontal distance 10 % longer, timing unchanged: speed, stride length and step
    width +10 %, cadence, stance and knee angles unchanged."""
    pos = walk.positions.copy()
    start = pos[0, 2, :2].copy()
    pos[..., :2] = start + 1.1 * (pos[..., :2] - start)
    video = walk.with_positions(pos)
    r = gait_video.compare(walk, video, GaitConfig())
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
