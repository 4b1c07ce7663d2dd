"""The level chain of one tree file and each level's tip error, cached on disk.

For a scene, every distinct tree file (and seed it is grown from) gets its explicit-form levels (model.md 5,
`plantlod.simplify.explicit`): level 0 the original, each next one <= 60 % of the
branches, down to one branch. Each level's **tip error (max)** (model.md 6, metres)
is measured against the original in the scene's wind: its speed, steady or in the scene's
own gusts (`Gusts`), the worst over `TIP_ERROR_DIRECTIONS` (so it holds for any heading).
The level files and the errors are kept in the cache folder under a key of the tree
file's bytes, the seed where one is given, the program version and the wind (gusts
included) and time settings, so a second run of a scene simplifies nothing.

Beside each entry's JSON (the level texts, the source of truth) the levels' trees are kept
built, one `.npz` tree archive a level in an uncompressed zip (`KEY.trees.zip`,
`plantlod.formats.npz`): reading five chains' 40 levels from their texts took 0.34 s, from
the archives 0.07 s. A missing or unreadable archive is only slower: the texts are read,
and the archive written again.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import pathlib
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from plantlod.formats.lsys_file import parse_lsys_text
from plantlod.lsys.build import build
from plantlod.lsys.errors import InputError
from plantlod.lsys.parse import parse_lsys
from plantlod.lsys.tree import Tree

from .constants import CACHE_ENTRY_MAX_BYTES, CACHE_ENV, TIP_ERROR_DIRECTIONS, WORKER_CHAINS
from .file import Source, source_name


@dataclass
class Chain:
    """Levels 0 (the original) .. last of one tree file.

    trees      : one Tree per level
    texts      : the L-system text of every level (level 0: the file's), for other processes
    tip_error_m: (L,) metres, the worst tip error (max) of each level in the scene's wind
    groups     : per level, (B0,) the level branch holding each original branch
    tips       : per level, (B_l,) the original branch whose tip each level branch stands for
    damping_ratio : ζ (model.md 4) the levels were fitted and measured under, and run with
    seed       : what the original (level 0, texts[0]) is grown from; None: the file's own
    """

    trees: list[Tree]
    texts: list[str]
    tip_error_m: np.ndarray
    groups: list[np.ndarray]
    tips: list[np.ndarray]
    damping_ratio: float = 0.0
    seed: int | None = None
    _lane_models: dict = field(default_factory=dict, repr=False, compare=False)

    def lane_model(self, level: int):
        """The `sim.lanes.LaneModel` of level ``level``, built once."""
        if level not in self._lane_models:
            from plantlod.sim.lanes import LaneModel

            from plantlod.sim.damping import Damping

            self._lane_models[level] = LaneModel.from_tree(self.trees[level],
                                                           Damping(ratio=self.damping_ratio))
        return self._lane_models[level]


@dataclass(frozen=True)
class Gusts:
    """A gusty scene's gusts (`plantlod.sim.wind.GustyWind`): strength (RMS relative
    fluctuation of the speed, > 0) and seed."""

    strength: float
    seed: int


def default_cache() -> pathlib.Path:
    env = os.environ.get(CACHE_ENV)
    if env:
        return pathlib.Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return pathlib.Path(base) / "plantlod"


@functools.lru_cache(maxsize=1)
def fit_code_digest() -> bytes:
    """SHA-256 of the source of every package a chain's levels depend on (lsys, sim, compare,
    simplify), so that a chain fitted by other code is never read from the cache (an
    editable install keeps its version number while the code changes)."""
    import plantlod.compare
    import plantlod.lsys
    import plantlod.sim
    import plantlod.simplify

    h = hashlib.sha256()
    for package in (plantlod.lsys, plantlod.sim, plantlod.compare, plantlod.simplify):
        root = pathlib.Path(package.__path__[0])
        for path in sorted(root.rglob("*.py")):
            name = f"{package.__name__}/{path.relative_to(root).as_posix()}".encode()
            data = path.read_bytes()
            h.update(len(name).to_bytes(8, "little") + name + len(data).to_bytes(8, "little") + data)
    return h.digest()


def cache_key(data: bytes, speed: float, dt: float, duration: float,
              damping_ratio: float = 0.0, seed: int | None = None,
              gusts: Gusts | None = None) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        program = version("plantlod")
    except PackageNotFoundError:
        program = "0+unknown"
    h = hashlib.sha256()
    # (a seed joins the settings only where given: the keys of unseeded trees are unchanged)
    settings = (speed, dt, duration, damping_ratio) + (() if seed is None else (int(seed),))
    # (and the directions the tip errors are the worst over: a cached chain's errors are theirs)
    settings += (TIP_ERROR_DIRECTIONS,)
    # (and the gusts they were measured in, where there are any: steady keys are unchanged)
    settings += () if gusts is None else (("gusts", float(gusts.strength), int(gusts.seed)),)
    for part in (data, program.encode(), fit_code_digest(), repr(settings).encode()):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()[:32]


def level_chain(path: pathlib.Path, speed: float, dt: float, duration: float,
                cache: pathlib.Path | None, damping_ratio: float = 0.0,
                progress=None, seed: int | None = None,
                gusts: Gusts | None = None) -> tuple[Chain, bool]:
    """The chain of ``path`` grown from ``seed`` (None: its own) and whether it came from the
    cache (one per damping ratio ζ), its tip errors measured at ``speed`` m/s, in ``gusts``
    where given (`_simplify_all`).

    progress: called as progress(level k, of n levels) while levels are fitted, if given.
    """
    done = None if progress is None else (lambda k, n, _name: progress(k, n))
    (_source, chain, hit), = level_chains([(path, seed)], speed, dt, duration, cache,
                                          damping_ratio, done, gusts=gusts)
    return chain, hit


def level_chains(sources: list[Source], speed: float, dt: float,
                 duration: float, cache: pathlib.Path | None, damping_ratio: float = 0.0,
                 progress=None, jobs: int = 1, gusts: Gusts | None = None
                 ) -> Iterator[tuple[Source, Chain, bool]]:
    """(source, chain, from the cache) of every (tree file, seed) in ``sources``, in order:
    the chains not cached are fitted in ``jobs`` processes, this one and jobs - 1 workers
    (`plantlod.sim.workers.run_jobs`; each chain is a pure function of its file, seed and
    the wind, so the same chains for any ``jobs``), and stored in the cache here.

    progress: progress(level k, of n levels, name) for the chains fitted in this process;
    progress(n, n, name) when a worker's chain comes back (name: `file.source_name`)."""
    from plantlod.sim.workers import run_jobs

    paths = [p for p, _seed in sources]
    seeds = [seed for _p, seed in sources]
    data = [p.read_bytes() for p in paths]
    known = [_cached_chain(p, d, speed, dt, duration, cache, damping_ratio, s, gusts)
             for p, d, s in zip(paths, data, seeds)]
    missing = [k for k, chain in enumerate(known) if chain is None]

    def fit_here(j: int):
        k = missing[j]
        done = None if progress is None else (lambda i, n, name=source_name(sources[k]):
                                              progress(i, n, name))
        return _simplify_all(paths[k], data[k], speed, dt, duration, damping_ratio, done, seeds[k],
                             gusts)

    fitted = {}
    payload = ([paths[k] for k in missing], [data[k] for k in missing], speed, dt, duration,
               damping_ratio, [seeds[k] for k in missing], gusts)
    for j, (texts, errors) in run_jobs(0, len(missing) - 1, fit_here, jobs - 1,
                                       _worker_simplify, payload):
        k = missing[j]
        if progress is not None:
            progress(len(texts), len(texts), source_name(sources[k]))
        fitted[k] = _new_chain(paths[k], data[k], texts, errors, speed, dt, duration, cache,
                               damping_ratio, seeds[k], gusts)
    for k, source in enumerate(sources):
        yield source, known[k] or fitted[k], known[k] is not None


def _worker_simplify(payload: tuple, _ask):
    """In a worker (`sim.workers`): fit(j), the texts and tip errors of the j-th source's chain."""
    paths, data, speed, dt, duration, damping_ratio, seeds, gusts = payload

    def fit(j: int):
        return _simplify_all(paths[j], data[j], speed, dt, duration, damping_ratio, seed=seeds[j],
                             gusts=gusts)

    return fit


def _cached_chain(path: pathlib.Path, data: bytes, speed: float, dt: float, duration: float,
                  cache: pathlib.Path | None, damping_ratio: float,
                  seed: int | None = None, gusts: Gusts | None = None) -> Chain | None:
    """The chain of ``path`` (its bytes ``data``) grown from ``seed``, from the cache; None
    where it is not there."""
    if cache is None:
        return None
    entry = cache / f"{cache_key(data, speed, dt, duration, damping_ratio, seed, gusts)}.json"
    stored = _stored_entry(entry)
    if stored is None:
        return None
    texts, errors = stored
    built = _read_built(entry.with_suffix(".trees.zip"), texts)
    try:
        chain = _chain(path, data, texts, errors, damping_ratio, built, seed)
    except InputError:                    # a level damaged in the cache: fitted again (an
        return None                       # error of the original's own is raised by the fit)
    if built is None:
        _write_built(entry.with_suffix(".trees.zip"), chain.trees[1:], texts)
    return chain


def _stored_entry(entry: pathlib.Path) -> tuple[list[str], np.ndarray] | None:
    """The level texts and (levels + 1,) tip errors (max, m; level 0's first) that
    `_new_chain` stored at ``entry``; None where there is no entry or it is not one whole
    (a damaged cache is a miss: the chain is fitted again and the entry written anew)."""
    from plantlod.formats.text_input import read_text

    if not entry.is_file():               # (a FIFO or a device in its place: never opened)
        return None
    try:
        # (one line: json.dumps writes the whole entry on it)
        stored = json.loads(read_text(str(entry), max_line_bytes=CACHE_ENTRY_MAX_BYTES,
                                      max_bytes=CACHE_ENTRY_MAX_BYTES))
    except (InputError, ValueError, RecursionError):
        return None
    if not isinstance(stored, dict):
        return None
    texts, errors = stored.get("levels"), stored.get("tip_error_m")
    if not (isinstance(texts, list) and isinstance(errors, list)
            and len(errors) == len(texts) + 1
            and all(isinstance(t, str) for t in texts)
            and all(type(e) in (int, float) for e in errors)):
        return None
    try:
        errors = np.array(errors, dtype=np.float64)
    except OverflowError:                 # an integer past a double's range
        return None
    if errors[0] != 0 or not np.all(np.isfinite(errors)) or np.any(errors < 0):
        return None                       # (level 0, the original, misses by nothing)
    return texts, errors


def _new_chain(path: pathlib.Path, data: bytes, texts: list[str], errors, speed: float,
               dt: float, duration: float, cache: pathlib.Path | None,
               damping_ratio: float, seed: int | None = None, gusts: Gusts | None = None) -> Chain:
    """The chain of fitted ``texts`` and tip ``errors``, stored in the cache where there is one."""
    chain = _chain(path, data, texts, np.asarray(errors), damping_ratio, seed=seed)
    if cache is not None:
        entry = cache / f"{cache_key(data, speed, dt, duration, damping_ratio, seed, gusts)}.json"
        entry.parent.mkdir(parents=True, exist_ok=True)
        _store(entry, json.dumps({"file": str(path), "seed": seed, "levels": texts,
                                  "tip_error_m": [float(e) for e in errors]}).encode("utf-8"))
        _write_built(entry.with_suffix(".trees.zip"), chain.trees[1:], texts)
    return chain


def _store(path: pathlib.Path, data: bytes) -> None:
    """``data`` at ``path``, written whole or not at all: through a temporary beside it that
    a signal handler removes (`formats.atomic.atomic_path`)."""
    from plantlod.formats.atomic import atomic_path, write_whole

    if path.is_dir() and not path.is_symlink():
        return                            # a folder where the entry goes: left, not cached
    if path.is_symlink() or (path.exists() and not path.is_file()):
        path.unlink()                     # a FIFO or a device in the cache: replaced, not written
    with atomic_path(str(path)) as tmp:
        write_whole(tmp, data)


def _archive_digest(texts: list[str], members: list[bytes]) -> bytes:
    """SHA-256 of the level texts and of the archive's members, in order: the comment of the
    archive built from them. An archive is read only beside the texts it was built from (a
    text changed in KEY.json is read) and as it was written (members swapped by hand ran a
    4-branch level as level 3, session 30)."""
    h = hashlib.sha256("\0".join(texts).encode("utf-8"))
    for data in members:
        h.update(len(data).to_bytes(8, "little") + data)
    return h.hexdigest().encode("ascii")


def _write_built(path: pathlib.Path, trees: list[Tree], texts: list[str]) -> None:
    """The levels' trees as one `.npz` archive each (`formats.npz.tree_bytes`) in an
    uncompressed zip (`_store`; a cache: a failure to write is ignored), marked with the
    digest of the ``texts`` they were built from."""
    import io
    import zipfile

    from plantlod.formats.npz import tree_bytes

    members = [tree_bytes(tree) for tree in trees]
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as archive:
        archive.comment = _archive_digest(texts, members)
        for k, data in enumerate(members, start=1):
            archive.writestr(f"level{k}.npz", data)
    try:
        _store(path, out.getvalue())
    except OSError:
        pass


def _read_built(path: pathlib.Path, texts: list[str]) -> list[Tree] | None:
    """The level trees `_write_built` kept at ``path`` from ``texts``, every one checked as a
    tree archive is (`formats.npz.read_tree_bytes`); None where the file is missing,
    unreadable, built from other texts or holds anything else."""
    import zipfile

    from plantlod.formats.npz import DAMAGED_ARCHIVE_ERRORS, read_tree_bytes

    if not path.is_file():
        return None
    try:
        count = len(texts)
        with zipfile.ZipFile(path) as archive:
            if archive.namelist() != [f"level{k}.npz" for k in range(1, count + 1)]:
                return None
            members = [archive.read(f"level{k}.npz") for k in range(1, count + 1)]
            if archive.comment != _archive_digest(texts, members):
                return None
            return [read_tree_bytes(data, str(path)) for data in members]
    except (InputError, *DAMAGED_ARCHIVE_ERRORS):
        return None


def chain_from_texts(source: str, texts: list[str], tip_error_m: np.ndarray,
                     damping_ratio: float = 0.0, seed: int | None = None) -> Chain:
    """A chain rebuilt from its level texts (level 0 the original's), as a worker does: once
    per process and chain (`_remembered_chain`). A worker runs many batches of one file, and
    reading the chain (0.1 s for a forest's tree) took longer than simulating a batch of it
    (about 0.07 s for examples/forest.toml's 18 batches). Callers only read the chain."""
    return _remembered_chain(source, tuple(texts), tuple(float(e) for e in tip_error_m),
                             float(damping_ratio), seed)


@functools.lru_cache(maxsize=WORKER_CHAINS)
def _remembered_chain(source: str, texts: tuple[str, ...], tip_error_m: tuple[float, ...],
                      damping_ratio: float, seed: int | None) -> Chain:
    return _chain(pathlib.Path(source), texts[0].encode("utf-8"), list(texts[1:]),
                  np.asarray(tip_error_m), damping_ratio, seed=seed)


def _chain(path, data: bytes, texts: list[str], errors: np.ndarray,
           damping_ratio: float = 0.0, built: list[Tree] | None = None,
           seed: int | None = None) -> Chain:
    """The chain of the original ``data`` (grown from ``seed``) and its level ``texts``;
    ``built``: the levels' trees where the cache kept them (`_read_built`), else each text
    is read and built."""
    from plantlod.compare.groups import assign_groups, main_paths

    original = build(parse_lsys_text(data.decode("utf-8-sig"), str(path)).grown_from(seed)).tree
    trees, groups, tips = [original], [np.arange(original.n_branches)], [np.arange(original.n_branches)]
    for k, text in enumerate(texts, start=1):
        tree = (built[k - 1] if built is not None
                else build(parse_lsys(text, f"{path.name} level {k}")).tree)
        g = assign_groups(original, tree)
        trees.append(tree)
        groups.append(g)
        tips.append(np.array([p[-1] for p in main_paths(original, g, tree.n_branches)], dtype=np.int64))
    return Chain(trees, [data.decode("utf-8-sig")] + list(texts), errors, groups, tips,
                 damping_ratio, seed)


def _simplify_all(path, data: bytes, speed: float, dt: float, duration: float,
                  damping_ratio: float = 0.0, progress=None, seed: int | None = None,
                  gusts: Gusts | None = None):
    """Every explicit level's text and tip error (max, m) in the scene's wind, of the file's
    tree grown from ``seed``; the original is simulated once for the whole chain (its runs
    serve every level's measure). The wind: ``speed`` m/s toward each of
    TIP_ERROR_DIRECTIONS, steady, or with ``gusts`` the scene's own gusts on it, from rest
    for the scene's duration (every tree of a gusty scene sees that series from the moment
    its wind arrives, a front only delaying it)."""
    from plantlod.sim.damping import Damping
    from plantlod.simplify.targets import group_map
    from plantlod.simplify.evaluate import Runs, WindCase, simulate_runs
    from plantlod.simplify.explicit import explicit_system_text, level_header, merge_levels
    from plantlod.simplify.motion_fit import measurement_runs_for
    from plantlod.simplify.regroup import regrouped

    from plantlod.simplify.levels import rises

    system = parse_lsys_text(data.decode("utf-8-sig"), str(path)).grown_from(seed)
    original = build(system).tree
    if not rises(original):      # no height to measure levels against: full detail only
        return [], np.zeros(1)
    header = level_header(system)
    levels = merge_levels(original)
    winds = [WindCase(speed, d) if gusts is None else WindCase(speed, d, gusts.strength, gusts.seed)
             for d in TIP_ERROR_DIRECTIONS]
    steps = int(round(duration / dt))
    texts, errors = [], [0.0]
    damping = Damping(ratio=damping_ratio)
    simulated = list(simulate_runs(original, winds, dt, steps, 1, damping))
    # the motion fit's runs of the original (simplify's winds), also once for the chain
    runs_for = measurement_runs_for(original, dt, duration, damping_ratio)

    def fit(k: int, groups) -> tuple[str, object]:
        return explicit_system_text(original, groups, name=system.name or path.stem,
                                    header=header, level=k, dt=dt, duration=duration,
                                    damping_ratio=damping_ratio, runs_for=runs_for)

    # level 1's groups chosen by its fitted level, as `simplify --levels` chooses them
    levels, level_one = regrouped(original, levels, lambda groups: fit(1, groups), runs_for)
    for k in range(1, len(levels)):
        if progress is not None:
            progress(k, len(levels) - 1)
        text, tree = level_one if k == 1 and level_one is not None else fit(k, levels[k])
        runs = Runs(original, group_map(original, tree), winds, dt, steps, every=1,
                    damping=damping, simulated=simulated)
        worst = max(r.tip_error_max_m for r in runs.compare(tree))
        texts.append(text)
        errors.append(float(worst) if np.isfinite(worst) else float("inf"))
    # a coarser level never claims less error than a finer one: the budget picks the
    # coarsest level within it, so the errors are made non-decreasing along the chain
    return texts, np.maximum.accumulate(np.asarray(errors))
