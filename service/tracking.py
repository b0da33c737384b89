"""Track a stream of frames with the work spread over threads.

:func:`tracked` yields a tracker's result for each time step, in order, as a plain loop over
``tracker.process`` would, while:

* a thread decodes (iterates the steps) and segments the next frames
  (:func:`service.prefetch.prefetched`);
* another runs the built-in 2D detector on the next frame while the tracker works on this one
  (``tracker.pipeline.Tracker.detect_ahead``; docs/tracker.md, "The next frame's detection
  beside the tracker"). The detections come in the same order as in the plain loop, so the
  results are the same.

Used by ``gaitwatch track`` and ``gaitwatch simulate --advise``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import closing

import numpy as np

from service.prefetch import prefetched, with_next

#: Run the built-in 2D detector of the next frame in a thread of its own (the results are the
#: same either way; the tests switch it off to compare).
DETECT_AHEAD = True

Step = tuple[int, float, Sequence[np.ndarray]]


def tracked(
    tracker,
    steps: Iterable[Step],
    *,
    segment: Callable[[Sequence[np.ndarray]], list] | None = None,
    keypoints: Callable[[int], list | None] | None = None,
) -> Iterator:
    """Yield ``tracker.process_segmentations(index, time_s, segs, frames, ...)`` for each step.

    Parameters
    ----------
    tracker : tracker.pipeline.Tracker or tracker.ensemble.EnsembleTracker
    steps : iterable of (index, time_s, frames)
        The time steps in order, one frame per camera each; iterated in the decode thread.
    segment : callable, optional
        Segments one step's frames (default ``tracker.segment``); runs in the decode thread, in
        order, so a stateful one sees what it would in a plain loop.
    keypoints : callable, optional
        Given key points of a frame index (per camera ``(19, 3)`` or None) or None; with it the
        built-in detector does not run ahead (the tracker uses what it is given).

    An error raised by the steps, the segmentation, the detector or the tracker is raised when
    the caller reaches that step: every result before it has been handed out. Close the
    generator (``contextlib.closing``) to stop the threads early.
    """
    seg = tracker.segment if segment is None else segment
    pool = (
        ThreadPoolExecutor(max_workers=1, thread_name_prefix="detect-ahead")
        if DETECT_AHEAD and keypoints is None and tracker.detects_keypoints
        else None
    )
    pending: Future | None = None  # this step's detection, started ahead

    def detect_next(following) -> Future:
        (_, _, frames), segs = following
        return pool.submit(tracker.detect_ahead, frames, segs)

    try:
        with closing(prefetched(steps, lambda step: seg(step[2]), name="decode+segment")) as it:
            for ((index, time_s, frames), segs), following in with_next(it):
                kps = None if keypoints is None else keypoints(index)
                detection = None if pending is None else pending.result()
                pending = None
                # This step's detection done: the next one's may start now; else (several
                # blobs, or the first step) after this step's own.
                if pool is not None and following is not None and detection is not None:
                    pending = detect_next(following)
                res = tracker.process_segmentations(
                    index, time_s, segs, frames, kps, detection=detection
                )
                if pool is not None and following is not None and pending is None:
                    pending = detect_next(following)
                yield res
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
