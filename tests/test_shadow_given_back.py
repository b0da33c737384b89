"""The shadow pixels given back under the built-in detector's person (config.keypoints.
shadow_given_back, on by default with two cameras): a walker in grey clothes, whom the shadow
test partly takes for a shadow, seen by two cameras."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from gaitwatch.sim.motion import procedural_walk
from gaitwatch.sim.synth import SceneConfig, build_scene, render_background, render_frames
from tracker.config import TrackerConfig
from tracker.ensemble import make_tracker
from tracker.pipeline import Tracker
from tracker.segmentation import downscale_mask


@pytest.fixture(scope="module")
def grey_walk():
    """Two cameras (side, frontal) on a walker in a grey shirt and grey trousers: BGR frames,
    true person masks, empty-scene images, the scene."""
    walk = procedural_walk(distance_m=2.4, fps=25)
    cfg = SceneConfig.model_validate(
        {
            "views": ["side", "frontal"],
            "image_size": (320, 240),
            "fps": 25.0,
            "seed": 3,
            "max_frames": 5,
            "clothing": {"shirt": (120, 120, 125), "trousers": (90, 90, 95), "pattern": "plain"},
            "lighting": {"mode": "steady"},
        }
    )
    scene = build_scene(walk, cfg)
    bgs = [cv2.cvtColor(render_background(scene, i), cv2.COLOR_RGB2BGR) for i in range(2)]
    frames, masks = [], []
    for _, images, truth in render_frames(scene):
        frames.append([cv2.cvtColor(im, cv2.COLOR_RGB2BGR) for im in images])
        masks.append(truth)
    return frames, masks, bgs, scene


def _ious(tracker, frames, masks, cameras=(0, 1)) -> list[float]:
    """Per frame and camera the IoU of the silhouette the tracker scored against the truth."""
    out = []
    for k, (views, truth) in enumerate(zip(frames, masks, strict=True)):
        tracker.process(k, k / 25.0, [views[c] for c in cameras])
        track = tracker.tracks[0] if hasattr(tracker, "tracks") else tracker
        for c, m in enumerate(track._last_obs.masks):
            t = downscale_mask(truth[cameras[c]], (m.shape[1], m.shape[0]))
            out.append(float((m & t).sum() / (m | t).sum()))
    return out


def _config(**keypoints) -> TrackerConfig:
    """The defaults (the shadow pixels given back with two cameras) with ``keypoints`` over
    them."""
    return TrackerConfig.model_validate({"keypoints": keypoints})


def _tracker(scene, bgs, n_cameras: int = 2, **keypoints) -> Tracker:
    """A tracker of the scene's first ``n_cameras`` cameras under :func:`_config`, seed 0."""
    return Tracker(
        scene.cameras[:n_cameras],
        _config(**keypoints),
        rng=np.random.default_rng(0),
        backgrounds=bgs[:n_cameras],
    )


def test_two_cameras_get_the_grey_clothes_back(grey_walk) -> None:
    frames, masks, bgs, scene = grey_walk

    def run(cfg):
        tr = Tracker(
            scene.cameras, cfg, rng=np.random.default_rng(0), height_m=1.70, backgrounds=bgs
        )
        return _ious(tr, frames, masks)

    on, off = run(_config()), run(_config(shadow_given_back=False))
    # measured: IoU 0.86-0.93 without, 0.91-0.96 with (five frames, two cameras; 0.93-0.96
    # at person_threshold 0.5)
    assert np.mean(on) > np.mean(off) + 0.03 and min(on) > 0.9, (off, on)
    assert all(a > b for a, b in zip(on, off, strict=True))


def test_on_by_default_but_not_through_one_camera(grey_walk) -> None:
    frames, masks, bgs, scene = grey_walk

    def run(cfg):
        tr = Tracker(
            scene.cameras[:1], cfg, rng=np.random.default_rng(0), height_m=1.70, backgrounds=bgs[:1]
        )
        return _ious(tr, frames, masks, cameras=(0,))

    assert TrackerConfig().keypoints.shadow_given_back
    default = run(TrackerConfig())
    assert default == run(_config(shadow_given_back=False))
    assert all(
        a > b for a, b in zip(run(_config(shadow_given_back_min_cameras=1)), default, strict=True)
    )


def test_every_track_of_an_ensemble_scores_the_silhouette_given_back(grey_walk) -> None:
    frames, masks, bgs, scene = grey_walk
    cfg = TrackerConfig.model_validate({"ensemble": {"tracks": 2}})
    tr = make_tracker(scene.cameras, cfg, rng=np.random.default_rng(0), backgrounds=bgs)
    single = _tracker(scene, bgs)
    for k, views in enumerate(frames[:3]):
        tr.process(k, k / 25.0, views)
        single.process(k, k / 25.0, views)
        first, second = (t._last_obs.masks for t in tr.tracks)
        for a, b, s in zip(first, second, single._last_obs.masks, strict=True):
            assert np.array_equal(a, b)
            assert np.array_equal(a, s)  # the same silhouettes as one tracker's


def test_key_points_given_leave_the_silhouette(grey_walk) -> None:
    """Without the built-in detector's run (key points given to process) nothing is given
    back."""
    frames, masks, bgs, scene = grey_walk
    tr = _tracker(scene, bgs)
    off = _tracker(scene, bgs, shadow_given_back=False)
    none = [None, None]
    for k, views in enumerate(frames[:2]):
        tr.process(k, k / 25.0, views, keypoints=none)
        off.process(k, k / 25.0, views, keypoints=none)
        for a, b in zip(tr._last_obs.masks, off._last_obs.masks, strict=True):
            assert np.array_equal(a, b)


def test_only_a_tracker_that_gives_shadows_back_keeps_them(grey_walk) -> None:
    _, _, bgs, scene = grey_walk
    on, off = _tracker(scene, bgs), _tracker(scene, bgs, shadow_given_back=False)
    one = _tracker(scene, bgs, n_cameras=1)
    assert all(sg.keep_shadow for sg in on.segmenters)
    assert not any(sg.keep_shadow for sg in off.segmenters + one.segmenters)


# -- the detector run ahead (Tracker.detect_ahead, what `gaitwatch track` does in a thread) --
def _same_results(a, b) -> None:
    assert a.status == b.status and a.notes == b.notes
    assert np.array_equal(a.pose, b.pose) and a.weight == b.weight
    assert np.array_equal(a.joints, b.joints)


def test_a_detection_made_ahead_tracks_as_the_tracker_s_own(grey_walk) -> None:
    """Two cameras (the shadow pixels given back under the detected person): each step
    detected ahead, then tracked with that detection, gives the results of plain process()
    (the same detections in the same order), for one tracker and for an ensemble."""
    frames, _, bgs, scene = grey_walk
    for cfg in (_config(), TrackerConfig.model_validate({"ensemble": {"tracks": 2}})):
        plain, ahead = (
            make_tracker(scene.cameras, cfg, rng=np.random.default_rng(0), backgrounds=bgs)
            for _ in range(2)
        )
        for k, views in enumerate(frames[:4]):
            want = plain.process(k, k / 25.0, views)
            segs = ahead.segment(views)
            det = ahead.detect_ahead(views, segs)
            assert det is not None and det.ran and det.segs == tuple(segs)
            assert det.people is not None and all(p is not None for p in det.people)
            got = ahead.process_segmentations(k, k / 25.0, segs, views, detection=det)
            _same_results(got, want)


def test_nothing_to_detect_and_several_blobs(grey_walk) -> None:
    """An empty step needs no detection (``ran`` False; the tracker then finds nobody); a
    camera that sees several blobs leaves the detection to the tracker's blob choice (None);
    a detection of other silhouettes, or with key points given, is refused."""
    from tracker.segmentation import keep_blobs

    frames, _, bgs, scene = grey_walk
    tr = _tracker(scene, bgs)
    views = frames[0]
    segs = tr.segment(views)
    empty = [keep_blobs(s, []) for s in segs]
    det = tr.detect_ahead(views, empty)
    assert det is not None and not det.ran and det.keypoints is None
    assert not tr.process_segmentations(0, 0.0, empty, views, detection=det).has_pose
    # a second blob in camera 0 (a copy of the person moved aside): the tracker's choice decides
    two = _two_blobs(segs[0])
    assert tr.detect_ahead(views, [two, segs[1]]) is None
    det = tr.detect_ahead(views, segs)
    with pytest.raises(ValueError, match="other silhouettes"):
        tr.process_segmentations(0, 0.0, tr.segment(views), views, detection=det)
    with pytest.raises(ValueError, match="give one"):
        tr.process_segmentations(0, 0.0, segs, views, keypoints=[None, None], detection=det)
    with pytest.raises(ValueError, match="cameras"):
        tr.detect_ahead(views[:1], segs[:1])
    off = _tracker(scene, bgs, detector="none")
    assert not off.detect_ahead(views, off.segment(views)).ran


def _two_blobs(seg):
    """``seg`` with a second blob listed (a small one at the image's corner)."""
    from dataclasses import replace

    from tracker.segmentation import Blob

    other = Blob(label=int(seg.labels.max()) + 1, area=50, area_fraction=0.001,
                 bbox=(0, 0, 5, 10), centroid=(2.0, 5.0))  # fmt: skip
    return replace(seg, blobs=[*seg.blobs, other])
