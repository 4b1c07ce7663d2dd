"""Rest lengths of a level's branches: tips where the groups' tips are (a linear fit)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import lsq_linear
from scipy.sparse import coo_matrix

from plantlod.lsys.tree import Tree

from .constants import MIN_LENGTH_FRACTION
from .static import RestFrames, rest_frames
from .targets import GroupMap


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
