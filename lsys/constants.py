"""The one place for model defaults, tolerances and output formatting.

Every package imports its numbers from here; nothing else hard-codes them.
"""

# --- model defaults (model.md sections 2 and 4; the thesis) -------------------
DEFAULT_DRAG_COEFFICIENT = 0.0015   # C_d, "set to 0.0015" in the thesis
DEFAULT_LEAF_FORCE_SCALE = 1.0      # s_L
DEFAULT_SEED = 0
DEFAULT_MOVE_LENGTH = 1.0           # f without a parameter
DEFAULT_MAX_MODULES = 20_000_000    # derive --max-modules

# --- tolerances ------------------------------------------------------------------
ZYZ_DEGENERATE_TOL = 1e-9     # h below this: alpha is exactly 0 or pi (model.md 2)
NORMAL_UNIT_TOL = 1e-6        # tree files: leaf normals must be unit length within this
ALPHA_TIE_TOL = 1e-9          # main path: alphas this close are tied (model.md 5)
PROBABILITY_SUM_TOL = 1e-9    # stochastic alternatives must sum to 1 within this
COUNTED_AMPLITUDE_FRACTION = 0.01  # error measures count components >= 1 % (model.md 6)

DOLLAR_VERTICAL_TOL = 1e-9    # `$` leaves M unchanged when |world z x heading| < this

# --- gusts (docs/model.md, "Gusts") -------------------------------------------------
GUST_COMPONENTS = 8           # number of seeded sinusoids
GUST_MIN_FREQUENCY = 0.05     # Hz
GUST_MAX_FREQUENCY = 1.0      # Hz

# --- memory bounds of streaming work -----------------------------------------------
SIM_CHUNK_VALUES = 1 << 20    # angle values per yielded simulation chunk (8 MB float64)
SIM_STEPS_PER_CALL = 1 << 16  # kernel steps per call at most (bounds wind samples held)
DERIVED_TEXT_CHUNK_MODULES = 1 << 18  # modules per chunk of `derive --format string`

# --- output formatting ------------------------------------------------------------
# Angles and other floats in CSV output: fixed significant digits, so that a
# last-bit difference in a libm routine on another machine does not change bytes.
CSV_FLOAT_FORMAT = "%.10g"
# Tree files store floats exactly (shortest repr round-trips), so that
# `derive | simulate -` and `simulate x.lsys` see identical numbers.
