"""Several tracks averaged (``tracker.ensemble``, config ``ensemble``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from service.cli import main
from service.poselog import read_poselog
from tests.test_track import FPS, _args, _lower_limb_error, clip  # noqa: F401 (fixture)
from tracker.config import EnsembleConfig, TrackerConfig
from tracker.ensemble import (
    ARM_PAIRS,
    LEG_PAIRS,
    EnsembleTracker,
    combine,
    make_tracker,
    match_sides,
    member_config,
)
from tracker.pipeline import FrameResult, Tracker
from tracker.revision import ResultQueue


def _swap(joints: np.ndarray, pairs) -> np.ndarray:
    out = joints.copy()
    for a, b in pairs:
        out[a], out[b] = joints[b], joints[a]
    return out


def _skeleton(rng: np.random.Generator) -> np.ndarray:
    """19 key points with the left side at y > 0 and the right at y < 0 (far apart)."""
    j = rng.normal(0.0, 0.01, (19, 3))
    for a, b in (*LEG_PAIRS, *ARM_PAIRS):
        j[a, 1] += 0.15
        j[b, 1] -= 0.15
    return j


def test_member_config_divides_the_evaluations() -> None:
    cfg = TrackerConfig(ensemble=EnsembleConfig(tracks=3))
    sub = member_config(cfg)
    assert sub.ensemble.tracks == 1
    assert sub.ipf.kept == 27
    assert sub.evaluations_per_frame * 3 == cfg.evaluations_per_frame
    base = TrackerConfig(filter="condensation", evaluations=1000, ensemble={"tracks": 2})
    assert member_config(base).evaluations_per_frame == 500
    assert member_config(TrackerConfig()) == TrackerConfig()
    with pytest.raises(ValueError):
        EnsembleConfig(tracks=0)


def test_match_sides_exchanges_legs_and_arms_apart() -> None:
    rng = np.random.default_rng(0)
    ref = _skeleton(rng)
    other = ref + rng.normal(0.0, 0.01, ref.shape)
    np.testing.assert_array_equal(match_sides(other, ref), other)
    # legs exchanged only: the legs come back, the arms stay
    np.testing.assert_array_equal(match_sides(_swap(other, LEG_PAIRS), ref), other)
    # a track facing the other way: legs and arms both exchanged
    both = _swap(_swap(other, LEG_PAIRS), ARM_PAIRS)
    np.testing.assert_array_equal(match_sides(both, ref), other)
    # the head and trunk never move
    fixed = [0, 1, 2]
    np.testing.assert_array_equal(match_sides(both, ref)[fixed], other[fixed])


def _result(k: int, joints, status="tracked", weight=0.8, notes=(), evals=100) -> FrameResult:
    pose = None if joints is None else np.zeros(31)
    return FrameResult(
        k,
        k / FPS,
        pose,
        joints,
        weight if joints is not None else 0.0,
        status if joints is not None else "no_pose",
        reason="" if joints is not None else "nobody in view",
        notes=list(notes),
        evaluations=evals,
    )


def test_combine_averages_the_matched_tracks() -> None:
    rng = np.random.default_rng(1)
    a = _skeleton(rng)
    b = a + 0.02
    out = combine(
        [
            _result(3, a, weight=0.8, notes=["x"]),
            _result(3, _swap(b, LEG_PAIRS), weight=0.6, notes=["y"]),
        ]
    )
    np.testing.assert_allclose(out.joints, a + 0.01)
    assert out.weight == pytest.approx(0.7)
    assert out.evaluations == 200
    assert out.status == "tracked"
    assert out.notes == ["track 1/2: x", "track 2/2: y"]
    # a track without a pose is left out; none with a pose: no pose, with the reason
    out = combine([_result(3, None), _result(3, b)])
    np.testing.assert_array_equal(out.joints, b)
    out = combine([_result(3, None), _result(3, None)])
    assert not out.has_pose and out.status == "no_pose" and out.reason == "nobody in view"
    # (re)initialised only when every posed track is
    one = combine([_result(3, a, status="reinitialised"), _result(3, b)])
    assert one.status == "tracked"
    both = combine([_result(3, a, status="reinitialised"), _result(3, b, "reinitialised")])
    assert both.status == "reinitialised"


def test_one_track_is_the_plain_tracker(clip: dict) -> None:  # noqa: F811
    tracker = make_tracker(
        clip["cams"], TrackerConfig(), rng=np.random.default_rng(0), backgrounds=clip["bgs"]
    )
    assert type(tracker) is Tracker


def test_ensemble_averages_its_tracks_and_revises(clip: dict) -> None:  # noqa: F811
    """Three tracks of a third of the evaluations each on the synthetic clip: every frame comes
    out once, final, in order, near the truth; the backward pass's revisions of the tracks come
    out as new means of earlier frames, and the final results are those."""
    n = len(clip["frames"])  # 1.2 s: the backward pass runs once the track has run 0.9 s
    cfg = TrackerConfig(ensemble=EnsembleConfig(tracks=3))
    ens = make_tracker(clip["cams"], cfg, rng=np.random.default_rng(0), backgrounds=clip["bgs"])
    assert isinstance(ens, EnsembleTracker) and len(ens.tracks) == 3
    assert ens.evaluations_per_step == cfg.evaluations_per_frame
    queue, out, first, last = ResultQueue(), [], {}, {}
    for i, frames in enumerate(clip["frames"][:n]):
        res = ens.process(i, i / FPS, frames)
        assert res.evaluations >= cfg.evaluations_per_frame
        first[i] = last[i] = res.joints
        for rev in res.revisions:
            assert rev.frame_index < i
            last[rev.frame_index] = rev.joints
        out += queue.push(res, ens.pending_from)
    out += queue.flush()
    assert [r.frame_index for r in out] == list(range(n))
    assert all(r.has_pose for r in out)
    revised = [f for f in first if not np.array_equal(first[f], last[f])]
    assert revised  # the backward pass ran and those frames were averaged anew
    for r in out:
        np.testing.assert_array_equal(r.joints, last[r.frame_index])
    err = _lower_limb_error(np.stack([r.joints for r in out]), clip["truth"][:n])
    assert err.mean() < 0.09


def test_each_frame_is_the_mean_of_the_tracks_results(clip: dict) -> None:  # noqa: F811
    """Without the backward pass, each frame's key points are the mean of the tracks' own
    results of that frame, each track's sides matched to the first's; nothing stays open."""
    cfg = TrackerConfig(ensemble=EnsembleConfig(tracks=2), revise={"enabled": False})
    ens = EnsembleTracker(clip["cams"], cfg, rng=np.random.default_rng(4), backgrounds=clip["bgs"])
    seen: list[list[FrameResult]] = [[] for _ in ens.tracks]
    for t, track in enumerate(ens.tracks):
        inner = track.process_segmentations

        def spy(*args, _inner=inner, _seen=seen[t], **kwargs):
            res = _inner(*args, **kwargs)
            _seen.append(res)
            return res

        track.process_segmentations = spy
    for i, frames in enumerate(clip["frames"][:6]):
        res = ens.process(i, i / FPS, frames)
        a, b = seen[0][i], seen[1][i]
        assert a.frame_index == b.frame_index == i
        np.testing.assert_allclose(res.joints, 0.5 * (a.joints + match_sides(b.joints, a.joints)))
        np.testing.assert_array_equal(res.pose, a.pose)
        assert res.evaluations == a.evaluations + b.evaluations
        assert ens.pending_from is None and not ens._open
    # the two tracks drew differently
    assert not np.allclose(seen[0][-1].joints, seen[1][-1].joints)


def test_track_cli_tracks_option(clip: dict, tmp_path: Path, capsys) -> None:  # noqa: F811
    out = tmp_path / "e.mcap"
    rc = main(
        _args(clip, out, "--max-frames", "5", "--particles", "729", "--tracks", "3", "--seed", "2")
    )
    assert rc == 0, capsys.readouterr().err
    log = read_poselog(out)
    assert len(log) == 5
    assert log.metadata["settings"]["tracker"]["ensemble"]["tracks"] == 3
    rc = main(_args(clip, tmp_path / "bad.mcap", "--tracks", "9"))
    assert rc != 0
    assert "--tracks must be 1 to 8" in capsys.readouterr().err
    assert not (tmp_path / "bad.mcap").exists()
