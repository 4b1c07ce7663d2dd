"""Forces summed from the tips down a tree, and their adjoint from the trunk up (compiled).

The static theory (`static.propagate`), the refinement's model and its Jacobian products
(`refine.StaticModel`) all run the recursion of model.md 4 at rest,

    through_own (leaves):  T_g = s_g (own_g + Σ_children T_c)
    otherwise (drag):      T_g = own_g + s_g Σ_children T_c

and the refinement also its adjoint, B_c = own_c + s_parent B_parent. A numpy version
must go a depth level at a time (abop_1_24a has about 80 levels), and its per-level
overhead dominated the refinement; these loops go branch by branch. Branches come
parent before child (children have higher indices), and children are summed in
ascending order, as the level-wise numpy sums did.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def _up(first, child, scale, own, through_own, out):
    d_count, g_count, width = own.shape
    for g in range(g_count - 1, -1, -1):
        for d in range(d_count):
            for j in range(width):
                incoming = 0.0
                for q in range(first[g], first[g + 1]):
                    incoming += out[d, child[q], j]
                if through_own:
                    out[d, g, j] = scale[g] * (own[d, g, j] + incoming)
                else:
                    out[d, g, j] = own[d, g, j] + scale[g] * incoming


@numba.njit(cache=True, error_model="numpy")
def _down(parent, scale, own, out):
    d_count, g_count, width = own.shape
    for g in range(g_count):
        p = parent[g]
        for d in range(d_count):
            for j in range(width):
                if p >= 0:
                    out[d, g, j] = own[d, g, j] + scale[p] * out[d, p, j]
                else:
                    out[d, g, j] = own[d, g, j]


class TreeSums:
    """The two passes for one tree. parent (G,) int64, parent before child."""

    def __init__(self, parent: np.ndarray):
        self.parent = np.ascontiguousarray(parent, dtype=np.int64)
        g = len(self.parent)
        has = self.parent >= 0
        kids = np.flatnonzero(has)                          # ascending, so each parent's
        order = np.argsort(self.parent[kids], kind="stable")    # children stay ascending
        self.child = np.ascontiguousarray(kids[order])
        counts = np.bincount(self.parent[kids], minlength=g)
        self.first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)

    def up(self, scale: np.ndarray, own: np.ndarray, through_own: bool) -> np.ndarray:
        """Totals T (D, G, 3) from own values (D, G, 3) and per-branch scale s (G,)."""
        own = np.ascontiguousarray(own, dtype=np.float64)
        out = np.empty_like(own)
        _up(self.first, self.child, np.ascontiguousarray(scale, dtype=np.float64), own,
            bool(through_own), out)
        return out

    def down(self, scale: np.ndarray, own: np.ndarray) -> np.ndarray:
        """Adjoint totals B (D, G, 3): B_g = own_g + s_parent B_parent, trunk first."""
        own = np.ascontiguousarray(own, dtype=np.float64)
        out = np.empty_like(own)
        _down(self.parent, np.ascontiguousarray(scale, dtype=np.float64), own, out)
        return out


class LeafSums:
    """Per-branch sums of per-leaf values. leaf_branch (K,) int64, g the branch count."""

    def __init__(self, leaf_branch: np.ndarray, g: int):
        leaf_branch = np.asarray(leaf_branch, dtype=np.int64)
        self.g = g
        self.order = np.argsort(leaf_branch, kind="stable")
        self.branches, self.starts = np.unique(leaf_branch[self.order], return_index=True)

    def sum(self, values: np.ndarray) -> np.ndarray:
        """(D, G, 3) sums over each branch's leaves of values (D, K, 3)."""
        out = np.zeros((values.shape[0], self.g, values.shape[2]))
        if len(self.order):
            out[:, self.branches] = np.add.reduceat(values[:, self.order], self.starts, axis=1)
        return out
