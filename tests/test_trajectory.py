from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gaitwatch.conventions import KEYPOINTS, N_KEYPOINTS
from gaitwatch.trajectory import (
    Trajectory,
    TrajectoryFormatError,
    read_joints_csv,
    write_joints_csv,
)


def _traj() -> Trajectory:
    rng = np.random.default_rng(3)
    pos = rng.normal(size=(5, N_KEYPOINTS, 3))
    pos[2, 4] = np.nan
    frames = np.array([0, 1, 2, 5, 6])
    return Trajectory(positions=pos, times=frames / 20.0, frames=frames, fps=20.0)


def test_csv_round_trip_keeps_gaps_and_nans(tmp_path: Path) -> None:
    t = _traj()
    p = tmp_path / "JOINTS.csv"
    write_joints_csv(t, p)
    lines = p.read_text().splitlines()
    assert lines[0] == "frame,time_s,joint,x,y,z"
    assert len(lines) == 1 + 5 * N_KEYPOINTS
    assert lines[1].split(",")[2] == KEYPOINTS[0]
    back = read_joints_csv(p)
    np.testing.assert_array_equal(back.frames, t.frames)
    np.testing.assert_allclose(back.positions, t.positions, atol=1e-6, equal_nan=True)
    assert back.fps == pytest.approx(20.0)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "empty"),
        ("frame,time_s,joint,x,y\n", "lacks column"),
        ("frame,time_s,joint,x,y,z\nA,0,head,0,0,0\n", ":2: frame"),
        ("frame,time_s,joint,x,y,z\n0,0,nose,0,0,0\n", "unknown joint 'nose'"),
        ("frame,time_s,joint,x,y,z\n0,0,head,0,zz,0\n", "y 'zz'"),
        ("frame,time_s,joint,x,y,z\n", "no frames"),
        ("frame,time_s,joint,x,y,z\n0,0,head,0,0,0\n0,1,neck,0,0,0\n", "two different times"),
    ],
)
def test_bad_csv(tmp_path: Path, text: str, match: str) -> None:
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(TrajectoryFormatError, match=match):
        read_joints_csv(p)
