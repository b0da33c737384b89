"""The initial search's body configurations (tracker.init): standing, walking and flexed-walk
phases, seated; and a crouched walker found facing the right way."""

from __future__ import annotations

import numpy as np
import pytest

from gaitwatch.conventions import L_HEEL, L_TOE, R_HEEL, R_TOE
from gaitwatch.mocap.mot import MotTable
from tracker.body import BodyModel
from tracker.config import TrackerConfig
from tracker.dof import DOF
from tracker.init import FLEXED_OFFSETS_DEG, SEATED_LEAN_DEG, body_configurations

FEET = [L_HEEL, L_TOE, R_HEEL, R_TOE]


def _configs(walking: int, flexed: int, profile: str = "walking"):
    cfg = TrackerConfig.model_validate(
        {
            "limits_profile": profile,
            "init": {"walking_phases": walking, "flexed_phases": flexed},
        }
    )
    body = BodyModel(height_m=1.70)
    limits = cfg.joint_limits().arrays()
    poses, labels = body_configurations(body, cfg, limits)
    return body, limits, poses, labels


def test_flexed_phases_add_a_crouched_walk() -> None:
    body, (low, high), poses, labels = _configs(8, 4)
    assert labels[0] == "standing"
    assert [lab.split("-")[0] for lab in labels[1:]] == ["walking"] * 8 + ["flexed"] * 4
    assert ((poses >= low - 1e-12) & (poses <= high + 1e-12)).all()
    joints = body.forward(poses)
    np.testing.assert_allclose(joints[:, FEET, 2].min(axis=1), 0.0, atol=1e-9)
    walk = {lab.split("-")[1]: p for lab, p in zip(labels, poses, strict=True) if "walking" in lab}
    for lab, p in zip(labels, poses, strict=True):
        if not lab.startswith("flexed"):
            continue
        w = walk[lab.split("-")[1]]  # the walking phase it flexes
        assert p[DOF["trunk_flexion"]] - w[DOF["trunk_flexion"]] == pytest.approx(
            np.radians(FLEXED_OFFSETS_DEG["trunk_flexion"])
        )
        for side in ("l", "r"):
            for joint in ("hip_flexion", "knee_flexion", "ankle_flexion"):
                i = DOF[f"{side}_{joint}"]
                want = min(w[i] + np.radians(FLEXED_OFFSETS_DEG[joint]), high[i])
                assert p[i] == pytest.approx(want)
    # crouched: the head is lower than in any walking phase
    head = joints[:, 0, 2]
    flexed = np.array([lab.startswith("flexed") for lab in labels])
    assert head[flexed].max() < head[~flexed].min()


def test_no_flexed_phases_by_request() -> None:
    _, _, poses, labels = _configs(8, 0)
    assert len(labels) == 9 and not any(lab.startswith("flexed") for lab in labels)
    # the general profile allows sitting
    _, _, _, labels = _configs(4, 2, "general")
    assert labels[-6:] == [
        "seated",
        "seated-lean25",
        "seated-lean50",
        "seated-low",
        "seated-low-lean25",
        "seated-low-lean50",
    ]
    assert len(labels) == 1 + 4 + 2 + 2 * len(SEATED_LEAN_DEG)


def test_seated_configurations_stand_on_their_feet() -> None:
    """Seated bodies are placed by their feet (the floor point the searches use is under the
    feet, a thigh's length ahead of a seated pelvis), sit on the floor's level, and lean."""
    body, (low, high), poses, labels = _configs(4, 0, "general")
    seated = [i for i, lab in enumerate(labels) if lab.startswith("seated")]
    joints = body.forward(poses[seated])
    np.testing.assert_allclose(joints[:, FEET, :2].mean(axis=1), 0.0, atol=1e-9)
    np.testing.assert_allclose(joints[:, FEET, 2].min(axis=1), 0.0, atol=1e-9)
    # the pelvis is behind the feet (heading 0 faces +x) and low
    assert (poses[seated, DOF["root_x"]] < -0.3).all()
    assert (joints[:, 2, 2] < 0.7).all()  # the sacrum, seated
    np.testing.assert_allclose(
        np.degrees(poses[seated, DOF["trunk_flexion"]]), 2 * SEATED_LEAN_DEG, atol=1e-9
    )
    head = joints[:, 0, 2].reshape(2, len(SEATED_LEAN_DEG))  # chair, low seat
    assert np.all(np.diff(head, axis=1) < -0.05)  # the head lowers as the trunk leans
    sacrum = joints[:, 2, 2].reshape(2, len(SEATED_LEAN_DEG))
    assert np.all(sacrum[1] < sacrum[0] - 0.05)  # the low seat is lower
    # the other configurations keep their pelvis at the placement point
    others = [i for i in range(len(labels)) if i not in seated]
    assert (poses[others][:, [DOF["root_x"], DOF["root_y"]]] == 0.0).all()
    # the walking profile has no seated configuration
    _, _, _, labels = _configs(4, 0, "walking")
    assert not any(lab.startswith("seated") for lab in labels)


def test_initial_search_finds_a_seated_person_by_their_feet() -> None:
    """The tracker's own body seated at a position and heading, seen by two cameras: the
    initial search finds it seated there (before, the seated configuration was placed with its
    pelvis on the floor point under the feet, half a metre off)."""
    from tracker.camera import Camera
    from tracker.init import floor_point, initial_search
    from tracker.likelihood import SilhouetteLikelihood

    body, (low, high), poses, labels = _configs(4, 0, "general")
    cfg = TrackerConfig.model_validate({"limits_profile": "general"})
    cams = [
        Camera.look_at(name="a", position=[4.0, 1.0, 2.3], target=[0.5, 0.3, 0.6]),
        Camera.look_at(name="b", position=[0.0, -4.0, 2.3], target=[0.5, 0.3, 0.6]),
    ]
    cams = [c.scaled(160, 120) for c in cams]
    lik = SilhouetteLikelihood(body, cams)
    for yaw in (0.3, 2.5):
        truth = poses[labels.index("seated-lean25")].copy()
        c, s = np.cos(yaw), np.sin(yaw)
        ox, oy = truth[DOF["root_x"]], truth[DOF["root_y"]]
        truth[DOF["root_x"]] = 0.5 + c * ox - s * oy
        truth[DOF["root_y"]] = 0.3 + s * ox + c * oy
        truth[DOF["root_yaw"]] = yaw
        feet = body.forward(truth[None])[0][FEET, :2].mean(axis=0)
        np.testing.assert_allclose(feet, [0.5, 0.3], atol=1e-9)
        masks = [np.asarray(lik.render_mask(truth, i)) for i in range(len(cams))]
        lik.set_silhouettes(masks)
        fp = floor_point(cams, masks)
        assert np.linalg.norm(fp - feet) < 0.25  # the floor point is under the feet
        res = initial_search(lik, body, cams, masks, cfg, limits=(low, high), dt=0.05)
        best = res.best
        err = np.linalg.norm(body.forward(best[None])[0] - body.forward(truth[None])[0], axis=1)
        assert err.mean() < 0.08, f"heading {yaw}: mean key-point error {err.mean():.3f} m"
        assert res.best_weight > 0.7


def _crouch_table(n: int = 41) -> MotTable:
    ph = np.linspace(0.0, 1.0, n)
    cols = {
        "time": ph,
        "hip_flexion_r": 35 + 18 * np.cos(2 * np.pi * ph),
        "hip_flexion_l": 35 + 18 * np.cos(2 * np.pi * (ph - 0.5)),
        "knee_angle_r": -(50 + 20 * np.clip(np.sin(2 * np.pi * (ph - 0.55)), 0, None)),
        "knee_angle_l": -(50 + 20 * np.clip(np.sin(2 * np.pi * (ph - 0.05)), 0, None)),
        "ankle_angle_r": np.full(n, 15.0),
        "ankle_angle_l": np.full(n, 15.0),
        "lumbar_extension": np.full(n, -10.0),
    }
    return MotTable(columns=list(cols), data=np.column_stack(list(cols.values())), header={})


def test_a_crouched_walker_is_found_facing_forwards() -> None:
    """The scene synthesiser's person (its own mesh) walking crouched through one oblique
    camera: with flexed phases the first frame faces the right way and fits the crouch (scene
    seeds 0-4, tracker seeds 0-1: 65-93 mm; without flexed phases 119-256 mm)."""
    from gait.geometry import body_forward
    from gaitwatch.sim.angles import AngleWalkParams, angle_walk
    from gaitwatch.sim.scene import SceneConfig
    from gaitwatch.sim.synth import build_scene, render_background, render_frames
    from tracker.pipeline import Tracker

    walk = angle_walk(_crouch_table(), AngleWalkParams(height_m=1.70, cycles=2))
    scene = build_scene(
        walk, SceneConfig(image_size=(320, 240), fps=20.0, views=["oblique"], seed=3)
    )
    bg = [np.ascontiguousarray(render_background(scene, 0)[..., ::-1])]
    k, images, _ = next(iter(render_frames(scene)))
    fwd = body_forward(scene.truth.positions)[k]
    truth_yaw = np.arctan2(fwd[1], fwd[0])
    cfg = TrackerConfig.model_validate({"init": {"flexed_phases": 8}})
    tracker = Tracker(
        scene.cameras,
        cfg,
        rng=np.random.default_rng(0),
        height_m=float(scene.body.stature_m),
        backgrounds=bg,
    )
    res = tracker.process(0, 0.0, [np.ascontiguousarray(images[0][..., ::-1])])
    assert res.has_pose
    off = np.degrees(abs((res.pose[DOF["root_yaw"]] - truth_yaw + np.pi) % (2 * np.pi) - np.pi))
    assert off < 45.0, f"heading {off:.0f} deg off"
    err = np.linalg.norm(res.joints - scene.truth.positions[k], axis=1).mean()
    assert err < 0.12, f"first-frame error {err:.3f} m"


@pytest.mark.parametrize(("fps", "frames"), [(20.0, 10), (30.0, 15)])
def test_shape_windows_cover_the_same_time_at_any_frame_rate(fps, frames, caplog) -> None:
    """``init.girth_frames`` (5), ``init.part_girth_frames`` and ``init.leg_length_frames`` (10)
    are frames at 20 Hz: at 30 fps the girth is scored over 8 frames and the part factors and
    the leg length over 15 tracked frames, the same time of the walk, and each is fixed on the
    last of its frames."""
    import logging

    from tracker.likelihood import SilhouetteLikelihood
    from tracker.pipeline import Tracker, frames_at_rate
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    assert frames_at_rate(10, 0.05, 1.0 / fps) == frames
    rng = np.random.default_rng(5)
    body = BodyModel(1.70)
    cams = side_cameras(2, image_size=(160, 120), fps=fps)
    poses = walking_motion(body, frames + 3, fps=fps, speed_m_s=1.0)
    bgs = [textured_background(160, 120, rng) for _ in cams]
    clip = list(render_clip(SilhouetteLikelihood(body, cams), poses, bgs, rng))
    cfg = TrackerConfig.model_validate({"init": {"part_girths": [0.9, 1.0], "hems": []}})
    tracker = Tracker(cams, cfg, rng=np.random.default_rng(0), height_m=1.70, backgrounds=bgs)
    fixed: dict[str, int] = {}
    with caplog.at_level(logging.INFO, logger="tracker.pipeline"):
        for k, images in enumerate(clip):
            caplog.clear()
            res = tracker.process(k, k / fps, images)
            assert res.has_pose
            for rec in caplog.records:
                msg = rec.getMessage()
                for key, text in (
                    ("girth", "body girth"),
                    ("parts", "body part girths"),
                    ("legs", "relative leg length"),
                ):
                    if text in msg:
                        fixed[key] = k
    # frame 0 initialises; the girth counts from it (5 frames at 20 Hz), the part factors and
    # the leg length count tracked frames from frame 1
    girth = frames_at_rate(5, 0.05, 1.0 / fps)
    assert fixed == {"girth": girth - 1, "parts": frames, "legs": frames}
