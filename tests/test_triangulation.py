"""Detections triangulated across cameras and averaged into the written key points
(tracker.triangulation, ``keypoints.fuse``)."""

from __future__ import annotations

import typing

import numpy as np
import pytest
from pydantic import ValidationError

from gaitwatch.conventions import KP
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.config import KeypointConfig, RayPair, TrackerConfig
from tracker.triangulation import (
    FUSE_PAIRS,
    RAY_PAIRS,
    fuse_along_rays,
    fuse_detections,
    triangulate,
)

SIZE = (640, 480)


@pytest.fixture(scope="module")
def cameras() -> list[Camera]:
    return [
        Camera.look_at(name="side", position=[0.5, -4.0, 2.3], target=[0, 0, 0.9]).scaled(*SIZE),
        Camera.look_at(name="front", position=[4.0, 0.3, 2.3], target=[0, 0, 0.9]).scaled(*SIZE),
    ]


@pytest.fixture(scope="module")
def joints() -> np.ndarray:
    body = BodyModel(1.72)
    return np.asarray(body.forward(body.neutral_pose(0.0, 0.0, 0.3)[None]))[0]


def _seen(cameras, points: np.ndarray) -> list[np.ndarray]:
    return [cam.project(points) for cam in cameras]


def test_triangulate_recovers_a_point_and_refuses_bad_geometry(cameras) -> None:
    x = np.array([0.2, -0.1, 1.1])
    px = np.stack([cam.project(x[None])[0] for cam in cameras])
    np.testing.assert_allclose(triangulate(cameras, px), x, atol=1e-9)
    # a distorted lens: the rays are undistorted first
    lens = Camera.from_params(
        name="lens", K=cameras[0].K, R=cameras[0].R, t=cameras[0].t, image_size=SIZE,
        dist=[-0.2, 0.05, 0.0, 0.0, 0.0],
    )  # fmt: skip
    both = [lens, cameras[1]]
    px = np.stack([cam.project(x[None])[0] for cam in both])
    np.testing.assert_allclose(triangulate(both, px), x, atol=1e-6)
    assert triangulate(cameras[:1], px[:1]) is None  # one camera: no depth
    assert triangulate(cameras, np.array([[np.nan, 1.0], [2.0, 3.0]])) is None
    twin = [cameras[0], cameras[0]]  # the same ray twice: nothing to intersect
    assert triangulate(twin, np.stack([px[0], px[0]])) is None


def test_fuse_moves_the_chosen_points_half_way(cameras, joints) -> None:
    """Detections of points 4 cm from the written ones: the fused pairs move half way there,
    whatever the labels each camera gave; the other points do not move."""
    true = joints.copy()
    shift = np.array([0.03, -0.02, 0.02])
    for name in ("hips", "shoulders"):
        true[list(FUSE_PAIRS[name])] += shift
    dets = _seen(cameras, true)
    side = [KP["left_hip"], KP["right_hip"], KP["left_shoulder"], KP["right_shoulder"]]
    swap = [KP["right_hip"], KP["left_hip"], KP["right_shoulder"], KP["left_shoulder"]]
    dets[1][side] = dets[1][swap]  # the front camera's labels exchanged
    out = fuse_detections(joints, cameras, dets, ("hips", "shoulders"))
    np.testing.assert_allclose(out[side], joints[side] + 0.5 * shift, atol=1e-6)
    # the sacrum (not detected) moves with the hips' midpoint
    np.testing.assert_allclose(out[KP["sacrum"]], joints[KP["sacrum"]] + 0.5 * shift, atol=1e-6)
    rest = [i for i in range(len(joints)) if i not in [*side, KP["sacrum"]]]
    np.testing.assert_array_equal(out[rest], joints[rest])
    only = fuse_detections(joints, cameras, dets, ("hips",), weight=1.0)
    np.testing.assert_allclose(only[side[:2]], true[side[:2]], atol=1e-6)
    np.testing.assert_array_equal(only[side[2:]], joints[side[2:]])
    shoulders = fuse_detections(joints, cameras, dets, ("shoulders",))
    np.testing.assert_array_equal(shoulders[KP["sacrum"]], joints[KP["sacrum"]])
    # the hips along the vertical only (the default): x and y stay, z moves half way
    up = fuse_detections(joints, cameras, dets, ("hips", "shoulders"), vertical=("hips",))
    half_z = np.array([0.0, 0.0, 0.5 * shift[2]])
    np.testing.assert_allclose(up[side[:2]], joints[side[:2]] + half_z, atol=1e-6)
    np.testing.assert_allclose(up[KP["sacrum"]], joints[KP["sacrum"]] + 0.5 * shift, atol=1e-6)
    np.testing.assert_allclose(up[side[2:]], joints[side[2:]] + 0.5 * shift, atol=1e-6)
    assert np.array_equal(fuse_detections(joints, cameras, dets, ()), joints)


def test_fuse_leaves_points_it_cannot_trust(cameras, joints) -> None:
    lh, rh = KP["left_hip"], KP["right_hip"]
    far = joints.copy()
    far[lh] += [0.0, 0.0, 0.3]  # the detection 30 cm off: beyond max_gap_m
    dets = _seen(cameras, far)
    out = fuse_detections(joints, cameras, dets, ("hips",), max_gap_m=0.15)
    np.testing.assert_array_equal(out[lh], joints[lh])
    near = fuse_detections(joints, cameras, dets, ("hips",), max_gap_m=0.5)
    assert np.linalg.norm(near[lh] - joints[lh]) == pytest.approx(0.15, abs=1e-6)
    missing = _seen(cameras, joints + 0.02)
    missing[1][rh] = np.nan  # seen by one camera only
    out = fuse_detections(joints, cameras, missing, ("hips",))
    np.testing.assert_array_equal(out[rh], joints[rh])
    np.testing.assert_allclose(out[lh], joints[lh] + 0.01, atol=1e-6)
    # one hip moved: the sacrum by half its move
    np.testing.assert_allclose(out[KP["sacrum"]], joints[KP["sacrum"]] + 0.005, atol=1e-6)
    one = fuse_detections(joints, cameras, [missing[0], None], ("hips",))  # one camera: nothing
    np.testing.assert_array_equal(one, joints)
    with pytest.raises(ValueError, match="for 2 cameras"):
        fuse_detections(joints, cameras, missing[:1], ("hips",))


def _across(cam: Camera, step: np.ndarray, point: np.ndarray) -> np.ndarray:
    """``step`` without its component along the camera's line of sight through ``point``."""
    ray = point - cam.center
    ray /= np.linalg.norm(ray)
    return step - (step @ ray) * ray


def test_rays_move_points_across_the_line_of_sight(cameras, joints) -> None:
    """One camera: each chosen point moves half way to the ray through its detection, at the
    model's distance from the camera; the sides are matched limb by limb whatever the
    detector's labels; the sacrum moves with the hips; the other points stay."""
    cam = cameras[0]
    shift = np.array([0.04, 0.03, 0.02])  # a component along the line of sight too
    names = ("hips", "heels", "toes", "shoulders", "elbows", "wrists")
    moved = sorted(i for n in names for i in RAY_PAIRS[n])
    true = joints.copy()
    true[moved] += shift
    det = cam.project(true)
    legs = [RAY_PAIRS[n] for n in ("hips", "knees", "ankles", "heels", "toes")]
    left, right = [p[0] for p in legs], [p[1] for p in legs]
    det[left + right] = det[right + left]  # the legs' labels exchanged
    out = fuse_along_rays(joints, cam, det, names)
    for i in moved:
        step = out[i] - joints[i]
        ray = cam.pixel_rays(cam.project(true[i][None]))[0]  # through the point's own detection
        assert abs(step @ ray) < 1e-9  # nothing along the detection's ray
        assert np.linalg.norm(step) == pytest.approx(
            0.5 * np.linalg.norm(_across(cam, shift, joints[i])), rel=0.05
        )
    hips = list(RAY_PAIRS["hips"])
    np.testing.assert_allclose(
        out[KP["sacrum"]] - joints[KP["sacrum"]], (out[hips] - joints[hips]).mean(axis=0)
    )
    rest = [i for i in range(len(joints)) if i not in [*moved, KP["sacrum"]]]
    np.testing.assert_array_equal(out[rest], joints[rest])
    # distance from the camera kept (to first order)
    d0 = np.linalg.norm(joints[moved] - cam.center, axis=1)
    d1 = np.linalg.norm(out[moved] - cam.center, axis=1)
    np.testing.assert_allclose(d1, d0, atol=2e-3)
    # the hips along the vertical only: their x and y stay, their z moves as before, and the
    # sacrum still takes their mean step along every axis
    up = fuse_along_rays(joints, cam, det, names, vertical=("hips",))
    np.testing.assert_array_equal(up[hips, :2], joints[hips, :2])
    np.testing.assert_allclose(up[hips, 2], out[hips, 2])
    np.testing.assert_allclose(up[KP["sacrum"]], out[KP["sacrum"]])
    others = [i for i in moved if i not in hips]
    np.testing.assert_allclose(up[others], out[others])
    # the arms all the way: the written elbows and wrists project onto their detections
    arms = sorted(i for n in ("elbows", "wrists") for i in RAY_PAIRS[n])
    whole = fuse_along_rays(joints, cam, det, names, full=("elbows", "wrists"))
    np.testing.assert_allclose(cam.project(whole[arms]), det[arms], atol=1e-6)
    np.testing.assert_allclose(whole[arms] - joints[arms], 2 * (out[arms] - joints[arms]))
    rest_moved = [i for i in moved if i not in arms]
    np.testing.assert_array_equal(whole[rest_moved], out[rest_moved])
    assert np.array_equal(fuse_along_rays(joints, cam, det, ()), joints)
    assert np.array_equal(fuse_along_rays(joints, cam, None, names), joints)


def test_rays_move_no_point_below_the_floor(cameras, joints) -> None:
    """Detections below the floor pull the feet down to the floor and no further; a point
    already below the floor goes no lower."""
    cam = cameras[0]
    feet = [*RAY_PAIRS["heels"], *RAY_PAIRS["toes"]]
    assert np.allclose(joints[feet, 2], 0.0)
    true = joints.copy()
    true[feet, 2] -= 0.08
    det = cam.project(true)
    out = fuse_along_rays(joints, cam, det, ("heels", "toes"))
    assert np.all(out[feet, 2] >= 0.0)
    assert np.all(np.linalg.norm(out[feet, :2] - joints[feet, :2], axis=1) > 0.005)  # moved
    sunk = joints.copy()
    sunk[feet, 2] = -0.01
    out = fuse_along_rays(sunk, cam, det, ("heels", "toes"))
    np.testing.assert_allclose(out[feet, 2], -0.01)
    lifted = fuse_along_rays(sunk, cam, cam.project(sunk + [0, 0, 0.05]), ("heels", "toes"))
    assert np.all(lifted[feet, 2] > 0.0)


def test_rays_leave_points_they_cannot_trust(cameras, joints) -> None:
    cam = cameras[0]
    lw, rw = KP["left_wrist"], KP["right_wrist"]
    far = joints.copy()
    far[lw] += [0.0, 0.0, 0.4]  # 40 cm off: beyond fuse_ray_max_gap_m
    far[rw] += [0.0, 0.0, 0.1]
    det = cam.project(far)
    det[KP["left_heel"]] = np.nan  # not detected
    out = fuse_along_rays(joints, cam, det, ("wrists", "heels"), max_gap_m=0.3)
    np.testing.assert_array_equal(out[lw], joints[lw])
    np.testing.assert_array_equal(out[KP["left_heel"]], joints[KP["left_heel"]])
    assert 0.01 < np.linalg.norm(out[rw] - joints[rw]) < 0.05
    with pytest.raises(ValueError, match="19, 2"):
        fuse_along_rays(joints, cam, det[:5], ("wrists",))
    with pytest.raises(ValueError, match="19, 2"):
        fuse_along_rays(joints, cam, det[:, 0], ("wrists",))


def test_fuse_config() -> None:
    kc = TrackerConfig().keypoints
    assert kc.fuse == ("hips", "shoulders") and kc.fuse_min_cameras == 2
    assert kc.fuse_vertical == ("hips",)
    assert set(FUSE_PAIRS) == {"hips", "shoulders"}
    with pytest.raises(ValidationError):
        KeypointConfig(fuse=("knees",))  # measured to lose: not offered
    with pytest.raises(ValidationError):
        KeypointConfig(fuse_min_cameras=1)
    assert kc.fuse_rays == ("hips", "heels", "toes", "shoulders", "elbows", "wrists")
    assert kc.fuse_rays_full == ("elbows", "wrists") and kc.fuse_ray_max_gap_m == 0.5
    assert set(typing.get_args(RayPair)) == set(RAY_PAIRS)  # every pair offered exists
    with pytest.raises(ValidationError):
        KeypointConfig(fuse_rays=("neck",))
    with pytest.raises(ValidationError):
        KeypointConfig(fuse_ray_max_gap_m=0.0)
    with pytest.raises(ValidationError):
        KeypointConfig(fuse_weight=0.0)


def test_tracker_writes_fused_points() -> None:
    """Through the pipeline with perfect detections of the rendered body: with two cameras the
    written hips and shoulders are averaged with the triangulated detections (the hips along
    the vertical only); with one camera ``fuse_rays``' points move across the line of sight
    towards their detections. The pose is the model's either way; with ``fuse`` and
    ``fuse_rays`` empty, the written points are the model's."""
    from tests.test_keypoints2d import _detections
    from tests.tracker_helpers import walking_clip
    from tracker.pipeline import Tracker

    clip = walking_clip()
    body, cams, bgs, frames, poses = (clip[k] for k in ("body", "cams", "bgs", "frames", "poses"))
    truth = np.asarray(body.forward(poses))
    fused = [KP[n] for n in ("left_hip", "right_hip", "left_shoulder", "right_shoulder")]
    moving = [*fused, KP["sacrum"]]

    def run(cams_used, fuse, rays=()):
        cfg = TrackerConfig.model_validate(
            {
                "ipf": {"kept": 9},
                "keypoints": {
                    "enabled": True, "detector": "none", "fuse": fuse, "fuse_rays": rays,
                },
            }
        )  # fmt: skip
        idx = [cams.index(c) for c in cams_used]
        tr = Tracker(
            cams_used, cfg, rng=np.random.default_rng(0), height_m=1.70,
            backgrounds=[bgs[i] for i in idx],
        )  # fmt: skip
        out = []
        for k, images in enumerate(frames):
            kp = _detections(body, poses[k], cams_used)
            out.append(tr.process(k, k / 20.0, [images[i] for i in idx], keypoints=kp))
        return tr, out

    rays = ("hips", "shoulders", "elbows", "wrists")
    tr, on = run(cams, ("hips", "shoulders"), rays)  # two cameras: the rays are not used
    _, off = run(cams, ())
    moved = 0
    for k, (a, b) in enumerate(zip(on, off, strict=True)):
        np.testing.assert_array_equal(a.pose, b.pose)
        model = np.asarray(tr.body.forward(a.pose[None]))[0]
        np.testing.assert_allclose(b.joints, model, atol=1e-9)
        rest = [i for i in range(19) if i not in moving]
        np.testing.assert_array_equal(a.joints[rest], b.joints[rest])
        hips = [KP["left_hip"], KP["right_hip"]]
        np.testing.assert_array_equal(a.joints[hips, :2], b.joints[hips, :2])
        err_on = np.linalg.norm(a.joints[fused] - truth[k, fused], axis=1)
        err_off = np.linalg.norm(b.joints[fused] - truth[k, fused], axis=1)
        moved += int(np.sum(err_on < err_off - 1e-6))
        assert np.all(err_on <= err_off + 1e-6)
    assert moved > 0

    cam = cams[0]
    _, one_on = run(cams[:1], ("hips", "shoulders"), rays)
    _, one_off = run(cams[:1], ("hips", "shoulders"))
    _, none = run(cams[:1], ())
    along = sorted(i for n in rays for i in RAY_PAIRS[n])
    hips = list(RAY_PAIRS["hips"])
    legs = ("hips", "knees", "ankles", "heels", "toes")
    limbs = [
        [RAY_PAIRS[n] for n in legs],
        [RAY_PAIRS[n] for n in ("shoulders", "elbows", "wrists")],
    ]
    err_on, err_off = [], []
    for k, (a, b, c) in enumerate(zip(one_on, one_off, none, strict=True)):
        np.testing.assert_array_equal(a.pose, b.pose)
        np.testing.assert_array_equal(b.joints, c.joints)  # one camera: nothing triangulated
        rest = [i for i in range(19) if i not in [*along, KP["sacrum"]]]
        np.testing.assert_array_equal(a.joints[rest], b.joints[rest])
        # the hips move along the vertical only (fuse_vertical); the other moved points keep
        # their distance from the camera (to first order)
        np.testing.assert_array_equal(a.joints[hips, :2], b.joints[hips, :2])
        across = [i for i in along if i not in hips]
        dist = [np.linalg.norm(j[across] - cam.center, axis=1) for j in (a.joints, b.joints)]
        np.testing.assert_allclose(dist[0], dist[1], atol=0.01)
        seen = cam.project(truth[k])
        for limb in limbs:  # each limb's detected sides as the fusion matched them
            left, right = [p[0] for p in limb], [p[1] for p in limb]
            model = cam.project(b.joints)
            same = np.linalg.norm(model[left + right] - seen[left + right], axis=1).sum()
            swap = np.linalg.norm(model[left + right] - seen[right + left], axis=1).sum()
            target = seen[right + left] if swap < same else seen[left + right]
            fused = np.isin(left + right, along)
            for j, out in ((a.joints, err_on), (b.joints, err_off)):
                err = np.linalg.norm(cam.project(j[left + right]) - target, axis=1)
                out.append(err[fused])
    # in the image the written points come half way to the detections
    assert np.mean(np.concatenate(err_on)) < 0.7 * np.mean(np.concatenate(err_off))
