"""The built-in 2D pose detector (tracker.detector2d): crops, detections on rendered people,
refusals, and its place in the tracker."""

from __future__ import annotations

import copy
import sys

import cv2
import numpy as np
import pytest
from pydantic import ValidationError

from gaitwatch.conventions import SIDES_EXCHANGED
from gaitwatch.sim.motion import procedural_walk
from gaitwatch.sim.synth import SceneConfig, build_scene, render_background, render_frames
from tracker.config import KeypointConfig, TrackerConfig
from tracker.detector2d import (
    _MIRROR,
    INPUT_SIZE,
    TO_BLAZEPOSE,
    DetectorUnavailableError,
    PoseDetector,
    alignment_crop,
    crop_box,
    crop_transform,
    make_detector,
    refine_from_heatmap,
    silhouette_box,
)
from tracker.segmentation import Blob

LEGS = [11, 12, 13, 14, 15, 16, 17, 18]
HIPS = [9, 10]
ARMS = [3, 4, 5, 6, 7, 8]  # shoulders, elbows, wrists
EXCHANGED = [12, 11, 14, 13, 16, 15, 18, 17]


class _Seg:
    """A stand-in segmentation: one blob with the given box (or an empty frame)."""

    def __init__(self, box, empty: bool = False) -> None:
        self.empty = empty
        self.blobs = [] if empty else [Blob(1, 1, 0.1, tuple(int(v) for v in box), (0.0, 0.0))]


@pytest.fixture(scope="module")
def detector() -> PoseDetector:
    return PoseDetector()


@pytest.fixture(scope="module")
def scene():
    walk = procedural_walk(distance_m=2.4, fps=25)
    return build_scene(
        walk, SceneConfig(views=["side"], image_size=(320, 240), fps=25.0, seed=1, max_frames=10)
    )


@pytest.fixture(scope="module")
def side_walk(scene) -> tuple[list[np.ndarray], list[tuple], np.ndarray]:
    """A rendered walk seen from the side: BGR frames, the person masks' boxes, and the true key
    points projected (T, 19, 2)."""
    cam = scene.cameras[0]
    frames, boxes, truth = [], [], []
    for k, images, masks in render_frames(scene):
        ys, xs = np.nonzero(masks[0])
        boxes.append((xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1))
        frames.append(cv2.cvtColor(images[0], cv2.COLOR_RGB2BGR))
        truth.append(cam.project(scene.truth.positions[k]))
    return frames, boxes, np.asarray(truth)


def test_crop_is_the_square_around_the_box() -> None:
    assert crop_box((100, 50, 40, 200), 1.3) == pytest.approx((120.0, 150.0, 260.0))
    assert crop_box((0, 0, 300, 100), 1.0) == pytest.approx((150.0, 50.0, 300.0))
    m = crop_transform(120.0, 150.0, 260.0)
    corners = np.array([[120 - 130, 150 - 130, 1], [120 + 130, 150 + 130, 1], [120, 150, 1]])
    expected = [[0, 0], [INPUT_SIZE, INPUT_SIZE], [128, 128]]
    np.testing.assert_allclose(corners @ m.T, expected, atol=1e-9)


def test_crops_turn_with_the_body() -> None:
    # a turned crop: the frame's direction (sin a, -cos a) is the input's up
    m = crop_transform(100.0, 100.0, 64.0, np.pi / 2)
    up = m[:, :2] @ np.array([1.0, 0.0])  # a = 90 degrees: the frame's right
    np.testing.assert_allclose(up / np.linalg.norm(up), [0.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(m @ [100, 100, 1], [128, 128])
    uv = np.zeros((39, 2))
    uv[33], uv[34] = (100, 100), (100, 60)  # standing: the body up the frame
    assert alignment_crop(uv) == pytest.approx((100, 100, 100, 0))
    uv[34] = (140, 100)  # lying, head to the right
    assert alignment_crop(uv) == pytest.approx((100, 100, 100, np.pi / 2))


def test_silhouette_box_is_the_union_of_the_blobs() -> None:
    blobs = [
        Blob(label=1, area=10, area_fraction=0.1, bbox=(10, 20, 5, 30), centroid=(12, 30)),
        Blob(label=2, area=10, area_fraction=0.1, bbox=(12, 5, 20, 10), centroid=(20, 10)),
    ]
    assert silhouette_box(blobs) == (10, 5, 22, 45)
    assert silhouette_box([]) is None


def test_detects_the_legs_of_a_rendered_walker(detector, side_walk) -> None:
    """Near the true key points (under the better assignment of the sides: a detector may
    exchange them), all 17 mapped points present, neck and sacrum not."""
    frames, boxes, truth = side_walk
    errs = []
    for frame, box, uv in zip(frames, boxes, truth, strict=True):
        d = detector.detect(frame, box)
        assert d is not None and d.shape == (19, 3)
        mapped = sorted(TO_BLAZEPOSE)
        assert np.isfinite(d[mapped]).all() and np.isnan(d[[1, 2]]).all()
        assert ((d[mapped, 2] >= 0) & (d[mapped, 2] <= 1)).all()
        height = uv[:, 1].max() - uv[:, 1].min()
        same = np.linalg.norm(d[LEGS, :2] - uv[LEGS], axis=1).mean()
        other = np.linalg.norm(d[EXCHANGED, :2] - uv[LEGS], axis=1).mean()
        errs.append(min(same, other) / height)
    # measured 2.9 % of the person's height (median), 12.0 % at most (without the heatmap
    # refinement 4.2 %, 12.0 %)
    assert np.median(errs) < 0.06 and max(errs) < 0.15


def test_heatmap_refinement_moves_landmarks_to_the_local_centre() -> None:
    """As MediaPipe's RefineLandmarksFromHeatmapCalculator: the confidence-weighted mean cell of
    the 7 x 7 window around a landmark (a cell's column c at c * 4 input pixels on a 64-cell
    map), when the window's highest confidence reaches 0.5; else, outside the map or NaN, the
    landmark stays."""
    hm = np.full((64, 64, 39), -30.0)  # sigmoid ~ 1e-13: no weight
    pts = np.full((39, 2), 100.0)
    pts[0] = (118.0, 82.0)  # cell (row 20, col 29)
    hm[20, 30:32, 0] = 4.0  # two equal cells: centre col 30.5, row 20
    pts[1] = (60.0, 60.0)
    hm[15, 16, 1] = -1.0  # the window's best is 0.27: not confident, kept
    pts[2] = (-10.0, 50.0)  # outside the map (column -2.5)
    hm[:, :, 2] = 4.0
    pts[3] = np.nan
    pts[4] = (1.0, 250.0)  # cell (62, 0): the window cut at the map's corner
    hm[63, 0, 4] = 6.0
    hm[60, 3, 4] = 6.0
    hm[60, 4, 4] = 6.0  # outside the window (col 4 > 0 + 3)
    out = refine_from_heatmap(pts, hm)
    np.testing.assert_allclose(out[0], (30.5 * 4, 20 * 4), atol=1e-6)
    np.testing.assert_allclose(out[4], (1.5 * 4, 61.5 * 4), atol=1e-6)
    np.testing.assert_array_equal(out[[1, 2, 5]], pts[[1, 2, 5]])
    assert np.isnan(out[3]).all()
    np.testing.assert_array_equal(pts[0], (118.0, 82.0))  # the input is not changed
    with pytest.raises(ValueError, match="38 landmarks"):
        refine_from_heatmap(pts[:38], hm)


def test_the_heatmap_refinement_brings_the_points_nearer(detector, side_walk) -> None:
    """On the rendered walk the refined landmarks (the default) lie nearer the true key points
    than the regression's own (``refine = False``)."""
    frames, boxes, truth = side_walk
    plain = PoseDetector(refine=False)
    errs = {"refined": [], "plain": []}
    for frame, box, uv in zip(frames, boxes, truth, strict=True):
        height = uv[:, 1].max() - uv[:, 1].min()
        for name, det in (("refined", detector), ("plain", plain)):
            d = det.detect(frame, box)
            same = np.linalg.norm(d[LEGS, :2] - uv[LEGS], axis=1).mean()
            other = np.linalg.norm(d[EXCHANGED, :2] - uv[LEGS], axis=1).mean()
            errs[name].append(min(same, other) / height)
    # measured: median 4.2 -> 2.9 % of the person's height, mean 5.1 -> 4.0 %, 9 of 10 frames
    # nearer, one the same
    assert np.median(errs["refined"]) < np.median(errs["plain"])
    assert np.mean(errs["refined"]) < np.mean(errs["plain"])
    assert make_detector(KeypointConfig(heatmap_refine=False)).refine is False
    assert make_detector(KeypointConfig()).refine is True


def test_a_crop_without_anybody_is_no_detection(detector, side_walk) -> None:
    frames, boxes, _ = side_walk
    assert detector.detect(np.zeros_like(frames[0]), boxes[0]) is None
    assert detector.detect(frames[0], None) is None
    assert detector.detect(frames[0], (10, 10, 0, 50)) is None


def test_points_follow_the_frame_size(detector, side_walk) -> None:
    """Frames twice the camera's size: the points come back in the camera's pixels."""
    frames, boxes, _ = side_walk

    mapped = sorted(TO_BLAZEPOSE)
    gaps = []
    for frame, box in list(zip(frames, boxes, strict=True))[::2]:
        big = cv2.resize(frame, None, fx=2, fy=2, interpolation=cv2.INTER_LINEAR)
        small = detector.detect_frames([frame], [_Seg(box)])[0]
        scaled = detector.detect_frames([big], [_Seg([2 * v for v in box])], sizes=[(320, 240)])
        gaps.append(np.linalg.norm(scaled[0][mapped, :2] - small[mapped, :2], axis=1))
    # The same crops resampled from larger images: the points agree, in the 320x240 frame's
    # pixels (measured: median 1.5 px; a frame where the legs cross moves an ankle by 19 px).
    assert np.median(np.concatenate(gaps)) < 2.0
    assert detector.detect_frames([frames[3]], [_Seg(None, empty=True)]) == [None]
    with pytest.raises(ValueError, match="1 frames for 2"):
        detector.detect_frames([frames[3]], [_Seg(boxes[3]), _Seg(boxes[3])])


def test_heatmaps_come_with_the_points_in_the_cameras_pixels(side_walk) -> None:
    """With ``heatmaps`` each detection keeps its 19 maps (probabilities; none for the neck and
    the sacrum) and the map of the camera's pixels to their cells: the detected leg points lie
    on their maps' high ground, also when the frame is larger than the camera's image."""
    frames, boxes, _ = side_walk
    det = PoseDetector(heatmaps=True)
    assert PoseDetector().last_heatmaps is None
    for scale in (1, 2):
        det.reset()
        near, values = [], []
        for frame, box in list(zip(frames, boxes, strict=True))[::2]:
            big = cv2.resize(frame, None, fx=scale, fy=scale, interpolation=cv2.INTER_LINEAR)
            kp = det.detect_frames([big], [_Seg([scale * v for v in box])], sizes=[(320, 240)])[0]
            (hm,) = det.last_heatmaps
            assert hm.maps.shape == (19, 64, 64) and hm.maps.dtype == np.float32
            assert hm.maps.min() >= 0 and hm.maps.max() <= 1 and not hm.maps[[1, 2]].any()
            cells = kp[LEGS, :2] @ hm.to_map[:, :2].T + hm.to_map[:, 2]
            for j, (c, r) in zip(LEGS, cells, strict=True):
                values.append(hm.maps[j, int(round(r)), int(round(c))])
                peak = np.unravel_index(np.argmax(hm.maps[j]), hm.maps[j].shape)
                near.append(np.hypot(peak[0] - r, peak[1] - c))
        # measured: the maps' value at the detected points median 0.61-0.62, their peaks a
        # median 0.6-0.7 cells from the points (a crossing leg's peak up to 18 cells away)
        assert np.median(values) > 0.4 and np.median(near) < 2.0, (scale, values, near)
    assert det.detect_frames([frames[0]], [_Seg(None, empty=True)]) == [None]
    assert det.last_heatmaps == [None]
    # on with two cameras by default (the key-point cue's score_multi_camera)
    assert not make_detector(KeypointConfig(), 1).heatmaps
    assert make_detector(KeypointConfig(), 2).heatmaps
    assert not make_detector(KeypointConfig(score_multi_camera="point"), 2).heatmaps


def test_bad_frames_and_settings_are_refused(detector, side_walk, tmp_path) -> None:
    frames, boxes, _ = side_walk
    with pytest.raises(ValueError, match="uint8 BGR"):
        detector.detect(frames[0].astype(np.float32), boxes[0])
    with pytest.raises(ValueError, match="uint8 BGR"):
        detector.detect(frames[0][:, :, 0], boxes[0])
    with pytest.raises(ValueError):
        PoseDetector(crop_scale=0)
    with pytest.raises(ValueError):
        PoseDetector(min_presence=2)
    with pytest.raises(DetectorUnavailableError, match="not found"):
        PoseDetector(model_path=tmp_path / "missing.tflite").load()
    junk = tmp_path / "junk.tflite"
    junk.write_bytes(b"not a model" * 100)
    with pytest.raises(DetectorUnavailableError, match="junk.tflite: not a model"):
        PoseDetector(model_path=junk).load()
    assert make_detector(KeypointConfig(detector="none")) is None
    assert make_detector(KeypointConfig(enabled=False)) is None


MIRRORED = list(SIDES_EXCHANGED)


def test_the_mirrored_detection_averages_the_frame_and_its_mirror(detector, side_walk) -> None:
    """With ``mirror`` the key points are the mean of the frame's and those found on the
    mirrored frame (the crop mirrored), mapped back with their sides matched; near the true key
    points on the rendered walk."""
    frames, boxes, truth = side_walk
    mirrored = PoseDetector(mirror=True)
    mapped = sorted(TO_BLAZEPOSE)
    errs = {"plain": [], "mirror": []}
    for frame, box, uv in zip(frames, boxes, truth, strict=True):
        w = frame.shape[1]
        cu, cv, side = crop_box(box, 1.3)
        plain = detector.detect(frame, box)
        back = detector.detect(
            np.ascontiguousarray(frame[:, ::-1]), box, (w - 1 - cu, cv, side, 0.0)
        )
        assert plain is not None and back is not None
        back[:, 0] = w - 1 - back[:, 0]
        back = back[MIRRORED]  # the mirror's left is the person's right
        # each part's sides matched on its own: the legs with the hips, the arms with the
        # shoulders
        for part, decide in ((HIPS + LEGS, LEGS), (ARMS, ARMS)):
            swapped = [MIRRORED[i] for i in decide]
            if (
                np.linalg.norm(back[swapped, :2] - plain[decide, :2], axis=1).mean()
                < np.linalg.norm(back[decide, :2] - plain[decide, :2], axis=1).mean()
            ):
                back[part] = back[[MIRRORED[i] for i in part]]
        got = mirrored.detect(frame, box)
        np.testing.assert_allclose(got[mapped, :2], 0.5 * (plain[mapped, :2] + back[mapped, :2]))
        np.testing.assert_allclose(got[mapped, 2], np.minimum(plain[mapped, 2], back[mapped, 2]))
        assert np.isnan(got[[1, 2]]).all()
        height = uv[:, 1].max() - uv[:, 1].min()
        for name, d in (("plain", plain), ("mirror", got)):
            same = np.linalg.norm(d[LEGS, :2] - uv[LEGS], axis=1).mean()
            other = np.linalg.norm(d[EXCHANGED, :2] - uv[LEGS], axis=1).mean()
            errs[name].append(min(same, other) / height)
    # measured on these 10 frames (heatmap refinement on): median 2.9 -> 3.8 % of the height,
    # mean 4.0 -> 4.1 %, at most 12.0 -> 8.6 % (without the refinement 4.2 -> 4.4 %, 5.1 -> 4.9
    # %, 12.0 -> 9.8 %; on the benchmark's footage median 3.6 -> 3.4 %, p90 8.4 -> 7.4 %)
    assert np.median(errs["mirror"]) < 0.06 and max(errs["mirror"]) < 0.15


@pytest.mark.parametrize("exchanged", ["legs", "arms", "both", "none"])
def test_the_mirrored_detection_matches_the_legs_and_the_arms_each_on_its_own(
    monkeypatch, exchanged
) -> None:
    """The model may label a person's legs and arms differently: the mirror's sides are
    matched part by part (the legs with the hips, the arms with the shoulders), so a part's
    points are averaged with the same side of the person whichever way the other part went."""
    rng = np.random.default_rng(3)
    w = 640
    uv = rng.uniform(50.0, 450.0, (39, 2))
    vis = np.full(39, 0.9)
    plain = PoseDetector._keypoints(uv, vis)
    # what the model finds on the mirrored frame, back in the frame: 2 px off, with the legs'
    # (hips, knees, ankles, heels, foot index) and/or the arms' landmark sides exchanged
    found = uv + 2.0
    pairs = {"legs": range(23, 33, 2), "arms": range(11, 17, 2)}
    for part in ("legs", "arms"):
        if exchanged in (part, "both"):
            for a in pairs[part]:
                found[[a, a + 1]] = found[[a + 1, a]]
    raw = found.copy()
    raw[:, 0] = w - 1 - raw[:, 0]  # as the model sees the mirrored frame
    raw = raw[_MIRROR]
    detector = PoseDetector(mirror=True)
    monkeypatch.setattr(detector, "landmarks", lambda image, crop: (raw, vis, 1.0))
    got = detector._with_mirrored(
        plain, np.zeros((480, w, 3), np.uint8), (300.0, 240.0, 400.0, 0.0)
    )
    mapped = sorted(TO_BLAZEPOSE)
    np.testing.assert_allclose(got[mapped, :2], plain[mapped, :2] + 1.0)
    np.testing.assert_allclose(got[mapped, 2], 0.9)


def test_the_mirrored_detection_is_opt_in_and_needs_two_cameras() -> None:
    assert not KeypointConfig().mirror and KeypointConfig().mirror_min_cameras == 2
    assert not make_detector(KeypointConfig(), 2).mirror
    cfg = KeypointConfig(mirror=True)
    assert not make_detector(cfg, 1).mirror
    assert make_detector(cfg, 2).mirror
    assert make_detector(KeypointConfig(mirror=True, mirror_min_cameras=1), 1).mirror
    with pytest.raises(ValidationError):
        KeypointConfig(mirror_min_cameras=0)
    from tracker.pipeline import Tracker
    from tracker.synthetic import side_cameras

    for n, on in ((1, False), (2, True)):
        cams = side_cameras(n, image_size=(160, 120), centre=(1.0, 0.0), fps=20.0)
        cfg = TrackerConfig.model_validate({"keypoints": {"mirror": True}})
        tr = Tracker(cams, cfg, rng=np.random.default_rng(0), height_m=1.70)
        assert tr.detector is not None and tr.detector.mirror is on


def test_without_the_runtime_the_tracker_warns_and_runs(monkeypatch, caplog) -> None:
    from tracker.pipeline import Tracker
    from tracker.synthetic import side_cameras

    monkeypatch.setitem(sys.modules, "ai_edge_litert", None)  # import fails
    monkeypatch.setitem(sys.modules, "ai_edge_litert.interpreter", None)
    with pytest.raises(DetectorUnavailableError, match="ai-edge-litert"):
        PoseDetector().load()
    cams = side_cameras(1, image_size=(160, 120), centre=(1.0, 0.0), fps=20.0)
    with caplog.at_level("WARNING", logger="tracker.pipeline"):
        tr = Tracker(cams, TrackerConfig(), rng=np.random.default_rng(0), height_m=1.70)
    assert tr.keypoint_cue is not None and tr.detector is None
    assert "ai-edge-litert" in caplog.text


def test_the_tracker_runs_it_on_frames_given_no_key_points(side_walk) -> None:
    """Defaults: the detector runs on each frame and the cue scores it; key points given to
    process() are used instead; the backward copy shares the detector."""
    from tracker.pipeline import Tracker
    from tracker.synthetic import side_cameras

    frames, boxes, _ = side_walk
    cams = side_cameras(1, image_size=(320, 240), centre=(1.0, 0.0), fps=25.0)
    tr = Tracker(cams, TrackerConfig(), rng=np.random.default_rng(0), height_m=1.70)
    assert tr.detector is not None and tr.config.keypoints.detector == "blazepose"

    seg = _Seg(boxes[0])

    kp = tr.detect_keypoints([frames[0]], [seg])
    assert kp is not None and kp[0] is not None and np.isfinite(kp[0][LEGS]).all()
    assert copy.deepcopy(tr.detector) is tr.detector
    off = Tracker(
        cams,
        TrackerConfig.model_validate({"keypoints": {"detector": "none"}}),
        rng=np.random.default_rng(0),
        height_m=1.70,
    )
    assert off.keypoint_cue is not None and off.detector is None
    assert off.detect_keypoints([frames[0]], [seg]) is None


def test_process_scores_each_frame_against_the_detections(scene, side_walk) -> None:
    """Through ``Tracker.process`` on the rendered walk with the defaults: every frame's
    detections reach the cue, which becomes active; the track differs from the cue-less one."""
    from tracker.pipeline import Tracker

    frames, _, _ = side_walk
    cams = scene.cameras
    bgs = [cv2.cvtColor(render_background(scene, 0), cv2.COLOR_RGB2BGR)]

    def run(cfg):
        tr = Tracker(cams, cfg, rng=np.random.default_rng(0), height_m=1.70, backgrounds=bgs)
        seen, out = [], []
        for k, frame in enumerate(frames[:5]):
            out.append(tr.process(k, k / 25.0, [frame]))
            seen.append(tr.keypoint_cue is not None and tr.keypoint_cue.has_frame)
        return tr, seen, out

    tr, seen, with_cue = run(TrackerConfig())
    assert all(seen) and tr.keypoint_cue.active
    _, seen_off, without = run(TrackerConfig.model_validate({"keypoints": {"enabled": False}}))
    assert not any(seen_off)
    assert all(r.has_pose for r in with_cue)
    assert any(not np.array_equal(a.pose, b.pose) for a, b in zip(with_cue, without, strict=True))


def test_a_person_lying_down_is_found_in_a_turned_crop(detector, side_walk) -> None:
    """The frame turned a quarter (as a person lying on the floor) with the crop turned alike
    gives the same points, turned; the crop followed to the next frame is the alignment
    points' (the silhouette box's when the person leaves it)."""
    frames, boxes, _ = side_walk
    frame, box = frames[6], boxes[6]
    _, crop, _, _ = detector._detect(frame, box, None)
    upright = detector.detect(frame, box, crop)
    h = frame.shape[0]
    turned = cv2.rotate(frame, cv2.ROTATE_90_CLOCKWISE)  # (x, y) -> (h - 1 - y, x)
    cu, cv, side, angle = crop
    found = detector.detect(turned, (0, 0, 1, 1), (h - 1 - cv, cu, side, angle + np.pi / 2))
    back = np.column_stack([found[:, 1], h - 1 - found[:, 0]])
    mapped = sorted(TO_BLAZEPOSE)
    assert np.median(np.linalg.norm(back[mapped] - upright[mapped, :2], axis=1)) < 1.0

    detector.reset()
    detector.detect_frames([frame], [_Seg(box)])
    assert detector._follow[0] == pytest.approx(crop)
    far = (box[0] + 200, box[1], box[2], box[3])  # the silhouette left the crop: the new
    assert detector.detect_frames([frame], [_Seg(far)]) == [None]  # box's crop holds nobody
    assert not detector._follow
    assert (
        detector.detect_frames([frame], [_Seg(None, empty=True)]) == [None] and not detector._follow
    )


def test_legs_cut_by_furniture_or_the_frame_are_left_out() -> None:
    """The legs' detections are dropped where an occluder lies under the silhouette's upper
    half (or just below it) or the silhouette reaches the image's lower edge; kept else."""
    from tracker.pipeline import LEG_POINTS, Tracker, _legs_cut
    from tracker.synthetic import side_cameras

    cam = side_cameras(1, image_size=(320, 240), centre=(1.0, 0.0), fps=25.0)[0]
    box = (100, 40, 40, 120)  # x 100-140, y 40-160
    occ = np.zeros((120, 160), dtype=bool)  # the likelihood's resolution: half the camera's
    assert not _legs_cut(box, None, cam) and not _legs_cut(box, occ, cam)
    assert _legs_cut((100, 100, 40, 139), None, cam)  # down to the last row but one
    table = occ.copy()
    table[85:95, 40:90] = True  # rows 170-190 of the camera: just below the box, under it
    assert _legs_cut(box, table, cam)
    aside = occ.copy()
    aside[60:100, 100:120] = True  # columns 200-240: beside the person
    assert not _legs_cut(box, aside, cam)
    above = occ.copy()
    above[0:30, 50:70] = True  # over the head and the chest
    assert not _legs_cut(box, above, cam)

    tr = Tracker([cam], TrackerConfig(), rng=np.random.default_rng(0), height_m=1.70)
    tr.set_occluders([np.kron(table, np.ones((2, 2), dtype=bool))])

    seg = _Seg(box)

    det = np.column_stack([np.full((19, 2), 120.0), np.ones(19)])
    seen = tr._legs_seen([det], [seg])[0]
    assert np.isnan(seen[list(LEG_POINTS)]).all() and np.isfinite(seen[:11]).all()
    assert np.isfinite(det).all()  # the caller's array is not changed
    tr.set_occluders(None)
    assert np.array_equal(tr._legs_seen([det], [seg])[0], det)
    assert tr._legs_seen(None, [seg]) is None


def test_several_tracks_share_one_detection_per_frame(scene, side_walk, monkeypatch) -> None:
    """``--tracks 2``: the built-in detector runs once per frame, for every track."""
    from tracker.ensemble import make_tracker

    frames, _, _ = side_walk
    bgs = [cv2.cvtColor(render_background(scene, 0), cv2.COLOR_RGB2BGR)]
    cfg = TrackerConfig.model_validate({"ensemble": {"tracks": 2}})
    tr = make_tracker(scene.cameras, cfg, rng=np.random.default_rng(0), backgrounds=bgs)
    calls = []
    first = tr.tracks[0].detector
    original = first.detect_frames

    def counting(*a, **k):
        calls.append(1)
        return original(*a, **k)

    monkeypatch.setattr(first, "detect_frames", counting)
    for t in tr.tracks[1:]:
        monkeypatch.setattr(t.detector, "detect_frames", lambda *a, **k: pytest.fail("again"))
    for k, frame in enumerate(frames[:2]):
        tr.process(k, k / 25.0, [frame])
    assert len(calls) == 2
    assert all(t.keypoint_cue.has_frame for t in tr.tracks)


def test_feet_below_the_silhouette() -> None:
    """The estimate's feet count as unseen when, at the median of the six foot points, they
    project more than a tenth of the body's projected height below the silhouette's lowest
    pixel in their columns (legs hidden by furniture not yet learned), or outside it."""
    from gaitwatch.conventions import KEYPOINTS
    from tracker.pipeline import _feet_below_silhouette
    from tracker.smoothing import FEET
    from tracker.synthetic import side_cameras

    cam = side_cameras(1, image_size=(160, 120), centre=(1.0, 0.0))[0]
    joints = np.zeros((19, 3))
    joints[:, 0] = 1.0
    joints[:, 2] = np.linspace(1.65, 0.6, 19)  # a column of points from the head down
    joints[FEET, 2] = [0.08, 0.02, 0.02, 0.08, 0.02, 0.02]  # ankle, heel, toe per side
    joints[FEET, 0] += [0.0, -0.05, 0.15, 0.0, -0.05, 0.15]
    joints[KEYPOINTS.index("head"), 2] = 1.65
    uv = cam.project(joints)
    u0, u1 = int(np.floor(uv[:, 0].min())) - 3, int(np.ceil(uv[:, 0].max())) + 3
    v0, v1 = int(np.floor(uv[:, 1].min())) - 3, int(np.ceil(uv[:, 1].max())) + 2
    mask = np.zeros((120, 160), dtype=bool)
    mask[v0 : v1 + 1, u0 : u1 + 1] = True  # the whole body: the feet at the bottom
    assert not _feet_below_silhouette(joints, cam, mask)
    height = uv[:, 1].max() - uv[0, 1]
    cut = mask.copy()
    cut[int(v1 - 0.25 * height) :] = False  # the lower legs hidden: cut a quarter higher
    assert _feet_below_silhouette(joints, cam, cut)
    slight = mask.copy()
    slight[int(v1 - 0.05 * height) :] = False  # a few pixels of sole lost: still seen
    assert not _feet_below_silhouette(joints, cam, slight)
    aside = np.zeros_like(mask)
    aside[v0 : v1 + 1, u1 + 10 : u1 + 30] = True  # a silhouette beside the feet's columns
    assert _feet_below_silhouette(joints, cam, aside)
    assert _feet_below_silhouette(joints, cam, np.zeros_like(mask))


def _recall_extra(found: tuple[int, int, np.ndarray], truth: np.ndarray) -> tuple[float, float]:
    """A person mask ``(x, y, mask)`` against the true mask of the frame: the share of the
    person's pixels it covers, and its pixels off the person over the person's area."""
    x, y, m = found
    full = np.zeros(truth.shape, bool)
    full[y : y + m.shape[0], x : x + m.shape[1]] = m
    return (full & truth).sum() / truth.sum(), (full & ~truth).sum() / truth.sum()


def test_person_mask_covers_the_rendered_walker(detector, scene, side_walk) -> None:
    """The model's segmentation output, warped back into the frame and grown a little: it
    covers the person's pixels, and not much more."""
    frames, boxes, _ = side_walk
    recall, extra = [], []
    for (_, _, masks), frame, box in zip(render_frames(scene), frames, boxes, strict=True):
        found = detector.person_mask(frame, box)
        assert found is not None
        x, y, m = found
        assert m.dtype == bool and min(x, y) >= 0
        assert y + m.shape[0] <= frame.shape[0] and x + m.shape[1] <= frame.shape[1]
        r, e = _recall_extra((x, y, m), masks[0])
        recall.append(r)
        extra.append(e)
    # measured: recall 1.00, extra 0.79-1.09 of the person's area (mostly the growth)
    assert min(recall) > 0.95 and max(extra) < 1.5, (recall, extra)
    assert detector.person_mask(np.zeros_like(frames[0]), boxes[0]) is None
    assert detector.person_mask(frames[0], (10, 10, 0, 40)) is None


def test_person_mask_needs_the_segmentation_output(side_walk) -> None:
    frames, boxes, _ = side_walk
    det = PoseDetector()
    det.load()
    det._seg_index = None  # a landmark model without it
    with pytest.raises(DetectorUnavailableError, match="segmentation"):
        det.person_mask(frames[0], boxes[0])


def test_detections_keep_the_person_segmentation(scene, side_walk, monkeypatch) -> None:
    """With ``people``, each camera's detection keeps its first inference's person output
    (no inference added): warped into the frame, it covers the rendered person."""
    frames, boxes, _ = side_walk
    det = PoseDetector(people=True)
    calls = []
    original = det.landmarks

    def counting(*a, **k):
        calls.append(1)
        return original(*a, **k)

    monkeypatch.setattr(det, "landmarks", counting)
    recall, extra = [], []
    for (_, _, masks), frame, box in zip(render_frames(scene), frames, boxes, strict=True):
        n = len(calls)
        det.detect_frames([frame, frame], [_Seg(box), _Seg(box, empty=True)])
        assert len(calls) - n == 1  # one camera sees someone: one inference
        assert det.last_people is not None and det.last_people[1] is None
        crop, logits = det.last_people[0]
        assert logits.shape == (INPUT_SIZE, INPUT_SIZE)
        x, y, m = PoseDetector.person_pixels(crop, logits, frame.shape)
        r, e = _recall_extra((x, y, m), masks[0])
        recall.append(r)
        extra.append(e)
    # measured at probability 0.5, not grown: recall 0.96-1.00, extra 0.01-0.03
    assert min(recall) > 0.9 and max(extra) < 0.1, (recall, extra)
    plain = PoseDetector()
    plain.detect_frames(frames[:1], [_Seg(boxes[0])])
    assert plain.last_people is None
    off = np.zeros((INPUT_SIZE, INPUT_SIZE), np.float32)
    assert PoseDetector.person_pixels((-500.0, -500.0, 100.0, 0.0), off, frames[0].shape) is None


def test_the_person_segmentation_is_kept_with_two_cameras() -> None:
    assert not make_detector(KeypointConfig(shadow_given_back=False), 3).people
    cfg = KeypointConfig()
    assert cfg.shadow_given_back and cfg.shadow_given_back_min_cameras == 2
    assert not make_detector(cfg, 1).people
    assert make_detector(cfg, 2).people
    assert make_detector(cfg.model_copy(update={"shadow_given_back_min_cameras": 1}), 1).people
    with pytest.raises(ValidationError):
        KeypointConfig(person_threshold=1.0)
    with pytest.raises(ValidationError):
        KeypointConfig(shadow_given_back_min_cameras=0)


def test_a_model_without_the_person_output_warns(monkeypatch, caplog) -> None:
    original = PoseDetector.load

    def load(self):
        original(self)
        self._seg_index = None

    monkeypatch.setattr(PoseDetector, "load", load)
    with caplog.at_level("WARNING", logger="tracker.detector2d"):
        det = make_detector(KeypointConfig(shadow_given_back=True), 2)
    assert det.people and not det.has_people
    assert "no person segmentation output" in caplog.text
