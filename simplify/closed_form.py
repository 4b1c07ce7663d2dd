"""Closed-form level-n parameters: match every group's static angle, tips down, then all at once.

The steps, each in its own module with the equation it implements:

1. `targets`: the groups (`GroupMap`) and what they must match, the original's combined
   static angles Θ_g = v Θ^L_g + v² Θ^D_g and the force at each group's root.
2. `lengths`: rest lengths putting the level's tips at the groups' tips (linear fit).
3. k_bs', k_rs': the group's own strengths (`targets.group_strengths`; the period depends
   on k and Δt only).
4. `sequential_fit`: κ, p', C_d and leaf areas group by group from the tips (small
   non-negative least-squares problems, exact for a stalk).
5. `refine`: all of them at once, least squares on every group's relative static error
   (kept only where it lowers the worst error).

docs/simplify.md has the derivation; the notation is docs/notation.md's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.tree import Tree, leaf_keys

from .constants import (EXPLICIT_REFINE_EVALUATIONS, EXPLICIT_REFINE_FLOOR,
                        EXPLICIT_REFINE_LSMR_ITERATIONS, EXPLICIT_REFINE_PRIOR,
                        FIT_ELEVATION, MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS,
                        REFINE_DIRECTIONS, REFINE_EVALUATIONS, REFINE_FLOOR,
                        REFINE_LSMR_ITERATIONS, REFINE_PRIOR, REFINE_TILTED_DIRECTIONS,
                        SIMPLIFY_WIND_RANGE)
from plantlod.compare.groups import carry_matrix
from .lengths import fit_lengths
from .refine import StaticModel
from .sequential_fit import drag_per_area, sequential_solution, unit_leaf_forces
from .static import angle_gains, fit_directions, own_drag_shape, rest_frames
from .targets import GroupMap, group_strengths, static_targets


@dataclass(frozen=True)
class RefineSettings:
    """How the refinement weighs errors (`refine.StaticModel`): floor (fraction of the
    wind's largest target below which errors are absolute), prior (pull toward the
    tips-down start), evaluations (budget), inner (lsmr iterations per step)."""

    floor: float
    prior: float
    evaluations: int
    inner: int


# the grammar form: relative errors per component (the stalk's measure)
GRAMMAR_REFINE = RefineSettings(REFINE_FLOOR, REFINE_PRIOR, REFINE_EVALUATIONS,
                                REFINE_LSMR_ITERATIONS)
# the explicit form: the motion error of model.md 6
EXPLICIT_REFINE = RefineSettings(EXPLICIT_REFINE_FLOOR, EXPLICIT_REFINE_PRIOR,
                                 EXPLICIT_REFINE_EVALUATIONS, EXPLICIT_REFINE_LSMR_ITERATIONS)


def carried_gains(gains: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """Gains (G, 2, 3) of the chords' angles carried into their group roots' swing frames.

    A chord's angles (θb', θr') are measured in its group root's frame W_0 as model.md 5
    carries a member's (`groups.carry_matrix` C per group): gains in W_0 = C · gains.
    """
    return np.einsum("gab,gbj->gaj", carry_matrix(turn), gains)


@dataclass
class LevelParameters:
    """Per simplified branch (G,) values and per leaf areas, ready for `write_parameters`.

    leaf_areas: (address, K) -> area m^2 (`leaf_keys`)
    static_error: with ``refine``, `refine.StaticModel.worst` of the returned values
    """

    branch: dict[str, np.ndarray]
    leaf_areas: dict[tuple[str, int], float]
    static_error: float = math.nan    # the refinement's worst weighted error at the result


def closed_form(original: Tree, skeleton: Tree, gmap: GroupMap,
                directions: np.ndarray | None = None, refine: bool = True,
                speeds: tuple[float, ...] = SIMPLIFY_WIND_RANGE,
                turn: np.ndarray | None = None,
                kappa_range: float | None = None,
                strengths: tuple[np.ndarray, np.ndarray] | None = None,
                target_gain: np.ndarray | None = None,
                settings: RefineSettings = GRAMMAR_REFINE,
                lengths: np.ndarray | None = None) -> LevelParameters:
    """Parameters of the level-n tree ``skeleton`` (its arrays are read for geometry only).

    ``skeleton`` is the level-n tree as the skeleton system builds it
    (`levels.level_system`), equivalent leaves included (any area).
    First the sequential solution, group by group from the tips down; then,
    with ``refine``, every k_FA, k_fp, C_d and leaf area at once
    (`refine.StaticModel.refine`): least squares on the relative errors of every
    group's static angles at the wind ``speeds`` (m/s), which is what the
    section-6 amplitude error is at small angles. The refinement is kept only
    where it lowers the worst of those errors. ``turn`` (G, 3, 3) = W_0^T W' of each
    chord (explicit form): the chords' angles are fitted as `compare` measures them,
    carried into their group roots' frames (`carried_gains`); ``strengths`` overrides
    k_bs', k_rs'; ``target_gain`` (G, 2) scales each group's bend and rotation targets
    (a group whose members swing with different periods: its amplitude over its static
    angle, `explicit.dominant_strengths`); ``settings`` weighs the refinement's errors;
    ``lengths`` (G,) m are the level's rest lengths where the caller fixes them (the explicit
    form's chords, exact by construction), fitted (`lengths.fit_lengths`) otherwise.
    """
    if directions is None:
        directions = fit_directions(MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS, FIT_ELEVATION)
    targets = static_targets(original, gmap, directions, target_gain)
    frames = rest_frames(skeleton)
    g_count = skeleton.n_branches
    kb, kr = group_strengths(original, gmap) if strengths is None else strengths
    if lengths is None:
        lengths = fit_lengths(original, skeleton, frames, gmap)
    lengths = np.asarray(lengths, dtype=np.float64)
    chain_kfa = np.array([original.force_absorbed[p].mean() for p in gmap.paths])
    chain_kfp = np.array([np.prod(original.force_propagated[p]) for p in gmap.paths])

    tmp = Tree(**{**skeleton.__dict__})
    tmp.bend_strength, tmp.rotation_strength = kb, kr
    tmp.force_absorbed = np.ones(g_count)
    gains = angle_gains(tmp, frames)                       # (G, 2, 3) per unit κ
    if turn is not None:
        gains = carried_gains(gains, turn)
    surface = 2.0 * math.pi * skeleton.radius * lengths    # (G,) m^2
    seq = sequential_solution(skeleton, gains, unit_leaf_forces(skeleton, frames, directions),
                              own_drag_shape(frames, directions), targets, surface,
                              chain_kfa, chain_kfp, kappa_range)
    kfa, kfp, drag_c, areas = seq.kfa, seq.kfp, seq.drag_coefficient, seq.areas
    static_error = math.nan
    if refine:
        rdirs = fit_directions(REFINE_DIRECTIONS, REFINE_TILTED_DIRECTIONS, FIT_ELEVATION)
        model = StaticModel(skeleton, gains, unit_leaf_forces(skeleton, frames, rdirs),
                            np.asarray(skeleton.leaf_branch, dtype=np.int64),
                            own_drag_shape(frames, rdirs),
                            static_targets(original, gmap, rdirs, target_gain),
                            np.asarray(speeds, dtype=np.float64), settings.floor)
        refined = model.refine(kfa, kfp, drag_c * surface, areas, settings.prior,
                               settings.evaluations, settings.inner)
        if refined is not None:
            kfa, kfp, drag_area_, areas = refined
            drag_c = drag_per_area(drag_area_, surface)
        values = np.concatenate([kfa, kfp, drag_c * surface, areas])
        static_error = model.worst(np.log(np.maximum(values, np.finfo(float).tiny)))
    branch = {"length": lengths, "bend_strength": kb, "rotation_strength": kr,
              "force_absorbed": kfa, "force_propagated": kfp, "drag_coefficient": drag_c}
    names = leaf_keys(skeleton)
    return LevelParameters(branch, {a: float(areas[k]) for k, a in enumerate(names)}, static_error)
