"""The lanes engine (sim/lanes.py) on ABOP 1.24a at n = 5 (3,125 branches), in one run:
branch-steps per second for 1 lane (the single-run kernel), 8 lanes on one core and 8 lanes on both cores.

Wall-clock rates (best of 3) are what the targets name; on a shared machine they also
measure the other users, so the single-core figures are given per second of this
process's CPU time too (all its threads), which the others barely disturb.

    .venv/bin/python bench/run.py lanes
"""

from __future__ import annotations

import time

import plantlod  # noqa: F401  (before numpy: pins OpenBLAS's kernels, plantlod/blas_kernels.py)
import numpy as np

STEPS = 600
COMMAND = "python bench/run.py lanes"


def _tree():
    import pathlib

    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys

    path = pathlib.Path(__file__).resolve().parents[1] / "examples" / "abop_1_24a.lsys"
    return build(parse_lsys(path.read_text(), "abop_1_24a")).tree


def _best(work, repeats: int) -> tuple[float, float]:
    """(wall, CPU) seconds of work(), the best of ``repeats`` each."""
    wall = cpu = float("inf")
    for _ in range(repeats):
        begin, begin_cpu = time.perf_counter(), time.process_time()
        work()
        wall = min(wall, time.perf_counter() - begin)
        cpu = min(cpu, time.process_time() - begin_cpu)
    return wall, cpu


def _rate(model, lanes: int, threads: int, repeats: int = 3) -> tuple[float, float]:
    """(per wall second, per CPU second) lane-branch-steps of `run_lanes`."""
    from plantlod.sim.lanes import run_lanes

    winds = np.array([[2.0 + k, 0.5 * k, 0.0] for k in range(lanes)])
    wall, cpu = _best(lambda: run_lanes(model, winds, 0.01, STEPS, every=STEPS, threads=threads),
                      repeats)
    work = model.n_branches * STEPS * lanes
    return work / wall, work / cpu


def _single_rate(tree, repeats: int = 3) -> tuple[float, float]:
    """The single-run kernel (sim/kernel.py), one wind: the 1-lane baseline (wall, CPU)."""
    from plantlod.sim.run import simulate_arrays
    from plantlod.sim.wind import ConstantWind

    wall, cpu = _best(lambda: simulate_arrays(tree, 0.01, STEPS, ConstantWind((2.0, 0.0, 0.0)),
                                              every=STEPS), repeats)
    return tree.n_branches * STEPS / wall, tree.n_branches * STEPS / cpu


def run(report) -> None:
    from plantlod.sim.lanes import LaneModel, run_lanes

    tree = _tree()
    model = LaneModel.from_tree(tree)
    run_lanes(model, np.ones((8, 3)), 0.01, 2)               # compile (or load) first
    _single_rate(tree, 1)
    one, one_cpu = _single_rate(tree)
    eight_one, eight_one_cpu = _rate(model, 8, 1)
    eight_two, _ = _rate(model, 8, 2)
    report("lanes: 1 lane (single-run kernel), 1 core", one / 1e6, "M branch-steps/s", "", COMMAND)
    report("lanes: 8 lanes, 1 core", eight_one / 1e6, "M branch-steps/s", "", COMMAND)
    report("lanes: 8 lanes, 2 cores", eight_two / 1e6, "M branch-steps/s", ">= 100", COMMAND)
    report("lanes: 8 lanes on 1 core / 1 lane", eight_one / one, "x", ">= 3", COMMAND)
    report("lanes: 2 cores / 1 core (8 lanes)", eight_two / eight_one, "x", ">= 1.8", COMMAND)
    report("lanes: 1 lane, per CPU second", one_cpu / 1e6, "M branch-steps/s", "", COMMAND)
    report("lanes: 8 lanes on 1 core, per CPU second", eight_one_cpu / 1e6, "M branch-steps/s",
           "", COMMAND)
    report("lanes: 8 lanes / 1 lane, per CPU second", eight_one_cpu / one_cpu, "x", ">= 3",
           COMMAND)
