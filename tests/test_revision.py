"""tracker.revision.ResultQueue: final results in frame order, revisions applied."""

from __future__ import annotations

import logging

import numpy as np

from tracker.pipeline import FrameResult
from tracker.revision import ResultQueue


def _res(k: int, value: float = 0.0, revisions: list[FrameResult] | None = None) -> FrameResult:
    return FrameResult(
        frame_index=k,
        time_s=k / 20.0,
        pose=np.full(31, value),
        joints=np.full((19, 3), value),
        weight=0.5,
        status="tracked",
        revisions=revisions or [],
    )


def test_without_pending_frames_each_result_is_final_at_once() -> None:
    q = ResultQueue()
    assert [r.frame_index for r in q.push(_res(0), None)] == [0]
    assert [r.frame_index for r in q.push(_res(1), None)] == [1]
    assert q.flush() == [] and len(q) == 0


def test_held_until_no_longer_pending_then_revised_in_order() -> None:
    q = ResultQueue()
    assert q.push(_res(0), 0) == [] and q.push(_res(1), 0) == [] and q.push(_res(2), 0) == []
    assert len(q) == 3
    revised = [_res(0, 1.0), _res(1, 1.0), _res(2, 1.0)]
    out = q.push(_res(3, 2.0, revisions=revised), None)
    assert [r.frame_index for r in out] == [0, 1, 2, 3]
    assert [float(r.joints[0, 0]) for r in out] == [1.0, 1.0, 1.0, 2.0]
    assert len(q) == 0


def test_only_frames_before_the_pending_one_are_released() -> None:
    q = ResultQueue()
    assert [r.frame_index for r in q.push(_res(0), None)] == [0]
    assert q.push(_res(1), 1) == []  # a track starts at frame 1
    assert q.push(_res(2), 1) == []
    # the window's oldest frames dropped (max_s): frames before the new oldest are final
    assert [r.frame_index for r in q.push(_res(3), 2)] == [1]
    assert [r.frame_index for r in q.flush()] == [2, 3]


def test_flush_returns_what_is_held_unrevised() -> None:
    q = ResultQueue()
    q.push(_res(5, 3.0), 5)
    q.push(_res(6, 3.0), 5)
    out = q.flush()
    assert [(r.frame_index, float(r.joints[0, 0])) for r in out] == [(5, 3.0), (6, 3.0)]
    assert q.flush() == []


def test_late_revision_is_ignored_with_a_warning(caplog) -> None:
    q = ResultQueue()
    q.push(_res(0), None)  # already handed out
    with caplog.at_level(logging.WARNING, logger="tracker.revision"):
        out = q.push(_res(1, revisions=[_res(0, 9.0)]), None)
    assert [(r.frame_index, float(r.joints[0, 0])) for r in out] == [(1, 0.0)]
    assert "arrived after they were written" in caplog.text


# -- the backward pass's leg labels against the forward pass's (config.revise.label_votes) ------


def _walking_joints() -> np.ndarray:
    """A walking pose's key points (19, 3): the left leg forward, the right one back."""
    from tracker.body import BodyModel
    from tracker.dof import DOF

    body = BodyModel(height_m=1.7)
    pose = np.asarray(body.neutral_pose(0.0, 0.0, 0.0), dtype=np.float64)
    pose[DOF["l_hip_flexion"]] = np.radians(25.0)
    pose[DOF["r_hip_flexion"]] = np.radians(-15.0)
    pose[DOF["r_knee_flexion"]] = np.radians(40.0)
    return np.asarray(body.forward(pose[None]))[0]


def _side_camera():
    from tracker.camera import Camera

    return Camera.look_at(name="side", position=(0.5, -4.0, 2.3), target=(0.0, 0.0, 0.9))


def test_legs_exchanged_tells_the_other_labelling() -> None:
    from tracker.leglabels import exchange_legs, labels_differ

    j = _walking_joints()
    assert not labels_differ(j, j)
    assert labels_differ(exchange_legs(j), j)
    assert not labels_differ(exchange_legs(j) + 0.01, exchange_legs(j))


def test_label_vote_follows_the_detections() -> None:
    from tracker.leglabels import exchange_legs, label_vote

    j = _walking_joints()
    cam = _side_camera()
    seen = np.asarray(cam.project(j))
    assert label_vote(j, [seen], [cam]) == -1  # as labelled
    assert label_vote(exchange_legs(j), [seen], [cam]) == 1  # the other way round
    assert label_vote(j, [seen + 3.0], [cam]) == -1  # a few pixels off: still as labelled
    legless = seen.copy()
    legless[[11, 13, 15, 17]] = np.nan  # no point of the left leg: nothing to compare
    assert label_vote(j, [legless], [cam]) == 0
    assert label_vote(j, [None], [cam]) == 0
    assert label_vote(j, None, [cam]) == 0
    # two cameras: the evidence is summed before the sign
    other = np.asarray(cam.project(exchange_legs(j)))
    assert label_vote(j, [seen, other + 0.5], [cam, cam]) == -1


def _relabel(
    votes: list[int | None],
    breaks: set[int],
    need: int = 3,
    cameras: int = 1,
    dt: float = 0.05,
) -> list[bool]:
    """Which of the results ``_relabel_revised`` exchanges (True) for these votes."""
    from types import SimpleNamespace

    from tracker.config import ReviseConfig, TrackerConfig
    from tracker.leglabels import exchange_legs
    from tracker.pipeline import Tracker

    j = _walking_joints()
    out = [_res(k) for k in range(len(votes))]
    for r in out:
        r.joints = j.copy()
    cfg = TrackerConfig(revise=ReviseConfig(label_votes=need))
    me = SimpleNamespace(config=cfg, cameras=[None] * cameras, dt_default=dt)
    me._label_votes_needed = lambda: Tracker._label_votes_needed(me)
    Tracker._relabel_revised(me, out, votes, breaks)
    flags = [bool(np.allclose(r.joints, exchange_legs(j))) for r in out]
    for r, f in zip(out, flags, strict=True):
        assert f or np.array_equal(r.joints, j)  # exchanged or untouched
        assert bool(r.notes) == f
    return flags


def test_a_run_is_exchanged_when_the_detections_favour_it_enough() -> None:
    assert _relabel([None, 1, 1, 1, None], set()) == [False, True, True, True, False]
    assert _relabel([1, 1, -1, 1, 1], set()) == [True] * 5  # net +3 over the run
    assert _relabel([1, 1, None, 1], set()) == [False] * 4  # two runs of +2 and +1
    assert _relabel([1, 0, 1, 0], set()) == [False] * 4  # +2: the backward pass's labels stand
    # a restart in the backward pass ends a run
    assert _relabel([1, 1, 1, 1], {2}) == [False] * 4
    assert _relabel([1, 1, 1, 1, 1], {2}) == [False, False, True, True, True]
    # the votes are stated at 20 Hz: at 40 Hz a run needs twice as many
    assert _relabel([1, 1, 1, 1, 1], set(), dt=0.025) == [False] * 5
    assert _relabel([1] * 6, set(), dt=0.025) == [True] * 6
    # off, and not with two cameras (revise.label_votes_max_cameras)
    assert _relabel([1, 1, 1, 1], set(), need=0) == [False] * 4
    assert _relabel([1, 1, 1, 1], set(), cameras=2) == [False] * 4
    assert _relabel([1, 1, 1, 1], set(), cameras=2, need=1) == [False] * 4


def test_label_vote_settings_are_checked() -> None:
    import pytest
    from pydantic import ValidationError

    from tracker.config import ReviseConfig

    assert ReviseConfig().label_votes == 3 and ReviseConfig().label_votes_max_cameras == 1
    for bad in ({"label_votes": -1}, {"label_votes_max_cameras": 0}, {"label_votes": 1.5}):
        with pytest.raises(ValidationError):
            ReviseConfig(**bad)
