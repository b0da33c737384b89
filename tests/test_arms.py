"""The arm search after the filter (tracker.arms)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.tracker_helpers import Counting, own_likelihood, walking_clip
from tracker.arms import arm_grid, search_arms
from tracker.body import BodyModel
from tracker.config import ArmSearchConfig, TrackerConfig, TrackerConfigError, parse_tracker_config
from tracker.dof import DOF

ARM_DOFS = [
    DOF[f"{s}_{n}"]
    for s in ("l", "r")
    for n in ("shoulder_flexion", "shoulder_abduction", "shoulder_rotation", "elbow_flexion")
]


def _truth(body: BodyModel) -> np.ndarray:
    """A walking pose with swinging, bent arms (elbows 35-45 degrees, as in the recordings)."""
    p = body.neutral_pose(x=0.1, y=0.05, yaw=0.3)
    for name, deg in (
        ("l_hip_flexion", 20),
        ("r_hip_flexion", -10),
        ("r_knee_flexion", 25),
        ("l_shoulder_flexion", -20),
        ("l_shoulder_abduction", 12),
        ("l_elbow_flexion", 35),
        ("r_shoulder_flexion", 22),
        ("r_shoulder_abduction", 10),
        ("r_elbow_flexion", 45),
    ):
        p[DOF[name]] = np.radians(deg)
    return p


def _wrist_error(body: BodyModel, a: np.ndarray, b: np.ndarray) -> float:
    from gaitwatch.conventions import KP

    ja, jb = body.forward(a[None])[0], body.forward(b[None])[0]
    idx = [KP["left_wrist"], KP["right_wrist"]]
    return float(np.linalg.norm(ja[idx] - jb[idx], axis=1).mean())


def test_recovers_lost_arms(body, limits) -> None:
    """Arms collapsed onto the trunk (straight, hanging: the failure seen on the benchmark) are
    found again; nothing else moves; the evaluations are the grid's."""
    truth = _truth(body)
    lik = own_likelihood(body, truth)
    start = truth.copy()
    for s in ("l", "r"):
        start[DOF[f"{s}_shoulder_flexion"]] = 0.0
        start[DOF[f"{s}_shoulder_abduction"]] = 0.0
        start[DOF[f"{s}_elbow_flexion"]] = 0.0
    w0 = float(lik.weights(start[None])[0])
    counting = Counting(lik, factored=False)
    cfg = ArmSearchConfig(levels=2)
    res = search_arms(counting, start, w0, cfg, limits=limits)
    assert res.evaluations == counting.count == cfg.levels * 2 * cfg.grid_size == 756
    assert res.weight > w0 + 0.01
    assert res.weight == pytest.approx(float(lik.weights(res.pose[None])[0]))
    err0, err1 = _wrist_error(body, start, truth), _wrist_error(body, res.pose, truth)
    # measured: 0.26 m -> 0.013 m (weight 0.82 -> 0.97, truth 1.0)
    assert err1 < 0.5 * err0, (err0, err1)
    others = np.setdiff1d(np.arange(31), ARM_DOFS)
    np.testing.assert_allclose(res.pose[others], start[others], atol=1e-12)


def test_never_lowers_the_weight_and_stays_in_limits(body, limits) -> None:
    truth = _truth(body)
    lik = own_likelihood(body, truth)
    lo, hi = limits
    w = float(lik.weights(truth[None])[0])
    res = search_arms(lik, truth, w, ArmSearchConfig(), limits=limits)
    assert res.weight >= w
    rng = np.random.default_rng(3)
    for _ in range(3):
        start = truth.copy()
        start[ARM_DOFS] += rng.normal(0, np.radians(25), len(ARM_DOFS))
        start = np.clip(start, lo, hi)
        w0 = float(lik.weights(start[None])[0])
        res = search_arms(lik, start, w0, ArmSearchConfig(levels=1), limits=limits)
        assert res.weight >= w0
        assert np.all(res.pose >= lo - 1e-12) and np.all(res.pose <= hi + 1e-12)


def test_rank_steers_the_choice_and_the_weight_stays_the_likelihoods(body, limits) -> None:
    """A ranking factor (the edge cue's, ``edges.scope = "arm_search"``) picks among the grid;
    the result's weight is the likelihood's own, and a factor of 1 changes nothing."""
    truth = _truth(body)
    lik = own_likelihood(body, truth)
    w = float(lik.weights(truth[None])[0])
    cfg = ArmSearchConfig(levels=1)
    plain = search_arms(lik, truth, w, cfg, limits=limits)
    ones = search_arms(lik, truth, w, cfg, limits=limits, rank=lambda p: np.ones(len(p)))
    np.testing.assert_array_equal(ones.pose, plain.pose)
    assert ones.weight == plain.weight
    # a factor that rewards a straighter left elbow moves it off the truth
    target = truth[DOF["l_elbow_flexion"]] - np.radians(25)

    def rank(poses: np.ndarray) -> np.ndarray:
        return np.exp(-np.abs(poses[:, DOF["l_elbow_flexion"]] - target))

    res = search_arms(lik, truth, w, cfg, limits=limits, rank=rank)
    assert res.pose[DOF["l_elbow_flexion"]] < truth[DOF["l_elbow_flexion"]] - 0.1
    assert res.weight == pytest.approx(float(lik.weights(res.pose[None])[0]))
    assert res.weight < w  # the silhouette alone preferred the truth


def test_grid_and_config() -> None:
    names, grid = arm_grid(ArmSearchConfig(range_rotation_deg=0, flexion_values=5))
    assert names == ["shoulder_flexion", "shoulder_abduction", "elbow_flexion"]
    assert (
        grid.shape
        == (5 * 9, 3)
        == (ArmSearchConfig(flexion_values=5, range_rotation_deg=0).grid_size, 3)
    )
    assert np.any(np.all(grid == 0, axis=1))  # the current pose is a candidate
    assert np.degrees(grid[:, 0]).max() == pytest.approx(30.0)
    with pytest.raises(TrackerConfigError, match="unknown key"):
        parse_tracker_config({"arms": {"range_wrist_deg": 3}})
    with pytest.raises(TrackerConfigError):
        parse_tracker_config({"arms": {"levels": 0}})
    with pytest.raises(TrackerConfigError, match="odd"):
        parse_tracker_config({"arms": {"flexion_values": 6}})
    c = TrackerConfig()
    # on with two cameras or more, one level (docs/tracker.md, "Arm search")
    assert c.arms.enabled and c.arms.min_cameras == 2 and c.arms.levels == 1


@pytest.fixture(scope="module")
def walking_frames() -> dict:
    return walking_clip()


def _track(clip: dict, arms: dict, n_cams: int = 2):
    from tracker.pipeline import Tracker

    # the legs' refinement off: the two tracks differ only by the arm search
    cfg = TrackerConfig.model_validate(
        {"ipf": {"kept": 9}, "arms": arms, "leg_refine": {"enabled": False}}
    )
    cams = clip["cams"][:n_cams]
    frames = [fr[:n_cams] for fr in clip["frames"]]
    tr = Tracker(
        cams, cfg, rng=np.random.default_rng(0), backgrounds=clip["bgs"][:n_cams], body=clip["body"]
    )
    res = [tr.process(k, k / 20.0, fr) for k, fr in enumerate(frames)]
    assert [r.status for r in res] == ["initialised", "tracked", "tracked"]
    return res[-1]


def test_pipeline_searches_the_arms_with_two_cameras(walking_frames: dict) -> None:
    off = _track(walking_frames, {"enabled": False})
    on = _track(walking_frames, {"enabled": True})
    assert on.evaluations >= off.evaluations + ArmSearchConfig().levels * 2 * 189
    assert on.weight >= off.weight - 0.02
    # one camera: below min_cameras the search does not run (same evaluations as off)
    one_off = _track(walking_frames, {"enabled": False}, n_cams=1)
    one_on = _track(walking_frames, {"enabled": True}, n_cams=1)
    assert one_on.evaluations == one_off.evaluations
    np.testing.assert_array_equal(one_on.pose, one_off.pose)


def test_weights_moving_equals_whole_renderings(body) -> None:
    """One arm's variants weighed with the rest of the body rendered once: the same weights,
    bit for bit, as rendering every pose whole."""
    truth = _truth(body)
    lik = own_likelihood(body, truth)
    rng = np.random.default_rng(5)
    for side, first in (("l", DOF["l_shoulder_flexion"]), ("r", DOF["r_shoulder_flexion"])):
        poses = np.repeat(truth[None], 50, axis=0)
        poses[:, first : first + 4] += rng.normal(0, 0.5, (50, 4))
        moving = lik.weights_moving(truth, poses, body.arm_capsules[side])
        np.testing.assert_array_equal(moving, lik.weights(poses))
        assert np.ptp(moving) > 0.01  # the arm moves do change the weight
    assert [len(body.arm_capsules[s]) for s in ("l", "r")] == [3, 3]


def test_no_arm_search_while_the_leg_length_is_scored(walking_frames: dict, monkeypatch) -> None:
    """The leg-length trials weigh bodies against each other: arms searched on the body in use
    would favour its length. The search starts once the length is fixed."""
    import tracker.pipeline as pipeline

    frame, calls = [0], []
    real = pipeline.search_arms

    def spy(*args, **kwargs):
        calls.append(frame[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(pipeline, "search_arms", spy)
    cfg = TrackerConfig.model_validate(
        {
            "ipf": {"kept": 9},
            "init": {
                "girths": (1.0,),
                "part_girths": (1.0,),
                "hems": (),
                "leg_lengths": (0.95, 1.0, 1.05),
                "leg_length_frames": 1,
            },
        }
    )
    clip = walking_frames
    tr = pipeline.Tracker(clip["cams"], cfg, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    statuses = []
    for k, fr in enumerate(clip["frames"]):
        frame[0] = k
        statuses.append(tr.process(k, k / 20.0, fr).status)
    assert statuses == ["initialised", "tracked", "tracked"]
    # frame 1 scores the leg lengths (leg_length_frames = 1): no search there or before
    assert calls and min(calls) == 2, calls
