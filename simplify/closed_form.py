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

from .constants import (FIT_ELEVATION, MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS,
                        REFINE_DIRECTIONS, REFINE_TILTED_DIRECTIONS, SIMPLIFY_WIND_RANGE)
from .lengths import fit_lengths
from .refine import StaticModel
from .sequential_fit import sequential_solution, unit_leaf_forces
from .static import angle_gains, fit_directions, own_drag_shape, rest_frames
from .targets import GroupMap, group_strengths, static_targets


@dataclass
class LevelParameters:
    """Per simplified branch (G,) values and per leaf areas, ready for `write_parameters`.

    leaf_areas: (address, K) -> area m^2 (`leaf_keys`)
    """

    branch: dict[str, np.ndarray]
    leaf_areas: dict[tuple[str, int], float]


def closed_form(original: Tree, skeleton: Tree, gmap: GroupMap,
                directions: np.ndarray | None = None, refine: bool = True,
                speeds: tuple[float, ...] = SIMPLIFY_WIND_RANGE,
                turn: np.ndarray | None = None,
                kappa_range: float | None = None,
                strengths: tuple[np.ndarray, np.ndarray] | None = None) -> LevelParameters:
    """Parameters of the level-n tree ``skeleton`` (its arrays are read for geometry only).

    ``skeleton`` is the level-n tree as the skeleton system builds it
    (`levels.level_system`), equivalent leaves included (any area).
    First the sequential solution, group by group from the tips down; then,
    with ``refine``, every k_FA, k_fp, C_d and leaf area at once
    (`refine.StaticModel.refine`): least squares on the relative errors of every
    group's static angles at the wind ``speeds`` (m/s), which is what the
    section-6 amplitude error is at small angles. The refinement is kept only
    where it lowers the worst of those errors. ``turn`` (G, 3, 3) carries the
    targets into chord frames (explicit form); ``strengths`` overrides k_bs', k_rs'.
    """
    if directions is None:
        directions = fit_directions(MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS, FIT_ELEVATION)
    targets = static_targets(original, gmap, directions, turn)
    frames = rest_frames(skeleton)
    g_count = skeleton.n_branches
    kb, kr = group_strengths(original, gmap) if strengths is None else strengths
    lengths = fit_lengths(original, skeleton, frames, gmap)
    chain_kfa = np.array([original.force_absorbed[p].mean() for p in gmap.paths])
    chain_kfp = np.array([np.prod(original.force_propagated[p]) for p in gmap.paths])

    tmp = Tree(**{**skeleton.__dict__})
    tmp.bend_strength, tmp.rotation_strength = kb, kr
    tmp.force_absorbed = np.ones(g_count)
    gains = angle_gains(tmp, frames)                       # (G, 2, 3) per unit κ
    surface = 2.0 * math.pi * skeleton.radius * lengths    # (G,) m^2
    seq = sequential_solution(skeleton, gains, unit_leaf_forces(skeleton, frames, directions),
                              own_drag_shape(frames, directions), targets, surface,
                              chain_kfa, chain_kfp, kappa_range)
    kfa, kfp, drag_c, areas = seq.kfa, seq.kfp, seq.drag_coefficient, seq.areas
    if refine:
        rdirs = fit_directions(REFINE_DIRECTIONS, REFINE_TILTED_DIRECTIONS, FIT_ELEVATION)
        model = StaticModel(skeleton, gains, unit_leaf_forces(skeleton, frames, rdirs),
                            np.asarray(skeleton.leaf_branch, dtype=np.int64),
                            own_drag_shape(frames, rdirs),
                            static_targets(original, gmap, rdirs, turn),
                            np.asarray(speeds, dtype=np.float64))
        refined = model.refine(kfa, kfp, drag_c * surface, areas)
        if refined is not None:
            kfa, kfp, drag_area_, areas = refined
            drag_c = drag_area_ / surface
    branch = {"length": lengths, "bend_strength": kb, "rotation_strength": kr,
              "force_absorbed": kfa, "force_propagated": kfp, "drag_coefficient": drag_c}
    names = leaf_keys(skeleton)
    return LevelParameters(branch, {a: float(areas[k]) for k, a in enumerate(names)})
