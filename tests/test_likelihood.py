"""Silhouette likelihood: the fast numba path against the OpenCV reference, weights, factoring."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from tracker import raster
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, JointLimits, clamp
from tracker.likelihood import SilhouetteLikelihood, warm_up, weight_from_counts
from tracker.render_ref import capsule_discs, counts_reference, render_reference

# Tolerance of the fast path against the reference (drawn at 7x and sampled at pixel centres):
# per camera and pose, |difference| of Nc and of Nm, and the number of pixels the two masks
# disagree on, at most EDGE_TOL pixels per row edge of the model's silhouette (+ 2 pixels).
EDGE_TOL = 0.35


@pytest.fixture(scope="module")
def body() -> BodyModel:
    return BodyModel(1.75, girth=1.05)


@pytest.fixture(scope="module")
def cameras() -> list[Camera]:
    """Three placements, mixed likelihood resolutions, one wide lens with strong distortion."""
    return [
        Camera.look_at(name="front", position=[4.5, 0.5, 1.6], target=[0, 0, 0.9]).scaled(160, 120),
        Camera.look_at(name="side", position=[0.3, -4.0, 2.2], target=[0, 0, 0.8]).scaled(160, 120),
        Camera.look_at(
            name="wide-corner",
            position=[-3.0, 3.0, 2.5],
            target=[0, 0, 0.9],
            hfov_deg=90,
            dist=[-0.28, 0.09, 0.001, -0.001, -0.012],
        ).scaled(320, 240),
    ]


def _random_poses(body: BodyModel, rng: np.random.Generator, n: int) -> np.ndarray:
    lo, hi = JointLimits.profile("walking").arrays()
    poses = rng.uniform(lo, hi, (n, N_DOF))
    poses[:, :2] = rng.uniform(-1.0, 1.0, (n, 2))
    poses[:, 2] = body.root_height + rng.uniform(-0.15, 0.05, n)
    poses[:, 3] = rng.uniform(-np.pi, np.pi, n)
    return poses


def _walking_pose(body: BodyModel) -> np.ndarray:
    p = body.neutral_pose(x=0.2, y=-0.1, yaw=0.4)
    for name, deg in (
        ("l_hip_flexion", 25),
        ("r_hip_flexion", -12),
        ("r_knee_flexion", 35),
        ("l_knee_flexion", 8),
        ("l_shoulder_flexion", -20),
        ("r_shoulder_flexion", 25),
        ("r_elbow_flexion", 30),
        ("l_elbow_flexion", 15),
        ("trunk_flexion", 5),
    ):
        p[DOF[name]] = np.radians(deg)
    p[DOF["root_z"]] -= 0.03
    return p


def _row_edges(mask: np.ndarray) -> int:
    padded = np.pad(mask, ((0, 0), (1, 1))).astype(np.int8)
    return int(np.count_nonzero(np.diff(padded, axis=1)))


def test_projection_matches_camera(cameras: list[Camera]) -> None:
    rng = np.random.default_rng(0)
    pts = rng.uniform([-1, -1, 0], [1, 1, 2], (50, 3))
    thin_prism = Camera.look_at(
        name="rational-thin-prism",
        position=[2.0, -3.0, 2.0],
        target=[0, 0, 1],
        dist=[0.2, -0.1, 0.001, -0.002, 0.02, 0.05, -0.01, 0.003, 0.001, -0.002, 0.003, 0.001],
    )
    for cam in [*cameras, thin_prism]:
        row = raster.pack_camera(cam.R, cam.t, cam.K, cam.dist)[None]
        ref = cam.project(pts)
        got = np.array([raster.project_point(*p, row, 0)[:2] for p in pts])
        np.testing.assert_allclose(got, ref, atol=1e-9)
        uv = np.array([raster.project_uv(*p, row, 0) for p in pts])  # (u, v, in front)
        assert uv[:, 2].all()
        np.testing.assert_allclose(uv[:, :2], ref, atol=1e-9)
        behind = 2 * cam.center - pts[0]  # mirrored through the optical centre
        assert np.isnan(cam.project(behind)).all() and not raster.project_uv(*behind, row, 0)[2]
    # the disc radii agree with the reference's (central differences) to 1e-4
    body = BodyModel()
    a, b = body.capsules(body.neutral_pose())
    cam = cameras[2]
    row = raster.pack_camera(cam.R, cam.t, cam.K, cam.dist)[None]
    _, _, ra, _, _ = capsule_discs(cam, a[0], b[0], body.radii)
    scale = np.array([raster.project_point(*p, row, 0)[2] for p in a[0]])
    np.testing.assert_allclose(scale * body.radii[:, 0], ra, rtol=1e-4)


def test_fast_counts_match_reference(body: BodyModel, cameras: list[Camera]) -> None:
    rng = np.random.default_rng(1)
    poses = _random_poses(body, rng, 200)
    sils = []
    for cam in cameras:  # the silhouette: another person's pose plus a clutter blob
        s = render_reference(body, _walking_pose(body), cam)
        s[cam.height // 4 : cam.height // 3, cam.width // 5 : cam.width // 3] = True
        sils.append(s)
    lik = SilhouetteLikelihood(body, cameras)
    lik.set_silhouettes(sils)
    fast = lik.counts(poses)
    ref = counts_reference(body, cameras, sils, poses)
    assert fast.shape == ref.shape == (200, 3, 3)
    assert fast.dtype == np.int64
    # Ns + Nc is the silhouette, whatever the pose
    for k, s in enumerate(sils):
        assert np.all(fast[:, k, 0] + fast[:, k, 1] == s.sum())
    assert (fast[..., 0] > 0).mean() > 0.3  # the test compares overlaps, not just empty images
    edges = np.zeros((200, 3))
    for i in range(200):
        for k, cam in enumerate(cameras):
            m = lik.render_mask(poses[i], k)
            edges[i, k] = _row_edges(m)
            assert m.sum() == fast[i, k, 0] + fast[i, k, 2]
            if i < 40:  # pixel-wise comparison on a subset
                r = render_reference(body, poses[i], cam)
                assert np.count_nonzero(m ^ r) <= EDGE_TOL * edges[i, k] + 2
    assert edges.min() > 0
    tol = EDGE_TOL * edges + 2
    assert np.all(np.abs(fast[..., 0] - ref[..., 0]) <= tol)
    assert np.all(np.abs(fast[..., 2] - ref[..., 2]) <= tol)
    # and the weights agree closely
    np.testing.assert_allclose(weight_from_counts(fast), weight_from_counts(ref), atol=0.03)


@pytest.mark.parametrize("measure", ["iou", "ratio"])
def test_true_pose_outweighs_perturbed_poses(
    body: BodyModel, cameras: list[Camera], measure: str
) -> None:
    true = _walking_pose(body)
    sils = [render_reference(body, true, cam) for cam in cameras]
    lik = SilhouetteLikelihood(body, cameras, measure=measure)  # type: ignore[arg-type]
    lik.set_silhouettes(sils)
    rng = np.random.default_rng(2)
    lo, hi = JointLimits.profile("general").arrays()
    pert = np.repeat(true[None], 300, axis=0)
    pert[:, 3:] += rng.normal(0, np.radians(8), (300, N_DOF - 3))
    pert[:, :3] += rng.normal(0, 0.04, (300, 3))
    clamp(pert, lo, hi)
    w_true = lik.weights(true)[0]
    w = lik.weights(pert)
    assert w_true > w.max()
    if measure == "iou":
        assert w_true > 0.85
    # one DOF at a time, by 15 degrees or 8 cm: every visible change lowers the weight
    for name in (
        "root_x",
        "root_y",
        "root_z",
        "root_yaw",
        "trunk_flexion",
        "l_hip_flexion",
        "r_hip_flexion",
        "l_knee_flexion",
        "r_knee_flexion",
        "l_shoulder_flexion",
        "r_elbow_flexion",
        "l_hip_abduction",
    ):
        for step in (-1, 1):
            p = true.copy()
            p[DOF[name]] += step * (0.08 if DOF[name] < 3 else np.radians(15))
            assert lik.weights(p)[0] < w_true, (name, step)


def test_perfect_match_and_empty_images(body: BodyModel, cameras: list[Camera]) -> None:
    lik = SilhouetteLikelihood(body, cameras)
    pose = _walking_pose(body)
    lik.set_silhouettes([lik.render_mask(pose, k) for k in range(3)])
    c = lik.counts(pose)[0]
    assert np.all(c[:, 0] > 100) and np.all(c[:, 1:] == 0)
    assert lik.weights(pose)[0] == 1.0
    far = pose.copy()
    far[2] += 50.0  # high above every camera's field of view
    assert np.all(lik.counts(far)[0, :, 2] == 0)
    lik.set_silhouettes([np.zeros((cam.height, cam.width), bool) for cam in cameras])
    assert np.all(lik.weights(far) == 0.0)  # nothing anywhere: weight 0, no division by zero


def test_weight_from_counts() -> None:
    c = np.array([[[0, 0, 0]], [[50, 0, 0]], [[40, 10, 0]], [[40, 10, 10]], [[0, 20, 30]]])
    np.testing.assert_allclose(weight_from_counts(c), [0.0, 1.0, 0.8, 40 / 60, 0.0])
    np.testing.assert_allclose(weight_from_counts(c, "ratio"), [0.0, 50.0, 4.0, 2.0, 0.0])
    # monotone: iou = r / (1 + r) with r the method's ratio Nc / (Ns + Nm)
    rng = np.random.default_rng(3)
    c = rng.integers(1, 500, (1000, 1, 3))
    r = c[:, 0, 0] / (c[:, 0, 1] + c[:, 0, 2])
    np.testing.assert_allclose(weight_from_counts(c), r / (1 + r))
    with pytest.raises(ValueError, match="measure"):
        weight_from_counts(c, "dice")  # type: ignore[arg-type]


@pytest.mark.parametrize("measure", ["iou", "ratio"])
def test_weight_from_counts_is_bit_identical_to_the_numpy_formula(measure: str) -> None:
    """The numba pass (up to 7 cameras) and numpy's (more) give numpy's mean bit for bit."""
    rng = np.random.default_rng(11)
    for k in range(1, 10):
        c = rng.integers(0, 20_000, (6, 5, 7, k, 3))
        c[rng.random(c.shape) < 0.2] = 0  # empty cameras: iou 0, ratio's floor of 1 pixel
        f = c.astype(np.float64)
        if measure == "iou":
            den = f[..., 0] + f[..., 1] + f[..., 2]
            per_cam = np.divide(f[..., 0], den, out=np.zeros_like(den), where=den > 0)
        else:
            per_cam = f[..., 0] / np.maximum(f[..., 1] + f[..., 2], 1.0)
        expect = per_cam.mean(axis=-1)
        got = weight_from_counts(c, measure)  # type: ignore[arg-type]
        assert got.shape == (6, 5, 7)
        assert np.array_equal(got, expect), k
        assert np.array_equal(weight_from_counts(f, measure), expect), k  # type: ignore[arg-type]


@pytest.mark.parametrize("hem", [None, (1.0, 0.08)])
def test_weights_factored_equals_expanded(
    body: BodyModel, cameras: list[Camera], hem: tuple[float, float] | None
) -> None:
    body = body.with_shape(hem=hem)  # a skirt's hem moves with the thighs: still exact
    rng = np.random.default_rng(4)
    m, na, nb_ = 6, 5, 4
    base = _random_poses(body, rng, m)
    base[:, 2] = body.root_height
    # lying and leaning bodies too: leg rows above, beside and across the upper body's rows
    base[0, DOF["root_pitch"]] = np.radians(85)
    base[1, DOF["root_roll"]] = np.radians(80)
    base[1, DOF["root_z"]] = 0.3
    left = base[:, None, list(LEFT_LEG)] + rng.normal(0, 0.3, (m, na, 6))
    right = base[:, None, list(RIGHT_LEG)] + rng.normal(0, 0.3, (m, nb_, 6))
    lik = SilhouetteLikelihood(body, cameras)
    lik.set_silhouettes([render_reference(body, _walking_pose(body), cam) for cam in cameras])
    expanded = np.repeat(np.repeat(base[:, None, None, :], na, 1), nb_, 2)
    expanded[..., list(LEFT_LEG)] = left[:, :, None, :]
    expanded[..., list(RIGHT_LEG)] = right[:, None, :, :]
    flat = expanded.reshape(-1, N_DOF)
    counts = lik.counts(flat).reshape(m, na, nb_, 3, 3)
    np.testing.assert_array_equal(lik.counts_factored(base, left, right), counts)
    wf = lik.weights_factored(base, left, right)
    assert wf.shape == (m, na, nb_)
    np.testing.assert_array_equal(wf, lik.weights(flat).reshape(m, na, nb_))
    assert np.ptp(wf) > 0  # the variants do differ
    with pytest.raises(ValueError, match="left_leg"):
        lik.weights_factored(base, left[:, :, :5], right)


def test_points_behind_the_camera_do_not_crash(body: BodyModel) -> None:
    # a camera standing inside the walking area: bodies around it, some straddling its plane
    cam = Camera.look_at(name="inside", position=[0.0, 0.0, 1.2], target=[3.0, 0.0, 1.0])
    cam = cam.scaled(160, 120)
    lik = SilhouetteLikelihood(body, [cam])
    lik.set_silhouettes([np.ones((120, 160), bool)])
    rng = np.random.default_rng(5)
    poses = _random_poses(body, rng, 300)
    poses[:, :2] = rng.uniform(-1.5, 1.5, (300, 2))
    c = lik.counts(poses)
    assert np.all(c >= 0) and np.all(c[:, 0, 0] + c[:, 0, 1] == 120 * 160)
    behind = body.neutral_pose(x=-2.0)
    assert lik.counts(behind)[0, 0, 0] == 0
    assert not lik.render_mask(behind, 0).any()
    w = lik.weights(poses)
    assert np.all(np.isfinite(w)) and np.all((w >= 0) & (w <= 1))


def test_bad_silhouettes_and_call_order(body: BodyModel, cameras: list[Camera]) -> None:
    lik = SilhouetteLikelihood(body, cameras)
    with pytest.raises(RuntimeError, match="set_silhouettes"):
        lik.weights(body.neutral_pose())
    with pytest.raises(ValueError, match="3 silhouettes"):
        lik.set_silhouettes([np.zeros((120, 160), bool)])
    with pytest.raises(ValueError, match="wide-corner"):
        lik.set_silhouettes([np.zeros((120, 160), bool)] * 3)
    with pytest.raises(ValueError, match="measure"):
        SilhouetteLikelihood(body, cameras, measure="dice")  # type: ignore[arg-type]


def test_pack_rows_round_trip() -> None:
    rng = np.random.default_rng(6)
    img = rng.random((7, 150)) > 0.5
    packed = raster.pack_rows(img)
    assert packed.shape == (7, 3) and packed.dtype == np.uint64
    np.testing.assert_array_equal(raster.unpack_rows(packed, 150), img)
    assert _popcount(packed[0, 1]) == int(img[0, 64:128].sum())
    assert _popcount(np.uint64(0xFFFFFFFFFFFFFFFF)) == 64


@numba.njit
def _popcount(x: np.uint64) -> int:
    return raster.popcount64(x)


def test_warm_up_compiles_every_kernel() -> None:
    assert warm_up() >= 0.0
    for kernel in (raster.counts_kernel, raster.counts_factored_kernel, raster.render_one_kernel):
        assert kernel.signatures  # compiled (or loaded from the cache)


def test_known_occluders_hide_model_pixels(body: BodyModel, cameras: list[Camera]) -> None:
    """Model pixels behind an occluder count neither as common nor as model-only; silhouette
    pixels there still count; factored and expanded counts agree; None clears."""
    pose = _walking_pose(body)
    truth = [render_reference(body, pose, cam) for cam in cameras]
    # a table in front of the legs in camera 0: the silhouette loses the rows below `cut`
    ys = np.flatnonzero(truth[0].any(axis=1))
    cut = int(ys[0] + 0.55 * (ys[-1] - ys[0]))
    occ0 = np.zeros_like(truth[0])
    occ0[cut:] = True
    sils = [t.copy() for t in truth]
    sils[0][cut:] = False
    lik = SilhouetteLikelihood(body, cameras)
    rng = np.random.default_rng(8)
    poses = np.concatenate([pose[None], _random_poses(body, rng, 20)])
    lik.set_silhouettes(sils)
    plain = lik.counts(poses)
    lik.set_occlusion([occ0, None, None])
    assert lik.occluded[0] is not None and lik.occluded[1] is None
    lik.set_silhouettes(sils)  # takes effect with the next silhouettes
    hidden = lik.counts(poses)
    # by hand for camera 0: Nm without the model's pixels behind the table
    for i, p in enumerate(poses[:6]):
        m = lik.render_mask(p, 0)
        nc = int(np.count_nonzero(m & sils[0]))
        assert hidden[i, 0, 0] == plain[i, 0, 0] == nc
        assert hidden[i, 0, 1] == plain[i, 0, 1]
        assert hidden[i, 0, 2] == int(np.count_nonzero(m & ~sils[0] & ~occ0))
    np.testing.assert_array_equal(hidden[:, 1:], plain[:, 1:])  # other cameras untouched
    # the true pose: its hidden legs no longer count against it, so it weighs more
    assert plain[0, 0, 2] > hidden[0, 0, 2]
    w_plain = weight_from_counts(plain)
    w_hidden = weight_from_counts(hidden)
    assert w_hidden[0] > w_plain[0]
    # silhouette pixels inside the occluder mask still count (a person in front of the table)
    lik.set_silhouettes(truth)
    front = lik.counts(pose[None])
    lik.set_occlusion(None)
    lik.set_silhouettes(truth)
    np.testing.assert_array_equal(lik.counts(pose[None])[0, 0, :2], front[0, 0, :2])
    assert front[0, 0, 2] <= lik.counts(pose[None])[0, 0, 2]
    # factored counts agree with the expanded ones under occlusion
    lik.set_occlusion([occ0, None, None])
    lik.set_silhouettes(sils)
    base = poses[:3]
    left = base[:, None, list(LEFT_LEG)] + rng.normal(0, 0.3, (3, 4, 6))
    right = base[:, None, list(RIGHT_LEG)] + rng.normal(0, 0.3, (3, 5, 6))
    full = np.repeat(np.repeat(base[:, None, None, :], 4, 1), 5, 2)
    full[..., list(LEFT_LEG)] = left[:, :, None, :]
    full[..., list(RIGHT_LEG)] = right[:, None, :, :]
    np.testing.assert_array_equal(
        lik.counts_factored(base, left, right),
        lik.counts(full.reshape(-1, N_DOF)).reshape(3, 4, 5, 3, 3),
    )
    lik.set_occlusion(None)
    assert all(o is None for o in lik.occluded)
    lik.set_silhouettes(sils)
    np.testing.assert_array_equal(lik.counts(poses), plain)
    with pytest.raises(ValueError, match="3 occlusion masks"):
        lik.set_occlusion([occ0])
    with pytest.raises(ValueError, match="wide-corner"):
        lik.set_occlusion([occ0, None, occ0])
