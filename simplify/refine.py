"""All of a level's force parameters at once: least squares on every group's relative
static error (the second step of `closed_form.closed_form`; docs/simplify.md, "Refinement").

With log-parameters x = (log κ, log p', log c', log A) the residual of group g, component
c, speed v, direction V̂ is

    r = (θ'_gc(v, V̂; x) - Θ_gc(v, V̂)) / max(|Θ_gc|, REFINE_FLOOR · max |Θ|)

plus a weak pull REFINE_PRIOR (x - x_0) toward the sequential solution x_0; the bounds
keep x within x_0 ± REFINE_LOG_RANGE. The Jacobian is exact: a force entering branch h
reaches its ancestor a multiplied by T(a, h) = Π p' on the path (`transfer`), so each
derivative is a sum over (ancestor, descendant) pairs (`ancestor_pairs`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix

from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import depth_levels

from .constants import (REFINE_EVALUATIONS, REFINE_FLOOR, REFINE_LOG_RANGE,
                        REFINE_LSMR_ITERATIONS, REFINE_PRIOR, REFINE_SKIP, REFINE_START_FLOOR)
from .targets import StaticTargets


class StaticModel:
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
    pairs (a, h) (`ancestor_pairs`) and the Jacobian is exact and sparse.

    gains (G, 2, 3) per unit κ; per_leaf (D, K, 3) unit-area leaf forces;
    leaf_branch (K,) the branch of each; drag_shape (D, G, 3); targets: the
    original's static angles; speeds (S,) m/s; floor: relative errors are taken against
    at least this fraction of the largest target of each wind (1: the motion error).
    """

    def __init__(self, tree: Tree, gains, per_leaf, leaf_branch, drag_shape,
                 targets: StaticTargets, speeds: np.ndarray, floor: float = REFINE_FLOOR):
        self.parent = np.asarray(tree.parent, dtype=np.int64)
        self.levels = depth_levels(self.parent)
        self.gains, self.per_leaf, self.leaf_branch = gains, per_leaf, leaf_branch
        self.drag_shape, self.speeds = drag_shape, speeds
        self.g = len(self.parent)
        v = speeds[:, None, None, None]
        self.target = v * targets.leaf[None] + v * v * targets.drag[None]     # (S, D, G, 2)
        largest = np.abs(self.target).max(axis=(2, 3), keepdims=True)
        self.weight = 1.0 / np.maximum(np.abs(self.target), floor * largest
                                       + np.finfo(float).tiny)
        self.pair_a, self.pair_h = ancestor_pairs(self.parent)
        # G_a ℓ_k and G_a s_h per pair, fixed by the geometry: (D, P, 2)
        self.gs = np.einsum("pij,dpj->dpi", gains[self.pair_a], drag_shape[:, self.pair_h])
        # (leaf k, pair (a, h_k)) for every ancestor-or-self a of leaf k's branch; this
        # relies on `ancestor_pairs` listing pairs by ascending h, those of one h together
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
        t = transfer(self.parent, p, self.pair_a, self.pair_h)
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

    def refine(self, kappa, p, c, area, prior: float = REFINE_PRIOR,
               evaluations: int = REFINE_EVALUATIONS):
        """Least-squares refinement of (κ, p', c', A) (G, G, G, K) from the sequential solution;
        ``prior`` weighs the pull of each log-value toward its start, ``evaluations`` bounds
        the residual evaluations.

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
        self.prior = prior
        if self.target.size == 0 or self.worst(x0) < REFINE_SKIP:
            return None
        fit = least_squares(self.residual, x0, jac=self.jacobian, method="trf",
                            bounds=(x0 - REFINE_LOG_RANGE, x0 + REFINE_LOG_RANGE),
                            x_scale="jac", max_nfev=evaluations,
                            tr_options={"maxiter": REFINE_LSMR_ITERATIONS})
        x = fit.x
        if self.worst(x) >= self.worst(x0):
            return None
        return self._unpack(x)


def ancestor_pairs(parent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (ancestor-or-self a, branch h) pair: two (P,) int64 arrays, by ascending h."""
    pa, ph = [], []
    for h in range(len(parent)):
        a = h
        while a >= 0:
            pa.append(a)
            ph.append(h)
            a = int(parent[a])
    return np.array(pa, dtype=np.int64), np.array(ph, dtype=np.int64)


def transfer(parent: np.ndarray, p: np.ndarray, pair_a: np.ndarray, pair_h: np.ndarray
              ) -> np.ndarray:
    """T(a, h) per pair: the product of p' from h's parent up to a (1 for a = h): (P,)."""
    out = np.empty(len(pair_a))
    prod = 1.0
    for i, (a, h) in enumerate(zip(pair_a.tolist(), pair_h.tolist())):
        prod = 1.0 if a == h else prod * p[a]
        out[i] = prod
    return out
