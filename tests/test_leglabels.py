"""tracker.leglabels: each frame's leg labelling chosen by smooth motion of the feet."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from gaitwatch.conventions import L_ANKLE, L_HEEL, L_KNEE, L_TOE, R_ANKLE, R_HEEL, R_KNEE, R_TOE
from tracker.config import LegLabelConfig, TrackerConfig
from tracker.leglabels import LegRelabeller, chooses_labels, exchange_legs, relabel_legs

FPS = 20.0


def _walk(n: int = 60, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    """Key points (n, 19, 3) of a walk along x at 1 m/s, one stride per second: the feet
    move ahead of and behind the pelvis in turn (legs apart 2 x 0.3 m at most), 0.2 m apart
    across. Points other than the legs' stay at the pelvis."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FPS
    j = np.zeros((n, 19, 3))
    j[:, :, 0] = t[:, None]
    j[:, :, 2] = 0.9
    for side, sign in ((0, 1.0), (1, -1.0)):
        knee, ankle, heel, toe = (
            (L_KNEE, L_ANKLE, L_HEEL, L_TOE) if side == 0 else (R_KNEE, R_ANKLE, R_HEEL, R_TOE)
        )
        x = t + sign * 0.3 * np.sin(2 * np.pi * t)
        y = 0.1 * sign
        for p, dx, z in (
            (knee, 0.0, 0.5),
            (ankle, 0.0, 0.08),
            (heel, -0.06, 0.03),
            (toe, 0.15, 0.02),
        ):
            j[:, p] = np.stack([x + dx, np.full(n, y), np.full(n, z)], axis=1)
    return j + rng.normal(0.0, noise, j.shape)


def _relabel(joints: np.ndarray, **cfg: float) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(len(joints)) / FPS
    return relabel_legs(t, joints, LegLabelConfig(**cfg), FPS)


def test_exchange_legs_swaps_knees_ankles_heels_toes_not_hips() -> None:
    j = np.arange(19 * 3, dtype=float).reshape(19, 3)
    x = exchange_legs(j)
    for a, b in ((L_KNEE, R_KNEE), (L_ANKLE, R_ANKLE), (L_HEEL, R_HEEL), (L_TOE, R_TOE)):
        assert np.array_equal(x[a], j[b]) and np.array_equal(x[b], j[a])
    others = [k for k in range(19) if k not in (L_KNEE, R_KNEE, L_ANKLE, R_ANKLE, L_HEEL,
                                                  R_HEEL, L_TOE, R_TOE)]  # fmt: skip
    assert np.array_equal(x[others], j[others])
    assert np.array_equal(exchange_legs(x), j)


@pytest.mark.parametrize("lag_s", [0.5, 0.25, 5.0])
def test_a_swapped_stretch_is_put_back(lag_s: float) -> None:
    truth = _walk()
    est = truth.copy()
    est[13:18] = exchange_legs(truth[13:18])  # the tracker followed the legs crossed
    est[41:47] = exchange_legs(truth[41:47])
    out, exchanged = _relabel(est, lag_s=lag_s)
    assert exchanged.tolist() == [13 <= i < 18 or 41 <= i < 47 for i in range(len(est))]
    np.testing.assert_array_equal(out, truth)


def test_clean_labels_stay_and_a_wholly_swapped_track_is_left_alone() -> None:
    truth = _walk()
    out, exchanged = _relabel(truth)
    assert not exchanged.any()
    np.testing.assert_array_equal(out, truth)
    # every frame exchanged moves as smoothly: motion cannot tell, the tracker's labels stay
    flipped = exchange_legs(truth)
    out, exchanged = _relabel(flipped)
    assert not exchanged.any()
    np.testing.assert_array_equal(out, flipped)


def test_without_a_swap_cost_or_when_disabled() -> None:
    truth = _walk()
    est = truth.copy()
    est[13:18] = exchange_legs(truth[13:18])
    out, exchanged = _relabel(est, enabled=False)
    assert not exchanged.any()
    np.testing.assert_array_equal(out, est)
    out, _ = _relabel(est, swap_cost_m2=0.0)  # the motion alone: either labelling of the whole
    assert np.array_equal(out, truth) or np.array_equal(out, exchange_legs(truth))


def test_the_stream_lags_keeps_order_and_splits_segments() -> None:
    truth = _walk(40)
    est = truth.copy()
    est[13:18] = exchange_legs(truth[13:18])
    rl = LegRelabeller.from_config(LegLabelConfig(lag_s=0.5), FPS)
    assert rl.lag == 10
    out = []
    for i, j in enumerate(est):
        got = rl.push(i / FPS, j, item=i)
        if i < 10:
            assert got == []  # nothing decided before the lag
        out += got
    out += rl.flush()
    assert [f.item for f in out] == list(range(40))
    np.testing.assert_array_equal(np.stack([f.joints for f in out]), truth)
    # a frame without a pose, a restart or a gap decides what is held and starts afresh
    rl = LegRelabeller(lag=10, swap_cost=0.03)
    assert rl.push(0.0, truth[0], item="a") == []
    got = rl.push(0.05, None, item="none")
    assert [f.item for f in got] == ["a", "none"] and got[1].joints is None
    assert rl.push(0.10, truth[2], item="b") == []
    assert [f.item for f in rl.push(0.15, truth[3], item="c", restart=True)] == ["b"]
    assert [f.item for f in rl.push(5.0, truth[4], item="d")] == ["c"]  # gap > max_gap_s
    assert [f.item for f in rl.flush()] == ["d"]
    assert rl.flush() == []


def test_whole_footage_form_equals_the_stream_and_splits_at_missing_frames() -> None:
    truth = _walk(50, seed=3)
    est = truth.copy()
    est[13:18] = exchange_legs(truth[13:18])
    frames = np.r_[0:25, 26:51]  # frame 25 had no pose: two segments
    t = frames / FPS
    cfg = LegLabelConfig()
    out, exchanged = relabel_legs(t, est, cfg, FPS, frames=frames)
    rl = LegRelabeller.from_config(cfg, FPS)
    stream = []
    for i, (ti, j) in enumerate(zip(t, est, strict=True)):
        stream += rl.push(float(ti), j, restart=i == 25)
    stream += rl.flush()
    np.testing.assert_array_equal(out, np.stack([f.joints for f in stream]))
    assert exchanged.tolist() == [f.exchanged for f in stream]
    assert exchanged[13:18].all() and exchanged.sum() == 5


def test_config_is_validated_and_on_by_default() -> None:
    assert TrackerConfig().leg_labels.enabled
    with pytest.raises(ValidationError):
        LegLabelConfig(lag_s=-1)
    with pytest.raises(ValidationError):
        LegLabelConfig(swap_cost_m2=-0.1)
    with pytest.raises(ValueError, match="lag"):
        LegRelabeller(lag=-1, swap_cost=0.1)
    with pytest.raises(ValueError, match="fps"):
        LegRelabeller.from_config(LegLabelConfig(), 0.0)


@pytest.mark.parametrize(
    ("setting", "single", "cue", "chosen"),
    [
        ("auto", False, True, True),  # two cameras or more: always
        ("off", False, True, True),
        ("auto", True, False, True),  # one camera without the key-point cue
        ("auto", True, True, False),  # one camera with the cue: the tracker's labels
        ("on", True, True, True),
        ("off", True, False, False),
    ],
)
def test_one_camera_keeps_its_labels_where_the_keypoint_cue_informs_them(
    setting: str, single: bool, cue: bool, chosen: bool
) -> None:
    truth = _walk(seed=4)
    est = truth.copy()
    est[20:26] = exchange_legs(truth[20:26])
    cfg = LegLabelConfig(single_camera=setting)
    assert chooses_labels(cfg, single_camera=single, keypoint_cue=cue) is chosen
    t = np.arange(len(est)) / FPS
    out, exchanged = relabel_legs(t, est, cfg, FPS, single_camera=single, keypoint_cue=cue)
    if chosen:
        assert exchanged[20:26].all() and exchanged.sum() == 6
        np.testing.assert_allclose(out, truth)
    else:
        assert not exchanged.any()
        np.testing.assert_array_equal(out, est)
    rl = LegRelabeller.from_config(cfg, FPS, single_camera=single, keypoint_cue=cue)
    assert rl.enabled is chosen
    assert not chooses_labels(
        LegLabelConfig(enabled=False, single_camera="on"), single_camera=single, keypoint_cue=cue
    )
    with pytest.raises(ValidationError):
        LegLabelConfig(single_camera="sometimes")


def test_written_keypoints_read_the_cue_from_the_settings_unless_told() -> None:
    from tracker.output import written_keypoints

    truth = _walk(seed=5)
    est = truth.copy()
    est[30:35] = exchange_legs(truth[30:35])
    t = np.arange(len(est)) / FPS
    off = TrackerConfig.model_validate({"smoothing": {"enabled": False}})
    cue_off = TrackerConfig.model_validate(
        {"smoothing": {"enabled": False}, "keypoints": {"enabled": False}}
    )
    eye = np.array([0.0, -4.0, 1.2])

    def exchanged(cfg: TrackerConfig, eye_: np.ndarray | None, **kw: bool) -> bool:
        out = written_keypoints(t, est, cfg, FPS, eye=eye_, **kw)
        return bool(np.allclose(out[30:35], truth[30:35]))

    assert exchanged(off, None)  # two cameras: relabelled
    assert not exchanged(off, eye)  # one camera, the cue on by default: kept
    assert exchanged(cue_off, eye)  # one camera without the cue: relabelled
    assert exchanged(off, eye, keypoint_cue=False)  # the detector could not run
