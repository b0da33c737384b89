"""Body model: anthropometry, forward kinematics, DOF signs, joint limits."""

from __future__ import annotations

import numpy as np
import pytest

from gaitwatch.conventions import BONE_INDICES, KP, N_KEYPOINTS
from tracker.body import N_CAPSULES, SEGMENT_NAMES, BodyModel
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, JointLimits, clamp


@pytest.fixture(scope="module")
def body() -> BodyModel:
    return BodyModel(1.70)


def _random_poses(body: BodyModel, rng: np.random.Generator, n: int, profile: str) -> np.ndarray:
    lo, hi = JointLimits.profile(profile).arrays()
    poses = rng.uniform(lo, hi, (n, N_DOF))
    poses[:, :2] = rng.uniform(-3, 3, (n, 2))
    poses[:, 2] = rng.uniform(0.6, 1.2, n)
    return poses


# Every bone of CONVENTIONS is rigid in the model but sacrum-neck and neck-head: the sacrum key
# point lies on the pelvis behind the trunk's pivot and the neck key point on the trunk ahead of
# the head's, so trunk and head flexion change those distances, as the spine's bending does.
_FLEXIBLE = ({KP["sacrum"], KP["neck"]}, {KP["neck"], KP["head"]})
_RIGID = [(i, j) for i, j in BONE_INDICES if {i, j} not in _FLEXIBLE]


def _bone_lengths(kp: np.ndarray) -> np.ndarray:
    a = np.array([i for i, _ in _RIGID])
    b = np.array([j for _, j in _RIGID])
    return np.linalg.norm(kp[:, a] - kp[:, b], axis=-1)


@pytest.mark.parametrize("height", [1.50, 1.70, 1.92])
def test_neutral_pose_stands_on_the_floor(height: float) -> None:
    body = BodyModel(height)
    kp = body.forward(body.neutral_pose(x=1.0, y=-2.0, yaw=0.7))[0]
    for name in ("left_heel", "right_heel", "left_toe", "right_toe"):
        assert kp[KP[name], 2] == pytest.approx(0.0, abs=1e-9)
    # the root is the pelvis frame's origin; the sacrum key point (mid-PSIS) lies behind and
    # above it, 0.084 H behind and 0.069 H above the hip centres' mid-point
    heading = np.array([np.cos(0.7), np.sin(0.7)])
    hips = 0.5 * (kp[KP["left_hip"]] + kp[KP["right_hip"]])
    d = kp[KP["sacrum"]] - hips
    assert -d[:2] @ heading == pytest.approx(0.084 * height)
    assert d[2] == pytest.approx(0.069 * height)
    assert kp[KP["sacrum"], 2] == pytest.approx(body.root_height + 0.024 * height)
    # the neck key point (base of the neck at C7 level) 0.005 H behind the shoulder centres
    shoulders = 0.5 * (kp[KP["left_shoulder"]] + kp[KP["right_shoulder"]])
    assert (kp[KP["neck"]] - shoulders)[:2] @ heading == pytest.approx(-0.005 * height)
    # head centre ~0.936 H (Winter), knee ~0.285 H, shoulder ~0.818 H
    assert kp[KP["head"], 2] == pytest.approx(0.936 * height, abs=0.01 * height)
    assert kp[KP["left_knee"], 2] == pytest.approx(0.285 * height, abs=0.005 * height)
    assert kp[KP["left_shoulder"], 2] == pytest.approx(0.818 * height, abs=0.005 * height)
    assert kp[KP["sacrum"], :2] == pytest.approx([1.0, -2.0] - 0.029 * height * heading)
    assert body.segment_lengths["thigh"] == pytest.approx((0.530 - 0.285) * height)


def test_left_is_plus_y_when_facing_plus_x(body: BodyModel) -> None:
    kp = body.forward(body.neutral_pose())[0]
    for joint in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "heel", "toe"):
        assert kp[KP[f"left_{joint}"], 1] > 0 > kp[KP[f"right_{joint}"], 1], joint
    assert kp[KP["left_toe"], 0] > kp[KP["left_heel"], 0]  # feet point to +x
    assert kp[KP["head"], 0] > kp[KP["neck"], 0]  # the face is in front of C7
    # turned to face +y: the left is now -x
    kp = body.forward(body.neutral_pose(yaw=np.pi / 2))[0]
    assert kp[KP["left_hip"], 0] < 0 < kp[KP["right_hip"], 0]
    assert kp[KP["left_toe"], 1] > kp[KP["left_heel"], 1]


def test_bone_lengths_preserved_for_random_poses(body: BodyModel) -> None:
    rng = np.random.default_rng(0)
    poses = _random_poses(body, rng, 500, "general")
    ref = _bone_lengths(body.forward(body.neutral_pose()))[0]
    lengths = _bone_lengths(body.forward(poses))
    np.testing.assert_allclose(lengths, np.broadcast_to(ref, lengths.shape), atol=1e-9)
    # and the heel-to-toe distance (same rigid foot)
    kp = body.forward(poses)
    d = np.linalg.norm(kp[:, KP["left_toe"]] - kp[:, KP["left_heel"]], axis=-1)
    np.testing.assert_allclose(d, body.segment_lengths["heel_to_toe"], atol=1e-9)


def test_batch_equals_one_at_a_time(body: BodyModel) -> None:
    poses = _random_poses(body, np.random.default_rng(1), 37, "general")
    batch = body.forward(poses)
    assert batch.shape == (37, N_KEYPOINTS, 3)
    for i in (0, 17, 36):
        np.testing.assert_array_equal(batch[i], body.forward(poses[i])[0])
    a, b = body.capsules(poses)
    assert a.shape == b.shape == (37, N_CAPSULES, 3)
    assert body.radii.shape == (N_CAPSULES, 2)
    assert len(SEGMENT_NAMES) == 17


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    cos = np.sum(u * v, axis=-1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def test_clamped_poses_respect_the_limits(body: BodyModel) -> None:
    rng = np.random.default_rng(2)
    limits = JointLimits.profile("walking").with_overrides({"l_knee_flexion": (5.0, 70.0)})
    lo, hi = limits.arrays()
    poses = rng.normal(0, 2.0, (400, N_DOF))  # far outside every range
    poses[:, 2] = rng.uniform(-1, 3, 400)
    clamp(poses, lo, hi)
    assert np.all(poses >= lo - 1e-12) and np.all(poses <= hi + 1e-12)
    # The geometry agrees: the knee angle measured on the key points is the knee flexion DOF.
    kp = body.forward(poses)
    for side, dof in (("left", "l_knee_flexion"), ("right", "r_knee_flexion")):
        thigh = kp[:, KP[f"{side}_knee"]] - kp[:, KP[f"{side}_hip"]]
        shank = kp[:, KP[f"{side}_ankle"]] - kp[:, KP[f"{side}_knee"]]
        measured = _angle(thigh, shank)
        np.testing.assert_allclose(measured, np.degrees(poses[:, DOF[dof]]), atol=1e-4)
        low, high = limits.ranges[dof]
        assert measured.min() >= low - 1e-4 and measured.max() <= high + 1e-4
    elbow_l = _angle(
        kp[:, KP["left_elbow"]] - kp[:, KP["left_shoulder"]],
        kp[:, KP["left_wrist"]] - kp[:, KP["left_elbow"]],
    )
    np.testing.assert_allclose(elbow_l, np.degrees(poses[:, DOF["l_elbow_flexion"]]), atol=1e-4)


# (DOF, angle in degrees, key point, axis, expected sign of its displacement) from the neutral
# pose facing +x with the left towards +y (signs of tracker/dof.py).
SIGNS = [
    ("l_hip_flexion", 30, "left_knee", 0, +1),
    ("r_hip_flexion", 30, "right_knee", 0, +1),
    ("l_hip_abduction", 20, "left_knee", 1, +1),
    ("r_hip_abduction", 20, "right_knee", 1, -1),
    ("l_ankle_flexion", 20, "left_toe", 2, +1),
    ("r_ankle_flexion", -20, "right_toe", 2, -1),
    ("l_ankle_rotation", 20, "left_toe", 1, -1),  # internal: toes turn in
    ("r_ankle_rotation", 20, "right_toe", 1, +1),
    ("l_shoulder_flexion", 40, "left_elbow", 0, +1),
    ("l_shoulder_abduction", 40, "left_elbow", 1, +1),
    ("r_shoulder_abduction", 40, "right_elbow", 1, -1),
    ("l_elbow_flexion", 60, "left_wrist", 0, +1),
    ("trunk_flexion", 20, "neck", 0, +1),
    ("trunk_lateral", 15, "neck", 1, +1),
    ("trunk_rotation", 20, "left_shoulder", 0, -1),  # turning left takes the left shoulder back
    ("neck_flexion", 20, "head", 0, +1),
    ("neck_rotation", 30, "head", 1, +1),
    ("root_pitch", 15, "neck", 0, +1),
    ("root_roll", 10, "left_hip", 2, +1),
    ("root_yaw", 30, "left_hip", 0, -1),
]


@pytest.mark.parametrize(("dof", "deg", "point", "axis", "sign"), SIGNS)
def test_dof_signs(body: BodyModel, dof: str, deg: float, point: str, axis: int, sign: int) -> None:
    p0 = body.neutral_pose()
    p1 = p0.copy()
    p1[DOF[dof]] = np.radians(deg)
    moved = body.forward(p1)[0, KP[point], axis] - body.forward(p0)[0, KP[point], axis]
    assert np.sign(moved) == sign and abs(moved) > 0.005


def test_knee_flexion_moves_the_ankle_back_and_hip_rotation_with_bent_knee(
    body: BodyModel,
) -> None:
    p = body.neutral_pose()
    p[DOF["l_knee_flexion"]] = np.radians(90)
    kp0 = body.forward(p)[0]
    assert kp0[KP["left_ankle"], 0] < kp0[KP["left_knee"], 0] - 0.3
    # internal rotation of the hip swings the lower leg outwards when the knee is bent
    p[DOF["l_hip_rotation"]] = np.radians(20)
    kp1 = body.forward(p)[0]
    assert kp1[KP["left_ankle"], 1] > kp0[KP["left_ankle"], 1] + 0.05


def test_leg_dofs_move_only_their_leg(body: BodyModel) -> None:
    rng = np.random.default_rng(3)
    p0 = _random_poses(body, rng, 1, "walking")[0]
    p1 = p0.copy()
    p1[list(LEFT_LEG)] += 0.2
    d = np.abs(body.points(p1)[0] - body.points(p0)[0]).max(axis=1)
    moved = np.flatnonzero(d > 1e-12)
    kp_moved = {i for i in moved if i < N_KEYPOINTS}
    assert kp_moved == {KP[n] for n in ("left_knee", "left_ankle", "left_heel", "left_toe")}
    caps = {(int(j) - N_KEYPOINTS) // 2 for j in moved if j >= N_KEYPOINTS}
    assert caps == set(body.left_leg_capsules.tolist())
    assert set(RIGHT_LEG).isdisjoint(LEFT_LEG)


def test_girth_scales_radii_not_lengths() -> None:
    a, b = BodyModel(1.7), BodyModel(1.7, girth=1.2)
    np.testing.assert_allclose(b.radii, 1.2 * a.radii)
    np.testing.assert_array_equal(a.forward(a.neutral_pose()), b.forward(b.neutral_pose()))
    tall = BodyModel(1.9)
    np.testing.assert_allclose(tall.radii, a.radii * 1.9 / 1.7)


def test_part_girths_scale_their_parts_only() -> None:
    from tracker.body import CAPSULES, GIRTH_PARTS

    a = BodyModel(1.7, girth=1.1)
    b = BodyModel(1.7, girth=1.1, part_girths={"thighs": 1.5, "feet": 0.8})
    segs = [c.segment for c in CAPSULES]
    for i, seg in enumerate(segs):
        f = 1.5 if seg in GIRTH_PARTS["thighs"] else 0.8 if seg in GIRTH_PARTS["feet"] else 1.0
        np.testing.assert_allclose(b.radii[i], f * a.radii[i])
    np.testing.assert_array_equal(a.forward(a.neutral_pose()), b.forward(b.neutral_pose()))
    assert b.part_girths["thighs"] == 1.5 and b.part_girths["arms"] == 1.0
    # with_shape keeps the height and the other factors
    c = b.with_shape(part_girths={"arms": 1.2})
    assert c.height_m == 1.7 and c.girth == 1.1
    assert c.part_girths == {**b.part_girths, "arms": 1.2}
    assert c.with_shape(girth=1.3).part_girths == c.part_girths
    assert b.shape_key != a.shape_key
    assert BodyModel(1.7, 1.1, {"thighs": 1.5, "feet": 0.8}).shape_key == b.shape_key
    assert "thighs" in repr(b)
    with pytest.raises(ValueError, match="unknown body part 'tail'"):
        BodyModel(1.7, part_girths={"tail": 1.0})
    with pytest.raises(ValueError, match="part_girths"):
        BodyModel(1.7, part_girths={"arms": 4.0})


def _top_and_bottom(body: BodyModel) -> tuple[float, float]:
    """Highest and lowest capsule surface point (z, metres) standing in the neutral pose."""
    a, b = body.capsules(body.neutral_pose()[None])
    top = max((a[0, :, 2] + body.radii[:, 0]).max(), (b[0, :, 2] + body.radii[:, 1]).max())
    low = min((a[0, :, 2] - body.radii[:, 0]).min(), (b[0, :, 2] - body.radii[:, 1]).min())
    return float(top), float(low)


@pytest.mark.parametrize("s", [0.9, 1.1])
def test_leg_length_scales_the_legs_at_the_same_height(s: float) -> None:
    a, b = BodyModel(1.7), BodyModel(1.7, leg_length=s)
    ka, kb = a.forward(a.neutral_pose())[0], b.forward(b.neutral_pose())[0]
    for side in ("left", "right"):
        for p, q in (("hip", "knee"), ("knee", "ankle")):
            la = np.linalg.norm(ka[KP[f"{side}_{p}"]] - ka[KP[f"{side}_{q}"]])
            lb = np.linalg.norm(kb[KP[f"{side}_{p}"]] - kb[KP[f"{side}_{q}"]])
            assert lb == pytest.approx(s * la)
    leg = a.segment_lengths["thigh"] + a.segment_lengths["shank"]
    assert kb[KP["left_hip"], 2] - ka[KP["left_hip"], 2] == pytest.approx((s - 1) * leg)
    assert b.segment_lengths["thigh"] == pytest.approx(s * a.segment_lengths["thigh"])
    # the trunk gives what the legs take: the standing height stays within 1 cm, the soles on
    # the floor; arms, feet and widths are unchanged
    (top_a, low_a), (top_b, low_b) = _top_and_bottom(a), _top_and_bottom(b)
    assert abs(top_b - top_a) < 0.01 and low_b == pytest.approx(low_a, abs=1e-9)
    trunk = b.segment_lengths["sacrum_to_neck"] - a.segment_lengths["sacrum_to_neck"]
    assert trunk * (s - 1) < 0
    for name in ("upper_arm", "forearm", "foot", "hip_separation", "shoulder_separation"):
        assert b.segment_lengths[name] == a.segment_lengths[name]
    np.testing.assert_array_equal(a.radii, b.radii)
    for heel in ("left_heel", "right_heel"):
        assert kb[KP[heel]] == pytest.approx(ka[KP[heel]])


def test_leg_length_with_shape_and_bad_values() -> None:
    b = BodyModel(1.7, girth=1.1, leg_length=1.1)
    assert b.with_shape(girth=1.2).leg_length == 1.1
    c = b.with_shape(leg_length=0.9)
    assert c.leg_length == 0.9 and c.girth == 1.1 and c.height_m == 1.7
    assert b.shape_key != BodyModel(1.7, girth=1.1).shape_key
    assert BodyModel(1.7, girth=1.1, leg_length=1.1).shape_key == b.shape_key
    assert "leg_length=1.1" in repr(b) and "leg_length" not in repr(BodyModel(1.7))
    for bad in (0.5, 1.5, float("nan")):
        with pytest.raises(ValueError, match="leg_length"):
            BodyModel(1.7, leg_length=bad)


def test_hem_adds_one_flared_volume_per_thigh() -> None:
    from tracker.body import CAPSULE_NAMES, HEM_CAPSULE_NAMES

    a = BodyModel(1.7, girth=1.2, part_girths={"thighs": 1.5}, leg_length=1.1)
    b = a.with_shape(hem=(0.8, 0.07))
    assert b.hem == (0.8, 0.07) and a.hem is None
    assert b.capsule_names == CAPSULE_NAMES + HEM_CAPSULE_NAMES
    assert b.radii.shape == (N_CAPSULES + 2, 2)
    np.testing.assert_array_equal(b.radii[:N_CAPSULES], a.radii)  # the body is unchanged
    pose = a.neutral_pose()
    pose[DOF["l_hip_flexion"]], pose[DOF["r_hip_flexion"]] = np.radians(25), np.radians(-10)
    pose[DOF["l_knee_flexion"]] = np.radians(30)
    np.testing.assert_array_equal(b.forward(pose), a.forward(pose))
    ka = a.forward(pose)[0]
    ca, cb = b.capsules(pose[None])
    thigh_len = b.segment_lengths["thigh"]
    for k, side in enumerate(("left", "right")):
        i = N_CAPSULES + k
        thigh = CAPSULE_NAMES.index(f"{side}_thigh")
        # from the hip joint down the thigh's axis to 0.8 of its length, flaring to 0.07 H
        assert ca[0, i] == pytest.approx(ka[KP[f"{side}_hip"]])
        expect = ka[KP[f"{side}_hip"]] + 0.8 * (ka[KP[f"{side}_knee"]] - ka[KP[f"{side}_hip"]])
        assert cb[0, i] == pytest.approx(expect)
        assert np.linalg.norm(cb[0, i] - ca[0, i]) == pytest.approx(0.8 * thigh_len)
        assert b.radii[i, 0] == pytest.approx(b.radii[thigh, 0])
        assert b.radii[i, 1] == pytest.approx(0.07 * 1.7 * 1.2)
        assert b.capsule_groups[i] == k + 1  # moves with its leg: the factorisation holds
        assert i in (b.left_leg_capsules if k == 0 else b.right_leg_capsules)
    # with_shape keeps the hem unless told; None removes it
    assert b.with_shape(girth=1.0).hem == (0.8, 0.07)
    assert b.with_shape(hem=None).shape_key == a.shape_key
    assert b.shape_key != a.shape_key and "hem=(0.8, 0.07)" in repr(b) and "hem" not in repr(a)
    for bad in ((0.1, 0.07), (0.8, 0.5), (float("nan"), 0.07)):
        with pytest.raises(ValueError, match="hem"):
            BodyModel(1.7, hem=bad)


def test_hem_config_is_checked_at_the_edge() -> None:
    """The tracker's configuration rejects the hems the body model would (before tracking)."""
    from pydantic import ValidationError

    from tracker.body import HEM_LENGTH_RANGE, HEM_RADIUS_RANGE
    from tracker.config import _HEM_RANGES, TrackerConfig

    assert _HEM_RANGES == (HEM_LENGTH_RANGE, HEM_RADIUS_RANGE)
    ok = TrackerConfig(init={"hems": [[1.0, 0.08], [0.5, 0.06]]})
    assert ok.init.hems == ((1.0, 0.08), (0.5, 0.06))
    for bad in ([[2.0, 0.08]], [[1.0, 0.3]], [[1.0]], [[float("nan"), 0.08]]):
        with pytest.raises(ValidationError, match="hems"):
            TrackerConfig(init={"hems": bad})


@pytest.mark.parametrize(("h", "g"), [(0.2, 1.0), (3.0, 1.0), (float("nan"), 1.0), (1.7, 0.0)])
def test_bad_body_parameters(h: float, g: float) -> None:
    with pytest.raises(ValueError, match="height_m|girth"):
        BodyModel(h, g)


def test_bad_pose_shape(body: BodyModel) -> None:
    with pytest.raises(ValueError, match="31"):
        body.forward(np.zeros((4, 30)))


def test_points_of_one_group_are_bit_identical(body: BodyModel) -> None:
    poses = _random_poses(body, np.random.default_rng(7), 50, "general")
    full = body.points(poses)
    for group in (0, 1, 2):
        part = body.points(poses, group=group)
        caps = np.flatnonzero(body.capsule_groups == group)
        ends = body.cap_ab[caps].ravel()
        np.testing.assert_array_equal(part[:, ends], full[:, ends])
        computed = ~np.isnan(part[0, :, 0])
        np.testing.assert_array_equal(part[:, computed], full[:, computed])
    head = body.capsule_names.index("head")
    assert np.isnan(body.points(poses, group=1)[:, body.cap_ab[head]]).all()


def test_sincos_matches_libm() -> None:
    import numba

    from tracker.body import sincos

    @numba.njit
    def _many(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = np.empty_like(x)
        c = np.empty_like(x)
        for i in range(x.size):
            s[i], c[i] = sincos(x[i])
        return s, c

    rng = np.random.default_rng(8)
    x = np.concatenate([rng.uniform(-7, 7, 20000), [0.0, np.pi / 4, np.pi / 2, -np.pi, 2e5]])
    s, c = _many(x)
    np.testing.assert_allclose(s, np.sin(x), rtol=0, atol=3e-16)
    np.testing.assert_allclose(c, np.cos(x), rtol=0, atol=3e-16)
    s, c = _many(np.array([np.nan, np.inf]))
    assert np.isnan(s).all() and np.isnan(c).all()
