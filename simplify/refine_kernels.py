"""The refinement's Jacobian products over the (speed, direction, group, component) grid,
compiled (`refine.StaticModel.jvp` / `vjp` call these).

The residual grid has S·D·G·2 entries (5 speeds × 16 directions × 1,875 groups × 2 at
abop_1_24a's level 1: 300,000), and each product touched it about ten times through numpy
temporaries: 3-4 ms a product, 1,500 of each per refinement. These loops touch it once.
Shapes: theta, weight (S, D, G, 2); gains (G, 2, 3) per unit κ; forces and their
adjoints (D, G, 3); per_leaf (D, K, 3); leaf_branch (K,) int64; speeds (S,) m/s.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def leaf_totals(leaf_branch, scale, per_leaf, g_count):
    """(D, G, 3): Σ over each branch's leaves k (ascending) of scale_k · per_leaf[:, k]."""
    d_count, k_count, width = per_leaf.shape
    out = np.zeros((d_count, g_count, width))
    for k in range(k_count):
        b = leaf_branch[k]
        for d in range(d_count):
            for j in range(width):
                out[d, b, j] += scale[k] * per_leaf[d, k, j]
    return out


@numba.njit(cache=True, error_model="numpy")
def angle_product(dk, kappa, theta, gains, speeds, d_leaf, d_drag, weight, out):
    """out[:S·D·G·2] = (δκ_g θ_g + κ_g G_g (v δL_g + v² δD_g)) · w, the grid in C order."""
    s_count, d_count, g_count, _ = theta.shape
    n = 0
    for s in range(s_count):
        v = speeds[s]
        v2 = v * v
        for d in range(d_count):
            for g in range(g_count):
                f0 = v * d_leaf[d, g, 0] + v2 * d_drag[d, g, 0]
                f1 = v * d_leaf[d, g, 1] + v2 * d_drag[d, g, 1]
                f2 = v * d_leaf[d, g, 2] + v2 * d_drag[d, g, 2]
                for i in range(2):
                    moved = gains[g, i, 0] * f0 + gains[g, i, 1] * f1 + gains[g, i, 2] * f2
                    out[n] = (dk[g] * theta[s, d, g, i] + kappa[g] * moved) * weight[s, d, g, i]
                    n += 1


@numba.njit(cache=True, error_model="numpy")
def angle_adjoint(u, kappa, theta, gains, speeds, weight, k_bar, l_bar, d_bar):
    """From u (S·D·G·2, C order) with ū = w u: k_bar[g] = Σ ū θ (over s, d, i) and the force
    adjoints F̄ = κ_g G_gᵀ ū summed over speeds with v (l_bar) and v² (d_bar), (D, G, 3).
    k_bar, l_bar, d_bar come in zeroed."""
    s_count, d_count, g_count, _ = theta.shape
    n = 0
    for s in range(s_count):
        v = speeds[s]
        v2 = v * v
        for d in range(d_count):
            for g in range(g_count):
                u0 = u[n] * weight[s, d, g, 0]
                u1 = u[n + 1] * weight[s, d, g, 1]
                n += 2
                k_bar[g] += u0 * theta[s, d, g, 0] + u1 * theta[s, d, g, 1]
                for j in range(3):
                    f = kappa[g] * (gains[g, 0, j] * u0 + gains[g, 1, j] * u1)
                    l_bar[d, g, j] += v * f
                    d_bar[d, g, j] += v2 * f


@numba.njit(cache=True, error_model="numpy")
def force_adjoint(l_bar, d_bar, leaf, drag, own_drag, out_p, out_c):
    """out_p[g] = Σ_{d,j} l̄ L + d̄ (D - c s); out_c[g] = Σ_{d,j} d̄ c s (zeroed on entry)."""
    d_count, g_count, width = leaf.shape
    for d in range(d_count):
        for g in range(g_count):
            for j in range(width):
                out_p[g] += l_bar[d, g, j] * leaf[d, g, j] \
                    + d_bar[d, g, j] * (drag[d, g, j] - own_drag[d, g, j])
                out_c[g] += d_bar[d, g, j] * own_drag[d, g, j]


@numba.njit(cache=True, error_model="numpy")
def leaf_adjoint(l_bar, leaf_branch, per_leaf, out):
    """out[k] = Σ_{d,j} l̄[d, branch_k, j] per_leaf[d, k, j] (zeroed on entry)."""
    d_count, k_count, width = per_leaf.shape
    for d in range(d_count):
        for k in range(k_count):
            b = leaf_branch[k]
            for j in range(width):
                out[k] += l_bar[d, b, j] * per_leaf[d, k, j]


@numba.njit(cache=True, error_model="numpy")
def force_product(first, child, p, c, dp, dc, d_own, leaf, drag, drag_shape, d_leaf, d_drag):
    """The force changes of `refine.StaticModel.jvp`, (D, G, 3) each into d_leaf and d_drag,
    in one pass from the tips down (children, ascending, at ``child[first[g]:first[g + 1]]``):

        δL_g = p_g (δown_g + (δp_g / p_g) L_g + Σ_c δL_c)
        δD_g = (c_g δc_g) s_g + δp_g (D_g - c_g s_g) + p_g Σ_c δD_c

    the same operations, in the same order, as `tree_sums.TreeSums.up` on the numpy terms
    (bit for bit; the numpy version's temporaries cost twice this pass)."""
    d_count, g_count, width = leaf.shape
    for d in range(d_count):                   # a direction at a time: its (G, 3) slabs stay in cache
        for g in range(g_count - 1, -1, -1):
            ratio = dp[g] / p[g]
            own_scale = c[g] * dc[g]
            for j in range(width):
                in_leaf = 0.0
                in_drag = 0.0
                for q in range(first[g], first[g + 1]):
                    in_leaf += d_leaf[d, child[q], j]
                    in_drag += d_drag[d, child[q], j]
                own_leaf = d_own[d, g, j] + ratio * leaf[d, g, j]
                d_leaf[d, g, j] = p[g] * (own_leaf + in_leaf)
                shape = drag_shape[d, g, j]
                own_drag = own_scale * shape + dp[g] * (drag[d, g, j] - c[g] * shape)
                d_drag[d, g, j] = own_drag + p[g] * in_drag


@numba.njit(cache=True, error_model="numpy")
def adjoint_down(parent, p, l_bar, d_bar):
    """In place, trunk first: B_g += p_parent B_parent for both force adjoints (D, G, 3), as
    `tree_sums.TreeSums.down` (a parent comes before its children, so it is final when read)."""
    d_count, g_count, width = l_bar.shape
    for d in range(d_count):                   # a direction at a time: its (G, 3) slabs stay in cache
        for g in range(g_count):
            q = parent[g]
            if q < 0:
                continue
            for j in range(width):
                l_bar[d, g, j] = l_bar[d, g, j] + p[q] * l_bar[d, q, j]
                d_bar[d, g, j] = d_bar[d, g, j] + p[q] * d_bar[d, q, j]
