"""Runs that sample a branch's swing too coarsely to read it.

A branch of strength k swings with model.md 4's period P = 2π Δt / arccos(1 - k Δt / 2000),
which falls toward 2 Δt as k nears the stability limit 4000 / Δt. A run kept every ``every``
steps samples that swing every ``every`` Δt; where P holds fewer than MIN_SAMPLES_PER_PERIOD
samples, the period and amplitude read from the run (model.md 6) are aliased and the
figures mean little (a branch of k = 390,000 at Δt = 0.01 s swings in 2.2 steps: a level's
figures of 46,464 %, session 30). `simplify` and `compare` warn of it, naming the largest Δt
under which the stiffest branch's period holds that many samples:

    P >= N · every · Δt   <=>   k Δt / 2000 <= 1 - cos(2π / (N · every))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.tree import Tree

from .constants import MIN_SAMPLES_PER_PERIOD
from .damping import period_of_strength
from .stability import round_down


@dataclass(frozen=True)
class Aliased:
    """The stiffest branch of a tree whose swing a run cannot read: its strength (the largest
    k_bs or k_rs), its period P (s) at the run's Δt, and the largest Δt (s, two significant
    digits, rounded down) under which P holds MIN_SAMPLES_PER_PERIOD samples."""

    strength: float
    period: float
    dt_wanted: float

    def said(self, runs: str, figures: str, dt_name: str = "dt") -> str:
        """The warning's words: ``runs`` names the runs and their sampling, ``figures`` what
        means little, ``dt_name`` the option to lower."""
        return (f"the stiffest branch (strength {self.strength:g}) swings with a period of "
                f"{self.period:.3g} s, under {MIN_SAMPLES_PER_PERIOD} samples of {runs}, so the "
                f"periods and amplitudes read from them are aliased and {figures} mean little; "
                f"give a {dt_name} of {self.dt_wanted:g} s or less")


def aliased(tree: Tree, dt: float, every: int = 1) -> Aliased | None:
    """`Aliased` where the tree's stiffest branch swings in fewer than MIN_SAMPLES_PER_PERIOD
    samples of a run of time step ``dt`` (s) kept every ``every`` steps; None otherwise (and
    for a tree of no branches)."""
    if tree.n_branches == 0:
        return None
    stiffest = max(float(np.max(tree.bend_strength)), float(np.max(tree.rotation_strength)))
    fastest = float(period_of_strength(stiffest, dt))
    if fastest >= MIN_SAMPLES_PER_PERIOD * every * dt:
        return None
    wanted = 2000.0 * (1.0 - math.cos(2.0 * math.pi / (MIN_SAMPLES_PER_PERIOD * every))) / stiffest
    return Aliased(stiffest, fastest, round_down(wanted, 2))
