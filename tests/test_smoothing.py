"""Fixed-lag key-point smoothing (tracker.smoothing)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import savgol_filter

from gaitwatch.conventions import KEYPOINTS
from tracker.config import SmoothingConfig
from tracker.smoothing import (
    FEET,
    KNEES,
    UPPER,
    KeypointSmoother,
    local_fit,
    sideways_offset,
    single_camera_eye,
    smooth_keypoints,
    window_frames,
)

FPS = 20.0


def _stream(sm: KeypointSmoother, times, joints, restarts=None):
    """Push every frame; returns [(item, joints or None)] in output order and the lags."""
    out, lags = [], []
    for k, (t, j) in enumerate(zip(times, joints, strict=True)):
        r = bool(restarts[k]) if restarts is not None else False
        done = sm.push(t, j, item=k, restart=r)
        lags += [k - f.item for f in done]
        out += [(f.item, f.joints) for f in done]
    out += [(f.item, f.joints) for f in sm.flush()]
    return out, lags


def test_window_frames() -> None:
    assert window_frames(0.45, 20.0) == 9
    assert window_frames(0.4, 20.0) == 9  # 8 -> the next odd number
    assert window_frames(0.45, 30.0) == 15  # 13.5 rounds to 14 -> 15
    assert window_frames(0.01, 20.0) == 1
    with pytest.raises(ValueError, match="fps"):
        window_frames(0.45, 0.0)


def test_interior_is_savitzky_golay_and_lag_is_half_a_window() -> None:
    rng = np.random.default_rng(0)
    T = 30
    times = np.arange(T) / FPS
    joints = rng.normal(size=(T, 19, 3))
    sm = KeypointSmoother(9, 2)
    out, lags = _stream(sm, times, joints)
    assert [i for i, _ in out] == list(range(T))  # every frame once, in order
    assert set(lags) == {4}  # each frame is final 4 frames (half a window) after it came in
    got = np.stack([j for _, j in out])
    ref = savgol_filter(joints, 9, 2, axis=0)
    np.testing.assert_allclose(got[4:-4], ref[4:-4], atol=1e-12)


def test_motion_of_low_order_passes_unchanged_and_noise_is_reduced() -> None:
    rng = np.random.default_rng(1)
    T = 40
    t = np.arange(T) / FPS
    # a walk: constant speed forward plus a quadratic rise; exact for an order-2 fit
    truth = np.zeros((T, 19, 3))
    truth[..., 0] = 1.2 * t[:, None]
    truth[..., 2] = 0.9 + 0.1 * t[:, None] ** 2
    cfg = SmoothingConfig(window_s=0.45, order=2)
    np.testing.assert_allclose(smooth_keypoints(t, truth, cfg, FPS), truth, atol=1e-9)
    noisy = truth + rng.normal(scale=0.03, size=truth.shape)
    smoothed = smooth_keypoints(t, noisy, cfg, FPS)
    err_raw = np.linalg.norm(noisy - truth, axis=-1).mean()
    err_smooth = np.linalg.norm(smoothed - truth, axis=-1).mean()
    assert err_smooth < 0.7 * err_raw, (err_raw, err_smooth)


def test_segments_are_not_mixed() -> None:
    """A frame without a pose, a restart or a gap in time ends a segment: two tracks at
    different places stay where they are."""
    sm = KeypointSmoother(9, 2, max_gap_s=0.5)
    a, b = np.zeros((19, 3)), np.ones((19, 3))
    times = [0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35]
    joints = [a, a, a, None, b, b, b, b]
    out, _ = _stream(sm, times, joints)
    assert [i for i, _ in out] == list(range(8))
    assert out[3][1] is None
    for _, j in out[:3]:
        np.testing.assert_allclose(j, a, atol=1e-12)
    for _, j in out[4:]:
        np.testing.assert_allclose(j, b, atol=1e-12)
    # a restart (re-initialised track) without a missing frame
    sm = KeypointSmoother(9, 2)
    out, _ = _stream(sm, times[:6], [a, a, a, b, b, b], restarts=[0, 0, 0, 1, 0, 0])
    assert np.allclose(out[2][1], a) and np.allclose(out[3][1], b)
    # a gap in time longer than max_gap_s
    sm = KeypointSmoother(9, 2, max_gap_s=0.5)
    out, _ = _stream(sm, [0.0, 0.05, 0.1, 2.0, 2.05], [a, a, a, b, b])
    assert np.allclose(out[2][1], a) and np.allclose(out[3][1], b)


def test_whole_footage_form_breaks_at_missing_frames() -> None:
    """``frames``: a frame number that does not follow the previous one starts a segment, as a
    frame without a pose does in the stream."""
    a, b = np.zeros((19, 3)), np.ones((19, 3))
    joints = np.stack([a, a, a, b, b, b])
    times = np.array([0.0, 0.05, 0.1, 0.2, 0.25, 0.3])  # frame 3 (0.15 s) had no pose
    cfg = SmoothingConfig()
    mixed = smooth_keypoints(times, joints, cfg, FPS)
    assert not np.allclose(mixed[2], a)  # one segment: the two places blur together
    split = smooth_keypoints(times, joints, cfg, FPS, frames=np.array([0, 1, 2, 4, 5, 6]))
    np.testing.assert_allclose(split, joints, atol=1e-12)


def test_single_frame_segments_and_window_one_pass_through() -> None:
    rng = np.random.default_rng(2)
    j = rng.normal(size=(19, 3))
    sm = KeypointSmoother(9, 2)
    out, _ = _stream(sm, [0.0, 0.05, 0.1], [j, None, j + 1])
    np.testing.assert_array_equal(out[0][1], j)
    np.testing.assert_array_equal(out[2][1], j + 1)
    joints = rng.normal(size=(5, 19, 3))
    sm = KeypointSmoother(1, 2)
    out, lags = _stream(sm, np.arange(5) / FPS, joints)
    assert set(lags) == {0}
    np.testing.assert_array_equal(np.stack([o[1] for o in out]), joints)
    off = smooth_keypoints(np.arange(5) / FPS, joints, SmoothingConfig(enabled=False), FPS)
    np.testing.assert_array_equal(off, joints)


def test_flush_returns_everything_pending_and_items_untouched() -> None:
    sm = KeypointSmoother(9, 2)
    payloads = [{"frame": k} for k in range(3)]
    done = []
    for k, p in enumerate(payloads):
        done += sm.push(k / FPS, np.full((19, 3), float(k)), item=p)
    assert done == []  # nothing final yet: the window is not full
    rest = sm.flush()
    assert [f.item for f in rest] == payloads and rest[0].item is payloads[0]
    assert sm.flush() == []


def test_local_fit_lowers_the_order_when_few_points() -> None:
    v = np.array([[1.0], [3.0]])
    assert local_fit(np.array([0.0, 1.0]), v, 0.0, 2)[0] == pytest.approx(1.0)  # a line
    assert local_fit(np.array([0.0]), v[:1], 0.0, 2)[0] == pytest.approx(1.0)


@pytest.mark.parametrize(("window", "order"), [(0, 2), (8, 2), (9, 5), (9, -1)])
def test_bad_parameters(window: int, order: int) -> None:
    with pytest.raises(ValueError, match="window|order"):
        KeypointSmoother(window, order)


def test_bad_feet_order() -> None:
    with pytest.raises(ValueError, match="feet_order"):
        KeypointSmoother(9, 2, feet_order=5)
    with pytest.raises(ValueError):
        SmoothingConfig(feet_order=-1)


def _random_feet_quartic(seed: int, T: int):
    """Random key points through a 9-frame smoother with a quartic for the feet: (times,
    joints, smoothed)."""
    rng = np.random.default_rng(seed)
    times = np.arange(T) / FPS
    joints = rng.normal(size=(T, 19, 3))
    out, _ = _stream(KeypointSmoother(9, 2, feet_order=4), times, joints)
    return times, joints, np.stack([j for _, j in out])


def test_feet_have_their_own_order() -> None:
    """Ankles, heels and toes are fitted with ``feet_order``, every other key point with
    ``order``; ``feet_order`` None is ``order``."""
    times, joints, got = _random_feet_quartic(seed=3, T=30)
    rest = [k for k in range(19) if k not in FEET]
    assert len(FEET) == 6 and {KEYPOINTS[k].split("_")[1] for k in FEET} == {"ankle", "heel", "toe"}
    np.testing.assert_allclose(
        got[4:-4, rest], savgol_filter(joints, 9, 2, axis=0)[4:-4, rest], atol=1e-12
    )
    np.testing.assert_allclose(
        got[4:-4, FEET], savgol_filter(joints, 9, 4, axis=0)[4:-4, FEET], atol=1e-12
    )
    same, _ = _stream(KeypointSmoother(9, 2, feet_order=None), times, joints)
    plain, _ = _stream(KeypointSmoother(9, 2), times, joints)
    np.testing.assert_array_equal(np.stack([j for _, j in same]), np.stack([j for _, j in plain]))
    # the configured smoother (the default feet_order is 4) does the same
    cfg_out = smooth_keypoints(times, joints, SmoothingConfig(), FPS)
    np.testing.assert_allclose(cfg_out[4:-4], got[4:-4], atol=1e-12)


def test_feet_order_keeps_a_heel_strike() -> None:
    """A heel that swings forward and stops dead at contact (the kink gait events are read
    from): around the contact the quartic fit misses the heel by about half as much as the
    quadratic (10 against 19 mm)."""
    T = 41
    times = np.arange(T) / FPS
    contact = times[20]
    x = np.where(times < contact, 1.0 * (times - contact), 0.0)  # 1 m/s forward, then at rest
    joints = np.zeros((T, 19, 3))
    joints[:, FEET, 0] = x[:, None]
    quad = smooth_keypoints(times, joints, SmoothingConfig(feet_order=2), FPS)[:, FEET[1], 0]
    quart = smooth_keypoints(times, joints, SmoothingConfig(feet_order=4), FPS)[:, FEET[1], 0]
    around = slice(17, 24)  # 0.15 s either side of the contact
    err_quad = np.abs(quad[around] - x[around]).max()
    err_quart = np.abs(quart[around] - x[around]).max()
    assert err_quart < 0.6 * err_quad, (err_quad, err_quart)


def test_stream_equals_the_local_fit_of_each_frame() -> None:
    """The stream's cached fit weights give each frame the fit of its own window, the
    segment's ends (shorter windows) included, for the feet's order as for the rest."""
    T = 25
    times, joints, got = _random_feet_quartic(seed=5, T=T)
    for k in range(T):
        lo, hi = max(0, k - 4), min(T, k + 5)
        ref = local_fit(times[lo:hi], joints[lo:hi], times[k], 2)
        ref[FEET] = local_fit(times[lo:hi], joints[lo:hi][:, FEET], times[k], 4)
        np.testing.assert_allclose(got[k], ref, atol=1e-12)


# -- depth through one camera -------------------------------------------------------------------
EYE = np.array([0.0, -5.0, 2.5])  # a camera 5 m from the walk's line, 2.5 m up


def _walk_with_depth_jitter(seed: int = 0, T: int = 40):
    """A rigid 19-point body walking across at 1.2 m/s, each frame moved along its horizontal
    line of sight from EYE by +-10 cm of noise: (times, clean, jittered, the noise)."""
    rng = np.random.default_rng(seed)
    times = np.arange(T) / FPS
    shape = rng.normal(scale=0.15, size=(19, 3)) + [0.0, 0.0, 1.0]
    clean = shape[None] + np.stack([1.2 * times - 1.0, 0.05 * times, 0 * times], axis=1)[:, None]
    noise = rng.normal(scale=0.1, size=T)
    sight = clean.mean(axis=1)[:, :2] - EYE[:2]
    sight /= np.linalg.norm(sight, axis=1, keepdims=True)
    jittered = clean.copy()
    jittered[..., :2] += (noise[:, None] * sight)[:, None]
    return times, clean, jittered, noise


def test_depth_stage_removes_jitter_along_the_line_of_sight_only() -> None:
    """With the camera's centre given, each frame's key points move together along the line
    of sight onto the distance fitted over the longer window: the depth jitter shrinks, the
    body keeps its shape and nothing moves across the line of sight."""
    times, clean, jittered, _ = _walk_with_depth_jitter()
    cfg = SmoothingConfig(balance=0.0)  # the balance step moves the upper body alone: below
    assert cfg.depth_window_s == 0.75 and cfg.depth_order == 1
    plain = smooth_keypoints(times, jittered, cfg, FPS)  # no camera centre: no depth stage
    deep = smooth_keypoints(times, jittered, cfg, FPS, eye=EYE)
    err = lambda x: float(np.linalg.norm(x - clean, axis=-1).mean())  # noqa: E731
    # measured: 43 mm with the key points' own 0.45 s fit, 27 mm with the depth stage
    assert err(deep) < 0.75 * err(plain), (err(deep), err(plain))
    move = deep - plain
    assert np.allclose(move, move[:, :1], atol=1e-12)  # one move per frame: the shape stays
    assert np.allclose(move[..., 2], 0.0)  # horizontal
    sight = plain.mean(axis=1)[:, :2] - EYE[:2]
    cross = move[:, 0, 0] * sight[:, 1] - move[:, 0, 1] * sight[:, 0]
    assert np.allclose(cross, 0.0, atol=1e-12)  # along the line of sight
    assert np.abs(move).max() > 0.01
    # off: depth_window_s 0, or the stage not asked for (two cameras: single_camera_eye None)
    off = cfg.model_copy(update={"depth_window_s": 0.0})
    assert np.array_equal(smooth_keypoints(times, jittered, off, FPS, eye=EYE), plain)


def test_depth_stage_lags_by_its_half_window_and_streams_like_the_whole_footage() -> None:
    times, _, jittered, _ = _walk_with_depth_jitter(seed=1, T=30)
    sm = KeypointSmoother.from_config(SmoothingConfig(), FPS, eye=EYE)
    assert (sm.half, sm.depth_half, sm.lag) == (4, 7, 7)  # 9 and 15 frames at 20 fps
    out, lags = _stream(sm, times, jittered)
    assert [k for k, _ in out] == list(range(30))
    assert set(lags) == {7}
    whole = smooth_keypoints(times, jittered, SmoothingConfig(), FPS, eye=EYE)
    np.testing.assert_allclose(np.stack([j for _, j in out]), whole, atol=1e-12)
    # walking straight away from the camera at constant speed, the distance is linear in
    # time, and the linear depth fit leaves the frames as they were
    away = np.stack([0 * times, 3.0 + 1.2 * times, 1.0 + 0 * times], axis=1)[:, None]
    away = away + np.zeros((1, 19, 3))
    np.testing.assert_allclose(
        smooth_keypoints(times, away, SmoothingConfig(), FPS, eye=np.zeros(3)), away, atol=1e-9
    )


def test_single_camera_eye_and_bad_depth_parameters() -> None:
    class Cam:
        def __init__(self, c):
            self.center = np.asarray(c, dtype=float)

    assert np.array_equal(single_camera_eye([Cam([1, 2, 3])]), [1.0, 2.0, 3.0])
    assert single_camera_eye([Cam([1, 2, 3]), Cam([0, 0, 3])]) is None
    with pytest.raises(ValueError, match="depth_window"):
        KeypointSmoother(9, 2, eye=EYE, depth_window=14)
    with pytest.raises(ValueError, match="depth_order"):
        KeypointSmoother(9, 2, eye=EYE, depth_window=15, depth_order=5)
    with pytest.raises(ValueError, match="eye"):
        KeypointSmoother(9, 2, eye=[np.nan, 0, 0], depth_window=15)
    with pytest.raises(ValueError):
        SmoothingConfig(depth_window_s=-1.0)


# -- balance through one camera -----------------------------------------------------------------
def _standing_body(sideways: float = 0.0) -> np.ndarray:
    """A 19-point body facing +x (left is +y), feet on the floor; everything above the feet
    (hips, trunk, arms; the knees half as far) shifted ``sideways`` metres to its left."""
    pts = {
        "head": (0.0, 0.0, 1.65),
        "neck": (0.0, 0.0, 1.45),
        "sacrum": (-0.08, 0.0, 1.0),
    }
    for side, y in (("left", 1.0), ("right", -1.0)):
        pts[f"{side}_shoulder"] = (0.0, 0.18 * y, 1.42)
        pts[f"{side}_elbow"] = (0.0, 0.2 * y, 1.15)
        pts[f"{side}_wrist"] = (0.02, 0.2 * y, 0.9)
        pts[f"{side}_hip"] = (0.0, 0.09 * y, 0.92)
        pts[f"{side}_knee"] = (0.02, 0.09 * y, 0.5)
        pts[f"{side}_ankle"] = (0.0, 0.09 * y, 0.08)
        pts[f"{side}_heel"] = (-0.05, 0.09 * y, 0.02)
        pts[f"{side}_toe"] = (0.15, 0.09 * y, 0.02)
    body = np.array([pts[n] for n in KEYPOINTS])
    body[UPPER, 1] += sideways
    body[KNEES, 1] += 0.5 * sideways
    return body


def test_sideways_offset() -> None:
    np.testing.assert_allclose(sideways_offset(_standing_body()), [0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(sideways_offset(_standing_body(0.07)), [0.0, 0.07], atol=1e-12)
    # only the component across the pelvis: the hips ahead of the feet do not count
    ahead = _standing_body(0.07)
    ahead[UPPER, 0] += 0.2
    np.testing.assert_allclose(sideways_offset(ahead), [0.0, 0.07], atol=1e-12)
    assert sideways_offset(_standing_body()[:17]) is None  # not the 19 key points
    stacked = _standing_body()
    stacked[[9, 10], :2] = 0.0  # hips one above the other: no across direction
    assert sideways_offset(stacked) is None


def test_balance_takes_back_the_sideways_offset_along_the_line_of_sight() -> None:
    """One camera: the hips and the body above them move along the line of sight until the
    pelvis's sideways offset from the feet has no component there; the knees move half as
    far, the feet not at all, and nothing moves across the line of sight. A body whose
    pelvis stands over its feet is left alone; two cameras (no eye) or balance 0: no step."""
    T = 30
    times = np.arange(T) / FPS
    eye = np.array([-3.0, -4.0, 2.5])  # the line of sight 37 deg from the walk's direction
    path = np.stack([1.2 * times, 0 * times, 0 * times], axis=1)[:, None]
    leaning = _standing_body(0.08)[None] + path
    off = SmoothingConfig(balance=0.0)
    on = SmoothingConfig()
    assert on.balance == 1.0
    before = smooth_keypoints(times, leaning, off, FPS, eye=eye)
    after = smooth_keypoints(times, leaning, on, FPS, eye=eye)
    move = after - before
    sight = 0.5 * (before[:, 9, :2] + before[:, 10, :2]) - eye[:2]
    sight /= np.linalg.norm(sight, axis=1, keepdims=True)
    expected = -(0.08 * sight[:, 1])[:, None] * sight  # -(offset . sight) sight
    for k in UPPER:
        np.testing.assert_allclose(move[:, k, :2], expected, atol=1e-9)
    for k in KNEES:
        np.testing.assert_allclose(move[:, k, :2], 0.5 * expected, atol=1e-9)
    assert np.abs(move[:, FEET]).max() < 1e-12
    assert np.abs(move[..., 2]).max() < 1e-12
    assert np.abs(expected).max() > 0.03
    for k in range(T):  # the nearest the hips get to over the feet along the line of sight
        o = sideways_offset(before[k]) + move[k, 9, :2]
        assert abs(float(o @ sight[k])) < 1e-9
    # balanced already: unchanged
    upright = _standing_body()[None] + path
    np.testing.assert_allclose(
        smooth_keypoints(times, upright, on, FPS, eye=eye),
        smooth_keypoints(times, upright, off, FPS, eye=eye),
        atol=1e-12,
    )
    # two cameras (no eye), or the depth stage off: no balance step either
    assert np.array_equal(
        smooth_keypoints(times, leaning, on, FPS), smooth_keypoints(times, leaning, off, FPS)
    )
    no_depth = on.model_copy(update={"depth_window_s": 0.0})
    assert np.array_equal(
        smooth_keypoints(times, leaning, no_depth, FPS, eye=eye),
        smooth_keypoints(times, leaning, off.model_copy(update={"depth_window_s": 0.0}), FPS),
    )
    half = smooth_keypoints(times, leaning, on.model_copy(update={"balance": 0.5}), FPS, eye=eye)
    np.testing.assert_allclose(half - before, 0.5 * move, atol=1e-9)
    # frames whose feet may be hidden (furniture, the image's edge) count as no offset in the
    # window's mean: none seen, no step; the second half unseen, the first half moves by the
    # first half's offset, and the step fades out over the depth window's half after it
    hidden = np.zeros(T, dtype=bool)
    got = smooth_keypoints(times, leaning, on, FPS, eye=eye, legs_seen=hidden)
    assert np.array_equal(got, before)
    hidden[: T // 2] = True
    shifted = leaning.copy()
    shifted[T // 2 :, UPPER, 1] -= 0.3  # a guess far off: it would move the pelvis the other way
    ref = smooth_keypoints(times, shifted, off, FPS, eye=eye)
    got = smooth_keypoints(times, shifted, on, FPS, eye=eye, legs_seen=hidden)
    step = (got - ref)[:, 9, :2]
    sight = 0.5 * (ref[:, 9, :2] + ref[:, 10, :2]) - eye[:2]
    towards = np.einsum("ij,ij->i", step, sight) / np.linalg.norm(sight, axis=1)
    lag = 7  # the depth window's half: 0.75 s at 20 fps
    assert (towards[: T // 2 + lag] < 0).all()  # the seen offset (+y) moves them nearer
    full = slice(0, T // 2 - lag)
    np.testing.assert_allclose(step[full], move[full, 9, :2], atol=2e-3)
    fading = np.linalg.norm(step[T // 2 - lag : T // 2 + lag], axis=1)
    assert (np.diff(fading) < 0).all()  # no jump in the sacrum's path
    np.testing.assert_allclose(got[T // 2 + lag :], ref[T // 2 + lag :], atol=1e-12)
    with pytest.raises(ValueError, match="legs_seen"):
        smooth_keypoints(times, leaning, on, FPS, eye=eye, legs_seen=hidden[:-1])


def test_bad_balance() -> None:
    with pytest.raises(ValueError, match="balance"):
        KeypointSmoother(9, 2, eye=EYE, depth_window=15, balance=-0.1)
    with pytest.raises(ValueError):
        SmoothingConfig(balance=3.0)
