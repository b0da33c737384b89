"""Work on the next items of a stream in a background thread while the caller handles this one.

``gaitwatch track`` decodes and segments the next frames (OpenCV and numpy, which release the
GIL in their long calls) while the tracker works on the current one (numba kernels that
release it too), so a second core is used even with ``--threads 1``::

    for (index, time_s, frames), segs in prefetched(videos, lambda f: tracker.segment(f[2])):
        tracker.process_segmentations(index, time_s, segs, frames)

The items come out in their order, each once; ``fn`` runs on them in that order, in one
thread, so a stateful ``fn`` (an adaptive background model) sees what it would see in a plain
loop. An exception raised by the iteration or by ``fn`` is raised by the consumer when it
reaches that position: everything before it has been handed out. Closing the generator (or
leaving the ``for`` loop by an exception) stops the worker.

:func:`with_next` hands out each item with the one after it, so that the caller can start work
on the next item (``gaitwatch track`` runs the 2D detector of the next frame in a thread of its
own, ``tracker.pipeline.Tracker.detect_ahead``) before it handles this one.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

log = logging.getLogger(__name__)

T = TypeVar("T")
R = TypeVar("R")

_END = object()
_POLL_S = 0.1


def prefetched(
    items: Iterable[T], fn: Callable[[T], R], depth: int = 2, *, name: str = "prefetch"
) -> Iterator[tuple[T, R]]:
    """Yield ``(item, fn(item))`` for the items in order, computing up to ``depth`` ahead.

    Parameters
    ----------
    items : iterable
        Iterated in a worker thread (it must not be iterated elsewhere meanwhile).
    fn : callable
        Applied to each item in the worker thread, in order.
    depth : int
        Items computed ahead at most (at least 1).
    name : str
        The worker thread's name (logs).
    """
    if depth < 1:
        raise ValueError(f"depth must be at least 1, not {depth}")
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def put(entry: object) -> bool:
        while not stop.is_set():
            try:
                q.put(entry, timeout=_POLL_S)
                return True
            except queue.Full:
                continue
        return False

    def work() -> None:
        try:
            for item in items:
                if stop.is_set():
                    return
                if not put((item, fn(item), None)):
                    return
        except BaseException as err:  # handed to the consumer, raised there
            put((None, None, err))
            return
        put(_END)

    worker = threading.Thread(target=work, name=name, daemon=True)
    worker.start()
    try:
        while True:
            entry = q.get()
            if entry is _END:
                return
            item, result, err = entry
            if err is not None:
                raise err
            yield item, result
    finally:
        stop.set()
        while True:  # unblock a worker waiting to put
            try:
                q.get_nowait()
            except queue.Empty:
                break
        worker.join(timeout=10)
        if worker.is_alive():
            log.warning("%s: the worker thread is still running", name)


def with_next(items: Iterable[T]) -> Iterator[tuple[T, T | None]]:
    """Yield ``(item, following)`` for the items in order: each with the one after it (None
    after the last), fetched before the item is handed out, so that work on the next item can
    start while the caller handles this one.

    An exception raised fetching the next item is raised when the caller asks for the pair
    after: the item before it is handed out first, as :func:`prefetched` does. The items must
    not be None.
    """
    it = iter(items)
    item = next(it, None)
    while item is not None:
        err: BaseException | None = None
        try:
            following = next(it, None)
        except Exception as e:  # raised after ``item`` is handed out
            following, err = None, e
        yield item, following
        if err is not None:
            raise err
        item = following
