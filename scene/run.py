"""Run a scene (model.md 7): every tree, frame by frame, at the coarsest level its distance allows.

1. Levels: the chain of every distinct tree file and seed (`file.Source`), with each
   level's tip error (max), from the cache or simplified now (`scene.levels`).
2. Schedule: per tree and frame (``frame_rate`` per second) the level, with hysteresis
   (`scene.schedule`); the camera may be keyed in time.
3. Engine: the trees of one source run in batches of up to STORE_BATCH_TREES. A batch's run
   is cut into epochs at the frames where any of its trees switches level; within an
   epoch the trees at one level step together as lanes of one `run_lanes` call on all
   cores, each in its own wind (the scene's wind turned into the tree's frame, with gusts,
   delayed by a front travelling at ``front_speed``). At a switch the tree's state is
   carried to the new level (`scene.switch`). Results do not depend on the thread count.
4. With ``verify``, every tree also runs at full detail; per frame, the largest distance
   between each group tip and its level branch's tip is turned into pixels by the same
   formula at that frame's distance: the error actually spent.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import pathlib
import re
import time
from dataclasses import dataclass, field

import numpy as np

from plantlod.lsys.errors import InputError, PlantlodError, RunFailure
from plantlod.sim.kinematics import pose
from plantlod.simplify.constants import CHAIN_JOBS

from .constants import (
    CLUSTER_TIMEOUT_S, FRAME_RATE, MAX_SCENE_BRANCH_STEPS, MAX_SCENE_TREE_STEPS, STORE_BATCH_TREES,
    VERIFY_LANES,
)
from .file import Scene, Source, members_by_source, seed_named, source_name, sources
from .levels import Chain, Gusts, chain_from_texts, level_chains
from .schedule import distances, frame_bounds, frame_ends, frame_times, schedules
from .switch import Transfer, switch_errors


@dataclass
class Batch:
    """Trees of one source (a file and the seed it is grown from, `file.Source`) that run
    together: scene indices ``members`` (n,), their rows ``first`` .. first+n-1 in the
    source's store arrays, and their levels (n, F) per frame."""

    file: str
    file_index: int
    members: list[int]
    first: int
    schedule: np.ndarray
    seed: int | None = None

    @property
    def source(self) -> Source:
        return (pathlib.Path(self.file), self.seed)


@dataclass
class BatchResult:
    """Branch-steps spent, level switches, and with verify each member's level tips:
    per member a list of (row0, level, tips (K, B_l, 3))."""

    spent: int = 0
    switches: int = 0
    tips: list = field(default_factory=list)
    large: tuple | None = None     # (scene tree index, LargeAngle): the first beyond the model


def tree_winds(scene: Scene, steps: int) -> np.ndarray:
    """(N, steps, 3) m/s: each tree's wind at the start of each step, in the tree's own frame."""
    from plantlod.sim.wind import GustyWind, wind_from_speed

    base = wind_from_speed(scene.wind.speed, scene.wind.direction)
    wind = (GustyWind(base, seed=scene.wind.gust_seed, strength=scene.wind.gust_strength)
            if scene.wind.gust_strength > 0 else base)
    heading_dir = np.array([math.cos(math.radians(scene.wind.direction)),
                            math.sin(math.radians(scene.wind.direction)), 0.0])
    t = np.arange(steps) * scene.dt
    out = np.empty((len(scene.trees), steps, 3))
    for k, tree in enumerate(scene.trees):
        delay = 0.0
        if scene.wind.front_speed > 0:
            along = float(np.dot(np.asarray(tree.position), heading_dir))
            delay = max(0.0, along) / scene.wind.front_speed
        v = np.asarray(wind.sample(t - delay), dtype=np.float64)
        if delay > 0:
            v[t < delay] = 0.0                          # the front has not arrived yet
        h = math.radians(tree.heading)                  # world -> tree frame: Rz(-heading)
        c, s = math.cos(h), math.sin(h)
        out[k, :, 0] = c * v[:, 0] + s * v[:, 1]
        out[k, :, 1] = -s * v[:, 0] + c * v[:, 1]
        out[k, :, 2] = v[:, 2]
    return out


def frame_steps(scene: Scene, frame_rate: float) -> int:
    """Time steps per frame: the frame period in steps, at least 1 (`check_frame_rate`
    refuses a frame longer than the scene first)."""
    return max(1, int(round(min(1.0 / (frame_rate * scene.dt), scene.steps))))


def check_frame_rate(scene: Scene, frame_rate: float, given: bool = True) -> None:
    """A frame must fit in the scene: one frame at least (bad input, exit 2). ``given``: the
    user gave the rate; where it is the default, the scene's duration is what is short, and
    the message names the scene file (it blamed an option nobody gave)."""
    if frame_rate * scene.duration >= 1.0:
        return
    if not given:
        raise InputError(f"the scene's duration {scene.duration:g} s is shorter than one frame "
                         f"({1.0 / frame_rate:.3g} s at the default --frame-rate "
                         f"{frame_rate:g}); expected a duration of at least "
                         f"{1.0 / frame_rate:.3g} s, or a --frame-rate of at least "
                         f"{1.0 / scene.duration:.3g}", scene.source)
    raise InputError(f"--frame-rate {frame_rate:g} gives frames of {1.0 / frame_rate:.3g} s, "
                     f"longer than the scene's {scene.duration:g} s; expected at least "
                     f"{1.0 / scene.duration:.3g} frames per second")


def run_batch(chain: Chain, transfer: Transfer, batch: Batch, winds: np.ndarray, dt: float,
              steps: int, every: int, *, threads: int | None = None, store=None,
              keep_tips: "bool | np.ndarray" = False) -> BatchResult:
    """Step one batch through its schedule (module doc, step 3).

    winds : (n, steps, 3) m/s, each member's wind in its own frame
    store : a zarr group (`scene.store`) receiving the angles, or None
    keep_tips : keep every member's level tips (True), or those of the members where the
                (n,) bool array is True (a verified sample)
    """
    from plantlod.sim.lanes import new_state, run_lanes

    from .store import write_block

    sched = batch.schedule
    n, frames = sched.shape
    cuts = [0] + [f for f in range(1, frames) if np.any(sched[:, f] != sched[:, f - 1])] + [frames]
    states = [new_state(chain.lane_model(int(sched[i, 0])), 1)[0] for i in range(n)]
    keep = (np.full(n, bool(keep_tips)) if np.ndim(keep_tips) == 0
            else np.asarray(keep_tips, dtype=bool))
    result = BatchResult(tips=[[] for _ in range(n)] if keep.any() else [])
    for fa, fb in zip(cuts[:-1], cuts[1:]):
        s0, s1 = fa * every, min(fb * every, steps)
        if s1 <= s0:
            continue
        rows = (s1 - s0) // every
        for level in np.unique(sched[:, fa]).tolist():
            idx = np.flatnonzero(sched[:, fa] == level)
            tree = chain.trees[level]
            state = np.stack([states[i] for i in idx])
            bend, rot = run_lanes(chain.lane_model(level), winds[idx, s0:s1], dt, s1 - s0,
                                  every=every, state=state, threads=threads,
                                  addresses=tree.address)
            for j, i in enumerate(idx.tolist()):
                states[i] = state[j]
            if result.large is None and rows:
                result.large = _first_large(batch, idx, tree, bend, rot, fa, every * dt)
            result.spent += tree.n_branches * (s1 - s0) * len(idx)
            if store is not None and rows:
                block_b = np.full((n, rows, tree.n_branches), np.nan)
                block_r = np.full((n, rows, tree.n_branches), np.nan)
                block_b[idx], block_r[idx] = bend, rot
                write_block(store, batch.file_index, level, batch.first, fa, block_b, block_r)
            if keep.any() and level > 0 and rows:
                for j, i in enumerate(idx.tolist()):
                    if keep[i]:
                        result.tips[i].append((fa, level, pose(tree, bend[j], rot[j]).tip))
        if fb < frames:                                   # switches at the cut
            for i in np.flatnonzero(sched[:, fb] != sched[:, fb - 1]).tolist():
                a, b = int(sched[i, fb - 1]), int(sched[i, fb])
                now = min(fb * every, steps)
                ahead = transfer.predicted(b, winds[i, :now], dt) if b < a else None
                states[i] = (ahead if ahead is not None else
                             transfer.carry(a, b, states[i], winds[i, min(now, steps - 1)]))
                result.switches += 1
    return result


def _first_large(batch: Batch, idx: np.ndarray, tree, bend: np.ndarray, rot: np.ndarray,
                 row0: int, row_seconds: float) -> tuple | None:
    """(scene tree index, LargeAngle) of the first member of this block beyond the model's
    range, or None; rows from ``row0`` at ``row_seconds`` apart (row r ends at (r+1) x)."""
    from plantlod.sim.angle_range import first_large_angle

    times = (row0 + 1 + np.arange(bend.shape[1])) * row_seconds
    for j, i in enumerate(idx.tolist()):
        large = first_large_angle(times, bend[j], rot[j], tree.address)
        if large is not None:
            return batch.members[i], large
    return None


def make_batches(scene: Scene, chains: dict, every: int, budget: float, transfers: dict,
                 speed: float, gusts: Gusts | None = None
                 ) -> tuple[list[Batch], np.ndarray, list, np.ndarray]:
    """The batches of every source, the levels (N, F), per source (name, members, trees,
    seed), and the levels (N, F) of `schedule.coarsest_levels` (what the report's
    `speedup_bound` counts).

    Where a source's trees switch into a level from a coarser one (`schedule.finer_switches`:
    a camera coming nearer, or turning away and back), the switch error of each such level
    is measured (`switch.switch_errors`, at ``speed`` m/s in ``gusts`` where given, as the
    levels' tip errors are, with ``transfers``' `Transfer` of the source) and spent by the
    schedule (`schedule.schedules`, `schedule.held_levels`)."""
    times = frame_times(scene, every)
    levels = np.zeros((len(scene.trees), len(times)), dtype=np.int16)
    bound = np.zeros_like(levels)
    batches, files = [], []
    members_of = members_by_source(scene.trees)
    for fi, source in enumerate(sources(scene.trees)):
        members = members_of[source]
        chain: Chain = chains[source]
        def measured(into: set[int], chain=chain, transfer=transfers[source]) -> np.ndarray:
            return switch_errors(chain, transfer, into, speed, scene.dt, scene.duration, gusts)

        sched, bound[members] = schedules(scene, members, chain.tip_error_m, times, budget,
                                          measured)
        levels[members] = sched
        path, seed = source
        files.append((str(path), members, chain.trees, seed))
        for lo in range(0, len(members), STORE_BATCH_TREES):
            batches.append(Batch(str(path), fi, members[lo:lo + STORE_BATCH_TREES], lo,
                                 sched[lo:lo + STORE_BATCH_TREES], seed))
    return batches, levels, files, bound


def verify_sample(scene: Scene, levels: np.ndarray, every: int, count: int) -> np.ndarray:
    """(N,) bool: a stratified sample of about ``count`` trees to verify at full detail.

    Strata: the finest level a tree uses in the run (its levels (N, F) row) and its distance
    band (the nearest it comes to the camera, in octaves: [2^k, 2^(k+1)) m). Every stratum
    gets at least one tree, the rest go to strata in proportion to their size; within a
    stratum the trees are taken evenly spread in scene order. Deterministic.
    """
    n = len(scene.trees)
    if count >= n:
        return np.ones(n, dtype=bool)
    times = frame_times(scene, every)
    # (at both ends of each frame, as the schedule judges frames)
    nearest = distances(scene, list(range(n)), frame_bounds(scene, times))[0].min(axis=1)
    band = np.floor(np.log2(np.maximum(nearest, 1e-3))).astype(np.int64)
    finest = levels.min(axis=1).astype(np.int64)
    key = finest * 4096 + (band + 2048)
    strata, inverse = np.unique(key, return_inverse=True)
    sizes = np.bincount(inverse, minlength=len(strata))
    share = np.maximum(1, np.floor(sizes * (max(count, len(strata)) - len(strata))
                                   / n).astype(np.int64) + 1)
    share = np.minimum(share, sizes)
    chosen = np.zeros(n, dtype=bool)
    for s_ in range(len(strata)):
        members = np.flatnonzero(inverse == s_)
        pick = np.unique(np.round(np.linspace(0, len(members) - 1, share[s_])).astype(np.int64))
        chosen[members[pick]] = True
    return chosen


def run_scene(scene: Scene, *, cache=None, threads: int | None = None, verify: bool = False,
              progress=None, store_path: str | None = None, scheduler: str | None = None,
              frame_rate: float = FRAME_RATE, sample: int | None = None) -> dict:
    """Run ``scene``; the report document of docs/scene.md, and its levels (N, F) under the
    private key ``_levels`` (for the plot; the CLI removes it).

    store_path : a new zarr store (`scene.store`) to receive every tree's angles
    scheduler  : the address of a Dask scheduler: the batches run on its workers, each
                 writing its own chunks of the store (nothing gathered through this process)
    sample     : with ``verify``, verify about this many trees (`verify_sample`: every level
                 and distance band represented) instead of all
    progress   : called as progress(stage, done, total, what): stage "levels" while a tree
                 file's level chain is fitted (what: the file, done: level k of total), then
                 "batches" as batches finish
    """
    if scheduler is not None and verify:
        raise InputError("--verify runs in this process; expected it without --scheduler")
    begin = time.perf_counter()
    chains, cached = {}, 0
    steps = scene.steps
    winds = tree_winds(scene, steps)
    # levels' tip errors and switch errors are measured in the scene's wind: at the
    # strongest wind any tree sees in a steady scene, in its own gusts on its speed in a
    # gusty one (`Gusts`; steady at the strongest gust, a tree's error was 0.5-1.2x of what
    # the gusts gave)
    speed = float(np.linalg.norm(winds, axis=-1).max()) if winds.size else 0.0
    speed = round(speed, 6)
    gusts = (Gusts(scene.wind.gust_strength, scene.wind.gust_seed)
             if scene.wind.gust_strength > 0 and speed > 0 else None)
    level_speed = speed if gusts is None else round(float(scene.wind.speed), 6)
    def levels_done(k: int, n: int, name: str) -> None:
        if progress:
            progress("levels", k, n, name)

    # the tree files' chains not cached are fitted in up to CHAIN_JOBS processes at once
    # (`level_chains`): a new forest's first run waits for them
    jobs = min(CHAIN_JOBS, os.cpu_count() or 1)
    for source, chain, hit in level_chains(sources(scene.trees), level_speed, scene.dt,
                                           scene.duration, cache, scene.damping_ratio,
                                           levels_done, jobs, gusts):
        chains[source] = chain
        cached += hit
    every = frame_steps(scene, frame_rate)
    transfers = {source: Transfer(chain.trees, chain.groups, chain.damping_ratio)
                 for source, chain in chains.items()}
    batches, levels, files, bound_levels = make_batches(scene, chains, every, scene.budget_px,
                                                        transfers, level_speed, gusts)
    rows = steps // every
    store = None
    if store_path is not None:
        from .store import open_store

        # (one level column per stored row: a last frame shorter than ``every`` steps has
        # a level but no row, and `levels` had that column more than the report's frames)
        store = open_store(store_path, levels[:, :rows], files, rows, every * scene.dt)
    started = time.perf_counter()
    spent = switches = 0
    verify_s = 0.0                                    # not part of the simulation's speed
    errors = np.full(len(scene.trees), np.nan)
    checked = (verify_sample(scene, levels, every, sample) if verify and sample is not None
               else np.full(len(scene.trees), verify))
    large = None
    if scheduler is not None:
        spent, switches = _run_on_cluster(scheduler, scene, chains, batches, winds, every,
                                          store_path)
    for n, batch in enumerate(batches if scheduler is None else []):
        chain = chains[batch.source]
        result = run_batch(chain, transfers[batch.source], batch,
                           winds[batch.members], scene.dt, steps, every, threads=threads,
                           store=store, keep_tips=checked[batch.members])
        spent += result.spent
        switches += result.switches
        if result.large is not None and large is None:
            large = result.large
        if checked[batch.members].any():
            checking = time.perf_counter()
            mine = checked[batch.members]
            found = _verify(scene, chain, batch, winds, every, result.tips, threads)
            errors[np.asarray(batch.members)[mine]] = found[mine]
            verify_s += time.perf_counter() - checking
        if progress:
            progress("batches", n + 1, len(batches), "")
    simulate_s = time.perf_counter() - started - verify_s
    if large is not None:
        import warnings

        from plantlod.lsys.errors import PlantlodWarning

        k, first = large
        where = f"{scene.source}: tree {k} ({source_name(scene.trees[k].source)})"
        warnings.warn(first.message(where), PlantlodWarning, stacklevel=2)
    full = sum(chains[t.source].trees[0].n_branches for t in scene.trees) * steps
    counts = {source: np.array([t.n_branches for t in chain.trees])
              for source, chain in chains.items()}
    in_use = np.zeros(levels.shape[1])
    for k, t in enumerate(scene.trees):
        in_use += counts[t.source][levels[k]]
    # branch-steps at the coarsest levels: frame f's for the every steps after it, the last
    # frame's for what remains
    per_frame = np.diff(np.r_[np.arange(levels.shape[1]) * every, scene.steps]).clip(min=0)
    bound = float(sum((counts[t.source][bound_levels[k]] * per_frame).sum()
                      for k, t in enumerate(scene.trees)))
    top = int(levels.max()) if levels.size else 0
    report = {
        "scene": scene.source,
        "trees": len(scene.trees),
        "files": len({path for path, _seed in chains}),
        "chains": len(chains),             # one per (file, seed): a seed grows a tree of its own
        "chains_from_cache": cached,
        "budget_px": scene.budget_px,
        "level_wind_speed": level_speed,
        # the gusts the levels' tip errors were measured in (the scene's), null: steady
        "level_wind_gusts": (None if gusts is None
                             else {"strength": gusts.strength, "seed": gusts.seed}),
        "dt": scene.dt,
        "damping_ratio": scene.damping_ratio,
        "duration": scene.duration,
        "frame_rate": round(1.0 / (every * scene.dt), 9),   # the rate run: whole steps a frame
        "frames": rows,
        "camera": "keyed" if scene.camera.moving else "fixed",
        "branches_full": int(sum(chains[t.source].trees[0].n_branches for t in scene.trees)),
        "branches_spent": float(round(in_use.mean(), 3)) if in_use.size else 0.0,
        "branch_steps_full": int(full),
        "branch_steps_spent": int(spent),
        "speedup": full / spent if spent else None,        # None: nothing to simulate
        # the speed-up if every frame used the coarsest level its current distance allows,
        # switching free: what the switching rule costs is speedup_bound / speedup
        "speedup_bound": full / bound if bound else None,
        "level_share": {str(k): float(np.mean(levels == k)) for k in range(top + 1)},
        # per chain, what the choice was made from and what it chose: each level's branches,
        # its tip error (max, m, at level_wind_speed) and its share of the chain's
        # tree-frames (level_share pooled level numbers across chains of other lengths)
        "chain_levels": _chain_levels(scene, chains, levels),
        "switches": int(switches),
        "simulated_seconds_per_wall_second": scene.duration / simulate_s if simulate_s > 0 else None,
        "wall_s": time.perf_counter() - begin,
    }
    if verify:
        report["max_error_px"] = float(np.nanmax(errors)) if np.isfinite(errors).any() else 0.0
        report["mean_error_px"] = float(np.nanmean(errors)) if np.isfinite(errors).any() else 0.0
        report["verified_trees"] = int(np.isfinite(errors).sum())
        if sample is not None:
            worst = int(np.nanargmax(errors)) if np.isfinite(errors).any() else -1
            report["verify_sample"] = {
                "asked": int(sample), "trees": int(checked.sum()),
                "levels": sorted({int(v) for v in levels[checked].min(axis=1)}),
                "worst_tree": worst}
    report["_levels"] = levels
    report["_branches_in_use"] = in_use
    return report


def _chain_levels(scene: Scene, chains: dict, levels: np.ndarray) -> list[dict]:
    """The report's ``chain_levels``: for each chain (`file.sources` order) its file
    (relative to the scene's folder) and seed, its trees, and per level its branches, tip
    error (max, m) and share of the chain's tree-frames."""
    members = members_by_source(scene.trees)
    # a file as the scene names it, relative to the scene's folder (the working folder for
    # stdin): its base name alone told a/s.lsys from b/s.lsys not (a review)
    folder = os.getcwd() if scene.source == "<stdin>" else os.path.dirname(
        os.path.realpath(scene.source))
    out = []
    for source in sources(scene.trees):
        rows = members[source]
        chain, mine = chains[source], levels[rows]
        out.append({"file": os.path.relpath(source[0], folder), "seed": source[1],
                    "trees": len(rows), "levels": [
            {"level": k, "branches": int(tree.n_branches),
             "tip_error_m": float(chain.tip_error_m[k]),
             "share": float(np.mean(mine == k)) if mine.size else 0.0}
            for k, tree in enumerate(chain.trees)]})
    return out


def simulate_batch(texts: list[str], tip_error_m: list[float], source: str, batch: Batch,
                   winds: np.ndarray, dt: float, steps: int, every: int,
                   store: str | None, damping_ratio: float = 0.0) -> tuple[int, int]:
    """One batch, wherever it runs (a Dask worker): rebuild the chain from its texts (the
    original grown from the batch's seed), step the batch through its schedule, write its
    chunks of the store; returns the branch-steps spent and the switches."""
    chain = chain_from_texts(source, texts, np.asarray(tip_error_m), damping_ratio, batch.seed)
    group = None
    if store is not None:
        import zarr

        from .rooted_store import RootedStore

        # (a store removed by a signal while this task runs stays removed: `rooted_store`)
        group = zarr.open_group(RootedStore(store), mode="r+")
    result = run_batch(chain, Transfer(chain.trees, chain.groups, damping_ratio), batch, winds,
                       dt, steps,
                       every, threads=1, store=group)
    return result.spent, result.switches


# tcp only: tls needs a security context plantlod does not take, ucx and inproc transports
# it does not set up, and each failed after the work with an internal error (a cluster
# fuzzing round); a trailing '/' failed int() after the work too
SCHEDULER_ADDRESS = re.compile(r"(tcp)://([^\s/]+):([0-9]{1,5})\Z")
DOTTED_QUAD = re.compile(r"[0-9]+(?:\.[0-9]+){3}\Z")


def check_scheduler_address(address: str) -> None:
    """A Dask scheduler's address, PROTOCOL://HOST:PORT, its port in 1-65535 and a host
    written as four numbers an IPv4 address; anything else is bad input (exit 2), refused
    before any work (tcp://256.1.1.1:99999 waited 30 s for the connection to fail)."""
    import ipaddress

    match = SCHEDULER_ADDRESS.match(address)
    problem = None if match else "is not a scheduler address"
    if match and not 1 <= int(match.group(3)) <= 65535:
        problem = f"has port {int(match.group(3))}, outside 1-65535"
    elif match and DOTTED_QUAD.match(match.group(2)):
        try:
            ipaddress.IPv4Address(match.group(2))
        except ValueError:
            problem = f"has host {match.group(2)}, not an IPv4 address"
    if problem:
        raise InputError(f"--scheduler {address!r} {problem}; expected tcp://HOST:PORT (what "
                         "`dask scheduler` prints)")


def _run_on_cluster(address: str, scene: Scene, chains: dict, batches: list[Batch],
                    winds: np.ndarray, every: int, store: str | None) -> tuple[int, int]:
    """Every batch as a task of the Dask cluster at ``address`` (dask.distributed)."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler needs dask.distributed: pip install 'plantlod[cluster]'") from None
    check_scheduler_address(address)
    with _cluster_failures(address, store):
        client = Client(address, timeout=f"{CLUSTER_TIMEOUT_S}s")
        with client:
            try:                    # (no worker: it waited for ever, without a word)
                client.wait_for_workers(1, timeout=CLUSTER_TIMEOUT_S)
            except TimeoutError:
                raise RunFailure(f"the scheduler at {address} has no workers (waited "
                                 f"{CLUSTER_TIMEOUT_S:g} s); start some with `dask worker "
                                 f"{address}`") from None
            futures = []
            for batch in batches:
                chain = chains[batch.source]
                futures.append(client.submit(
                    simulate_batch, chain.texts, chain.tip_error_m.tolist(), batch.file, batch,
                    winds[batch.members], scene.dt, scene.steps, every, store,
                    scene.damping_ratio, pure=False))
            done = client.gather(futures)
    return int(sum(d[0] for d in done)), int(sum(d[1] for d in done))


@contextlib.contextmanager
def _cluster_failures(address: str, store: str | None):
    """A failure of the cluster at ``address`` as one line, exit 1 (`RunFailure`): the
    scheduler not reached, lost or not a scheduler, workers killed, a store the workers
    cannot see. Before, dask.distributed's own errors reached the command as internal errors
    and its client logged tracebacks on stderr (a cluster fuzzing round: about 30 lines where
    the scheduler was killed mid-run; "out of memory" where the port answered with other
    bytes). Signals and plantlod's own errors pass as they are."""
    import logging

    quiet = [logging.getLogger(name) for name in ("distributed", "distributed.client")]
    levels = [logger.level for logger in quiet]
    for logger in quiet:
        logger.setLevel(logging.CRITICAL)
    try:
        yield
    except (PlantlodError, KeyboardInterrupt):
        raise
    except FileNotFoundError as exc:    # a worker could not find the store's folder
        if store is None or "store" not in str(exc):
            raise RunFailure(f"the cluster at {address} failed: {_first_line(exc)}") from None
        raise RunFailure("the cluster's workers cannot see the --angles store: they write "
                         "it, so it must be on a file system they share with this machine"
                         ) from None
    except (OSError, TimeoutError) as exc:
        raise RunFailure(f"cannot reach the scheduler at {address}: "
                         f"{_first_line(exc) or type(exc).__name__}") from None
    except MemoryError:                 # (another service's bytes read as a frame length)
        raise RunFailure(f"the scheduler at {address} answered with what no Dask scheduler "
                         "sends; is it a Dask scheduler's address?") from None
    except (Exception, asyncio.CancelledError) as exc:   # noqa: BLE001 -- dask's own: a
        # task cancelled as the scheduler was lost is a CancelledError, a BaseException
        raise RunFailure(f"the cluster at {address} failed ({type(exc).__name__}: "
                         f"{_first_line(exc)}): the scheduler or its workers went away, or it is "
                         "not a Dask scheduler") from None
    finally:
        for logger, level in zip(quiet, levels):
            logger.setLevel(level)


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else ""


def _verify(scene: Scene, chain: Chain, batch: Batch, winds: np.ndarray, every: int,
            tips: list, threads) -> np.ndarray:
    """Each member's largest error in pixels over the run: its level's branch tips against
    the full tree's group tips, per frame, at that frame's distance (0 px behind the camera).
    The full trees run VERIFY_LANES at a time so that memory stays bounded."""
    from plantlod.sim.lanes import run_lanes

    out = np.zeros(len(batch.members))
    need = [i for i in range(len(batch.members)) if tips[i]]
    if not need:
        return out
    full_tree = chain.trees[0]
    model = chain.lane_model(0)
    # the distance when each row's pose is shown: its frame's end (the frame's start, before
    # session 43, left a camera jumping nearer within a frame unmeasured)
    d, ahead = distances(scene, batch.members, frame_ends(scene, frame_times(scene, every)))
    for lo in range(0, len(need), VERIFY_LANES):
        part = need[lo:lo + VERIFY_LANES]
        lanes = [batch.members[i] for i in part]
        bend, rot = run_lanes(model, winds[lanes], scene.dt, scene.steps, every=every,
                              threads=threads, addresses=full_tree.address)
        for lane, i in enumerate(part):
            full_tips = pose(full_tree, bend[lane], rot[lane]).tip          # (R, B0, 3)
            scale = scene.trees[batch.members[i]].scale
            worst = 0.0
            for row0, level, level_tips in tips[i]:
                k = level_tips.shape[0]
                gap = np.linalg.norm(level_tips - full_tips[row0:row0 + k][:, chain.tips[level]],
                                     axis=-1).max(axis=1) * scale           # (k,) m
                ppm = scene.camera.pixels_per_metre(d[i, row0:row0 + k])
                px = np.where(ahead[i, row0:row0 + k], gap * ppm, 0.0)
                worst = max(worst, float(px.max()) if k else 0.0)
            out[i] = worst
    return out


def check_scene(scene: Scene) -> None:
    """Refuse what the runner cannot do (bad input, exit 2) before it allocates anything: no
    time step, a dt too large for some tree, or more work than the declared caps
    (MAX_SCENE_TREE_STEPS, MAX_SCENE_BRANCH_STEPS)."""
    from plantlod.formats.lsys_file import read_lsys
    from plantlod.lsys.build import build
    from plantlod.sim.damping import Damping
    from plantlod.sim.stability import check_stability
    from plantlod.simplify.levels import check_moves, lies_flat, rises

    steps = scene.steps
    if steps < 1:
        raise InputError("the scene's duration is shorter than one time step", scene.source)
    tree_steps = len(scene.trees) * steps
    if tree_steps > MAX_SCENE_TREE_STEPS:
        raise InputError(f"{len(scene.trees):,} trees x {steps:,} steps is {tree_steps:,} "
                         f"tree-steps of wind, more than the limit of {MAX_SCENE_TREE_STEPS:,}; "
                         "expected fewer trees or a shorter scene", scene.source)
    import warnings

    from plantlod.lsys.errors import PlantlodWarning

    branches, systems = {}, {}
    for source in sources(scene.trees):         # (a seed grows a tree of its own)
        path, seed = source
        if path not in systems:
            systems[path] = read_lsys(str(path))
        with seed_named(source):
            built = build(systems[path].grown_from(seed))
            for message in built.warnings:      # a tree with no branches, say
                warnings.warn(f"{source_name(source, full=True)}: {message}", PlantlodWarning,
                              stacklevel=2)
            tree = built.tree
            if tree.n_branches:                 # (a tree without branches runs, and warns;
                check_moves(tree, str(path), height=False)   # one that stands still has no levels)
                if not rises(tree):             # (no height for simplify's measures: no levels)
                    warnings.warn(f"{source_name(source, full=True)}: {lies_flat(tree)}: it has "
                                  "no levels to measure, so it runs at full detail",
                                  PlantlodWarning, stacklevel=2)
            try:
                check_stability(tree, scene.dt, Damping(ratio=scene.damping_ratio))
            except InputError as exc:           # (the dt is the scene's, not the tree's)
                raise InputError(f"{exc.message} (dt {scene.dt:g} s is the scene's: "
                                 f"{scene.source})", exc.file, exc.line, exc.col) from None
        branches[source] = max(1, tree.n_branches)
    work = sum(branches[t.source] for t in scene.trees) * steps
    if work > MAX_SCENE_BRANCH_STEPS:
        raise InputError(f"the scene asks {work:,} branch-steps at full detail (trees x branches "
                         f"x steps), more than the limit of {MAX_SCENE_BRANCH_STEPS:,}; expected "
                         "fewer or smaller trees or a shorter scene", scene.source)
