"""Start-up: `plantlod --help` and `plantlod derive examples/stalk8.lsys` against
`python -c "import numpy"`, as whole processes (median of 7 after a warm-up).

    .venv/bin/python bench/run.py startup
"""

from __future__ import annotations

import pathlib
import statistics
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
PLANTLOD = str(pathlib.Path(sys.executable).with_name("plantlod"))


def _median(cmd: list[str], runs: int = 7) -> float:
    subprocess.run(cmd, capture_output=True, cwd=ROOT, check=True)
    times = []
    for _ in range(runs):
        begin = time.perf_counter()
        subprocess.run(cmd, capture_output=True, cwd=ROOT, check=True)
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
