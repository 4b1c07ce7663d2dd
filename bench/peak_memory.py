"""Run a command and read its peak resident memory while it runs (a helper of the benchmarks).

Not rusage: Linux keeps a forked child's pre-exec high-water mark (the benchmark process's
own size, often over a GB here) in ru_maxrss across exec, so RUSAGE_CHILDREN reports the
parent's size for a small child. VmHWM in /proc/<pid>/status belongs to the new image only;
it is polled every POLL_S seconds until the process ends. A command that spawns workers
(`simplify --levels`, `plantlod.simplify.chain_workers`) is one job of several processes:
its peak is the largest, over the polls, of the summed resident sets (VmRSS) of the
process and its descendants, or the process's own VmHWM where that is larger (a peak
between two polls).
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import time

POLL_S = 0.05


def _status_kb(pid: int, field: str) -> int:
    """A ``field`` (VmRSS, VmHWM) of /proc/<pid>/status in kB; 0 once the process is gone."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def high_water_kb(pid: int) -> int:
    """The process' peak resident set so far (VmHWM, kB); 0 once it is gone."""
    return _status_kb(pid, "VmHWM")


def descendants(pid: int) -> list[int]:
    """The processes below ``pid`` (children, their children, ...), from each thread's
    /proc/<pid>/task/<tid>/children (a worker may be started by any thread)."""
    found, frontier = [], [pid]
    while frontier:
        p = frontier.pop()
        try:
            tasks = os.listdir(f"/proc/{p}/task")
        except OSError:
            continue
        for tid in tasks:
            try:
                with open(f"/proc/{p}/task/{tid}/children") as children:
                    kids = [int(c) for c in children.read().split()]
            except (OSError, ValueError):
                continue
            found += kids
            frontier += kids
    return found


def job_rss_kb(pid: int) -> int:
    """The summed resident sets (VmRSS, kB) of ``pid`` and its descendants now."""
    return sum(_status_kb(p, "VmRSS") for p in [pid] + descendants(pid))


def run_with_peak(args: list[str]) -> tuple[str, str, float, float]:
    """Run ``args`` to the end: (stdout, stderr, wall seconds, peak MB of the process and its
    workers together, module docstring). Raises
    RuntimeError naming the command's stderr when it fails."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        begin = time.perf_counter()
        child = subprocess.Popen(args, stdout=out, stderr=err, text=True)
        peak = 0
        while child.poll() is None:
            peak = max(peak, high_water_kb(child.pid), job_rss_kb(child.pid))
            time.sleep(POLL_S)
        seconds = time.perf_counter() - begin
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    if child.returncode != 0:
        raise RuntimeError(f"{' '.join(args[:3])} ... failed: {stderr.strip()}")
    return stdout, stderr, seconds, peak / 1024.0
