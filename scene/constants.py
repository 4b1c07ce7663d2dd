"""Constants of scenes (docs/scene.md)."""

MAX_TREES = 100_000            # trees one scene may place (a [scatter] count is checked before drawing)
# m: every coordinate a scene gives (positions, camera targets, a scatter's area) lies within
# this of the origin, as every tree's own rest extent does (compare's MAX_EXTENT_M); a tree at
# 1e308 m made distances overflow, the run went on with numpy's warning (session 38's fuzzing)
MAX_SCENE_COORDINATE_M = 1e9
MAX_TREE_SCALE = 1e6           # a tree's scale: 1e308 made its extent overflow the same way
# distinct (file, seed) pairs of one scene: a level chain each, fitted in 10-20 s for the
# bundled trees (a few hours at the limit; one seed per tree of a 100,000-tree forest was weeks)
MAX_SCENE_CHAINS = 1_000
MAX_SCENE_NESTING = 100          # arrays and inline tables inside each other: where tomllib's stack ran
                                 # out, the first bracket past this many is named (a scene needs 3)
MAX_SCENE_STEPS = 1_000_000    # time steps of one scene (duration / dt): 10,000 s at dt = 0.01
# trees x branches x steps of a scene at full detail (a tree with no branch counts as one):
# the bound on the work a scene may ask for; forest10k.toml asks about 2e9
MAX_SCENE_BRANCH_STEPS = 100_000_000_000
# trees x steps: every tree's wind is held for the whole scene (24 bytes a tree-step, 2.4 GB)
MAX_SCENE_TREE_STEPS = 100_000_000
MAX_SCATTER_CELLS = 1e15       # a scatter's spacing grid: at most this many cells along the area's longer side
MAX_SCATTER_TRIES = 200        # random draws per tree before a scatter gives up on its spacing
FRAME_RATE = 30.0              # frames per second: levels are chosen, and errors verified, per frame
# Directions (deg, relative to the wind) over which a level's tip error and its error after a
# switch are taken, the worst of them, so the figures hold for any heading of the tree. Four
# sides (session 31 and before) missed by up to a third between them: bent_leafy's level 1
# switched into at 15 m/s, 15.9 mm at 0/90/180/270 deg, 21.4 mm at 8 or 16 directions.
TIP_ERROR_DIRECTIONS = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)
CACHE_ENV = "PLANTLOD_CACHE"   # overrides the per-user cache folder
VERIFY_LANES = 16             # full-detail trees run at once by --verify (bounds memory)
STORE_BATCH_TREES = 64         # --angles: trees per zarr chunk
STORE_TIME_CHUNK = 256         # --angles: frames per zarr chunk
HYSTERESIS = 0.8             # a tree moves to a coarser level only at <= this x the budget
CLUSTER_TIMEOUT_S = 30.0     # --scheduler: to connect, and to wait for a first worker
HELD_NOTE_RATIO = 0.8        # `scene` says why, where its speedup is below this x its bound
# A switch to a finer level starts it from a predicted state (scene/switch.py); its error is
# measured (`switch.switch_errors`) for switches every SWITCH_SAMPLE_S of a steady-wind run,
# each followed SWITCH_FOLLOW_S, tips compared every SWITCH_SAMPLE_EVERY_S
SWITCH_SAMPLE_S = 2.0
SWITCH_FOLLOW_S = 3.0
SWITCH_SAMPLE_EVERY_S = 0.05
TIP_RATE_STEP_S = 1e-6         # s: a tip-matched carry's rates differenced over this much of the finer level's
SHARE_FLOOR = 1e-9             # a group whose static deflection is below this x the largest shares equally
WORKER_CHAINS = 16              # level chains a process (a Dask worker) keeps read, one per tree file
CACHE_ENTRY_MAX_BYTES = 256 << 20   # a cache's KEY.json read at most (a forest's chains: a few MB);
                                    # a larger one, or one that is not a regular file, is a miss
