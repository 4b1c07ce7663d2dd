"""Numbered jobs shared out between this process and spawned workers, results in job order.

`run_jobs` fits a chain's levels (`plantlod.simplify.chain_workers`) and a scene's tree files
(`plantlod.scene.levels`) on every core: each job is a pure function of its number and of
what every worker is given once, so the results are the same bytes whichever process
computes them, and come back in job order.

- This process takes jobs from the front (job ``first``, the largest where the caller orders
  them so, first), the workers from the back, each the next job left whenever it is free:
  the work balances itself, and the largest jobs are not run at once (each process' memory
  peaks with its largest job, and the peaks add up).
- A worker is a fresh interpreter started with only its link and this process' id (`main`);
  this process' sys.path, the job function and the caller's ``payload`` follow on the
  link, and a worker may ask for more by name (``answers``: a chain's original runs, sent once this
  process has simulated them). A thread of this process serves each link.
- Results come back with the warnings the job raised, warned here when the result is
  yielded; a job's error is raised here where that job's result would have been yielded, as
  if it had run here; a worker that dies (killed, out of memory) leaves its jobs to this
  process.
- Workers are new processes, not forks (GNU OpenMP, numba's threading layer here, is not
  fork-safe once a parallel region has run), run numba on one thread (the processes fill the
  cores), fix the heap's threshold as commands do (`sim.heap`), ignore SIGINT, SIGTERM and
  SIGHUP (the command handles them and ends at once, `cli.discipline`, killing and reaping
  its workers first: `formats.atomic.remove_pending`) and are killed with their parent
  otherwise (Linux's PR_SET_PDEATHSIG); they write no file. While it has workers this
  process ignores SIGPIPE, so that a worker's end cannot end it (an output reader gone then
  raises BrokenPipeError, which the commands end on quietly).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import warnings
from typing import Any, Callable, Iterator

from plantlod.formats.atomic import hold_child, release_child

from .constants import CAUGHT_SIGNALS, WORKER_POLL

PR_SET_PDEATHSIG = 1                              # linux/prctl.h


class _Failed:
    """A job's error, carried back to be raised where its result would have been."""

    def __init__(self, error: BaseException):
        self.error = error


class Jobs:
    """The jobs left, first to last, and the results that came back, shared by this process'
    threads; lost: jobs taken by a worker that ended without giving them back."""

    def __init__(self, first: int, last: int):
        self.lo, self.hi = first, last
        self.done: dict[int, tuple[Any, tuple]] = {}  # job -> (result or _Failed, warnings)
        self.lost: set[int] = set()
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

    def put(self, k: int, result, said: tuple = ()) -> None:
        with self.changed:
            self.done[k] = (result, said)
            self.changed.notify_all()

    def worker_ended(self, taken: set[int]) -> None:
        with self.changed:
            self.lost |= {k for k in taken if k not in self.done}
            self.changed.notify_all()

    def wait_for(self, k: int) -> bool:
        """Wait until job k is back (True) or lost with its worker (False)."""
        with self.changed:
            while k not in self.done and k not in self.lost:
                self.changed.wait(WORKER_POLL)
            return k in self.done


def run_jobs(first: int, last: int, here: Callable[[int], Any], workers: int,
             target: Callable, payload: Any,
             answers: dict[str, Callable[[], Any]] | None = None) -> Iterator[tuple[int, Any]]:
    """(k, result) for jobs first..last in order: ``here(k)`` in this process, or in one of
    ``workers`` spawned workers ``target(payload, ask)(k)``, where ``target`` is a module-level
    function run once per worker with the ``payload`` and ``ask(name)``, which gets
    ``answers[name]()`` from this process. 0 workers: every job here, in order."""
    if workers <= 0 or first >= last:
        for k in range(first, last + 1):
            yield k, here(k)
        return
    jobs = Jobs(first, last)
    procs = []
    old_pipe = None                   # (signal handlers can only be set in the main thread)
    if hasattr(signal, "SIGPIPE") and threading.current_thread() is threading.main_thread():
        old_pipe = signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    try:
        for _ in range(min(workers, last - first)):
            link, proc = _start()
            procs.append(proc)
            threading.Thread(target=_serve, args=(link, (target, payload), jobs, answers or {}),
                             daemon=True, name="plantlod-worker-link").start()
        next_out = first
        while True:
            k = jobs.take(from_back=False)
            if k is None:
                break
            try:
                jobs.put(k, here(k))
            except Exception as exc:              # noqa: BLE001 - raised in its turn, below
                jobs.put(k, _Failed(exc))
            while next_out in jobs.done:
                yield next_out, _result(jobs.done.pop(next_out))
                next_out += 1
        for k in range(next_out, last + 1):
            yield k, (_result(jobs.done.pop(k)) if jobs.wait_for(k) else here(k))
    finally:
        for proc in procs:
            try:
                proc.wait(timeout=WORKER_POLL)
            except subprocess.TimeoutExpired:     # (a worker ignores SIGTERM)
                proc.kill()
                proc.wait()
            release_child(proc)
        if old_pipe is not None:
            signal.signal(signal.SIGPIPE, old_pipe)


def _start():
    """A new worker process and this process' end of its link (a socket pair). The worker is
    a fresh interpreter running `main` (not multiprocessing's spawn, which imports the
    caller's main script again in the worker: a script without a main guard would run
    twice); it gets this process' sys.path first on the link, so it imports what this
    process imports."""
    import socket
    from multiprocessing.connection import Connection

    here, there = socket.socketpair()
    # the kernel's kill with the parent asked for first thing, before any import: a command
    # ended while a worker was still starting left it running until it got that far
    code = (f"import ctypes, os; ctypes.CDLL(None).prctl({PR_SET_PDEATHSIG}, {int(signal.SIGKILL)})"
            f" if os.uname().sysname == 'Linux' else None; os.getppid() != {os.getpid()} and "
            f"os._exit(0); import plantlod.sim.workers as w; w.main({there.fileno()})")
    # nothing of a worker's reaches the command's output: results, errors and warnings come
    # over the link, and a worker that fails outside a job leaves its jobs to the command
    proc = subprocess.Popen([sys.executable, "-c", code], pass_fds=[there.fileno()],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, close_fds=True)
    hold_child(proc)                              # (a signal's handler ends it at once)
    there.close()
    link = Connection(here.detach())
    link.send(list(sys.path))
    return link, proc


def _result(item: tuple):
    """A job's result, its warnings warned here; its error raised here."""
    result, said = item
    for message, category in said:
        warnings.warn(message, category, stacklevel=3)
    if isinstance(result, _Failed):
        raise result.error
    return result


def _serve(link, payload, jobs: Jobs, answers: dict) -> None:
    """This process' end of one worker's link (a thread): send the payload, then answer
    "next" (the next job from the back, None when none is left) and the ``answers`` asked
    for by name, and take "done" results. Ends when the worker does (its jobs not given
    back are then lost, and run here)."""
    taken: set[int] = set()
    try:
        link.send(payload)
        while True:
            message = link.recv()
            if message[0] == "next":
                k = jobs.take(from_back=True)
                if k is not None:
                    taken.add(k)
                link.send(k)
            elif message[0] == "done":
                jobs.put(message[1], message[2], message[3])
            else:
                link.send(answers[message[0]]())
    except BaseException:                         # noqa: BLE001 - EOF, a broken pipe, an answer
        pass                                      # that failed (the job here raises it again)
    finally:
        jobs.worker_ended(taken)
        link.close()


def main(fd: int) -> None:
    """A worker (module docstring; `_start`): the link on file descriptor ``fd``, the job
    function and its payload from it, then jobs until none is left. Anything that ends it
    outside a job (its parent gone, a link cut short) ends it quietly: the parent runs what
    it leaves, and says what goes wrong."""
    for signum in CAUGHT_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
    try:
        from multiprocessing.connection import Connection

        link = Connection(fd)
        sys.path[:] = link.recv()
        _work(link)
    except BaseException:                         # noqa: BLE001 - see the docstring
        os._exit(1)
    os._exit(0)


def _work(link) -> None:
    target, payload = link.recv()
    import numba

    from .heap import return_large_arrays

    return_large_arrays()
    numba.set_num_threads(1)

    def ask(name: str):
        link.send((name,))
        return link.recv()

    job = target(payload, ask)
    while True:
        link.send(("next",))
        k = link.recv()
        if k is None:
            return
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("default")
                result = job(k)
        except Exception as exc:                  # noqa: BLE001 - raised in the parent
            link.send(("done", k, _Failed(portable(exc)), ()))
            return
        link.send(("done", k, result, tuple((str(w.message), w.category) for w in caught)))


def portable(exc: BaseException) -> BaseException:
    """``exc`` where it pickles (plantlod's errors do, location included), else a
    RuntimeError naming it."""
    import pickle

    try:
        pickle.dumps(exc)
    except Exception:                             # noqa: BLE001 - any unpicklable exception
        return RuntimeError(f"{type(exc).__name__}: {exc}")
    return exc
