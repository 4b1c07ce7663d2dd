"""The progress display says when numba compiles (`cli.io.compiling_shown`): the first run
after an install compiles for up to half a minute, and the stage's bar stood still."""

from __future__ import annotations

import threading

import numba

from plantlod.cli.io import COMPILING, compiling_shown


class RecordingBar:
    """What `compiling_shown` calls of a rich Progress, recorded."""

    def __init__(self):
        self.calls: list[tuple] = []
        self.live: dict[int, str] = {}

    def add_task(self, description, total=None):
        task = len(self.calls)
        self.calls.append(("add", description))
        self.live[task] = description
        return task

    def remove_task(self, task):
        self.calls.append(("remove", self.live.pop(task)))


def _fresh_kernel():
    """A function numba has never compiled (a new object each call, no cache)."""
    @numba.njit(cache=False)
    def inner(x):
        return x + 1.0

    @numba.njit(cache=False)
    def outer(x):                       # (compiling it compiles `inner`: nested events)
        return inner(x) * 2.0

    return outer


def test_one_line_while_compiling_and_none_after():
    bar = RecordingBar()
    kernel = _fresh_kernel()
    with compiling_shown(bar):
        assert kernel(1.0) == 4.0       # compiles outer, and inner inside it
        assert bar.live == {}           # gone once the compiling ended
        kernel(2.0)                     # compiled already: nothing more
    assert bar.calls == [("add", COMPILING), ("remove", COMPILING)]


def test_compiling_in_threads_and_after_the_display_ended():
    bar = RecordingBar()
    kernels = [_fresh_kernel() for _ in range(3)]
    with compiling_shown(bar):
        threads = [threading.Thread(target=k, args=(1.0,)) for k in kernels]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert bar.live == {} and bar.calls and len(bar.calls) % 2 == 0
    assert all(c == (("add" if k % 2 == 0 else "remove"), COMPILING)
               for k, c in enumerate(bar.calls))
    seen = len(bar.calls)
    _fresh_kernel()(1.0)                # the listener is gone with the display
    assert len(bar.calls) == seen
