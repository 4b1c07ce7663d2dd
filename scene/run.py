"""Run a scene (model.md 7): every tree at the coarsest level its distance allows.

1. Levels: the chain of every distinct tree file, with each level's tip error (max),
   from the cache or simplified now (`scene.levels`).
2. Selection: a tree at distance d from a fixed camera shows a level's error e
   (metres, times the tree's scale) as p = e H / (2 d tan(fov / 2)) pixels; it runs at
   the coarsest level with p <= the budget. A tree behind the camera runs at the
   coarsest level; a tree at distance 0 at full detail.
3. Engine: trees of one file and level step together as lanes of one `run_lanes`
   call on all cores, each with its own wind: the scene's wind turned into the tree's
   frame (its heading), with gusts, and delayed by the time a front travelling at
   `front_speed` takes to reach it along the wind.
4. With ``verify``, every tree also runs at full detail, and the largest distance between
   each group tip and its level branch's tip, per frame, is turned into pixels by the
   same formula: the error actually spent.
"""

from __future__ import annotations

import math
import pathlib
import time
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.sim.kinematics import pose

from .constants import FRAME_RATE, VERIFY_LANES
from .file import Scene
from .levels import Chain, level_chain


@dataclass
class TreeRun:
    """What one tree did: its chosen level, distance (m), and verified error (px, NaN if not verified)."""

    level: int
    distance: float
    error_px: float = math.nan


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


def choose_levels(scene: Scene, chains: dict, budget: float) -> list[TreeRun]:
    """The coarsest level within the pixel budget for every tree (module doc, step 2)."""
    cam = scene.camera
    view = cam.target - cam.position
    runs = []
    for tree in scene.trees:
        chain: Chain = chains[tree.file]
        offset = np.asarray(tree.position) - cam.position
        d = float(np.linalg.norm(offset))
        last = len(chain.trees) - 1
        if d == 0.0:
            runs.append(TreeRun(0, d))
            continue
        if float(np.dot(offset, view)) <= 0.0:           # behind the camera: nothing shows
            runs.append(TreeRun(last, d))
            continue
        px = chain.tip_error_m * tree.scale * float(cam.pixels_per_metre(d))
        ok = np.flatnonzero(px <= budget)
        runs.append(TreeRun(int(ok.max()) if ok.size else 0, d))
    return runs


def run_scene(scene: Scene, *, cache=None, threads: int | None = None, verify: bool = False,
              progress=None, angles=None, scheduler: str | None = None) -> dict:
    """Run ``scene``; the report document of docs/scene.md.

    angles    : an open zarr group (`scene.store`) that receives every batch's angles
    scheduler : the address of a Dask scheduler: the batches run on its workers, each
                writing its own groups of the store (nothing gathered through this process)
    """
    if scheduler is not None and verify:
        raise InputError("--verify runs in this process; expected it without --scheduler")
    from plantlod.sim.lanes import LaneModel, run_lanes

    begin = time.perf_counter()
    chains, cached = {}, 0
    steps = scene.steps
    winds = tree_winds(scene, steps)
    # levels are measured at the strongest wind any tree sees (gusts included), so that a
    # gust does not carry a far tree past its budget
    speed = float(np.linalg.norm(winds, axis=-1).max()) if winds.size else 0.0
    speed = round(speed, 6)
    for path in sorted({t.file for t in scene.trees}):
        chain, hit = level_chain(path, speed, scene.dt, scene.duration, cache)
        chains[path] = chain
        cached += hit
    runs = choose_levels(scene, chains, scene.budget_px)
    every = max(1, int(round(1.0 / (FRAME_RATE * scene.dt))))
    frames = steps // every
    batches: dict[tuple, list[int]] = {}
    for k, (tree, run) in enumerate(zip(scene.trees, runs)):
        batches.setdefault((str(tree.file), run.level), []).append(k)
    spent = full = 0
    started = time.perf_counter()
    level_tips: dict[int, np.ndarray] = {}            # tree -> (frames, B_level, 3), with verify
    ordered = sorted(batches.items())
    if scheduler is not None:
        spent = _run_on_cluster(scheduler, scene, chains, ordered, winds, every, angles)
    for n, ((file, level), members) in enumerate(ordered if scheduler is None else []):
        chain = chains[pathlib.Path(file)]
        tree = chain.trees[level]
        bend, rot = run_lanes(LaneModel.from_tree(tree), winds[members], scene.dt, steps,
                              every=every, threads=threads, addresses=tree.address)
        spent += tree.n_branches * steps * len(members)
        if angles is not None:
            from .store import write_batch

            write_batch(angles, n, file, level, members, tree, bend, rot, every * scene.dt)
        if verify:
            for lane, k in enumerate(members):
                level_tips[k] = pose(tree, bend[lane], rot[lane]).tip
        if progress:
            progress(n + 1, len(batches))
    for tree in scene.trees:
        full += chains[tree.file].trees[0].n_branches * steps
    simulate_s = time.perf_counter() - started
    if verify:
        _verify(scene, chains, runs, winds, every, level_tips, threads)
    levels = np.array([r.level for r in runs])
    top = int(levels.max())
    errors = np.array([r.error_px for r in runs])
    report = {
        "scene": scene.source,
        "trees": len(scene.trees),
        "files": len(chains),
        "chains_from_cache": cached,
        "budget_px": scene.budget_px,
        "level_wind_speed": speed,
        "dt": scene.dt,
        "duration": scene.duration,
        "frames": frames,
        "branches_full": int(sum(chains[t.file].trees[0].n_branches for t in scene.trees)),
        "branches_spent": int(sum(chains[t.file].trees[r.level].n_branches
                                  for t, r in zip(scene.trees, runs))),
        "branch_steps_full": int(full),
        "branch_steps_spent": int(spent),
        "speedup": full / spent if spent else math.inf,
        "level_share": {str(k): float(np.mean(levels == k)) for k in range(top + 1)},
        "simulated_seconds_per_wall_second": scene.duration / simulate_s if simulate_s > 0 else None,
        "wall_s": time.perf_counter() - begin,
    }
    report["_levels"] = levels.tolist()                 # for the caller's store; not reported
    if verify:
        report["max_error_px"] = float(np.nanmax(errors)) if np.isfinite(errors).any() else 0.0
        report["mean_error_px"] = float(np.nanmean(errors)) if np.isfinite(errors).any() else 0.0
    return report


def simulate_batch(text: str, source: str, winds: np.ndarray, dt: float, steps: int, every: int,
                   store: str | None, index: int, file: str, level: int, members: list[int]) -> int:
    """One batch, wherever it runs (a Dask worker): build the level's tree from its text,
    step its lanes, write its group of the store; returns the branch-steps spent."""
    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys
    from plantlod.sim.lanes import LaneModel, run_lanes

    tree = build(parse_lsys(text, source)).tree
    bend, rot = run_lanes(LaneModel.from_tree(tree), winds, dt, steps, every=every,
                          addresses=tree.address)
    if store is not None:
        import zarr

        from .store import write_batch

        write_batch(zarr.open_group(store, mode="r+"), index, file, level, members, tree, bend,
                    rot, every * dt)
    return tree.n_branches * steps * len(members)


def _run_on_cluster(address: str, scene: Scene, chains: dict, ordered, winds: np.ndarray,
                    every: int, angles) -> int:
    """Every batch as a task of the Dask cluster at ``address`` (dask.distributed)."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler needs dask.distributed: pip install 'plantlod[cluster]'") from None
    store = None if angles is None else str(angles.store.root)
    with Client(address, timeout="30s") as client:
        futures = []
        for n, ((file, level), members) in enumerate(ordered):
            chain = chains[pathlib.Path(file)]
            futures.append(client.submit(
                simulate_batch, chain.texts[level], f"{pathlib.Path(file).name} level {level}",
                winds[members], scene.dt, scene.steps, every, store, n, file, level, members,
                pure=False))
        return int(sum(client.gather(futures)))


def _verify(scene: Scene, chains: dict, runs: list[TreeRun], winds: np.ndarray, every: int,
            level_tips: dict, threads) -> None:
    """Each tree's error in pixels: its level's branch tips against the full tree's group tips,
    the full trees run a few lanes at a time (VERIFY_LANES) so memory stays bounded."""
    from plantlod.sim.lanes import LaneModel, run_lanes

    cam = scene.camera
    by_file: dict[str, list[int]] = {}
    for k, (tree, run) in enumerate(zip(scene.trees, runs)):
        if run.level == 0:
            run.error_px = 0.0
        else:
            by_file.setdefault(str(tree.file), []).append(k)
    for file, members in sorted(by_file.items()):
        chain = chains[pathlib.Path(file)]
        model = LaneModel.from_tree(chain.trees[0])
        for lo in range(0, len(members), VERIFY_LANES):
            part = members[lo:lo + VERIFY_LANES]
            bend, rot = run_lanes(model, winds[part], scene.dt, scene.steps, every=every,
                                  threads=threads, addresses=chain.trees[0].address)
            for lane, k in enumerate(part):
                tree, run = scene.trees[k], runs[k]
                tips_full = pose(chain.trees[0], bend[lane], rot[lane]).tip[:, chain.tips[run.level]]
                worst_m = float(np.linalg.norm(level_tips[k] - tips_full, axis=-1).max()) * tree.scale
                ahead = float(np.dot(np.asarray(tree.position) - cam.position,
                                     cam.target - cam.position)) > 0
                run.error_px = worst_m * float(cam.pixels_per_metre(run.distance)) if ahead else 0.0


def check_scene(scene: Scene) -> None:
    """Refuse what the runner cannot do (bad input, exit 2): no time step, or a dt too large
    for some tree."""
    from plantlod.formats.lsys_file import read_lsys
    from plantlod.lsys.build import build
    from plantlod.sim.stability import check_stability

    if scene.steps < 1:
        raise InputError("the scene's duration is shorter than one time step", scene.source)
    for path in sorted({t.file for t in scene.trees}):
        check_stability(build(read_lsys(str(path))).tree, scene.dt)
