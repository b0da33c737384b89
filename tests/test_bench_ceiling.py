"""bench/likelihood_ceiling.py and bench/keypoint_cue.py: the body fitted to key points, the
window shares, the detector's error, and short runs of both."""

from __future__ import annotations

import importlib.util
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def _load(name: str, file: str):
    spec = importlib.util.spec_from_file_location(name, REPO / "bench" / file)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@contextmanager
def _bench(name: str, file: str):
    """A bench script imported as ``name`` (bench/ on the path while it is used)."""
    sys.path.insert(0, str(REPO / "bench"))
    try:
        yield _load(name, file)
    finally:
        sys.path.remove(str(REPO / "bench"))
        sys.modules.pop(name, None)


@pytest.fixture(scope="module")
def ceiling():
    with _bench("bench_likelihood_ceiling", "likelihood_ceiling.py") as module:
        yield module


def test_window_share_counts_windows_summing_above_zero(ceiling):
    # windows of 2: (1 - 1) = 0, (-1 + 1) = 0, (1 + 1) = 2 -> one of three above zero
    assert ceiling.window_share(np.array([1.0, -1.0, 1.0, 1.0]), 2) == pytest.approx(1 / 3)
    assert ceiling.window_share(np.array([0.5, 0.5]), 1) == 1.0
    assert np.isnan(ceiling.window_share(np.array([1.0]), 2))


def test_fit_pose_recovers_the_key_points_of_a_known_pose(ceiling):
    from tracker.body import BodyModel
    from tracker.config import TrackerConfig
    from tracker.dof import DOF

    A = ceiling.A
    legs = [DOF[f"{s}_{j}_flexion"] for s in ("l", "r") for j in ("hip", "knee")]
    body = BodyModel(height_m=1.62, leg_length=1.05)
    limits = TrackerConfig().joint_limits().arrays()
    pose = body.neutral_pose(0.4, -0.2, 0.7)
    pose[legs] = np.radians([20.0, 35.0, -10.0, 5.0])
    target = np.asarray(body.forward(pose[None]))[0]
    start = pose.copy()
    start[:3] += (0.05, -0.04, 0.03)
    start[legs[:3]] += np.radians(15.0)
    fit = A.fit_pose(body, target, start, limits)
    err = np.linalg.norm(np.asarray(body.forward(fit[None]))[0] - target, axis=1)
    assert err.max() < 1e-3
    assert np.all(fit[4:] >= limits[0][4:] - 1e-9) and np.all(fit[4:] <= limits[1][4:] + 1e-9)


def test_probe_climbs_from_the_truth_and_scores_it(ceiling, shared_data, capsys):
    """One short scene: the truth fit lies near the truth, the climb never lowers a weight,
    and the printed table has a row per camera count."""
    code = ceiling.main(
        ["--recordings", "07_06", "--views", "oblique", "--max-frames", "6", "--direct",
         "--data", str(shared_data)]
    )  # fmt: skip
    assert code == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| 1 / oblique |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    fit_all = float(cells[3].split(" / ")[0])
    est_w, fit_w, opt_w, climbed_w = (float(x) for x in cells[6].split(" / "))
    assert fit_all < 60.0  # the body fitted to the true key points
    assert opt_w >= fit_w and climbed_w >= est_w  # a climb keeps only heavier poses
    assert "| 1 camera(s), all views |" in out


def test_bad_arguments_are_refused(ceiling, tmp_path, capsys):
    with pytest.raises(SystemExit):
        ceiling.parse_args(["--filter", "kalman"])
    with pytest.raises(SystemExit):
        ceiling.parse_args(["--seeds", "0,x"])
    assert ceiling.main(["--data", str(tmp_path / "none")]) == 2
    assert "no shared recordings" in capsys.readouterr().err


@pytest.fixture(scope="module")
def keypoint_bench():
    with _bench("bench_keypoint_cue", "keypoint_cue.py") as module:
        yield module


def test_detector_error_of_exact_and_exchanged_detections(keypoint_bench):
    from gaitwatch.trajectory import Trajectory
    from tracker.camera import Camera

    cam = Camera.look_at(name="c", position=[4.0, 1.0, 1.6], target=[0, 0, 0.9])
    rng = np.random.default_rng(0)
    pos = rng.uniform(-0.5, 0.5, (5, 19, 3)) + np.array([0.0, 0.0, 0.9])
    pos[:, 0, 2], pos[:, 17, 2] = 1.7, 0.0  # head and a toe: the image height
    truth = Trajectory(positions=pos, times=np.arange(5) / 20.0, frames=list(range(5)), fps=20.0)
    exact = np.concatenate([cam.project(pos), np.ones((5, 19, 1))], axis=2)
    assert keypoint_bench.detector_error([exact], truth, [cam]) == (0.0, 0.0)
    exchanged = exact.copy()
    exchanged[:, list(keypoint_bench.LEGS)] = exact[:, list(keypoint_bench.EXCHANGED)]
    err, share = keypoint_bench.detector_error([exchanged], truth, [cam])
    assert err == 0.0 and share == 1.0
    shifted = exact.copy()
    shifted[:, :, 0] += 10.0  # 10 px right
    height = cam.project(pos)[:, :, 1].max(axis=1) - cam.project(pos)[:, :, 1].min(axis=1)
    err, _ = keypoint_bench.detector_error([shifted], truth, [cam])
    assert err == pytest.approx(np.median(10.0 / height))


def test_keypoint_bench_without_detections_tracks_as_the_base(
    keypoint_bench, shared_data, tmp_path, capsys
):
    """A detector that finds nobody: the cue never scores, so the two runs (the base without
    the cue, whose defaults would run the built-in detector) are equal."""
    fake = tmp_path / "nobody.py"
    fake.write_text(
        "import sys, numpy as np\n"
        "f = np.load(sys.argv[1])\n"
        "np.save(sys.argv[2], np.full((len(f), 19, 3), np.nan))\n"
    )
    off = tmp_path / "off.toml"
    off.write_text("[keypoints]\nenabled = false\n")
    code = keypoint_bench.main(
        ["--detector-python", sys.executable, "--detector", str(fake), "--recordings", "07_06",
         "--views", "oblique", "--max-frames", "5", "--data", str(shared_data),
         "--base-config", str(off)]
    )  # fmt: skip
    assert code == 0
    row = next(line for line in capsys.readouterr().out.splitlines() if "| 1 / oblique |" in line)
    assert "(+0.0 +- 0.0)" in row and row.count("(+0.0 +- 0.0)") == 3


def test_accuracy_bench_with_a_detector_that_finds_nobody(ceiling, shared_data, tmp_path, capsys):
    """``bench/accuracy.py --detector-python``: the detector runs on every scene and the cue is
    turned on, its detections replacing the built-in detector's; with no detection the scores
    equal those of the run without the cue."""
    fake = tmp_path / "nobody.py"
    fake.write_text(
        "import sys, numpy as np\n"
        "f = np.load(sys.argv[1])\n"
        "np.save(sys.argv[2], np.full((len(f), 19, 3), np.nan))\n"
    )
    off = tmp_path / "off.toml"
    off.write_text("[keypoints]\nenabled = false\n")
    common = ["--recordings", "07_06", "--views", "oblique", "--max-frames", "5", "--filters",
              "ipf", "--direct", "--no-out", "--data", str(shared_data)]  # fmt: skip
    assert ceiling.A.main([*common, "--config", str(off)]) == 0
    plain = capsys.readouterr().out
    detector = ["--detector-python", sys.executable, "--detector", str(fake)]
    assert ceiling.A.main([*common, *detector]) == 0
    cued = capsys.readouterr().out

    def rows(text: str) -> list[str]:  # the per-scene rows without the ms/frame column
        return [ln.rsplit("|", 2)[0] for ln in text.splitlines() if ln.startswith("| 07_06 |")]

    assert rows(plain) and rows(plain) == rows(cued)
