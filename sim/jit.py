"""The numba side of the engine's shared formulas: import this before compiling a kernel.

`branch_math` and `trig` are plain Python (the interpreter runs them for short runs,
`kernel.advance`); here they are registered with numba (``register_jitable``, inlined
at the call), and `vec4` registers the Vec4 type and the compiled `ops.select` and
`ops.floor`, so a kernel calls the same source for floats and for vectors.
"""

from __future__ import annotations

from numba.extending import register_jitable

from . import branch_math, trig, vec4  # noqa: F401  (vec4: the types and overloads)

for _fn in (branch_math.times_rest, branch_math.swing, branch_math.twist,
            branch_math.drag_magnitude, branch_math.gained_forces, branch_math.advance_angle,
            trig.sincos, trig.sincos1, trig._kernels):
    register_jitable(inline="always")(_fn)
