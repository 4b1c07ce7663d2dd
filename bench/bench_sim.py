"""Simulation benchmarks: kernel throughput, numba compile and cache-load time,
angle-CSV writing speed, and the kernel's speed against the slow reference.

``run(report)`` is called by bench/run.py; ``python bench/bench_sim.py`` runs it
alone. The trees come from tests/treegen.py (the ABOP Fig. 1.24a structure,
F -> F[+F]F[-F]F: 5^5 = 3125 branches at n = 5).
"""

from __future__ import annotations

import io
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import plantlod  # noqa: F401  (before numpy: pins OpenBLAS's kernels, plantlod/blas_kernels.py)
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from treegen import abop_124a  # noqa: E402

COMMAND = ".venv/bin/python bench/run.py sim"

# A fresh interpreter timing the kernel's first call on a tiny tree; run twice
# with one empty NUMBA_CACHE_DIR: the first run compiles and writes the cache,
# the second loads it.
_FIRST_CALL = """
import sys, time
import numpy as np
sys.path.insert(0, {tests!r})
from treegen import stalk
t0 = time.perf_counter()
from plantlod.sim import kernel
tree = stalk(2)
model, state = kernel.prepare(tree), kernel.KernelState(2)
out = np.empty((1, 2))
kernel.advance(model, state, np.ones((1, 3)), 0.01, 1, 1, out, out.copy(), 0)
print(time.perf_counter() - t0)
"""


def _bench_tree(n: int):
    return abop_124a(n, bend_strength=200.0, rotation_strength=150.0, force_absorbed=0.05,
                     drag_coefficient=0.01)


def kernel_throughput(steps: int = 2000, repeats: int = 3) -> tuple[int, float]:
    """Branch-steps per second of `kernel.advance` on the 3125-branch tree, best of repeats."""
    from plantlod.sim import kernel

    tree = _bench_tree(5)
    b = tree.n_branches
    model = kernel.prepare(tree)
    wind = np.tile([5.0, 2.0, 0.0], (steps, 1))
    out = np.empty((1, b))
    kernel.advance(model, kernel.KernelState(b), wind[:1], 0.01, 1, 1, out, out.copy(), 0,
                   "compiled")  # warm
    best = np.inf
    for _ in range(repeats):
        state = kernel.KernelState(b)
        t0 = time.perf_counter()
        kernel.advance(model, state, wind, 0.01, 1, 10**12, out, out.copy(), 0,
                       "compiled")  # no output rows
        best = min(best, time.perf_counter() - t0)
    return b, b * steps / best


def first_call_seconds() -> tuple[float, float]:
    """(compile, cached) seconds of the kernel's first call in a fresh interpreter."""
    code = _FIRST_CALL.format(tests=str(ROOT / "tests"))
    times = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PLANTLOD_KERNEL="compiled")
        for _ in range(2):
            done = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                  capture_output=True, text=True)
            times.append(float(done.stdout.strip()))
    return times[0], times[1]


def csv_values_per_second(rows: int = 200, repeats: int = 3) -> float:
    """Values per second of `AnglesCsvWriter.write` for (rows, 3125) angles into memory."""
    from plantlod.formats.angles_csv import AnglesCsvWriter

    tree = _bench_tree(5)
    rng = np.random.default_rng(0)
    bend, rot = rng.normal(size=(2, rows, tree.n_branches)) * 0.3
    times = np.arange(rows) * 0.01
    best = np.inf
    for _ in range(repeats):
        writer = AnglesCsvWriter(io.StringIO(), tree.address)
        t0 = time.perf_counter()
        writer.write(times, bend, rot)
        best = min(best, time.perf_counter() - t0)
    return rows * (2 * tree.n_branches + 1) / best


def speedup_over_reference(steps: int = 200) -> tuple[int, float]:
    """(branches, reference time / kernel time) on the 25-branch tree, same run."""
    from reference_model import reference_simulate

    from plantlod.sim.run import simulate_arrays
    from plantlod.sim.wind import ConstantWind

    tree = _bench_tree(2)
    wind = ConstantWind((5.0, 2.0, 0.0))
    simulate_arrays(tree, 0.01, 1, wind)    # warm
    t0 = time.perf_counter()
    fast = simulate_arrays(tree, 0.01, steps, wind)
    t_kernel = time.perf_counter() - t0
    t0 = time.perf_counter()
    bend, _ = reference_simulate(tree, 0.01, steps, lambda t: wind.vector)
    t_ref = time.perf_counter() - t0
    assert np.abs(np.asarray(bend) - fast.bend).max() < 1e-9
    return tree.n_branches, t_ref / t_kernel


def end_to_end_values_per_second() -> tuple[int, float]:
    """(values, values/s) of a whole ``plantlod simulate`` writing CSV (subprocess, best of 2).

    ABOP 1.24a (3125 branches) for 2000 steps: 2001 rows of 6250 angles, derived,
    simulated and written to a file; start-up and derivation included.
    """
    plantlod = ROOT / ".venv" / "bin" / "plantlod"
    steps = 2000
    best = float("inf")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "angles.csv")
        args = [str(plantlod), "simulate", "examples/abop_1_24a.lsys", "--dt", "0.01",
                "--steps", str(steps), "--wind-speed", "10", "-o", out]
        for _ in range(2):
            t0 = time.perf_counter()
            subprocess.run(args, cwd=ROOT, check=True, capture_output=True)
            best = min(best, time.perf_counter() - t0)
        with open(out) as fh:
            columns = fh.readline().count(",")
    values = (steps + 1) * columns
    return values, values / best


def run(report) -> None:
    b, rate = kernel_throughput()
    report(f"kernel throughput ({b} branches, 2000 steps, no output)", rate, "branch-steps/s",
           ">= 2e7", COMMAND)
    compile_s, cached_s = first_call_seconds()
    report("kernel first call, empty numba cache (compile)", compile_s, "s", "", COMMAND)
    report("kernel first call, numba cache filled (load)", cached_s, "s", "", COMMAND)
    report("angle CSV writing (200 rows x 6251 values)", csv_values_per_second(), "values/s",
           ">= 2e6", COMMAND)
    values, per_second = end_to_end_values_per_second()
    report(f"plantlod simulate abop_1_24a.lsys, 2000 steps to CSV ({values:,} values, "
           "start-up included)", per_second, "values/s", ">= 2e6",
           "plantlod simulate examples/abop_1_24a.lsys --dt 0.01 --steps 2000 --wind-speed 10 -o x.csv")
    nb, speedup = speedup_over_reference()
    report(f"kernel speed / reference speed ({nb} branches, 200 steps)", speedup, "x", "", COMMAND)


if __name__ == "__main__":
    def _print(name, value, unit, target="", command=""):
        print(f"{name}: {value:.4g} {unit}" + (f" (target {target})" if target else ""))

    run(_print)
