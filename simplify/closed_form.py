"""Closed-form level-n parameters: match every group's static angle, tips down.

Notation (docs/simplify.md has the derivation): for a wind v V̂ at small
angles, group g of the original turns by the combined angle
Θ_g = v Θ^L_g(V̂) + v² Θ^D_g(V̂) (leaf part and drag part, `static`). Its
simplified branch, with absorbed force κ, propagated force p', drag area
c' = C_d' 2π r' L' and areas A_k of the leaves it carries, turns by

    θ'_g = κ G_g (F'^L_g v + F'^D_g v²),     G_g = 1000 [W'e_x / k_bs', W'e_y / k_rs']  (2, 3)
    F'^L_g = p' (Σ_k A_k ℓ_k(V̂) + Σ_children F'^L_c)
    F'^D_g = c' |z'×V̂| V̂ + p' Σ_children F'^D_c

Only the products λ = κ p', u_k = κ p' A_k and μ = κ c' enter θ'_g, and the
children are fixed first (children have higher indices), so each group is a
small linear least-squares problem over a set of wind directions (horizontal,
and tilted out of the horizontal: docs/simplify.md, "Tilt"):

    leaf part:  Θ^L_g ≈ λ G ΣF'^L_c + Σ_k u_k G ℓ_k          (λ, u_k >= 0: NNLS)
    drag part:  Θ^D_g - λ G ΣF'^D_c ≈ μ G |z'×V̂| V̂           (μ >= 0)

For a stalk every direction gives the same equations, so the match is exact.
In a branching tree the sequential fit has two flaws: it fits absolute angles
(small components of a group are fitted badly in relative terms, and section 6
measures relative errors), and a group's parameters are fixed before its
parent's, so the force it passes down has whatever shape fits its own angle.
A global refinement (`_StaticModel`) therefore adjusts all values together,
minimising the relative static errors of all groups at once, starting from the
sequential solution.
What is left, κ, sets how large a force the branch passes down: it is chosen so
that the leaf part of F'_g best matches the force at the original group's root
(the force the parent group receives), which for a stalk gives k_fp' = k_fp^m
for a group of m branches in a row. k_bs' and k_rs' keep the group's own
values (the period depends on k and Δt only); the length makes the rest tip
lie as near the group tip as the branch's direction allows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, lsq_linear, nnls
from scipy.sparse import coo_matrix

from .constants import FIT_ELEVATION, MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS
from .constants import SIMPLIFY_WIND_RANGE
from .constants import MIN_LENGTH_FRACTION
from .constants import SPLIT_REGULARISATION
from .constants import REFINE_DIRECTIONS
from .constants import REFINE_TILTED_DIRECTIONS
from .constants import REFINE_LOG_RANGE
from .constants import REFINE_FLOOR
from .constants import REFINE_START_FLOOR
from .constants import REFINE_PRIOR
from .constants import REFINE_SKIP
from .constants import REFINE_EVALUATIONS
from .constants import REFINE_LSMR_ITERATIONS
from plantlod.lsys.tree import Tree, leaf_keys
from plantlod.sim.kinematics import depth_levels

from .groups import assign_groups, carry_angles, combined_angles, main_paths
from .static import (RestFrames, angle_gains, fit_directions, own_drag_shape,
                     own_leaf_forces, rest_frames, static_angles, static_parts)


@dataclass
class GroupMap:
    """Which original branches each simplified branch stands for.

    groups : (B_orig,) int64 simplified-branch index of every original branch (-1: none)
    paths  : G main paths, (m_g,) int64 original branch indices each
    """

    groups: np.ndarray
    paths: list[np.ndarray]

    @property
    def roots(self) -> np.ndarray:
        return np.array([int(p[0]) for p in self.paths], dtype=np.int64)

    @property
    def tips(self) -> np.ndarray:
        return np.array([int(p[-1]) for p in self.paths], dtype=np.int64)


def group_map(original: Tree, simplified: Tree) -> GroupMap:
    groups = assign_groups(original, simplified)
    return GroupMap(groups, main_paths(original, groups, simplified.n_branches))


@dataclass
class StaticTargets:
    """The original's static combined angles and root forces per group.

    directions : (D, 3) unit wind directions
    leaf, drag : (D, G, 2) combined (Θb, Θr) per unit v and per unit v², rad
    root_leaf  : (D, G, 3) leaf part of the force at each group's root branch, N per (m/s)
    """

    directions: np.ndarray
    leaf: np.ndarray
    drag: np.ndarray
    root_leaf: np.ndarray


def static_targets(original: Tree, gmap: GroupMap, directions: np.ndarray,
                   turn: np.ndarray | None = None) -> StaticTargets:
    """The targets; with ``turn`` (G, 3, 3) = W_0^T W'_g (`groups.swing_turns`) the combined
    angles are carried from each group root's swing frame into its branch's (by turn^T)."""
    frames = rest_frames(original)
    parts = static_parts(original, directions, frames)
    out = []
    for force in (parts.leaf, parts.drag):
        bend, rot = static_angles(original, force, frames)
        cb, cr = combined_angles(original, gmap.paths, bend, rot)
        if turn is not None:
            cb, cr = carry_angles(np.transpose(turn, (0, 2, 1)), cb, cr)
        out.append(np.stack([cb, cr], axis=-1))
    return StaticTargets(directions, out[0], out[1], parts.leaf[:, gmap.roots])


def group_strengths(original: Tree, gmap: GroupMap) -> tuple[np.ndarray, np.ndarray]:
    """k_bs' and k_rs' per group: (G,) each; the members' values where the main path is uniform.

    Where members differ, the mean over the main path (the combined angle
    sums the members' swings, each with its own period; the mean keeps the
    result between the members' periods and the tree stable wherever the
    original is).
    """
    kb = np.array([original.bend_strength[p].mean() for p in gmap.paths])
    kr = np.array([original.rotation_strength[p].mean() for p in gmap.paths])
    return kb, kr


def fit_lengths(original: Tree, simplified: Tree, frames: RestFrames, gmap: GroupMap) -> np.ndarray:
    """Lengths (G,) m that put the simplified rest tips nearest their groups' rest tips.

    A tip is its root's offset plus, for every branch on the way to it, length
    times axis plus offset; with the frames fixed (they do not depend on
    lengths) this is linear in the lengths, so all lengths are fitted at once
    (bounded linear least squares, `scipy.optimize.lsq_linear`): one group's
    miss does not push every group above it. Each length stays at least
    `MIN_LENGTH_FRACTION` of its group's summed main-path length.
    """
    orig_tips = rest_frames(original).tip[gmap.tips]                    # (G, 3)
    summed = np.array([original.length[p].sum() for p in gmap.paths])
    g = simplified.n_branches
    parent = simplified.parent
    # constant part: offsets, carried by the parents' frames
    shift = np.empty((g, 3))
    for i in range(g):
        p = int(parent[i])
        shift[i] = simplified.offset[i] if p < 0 else shift[p] + frames.frame[p] @ simplified.offset[i]
    rows, cols, vals = [], [], []
    for i in range(g):
        a = i
        while a >= 0:                                  # i and its ancestors
            for k in range(3):
                rows.append(3 * i + k)
                cols.append(a)
                vals.append(frames.axis[a, k])
            a = int(parent[a])
    matrix = coo_matrix((vals, (rows, cols)), shape=(3 * g, g)).tocsr()
    lower = MIN_LENGTH_FRACTION * summed
    fit = lsq_linear(matrix, (orig_tips - shift).reshape(-1), bounds=(lower, np.inf),
                     method="trf", lsmr_tol="auto", tol=1e-12)
    return np.maximum(fit.x, lower)


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
    (`_StaticModel.refine`): least squares on the relative errors of every
    group's static angles at the wind ``speeds`` (m/s), which is what the
    section-6 amplitude error is at small angles. The refinement is kept only
    where it lowers the worst of those errors.
    """
    if directions is None:
        directions = fit_directions(MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS, FIT_ELEVATION)
    targets = static_targets(original, gmap, directions, turn)
    frames = rest_frames(skeleton)
    g_count = skeleton.n_branches
    d = len(directions)
    kb, kr = group_strengths(original, gmap) if strengths is None else strengths
    lengths = fit_lengths(original, skeleton, frames, gmap)
    path_kfa = np.array([original.force_absorbed[p].mean() for p in gmap.paths])
    path_kfp = np.array([np.prod(original.force_propagated[p]) for p in gmap.paths])

    # every leaf has its own area (area_K overrides), so each is one adjustable value
    names = leaf_keys(skeleton)
    leaf_branch = np.asarray(skeleton.leaf_branch, dtype=np.int64)
    per_leaf = _unit_leaf_forces(skeleton, frames, directions)         # (D, F, 3)
    natural_area = np.asarray(skeleton.leaf_area, dtype=np.float64).copy()
    leaves_of_branch: list[list[int]] = [[] for _ in range(g_count)]
    for k, b in enumerate(leaf_branch.tolist()):
        leaves_of_branch[b].append(k)

    tmp = Tree(**{**skeleton.__dict__})
    tmp.bend_strength, tmp.rotation_strength = kb, kr
    tmp.force_absorbed = np.ones(g_count)
    gains = angle_gains(tmp, frames)                       # (G, 2, 3) per unit κ
    drag_shape = own_drag_shape(frames, directions)        # (D, G, 3)

    kfa = np.empty(g_count)
    kfp = np.empty(g_count)
    drag_c = np.empty(g_count)
    areas = np.zeros(len(names))
    in_leaf = np.zeros((d, g_count, 3))                    # Σ children F'^L
    in_drag = np.zeros((d, g_count, 3))
    for g in range(g_count - 1, -1, -1):
        gain = gains[g]                                    # (2, 3)
        own = leaves_of_branch[g]
        has_in = bool(np.any(in_leaf[:, g] != 0))
        lam, u = _leaf_split(gain, in_leaf[:, g], per_leaf[:, own], targets.leaf[:, g],
                             natural_area[own])
        # κ: the force passed down (y / κ) should match the original group root's
        y = lam * in_leaf[:, g] + np.einsum("k,dkj->dj", u, per_leaf[:, own])
        t = targets.root_leaf[:, g]
        yy, yt = float(np.sum(y * y)), float(np.sum(y * t))
        kappa = yy / yt if yy > 0 and yt > 0 else path_kfa[g]
        if kappa_range is not None:            # a near-orthogonal force match is no evidence
            kappa = min(max(kappa, path_kfa[g] / kappa_range), path_kfa[g] * kappa_range)
        p_new = lam / kappa if has_in else path_kfp[g]     # no children: the chain's k_fp^m
        if p_new == 0 and np.any(u > 0):                   # leaves need p' > 0
            p_new = path_kfp[g]
        if kappa_range is not None:            # likewise the force passed on, and the leaf gains
            p_new = min(max(p_new, path_kfp[g] / kappa_range), path_kfp[g] * kappa_range)
        lam = kappa * p_new
        if own:
            areas[own] = u / lam if lam > 0 else 0.0
            if kappa_range is not None:
                areas[own] = np.minimum(areas[own], kappa_range * natural_area[own])
        col = (drag_shape[:, g] @ gain.T).reshape(-1)
        rhs = (targets.drag[:, g] - lam * (in_drag[:, g] @ gain.T)).reshape(-1)
        cc = float(col @ col)
        mu = max(0.0, float(col @ rhs) / cc) if cc > 0 else 0.0
        c_new = mu / kappa
        kfa[g], kfp[g] = kappa, p_new
        drag_c[g] = c_new / (2.0 * math.pi * skeleton.radius[g] * lengths[g])
        out_leaf = p_new * (in_leaf[:, g] + np.einsum("k,dkj->dj", areas[own], per_leaf[:, own]))
        out_drag = c_new * drag_shape[:, g] + p_new * in_drag[:, g]
        parent = int(skeleton.parent[g])
        if parent >= 0:
            in_leaf[:, parent] += out_leaf
            in_drag[:, parent] += out_drag
    if refine:
        rdirs = fit_directions(REFINE_DIRECTIONS, REFINE_TILTED_DIRECTIONS, FIT_ELEVATION)
        model = _StaticModel(skeleton, gains, _unit_leaf_forces(skeleton, frames, rdirs),
                             leaf_branch, own_drag_shape(frames, rdirs), static_targets(original, gmap, rdirs, turn),
                             np.asarray(speeds, dtype=np.float64))
        surface = 2.0 * math.pi * skeleton.radius * lengths            # (G,) m^2
        refined = model.refine(kfa, kfp, drag_c * surface, areas)
        if refined is not None:
            kfa, kfp, drag_area_, areas = refined
            drag_c = drag_area_ / surface
    branch = {"length": lengths, "bend_strength": kb, "rotation_strength": kr,
              "force_absorbed": kfa, "force_propagated": kfp, "drag_coefficient": drag_c}
    return LevelParameters(branch, {a: float(areas[k]) for k, a in enumerate(names)})


class _StaticModel:
    """Every group's static angle as a function of all level-n parameters at once.

    Parameters (log scale, so they stay positive): κ_g, p'_g, c'_g (G each: the
    absorbed force, propagated force and drag area C_d 2π r L of each
    simplified branch) and A_k (K leaf areas, one per leaf).
    For speeds v_s and directions V̂_d,

        θ'_g(v, V̂) = κ_g G_g F'_g,   F'_g = p'_g (Σ_k A_k ℓ_k + Σ_c F'_c) v
                                            + c'_g s_g v² + p'_g Σ_c F'^D_c v²

    and the residual of group g, component c is (θ'_gc - Θ_gc) / max(|Θ_gc|,
    `REFINE_FLOOR` · largest), the section-6 relative amplitude error at small
    angles (floored where a component does not count). A force entering branch
    h reaches its ancestor a multiplied by T(a, h), the product of p' over the
    path from h's parent to a, so every derivative is a sum over ancestor
    pairs (a, h) (`_pairs`) and the Jacobian is exact and sparse.

    gains (G, 2, 3) per unit κ; per_leaf (D, K, 3) unit-area leaf forces;
    leaf_branch (K,) the branch of each; drag_shape (D, G, 3); targets: the
    original's static angles; speeds (S,) m/s.
    """

    def __init__(self, tree: Tree, gains, per_leaf, leaf_branch, drag_shape,
                 targets: StaticTargets, speeds: np.ndarray):
        self.parent = np.asarray(tree.parent, dtype=np.int64)
        self.levels = depth_levels(self.parent)
        self.gains, self.per_leaf, self.leaf_branch = gains, per_leaf, leaf_branch
        self.drag_shape, self.speeds = drag_shape, speeds
        self.g = len(self.parent)
        v = speeds[:, None, None, None]
        self.target = v * targets.leaf[None] + v * v * targets.drag[None]     # (S, D, G, 2)
        largest = np.abs(self.target).max(axis=(2, 3), keepdims=True)
        self.weight = 1.0 / np.maximum(np.abs(self.target), REFINE_FLOOR * largest
                                       + np.finfo(float).tiny)
        self.pair_a, self.pair_h = _pairs(self.parent)
        # G_a ℓ_k and G_a s_h per pair, fixed by the geometry: (D, P, 2)
        self.gs = np.einsum("pij,dpj->dpi", gains[self.pair_a], drag_shape[:, self.pair_h])
        # (leaf k, pair (a, h_k)) for every ancestor-or-self a of leaf k's branch; this
        # relies on `_pairs` listing pairs by ascending h, those of one h together
        count = np.bincount(self.pair_h, minlength=self.g)
        first = np.concatenate([[0], np.cumsum(count)[:-1]])
        n_k = count[leaf_branch]
        self.leaf_of_pair = np.repeat(np.arange(len(leaf_branch)), n_k)                # (Q,)
        self.pair_of_leaf = (np.repeat(first[leaf_branch] - np.cumsum(n_k) + n_k, n_k)
                             + np.arange(int(n_k.sum())))                              # (Q,)
        # G_a ℓ_k per (leaf, pair): (D, Q, 2)
        self.gl = np.einsum("qij,dqj->dqi", gains[self.pair_a[self.pair_of_leaf]],
                            per_leaf[:, self.leaf_of_pair])

    def _unpack(self, x):
        g = self.g
        e = np.exp(x)
        return e[:g], e[g:2 * g], e[2 * g:3 * g], e[3 * g:]

    def forces(self, p, c, area):
        """(F^L, F^D) (D, G, 3) of every simplified branch at unit speed."""
        leaf = np.zeros((self.per_leaf.shape[0], self.g, 3))
        np.add.at(leaf, (slice(None), self.leaf_branch), area[None, :, None] * self.per_leaf)
        drag = c[None, :, None] * self.drag_shape
        incoming_l = np.zeros_like(leaf)
        incoming_d = np.zeros_like(drag)
        for idx in reversed(self.levels):
            leaf[:, idx] = p[idx][None, :, None] * (leaf[:, idx] + incoming_l[:, idx])
            drag[:, idx] = drag[:, idx] + p[idx][None, :, None] * incoming_d[:, idx]
            kids = idx[self.parent[idx] >= 0]
            if len(kids):
                np.add.at(incoming_l, (slice(None), self.parent[kids]), leaf[:, kids])
                np.add.at(incoming_d, (slice(None), self.parent[kids]), drag[:, kids])
        return leaf, drag

    def angles(self, x):
        """Static (θb, θr) (S, D, G, 2) rad at the log-parameters x, and (F^L, F^D) (D, G, 3)."""
        kappa, p, c, area = self._unpack(x)
        leaf, drag = self.forces(p, c, area)
        v = self.speeds[:, None, None, None]
        force = v * leaf[None] + v * v * drag[None]                         # (S, D, G, 3)
        return kappa[None, None, :, None] * np.einsum("gij,sdgj->sdgi", self.gains, force), \
            leaf, drag

    def residual(self, x):
        """Weighted angle errors (S·D·G·2,), then the pull toward the start (len(x),)."""
        theta, _, _ = self.angles(x)
        return np.concatenate([((theta - self.target) * self.weight).reshape(-1),
                               self.prior * (x - self.x0)])

    def worst(self, x) -> float:
        """The largest weighted angle error (the prior left out)."""
        theta, _, _ = self.angles(x)
        return float(np.max(np.abs((theta - self.target) * self.weight)))

    def jacobian(self, x):
        """d residual / d x, sparse (S·D·G·2 + len(x), len(x)): one block per ancestor pair."""
        kappa, p, c, area = self._unpack(x)
        theta, leaf, drag = self.angles(x)
        s_count, d_count = len(self.speeds), leaf.shape[0]
        v = self.speeds[:, None, None]
        # T(a, h) for every pair
        t = _transfer(self.parent, p, self.pair_a, self.pair_h)
        a, h = self.pair_a, self.pair_h
        scale = (kappa[a] * t)[None, None, :, None]                      # (1, 1, P, 1)
        w = self.weight                                                  # (S, D, G, 2)
        blocks_r, blocks_c, blocks_v = [], [], []
        sidx = np.arange(s_count)[:, None, None, None]
        didx = np.arange(d_count)[None, :, None, None]
        comp = np.arange(2)[None, None, None, :]

        def add(values, groups, cols):
            # values (S, D, n, 2) for rows of ``groups`` (n,), columns ``cols`` (n,)
            grp = groups[None, None, :, None]
            r = ((sidx * d_count + didx) * self.g + grp) * 2 + comp
            ww = w[sidx, didx, grp, comp]
            blocks_r.append(np.broadcast_to(r, values.shape).reshape(-1))
            blocks_c.append(np.broadcast_to(cols[None, None, :, None], values.shape).reshape(-1))
            blocks_v.append((values * ww).reshape(-1))

        gidx = np.arange(self.g)
        add(theta, gidx, gidx)                                            # log κ
        # log p'_h: T(a,h) κ_a G_a (F_h - v² c_h s_h)
        e = v[..., None] * leaf[None] + (v * v)[..., None] * (drag - c[None, :, None]
                                                                * self.drag_shape)[None]
        ge = np.einsum("pij,sdpj->sdpi", self.gains[a], e[:, :, h])
        add(scale * ge, a, self.g + h)
        # log c'_h: T(a,h) κ_a v² c_h G_a s_h
        add(scale * (v * v)[..., None] * c[h][None, None, :, None] * self.gs[None], a,
            2 * self.g + h)
        # log A_k: T(a,h_k) κ_a v p'_{h_k} A_k G_a ℓ_k, one term per (leaf, pair)
        q, k = self.pair_of_leaf, self.leaf_of_pair
        if len(q):
            coef = kappa[a[q]] * t[q] * p[self.leaf_branch[k]] * area[k]
            add(coef[None, None, :, None] * v[..., None] * self.gl[None], a[q], 3 * self.g + k)
        n_rows = s_count * d_count * self.g * 2
        blocks_r.append(n_rows + np.arange(len(x)))
        blocks_c.append(np.arange(len(x)))
        blocks_v.append(np.full(len(x), self.prior))
        return coo_matrix((np.concatenate(blocks_v), (np.concatenate(blocks_r),
                                                      np.concatenate(blocks_c))),
                          shape=(n_rows + len(x), len(x))).tocsr()

    def refine(self, kappa, p, c, area):
        """Least-squares refinement of (κ, p', c', A) (G, G, G, K) from the sequential solution.

        Returns the refined values, or None where refining does not lower the
        worst weighted error (or there is nothing to refine).
        """
        def start(vals):
            vals = np.asarray(vals, dtype=np.float64)
            pos = vals[vals > 0]
            lo = REFINE_START_FLOOR * (pos.max() if len(pos) else 1.0)
            return np.log(np.maximum(vals, lo))
        x0 = np.concatenate([start(kappa), start(p), start(c), start(area)])
        self.x0 = x0
        self.prior = REFINE_PRIOR
        if self.target.size == 0 or self.worst(x0) < REFINE_SKIP:
            return None
        fit = least_squares(self.residual, x0, jac=self.jacobian, method="trf",
                            bounds=(x0 - REFINE_LOG_RANGE, x0 + REFINE_LOG_RANGE),
                            x_scale="jac", max_nfev=REFINE_EVALUATIONS,
                            tr_options={"maxiter": REFINE_LSMR_ITERATIONS})
        x = fit.x
        if self.worst(x) >= self.worst(x0):
            return None
        return self._unpack(x)


def _pairs(parent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (ancestor-or-self a, branch h) pair: two (P,) int64 arrays, by ascending h."""
    pa, ph = [], []
    for h in range(len(parent)):
        a = h
        while a >= 0:
            pa.append(a)
            ph.append(h)
            a = int(parent[a])
    return np.array(pa, dtype=np.int64), np.array(ph, dtype=np.int64)


def _transfer(parent: np.ndarray, p: np.ndarray, pair_a: np.ndarray, pair_h: np.ndarray
              ) -> np.ndarray:
    """T(a, h) per pair: the product of p' from h's parent up to a (1 for a = h): (P,)."""
    out = np.empty(len(pair_a))
    prod = 1.0
    for i, (a, h) in enumerate(zip(pair_a.tolist(), pair_h.tolist())):
        prod = 1.0 if a == h else prod * p[a]
        out[i] = prod
    return out


def _nnls(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return nnls(a, b)[0] if np.any(a) else np.zeros(a.shape[1])


def _leaf_split(gain: np.ndarray, incoming: np.ndarray, own: np.ndarray, target: np.ndarray,
                natural_areas: np.ndarray) -> tuple[float, np.ndarray]:
    """λ and u_k of one group's leaf part: Θ^L ≈ λ G·incoming + Σ_k u_k G·ℓ_k, all >= 0.

    gain (2, 3); incoming (D, 3) children's F'^L; own (D, K, 3)
    unit-area forces of the group's adjustable leaves; target (D, 2);
    natural_areas (K,) the areas the level-n file gives those leaves.

    Where several splits fit equally well (a planar tree: children and own
    leaves push the same way), the fit is pulled, with a small weight
    (`SPLIT_REGULARISATION`, relative to the column norms), toward the natural
    split: children passed through and leaves at their natural areas, in the
    ratio 1 : A_k, scaled to fit.
    """
    basis = np.concatenate([incoming[:, None, :], own], axis=1)            # (D, 1+K, 3)
    a = np.einsum("ij,dkj->dik", gain, basis).reshape(-1, basis.shape[1])   # (2D, 1+K)
    b = target.reshape(-1)
    shape = np.concatenate([[1.0 if np.any(incoming) else 0.0], natural_areas])
    guess = a @ shape
    gg = float(guess @ guess)
    x0 = shape * max(0.0, float(guess @ b) / gg) if gg > 0 else np.zeros_like(shape)
    reg = SPLIT_REGULARISATION * np.diag(np.linalg.norm(a, axis=0))
    sol = _nnls(np.vstack([a, reg]), np.concatenate([b, reg @ x0]))
    return float(sol[0]), sol[1:]


def _unit_leaf_forces(skeleton: Tree, frames: RestFrames, directions: np.ndarray) -> np.ndarray:
    """The force of every leaf of ``skeleton`` at unit area and unit speed: (D, F, 3)."""
    return own_leaf_forces(_one_leaf_per_branch(skeleton), frames_for_leaves(frames, skeleton),
                           directions, np.ones(skeleton.n_leaves))


def _one_leaf_per_branch(tree: Tree) -> Tree:
    """A view of ``tree`` whose leaves are indexed as 'branches' for per-leaf forces.

    `own_leaf_forces` sums leaves per branch; giving every leaf its own slot
    yields per-leaf forces (D, F, 3).
    """
    view = Tree(**{**tree.__dict__})
    view.leaf_branch = np.arange(tree.n_leaves, dtype=np.int64)
    view.parent = np.full(tree.n_leaves, -1, dtype=np.int64)
    return view


def frames_for_leaves(frames: RestFrames, tree: Tree) -> RestFrames:
    """Rest frames re-indexed by leaf (each leaf gets its branch's frame), for `_one_leaf_per_branch`."""
    b = tree.leaf_branch
    return RestFrames(frames.swing[b], frames.axis[b], frames.base[b], frames.tip[b], frames.frame[b])
