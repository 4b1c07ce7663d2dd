"""A chain's explicit levels fitted in several processes (`simplify --levels`, `--jobs`).

Once level 1's groups are settled (`pipeline.settle_level_one`: the regrouping, where the
tree has one), every level of a chain is an independent fit of the same original, its
groupings and its runs in the measurement winds (`pipeline.ChainShare`): the levels can be
fitted in any order and anywhere, and each one's text is the same bytes. One process used
about 1.2 of two cores on abop_1_24c (the kernels are parallel, the fits are not), so the
levels are shared out between this process and ``jobs - 1`` spawned workers:

- this process takes levels from the front (level 1, the largest, first), the workers from
  the back (the coarsest, smallest first), each the next one left whenever it is free, so
  the work balances itself and the largest levels are not fitted at once: each process'
  memory peaks with its largest level, and the peaks add up (issue 21 bounds the chain at
  2 GB; abop_1_24c: 1.87 GB in two processes, 2.5 GB with both taking from the front);
- a worker gets the system, the original tree and the groupings over its link once
  started, and the original's runs (float32 angles, 0.13 GB at 4,096 branches) when its
  first level's motion fit asks for them, once they are simulated here: the original is
  simulated once. A thread of this process serves each link (`_serve`);
- a worker's numba kernels run on one thread (the processes already fill the cores);
- results come back as `LevelOutcome` (the text and the figures the command prints) and are
  yielded in level order; a worker's error is raised here, and its warnings warned, as if
  the level had been fitted here; a worker that dies (killed, out of memory) leaves its
  levels to this process.

Workers are spawned, not forked (GNU OpenMP, numba's threading layer here, is not
fork-safe once a parallel region has run), ignore SIGINT, SIGTERM and SIGHUP (the command
handles them and exits at once, `cli.discipline`) and are killed with their parent
(Linux's PR_SET_PDEATHSIG), so a signal leaves no worker behind; they write no file.
"""

from __future__ import annotations

import dataclasses
import math
import multiprocessing
import os
import signal
import sys
import threading
import warnings
from dataclasses import dataclass
from typing import Iterator

from plantlod.lsys.system import LSystem

from .constants import CHAIN_WORKER_POLL
from .pipeline import ChainShare, Options, Result, settle_level_one, simplify_explicit

@dataclass(frozen=True)
class LevelOutcome:
    """What `simplify --levels` writes and prints of one level: its text, the branch counts
    (original, level), the worst amplitude and tip errors (relative, NaN where nothing
    counted) and the largest tip error (max) in metres over the measurement winds."""

    level: int
    text: str
    branches: tuple[int, int]
    amplitude: float
    tip: float
    tip_max_m: float
    warnings: tuple = ()          # (message, category) a worker's fit warned (`_outcome`)

    @classmethod
    def of(cls, level: int, result: Result) -> "LevelOutcome":
        tip_m = max((r.tip_error_max_m for _w, r in result.reports
                     if math.isfinite(r.tip_error_max_m)), default=math.nan)
        return cls(level, result.text, (result.original.n_branches, result.tree.n_branches),
                   float(result.summary.amplitude), float(result.summary.tip), float(tip_m))


class _Levels:
    """The levels left to fit and the outcomes that came back, shared by this process'
    threads: this process takes levels from the front (level 1, the largest, first), the
    workers (through their `_serve` threads) from the back, the coarsest and smallest first,
    so that the largest levels are not fitted at the same time (their memory peaks would add
    up; issue 21 bounds the chain's memory)."""

    def __init__(self, first: int, last: int):
        self.lo, self.hi = first, last
        self.done: dict[int, LevelOutcome | BaseException] = {}
        self.lost: set[int] = set()                  # taken by a worker that ended without them
        self.changed = threading.Condition()

    def take(self, from_back: bool) -> int | None:
        with self.changed:
            if self.lo > self.hi:
                return None
            if from_back:
                self.hi -= 1
                return self.hi + 1
            self.lo += 1
            return self.lo - 1

    def put(self, k: int, outcome) -> None:
        with self.changed:
            self.done[k] = outcome
            self.changed.notify_all()

    def worker_ended(self, taken: set[int]) -> None:
        with self.changed:
            self.lost |= {k for k in taken if k not in self.done}
            self.changed.notify_all()

    def wait_for(self, k: int) -> bool:
        """Wait until level k is back (True) or lost with its worker (False)."""
        with self.changed:
            while k not in self.done and k not in self.lost:
                self.changed.wait(CHAIN_WORKER_POLL)
            return k in self.done


def chain_levels(system: LSystem, options: list[Options], shared: ChainShare,
                 jobs: int = 1) -> Iterator[LevelOutcome]:
    """Every level of ``options`` (levels 1 to the last, in order, one `Options` each, equal
    but for the level) as a `LevelOutcome`, in level order, fitted in ``jobs`` processes
    (this one and jobs - 1 workers; 1: all here, in order). ``shared``: the chain's
    `pipeline.chain_share`. The outcomes are the same for any ``jobs``."""
    if not options:
        return
    settle_level_one(system, options[0], shared)
    by_level = {o.level: o for o in options}
    first, last = min(by_level), max(by_level)
    workers = min(max(jobs, 1) - 1, last - first)
    if workers == 0:
        for o in options:
            yield LevelOutcome.of(o.level, simplify_explicit(system, o, shared=shared))
        return
    yield from _in_processes(system, by_level, shared, first, last, workers)


def _in_processes(system, by_level, shared, first, last, workers) -> Iterator[LevelOutcome]:
    def fit_here(k: int) -> LevelOutcome:
        return LevelOutcome.of(k, simplify_explicit(system, by_level[k], shared=shared))

    levels = _Levels(first, last)
    context = multiprocessing.get_context("spawn")
    procs = []
    # a worker that ends while this process writes to it must not end this process too:
    # SIGPIPE ignored (the write raises, and `_serve` ends), as it was before the command
    # set it (cli.discipline; an output reader gone then raises BrokenPipeError, also quiet)
    old_pipe = signal.signal(signal.SIGPIPE, signal.SIG_IGN) if hasattr(signal, "SIGPIPE") else None
    try:
        for _ in range(workers):
            here, there = context.Pipe()
            # only the link and this pid go with the start (a few hundred bytes, in the pipe
            # at once: a worker whose parent ends while it starts must not find its start
            # data cut short and print a traceback); the tree and its groupings follow on
            # the link
            proc = context.Process(target=_worker, args=(there, os.getpid()), daemon=True,
                                   name="plantlod-level-worker")
            proc.start()
            there.close()
            procs.append(proc)
            payload = (system, by_level, shared.original, shared.groupings)
            threading.Thread(target=_serve, args=(here, payload, levels, shared), daemon=True,
                             name="plantlod-level-worker-link").start()
        next_out = first
        while True:
            k = levels.take(from_back=False)
            if k is None:
                break
            levels.put(k, fit_here(k))
            while next_out in levels.done:
                yield _outcome(levels.done.pop(next_out))
                next_out += 1
        for k in range(next_out, last + 1):
            yield _outcome(levels.done.pop(k) if levels.wait_for(k) else fit_here(k))
    finally:
        for proc in procs:
            proc.join(timeout=CHAIN_WORKER_POLL)
            if proc.is_alive():           # (a worker ignores SIGTERM)
                proc.kill()
                proc.join()
        if old_pipe is not None:
            signal.signal(signal.SIGPIPE, old_pipe)


def _outcome(item) -> LevelOutcome:
    """A level's outcome; the error a worker met fitting it is raised here, its warnings
    warned here (as the fit here would have)."""
    if isinstance(item, BaseException):
        raise item
    for message, category in item.warnings:
        warnings.warn(message, category, stacklevel=2)
    return item


def _serve(connection, payload: tuple, levels: _Levels, shared: ChainShare) -> None:
    """This process' end of one worker's link (a thread): send the worker its ``payload``
    (the system, the options by level, the original tree, the groupings), then answer its
    requests for the next level ("next") and for the original's runs ("runs", sent once they
    are simulated here), and take its outcomes ("done"). Ends when the worker does; the
    levels it took without giving them back are then fitted here."""
    taken: set[int] = set()
    try:
        connection.send(payload)
        while True:
            message = connection.recv()
            if message[0] == "next":
                k = levels.take(from_back=True)
                if k is not None:
                    taken.add(k)
                connection.send(k)
            elif message[0] == "runs":
                connection.send(shared.measure)
            else:                                  # ("done", k, outcome or error)
                levels.put(message[1], message[2])
    except BaseException:                          # noqa: BLE001 - EOF, a broken pipe, runs that
        pass                                       # failed here (the fit here raises them)
    finally:
        levels.worker_ended(taken)
        connection.close()


class _RunsFromLink:
    """A worker's stand-in for `pipeline.InBackground`: the original's runs, asked for on the
    link when first needed (a worker that gets no level never asks)."""

    def __init__(self, connection):
        self._connection, self._runs = connection, None

    def result(self) -> list:
        if self._runs is None:
            self._connection.send(("runs",))
            self._runs = self._connection.recv()
        return self._runs


def _worker(connection, parent: int) -> None:
    """A spawned worker: take its payload from the link (`_serve`), ask for levels until
    none is left, fit each, send back ("done", level, `LevelOutcome` or the error met)."""
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_IGN)
    _die_with_parent(parent)
    try:
        _work(connection)
    except BaseException:                 # noqa: BLE001 - the parent ended first (a link cut
        os._exit(1)                       # short), or a fault outside a fit: the parent fits
                                          # what this worker leaves, and says what goes wrong


def _work(connection) -> None:
    system, by_level, original, groupings = connection.recv()
    import numba

    from plantlod.sim.heap import return_large_arrays

    return_large_arrays()                 # as the command does (cli.main)
    numba.set_num_threads(1)              # the processes fill the cores
    shared = ChainShare(original, groupings, _RunsFromLink(connection), regrouped=True)
    while True:
        connection.send(("next",))
        k = connection.recv()
        if k is None:
            return
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("default")
                outcome = LevelOutcome.of(k, simplify_explicit(system, by_level[k],
                                                                shared=shared))
        except Exception as exc:          # noqa: BLE001 - raised in the parent, as if met there
            connection.send(("done", k, _portable(exc)))
            return
        said = tuple((str(w.message), w.category) for w in caught)
        connection.send(("done", k, dataclasses.replace(outcome, warnings=said)))


def _portable(exc: Exception) -> Exception:
    """``exc`` where it pickles (plantlod's errors do, location included), else a
    RuntimeError naming it: the parent raises it as if the level had been fitted there."""
    import pickle

    try:
        pickle.dumps(exc)
    except Exception:                     # noqa: BLE001 - any unpicklable exception
        return RuntimeError(f"{type(exc).__name__}: {exc}")
    return exc


def _die_with_parent(parent: int) -> None:
    """Linux: the kernel kills this process when its parent (pid ``parent``) ends
    (PR_SET_PDEATHSIG), so a command ended by a signal (`os._exit`) leaves no worker running;
    where the parent ended before the call, this process ends now."""
    if sys.platform.startswith("linux"):
        import ctypes

        PR_SET_PDEATHSIG = 1
        try:
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL))
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:
        os._exit(0)
