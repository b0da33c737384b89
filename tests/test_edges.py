"""The edge cue (tracker.edges): edge maps, outline scores, factoring, plumbing."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pydantic import ValidationError

from tests.test_appearance import _paint, _pose
from tests.tracker_helpers import assert_written_is_model, factored_equals_flat
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.config import EdgeConfig, TrackerConfig
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, JointLimits
from tracker.edges import EdgeCue, capsules_of, edge_map
from tracker.likelihood import SilhouetteLikelihood, weight_from_counts

SIZE = (320, 240)


@pytest.fixture(scope="module")
def body() -> BodyModel:
    return BodyModel(1.72)


@pytest.fixture(scope="module")
def cameras() -> list[Camera]:
    return [
        Camera.look_at(name="front", position=[4.0, 1.0, 1.6], target=[0, 0, 0.9]).scaled(*SIZE),
        Camera.look_at(name="side", position=[0.5, -4.0, 1.8], target=[0, 0, 0.9]).scaled(*SIZE),
    ]


@pytest.fixture(scope="module")
def scene(body: BodyModel, cameras: list[Camera]) -> dict:
    pose = _pose(body)
    painted = [_paint(body, pose, c) for c in cameras]
    return {"pose": pose, "frames": [p[0] for p in painted], "masks": [p[1] for p in painted]}


def _cue(cameras, scene, typical: float | None = None, **kw) -> EdgeCue:
    cue = EdgeCue(cameras, EdgeConfig(enabled=True, **kw))
    cue.set_frame(scene["frames"], scene["masks"])
    cue.typical = typical
    return cue


def test_edge_map_sees_an_edge_inside_the_silhouette_only() -> None:
    # a grey frame with a darker vertical band (x 40..59) inside a silhouette box (x 20..79),
    # and a strong edge of the room (y = 10) outside it
    img = np.full((100, 100, 3), 150, np.uint8)
    img[:, 40:60] = 60
    img[:10] = 255
    sil = np.zeros((100, 100), bool)
    sil[30:90, 20:80] = True
    m = edge_map(img, sil, (100, 100), blur_px=0.0, margin_px=0, scale_percentile=90.0)
    assert m.shape == (100, 100, 6)
    gx = np.sqrt((m[..., 0::2] ** 2).sum(axis=2))  # |d/dx| over the channels
    gy = np.sqrt((m[..., 1::2] ** 2).sum(axis=2))
    # the band's sides are vertical edges: strong gx there, no gy
    assert gx[60, 39:41].max() >= 1.0 and gx[60, 59:61].max() >= 1.0
    assert gy[40:80, 25:75].max() < 1e-6
    # flat inside the band and outside it
    assert gx[60, 45:55].max() < 1e-6 and gx[60, 25:35].max() < 1e-6
    # the room's edge lies outside the silhouette: gone
    assert np.abs(m[:30]).max() == 0.0
    # nobody in view or a flat image: all zero, no error
    assert not edge_map(img, np.zeros((100, 100), bool), (100, 100)).any()
    flat = np.full((100, 100, 3), 90, np.uint8)
    assert not edge_map(flat, sil, (100, 100)).any()
    # a grey frame is a BGR one with equal channels; other shapes are refused
    np.testing.assert_array_equal(
        edge_map(img[..., 0], sil, (100, 100)), edge_map(img, sil, (100, 100))
    )
    with pytest.raises(ValueError, match="frame must be"):
        edge_map(np.zeros((100, 100, 4), np.uint8), sil, (100, 100))
    # sensor noise alone stays far below an edge's score
    noisy = np.clip(flat + np.random.default_rng(0).normal(0, 3, flat.shape), 0, 255)
    mag = np.sqrt((edge_map(noisy.astype(np.uint8), sil, (100, 100)) ** 2).sum(axis=2))
    assert mag[sil].mean() < 0.4


def test_interior_px_drops_the_outline_against_the_room() -> None:
    img = np.full((100, 100, 3), 200, np.uint8)
    img[30:90, 20:80] = 120  # the person, a plain box ...
    img[30:90, 45:55] = 40  # ... with a dark band inside
    sil = np.zeros((100, 100), bool)
    sil[30:90, 20:80] = True
    full = edge_map(img, sil, (100, 100), blur_px=0.0)
    inner = edge_map(img, sil, (100, 100), blur_px=0.0, interior_px=2)
    mag = lambda m: np.sqrt((m**2).sum(axis=2))  # noqa: E731
    assert mag(full)[60, 19:21].max() > 0.5 and mag(inner)[60, 17:23].max() == 0.0
    # the band's edges stay, on the same scale
    np.testing.assert_array_equal(inner[60, 43:57], full[60, 43:57])
    assert mag(inner)[60, 44:46].max() > 0.5


def test_capsules_of_parts() -> None:
    on = capsules_of(("thigh",))
    from tracker.body import CAPSULE_NAMES

    assert {CAPSULE_NAMES[i] for i in np.flatnonzero(on)} == {"left_thigh", "right_thigh"}
    with pytest.raises(ValueError, match="unknown part"):
        capsules_of(("tail",))


@pytest.mark.parametrize(
    ("dof", "delta"),
    [
        ("r_elbow_flexion", np.radians(50)),  # the forearm moves over the trunk
        ("l_shoulder_abduction", np.radians(-25)),  # the arm into the trunk
        ("r_knee_flexion", np.radians(-30)),
        ("l_hip_flexion", np.radians(-25)),
    ],
)
def test_score_is_highest_at_the_painted_pose(body, cameras, scene, dof, delta) -> None:
    cue = _cue(cameras, scene, parts=("upper_arm", "forearm", "thigh", "shank"))
    poses = np.stack([scene["pose"], scene["pose"]])
    poses[1, DOF[dof]] += delta
    s = cue.scores(body, body.points(poses))
    assert 0.0 < s[1] < s[0] <= 1.0, (dof, s)


def test_factored_equals_unfactored_with_the_cue(body, cameras, scene) -> None:
    cue = _cue(cameras, scene, typical=0.4)
    lik = SilhouetteLikelihood(body, cameras)
    lik.set_silhouettes(scene["masks"])
    lik.edges = cue
    rng = np.random.default_rng(3)
    lo, hi = JointLimits.profile("walking").arrays()
    m, na, nb = 3, 4, 5
    base = np.repeat(scene["pose"][None], m, axis=0)
    base[:, 6:] = np.clip(base[:, 6:] + rng.normal(0, 0.2, (m, N_DOF - 6)), lo[6:], hi[6:])
    left = rng.uniform(lo[list(LEFT_LEG)], hi[list(LEFT_LEG)], (m, na, len(LEFT_LEG)))
    right = rng.uniform(lo[list(RIGHT_LEG)], hi[list(RIGHT_LEG)], (m, nb, len(RIGHT_LEG)))
    flat, w = factored_equals_flat(lik, base, left, right, rtol=1e-12)
    sil = weight_from_counts(lik.counts(flat), lik.measure).reshape(m, na, nb)
    s = cue.scores(body, body.points(flat)).reshape(m, na, nb)
    assert s.std() > 0
    np.testing.assert_allclose(w, sil * (s / 0.4) ** cue.config.beta, rtol=1e-12)
    # the parallel kernel (large batches) gives the serial one's scores
    many = np.repeat(flat, 8, axis=0)
    np.testing.assert_allclose(
        cue.scores(body, body.points(many)), np.repeat(s.ravel(), 8), rtol=1e-12
    )


def test_inactive_until_an_estimate_and_without_a_frame(body, cameras, scene) -> None:
    lik = SilhouetteLikelihood(body, cameras)
    lik.set_silhouettes(scene["masks"])
    rng = np.random.default_rng(0)
    poses = scene["pose"][None] + rng.normal(0, 0.05, (20, N_DOF))
    plain = weight_from_counts(lik.counts(poses), lik.measure)
    cue = _cue(cameras, scene)
    lik.edges = cue
    assert not cue.active and np.array_equal(lik.weights(poses), plain)
    cue.update(body, scene["pose"])  # the first estimate sets the typical score
    assert cue.active and cue.typical == pytest.approx(
        float(cue.scores(body, body.points(scene["pose"][None]))[0])
    )
    w = lik.weights(poses)
    assert not np.array_equal(w, plain)
    state = cue.frame_state()
    cue.clear_frame()
    assert np.array_equal(lik.weights(poses), plain)
    cue.restore_frame(state)
    np.testing.assert_array_equal(lik.weights(poses), w)
    assert not TrackerConfig().edges.enabled  # off by default (docs/tracker.md, "Edge cue")
    # scope "arm_search": the likelihood's weights stay the silhouette's (the arm search ranks)
    lik.edges = _cue(cameras, scene, typical=0.4, scope="arm_search")
    assert lik.edges.active and np.array_equal(lik.weights(poses), plain)


def test_wrong_frame_count_and_config_are_rejected(cameras, scene) -> None:
    cue = EdgeCue(cameras, EdgeConfig(enabled=True))
    with pytest.raises(ValueError, match="expected 2 frames"):
        cue.set_frame(scene["frames"][:1], scene["masks"][:1])
    with pytest.raises(ValidationError):
        EdgeConfig(parts=("tail",))
    with pytest.raises(ValidationError):
        EdgeConfig(parts=())
    with pytest.raises(ValidationError):
        EdgeConfig(size=(4, 4000))
    with pytest.raises(ValidationError):
        TrackerConfig.model_validate({"edges": {"enabled": True, "strength": 2}})


def test_tracker_feeds_the_cue() -> None:
    """Through the pipeline: frames set the cue's maps, each estimate its typical score, and
    the likelihood carries the cue."""
    from tracker.pipeline import Tracker
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    rng = np.random.default_rng(5)
    body = BodyModel(1.70)
    cams = side_cameras(1, image_size=(160, 120), centre=(1.0, 0.0), fps=20.0)
    poses = walking_motion(body, 4, fps=20.0, speed_m_s=1.0, start_xy=(0.2, 0.0))
    bgs = [textured_background(160, 120, rng) for _ in cams]
    frames = list(render_clip(SilhouetteLikelihood(body, cams), poses, bgs, rng))
    cfg = TrackerConfig.model_validate({"edges": {"enabled": True, "size": [160, 120]}})
    tracker = Tracker(cams, cfg, rng=np.random.default_rng(0), height_m=1.70, backgrounds=bgs)
    assert tracker.likelihood.edges is tracker.edge_cue
    for k, images in enumerate(frames):
        assert tracker.process(k, k / 20.0, images).has_pose
    cue = tracker.edge_cue
    assert cue.active and 0.0 < cue.typical <= 1.0
    # the maps are this frame's: the person's outline, nothing of the room
    assert np.abs(cue.maps).max() > 0
    far = ~np.asarray(SilhouetteLikelihood(body, cams).render_mask(poses[-1], 0), bool)
    import cv2

    far = cv2.erode(far.astype(np.uint8), np.ones((9, 9), np.uint8)) > 0
    assert np.abs(cue.maps[0][far]).max() == 0.0


def test_output_scope_changes_only_the_written_arms() -> None:
    """``scope = "output"``: the written pose may differ from the tracker's own estimate in the
    arms only; the estimate (kept for the next frame) and the weights stay the silhouette's.
    One camera (fewer than ``arms.min_cameras``): no cue at all."""
    from tests.tracker_helpers import walking_clip
    from tracker.pipeline import Tracker

    clip = walking_clip()
    cfg = TrackerConfig.model_validate(
        {"edges": {"enabled": True, "scope": "output", "parts": ["upper_arm", "forearm"]}}
    )
    arm_dofs = [
        DOF[f"{s}_{n}"]
        for s in ("l", "r")
        for n in ("shoulder_flexion", "shoulder_abduction", "shoulder_rotation", "elbow_flexion")
    ]
    others = np.setdiff1d(np.arange(N_DOF), arm_dofs)
    tracker = Tracker(
        clip["cams"], cfg, rng=np.random.default_rng(0), height_m=1.70, backgrounds=clip["bgs"]
    )
    assert tracker.edge_cue is not None and not tracker.edge_cue.everywhere
    for k, images in enumerate(clip["frames"]):
        res = tracker.process(k, k / 20.0, images)
        assert res.has_pose
        own = tracker.prev_pose
        np.testing.assert_allclose(res.pose[others], own[others], atol=1e-12)
        assert_written_is_model(res.joints, tracker.body.forward(res.pose[None])[0])
    assert tracker.edge_cue.active
    one = Tracker(clip["cams"][:1], cfg, rng=np.random.default_rng(0), height_m=1.70)
    assert one.edge_cue is None and one.likelihood.edges is None


def _edge_map_whole_frame(frame, sil, size, blur_px, margin_px, interior_px):
    """The edge map computed over the whole frame, as before the bounding-box crop."""
    from tracker.appearance import lab_image

    w, h = size
    lab = lab_image(frame, size, 1.0)
    if blur_px > 0:
        lab = cv2.GaussianBlur(lab, (0, 0), blur_px)
    s = cv2.resize(sil.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST)
    out = np.zeros((h, w, 6), np.float32)
    for c in range(3):
        out[..., 2 * c] = cv2.Sobel(lab[..., c], cv2.CV_32F, 1, 0, ksize=3) / 8.0
        out[..., 2 * c + 1] = cv2.Sobel(lab[..., c], cv2.CV_32F, 0, 1, ksize=3) / 8.0
    inside = s > 0
    near = inside
    if margin_px > 0:
        near = cv2.dilate(s, np.ones((2 * margin_px + 1,) * 2, np.uint8)) > 0
    out[~near] = 0.0
    mag = np.sqrt((out[inside] ** 2).sum(axis=1))
    if interior_px > 0:
        out[cv2.erode(s, np.ones((2 * interior_px + 1,) * 2, np.uint8)) == 0] = 0.0
    return out / np.float32(max(float(np.percentile(mag, 90.0)), 2.0))


@pytest.mark.parametrize(
    ("blur_px", "margin_px", "interior_px"), [(1.0, 2, 0), (2.5, 2, 0), (0.0, 0, 0), (1.0, 2, 3)]
)
def test_edge_map_on_the_bounding_box_equals_the_whole_frame(
    blur_px: float, margin_px: int, interior_px: int
) -> None:
    rng = np.random.default_rng(7)
    img = cv2.GaussianBlur(rng.integers(0, 256, (240, 320, 3), dtype=np.uint8), (0, 0), 2.0)
    for box in ((slice(60, 200), slice(120, 180)), (slice(100, 240), slice(0, 40))):
        sil = np.zeros((240, 320), bool)
        sil[box] = True
        sil[box[0].start + 10 : box[0].start + 30, box[1].start : box[1].start + 5] = False
        kw = dict(blur_px=blur_px, margin_px=margin_px, interior_px=interior_px)
        want = _edge_map_whole_frame(img, sil, (160, 120), **kw)
        got = edge_map(img, sil, (160, 120), **kw)
        assert np.abs(want).max() > 0.5
        # OpenCV's vectorised filters may round the last bit differently by position
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5)


def test_frame_state_keeps_the_silhouettes_box_only(body, cameras, scene) -> None:
    cue = _cue(cameras, scene)
    full = cue.maps.copy()
    state = cue.frame_state()
    kept = sum(m.nbytes for _, _, m in state if m is not None)
    assert kept < full.nbytes / 2
    other = [np.zeros_like(scene["masks"][0])] + list(scene["masks"][1:])
    other[0][10:20, 10:20] = True  # another frame: a small blob elsewhere in camera 0
    cue.set_frame(scene["frames"], other)
    assert not np.array_equal(cue.maps, full)
    cue.restore_frame(state)
    np.testing.assert_array_equal(cue.maps, full)
    # nobody in view in one camera: its map is all zero, its state None
    cue.set_frame(scene["frames"], [np.zeros_like(scene["masks"][0]), scene["masks"][1]])
    assert not cue.maps[0].any() and cue.frame_state()[0] is None
