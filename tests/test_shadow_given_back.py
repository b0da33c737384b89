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
