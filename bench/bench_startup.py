"""Start-up: `plantlod --help`, `plantlod derive examples/stalk8.lsys` and `plantlod
simulate` against `python -c "import numpy"`, as whole processes (median of 7 after a
warm-up). simulate of the 8-branch stalk for 10 steps twice: as it runs (a short run:
the interpreted kernel, numba not loaded) and with PLANTLOD_KERNEL=compiled (numba and
the kernel's cached machine code loaded, as every run above 15,000 branch-steps does).

    .venv/bin/python bench/run.py startup
"""

from __future__ import annotations

import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
PLANTLOD = str(pathlib.Path(sys.executable).with_name("plantlod"))


def _median(cmd: list[str], runs: int = 7, env: dict | None = None) -> float:
    subprocess.run(cmd, capture_output=True, cwd=ROOT, check=True, env=env)
    times = []
    for _ in range(runs):
        begin = time.perf_counter()
        subprocess.run(cmd, capture_output=True, cwd=ROOT, check=True, env=env)
        times.append(time.perf_counter() - begin)
    return statistics.median(times)


def run(report) -> None:
    numpy = _median([sys.executable, "-c", "import numpy"])
    helps = _median([PLANTLOD, "--help"])
    derive = _median([PLANTLOD, "derive", "examples/stalk8.lsys"])
    report("start-up: python -c 'import numpy'", numpy, "s", "", "python -c 'import numpy'")
    report("start-up: plantlod --help / import numpy", helps / numpy, "x", "<= 3",
           "plantlod --help")
    report("start-up: plantlod derive stalk8 / import numpy", derive / numpy, "x", "<= 3",
           "plantlod derive examples/stalk8.lsys")
    with tempfile.TemporaryDirectory() as tmp:
        args = ["simulate", "examples/stalk8.lsys", "--dt", "0.01", "--steps", "10",
                "--wind-speed", "5", "-o", str(pathlib.Path(tmp) / "stalk8.csv")]
        command = "plantlod " + " ".join(args[:-1]) + " out.csv"
        for kernel, target in (("", "<= 4"), ("compiled", "")):
            env = {**os.environ, "PLANTLOD_KERNEL": kernel}
            seconds = _median([PLANTLOD] + args, env=env)
            name = f"plantlod simulate stalk8 10 steps ({kernel or 'as it runs: interpreted'})"
            prefix = f"PLANTLOD_KERNEL={kernel} " if kernel else ""
            report(f"start-up: {name}", seconds, "s", "", prefix + command)
            report(f"start-up: {name} / import numpy", seconds / numpy, "x", target,
                   prefix + command)
