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
