"""Constants of the dynamics: gusts and the memory bounds of streaming runs."""

import signal as _signal

# --- gusts (docs/model.md, "Gusts") -------------------------------------------------
GUST_COMPONENTS = 8           # number of seeded sinusoids
GUST_MIN_FREQUENCY = 0.05     # Hz
GUST_MAX_FREQUENCY = 1.0      # Hz

# --- memory bounds of streaming work -----------------------------------------------
SIM_CHUNK_VALUES = 1 << 20    # angle values per yielded simulation chunk (8 MB float64)
SIM_STEPS_PER_CALL = 1 << 16  # kernel steps per call at most (bounds wind samples held)

# --- limits of a run (docs/errors.md, "Limits") --------------------------------------
MIN_TIME_STEP = 1e-9          # s; a smaller --dt is refused (1e-320 overflowed the step count)
FIRST_STEPS_DIVERGED = 3      # a run no longer finite within these steps had a force out of range
MAX_TIME_STEPS = 10**10       # steps of one run, --steps or round(--duration / --dt)
# Angles a whole run may hold in memory (compare, simplify; simulate streams): 4 GB.
MAX_HELD_ANGLE_BYTES = 4_000_000_000

# A branch period shorter than this many samples of a run is aliased: its period and amplitude
# read from the run mean little (a warning in simplify and compare; sim/aliasing.py)
MIN_SAMPLES_PER_PERIOD = 8

# --- the model's range (docs/model.md) ---------------------------------------------
# A branch tilted by more than this (hypot of bend and rotation, rad) is far outside the
# small-angle model: the run goes on, and says so once (the branch and the time).
LARGE_ANGLE_RAD = 1.0

# --- the lanes engine (sim/lanes.py, docs/engine.md) --------------------------------
THREADS_ENV = "PLANTLOD_THREADS"  # environment variable: threads of the engine (default: all cores)
# environment variable: "compiled" or "interpreted" forces the single-run kernel's engine
# (default: interpreted for short runs while numba is not loaded; the same bits either way)
KERNEL_ENV = "PLANTLOD_KERNEL"
# numba's own variables, read when numba is imported; checked before a command starts
# (sim/engine_env.py): a whole number of threads from 1 to MAX_NUMBA_THREADS (99,999 threads
# ended in a segmentation fault, 20,000 in "libgomp: Thread creation failed"), and whether
# its compiler is off
NUMBA_THREADS_ENV = "NUMBA_NUM_THREADS"
NUMBA_NO_JIT_ENV = "NUMBA_DISABLE_JIT"
MAX_NUMBA_THREADS = 1024

# --- workers (sim/workers.py) ----------------------------------------------------------
# Signals that end a command (cli.discipline: temporaries removed, exit 128 + n); workers
# ignore them and die with the command instead
CAUGHT_SIGNALS = tuple(getattr(_signal, name) for name in (
    "SIGINT", "SIGTERM", "SIGHUP",
    # ... and every other signal whose default ends the process and that a user or a
    # limit sends (`ulimit -t`: SIGXCPU; `kill -QUIT`, -USR1, -USR2, -ALRM): their default
    # action left temporary files and --levels' worker processes behind (session 29)
    "SIGQUIT", "SIGUSR1", "SIGUSR2", "SIGXCPU", "SIGALRM") if hasattr(_signal, name))
WORKER_POLL = 1.0            # s: waits on the workers wake this often (and a finished worker is joined)
MAX_DAMPING_RATIO = 100.0     # ζ above this is refused (measured trees 0.02-0.10, critical 1; at 1e10 the
                             # stable step underflowed to 0 s)
MAX_WIND_SPEED = 1000.0        # m/s: faster winds are refused (the strongest gusts measured are near 110 m/s;
                             # at 1e300 the scene's wind overflowed to inf)
SPEED_ROUNDING = 1e-12       # relative: a speed of exactly MAX_WIND_SPEED toward 30° measures 1000.0000000000001
REST_HEIGHT_ROUNDING = 1e-12   # a rest height within this x the tree's largest tip coordinate is 0 (flat)
