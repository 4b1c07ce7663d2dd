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
from typing import Callable

import numpy as np

from plantlod.lsys.errors import RunFailure


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
            raise RunFailure("simplify's fit met numbers that are not finite; the tree's "
                             "strengths, lengths or forces are far outside what it fits") from None

    return guarded
