"""The sequential solution: a level's force parameters group by group, tips first (the first
step of `closed_form.closed_form`; docs/simplify.md has the derivation).

For a wind v V̂ at small angles, simplified branch g with absorbed force κ, propagated
force p', drag area c' = C_d' 2π r' L' and leaves of areas A_k turns by

    θ'_g = κ G_g (F'^L_g v + F'^D_g v²),       G_g = 1000 [W'e_x / k_bs', W'e_y / k_rs']
    F'^L_g = p' (Σ_k A_k ℓ_k(V̂) + Σ_children F'^L_c)
    F'^D_g = c' |z'×V̂| V̂ + p' Σ_children F'^D_c

Only λ = κ p', u_k = κ p' A_k and μ = κ c' enter θ'_g, and children (higher indices) are
fixed first, so each group is three small problems: `leaf_split` (λ, u_k), then
`absorbed_force` (κ, which splits λ into κ and p'), then `drag_gain` (μ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from plantlod.lsys.tree import Tree

from .constants import SPLIT_COLUMN_FLOOR, SPLIT_REGULARISATION
from .static import RestFrames, own_leaf_forces
from .targets import StaticTargets


@dataclass
class SequentialSolution:
    """kfa, kfp, drag_coefficient (G,) per simplified branch; areas (K,) m² per leaf."""

    kfa: np.ndarray
    kfp: np.ndarray
    drag_coefficient: np.ndarray
    areas: np.ndarray


def sequential_solution(skeleton: Tree, gains: np.ndarray, per_leaf: np.ndarray,
                        drag_shape: np.ndarray, targets: StaticTargets, surface: np.ndarray,
                        chain_kfa: np.ndarray, chain_kfp: np.ndarray,
                        kappa_range: float | None = None) -> SequentialSolution:
    """Every group's κ, p', C_d and leaf areas, from the tips down.

    gains (G, 2, 3) angle per unit force at κ = 1 (`static.angle_gains`); per_leaf (D, K, 3)
    each leaf's force at unit area and speed; drag_shape (D, G, 3) |z'×V̂| V̂; targets the
    original's; surface (G,) 2π r' L' m²; chain_kfa, chain_kfp (G,) the mean k_FA and the
    product of k_fp along each group's main path (the stalk's values, used where the data
    say nothing); ``kappa_range`` bounds κ, p' and the areas to that factor of those values.
    """
    g_count, d = skeleton.n_branches, len(targets.directions)
    leaf_branch = np.asarray(skeleton.leaf_branch, dtype=np.int64)
    natural_area = np.asarray(skeleton.leaf_area, dtype=np.float64).copy()
    leaves_of_branch: list[list[int]] = [[] for _ in range(g_count)]
    for k, b in enumerate(leaf_branch.tolist()):
        leaves_of_branch[b].append(k)
    kfa, kfp, drag_c = np.empty(g_count), np.empty(g_count), np.empty(g_count)
    areas = np.zeros(len(natural_area))
    in_leaf = np.zeros((d, g_count, 3))                    # Σ children F'^L
    in_drag = np.zeros((d, g_count, 3))
    for g in range(g_count - 1, -1, -1):
        gain = gains[g]                                    # (2, 3)
        own = leaves_of_branch[g]
        has_in = bool(np.any(in_leaf[:, g] != 0))
        lam, u = leaf_split(gain, in_leaf[:, g], per_leaf[:, own], targets.leaf[:, g],
                            natural_area[own])
        y = lam * in_leaf[:, g] + np.einsum("k,dkj->dj", u, per_leaf[:, own])
        kappa = absorbed_force(y, targets.root_leaf[:, g], chain_kfa[g], kappa_range)
        if not kappa > 0:
            # a group whose members absorb no force (k_FA = 0: they never move) says nothing
            # of what it passes on: the chain's k_fp^m, its leaves at their areas, no drag of
            # its own (its parent's fit takes that up); p' / κ divided by 0 before
            kappa, p_new, c_new = 0.0, chain_kfp[g], 0.0
            if own:
                areas[own] = natural_area[own]
        else:
            p_new = lam / kappa if has_in else chain_kfp[g]    # no children: the chain's k_fp^m
            if p_new == 0 and np.any(u > 0):                   # leaves need p' > 0
                p_new = chain_kfp[g]
            if kappa_range is not None:        # likewise the force passed on, and the leaf gains
                p_new = min(max(p_new, chain_kfp[g] / kappa_range), chain_kfp[g] * kappa_range)
            lam = kappa * p_new
            if own:
                # (lam can be subnormal: k_fp^2048 at the top of a 2,048-branch stalk; the
                # quotient's overflow to inf is capped below, and its warning was noise)
                with np.errstate(over="ignore"):
                    areas[own] = u / lam if lam > 0 else 0.0
                if kappa_range is not None:
                    areas[own] = np.minimum(areas[own], kappa_range * natural_area[own])
            mu = drag_gain(gain, drag_shape[:, g], targets.drag[:, g], lam, in_drag[:, g])
            c_new = mu / kappa
        kfa[g], kfp[g] = kappa, p_new
        drag_c[g] = drag_per_area(c_new, surface[g])
        out_leaf = p_new * (in_leaf[:, g] + np.einsum("k,dkj->dj", areas[own], per_leaf[:, own]))
        out_drag = c_new * drag_shape[:, g] + p_new * in_drag[:, g]
        parent = int(skeleton.parent[g])
        if parent >= 0:
            in_leaf[:, parent] += out_leaf
            in_drag[:, parent] += out_drag
    return SequentialSolution(kfa, kfp, drag_c, areas)


def drag_per_area(drag_area, surface):
    """C_d = drag area / surface (2π r L, m²), elementwise; 0 where the surface is 0. A branch
    of no surface (radius or length 0, both legal) carries no drag: its group's members have
    none of their own (`explicit.level_radii` gives a chord any radius in its group), or its
    chord folds back to its base; what drag it would take is lost, and the level's measures
    say so."""
    surface = np.asarray(surface, dtype=np.float64)
    has = surface > 0
    out = np.where(has, np.asarray(drag_area, dtype=np.float64) / np.where(has, surface, 1.0), 0.0)
    return out if out.ndim else float(out)


def leaf_split(gain: np.ndarray, incoming: np.ndarray, own: np.ndarray, target: np.ndarray,
               natural_areas: np.ndarray) -> tuple[float, np.ndarray]:
    """λ and u_k of one group's leaf part: Θ^L ≈ λ G·incoming + Σ_k u_k G·ℓ_k, all >= 0.

    gain (2, 3); incoming (D, 3) children's F'^L; own (D, K, 3)
    unit-area forces of the group's adjustable leaves; target (D, 2);
    natural_areas (K,) the areas the level-n file gives those leaves.

    Where several splits fit equally well (a planar tree: children and own
    leaves push the same way), the fit is pulled, with a small weight
    (`SPLIT_REGULARISATION`, relative to the column norms), toward the natural
    split: children passed through and leaves at their natural areas, in the
    ratio 1 : A_k, scaled to fit. Each pull is at least SPLIT_COLUMN_FLOOR of the largest:
    a leaf whose force the group's own angles barely see (one along the branch's axis, a
    basis leaf's normal along the chord) keeps its natural share instead of fitting the
    targets' misfit through its vanishing column with an area thousands of times its own,
    whose force along the branch then turns across it as the branch swings (family
    bent_leafy-123's level 1 swung a group 26x the tree's largest swing at 20 m/s).
    """
    basis = np.concatenate([incoming[:, None, :], own], axis=1)            # (D, 1+K, 3)
    a = np.einsum("ij,dkj->dik", gain, basis).reshape(-1, basis.shape[1])   # (2D, 1+K)
    b = target.reshape(-1)
    shape = np.concatenate([[1.0 if np.any(incoming) else 0.0], natural_areas])
    guess = a @ shape
    gg = float(guess @ guess)
    x0 = shape * max(0.0, float(guess @ b) / gg) if gg > 0 else np.zeros_like(shape)
    norms = np.linalg.norm(a, axis=0)                  # (1+K,): never empty
    reg = SPLIT_REGULARISATION * np.diag(np.maximum(norms, SPLIT_COLUMN_FLOOR * norms.max()))
    a_reg, b_reg = np.vstack([a, reg]), np.concatenate([b, reg @ x0])
    sol = nnls(a_reg, b_reg)[0] if np.any(a_reg) else np.zeros(a_reg.shape[1])
    return float(sol[0]), sol[1:]


def absorbed_force(passed: np.ndarray, root_force: np.ndarray, fallback: float,
                   limit: float | None = None) -> float:
    """κ: the force the group passes down, y / κ, should match the force at the original
    group's root t (D, 3) in least squares: min_s |s y - t|² gives s = y·t / y·y, so

        κ = (y·y) / (y·t)

    (for a stalk this gives k_fp' = k_fp^m for a group of m branches in a row). Where
    y·t <= 0 the match says nothing and κ is ``fallback`` (the chain's mean k_FA);
    ``limit`` keeps κ within that factor of it."""
    yy, yt = float(np.sum(passed * passed)), float(np.sum(passed * root_force))
    kappa = yy / yt if yy > 0 and yt > 0 else fallback
    if limit is not None:                      # a near-orthogonal force match is no evidence
        kappa = min(max(kappa, fallback / limit), fallback * limit)
    return kappa


def drag_gain(gain: np.ndarray, shape: np.ndarray, target: np.ndarray, lam: float,
              incoming: np.ndarray) -> float:
    """μ = κ c' >= 0 of one group's drag part, one unknown in least squares:

        Θ^D_g - λ G ΣF'^D_c ≈ μ G |z'×V̂| V̂,    μ = max(0, col·rhs / col·col)

    gain (2, 3); shape (D, 3) |z'×V̂| V̂; target (D, 2) Θ^D_g; incoming (D, 3) ΣF'^D_c."""
    col = (shape @ gain.T).reshape(-1)
    rhs = (target - lam * (incoming @ gain.T)).reshape(-1)
    cc = float(col @ col)
    return max(0.0, float(col @ rhs) / cc) if cc > 0 else 0.0


def unit_leaf_forces(skeleton: Tree, frames: RestFrames, directions: np.ndarray) -> np.ndarray:
    """The force of every leaf of ``skeleton`` at unit area and unit speed: (D, F, 3).

    `own_leaf_forces` sums leaves per branch; a view of the tree in which every leaf is
    its own 'branch' (with its branch's frame) yields the forces leaf by leaf."""
    view = Tree(**{**skeleton.__dict__})
    view.leaf_branch = np.arange(skeleton.n_leaves, dtype=np.int64)
    view.parent = np.full(skeleton.n_leaves, -1, dtype=np.int64)
    b = skeleton.leaf_branch
    per_leaf_frames = RestFrames(frames.swing[b], frames.axis[b], frames.base[b], frames.tip[b],
                                 frames.frame[b])
    return own_leaf_forces(view, per_leaf_frames, directions, np.ones(skeleton.n_leaves))
