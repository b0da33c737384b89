"""The tracking pipeline and ``gaitwatch track`` on a short synthetic clip.

The clip: the body model walking (DOF sinusoids, 1 m/s, 105 steps/min) seen by two cameras
2.3 m high (side and oblique), rendered as flat-coloured silhouettes over a textured background
with sensor noise, 320x240 frames at 20 Hz (likelihood at 160x120), written as PNG folders.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest

from gaitwatch.conventions import L_ANKLE, L_HIP, L_KNEE, R_ANKLE, R_HIP, R_KNEE
from service.cli import main
from service.poselog import read_poselog
from tests.conftest import shared_file
from tests.tracker_helpers import assert_written_is_model
from tracker.camera import save_camera
from tracker.config import IPFConfig, KeypointConfig, TrackerConfig

LOWER = [L_HIP, R_HIP, L_KNEE, R_KNEE, L_ANKLE, R_ANKLE]
SIZE = (320, 240)
FPS = 20.0
N_FRAMES = 24


@pytest.fixture(scope="module")
def clip(tmp_path_factory: pytest.TempPathFactory) -> dict:
    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    root = tmp_path_factory.mktemp("clip")
    rng = np.random.default_rng(123)
    body = BodyModel(1.70)
    cams = side_cameras(2, image_size=SIZE, centre=(1.0, 0.0), fps=FPS)
    poses = walking_motion(body, N_FRAMES, fps=FPS, speed_m_s=1.0, start_xy=(0.2, 0.0))
    truth = np.asarray(body.forward(poses))
    renderer = SilhouetteLikelihood(body, cams)
    bgs = [textured_background(*SIZE, rng) for _ in cams]
    frames = list(render_clip(renderer, poses, bgs, rng))
    cam_files, bg_files, folders = [], [], []
    for c, cam in enumerate(cams):
        f = root / f"cam{c}.yaml"
        save_camera(cam, f)
        cam_files.append(f)
        b = root / f"cam{c}-background.png"
        cv2.imwrite(str(b), bgs[c])
        bg_files.append(b)
        d = root / f"cam{c}"
        d.mkdir()
        for i, fr in enumerate(frames):
            cv2.imwrite(str(d / f"frame{i:04d}.png"), fr[c])
        folders.append(d)
    return {
        "root": root,
        "body": body,
        "cams": cams,
        "poses": poses,
        "truth": truth,
        "bgs": bgs,
        "frames": frames,
        "cam_files": cam_files,
        "bg_files": bg_files,
        "folders": folders,
    }


def _args(clip: dict, out: Path, *extra: str, folders=None, cams=None, bgs=True) -> list[str]:
    a = ["-q", "track", *map(str, folders or clip["folders"])]
    for c in cams or clip["cam_files"]:
        a += ["--camera", str(c)]
    if bgs:
        for b in clip["bg_files"]:
            a += ["--background", str(b)]
    return [*a, "--out", str(out), "--no-progress", *extra]


def _lower_limb_error(joints: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Mean distance (m) over hips, knees and ankles, per frame."""
    return np.linalg.norm(joints[:, LOWER] - truth[:, LOWER], axis=-1).mean(axis=-1)


# -- accuracy on the synthetic clip -------------------------------------------------------------
#: The IPF as issue 3 describes it (the defaults add a coarse-to-fine pass and a diverse
#: selection; docs/tracker.md).
METHOD = {
    "interval_centre": "value",
    "adaptive_width": 0,
    "refine_share": 0,
    "max_per_group": 0,
    "anneal": {"share": 0.0},
}


@pytest.mark.parametrize("n_cams", [1, 2, 3])
def test_ipf_anneals_only_with_enough_cameras(n_cams: int) -> None:
    """The IPF's annealing stage (``ipf.anneal``, opt-in) runs with ``min_cameras`` cameras or
    more; below, its groups go back to the grid. The filter's evaluations stay the same."""
    from tracker.pipeline import Tracker
    from tracker.synthetic import side_cameras

    cams = side_cameras(n_cams, image_size=SIZE, fps=FPS)
    assert TrackerConfig().ipf.anneal_groups == 0  # opt-in
    config = TrackerConfig(keypoints={"enabled": False}, ipf={"anneal": {"share": 0.15}})
    assert config.ipf.anneal.min_cameras == 2 and config.ipf.anneal_groups == 12
    tracker = Tracker(cams, config, rng=np.random.default_rng(0))
    f = tracker.filter
    assert f.evaluations_per_step == config.evaluations_per_frame == 6561
    if n_cams < 2:
        assert f.M == 81 and f.anneal_sizes == []
    else:
        assert f.M == 69 and f.anneal_sizes == [486, 486]
    # the trials' and the heading alternative's filters are built from the same settings
    assert tracker._filter_config.ipf.anneal_groups == (0 if n_cams < 2 else 12)
    three = TrackerConfig(
        keypoints={"enabled": False}, ipf={"anneal": {"share": 0.15, "min_cameras": 3}}
    )
    m_three = Tracker(cams, three, rng=np.random.default_rng(0)).filter.M
    assert m_three == (69 if n_cams >= 3 else 81)


@pytest.mark.parametrize(
    ("label", "ipf", "bound_m"),
    [
        # Measured on this clip (mean over frames, seed 0, session 11): the method 0.028 m,
        # velocity-centred intervals 0.030 m, the defaults (the method's intervals with a
        # coarse-to-fine pass and a diverse selection) 0.026 m. The method's bound is loose:
        # its intervals follow at most w/2 = 5 deg per frame, slower than the knee in swing,
        # and in earlier versions its legs now and then swapped (0.05-0.17 m over seeds).
        ("method", METHOD, 0.25),
        ("velocity", {**METHOD, "interval_centre": "velocity"}, 0.09),
        ("default", {}, 0.09),
    ],
)
def test_tracker_follows_lower_limbs(clip: dict, label: str, ipf: dict, bound_m: float) -> None:
    from tracker.pipeline import Tracker

    config = TrackerConfig(ipf=IPFConfig(**ipf))
    tracker = Tracker(
        clip["cams"],
        config,
        rng=np.random.default_rng(0),
        backgrounds=clip["bgs"],
        body=clip["body"],
    )
    joints = []
    for i, frames in enumerate(clip["frames"]):
        res = tracker.process(i, i / FPS, frames)
        assert res.has_pose, res.reason
        assert res.status == "initialised" if i == 0 else res.status != "no_pose"
        assert res.evaluations >= config.evaluations_per_frame
        joints.append(res.joints)
    err = _lower_limb_error(np.stack(joints), clip["truth"])
    print(f"{label}: lower-limb error mean {err.mean():.3f} m, max {err.max():.3f} m")
    assert err[0] < 0.12  # the exhaustive initial search finds the person
    assert err.mean() < bound_m


def test_tracker_on_an_independent_rendering() -> None:
    """A clip of the scene synthesiser (its own mesh body, clothing, room, lighting, shadow),
    three cameras."""
    from gaitwatch.sim.motion import procedural_walk
    from gaitwatch.sim.scene import SceneConfig
    from gaitwatch.sim.synth import build_scene, render_background, render_frames
    from tracker.pipeline import Tracker

    walk = procedural_walk(
        height_m=1.70, speed_m_s=1.0, cadence_steps_min=105, distance_m=1.6, start=(0.0, 0.0)
    )
    scene = build_scene(
        walk,
        SceneConfig(image_size=SIZE, fps=FPS, views=["side", "oblique", "frontal"], seed=0),
    )
    bgs = [np.ascontiguousarray(render_background(scene, i)[..., ::-1]) for i in range(3)]
    tracker = Tracker(
        scene.cameras,
        TrackerConfig(),
        rng=np.random.default_rng(0),
        height_m=float(scene.body.stature_m),
        backgrounds=bgs,
    )
    joints = []
    for k, images, _ in render_frames(scene):
        res = tracker.process(k, k / FPS, [np.ascontiguousarray(im[..., ::-1]) for im in images])
        assert res.has_pose
        joints.append(res.joints)
    err = _lower_limb_error(np.stack(joints), scene.truth.positions)
    print(f"independent rendering: lower-limb error mean {err.mean():.3f} m, max {err.max():.3f}")
    # Measured with tracker seed 0: mean 0.063 m with the defaults (girth estimated at the first
    # frame, coarse-to-fine velocity-centred IPF, origin searched again after the legs); the
    # method's own settings gave 0.08-0.20 m over seeds 0-3.
    assert err.mean() < 0.15


def test_girth_estimated_over_the_first_frames(clip: dict) -> None:
    """A heavier person gets a heavier model; the girth is then fixed.

    The silhouettes the likelihood sees are about 20 % larger than the model's own rendering
    (segmentation clean-up at 160x120), so the estimate absorbs that too: it is compared between
    a default and a heavy person rather than with the rendered girth.
    """
    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.pipeline import Tracker
    from tracker.synthetic import render_clip

    girths = (0.8, 0.9, 1.0, 1.15, 1.3, 1.5, 1.7)
    config = TrackerConfig(ipf=IPFConfig(kept=9), init={"girths": girths, "girth_frames": 3})
    found = []
    for girth in (1.0, 1.4):
        person = SilhouetteLikelihood(BodyModel(1.70, girth=girth), clip["cams"])
        frames = list(render_clip(person, clip["poses"][:5], clip["bgs"], np.random.default_rng(1)))
        tracker = Tracker(
            clip["cams"], config, rng=np.random.default_rng(0), backgrounds=clip["bgs"]
        )
        assert tracker.body.girth == 1.0
        seen = []
        for i in range(5):
            tracker.process(i, i / FPS, frames[i])
            seen.append(tracker.body.girth)
            assert tracker.likelihood.body is tracker.body
        assert seen[2] == seen[3] == seen[4]  # fixed after girth_frames
        found.append(seen[-1])
    print(f"estimated girth: {found[0]} (person 1.0), {found[1]} (person 1.4)")
    assert found[1] > found[0]
    # one value: no estimation
    fixed = TrackerConfig(ipf=IPFConfig(kept=9), init={"girths": (1.0,)})
    tracker = Tracker(clip["cams"], fixed, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    tracker.process(0, 0.0, frames[0])
    tracker.process(1, 1 / FPS, frames[1])
    assert tracker.body.girth == 1.0
    # one value other than 1.0: the tracker's body has that girth from the start
    fixed = TrackerConfig(ipf=IPFConfig(kept=9), init={"girths": (1.3,), "part_girths": (1.0,)})
    tracker = Tracker(clip["cams"], fixed, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    assert tracker.body.girth == 1.3
    tracker.process(0, 0.0, frames[0])
    assert tracker.body.girth == 1.3 and tracker.likelihood.body is tracker.body


def test_leg_length_estimated_with_two_cameras(clip: dict) -> None:
    """A long-legged person gets longer model legs than a short-legged one of the same height
    (two cameras); the length is then fixed. One camera, or one value: nothing estimated."""
    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.pipeline import Tracker
    from tracker.synthetic import render_clip, walking_motion

    lengths = (0.9, 1.0, 1.1)
    config = TrackerConfig(
        ipf=IPFConfig(kept=9),
        init={
            "girths": (1.0,),
            "part_girths": (1.0,),
            "hems": (),
            "leg_lengths": lengths,
            "leg_length_frames": 3,
        },
    )
    found, clips = [], {}
    for s in (0.9, 1.1):
        body = BodyModel(1.70, leg_length=s)
        poses = walking_motion(body, 6, fps=FPS, speed_m_s=1.0, start_xy=(0.2, 0.0))
        person = SilhouetteLikelihood(body, clip["cams"])
        frames = list(render_clip(person, poses, clip["bgs"], np.random.default_rng(1)))
        clips[s] = frames
        tracker = Tracker(
            clip["cams"], config, rng=np.random.default_rng(0), backgrounds=clip["bgs"]
        )
        assert tracker.body.leg_length == 1.0
        seen = []
        for i in range(6):
            res = tracker.process(i, i / FPS, frames[i])
            assert res.has_pose
            assert tracker.likelihood.body is tracker.body
            # the estimate is the body's own, and that body stands on the floor (floor contact:
            # the lowest key point within the tolerance of z = 0)
            model = tracker.body.forward(res.pose[None])[0]
            assert_written_is_model(res.joints, model)
            assert abs(model[:, 2].min()) <= config.floor_tolerance_m + 1e-9
            seen.append(tracker.body.leg_length)
        assert seen[0] == 1.0  # the initialised frame is not scored
        assert seen[3] == seen[4] == seen[5]  # fixed after leg_length_frames tracked frames
        found.append(seen[-1])
    print(f"estimated leg length: {found[0]} (person 0.9), {found[1]} (person 1.1)")
    assert found[0] < found[1]
    # one camera: the table's leg length, nothing estimated
    one = Tracker(
        clip["cams"][:1], config, rng=np.random.default_rng(0), backgrounds=clip["bgs"][:1]
    )
    for i in range(4):
        one.process(i, i / FPS, clips[1.1][i][:1])
    assert one.body.leg_length == 1.0
    # one value: that leg length from the start
    fixed = config.model_copy(
        update={"init": config.init.model_copy(update={"leg_lengths": (1.1,)})}
    )
    tracker = Tracker(clip["cams"], fixed, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    assert tracker.body.leg_length == 1.1
    tracker.process(0, 0.0, clips[0.9][0])
    tracker.process(1, 1 / FPS, clips[0.9][1])
    assert tracker.body.leg_length == 1.1


def test_part_girths_estimated_over_the_first_tracked_frames(clip: dict) -> None:
    """A person with thick legs gets thicker thighs and shanks than a default person; the
    factors are then fixed. One value: that factor on every part, nothing estimated."""
    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.pipeline import Tracker
    from tracker.synthetic import render_clip

    factors = (0.8, 1.0, 1.25, 1.5, 1.8)
    config = TrackerConfig(
        ipf=IPFConfig(kept=9),
        init={
            "girths": (1.0,),
            "part_girths": factors,
            "part_girth_frames": 3,
            "part_girth_max_multi_camera": None,  # every factor, two cameras as they are
        },
    )
    found = []
    for legs in (1.0, 1.6):
        shape = {"thighs": legs, "shanks": legs}
        person = SilhouetteLikelihood(BodyModel(1.70, part_girths=shape), clip["cams"])
        frames = list(render_clip(person, clip["poses"][:6], clip["bgs"], np.random.default_rng(1)))
        tracker = Tracker(
            clip["cams"], config, rng=np.random.default_rng(0), backgrounds=clip["bgs"]
        )
        assert set(tracker.body.part_girths.values()) == {1.0}
        seen = []
        for i in range(6):
            res = tracker.process(i, i / FPS, frames[i])
            assert res.has_pose
            assert tracker.likelihood.body is tracker.body
            seen.append(dict(tracker.body.part_girths))
        assert seen[0] == dict.fromkeys(seen[0], 1.0)  # the initialised frame is not scored
        assert seen[3] == seen[4] == seen[5]  # fixed after part_girth_frames tracked frames
        assert all(v in factors for v in seen[-1].values())
        found.append(seen[-1])
    print(f"estimated part girths: {found[0]} (default legs), {found[1]} (legs 1.6)")
    assert found[1]["thighs"] + found[1]["shanks"] > found[0]["thighs"] + found[0]["shanks"]
    one = TrackerConfig(ipf=IPFConfig(kept=9), init={"girths": (1.0,), "part_girths": (1.2,)})
    tracker = Tracker(clip["cams"], one, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    assert set(tracker.body.part_girths.values()) == {1.2}
    for i in range(3):
        tracker.process(i, i / FPS, frames[i])
    assert set(tracker.body.part_girths.values()) == {1.2}


def test_part_factors_capped_with_two_cameras(clip: dict) -> None:
    """With two cameras the part factors above part_girth_max_multi_camera are not tried;
    through one camera, or with no cap, all are; all above the cap: the smallest."""
    from tracker.config import InitConfig
    from tracker.pipeline import Tracker, part_factors

    init = InitConfig(part_girths=(0.8, 1.0, 1.5, 1.8, 2.2), part_girth_max_multi_camera=1.5)
    assert part_factors(init, 2) == (0.8, 1.0, 1.5)
    assert part_factors(init, 3) == (0.8, 1.0, 1.5)
    assert part_factors(init, 1) == (0.8, 1.0, 1.5, 1.8, 2.2)
    uncapped = init.model_copy(update={"part_girth_max_multi_camera": None})
    assert part_factors(uncapped, 2) == (0.8, 1.0, 1.5, 1.8, 2.2)
    fat = init.model_copy(update={"part_girths": (2.2, 1.8)})
    assert part_factors(fat, 2) == (1.8,)
    assert TrackerConfig().init.part_girth_max_multi_camera == 1.5
    with pytest.raises(ValueError):
        InitConfig(part_girth_max_multi_camera=0.2)
    # the tracker tries these factors, and a single one left is used from the start
    config = TrackerConfig(
        ipf=IPFConfig(kept=9), init={"girths": (1.0,), "part_girths": (1.0, 1.8)}
    )
    two = Tracker(clip["cams"], config, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    assert len(clip["cams"]) == 2 and two.part_factors == (1.0,)
    one = Tracker(
        clip["cams"][:1], config, rng=np.random.default_rng(0), backgrounds=clip["bgs"][:1]
    )
    assert one.part_factors == (1.0, 1.8)


def test_hem_estimated_for_a_skirt_and_not_for_trousers(clip: dict) -> None:
    """With init.hems given, a person in a knee-length skirt gets a hem; a person in trousers
    does not (the hem must beat no hem by init.hem_margin). Empty init.hems (the default):
    nothing estimated."""
    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.pipeline import Tracker
    from tracker.synthetic import render_clip

    hems = ((0.5, 0.06), (0.5, 0.09), (1.0, 0.06), (1.0, 0.09))
    assert TrackerConfig().init.hems == ()  # opt-in
    config = TrackerConfig(ipf=IPFConfig(kept=9), init={"part_girth_frames": 3, "hems": hems})
    found = {}
    for name, hem in (("trousers", None), ("skirt", (1.0, 0.09))):
        person = SilhouetteLikelihood(BodyModel(1.70, hem=hem), clip["cams"])
        frames = list(render_clip(person, clip["poses"][:6], clip["bgs"], np.random.default_rng(1)))
        tracker = Tracker(
            clip["cams"], config, rng=np.random.default_rng(0), backgrounds=clip["bgs"]
        )
        seen = []
        for i in range(6):
            assert tracker.process(i, i / FPS, frames[i]).has_pose
            assert tracker.likelihood.body is tracker.body
            seen.append(tracker.body.hem)
        assert seen[0] is None  # the initialised frame is not scored
        assert seen[3] == seen[4] == seen[5]  # fixed after part_girth_frames tracked frames
        found[name] = seen[-1]
    print(f"estimated hems: {found}")
    assert found["trousers"] is None
    assert found["skirt"] is not None and found["skirt"][0] >= 1.0
    off = config.model_copy(update={"init": config.init.model_copy(update={"hems": ()})})
    tracker = Tracker(clip["cams"], off, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    for i in range(5):
        tracker.process(i, i / FPS, frames[i])
    assert tracker.body.hem is None


def _tracker_after_first_frame(clip: dict, **config):
    from tracker.pipeline import Tracker

    tracker = Tracker(
        clip["cams"],
        TrackerConfig(ipf=IPFConfig(kept=9), **config),
        rng=np.random.default_rng(2),
        backgrounds=clip["bgs"],
        body=clip["body"],
    )
    assert tracker.process(0, 0.0, clip["frames"][0]).status == "initialised"
    return tracker


def test_heading_check_turns_a_backward_track(clip: dict) -> None:
    """A track facing backwards is turned to the walking direction within a few frames."""
    from tracker.dof import DOF, wrap_angle

    tracker = _tracker_after_first_frame(clip)
    yaw = DOF["root_yaw"]
    tracker.filter.particles[:, yaw] = wrap_angle(tracker.filter.particles[:, yaw] + np.pi)
    tracker.prev_pose[yaw] = wrap_angle(tracker.prev_pose[yaw] + np.pi)
    notes = []
    for i in range(1, 9):
        res = tracker.process(i, i / FPS, clip["frames"][i])
        notes += res.notes
    assert any("walking direction" in n for n in notes), notes
    assert abs(wrap_angle(res.pose[yaw] - clip["poses"][8, yaw])) < np.radians(30)


def test_walking_direction_auto_falls_back_on_the_silhouettes(clip: dict) -> None:
    """``heading_check.source`` "auto": the estimate's path when it is a walk, else the
    silhouettes' floor point's (a track stuck while the person walks) once it spans
    ``auto_min_span_s``."""
    tracker = _tracker_after_first_frame(clip)
    hc = tracker.config.heading_check
    assert hc.source == "auto"
    assert hc.min_span_s < hc.auto_min_span_s == pytest.approx(0.3)
    pose = tracker.prev_pose.copy()
    t = np.arange(8) * 0.05  # 0.35 s

    def walk(estimate_v, floor_v):
        # (time, estimate x, y, floor point x, y); the last entry is the current frame's.
        path = [(ti, *(np.asarray(estimate_v) * ti), *(np.asarray(floor_v) * ti)) for ti in t]
        tracker._path = path[:-1]
        pose[:2] = path[-1][1:3]
        tracker._floor_now = np.asarray(path[-1][3:5])
        return {
            s: tracker._walking_direction(pose, t[-1], s, 0.4)
            for s in ("estimate", "silhouette", "auto")
        }

    stuck = walk((0.0, 0.0), (0.0, 1.0))  # the track stays, the silhouettes walk along +y
    assert stuck["estimate"] is None
    assert stuck["silhouette"] == pytest.approx(np.pi / 2)
    assert stuck["auto"] == stuck["silhouette"]
    both = walk((1.0, 0.0), (0.0, 1.0))  # both walk: the estimate's path decides
    assert both["estimate"] == pytest.approx(0.0)
    assert both["auto"] == both["estimate"]
    still = walk((0.0, 0.0), (0.0, 0.0))  # nobody walks
    assert still["auto"] is None
    t = np.arange(5) * 0.05  # 0.2 s: long enough for the estimate, not for the fallback
    short = walk((0.0, 0.0), (0.0, 1.0))
    assert short["silhouette"] == pytest.approx(np.pi / 2)
    assert short["auto"] is None
    assert walk((1.0, 0.0), (0.0, 1.0))["auto"] == pytest.approx(0.0)


def test_sustained_backward_walk_despite_depth_jitter(clip: dict) -> None:
    """``heading_check.sustained_s``: a second in which the silhouettes and the estimate both
    walked away from the heading counts even when frame-to-frame jitter (one camera's depth)
    fails ``min_straightness``; it does not when the estimate stayed (a treadmill's belt moves
    the floor point) or walked the other way, without floor points, over a shorter path, for a
    person standing still, for a heading along the walk, or with the setting off."""
    from tracker.dof import DOF

    tracker = _tracker_after_first_frame(clip)
    hc = tracker.config.heading_check
    assert hc.sustained_s == pytest.approx(1.0) and hc.min_straightness == pytest.approx(0.7)
    pose = tracker.prev_pose.copy()
    yaw = DOF["root_yaw"]

    def path(duration, silhouette_v, estimate_v, jitter=0.08):
        t = np.arange(int(round(duration / 0.05)) + 1) * 0.05
        wobble = jitter * (-1.0) ** np.arange(t.size)  # along x, as depth through one camera
        sil = silhouette_v * t + wobble
        est = estimate_v * t + 0.5 * wobble
        entries = list(zip(t, est, 0.0 * t, sil, 0.0 * t, strict=True))
        tracker._path = entries[:-1]
        pose[:2] = entries[-1][1:3]
        tracker._floor_now = np.asarray(entries[-1][3:5])
        return t[-1]

    now = path(1.0, 1.0, 1.0)  # walking +x
    assert tracker._walking_direction(pose, now, "silhouette", 1.0, 0.9) is None  # jittery
    pose[yaw] = np.pi  # facing -x
    assert tracker._walks_backwards(pose, now)
    pose[yaw] = 0.3  # facing the walk
    assert not tracker._walks_backwards(pose, now)
    pose[yaw] = np.pi
    assert not tracker._walks_backwards(pose, path(1.0, 1.0, 0.0))  # the estimate stays
    assert not tracker._walks_backwards(pose, path(1.0, 1.0, -1.0))  # the estimate disagrees
    assert not tracker._walks_backwards(pose, path(0.5, 1.0, 1.0))  # half a second only
    assert not tracker._walks_backwards(pose, path(1.0, 0.0, 0.0))  # jitter, no walk
    now = path(1.0, 1.0, 1.0)
    tracker._path = [(*e[:3], np.nan, np.nan) for e in tracker._path]
    tracker._floor_now = np.array([np.nan, np.nan])
    assert not tracker._walks_backwards(pose, now)  # no floor points
    now = path(1.0, 1.0, 1.0)
    tracker.config.heading_check.sustained_s = 0.0
    assert not tracker._walks_backwards(pose, now)


def test_auto_span_longer_than_its_window_is_refused() -> None:
    from pydantic import ValidationError

    from tracker.config import HeadingCheckConfig

    with pytest.raises(ValidationError, match="auto_min_span_s"):
        TrackerConfig(heading_check={"auto_min_span_s": 0.5})  # window_s 0.4
    with pytest.raises(ValidationError, match="auto_min_span_s"):
        HeadingCheckConfig(source="estimate", turn_source="auto", turn_window_s=0.2)
    assert HeadingCheckConfig(source="estimate", auto_min_span_s=0.5).auto_min_span_s == 0.5


def test_leg_swap_check_unswaps_the_legs(clip: dict) -> None:
    from tracker.dof import LEFT_LEG, RIGHT_LEG

    tracker = _tracker_after_first_frame(clip)
    f = tracker.filter
    left, right = list(LEFT_LEG), list(RIGHT_LEG)
    f.particles[:, left], f.particles[:, right] = f.particles[:, right], f.particles[:, left].copy()
    p = tracker.prev_pose
    p[left], p[right] = p[right], p[left].copy()
    res = tracker.process(1, 1 / FPS, clip["frames"][1])
    # measured: 0.06 m with the check, 0.35 m without (legs apart at this phase)
    assert _lower_limb_error(res.joints[None], clip["truth"][1:2])[0] < 0.12


@pytest.mark.parametrize("enabled", [True, False])
def test_redetect_recovers_a_track_that_slid_away(clip: dict, enabled: bool) -> None:
    """A track moved 0.6 m off the person (beyond the origin search's reach) comes back at once
    with re-detection (onto the person at once, within a few centimetres the next frame);
    without it, it stays off."""
    from tracker.config import RedetectConfig
    from tracker.pipeline import Tracker

    tracker = Tracker(
        clip["cams"],
        TrackerConfig(ipf=IPFConfig(kept=9), redetect=RedetectConfig(enabled=enabled)),
        rng=np.random.default_rng(2),
        backgrounds=clip["bgs"],
        body=clip["body"],
    )
    tracker.process(0, 0.0, clip["frames"][0])
    tracker.filter.particles[:, 1] += 0.6
    tracker.prev_pose[1] += 0.6
    res = tracker.process(1, 1 / FPS, clip["frames"][1])
    assert res.status == "tracked"
    sacrum_err = np.linalg.norm(res.joints[2, :2] - clip["truth"][1, 2, :2])
    if enabled:
        # measured 0.11 m at once with the two cameras' heatmaps (0.02 m scoring the detected
        # points as points; docs/tracker.md "Session 43"), 0.003 m the next frame
        assert sacrum_err < 0.2
        nxt = tracker.process(2, 2 / FPS, clip["frames"][2])
        assert np.linalg.norm(nxt.joints[2, :2] - clip["truth"][2, 2, :2]) < 0.05
    else:
        assert sacrum_err > 0.3


def _grid_capped_at_the_estimate(tracker) -> list[tuple[float, float]]:
    """Make re-detection's grid look no heavier than the estimate: its weights are scaled so its
    best equals the estimate's weight (a coarse pose that does not win as it is). Returns the
    (estimate weight, real grid best) of every search."""
    calls: list[tuple[float, float]] = []
    redetect, reduced = tracker._redetect_search, tracker._reduced_search

    def capped_reduced(headings, dt, threads):
        res = reduced(headings, dt, threads)
        if res is None:
            return None
        scale = calls[-1][0] / res.best_weight
        calls[-1] = (calls[-1][0], float(res.best_weight))
        return dataclasses.replace(res, weights=res.weights * scale)

    def recording(pose, weight, dt):
        calls.append((float(weight), float("nan")))
        return redetect(pose, weight, dt)

    tracker._reduced_search = capped_reduced
    tracker._redetect_search = recording
    return calls


@pytest.mark.parametrize(("steps", "share"), [(2, 1.0), (0, 1.0), (2, 1 / 3)])
def test_redetect_refines_a_grid_pose_that_does_not_win_as_it_is(
    clip: dict, steps: int, share: float
) -> None:
    """A grid pose in the right basin that weighs no more than a slid track wins once refined
    by filter steps (refine_steps), also with a third of the budget (trial_share); compared as
    it is (0), the track stays off."""
    from tracker.config import RedetectConfig

    tracker = _tracker_after_first_frame(
        clip, redetect=RedetectConfig(refine_steps=steps, trial_share=share)
    )
    calls = _grid_capped_at_the_estimate(tracker)
    tracker.filter.particles[:, 1] += 0.6
    tracker.prev_pose[1] += 0.6
    res = tracker.process(1, 1 / FPS, clip["frames"][1])
    assert len(calls) == 1
    estimate_weight, grid_best = calls[0]
    assert grid_best > estimate_weight  # the premise: the real grid pose is the better one
    sacrum_err = np.linalg.norm(res.joints[2, :2] - clip["truth"][1, 2, :2])
    if steps:
        assert res.weight > estimate_weight + tracker.config.redetect.margin
        # measured 0.06 m (all the budget) and 0.13 m (a third) at once, 0.008 and 0.019 m
        # the next frame (docs/tracker.md, "Session 43")
        assert sacrum_err < 0.2
        nxt = tracker.process(2, 2 / FPS, clip["frames"][2])
        assert np.linalg.norm(nxt.joints[2, :2] - clip["truth"][2, 2, :2]) < 0.05
    else:
        assert sacrum_err > 0.3


@pytest.mark.parametrize("share", [1.0, 1 / 3])
def test_redetect_refinement_not_adopted_restores_the_particles(clip: dict, share: float) -> None:
    """A refinement that does not beat the estimate by the margin leaves the estimate and the
    filter's particle set exactly as the filter left them; with trial_share < 1 the trial runs
    on a filter of that share of the budget."""
    from tracker.config import RedetectConfig

    tracker = _tracker_after_first_frame(
        clip,
        redetect=RedetectConfig(margin=0.9, refine_steps=2, trial_share=share),  # nothing can win
    )
    calls = _grid_capped_at_the_estimate(tracker)
    steps = []
    step = tracker.filter.step

    def counting(lik, dt):
        steps.append(dt)
        return step(lik, dt)

    tracker.filter.step = counting
    trials = []
    seed_and_step = tracker._seed_and_step

    def trial_budget(filt, poses, weights, dt, n=1):
        trials.append((filt is tracker.filter, filt.evaluations_per_step, n))
        return seed_and_step(filt, poses, weights, dt, n)

    tracker._seed_and_step = trial_budget
    seen = {}
    redetect = tracker._redetect_search

    def snapshot(pose, weight, dt):
        seen["before"] = (tracker.filter.particles.copy(), tracker.filter.weights.copy())
        out = redetect(pose, weight, dt)
        seen["after"] = (tracker.filter.particles.copy(), tracker.filter.weights.copy())
        seen["in_out"] = (pose.copy(), weight, out[0].copy(), out[1])
        return out

    tracker._redetect_search = snapshot
    tracker.process(1, 1 / FPS, clip["frames"][1])
    assert len(calls) == 1
    if share == 1:
        assert trials == [(True, 729, 2)]
        assert len(steps) == 1 + tracker.config.redetect.refine_steps  # the filter's + the trial's
    else:
        assert trials == [(False, 243, 2)]  # a third of IPF(kept=9)'s 729
        assert len(steps) == 1  # the filter's own step only
    assert np.array_equal(seen["before"][0], seen["after"][0])
    assert np.array_equal(seen["before"][1], seen["after"][1])
    pose, weight, out_pose, out_weight = seen["in_out"]
    assert np.array_equal(pose, out_pose) and weight == out_weight


# -- the command line -----------------------------------------------------------------------------
def test_track_cli_round_trip_and_seed(clip: dict, tmp_path: Path, capsys) -> None:
    outs = [tmp_path / "a.mcap", tmp_path / "b.mcap", tmp_path / "c.mcap"]
    for out, seed in zip(outs, ("5", "5", "6"), strict=True):
        rc = main(_args(clip, out, "--seed", seed, "--max-frames", "6", "--particles", "729"))
        assert rc == 0, capsys.readouterr().err
    assert "6 frame(s): 6 with a pose" in capsys.readouterr().out
    a, b, c = (read_poselog(o) for o in outs)
    assert not a.truncated and len(a) == 6
    assert a.trajectory.frames.tolist() == list(range(6))
    assert np.allclose(a.trajectory.times, np.arange(6) / FPS)
    assert a.filters == ["ipf"] * 6
    # same seed -> identical pose content; another seed -> different particles
    assert np.array_equal(a.dofs, b.dofs)
    assert np.array_equal(a.trajectory.positions, b.trajectory.positions)
    assert np.array_equal(a.weights, b.weights)
    assert not np.array_equal(a.dofs, c.dofs)
    # the stored joints are smoothed over each track (tracker.smoothing): near the forward
    # kinematics of each frame's own DOFs, not equal to it
    fk = np.asarray(clip["body"].forward(a.dofs))
    gap = np.linalg.norm(fk - a.trajectory.positions, axis=-1)
    assert 0 < gap.max() < 0.1
    assert a.metadata["settings"]["tracker"]["smoothing"]["enabled"] is True
    # --no-smoothing: each frame's own estimate, the forward kinematics of its DOFs
    raw_out = tmp_path / "raw.mcap"
    rc = main(
        _args(clip, raw_out, "--seed", "5", "--max-frames", "6", "--particles", "729")
        + ["--no-smoothing"]
    )
    assert rc == 0
    raw = read_poselog(raw_out)
    assert raw.metadata["settings"]["tracker"]["smoothing"]["enabled"] is False
    assert np.array_equal(raw.dofs, a.dofs)  # the same tracking
    # the key points are the forward kinematics of the DOFs on the body the log names (two
    # cameras: the leg length is estimated over the first tracked frames), with the legs' key
    # points exchanged on the frames whose leg labels were exchanged (tracker.leglabels), and
    # the hips' height, the sacrum and the shoulders fused with the detections (keypoints.fuse)
    from tracker.body import BodyModel
    from tracker.leglabels import exchange_legs

    assert raw.leg_lengths.shape == (6,)
    assert set(raw.leg_lengths) <= set(TrackerConfig().init.leg_lengths)
    for dofs, legs, joints in zip(raw.dofs, raw.leg_lengths, raw.trajectory.positions, strict=True):
        fk = BodyModel(clip["body"].height_m, leg_length=float(legs)).forward(dofs[None])[0]
        try:
            assert_written_is_model(joints, fk)
        except AssertionError:
            assert_written_is_model(joints, exchange_legs(fk))
    from tracker.config import SmoothingConfig
    from tracker.smoothing import smooth_keypoints

    again = smooth_keypoints(raw.trajectory.times, raw.trajectory.positions, SmoothingConfig(), FPS)
    np.testing.assert_allclose(again, a.trajectory.positions, atol=1e-9)
    # metadata: cameras, height, filter and settings come back
    assert [cam.name for cam in a.cameras] == [cam.name for cam in clip["cams"]]
    assert np.allclose(a.cameras[1].K, clip["cams"][1].K)
    assert float(a.metadata["body_height_m"]) == pytest.approx(1.70)
    assert a.metadata["filter"] == "ipf"
    assert a.metadata["settings"]["seed"] == 5
    err = _lower_limb_error(a.trajectory.positions, clip["truth"][:6])
    assert err.mean() < 0.15


def test_track_cli_detects_the_next_frame_ahead_with_the_same_poses(
    clip: dict, tmp_path: Path, monkeypatch
) -> None:
    """`gaitwatch track` runs the built-in detector of the next frame in a thread of its own
    while it tracks the current one (Tracker.detect_ahead); the pose log is the same as with
    every detection made in turn."""
    import threading

    import service.tracking as tracking
    from tracker.pipeline import Tracker

    calls: list[tuple[str, int]] = []
    original = Tracker.detect_ahead

    def spy(self, frames, segs):
        det = original(self, frames, segs)
        calls.append((threading.current_thread().name, int(det is not None and det.ran)))
        return det

    monkeypatch.setattr(Tracker, "detect_ahead", spy)
    logs = []
    for ahead in (True, False):
        monkeypatch.setattr(tracking, "DETECT_AHEAD", ahead)
        out = tmp_path / f"ahead-{ahead}.mcap"
        assert main(_args(clip, out, "--max-frames", "6", "--particles", "729")) == 0
        logs.append(read_poselog(out))
    # every frame after the first was detected ahead, in the worker thread
    assert len(calls) == 5 and all(name.startswith("detect-ahead") for name, _ in calls)
    assert all(ran for _, ran in calls)
    a, b = logs
    assert len(a) == len(b) == 6
    assert np.array_equal(a.dofs, b.dofs) and np.array_equal(a.weights, b.weights)
    assert np.array_equal(a.trajectory.positions, b.trajectory.positions)


def test_track_cli_one_camera_writes_the_depth_stage(clip: dict, tmp_path: Path, capsys) -> None:
    """Through one camera `gaitwatch track` fits the body's distance from it over the longer
    window (tracker.smoothing, depth stage): its stream writes what the whole-footage form
    makes of the unsmoothed key points, and without the stage each frame differs by one
    horizontal move along that camera's line of sight. Its balance step moves only the hips,
    the body above them and the knees, along the line of sight too."""
    from tracker.config import SmoothingConfig
    from tracker.smoothing import FEET, KNEES, UPPER, smooth_keypoints

    one = {
        "folders": [clip["folders"][0]],
        "cams": [clip["cam_files"][0]],
        "bgs": False,
    }
    common = ["--background", str(clip["bg_files"][0]), "--seed", "2", "--max-frames", "12"]
    common += ["--particles", "729"]
    off_cfg = tmp_path / "off.toml"
    off_cfg.write_text("[smoothing]\ndepth_window_s = 0.0\n")
    rigid_cfg = tmp_path / "rigid.toml"
    rigid_cfg.write_text("[smoothing]\nbalance = 0.0\n")
    logs = {}
    for name, extra in (
        ("on", []),
        ("rigid", ["--config", str(rigid_cfg)]),
        ("off", ["--config", str(off_cfg)]),
        ("raw", ["--no-smoothing"]),
    ):
        out = tmp_path / f"{name}.mcap"
        assert main(_args(clip, out, *common, *extra, **one)) == 0, capsys.readouterr().err
        logs[name] = read_poselog(out)
    on, rigid, off, raw = logs["on"], logs["rigid"], logs["off"], logs["raw"]
    assert np.array_equal(on.dofs, off.dofs) and np.array_equal(on.dofs, raw.dofs)
    eye = np.asarray(clip["cams"][0].center)
    again = smooth_keypoints(
        raw.trajectory.times, raw.trajectory.positions, SmoothingConfig(), FPS, eye=eye
    )
    np.testing.assert_allclose(on.trajectory.positions, again, atol=1e-9)
    move = rigid.trajectory.positions - off.trajectory.positions
    assert np.abs(move).max() > 1e-4  # the stage moved the frames
    assert np.allclose(move, move[:, :1], atol=1e-9) and np.allclose(move[..., 2], 0.0)
    sight = off.trajectory.positions.mean(axis=1)[:, :2] - eye[:2]
    assert np.allclose(move[:, 0, 0] * sight[:, 1] - move[:, 0, 1] * sight[:, 0], 0.0, atol=1e-9)
    step = on.trajectory.positions - rigid.trajectory.positions  # the balance step
    assert np.abs(step[:, UPPER]).max() > 1e-4
    assert np.abs(step[:, FEET]).max() < 1e-12 and np.abs(step[..., 2]).max() < 1e-12
    np.testing.assert_allclose(step[:, KNEES], 0.5 * step[:, [9, 10]], atol=1e-12)
    hips = 0.5 * (rigid.trajectory.positions[:, 9, :2] + rigid.trajectory.positions[:, 10, :2])
    sight = hips - eye[:2]
    assert np.allclose(step[:, 9, 0] * sight[:, 1] - step[:, 9, 1] * sight[:, 0], 0.0, atol=1e-9)


@pytest.mark.parametrize("name", ["apf", "condensation"])
def test_track_cli_baselines(clip: dict, tmp_path: Path, name: str) -> None:
    out = tmp_path / "p.mcap"
    rc = main(_args(clip, out, "--filter", name, "--max-frames", "4", "--particles", "729"))
    assert rc == 0
    log = read_poselog(out)
    assert log.filters == [name] * 4 and log.metadata["filter"] == name


def test_without_background_estimates_it(clip: dict, tmp_path: Path) -> None:
    """No --background: the empty scene is estimated from the footage (the per-pixel median of
    its frames), so every frame has a pose, and the track is about as near the truth as with the
    background image given."""
    out, given = tmp_path / "p.mcap", tmp_path / "given.mcap"
    assert main(_args(clip, out, "--particles", "729", bgs=False)) == 0
    assert main(_args(clip, given, "--particles", "729")) == 0
    log, ref = read_poselog(out), read_poselog(given)
    assert len(log) == N_FRAMES and not log.no_pose
    settings = log.metadata["settings"]
    assert settings["tracker"]["segmentation"]["mode"] == "static"
    assert settings["backgrounds_estimated"] == [True, True]
    assert ref.metadata["settings"]["backgrounds_estimated"] == [False, False]
    err = _lower_limb_error(log.trajectory.positions, clip["truth"])
    err_given = _lower_limb_error(ref.trajectory.positions, clip["truth"])
    # measured 19.5 mm against 18.5 mm with the image given
    assert err.mean() < err_given.mean() + 0.01, (err.mean(), err_given.mean())


def test_without_background_follows_a_light_switch(clip: dict, tmp_path: Path) -> None:
    """No --background and the light dimmed to 60 % half way through: the footage gives two
    lighting states and each frame is subtracted from its own. Every frame has a pose (MOG2
    misses the first ones), and the track is far nearer the truth than with one median of
    both lights, whose brighter half is foreground nearly everywhere (also with --tracks 2)."""
    from service.background import footage_backgrounds
    from tracker.background import median_background

    folders = []
    for c in range(len(clip["cams"])):
        d = tmp_path / f"cam{c}"
        d.mkdir()
        for i, fr in enumerate(clip["frames"]):
            img = fr[c] if i < N_FRAMES // 2 else (fr[c] * 0.6).astype(np.uint8)
            cv2.imwrite(str(d / f"{i:04d}.png"), img)
        folders.append(d)
    states = footage_backgrounds(folders, clip["cams"])
    assert [len(s.states) for s in states] == [2, 2]
    frames = [cv2.imread(str(folders[0] / f"{i:04d}.png")) for i in range(N_FRAMES)]
    half = N_FRAMES // 2
    assert [states[0].state_of(f) for f in frames] == [1] * half + [0] * (N_FRAMES - half)
    out = tmp_path / "p.mcap"
    assert main(_args(clip, out, "--particles", "729", folders=folders, bgs=False)) == 0
    log = read_poselog(out)
    assert len(log) == N_FRAMES and not log.no_pose
    err = _lower_limb_error(log.trajectory.positions, clip["truth"])
    # one median of both lights, given as the background images
    one = []
    for c, d in enumerate(folders):
        imgs = [cv2.imread(str(d / f"{i:04d}.png")) for i in range(N_FRAMES)]
        one.append(tmp_path / f"one{c}.png")
        cv2.imwrite(str(one[-1]), median_background(imgs).image)
    mixed = tmp_path / "mixed.mcap"
    extra = [a for b in one for a in ("--background", str(b))]
    assert main(_args(clip, mixed, "--particles", "729", *extra, folders=folders, bgs=False)) == 0
    ref = read_poselog(mixed)
    err_mixed = _lower_limb_error(ref.trajectory.positions, clip["truth"][ref.trajectory.frames])
    # measured 128 mm against 294 (44 mm over the first half: the dimmed half loses contrast);
    # MOG2 on the same footage: 141 mm over the 19 frames it has
    assert err.mean() < 0.6 * err_mixed.mean(), (err.mean(), err_mixed.mean())
    assert err[:half].mean() < 0.08
    two = tmp_path / "two.mcap"
    rc = main(_args(clip, two, "--particles", "729", "--tracks", "2", folders=folders, bgs=False))
    assert rc == 0 and len(read_poselog(two)) == N_FRAMES


def test_without_background_mog2_learns_it(clip: dict, tmp_path: Path) -> None:
    """No --background and --segmentation mog2: MOG2 learns the scene as the footage goes (the
    person is there from frame 0, so the first frames have no silhouette yet)."""
    out = tmp_path / "p.mcap"
    assert main(_args(clip, out, "--particles", "729", "--segmentation", "mog2", bgs=False)) == 0
    log = read_poselog(out)
    assert N_FRAMES // 2 <= len(log) < N_FRAMES
    assert all(reason.startswith("nobody in view") for _, _, reason in log.no_pose)
    settings = log.metadata["settings"]
    assert settings["tracker"]["segmentation"]["mode"] == "mog2"
    assert settings["backgrounds_estimated"] == [False, False]
    err = _lower_limb_error(log.trajectory.positions, clip["truth"][log.trajectory.frames])
    assert err.mean() < 0.35  # measured ~0.2: the learned silhouettes are incomplete


def test_nobody_in_view_then_resumes(clip: dict, tmp_path: Path) -> None:
    """Empty frames give "no pose" entries; the track resumes by re-initialisation."""
    folders = []
    empty = {3, 4, 5}
    for c, bg in enumerate(clip["bgs"]):
        d = tmp_path / f"cam{c}"
        d.mkdir()
        for i in range(9):
            img = bg if i in empty else clip["frames"][i][c]
            cv2.imwrite(str(d / f"{i:03d}.png"), img)
        folders.append(d)
    out = tmp_path / "p.mcap"
    assert main(_args(clip, out, "--particles", "729", folders=folders)) == 0
    log = read_poselog(out)
    assert [f for f, _, _ in log.no_pose] == sorted(empty)
    assert all("nobody in view" in reason for _, _, reason in log.no_pose)
    assert log.trajectory.frames.tolist() == [0, 1, 2, 6, 7, 8]
    assert any("reinitialised" in text for f, _, text in log.notes if f == 6)
    idx = log.trajectory.frames
    assert _lower_limb_error(log.trajectory.positions, clip["truth"][idx]).mean() < 0.15


def test_several_blobs_follow_the_tracked_one(clip: dict) -> None:
    """A second person-sized blob appears: the tracker stays on the one it follows."""
    from tracker.pipeline import Tracker

    config = TrackerConfig(ipf=IPFConfig(kept=9))
    tracker = Tracker(
        clip["cams"],
        config,
        rng=np.random.default_rng(1),
        backgrounds=clip["bgs"],
        body=clip["body"],
    )
    notes = []
    errs = []
    for i, frames in enumerate(clip["frames"][:8]):
        frames = [f.copy() for f in frames]
        if i >= 2:
            for f in frames:  # a tall distractor near the right edge
                cv2.rectangle(f, (290, 60), (312, 200), (30, 220, 40), -1)
        res = tracker.process(i, i / FPS, frames)
        notes += res.notes
        errs.append(_lower_limb_error(res.joints[None], clip["truth"][i : i + 1])[0])
    assert any("blobs, following" in n for n in notes)
    assert max(errs[2:]) < 0.2


@pytest.mark.parametrize("part_box", [(0.25, 0.5), (0.0, 0.0)])
def test_a_part_below_the_followed_blob_is_kept(clip: dict, part_box) -> None:
    """Feet cut off from the body (legs the segmentation misses) stay in the silhouette when
    they lie below the followed blob (``part_box``); a blob off to the side does not."""
    from tracker.pipeline import Tracker

    tracker = Tracker(
        clip["cams"],
        TrackerConfig(ipf=IPFConfig(kept=9), part_box=part_box),
        rng=np.random.default_rng(1),
        backgrounds=clip["bgs"],
        body=clip["body"],
    )
    for i in range(2):
        tracker.process(i, i / FPS, clip["frames"][i])
    frames = [f.copy() for f in clip["frames"][2]]
    main = tracker.segment(frames)[0].blobs[0]
    x, y, w, h = main.bbox
    foot = (x + w // 2, y + h + h // 5)  # below the person's feet: outside the model
    side = (x + w + h, y + h // 2)  # a person height to the right
    for cx, cy in (foot, side):
        cv2.rectangle(frames[0], (cx - 12, cy - 5), (cx + 12, cy + 5), (20, 20, 200), -1)
    seg = tracker.segment(frames)[0]
    assert len(seg.blobs) == 3
    label_at = {name: int(seg.labels[c[1], c[0]]) for name, c in (("foot", foot), ("side", side))}
    notes: list[str] = []
    kept = {b.label for b in tracker._choose_blobs(0, seg, notes).blobs}
    assert main.label in kept and label_at["side"] not in kept
    assert (label_at["foot"] in kept) == (part_box != (0.0, 0.0))
    assert ("with 1 other part(s) of the person" in notes[0]) == (part_box != (0.0, 0.0))


# -- bad input: one-line error, non-zero exit, poses so far kept ----------------------------------
def test_track_cli_writes_the_revised_first_frames_in_order(
    clip: dict, tmp_path: Path, capsys
) -> None:
    """The backward pass (config.revise) rewrites the frames before the track settled: the log
    still has each frame once, in order; --no-revise gives the forward estimates."""
    settled = round(TrackerConfig().revise.settle_s * FPS)  # no heading flip on this clip
    n = settled + 4
    # (--detector none: the built-in detector finds this clip's capsule bodies only roughly,
    # leg points 3-8 % of the height off, which the tracker of its own renderings does not need)
    common = ["--seed", "3", "--max-frames", str(n), "--particles", "729", "--no-smoothing"]
    common += ["--detector", "none"]
    rev_out, fwd_out = tmp_path / "rev.mcap", tmp_path / "fwd.mcap"
    assert main(_args(clip, rev_out, *common)) == 0, capsys.readouterr().err
    assert main(_args(clip, fwd_out, *common, "--no-revise")) == 0, capsys.readouterr().err
    rev, fwd = read_poselog(rev_out), read_poselog(fwd_out)
    assert rev.trajectory.frames.tolist() == fwd.trajectory.frames.tolist() == list(range(n))
    assert rev.metadata["settings"]["tracker"]["revise"]["enabled"] is True
    assert fwd.metadata["settings"]["tracker"]["revise"]["enabled"] is False
    notes = [(k, text) for k, _, text in rev.notes if text.startswith("revised frames")]
    assert notes == [
        (settled, f"revised frames 0-{settled - 1}: tracked backwards from this settled frame")
    ]
    # before the settled frame: other estimates; the settled frame itself: the same forward one
    assert all(not np.array_equal(rev.dofs[k], fwd.dofs[k]) for k in range(settled))
    assert np.array_equal(rev.dofs[settled], fwd.dofs[settled])
    # revised or not, the poses are the tracker's (forward kinematics of the logged DOFs) and
    # as good on this easy clip, whose forward track starts well (measured lower limbs 30.6 mm
    # revised, 29.4 mm forwards)
    assert np.allclose(clip["body"].forward(rev.dofs), rev.trajectory.positions, atol=1e-9)
    err = [
        _lower_limb_error(x.trajectory.positions[:settled], clip["truth"][:settled]).mean()
        for x in (rev, fwd)
    ]
    assert err[0] < err[1] + 0.01, err


def test_backward_pass_window_closes_on_no_pose_and_reopens(clip: dict) -> None:
    """The frames open to revision are those since a track began: a frame without a pose ends
    the window without a pass (nothing revised), the next initialisation opens a new one."""
    from tracker.config import ReviseConfig
    from tracker.pipeline import Tracker

    tr = Tracker(
        clip["cams"],
        TrackerConfig(ipf=IPFConfig(kept=9), revise=ReviseConfig(settle_s=4 / FPS)),
        rng=np.random.default_rng(2),
        backgrounds=clip["bgs"],
        body=clip["body"],
    )
    empty = [b.copy() for b in clip["bgs"]]
    seq = [0, 1, 2, None, 3, 4, 5, 6, 7, 8]  # None: the empty scene
    results, pending = [], []
    for k, i in enumerate(seq):
        frames = empty if i is None else clip["frames"][i]
        results.append(tr.process(k, k / FPS, frames))
        pending.append(tr.pending_from)
    assert [r.status for r in results[:5]] == [
        "initialised",
        "tracked",
        "tracked",
        "no_pose",
        "reinitialised",
    ]
    assert pending[:5] == [0, 0, 0, None, 4]  # frames 0-2 were never revised
    assert all(not r.revisions for r in results[:8])
    # settled 4 frames after the re-initialisation at frame 4: frames 4-7 revised at frame 8
    assert [x.frame_index for x in results[8].revisions] == [4, 5, 6, 7]
    assert results[8].revisions[0].status == "reinitialised"
    assert pending[8] is None and pending[9] is None


def test_corrupt_frame_keeps_poses_written_so_far(clip: dict, tmp_path: Path, capsys) -> None:
    folders = []
    for c in range(2):
        d = tmp_path / f"cam{c}"
        d.mkdir()
        for i in range(6):
            cv2.imwrite(str(d / f"{i:03d}.png"), clip["frames"][i][c])
        folders.append(d)
    (folders[1] / "003.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(200)))
    out = tmp_path / "p.mcap"
    rc = main(_args(clip, out, "--particles", "729", folders=folders))
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert err.startswith("gaitwatch: error:") and "\n" not in err and "003.png" in err
    log = read_poselog(out)
    assert log.trajectory.frames.tolist() == [0, 1, 2]
    assert log.metadata.get("end", {}).get("status") == "error"


def test_not_a_video(clip: dict, tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(np.random.default_rng(0).bytes(5000))
    out = tmp_path / "p.mcap"
    rc = main(_args(clip, out, folders=[bad, clip["folders"][1]]))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "bad.mp4" in err and "\n" not in err


def test_frame_size_mismatch(clip: dict, tmp_path: Path, capsys) -> None:
    from tracker.camera import load_camera

    big = load_camera(clip["cam_files"][0]).scaled(640, 480)
    f = tmp_path / "big.yaml"
    save_camera(big, f)
    rc = main(_args(clip, tmp_path / "p.mcap", cams=[f, clip["cam_files"][1]], bgs=False))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "image_size" in err and "\n" not in err


def test_different_lengths(clip: dict, tmp_path: Path, capsys) -> None:
    short = tmp_path / "short"
    short.mkdir()
    for i in range(3):
        cv2.imwrite(str(short / f"{i:03d}.png"), clip["frames"][i][1])
    out = tmp_path / "p.mcap"
    rc = main(_args(clip, out, "--particles", "729", folders=[clip["folders"][0], short]))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "different lengths" in err and "\n" not in err
    assert read_poselog(out).trajectory.frames.tolist() == [0, 1, 2]


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--height", "3.5"], "--height"),
        (["--particles", "0"], "--particles"),
        (["--max-frames", "0"], "--max-frames"),
    ],
)
def test_bad_options(clip: dict, tmp_path: Path, capsys, extra: list[str], needle: str) -> None:
    rc = main(_args(clip, tmp_path / "p.mcap", *extra))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and needle in err and "\n" not in err


def test_background_size_must_match_camera(clip: dict, tmp_path: Path, capsys) -> None:
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), clip["bgs"][0][::2, ::2])
    a = _args(clip, tmp_path / "p.mcap", bgs=False)
    a += ["--background", str(small), "--background", str(clip["bg_files"][1])]
    rc = main(a)
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "small.png" in err and "image_size" in err and "\n" not in err


def test_occluder_masks_on_the_command_line(clip: dict, tmp_path: Path, capsys) -> None:
    """``--occluder`` per camera ('none' for one without): a mask over the lower half of camera
    0 changes the tracking there, is recorded in the log's settings; bad masks are refused."""
    h, w = clip["bgs"][0].shape[:2]
    mask = np.zeros((h, w), np.uint8)
    mask[h // 2 :] = 255
    mask_file = tmp_path / "table.png"
    cv2.imwrite(str(mask_file), mask)
    base = ["--seed", "5", "--max-frames", "4", "--particles", "729"]
    plain, masked = tmp_path / "plain.mcap", tmp_path / "masked.mcap"
    assert main(_args(clip, plain, *base)) == 0
    rc = main(_args(clip, masked, *base, "--occluder", str(mask_file), "--occluder", "none"))
    assert rc == 0, capsys.readouterr().err
    a, b = read_poselog(plain), read_poselog(masked)
    assert len(b) == 4 and b.metadata["settings"]["occluders"] == [str(mask_file), "none"]
    assert a.metadata["settings"]["occluders"] == []
    assert not np.array_equal(a.dofs, b.dofs)  # the legs in camera 0 count differently
    # one per camera
    rc = main(_args(clip, tmp_path / "x.mcap", *base, "--occluder", str(mask_file)))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "--occluder" in err and "one per camera" in err and "\n" not in err
    # the frame's size
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), mask[::2, ::2])
    rc = main(
        _args(clip, tmp_path / "y.mcap", *base, "--occluder", str(small), "--occluder", "none")
    )
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "small.png" in err and "image_size" in err
    # not an image
    rc = main(_args(clip, tmp_path / "z.mcap", "--occluder", "nope.png", "--occluder", "none"))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "nope.png" in err and "\n" not in err
    assert not (tmp_path / "z.mcap").exists()


def test_video_count_must_match_cameras(clip: dict, tmp_path: Path, capsys) -> None:
    rc = main(_args(clip, tmp_path / "p.mcap", folders=clip["folders"][:1], bgs=False))
    assert rc == 2 and "one per camera" in capsys.readouterr().err


def test_config_file_and_unknown_key(clip: dict, tmp_path: Path, capsys) -> None:
    good = tmp_path / "t.toml"
    good.write_text('filter = "condensation"\n[ipf]\nkept = 9\n')
    out = tmp_path / "p.mcap"
    assert main(_args(clip, out, "--config", str(good), "--max-frames", "2")) == 0
    assert read_poselog(out).filters == ["condensation"] * 2
    bad = tmp_path / "bad.yaml"
    bad.write_text("ipf:\n  kept: 9\n  colour: red\n")
    rc = main(_args(clip, out, "--config", str(bad)))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "bad.yaml" in err and "colour" in err and "unknown key" in err


def test_real_footage_smoke(shared_data: Path, tmp_path: Path) -> None:
    """The Sports2D outdoor clip (one camera, no background image, trees, a second person):
    the track starts once the person is down on the ground, and the poses stand on the floor."""
    import tomllib

    from gaitwatch.conventions import SACRUM
    from tracker.camera import Camera
    from tracker.pipeline import NO_FLOOR_POINT, NOBODY_IN_VIEW

    video = shared_file(shared_data, "video/outdoor-walk-1768x994-30fps.mp4")
    calib = tomllib.loads(shared_file(shared_data, "video/outdoor-walk-calib.toml").read_text())
    d = calib["demo"]
    R, _ = cv2.Rodrigues(np.array(d["rotation"], dtype=float))
    cam = Camera.from_params(
        name="outdoor", image_size=tuple(d["size"]), K=np.array(d["matrix"]), R=R,
        t=np.array(d["translation"]), dist=d["distortions"], fps=30.0,
    )  # fmt: skip
    cam_file = tmp_path / "outdoor.yaml"
    save_camera(cam, cam_file)
    out = tmp_path / "p.mcap"
    args = [str(video), "--camera", str(cam_file), "--height", "1.65", "--out", str(out)]
    assert main(["-q", "track", *args, "--max-frames", "90", "--no-progress"]) == 0
    log = read_poselog(out)
    # measured: the empty scene estimated from 29 frames spread over the clip's 230; no pose
    # for frames 0-36, where the person stands on a hut before the bright sky and only scraps
    # of them pass the segmentation (their dark shirt taken for a shadow; before session 53,
    # with MOG2 learning the scene, frames 0-35), then 53 poses
    assert len(log) >= 40
    known = (NOBODY_IN_VIEW, NO_FLOOR_POINT)
    assert all(reason.startswith(known) for _, _, reason in log.no_pose)
    p = log.trajectory.positions
    assert p[:, :, 2].min() > -0.05  # floor constraint
    sacrum_z = p[:, SACRUM, 2]
    assert np.mean((sacrum_z > 0.75) & (sacrum_z < 1.1)) > 0.9  # measured 0.88-0.99 m


def test_redetect_skipped_while_stable_still_catches_a_slide(clip: dict) -> None:
    """Re-detection is skipped while the weight holds (at most max_skipped frames in a row) and
    runs, and recovers the track, when a slide off the person drops the weight."""
    from tracker.config import RedetectConfig, ReviseConfig

    # Without the refinement of re-detection's candidates: adopted refinements raise the weight
    # by steps (measured 0.76 -> 0.87 over this clip's first frames), so few frames are stable.
    # Without the backward pass, whose copy of the tracker would call the spy too. Without the
    # 2D key-point cue: the built-in detector finds this clip's capsule bodies only roughly
    # (leg points 3-8 % of the height off), which moves the weight from frame to frame.
    tracker = _tracker_after_first_frame(
        clip,
        redetect=RedetectConfig(refine_steps=0),
        revise=ReviseConfig(enabled=False),
        keypoints=KeypointConfig(enabled=False),
    )
    rc = tracker.config.redetect
    searched = []
    search = tracker._redetect_search

    def recording(pose, weight, dt):
        searched.append(tracker._tracked_frames)
        return search(pose, weight, dt)

    tracker._redetect_search = recording
    for i in range(1, 12):
        tracker.process(i, i / FPS, clip["frames"][i])
    assert searched[: rc.stable_frames] == list(range(1, rc.stable_frames + 1))
    assert len(searched) < 11  # some stable frames skipped ...
    assert max(np.diff(searched)) <= rc.max_skipped + 1  # ... never more than max_skipped
    n = len(searched)
    tracker.filter.particles[:, 1] += 0.6
    tracker.prev_pose[1] += 0.6
    res = tracker.process(12, 12 / FPS, clip["frames"][12])
    assert len(searched) == n + 1
    assert np.linalg.norm(res.joints[2, :2] - clip["truth"][12, 2, :2]) < 0.1


def test_keypoints_on_the_command_line(clip: dict, tmp_path: Path, capsys) -> None:
    """``--keypoints`` per camera ('none' for one without): a perfect detector's file for
    camera 0 turns the 2D key-point cue on and changes the track; it is recorded in the log's
    settings; wrong counts and bad files are refused before anything is written."""
    from service.keypoints import COLUMNS

    cam = clip["cams"][0]
    lines = [",".join(COLUMNS)]
    for k, kp in enumerate(clip["truth"]):
        uv = cam.project(kp)
        cells = [f"{x:.3f}" for row in np.column_stack([uv, np.ones(len(uv))]) for x in row]
        lines.append(",".join([str(k), *cells]))
    good = tmp_path / "cam0-keypoints.csv"
    good.write_text("\n".join(lines) + "\n")
    base = ["--seed", "5", "--max-frames", "4", "--particles", "729"]
    plain, cued = tmp_path / "plain.mcap", tmp_path / "cued.mcap"
    assert main(_args(clip, plain, *base, "--detector", "none")) == 0
    rc = main(_args(clip, cued, *base, "--keypoints", str(good), "--keypoints", "none"))
    assert rc == 0, capsys.readouterr().err
    a, b = read_poselog(plain), read_poselog(cued)
    assert len(b) == 4 and b.metadata["settings"]["keypoints"] == [str(good), "none"]
    assert b.metadata["settings"]["tracker"]["keypoints"]["enabled"] is True
    assert not a.metadata["settings"]["tracker"]["keypoints"]["enabled"]
    assert not np.array_equal(a.dofs, b.dofs)
    # by default the built-in detector runs (the cue on); --detector names it
    default, named = tmp_path / "default.mcap", tmp_path / "named.mcap"
    assert main(_args(clip, default, *base, "--max-frames", "2")) == 0
    settings = read_poselog(default).metadata["settings"]["tracker"]["keypoints"]
    assert settings["enabled"] is True and settings["detector"] == "blazepose"
    off = tmp_path / "off.toml"
    off.write_text("[keypoints]\nenabled = false\n")
    assert main(_args(clip, named, *base, "--config", str(off), "--detector", "blazepose")) == 0
    settings = read_poselog(named).metadata["settings"]["tracker"]["keypoints"]
    assert settings["enabled"] is True and settings["detector"] == "blazepose"
    # one per camera, and not all of them 'none'
    rc = main(_args(clip, tmp_path / "x.mcap", *base, "--keypoints", str(good)))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "--keypoints" in err and "one per camera" in err and "\n" not in err
    rc = main(_args(clip, tmp_path / "y.mcap", *base, "--keypoints", "none", "--keypoints", "none"))
    assert rc == 2 and "every camera is 'none'" in capsys.readouterr().err
    # a bad file names itself and its line; nothing is written
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join([lines[0], "0,1,2"]) + "\n")
    rc = main(_args(clip, tmp_path / "z.mcap", "--keypoints", str(bad), "--keypoints", "none"))
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "bad.csv: line 2" in err and "\n" not in err
    assert not (tmp_path / "z.mcap").exists()
