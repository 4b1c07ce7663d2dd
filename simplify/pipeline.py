"""`simplify`: from an L-system and a level to the level-n L-system and its measured errors.

Steps: check the level; build the original; make the level-n skeleton (with
equivalent leaves where the level-n tree loses leaves, for the derived
method); compute the parameters (`closed_form` or `thesis`); write them per
symbol or per address; optionally calibrate; read the written text back and
measure it against the original over the calibration winds (section 6); put
those figures in the file's header comment.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from plantlod.formats.level_header import DAMPING_RATIO_LINE, HEADER_START, RUNS_LINE
from plantlod.formats.lsys_file import with_header_comment, write_lsys
from plantlod.lsys.build import build
from plantlod.lsys.checks import did_you_mean, flag, real, whole
from .constants import CALIBRATION_EVALUATIONS
from .constants import SIMPLIFY_DT
from .constants import SIMPLIFY_DURATION
from .constants import SIMPLIFY_EVERY
from .constants import SIMPLIFY_WIND_RANGE
from .constants import MAX_LEVEL
from .constants import MAX_SIMPLIFY_STEPS
from .constants import LEVEL_RATIO
from plantlod.lsys.errors import InputError, warn_caller
from plantlod.lsys.parse import parse_lsys
from plantlod.lsys.system import LSystem
from plantlod.lsys.tree import Tree
from plantlod.sim.damping import Damping
from plantlod.sim.stability import check_stability, largest_stable_s

from .bounds import bounds_score, form_rank
from .constants import SMALL_ANGLE_LIMIT
from .calibrate import calibrate
from .targets import GroupMap, group_map
from .closed_form import closed_form
from .evaluate import Runs, Summary, WindCase, summarize, wind_cases
from .levels import check_level, check_moves, level_system, round_sig, write_parameters
from plantlod.compare.measures import Report
from .thesis import thesis_parameters
from .finite import finite_fit
from plantlod.lsys.words import counted

if TYPE_CHECKING:
    from .grouping import Grouping

METHODS = ("derived", "thesis")
FORMS = ("auto", "grammar", "explicit")


@dataclass
class Options:
    """What `simplify` does.

    level        : n >= 1: below the derivation length N in the grammar form (N - n steps),
                   up to the explicit form's last level there (one branch per root)
    method       : "derived" (closed form) or "thesis"
    calibrate    : refine against simulated series (derived method only)
    wind_range   : (low, high) m/s of the measurement and calibration winds
    dt, duration : time step and run length (s) of those runs
    every        : keep every k-th step when measuring
    max_evaluations : calibration budget (candidate evaluations)
    form         : "grammar" (model.md 5: same productions, N - n steps), "explicit"
                   (groups merged from the tips, chords), or "auto": the grammar form
                   where it meets the level's bounds (`LEVEL_BOUNDS`), else the explicit form
    damping_ratio: ζ of model.md 4 under which the level is fitted and measured (0: undamped)
    flags        : messages name the options as the CLI's flags (``--dt``), else as the API's
                   keywords (``dt``); `spelled`
    """

    level: int
    method: str = "derived"
    calibrate: bool = False
    wind_range: tuple[float, float] = SIMPLIFY_WIND_RANGE
    dt: float = SIMPLIFY_DT
    duration: float = SIMPLIFY_DURATION
    every: int = SIMPLIFY_EVERY
    max_evaluations: int = CALIBRATION_EVALUATIONS
    form: str = "auto"
    damping_ratio: float = 0.0
    flags: bool = field(default=False, repr=False, compare=False)   # messages name CLI flags

    def spelled(self, name: str, value: object = None) -> str:
        """Option ``name`` (with ``value``) as the caller wrote it: ``--dt``, ``--method derived``
        and ``--calibrate`` for the CLI (``flags``), ``dt``, ``method='derived'`` and
        ``calibrate=True`` for the API."""
        if self.flags:
            flag = "--" + name.replace("_", "-")
            return flag if value is None or isinstance(value, bool) else f"{flag} {value}"
        return name if value is None else f"{name}={value!r}"

    def __post_init__(self) -> None:
        from plantlod.sim.constants import MAX_TIME_STEPS, MAX_WIND_SPEED
        from plantlod.sim.damping import as_damping
        from plantlod.sim.run import step_count

        # (no tree has that many levels; a numpy integer is kept as an int, since the level's
        # derivation length is computed from it)
        self.level = whole("level", self.level, low=1, high=MAX_LEVEL)
        for name, value, choices in (("method", self.method, METHODS), ("form", self.form, FORMS)):
            # (a str first: an array compared with the choices has no single truth value)
            if not isinstance(value, str) or value not in choices:
                raise InputError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
        flag("calibrate", self.calibrate)
        if not isinstance(self.wind_range, (tuple, list)) or len(self.wind_range) != 2:
            raise InputError(f"wind_range must be (low, high) in m/s, got {self.wind_range!r}")
        for value in self.wind_range:           # (its own bounds, not a measurement wind's)
            real("wind_range", value, low=0, low_open=True, high=MAX_WIND_SPEED)
        if self.wind_range[0] > self.wind_range[1]:     # (it was blamed on the run's length)
            raise InputError(f"{self.spelled('wind_range')} must be (low, high) with low <= "
                             f"high, got {self.wind_range[0]:g} and {self.wind_range[1]:g}")
        for name, value in (("dt", self.dt), ("duration", self.duration),
                            ("damping_ratio", self.damping_ratio)):
            real(name, value)
        as_damping(0.0, self.damping_ratio or None)      # ζ checked as every run checks it
        whole("every", self.every, low=1, high=MAX_TIME_STEPS)
        whole("max_evaluations", self.max_evaluations, low=1, high=MAX_TIME_STEPS)
        dt, duration = self.spelled("dt"), self.spelled("duration")
        steps = step_count(self.dt, self.duration, dt, duration)
        if steps > MAX_SIMPLIFY_STEPS:
            raise InputError(f"{duration} {self.duration:g} s at {dt} {self.dt:g} s gives "
                             f"{steps:,} steps; simplify measures runs of at most "
                             f"{MAX_SIMPLIFY_STEPS:,} steps (the default: "
                             f"{round(SIMPLIFY_DURATION / SIMPLIFY_DT):,}); expected a larger "
                             f"{dt} or a shorter {duration}")
        if self.duration < 2 * self.every * self.dt:    # (a period needs two kept samples)
            # (the API's every too: the CLI keeps every 4th step and has no flag for it)
            kept, or_every = (("", "") if self.flags else
                              (f" (two kept samples at every={self.every})", " or a smaller every"))
            raise InputError(f"{duration} {self.duration:g} s at {dt} {self.dt:g} s gives fewer "
                             f"than {2 * self.every} steps to measure the motion in{kept}; "
                             f"expected a longer {duration}, a smaller {dt}{or_every}")

    def winds(self) -> list[WindCase]:
        return wind_cases(*self.wind_range)

    @property
    def damping(self):
        """The runs' damping (`plantlod.sim.damping.Damping`)."""
        from plantlod.sim.damping import as_damping

        return as_damping(0.0, self.damping_ratio or None)

    @property
    def steps(self) -> int:
        return int(round(self.duration / self.dt))


@dataclass
class Result:
    """The level-n system, its text (header comment included) and the figures in that header."""

    text: str
    original: Tree
    tree: Tree
    reports: list[tuple[WindCase, Report]]
    summary: Summary
    notes: list[str] = field(default_factory=list)
    largest_angles: list[float] = field(default_factory=list)   # per wind, rad (Runs)
    comment: str | None = None               # the header comment (`header_comment`)
    source: str | None = None                # the original's file, for messages
    _system: LSystem | None = field(default=None, repr=False)

    @property
    def system(self) -> LSystem:
        """The level's system, its ``comment`` the header: read from ``text`` when first
        asked for (an explicit level of thousands of branches takes about a second to read,
        and the command writes ``text`` only)."""
        if self._system is None:
            self._system = replace(parse_lsys(self.text, self.source), comment=self.comment)
        return self._system


def check_measurement_memory(original: Tree, options: Options) -> None:
    """Refuse (InputError) measurement runs whose angles would pass the memory limit of a
    held run (`sim.run.check_held_angles`): simplify holds the original's angles in every one
    of its winds at once, (winds, steps // every + 1, branches), before they are allocated."""
    from plantlod.sim.run import check_held_angles

    try:
        check_held_angles(options.steps // options.every + 1, original.n_branches,
                          lanes=len(options.winds()))
    except InputError as exc:
        names = [options.spelled("duration"), options.spelled("dt")] \
            + ([] if options.flags else [options.spelled("every")])     # (no CLI option)
        raise InputError(str(exc).split("; expected")[0] + f"; expected another "
                         f"{', '.join(names[:-1])} or {names[-1]}, or a tree of fewer branches"
                         ) from None


def _check_something_merges(original: Tree, simplified: Tree, gmap: GroupMap, source) -> None:
    sizes = np.bincount(gmap.groups[gmap.groups >= 0], minlength=simplified.n_branches)
    if np.all(sizes <= 1) and original.n_leaves == simplified.n_leaves \
            and original.n_branches == simplified.n_branches:
        raise InputError("nothing to merge: the level-n tree has the same branches and leaves as "
                         "the original; expected productions that add branches in the last steps",
                         source)


def simplify(system: LSystem, options: Options,
             progress: Callable[[str, float], None] | None = None,
             chain: "LevelChain | None" = None) -> Result:
    """Simplify ``system`` to ``options.level`` in ``options.form``. Raises InputError for bad input.
    chain: what the caller's earlier levels of this tree left to share (`LevelChain`)."""
    # --calibrate refines the grammar form only: under --form auto the calibrated grammar
    # form competes with the explicit form as derived (it used to be taken unmeasured against
    # it: examples/eval/bent_leafy's level 1 went from the explicit form's 0.22 % tip error
    # to the calibrated grammar form's 15 %, with no word of why)
    explicit_options = replace(options, calibrate=False) if options.form == "auto" else options
    calibrate = options.spelled("calibrate", True)

    def run_explicit(grouping: int | None = None) -> Result:
        return simplify_explicit(system, explicit_options, progress, grouping=grouping,
                                 chain=chain)

    if options.form == "explicit":
        return run_explicit()
    if options.form == "grammar" or options.method != "derived":
        return simplify_grammar(system, options, progress)
    plan = chain_plan(system, options.level)
    if options.calibrate and (plan.grammar_fits is False
                              or options.level >= system.derivation_length):
        why = ("has no such level" if options.level >= system.derivation_length
               else "would keep more than 60 % of a finer level's branches")
        raise InputError(f"{calibrate} refines the grammar form, and level {options.level} of "
                         f"this tree is explicit (the grammar form {why}); expected it without "
                         f"{calibrate}", system.source or None)
    if plan.grammar_fits is False or options.level >= system.derivation_length:
        result = run_explicit(plan.explicit_grouping)
        if options.level < system.derivation_length:
            result.notes.insert(0, "explicit form: the grammar form would keep more than "
                                   "60 % of a finer level's branches (model.md 5)")
        else:
            result.notes.insert(0, f"explicit form: the grammar form has no level "
                                   f"{options.level} (it derives N - n steps, and N is "
                                   f"{system.derivation_length})")
        return result
    try:
        grammar = simplify_grammar(system, options, progress)
    except InputError as exc:               # the grammar form cannot follow this tree
        if options.calibrate:               # (and nothing else takes the calibration)
            raise
        result = run_explicit(plan.explicit_grouping)
        result.notes.insert(0, f"explicit form: the grammar form does not apply ({exc.message})")
        return result
    from .explicit import is_stalk

    stalk = is_stalk(grammar.original)          # a chain is held to the relative bounds
    grammar_score = bounds_score(grammar.reports, options.level, grammar.largest_angles, stalk)
    if grammar_score <= 1.0:
        grammar.notes.insert(0, "grammar form: it meets the level's bounds in the winds they "
                                "apply to (the original's combined angles under 0.1 rad)")
        return grammar
    try:
        explicit = run_explicit(plan.explicit_grouping)
    except InputError as exc:
        grammar.notes.insert(0, f"grammar form: it misses the level's bounds and the explicit "
                                f"form does not apply ({exc.message})")
        return grammar
    explicit_rank = form_rank(explicit.reports, options.level, explicit.largest_angles, stalk)
    if explicit_rank < form_rank(grammar.reports, options.level, grammar.largest_angles, stalk):
        if explicit_rank[0] == 0:
            explicit.notes.insert(0, "explicit form: the grammar form misses the level's bounds "
                                     f"({_bounds_text(grammar.reports)})")
        else:                               # (form_rank: the winds missed first, then by how much)
            explicit.notes.insert(0, "explicit form: both forms miss the level's bounds, the "
                                     "explicit form in fewer winds or by less (grammar: "
                                     f"{_bounds_text(grammar.reports)}; explicit: "
                                     f"{_bounds_text(explicit.reports)})")
        if options.calibrate:               # (the API heard nothing of it: a warning is said)
            explicit.notes.insert(1, f"warning: {calibrate} was not applied: it refines the "
                                     f"grammar form only, and the explicit form was chosen")
        return explicit
    grammar.notes.insert(0, "grammar form: both forms miss the level's bounds, the grammar form "
                            f"less ({_bounds_text(grammar.reports)}; explicit: "
                            f"{_bounds_text(explicit.reports)})")
    return grammar


@dataclass(frozen=True)
class ChainPlan:
    """What `--form auto` may use at one level so that a chain only gets coarser.

    budget            : the most branches level n may have: the fewest that any form has at
                        any finer level k < n (the original at k = 0)
    grammar_fits      : the grammar form's level n has at most LEVEL_RATIO x ``budget``
                        branches, model.md 5's 60 % (None: the grammar form does not apply
                        at this level)
    explicit_grouping : the explicit grouping (an index into `explicit.merge_levels`) for level
                        n: level n's own, or the first coarser one within ``budget``; None
                        past the explicit form's last level
    """

    budget: int
    grammar_fits: bool | None
    explicit_grouping: int | None


def chain_plan(system: LSystem, level: int) -> ChainPlan:
    """The `ChainPlan` of ``level``: counts only (derivations and groupings, no fit), so that
    level n + 1 never has more branches than level n, whichever form each level takes.

    Each form's count falls with the level (the grammar form derives fewer steps, each
    explicit grouping keeps at most 60 % of the one before), but across forms it need not:
    a tree whose last steps add few branches has a grammar level above the explicit level
    before it. Any level chosen within ``budget`` has no more branches than any choice at
    a finer level, since ``budget`` is the minimum over every form there.
    """
    from .grouping import level_counts

    original = build(system).tree
    explicit_counts = level_counts(original)                # index k: level k's groups
    n = system.derivation_length

    def grammar_count(k: int) -> int | None:
        if not 1 <= k < n:
            return None
        try:
            return build(replace(system, derivation_length=n - k, overrides=())).tree.n_branches
        except InputError:
            return None

    budget = original.n_branches
    for k in range(1, level):
        counts = [c for c in (grammar_count(k),
                              explicit_counts[k] if k < len(explicit_counts) else None) if c]
        budget = min([budget, *counts])
    own = grammar_count(level)
    # (a grammar level whose last step added few branches is hardly coarser: family stalk-162
    # 80 -> 79, monopodial-37 235 -> 189; it is held to the explicit form's 60 % too, with no
    # floor of one branch: one branch whose steps grow only leaves gave a "level 1" of 1 -> 1
    # branch while --levels said the tree has none, session 38)
    fits = None if own is None else own <= math.floor(LEVEL_RATIO * budget)
    if level >= len(explicit_counts):           # past the explicit form's last level
        return ChainPlan(budget, fits, None)
    grouping = level
    while grouping < len(explicit_counts) - 1 and explicit_counts[grouping] > budget:
        grouping += 1
    return ChainPlan(budget, fits, grouping)


def _bounds_text(reports: list[tuple[WindCase, Report]]) -> str:
    worst = lambda name: max((getattr(r, name) for _, r in reports  # noqa: E731
                              if math.isfinite(getattr(r, name))), default=math.nan)
    return (f"motion {_percent(worst('motion_error'))}, period {_percent(worst('period_error_major'))}, "
            f"tip {_percent(worst('tip_error'))} of the height")


class InBackground:
    """``work()`` run on a daemon thread from the start, its value (or its exception) taken by
    `result`. The original's runs go there while the level's statics are fitted: the lanes
    kernel releases the GIL (`plantlod.sim.lanes_kernel`), the static fits call no parallel
    kernel, and neither reads what the other writes, so the output is the same as in order.
    A daemon thread, not a `concurrent.futures` pool: a pool's worker is joined at exit, so a
    refused input or a signal would wait for the runs to end before the command exits."""

    def __init__(self, work: Callable[[], object]):
        self._value, self._error = None, None
        self._thread = threading.Thread(target=self._run, args=(work,), daemon=True,
                                        name="plantlod-original-runs")
        self._thread.start()

    def _run(self, work) -> None:
        try:
            self._value = work()
        except BaseException as exc:          # handed to the caller of result()
            self._error = exc

    def result(self):
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value


@dataclass
class LevelChain:
    """What the levels of one tree share when a caller simplifies them one at a time, with the
    same options but the level (`simplify`'s ``chain``; bench/lod_family.py): the first
    explicit level's `ChainShare` (the original built, grouped to its last level and simulated,
    and level 1 regrouped and fitted), so a later level neither runs the original again nor
    fits level 1 again. Each level's text is the one it gets alone."""

    share: "ChainShare | None" = None


@dataclass
class ChainShare:
    """What every explicit level of one tree shares, so that a chain (``--levels``) builds,
    groups and simulates the original once: the original tree, its groupings
    (`grouping.merge_levels`) and its runs in the measurement winds (`Options.winds`, an
    `evaluate.simulate_runs` list) that each level is fitted to motion and measured against,
    simulated in the background (`InBackground`; `measure` waits for them).
    The runs are kept as float32 angles (rounding 6e-8 relative; 4,096 branches' 16 runs of
    501 samples take 0.13 GB so)."""

    original: Tree
    groupings: list                # levels 0 to the last, or to the level asked for (`up_to`)
    runs: InBackground             # (or anything whose result() gives the runs: `chain_workers`)
    tips: dict = field(default_factory=dict)   # the original's group tips per run (`evaluate.Runs`)
    regrouped: bool = False        # level 1's grouping chosen by its fitted level (`regroup`)
    level_one: tuple | None = None  # ... and that level's (text, tree), where it was fitted
    _reader: Callable | None = field(default=None, repr=False)

    @property
    def measure(self) -> list:
        return self.runs.result()

    def runs_for(self, options: Options) -> Callable[[Tree], "Runs"]:
        """`motion_fit.shared_runs` over these runs: the original's `Runs` read with a level's
        groups, one reader for every level of the chain (a chain's levels share the options
        but the level)."""
        if self._reader is None:
            from .motion_fit import shared_runs

            self._reader = shared_runs(self.original, options.winds(), options.dt, options.steps,
                                       options.every, options.damping, lambda: self.measure,
                                       self.tips)
        return self._reader

    @property
    def last(self) -> int:
        """The explicit form's last level (``groupings`` may stop before it)."""
        from .grouping import level_counts

        return len(level_counts(self.original)) - 1


def explicit_levels_said(last: int, roots: int) -> str:
    """How many explicit levels a tree has, for a message: ``last`` (the last level's number)
    and ``roots``, its root branches (groups never join two roots, so the chain ends at one
    branch per root)."""
    end = "a single branch" if roots == 1 else f"one branch per root branch, {roots}"
    if last == 0:
        return (f"this tree has no levels in the explicit form (it is already "
                f"{'a single branch' if roots == 1 else f'{roots} root branches'})")
    if last == 1:
        return f"this tree has 1 level in the explicit form (level 1, {end})"
    return f"this tree has {last} levels in the explicit form (1 to {last}, the last {end})"


def roots(tree: Tree) -> int:
    """The root branches of ``tree`` (parent -1)."""
    return int(np.count_nonzero(np.asarray(tree.parent) < 0))


def chain_share(system: LSystem, options: Options, last_checked=None,
                built: tuple[Tree, list] | None = None, up_to: int | None = None) -> ChainShare:
    """Build, check, group and simulate the original of ``system`` once (`ChainShare`; the
    simulation goes on in the background). Raises InputError for a tree without branches or
    one unstable at ``options.dt``.
    last_checked: called with the explicit form's last level before the groupings and the
    simulation (a caller's own checks, so that bad input is refused before they are paid for).
    built: (original, groupings) where the caller has them already.
    up_to: the last level to group (one level needs no coarser ones), default all."""
    from .evaluate import simulate_runs
    from .grouping import level_counts, merge_levels

    original = build(system).tree if built is None else built[0]
    # the memory check first: it costs nothing, where check_moves poses the tree at rest, a
    # loop per depth (an axiom of 999,000 F, refused by the memory check, ran past 10 min
    # posing first; an L-system fuzzing round)
    check_measurement_memory(original, options)
    check_moves(original, system.source or None)
    check_stability(original, options.dt, options.damping)
    last = len(level_counts(original)) - 1
    if last_checked is not None:
        last_checked(last)
    groupings = merge_levels(original, up_to=up_to) if built is None else built[1]

    def runs() -> list:
        return [(wind, times, bend.astype(np.float32), rot.astype(np.float32))
                for wind, times, bend, rot in simulate_runs(
                    original, options.winds(), options.dt, options.steps, options.every,
                    options.damping)]

    return ChainShare(original, groupings, InBackground(runs))


@finite_fit
def simplify_explicit(system: LSystem, options: Options,
                      progress: Callable[[str, float], None] | None = None,
                      grouping: int | None = None, shared: ChainShare | None = None,
                      chain: "LevelChain | None" = None) -> Result:
    """The explicit form of model.md 5 (simplify/explicit.py), measured like the grammar form.

    grouping: the explicit grouping to use (an index into `explicit.merge_levels`), default
    the level's own; `chain_plan` gives a coarser one where a finer level has fewer branches.
    shared: the original, its groupings and runs (`chain_share`) for these options, when a
    chain shares them; chain: where the first level of a caller's `LevelChain` leaves them
    (every level grouped) for the levels after it.
    """
    source = system.source or None
    if options.method != "derived" or options.calibrate:
        raise InputError(f"the explicit form has derived parameters only; expected "
                         f"{options.spelled('method', 'derived')} without "
                         f"{options.spelled('calibrate', True)} "
                         f"(or {options.spelled('form', 'grammar')})", source)

    def level_exists(last: int) -> None:
        if grouping is None and not 1 <= options.level <= last:
            raise InputError(f"level {options.level} is past the last: "
                             f"{explicit_levels_said(last, roots(build(system).tree))}", source)

    if shared is None and chain is not None:
        shared = chain.share
    if shared is None:
        # one level needs no coarser groupings; a chain's later levels need them all
        up_to = None if chain is not None else options.level if grouping is None else grouping
        shared = chain_share(system, options, level_exists, up_to=up_to)
        if chain is not None:
            chain.share = shared
    else:
        level_exists(shared.last)
    original = shared.original
    if progress:
        progress("fitting the explicit form", 0.0)
    settle_level_one(system, options, shared, progress)   # level 1's groups (the chain's too)
    if progress:
        progress("fitting the explicit form", 0.4)
    index = options.level if grouping is None else min(grouping, shared.last)
    if index == options.level == 1 and shared.level_one is not None:
        text, tree = shared.level_one
    else:
        text, tree = _level_fitter(system, options, shared)(shared.groupings[index], options.level)
    check_stability(tree, options.dt, options.damping)
    if progress:
        progress("measuring", 0.5)
    runs = shared.runs_for(options)(tree)   # the motion fit's, when the level's branches are the same
    reports, summary, largest, notes = _measured(original, runs, tree, options)
    comment = header_comment(system, options, reports, summary, form="explicit",
                             branches=(original.n_branches, tree.n_branches))
    # the level's text is canonical (what write_lsys writes of it; tests/test_simplify_explicit.py)
    return Result(with_header_comment(text, comment), original, tree, reports, summary, notes,
                  largest, comment, system.source)


def _level_fitter(system: LSystem, options: Options,
                  shared: ChainShare) -> Callable[["Grouping", int], tuple[str, Tree]]:
    """fit(groups, level): the explicit level of ``shared.original`` with ``groups``, its
    (text, tree) (`explicit.explicit_system_text`), fitted to motion in the chain's runs."""
    from .explicit import explicit_system_text, level_header

    header = level_header(system)
    runs_for = shared.runs_for(options)

    def fit(groups, level: int) -> tuple[str, Tree]:
        return explicit_system_text(shared.original, groups, name=system.name or "tree",
                                    header=header, level=level, dt=options.dt,
                                    duration=options.duration,
                                    damping_ratio=options.damping_ratio, runs_for=runs_for)

    return fit


def settle_level_one(system: LSystem, options: Options, shared: ChainShare,
                     progress: Callable[[str, float], None] | None = None) -> None:
    """Level 1's groups chosen by its fitted level (`regroup.regrouped`), once per chain:
    ``shared.groupings`` then hold every level's final groups (the coarser levels grouped on
    level 1's) and ``shared.level_one`` level 1's (text, tree) where it was fitted here.
    Every level of a chain needs this first; after it the levels are independent fits
    (`chain_workers`)."""
    from .regroup import regrouped

    if shared.regrouped:
        return
    fit = _level_fitter(system, options, shared)
    def fitted(k: int, most: int) -> None:       # (the fits take the first half of the bar)
        if progress is not None:
            progress(f"fitting the explicit form (level 1's grouping, fit {k})",
                     0.4 * k / most)

    shared.groupings, shared.level_one = regrouped(shared.original, shared.groupings,
                                                   lambda g: fit(g, 1), shared.runs_for(options),
                                                   fitted)
    shared.regrouped = True


def _angle_notes(winds: list[WindCase], largest: list[float]) -> list[str]:
    """A warning where the original's combined angles (``largest``, per wind) pass
    SMALL_ANGLE_LIMIT (the targets hold below). They are read over the level's groups (a
    group sums its main path's angles), so a coarser level can name a lower speed: the
    warning says so (`--levels` gave two speeds "of the original", a helper's first hour,
    session 36)."""
    over = [w.speed for w, a in zip(winds, largest) if a > SMALL_ANGLE_LIMIT]
    if not over:
        return []
    return [f"warning: the original's combined angles over this level's groups pass "
            f"{SMALL_ANGLE_LIMIT:g} rad at {min(over):g} m/s and above; the accuracy targets "
            f"hold below that speed"]


def _period_notes(original: Tree, reports: list[tuple[WindCase, Report]],
                  options: Options) -> list[str]:
    """A warning where the original itself shows no period in any wind (model.md 6: the mean
    spacing of two or more upward crossings), so the level's periods were neither fitted nor
    checked: runs shorter than two swings of the tree's slowest branch, whose period
    P = 2π dt / arccos(1 - k dt / 2000) is longest where k is smallest (model.md 4), slowed
    by a damping ratio ζ to P / sqrt(1 - ζ²), or no swing at all at ζ >= 1 (overdamped).
    Where only the level lacks a period, the figures say so ("period undefined")."""
    if original.n_branches == 0 or any(
            np.isfinite(np.asarray(r.table.period_original)).any() for _, r in reports):
        return []
    zeta = options.damping_ratio
    if zeta >= 1.0:
        return [f"warning: no period was measured in any wind: at damping ratio {zeta:g} the "
                "tree is overdamped and swings back without oscillating, so the level's "
                "periods are not checked"]
    from plantlod.sim.damping import period_of_strength

    weakest = min(float(np.min(original.bend_strength)), float(np.min(original.rotation_strength)))
    slowest = float(period_of_strength(weakest, options.dt)) / math.sqrt(1.0 - zeta * zeta)
    if not math.isfinite(slowest):           # (k dt / 2000 below rounding: 1 - s/2 is 1)
        return [f"warning: no period was measured in any wind: at dt = {options.dt:g} s the "
                f"weakest branch (strength {weakest:g}) has no period the scheme can step "
                "(k dt / 2000 is lost to rounding), so the level's periods are not checked; "
                "give stiffer branches or a larger --dt"]
    longer = max(math.ceil(3 * slowest), math.floor(options.duration) + 1)
    return [f"warning: no period was measured in any wind: the runs of {options.duration:g} s "
            f"hold fewer than two swings of the tree's slowest branch ({slowest:.3g} s at dt = "
            f"{options.dt:g} s{f', damping ratio {zeta:g}' if zeta else ''}), so the level's "
            f"periods are not checked; give a duration of {longer:g} s or more"]


def _sampling_notes(original: Tree, options: Options) -> list[str]:
    """A warning where the original's stiffest branch swings faster than the measurement
    runs can read (`sim.aliasing`: its period under MIN_SAMPLES_PER_PERIOD of the runs'
    samples, every ``options.every`` steps), naming the largest dt that reads it."""
    from plantlod.sim.aliasing import aliased

    found = aliased(original, options.dt, options.every)
    if found is None:
        return []
    return ["warning: " + found.said(f"the measurement runs (every {options.every} steps of "
                                     f"{options.dt:g} s)", "the level's figures")]


def _measured(original: Tree, runs: Runs, tree: Tree, options: Options) -> tuple:
    """The level ``tree`` measured against the original's ``runs`` in the measurement winds
    (either form): (reports [(wind, Report)], their summary, the original's largest combined
    angle per wind, and the notes the measurement gives: angles past SMALL_ANGLE_LIMIT, runs
    too short for a period, and for a chain, whose downward periods are read too, a period
    bound missed in the opposite winds)."""
    from .explicit import is_stalk

    stalk = is_stalk(original)
    reports = list(zip(options.winds(), runs.compare(tree, downward=stalk)))
    summary = summarize([r for _, r in reports])
    largest = runs.largest_combined_angle()
    notes = _angle_notes(runs.winds, largest) + _period_notes(original, reports, options) \
        + _sampling_notes(original, options) \
        + (_opposite_wind_notes(runs, tree, reports, options) if stalk else [])
    return reports, summary, largest, notes


def _opposite_wind_notes(runs: Runs, tree: Tree,
                         reports: list[tuple[WindCase, Report]], options: Options) -> list[str]:
    """For a chain (the caller checks `explicit.is_stalk`, its runs compared with
    ``downward``): a note where its level misses its period bound in the opposite winds though
    the measurement winds (0-90°) do not show it: the worst of
    `motion_fit.opposite_period_errors` (the reversed wind's period, read from this run's
    downward crossings where the chain is linear) against the level's stalk period bound
    (STALK_BOUNDS). A group that sums members of several periods crosses its mean at another
    pace downward than upward over a few periods, and one branch holds one pace
    (docs/simplify.md, Limits: family stalk-180's level 1 misses by 5.8 % reversed)."""
    from .constants import STALK_BOUNDS
    from .motion_fit import opposite_period_errors

    bound = STALK_BOUNDS[min(options.level, max(STALK_BOUNDS))][1]
    errors = [e for e in opposite_period_errors(runs, tree, [r for _w, r in reports])
              if e is not None and e.size]
    worst = max((float(e.max()) for e in errors), default=-math.inf)
    if not worst > bound:
        return []
    return [f"note: in the opposite winds (each measurement wind where the chain is linear, "
            f"reversed: its response is then the negative) the level's period error reaches "
            f"{_percent(worst)}, beyond its bound of {_percent(bound)}: a group that sums "
            "members of several periods crosses its mean at another pace downward, and one "
            "branch keeps one pace (docs/simplify.md, Limits)"]


@finite_fit
def simplify_grammar(system: LSystem, options: Options,
                     progress: Callable[[str, float], None] | None = None) -> Result:
    """The grammar form: the same productions, derivation length N - n, new parameters."""
    source = system.source or None
    if options.method not in METHODS:
        raise InputError(f"unknown method {options.method!r}; expected one of {', '.join(METHODS)}")
    if options.calibrate and options.method != "derived":
        raise InputError(f"{options.spelled('calibrate', True)} refines the derived method; "
                         f"expected {options.spelled('method', 'derived')}")
    check_level(system, options.level)
    winds = options.winds()
    original = build(system).tree
    check_measurement_memory(original, options)         # (first: `chain_share` says why)
    check_moves(original, source)
    check_stability(original, options.dt, options.damping)

    plain, _ = level_system(system, options.level, equivalent_leaves=False)
    plain_tree = build(plain).tree
    if plain_tree.n_branches == 0:
        raise InputError(f"the level-{options.level} tree has no branches (nothing draws after "
                         f"{plain.derivation_length} steps); expected a lower level", source)
    try:
        gmap = group_map(original, plain_tree)
    except InputError as exc:     # (a level-n branch no original branch falls under: the file)
        raise InputError(f"the grammar form's level {options.level}: {exc.message}",
                         exc.file or source) from None
    _check_something_merges(original, plain_tree, gmap, source)
    loses_leaves = plain_tree.n_leaves < original.n_leaves
    notes = []

    if options.method == "thesis":
        skeleton, skeleton_tree = plain, plain_tree
        params, scale = thesis_parameters(original, skeleton_tree, gmap, options.level)
        skeleton = replace(skeleton, leaf_force_scale=round_sig(system.leaf_force_scale * scale))
    else:
        skeleton, expanded = level_system(system, options.level, equivalent_leaves=loses_leaves)
        skeleton_tree = build(skeleton).tree if expanded else plain_tree
        if expanded and list(skeleton_tree.address) != list(plain_tree.address):
            # (the leaf rules must not move a branch: each stands for its group; drawn
            # otherwise, the level goes without equivalent leaves)
            skeleton, skeleton_tree, expanded = plain, plain_tree, []
        if expanded:
            notes.append(f"equivalent leaves at the modules {', '.join(expanded)} (each draws "
                         "the leaves its next step would grow; docs/simplify.md, \"Equivalent "
                         "leaves\")")
        # fitted where compare reads it: in each group root's frame W_0 (model.md 6)
        from plantlod.compare.groups import swing_turns

        params = closed_form(original, skeleton_tree, gmap, speeds=tuple(options.wind_range),
                             turn=swing_turns(original, skeleton_tree, gmap.paths))
    # (no strength rounded up to where the time step is unstable)
    below = largest_stable_s(Damping()) * 1000.0 / options.dt
    out = write_parameters(skeleton, params.branch, params.leaf_areas, below)
    tree = _read_back(out)
    check_stability(tree, options.dt, options.damping)

    runs = None
    if options.calibrate:
        if progress:
            progress("simulating the original", 0.0)
        runs = Runs(original, gmap, winds, options.dt, options.steps, options.every,
                    options.damping)
        cal = calibrate(runs, tree, options.max_evaluations,
                        None if progress is None else (lambda f: progress("calibrating", f)))
        values = {**params.branch, **cal.values}
        out = write_parameters(skeleton, values, params.leaf_areas, below)
        tree = _read_back(out)
        check_stability(tree, options.dt, options.damping)
        notes.append(f"calibration: worst weighted error (period errors x5) {cal.worst_before:.4f} -> "
                     f"{cal.worst_after:.4f} in {cal.evaluations - 1} candidate evaluations "
                     "after the closed form's")
    if progress:
        progress("measuring", 1.0)
    if runs is None:
        runs = Runs(original, gmap, winds, options.dt, options.steps, options.every,
                    options.damping)
    reports, summary, largest, measured_notes = _measured(original, runs, tree, options)
    notes += measured_notes
    header = header_comment(system, options, reports, summary, form="grammar",
                            branches=(original.n_branches, tree.n_branches))
    out = replace(out, comment=header)
    return Result(write_lsys(out, header), original, tree, reports, summary, notes, largest,
                  header, system.source, out)


def simplified_system(system: LSystem, level: int = 1, **options) -> LSystem:
    """The level-``level`` L-system of ``system``, its header comment (``.comment``) set.

    options : the other fields of `Options` (method, calibrate, wind_range, dt, ...).
    """
    import dataclasses

    if not isinstance(system, LSystem):
        raise InputError(f"expected an LSystem, got {type(system).__name__}")
    known = {f.name for f in dataclasses.fields(Options)} - {"level", "flags"}
    unknown = sorted(set(options) - known)
    if unknown:
        # ('levle' was told 'did you mean every?': level is a keyword too)
        names = known | {"level"}
        raise InputError(f"unknown option {unknown[0]!r}{did_you_mean(str(unknown[0]), names)}; "
                         f"expected some of {', '.join(sorted(names))}")
    checked = Options(level=level, **options)
    if "max_evaluations" in options and not checked.calibrate:
        # (ignored without calibrate, as the CLI refuses --evaluations without --calibrate)
        raise InputError("max_evaluations is the calibration's budget; it applies with "
                         "calibrate=True")
    result = simplify(system, checked)
    for note in result.notes:                 # (the CLI says them on stderr)
        if note.startswith("warning: "):
            warn_caller(note[len("warning: "):])
    level_system_ = result.system
    # (named as the level it is: the original's file name made a warning about the level's
    # branch 3 name a file that has no branch 3)
    source = f"{system.source or system.name or 'tree'} (level {level})"
    return replace(level_system_, source=source)


def _read_back(system: LSystem) -> Tree:
    """The tree of the text that will be written (so the figures describe the file)."""
    return build(parse_lsys(write_lsys(system), system.source)).tree


def _percent(x: float) -> str:
    return "undefined" if not math.isfinite(x) else f"{100.0 * x:.3f} %"


def header_comment(system: LSystem, options: Options, reports: list[tuple[WindCase, Report]],
                   summary: Summary, form: str = "grammar",
                   branches: tuple[int, int] | None = None) -> str:
    """The header: source, level, form, method, and the section-6 errors simplify measured
    (its dt and damping ratio read back by `formats.level_header.fitted_conditions`)."""
    shape = (f"derivation length {system.derivation_length} -> {system.derivation_length - options.level}"
             if form == "grammar" else
             f"explicit form, {branches[0]:,} -> {counted(branches[1], 'branch')}" if branches
             else "explicit form")
    lines = [
        f"{HEADER_START}level {options.level} of {system.source or '<input>'} ({shape})",
        f"form: {form}",
        f"method: {options.method}" + (", calibrated" if options.calibrate else ""),
        *([f"{DAMPING_RATIO_LINE}{options.damping_ratio:g} (fitted and measured under it; "
            "simulate it with --damping-ratio)"] if options.damping_ratio else []),
        "errors of this file against the original (model.md section 6), steady winds from rest,",
        f"{RUNS_LINE}{options.dt:g} s, {options.duration:g} s, every {options.every} steps sampled:",
        "  wind m/s  toward deg  amplitude    period       tip/height   motion       period(major)",
    ]
    for wind, rep in reports:
        lines.append(f"  {wind.speed:<8g}  {wind.direction:<10g}  {_percent(rep.amplitude_error):<11}"
                     f"  {_percent(rep.period_error):<11}  {_percent(rep.tip_error):<11}"
                     f"  {_percent(rep.motion_error):<11}  {_percent(rep.period_error_major)}")
    lines.append(f"worst: amplitude {_percent(summary.amplitude)}, period {_percent(summary.period)}, "
                 f"tip {_percent(summary.tip)} of the rest height; {_bounds_text(reports)}")
    return "\n".join(lines)
