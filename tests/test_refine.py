"""Local refinement of the whole pose (tracker.refine): improvements only, recovers poses."""

from __future__ import annotations

import numpy as np
import pytest

from tests.tracker_helpers import Counting, own_likelihood, walking_clip
from tracker.body import BodyModel
from tracker.config import RefineConfig, TrackerConfig, TrackerConfigError, parse_tracker_config
from tracker.dof import DOF, LEFT_LEG, RIGHT_LEG
from tracker.refine import dof_ranges, refine_pose


def _truth(body: BodyModel) -> np.ndarray:
    p = body.neutral_pose(x=0.1, y=0.05, yaw=0.3)
    for name, deg in (
        ("l_hip_flexion", 22),
        ("r_hip_flexion", -10),
        ("r_knee_flexion", 30),
        ("l_knee_flexion", 6),
        ("l_shoulder_flexion", -15),
        ("r_shoulder_flexion", 20),
        ("r_elbow_flexion", 25),
    ):
        p[DOF[name]] = np.radians(deg)
    return p


# Perturbations of DOFs the IPF does not grid-search (degrees), within the default ranges.
PERTURB = {
    "l_hip_abduction": 7,
    "r_hip_rotation": -8,
    "r_ankle_flexion": 9,
    "trunk_lateral": -6,
    "l_shoulder_abduction": 10,
    "r_knee_flexion": -7,
}


@pytest.mark.parametrize("factored", [True, False])
def test_recovers_a_known_perturbation(body, limits, factored: bool) -> None:
    truth = _truth(body)
    lik = own_likelihood(body, truth, 2)
    start = truth.copy()
    for name, deg in PERTURB.items():
        start[DOF[name]] += np.radians(deg)
    counting = Counting(lik, factored)
    w0 = float(lik.weights(start[None])[0])
    cfg = RefineConfig(offsets=4, levels=3, sweeps=2, factored=factored)
    res = refine_pose(counting, start, w0, cfg, limits=limits)
    assert res.weight > w0 + 0.05
    assert res.evaluations == counting.count
    j_true = body.forward(truth[None])[0]
    err0 = np.linalg.norm(body.forward(start[None])[0] - j_true, axis=1).mean()
    err1 = np.linalg.norm(body.forward(res.pose[None])[0] - j_true, axis=1).mean()
    # measured: 0.040 m -> about 0.01 m
    assert err1 < 0.4 * err0, (err0, err1)
    d = np.degrees(np.abs(res.pose - truth))
    moved = [DOF[n] for n in PERTURB]
    assert np.mean(d[moved]) < 0.4 * np.mean(np.abs(list(PERTURB.values())))


def test_never_lowers_the_weight_and_stays_in_limits(body, limits) -> None:
    truth = _truth(body)
    lik = own_likelihood(body, truth, 1)
    rng = np.random.default_rng(4)
    lo, hi = limits
    for _ in range(4):
        start = truth + rng.normal(0, np.radians(12), truth.shape) * (np.arange(31) >= 6)
        start = np.clip(start, lo, hi)
        w0 = float(lik.weights(start[None])[0])
        res = refine_pose(lik, start, w0, RefineConfig(root=True), limits=limits)
        assert res.weight >= w0
        assert np.all(res.pose >= lo - 1e-12) and np.all(res.pose <= hi + 1e-12)
        assert res.weight == pytest.approx(float(lik.weights(res.pose[None])[0]))


def test_at_the_optimum_nothing_moves(body, limits) -> None:
    truth = _truth(body)
    lik = own_likelihood(body, truth, 2)
    w = float(lik.weights(truth[None])[0])
    res = refine_pose(lik, truth, w, RefineConfig(), limits=limits)
    assert res.weight == pytest.approx(w)
    np.testing.assert_allclose(res.pose, truth, atol=1e-12)


def test_legs_only_leaves_the_upper_body(body, limits) -> None:
    truth = _truth(body)
    lik = own_likelihood(body, truth, 2)
    start = truth.copy()
    start[DOF["trunk_lateral"]] += np.radians(8)
    start[DOF["l_hip_abduction"]] += np.radians(6)
    cfg = RefineConfig(upper_body=False, offsets=4)
    res = refine_pose(lik, start, None, cfg, limits=limits)
    assert res.pose[DOF["trunk_lateral"]] == start[DOF["trunk_lateral"]]
    assert abs(res.pose[DOF["l_hip_abduction"]] - truth[DOF["l_hip_abduction"]]) < np.radians(2)
    legs = list(LEFT_LEG + RIGHT_LEG)
    assert np.count_nonzero(dof_ranges(cfg)[legs]) == len(legs)
    assert np.count_nonzero(dof_ranges(cfg)) == len(legs)


def test_config_validation_and_overrides() -> None:
    cfg = RefineConfig(range_overrides={"l_ankle_rotation": 0, "root_x": 0.05}, root=True)
    r = dof_ranges(cfg)
    assert r[DOF["l_ankle_rotation"]] == 0 and r[DOF["root_x"]] == pytest.approx(0.05)
    with pytest.raises(TrackerConfigError, match="range_overrides"):
        parse_tracker_config({"refine": {"range_overrides": {"l_toe": 3}}})
    with pytest.raises(TrackerConfigError, match="unknown key"):
        parse_tracker_config({"refine": {"sweep": 2}})
    assert not TrackerConfig().refine.enabled  # measured neutral: opt-in (docs/tracker.md)


@pytest.fixture(scope="module")
def walking_frames() -> dict:
    return walking_clip()


def _track(clip: dict, refine: dict):
    from tracker.pipeline import Tracker

    cfg = TrackerConfig.model_validate(
        {"ipf": {"kept": 9}, "refine": refine, "leg_refine": {"enabled": False}}
    )
    tr = Tracker(
        clip["cams"], cfg, rng=np.random.default_rng(0), backgrounds=clip["bgs"], body=clip["body"]
    )
    res = [tr.process(k, k / 20.0, fr) for k, fr in enumerate(clip["frames"])]
    assert [r.status for r in res] == ["initialised", "tracked", "tracked"]
    return res[-1], tr


@pytest.mark.parametrize("inject", [True, False])
def test_pipeline_refines_and_counts(walking_frames: dict, inject: bool, monkeypatch) -> None:
    """A tracked frame's estimate is refined (counted); with ``inject`` it joins the particles."""
    import tracker.refine

    spent: list[int] = []
    plain = tracker.refine.refine_top

    def counted(likelihood, *args, **kwargs):
        before = likelihood.count
        out = plain(likelihood, *args, **kwargs)
        spent.append(likelihood.count - before)
        return out

    monkeypatch.setattr(tracker.refine, "refine_top", counted)
    _track(walking_frames, {"enabled": False})
    assert spent == []
    on, tr = _track(walking_frames, {"enabled": True, "inject": inject})
    # each tracked frame's estimate (frames 1 and 2): legs (2 * 6 + 1)^2 combinations per
    # level, two levels, plus the upper body; the last frame's are among its evaluations
    assert len(spent) == 2 and min(spent) >= 2 * 13**2
    assert on.evaluations >= spent[-1]
    # (the floor constraint may move the root afterwards: it moves every particle's root too)
    in_set = bool(np.any(np.all(tr.filter.particles == on.pose, axis=1)))
    assert in_set == inject


def _track_legs(clip: dict, leg_refine: dict, cameras: int = 2, cue: bool = True):
    """The clip's first two frames (initialised, tracked) with 2D detections that under-read
    the knees' bend (the key points of the true poses with the knees' flexion squeezed, as
    docs/tracker.md "Session 38" measured of the built-in detector); the tracker and the
    tracked frame's result."""
    from tracker.pipeline import Tracker
    from tracker.synthetic import walking_motion

    body = clip["body"]
    cams = clip["cams"][:cameras]
    truth = walking_motion(body, 3, fps=20.0, speed_m_s=1.0)
    knees = [DOF["l_knee_flexion"], DOF["r_knee_flexion"]]
    truth[:, knees] *= 0.3
    dets = [[np.c_[c.project(body.forward(p[None])[0]), np.ones(19)] for c in cams] for p in truth]
    cfg = TrackerConfig.model_validate(
        {
            "ipf": {"kept": 9},
            "leg_refine": leg_refine,
            "keypoints": {"enabled": cue, "detector": "none"},
        }
    )
    tr = Tracker(
        cams, cfg, rng=np.random.default_rng(0), backgrounds=clip["bgs"][:cameras], body=body
    )
    res = [tr.process(k, k / 20.0, clip["frames"][k][:cameras], dets[k]) for k in range(2)]
    assert [r.status for r in res] == ["initialised", "tracked"]
    return tr, res[-1]


def test_leg_refine_searches_only_the_legs_flexion() -> None:
    cfg = TrackerConfig().leg_refine
    assert cfg.enabled and cfg.min_cameras == 2  # on by default with two cameras or more
    r = dof_ranges(cfg.refine_config())
    flex = [DOF[f"{s}_{j}_flexion"] for s in "lr" for j in ("hip", "knee")]
    assert np.all(r[flex] == pytest.approx(np.radians(cfg.range_deg)))
    assert np.count_nonzero(r) == 4
    with pytest.raises(TrackerConfigError):
        parse_tracker_config({"leg_refine": {"range_deg": 0}})


def test_pipeline_refines_the_legs_flexion_without_the_cue(walking_frames: dict) -> None:
    """With two cameras and the key-point cue, the tracked frame's hip and knee flexion are
    searched on the weight without the cue: more evaluations, the other DOFs untouched, and
    the silhouettes prefer the result; one camera or no cue: the track as without it."""
    tr_off, off = _track_legs(walking_frames, {"enabled": False})
    tr_on, on = _track_legs(walking_frames, {"enabled": True})
    assert on.evaluations > off.evaluations
    flex = [DOF[f"{s}_{j}_flexion"] for s in "lr" for j in ("hip", "knee")]
    others = np.setdiff1d(np.arange(6, len(on.pose)), flex)
    np.testing.assert_array_equal(on.pose[others], off.pose[others])
    assert not np.array_equal(on.pose[flex], off.pose[flex])
    inner = tr_on._lik.inner
    cue, inner.keypoints = inner.keypoints, None
    try:
        plain = inner.weights(np.stack([on.pose, off.pose]))
    finally:
        inner.keypoints = cue
    assert plain[0] > plain[1]
    for kw in ({"cameras": 1}, {"cue": False}):
        _, a = _track_legs(walking_frames, {"enabled": False}, **kw)
        _, b = _track_legs(walking_frames, {"enabled": True}, **kw)
        assert a.evaluations == b.evaluations
        np.testing.assert_array_equal(a.pose, b.pose)
