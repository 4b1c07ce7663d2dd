"""The wind simulation (model.md sections 3 and 4).

Modules: `kinematics` (poses, numpy), `wind` (wind objects), `stability` (the
time-step limit), `run` (chunked runs), `kernel` (the time-stepping loop, interpreted
for short runs or compiled by numba), `lanes` (many runs as vector lanes),
`branch_math`, `trig` and `ops` (the formulas every kernel shares, plain Python),
`jit` and `vec4` (their numba side). This package imports nothing at import time, and
numba only loads when a run needs the compiled kernels (docs/engine.md).
"""
