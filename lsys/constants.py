"""Constants of the L-system language: model defaults and geometric tolerances.

One place per domain: `plantlod.lsys.constants` (the language),
`plantlod.sim.constants` (the dynamics), `plantlod.simplify.constants` (levels of
detail and their measures), `plantlod.formats.constants` (bytes in and out).
Import a constant under its own name, never an alias.
"""

# --- model defaults (model.md sections 2 and 4; the thesis) -------------------
DEFAULT_DRAG_COEFFICIENT = 0.0015   # C_d, "set to 0.0015" in the thesis
DEFAULT_LEAF_FORCE_SCALE = 1.0      # s_L
DEFAULT_SEED = 0
DEFAULT_MOVE_LENGTH = 1.0           # f without a parameter
DEFAULT_MAX_MODULES = 20_000_000    # derive --max-modules


# --- tolerances ------------------------------------------------------------------
ZYZ_DEGENERATE_TOL = 1e-9     # h below this: alpha is exactly 0 or pi (model.md 2)
PROBABILITY_SUM_TOL = 1e-9    # stochastic alternatives must sum to 1 within this

DOLLAR_VERTICAL_TOL = 1e-9    # `$` leaves M unchanged when |world z x heading| < this
