"""`make lod-family`: pass fractions of levels 1-3 on the generated family of trees (issue 21).

Every tree of bench/tree_family.py in the seed range is derived, simplified at
levels 1, 2 and 3 (`plantlod.simplify.pipeline.simplify`, `--form auto`) and
measured against the original in steady winds of SPEEDS m/s toward DIRECTIONS deg,
from rest, DURATION s at time step DT (model.md section 6's visible figures).
A (tree, level, speed, direction) case passes when it meets the issue's targets:

    level 1: motion <= 5 %, period (major) <= 2 %, tip RMS <= 1 % of the height
    level 2: motion <= 10 %, period (major) <= 4 %, tip RMS <= 2 % of the height
    stalks (chains): relative amplitude and period in place of motion and
    period (major): 2 % and 1 % at level 1, 5 % and 2 % at level 2
    level 3: figures only, no target (ranked by level 2's for the worst case)

Cases where the original's largest combined angle (over the level's groups)
passes SMALL_ANGLE_LIMIT rad are left out (the targets apply below it) and
counted as excluded; a figure that is undefined (nothing counted) does not fail
a case; a level that simplify refuses or that diverges fails all its cases. Each
case also records the original's largest turn of any branch's axis from its rest
direction over the run (`largest_turns`, level-independent): a chain turns its top far
while its groups' combined angles stay small, and a last table splits each level's
counted cases by it (a diagnosis of where the misses are; the pass fractions above
are the counting rule's).

Seeds 0-199 are the tuning range; --held-out measures seeds 1000-1199, the
range nobody tunes on. Output (stdout, and --out FILE.md) is the same for any
--jobs; only the last line (the full command and its wall time) differs from run to run.

    .venv/bin/python bench/lod_family.py [--seeds 0-199 | --held-out] [--jobs N]
                                         [--kinds k1,k2] [--levels 1-3] [--quick] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import pathlib
import statistics
import sys
import time
from dataclasses import dataclass, field

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from lod_table import DT, DURATION, EVERY, LEVEL_TARGETS, SPEEDS, STALK_TARGETS, _pct  # noqa: E402
from tree_family import KINDS, kind_of, parse_kinds, parse_seeds  # noqa: E402

DIRECTIONS = (0.0, 90.0, 200.0, 37.0)       # deg: the axes, and two off any grid
LEVELS = "1-3"
TUNING_SEEDS = "0-199"
HELD_OUT_SEEDS = "1000-1199"
QUICK_PER_KIND = 2                          # --quick: the first trees of each kind in the range
from plantlod.simplify.constants import SMALL_ANGLE_LIMIT  # noqa: E402  (rad: the targets apply below)
FORM = "auto"                               # simplify's --form, every level
RANK_LEVEL = 2                              # levels without targets are ranked by this level's
FIGURES = ("motion_error", "period_error_major", "tip_error", "tip_error_max_m",
           "amplitude_error", "period_error")


@dataclass
class Case:
    """One (tree, level, wind) measurement: the Report figures that count, or the error that
    stopped the level. ``excluded``: the original's largest combined angle passed the limit."""

    tree: str
    kind: str
    seed: int
    level: int
    speed: float
    direction: float
    stalk: bool
    branches: tuple[int, int]                      # original, level
    form: str
    angle: float                                   # the original's largest combined angle, rad
    turn: float                                    # the original's largest axis turn, rad
    figures: dict[str, float] = field(default_factory=dict)
    error: str = ""

    @property
    def excluded(self) -> bool:
        """The original passed SMALL_ANGLE_LIMIT in this wind: the targets do not apply."""
        return not self.error and self.angle > SMALL_ANGLE_LIMIT

    def limits(self, level: int | None = None) -> tuple[tuple[str, float], ...] | None:
        """(figure, bound) pairs of ``level`` (default: this case's), None without targets."""
        level = self.level if level is None else level
        if level not in LEVEL_TARGETS:
            return None
        motion, period, tip = LEVEL_TARGETS[level]
        if self.stalk:
            motion, period = STALK_TARGETS[level]
            return (("amplitude_error", motion), ("period_error", period), ("tip_error", tip))
        return (("motion_error", motion), ("period_error_major", period), ("tip_error", tip))

    def ratio(self) -> float:
        """The worst figure over its bound (this level's, else RANK_LEVEL's): <= 1 passes;
        inf for an error. Undefined figures do not count."""
        if self.error:
            return math.inf
        limits = self.limits() or self.limits(RANK_LEVEL)
        values = [self.figures[name] / bound for name, bound in limits
                  if math.isfinite(self.figures[name])]
        return max(values, default=0.0)

    def passed(self) -> bool | None:
        """True / False against this level's targets; None without targets."""
        return None if self.limits() is None else self.ratio() <= 1.0


def measure_tree(kind: str, seed: int, levels: tuple[int, ...]) -> list[Case]:
    """Every Case of tree (kind, seed): each level simplified and measured in every wind."""
    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys
    from plantlod.simplify.evaluate import Runs, WindCase, simulate_runs
    from plantlod.simplify.explicit import is_stalk
    from plantlod.simplify.pipeline import LevelChain, Options, simplify
    from plantlod.simplify.targets import group_map
    from tree_family import generate

    name = f"{kind}-{seed}"
    system = parse_lsys(generate(kind, seed), f"{name}.lsys")
    original = build(system).tree
    stalk = is_stalk(original)
    winds = [WindCase(s, d) for s in SPEEDS for d in DIRECTIONS]
    steps = int(round(DURATION / DT))
    simulated = list(simulate_runs(original, winds, DT, steps, EVERY))   # once for every level
    turn = dict(zip(winds, largest_turns(original, simulated)))
    cases = []
    chain = LevelChain()          # the levels share the original's runs and level 1's fit
    for level in levels:
        def case(wind, **kw):
            """A Case of this tree and level in ``wind``."""
            return Case(name, kind, seed, level, wind.speed, wind.direction, stalk,
                        turn=turn[wind], **kw)
        try:
            tree = simplify(system, Options(level=level, form=FORM), chain=chain).tree
            runs = Runs(original, group_map(original, tree), winds, DT, steps, EVERY,
                        simulated=simulated)
            reports = runs.compare(tree)
            angles = runs.largest_combined_angle()
        except Exception as exc:     # noqa: BLE001 - refused, diverged or a bug: a row, not the end
            message = (getattr(exc, "message", "") or f"{type(exc).__name__}: {exc}").splitlines()[0]
        else:
            message = ""
        if message:
            cases += [case(w, branches=(original.n_branches, 0), form="–", angle=math.nan,
                           error=message) for w in winds]
            continue
        form = "explicit" if tree.group_root else "grammar"
        for wind, report, angle in zip(winds, reports, angles):
            cases.append(case(wind, branches=(original.n_branches, tree.n_branches), form=form,
                              angle=angle, figures={f: float(getattr(report, f)) for f in FIGURES}))
    return cases


def largest_turns(original, simulated: list, chunk: int = 64) -> list[float]:
    """Per run of ``simulated`` (the original's runs, as `simulate_runs` gives them), the
    largest angle (rad) between any branch's axis R_i e_z and its rest direction over the run:
    atan2(|a x a0|, a . a0), which keeps small angles exact. Poses ``chunk`` samples at once."""
    import numpy as np
    from plantlod.sim.kinematics import pose, rest_pose

    rest = rest_pose(original).frame[:, :, 2]                                   # (B, 3)
    out = []
    for _wind, times, bend, rot in simulated:
        largest = 0.0
        for lo in range(0, len(times), chunk):
            axis = pose(original, bend[lo:lo + chunk], rot[lo:lo + chunk]).frame[..., 2]  # (k, B, 3)
            angle = np.arctan2(np.linalg.norm(np.cross(axis, rest), axis=-1), (axis * rest).sum(-1))
            largest = max(largest, float(angle.max(initial=0.0)))
        out.append(largest)
    return out


def _init_worker() -> None:
    """A pool worker: one numba thread (the pool already uses the cores)."""
    os.environ["NUMBA_NUM_THREADS"] = "1"


def _run(job: tuple[str, int, tuple[int, ...]]) -> tuple[list[Case], float]:
    """measure_tree(*job) and the seconds it took (for the progress lines only)."""
    begin = time.perf_counter()
    cases = measure_tree(*job)
    return cases, time.perf_counter() - begin


def run_all(jobs: list[tuple[str, int, tuple[int, ...]]], workers: int) -> list[Case]:
    """Every job's cases, in the order of ``jobs`` whatever ``workers``. Progress on stderr: a
    rich bar when stderr is a terminal, else a line per tree with its branches and seconds."""
    progress = None
    if sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import Progress
        progress = Progress(console=Console(stderr=True), transient=True)
        progress.start()
        task = progress.add_task("trees", total=len(jobs))
    results: dict[int, list[Case]] = {}

    def done(k: int, outcome: tuple[list[Case], float]) -> None:
        results[k] = outcome[0]
        if progress:
            progress.advance(task)
        else:
            kind, seed, _ = jobs[k]
            size = outcome[0][0].branches[0] if outcome[0] else 0
            print(f"[{len(results)}/{len(jobs)}] {kind}-{seed}: {size} branches, {outcome[1]:.1f} s",
                  file=sys.stderr, flush=True)

    try:
        if workers <= 1:
            for k, job in enumerate(jobs):
                done(k, _run(job))
        else:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor, as_completed
            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                                     initializer=_init_worker) as pool:
                futures = {pool.submit(_run, job): k for k, job in enumerate(jobs)}
                for future in as_completed(futures):
                    done(futures[future], future.result())
    finally:
        if progress:
            progress.stop()
    return [c for k in range(len(jobs)) for c in results[k]]


def _command(argv: list[str]) -> str:
    """The command line, without the options that do not change the tables (--jobs, --out,
    --cases)."""
    kept, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg in ("--jobs", "--out", "--cases"):
            skip = True
        elif not arg.startswith(("--jobs=", "--out=", "--cases=")):
            kept.append(arg)
    return " ".join(["python bench/lod_family.py"] + kept)


def _fraction(cases: list[Case]) -> str:
    """'passed/counted (pct)' over the cases that count (not excluded)."""
    counted = [c for c in cases if not c.excluded]
    if not counted:
        return "–"
    ok = sum(bool(c.passed()) for c in counted)
    return f"{ok}/{len(counted)} ({100 * ok / len(counted):.0f} %)"


def _median_worst(cases: list[Case], name: str, scale: float = 100.0) -> str:
    """'median / worst' of figure ``name`` over the counted cases (x ``scale``)."""
    values = [c.figures[name] for c in cases if not c.excluded and not c.error
              and math.isfinite(c.figures[name])]
    if not values:
        return "–"
    return f"{scale * statistics.median(values):.2f} / {scale * max(values):.2f}"


def tables(cases: list[Case], kinds: tuple[str, ...], levels: tuple[int, ...]) -> list[str]:
    """The markdown lines: pass fractions per kind and level, figures per kind and level, and
    the worst case per kind and level."""
    by = {(k, lv): [c for c in cases if c.kind == k and c.level == lv] for k in kinds for lv in levels}
    present = [k for k in kinds if any(by[(k, lv)] for lv in levels)]
    targeted = [lv for lv in levels if lv in LEVEL_TARGETS]
    lines = ["### Pass fractions (cases within the level's targets / cases that count)", "",
             "| kind | trees | branches (median) | "
             + " | ".join(f"level {lv} | excluded" for lv in targeted) + " |",
             "|---|--:|--:|" + "--:|--:|" * len(targeted)]
    for k in present + ["all"]:
        pick = (lambda lv: [c for c in cases if c.level == lv]) if k == "all" else \
            (lambda lv, k=k: by[(k, lv)])
        some = [c for lv in levels for c in pick(lv)]
        trees = sorted({c.tree for c in some})
        sizes = {c.tree: c.branches[0] for c in some}
        row = [k, str(len(trees)), f"{statistics.median(sizes.values()):g}" if sizes else "–"]
        for lv in targeted:
            sel = pick(lv)
            errors = len({c.tree for c in sel if c.error})
            row += [_fraction(sel) + (f", {errors} trees failed" if errors else ""),
                    str(sum(c.excluded for c in sel))]
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "### Figures over the counted cases (median / worst, per cent; tip max in mm)", "",
              "| kind | level | forms | motion % | period (major) % | tip RMS % height | tip max mm "
              "| stalk amplitude % | stalk period % |",
              "|---|--:|---|--:|--:|--:|--:|--:|--:|"]
    for k in present:
        for lv in levels:
            sel = by[(k, lv)]
            forms = sorted({c.form for c in sel})
            counts = ", ".join(f"{f} {len({c.tree for c in sel if c.form == f})}" for f in forms)
            stalky = [c for c in sel if c.stalk]
            lines.append(f"| {k} | {lv} | {counts} | {_median_worst(sel, 'motion_error')} | "
                         f"{_median_worst(sel, 'period_error_major')} | {_median_worst(sel, 'tip_error')} | "
                         f"{_median_worst(sel, 'tip_error_max_m', 1000.0)} | "
                         f"{_median_worst(stalky, 'amplitude_error')} | {_median_worst(stalky, 'period_error')} |")
    lines += ["", "### Worst case per kind and level (largest figure over its bound; level 3 ranked by "
              f"level {RANK_LEVEL}'s)", "",
              "| kind | level | tree | branches | form | speed m/s | direction deg | angle rad | "
              "motion % | period (major) % | tip % | amplitude % | period % | note |",
              "|---|--:|---|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|---|"]
    for k in present:
        for lv in levels:
            counted = [c for c in by[(k, lv)] if not c.excluded]
            if not counted:
                continue
            w = max(counted, key=lambda c: (c.ratio(), c.tree, c.speed, c.direction))
            f = w.figures
            cells = [k, str(lv), w.tree, f"{w.branches[0]}→{w.branches[1]}", w.form, f"{w.speed:g}",
                     f"{w.direction:g}", f"{w.angle:.3f}" if math.isfinite(w.angle) else "–"]
            cells += [_pct(f.get(n, math.nan)) for n in
                      ("motion_error", "period_error_major", "tip_error", "amplitude_error", "period_error")]
            cells.append(w.error.replace("|", "/")[:120])
            lines.append("| " + " | ".join(cells) + " |")
    lines += turn_split(cases, present, targeted)
    return lines


def turn_split(cases: list[Case], kinds: list[str], levels: list[int]) -> list[str]:
    """Markdown lines: each level's counted cases split by the original's largest axis turn
    (`Case.turn`) at SMALL_ANGLE_LIMIT, passed/counted on each side, per kind."""
    lines = ["", f"### Where the misses are: counted cases by the original's largest axis turn "
             f"(at most / more than {SMALL_ANGLE_LIMIT:g} rad)", "",
             "| kind | " + " | ".join(f"level {lv} turn ≤ {SMALL_ANGLE_LIMIT:g} | level {lv} turn > "
                                      f"{SMALL_ANGLE_LIMIT:g}" for lv in levels) + " |",
             "|---|" + "--:|--:|" * len(levels)]
    for k in kinds + ["all"]:
        row = [k]
        for lv in levels:
            sel = [c for c in cases if c.level == lv and (k == "all" or c.kind == k)]
            low = [c for c in sel if not c.turn > SMALL_ANGLE_LIMIT]
            row += [_fraction(low), _fraction([c for c in sel if c.turn > SMALL_ANGLE_LIMIT])]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def select(seeds: list[int], kinds: tuple[str, ...], quick: bool) -> list[tuple[str, int]]:
    """(kind, seed) of every seed in range whose kind (tree_family.kind_of) is in ``kinds``;
    with ``quick``, only the first QUICK_PER_KIND of each kind."""
    chosen, per_kind = [], {}
    for s in seeds:
        k = kind_of(s)
        if k not in kinds or (quick and per_kind.get(k, 0) >= QUICK_PER_KIND):
            continue
        per_kind[k] = per_kind.get(k, 0) + 1
        chosen.append((k, s))
    return chosen


def main(argv: list[str] | None = None) -> int:
    """The command line: measures the chosen trees, prints the tables; exit status 0."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=parse_seeds, default=None,
                        help=f"seed range A-B (default {TUNING_SEEDS}, the tuning range)")
    parser.add_argument("--held-out", action="store_true",
                        help=f"seeds {HELD_OUT_SEEDS}: the range nobody tunes on")
    parser.add_argument("--kinds", type=parse_kinds, default=KINDS)
    parser.add_argument("--levels", type=parse_seeds, default=parse_seeds(LEVELS))   # a range, as seeds
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (output is the same)")
    parser.add_argument("--quick", action="store_true",
                        help=f"only the first {QUICK_PER_KIND} trees of each kind (smoke test)")
    parser.add_argument("--out", default=None, help="also write the tables (markdown) here")
    parser.add_argument("--cases", default=None,
                        help="also write every case here, one JSON object a line (for analysis)")
    args = parser.parse_args(argv)
    if args.held_out and args.seeds is not None:
        parser.error("--held-out and --seeds: give one of them")
    seeds = parse_seeds(HELD_OUT_SEEDS if args.held_out else TUNING_SEEDS) if args.seeds is None \
        else args.seeds
    levels = tuple(args.levels)
    begin = time.perf_counter()
    chosen = select(seeds, args.kinds, args.quick)
    cases = run_all([(k, s, levels) for k, s in chosen], max(1, args.jobs))
    argv = sys.argv[1:] if argv is None else argv
    head = [f"`{_command(argv)}` — {len(chosen)} trees (seeds {seeds[0]}-{seeds[-1]}, kind = "
            f"kinds[seed % {len(KINDS)}]), levels {', '.join(map(str, levels))} (--form {FORM}); "
            f"winds {', '.join(f'{s:g}' for s in SPEEDS)} m/s toward "
            f"{', '.join(f'{d:g}' for d in DIRECTIONS)}°, dt {DT} s, {DURATION:g} s from rest; "
            f"cases whose original passes {SMALL_ANGLE_LIMIT:g} rad are excluded", ""]
    lines = head + tables(cases, tuple(k for k in KINDS if k in args.kinds), levels)
    print("\n".join(lines), flush=True)
    if args.out:
        pathlib.Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    if args.cases:
        pathlib.Path(args.cases).write_text("".join(
            json.dumps(dataclasses.asdict(c), sort_keys=True) + "\n" for c in cases), encoding="utf-8")
    print(f"\n`python bench/lod_family.py {' '.join(argv)}`: wall time "
          f"{time.perf_counter() - begin:.0f} s ({len(chosen)} trees)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
