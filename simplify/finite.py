"""A fit that meets numbers that are not finite is a RunFailure, not numpy's or scipy's error.

A tree far outside what simplify fits (a strength of 1e-300 makes 1000 / k overflow; a
branch that absorbs no force leaves a leaf split with nothing to solve) reaches linear algebra
with infinities or NaNs, where numpy raises LinAlgError and scipy ValueError("array must not
contain infs or NaNs"). `finite_fit` wraps every fit of a level (`explicit.explicit_system_text`,
which `simplify --level`, a chain's levels, its regrouping and a scene's chain all call, and
`pipeline`'s forms), so each says so in one line.
"""

from __future__ import annotations

import functools
import math
from typing import Callable

import numpy as np

from plantlod.lsys.errors import RunFailure
from plantlod.lsys.tree import Tree

NOT_FINITE_FIT = ("simplify's fit met numbers that are not finite; the tree's strengths, "
                  "lengths or forces are far outside what it fits")


def finite_fit(fit: Callable) -> Callable:
    """``fit``, with numpy's LinAlgError and scipy's "infs or NaNs" ValueError raised as a
    RunFailure that says the tree is far outside what simplify fits."""

    @functools.wraps(fit)
    def guarded(*args, **kwargs):
        try:
            return fit(*args, **kwargs)
        except np.linalg.LinAlgError as exc:
            raise RunFailure(f"simplify's fit failed ({exc}); the tree's strengths, lengths or "
                             "forces are far outside what it fits") from None
        except ValueError as exc:
            if "infs or NaNs" not in str(exc):
                raise
            raise RunFailure(NOT_FINITE_FIT) from None

    return guarded


def finite_parameters(tree: Tree) -> bool:
    """Whether every parameter array of ``tree`` (lengths, strengths, forces, rest geometry,
    leaves, gain matrices, rolls) holds finite numbers only: a level whose fit overflowed
    (lengths of 1e-300 m make a chord's length underflow to 0 and its drag per area infinite)
    diverges at its first step, which says nothing about the winds."""
    arrays = [tree.length, tree.radius, tree.bend_strength, tree.rotation_strength,
              tree.force_absorbed, tree.force_propagated, tree.drag_coefficient, tree.euler,
              tree.offset, tree.leaf_area, tree.leaf_normal, tree.force_gain, tree.swing_roll]
    return all(bool(np.isfinite(np.asarray(a, dtype=np.float64)).all())
               for a in arrays if a is not None) and math.isfinite(tree.leaf_force_scale)
