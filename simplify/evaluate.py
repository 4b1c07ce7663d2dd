"""Measure a simplified tree against the original: simulate both, compare (model.md section 6).

`Runs` simulates the original once per wind and keeps what the comparison
needs (combined angles and group tips per group), so that calibration can
simulate many candidate simplified trees against the same original runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .constants import HIGH_SPEED_FRACTION
from .constants import MEASURE_WIND_DIRECTIONS
from .constants import POSE_BLOCK_BRANCH_SAMPLES
from plantlod.lsys.errors import InputError, RunFailure
from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import pose, rest_height
from plantlod.sim.run import simulate_arrays
from plantlod.sim.wind import wind_from_speed

from .closed_form import GroupMap
from .groups import combined_angles
from .measures import Report, compare_groups



@dataclass(frozen=True)
class WindCase:
    """A steady horizontal wind: speed m/s toward azimuth direction deg (0 = +x)."""

    speed: float
    direction: float

    def label(self) -> str:
        return f"{self.speed:g} m/s toward {self.direction:g} deg"




def wind_cases(low: float, high: float,
               directions: tuple[float, ...] = MEASURE_WIND_DIRECTIONS) -> list[WindCase]:
    """Steady winds: speeds low, sqrt(low high), 0.75 high, high (duplicates once), each direction."""
    if not (0 < low <= high and math.isfinite(high)):
        raise InputError(f"wind range {low:g} to {high:g} m/s: expected 0 < low <= high")
    values = []
    for v in (low, math.sqrt(low * high), max(low, HIGH_SPEED_FRACTION * high), high):
        v = float(f"{v:.6g}")
        if v not in values:
            values.append(v)
    return [WindCase(s, d) for s in values for d in directions]


def tips_of(tree: Tree, bend: np.ndarray, rot: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Tips (K, len(which), 3) m of branches ``which`` over samples bend, rot (K, B)."""
    k = bend.shape[0]
    out = np.empty((k, len(which), 3))
    rows = max(1, POSE_BLOCK_BRANCH_SAMPLES // max(tree.n_branches, 1))
    for lo in range(0, k, rows):
        out[lo:lo + rows] = pose(tree, bend[lo:lo + rows], rot[lo:lo + rows]).tip[:, which]
    return out


@dataclass
class OriginalRun:
    """One wind's run of the original, reduced to what comparison needs."""

    wind: WindCase
    times: np.ndarray          # (K,) s
    combined_b: np.ndarray     # (K, G) rad
    combined_r: np.ndarray     # (K, G) rad
    tips: np.ndarray           # (K, G, 3) m


class Runs:
    """The original's runs over a set of winds, and comparisons of simplified trees with them.

    dt, steps, every: time step (s), steps per run, keep every k-th sample.
    """

    def __init__(self, original: Tree, gmap: GroupMap, winds: list[WindCase],
                 dt: float, steps: int, every: int = 1):
        self.original = original
        self.gmap = gmap
        self.dt, self.steps, self.every = dt, steps, every
        self.height = rest_height(original)
        self.runs = [self._run_original(w) for w in winds]

    def _run_original(self, wind: WindCase) -> OriginalRun:
        s = simulate_arrays(self.original, self.dt, self.steps,
                            wind_from_speed(wind.speed, wind.direction), every=self.every)
        cb, cr = combined_angles(self.original, self.gmap.paths, s.bend, s.rot)
        tips = tips_of(self.original, s.bend, s.rot, self.gmap.tips)
        return OriginalRun(wind, s.times, cb, cr, tips)

    def compare(self, simplified: Tree) -> list[Report]:
        """One section-6 report per wind. Raises InputError when the simplified run diverges."""
        reports = []
        every_branch = np.arange(simplified.n_branches)
        for run in self.runs:
            try:
                s = simulate_arrays(simplified, self.dt, self.steps,
                                    wind_from_speed(run.wind.speed, run.wind.direction),
                                    every=self.every)
            except RunFailure as exc:
                raise InputError(f"the simplified tree is unstable at {run.wind.label()}: {exc}",
                                 simplified.source or None) from None
            tips = tips_of(simplified, s.bend, s.rot, every_branch)
            reports.append(compare_groups(run.times, run.combined_b, run.combined_r,
                                          s.bend, s.rot, run.tips, tips, self.height,
                                          simplified.address))
        return reports


@dataclass
class Summary:
    """Worst figures over a set of winds (relative errors, NaN where nothing counted)."""

    amplitude: float
    period: float
    tip: float


def summarize(reports: list[Report]) -> Summary:
    def worst(values):
        vals = [v for v in values if math.isfinite(v)]
        return max(vals) if vals else math.nan
    return Summary(worst(r.amplitude_error for r in reports),
                   worst(r.period_error for r in reports),
                   worst(r.tip_error for r in reports))
