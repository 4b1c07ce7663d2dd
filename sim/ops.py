"""select and floor: plain Python here, a `select` instruction and ``llvm.floor`` in numba.

The kernels' per-branch formulas (`branch_math`, `trig`) are plain Python functions
written with these two and + - * / sqrt, so the same source runs three ways with the
same bits: interpreted (short runs, no numba import: `kernel`), compiled for floats
(the single-run kernel) and compiled for `vec4.Vec4` lanes. `plantlod.sim.jit`
registers the numba versions (this module imports nothing heavy).
"""

from __future__ import annotations

import math


def select(c, a, b):
    """a where c, else b (lane by lane for a `vec4.Mask4`); compiled, a select, no branch."""
    return a if c else b


def floor(x):
    """The largest whole number <= x, as a float (a Vec4 lane by lane); inf and nan unchanged."""
    return float(math.floor(x)) if math.isfinite(x) else x
