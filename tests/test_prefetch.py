"""service.prefetch: work one item ahead in a thread, in order, errors at their position."""

from __future__ import annotations

import itertools
import threading
import time
from contextlib import closing

import pytest

from service.prefetch import prefetched, with_next


def _workers() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith("test-prefetch")]


def test_items_and_results_in_order_computed_in_one_other_thread() -> None:
    seen: list[tuple[int, int]] = []

    def fn(x: int) -> int:
        seen.append((x, threading.get_ident()))
        time.sleep(0.001 * (x % 3))  # uneven work: the order must not depend on it
        return x * x

    out = list(prefetched(range(50), fn, depth=3, name="test-prefetch"))
    assert out == [(x, x * x) for x in range(50)]
    assert [x for x, _ in seen] == list(range(50))  # fn saw the items in order
    threads = {t for _, t in seen}
    assert len(threads) == 1 and threads != {threading.get_ident()}
    assert not _workers()


def test_the_worker_runs_ahead_at_most_depth_items() -> None:
    started: list[int] = []

    def fn(x: int) -> int:
        started.append(x)
        return x

    with closing(prefetched(itertools.count(), fn, depth=2, name="test-prefetch")) as it:
        assert next(it) == (0, 0)
        time.sleep(0.2)  # time for the worker to fill the queue
        # item 0 handed out, 2 waiting in the queue, 1 more computed and waiting to be put
        assert len(started) <= 4
    assert not _workers()


@pytest.mark.parametrize("where", ["fn", "iteration"])
def test_an_error_is_raised_at_its_position_after_the_items_before_it(where: str) -> None:
    def items():
        for x in range(10):
            if where == "iteration" and x == 4:
                raise OSError("decode failed at item 4")
            yield x

    def fn(x: int) -> int:
        if where == "fn" and x == 4:
            raise ValueError("bad item 4")
        return -x

    got = []
    with pytest.raises((OSError, ValueError), match="item 4"):
        for item, result in prefetched(items(), fn, name="test-prefetch"):
            got.append((item, result))
    assert got == [(0, 0), (1, -1), (2, -2), (3, -3)]
    assert not _workers()


def test_closing_early_stops_the_worker_on_an_endless_stream() -> None:
    it = prefetched(itertools.count(), lambda x: x, depth=1, name="test-prefetch")
    assert [next(it)[0] for _ in range(3)] == [0, 1, 2]
    it.close()
    assert not _workers()


def test_an_error_in_the_consumer_stops_the_worker() -> None:
    it = prefetched(itertools.count(), lambda x: x, name="test-prefetch")
    with pytest.raises(RuntimeError, match="consumer"), closing(it):
        for item, _ in it:
            if item == 5:
                raise RuntimeError("consumer failed")
    assert not _workers()


def test_depth_must_be_positive() -> None:
    with pytest.raises(ValueError, match="depth"):
        next(prefetched(range(3), lambda x: x, depth=0))


# -- with_next: each item with the one after it ----------------------------------------------
def test_each_item_comes_with_the_next_one_fetched_before() -> None:
    fetched: list[int] = []

    def items():
        for x in range(4):
            fetched.append(x)
            yield x

    got = []
    for item, following in with_next(items()):
        assert fetched[-1] == (item + 1 if item < 3 else 3)  # the next one is already fetched
        got.append((item, following))
    assert got == [(0, 1), (1, 2), (2, 3), (3, None)]
    assert list(with_next([])) == []
    assert list(with_next(["only"])) == [("only", None)]


def test_an_error_fetching_the_next_item_comes_after_the_item_before() -> None:
    def items():
        yield from range(3)
        raise OSError("item 3 is corrupt")

    got = []
    with pytest.raises(OSError, match="item 3"):
        for item, following in with_next(items()):
            got.append((item, following))
    # item 2 was handed out (without a next one) before the error was raised
    assert got == [(0, 1), (1, 2), (2, None)]


def test_an_error_fetching_the_first_item_is_raised_at_once() -> None:
    def items():
        raise OSError("no first item")
        yield 0

    with pytest.raises(OSError, match="first"):
        next(with_next(items()))
