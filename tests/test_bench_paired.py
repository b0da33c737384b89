"""bench/paired.py and bench/accuracy.py --json: known scores in, known paired figures out."""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def _load(name: str, module_name: str):
    spec = importlib.util.spec_from_file_location(module_name, REPO / "bench" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def paired():
    yield _load("paired", "bench_paired")
    sys.modules.pop("bench_paired", None)


@pytest.fixture(scope="module")
def accuracy():
    yield _load("accuracy", "bench_accuracy_json")
    sys.modules.pop("bench_accuracy_json", None)


def _doc(seed: int, runs: list[tuple[str, str, int, str, float, float, float | None]]) -> dict:
    return {
        "seed": seed,
        "tracker_seed": seed + 900,
        "runs": [
            {
                "recording": rec,
                "view": view,
                "cameras": cams,
                "filter": filt,
                "all_mm": a,
                "lower_mm": lo,
                "knee_rmse_deg": knee,
            }
            for rec, view, cams, filt, a, lo, knee in runs
        ],
    }


def _write(tmp: Path, name: str, doc: dict) -> Path:
    p = tmp / name
    p.write_text(json.dumps(doc), encoding="utf-8")
    return p


def _run(accuracy, metrics, view: str, diag: dict | None = None, seed: int = 2):
    """A benchmark run of 07_06 by the IPF with these scores (scene seed ``seed``, tracker
    seed ``seed + 900``)."""
    return accuracy.Run(
        recording="07_06",
        view=accuracy.ViewSpec.parse(view),
        body="heavy/fitted",
        filter="ipf",
        metrics=metrics,
        filter_evaluations=6561,
        evals_tracked=7000.0,
        evals_init=0.0,
        reinits=0,
        seed=seed,
        tracker_seed=seed + 900,
        diag=diag or {},
    )


def test_paired_differences(paired, tmp_path):
    """Two draws of two scenes: the new setting is 10 mm better on one scene and 20 mm worse
    on the other; a run without a partner and a knee score of None are left out."""
    base = [
        _write(tmp_path, "b0.json", _doc(0, [("a", "oblique", 1, "ipf", 100, 90, 10.0),
                                             ("b", "side+frontal", 2, "ipf", 60, 50, 8.0)])),
        _write(tmp_path, "b1.json", _doc(1, [("a", "oblique", 1, "ipf", 120, 110, None),
                                             ("b", "side+frontal", 2, "ipf", 70, 60, 9.0),
                                             ("c", "oblique", 1, "ipf", 300, 300, 30.0)])),
    ]  # fmt: skip
    new = [
        _write(tmp_path, "n0.json", _doc(0, [("a", "oblique", 1, "ipf", 90, 80, 9.0),
                                             ("b", "side+frontal", 2, "ipf", 80, 70, 8.0)])),
        _write(tmp_path, "n1.json", _doc(1, [("a", "oblique", 1, "ipf", 110, 100, 12.0),
                                             ("b", "side+frontal", 2, "ipf", 90, 80, 9.5)])),
    ]  # fmt: skip
    b, n = paired.load(base), paired.load(new)
    assert len(b) == 5 and len(n) == 4
    v = paired.paired(b, n, "all_mm")
    assert v.shape == (4, 2)
    d = v[:, 1] - v[:, 0]
    assert sorted(d) == [-10, -10, 20, 20]
    assert paired.paired(b, n, "knee_rmse_deg").shape == (3, 2)  # the None is left out
    text = "\n".join(paired.tables(b, n))
    # the oblique runs: 110 -> 100 mm, -10 +- 0, both better
    assert "| ipf, oblique | 2 | 110.0 | 100.0 | -10.0 +- 0.0 | 2 |" in text
    # all four runs: +5 +- se of [-10, -10, 20, 20]
    se = np.std([-10, -10, 20, 20], ddof=1) / 2
    assert f"| ipf, all runs | 4 | 87.5 | 92.5 | +5.0 +- {se:.1f} | 2 |" in text


def test_paired_command_line_errors(paired, tmp_path, capsys):
    good = _write(tmp_path, "g.json", _doc(0, [("a", "oblique", 1, "ipf", 1, 1, 1.0)]))
    other = _write(tmp_path, "o.json", _doc(5, [("a", "oblique", 1, "ipf", 1, 1, 1.0)]))
    bad = tmp_path / "bad.json"
    bad.write_text("{}", encoding="utf-8")
    assert paired.main(["--base", str(bad), "--new", str(good)]) == 2
    assert "not a bench/accuracy.py --json file" in capsys.readouterr().err
    assert paired.main(["--base", str(good), str(good), "--new", str(good)]) == 2
    assert "already in another file" in capsys.readouterr().err
    assert paired.main(["--base", str(good), "--new", str(other)]) == 2
    assert "no run of --base has a partner" in capsys.readouterr().err
    assert paired.main(["--base", str(good), "--new", str(good)]) == 0
    assert "1 paired runs" in capsys.readouterr().out


def test_accuracy_json_round_trip(accuracy, paired, tmp_path):
    """--json writes strict JSON that paired.py reads: the scores as evaluated, NaN as None."""
    from gaitwatch.evaluation import evaluate
    from gaitwatch.trajectory import Trajectory

    rng = np.random.default_rng(0)
    pos = rng.normal(size=(5, 19, 3))
    truth = Trajectory(times=np.arange(5) * 0.05, positions=pos, frames=np.arange(5))
    est = Trajectory(times=truth.times, positions=pos + 0.01, frames=truth.frames)
    m = evaluate(truth, est)
    run = _run(accuracy, m, "side+frontal")
    args = argparse.Namespace(seed=2, tracker_seed=902, config=None)
    out = tmp_path / "sub" / "r.json"
    accuracy.write_json(out, [run], ["--seed", "2"], args)
    doc = json.loads(out.read_text(encoding="utf-8"))  # strict: no NaN tokens
    assert doc["command"] == "python3 bench/accuracy.py --seed 2"
    (rec,) = doc["runs"]
    assert rec["cameras"] == 2 and rec["view"] == "side+frontal"
    assert rec["all_mm"] == pytest.approx(m.mpjpe_mm) == pytest.approx(10 * math.sqrt(3))
    knee = m.knee_flexion_rmse_deg
    assert rec["knee_rmse_deg"] == (None if math.isnan(knee) else pytest.approx(knee))
    assert list(paired.load([out])) == [(2, 902, "07_06", "side+frontal", "ipf")]
    # the processor and library versions are recorded
    assert doc["environment"] == accuracy.environment()
    assert f"NumPy {np.__version__}" in doc["environment"]


def test_paired_warns_across_environments(paired, tmp_path, capsys):
    """Files from two processors or library builds pair by seeds, but the runs' numerics
    differ: the output says so; one environment (or files without one) does not."""
    runs = [("a", "oblique", 1, "ipf", 100, 90, 10.0)]
    one = _write(tmp_path, "e1.json", {**_doc(0, runs), "environment": "CPU A; NumPy 2"})
    same = _write(tmp_path, "e2.json", {**_doc(1, runs), "environment": "CPU A; NumPy 2"})
    other = _write(tmp_path, "e3.json", {**_doc(0, runs), "environment": "CPU B; NumPy 2"})
    old = _write(tmp_path, "e4.json", _doc(1, runs))
    assert paired.main(["--base", str(one), "--new", str(other)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("warning: the files come from different processors")
    assert "CPU A; NumPy 2" in out and "CPU B; NumPy 2" in out
    assert paired.main(["--base", str(one), str(same), "--new", str(one), str(old)]) == 0
    assert "warning" not in capsys.readouterr().out


def test_accuracy_json_has_groups_and_proportions(accuracy, tmp_path):
    """--json also records each joint group's error and the estimate's proportions: legs 10 %
    too long give leg_length_ratio 1.1 and leg_length_err_pct 10; hips 20 % wide, 1.2."""
    from gaitwatch.conventions import L_ANKLE, L_HIP, L_KNEE, R_ANKLE, R_HIP, R_KNEE, SACRUM
    from gaitwatch.evaluation import JOINT_GROUPS, evaluate
    from gaitwatch.trajectory import Trajectory

    pos = np.zeros((6, 19, 3))
    pos[:, :, 2] = 1.0
    pos[:, :, 0] = np.arange(6)[:, None] * 0.06  # walking along x
    for side, (hip, knee, ankle) in ((1, (L_HIP, L_KNEE, L_ANKLE)), (-1, (R_HIP, R_KNEE, R_ANKLE))):
        pos[:, [hip, knee, ankle], 1] = side * 0.1
        pos[:, hip, 2], pos[:, knee, 2], pos[:, ankle, 2] = 0.9, 0.5, 0.1
    truth = Trajectory(times=np.arange(6) * 0.05, positions=pos, frames=np.arange(6))
    est_pos = pos.copy()
    for hip, knee, ankle in ((L_HIP, L_KNEE, L_ANKLE), (R_HIP, R_KNEE, R_ANKLE)):
        est_pos[:, knee, 2], est_pos[:, ankle, 2] = 0.46, 0.02  # 0.88 m instead of 0.8
        est_pos[:, [hip, knee, ankle], 1] *= 1.2  # legs 20 mm further out
    est_pos[:, SACRUM, 2] -= 0.03
    est_pos[:, SACRUM, 0] -= 0.01  # 10 mm behind (the walk goes along +x)
    est_pos[:, SACRUM, 1] += 0.02  # 20 mm to the walker's left (+y)
    est = Trajectory(times=truth.times, positions=est_pos, frames=truth.frames)

    class Cam:
        center = (5.0, -4.0, 1.5)

    class Side:  # on the walker's left, level with the sacrum: depth is minus the left bias
        center = (0.15, 3.0, 1.0)

    class Ahead:  # ahead on the path, level with the sacrum: depth is minus the forward bias
        center = (40.0, 0.0, 1.0)

    diag = accuracy.diagnostics(truth, est, Cam())
    assert diag["leg_length_ratio"] == pytest.approx(1.1)
    assert diag["hip_width_ratio"] == pytest.approx(1.2)
    assert diag["sacrum_dz_mm"] == pytest.approx(-30)
    assert diag["sacrum_forward_mm"] == pytest.approx(-10)
    assert diag["sacrum_left_mm"] == pytest.approx(20)
    assert math.isnan(diag["depth2_mm"])
    two = accuracy.diagnostics(truth, est, Side(), Ahead())
    assert two["depth_mm"] == pytest.approx(-20, abs=1.5)  # nearer the side camera
    assert two["depth2_mm"] == pytest.approx(10, abs=0.5)  # farther from the one ahead
    m = evaluate(truth, est)
    run = _run(accuracy, m, "oblique", diag)
    rec = accuracy.run_record(run)
    assert rec["leg_length_ratio"] == pytest.approx(1.1)
    assert rec["leg_length_err_pct"] == pytest.approx(10)
    assert rec["sacrum_dz_mm"] == pytest.approx(-30)
    for g in JOINT_GROUPS:
        assert (rec[f"{g}_mm"] is None) == math.isnan(m.group_mm.get(g, math.nan))
    assert rec["knees_mm"] == pytest.approx(1000 * math.hypot(0.04, 0.02))
    assert rec["arms_mm"] == pytest.approx(0)


def test_paired_other_scores(paired, tmp_path, capsys):
    """--scores compares any score of the runs; a score no run has is an error."""
    doc = _doc(0, [("a", "oblique", 1, "ipf", 100, 90, 10.0)])
    doc["runs"][0]["leg_length_err_pct"] = 8.0
    base = _write(tmp_path, "b.json", doc)
    doc["runs"][0]["leg_length_err_pct"] = 3.0
    new = _write(tmp_path, "n.json", doc)
    argv = ["--base", str(base), "--new", str(new)]
    assert paired.main([*argv, "--scores", "leg_length_err_pct,all_mm"]) == 0
    out = capsys.readouterr().out
    assert "### leg length error % (|est/true - 1|)" in out and "### all joints mm" in out
    assert "| ipf, all runs | 1 | 8.0 | 3.0 | -5.0 +- n/a | 1 |" in out
    assert "### knee deg" not in out
    assert paired.main([*argv, "--scores", "arms_mm"]) == 2
    assert "no run has the score(s) arms_mm" in capsys.readouterr().err


def _offset_metrics(mm: float):
    """Scores of an estimate that misses every key point of a short walk by ``mm``."""
    from gaitwatch.evaluation import evaluate
    from gaitwatch.trajectory import Trajectory

    pos = np.zeros((5, 19, 3))
    pos[:, :, 2] = np.linspace(0.05, 1.7, 19)
    pos[:, :, 0] = np.arange(5)[:, None] * 0.06
    truth = Trajectory(times=np.arange(5) * 0.05, positions=pos, frames=np.arange(5))
    est = Trajectory(times=truth.times, positions=pos + [0.0, 0.0, mm / 1000], frames=truth.frames)
    return evaluate(truth, est)


def _draw_run(accuracy, filt: str, seed: int, mm: float, view: str = "side+frontal"):
    run = _run(accuracy, _offset_metrics(mm), view, seed=seed)
    run.filter = filt
    run.profile = (np.full(7, 0.5 + 0.1 * seed), np.full(7, 0.4))
    return run


def test_draws_pair_filters_within_each_draw(accuracy):
    """Two draws of one scene: the filters pair within a draw, never across draws, and each
    draw's own figure is printed beside the pooled one."""
    runs = []
    for seed, (ipf, apf, cond) in ((0, (50, 80, 60)), (1, (100, 90, 130))):
        runs += [
            _draw_run(accuracy, "ipf", seed, ipf),
            _draw_run(accuracy, "apf", seed, apf),
            _draw_run(accuracy, "condensation", seed, cond),
        ]
    text, checks = accuracy.targets(runs)
    assert "Two cameras (2 scenes, IPF): all-joint error 75 mm" in text
    assert "per draw (scene seeds 0, 1) 50 / 100 mm" in text
    # IPF - APF per scene: -30 (draw 0), +10 (draw 1): mean -10, standard error 20
    assert "IPF lower all-joint error in 1/2 scenes, per-scene difference -10 +- 20 mm" in text
    assert "all-joint per draw 50 vs 80, 100 vs 90 mm" in text
    # IPF - Condensation: -10, -30
    assert "IPF lower all-joint error in 2/2 scenes, per-scene difference -20 +- 10 mm" in text
    assert dict(checks)["IPF beats condensation at equal evaluations"] is True
    # one draw alone: no per-draw figures, no seed column
    one = [r for r in runs if r.seed == 0]
    assert "per draw" not in accuracy.targets(one)[0]
    assert accuracy.runs_table(one).startswith("| recording | view | body |")


def test_draws_in_tables_and_json(accuracy, paired, tmp_path):
    """Over several draws the per-run tables show the scene seed, the depth profile is
    averaged per scene, and --json gives each run its own seeds, which paired.py pairs on."""
    runs = [_draw_run(accuracy, "ipf", s, 50 + 10 * s) for s in (3, 4)]
    table = accuracy.runs_table(runs).splitlines()
    assert table[0].startswith("| recording | view | seed | body | filter |")
    assert table[2].startswith("| 07_06 | side+frontal | 3 |")
    assert table[3].startswith("| 07_06 | side+frontal | 4 |")
    assert accuracy.diag_table(runs).startswith("| recording | view | seed | filter |")
    profile = accuracy.profile_table(runs).splitlines()
    assert len(profile) == 3  # one row: the two draws averaged
    assert profile[2].startswith("| 07_06 | side+frontal | 0.85 / 0.40 |")
    args = argparse.Namespace(seed=3, tracker_seed=903, config=None, draws=2)
    out = tmp_path / "d.json"
    accuracy.write_json(out, runs, ["--seed", "3", "--draws", "2"], args)
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["draws"] == 2
    assert [(r["seed"], r["tracker_seed"]) for r in doc["runs"]] == [(3, 903), (4, 904)]
    keys = sorted(paired.load([out]))
    assert keys == [
        (3, 903, "07_06", "side+frontal", "ipf"),
        (4, 904, "07_06", "side+frontal", "ipf"),
    ]
    assert "2 draws: scene seeds 3-4 with tracker seeds 903-904" in accuracy._seeds_text(args)


def test_draws_must_be_positive(accuracy, capsys):
    with pytest.raises(SystemExit):
        accuracy.parse_args(["--draws", "0"])
    assert "--draws must be within 1..100" in capsys.readouterr().err
    assert accuracy.parse_args(["--draws", "3"]).draws == 3
