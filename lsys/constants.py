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
# --max-modules: derive's peak memory is 650 bytes (ABOP 1.24a at n = 8: 1.17 M modules,
# 750 MB) to 1.1 kB (F -> FF at n = 21, every module a branch: 2.1 M modules, 2.3 GB) per
# module, so 5 M modules stay within about 3.5 to 5.5 GB.
DEFAULT_MAX_MODULES = 5_000_000
# how the module limit is named in its errors, which every command that derives can raise
# (only derive has the option, the API's build functions max_modules; a scene neither:
# fewer steps is what every command can be given)
MODULE_LIMIT_SAID = ("more than the {:,} modules allowed; expected a smaller derivation length "
                     "(the file's derivation_length, or -n / --steps where given; or derive "
                     "--max-modules, the API's max_modules)")


# --- tolerances ------------------------------------------------------------------
ZYZ_DEGENERATE_TOL = 1e-9     # h below this: alpha is exactly 0 or pi (model.md 2)
PROBABILITY_SUM_TOL = 1e-9    # stochastic alternatives must sum to 1 within this

DOLLAR_VERTICAL_TOL = 1e-9    # `$` leaves M unchanged when |world z x heading| < this


# --- limits on input (docs/errors.md, "Limits") ----------------------------------
MAX_DERIVATION_STEPS = 10_000       # derivation_length / -n above this: exit 2
# The derivation history keeps two int64 per module per step (the addresses);
# its total over all steps may be at most this many times --max-modules.
DERIVATION_HISTORY_FACTOR = 8
# Addresses (lsys/derived.py `address_strings`): built prefix by prefix unless that would
# write this many times the characters of the addresses themselves (a chain k steps deep:
# k/3 times; the chain of 8,900 branches took 481 s, joined row by row 17 s), then joined
# from their numbers, at most this many numbers at a time.
ADDRESS_PREFIX_EXCESS = 4
ADDRESS_BLOCK_NUMBERS = 4_000_000
MAX_LINE_CHARS = 1_000_000          # one line of an .lsys file
MAX_EXPRESSION_DEPTH = 100          # nesting of an expression (operators, parentheses, calls)
