"""Constants of the error measures and of comparing runs (model.md 5 and 6)."""

# --- groups and error measures (model.md 5 and 6) ---------------------------------
ALPHA_TIE_TOL = 1e-9          # main path: alphas this close are tied (model.md 5)
COUNTED_AMPLITUDE_FRACTION = 0.01  # error measures count components >= 1 % (model.md 6)
MAJOR_AMPLITUDE_FRACTION = 0.10   # period error (major): components >= 10 % of A_max (model.md 6)
STILL_AMPLITUDE = 1e-12       # rad: an original whose largest combined-angle amplitude is at most
                              # this does not move, and nothing counts, as model.md 6 says of 0: a
                              # planar tree without drag in a wind across its plane swings 1e-17 rad
                              # of float64 roundoff, against which a level read 8e8 % motion error

# --- compare -------------------------------------------------------------------------
# Two runs' times agree when they differ by at most this much, relative to
# max(1 s, |t|): the CSV keeps 10 significant digits, a fresh run exact k * dt.
TIME_MATCH_RTOL = 1e-9
MAX_EXTENT_M = 1e9           # m: a tree reaching farther from the origin at rest is refused where
                              # positions are measured (compare, simplify, scene): 1e300 m posed
                              # tips whose squares overflow ("original tips is not finite", no file)
DEFAULT_PLOT_TIME = 4.0       # s: the posed trees of compare --plot (the thesis' figure 4)
