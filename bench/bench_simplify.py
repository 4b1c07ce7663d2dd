"""Simplification benchmarks: section-6 errors of level-n trees over wind sweeps, and their cost.

``run(report)`` is called by bench/run.py (``make bench``); ``python
bench/bench_simplify.py [stalk|trees [NAME ...] [--level N ...]|all]`` prints
the full tables that docs/simplify.md quotes.

- stalk8, levels 1 and 2, methods thesis, derived (closed form) and derived
  with --calibrate: worst-group amplitude, period and tip errors over speeds
  0.5 .. 20 m/s and directions 0 .. 180 deg every 15 deg (the stalk is
  symmetric about the x axis, so this is every horizontal direction).
- the branching examples, levels 1 and 2 (closed form): the same errors per
  wind speed (directions 0 and 90 deg), beside the original's largest combined
  angle at that wind (the bound applies where it stays under 0.1 rad), and the
  simulation cost of each level against the original's.
"""

from __future__ import annotations

import math
import pathlib
import sys
import time

import plantlod  # noqa: F401  (before numpy: pins OpenBLAS's kernels, plantlod/blas_kernels.py)
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent

COMMAND = ".venv/bin/python bench/bench_simplify.py"
DT = 0.01
STALK_SPEEDS = (0.5, 1.0, 2.0, 5.0, 10.0, 15.0, 20.0)
STALK_DIRECTIONS = tuple(range(0, 181, 15))
TREE_SPEEDS = (0.5, 2.0, 5.0, 10.0, 20.0)
TREE_DIRECTIONS = (0.0, 90.0)
TREES = ("abop_1_24a", "abop_1_24b", "abop_1_24c", "abop_1_24d", "abop_1_24e", "abop_1_24f",
         "abop_1_25", "abop_2_6", "abop_2_7")


def _load(name):
    from plantlod.formats.lsys_file import read_lsys
    return read_lsys(str(ROOT / "examples" / f"{name}.lsys"))


def _simplified(system, level, method, calibrate):
    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys
    from plantlod.simplify.pipeline import Options, simplify
    t0 = time.perf_counter()
    result = simplify(system, Options(level=level, method=method, calibrate=calibrate))
    seconds = time.perf_counter() - t0
    return result, build(parse_lsys(result.text)).tree, seconds


def _sweep(original, tree, speeds, directions, duration, every=2):
    """{(speed, direction): Report} and the original's largest |combined angle| per speed."""
    from plantlod.simplify.targets import group_map
    from plantlod.simplify.evaluate import Runs, WindCase
    gmap = group_map(original, tree)
    steps = int(round(duration / DT))
    out, largest = {}, {}
    for s in speeds:
        for d in directions:
            runs = Runs(original, gmap, [WindCase(s, d)], DT, steps, every)
            run = runs.runs[0]
            largest[s] = max(largest.get(s, 0.0), float(np.max(np.abs(run.combined_b))),
                             float(np.max(np.abs(run.combined_r))))
            out[(s, d)] = runs.compare(tree)[0]
    return out, largest


def _worst(reports, key):
    vals = [getattr(r, key) for r in reports if math.isfinite(getattr(r, key))]
    return max(vals) if vals else math.nan


def _pct(x):
    return "n/a" if not math.isfinite(x) else f"{100 * x:.2f}"


def stalk_table(report=None):
    from plantlod.lsys.build import build
    system = _load("stalk8")
    original = build(system).tree
    print("### stalk8: worst group over speeds", STALK_SPEEDS, "m/s and directions 0..180 deg by 15")
    print("| level | method | amplitude % | period % | tip % of height | worst amplitude at | simplify s |")
    print("|---|---|---:|---:|---:|---|---:|")
    for level in (1, 2):
        for method, calibrate in (("thesis", False), ("derived", False), ("derived", True)):
            result, tree, seconds = _simplified(system, level, method, calibrate)
            reps, _ = _sweep(original, tree, STALK_SPEEDS, STALK_DIRECTIONS, 20.0)
            amp = {k: r.amplitude_error for k, r in reps.items()}
            at = max(amp, key=lambda k: amp[k])
            name = method + (" --calibrate" if calibrate else "")
            a, p, t = (_worst(reps.values(), k) for k in ("amplitude_error", "period_error", "tip_error"))
            print(f"| {level} | {name} | {_pct(a)} | {_pct(p)} | {_pct(t)} | "
                  f"{at[0]:g} m/s, {at[1]:g} deg | {seconds:.2f} |", flush=True)
            if report is not None:
                cmd = f"{COMMAND} stalk"
                report(f"stalk8 level {level} {name}: worst amplitude error", 100 * a, "%",
                       "<= 2" if level == 1 else "<= 5", cmd)
                report(f"stalk8 level {level} {name}: worst period error", 100 * p, "%",
                       "<= 1" if level == 1 else "<= 2", cmd)


def _sim_seconds(tree, steps=2000):
    from plantlod.sim.run import simulate_arrays
    from plantlod.sim.wind import wind_from_speed
    simulate_arrays(tree, DT, 10, wind_from_speed(5, 0))          # compile / warm
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        simulate_arrays(tree, DT, steps, wind_from_speed(5, 0), every=10)
        best = min(best, time.perf_counter() - t0)
    return best


def trees_table(report=None, names=TREES, levels=(1, 2)):
    from plantlod.lsys.build import build
    print("### branching examples (closed form): worst group per wind speed, directions 0 and 90 deg,")
    print("### 15 s runs; 'largest' is the original's largest combined angle (rad) at that speed")
    for name in names:
        system = _load(name)
        original = build(system).tree
        base = _sim_seconds(original)
        for level in levels:
            try:
                result, tree, seconds = _simplified(system, level, "derived", False)
            except Exception as exc:                      # report, do not stop the bench
                print(f"{name} level {level}: simplify failed: {exc}", flush=True)
                continue
            cost = _sim_seconds(tree)
            reps, largest = _sweep(original, tree, TREE_SPEEDS, TREE_DIRECTIONS, 15.0, every=4)
            print(f"\n{name} level {level}: {original.n_branches} -> {tree.n_branches} branches, "
                  f"simulation {1000 * base:.0f} -> {1000 * cost:.0f} ms per 2000 steps "
                  f"({cost / base:.2f} of the original), simplify {seconds:.1f} s")
            print("| speed m/s | largest rad | amplitude % | period % | tip % |")
            print("|---:|---:|---:|---:|---:|")
            for s in TREE_SPEEDS:
                rs = [reps[(s, d)] for d in TREE_DIRECTIONS]
                a, p, t = (_worst(rs, k) for k in ("amplitude_error", "period_error", "tip_error"))
                print(f"| {s:g} | {largest[s]:.3g} | {_pct(a)} | {_pct(p)} | {_pct(t)} |", flush=True)
            if report is not None:
                cmd = f"{COMMAND} trees {name}"
                report(f"{name} level {level}: simulation cost vs original", cost / base, "x", "", cmd)
                small = [s for s in TREE_SPEEDS if largest[s] < 0.1]
                if small:
                    rs = [reps[(s, d)] for s in small for d in TREE_DIRECTIONS]
                    report(f"{name} level {level}: worst amplitude error, angles < 0.1 rad",
                           100 * _worst(rs, "amplitude_error"), "%",
                           "<= 10" if level == 1 else "", cmd)


def run(report):
    stalk_table(report)
    trees_table(report, names=("abop_1_24a", "abop_2_6"), levels=(1,))


if __name__ == "__main__":
    which = sys.argv[1] if len(sys.argv) > 1 else "all"
    if which in ("stalk", "all"):
        stalk_table()
    if which in ("trees", "all"):
        # arguments: tree names, and optionally --level N (repeatable) to bench only those levels
        args, levels = sys.argv[2:], []
        while "--level" in args:
            k = args.index("--level")
            levels.append(int(args[k + 1]))
            del args[k:k + 2]
        trees_table(names=tuple(args) or TREES, levels=tuple(levels) or (1, 2))
