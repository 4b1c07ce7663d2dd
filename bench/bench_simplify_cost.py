"""What `simplify` costs as trees grow: abop_1_24a at derivation lengths 3 to 6, level 1.

Each size is one `plantlod simplify` process (the default form and measurement, as a user
runs it), timed by wall clock, its peak memory read from /proc (VmHWM) while it runs. The growth exponent is the slope of log(seconds) against
log(branches) between the two largest sizes (where fixed costs weigh least), and
over all four by least squares. Issue 12's targets: 10 s at derivation length 5,
60 s and 2 GB at 6, and growth linear or n log n (exponent near 1).

A fan too: one branch with FAN_LATERALS laterals of a leaf each, the case where the grouping
was quadratic in a branch's children (docs/simplify.md, "One branch with hundreds of
children").

    .venv/bin/python bench/bench_simplify_cost.py
"""

from __future__ import annotations

import pathlib
import re
import sys
import tempfile

import plantlod  # noqa: F401  (before numpy: pins OpenBLAS's kernels, plantlod/blas_kernels.py)
import numpy as np

from peak_memory import run_with_peak

ROOT = pathlib.Path(__file__).resolve().parents[1]
PLANTLOD = ROOT / ".venv" / "bin" / "plantlod"
LENGTHS = (3, 4, 5, 6)
COMMAND = "plantlod simplify abop_1_24a.lsys (derivation_length N) --level 1 -o OUT"
FAN_LATERALS = 1000
FAN_COMMAND = f"plantlod simplify FAN.lsys --level 1 -o OUT (one branch, {FAN_LATERALS} laterals)"


def fan_source(laterals: int) -> str:
    """An L-system of one branch with ``laterals`` laterals, a leaf on each, turned to both
    sides in turn."""
    fan = " ".join(f"[{'+' if i % 2 else '-'}F L]" for i in range(laterals))
    return (f"name: fan{laterals}\nderivation_length: 0\nbranching_angle: 30\n"
            "force_absorbed: 0.005\nforce_propagated: 0.7\n"
            "branch F: length=0.5 radius=0.02 bend_strength=20 rotation_strength=20\n"
            f"leaf L: area=0.01\naxiom: F {fan}\n")


def _measure_fan(work: pathlib.Path) -> tuple[float, float]:
    """(wall seconds, peak resident MB) of simplify on the fan at level 1."""
    path = work / "fan.lsys"
    path.write_text(fan_source(FAN_LATERALS))
    _, _, seconds, peak_mb = run_with_peak(
        [str(PLANTLOD), "simplify", str(path), "--level", "1", "-o", str(work / "fan_l1.lsys")])
    return seconds, peak_mb


def _measure(n: int, work: pathlib.Path) -> tuple[int, float, float]:
    """(branches, wall seconds, peak resident MB) of one simplify run at derivation length n."""
    source = (ROOT / "examples" / "abop_1_24a.lsys").read_text()
    path = work / f"a{n}.lsys"
    path.write_text(re.sub(r"(?m)^derivation_length: .*$", f"derivation_length: {n}", source))
    stdout, stderr, seconds, peak_mb = run_with_peak(
        [str(PLANTLOD), "simplify", str(path), "--level", "1", "-o", str(work / f"a{n}_l1.lsys")])
    branches = int(re.search(r"([\d,]+) ->", stderr).group(1).replace(",", ""))
    return branches, seconds, peak_mb


def run(report) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        rows = [_measure(n, pathlib.Path(tmp)) for n in LENGTHS]
        fan_seconds, fan_mb = _measure_fan(pathlib.Path(tmp))
    for n, (branches, seconds, mb) in zip(LENGTHS, rows):
        target = {5: "<= 10", 6: "<= 60"}.get(n, "")
        report(f"simplify abop_1_24a n={n} ({branches:,} branches), level 1: wall", seconds, "s",
               target, COMMAND)
        report(f"simplify abop_1_24a n={n}: peak memory", mb, "MB", "<= 2048" if n == 6 else "",
               "peak resident memory of the command (/proc, bench/peak_memory.py)")
    b = np.log([r[0] for r in rows])
    t = np.log([r[1] for r in rows])
    last = float((t[-1] - t[-2]) / (b[-1] - b[-2]))
    fit = float(np.polyfit(b, t, 1)[0])
    report("simplify growth exponent, largest two sizes (seconds ~ branches^k)", last, "",
           "~1 (linear or n log n)", COMMAND)
    report("simplify growth exponent, least squares over n = 3..6", fit, "", "", COMMAND)
    report(f"simplify fan of {FAN_LATERALS:,} laterals on one branch, level 1: wall", fan_seconds,
           "s", "", FAN_COMMAND)
    report(f"simplify fan of {FAN_LATERALS:,} laterals: peak memory", fan_mb, "MB", "", FAN_COMMAND)


if __name__ == "__main__":
    def _print(name, value, unit, target="", command=""):
        print(f"{name}: {value:.3g} {unit}" + (f"  (target {target})" if target else ""))
    sys.exit(run(_print) or 0)
