"""A tracker's results in frame order, once no later frame can revise them.

With ``config.revise`` on, :class:`tracker.pipeline.Tracker` runs a backward pass over the first
frames of a track once it has settled, and attaches the new results for those frames to a later
frame's result (``FrameResult.revisions``). :class:`ResultQueue` holds the results of the frames
still open to revision (``Tracker.pending_from`` says which) and hands out each frame's final
result once, in frame order::

    queue = ResultQueue()
    for index, time_s, frames in video:
        for res in queue.push(tracker.process(index, time_s, frames), tracker.pending_from):
            write(res)
    for res in queue.flush():  # at the end, or when tracking stops on an error
        write(res)

It holds at most ``revise.max_s`` seconds of results; without revision it hands each result
back at once.
"""

from __future__ import annotations

import logging
from collections import deque

from tracker.pipeline import FrameResult

log = logging.getLogger(__name__)


class ResultQueue:
    """Results held until final, revisions applied (see the module's documentation)."""

    def __init__(self) -> None:
        self._held: deque[FrameResult] = deque()

    def __len__(self) -> int:
        return len(self._held)

    def push(self, result: FrameResult, pending_from: int | None) -> list[FrameResult]:
        """Take one frame's result (and the revisions it carries); return the results that are
        final now, oldest first. ``pending_from``: the tracker's ``pending_from`` after that
        frame (None: nothing can be revised any more)."""
        if result.revisions:
            revised = {r.frame_index: r for r in result.revisions}
            for i, held in enumerate(self._held):
                new = revised.pop(held.frame_index, None)
                if new is not None:
                    self._held[i] = new
            if revised:  # already handed out: too late (the window outgrew the queue's holding)
                log.warning(
                    "revisions of frames %s arrived after they were written; ignored",
                    sorted(revised),
                )
        self._held.append(result)
        out: list[FrameResult] = []
        while self._held and (pending_from is None or self._held[0].frame_index < pending_from):
            out.append(self._held.popleft())
        return out

    def flush(self) -> list[FrameResult]:
        """Every result still held, oldest first (the end of the footage, or an error)."""
        out = list(self._held)
        self._held.clear()
        return out
