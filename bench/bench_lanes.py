"""The lanes engine (sim/lanes.py) on ABOP 1.24a at n = 5 (3,125 branches), in one run:
branch-steps per second for 1 lane (the single-run kernel), 8 lanes on one core and 8 lanes on both cores.

    .venv/bin/python bench/run.py lanes
"""

from __future__ import annotations

import time

import numpy as np

STEPS = 600
COMMAND = "python bench/run.py lanes"


def _tree():
    import pathlib

    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys

    path = pathlib.Path(__file__).resolve().parents[1] / "examples" / "abop_1_24a.lsys"
    return build(parse_lsys(path.read_text(), "abop_1_24a")).tree


def _rate(model, lanes: int, threads: int, repeats: int = 3) -> float:
    from plantlod.sim.lanes import run_lanes

    winds = np.array([[2.0 + k, 0.5 * k, 0.0] for k in range(lanes)])
    best = float("inf")
    for _ in range(repeats):
        begin = time.perf_counter()
        run_lanes(model, winds, 0.01, STEPS, every=STEPS, threads=threads)
        best = min(best, time.perf_counter() - begin)
    return model.n_branches * STEPS * lanes / best


def _single_rate(tree, repeats: int = 3) -> float:
    """The single-run kernel (sim/kernel.py), one wind: the 1-lane baseline."""
    from plantlod.sim.run import simulate_arrays
    from plantlod.sim.wind import ConstantWind

    best = float("inf")
    for _ in range(repeats):
        begin = time.perf_counter()
        simulate_arrays(tree, 0.01, STEPS, ConstantWind((2.0, 0.0, 0.0)), every=STEPS)
        best = min(best, time.perf_counter() - begin)
    return tree.n_branches * STEPS / best


def run(report) -> None:
    from plantlod.sim.lanes import LaneModel, run_lanes

    tree = _tree()
    model = LaneModel.from_tree(tree)
    run_lanes(model, np.ones((8, 3)), 0.01, 2)               # compile (or load) first
    _single_rate(tree, 1)
    one = _single_rate(tree)
    eight_one = _rate(model, 8, 1)
    eight_two = _rate(model, 8, 2)
    report("lanes: 1 lane (single-run kernel), 1 core", one / 1e6, "M branch-steps/s", "", COMMAND)
    report("lanes: 8 lanes, 1 core", eight_one / 1e6, "M branch-steps/s", "", COMMAND)
    report("lanes: 8 lanes, 2 cores", eight_two / 1e6, "M branch-steps/s", ">= 100", COMMAND)
    report("lanes: 8 lanes on 1 core / 1 lane", eight_one / one, "x", ">= 3", COMMAND)
    report("lanes: 2 cores / 1 core (8 lanes)", eight_two / eight_one, "x", ">= 1.8", COMMAND)
