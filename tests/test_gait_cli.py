"""``gaitwatch gait``: JOINTS.csv and POSES.mcap input, the table, --json, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gait.synthetic import synthetic_walk
from gaitwatch.conventions import GAIT_JSON_FIELDS
from gaitwatch.trajectory import Trajectory, write_joints_csv
from service.cli import main


@pytest.fixture(scope="module")
def walk() -> Trajectory:
    return synthetic_walk(speed_m_s=0.9, cadence_steps_min=100, n_strides=5, fps=25)


@pytest.fixture()
def joints_csv(tmp_path: Path, walk: Trajectory) -> Path:
    p = tmp_path / "JOINTS.csv"
    write_joints_csv(walk, p)
    return p


def test_csv_to_table_and_json(joints_csv: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "gait.json"
    assert main(["gait", str(joints_csv), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "bout 1" in text and "summary" in text and "fall risk: MODERATE" in text
    assert "gait speed below 1.0 m/s" in text
    d = json.loads(out.read_text())
    assert set(d) >= {"bouts", "events", "summary"}
    for obj in [d["summary"], *d["bouts"]]:
        assert set(GAIT_JSON_FIELDS) <= set(obj)
    assert d["summary"]["walking_speed_m_s"] == pytest.approx(0.9, rel=0.03)
    assert {e["type"] for e in d["events"]} == {"heel_strike", "toe_off"}
    assert d["risk"]["level"] == "moderate"


def test_fps_option_overrides_the_rate(joints_csv: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "g.json"
    # Claiming 50 Hz for 25 Hz time stamps: the analysis follows the given rate.
    assert main(["gait", str(joints_csv), "--fps", "50", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["summary"]["fps"] == 50


def test_unknown_values_are_null(tmp_path: Path, capsys) -> None:
    pos = np.zeros((40, 19, 3))
    pos[:, :, 2] = 1.0
    traj = Trajectory(positions=pos, times=np.arange(40) / 20, fps=20)
    csv = tmp_path / "still.csv"
    write_joints_csv(traj, csv)
    out = tmp_path / "still.json"
    assert main(["gait", str(csv), "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["bouts"] == [] and d["summary"]["walking_speed_m_s"] is None
    assert "NaN" not in out.read_text()


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("", "empty file"),
        ("frame,time_s,joint,x,y,z\n0,0.0,nose,1,2,3\n", "unknown joint 'nose'"),
        ("frame,time_s,joint,x,y,z\n0,0.0,head,1,2,3\n", "fewer than two frames"),
    ],
)
def test_bad_csv_is_one_line_exit_2(tmp_path: Path, capsys, content: str, fragment: str) -> None:
    p = tmp_path / "bad.csv"
    p.write_text(content)
    out = tmp_path / "keep.json"
    out.write_text("{}")
    assert main(["gait", str(p), "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gaitwatch: error:") and fragment in err and "\n" not in err
    assert out.read_text() == "{}"  # nothing already stored is lost


def test_missing_file_wrong_type_and_bad_fps(tmp_path: Path, joints_csv: Path, capsys) -> None:
    assert main(["gait", str(tmp_path / "nope.csv")]) == 2
    assert "no such file" in capsys.readouterr().err
    other = tmp_path / "x.txt"
    other.write_text("hello")
    assert main(["gait", str(other)]) == 2
    assert "expected .mcap or .csv" in capsys.readouterr().err
    assert main(["gait", str(joints_csv), "--fps", "0"]) == 2
    assert "--fps" in capsys.readouterr().err
    assert main(["gait", str(joints_csv), "--json", str(joints_csv)]) == 2
    assert "overwrite" in capsys.readouterr().err
    assert main(["gait", str(joints_csv), "--long-lie-s", "-5"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gaitwatch: error: --long-lie-s:") and err.count("\n") == 1


def test_pose_log_input(tmp_path: Path, walk: Trajectory, capsys) -> None:
    poselog = pytest.importorskip("service.poselog")
    from tracker.dof import N_DOF

    p = tmp_path / "POSES.mcap"
    with poselog.PoseLogWriter(
        p,
        cameras=[],
        body_height_m=1.7,
        filter_name="ipf",
        settings={},
        fps=25,
        start_time_ns=0,
    ) as w:
        for i, (f, t) in enumerate(zip(walk.frames, walk.times, strict=True)):
            if i % 17 == 5:
                w.write_no_pose(int(f), float(t), "no silhouette")
                continue
            w.write_frame(int(f), float(t), walk.positions[i], np.zeros(N_DOF), weight=1.0)
    out = tmp_path / "g.json"
    assert main(["gait", str(p), "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["summary"]["walking_speed_m_s"] == pytest.approx(0.9, rel=0.03)
    assert d["summary"]["cadence_steps_min"] == pytest.approx(100, rel=0.03)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file")
    assert main(["gait", str(bad)]) == 2
    assert "MCAP" in capsys.readouterr().err
    # A pose log is tracked: the laboratory calibration is refused, one line, nothing written.
    out.unlink()
    assert main(["gait", str(p), "--source", "markers", "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--source markers" in err and err.count("\n") == 1
    assert not out.exists()


def test_source_option_sets_the_heel_strike_calibration(
    joints_csv: Path, walk: Trajectory, tmp_path: Path, capsys
) -> None:
    """--source markers (a laboratory JOINTS.csv) puts heel strikes later and toe offs earlier
    than the default (tracked key points)."""
    events = {}
    for source in ("video", "markers"):
        out = tmp_path / f"{source}.json"
        assert main(["gait", str(joints_csv), "--source", source, "--json", str(out)]) == 0
        events[source] = json.loads(out.read_text())["events"]
    default = tmp_path / "default.json"
    assert main(["gait", str(joints_csv), "--json", str(default)]) == 0
    assert json.loads(default.read_text())["events"] == events["video"]

    def times(source: str, kind: str) -> np.ndarray:
        return np.array([e["time_s"] for e in events[source] if e["type"] == kind])

    hs_v, hs_m = times("video", "heel_strike"), times("markers", "heel_strike")
    assert hs_v.size == hs_m.size >= 8
    assert np.all(hs_m - hs_v > 0.005)
    to_v, to_m = times("video", "toe_off"), times("markers", "toe_off")
    assert to_v.size == to_m.size >= 8
    assert np.all(to_v - to_m > 0.001)
    with pytest.raises(SystemExit) as exc:  # argparse's own usage error
        main(["gait", str(joints_csv), "--source", "imu"])
    assert exc.value.code == 2
    assert "--source: invalid choice: 'imu'" in capsys.readouterr().err
