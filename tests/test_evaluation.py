"""Tracking metrics (gaitwatch.evaluation): known error in, same error out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gait.kinematics import knee_flexion
from gaitwatch.conventions import (
    HEAD,
    KP,
    L_ANKLE,
    L_ELBOW,
    L_HEEL,
    L_HIP,
    L_KNEE,
    L_TOE,
    L_WRIST,
    NECK,
    R_ANKLE,
    R_HEEL,
    R_HIP,
    R_KNEE,
    R_TOE,
    R_WRIST,
    SACRUM,
)
from gaitwatch.evaluation import (
    JOINT_GROUPS,
    LEFT_LEG,
    LOWER_LIMB,
    RIGHT_LEG,
    align,
    evaluate,
    foot_pitch_deg,
    leg_swaps,
    offset_split,
    pool,
    stance_bias,
    swap_legs,
    truth_forward,
)
from gaitwatch.trajectory import Trajectory

FPS = 20.0


def walker(n: int = 60, seed: int = 0) -> Trajectory:
    """A person walking along +x at 1.1 m/s, legs in anti-phase, knees never straight."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FPS
    ph = 2 * np.pi * 0.9 * t + rng.uniform(0, 2 * np.pi)
    p = np.zeros((n, 19, 3))
    p[:, SACRUM] = np.stack([1.1 * t, 0.02 * np.sin(ph), 0.95 + 0.02 * np.cos(2 * ph)], -1)
    p[:, NECK] = p[:, SACRUM] + [0.03, 0.0, 0.55]
    p[:, HEAD] = p[:, NECK] + [0.02, 0.0, 0.2]
    for side, sgn, phase in (("left", 1.0, 0.0), ("right", -1.0, np.pi)):
        hip_f = np.radians(10 + 25 * np.sin(ph + phase))  # thigh forward of vertical
        knee_f = np.radians(35 + 27 * np.sin(ph + phase - 1.2))  # 8..62 degrees
        hip = p[:, SACRUM] + [0.0, sgn * 0.09, -0.08]
        thigh = 0.44 * np.stack([np.sin(hip_f), 0 * hip_f, -np.cos(hip_f)], -1)
        shank_a = hip_f - knee_f
        shank = 0.42 * np.stack([np.sin(shank_a), 0 * hip_f, -np.cos(shank_a)], -1)
        knee = hip + thigh
        ankle = knee + shank
        p[:, KP[f"{side}_hip"]] = hip
        p[:, KP[f"{side}_knee"]] = knee
        p[:, KP[f"{side}_ankle"]] = ankle
        p[:, KP[f"{side}_heel"]] = ankle + [-0.05, 0.0, -0.07]
        p[:, KP[f"{side}_toe"]] = ankle + [0.15, 0.0, -0.07]
        sh = p[:, NECK] + [0.0, sgn * 0.19, -0.03]
        p[:, KP[f"{side}_shoulder"]] = sh
        arm = np.radians(-15 * np.sin(ph + phase))
        p[:, KP[f"{side}_elbow"]] = sh + 0.29 * np.stack([np.sin(arm), 0 * arm, -np.cos(arm)], -1)
        p[:, KP[f"{side}_wrist"]] = p[:, KP[f"{side}_elbow"]] + [0.08, 0.0, -0.24]
    return Trajectory(positions=p, times=t, frames=np.arange(n), fps=FPS, source="walker")


def copy_traj(tr: Trajectory, positions=None, keep=None) -> Trajectory:
    keep = np.arange(len(tr)) if keep is None else np.asarray(keep)
    pos = tr.positions if positions is None else positions
    return Trajectory(
        positions=np.array(pos)[keep], times=tr.times[keep], frames=tr.frames[keep], fps=tr.fps
    )


def rotate(v: np.ndarray, axis: np.ndarray, ang: float) -> np.ndarray:
    """Rodrigues rotation of vectors (N, 3) about unit axes (N, 3)."""
    c, s = math.cos(ang), math.sin(ang)
    return v * c + np.cross(axis, v) * s + axis * np.sum(axis * v, -1, keepdims=True) * (1 - c)


def test_translation_gives_exact_error_everywhere() -> None:
    truth = walker()
    offset = np.array([0.03, -0.04, 0.012])  # |offset| = 51.4 mm
    m = evaluate(truth, copy_traj(truth, truth.positions + offset))
    expected = 1000 * np.linalg.norm(offset)
    assert m.mpjpe_mm == pytest.approx(expected, abs=1e-9)
    assert m.lower_limb_mm == pytest.approx(expected, abs=1e-9)
    for g in JOINT_GROUPS:
        assert m.group_mm[g] == pytest.approx(expected, abs=1e-9)
    np.testing.assert_allclose(m.per_joint_mm, expected, atol=1e-9)
    # a translation does not change joint angles; legs are not swapped; nothing lost
    assert m.knee_flexion_rmse_deg == pytest.approx(0, abs=1e-6)
    assert m.hip_flexion_rmse_deg == pytest.approx(0, abs=1e-6)
    assert m.swap_frames == 0 and m.frames_lost == 0 and m.n_tracked == len(truth)


def test_error_on_one_group_only() -> None:
    truth = walker()
    est = truth.positions.copy()
    est[:, [L_ELBOW, L_WRIST]] += [0.0, 0.0, 0.1]  # left arm 100 mm too high
    m = evaluate(truth, copy_traj(truth, est))
    assert m.group_mm["arms"] == pytest.approx(50.0)  # 2 of its 4 points off by 100 mm
    assert m.mpjpe_mm == pytest.approx(200.0 / 19)
    assert m.lower_limb_mm == pytest.approx(0.0)
    for g in ("head_neck", "trunk", "hips", "knees", "ankles_feet"):
        assert m.group_mm[g] == pytest.approx(0.0)


def test_groups_partition_the_keypoints() -> None:
    idx = sorted(i for g in JOINT_GROUPS.values() for i in g)
    assert idx == list(range(19))
    assert set(LOWER_LIMB) == {L_HIP, R_HIP, L_KNEE, R_KNEE, L_ANKLE, R_ANKLE}.union(
        {L_HEEL, R_HEEL, L_TOE, R_TOE}
    )


@pytest.mark.parametrize("deg", [5.0, 12.0])
def test_shank_rotation_gives_that_knee_angle_error(deg: float) -> None:
    truth = walker()
    p = truth.positions
    est = p.copy()
    knee, ankle = p[:, R_KNEE], p[:, R_ANKLE]
    thigh = knee - p[:, R_HIP]
    shank = ankle - knee
    axis = np.cross(thigh, shank)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    ang = math.radians(deg)
    for j in (R_ANKLE, R_HEEL, R_TOE):  # the whole shank and foot turn about the knee
        est[:, j] = knee + rotate(p[:, j] - knee, axis, ang)
    np.testing.assert_allclose(
        knee_flexion(est, "right") - knee_flexion(p, "right"), deg, atol=1e-9
    )
    m = evaluate(truth, copy_traj(truth, est))
    assert m.angle_rmse_deg["knee_right"] == pytest.approx(deg, abs=1e-6)
    assert m.angle_rmse_deg["knee_left"] == pytest.approx(0.0, abs=1e-9)
    assert m.knee_flexion_rmse_deg == pytest.approx(deg / math.sqrt(2), abs=1e-6)
    assert m.hip_flexion_rmse_deg == pytest.approx(0.0, abs=1e-6)
    # the ankle moved on a circle of the shank's length: chord 2 L sin(angle / 2)
    chord = 2 * np.linalg.norm(shank, axis=1) * math.sin(ang / 2) * 1000
    assert m.per_joint_mm[R_ANKLE] == pytest.approx(chord.mean(), rel=1e-9)
    assert m.per_joint_mm[R_KNEE] == pytest.approx(0.0)


@pytest.mark.parametrize("deg", [4.0, 15.0])
def test_knees_bent_further_give_that_stance_bias(deg: float) -> None:
    truth = walker()
    p = truth.positions
    est = p.copy()
    for hip, knee, ankle, heel, toe in (
        (L_HIP, L_KNEE, L_ANKLE, L_HEEL, L_TOE),
        (R_HIP, R_KNEE, R_ANKLE, R_HEEL, R_TOE),
    ):
        axis = np.cross(p[:, knee] - p[:, hip], p[:, ankle] - p[:, knee])
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        for j in (ankle, heel, toe):  # shank and foot turn about the knee: the knee bends
            est[:, j] = p[:, knee] + rotate(p[:, j] - p[:, knee], axis, math.radians(deg))
    flat = [
        (p[:, h, 2] < 0.04) & (p[:, t, 2] < 0.06) for h, t in ((L_HEEL, L_TOE), (R_HEEL, R_TOE))
    ]
    assert 0 < np.mean(flat) < 1  # the walker has stance and swing
    b = stance_bias(p, est)
    assert b["share"] == pytest.approx(np.mean(flat))
    assert b["knee_deg"] == pytest.approx(deg, abs=1e-9)
    assert b["pitch_deg"] == pytest.approx(-deg, abs=1e-9)  # the toe points down
    # only the frames with the foot flat count: a swing-only error is not seen
    swing = p.copy()
    off = ~flat[0]
    swing[off, L_TOE] = swing[off, L_TOE] + [0.0, 0.0, 0.1]
    assert stance_bias(p, swing)["pitch_deg"] == pytest.approx(0.0, abs=1e-12)
    assert np.nanmax(np.abs(foot_pitch_deg(swing, "left") - foot_pitch_deg(p, "left"))) > 10


def test_stance_bias_without_a_foot_on_the_floor() -> None:
    p = walker().positions + [0.0, 0.0, 0.3]
    b = stance_bias(p, p)
    assert b["share"] == 0.0 and math.isnan(b["knee_deg"]) and math.isnan(b["pitch_deg"])


def test_a_fixed_offset_per_key_point_is_all_constant() -> None:
    p = walker().positions
    rng = np.random.default_rng(3)
    offsets = rng.normal(0.0, 0.04, (19, 3))  # metres, one vector per key point
    split = offset_split(p, p + offsets)
    assert split["constant_mm"] == pytest.approx(
        np.linalg.norm(offsets, axis=1).mean() * 1000, rel=1e-9
    )
    assert split["varying_mm"] == pytest.approx(0.0, abs=1e-9)


def test_an_offset_and_a_zero_mean_error_are_told_apart() -> None:
    p = walker(n=40).positions
    est = p.copy()
    est[:, L_KNEE] += [0.03, 0.0, 0.0]  # 30 mm forward, every frame
    sign = np.where(np.arange(40) % 2 == 0, 1.0, -1.0)
    est[:, R_WRIST] += sign[:, None] * [0.0, 0.0, 0.05]  # 50 mm up and down in turn
    est[5, HEAD] = np.nan  # unknown points are left out, not scored as errors
    split = offset_split(p, est)
    assert split["constant_mm"] == pytest.approx(30.0 / 19, rel=1e-9)
    # only the wrist varies: 50 mm in each of its 40 frames, over 40 x 19 - 1 known pairs
    assert split["varying_mm"] == pytest.approx(50.0 * 40 / (40 * 19 - 1), rel=1e-9)


def test_offset_split_of_nothing_known() -> None:
    p = walker(n=5).positions
    split = offset_split(p, np.full_like(p, np.nan))
    assert math.isnan(split["constant_mm"]) and math.isnan(split["varying_mm"])


def test_thigh_rotation_gives_that_hip_angle_error() -> None:
    truth = walker()
    p = truth.positions
    est = p.copy()
    hip = p[:, L_HIP]
    # about the walker's left (the normal of the sagittal plane hip flexion is measured in),
    # a negative angle swings the leg forward
    axis = np.cross([0.0, 0.0, 1.0], truth_forward(truth))
    ang = math.radians(-8.0)
    for j in (L_KNEE, L_ANKLE, L_HEEL, L_TOE):  # the whole leg turns about the hip
        est[:, j] = hip + rotate(p[:, j] - hip, axis, ang)
    m = evaluate(truth, copy_traj(truth, est))
    assert m.angle_rmse_deg["hip_left"] == pytest.approx(8.0, abs=1e-6)
    assert m.angle_rmse_deg["hip_right"] == pytest.approx(0.0, abs=1e-9)
    assert m.knee_flexion_rmse_deg == pytest.approx(0.0, abs=1e-6)


def test_swapped_legs_on_some_frames_give_that_rate() -> None:
    truth = walker(n=40)
    rng = np.random.default_rng(1)
    est = truth.positions + rng.normal(0, 0.01, truth.positions.shape)  # 10 mm jitter
    swapped = [3, 7, 8, 20, 33]
    est[swapped] = swap_legs(est[swapped])
    m = evaluate(truth, copy_traj(truth, est))
    assert m.swap_frames == len(swapped)
    assert m.swap_rate == pytest.approx(len(swapped) / 40)
    flags = leg_swaps(truth.positions, est)
    assert sorted(np.flatnonzero(flags)) == swapped


def test_swap_needs_both_margins() -> None:
    truth = walker(n=10)
    # legs swapped but the estimate is far off anyway: the swap lowers the error by less than
    # 30 % of it -> not counted
    far = swap_legs(truth.positions) + [0.0, 0.0, 0.6]
    assert not leg_swaps(truth.positions, far).any()
    # a swap that helps by 100 % of the error but only by 40 mm -> not counted
    close = truth.positions.copy()
    close[:, RIGHT_LEG] = close[:, LEFT_LEG] + [0.0, -0.04, 0.0]  # legs 40 mm apart
    near = swap_legs(close)
    assert evaluate(copy_traj(truth, close), copy_traj(truth, near)).lower_limb_mm == (
        pytest.approx(40.0)
    )
    assert not leg_swaps(close, near).any()
    assert leg_swaps(close, near, absolute_mm=30.0).all()


def test_dropped_frames_count_as_lost_not_as_error() -> None:
    truth = walker(n=50)
    offset = np.array([0.0, 0.02, 0.0])
    keep = np.setdiff1d(np.arange(50), [0, 10, 11, 12, 49])
    m = evaluate(truth, copy_traj(truth, truth.positions + offset, keep=keep))
    assert m.frames_lost == 5
    assert m.n_tracked == 45
    assert m.lost_fraction == pytest.approx(0.1)
    assert m.mpjpe_mm == pytest.approx(20.0)
    # a frame whose estimate is all NaN is lost too
    est = truth.positions + offset
    est[5] = np.nan
    m2 = evaluate(truth, copy_traj(truth, est))
    assert m2.frames_lost == 1 and m2.mpjpe_mm == pytest.approx(20.0)


def test_nothing_tracked() -> None:
    truth = walker(n=10)
    empty = Trajectory(positions=np.zeros((0, 19, 3)), times=np.zeros(0), frames=[])
    m = evaluate(truth, empty)
    assert m.frames_lost == 10 and m.n_tracked == 0
    assert math.isnan(m.mpjpe_mm) and math.isnan(m.knee_flexion_rmse_deg)
    assert math.isnan(m.swap_rate)
    row = m.to_row()
    assert row["frames_lost"] == 10 and row["lost_fraction"] == 1.0


def test_alignment_by_frame_number_and_by_time() -> None:
    truth = walker(n=30)
    # the estimate starts at frame 4 of the same footage
    keep = np.arange(4, 30)
    est = copy_traj(truth, truth.positions + [0.01, 0, 0], keep=keep)
    it, ie = align(truth, est)
    np.testing.assert_array_equal(it, keep)
    np.testing.assert_array_equal(ie, np.arange(26))
    # numbered from 0 but time-stamped: time matching pairs them within half a frame
    shifted = Trajectory(
        positions=est.positions, times=est.times + 0.2 / FPS, frames=np.arange(26), fps=FPS
    )
    m = evaluate(truth, shifted, match="time")
    assert m.frames_lost == 4 and m.mpjpe_mm == pytest.approx(10.0)
    assert evaluate(truth, shifted).mpjpe_mm > 10.0  # by frame number they are misaligned


def test_timing_carried_and_row() -> None:
    truth = walker(n=20)
    m = evaluate(truth, copy_traj(truth), ms_per_frame=123.0, evaluations_per_frame=6561)
    row = m.to_row()
    assert row["ms_per_frame"] == 123.0 and row["evals_per_frame"] == 6561
    assert {f"{g}_mm" for g in JOINT_GROUPS} <= set(row)
    assert {"all_mm", "lower_mm", "hip_rmse_deg", "knee_rmse_deg", "swap_rate"} <= set(row)


def test_pool_weights_by_frames() -> None:
    a_truth, b_truth = walker(n=30, seed=1), walker(n=10, seed=2)
    a = evaluate(a_truth, copy_traj(a_truth, a_truth.positions + [0.01, 0, 0]))
    est_b = b_truth.positions + [0.05, 0, 0]
    est_b[[2, 5]] = swap_legs(est_b[[2, 5]])
    b = evaluate(b_truth, copy_traj(b_truth, est_b, keep=np.arange(8)), ms_per_frame=10.0)
    p = pool([a, b])
    assert p.n_truth_frames == 40 and p.n_tracked == 38 and p.frames_lost == 2
    assert p.swap_frames == b.swap_frames == 2
    # hip/knee unaffected by translation; swapped frames give b its angle errors
    assert p.mpjpe_mm == pytest.approx((30 * a.mpjpe_mm + 8 * b.mpjpe_mm) / 38)
    sq = [
        (m.angle_rmse_deg[k] ** 2, m.n_angle_samples[k])
        for m in (a, b)
        for k in ("knee_left", "knee_right")
    ]
    expect = math.sqrt(sum(v * n for v, n in sq) / sum(n for _, n in sq))
    assert p.knee_flexion_rmse_deg == pytest.approx(expect)
    assert b.knee_flexion_rmse_deg > 0
    single = pool([b])
    assert single.mpjpe_mm == pytest.approx(b.mpjpe_mm)
    assert single.knee_flexion_rmse_deg == pytest.approx(b.knee_flexion_rmse_deg)


def test_real_recording_leg_swap(shared_data) -> None:
    """On a real walk, swapping every frame's legs is caught wherever the legs are apart."""
    from gaitwatch.mocap import load_mocap

    truth = load_mocap(shared_data / "cmu" / "07_06.bvh")
    est = swap_legs(truth.positions)
    apart = (
        np.linalg.norm(
            truth.positions[:, LOWER_LIMB[::2]] - truth.positions[:, LOWER_LIMB[1::2]], axis=-1
        ).mean(1)
        * 1000
    )
    m = evaluate(truth, copy_traj(truth, est))
    assert m.swap_rate > 0.9
    # hip separation alone is > 100 mm, so the mean swapped lower-limb error exceeds 50 mm
    assert np.all(apart > 100)
    assert m.group_mm["head_neck"] == pytest.approx(0.0)
    assert m.group_mm["arms"] == pytest.approx(0.0)
