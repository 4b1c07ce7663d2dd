"""`plantlod scene`: a forest, every tree at the level its camera distance allows (docs/scene.md)."""

from __future__ import annotations

import contextlib
import json
import sys

import click

from plantlod.lsys.words import counted

from .discipline import given
from .io import (check_output_folder, check_output_kind, check_output_path, distinct_paths,
                 is_terminal, open_output, output_folder, reader_gone_after, say, warn,
                 warn_once_running)


@click.command()
@click.argument("scene_path", metavar="SCENE.toml")
@click.option("--report", "report_path", default="-", show_default=True, metavar="FILE",
              help="Write the report (JSON) here; - for stdout.")
@click.option("--verify", is_flag=True,
              help="Also run every tree at full detail and measure the error spent, in pixels.")
@click.option("--verify-sample", "sample", type=click.IntRange(min=1), default=None, metavar="N",
              help="With --verify: verify about N trees, every level and distance band "
                   "represented, instead of all (for big scenes).")
@click.option("--budget", "budget_px", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Pixel budget (overrides the scene's budget_px).")
@click.option("--cache", "cache_dir", default=None, metavar="DIR",
              help="Folder of cached level chains (default: $PLANTLOD_CACHE, else "
                   "$XDG_CACHE_HOME/plantlod or ~/.cache/plantlod).")
@click.option("--no-cache", is_flag=True, help="Simplify every tree file anew; keep nothing.")
@click.option("--angles", "angles_path", default=None, metavar="STORE.zarr",
              help="Also write every tree's angles at its level (zarr, float32, chunked by batch and time).")
@click.option("--plot", "plot_path", default=None, metavar="FILE.png",
              help="A picture: the scene from above coloured by level, and the cost against full detail.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the batches on the Dask cluster of this scheduler (tcp://host:8786).")
@click.option("--frame-rate", type=click.FloatRange(min=0, min_open=True, max=10000), default=30.0,
              show_default=True, help="Frames per second: levels are chosen (and errors "
              "verified) per frame.")
@click.option("--threads", type=click.IntRange(min=1), default=None,
              help="Engine threads (default: every core, or $PLANTLOD_THREADS); same output for any.")
@click.option("--progress/--no-progress", "show_progress", default=None,
              help="Progress bar on stderr (default: only when stderr is a terminal).")
@click.option("--run-info", is_flag=True,
              help="Add \"run\" to the report: chains from the cache, wall seconds, simulated "
                   "seconds per wall second (facts of this run, not the same from run to run).")
def scene(scene_path, report_path, verify, sample, budget_px, cache_dir, no_cache, angles_path,
          plot_path, scheduler, frame_rate, threads, show_progress, run_info):
    """Run a scene of many trees, each at the coarsest level within the pixel budget.

    SCENE.toml places trees (explicitly or scattered), the wind and a camera
    (docs/scene.md). Each distinct tree file (and seed a tree gives it) is simplified
    into its chain of levels once (cached); each tree then runs at the coarsest level whose tip error, seen
    from the camera, stays within the budget (model.md section 7).

    \b
    Example:
      plantlod scene examples/forest.toml --verify --report -
    """
    import dataclasses
    import pathlib

    from plantlod.scene.file import read_scene
    from plantlod.scene.levels import default_cache
    from plantlod.scene.run import check_frame_rate, check_scene, run_scene

    if no_cache and cache_dir is not None:
        raise click.UsageError("--cache and --no-cache do not go together")
    if cache_dir == "":                     # (it fell back to the default cache, unsaid)
        raise click.UsageError("--cache needs a folder name; got an empty one")
    if scheduler is not None:
        from plantlod.scene.run import check_scheduler_address

        check_scheduler_address(scheduler)
    for path in (report_path, plot_path):
        check_output_path(path)                 # refuse an unwritable output before running
    report_name = "--report" if given(click.get_current_context(), "report_path") \
        else "the report (no --report)"
    distinct_paths({report_name: report_path, "--plot": plot_path, "--angles": angles_path},
                   {"SCENE.toml": scene_path})
    check_output_kind(report_path, "--report", "the report (JSON)", (".json", ".txt"))
    check_output_kind(plot_path, "--plot", "a PNG picture", (".png",))
    check_output_kind(angles_path, "--angles", "a Zarr store (a folder)", (".zarr",))
    if plot_path is not None:                # (as compare: not after minutes of work)
        from plantlod.compare.plot import require_matplotlib

        require_matplotlib()
    if sample is not None and not verify:
        raise click.UsageError("--verify-sample N goes with --verify")
    if angles_path is not None:
        import os

        check_output_folder(angles_path, "--angles", "a Zarr store", parents=False)
        if os.path.lexists(angles_path):
            raise click.UsageError(f"--angles {angles_path} exists; expected a new path")
    spec = read_scene(scene_path)
    if budget_px is not None:
        spec = dataclasses.replace(spec, budget_px=budget_px)
    # the tree files the scene reads are inputs too (`--report treeA` replaced one; one key
    # per file: a key shared by every file checked only the last, session 42's fuzzing)
    distinct_paths({report_name: report_path, "--plot": plot_path},
                   {f"tree file {k + 1} of {scene_path}": str(p)
                    for k, p in enumerate(dict.fromkeys(t.source[0] for t in spec.trees))})
    check_scene(spec)
    check_frame_rate(spec, frame_rate, given=given(click.get_current_context(), "frame_rate"))
    cache = None if no_cache else (pathlib.Path(cache_dir) if cache_dir else default_cache())
    if cache is not None:
        check_cache_folder(cache)
        if angles_path is not None:
            _apart(cache, angles_path)
    if spec.wind.speed == 0:                 # (a missing [wind] is no wind: a still forest)
        warn_once_running("the wind is zero, so the trees stay at rest; give [wind] speed = S "
                          "(m/s) in the scene")
    show = is_terminal(sys.stderr) if show_progress is None else show_progress
    bar = _ProgressBar() if show else None

    def progress(stage: str, done: int, total: int, what: str) -> None:
        if bar is not None:
            bar.show(stage, done, total, what)

    with contextlib.ExitStack() as stack:
        tmp = None
        if angles_path is not None:     # a new zarr store: in place only when every output is
            tmp = stack.enter_context(output_folder(angles_path, suffix=".zarr"))
        try:
            report = run_scene(spec, cache=cache, threads=threads, verify=verify,
                               progress=progress, store_path=tmp, scheduler=scheduler,
                               frame_rate=frame_rate, sample=sample)
        except BaseException:
            if tmp is not None:             # the store's writes in flight end before it goes
                from plantlod.scene.store import settle_writes

                settle_writes()
            raise
        finally:
            if bar is not None:
                bar.stop()
        facts = {key: report.pop(key) for key in RUN_FACTS}
        if run_info:
            report["run"] = facts
        gone = _write_outputs(spec, report, plot_path, report_path, frame_rate, stack)
    if gone is not None:                     # (the picture and the store landed: `| head`)
        raise gone
    say(f"scene: {counted(report['trees'], 'tree')}, {report['branch_steps_spent']:,} of "
        f"{report['branch_steps_full']:,} branch-steps ("
        + (f"{report['speedup']:.1f}x fewer)" if report["branch_steps_spent"] else "no branches)")
        + (f", verified max error {report['max_error_px']:.3f} px" if verify else "")
        + f", {facts['wall_s']:.1f} s")
    from plantlod.scene.constants import HELD_NOTE_RATIO

    bound = report.get("speedup_bound")
    if report["speedup"] and bound and report["speedup"] < HELD_NOTE_RATIO * bound:
        # (a camera driving up to two trees ran them at full detail from 60 m, 1.0x against
        # a bound of 1.74x, and nothing said why: a newcomer's first hour)
        say(f"scene: {bound:.1f}x if switching were free (speedup_bound): trees start or stay "
            "finer than their distance needs where a later switch to a finer level would "
            "overspend the budget (docs/scene.md, \"Switching\")")
    if verify and report["max_error_px"] is not None and report["max_error_px"] > spec.budget_px:
        warn(f"the verified max error {report['max_error_px']:.3f} px is above the budget of "
             f"{spec.budget_px:g} px: a level's tip error was measured over eight headings "
             "from rest, and this scene's trees or its switches back to finer levels (a "
             "predicted state) cost more (docs/scene.md, \"Where the budget does not hold\")")


# What the report leaves out unless --run-info asks: facts of one run (the cache's state, the
# machine's speed), so that the report is the same bytes for the same scene, as every other
# output is (they were always in it until session 35; a helper's fuzzing)
RUN_FACTS = ("chains_from_cache", "simulated_seconds_per_wall_second", "wall_s")


def _write_outputs(spec, report: dict, plot_path, report_path, frame_rate: float,
                   landing) -> BrokenPipeError | None:
    """The picture (with --plot) and the report; takes the private keys out of ``report``.
    The picture (and a report file) are held in ``landing`` (an ExitStack, with the
    --angles store) and land together when it closes; a report on standard output is written
    before that, so a full disk there leaves no picture (session 35); a reader gone there is
    returned (`reader_gone_after`), for the caller to raise once the rest has landed."""
    levels = report.pop("_levels")
    in_use = report.pop("_branches_in_use")
    if plot_path is not None:
        from plantlod.scene.plot import scene_png
        from plantlod.scene.run import frame_steps

        png = scene_png(spec, levels, in_use, report["branches_full"],
                        frame_steps(spec, frame_rate) * spec.dt)
        landing.enter_context(open_output(plot_path, binary=True)).write(png)
    text = json.dumps(report, indent=2, sort_keys=False) + "\n"
    if report_path not in (None, "-"):
        landing.enter_context(open_output(report_path)).write(text)
        return None

    def write() -> None:
        with open_output(report_path) as out:
            out.write(text)

    return reader_gone_after(write)


class _ProgressBar:
    """rich progress on stderr (a terminal only): one task while a file's levels are
    fitted ("levels: FILE, level k of n"), then one for the batches."""

    def __init__(self):
        from .io import compiling_shown, progress_bar

        self.bar = progress_bar()
        self.bar.start()
        self.held = contextlib.ExitStack()
        self.held.enter_context(compiling_shown(self.bar))
        self.tasks: dict[str, int] = {}

    def show(self, stage: str, done: int, total: int, what: str) -> None:
        label = f"levels: {what}, level {done} of {total}" if stage == "levels" else "batches"
        key = f"{stage}:{what}"
        if key not in self.tasks:
            self.tasks[key] = self.bar.add_task(label, total=total)
        self.bar.update(self.tasks[key], description=label,
                        completed=done if stage == "batches" else done - 1)

    def stop(self) -> None:
        self.held.close()
        self.bar.stop()


def check_cache_folder(cache) -> None:
    """Refuse, before any work, a cache path that is not a folder and cannot become one: the
    path itself, or the nearest of its parents that exists, is not a folder (a link that
    leads nowhere, or round in a loop, too). They failed at mkdir, after the fit, exit 1."""
    from plantlod.lsys.errors import InputError

    why = ("expected a folder for the cached level chains (--cache DIR, $PLANTLOD_CACHE) or "
           "--no-cache")
    if (cache.exists() or cache.is_symlink()) and not cache.is_dir():
        raise InputError(f"not a folder; {why}", str(cache))
    for parent in cache.parents:
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                raise InputError(f"{parent} is not a folder, so no cache can be made in it; "
                                 f"{why}", str(cache))
            return


def _apart(cache, angles_path: str) -> None:
    """Refuse, before any work, a cache folder and a new --angles store at one path or one
    inside the other: the cache made the store's folder first, and the whole scene ran
    before the store could not be placed (session 42's fuzzing)."""
    import pathlib

    a, c = pathlib.Path(angles_path).resolve(), pathlib.Path(cache).resolve()
    if a == c or a in c.parents or c in a.parents:
        raise click.UsageError(f"--cache {cache} and --angles {angles_path} share a path; "
                               "expected the cache outside the store and the store outside the "
                               "cache")
