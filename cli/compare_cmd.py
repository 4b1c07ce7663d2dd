"""`plantlod compare`: how far simplified trees move from the original (docs/compare.md).

The work is in `plantlod.compare.runs` (groups, combined angles, report),
`plantlod.compare.report` (table, JSON), `plantlod.export.obj` and
`plantlod.compare.plot`; this module reads the inputs, runs what needs running
and writes the report; `compare_exports` writes the OBJ frames and the picture.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys

import click

from plantlod.lsys.errors import InputError, RunFailure

from .discipline import ErrorBound, Metres, given, require_together
from .io import (check_output_folder, check_output_kind, check_output_path, display_name,
                 distinct_paths, is_terminal, large_file_angles, open_output, reader_gone_after,
                 say, warn, warn_once_running)
from .compare_exports import is_frame_in, prepare_pictures, write_pictures
from .loading import load_tree
from .sim_options import SIMULATION_PARAMS, settings_from_kwargs, simulation_options
from plantlod.lsys.words import counted


def _numbers(text: str | None, option: str, allow_empty: bool = False) -> list[float | None]:
    """Comma-separated numbers; with allow_empty an empty field is None."""
    if text is None:
        return []
    out: list[float | None] = []
    for part in text.split(","):
        part = part.strip()
        if not part and allow_empty:
            out.append(None)
            continue
        try:
            value = float(part)
        except ValueError:
            raise click.BadParameter(f"expected numbers separated by commas, got {text!r}",
                                     param_hint=option) from None
        if not math.isfinite(value):
            raise click.BadParameter(f"expected finite numbers, got {text!r}", param_hint=option)
        out.append(value)
    return out


@click.command()
@click.argument("original", metavar="ORIGINAL")
@click.argument("simplified", metavar="SIMPLIFIED...", nargs=-1)   # (required: checked below)
@click.option("--original-angles", metavar="A.csv", default=None,
              help="Angle CSV of ORIGINAL from `plantlod simulate` (else ORIGINAL is simulated here).")
@click.option("--simplified-angles", metavar="B.csv", multiple=True,
              help="Angle CSV of a SIMPLIFIED file; give it once per SIMPLIFIED, in order.")
@click.option("--degrees", is_flag=True, help="The angle CSVs hold degrees (simulate --degrees).")
@click.option("-n", "--derivation-length", "original_n", type=click.IntRange(min=0), default=None,
              help="Derivation length of an .lsys ORIGINAL (default: the file's).")
@click.option("--simplified-n", type=click.IntRange(min=0), multiple=True,
              help="Derivation length of an .lsys SIMPLIFIED; once per SIMPLIFIED, in order.")
@simulation_options(dt_required=False)
@click.option("--window", "window_text", metavar="T0,T1", default=None,
              help="Compare only the samples with T0 <= t <= T1 (either may be left empty).")
@click.option("--json", "as_json", is_flag=True, help="Write JSON instead of the table.")
@click.option("-o", "--output", default=None, metavar="OUT",
              help="Write the table or JSON here (atomically) instead of stdout.")
@click.option("--max-amplitude-error", type=ErrorBound(), default=None,
              help="Exit 1 when the worst amplitude error is above this (a fraction, 0.05, "
                   "or a percentage, 5%).")
@click.option("--max-period-error", type=ErrorBound(), default=None,
              help="Exit 1 when the worst period error is above this (0.01 or 1%).")
@click.option("--max-tip-error", type=ErrorBound(), default=None,
              help="Exit 1 when the worst tip error is above this (a fraction of the rest "
                   "height, or a percentage of it).")
@click.option("--max-motion-error", type=ErrorBound(), default=None,
              help="Exit 1 when the motion error (a fraction of the largest motion, or a "
                   "percentage) is above this.")
@click.option("--max-period-error-major", type=ErrorBound(), default=None,
              help="Exit 1 when the period error of the major components is above this "
                   "(a fraction or a percentage).")
@click.option("--max-tip-error-m", type=Metres(), default=None,
              help="Exit 1 when a group tip strays farther than this many metres.")
@click.option("--obj", "obj_dir", metavar="DIR", default=None,
              help="Write OBJ files of the posed trees side by side into DIR (with --at / --every).")
@click.option("--at", "at_text", metavar="T[,T...]", default=None,
              help="Times (s) of the OBJ frames DIR/frame_t<T>.obj.")
@click.option("--every", type=click.IntRange(min=1), default=None,
              help="Also write every K-th sample as DIR/frame_<NNNNN>.obj (an animation).")
@click.option("--plot", "plot_path", metavar="FILE.png", default=None,
              help="Draw angles of the worst groups and the posed trees into a PNG (needs matplotlib).")
@click.option("--plot-at", type=float, default=None,
              help="Time (s) of the posed trees in the plot (default: the first --at, else 4 s).")
@click.option("--angles", "angles_mode", is_flag=True,
              help="Compare two angle CSVs of one tree instead: ORIGINAL and SIMPLIFIED are CSVs.")
@click.option("--atol", type=click.FloatRange(min=0), default=None,
              help="With --angles: exit 1 when some angle differs by more than this (radians, "
                   "or degrees with --degrees).")
@click.pass_context
def compare(ctx, original, simplified, original_angles, simplified_angles, degrees, original_n,
            simplified_n, window_text, as_json, output, max_amplitude_error, max_period_error,
            max_tip_error, max_motion_error, max_period_error_major, max_tip_error_m, obj_dir, at_text, every, plot_path, plot_at, angles_mode, atol,
            **sim_kwargs):
    """Compare the motion of simplified trees with the original's.

    ORIGINAL and each SIMPLIFIED are .lsys files or tree files. Each is
    simulated here with the simulation options, unless its angle CSV from
    `plantlod simulate` is given (--original-angles, --simplified-angles).
    Every simplified branch stands for a group of original branches (the
    original branches whose addresses begin with its address); per group the
    table shows amplitudes, periods, their errors and the tip error
    (docs/compare.md, docs/errors.md). Exit status 1 when a --max-… bound is
    broken, 2 for bad input.

    \b
    Examples (l1.lsys, l2.lsys from `plantlod simplify examples/stalk8.lsys --level 1 -o
    l1.lsys`; tree files from `plantlod derive`, angle CSVs from `plantlod simulate`; the
    whole set in docs/compare.md):
      plantlod compare examples/stalk8.lsys l1.lsys --dt 0.01 --duration 20 --wind-speed 10
      plantlod compare examples/stalk8.lsys l1.lsys l2.lsys --dt 0.01 --duration 6 \\
          --wind-speed 10 --obj frames --at 4 --plot cmp.png
      plantlod compare tree.jsonl l1.tree.jsonl --original-angles a.csv --simplified-angles b.csv --json
      plantlod compare --angles golden.csv new.csv --atol 1e-9
    """
    if not simplified:                      # (click's own message named no --angles form)
        raise click.UsageError("--angles compares two angle CSVs of one tree: give both, as in "
                               "'plantlod compare --angles golden.csv new.csv'" if angles_mode
                               else "Missing argument 'SIMPLIFIED...'.")
    require_together(ctx, {"degrees": ("original_angles", "simplified_angles", "angles_mode")})
    inputs = {"ORIGINAL": original, "--original-angles": original_angles}
    for k, path in enumerate(simplified):
        inputs[f"SIMPLIFIED {k + 1}"] = path
    for k, path in enumerate(simplified_angles or ()):
        inputs[f"--simplified-angles {k + 1}"] = path
    # (-o unset is standard output too: `--plot -` there mixed the PNG into the table)
    distinct_paths({"-o" if output is not None else "the table (no -o)":
                    "-" if output is None else output, "--obj": obj_dir,
                    "--plot": plot_path}, inputs)
    if obj_dir is not None:                 # (the frames land in DIR, over a file so named)
        for what, path in inputs.items():
            if path not in (None, "-") and is_frame_in(path, obj_dir):
                raise click.UsageError(f"--obj {obj_dir} writes frame_*.obj files, and the input "
                                       f"{path} ({what}) is one of its names; expected another "
                                       "folder")
    check_output_kind(output, "-o", "the report (a table, or JSON with --json)", (".txt", ".json"))
    check_output_kind(plot_path, "--plot", "a PNG picture", (".png",))
    if angles_mode:
        _check_angles_mode(ctx, simplified)
        _compare_csvs(original, simplified[0], degrees, atol, as_json, output)
        return
    if atol is not None:
        raise click.UsageError("--atol applies to --angles (two angle CSVs of one tree)")
    _check_pairs(simplified, simplified_angles, "--simplified-angles")
    _check_pairs(simplified, simplified_n, "--simplified-n")
    window = _numbers(window_text, "--window", allow_empty=True)
    if window_text is not None and len(window) != 2:
        raise click.BadParameter("expected T0,T1 (either may be empty)", param_hint="--window")
    if window_text is not None and None not in window and window[0] > window[1]:
        raise click.BadParameter(f"the start {window[0]:g} s is after the end {window[1]:g} s; "
                                 "expected T0 <= T1", param_hint="--window")
    at_times = _numbers(at_text, "--at")
    if (at_times or every) and obj_dir is None:
        raise click.UsageError("--at and --every choose OBJ frames; give --obj DIR too")
    if obj_dir is not None and not at_times and every is None:
        raise click.UsageError("--obj needs the times of its frames: --at T[,T...] and/or --every K")
    if plot_at is not None and plot_path is None:
        raise click.UsageError("--plot-at chooses the time of the trees in --plot FILE.png; give --plot too")
    if plot_path is not None:
        from plantlod.compare.plot import require_matplotlib
        require_matplotlib()                 # fail before any simulation runs
    if obj_dir is not None and os.path.exists(obj_dir) and not os.path.isdir(obj_dir):
        raise InputError("--obj needs a directory; this is a file", obj_dir)
    if obj_dir is not None:
        check_output_folder(obj_dir, "--obj", "frame_*.obj files")
    for path in (output, plot_path):
        check_output_path(path)

    sides = [(original, original_angles, original_n)]
    sides += [(s, simplified_angles[i] if simplified_angles else None,
               simplified_n[i] if simplified_n else None) for i, s in enumerate(simplified)]
    settings = _settings_if_needed(ctx, sides, sim_kwargs)
    from plantlod.compare.runs import check_bounds, compare_runs, on_common_samples

    # a side kept every K-th step (simulate --every K): every side at its samples, so that
    # the comparisons and the pictures pose each tree at one time
    from plantlod.formats.level_header import made_from_another

    read = [_run_side(path, csv, n, degrees, settings) for path, csv, n in sides]
    runs = on_common_samples([run for run, _ in read])
    others = {path: made_from_another(source, display_name(path), display_name(original))
              for path, (_, source) in zip(simplified, read[1:])}
    for said in others.values():
        if said is not None:
            warn_once_running(said)

    # (an error of a SIMPLIFIED's groups names its file, the run's name; one of the samples or
    # the window names the files or the option at fault: `compare_runs`)
    comparisons = []
    for path, run in zip(simplified, runs[1:]):
        try:
            comparisons.append(compare_runs(runs[0], run, *(window or (None, None))))
        except InputError as exc:           # (the trees do not match: say which it came from)
            if others[path] is None:
                raise
            raise InputError(f"{exc.message} ({others[path].split(': ', 1)[1]})", exc.file,
                             exc.line, exc.col) from None
    bounds = {"amplitude_error": max_amplitude_error, "period_error": max_period_error,
              "tip_error": max_tip_error, "motion_error": max_motion_error,
              "period_error_major": max_period_error_major, "tip_error_max_m": max_tip_error_m}
    violations = [check_bounds(c.report, bounds) for c in comparisons]

    # Everything that can still refuse the run (times outside it, the picture) comes
    # before the first output is written.
    pictures = (prepare_pictures(runs, at_times, plot_path, plot_at, comparisons, every)
                if obj_dir is not None or plot_path is not None else None)
    # the report file, the OBJ frames and the picture land together, when all are written: a
    # picture that cannot be written (or a signal) left the report replaced before (session
    # 29). Standard output cannot be held: it is written last, before the rest lands, so a
    # full disk there leaves no frames or picture either; a reader gone (`| head`) lets them
    # land and then ends the command quietly (`reader_gone_after`, session 35)
    to_file = output not in (None, "-")
    gone = None
    with contextlib.ExitStack() as landing:
        lines = ([] if pictures is None
                 else write_pictures(runs, obj_dir, every, plot_path, pictures, landing))
        if to_file:     # entered last, so it lands first: a device written in place (-o
            # /dev/full) fails at its flush before the frames and the picture land (42)
            _write_report(comparisons, bounds, violations, as_json, output, landing)
        if not to_file:
            gone = reader_gone_after(
                lambda: _write_report(comparisons, bounds, violations, as_json, output))
    if gone is not None:
        raise gone
    broken = [v.describe(c.simplified.name) for c, vs in zip(comparisons, violations) for v in vs]
    if broken:                      # one line: the bounds missed (the summary's figures in it),
        # and what was written all the same in it, not on lines of its own before (a fuzzing
        # round: exit 1 with two lines)
        landed = "".join(f"; {line.removeprefix('compare: ')}" for line in lines)
        raise RunFailure("bound exceeded: " + "; ".join(broken) + landed)
    for line in lines:
        say(line)
    for comp in comparisons:
        _summarise(comp)


# --- inputs ----------------------------------------------------------------------------

def _check_pairs(simplified, values, option: str) -> None:
    if values and len(values) != len(simplified):
        raise click.UsageError(f"{option} was given {len(values)} time(s) for {len(simplified)} "
                               f"SIMPLIFIED file(s); give it once per SIMPLIFIED, in order")


def _settings_if_needed(ctx, sides, sim_kwargs):
    """The simulation settings when some side has no angle CSV; None (and no options) otherwise."""
    needed = [path for path, csv, _n in sides if csv is None]
    if not needed:
        extra = [p for p in SIMULATION_PARAMS if given(ctx, p)]
        if extra:
            raise click.UsageError(f"--{extra[0].replace('_', '-')} applies only when a side is "
                                   f"simulated; every side here comes with an angle CSV")
        return None
    if sim_kwargs.get("dt") is None:
        raise click.UsageError(f"--dt is required to simulate {display_name(needed[0])} "
                               f"(or give its angle CSV)")
    settings = settings_from_kwargs(dict(sim_kwargs))
    if settings.steps < 1:                   # (it said "window [-, -] s holds 1 sample(s)")
        given_as = ("--steps 0" if sim_kwargs.get("steps") is not None
                    else f"--duration {sim_kwargs.get('duration'):g} s at --dt {settings.dt:g} s")
        raise click.UsageError(f"compare needs a run of at least one step (two samples); "
                               f"{given_as} gives none")
    return settings


def _check_angles_mode(ctx, simplified) -> None:
    if len(simplified) != 1:
        raise click.UsageError(f"--angles compares exactly two CSVs; got {1 + len(simplified)} files")
    other = [p for p in ("original_angles", "simplified_angles", "original_n", "simplified_n",
                         "window_text", "max_amplitude_error", "max_period_error", "max_tip_error",
                         "max_motion_error", "max_period_error_major", "max_tip_error_m", "obj_dir", "at_text", "every", "plot_path", "plot_at") + SIMULATION_PARAMS
             if given(ctx, p)]
    if other:
        name = {"window_text": "window", "at_text": "at", "obj_dir": "obj", "plot_path": "plot",
                "original_n": "derivation-length"}.get(other[0], other[0])
        raise click.UsageError(f"--{name.replace('_', '-')} does not apply to --angles "
                               f"(two angle CSVs of one tree)")


def _read_csv(path: str, degrees: bool):
    """The angles of an angle CSV or an .npz archive (`simulate -o X.npz`)."""
    from plantlod.formats.angles_csv import read_angles_file

    return read_angles_file(path, degrees)


def _run_side(path: str, csv: str | None, n: int | None, degrees: bool, settings):
    """A `Run` of one side: its tree, with angles from its CSV or simulated here; and the
    file its simplify header says it was made from (`level_header.comment_source`), if any."""
    from plantlod.formats.level_header import comment_source

    tree, system = load_tree(path, n, run=None if csv is not None else settings)
    return _run_of(tree, path, csv, n, degrees, settings), \
        None if system is None else comment_source(system.comment)


def _run_of(tree, path: str, csv: str | None, n: int | None, degrees: bool, settings):
    """A `Run` of ``tree`` (read from ``path``), with angles from its CSV or simulated here."""
    from plantlod.compare.runs import Run, angles_in_tree_order

    name = display_name(path) if n is None else f"{display_name(path)} (n={n})"
    if csv is not None:
        times, addresses, bend, rot = _read_csv(csv, degrees)
        bend, rot = angles_in_tree_order(tree, addresses, bend, rot, display_name(csv))
        large = large_file_angles(times, bend, rot, tree.address, display_name(csv), degrees)
        if large is not None:
            warn_once_running(large)
        return Run(tree, times, bend, rot, name, angles=display_name(csv))
    from plantlod.sim.aliasing import aliased
    from plantlod.sim.run import simulate_arrays

    fast = aliased(tree, settings.dt)
    if fast is not None:                     # (simplify says the same of its runs)
        warn_once_running(f"{name}: " + fast.said(f"the runs (every step of {settings.dt:g} s)",
                                                  "compare's figures", "--dt"))
    samples = simulate_arrays(tree, settings.dt, settings.steps, settings.wind,
                              damping=settings.damping)
    from plantlod.sim.angle_range import first_large_angle

    large = first_large_angle(samples.times, samples.bend, samples.rot, tree.address)
    if large is not None:
        warn_once_running(large.message(name))
    return Run(tree, samples.times, samples.bend, samples.rot, name)


# --- outputs ---------------------------------------------------------------------------

def _write_report(comparisons, bounds, violations, as_json: bool, output: str | None,
                  landing=None) -> None:
    """The table or JSON on ``output`` (stdout for None or ``-``); a file is held as a
    temporary in ``landing`` (an ExitStack) where given, landing when it closes."""
    from plantlod.compare import report as fmt

    if as_json:
        text = fmt.dumps(fmt.comparison_document(comparisons, bounds, violations))
    elif output in (None, "-") and is_terminal(sys.stdout):
        from .io import rich_console

        fmt.print_rich(comparisons, rich_console(file=sys.stdout))
        return
    else:
        text = fmt.comparison_text(comparisons)
    if landing is not None:
        landing.enter_context(open_output(output)).write(text)
        return
    with open_output(output) as out:
        out.write(text)


def _summarise(comp) -> None:
    r = comp.report
    say(f"compare: {comp.simplified.name} against {comp.original.name}: "
        f"{counted(len(r.groups), 'group')}, "
        f"{counted(comp.window.stop - comp.window.start, 'sample')}; worst amplitude error "
        f"{_g(r.amplitude_error)}, period error {_g(r.period_error)}, tip error {_g(r.tip_error)}")
    if r.undefined_periods:
        first = r.undefined_periods[0]
        figures = next(g for g in r.groups if g.address == first.address).component(first.component)
        side = (comp.original.name if not math.isfinite(figures.period_original)
                else comp.simplified.name)
        warn(f"{comp.simplified.name}: {len(r.undefined_periods)} counted component(s) have no "
             f"defined period (e.g. group {first.address} {first.component}: {side} crosses "
             f"its mean upward fewer than twice in the {r.t1 - r.t0:g} s window); the period "
             f"error leaves them out; a window of two swings or more measures them (--duration)")


def _g(value: float) -> str:
    return "undefined" if not math.isfinite(value) else f"{value:.4g}"


def _compare_csvs(path_a: str, path_b: str, degrees: bool, atol: float | None, as_json: bool,
                  output: str | None) -> None:
    from plantlod.compare import report as fmt
    from plantlod.compare.runs import angle_differences

    name_a, name_b = display_name(path_a), display_name(path_b)
    times_a, addr_a, bend_a, rot_a = _read_csv(path_a, degrees)
    times_b, addr_b, bend_b, rot_b = _read_csv(path_b, degrees)
    diff = angle_differences(times_a, addr_a, bend_a, rot_a, times_b, addr_b, bend_b, rot_b,
                             name_a, name_b)
    limit = None if atol is None else (math.radians(atol) if degrees else atol)
    if as_json:
        text = fmt.dumps(fmt.difference_document(diff, name_a, name_b, len(times_a), limit))
    else:
        text = fmt.plain_table(fmt.DIFF_HEADERS, fmt.difference_rows(diff))
    with open_output(output) as out:
        out.write(text)
    j, component = diff.worst()
    largest = float(diff.largest[j])
    t = diff.bend_at[j] if component == "bend" else diff.rot_at[j]
    unit, scale = ("deg", 180 / math.pi) if degrees else ("rad", 1.0)
    if limit is not None and largest > limit:       # one line, the summary's figure in it
        raise RunFailure(f"largest angle difference {largest * scale:.4g} {unit} > --atol {atol:g} "
                         f"at branch {diff.addresses[j]} {component}, t = {t:g} s")
    # the new file against the reference, as trees read (SIMPLIFIED against ORIGINAL)
    say(f"compare: {name_b} against {name_a}: {counted(len(addr_a), 'branch')}, "
        f"{counted(len(times_a), 'sample')}; "
        f"largest difference {largest * scale:.4g} {unit} at branch {diff.addresses[j]} "
        f"{component}, t = {t:g} s")
