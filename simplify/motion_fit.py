"""Fit an explicit level to motion (issue 21 item 2): correct each level branch's periods and
gains from its simulated swing against its group's, on the measures themselves.

The statics (`closed_form`, `gain_matrix`) and the swing model (`explicit.dominant_strengths`:
members started from rest, each on its own) fix a level branch's parameters before anything
moves. What they cannot see — a parent's lean turning the force a group feels, members whose
periods beat, a chord whose bending plane turns against W_0 (model.md 6) — shows in the level's
own runs. So, over the fit winds (`fit_winds`: speeds × directions round the compass, the
original run once for the whole chain), each round simulates the level and reads, per group g
and W_0 component c (model.md 6's measures, in `compare_groups`), over the winds where the
component counts:

    ρ_P[g, c] = Σ_w q ln(P_x / P_y) / Σ_w q,     q = (A_x / A_max)²   (the major swings lead)
    ρ_A[g, c] = Σ_w a ln(A_x / A_y) / Σ_w a,     a = A_x / A_max      (motion error's weight)

and carries them back to the branch's own components through its carry map C (y = C θ',
`compare.groups.carry_matrix`): own component m takes Σ_c |C[c, m]| w_c ρ[g, c] / Σ_c |C[c, m]| w_c
(w_c: the summed weights). The branch's own period is multiplied by exp(ρ_P) (so its strength is
`strength_of_period` of it) and its gain row by exp(ρ_A), each clipped to exp(±MOTION_FIT_STEP).
A branch whose two strengths are one (`explicit.own_strengths` tied them) keeps them tied.

The round scoring best on the fit winds (`bounds.form_rank`: winds missing the level's bounds,
then the worst ratio) is kept, so a round can only help on the winds it is scored in.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.system import GAIN_KEYS
from plantlod.lsys.tree import Tree

from .bounds import form_rank
from .constants import (COUNTED_AMPLITUDE_FRACTION, MOTION_FIT_DIRECTIONS, MOTION_FIT_GOOD,
                        MOTION_FIT_ROUNDS, MOTION_FIT_SPEEDS, MOTION_FIT_STEP,
                        SMALL_ANGLE_LIMIT)
from .evaluate import Runs, WindCase


def fit_winds() -> list[WindCase]:
    """The motion fit's winds: MOTION_FIT_SPEEDS (m/s) × MOTION_FIT_DIRECTIONS (deg)."""
    return [WindCase(s, d) for s in MOTION_FIT_SPEEDS for d in MOTION_FIT_DIRECTIONS]


def swing_figures(reports, largest: list[float]) -> tuple[np.ndarray, ...]:
    """(A_x, A_y, P_x, P_y) (W, 2, S) and A_max (W,) of the winds whose original stays within
    SMALL_ANGLE_LIMIT (all winds when none does): rows of ``reports`` (one `Report` per wind)."""
    keep = [k for k, a in enumerate(largest) if a <= SMALL_ANGLE_LIMIT] or list(range(len(reports)))
    figures = np.array([[[(getattr(g.bend, name), getattr(g.rotation, name)) for g in reports[k].groups]
                         for name in ("amplitude_original", "amplitude_simplified",
                                      "period_original", "period_simplified")]
                        for k in keep], dtype=np.float64)                     # (W, 4, S, 2)
    figures = figures.transpose(1, 0, 3, 2)                                   # (4, W, 2, S)
    a_max = np.array([reports[k].largest_amplitude for k in keep], dtype=np.float64)
    return figures[0], figures[1], figures[2], figures[3], a_max


def own_corrections(ax, ay, px, py, a_max, carry: np.ndarray, tied: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Log-corrections (S, 2) of each level branch's own period and own gain rows (bend,
    rotation), from the figures of `swing_figures` and its carry map ``carry`` (S, 2, 2);
    ``tied`` (S,): branches whose two strengths are one get one period correction."""
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(a_max[:, None, None] > 0, ax / a_max[:, None, None], 0.0)
        counted = rel >= COUNTED_AMPLITUDE_FRACTION
        p_ok = counted & np.isfinite(px) & np.isfinite(py) & (px > 0) & (py > 0)
        a_ok = counted & (ay > 0)
        lp = np.where(p_ok, np.log(np.where(p_ok, px / py, 1.0)), 0.0)
        la = np.where(a_ok, np.log(np.where(a_ok, ax / ay, 1.0)), 0.0)
    wp = np.where(p_ok, rel ** 2, 0.0)
    wa = np.where(a_ok, rel, 0.0)

    def to_own(weight: np.ndarray, value: np.ndarray, tie: np.ndarray) -> np.ndarray:
        total = weight.sum(axis=0)                                            # (2, S): per W_0 comp.
        mean = np.where(total > 0, (weight * value).sum(axis=0) / np.where(total > 0, total, 1), 0.0)
        w = np.abs(carry) * total.T[:, :, None]                               # (S, c, m)
        num = (w * mean.T[:, :, None]).sum(axis=1)                            # (S, m)
        den = w.sum(axis=1)
        own = np.where(den > 0, num / np.where(den > 0, den, 1), 0.0)
        both = np.where(den.sum(axis=1) > 0, num.sum(axis=1) / np.where(den.sum(axis=1) > 0,
                                                                        den.sum(axis=1), 1), 0.0)
        own = np.where(tie[:, None], both[:, None], own)
        return np.clip(own, -MOTION_FIT_STEP, MOTION_FIT_STEP)

    return to_own(wp, lp, tied), to_own(wa, la, np.zeros_like(tied))


def motion_fit(original: Tree, values: dict[str, np.ndarray], rebuild: Callable[[dict], tuple[str, Tree]],
               to_group: np.ndarray, carry: np.ndarray, runs_for: Callable[[Tree], Runs],
               level: int, dt: float) -> tuple[str, Tree]:
    """The best of MOTION_FIT_ROUNDS rounds of corrections (module docstring) to ``values``
    (group order: each key an array over groups), as (text, tree) from ``rebuild(values)``.

    to_group (S,): the group of each level-tree branch (tree order); carry (S, 2, 2) their carry
    maps; runs_for(tree): the original's `Runs` in the fit winds, read with ``tree``'s groups.
    """
    from .explicit import period_of_strength, strength_of_period

    values = {k: np.array(v, dtype=np.float64) for k, v in values.items()}
    text, tree = first = rebuild(values)
    runs = runs_for(tree)
    winds, largest = runs.winds, runs.largest_combined_angle()
    best = None
    gain_keys = [k for k in GAIN_KEYS if k in values] or ["force_absorbed"]
    rows = {"bend": gain_keys[:3] if len(gain_keys) == 6 else gain_keys,
            "rotation": gain_keys[3:] if len(gain_keys) == 6 else gain_keys}
    for round_ in range(MOTION_FIT_ROUNDS + 1):
        try:
            reports = runs.compare(tree)
        except InputError:                        # the corrected level diverges: keep the best
            break
        rank = form_rank(list(zip(winds, reports)), level, largest)
        if best is None or rank < best[0]:
            best = (rank, text, tree)
        if round_ == MOTION_FIT_ROUNDS or (rank[0] == 0 and rank[1] <= MOTION_FIT_GOOD):
            break
        ax, ay, px, py, a_max = swing_figures(reports, largest)
        kb = values["bend_strength"][to_group]
        kr = values["rotation_strength"][to_group]
        tied = kb == kr
        d_period, d_gain = own_corrections(ax, ay, px, py, a_max, carry, tied)
        values["bend_strength"][to_group] = strength_of_period(
            period_of_strength(kb, dt) * np.exp(d_period[:, 0]), dt)
        values["rotation_strength"][to_group] = strength_of_period(
            period_of_strength(kr, dt) * np.exp(d_period[:, 1]), dt)
        if len(gain_keys) == 6:
            for m, name in enumerate(("bend", "rotation")):
                for key in rows[name]:
                    values[key][to_group] *= np.exp(d_gain[:, m])
        else:                                     # one k_FA: the mean of the two rows' corrections
            values["force_absorbed"][to_group] *= np.exp(d_gain.mean(axis=1))
        text, tree = rebuild(values)
    return first if best is None else (best[1], best[2])
