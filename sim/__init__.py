"""The wind simulation (model.md sections 3 and 4).

Modules: `kinematics` (poses, numpy), `wind` (wind objects), `stability` (the
time-step limit), `run` (chunked runs), `kernel` (the numba time-stepping loop).
This package does not import numba at import time; only `kernel` does, and
`run` imports it when a simulation starts.
"""
