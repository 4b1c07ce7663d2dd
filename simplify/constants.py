"""Constants of levels of detail: simplification (the measures' are plantlod.compare.constants)."""

from plantlod.compare.constants import COUNTED_AMPLITUDE_FRACTION  # noqa: F401  (the fit counts as compare does)

# --- simplify (docs/simplify.md) ------------------------------------------------------
SIMPLIFY_WRITE_DIGITS = 12    # significant digits of every computed value simplify writes
MATCH_DIRECTIONS = 16         # horizontal wind directions the static least-squares matches use
# Tilted winds matched too (docs/simplify.md, "Tilt"): when the branches below a group
# turn it, the wind it sees leaves the horizontal; matching the response to winds
# FIT_ELEVATION rad above and below the horizontal matches that part of the motion.
MATCH_TILTED_DIRECTIONS = 8   # azimuths at +FIT_ELEVATION and at -FIT_ELEVATION
FIT_ELEVATION = 0.2           # rad
MIN_LENGTH_FRACTION = 0.05    # no simplified branch shorter than this x its group's path length
SPLIT_REGULARISATION = 1e-2   # weight of the transmitted-force objective when splitting leaf force
SPLIT_COLUMN_FLOOR = 0.1      # ... and each leaf's pull at least this x the largest column's (`leaf_split`;
                              # tuning range, levels 1 / 2: none 3457 / 3508, 0.03 3538 / 3534, 0.1 3540 / 3534,
                              # 0.3 3544 / 3532 of 3862 / 3796; seeds 200-299 at 0.1: 1707 / 1664 -> 1737 / 1670)
# Global static refinement of the derived parameters (simplify/refine.py):
REFINE_DIRECTIONS = 8        # horizontal wind directions of the refinement
REFINE_TILTED_DIRECTIONS = 4  # azimuths at +FIT_ELEVATION and at -FIT_ELEVATION in the refinement
REFINE_LOG_RANGE = 8.0       # each refined value stays within e^±8 of its sequential value
REFINE_FLOOR = 0.01          # relative errors are taken against at least this x the largest angle
REFINE_START_FLOOR = 1e-4    # zero values start at this x the largest of their kind (log scale)
REFINE_PRIOR = 0.3           # pull of every log-value toward its sequential value (one residual each)
REFINE_SKIP = 1e-9           # no refinement where the sequential solution is already this close
REFINE_EVALUATIONS = 30      # residual evaluations of the least-squares refinement
REFINE_LSMR_ITERATIONS = 25  # inner iterations of each trust-region step (scipy lsmr); grammar form
REFINE_SCALE_PROBES = 16     # random ±1 probes estimating the Jacobian's column norms (seeded)
# Measurement and calibration winds: directions (deg) along x, 15 deg off x (hardest
# for a stalk whose leaf faces x), the diagonal and y; speeds low, sqrt(low*high),
# HIGH_SPEED_FRACTION of the way to high, and high.
MEASURE_WIND_DIRECTIONS = (0.0, 15.0, 45.0, 90.0)
HIGH_SPEED_FRACTION = 0.75
SIMPLIFY_DT = 0.01            # s, measurement runs (periods are 2.5 to 4.5 s)
SIMPLIFY_DURATION = 20.0      # s, at least four periods
SIMPLIFY_WIND_RANGE = (0.5, 20.0)   # m/s
SIMPLIFY_EVERY = 4            # keep every 4th step when measuring
# Steps of one measurement run at most (500 x the default's 2,000): the fit steps each
# group's swing from rest in numpy, a step at a time, and holds every wind's run at once,
# so --dt 1e-9 asked 37 GB and --dt 1e-7 ran for minutes before (a helper, session 34)
MAX_SIMPLIFY_STEPS = 1_000_000
CALIBRATION_EVALUATIONS = 40  # candidate trees simulated by --calibrate (each at every wind)
CALIBRATION_BOUNDS = ((-1.5, 1.5), (-3.0, 3.0), (-0.5, 0.5))   # log-factors: k_FA, C_d, strengths
CALIBRATION_STABILITY_MARGIN = 0.9  # largest fraction of the stability limit a strength may reach
CALIBRATION_ROUNDS = 6        # re-weighting rounds toward the worst error
CALIBRATION_WEIGHT_FLOOR = 0.1  # weight every residual keeps
# A period error counts this many times an amplitude error of the same size (the
# branching targets: amplitude 10 %, period 2 %); without it calibration trades
# periods for amplitudes (abop_1_24f: 43 % -> 29 % amplitude for 0.3 % -> 3.7 % period).
CALIBRATION_PERIOD_WEIGHT = 5.0

# --- explicit form (simplify/explicit.py, docs/simplify.md "Explicit form") -------------
LEVEL_NAME_CHARS = 1000      # an explicit level's name: the original's, cut to this, then " level n (explicit form)"
LEVEL_RATIO = 0.6             # level n has at most this x the branches of level n - 1 (model.md 5)
MAX_LEVEL = 1000              # a level number above this is refused at once (0.6^1000 of any tree is one branch;
                              # a level of 1e30 looped over every level number before it)
RUNS_BATCH_BYTES = 400_000_000  # angles held at once by simplify's measurement runs (lanes batched to this)
RUNS_PIECE_BYTES = 100_000_000  # angles of every wind in one piece of time of the original's runs (`evaluate.simulate_pieces`)
# The accuracy each level is held to (issue 12): motion error, period error (major), tip
# error as a fraction of the height; `simplify --form auto` keeps the grammar form where it
# meets them. Level 3 and beyond are held to level 2's.
LEVEL_BOUNDS = {1: (0.05, 0.02, 0.01), 2: (0.10, 0.04, 0.02)}
# A stalk's (a chain's) relative amplitude and period errors, in place of the first two (issue 21)
STALK_BOUNDS = {1: (0.02, 0.01), 2: (0.05, 0.02)}
SMALL_ANGLE_LIMIT = 0.1       # rad: the bounds apply while the original's combined angles stay below
# The explicit form's refinement fits what its levels are held to, the motion error
# (model.md 6: errors against the largest angle of the wind, so the floor is 1), with a
# weaker pull toward the tips-down start and more evaluations (docs/simplify.md,
# "The explicit form"; bench/lod_table.py measured the choice).
EXPLICIT_REFINE_FLOOR = 1.0
EXPLICIT_REFINE_PRIOR = 0.03
EXPLICIT_REFINE_EVALUATIONS = 30    # 100 before the gain matrix: same passes on the eval trees, 3-4x the time
EXPLICIT_REFINE_LSMR_ITERATIONS = 25   # 50 before the gain matrix (bent_leafy needed it then); 15 tried in
                                       # session 12: family tuning range 3270 -> 3281 / 3320 -> 3318 cases
                                       # (levels 1 / 2), abop_1_24a level 1 10.7 -> 9.7 s, but eval/bent_leafy
                                       # level 1 at 0.5 m/s 6.1 % motion (bound 5 %; its test)
# Equivalent leaves of an explicit level: the eigen-leaves ("eigen"), or the nine basis leaves
# ("basis") where their static error is the lower one (simplify/explicit.py). Basis
# leaves: bent_leafy level 2 21 % -> 1.7 % motion error. Until session 10 they had to halve
# the static error (they carried a scene's level switches less well, twin_draw level 9,
# the scene test's verified error 0.88 -> 1.19 px, which no longer happens); with the lower
# error winning, make lod-family's tuning range went 2653 -> 2705 level-1 and 2556 -> 2589
# level-2 cases (bent_leafy 302 -> 351 at level 1).
BASIS_LEAF_TRY = 0.1          # basis leaves are tried only where the eigen-leaves' static error is above this
                              # (0.02 until session 12; family tuning range, levels 1 / 2: 0.02 3271 / 3320,
                              # 0.1 3273 / 3329 (bent_leafy level 1 343 -> 328, stochastic 410 -> 429); the
                              # second fit was most of a level's cost: abop_1_24a level 1 10.7 -> 6.8 s)
BASIS_LEAF_ALWAYS = 300       # ... except in levels of at most this many branches, which try both leaf sets (session 15:
                              # with `sequential_fit.leaf_split`'s column floor the basis leaves lost their axial
                              # blow-ups; family tuning range, every kind but stalks, levels 1 / 2: 0.1 3245 / 3265,
                              # both always 3282 / 3278 (bent_leafy 407 -> 429, weeping 413 -> 425); trying both at
                              # every size took abop_1_24a level 1 to 12.1 s and abop_1_24c's chain to 39.1 s; up to
                              # 600 branches, the chain to 31.6 s; the family's level-1 trees have at most 252)
BASIS_LEAF_FLOOR = 1e-3       # a basis leaf starts at least at this x the group's leaf area
KAPPA_RANGE = 100.0           # explicit form: k_FA' stays within this factor of its group's mean k_FA

# --- the gain matrix of a level branch (simplify/gain_matrix.py, model.md 5) -----------
GAIN_FIT_SPEEDS = (0.5, 2.0, 5.0, 10.0, 20.0)   # m/s: the static match's wind speeds
GAIN_TARGET_FLOOR = 0.01     # a wind's errors count against at least this x the largest target
GAIN_RIDGE = 1e-6            # pull toward k_FA [[1,0,0],[0,1,0]], relative to the problem's scale
MIXED_CARRY = 0.1            # a chord whose carry map has diagonal and off-diagonal entries above
                             # this mixes bend and rotation in W_0: its strengths are searched
STRENGTH_SEARCH_POINTS = 8   # period grid of that search, coarse and then around the best
STRENGTH_SEARCH_EVERY = 4    # samples of the search's swings kept (as simplify measures)
GROUP_SWING_DIRECTIONS = 8   # horizontal wind directions a group's swing (period, amplitude) is read in
# swing rolls of a level branch about its rest axis (simplify/swing_rolls.py)
ROLL_CANDIDATES = (0.0, -45.0, -30.0, -15.0, 15.0, 30.0)   # degrees tried, 0 (unrolled) first,
                                                          # then the members' mean roll
ROLL_MIN = 5.0                # degrees: groups whose members' mean roll is smaller are left unrolled
ROLL_GAIN = 0.1               # a roll is kept only where it lowers the search cost by this fraction
ROLL_MIXED_PERIODS = 1.002    # only groups whose swing periods spread by more than this ratio
STRENGTH_MISMATCH_WEIGHT = (8.0, 16.0)  # explicit groupings: a merge's size counts x (1 + W x period gap
                              # + W_t x turn), W the first entry while level 1 is merged, the
                              # second for every level after it (family seeds 0-199, cases within
                              # targets at levels 1 / 2: W = 4 2740 / 2626, 8 2767 / 2691,
                              # 16 2729 / 2768, (8, 16) 2767 / 2762)
FRAME_TURN_WEIGHT = 8.0      # ... and x (1 + this x the turn it gives level branches; simplify/grouping.py;
                             # family tuning range with W as above, levels 1 / 2: W_t = 4 2767 / 2762,
                             # 8 2835 / 2769, 16 2832 / 2770)
TIP_MISS_WEIGHT = (1.0, 4.0)  # ... and x (1 + this x the tip miss it adds, in tip bounds; `merge_costs.TipMisses`),
                              # the first entry at level 1 (family tuning range, levels 1 / 2: without
                              # it 2835/3731 / 2769/3595, with (1, 4) 3002/3832 / 2990/3719; once merges
                              # were re-pushed (grouping.py), (2, 4) 3239/3865 / 3309/3794 against
                              # (1, 4) 3270/3865 / 3320/3790)
SHARE_SPREAD_WEIGHT = 1000.0  # ... and x (1 + this x the merged group's share spread; `merge_costs.ShareSpread`),
                              # chains only (stalks of the tuning range, levels 1 / 2, with the motion fit's
                              # turned winds left out: without it 226 / 206 of 434 / 413 cases; 100 269 / 253,
                              # 300 279 / 255, 1000 286 / 260 of 436 / 415, 3000 279 / 275 of 433 / 401)
SHARE_SPREAD_BRANCHING_WEIGHT = (10.0, 0.0)  # ... the same for branching trees, while level 1 is merged and
                              # after (family, levels 1 / 2, branching kinds: tuning range 3087 / 3206 -> 3135 / 3204
                              # cases; 5: 3111 / 3206; 30: 3114 / 3187, sympodial level 1 -28; at every level, 10
                              # lost 31 level-2 cases (before the shares were absolute; absolute, (10, 5): level 2
                              # 3204 -> 3203); seeds 200-399, sympodial,
                              # bush3d, monopodial and mixed: 1356 / 1360 -> 1438 / 1359)
SHARE_SPREAD_FLOOR = 0.1      # the loadings a share spread compares: where the component's parts, summed in size, reach this
                              # x the group's largest at that speed (0.01: 288 / 259, 0.3: 284 / 251; the floor on the
                              # component's static swing, |Σ parts|, in place of Σ |parts|: every kind, levels 1 / 2,
                              # 3407 / 3472 against 3430 / 3473, bush3d level 1 343 -> 323)
MODE_MISFIT_WEIGHT = (0.0, 150.0)  # ... and x (1 + this x the merged group's mode misfit; `merge_costs.ModeMisfit`),
                              # level 1's merges, then the later levels' (family, every kind but stalks, level 2:
                              # tuning range 3278 -> 3285 / 3297 / 3299 / 3292 of ~3385 cases with 20 / 60 / 150 / 400,
                              # seeds 200-299 1527 -> 1533 / 1581 / 1607 / 1624; at level 1 of 3282 cases, 3: the same,
                              # 8: -6, 20: -34)
CROSSING_SKEW_WEIGHT = (300.0, 300.0)  # ... and a chain's x (1 + this x the merged group's crossing skew;
                              # `merge_costs.CrossingSkew`), level 1's merges, then the later levels'
                              # (family stalks, levels 1 / 2 against none: tuning range +13 / +19 with 100,
                              # +21 / +34 with 300, +18 / +36 with 1000 of ~430 cases each; seeds 200-399
                              # +26 / +12 with 300, +28 / +8 with 1000. Branching trees, where only major
                              # components' periods are held, to 2 %: 100 gave +5 / -19, so they go without)
MIN_MERGE_FACTOR = 0.25      # ... and at least this x (a merge that untwists frames is cheaper, never free)

# --- a chain's levels in several processes (simplify/chain_workers.py) ------------------
CHAIN_JOBS = 2                # `simplify --levels`' processes by default (at most the cores): each
                              # holds its own fits, so the 2 GB bound of issue 21 counts them all

# --- level 1 regrouped where its fitted level misses (simplify/regroup.py, session 18) ---
REGROUP_ATTEMPTS = 3          # level-1 fits at most: the first grouping, then groups kept apart where it missed
                              # (family level 1: tuning range +41 cases, held out +69; 5 attempts on 45 tuning
                              # trees that still missed after 3: +9, stalks -3; within noise, for 2 more fits)
REGROUP_MAX_BRANCHES = 1000   # ... for trees of at most this many branches (each attempt is a level-1 fit)
REGROUP_MISFIT_PRICINGS = ((150.0, 3), (1000.0, 2))  # where every attempt above misses: level 1 grouped
                              # again with the mode misfit priced at level 1 too, at each weight in turn (W_f for
                              # level 1 and after it; `MODE_MISFIT_WEIGHT`), for at most that many fits each (the
                              # first, then groups kept apart as above). 150 (session 22; diagnosis range 2000-2399,
                              # sympodial level 1: 633 cases without, 650 with 1 fit, 659 with 3 of 815); 1000
                              # (session 27; diagnosis range 200-399, sympodial: level 1 341 -> 366 of 431 cases,
                              # level 2 331 -> 361 of 429; a third weight, 10000, gained none; 500 in place of
                              # 1000: 363; 3 fits at 1000: one tree more there, none on seeds 400-599)
KEPT_APART_COST = 1e12        # added to the cost of a merge kept apart: level 1 takes it after every other

# --- the motion fit of an explicit level (simplify/motion_fit.py, issue 21) ------------
# (in simplify's measurement winds: on family seeds 0-35 they did as well as 32 winds round
# the compass, 299 against 289 of 665 level-1 cases, and share the original's runs)
MOTION_FIT_ROUNDS = 4         # rounds of corrections (each one run of the level per fit wind)
MOTION_FIT_STEP = 0.3         # largest log-correction of a period or gain row per round
MOTION_FIT_GOOD = 0.5         # stop once every fit wind is within this x the level's bounds
MOTION_FIT_MIN_GAIN = 0.01    # stop at the first round that lowers the worst ratio by less than this
                              # fraction (and misses no fewer winds): family seeds 0-35, levels 1-2,
                              # 187 rounds in place of 265, no fit wind more missed. Session 13, each group's
                              # best round kept: going on while any group improved, abop_1_24c's chain took
                              # 29.9 s (24.4 s before) for 15 more level-1 cases of the family's tuning range
                              # (3312 against 3297; level 2 3367 both), so this rule stays
MOTION_FIT_AMPLIFIED = 8.0    # a level branch swinging more than this x its static angle has its gain rows
                              # scaled, not refitted to its statics (motion_fit.swing_amplification; family
                              # tuning range, levels 1 / 2, with the final fit: 3297 / 3367 cases at 8, 3289 /
                              # 3363 at 4; with the fit going on while any group improved: 3316 / 3366 at 8,
                              # 3298 / 3350 at 2 (an earlier form of the keeping), 3269 / 3338 scaling every
                              # branch's rows)
MOTION_FIT_TURN = SMALL_ANGLE_LIMIT   # rad: fit only winds whose linear statics turn no branch's axis further
                              # (motion_fit.unturned; stalks of the tuning range, levels 1 / 2, with the share spread
                              # weighed 300: 0.1 rad 279 / 255, 0.2 286 / 251, 0.3 279 / 228)
MOTION_FIT_BOTH_WAYS = 0.8    # a chain's periods are corrected toward the mean of its upward and downward
                              # crossings' where that leaves each within this x the level's period bound
                              # (motion_fit.both_ways; stalks of the tuning range, levels 1 / 2: 0.6 286 / 267,
                              # 0.8 295 / 269, 1.0 297 / 269 (the mean then at the bound), 1.3 260 / 235)
MOTION_FIT_GAIN_RIDGE = 0.1   # the motion fit's gain-matrix step: pull toward the current G, x the
                              # normal matrix's mean diagonal (family seeds 0-35, level 1: 1e-3
                              # 460, 0.03 464, 0.1 466, 0.3 466, 1 457 of 667; 459 without the step)
MOTION_FIT_SWING_ITERATIONS = 6   # Gauss-Newton steps of the motion fit's second gain step, the modelled
                              # swing's (motion_fit.dynamic_gain_step; session 41's second fit: family tuning
                              # range, levels 1 / 2, 3665 / 3581 -> 3665 / 3586 cases, seeds 2000-2399 sympodial
                              # and bush3d level 1, 1538 -> 1557, no tree losing a level-1 case in either)
SWING_MIX = 1e-3              # a carry map whose diagonal and off-diagonal entries both pass this mixes a
                              # level branch's own angles (motion_fit.swings_differ: where none does, the second
                              # fit is not run; abop_1_24c's chain reads at most 2e-15)
MEMBER_STATICS_KEPT = 4       # the original's per-branch static angles kept for this many direction sets (`targets`)
REPORTS_KEPT = 6              # a Runs keeps the reports of this many trees (the motion fit's rounds, then the measurement)
