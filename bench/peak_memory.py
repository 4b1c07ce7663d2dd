"""Run a command and read its peak resident memory while it runs (a helper of the benchmarks).

Not rusage: Linux keeps a forked child's pre-exec high-water mark (the benchmark process's
own size, often over a GB here) in ru_maxrss across exec, so RUSAGE_CHILDREN reports the
parent's size for a small child. VmHWM in /proc/<pid>/status belongs to the new image only;
it is polled every POLL_S seconds until the process ends.
"""

from __future__ import annotations

import subprocess
import tempfile
import time

POLL_S = 0.05


def high_water_kb(pid: int) -> int:
    """The process' peak resident set so far (VmHWM, kB); 0 once it is gone."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def run_with_peak(args: list[str]) -> tuple[str, str, float, float]:
    """Run ``args`` to the end: (stdout, stderr, wall seconds, peak MB). Raises
    RuntimeError naming the command's stderr when it fails."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        begin = time.perf_counter()
        child = subprocess.Popen(args, stdout=out, stderr=err, text=True)
        peak = 0
        while child.poll() is None:
            peak = max(peak, high_water_kb(child.pid))
            time.sleep(POLL_S)
        seconds = time.perf_counter() - begin
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    if child.returncode != 0:
        raise RuntimeError(f"{' '.join(args[:3])} ... failed: {stderr.strip()}")
    return stdout, stderr, seconds, peak / 1024.0
