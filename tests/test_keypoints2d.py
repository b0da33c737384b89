"""The 2D key-point cue (tracker.keypoints2d): scores, side assignment, factoring, plumbing."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from tests.test_appearance import _paint, _pose
from tests.tracker_helpers import factored_equals_flat
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.config import KeypointConfig, TrackerConfig
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, JointLimits
from tracker.keypoints2d import PARTS, KeypointCue, KeypointHeatmaps, sample_maps
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


def _detections(body, pose, cameras, swap=None, conf=1.0) -> list[np.ndarray]:
    """A perfect detector: the pose's key points projected, optionally with the legs' labels
    exchanged per camera."""
    kp = np.asarray(body.forward(pose[None]))[0]
    out = []
    for cam, sw in zip(cameras, swap or [False] * len(cameras), strict=True):
        d = np.concatenate([cam.project(kp), np.full((len(kp), 1), conf)], axis=1)
        if sw:
            for left, right in PARTS.values():
                d[list(left) + list(right)] = d[list(right) + list(left)]
        out.append(d)
    return out


def _painted_likelihood(body, cameras, pose) -> SilhouetteLikelihood:
    """The silhouette likelihood of the pose's own painted silhouettes in every camera."""
    lik = SilhouetteLikelihood(body, cameras)
    lik.set_silhouettes([_paint(body, pose, c)[1] for c in cameras])
    return lik


def _cue(cameras, dets, typical=None, **kw) -> KeypointCue:
    if "parts" in kw:
        kw["parts_multi_camera"] = None  # the test's parts with any number of cameras
    cue = KeypointCue(cameras, KeypointConfig(enabled=True, **kw))
    cue.set_frame(dets)
    cue.typical = typical
    return cue


@pytest.mark.parametrize(
    ("dof", "delta", "parts"),
    [
        ("l_knee_flexion", 0.3, ("legs",)),
        ("r_hip_flexion", -0.3, ("legs",)),
        ("r_ankle_flexion", 0.4, ("legs",)),
        ("root_x", 0.1, ("legs",)),
        ("l_elbow_flexion", 0.5, ("legs", "arms")),
        ("r_shoulder_abduction", 0.4, ("arms",)),
        ("root_x", 0.05, ("hips",)),
        ("root_roll", 0.15, ("legs", "hips")),
    ],
)
def test_score_is_highest_at_the_detected_pose(body, cameras, dof, delta, parts) -> None:
    pose = _pose(body)
    cue = _cue(cameras, _detections(body, pose, cameras), parts=parts)
    poses = np.stack([pose, pose])
    poses[1, DOF[dof]] += delta
    s = cue.scores(body, body.points(poses))
    assert s[0] == pytest.approx(1.0)
    assert 0.0 < s[1] < 0.99, (dof, s)


def test_the_detectors_side_labels_do_not_matter_but_both_legs_count(body, cameras) -> None:
    pose = _pose(body)
    right = body.points(pose[None])
    moved = pose.copy()
    moved[[DOF["l_knee_flexion"], DOF["r_elbow_flexion"]]] += 0.3
    poses = body.points(np.stack([pose, moved]))
    base = _cue(cameras, _detections(body, pose, cameras)).scores(body, right)
    for parts in (("legs",), ("legs", "arms"), ("legs", "hips")):
        ref = _cue(cameras, _detections(body, pose, cameras), parts=parts).scores(body, poses)
        for swap in ((True, False), (False, True), (True, True)):
            dets = _detections(body, pose, cameras, swap=swap)
            np.testing.assert_allclose(_cue(cameras, dets, parts=parts).scores(body, poses), ref)
    # both model legs on the detected left leg: one leg is always far from its detection
    both = pose.copy()
    both[list(RIGHT_LEG)] = pose[list(LEFT_LEG)]
    cue = _cue(cameras, _detections(body, pose, cameras))
    assert cue.scores(body, body.points(both[None]))[0] < 0.8 * base[0]


def test_missing_and_unconfident_points_are_left_out(body, cameras) -> None:
    pose = _pose(body)
    moved = pose.copy()
    moved[DOF["l_knee_flexion"]] += 0.4  # moves the left ankle, heel and toe, and the knee
    dets = _detections(body, pose, cameras)
    full = _cue(cameras, dets).scores(body, body.points(np.stack([pose, moved])))
    for d in dets:  # the left shank and foot not found by the detector
        d[[13, 15, 17], :2] = np.nan
    fewer = _cue(cameras, dets).scores(body, body.points(np.stack([pose, moved])))
    assert fewer[0] == pytest.approx(1.0) and fewer[1] > full[1]
    # a camera whose points are all below min_confidence is not used; none at all: no frame
    low = _detections(body, pose, cameras, conf=0.2)
    cue = _cue(cameras, [low[0], _detections(body, pose, cameras)[1]], parts=("legs",))
    one = _cue(cameras[1:], _detections(body, pose, cameras[1:]), parts=("legs",))
    np.testing.assert_allclose(
        cue.scores(body, body.points(moved[None])), one.scores(body, body.points(moved[None]))
    )
    cue.set_frame(low)
    assert not cue.has_frame
    cue.set_frame([None, None])
    assert not cue.has_frame
    cue.set_frame(None)
    assert not cue.has_frame


def test_a_tolerance_scores_near_points_as_matches(body, cameras) -> None:
    pose = _pose(body)
    cam = cameras[:1]
    det = _detections(body, pose, cam)[0]
    height = float(np.nanmax(det[:, 1]) - np.nanmin(det[:, 1]))
    sigma, tol = 0.08 * height, 0.05 * height
    pts = body.points(pose[None])
    for shift, tolerance, expected in [
        (0.04 * height, 0.05, 1.0),  # within the tolerance: a match
        (0.09 * height, 0.05, np.exp(-0.5 * ((0.09 * height - tol) / sigma) ** 2)),
        (0.09 * height, 0.0, np.exp(-0.5 * (0.09 * height / sigma) ** 2)),
    ]:
        moved = det.copy()
        moved[:, :2] += shift * np.array([0.6, 0.8])  # every point, the same distance
        cue = _cue(cam, [moved], tolerance_fraction=tolerance)
        assert cue.scores(body, pts)[0] == pytest.approx(expected, rel=1e-9)
        state = cue.frame_state()  # the backward pass keeps the tolerance with the frame
        cue.clear_frame()
        cue.restore_frame(state)
        assert cue.scores(body, pts)[0] == pytest.approx(expected, rel=1e-9)
    # a tolerance leaves the far basins far: a swapped-in wrong leg still scores lower
    cue = _cue(cameras, _detections(body, pose, cameras), tolerance_fraction=0.05)
    both = pose.copy()
    both[list(RIGHT_LEG)] = pose[list(LEFT_LEG)]
    s = cue.scores(body, body.points(np.stack([pose, both])))
    assert s[0] == pytest.approx(1.0) and s[1] < 0.9
    with pytest.raises(ValidationError):
        KeypointConfig(tolerance_fraction=-0.1)


def _jittered_bases(pose: np.ndarray, rng: np.random.Generator, m: int, sd: float) -> np.ndarray:
    """``m`` copies of ``pose`` with Gaussian noise (radians) on every DOF but the root, kept
    inside the walking limits: the base poses of the factoring tests."""
    lo, hi = JointLimits.profile("walking").arrays()
    base = np.repeat(pose[None], m, axis=0)
    base[:, 6:] = np.clip(base[:, 6:] + rng.normal(0, sd, (m, N_DOF - 6)), lo[6:], hi[6:])
    return base


def _moved_poses(
    pose: np.ndarray, rng: np.random.Generator, n: int, sd: float, root_sd: float, root: int
) -> np.ndarray:
    """``pose`` and ``n - 1`` copies with Gaussian noise on every joint angle (``sd``, radians)
    and on the first ``root`` root DOFs (``root_sd``, metres): poses to score."""
    poses = np.repeat(pose[None], n, axis=0)
    poses[1:, 6:] += rng.normal(0, sd, (n - 1, N_DOF - 6))
    poses[1:, :root] += rng.normal(0, root_sd, (n - 1, root))
    return poses


@pytest.mark.parametrize(
    ("parts", "tolerance"),
    [
        (("legs",), 0.0),
        (("legs", "arms"), 0.0),
        (("arms",), 0.0),
        (("legs", "arms"), 0.05),
        (("legs", "hips"), 0.0),
        (("legs", "arms", "hips"), 0.0),
    ],
)
def test_factored_equals_unfactored_with_the_cue(body, cameras, parts, tolerance) -> None:
    pose = _pose(body)
    lik = _painted_likelihood(body, cameras, pose)
    dets = _detections(body, pose, cameras, swap=(False, True))
    cue = _cue(cameras, dets, typical=0.6, parts=parts, tolerance_fraction=tolerance)
    lik.keypoints = cue
    rng = np.random.default_rng(3)
    lo, hi = JointLimits.profile("walking").arrays()
    m, na, nb = 3, 4, 5
    base = _jittered_bases(pose, rng, m, 0.2)
    left = rng.uniform(lo[list(LEFT_LEG)], hi[list(LEFT_LEG)], (m, na, len(LEFT_LEG)))
    right = rng.uniform(lo[list(RIGHT_LEG)], hi[list(RIGHT_LEG)], (m, nb, len(RIGHT_LEG)))
    flat, w = factored_equals_flat(lik, base, left, right, rtol=1e-12)
    sil = weight_from_counts(lik.counts(flat), lik.measure).reshape(m, na, nb)
    s = cue.scores(body, body.points(flat)).reshape(m, na, nb)
    assert s.std() > 0
    np.testing.assert_allclose(w, sil * np.maximum(s, 1e-6) / 0.6, rtol=1e-12)  # beta 1


@pytest.mark.parametrize("heat", [False, True])
def test_parts_scored_together_as_each_alone(body, cameras, heat) -> None:
    """The parts are scored in one pass per camera: the score of several parts is each part's
    own score weighted by its detected points, each part's sides assigned on their own, with
    points and whole parts missing."""
    pose = _pose(body)
    pts = body.points(_moved_poses(pose, np.random.default_rng(11), 6, 0.15, 0.05, 3))
    dets = _detections(body, pose, cameras)
    left, right = (list(side) for side in PARTS["legs"])
    dets[0][left + right] = dets[0][right + left]  # the legs' labels exchanged, not the arms'
    dets[0][[5, 12]] = np.nan  # an elbow and a knee not found
    dets[1][[9, 10]] = np.nan  # no hip at all in the second camera
    parts = ("legs", "arms", "hips")
    for k in range(len(cameras)):
        cams, det = cameras[k : k + 1], dets[k : k + 1]
        maps = _heatmaps(det) if heat else None

        def cue(p, cams=cams, det=det, maps=maps):
            return _heat_cue(cams, det, maps, parts=p) if heat else _cue(cams, det, parts=p)

        found = {
            p: int(np.isfinite(det[0][list(sum(PARTS[p], ()))]).all(axis=1).sum()) for p in parts
        }
        assert found["hips"] == (2 if k == 0 else 0)
        alone = sum(cue((p,)).scores(body, pts) * n for p, n in found.items() if n)
        together = cue(parts).scores(body, pts)
        assert together.std() > 0.01
        np.testing.assert_allclose(together, alone / sum(found.values()), rtol=1e-12)


def test_scores_match_a_plain_reference_through_a_distorted_camera(body) -> None:
    """The cue's kernel against the score written out in numpy: Camera.project (OpenCV's
    distortion), the Gaussian of each distance, the better assignment of the sides per part,
    the mean over the detected points; a point behind the camera scores 0."""
    cam = Camera.look_at(
        name="wide",
        position=[3.0, -2.5, 1.7],
        target=[0, 0, 0.9],
        dist=[-0.25, 0.08, 0.001, -0.002, -0.01],
    ).scaled(*SIZE)
    pose = _pose(body)
    rng = np.random.default_rng(4)
    poses = _moved_poses(pose, rng, 8, 0.2, 0.1, 2)
    pts = body.points(poses)
    det = _detections(body, pose, [cam])[0]
    det[:, :2] += rng.normal(0, 3.0, (19, 2))
    det[[13, 17, 4]] = np.nan  # the left ankle and toe, a shoulder: not found
    parts = ("legs", "arms", "hips")
    cue = _cue([cam], [det], parts=parts)
    kp = body.forward(poses)  # (N, 19, 3) key points
    uv = cam.project(kp)
    height = np.nanmax(det[:, 1]) - np.nanmin(det[:, 1])
    sigma = max(0.08 * height, 2.0)

    def side_sum(model_side, det_side, part):
        g = np.zeros(len(poses))
        for m, d in zip(PARTS[part][model_side], PARTS[part][det_side], strict=True):
            if np.isfinite(det[d]).all():
                dist = np.linalg.norm(uv[:, m] - det[d, :2], axis=1)
                g += np.exp(-0.5 * (dist / sigma) ** 2)
        return g

    total = sum(
        np.maximum(side_sum(0, 0, p) + side_sum(1, 1, p), side_sum(0, 1, p) + side_sum(1, 0, p))
        for p in parts
    )
    found = sum(np.isfinite(det[list(sum(PARTS[p], ()))]).all(axis=1).sum() for p in parts)
    np.testing.assert_allclose(cue.scores(body, pts), total / found, rtol=1e-10)
    # the whole body moved behind the camera: nothing projects, the score is 0
    behind = 2 * cam.center - pts  # mirrored through the optical centre
    assert np.isnan(cam.project(behind[:, :19])).all()
    np.testing.assert_array_equal(cue.scores(body, behind), 0.0)


def test_inactive_until_an_estimate_and_without_a_frame(body, cameras) -> None:
    pose = _pose(body)
    lik = _painted_likelihood(body, cameras, pose)
    rng = np.random.default_rng(0)
    poses = pose[None] + rng.normal(0, 0.05, (20, N_DOF))
    plain = lik.weights(poses)
    cue = _cue(cameras, _detections(body, pose, cameras))
    lik.keypoints = cue
    assert not cue.active and np.array_equal(lik.weights(poses), plain)
    cue.update(body, poses[0])  # the first estimate sets the typical score
    first = float(cue.scores(body, body.points(poses[:1]))[0])
    assert cue.active and cue.typical == pytest.approx(first)
    cue.update(body, pose)  # then follows at `rate`
    assert cue.typical == pytest.approx(first + 0.2 * (1.0 - first))
    w = lik.weights(poses)
    assert not np.array_equal(w, plain)
    state = cue.frame_state()
    cue.clear_frame()
    assert np.array_equal(lik.weights(poses), plain)
    cue.update(body, pose)  # no frame: nothing learned
    assert cue.typical == pytest.approx(first + 0.2 * (1.0 - first))
    cue.restore_frame(state)
    np.testing.assert_array_equal(lik.weights(poses), w)
    assert TrackerConfig().keypoints.enabled  # on by default, with the built-in detector
    assert TrackerConfig().keypoints.detector == "blazepose"


def test_parts_follow_the_camera_count(body, cameras) -> None:
    cfg = KeypointConfig(enabled=True)
    # measured: the arms cost one camera and the hips gain there (docs/tracker.md, "Session 44")
    assert KeypointCue(cameras[:1], cfg).parts == ("legs", "hips")
    assert KeypointCue(cameras, cfg).parts == ("legs", "arms")
    same = KeypointConfig(enabled=True, parts=("arms",), parts_multi_camera=None)
    assert KeypointCue(cameras, same).parts == ("arms",)


def test_bad_detections_and_config_are_rejected(body, cameras) -> None:
    cue = KeypointCue(cameras, KeypointConfig(enabled=True))
    dets = _detections(body, _pose(body), cameras)
    with pytest.raises(ValueError, match="for 2 cameras"):
        cue.set_frame(dets[:1])
    with pytest.raises(ValueError, match="shape"):
        cue.set_frame([dets[0][:, :2], dets[1]])
    with pytest.raises(ValidationError):
        KeypointConfig(beta=0)
    with pytest.raises(ValidationError):
        KeypointConfig(parts=("tail",))
    with pytest.raises(ValidationError):
        KeypointConfig(parts=())
    with pytest.raises(ValidationError):
        TrackerConfig.model_validate({"keypoints": {"enabled": True, "sigma": 2}})


def test_tracker_feeds_the_cue_and_without_key_points_tracks_as_before() -> None:
    """Through the pipeline: each frame's detections set the cue, each estimate its typical
    score; with the cue on but no key points given the track is the cue-less one exactly."""
    from tracker.pipeline import Tracker
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    rng = np.random.default_rng(5)
    body = BodyModel(1.70)
    cams = side_cameras(1, image_size=(160, 120), centre=(1.0, 0.0), fps=20.0)
    poses = walking_motion(body, 4, fps=20.0, speed_m_s=1.0, start_xy=(0.2, 0.0))
    bgs = [textured_background(160, 120, rng) for _ in cams]
    frames = list(render_clip(SilhouetteLikelihood(body, cams), poses, bgs, rng))

    def run(cfg, with_points):
        tr = Tracker(cams, cfg, rng=np.random.default_rng(0), height_m=1.70, backgrounds=bgs)
        out = []
        for k, images in enumerate(frames):
            kp = _detections(body, poses[k], cams) if with_points else None
            out.append(tr.process(k, k / 20.0, images, keypoints=kp))
        return tr, out

    off_tr, off = run(TrackerConfig.model_validate({"keypoints": {"enabled": False}}), False)
    cfg = TrackerConfig.model_validate({"keypoints": {"enabled": True, "detector": "none"}})
    tr, without = run(cfg, False)
    assert tr.likelihood.keypoints is tr.keypoint_cue and off_tr.keypoint_cue is None
    for a, b in zip(off, without, strict=True):
        np.testing.assert_array_equal(a.pose, b.pose)
    tr, with_points = run(cfg, True)
    assert tr.keypoint_cue.active and 0.0 < tr.keypoint_cue.typical <= 1.0
    assert all(r.has_pose for r in with_points)
    assert any(not np.array_equal(a.pose, b.pose) for a, b in zip(off, with_points, strict=True))


# -- scored by the detector's heatmaps ------------------------------------------------------


def _heatmaps(dets, extra=None, sigma_cells=1.5, scale=0.25) -> list[KeypointHeatmaps]:
    """Per camera heatmaps with a Gaussian blob (peak 0.8) at each detected point, in cells of
    ``scale`` x the image's pixels; ``extra`` {key point: (u, v)} adds a second blob of the same
    height (a second place the detector thinks the landmark may be)."""
    out = []
    for d in dets:
        rows, cols = int(np.ceil(SIZE[1] * scale)) + 1, int(np.ceil(SIZE[0] * scale)) + 1
        yy, xx = np.mgrid[0:rows, 0:cols]
        maps = np.zeros((d.shape[0], rows, cols), dtype=np.float32)
        for j, (u, v) in enumerate(d[:, :2]):
            for pu, pv in [(u, v), *([extra[j]] if extra and j in extra else [])]:
                blob = 0.8 * np.exp(
                    -((xx - pu * scale) ** 2 + (yy - pv * scale) ** 2) / (2 * sigma_cells**2)
                )
                maps[j] = np.maximum(maps[j], blob)
        out.append(KeypointHeatmaps(maps, np.array([[scale, 0, 0], [0, scale, 0.0]])))
    return out


def _heat_cue(cameras, dets, maps, typical=None, **kw) -> KeypointCue:
    kw.setdefault("parts", ("legs",))
    kw.setdefault("parts_multi_camera", None)
    cue = KeypointCue(cameras, KeypointConfig(enabled=True, score="heatmap", **kw))
    cue.set_frame(dets, maps)
    cue.typical = typical
    return cue


def test_sample_maps_is_bilinear_and_zero_outside() -> None:
    rows, cols = 5, 7
    yy, xx = np.mgrid[0:rows, 0:cols]
    # (2 sides, 2 points, 5 rows, 7 columns): linear in the cells, so bilinear samples are exact
    maps = np.stack([np.stack([1 + 2 * xx + 3 * yy, 10 - xx])] * 2).astype(np.float32)
    cells = np.array(
        [
            [[0.0, 0.0], [2.5, 1.25]],
            [[6.0, 4.0], [5.9, 3.1]],  # the last column and row are inside
            [[-0.1, 2.0], [3.0, 4.2]],  # outside
            [[np.nan, 1.0], [1.0, np.inf]],  # NaN and infinity: outside
        ]
    )  # (N 4, h 2, 2)
    got = sample_maps(maps, cells)
    assert got.shape == (2, 4, 2)
    expected = np.array([[1.0, 10 - 2.5], [1 + 12 + 12, 10 - 5.9], [0, 0], [0, 0]])
    expected[0, 0] = 1.0
    expected[0, 1] = 10 - 2.5
    expected[1, 0] = 1 + 2 * 6 + 3 * 4
    expected[1, 1] = 10 - 5.9
    np.testing.assert_allclose(got[0], expected, rtol=1e-6)
    np.testing.assert_allclose(got[1], expected, rtol=1e-6)
    np.testing.assert_allclose(
        sample_maps(maps, np.array([[[2.5, 1.25], [0.0, 0.0]]]))[0, 0, 0], 1 + 5 + 3.75, rtol=1e-6
    )
    with pytest.raises(ValueError, match="maps must have shape"):
        sample_maps(maps[0], cells)
    with pytest.raises(ValueError, match="cells must have shape"):
        sample_maps(maps, cells[:, :1])


def test_heatmaps_are_checked() -> None:
    with pytest.raises(ValueError, match="shape"):
        KeypointHeatmaps(np.zeros((18, 8, 8)), np.eye(2, 3))
    with pytest.raises(ValueError, match="shape"):
        KeypointHeatmaps(np.zeros((19, 1, 8)), np.eye(2, 3))
    with pytest.raises(ValueError, match="affine"):
        KeypointHeatmaps(np.zeros((19, 8, 8)), np.eye(3))
    with pytest.raises(ValueError, match="affine"):
        KeypointHeatmaps(np.zeros((19, 8, 8)), np.full((2, 3), np.nan))


@pytest.mark.parametrize(
    ("dof", "delta", "parts"),
    [
        ("l_knee_flexion", 0.3, ("legs",)),
        ("r_hip_flexion", -0.3, ("legs",)),
        ("root_x", 0.1, ("legs",)),
        ("l_elbow_flexion", 0.5, ("legs", "arms")),
    ],
)
def test_heatmap_score_is_highest_at_the_detected_pose(body, cameras, dof, delta, parts) -> None:
    pose = _pose(body)
    dets = _detections(body, pose, cameras)
    cue = _heat_cue(cameras, dets, _heatmaps(dets), parts=parts)
    poses = np.stack([pose, pose])
    poses[1, DOF[dof]] += delta
    s = cue.scores(body, body.points(poses))
    assert 0.7 < s[0] <= 0.8  # the blobs' peak, less what bilinear samples between cells lose
    assert 0.0 <= s[1] < s[0] - 0.01, (dof, s)  # the elbow moves one point of 14


def test_heatmaps_keep_a_second_place_a_point_loses(body, cameras) -> None:
    """The detector's point is on the wrong knee place but its heatmap also has the right one:
    scored by the heatmap both places score alike; scored by the point only the wrong one."""
    pose = _pose(body)
    bent = pose.copy()
    bent[DOF["l_knee_flexion"]] += 0.5
    truth = _detections(body, pose, cameras)
    wrong = _detections(body, bent, cameras)
    extra = [{j: tuple(t[j, :2]) for j in (13, 15, 17)} for t in truth]
    maps = [
        _heatmaps([w], extra=e)[0] for w, e in zip(wrong, extra, strict=True)
    ]  # blobs at both places
    pts = body.points(np.stack([pose, bent]))
    by_heat = _heat_cue(cameras, wrong, maps).scores(body, pts)
    by_point = _cue(cameras, wrong).scores(body, pts)
    assert by_heat[0] == pytest.approx(by_heat[1], rel=0.05)
    assert by_point[0] < 0.95 * by_point[1]


def test_heatmap_side_labels_do_not_matter(body, cameras) -> None:
    pose = _pose(body)
    moved = pose.copy()
    moved[[DOF["l_knee_flexion"], DOF["r_elbow_flexion"]]] += 0.3
    pts = body.points(np.stack([pose, moved]))
    dets = _detections(body, pose, cameras)
    ref = _heat_cue(cameras, dets, _heatmaps(dets), parts=("legs", "arms")).scores(body, pts)
    swapped = _detections(body, pose, cameras, swap=(True, False))
    got = _heat_cue(cameras, swapped, _heatmaps(swapped), parts=("legs", "arms")).scores(body, pts)
    np.testing.assert_allclose(got, ref, rtol=1e-6)


@pytest.mark.parametrize("parts", [("legs",), ("legs", "arms"), ("hips", "legs", "arms")])
def test_factored_equals_unfactored_with_heatmaps(body, cameras, parts) -> None:
    pose = _pose(body)
    lik = _painted_likelihood(body, cameras, pose)
    dets = _detections(body, pose, cameras, swap=(False, True))
    cue = _heat_cue(cameras, dets, _heatmaps(dets, sigma_cells=4.0), typical=0.5, parts=parts)
    lik.keypoints = cue
    rng = np.random.default_rng(5)
    lo, hi = JointLimits.profile("walking").arrays()
    m, na, nb = 3, 4, 5
    base = _jittered_bases(pose, rng, m, 0.1)
    left = np.clip(
        pose[list(LEFT_LEG)] + rng.normal(0, 0.15, (m, na, len(LEFT_LEG))),
        lo[list(LEFT_LEG)],
        hi[list(LEFT_LEG)],
    )
    right = np.clip(
        pose[list(RIGHT_LEG)] + rng.normal(0, 0.15, (m, nb, len(RIGHT_LEG))),
        lo[list(RIGHT_LEG)],
        hi[list(RIGHT_LEG)],
    )
    flat, _ = factored_equals_flat(lik, base, left, right, rtol=1e-10)
    s = cue.scores(body, body.points(flat))
    assert s.std() > 0.01


def test_heatmaps_follow_the_config_and_the_frame_state(body, cameras) -> None:
    pose = _pose(body)
    moved = pose.copy()
    moved[DOF["l_knee_flexion"]] += 0.3
    pts = body.points(np.stack([pose, moved]))
    dets = _detections(body, pose, cameras)
    maps = _heatmaps(dets)
    cue = _heat_cue(cameras, dets, maps)
    by_heat = cue.scores(body, pts)
    state = cue.frame_state()  # the backward pass keeps the heatmaps with the frame
    cue.set_frame(dets)  # no heatmaps (key points given by a caller): scored as points
    legs = _cue(cameras, dets, parts=("legs",))
    np.testing.assert_allclose(cue.scores(body, pts), legs.scores(body, pts))
    cue.restore_frame(state)
    np.testing.assert_allclose(cue.scores(body, pts), by_heat)
    # scored as points where the config says so, heatmaps or not
    point = KeypointCue(cameras, KeypointConfig(score_multi_camera="point"))
    point.set_frame(dets, maps)
    np.testing.assert_allclose(point.scores(body, pts), _cue(cameras, dets).scores(body, pts))
    # the default: points through one camera, heatmaps through more
    cfg = KeypointConfig()
    assert (cfg.score_for(1), cfg.score_for(2), cfg.score_for(3)) == ("point", "heatmap", "heatmap")
    assert KeypointConfig(score="heatmap", score_multi_camera=None).score_for(2) == "heatmap"
    assert KeypointCue(cameras[:1], cfg).score_mode == "point"
    cue.set_frame(dets, [None, None])  # no camera's maps: scored as points, with beta
    assert not cue.scores_heatmaps
    np.testing.assert_allclose(cue.scores(body, pts), legs.scores(body, pts))
    with pytest.raises(ValueError, match="heatmaps for 2 cameras"):
        cue.set_frame(dets, maps[:1])
    with pytest.raises(ValueError, match="KeypointHeatmaps"):
        cue.set_frame(dets, [maps[0].maps, maps[1]])
    with pytest.raises(ValidationError):
        KeypointConfig(score="gaussian")


def test_provisional_typical_of_the_first_search(body, cameras) -> None:
    """``begin_initial`` makes the cue score a search before any estimate gave the typical
    score (rankings as with any typical); ``end_initial`` takes the search's best as the typical
    and returns the multiplier that puts the search's weights on that scale."""
    pose = _pose(body)
    lik = _painted_likelihood(body, cameras, pose)
    rng = np.random.default_rng(4)
    poses = pose[None] + rng.normal(0, 0.05, (20, N_DOF))
    plain = lik.weights(poses)
    assert not _cue(cameras, _detections(body, pose, cameras)).begin_initial()  # opt-in
    cue = _cue(cameras, _detections(body, pose, cameras), initial=True)
    lik.keypoints = cue
    assert cue.begin_initial() and cue.active
    searched = lik.weights(poses)
    scores = cue.scores(body, body.points(poses))
    np.testing.assert_allclose(searched, plain * scores**cue.config.beta, rtol=1e-10)
    best = int(np.argmax(searched))
    mult = cue.end_initial(body, poses[best])
    assert cue.typical == pytest.approx(scores[best])
    np.testing.assert_allclose(searched * mult, lik.weights(poses), rtol=1e-10)
    assert not cue.begin_initial()  # a typical score is known: nothing to do
    # no detections this frame: the search is silhouette-only as before
    none = _cue(cameras, _detections(body, pose, cameras), initial=True)
    none.clear_frame()
    assert not none.begin_initial() and none.typical is None
    # a best that scores nothing (every point behind the camera) leaves the cue inactive
    lone = _cue(cameras[:1], _detections(body, pose, cameras[:1]), initial=True)
    assert lone.begin_initial()
    behind = pose.copy()
    behind[:2] = 2 * np.asarray(cameras[0].center)[:2] - pose[:2]  # mirrored past the camera
    assert float(lone.scores(body, body.points(behind[None]))[0]) == 0.0
    assert lone.end_initial(body, behind) == pytest.approx(1e-6**-lone.config.beta)
    assert lone.typical is None and not lone.active
