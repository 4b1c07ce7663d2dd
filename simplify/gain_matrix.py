"""The gain matrix G of each level branch (model.md 5), fitted to its group's static response.

A level branch g with gain matrix G_g (2×3), strengths k_bs', k_rs' and rest swing
frame S_g settles, under the force F_g it carries at rest geometry, at

    θ'_g = 1000 diag(1/k_bs', 1/k_rs') G_g S_gᵀ F_g

and compare reads it in its group root's frame W_0 (model.md 6) as y_g = C_g θ'_g, with
C_g the 2×2 carry map (`compare.groups.carry_matrix`; the identity where the frames
agree). At rest geometry F_g = v F^L_g(V̂) + v² F^D_g(V̂) does not depend on any
branch's G, so each group's G is a linear least-squares problem of its own (6
unknowns): match y_g to the group's combined static angles Θ_g = v Θ^L_g + v² Θ^D_g
over wind directions (horizontal and tilted) and speeds,

    min_G  Σ_(d,v) |A_g G f_g(d,v) - Θ_g(d,v)|² / s(d,v)²  +  λ_g |G - G0_g|²

with A_g = C_g · 1000 diag(1/k_bs', 1/k_rs'), f_g = S_gᵀ F_g, s(d,v) the largest target of
that wind over all groups (errors count against the largest motion, as model.md 6's
motion error does; floored at GAIN_TARGET_FLOOR of the largest target of any wind),
and a small ridge λ_g toward the scalar gain G0_g = k_FA [[1,0,0],[0,1,0]] that keeps
directions the winds never excite (a force along the branch, say) where k_FA had them.
Where one scalar k_FA could only scale the force's projection on the chord's own axes,
G answers a force in the directions the group answers it: a group whose members lean,
turn or differ in strength.
"""

from __future__ import annotations

import math

import numpy as np

from plantlod.compare.groups import carry_matrix
from plantlod.lsys.system import IDENTITY_GAIN
from plantlod.lsys.tree import Tree

from .constants import (FIT_ELEVATION, GAIN_FIT_SPEEDS, GAIN_RIDGE, GAIN_TARGET_FLOOR,
                        MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS)
from .static import fit_directions, rest_frames, static_parts
from .targets import GroupMap, static_targets


def fit_gain_matrices(level: Tree, original: Tree, gmap: GroupMap,
                      turn: np.ndarray | None = None, target_gain: np.ndarray | None = None,
                      speeds: tuple[float, ...] = GAIN_FIT_SPEEDS,
                      directions: np.ndarray | None = None) -> np.ndarray:
    """(G, 6) gain matrices [G_bx G_by G_bz G_rx G_ry G_rz] for the branches of ``level``.

    level       : the level's tree with its fitted k_FA, k_fp, C_d, leaf areas and strengths
                  (branch g stands for group g of ``gmap``)
    turn        : (G, 3, 3) W_0ᵀ W' per branch (explicit form), None where frames agree
    target_gain : (G, 2) factors on each group's (bend, rotation) targets (its swing's
                  amplitude over its static angle, `explicit.dominant_strengths`)
    speeds      : m/s; directions (D, 3) unit, default 16 horizontal and 8 tilted each way
    """
    if directions is None:
        directions = fit_directions(MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS, FIT_ELEVATION)
    g_count = level.n_branches
    frames = rest_frames(level)
    parts = static_parts(level, directions, frames)
    targets = static_targets(original, gmap, directions, target_gain)
    carry = carry_matrix(turn) if turn is not None else np.broadcast_to(np.eye(2), (g_count, 2, 2))
    strength = np.stack([level.bend_strength, level.rotation_strength], axis=1)      # (G, 2)
    a = carry * (1000.0 / strength)[:, None, :]                                      # (G, 2, 2)
    forces, wanted = [], []
    for v in speeds:
        force = v * parts.leaf + v * v * parts.drag                                  # (D, G, 3)
        forces.append(np.einsum("gji,dgj->dgi", frames.swing, force))                # S_gᵀ F_g
        wanted.append(v * targets.leaf + v * v * targets.drag)                       # (D, G, 2)
    f = np.concatenate(forces)                                                       # (K, G, 3)
    t = np.concatenate(wanted)                                                       # (K, G, 2)
    largest = np.abs(t).max(axis=(1, 2))                                             # (K,)
    base = np.asarray(IDENTITY_GAIN)
    if not float(largest.max()) > 0.0:
        # no group's combined angle moves in any wind (its main path's members absorb no
        # force, k_FA = 0, and what moves hangs beside them): nothing to fit, the scalar
        # gain stands. Scaled by the floor of a zero target, the forces overflowed the
        # normal equations to NaN (a stiff trunk under swaying laterals, level 2; session 29)
        return np.asarray(level.force_absorbed, dtype=np.float64)[:, None] * base[None, :]
    scale = np.maximum(largest, GAIN_TARGET_FLOOR * max(float(largest.max()), 1e-300))
    # G is solved for in units of `unit` (a power of two near the gains, so that the solution
    # is the same to the bit, only exactly scaled): targets and forces far from 1 (k_FA of
    # 1e-300) would otherwise overflow the normal equations
    unit = gain_unit(level.force_absorbed)
    f = f / (scale / unit)[:, None, None]
    t = t / scale[:, None, None]
    out = np.empty((g_count, 6))
    for g in range(g_count):
        # rows: y_i = A[i,0] (f · G_b) + A[i,1] (f · G_r), i = bend, rotation
        design = np.concatenate([np.concatenate([a[g, i, 0] * f[:, g], a[g, i, 1] * f[:, g]], axis=1)
                                 for i in range(2)])                                  # (2K, 6)
        rhs = np.concatenate([t[:, g, 0], t[:, g, 1]])
        g0 = level.force_absorbed[g] / unit * base
        normal = design.T @ design
        ridge = GAIN_RIDGE * max(float(np.trace(normal)) / 6.0, 1e-300)
        out[g] = np.linalg.solve(normal + ridge * np.eye(6), design.T @ rhs + ridge * g0)
    return out * unit


def gain_unit(force_absorbed: np.ndarray) -> float:
    """A power of two near the largest |k_FA| (1 where there is none): scaling by it is
    exact, so a fit in its units gives the same bits as one in N·s/kg units wherever neither
    overflows."""
    finite = np.abs(force_absorbed[np.isfinite(force_absorbed)])
    largest = float(finite.max()) if finite.size else 0.0
    if not largest > 0.0:
        return 1.0
    return math.ldexp(1.0, math.frexp(largest)[1] - 1)    # (in [largest / 2, largest]: no overflow)
