"""Fit an explicit level to motion (issue 21 item 2): correct each level branch's periods and
gains from its simulated swing against its group's, on the measures themselves.

The statics (`closed_form`, `gain_matrix`) and the swing model (`explicit.dominant_strengths`:
members started from rest, each on its own) fix a level branch's parameters before anything
moves. What they cannot see — a parent's lean turning the force a group feels, members whose
periods beat, a chord whose bending plane turns against W_0 (model.md 6) — shows in the level's
own runs. So, over the winds the level is measured in (`simplify`'s winds: the original run
once for the whole chain, `shared_runs`), each round simulates the level and reads, per group g
and W_0 component c (model.md 6's measures, in `compare_groups`), over the winds where the
component counts:

    ρ_P[g, c] = Σ_w q ln(P_x / P_y) / Σ_w q,     q = (A_x / A_max)²   (the major swings lead)
    ρ_A[g, c] = ln(Σ_w A_x A_y / Σ_w A_y²)   (the least-squares scale of the level's swing;
                                             the motion error |A_y - A_x| / A_max is linear in it)

and carries them back to the branch's own components through its carry map C (y = C θ',
`compare.groups.carry_matrix`): own component m takes Σ_c |C[c, m]| w_c ρ[g, c] / Σ_c |C[c, m]| w_c
(w_c: the summed weights). The branch's own period is multiplied by exp(ρ_P) (so its strength is
`strength_of_period` of it), clipped to exp(±MOTION_FIT_STEP). A branch whose two strengths are
one (`explicit.own_strengths` tied them) keeps them tied.

Gains: a level whose branches carry the gain matrix G gets G refitted wind by wind
(`gain_matrix_step`): its static W_0 angles C diag(1000 / k) G f(w) (f the rest force in the
branch's swing frame) are fitted to the current ones scaled by A_x / A_y per wind and
component, so a group that swings more than its level branch toward one direction and less
toward another is followed there (one scale per row cannot). That fit assumes a branch swings
as far as its static angle says. A branch whose swing is more than MOTION_FIT_AMPLIFIED
times its static angle (`swing_amplification`) is driven by something else: its frame turning
with its parent, the force along its axis turned across it. Refitting G to its statics moves
the wrong entries (its lateral force is nearly nothing), so its rows are scaled by exp(ρ_A)
instead, which scales every drive that passes through them. A level with one k_FA per branch
scales it by exp of the mean of the two rows' ρ_A, clipped as above.

That static model of a swing fails where a component's static reading cancels between the
branch's two own angles (C mixes them): the group still swings there, and so does the branch,
at its two periods (`swing_model`), but the static fit reads a swing of many times its static
angle and scales rows. So where the rounds still miss in some fit wind and some branch's
carry map mixes two own angles of different strengths (`swings_differ`; elsewhere the
modelled swing is the static reading times a constant), the fit runs once
more from the same start with the modelled swing in place of the static angle
(`dynamic_gain_step`; the amplification read against it, so only a branch driven by its
frame's turning has its rows scaled), and that second fit replaces the first only where it
ranks no worse on both of `form_rank`'s counts and worth a round against it (`dominates`): fewer winds
missed at a higher worst ratio is a trade the fit winds cannot judge (family sympodial-29:
4 winds missed at 4.96 the bounds against 6 at 2.93, and worse in the family's winds).

Only the winds where the original stays within SMALL_ANGLE_LIMIT are run (the bounds hold
only there; all of them where none does), and of those only the ones where its linear statics
turn no branch's axis by more than MOTION_FIT_TURN (`unturned`: a chain turns its top far
while every group stays small, and its periods then leave their small-angle values). A
chain's periods are corrected both ways (`both_ways`: toward the mean of the upward and
downward crossings' paces where one branch can hold both). Each round is scored group by group
(`group_scores`: each level branch's worst figure over the level's bounds), and each group
keeps the values of its best round; the corrections go on from the latest round (a group
that got worse may get better again). At most MOTION_FIT_ROUNDS rounds; the fit stops at the
first round that does not improve on the best whole round (`bounds.form_rank`: winds missing
the level's bounds, then the worst ratio) by a wind fewer missed or a worst ratio
MOTION_FIT_MIN_GAIN lower (`improves`; later rounds gain less than that), or once every wind
is within MOTION_FIT_GOOD of its bounds. The result is whichever ranks best on the fit winds:
the groups' best rounds put together (run once more, unless the best whole round already
holds every fit wind), or the best whole round; so the fit can only help on the winds it is
scored in.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.system import GAIN_KEYS
from plantlod.lsys.tree import Tree

from .bounds import form_rank
from .constants import (COUNTED_AMPLITUDE_FRACTION, LEVEL_BOUNDS, MOTION_FIT_AMPLIFIED,
                        MOTION_FIT_BOTH_WAYS, MOTION_FIT_GAIN_RIDGE, MOTION_FIT_GOOD,
                        MOTION_FIT_MIN_GAIN, MOTION_FIT_ROUNDS, MOTION_FIT_STEP,
                        MOTION_FIT_SWING_ITERATIONS, MOTION_FIT_TURN, SMALL_ANGLE_LIMIT,
                        STALK_BOUNDS, SWING_MIX)
from .evaluate import Runs, WindCase
from .swing_model import carry_mixing, step_responses, swing_amplitudes


def shared_runs(original: Tree, winds: list[WindCase], dt: float, steps: int, every: int,
                damping, simulated: list | Callable[[], list],
                tip_cache: dict | None = None) -> Callable[[Tree], Runs]:
    """runs_for(tree): the original's `Runs` in ``winds`` (its runs ``simulated``, an
    `evaluate.simulate_runs` list, or a function giving it when first needed) read with
    ``tree``'s groups, made once per set of level branch addresses and group roots (two
    groupings of one shape, as a chain's regrouped level 1, have the same addresses), so
    that a level's fit and its measurement share it; ``tip_cache`` (a dict, `Runs`) is
    shared by a chain's levels."""
    from .targets import group_map

    made: dict[tuple[str, ...], Runs] = {}
    tips = {} if tip_cache is None else tip_cache   # the original's group tips (`Runs`)

    def runs_for(tree: Tree) -> Runs:
        key = (tuple(tree.address), tuple(tree.group_root))
        if key not in made:
            made.clear()
            made[key] = Runs(original, group_map(original, tree), winds, dt, steps, every, damping,
                             simulated=simulated() if callable(simulated) else simulated,
                             tip_cache=tips)
        return made[key]

    return runs_for


def measurement_runs_for(original: Tree, dt: float, duration: float,
                         damping_ratio: float = 0.0) -> Callable[[Tree], Runs]:
    """`shared_runs` in simplify's measurement winds over SIMPLIFY_WIND_RANGE (every
    SIMPLIFY_EVERY-th step kept), the original simulated here, once: what a level is fitted to
    motion in when no caller shares its own runs (`explicit.explicit_system_text`, a scene's
    chain)."""
    from plantlod.sim.damping import Damping

    from .constants import SIMPLIFY_EVERY, SIMPLIFY_WIND_RANGE
    from .evaluate import simulate_runs, wind_cases

    winds = wind_cases(*SIMPLIFY_WIND_RANGE)
    steps = int(round(duration / dt))
    damping = Damping(ratio=damping_ratio)
    return shared_runs(original, winds, dt, steps, SIMPLIFY_EVERY, damping,
                       list(simulate_runs(original, winds, dt, steps, SIMPLIFY_EVERY, damping)))


def unturned(original: Tree, runs: Runs, largest: list[float]) -> tuple[Runs, list[float]]:
    """``runs`` (and their ``largest`` combined angles) without the winds in which the
    original's linear statics turn some branch's axis by more than MOTION_FIT_TURN
    (`static.turned_most`); the lowest speed's winds where every wind does.

    A group's combined angle can stay small while the branches below it turn it far: a stalk
    of 80 branches at 15 m/s turns its top by 0.5-1 rad while no group passes 0.1 rad. Its
    members' forces then follow their turned frames, the chain couples, and its periods leave
    their small-angle values (family stalk-36: one group's 4.48 s at 0.5 m/s, 3.06 s at
    20 m/s); a level's strengths corrected toward those periods miss every slow wind. Family
    tuning range, levels 1 / 2: the stalks 209 / 159 -> 226 / 206 of 434 / 413 cases (a cut at
    4 m/s instead, 236 / 206); the branching kinds 3088 / 3208 -> 3087 / 3206."""
    keep = list(np.flatnonzero(within_turn(original, runs.winds)))
    if not keep:
        slowest = min(w.speed for w in runs.winds)
        keep = [k for k, w in enumerate(runs.winds) if w.speed == slowest]
    if len(keep) == len(runs.winds):
        return runs, largest
    return runs.subset(keep), [largest[k] for k in keep]


def within_turn(original: Tree, winds: list[WindCase]) -> np.ndarray:
    """(W,) bool: the winds in which the original's linear statics turn no branch's axis by
    more than MOTION_FIT_TURN (`static.turned_most`), where a chain stays linear (`unturned`)."""
    from .static import turned_most

    turned = turned_most(original, wind_directions(winds), [w.speed for w in winds])
    return np.asarray(turned) <= MOTION_FIT_TURN


def wind_directions(winds: list[WindCase]) -> np.ndarray:
    """(W, 3) unit horizontal directions of ``winds``: cos and sin of the azimuth. The runs blow
    `sim.wind.wind_from_speed`'s exact axis vectors; using those moves the fitted gains in
    their last digits (every level file's bytes), so it waits for a change that re-measures
    the family."""
    az = np.radians([w.direction for w in winds])
    return np.stack([np.cos(az), np.sin(az), np.zeros(len(winds))], axis=1)


def fit_wind_forces(tree: Tree, winds: list[WindCase]) -> np.ndarray:
    """(W, S, 3) N: each branch's total rest force in its rest swing frame in each wind
    (model.md 4 at rest: v F^L + v² F^D, `static.wind_forces`)."""
    from .static import rest_frames, wind_forces

    frames = rest_frames(tree)
    world = wind_forces(tree, wind_directions(winds), [w.speed for w in winds], frames)
    return np.einsum("sji,wsj->wsi", frames.swing, world)


def swing_figures(reports) -> tuple[np.ndarray, ...]:
    """(A_x, A_y, P_x, P_y) (W, 2, S) and A_max (W,) of ``reports`` (one `Report` per fit wind;
    `motion_fit` has already kept only the winds within SMALL_ANGLE_LIMIT)."""
    figures = np.array([[getattr(r.table, name) for r in reports]
                        for name in ("amplitude_original", "amplitude_simplified",
                                     "period_original", "period_simplified")],
                       dtype=np.float64)                                      # (4, W, 2, S)
    a_max = np.array([r.largest_amplitude for r in reports], dtype=np.float64)
    return figures[0], figures[1], figures[2], figures[3], a_max


def own_corrections(ax, ay, px, py, a_max, carry: np.ndarray, tied: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Log-corrections (S, 2) of each level branch's own period and own gain rows (bend,
    rotation), from the figures of `swing_figures` and its carry map ``carry`` (S, 2, 2);
    ``tied`` (S,): branches whose two strengths are one get one period correction."""
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(a_max > 0, a_max, 1.0)[:, None, None]
        rel, rel_y = ax / scale, ay / scale
        counted = (a_max[:, None, None] > 0) & (rel >= COUNTED_AMPLITUDE_FRACTION)
        p_ok = counted & np.isfinite(px) & np.isfinite(py) & (px > 0) & (py > 0)
        a_ok = counted & (ay > 0)
        lp = np.where(p_ok, np.log(np.where(p_ok, px / py, 1.0)), 0.0)
    # periods: the log-ratios' mean weighted by the squared swing (the major ones lead)
    wp = np.where(p_ok, rel ** 2, 0.0)
    p_total = wp.sum(axis=0)                                                  # (2, S)
    p_mean = np.where(p_total > 0, (wp * lp).sum(axis=0) / np.where(p_total > 0, p_total, 1), 0.0)
    # gains: the least-squares scale s of the level's swing, min Σ_w (s A_y - A_x)² / A_max²
    # (the motion error is linear in it), as ln s
    xy = np.where(a_ok, rel * rel_y, 0.0).sum(axis=0)
    a_total = np.where(a_ok, rel_y ** 2, 0.0).sum(axis=0)
    a_mean = np.where((a_total > 0) & (xy > 0),
                      np.log(np.where((a_total > 0) & (xy > 0), xy / np.where(a_total > 0, a_total, 1), 1.0)),
                      0.0)

    def to_own(total: np.ndarray, mean: np.ndarray, tie: np.ndarray) -> np.ndarray:
        """Per W_0 component corrections ``mean`` (2, S) of weight ``total`` to own ones (S, 2)."""
        w = np.abs(carry) * total.T[:, :, None]                               # (S, c, m)
        num = (w * mean.T[:, :, None]).sum(axis=1)                            # (S, m)
        den = w.sum(axis=1)
        own = np.where(den > 0, num / np.where(den > 0, den, 1), 0.0)
        both = np.where(den.sum(axis=1) > 0, num.sum(axis=1) / np.where(den.sum(axis=1) > 0,
                                                                        den.sum(axis=1), 1), 0.0)
        own = np.where(tie[:, None], both[:, None], own)
        return np.clip(own, -MOTION_FIT_STEP, MOTION_FIT_STEP)

    return to_own(p_total, p_mean, tied), to_own(a_total, a_mean, np.zeros_like(tied))


def swing_ratios(ax: np.ndarray, ay: np.ndarray, a_max: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the gain steps fit toward: A_max (W,) with 1 where it is 0, and per (W, S, c) the
    ratio A_x / A_y of the group's swing to the branch's and its weight (A_x / A_max)² where the
    component counts and the branch swings (ratio 1, weight 0 elsewhere); ax, ay (W, 2, S) and
    a_max (W,) as `swing_figures` gives them."""
    scale = np.where(a_max > 0, a_max, 1.0)
    ax, ay = np.transpose(ax, (0, 2, 1)), np.transpose(ay, (0, 2, 1))          # (W, S, c)
    rel = ax / scale[:, None, None]
    ok = (a_max[:, None, None] > 0) & (rel >= COUNTED_AMPLITUDE_FRACTION) & (ay > 0)
    return scale, np.where(ok, ax / np.where(ok, ay, 1.0), 1.0), np.where(ok, rel ** 2, 0.0)


def gain_matrix_step(gain: np.ndarray, k_old: np.ndarray, k_new: np.ndarray, carry: np.ndarray,
                     force: np.ndarray, ax: np.ndarray, ay: np.ndarray, a_max: np.ndarray,
                     ridge: float = MOTION_FIT_GAIN_RIDGE) -> np.ndarray:
    """New gain matrices (S, 2, 3) whose static swing reads, wind by wind, as the group swings.

    gain (S, 2, 3) the level branches' G; k_old, k_new (S, 2) their strengths before and after
    this round's period step; carry (S, 2, 2); force (W, S, 3) each branch's rest force in its
    swing frame in each fit wind (N); ax, ay (W, 2, S) the group's and the branch's amplitudes
    in W_0 (`swing_figures`), a_max (W,).

    The branch's static W_0 angles are y(w) = C diag(1000 / k) G f(w) (model.md 4, 5). Where a
    component counts, the target is y_old(w) A_x / A_y (its swing scaled as the group's); G is
    the ridge-regularised least-squares fit to those targets in A_max units, each (w, c)
    weighted by (A_x / A_max)² (the major swings lead), pulled toward the current G (directions
    no fit wind drives keep their gains).
    """
    scale, ratio, weight = swing_ratios(ax, ay, a_max)
    # y_old (W, S, c): static own angles carried into W_0; the targets in A_max units
    target = static_reading(gain, k_old, carry, force) * ratio / scale[:, None, None]
    # design (W, S, c, m, j): C[c, m] 1000 / k_new[m] f_j, in A_max units
    design = (carry[None, :, :, :, None] * (1000.0 / k_new)[None, :, None, :, None]
              * force[:, :, None, None, :]) / scale[:, None, None, None, None]
    design = design.reshape(force.shape[0], force.shape[1], 2, 6)              # (W, S, c, 6)
    normal = np.einsum("wsc,wsck,wscl->skl", weight, design, design)           # (S, 6, 6)
    rhs = np.einsum("wsc,wsck,wsc->sk", weight, design, target)                # (S, 6)
    g0 = gain.reshape(-1, 6)
    lam = ridge * np.maximum(np.trace(normal, axis1=1, axis2=2) / 6.0, 1e-300)  # (S,)
    normal = normal + lam[:, None, None] * np.eye(6)[None]
    rhs = rhs + lam[:, None] * g0
    solved = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
    active = weight.sum(axis=(0, 2)) > 0
    return np.where(active[:, None], solved, g0).reshape(-1, 2, 3)


def dynamic_gain_step(gain: np.ndarray, k_old: np.ndarray, k_new: np.ndarray, carry: np.ndarray,
                      force: np.ndarray, ax: np.ndarray, ay: np.ndarray, a_max: np.ndarray,
                      h_old: np.ndarray, h_new: np.ndarray, ridge: float = MOTION_FIT_GAIN_RIDGE,
                      iterations: int = MOTION_FIT_SWING_ITERATIONS) -> np.ndarray:
    """New gain matrices (S, 2, 3) whose modelled swing reads, wind by wind, as the group swings:
    `gain_matrix_step` with `swing_model`'s amplitudes A(G, k) in place of static angles.

    Arguments as `gain_matrix_step`'s; h_old, h_new (K, S, 2) the `swing_model.step_responses`
    of k_old and k_new. Where a component counts, the target is A(G, k_old) A_x / A_y (the
    modelled swing scaled as the group's, in A_max units); G' minimises

        Σ_w,c (A_x / A_max)² (A(G', k_new) / A_max - target)² + λ |G' - G|²

    (λ as `gain_matrix_step`'s, from the first step's normal matrix) by up to ``iterations``
    Gauss-Newton steps (A is piecewise linear in G), each branch keeping a step only where it
    lowers that sum.
    """
    scale, ratio, weight = swing_ratios(ax, ay, a_max)
    modelled, _ = swing_amplitudes(h_old, own_swings(gain, k_old, carry, force))
    target = modelled * ratio / scale[:, None, None]
    g0 = gain.reshape(-1, 6)
    # dA/dG[m, j] = dA/d own[c, m] C[c, m] 1000 / k_m f_j (W, S, c, m, j), in A_max units
    drive = (carry[None] * (1000.0 / k_new)[None, :, None, :])[..., None] \
        * force[:, :, None, None, :] / scale[:, None, None, None, None]

    def misfit(g: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(S,) the weighted sum, residuals (W, S, c) and Jacobian (W, S, c, 6) at g (S, 6)."""
        amp, grad = swing_amplitudes(h_new, own_swings(g.reshape(-1, 2, 3), k_new, carry, force))
        r = amp / scale[:, None, None] - target
        jac = (grad[..., None] * drive).reshape(r.shape + (6,))
        return (weight * r ** 2).sum(axis=(0, 2)), r, jac

    g = g0.copy()
    value, r, jac = misfit(g)
    lam = None                                # (S,) from the first step's normal matrix
    for _ in range(iterations):
        normal = np.einsum("wsc,wsck,wscl->skl", weight, jac, jac)             # (S, 6, 6)
        if lam is None:
            lam = ridge * np.maximum(np.trace(normal, axis1=1, axis2=2) / 6.0, 1e-300)
        rhs = -np.einsum("wsc,wsck,wsc->sk", weight, jac, r) - lam[:, None] * (g - g0)
        trial = g + np.linalg.solve(normal + lam[:, None, None] * np.eye(6)[None],
                                    rhs[:, :, None])[:, :, 0]
        t_value, t_r, t_jac = misfit(trial)
        better = (t_value + lam * ((trial - g0) ** 2).sum(axis=1)
                  < value + lam * ((g - g0) ** 2).sum(axis=1))
        if not better.any():
            break
        g = np.where(better[:, None], trial, g)
        value = np.where(better, t_value, value)
        r = np.where(better[None, :, None], t_r, r)
        jac = np.where(better[None, :, None, None], t_jac, jac)
    active = weight.sum(axis=(0, 2)) > 0
    return np.where(active[:, None], g, g0).reshape(-1, 2, 3)


def own_statics(gain: np.ndarray, strength: np.ndarray, force: np.ndarray) -> np.ndarray:
    """(W, S, m) each level branch's static own angles θ*_m = 1000 (G f)_m / k_m (model.md 4,
    5): gain (S, 2, 3), strength (S, 2) k_bs and k_rs, force (W, S, 3) its rest force in its
    swing frame (`fit_wind_forces`)."""
    return 1000.0 / strength[None, :, :] * np.einsum("smj,wsj->wsm", gain, force)


def own_swings(gain: np.ndarray, strength: np.ndarray, carry: np.ndarray,
               force: np.ndarray) -> np.ndarray:
    """(W, S, c, m) `own_statics` weighed by the carry map (S, 2, 2) into the group root's
    frame W_0, C[c, m] θ*_m (`swing_model.swing_amplitudes`' ``own``)."""
    return carry[None, :, :, :] * own_statics(gain, strength, force)[:, :, None, :]


def static_reading(gain: np.ndarray, strength: np.ndarray, carry: np.ndarray,
                   force: np.ndarray) -> np.ndarray:
    """(W, S, 2) each level branch's static angles read in its group root's frame W_0,
    y = C diag(1000 / k) G f (model.md 4, 5), arguments as `own_swings`'."""
    return np.einsum("scm,wsm->wsc", carry, own_statics(gain, strength, force))


def improves(rank: tuple, best: tuple) -> bool:
    """Whether a round's `form_rank` (winds missed, worst ratio) is worth another round
    against the best so far: a wind fewer missed, or the same and a worst ratio at least
    MOTION_FIT_MIN_GAIN lower."""
    return rank[0] < best[0] or (rank[0] == best[0] and rank[1] < best[1] * (1 - MOTION_FIT_MIN_GAIN))


def dominates(rank: tuple, other: tuple) -> bool:
    """Whether a `form_rank` (winds missed, worst ratio) is no worse than ``other`` on both
    counts and worth a round against it (`improves`: a wind fewer, or a worst ratio
    MOTION_FIT_MIN_GAIN lower): where the motion fit's second fit replaces its first."""
    return rank[0] <= other[0] and rank[1] <= other[1] and improves(rank, other)


def swings_differ(carry: np.ndarray, bend_strength: np.ndarray,
                  rotation_strength: np.ndarray) -> np.ndarray:
    """(S,) the level branches whose modelled swing (`swing_model`) is not their static W_0
    reading times one constant per component: those whose carry map (S, 2, 2) mixes their two
    own angles (a diagonal and an off-diagonal entry both above SWING_MIX) and whose two
    strengths differ, so that the two swing at two periods. Elsewhere the second fit would
    repeat the first (family abop_1_24c's chain: no such branch at any level)."""
    return (carry_mixing(carry) > SWING_MIX) & (bend_strength != rotation_strength)


def swing_amplification(gain: np.ndarray, strength: np.ndarray, carry: np.ndarray,
                        force: np.ndarray, ay: np.ndarray, a_max: np.ndarray,
                        h: np.ndarray | None = None) -> np.ndarray:
    """(S,) the largest ratio, over fit winds and counted W_0 components, of a level branch's
    swing A_y to its static angle |C diag(1000 / k) G f| (model.md 4, 5): 1 for a branch that
    swings from rest as its statics say (an oscillator started at rest swings from 0 to twice
    its static angle), far above where its swing is driven by its frame's turning.

    gain (S, 2, 3); strength (S, 2) k_bs, k_rs; carry (S, 2, 2); force (W, S, 3) the rest force
    in each branch's swing frame (`fit_wind_forces`); ay (W, 2, S), a_max (W,) as
    `swing_figures` gives them; h (K, S, 2) `swing_model.step_responses` of ``strength``:
    the ratio to the modelled swing (`swing_model.swing_amplitudes`), 1 for a branch that
    swings as its own two oscillators do, in place of the static angle."""
    ay = np.transpose(ay, (0, 2, 1))                                           # (W, S, c)
    if h is None:
        reference = np.abs(static_reading(gain, strength, carry, force))
    else:
        reference = swing_amplitudes(h, own_swings(gain, strength, carry, force))[0]
    counted = (a_max[:, None, None] > 0) & (ay >= COUNTED_AMPLITUDE_FRACTION * a_max[:, None, None])
    ratio = np.where(counted, ay / np.maximum(reference, 1e-300), 0.0)
    return ratio.max(axis=(0, 2), initial=0.0)


def group_scores(reports, level: int, stalk: bool, s_count: int) -> np.ndarray:
    """(S,) each level branch's worst figure over its bound in ``reports`` (one `Report` per
    fit wind): the motion error of its counted components (a stalk: their relative amplitude
    error), the period error of its major ones (a stalk: of its counted ones) and its tip
    error, each over the level's bound. The largest over branches is `bounds.bounds_score`
    of the same reports (tests/test_motion_fit.py)."""
    motion, period, tip = LEVEL_BOUNDS[min(level, max(LEVEL_BOUNDS))]
    if stalk:
        motion, period = STALK_BOUNDS[min(level, max(STALK_BOUNDS))]
    worst = np.zeros(s_count)
    for r in reports:
        t = r.table
        a_max = r.largest_amplitude
        if not a_max > 0:
            continue
        counted = t.counted
        if stalk:
            amp = np.where(counted, t.amplitude_error, 0.0)
            timed = counted & np.isfinite(t.period_error)
        else:
            amp = np.where(counted, t.motion(a_max), 0.0)
            timed = t.major(a_max)
        per = np.where(timed, t.period_error, 0.0)
        tips = np.where(np.isfinite(t.tip_error), t.tip_error, 0.0)
        worst = np.maximum.reduce([worst, amp.max(axis=0) / motion, per.max(axis=0) / period,
                                   tips / tip])
    return worst


def opposite_period_errors(runs: Runs, tree: Tree, reports) -> list[np.ndarray | None]:
    """Per wind of ``runs``, (S,) each group's largest period error in the opposite wind over
    its counted components, or None where that wind does not count: a chain's level, compared
    with ``downward`` set (``reports``: those `Report`s, one per wind).

    Below SMALL_ANGLE_LIMIT a chain's response to the reversed wind is the negative, whose
    upward crossings (model.md 6's period) are this run's downward ones
    (`evaluate.downward_periods`); so each wind where the original's combined angles stay
    under SMALL_ANGLE_LIMIT and its linear statics turn no axis past MOTION_FIT_TURN
    (`within_turn`) reads, per group, |P_y,down / P_x,down - 1| over the components the
    upward report counts (a component with no downward period: 0)."""
    out: list[np.ndarray | None] = []
    for report, (p_x, p_y), largest, linear in zip(
            reports, runs.downward(tree), runs.largest_combined_angle(),
            within_turn(runs.original, runs.winds)):
        if largest > SMALL_ANGLE_LIMIT or not linear:
            out.append(None)
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.abs(np.asarray(p_y) / np.asarray(p_x) - 1.0)          # (2, S)
        counted = np.asarray(report.table.counted, dtype=bool) & np.isfinite(error)
        out.append(np.where(counted, error, 0.0).max(axis=0, initial=0.0))
    return out


def both_ways(px: np.ndarray, py: np.ndarray, down: list, bound: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """The periods (W, 2, S) a round corrects toward, where the opposite winds count too.

    In the linear regime a wind from the opposite side gives the negative response, whose
    upward crossings are this wind's downward ones (`evaluate.downward_periods`); a group
    whose components sum members of several periods crosses its mean at another pace
    downward than upward over a window of a few periods (family stalk-63: 3.598 s and
    3.509 s), while its level branch, nearly one oscillator, crosses at one pace. Where the
    group's two paces lie within 2 MOTION_FIT_BOTH_WAYS bounds of each other, both are held
    by the geometric means of the group's and of the branch's two paces; elsewhere the upward
    one alone (a branch between them would miss both). ``down``: per wind, (original,
    level) downward periods (2, S); bound: the level's period bound."""
    pxd = np.stack([d[0] for d in down])
    pyd = np.stack([d[1] for d in down])
    with np.errstate(divide="ignore", invalid="ignore"):
        gap = np.abs(np.log(px / pxd))
        both = np.isfinite(gap) & (gap <= 2.0 * MOTION_FIT_BOTH_WAYS * bound) \
            & np.isfinite(pyd) & (pyd > 0)
        return (np.where(both, np.sqrt(px * pxd), px), np.where(both, np.sqrt(py * pyd), py))


def corrected(values: dict[str, np.ndarray], reports, to_group: np.ndarray, carry: np.ndarray,
              dt: float, force: np.ndarray | None, down: list | None = None,
              bound: float = 0.0, swing: Runs | None = None) -> dict[str, np.ndarray]:
    """``values`` after one round of corrections (module docstring) from ``reports``, the
    level's runs with ``values`` in the fit winds; ``force`` (`fit_wind_forces`) for a level
    with gain matrices, None for one with k_FA; ``down`` (`evaluate.Runs.downward`) where the
    periods are corrected both ways (`both_ways`, ``bound`` the level's period bound); ``swing``:
    the fit winds' `Runs`, whose steps, sampling and damping the gain step's swing model
    follows (`dynamic_gain_step`), None for the static model (`gain_matrix_step`)."""
    from plantlod.sim.damping import as_damping, period_of_strength

    from .explicit import strength_of_period

    values = {k: v.copy() for k, v in values.items()}
    ax, ay, px, py, a_max = swing_figures(reports)
    if down is not None:
        px, py = both_ways(px, py, down, bound)
    kb = values["bend_strength"][to_group]
    kr = values["rotation_strength"][to_group]
    d_period, d_gain = own_corrections(ax, ay, px, py, a_max, carry, kb == kr)
    values["bend_strength"][to_group] = strength_of_period(
        period_of_strength(kb, dt) * np.exp(d_period[:, 0]), dt)
    values["rotation_strength"][to_group] = strength_of_period(
        period_of_strength(kr, dt) * np.exp(d_period[:, 1]), dt)
    if force is None:                         # one k_FA: the mean of the two rows' corrections
        values["force_absorbed"][to_group] *= np.exp(d_gain.mean(axis=1))
        return values
    # G fitted to the group's swing, wind by wind; rows scaled where the swing is not static
    g = np.stack([values[k][to_group] for k in GAIN_KEYS], axis=1).reshape(-1, 2, 3)
    k_old = np.stack([kb, kr], axis=1)
    k_new = np.stack([values["bend_strength"][to_group],
                      values["rotation_strength"][to_group]], axis=1)
    if swing is None:
        fitted = gain_matrix_step(g, k_old, k_new, carry, force, ax, ay, a_max)
        h_old = None
    else:
        damping = as_damping(swing.damping)
        h_old, h_new = (step_responses(k, dt, swing.steps, swing.every, damping)
                        for k in (k_old, k_new))
        fitted = dynamic_gain_step(g, k_old, k_new, carry, force, ax, ay, a_max, h_old, h_new)
    amplified = swing_amplification(g, k_old, carry, force, ay, a_max, h_old) > MOTION_FIT_AMPLIFIED
    g = np.where(amplified[:, None, None], g * np.exp(d_gain)[:, :, None], fitted).reshape(-1, 6)
    for k, key in enumerate(GAIN_KEYS):
        values[key][to_group] = g[:, k]
    return values


def motion_fit(original: Tree, values: dict[str, np.ndarray], rebuild: Callable[[dict], tuple[str, Tree]],
               to_group: np.ndarray, carry: np.ndarray, runs_for: Callable[[Tree], Runs],
               level: int, dt: float) -> tuple[str, Tree]:
    """Rounds of corrections (module docstring) to ``values`` (group order: each key an array
    over groups), each group's best round kept; as (text, tree) from ``rebuild(values)``.

    to_group (S,): the group of each level-tree branch (tree order); carry (S, 2, 2) their carry
    maps; runs_for(tree): the original's `Runs` in the fit winds, read with ``tree``'s groups.
    The rounds change the level tree's arrays in place of its text (parsing a level of
    thousands of branches takes longer than simulating it).
    """
    from .explicit import is_stalk

    stalk = is_stalk(original)                # held to the relative bounds (STALK_BOUNDS)

    values = {k: np.array(v, dtype=np.float64) for k, v in values.items()}
    first = rebuild(values)
    level_tree = first[1]
    runs = runs_for(level_tree)
    largest = runs.largest_combined_angle()
    small = [k for k, a in enumerate(largest) if a <= SMALL_ANGLE_LIMIT]
    if small:                                 # only winds where the bounds hold are fitted
        runs = runs.subset(small)
        largest = [largest[k] for k in small]
    runs, largest = unturned(original, runs, largest)
    period_bound = STALK_BOUNDS[min(level, max(STALK_BOUNDS))][1]   # (a chain's, `both_ways`)
    winds = runs.winds
    gains = all(k in values for k in GAIN_KEYS)
    s_count = len(to_group)

    def tree_of(v: dict[str, np.ndarray]) -> Tree:
        changed = {"bend_strength": v["bend_strength"][to_group],
                   "rotation_strength": v["rotation_strength"][to_group]}
        if gains:
            changed["force_gain"] = np.stack([v[k][to_group] for k in GAIN_KEYS], axis=1)
        else:
            changed["force_absorbed"] = v["force_absorbed"][to_group]
        return replace(level_tree, **changed)

    def rank_of(v: dict[str, np.ndarray]):
        """(form_rank, reports, downward) of the level with values ``v``, downward the
        `Runs.downward` periods of a chain (its periods are corrected both ways, `both_ways`),
        None for another tree; None where the level diverges."""
        tree = tree_of(v)
        try:
            reports = runs.compare(tree, downward=stalk)
        except InputError:
            return None
        down = runs.downward(tree) if stalk else None
        return form_rank(list(zip(winds, reports)), level, largest, stalk), reports, down

    forces: list[np.ndarray] = []             # `fit_wind_forces`, once a round corrects gains

    start = rank_of(values)                   # round 0 of either fit: the level as it came

    def fit(swing: Runs | None) -> tuple[tuple | None, tuple[str, Tree]]:
        """(its `form_rank` or None, the level) of rounds from ``values`` with the static
        (``swing`` None) or the modelled swing (``swing``: the fit winds' runs) in the gain
        step (`corrected`)."""
        current = {k: v.copy() for k, v in values.items()}
        best = None                           # (rank, values, round) of the best whole round
        best_score = np.full(s_count, np.inf)     # each level branch's best score so far
        kept = {k: v.copy() for k, v in values.items()}   # each group's values of that round
        for round_ in range(MOTION_FIT_ROUNDS + 1):
            ranked = start if round_ == 0 else rank_of(current)
            if ranked is None:                # the corrected level diverges: keep the best
                break
            rank, reports, down = ranked
            gained = best is None or improves(rank, best[0])
            if best is None or rank < best[0]:
                best = (rank, {k: v.copy() for k, v in current.items()}, round_)
            score = group_scores(reports, level, stalk, s_count)
            better = score < best_score
            best_score[better] = score[better]
            for key in kept:
                kept[key][to_group[better]] = current[key][to_group[better]]
            if round_ == MOTION_FIT_ROUNDS or not gained or (rank[0] == 0 and rank[1] <= MOTION_FIT_GOOD):
                break
            if gains and not forces:
                forces.append(fit_wind_forces(level_tree, winds))
            current = corrected(current, reports, to_group, carry, dt, forces[0] if gains else None,
                                down, period_bound, swing)
        if best is None:
            return None, first
        if best[0][0] > 0 and any(not np.array_equal(kept[k], best[1][k]) for k in kept):
            ranked = rank_of(kept)            # the groups' best rounds put together
            if ranked is not None and ranked[0] < best[0]:
                return ranked[0], rebuild(kept)
        return best[0], (first if best[2] == 0 else rebuild(best[1]))

    rank, level_text = fit(None)
    if (gains and rank is not None and rank[0] > 0     # misses a fit wind: the modelled swing,
            and swings_differ(carry, values["bend_strength"][to_group],
                              values["rotation_strength"][to_group]).any()):
        second_rank, second = fit(runs)
        if second_rank is not None and dominates(second_rank, rank):
            return second
    return level_text
