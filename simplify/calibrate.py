"""Optional calibration: refine per-branch values against simulated series of the original.

The closed form (`closed_form`) matches static angles at small angles. At
high wind the original bends far enough that the forces change with the pose,
and in branching trees a swinging parent shakes its children at their own
period; neither is in the closed form. Calibration simulates the original
once per calibration wind, then lets `scipy.optimize.least_squares` adjust,
for every simplified branch g, three factors on its closed-form values:

    x_g = (log a_g, log d_g, log k_g):  k_FA *= a_g,  C_d *= d_g,  k_bs and k_rs *= k_g

The residuals are the section-6 errors, signed: for every wind, group and
counted component, (A_y - A_x) / A_x and w_P (P_y - P_x) / P_x, times a weight;
w_P (`CALIBRATION_PERIOD_WEIGHT`) measures both against their targets, so that
calibration does not buy amplitude with period (changing the strengths detunes
a branch from the resonance that makes its amplitude hard to match).
A few rounds multiply each weight by that residual's size relative to the
largest (iteratively re-weighted least squares, a smooth stand-in for
minimising the worst case). Group g's residuals depend mostly on its own
factors and its children's drag (which it receives), so the Jacobian is
declared sparse (`jac_sparsity`), and a finite-difference Jacobian costs a few
simulations instead of one per parameter.

Deterministic: fixed winds, fixed evaluation budget, no clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from .constants import CALIBRATION_BOUNDS
from .constants import CALIBRATION_PERIOD_WEIGHT
from .constants import CALIBRATION_ROUNDS
from .constants import CALIBRATION_STABILITY_MARGIN
from .constants import CALIBRATION_WEIGHT_FLOOR
from plantlod.lsys.tree import Tree
from plantlod.sim.run import simulate_arrays
from plantlod.sim.wind import wind_from_speed

from .evaluate import Runs
from plantlod.compare.measures import amplitude, period


@dataclass
class Calibrated:
    """The calibrated per-branch values and how the cost went.

    values  : key -> (G,) branch values (force_absorbed, drag_coefficient,
              bend_strength, rotation_strength)
    worst_before, worst_after : worst |residual| before and after (period errors
              times CALIBRATION_PERIOD_WEIGHT)
    evaluations : simulations of the simplified tree (one per wind each)
    """

    values: dict[str, np.ndarray]
    worst_before: float
    worst_after: float
    evaluations: int


def _apply(tree: Tree, base: dict[str, np.ndarray], x: np.ndarray) -> Tree:
    g = tree.n_branches
    f = np.exp(x.reshape(g, 3))
    out = Tree(**{**tree.__dict__})
    out.force_absorbed = base["force_absorbed"] * f[:, 0]
    out.drag_coefficient = base["drag_coefficient"] * f[:, 1]
    out.bend_strength = base["bend_strength"] * f[:, 2]
    out.rotation_strength = base["rotation_strength"] * f[:, 2]
    return out


def _sparsity(tree: Tree, rows_per_group: int, winds: int):
    """Rows (wind, group, 4 figures) depend on the group's own 3 factors and its children's drag."""
    g = tree.n_branches
    s = lil_matrix((winds * g * rows_per_group, 3 * g), dtype=np.int8)
    for w in range(winds):
        for i in range(g):
            r0 = (w * g + i) * rows_per_group
            cols = [3 * i, 3 * i + 1, 3 * i + 2]
            for c in np.flatnonzero(tree.parent == i).tolist():
                cols.append(3 * c + 1)
            for r in range(rows_per_group):
                for col in cols:
                    s[r0 + r, col] = 1
    return s


class _BudgetSpent(Exception):
    """The evaluation budget is used up (stops least_squares between evaluations)."""


class _Residuals:
    """Signed section-6 amplitude and period errors of a candidate, per wind, group, component."""

    def __init__(self, runs: Runs, tree: Tree, base: dict[str, np.ndarray], budget: int):
        self.runs, self.tree, self.base = runs, tree, base
        self.weights = np.ones((len(runs.runs), tree.n_branches, 4))
        self.evaluations = 0
        self.budget = budget
        self.best: tuple[np.ndarray | None, float] = (None, math.inf)
        amp_x = [np.stack([amplitude(r.combined_b), amplitude(r.combined_r)]) for r in runs.runs]
        self.amp_x = amp_x                                               # (2, G) per wind
        self.per_x = [np.stack([period(r.times, r.combined_b), period(r.times, r.combined_r)])
                      for r in runs.runs]
        from .constants import COUNTED_AMPLITUDE_FRACTION
        self.counted = [a >= COUNTED_AMPLITUDE_FRACTION * a.max() if a.max() > 0
                        else np.zeros_like(a, bool) for a in amp_x]

    def per_wind(self, x: np.ndarray) -> np.ndarray:
        """(W, G, 4) signed errors: bend amplitude, rotation amplitude, bend and rotation period
        (these two times CALIBRATION_PERIOD_WEIGHT)."""
        if self.evaluations >= self.budget:
            raise _BudgetSpent
        self.evaluations += 1
        cand = _apply(self.tree, self.base, x)
        out = np.zeros((len(self.runs.runs), self.tree.n_branches, 4))
        for w, run in enumerate(self.runs.runs):
            s = simulate_arrays(cand, self.runs.dt, self.runs.steps,
                                wind_from_speed(run.wind.speed, run.wind.direction),
                                every=self.runs.every)
            if not (np.all(np.isfinite(s.bend)) and np.all(np.isfinite(s.rot))):
                out[w] = 10.0
                continue
            amp_y = np.stack([amplitude(s.bend), amplitude(s.rot)])
            per_y = np.stack([period(s.times, s.bend), period(s.times, s.rot)])
            with np.errstate(invalid="ignore", divide="ignore"):
                ea = (amp_y - self.amp_x[w]) / self.amp_x[w]
                ep = (per_y - self.per_x[w]) / self.per_x[w]
            cnt = self.counted[w]
            ea = np.where(cnt & np.isfinite(ea), ea, 0.0)
            ep = np.where(cnt & np.isfinite(ep), ep, 0.0)
            out[w] = np.concatenate([ea.T, CALIBRATION_PERIOD_WEIGHT * ep.T], axis=1)
        worst = float(np.max(np.abs(out)))
        if worst < self.best[1]:
            self.best = (np.array(x, copy=True), worst)
        return out

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return (self.weights * self.per_wind(x)).reshape(-1)


def calibrate(runs: Runs, tree: Tree, max_evaluations: int = 40,
              progress: Callable[[float], None] | None = None) -> Calibrated:
    """Refine ``tree``'s (the simplified tree's) k_FA, C_d and strengths against ``runs``.

    max_evaluations : bound on candidate evaluations (each simulates every
                      calibration wind once), Jacobian columns included, over
                      all rounds; the best candidate seen (smallest worst
                      unweighted error) is returned, never one worse than the
                      closed form
    progress        : called with the fraction of the budget used
    """
    g = tree.n_branches
    base = {k: np.array(getattr(tree, k), dtype=np.float64) for k in
            ("force_absorbed", "drag_coefficient", "bend_strength", "rotation_strength")}
    res = _Residuals(runs, tree, base, max_evaluations + 1)
    k_max = np.maximum(base["bend_strength"], base["rotation_strength"])
    stable = CALIBRATION_STABILITY_MARGIN * 4.0 * 1000.0 / (runs.dt * k_max)
    lo = np.tile([b[0] for b in CALIBRATION_BOUNDS], g)
    hi = np.tile([b[1] for b in CALIBRATION_BOUNDS], g)
    hi[2::3] = np.maximum(np.minimum(hi[2::3], np.log(stable)), 1e-6)
    x = np.zeros(3 * g)
    sparsity = _sparsity(tree, 4, len(runs.runs))
    before = float(np.max(np.abs(res.per_wind(x))))
    for _ in range(CALIBRATION_ROUNDS):
        try:
            fit = least_squares(res, x, jac_sparsity=sparsity, bounds=(lo, hi), method="trf",
                                x_scale=1.0, diff_step=1e-3)
            x = fit.x
        except _BudgetSpent:
            break
        finally:
            if progress is not None:
                progress(min(1.0, res.evaluations / res.budget))
        try:
            err = np.abs(res.per_wind(x))                                  # (W, G, 4)
        except _BudgetSpent:
            break
        if err.max() <= 0:
            break
        # iteratively re-weighted least squares toward the largest error (a minimax)
        res.weights = res.weights * (err / err.max() + CALIBRATION_WEIGHT_FLOOR)
    best_x, after = res.best
    if best_x is None or after >= before:
        best_x, after = np.zeros(3 * g), before
    final = _apply(tree, base, best_x)
    values = {k: np.array(getattr(final, k)) for k in base}
    return Calibrated(values, before, after, res.evaluations)
