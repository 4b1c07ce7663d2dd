"""`plantlod simulate`: run the wind model and write the angle CSV."""

from __future__ import annotations

import sys
import time

import click

from plantlod.formats.kinds import OUTPUT_KINDS

from .io import (check_output_kind, check_output_path, count, display_name, distinct_paths,
                 is_terminal, open_output, say, warn)
from .loading import load_tree
from .sim_options import settings_from_kwargs, simulation_options


@click.command()
@click.argument("input_path", metavar="INPUT")
@click.option("-o", "--output", default=None, metavar="OUT.csv",
              help="Write the CSV here (atomically) instead of stdout.")
@simulation_options
@click.option("--every", type=click.IntRange(min=1), default=1, show_default=True,
              help="Keep every K-th step.")
@click.option("--degrees", is_flag=True, help="Write angles in degrees (default radians).")
@click.option("-n", "--derivation-length", "steps_n", type=click.IntRange(min=0), default=None,
              help="Derivation length for .lsys input (default: the file's).")
@click.option("--progress/--no-progress", default=None,
              help="Progress bar on stderr (default: only when stderr is a terminal).")
def simulate(input_path, output, every, degrees, steps_n, progress, **kwargs):
    """Simulate a tree in the wind and write bend and rotation angles as CSV.

    INPUT is an .lsys file (derived here), a tree file from `plantlod derive`,
    or - for either on stdin. The CSV (docs/angles-csv.md) has a column t and,
    per branch, b:ADDRESS and r:ADDRESS; rows start at t = 0.

    \b
    Example:
      plantlod simulate examples/stalk8.lsys --dt 0.01 --duration 10 --wind-speed 5 -o stalk8.csv
      plantlod derive examples/stalk8.lsys | plantlod simulate - --dt 0.01 --steps 1000 --wind 2,0,0
      plantlod simulate examples/stalk8.lsys --dt 0.01 --steps 500 --wind-file gusts.csv --every 10
    (gusts.csv: rows t,vx,vy,vz in m/s, linearly interpolated; docs/model.md, "Winds")
    """
    distinct_paths({"-o": output}, {"INPUT": input_path, "--wind-file": kwargs.get("wind_file")})
    check_output_kind(output, "-o", *OUTPUT_KINDS["angles"])
    check_output_path(output)                   # (a missing folder: before the run, not after)
    settings = settings_from_kwargs(kwargs)
    if every > max(settings.steps, 1):       # (only row 0 was written; the API refused it)
        raise click.BadParameter(f"{every:,} is more than the run's {settings.steps:,} steps; "
                                 f"expected at most {max(settings.steps, 1):,}",
                                 param_hint="'--every'")
    tree, _system = load_tree(input_path, steps_n, run=settings)
    from plantlod.formats.angles_csv import AnglesCsvWriter
    from plantlod.sim.run import simulate as run_simulation
    from plantlod.sim.stability import check_stability

    check_stability(tree, settings.dt, settings.damping)
    show = is_terminal(sys.stderr) if progress is None else progress
    begin = time.perf_counter()
    from plantlod.sim import kernel

    engine = kernel.engine_for(tree, settings.steps)     # the counts only: no flattening
    if engine == "compiled":
        kernel.compiled()          # numba loads here (the cached machine code on the first call)

    start = time.perf_counter()
    from plantlod.sim.angle_range import LargeAngleWatch

    watch = LargeAngleWatch(tree.address)
    chunks = _watched(run_simulation(tree, settings.dt, settings.steps, settings.wind,
                                     every=every, damping=settings.damping), watch,
                      tree, display_name(input_path))
    from plantlod.formats.npz import angles_bytes, is_npz

    if is_npz(output):
        if degrees:
            raise click.UsageError("--degrees applies to CSV output; an .npz holds radians")
        import numpy as np

        parts = list(chunks)
        with open_output(output, binary=True) as out:
            out.write(angles_bytes(np.concatenate([c.times for c in parts]), tree.address,
                                   np.concatenate([c.bend for c in parts]),
                                   np.concatenate([c.rot for c in parts])))
    else:
        with open_output(output) as out:
            writer = AnglesCsvWriter(out, tree.address, degrees=degrees)
            if show:
                _write_with_progress(writer, chunks, settings.steps, settings.dt)
            else:
                for chunk in chunks:
                    writer.write(*chunk)
    if watch.first is not None:
        warn(watch.first.message(display_name(input_path)))
    seconds = time.perf_counter() - start
    branch_steps = tree.n_branches * settings.steps
    rate = branch_steps / seconds if seconds > 0 else float("inf")
    say(f"simulate: {display_name(input_path)}: {count(tree.n_branches, 'branch')}, "
        f"{settings.steps:,} steps of {settings.dt:g} s, {settings.description}, "
        f"{seconds:.2f} s, {rate:,.0f} branch-steps/s with output "
        + (f"(+{start - begin:.2f} s kernel start-up)" if engine == "compiled"
           else "(interpreted kernel: a short run)"))


def _watched(chunks, watch, tree, name: str):
    """The chunks of a run, each shown to ``watch`` (the model's range) on its way out. A run
    that diverges on a tree of absurd size (a branch `F(1e200)`: its drag is 1e200 N) is bad
    input, said as compare and export say it (`compare.runs.check_extent`, exit 2), not a
    divergence whose advice, lower k_FA, the wind or dt, cannot help (session 37's fuzzing)."""
    from plantlod.lsys.errors import RunFailure

    try:
        for chunk in chunks:
            watch.see(chunk.times, chunk.bend, chunk.rot)
            yield chunk
    except RunFailure:
        from plantlod.compare.runs import check_extent

        check_extent(tree, name)
        raise


def _write_with_progress(writer, chunks, steps: int, dt: float) -> None:
    from .io import progress_bar

    with progress_bar() as bar:
        task = bar.add_task("simulating", total=max(steps * dt, 1e-12))
        for chunk in chunks:
            writer.write(*chunk)
            times = chunk[0]
            if len(times):
                bar.update(task, completed=float(times[-1]))
