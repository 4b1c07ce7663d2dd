"""All of a level's force parameters at once: least squares on every group's relative
static error (the second step of `closed_form.closed_form`; docs/simplify.md, "Refinement").

With log-parameters x = (log κ, log p', log c', log A) the residual of group g, component
c, speed v, direction V̂ is

    r = (θ'_gc(v, V̂; x) - Θ_gc(v, V̂)) / max(|Θ_gc|, REFINE_FLOOR · max |Θ|)

plus a weak pull REFINE_PRIOR (x - x_0) toward the sequential solution x_0; the bounds
keep x within x_0 ± REFINE_LOG_RANGE. The Jacobian is exact and never formed: its
products with a vector (`StaticModel.jvp`, `StaticModel.vjp`) are one pass over the tree
each, the recursion of the forces differentiated, so the refinement costs time linear
in the branch count (the pairs of ancestor and descendant it used to sum over grow with
the branch count times the depth).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse.linalg import LinearOperator

from plantlod.lsys.tree import Tree
from plantlod.sim.blas_threads import one_blas_thread

from .constants import (REFINE_EVALUATIONS, REFINE_FLOOR, REFINE_LOG_RANGE,
                        REFINE_LSMR_ITERATIONS, REFINE_PRIOR, REFINE_SCALE_PROBES, REFINE_SKIP,
                        REFINE_START_FLOOR)
from .targets import StaticTargets
from .refine_kernels import (adjoint_down, angle_adjoint, angle_product, force_adjoint, force_product,
                             leaf_adjoint, leaf_totals)
from .tree_sums import LeafSums, TreeSums


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
    angles (floored where a component does not count). The Jacobian is a
    `LinearOperator` whose products are one pass over the tree (`jvp`, `vjp`).

    gains (G, 2, 3) per unit κ; per_leaf (D, K, 3) unit-area leaf forces;
    leaf_branch (K,) the branch of each; drag_shape (D, G, 3); targets: the
    original's static angles; speeds (S,) m/s; floor: relative errors are taken against
    at least this fraction of the largest target of each wind (1: the motion error).
    """

    def __init__(self, tree: Tree, gains, per_leaf, leaf_branch, drag_shape,
                 targets: StaticTargets, speeds: np.ndarray, floor: float = REFINE_FLOOR):
        self.parent = np.asarray(tree.parent, dtype=np.int64)
        self.sums = TreeSums(self.parent)
        self.leaf_sums = LeafSums(leaf_branch, len(self.parent))
        as_array = np.ascontiguousarray
        self.gains, self.per_leaf = as_array(gains, np.float64), as_array(per_leaf, np.float64)
        self.leaf_branch = as_array(leaf_branch, np.int64)
        self.drag_shape, self.speeds = drag_shape, as_array(speeds, np.float64)
        self.g = len(self.parent)
        v = speeds[:, None, None, None]
        self.target = v * targets.leaf[None] + v * v * targets.drag[None]     # (S, D, G, 2)
        largest = np.abs(self.target).max(axis=(2, 3), keepdims=True)
        self.weight = 1.0 / np.maximum(np.abs(self.target), floor * largest
                                       + np.finfo(float).tiny)

    def _unpack(self, x):
        g = self.g
        e = np.exp(x)
        return e[:g], e[g:2 * g], e[2 * g:3 * g], e[3 * g:]

    def forces(self, p, c, area):
        """(F^L, F^D) (D, G, 3) of every simplified branch at unit speed."""
        leaf = self.leaf_sums.sum(area[None, :, None] * self.per_leaf)
        drag = c[None, :, None] * self.drag_shape
        return self.sums.up(p, leaf, True), self.sums.up(p, drag, False)

    def angles(self, x):
        """Static (θb, θr) (S, D, G, 2) rad at the log-parameters x, and (F^L, F^D) (D, G, 3)."""
        kappa, p, c, area = self._unpack(x)
        leaf, drag = self.forces(p, c, area)
        v = self.speeds[:, None, None, None]
        force = v * leaf[None] + v * v * drag[None]                         # (S, D, G, 3)
        return kappa[None, None, :, None] * _gain_times(self.gains, force), \
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

    def _parts(self, x):
        """What both products need at x: the parameters, angles, forces and each branch's own
        drag c_g s_g (D, G, 3)."""
        kappa, p, c, area = self._unpack(x)
        theta, leaf, drag = self.angles(x)
        return kappa, p, c, area, theta, leaf, drag, c[None, :, None] * self.drag_shape

    def jvp(self, x, dx, parts=None):
        """J dx: the change of the residual (S·D·G·2 + len(x),) along log-parameters dx,
        by one pass from the tips down the tree (the recursion of `forces`, differentiated):

            δL_g = δp_g L_g + p_g (Σ_k A_k δA_k ℓ_k + Σ_c δL_c)
            δD_g = δp_g (D_g - c_g s_g) + δc_g c_g s_g + p_g Σ_c δD_c
            δθ_g = δκ_g θ_g + κ_g G_g (v δL_g + v² δD_g)
        """
        kappa, p, c, area, theta, leaf, drag, _own_drag = parts or self._parts(x)
        g = self.g
        dk, dp, dc, da = dx[:g], dx[g:2 * g], dx[2 * g:3 * g], dx[3 * g:]
        d_own = leaf_totals(self.leaf_branch, area * da, self.per_leaf, g)
        # δL_g = p_g (own'_g + Σ_c δL_c) with own' = Σ_k A_k δA_k ℓ_k + δp_g L_g / p_g
        d_leaf, d_drag = np.empty_like(leaf), np.empty_like(drag)
        force_product(self.sums.first, self.sums.child, p, c, np.ascontiguousarray(dp),
                      np.ascontiguousarray(dc), d_own, leaf, drag, self.drag_shape, d_leaf, d_drag)
        out = np.empty(self.weight.size + len(x))
        angle_product(np.ascontiguousarray(dk), kappa, theta, self.gains, self.speeds, d_leaf,
                      d_drag, self.weight, out)
        out[self.weight.size:] = self.prior * dx
        return out

    def vjp(self, x, u, parts=None):
        """Jᵀ u (len(x),) for u (S·D·G·2 + len(x),), by one pass from the trunk up (the
        adjoint of `jvp`): each branch's force adjoint F̄_g = κ_g G_gᵀ (w ū)_g summed over
        speeds with v and v², plus p'_parent times its parent's."""
        kappa, p, c, area, theta, leaf, drag, own_drag = parts or self._parts(x)
        g = self.g
        n = self.weight.size
        d_count = self.weight.shape[1]
        k_bar = np.zeros(g)
        l_bar, d_bar = np.zeros((d_count, g, 3)), np.zeros((d_count, g, 3))
        angle_adjoint(np.ascontiguousarray(u[:n]), kappa, theta, self.gains, self.speeds,
                      self.weight, k_bar, l_bar, d_bar)
        adjoint_down(self.parent, p, l_bar, d_bar)                          # trunk first
        out = np.zeros(len(x))
        out[:g] = k_bar
        p_bar, c_bar = np.zeros(g), np.zeros(g)
        force_adjoint(l_bar, d_bar, leaf, drag, own_drag, p_bar, c_bar)
        out[g:2 * g], out[2 * g:3 * g] = p_bar, c_bar
        per_leaf_bar = np.zeros(len(self.leaf_branch))
        leaf_adjoint(l_bar, self.leaf_branch, self.per_leaf, per_leaf_bar)
        out[3 * g:] = p[self.leaf_branch] * area * per_leaf_bar
        return out + self.prior * u[n:]

    def jacobian(self, x):
        """d residual / d x as a `LinearOperator` (`jvp`, `vjp`): each product costs one
        pass over the tree, so the refinement is linear in the branch count."""
        rows = self.weight.size + len(x)
        x = np.array(x, copy=True)
        parts = self._parts(x)
        return LinearOperator((rows, len(x)), matvec=lambda dx: self.jvp(x, np.ravel(dx), parts),
                              rmatvec=lambda u: self.vjp(x, np.ravel(u), parts), dtype=np.float64)

    def column_scale(self, x, probes: int = REFINE_SCALE_PROBES) -> np.ndarray:
        """1 / the Jacobian's column norms at x, estimated from ``probes`` fixed ±1 vectors
        (E[(Jᵀz)_j²] = Σ_i J_ij² for independent signs z_i; seeded, so the same every run):
        the variable scaling `least_squares` calls x_scale="jac", without forming J."""
        op = self.jacobian(x)
        signs = np.random.default_rng(0).choice([-1.0, 1.0], size=(probes, op.shape[0]))
        sq = np.mean([op.rmatvec(z) ** 2 for z in signs], axis=0)
        norm = np.sqrt(sq)
        return 1.0 / np.maximum(norm, 1e-12 * max(float(norm.max()), 1e-300))

    def refine(self, kappa, p, c, area, prior: float = REFINE_PRIOR,
               evaluations: int = REFINE_EVALUATIONS, inner: int = REFINE_LSMR_ITERATIONS):
        """Least-squares refinement of (κ, p', c', A) (G, G, G, K) from the sequential solution;
        ``prior`` weighs the pull of each log-value toward its start, ``evaluations`` bounds
        the residual evaluations, ``inner`` the lsmr iterations of each step.

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
        try:
            # lsmr's norms of long residuals: on one BLAS thread, the same bits on any machine
            with np.errstate(over="ignore", invalid="ignore"), one_blas_thread():
                fit = least_squares(self.residual, x0, jac=self.jacobian, method="trf",
                                    bounds=(x0 - REFINE_LOG_RANGE, x0 + REFINE_LOG_RANGE),
                                    x_scale=self.column_scale(x0), max_nfev=evaluations,
                                    tr_solver="lsmr", tr_options={"maxiter": inner})
        except ValueError:
            # a trial step overflowed (values e^±8 from a start whose forces are already
            # extreme): the refinement has nothing to offer, the sequential solution stands
            return None
        x = fit.x
        if not np.all(np.isfinite(x)) or not self.worst(x) < self.worst(x0):
            return None
        return self._unpack(x)


def _gain_times(gains: np.ndarray, force: np.ndarray) -> np.ndarray:
    """(..., G, 2) angles of gains (G, 2, 3) times forces (..., G, 3), written out (the
    refinement's inner loop: much faster than einsum for these 2×3 blocks)."""
    return np.stack([gains[:, i, 0] * force[..., 0] + gains[:, i, 1] * force[..., 1]
                     + gains[:, i, 2] * force[..., 2] for i in range(2)], axis=-1)
