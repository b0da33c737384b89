"""The colour cue (tracker.appearance): learning part colours, scoring, factoring, plumbing."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pydantic import ValidationError

from tracker.appearance import ColourCue, lab_image, part_table
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.config import AppearanceConfig, TrackerConfig
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, JointLimits
from tracker.likelihood import SilhouetteLikelihood, weight_from_counts
from tracker.render_ref import capsule_discs

SIZE = (160, 120)
# BGR paint per part: skin head and hands, a red top with red sleeves, blue trousers, dark shoes.
PAINT = {
    "head": (120, 160, 220),
    "hand": (120, 160, 220),
    "forearm": (120, 160, 220),
    "trunk": (40, 40, 200),
    "upper_arm": (40, 40, 200),
    "pelvis": (160, 90, 40),
    "thigh": (160, 90, 40),
    "shank": (160, 90, 40),
    "foot": (30, 30, 30),
}


@pytest.fixture(scope="module")
def body() -> BodyModel:
    return BodyModel(1.72)


@pytest.fixture(scope="module")
def cameras() -> list[Camera]:
    return [
        Camera.look_at(name="front", position=[4.0, 1.0, 1.6], target=[0, 0, 0.9]).scaled(*SIZE),
        Camera.look_at(name="side", position=[0.5, -4.0, 1.8], target=[0, 0, 0.9]).scaled(*SIZE),
    ]


def _pose(body: BodyModel) -> np.ndarray:
    p = body.neutral_pose(x=0.1, y=0.0, yaw=0.3)
    for name, deg in (
        ("l_hip_flexion", 20),
        ("r_hip_flexion", -10),
        ("r_knee_flexion", 30),
        ("l_shoulder_flexion", -15),
        ("r_shoulder_flexion", 20),
        ("r_elbow_flexion", 30),
        ("l_shoulder_abduction", 10),
    ):
        p[DOF[name]] = np.radians(deg)
    return p


def _paint(body: BodyModel, pose: np.ndarray, cam: Camera) -> tuple[np.ndarray, np.ndarray]:
    """A BGR frame of the body painted per part (far capsules first) on grey, and its mask."""
    names, of_cap = part_table(True)
    a, b = body.capsules(pose[None])
    ca, cb, ra, rb, ok = capsule_discs(cam, a[0], b[0], body.radii)
    depth = cam.to_camera(0.5 * (a[0] + b[0]))[:, 2]
    img = np.full((cam.height, cam.width, 3), 128, np.uint8)
    mask = np.zeros((cam.height, cam.width), np.uint8)
    for c in np.argsort(-depth):
        if not ok[c]:
            continue
        colour = PAINT[names[of_cap[c]]]
        d = cb[c] - ca[c]
        n = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
        quad = np.array(
            [ca[c] + ra[c] * n, cb[c] + rb[c] * n, cb[c] - rb[c] * n, ca[c] - ra[c] * n]
        )
        for target, value in ((img, colour), (mask, 1)):
            cv2.fillConvexPoly(target, np.round(quad).astype(np.int32), value)
            for centre, r in ((ca[c], ra[c]), (cb[c], rb[c])):
                cx, cy = np.round(centre).astype(int)
                cv2.circle(target, (int(cx), int(cy)), int(round(r)), value, -1)
    return img, mask.astype(bool)


@pytest.fixture(scope="module")
def scene(body: BodyModel, cameras: list[Camera]) -> dict:
    pose = _pose(body)
    painted = [_paint(body, pose, c) for c in cameras]
    return {"pose": pose, "frames": [p[0] for p in painted], "masks": [p[1] for p in painted]}


def _learned_cue(body, cameras, scene, **kw) -> ColourCue:
    cfg = AppearanceConfig(enabled=True, min_frames=1, **kw)
    cue = ColourCue(cameras, cfg)
    cue.set_frame(scene["frames"], scene["masks"])
    assert cue.update(body, scene["pose"], 1.0)
    return cue


def test_learns_the_painted_part_colours(body, cameras, scene) -> None:
    cue = _learned_cue(body, cameras, scene)
    lw = cue.config.lightness_weight
    for part in ("head", "trunk", "pelvis", "thigh", "foot"):
        patch = np.full((2, 2, 3), PAINT[part], np.uint8)
        want = lab_image(patch, (2, 2), lw)[0, 0]
        got = cue.ref[cue.part_names.index(part)]
        assert np.linalg.norm(got - want) < 3.0, (part, got, want)
    # Left and right arms share the sleeve colour; the learned spread of a plain part is small.
    assert cue.spread[cue.part_names.index("trunk")] < 3.0


def test_low_silhouette_weight_teaches_nothing(body, cameras, scene) -> None:
    cue = ColourCue(cameras, AppearanceConfig(enabled=True, min_weight=0.6))
    cue.set_frame(scene["frames"], scene["masks"])
    assert not cue.update(body, scene["pose"], 0.5)
    assert not cue.frames_learned.any() and not cue.active


@pytest.mark.parametrize(
    ("dof", "delta"),
    [
        ("root_z", -0.08),  # crouched: the waist band moves down
        ("root_yaw", np.radians(35)),
        ("trunk_flexion", np.radians(25)),
        ("r_elbow_flexion", np.radians(70)),  # the forearm (skin) over the trunk
        ("l_shoulder_abduction", np.radians(35)),
        ("l_knee_flexion", np.radians(60)),
        ("neck_flexion", np.radians(40)),
    ],
)
def test_score_is_highest_at_the_painted_pose(body, cameras, scene, dof, delta) -> None:
    cue = _learned_cue(body, cameras, scene)
    poses = np.stack([scene["pose"], scene["pose"]])
    poses[1, DOF[dof]] += delta
    s = cue.scores(body, body.points(poses))
    assert s[0] > 0.9
    assert s[0] > s[1] + 0.01, (dof, s)


def test_factored_equals_unfactored_with_the_cue(body, cameras, scene) -> None:
    cue = _learned_cue(body, cameras, scene)
    lik = SilhouetteLikelihood(body, cameras)
    lik.set_silhouettes(scene["masks"])
    lik.appearance = cue
    cue.typical = 0.8
    rng = np.random.default_rng(3)
    lo, hi = JointLimits.profile("walking").arrays()
    m, na, nb = 3, 4, 5
    base = np.repeat(scene["pose"][None], m, axis=0)
    base[:, 6:] = np.clip(base[:, 6:] + rng.normal(0, 0.2, (m, N_DOF - 6)), lo[6:], hi[6:])
    left = rng.uniform(lo[list(LEFT_LEG)], hi[list(LEFT_LEG)], (m, na, len(LEFT_LEG)))
    right = rng.uniform(lo[list(RIGHT_LEG)], hi[list(RIGHT_LEG)], (m, nb, len(RIGHT_LEG)))
    wf = lik.weights_factored(base, left, right)
    full = np.repeat(np.repeat(base[:, None, None], na, 1), nb, 2)
    full[..., list(LEFT_LEG)] = left[:, :, None]
    full[..., list(RIGHT_LEG)] = right[:, None, :]
    w = lik.weights(full.reshape(-1, N_DOF)).reshape(m, na, nb)
    np.testing.assert_allclose(wf, w, rtol=1e-12, atol=1e-15)
    # the cue changed the weights (it is active) ...
    sil = weight_from_counts(lik.counts(full.reshape(-1, N_DOF)), lik.measure).reshape(m, na, nb)
    assert not np.allclose(w, sil)
    # ... by the factor of its scores
    s = cue.scores(body, body.points(full.reshape(-1, N_DOF))).reshape(m, na, nb)
    np.testing.assert_allclose(w, sil * (s / 0.8) ** cue.config.beta, rtol=1e-12)


def test_a_hem_is_not_scored_and_the_thigh_still_learned(body, cameras, scene) -> None:
    skirted = body.with_shape(hem=(1.0, 0.09))
    plain, cue = _learned_cue(body, cameras, scene), _learned_cue(skirted, cameras, scene)
    # the hem shares the thigh's axis, so it does not hide the thigh: learned as before
    thigh = cue.part_names.index("thigh")
    assert cue.frames_learned[thigh] == plain.frames_learned[thigh] == 1
    np.testing.assert_allclose(cue.ref, plain.ref)
    # the hem's axis is the thigh's: not scored, so both bodies score a pose alike
    poses = np.stack([scene["pose"], scene["pose"]])
    poses[1, DOF["l_knee_flexion"]] += np.radians(40)
    np.testing.assert_allclose(
        cue.scores(skirted, skirted.points(poses)), cue.scores(body, body.points(poses))
    )
    np.testing.assert_allclose(
        cue.scores(body, body.points(poses)), plain.scores(body, body.points(poses))
    )


def test_off_or_without_a_frame_gives_the_silhouette_weights(body, cameras, scene) -> None:
    lik = SilhouetteLikelihood(body, cameras)
    lik.set_silhouettes(scene["masks"])
    rng = np.random.default_rng(0)
    poses = scene["pose"][None] + rng.normal(0, 0.05, (20, N_DOF))
    plain = weight_from_counts(lik.counts(poses), lik.measure)
    assert np.array_equal(lik.weights(poses), plain)
    cue = _learned_cue(body, cameras, scene)
    lik.appearance = cue
    assert not np.array_equal(lik.weights(poses), plain)
    cue.clear_frame()
    assert np.array_equal(lik.weights(poses), plain)
    assert TrackerConfig().appearance.enabled  # on by default (it wins on the 108 probe runs)


def test_hidden_samples_score_typical_behind_known_occluders(body, cameras, scene) -> None:
    """Behind a known occluder (and outside the silhouette) a sample scores the typical score:
    hidden legs neither cost nor gain; samples elsewhere and the other camera are unchanged."""
    cue = _learned_cue(body, cameras, scene)
    cue.typical = 0.7
    pose = scene["pose"]
    mask0 = scene["masks"][0]
    ys = np.flatnonzero(mask0.any(axis=1))
    cut = int(ys[0] + 0.55 * (ys[-1] - ys[0]))
    hidden_masks = [m.copy() for m in scene["masks"]]
    hidden_masks[0][cut:] = False  # the legs are hidden in camera 0
    occ = np.zeros_like(mask0)
    occ[cut:] = True
    cue.set_frame(scene["frames"], hidden_masks)
    pts = body.points(pose[None])
    plain = cue._sums(body, pts, None)[0]
    # full resolution masks are accepted and resized to the cue's size
    big = cv2.resize(occ.astype(np.uint8), (640, 480), interpolation=cv2.INTER_NEAREST)
    cue.set_occlusion([big, None])
    assert cue.occluded[0] is not None and cue.occluded[1] is None
    sums = cue._sums(body, pts, None)[0]
    assert sums[1] == plain[1]
    assert sums[0] > plain[0]  # the hidden leg samples now score 0.7 instead of 0
    maps = cue._score_maps()
    on = np.flatnonzero(cue._part_on)
    np.testing.assert_array_equal(maps[0][:, cut:][on], np.float32(0.7))
    np.testing.assert_array_less(maps[0][:, :cut][on][:, ~hidden_masks[0][:cut]], 1e-12)
    # reset forgets the person, not the room
    cue.reset()
    assert cue.occluded[0] is not None
    cue.set_occlusion(None)
    assert all(o is None for o in cue.occluded)
    with pytest.raises(ValueError, match="2 occlusion masks"):
        cue.set_occlusion([occ])


def test_config_is_validated() -> None:
    with pytest.raises(ValidationError):
        TrackerConfig.model_validate({"appearance": {"enabled": True, "colour": "red"}})
    with pytest.raises(ValidationError):
        AppearanceConfig(axis_margin=0.5)


def test_tracker_with_the_cue_on_a_synthesised_person() -> None:
    """The scene synthesiser's clothed person (its own mesh, clothes, lighting), two cameras:
    the pipeline feeds the frames, learns the part colours and tracks with the cue.

    One draw of the tracker can lose the legs for the whole clip (tracker seeds 0-9 give mean
    errors of 0.07-0.17 m), so the accuracy is judged on the median of three draws."""
    from gaitwatch.sim.motion import procedural_walk
    from gaitwatch.sim.scene import SceneConfig
    from gaitwatch.sim.synth import build_scene, render_background, render_frames
    from tracker.pipeline import Tracker

    walk = procedural_walk(
        height_m=1.70, speed_m_s=1.0, cadence_steps_min=105, distance_m=1.2, start=(0.0, 0.0)
    )
    scene = build_scene(
        walk, SceneConfig(image_size=(320, 240), fps=20.0, views=["side", "frontal"], seed=1)
    )
    bgs = [np.ascontiguousarray(render_background(scene, i)[..., ::-1]) for i in range(2)]
    frames = [
        (k, [np.ascontiguousarray(im[..., ::-1]) for im in images])
        for k, images, _ in render_frames(scene)
    ]
    cfg = TrackerConfig.model_validate({"appearance": {"enabled": True}})
    mean_errors, trackers = [], []
    for seed in range(3):
        tracker = Tracker(
            scene.cameras,
            cfg,
            rng=np.random.default_rng(seed),
            height_m=float(scene.body.stature_m),
            backgrounds=bgs,
        )
        assert tracker.likelihood.appearance is tracker.colour
        errs = []
        for k, images in frames:
            res = tracker.process(k, k / 20.0, images)
            assert res.has_pose
            errs.append(np.linalg.norm(res.joints - scene.truth.positions[k], axis=1).mean())
        mean_errors.append(float(np.mean(errs)))
        trackers.append(tracker)
    for tracker in trackers:
        cue = tracker.colour
        assert cue.active and cue.typical is not None
        learned = {n for n, f in zip(cue.part_names, cue.frames_learned, strict=True) if f >= 3}
        assert {"trunk", "pelvis", "thigh", "head"} <= learned
        # The top and the trousers differ in colour: so do their references.
        t, p = cue.ref[cue.part_names.index("trunk")], cue.ref[cue.part_names.index("pelvis")]
        assert np.linalg.norm(t - p) > 5.0
    assert np.median(mean_errors) < 0.15, f"mean errors {np.round(mean_errors, 3)} m"
