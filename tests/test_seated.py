"""The tracker's seated mode (config.seated): someone sits down while the joint limits are the
walking profile's, and stands up again."""

from __future__ import annotations

import numpy as np
import pytest

from gaitwatch.conventions import SACRUM
from tracker.body import BodyModel
from tracker.config import TrackerConfig
from tracker.dof import DOF, DOF_NAMES, SEATED_DOFS, JointLimits

FPS = 20.0


def test_seated_limits_widen_only_the_seated_dofs() -> None:
    walk = TrackerConfig()
    lo, hi = walk.joint_limits().arrays()
    slo, shi = walk.seated_limits().arrays()
    glo, ghi = JointLimits.profile("general").arrays()
    for i, name in enumerate(DOF_NAMES):
        if name in SEATED_DOFS:
            assert slo[i] == min(lo[i], glo[i]) and shi[i] == max(hi[i], ghi[i])
        else:
            assert (slo[i], shi[i]) == (lo[i], hi[i])
    assert np.degrees(shi[DOF["l_knee_flexion"]]) >= 120 > np.degrees(hi[DOF["l_knee_flexion"]])
    general = TrackerConfig(limits_profile="general")
    for a, b in zip(general.seated_limits().arrays(), general.joint_limits().arrays(), strict=True):
        np.testing.assert_array_equal(a, b)


def _sit_down_poses(body: BodyModel, schedule: list[tuple[float, str]] | None = None) -> np.ndarray:
    """Standing 0.5 s, sitting down over 1 s (hips 90, knees 105 deg, trunk leaning 30 deg
    then 10), seated 1 s, standing up over 1 s, standing 0.5 s: (81, 31) poses at 20 Hz; or
    the key poses ("stand", "lean", "seated") at the times of ``schedule``."""
    stand = body.neutral_pose(1.0, 0.0, 0.6)
    seated = stand.copy()
    for side in ("l", "r"):
        seated[DOF[f"{side}_hip_flexion"]] = np.radians(90.0)
        seated[DOF[f"{side}_knee_flexion"]] = np.radians(105.0)
        seated[DOF[f"{side}_ankle_flexion"]] = np.radians(15.0)
    seated[DOF["trunk_flexion"]] = np.radians(10.0)
    # the seated pelvis behind the feet, the feet on the floor where they stood
    feet = [15, 16, 17, 18]
    j0 = body.forward(stand[None])[0]
    j1 = body.forward(seated[None])[0]
    seated[:2] += j0[feet, :2].mean(axis=0) - j1[feet, :2].mean(axis=0)
    seated[2] -= j1[feet, 2].min() - j0[feet, 2].min()
    lean = 0.5 * (stand + seated)
    lean[DOF["trunk_flexion"]] = np.radians(30.0)
    named = {"stand": stand, "lean": lean, "seated": seated}
    if schedule is None:
        schedule = [(0.0, "stand"), (0.5, "stand"), (1.0, "lean"), (1.5, "seated")]
        schedule += [(2.5, "seated"), (3.0, "lean"), (3.5, "stand"), (4.0, "stand")]
    keys = [(t, named[name]) for t, name in schedule]
    times = np.arange(0.0, keys[-1][0] + 1e-9, 1.0 / FPS)
    kt = np.array([k[0] for k in keys])
    kp = np.stack([k[1] for k in keys])
    i = np.clip(np.searchsorted(kt, times, side="right") - 1, 0, len(kt) - 2)
    w = 0.5 - 0.5 * np.cos(np.pi * np.clip((times - kt[i]) / (kt[i + 1] - kt[i]), 0, 1))
    return (1 - w)[:, None] * kp[i] + w[:, None] * kp[i + 1]


def _sit_down_clip(schedule: list[tuple[float, str]] | None = None):
    """:func:`_sit_down_poses` of the tracker's own body, seen by two cameras at 320x240."""
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.synthetic import render_clip, side_cameras, textured_background

    body = BodyModel(1.70)
    poses = _sit_down_poses(body, schedule)
    rng = np.random.default_rng(5)
    cams = side_cameras(2, image_size=(320, 240), centre=(1.0, 0.0), fps=FPS)
    bgs = [textured_background(320, 240, rng) for _ in cams]
    frames = list(render_clip(SilhouetteLikelihood(body, cams), poses, bgs, rng))
    return body, cams, bgs, frames, np.asarray(body.forward(poses))


@pytest.fixture(scope="module")
def clip():
    return _sit_down_clip()


def test_lower_than_standing_from_the_silhouettes_alone(clip) -> None:
    """The seated search's gate: a silhouette shorter than a standing body of the stature at
    its floor point by seated.lower_fraction, in every camera."""
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.pipeline import Tracker

    body, cams, bgs, _, _ = clip
    tracker = Tracker(
        cams, TrackerConfig(), rng=np.random.default_rng(0), backgrounds=bgs, body=body
    )
    render = SilhouetteLikelihood(body, tracker.lik_cameras)
    poses = _sit_down_poses(body)
    first, seated = poses[0], poses[40]
    fraction = TrackerConfig().seated.lower_fraction
    tracker._masks = [np.asarray(render.render_mask(first, c)) for c in range(len(cams))]
    assert not tracker._lower_than_standing(fraction)
    tracker._masks = [np.asarray(render.render_mask(seated, c)) for c in range(len(cams))]
    assert tracker._lower_than_standing(fraction)
    # one camera that sees nobody is left out; none at all is not "lower"
    tracker._masks[0] = np.zeros_like(tracker._masks[0])
    assert tracker._lower_than_standing(fraction)
    tracker._masks[1] = np.zeros_like(tracker._masks[1])
    assert not tracker._lower_than_standing(fraction)


def _track(clip, seated: bool):
    from tracker.pipeline import Tracker

    body, cams, bgs, frames, truth = clip
    cfg = TrackerConfig.model_validate({"seated": {"enabled": seated}})
    tracker = Tracker(cams, cfg, rng=np.random.default_rng(0), backgrounds=bgs, body=body)
    joints, modes = [], []
    for k, fr in enumerate(frames):
        res = tracker.process(k, k / FPS, fr)
        assert res.has_pose
        joints.append(res.joints)
        modes.append(tracker._seated)
    return np.stack(joints), np.array(modes), truth


def test_sitting_down_switches_to_the_seated_limits_and_back(clip) -> None:
    joints, modes, truth = _track(clip, True)
    seated = slice(32, 50)  # 1.6-2.5 s
    err = np.linalg.norm(joints - truth, axis=2).mean(axis=1)
    print("error while seated", err[seated].mean(), "mode", modes.astype(int))
    assert modes[seated].all()  # the seated limits apply while seated
    assert not modes[-3:].any()  # and the walking limits once standing again
    # the estimate sits: its sacrum as low as the truth's, within 0.1 m
    assert np.abs(joints[seated, SACRUM, 2] - truth[seated, SACRUM, 2]).max() < 0.1
    assert err[seated].mean() < 0.12  # 0.056 m (seed 0)
    # under the walking limits alone the estimate cannot sit
    joints_w, modes_w, _ = _track(clip, False)
    assert not modes_w.any()
    err_w = np.linalg.norm(joints_w - truth, axis=2).mean(axis=1)
    print("walking limits only: error while seated", err_w[seated].mean())
    assert err_w[seated].mean() > 2 * err[seated].mean()  # 0.398 m


def test_someone_seated_from_the_first_frame_is_found_seated() -> None:
    """A track that starts on a seated person (under the walking limits the initial search
    has no seated configuration) switches once the floor point's speed is known."""
    clip = _sit_down_clip([(0.0, "seated"), (2.5, "seated"), (3.0, "lean"), (3.5, "stand")])
    joints, modes, truth = _track(clip, True)
    seated = slice(20, 50)  # 1.0-2.5 s
    print("mode", modes.astype(int))
    assert not modes[:5].any()  # the speed is not known in the track's first frames
    assert modes[seated].all()
    assert not modes[-2:].any()
    err = np.linalg.norm(joints - truth, axis=2).mean(axis=1)
    print("error while seated", err[seated].mean())
    assert np.abs(joints[seated, SACRUM, 2] - truth[seated, SACRUM, 2]).max() < 0.1
    assert err[seated].mean() < 0.12


def _tracker(clip, **seated):
    from tracker.pipeline import Tracker

    body, cams, bgs, _, _ = clip
    cfg = TrackerConfig.model_validate({"seated": seated})
    return Tracker(cams, cfg, rng=np.random.default_rng(0), backgrounds=bgs, body=body)


def _set_floor_points(tracker, times: np.ndarray, floor: np.ndarray) -> None:
    """The silhouettes' floor points up to the last time (the current frame); NaN rows are
    frames without one."""
    ok = np.isfinite(floor).all(axis=1)
    tracker._floor_hist = [
        (float(t), float(f[0]), float(f[1])) for t, f in zip(times[ok], floor[ok], strict=True)
    ]
    tracker._time_now, tracker._floor_now = float(times[-1]), np.asarray(floor[-1], float)


def _staircase(times: np.ndarray, speed: float, step: float) -> np.ndarray:
    """The nearest foot's floor point of a walker along x: it stands still while in stance and
    jumps by a step when the other foot lands ahead."""
    x = step * np.floor(times * speed / step)
    return np.stack([x, np.full_like(x, 0.3)], axis=1)


def test_floor_speed_rides_over_the_feet_alternation(clip) -> None:
    tracker = _tracker(clip)
    times = np.arange(0.0, 2.0 + 1e-9, 1 / FPS)
    for speed, step in [(0.5, 0.3), (1.0, 0.6), (0.4, 0.35)]:
        for start in (0.0, 0.13, 0.37):  # the window against the steps' phase
            _set_floor_points(tracker, times, _staircase(times + start, speed, step))
            v = tracker._floor_speed(1.0)
            assert 0.5 * speed < v < 2.5 * speed, (speed, step, start, v)
    # standing still: 2 cm of noise and one frame's floor point 2 m off
    rng = np.random.default_rng(3)
    still = np.array([1.0, 0.5]) + rng.normal(0, 0.02, (times.size, 2))
    still[-8] += [2.0, 0.0]
    _set_floor_points(tracker, times, still)
    assert tracker._floor_speed(1.0) < 0.1
    # frames without a floor point are left out
    still[-5:-2] = np.nan
    _set_floor_points(tracker, times, still)
    assert tracker._floor_speed(1.0) < 0.1
    # a re-initialised estimate does not reset the silhouettes' floor points
    tracker._path = []
    assert tracker._floor_speed(1.0) < 0.1
    # nobody in view: they are forgotten
    tracker._no_pose(40, 2.0, "nobody in view")
    assert tracker._floor_hist == [] and tracker._floor_speed(1.0) is None
    # a history shorter than half the window says nothing
    _set_floor_points(tracker, times[:8], still[:8])
    assert tracker._floor_speed(1.0) is None
    tracker._floor_hist = []
    assert tracker._floor_speed(1.0) is None


def test_seated_search_waits_for_the_person_to_stand_still(clip, monkeypatch) -> None:
    """A short silhouette that walks (crouch gait, legs behind furniture) is not someone sitting
    down: the seated search does not run until the floor point stands still."""
    tracker = _tracker(clip)
    searched = []

    def search(*args, **kwargs):
        searched.append(True)
        return None

    monkeypatch.setattr(tracker, "_lower_than_standing", lambda fraction: True)
    monkeypatch.setattr(tracker, "_reduced_search", search)
    pose = tracker.body.neutral_pose(1.0, 0.0, 0.0)
    times = np.arange(0.0, 1.5 + 1e-9, 1 / FPS)
    _set_floor_points(tracker, times, _staircase(times, 0.6, 0.35))  # crouch gait's speed
    out, w = tracker._seated_search(pose, 0.5, 1 / FPS)
    assert not searched and out is pose and w == 0.5
    _set_floor_points(tracker, times[:3], np.full((3, 2), 1.0))  # the track's first frames
    tracker._seated_search(pose, 0.5, 1 / FPS)
    assert not searched
    _set_floor_points(tracker, times, np.full((times.size, 2), 1.0))  # standing still
    tracker._seated_search(pose, 0.5, 1 / FPS)
    assert searched == [True]
    # with the gate's speed raised, the walker is searched too
    tracker = _tracker(clip, max_floor_speed_m_s=5.0)
    monkeypatch.setattr(tracker, "_lower_than_standing", lambda fraction: True)
    monkeypatch.setattr(tracker, "_reduced_search", search)
    _set_floor_points(tracker, times, _staircase(times, 0.6, 0.35))
    tracker._seated_search(pose, 0.5, 1 / FPS)
    assert searched == [True, True]
