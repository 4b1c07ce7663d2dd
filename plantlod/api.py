"""The public API: what the commands do, as functions (docs/api.md).

    system = plantlod.read_lsystem("examples/stalk8.lsys")    # LSystem
    tree = plantlod.derive(system)                            # Tree
    angles = plantlod.simulate(tree, wind=(2, 0, 0), dt=0.01, steps=400)
    level = plantlod.simplify(system, level=1)                # LSystem
    report = plantlod.compare(system, level, wind=(5, 0, 0), dt=0.01, duration=20)

Each CLI command is this plus option parsing, messages and files, so the same
input gives the same bytes either way (tests/test_api.py). Angles are radians,
lengths metres, times seconds, winds metres per second (model.md).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import os
from dataclasses import dataclass, replace
from typing import IO, Any, Union

import numpy as np

from plantlod.formats.kinds import OUTPUT_KINDS
from plantlod.lsys.checks import finite, shown_value
from plantlod.lsys.errors import InputError, RunFailure, warn_caller
from plantlod.lsys.system import LSystem
from plantlod.lsys.tree import Tree

from .arguments import (angle_ndim, binary_stream, flag, label, one_run, output_target, path_of,
                        real, whole)

PathOrText = Union[str, "os.PathLike[str]"]
PathOrFile = Union[str, "os.PathLike[str]", IO[str]]


@dataclass(frozen=True)
class Angles:
    """Sampled angles of a run, rows at t = 0, every*dt, 2*every*dt, ...

    time      : (T,) seconds; row 0 is t = 0 (every angle 0, model.md 4)
    bend      : (T, B) radians, or (W, T, B) for a list of W winds
    rotation  : the same shape as ``bend``
    addresses : (B,) the branches' derivation addresses, in tree order
    """

    time: np.ndarray
    bend: np.ndarray
    rotation: np.ndarray
    addresses: tuple[str, ...]

    def __getitem__(self, lane: int | slice) -> "Angles":
        """One run of a result for a list of winds: ``angles[w]`` has bend (T, B); a slice,
        ``angles[a:b]``, keeps those runs as a result for a list of winds, (W', T, B)."""
        if angle_ndim(self.bend) != 3:
            raise InputError("these angles are one run; angles[w] selects a run of "
                             "simulate(tree, wind=[...]) (a list of winds)")
        lanes = np.shape(self.bend)[0]
        if isinstance(lane, slice):
            return Angles(self.time, self.bend[lane], self.rotation[lane], self.addresses)
        if not isinstance(lane, (int, np.integer)) or isinstance(lane, bool):
            # (as a list says it: a run is chosen by a whole number or a slice)
            raise TypeError(f"runs are chosen by a whole number or a slice, got {lane!r}")
        if not -lanes <= lane < lanes:
            raise IndexError(f"run {lane!r} of {lanes}; expected 0..{lanes - 1}")
        return Angles(self.time, self.bend[lane], self.rotation[lane], self.addresses)

    def __len__(self) -> int:
        """The number of runs (winds) of a result for a list of winds."""
        if angle_ndim(self.bend) != 3:
            raise TypeError("these angles are one run; len() counts the runs of a list of winds")
        return int(np.shape(self.bend)[0])

    def __iter__(self):
        """The runs of a result for a list of winds, in wind order."""
        return (self[w] for w in range(len(self)))


# --- L-systems and trees -----------------------------------------------------------------

def read_lsystem(path_or_text: PathOrText, *, name: str | None = None) -> LSystem:
    """Parse an L-system from a file path or from its text (docs/lsys-format.md).

    A string with a line break (LF or CR) is the text itself (an L-system has several lines); any
    other string, or a path object, names a file (a missing one is an `InputError`
    "no such file"); an open text stream is read. ``name`` names a text or a stream in
    messages. Raises `plantlod.InputError` (file:line:col) on bad input, and names a file of
    another kind by what it is (an angle CSV, a tree file).
    """
    from plantlod.formats.lsys_file import parse_lsys_text

    name = label("name", name)
    if isinstance(path_or_text, os.PathLike) or (
            isinstance(path_or_text, str) and not _is_text(path_or_text)):
        from plantlod.formats.lsys_file import read_lsys
        return read_lsys(path_of(path_or_text))
    if hasattr(path_or_text, "read"):
        stream, stream_name = _text_stream(path_or_text)
        return parse_lsys_text(_read_text(stream, name or stream_name).lstrip("\ufeff"),
                               name or stream_name)
    if not isinstance(path_or_text, str):
        raise InputError(f"expected a path, an open text stream or the text of an L-system, got "
                         f"{type(path_or_text).__name__}")
    # (a leading byte-order mark is dropped, as the file reader drops it)
    return parse_lsys_text(path_or_text.lstrip("\ufeff"), name or "<text>")


def write_lsystem(system: LSystem, path_or_file: PathOrFile | None = None) -> str:
    """The canonical text of ``system`` (with its header comment); written when a target is given."""
    from plantlod.formats.lsys_file import write_lsys

    if not isinstance(system, LSystem):
        raise InputError(f"write_lsystem takes an LSystem, got {type(system).__name__}")
    _checked_system(system)
    output_target(path_or_file, kind=OUTPUT_KINDS["lsystem"])
    text = write_lsys(system, system.comment or None)
    _write_text(text, path_or_file)
    return text


def derive(system: LSystem | PathOrText, n: int | None = None, *,
           max_modules: int | None = None) -> Tree:
    """Derive ``system`` (an `LSystem` or the path of an .lsys file) ``n`` steps (default:
    its derivation length) and run the turtle.

    Returns the `Tree` (plantlod.lsys.tree: per-branch arrays of shape (B,),
    per-leaf arrays (F,), rest rotations as ZYZ angles (B, 3)).
    """
    from plantlod.lsys.build import build
    from plantlod.lsys.constants import DEFAULT_MAX_MODULES, MAX_DERIVATION_STEPS

    system = _as_system(system)
    if n is not None:
        n = whole("n", n, high=MAX_DERIVATION_STEPS)
    if max_modules is not None:
        max_modules = whole("max_modules", max_modules, low=1)
    built = build(system, n, max_modules=max_modules or DEFAULT_MAX_MODULES)
    for message in built.warnings:
        warn_caller(message)
    return built.tree


def read_tree(path_or_file: PathOrFile) -> Tree:
    """Read a tree file (JSON Lines, docs/tree-format.md) from a path, an open text stream or
    its text; a path ending in .npz is a tree archive (`plantlod derive -o T.npz`)."""
    from plantlod.formats.npz import read_npz_file, read_tree_bytes
    from plantlod.formats.treefile import read_tree_text

    archive = _npz_path(path_or_file)
    if archive is not None:             # (messages about its values name the file read:
        return replace(read_tree_bytes(read_npz_file(archive), archive),    # `Tree.where`)
                       read_from=archive)
    stream, name = _text_stream(path_or_file)
    return replace(read_tree_text(_read_text(stream, name), name), read_from=name)


def write_tree(tree: Tree, path_or_file: PathOrFile | None = None) -> str:
    """The tree file text of ``tree``; written when a target is given."""
    from plantlod.formats.treefile import write_tree as _write

    if not isinstance(tree, Tree):
        raise InputError(f"write_tree takes a Tree, got {type(tree).__name__}")
    _checked(tree)
    output_target(path_or_file, kind=OUTPUT_KINDS["tree"])
    buf = io.StringIO()
    _write(tree, buf)
    if _is_npz_path(path_or_file):             # the archive `plantlod derive -o X.npz` writes
        from plantlod.formats.npz import tree_bytes

        _write_bytes(tree_bytes(tree), path_or_file)
    else:
        _write_text(buf.getvalue(), path_or_file)
    return buf.getvalue()


# --- simulation --------------------------------------------------------------------------

def simulate(tree: Tree | LSystem | PathOrText, wind: Any = None, dt: float = 0.01,
             steps: int | None = None, *, duration: float | None = None, every: int = 1,
             damping: float = 0.0, threads: int | None = None,
             wind_speed: float | None = None, wind_direction: float | None = None,
             damping_ratio: float | None = None, gust_strength: float = 0.0,
             gust_seed: int | None = None) -> Angles:
    """Simulate ``tree`` in ``wind`` (model.md 3-4); an `LSystem` is derived first, a path
    is read (an .lsys file, a tree file or a tree .npz).

    wind     : (vx, vy, vz) m/s (a tuple, a list of three numbers or an array (3,)), a
               wind object of plantlod.sim.wind (anything with ``sample(times) ->
               (K, 3)``), or several: a list or tuple of those, or an array (W, 3). Then
               bend and rot get a leading lane axis (W, T, B) (time stays (T,)) and the
               runs step together on all cores (plantlod.sim.lanes; each lane equals its
               single run bit for bit); ``angles[w]`` is then run w. None: no wind (or
               ``wind_speed``).
    wind_speed, wind_direction : instead of ``wind``, as the CLI's --wind-speed and
               --wind-direction: a horizontal wind of this many m/s toward this azimuth
               (degrees, 0 = +x, 90 = +y; default 0)
    gust_strength, gust_seed : as the CLI's --gust-strength and --gust-seed: each wind
               scaled by seeded gusts of this RMS relative strength
               (`plantlod.sim.wind.GustyWind`; seed default 0)
    steps    : time steps, or ``duration`` seconds (rounded to whole steps)
    every    : keep every ``every``-th step (row 0 is t = 0)
    threads  : engine threads for a list of winds (default: all cores or $PLANTLOD_THREADS)
    damping  : the velocity damping c per step, or ``damping_ratio`` ζ (each branch damped
               by its own period, model.md 4); not both
    Raises `InputError` for an unstable dt (model.md 4) and `RunFailure` when a run diverges.
    """
    damping = _damping(damping, damping_ratio)
    if threads is not None:
        threads = whole("threads", threads, low=1)
    given = _given_tree(tree)
    tree = given.tree
    wind = _wind_option(wind, wind_speed, wind_direction)
    steps = _step_count(dt, steps, duration)
    given.warn_fitted_otherwise(float(dt), damping)
    every = whole("every", every, low=1, high=max(steps, 1))
    winds, many = _winds(wind)
    winds = _gusty(winds, gust_strength, gust_seed)
    return _simulated(tree, winds, many, float(dt), steps, every, damping, threads)


def _simulated(tree: Tree, winds: list, many: bool, dt: float, steps: int, every: int, damping,
               threads: int | None) -> Angles:
    """`simulate`'s run, its options checked (winds: wind objects; many: a lane axis)."""
    from plantlod.sim.stability import check_stability

    check_stability(tree, dt, damping)
    time, bend, rot = _run_winds(tree, winds, dt, steps, every, damping, threads)
    _warn_large_angles(tree, time, bend, rot, many)
    if not many:
        bend, rot = bend[0], rot[0]
    return Angles(time, bend, rot, tuple(tree.address))


def _warn_large_angles(tree: Tree, time, bend, rot, many: bool) -> None:
    """A `PlantlodWarning` for the first run (lane) whose angles leave the small-angle model."""
    from plantlod.sim.angle_range import first_large_angle

    for lane in range(len(bend)):
        large = first_large_angle(time, bend[lane], rot[lane], tree.address)
        if large is not None:
            what = (tree.where or "tree") + (f", wind {lane}" if many else "")
            warn_caller(large.message(what))
            return


def _run_winds(tree: Tree, winds: list, dt: float, steps: int, every: int, damping,
               threads: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All winds in one pass of the lanes engine: times (T,), bend and rot (W, T, B).
    One wind runs on the single-run kernel (the same values, without lanes' padding)."""
    from plantlod.sim.constants import SIM_CHUNK_VALUES
    from plantlod.sim.lanes import LaneModel, new_state, run_lanes

    if len(winds) == 1:
        from plantlod.sim.run import simulate_arrays

        s = simulate_arrays(tree, dt, steps, winds[0], every=every, damping=damping)
        return s.times, s.bend[None], s.rot[None]

    from plantlod.sim.run import check_held_angles
    from plantlod.sim.wind import wind_samples

    # (before the winds' samples and the lanes' state: 20,000 winds were refused after 46 s)
    check_held_angles(steps // every, tree.n_branches, len(winds))
    model = LaneModel.from_tree(tree, damping)
    names = [f"wind {k + 1} of {len(winds)}" for k in range(len(winds))]
    state = None
    rows = steps // every
    bend = np.zeros((len(winds), rows + 1, tree.n_branches))    # row 0: the rest pose
    rot = np.zeros_like(bend)
    # the winds sampled a piece of steps at a time (about SIM_CHUNK_VALUES values), the lanes'
    # state carried between pieces: a long run's samples, (W, steps, 3), were all made first
    # (37 winds of 10^7 steps: 8 GiB for 1,001 rows kept)
    piece = max(every, SIM_CHUNK_VALUES // (3 * len(winds)) // every * every)
    for first in range(1, steps + 1, piece):
        count = min(piece, steps - first + 1)
        ks = np.arange(first - 1, first - 1 + count, dtype=np.float64)   # step k: V(t_{k-1})
        samples = np.stack([wind_samples(w, ks * dt) for w in winds])
        if state is None:
            state = new_state(model, len(winds))
        b, r = run_lanes(model, samples, dt, count, every=every, state=state, threads=threads,
                         first_step=first, addresses=tree.address, lane_names=names)
        at = (first - 1) // every + 1
        bend[:, at:at + b.shape[1]] = b
        rot[:, at:at + r.shape[1]] = r
    time = np.arange(rows + 1, dtype=np.float64) * every * dt
    return time, bend, rot


def read_angles(path_or_file: PathOrFile, *, degrees: bool = False) -> Angles:
    """Read an angle CSV (docs/angles-csv.md) from a path, an open text stream or its text;
    ``degrees`` says the file holds degrees. A path ending in .npz is an angle archive
    (`plantlod simulate -o A.npz`, radians)."""
    from plantlod.formats.angles_csv import read_angles_file, read_angles_text

    degrees = flag("degrees", degrees)
    archive = _npz_path(path_or_file)
    if archive is not None and degrees:        # (the reader's message named the CLI's --degrees)
        raise InputError("degrees=True applies to an angle CSV; an .npz archive holds radians",
                         archive)
    if archive is not None:
        time, addresses, bend, rot = read_angles_file(archive, degrees)
    else:
        stream, name = _text_stream(path_or_file)
        time, addresses, bend, rot = read_angles_text(_read_text(stream, name), name, degrees)
    return Angles(time, bend, rot, tuple(addresses))


def _npz_path(path_or_file: Any) -> str | None:
    """The path of an .npz archive that ``path_or_file`` names, None for anything else (a
    stream, a text, another file)."""
    from plantlod.formats.npz import is_npz

    if isinstance(path_or_file, (str, os.PathLike)) and not _is_text(path_or_file):
        path = path_of(path_or_file)
        return path if is_npz(path) else None
    return None


def write_angles(angles: Angles, path_or_file: PathOrFile | None = None, *,
                 degrees: bool = False) -> str:
    """The angle CSV of a single run (``bend`` of shape (T, B)); written when a target is given."""
    from plantlod.formats.angles_csv import AnglesCsvWriter

    degrees = flag("degrees", degrees)
    time, bend, rot, addresses = one_run(angles, "write_angles")
    bad = next((a for a in addresses if "," in a or "\n" in a or "\r" in a), None)
    if bad is not None:
        raise InputError(f"the angles' address {bad[:40]!r} holds a comma or a line break")
    # (what read_angles refuses is never written: session 34's fuzzing wrote both)
    if any(not a for a in addresses):
        raise InputError("the angles hold an empty address; expected each branch's address")
    twice = _first_repeated(addresses)
    if twice is not None:
        raise InputError(f"the angles' address {twice[:40]!r} appears twice; expected each "
                         "branch's address once")
    output_target(path_or_file, kind=OUTPUT_KINDS["angles"])
    if degrees and _is_npz_path(path_or_file):
        raise InputError("degrees applies to CSV output; an .npz holds radians")
    if not _is_npz_path(path_or_file):
        _check_printed_times(time)
    buf = io.StringIO()
    AnglesCsvWriter(buf, addresses, degrees=degrees).write(time, bend, rot)
    if _is_npz_path(path_or_file):             # the archive `plantlod simulate -o X.npz` writes
        from plantlod.formats.npz import angles_bytes

        _write_bytes(angles_bytes(time, addresses, bend, rot), path_or_file)
    else:
        _write_text(buf.getvalue(), path_or_file)
    return buf.getvalue()


def _check_printed_times(time) -> None:
    """Times that still increase as the CSV prints them (CSV_FLOAT_FORMAT, 10 significant
    digits), which read_angles asks of a file: 1 + k·1e-12 s all printed as 1 (a fuzzer's
    find, session 42). A run's own k·dt never comes that close."""
    from plantlod.formats.constants import CSV_FLOAT_FORMAT

    time = np.asarray(time, dtype=np.float64)
    shown = np.array([float(CSV_FLOAT_FORMAT % t) for t in time.tolist()])
    if len(shown) > 1 and not np.all(np.diff(shown) > 0):
        k = int(np.argmax(np.diff(shown) <= 0))
        raise InputError(f"times {float(time[k])!r} s and {float(time[k + 1])!r} s print alike in an angle "
                         f"CSV ({CSV_FLOAT_FORMAT % time[k]}), which needs increasing times; "
                         "write an .npz, which keeps every bit")


# --- levels of detail ----------------------------------------------------------------------

def simplify(system: LSystem | PathOrText, level: int = 1, **options: Any) -> LSystem:
    """The level-``level`` L-system standing for ``system`` (an `LSystem`, the path of an
    .lsys file, or its text as `read_lsystem` reads it; docs/simplify.md).

    options : those of `plantlod.simplify.pipeline.Options` (method, calibrate,
              wind_range, dt, duration, max_evaluations, form, damping_ratio). Its header comment
              (``.comment``) records the errors measured for it.
    """
    from plantlod.simplify.pipeline import simplified_system

    return simplified_system(_as_system(system), level, **options)


def compare(original: Tree | LSystem | PathOrText, *simplified: Tree | LSystem | PathOrText,
            wind: Any = None, dt: float = 0.01, steps: int | None = None,
            duration: float | None = None,
            window: tuple[float | None, float | None] | None = None,
            bounds: dict[str, float] | None = None, damping: float = 0.0,
            wind_speed: float | None = None, wind_direction: float | None = None,
            damping_ratio: float | None = None, gust_strength: float = 0.0,
            gust_seed: int | None = None) -> dict:
    """Compare simplified trees with the original in one wind (model.md 6); trees, systems
    or paths, and the wind as `simulate` takes them. Each is labelled by its file, or, where
    that repeats an earlier one (a level made by `simplify`), by its name.

    Returns the document ``plantlod compare --json`` prints (before rounding):
    per simplified tree the worst-group amplitude, period and tip errors, the
    visible-motion figures (motion_error, period_error_major, tip_error_max_m)
    and every group. ``bounds`` maps figure names (``"motion_error"``, ...; or the report's
    own ``"max_motion_error"``, ...) to limits; ``passed`` says whether all held.
    """
    from plantlod.compare.runs import BOUND_OPTIONS, Run, check_bounds, compare_runs
    from plantlod.compare.report import comparison_document

    if not simplified:
        raise InputError("compare needs at least one simplified tree")
    items = (original,) + simplified
    givens = [_compared_tree(item, k) for k, item in enumerate(items)]
    trees = [g.tree for g in givens]
    n = _step_count(dt, steps, duration)
    if n < 1:                               # (it said "window [-, -] s holds 1 sample(s)")
        raise InputError(f"compare needs a run of at least one step (two samples); "
                         f"{'steps 0' if steps is not None else f'duration {duration:g} s'} "
                         f"gives none")
    given, many = _winds(_wind_option(wind, wind_speed, wind_direction))
    if many:
        raise InputError(f"compare runs one wind; got a list of {len(given)} (compare each wind "
                         "in its own call, or simulate them together with simulate)")
    given = _gusty(given, gust_strength, gust_seed)
    w = given[0]
    # every argument checked before any run (a bad bound after a diverging run was a
    # RunFailure; bounds=5 a TypeError)
    if window is not None and not (isinstance(window, (tuple, list)) and len(window) == 2):
        raise InputError(f"window must be (start, end) in seconds (either None), got {window!r}")
    t0, t1 = ((None if t is None else real("window", t)) for t in window) if window else (None, None)
    if bounds is not None and not isinstance(bounds, dict):
        raise InputError(f"bounds must map figure names to limits, got {type(bounds).__name__}")
    # (a report's own bound keys, "max_motion_error", name the same figures)
    limits: dict = {}
    given: dict = {}                          # each figure's key as the caller wrote it
    for name, limit in (bounds or {}).items():
        figure = (name[4:] if isinstance(name, str) and name.startswith("max_")
                  and name[4:] in BOUND_OPTIONS else name)
        if figure in limits:
            raise InputError(f"bounds name {figure!r} twice (as {figure!r} and 'max_{figure}'); "
                             "expected one")
        limits[figure], given[figure] = limit, name
    unknown = [name for name in limits if name not in BOUND_OPTIONS]
    if unknown:
        raise InputError(f"unknown bound {unknown[0]!r}; expected one of {', '.join(BOUND_OPTIONS)}"
                         " (or the report's max_… names of them)")
    bounds = {name: limits.get(name) for name in BOUND_OPTIONS}
    for name, b in bounds.items():
        if isinstance(b, str) and b.strip().endswith("%"):   # (the CLI's "5%")
            raise InputError(f"bounds[{given[name]!r}] is {b!r}; expected "
                             + ("a number of metres" if name == "tip_error_max_m" else
                                "a number (a fraction: 0.05 for 5 %)"))
    bounds = {name: None if b is None else real(f"bounds[{given[name]!r}]", b, low=0)
              for name, b in bounds.items()}
    runs = []
    damped = _damping(damping, damping_ratio)
    for g in givens:
        g.warn_fitted_otherwise(float(dt), damped)
    from plantlod.formats.level_header import made_from_another

    for g in givens[1:]:                      # (as the CLI says it: a level of another file)
        said = made_from_another(g.level_of, g.name, givens[0].name)
        if said is not None:
            warn_caller(said)
    for tree, label in zip(trees, _labels(items)):
        a = _simulated(tree, [w], False, real("dt", dt), n, 1, damped, None)   # (warned once)
        runs.append(Run(tree, a.time, a.bend, a.rotation, label))
    comparisons = [compare_runs(runs[0], r, t0, t1) for r in runs[1:]]
    violations = [check_bounds(c.report, bounds) for c in comparisons]
    return comparison_document(comparisons, bounds, violations)


def _compared_tree(item: Any, k: int) -> "_Given":
    """Argument ``k`` of `compare` (0 the original) as a tree, every one before any run: a
    wrong third argument was found after the first two had been simulated (12 s), and said
    neither which argument it was nor that a wind is given as ``wind=``."""
    try:
        return _given_tree(item)
    except InputError as exc:
        if isinstance(item, (Tree, LSystem, str, os.PathLike)):
            raise                              # (a tree whose own reading failed says where)
        which = "the original" if k == 0 else f"simplified tree {k}"
        hint = (" (the wind is a keyword: wind=(vx, vy, vz) or wind_speed=...)"
                if _is_number(item) or _reads_as_wind(item) else "")
        raise InputError(f"compare's argument {k + 1} ({which}): {exc.message}{hint}") from None


# --- helpers -------------------------------------------------------------------------------

# --- animation out ---------------------------------------------------------------------------

def export_animation(tree: Tree | LSystem, angles: Angles, path: str | os.PathLike, *,
                     fps: float = 30.0, frames: tuple[int, int] | None = None) -> None:
    """Write ``tree`` moving by ``angles`` (one run, (T, B)) to ``path`` as glTF 2.0
    (.glb, .gltf) or OpenUSD (.usda, .usdc, .usd), chosen by the extension; frames at
    ``fps``, resampled linearly; ``frames`` (A, B) keeps frames A to B-1 (docs/export.md).
    The file appears whole or not at all."""
    from plantlod.export.files import export_animation as write
    from plantlod.compare.runs import angles_in_tree_order

    tree = _as_tree(tree)
    time, bend, rot, addresses = one_run(angles, "export_animation")
    path = path_of(path, "path", output=True)
    fps = real("fps", fps, low=0, low_open=True, high=1000)
    if frames is not None:
        if not (isinstance(frames, (tuple, list)) and len(frames) == 2):
            raise InputError(f"frames must be (A, B), frames A to B-1, got {frames!r}")
        frames = (whole("frames", frames[0]), whole("frames", frames[1], low=1))
        if frames[0] >= frames[1]:
            raise InputError(f"frames {frames} keeps no frame; expected (A, B) with A < B "
                             "(frames A to B-1)")
    bend, rot = angles_in_tree_order(tree, addresses, bend, rot, None)   # (an Angles: no file)
    with _writing(path):
        write(path, tree, time, bend, rot, fps, frames)


def write_view(gltf_paths: Any, path_or_file: PathOrFile | None = None, *,
               wind_direction: float = 0.0, title: str | None = None) -> str:
    """One self-contained HTML page playing the glTF files ``gltf_paths`` side by side
    (the original first, then its levels); written when a target is given. The wind arrow
    points toward ``wind_direction`` degrees (0 = +x, 90 = +y). docs/export.md, "Watching"."""
    from plantlod.export.constants import VIEW_TITLE
    from plantlod.export.view import view_page_from_files

    if isinstance(gltf_paths, (str, os.PathLike)):
        gltf_paths = [gltf_paths]
    if not isinstance(gltf_paths, (list, tuple)) or not gltf_paths:
        raise InputError("write_view takes the paths of .glb/.gltf files (a path or a list)")
    paths = [path_of(p, "a glTF path") for p in gltf_paths]
    wind_direction = real("wind_direction", wind_direction)
    if title is not None and not isinstance(title, str):
        raise InputError(f"title must be text, got {type(title).__name__}")
    output_target(path_or_file, kind=OUTPUT_KINDS["page"])
    if isinstance(path_or_file, (str, os.PathLike)):
        from plantlod.export.view import files_read
        from plantlod.formats.atomic import lands_on

        for p in paths:
            for source in files_read(p):
                if lands_on(os.fspath(path_or_file), source):
                    raise InputError("the page would be written over its input"
                                     + ("" if source == p else f" (its buffer {source})")
                                     + "; expected another path", p)
    page = view_page_from_files(paths, wind_direction, title or VIEW_TITLE)
    _write_text(page, path_or_file)
    return page


def _step_count(dt: float, steps: int | None, duration: float | None) -> int:
    dt = real("dt", dt, low=0, low_open=True)
    if (steps is None) == (duration is None):
        raise InputError("give exactly one of steps and duration")
    from plantlod.sim.run import refuse_no_step, step_count

    duration = 0.0 if steps is not None else real("duration", duration, low=0)
    count = step_count(dt, duration)           # (dt checked against MIN_TIME_STEP either way)
    if steps is None:
        refuse_no_step(count, dt, duration)
    from plantlod.sim.constants import MAX_TIME_STEPS

    return count if steps is None else whole("steps", steps, high=MAX_TIME_STEPS)


def _is_wind_object(wind: Any) -> bool:
    """A wind object (`plantlod.sim.wind`'s or the caller's): it has a ``sample(times)``. One
    whose ``sample`` is no method is refused here (its run failed: "'int' object is not
    callable", a RunFailure for what is bad input)."""
    if not hasattr(wind, "sample"):
        return False
    if not callable(wind.sample):
        raise InputError(f"wind has a sample that is not a method (got "
                         f"{type(wind.sample).__name__}); a wind object needs sample(times) -> "
                         f"(K, 3) m/s")
    return True


def _winds(wind: Any) -> tuple[list, bool]:
    """The winds ``wind`` gives, and whether it gives several (a lane axis): one wind is a
    wind object, a vector (vx, vy, vz) as a tuple, a list of three numbers or an array of
    shape (3,); several are a list or tuple of winds, or an array of shape (W, 3)."""
    if _is_wind_object(wind):
        return [wind], False
    if isinstance(wind, np.ndarray):
        if wind.ndim == 2 and wind.shape[1:] == (3,):
            many = list(wind)
        else:
            return [_wind(wind)], False
    elif isinstance(wind, (list, tuple)) and not _is_vector(wind):
        if all(_is_number(v) for v in wind):    # numbers, but not three: a vector gone wrong
            return [_wind(wind)], False
        many = list(wind)
    else:
        return [_wind(wind)], False
    if not many:
        raise InputError("an empty list of winds; expected at least one wind")
    return [_wind(w) for w in many], True


def _gusty(winds: list, strength: Any, seed: Any) -> list:
    """``winds`` with seeded gusts of RMS relative ``strength`` (the CLI's --gust-strength,
    --gust-seed; `GustyWind`), and a `PlantlodWarning` where every wind is a steady zero
    (the tree stays at rest, as the CLI warns)."""
    from plantlod.sim.wind import ConstantWind, GustyWind, KeyframeWind, wind_samples

    strength = real("gust_strength", strength, low=0)
    if seed is not None and not strength:
        raise InputError("gust_seed applies to gusts; give gust_strength > 0 too")
    if strength:
        winds = [GustyWind(w, seed=0 if seed is None else whole("gust_seed", seed, low=0),
                           strength=strength) for w in winds]
    steady = [getattr(w, "base", w) for w in winds]     # (a gust scales its base wind)
    if all((isinstance(w, ConstantWind) and not np.any(wind_samples(w, np.zeros(1))))
           or (isinstance(w, KeyframeWind) and not np.any(w.vectors)) for w in steady):
        warn_caller("the wind is zero, so the tree stays at rest; give wind=(vx, vy, vz) or "
                    "wind_speed=S")
    return winds


def _reads_as_wind(value: Any) -> bool:
    """Whether ``value`` is a wind or winds as `simulate` reads them (`_winds`)."""
    try:
        _winds(value)
    except InputError:
        return False
    return True


def _is_vector(value: Any) -> bool:
    """Three real numbers (not a list of winds)."""
    return len(value) == 3 and all(_is_number(v) for v in value)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def _wind(wind: Any):
    from plantlod.lsys.errors import shown
    from plantlod.sim.wind import ConstantWind

    if _is_wind_object(wind):
        return wind
    try:
        if np.iscomplexobj(wind):                 # (float64 of it drops the imaginary part)
            raise TypeError("complex")
        if np.asarray(wind).dtype.kind not in "iuf":   # (strings, "1" in a list, were read as
            raise TypeError("not numbers")        # numbers; timedelta64 counts as one in numpy)
        vector = np.asarray(wind, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):   # (an int past a double's range)
        vector = np.zeros(0)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        got = shown(" ".join(shown_value(wind).split()), 80)   # (one line: an array's repr has several)
        raise InputError(f"a wind is (vx, vy, vz) in m/s (a tuple, a list of three numbers or an "
                         f"array of shape (3,)) or a wind object, and several winds a list of "
                         f"them or an array (W, 3); got {got}")
    return ConstantWind(vector)


def _is_text(value: Any) -> bool:
    """A string with a line break is a file's text itself, any other string a path (no file
    name of the commands' has a line break, every file they read has one)."""
    return isinstance(value, str) and ("\n" in value or "\r" in value)


def _labels(items: tuple) -> list[str]:
    """A label per compared item: its file (``<text>`` for a text); where that repeats an
    earlier label (a level `simplify` made keeps its original's file name), its name, else
    "<label> (simplified k)"."""
    out: list[str] = []
    for k, item in enumerate(items):
        if _is_text(item):
            label = "<text>"                                   # a text read as its tree
        elif isinstance(item, (str, os.PathLike)):
            label = os.fspath(item)
        else:
            label = getattr(item, "source", "") or ("original" if k == 0 else f"simplified {k}")
        if label in out:
            name = getattr(item, "name", "") or ""
            label = name if name and name not in out else f"{label} (simplified {k})"
        out.append(label)
    return out


def _as_system(item: Any) -> LSystem:
    """An `LSystem`, or one read from a path or text (`read_lsystem`)."""
    if isinstance(item, LSystem):
        return _checked_system(item)
    if isinstance(item, (str, os.PathLike)):
        return read_lsystem(item)
    raise InputError(f"expected an LSystem, the path of an .lsys file or its text, got "
                     f"{type(item).__name__}")


def _checked_system(system: LSystem) -> LSystem:
    """``system`` as given, once its fields have the types an .lsys file gives them and it
    reads back from its own text: an `LSystem` edited by hand (`dataclasses.replace`) with a
    string, a float count or a bare string axiom leaked TypeError and AttributeError."""
    from plantlod.formats.lsys_file import write_lsys
    from plantlod.lsys.parse import parse_lsys
    from plantlod.lsys.system import BranchSymbol, LeafSymbol, Module, Override, Production

    def fail(message: str):
        raise InputError(f"the LSystem is not one an .lsys file can say: {message}",
                         system.source or None)

    for name in ("derivation_length", "seed"):
        value = getattr(system, name)
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            fail(f"{name} must be a whole number >= 0, got {shown_value(value)}")
    for name in ("branching_angle", "rotation_angle", "force_absorbed", "force_propagated",
                 "drag_coefficient", "leaf_force_scale"):
        try:
            real(name, getattr(system, name))
        except InputError as exc:
            fail(exc.message)
    for name in ("name", "source", "comment"):
        if not isinstance(getattr(system, name), str):
            fail(f"{name} must be a string, got {shown_value(getattr(system, name))}")
    kinds = {"axiom": Module, "productions": Production, "interpretation": Production,
             "branches": BranchSymbol, "leaves": LeafSymbol, "overrides": Override, "ignore": str}
    for name, kind in kinds.items():
        value = getattr(system, name)
        if not isinstance(value, (tuple, list)) or not all(isinstance(v, kind) for v in value):
            fail(f"{name} must be a tuple of {kind.__name__}s, got {shown_value(value)}")
    # a list where the file gives a tuple is the same sequence (it read back as another:
    # `replace(system, productions=list(...))`; session 40, a helper's first hour)
    system = dataclasses.replace(system, **{name: tuple(getattr(system, name))
                                            for name in (*kinds, "defines")
                                            if isinstance(getattr(system, name), list)})
    if not isinstance(system.defines, (tuple, list)) or not all(
            isinstance(d, tuple) and len(d) == 2 and isinstance(d[0], str) for d in system.defines):
        fail("defines must be a tuple of (name, value) pairs")
    import warnings

    try:
        with warnings.catch_warnings():           # (its own reading warned already)
            warnings.simplefilter("ignore")
            text = write_lsys(system)
            again = parse_lsys(text, system.source or "<LSystem>")
    except InputError as exc:
        fail(exc.message)
    except OverflowError:
        fail("a number is past a float's range")
    except (TypeError, ValueError, AttributeError) as exc:
        fail(f"{type(exc).__name__}: {exc}")
    differs = [f.name for f in dataclasses.fields(system)
               if f.compare and getattr(system, f.name) != getattr(again, f.name)]
    if differs:             # (an axiom module named "F F" derived nothing, its text 16 branches)
        fail(f"its {' and '.join(differs)} read(s) back from its own text as something else "
             f"(a module's name is one symbol; arguments, lengths, strengths and areas are "
             f"numbers)")
    return system


def _checked(tree: Tree) -> Tree:
    """``tree`` as given, once its arrays keep the invariants of `Tree` (shapes, parents
    before children, leaves on branches that exist, distinct addresses, finite numbers): a
    Tree built or edited by hand (`dataclasses.replace`) is checked before anything runs on
    it (a parent cycle made `write_tree` loop forever, a short array leaked numpy's errors)."""
    from plantlod.formats.constants import NORMAL_UNIT_TOL
    from plantlod.formats.treefile import (BRANCH_ADDRESS, LEAF_ADDRESS, NON_NEGATIVE_FIELDS,
                                           POSITIVE_FIELDS)
    from plantlod.lsys.tree import BRANCH_FLOAT_FIELDS, is_symbol

    try:
        for name in ("parent", "leaf_branch"):
            index = np.asarray(getattr(tree, name))
            if not np.issubdtype(index.dtype, np.integer) or index.ndim != 1:
                raise ValueError(f"{name} must be a flat array of whole numbers (indices)")
        scale = tree.leaf_force_scale
        if isinstance(scale, bool) or not isinstance(scale, (int, float, np.integer, np.floating)):
            raise ValueError(f"leaf_force_scale must be one number, got {type(scale).__name__}")
        if isinstance(scale, int) and not finite(scale):     # (float() raised OverflowError)
            raise ValueError("leaf_force_scale is past a float's range")
        fields = (*BRANCH_FLOAT_FIELDS, "euler", "offset", "leaf_area", "leaf_normal")
        optional = [name for name in ("force_gain", "swing_roll") if getattr(tree, name) is not None]
        # (a list said "'list' object has no attribute 'shape'", strings were read as numbers,
        # and timedelta64 passed as a number: numpy counts it as an integer kind)
        for name in (*fields, *optional):
            value = getattr(tree, name)
            if not isinstance(value, np.ndarray) or value.dtype.kind not in "iufc":
                kind = (f"an array of {value.dtype}" if isinstance(value, np.ndarray)
                        else type(value).__name__)
                raise ValueError(f"{name} must be a numpy array of numbers, got {kind}")
        given = [getattr(tree, name) for name in (*fields, *optional)]
        if any(np.iscomplexobj(a) for a in given):
            raise ValueError("its numbers must be real (a complex array lost its imaginary "
                             "part without a word)")
        tree.check()
        arrays = [np.asarray(a, dtype=np.float64) for a in given] + [
            np.asarray([tree.leaf_force_scale], dtype=np.float64)]
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise ValueError("its numbers must be finite (a NaN or an infinity in lengths, "
                             "strengths, forces, rest angles, offsets, leaves, gains or rolls)")
        with np.errstate(over="ignore"):
            norms = np.linalg.norm(np.asarray(tree.leaf_normal, dtype=np.float64), axis=-1)
        # (a normal of length 5 gave its leaf 5 times the force; a tree file refuses it)
        if np.any(np.asarray(tree.leaf_area) < 0) or not np.all(
                np.abs(norms - 1.0) <= NORMAL_UNIT_TOL):
            raise ValueError(f"its leaves need areas >= 0 and unit normals (length within "
                             f"{NORMAL_UNIT_TOL:g} of 1, as in a tree file)")
        for name in sorted(NON_NEGATIVE_FIELDS):  # (what its tree file could not hold either)
            value = getattr(tree, name, None)
            if value is not None and np.any(np.asarray(value, dtype=np.float64) < 0):
                raise ValueError(f"{name} must not be negative")
        for name in sorted(POSITIVE_FIELDS):
            if not np.all(np.asarray(getattr(tree, name), dtype=np.float64) > 0):
                raise ValueError(f"{name} must be > 0")
        addresses = [(a, BRANCH_ADDRESS) for a in [*tree.address, *tree.group_root]] + [
            (a, LEAF_ADDRESS) for a in tree.leaf_address]          # (as the tree files' readers)
        if not all(isinstance(a, str) and pattern.match(a) for a, pattern in addresses):
            raise ValueError("its addresses must be strings like '0.2.1' (a branch's may end "
                             "in ':K'; numbers without leading zeros)")
        if not all(map(is_symbol, tree.symbol)):     # (as the tree files' readers hold them)
            raise ValueError("its symbols must be single characters (not control characters "
                             "nor halves of surrogate pairs)")
        if tree.group_root and len(tree.group_root) != tree.n_branches:
            raise ValueError(f"group_root must name a root for each of its {tree.n_branches} "
                             "branches, or none")
        if len(set(tree.address)) != len(tree.address):
            raise ValueError("its branch addresses must be distinct")
    except (ValueError, TypeError, AttributeError, IndexError) as exc:
        raise tree.broken(exc) from None
    return tree


def _as_tree(item: Any) -> Tree:
    """A `Tree`: as given, derived from an `LSystem`, or read from a path (an .lsys file, a
    tree file, a tree .npz), as the commands read their TREE argument; a string with a line
    break is the text of an .lsys file or a tree file itself (as `read_lsystem` reads it)."""
    return _given_tree(item).tree


@dataclass(frozen=True)
class _Given:
    """A tree argument as read (`_given_tree`): the tree, and where it is a level, the dt and
    damping its simplify header says it was fitted at (`formats.level_header`)."""

    tree: Tree
    name: str = ""
    fitted: Any = None                        # FittedConditions | None
    level_of: str | None = None               # the file its header says it was made from

    def warn_fitted_otherwise(self, dt: float, damping) -> None:
        """A `PlantlodWarning` where a run at ``dt`` under ``damping`` differs from the
        conditions the level was fitted at, as the CLI warns."""
        from plantlod.formats.level_header import API_SPELLING

        message = None if self.fitted is None else self.fitted.said(
            self.name, dt, damping.c, damping.ratio, API_SPELLING)
        if message is not None:
            warn_caller(message)


def _given_tree(item: Any) -> _Given:
    """`_as_tree`'s tree with the conditions its header names (each file read once)."""
    from plantlod.formats.level_header import (comment_conditions, comment_source,
                                               leading_comment)

    if isinstance(item, Tree):
        return _Given(_checked(item))
    if isinstance(item, LSystem):
        return _Given(derive(item), item.source or item.name or "the level",
                      comment_conditions(item.comment or ""), comment_source(item.comment or ""))
    if not isinstance(item, (str, os.PathLike)):
        raise InputError(f"expected a Tree, an LSystem, a path or the text of either, got "
                         f"{type(item).__name__}")
    if _is_text(item):
        text, path = item, "<text>"       # the text itself, as `read_lsystem` takes it
    else:
        path = path_of(item)
        from plantlod.formats.npz import is_npz, read_npz_file, read_tree_bytes

        if is_npz(path):
            return _Given(read_tree_bytes(read_npz_file(path), path).named(path))
        from plantlod.formats.text_input import read_text

        text = read_text(path)
    from plantlod.formats.kinds import looks_like_tree_file, text_kind
    from plantlod.formats.lsys_file import parse_lsys_text

    if looks_like_tree_file(text) and text_kind(text) != "gltf":
        from plantlod.formats.treefile import read_tree_text

        return _Given(read_tree_text(text, path).named(path))
    header = leading_comment(text)
    return _Given(derive(parse_lsys_text(text, path)), path, comment_conditions(header),
                  comment_source(header))


def _damping(damping: Any, damping_ratio: Any):
    """The runs' `plantlod.sim.damping.Damping` from the API's ``damping`` (c) and
    ``damping_ratio`` (ζ, None: not given), each checked as a number."""
    from plantlod.sim.damping import as_damping

    return as_damping(real("damping", damping),
                      None if damping_ratio is None else real("damping_ratio", damping_ratio))


def _read_text(stream: IO[str], name: str) -> str:
    """The text of an open stream; one not open for reading, or not UTF-8 text, is bad input
    naming it (the path of such a file says so as well: `formats.text_input`)."""
    try:
        text = stream.read()
    except io.UnsupportedOperation:
        raise InputError("the stream is not open for reading; expected a file opened with "
                         "open(path) or open(path, 'r')", name) from None
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text ({exc.reason}); expected a UTF-8 file", name
                         ) from None
    except ValueError as exc:                    # a closed file
        raise InputError(f"cannot read the stream: {exc}", name) from None
    if not isinstance(text, str):
        raise InputError("the stream gives bytes; expected a text stream (open(path), not "
                         "open(path, 'rb'))", name)
    return text


def _wind_option(wind: Any, speed: float | None, direction: float | None) -> Any:
    """``wind``, or the horizontal wind of ``speed`` toward ``direction`` degrees (the CLI's
    --wind-speed, --wind-direction); no wind at all is (0, 0, 0)."""
    if speed is None:
        if direction is not None:
            raise InputError("wind_direction applies to wind_speed; give a speed too (or the "
                             "whole vector as wind=(vx, vy, vz))")
        return (0.0, 0.0, 0.0) if wind is None else wind
    if wind is not None:
        raise InputError("give one of wind and wind_speed")
    from plantlod.sim.wind import wind_from_speed

    from plantlod.sim.constants import MAX_WIND_SPEED

    speed = real("wind_speed", speed, low=0, high=MAX_WIND_SPEED)
    direction = 0.0 if direction is None else real("wind_direction", direction)
    return wind_from_speed(speed, direction)


def _text_stream(path_or_file: PathOrFile) -> tuple[IO[str], str]:
    if hasattr(path_or_file, "read"):
        if getattr(path_or_file, "closed", False):
            raise InputError("a closed stream; expected an open one or a path")
        if binary_stream(path_or_file):
            raise InputError("a binary stream; expected a text stream or a path")
        return path_or_file, getattr(path_or_file, "name", "<stream>")  # type: ignore[return-value]
    if _is_text(path_or_file):
        return io.StringIO(path_or_file), "<text>"   # the text itself, as read_lsystem takes it
    from plantlod.formats.text_input import read_text

    path = path_of(path_or_file)
    return io.StringIO(read_text(path)), path


def _write_text(text: str, path_or_file: PathOrFile | None) -> None:
    """``text`` to a target `output_target` has checked."""
    if path_or_file is None:
        return
    if hasattr(path_or_file, "write"):
        name = getattr(path_or_file, "name", None) or "the stream"
        with _writing(name):
            try:
                path_or_file.write(text)      # type: ignore[union-attr]
                flush = getattr(path_or_file, "flush", None)
                if flush is not None:
                    flush()                   # (a full disk says so here, not at close)
            except ValueError as exc:         # (the caller's stream: closed since, or an
                # encoding such as ascii that cannot hold the text: UnicodeEncodeError)
                raise RunFailure(f"cannot write {name}: {exc}") from None
        return
    _write_bytes(text.encode("utf-8", "backslashreplace"), path_or_file)


def _write_bytes(data: bytes, path: PathOrFile) -> None:
    """``data`` to a path `output_target` has checked, whole or not at all (a temporary
    beside it, renamed over it: no partial file)."""
    from plantlod.formats.atomic import atomic_path, write_whole

    with _writing(os.fspath(path)), atomic_path(os.fspath(path)) as tmp:
        write_whole(tmp, data)


def _is_npz_path(target: PathOrFile | None) -> bool:
    """A path (not a stream) that names an .npz archive (`formats.npz.is_npz`)."""
    from plantlod.formats.npz import is_npz

    return isinstance(target, (str, os.PathLike)) and is_npz(os.fspath(target))


def _first_repeated(names: list[str]) -> str | None:
    """The first name that appears a second time in ``names``, or None."""
    seen: set[str] = set()
    for name in names:
        if name in seen:
            return name
        seen.add(name)
    return None


@contextlib.contextmanager
def _writing(path: str):
    """A file that cannot be written (a full disk, a folder that takes no file) is a
    `RunFailure` naming it, as the commands say it (it was a raw OSError). A reader that went
    away (``plantlod view ... -o - | head``) is not a failure: BrokenPipeError passes, and
    the command ends quietly (exit 141) as every other does."""
    try:
        yield
    except BrokenPipeError:
        raise
    except OSError as exc:
        raise RunFailure(f"cannot write {exc.filename or path}: "
                         f"{exc.strerror or exc}") from None


__all__ = ["Angles", "read_lsystem", "write_lsystem", "derive", "read_tree", "write_tree",
           "simulate", "read_angles", "write_angles", "simplify", "compare",
           "export_animation", "write_view"]
