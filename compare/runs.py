"""Compare the motion of a simplified tree with the original's (model.md sections 5 and 6).

The library side of `plantlod compare`: given both trees and their sampled
angles (simulated here or read from angle CSVs), find the groups and main
paths (`plantlod.compare.groups`), the original's combined angles and group
tips, and the simplified branches' angles and tips, and hand them to
`plantlod.compare.measures.compare_groups` for the report. Also the plain
angle-against-angle check of two runs of one tree (`angle_differences`).

Shapes: K samples, B_o original branches, G = B_s simplified branches (one
group per simplified branch). Times in seconds, angles in radians, positions
in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import rest_height, rest_pose
from .groups import assign_groups, carry_angles, combined_angles, main_paths, swing_turns
from plantlod.compare.measures import Report, Worst, compare_groups, window

from .constants import MAX_EXTENT_M, TIME_MATCH_RTOL
from plantlod.lsys.words import counted


@dataclass
class Run:
    """One tree and its sampled motion.

    tree  : the tree at rest
    times : (K,) sample times, s, increasing
    bend  : (K, B) bend angles θb per branch (tree order), rad
    rot   : (K, B) rotation angles θr per branch, rad
    name  : where it came from, for messages and reports
    angles: the file its angles were read from, "" where they were simulated (messages)
    """

    tree: Tree
    times: np.ndarray
    bend: np.ndarray
    rot: np.ndarray
    name: str = ""
    angles: str = ""

    @property
    def samples_name(self) -> str:
        """Where its sample times come from, for a message about them."""
        return f"{self.angles} (the angles of {self.name})" if self.angles else self.name

    def __post_init__(self) -> None:
        self.times = np.asarray(self.times, dtype=np.float64)
        self.bend = np.asarray(self.bend, dtype=np.float64)
        self.rot = np.asarray(self.rot, dtype=np.float64)
        shape = (len(self.times), self.tree.n_branches)
        if self.times.ndim != 1 or self.bend.shape != shape or self.rot.shape != shape:
            raise ValueError(f"{self.name}: expected times (K,) and angles {shape}; got "
                             f"{self.times.shape}, {self.bend.shape} and {self.rot.shape}")


@dataclass
class Comparison:
    """The comparison of one simplified run with the original.

    groups         : (B_o,) int64 group (simplified branch index) of every original branch, -1: none
    paths          : G main paths, (m_g,) int64 original branch indices each
    unassigned     : number of original branches in no group
    combined_bend  : (K, G) the original's combined angle Θb per group over the whole run, rad
    combined_rot   : (K, G) Θr, rad
    window         : the slice of samples the report covers
    report         : the figures (`plantlod.compare.measures.Report`)
    """

    original: Run
    simplified: Run
    groups: np.ndarray
    paths: list[np.ndarray]
    unassigned: int
    combined_bend: np.ndarray
    combined_rot: np.ndarray
    window: slice
    report: Report


# --- checking inputs -----------------------------------------------------------------

def angles_in_tree_order(tree: Tree, addresses: list[str], bend: np.ndarray, rot: np.ndarray,
                         source: str | None) -> tuple[np.ndarray, np.ndarray]:
    """Angle columns (K, B) of a CSV rearranged into ``tree``'s branch order.

    addresses : the CSV's branch addresses, one per column of bend and rot
    source    : the file they were read from, None for an API caller's `Angles`
    Raises InputError when the CSV's addresses are not exactly the tree's.
    """
    column = {a: j for j, a in enumerate(addresses)}
    missing = [a for a in tree.address if a not in column]
    extra = sorted(set(addresses) - set(tree.address))
    if missing or extra:
        parts = []
        if missing:
            parts.append(f"no columns for branch(es) {_examples(missing)}")
        if extra:
            parts.append(f"columns for branch(es) {_examples(extra)} that the tree does not have")
        kind = ("set (an Angles)" if source is None else
                "archive" if str(source).lower().endswith(".npz") else "CSV")
        raise InputError(f"the angle {kind} does not belong to the tree {tree.where or '?'}: "
                         f"{'; '.join(parts)}; expected the {kind} that `plantlod simulate` "
                         f"wrote for this tree ({counted(tree.n_branches, 'branch')})", source)
    order = np.asarray([column[a] for a in tree.address], dtype=np.int64)
    return np.asarray(bend)[:, order], np.asarray(rot)[:, order]


def check_same_times(times_a: np.ndarray, times_b: np.ndarray, name_a: str, name_b: str,
                     thinned: bool = True) -> None:
    """Raise InputError unless two runs are sampled at the same times (within TIME_MATCH_RTOL).
    ``thinned``: the caller reads a run kept every K-th step at the other's samples
    (`on_common_samples`), and the message says so."""
    a, b = np.asarray(times_a, np.float64), np.asarray(times_b, np.float64)
    if a.shape != b.shape:
        how = ("over the same span with the same --dt (one may keep every K-th sample of the "
               "other: simulate --every)" if thinned else
               "at the same times (the same --dt, span and --every)")
        raise InputError(f"{name_a} has {counted(len(a), 'sample', grouped=False)} ({_span(a)}) "
                         f"but {name_b} has {len(b)} ({_span(b)}); expected both runs {how}")
    tol = TIME_MATCH_RTOL * np.maximum(1.0, np.abs(a))
    bad = np.flatnonzero(np.abs(a - b) > tol)
    if len(bad):
        k = int(bad[0])
        raise InputError(f"sample {k} is at t = {a[k]:.10g} s in {name_a} but t = {b[k]:.10g} s "
                         f"in {name_b}; expected both runs sampled at the same times")


def on_common_samples(runs: list[Run]) -> list[Run]:
    """Every run at the samples of the one with fewest, where those are its samples 0, K, 2K,
    ... (`simulate --every K`: the same Δt and span), so that comparisons and pictures pose
    each tree at one time; a run not thinned so as it is (`check_same_times` then says what
    differs)."""
    coarse = min(runs, key=lambda r: len(r.times))
    out = []
    for run in runs:
        thinned = _thinned_to(run, coarse.times)
        out.append(run if thinned is None else thinned)
    return out


def _thinned_to(fine: Run, times: np.ndarray) -> Run | None:
    """``fine`` at ``times`` where those are its samples 0, K, 2K, ... (K from their spacing,
    K >= 2) and it ends less than K steps after them; None otherwise."""
    n, m = len(fine.times), len(times)
    if m < 2 or n <= m or n < 2:
        return None
    step = fine.times[1] - fine.times[0]
    if not step > 0:
        return None
    k = int(round((times[1] - times[0]) / step))
    if k < 2 or len(fine.times[::k]) != m:
        return None
    picked = fine.times[::k]
    if not np.all(np.abs(picked - times) <= TIME_MATCH_RTOL * np.maximum(1.0, np.abs(picked))):
        return None
    return replace(fine, times=picked, bend=fine.bend[::k], rot=fine.rot[::k])


# --- tips ------------------------------------------------------------------------

def tip_series(tree: Tree, bend: np.ndarray, rot: np.ndarray, branches: np.ndarray) -> np.ndarray:
    """Posed tips of the given branches at every sample: (K, n, 3) m.

    bend, rot : (K, B) rad; branches : (n,) branch indices (`plantlod.sim.tips_kernel`).
    """
    from plantlod.sim.tips_kernel import tips

    return tips(tree, bend, rot, branches)


# --- the comparison ----------------------------------------------------------------

def compare_runs(original: Run, simplified: Run, t0: float | None = None,
                 t1: float | None = None) -> Comparison:
    """Compare ``simplified`` with ``original`` over the samples with t0 <= t <= t1.

    Both runs must be sampled at the same times (InputError otherwise). The
    combined angles are returned for the whole run (for plots); the report
    covers the window only.
    """
    original, simplified = on_common_samples([original, simplified])
    for run in (original, simplified):
        check_extent(run.tree, run.name or None)
    height = rest_height(original.tree)
    if not height > 0:                             # (compare_groups says so too, naming no file)
        raise InputError("the tree's rest height is 0 m: tip errors are fractions of it "
                         "(model.md 6); expected a tree whose highest tip is above z = 0",
                         original.name or None)
    check_same_times(original.times, simplified.times, original.samples_name,
                     simplified.samples_name)
    try:
        groups = assign_groups(original.tree, simplified.tree)
    except InputError as exc:         # (the simplified tree's groups: its file is at fault)
        if exc.file is not None or not simplified.name:
            raise
        raise InputError(exc.message, simplified.name) from None
    g = simplified.tree.n_branches
    paths = main_paths(original.tree, groups, g)
    combined_b, combined_r = combined_angles(original.tree, paths, original.bend, original.rot)
    cut = window(original.times, t0, t1)
    last = np.asarray([int(p[-1]) for p in paths], dtype=np.int64)
    tips_o = tip_series(original.tree, original.bend[cut], original.rot[cut], last)
    tips_s = tip_series(simplified.tree, simplified.bend[cut], simplified.rot[cut], np.arange(g))
    for run, tips in ((original, tips_o), (simplified, tips_s)):
        _check_finite(run, original.times[cut], tips)
    simp_b, simp_r = simplified.bend[cut], simplified.rot[cut]
    # every simplified branch is read in its group root's rest swing frame W_0 (model.md 6),
    # either form: a chord's frame turns against its root's, and a grammar-form branch's may
    # too; where the frames agree the carry is the identity and changes no value
    simp_b, simp_r = carry_angles(swing_turns(original.tree, simplified.tree, paths),
                                  simp_b, simp_r)
    report = compare_groups(original.times[cut], combined_b[cut], combined_r[cut],
                            simp_b, simp_r, tips_o, tips_s,
                            height, list(simplified.tree.address))
    return Comparison(original, simplified, groups, paths, int((groups < 0).sum()),
                      combined_b, combined_r, cut, report)


def check_extent(tree: Tree, source: str | None) -> None:
    """InputError (naming ``source``) where the tree's rest bases or tips lie farther than
    MAX_EXTENT_M from the origin, or are not finite: tip errors square position differences,
    and a tree of 1e300 m offsets (`f(1e300)`) posed tips that overflowed, reported as a run
    that diverged and under no file. Angles alone (simulate) never need positions: simulate
    asks only when its run diverged, to tell a tree of absurd size from a run too strong."""
    if tree.n_branches == 0:
        return
    rest = rest_pose(tree)
    with np.errstate(invalid="ignore", over="ignore"):
        reach = float(max(np.abs(rest.base).max(), np.abs(rest.tip).max()))
    if not reach <= MAX_EXTENT_M:                      # (NaN too)
        raise InputError(f"the tree reaches {reach:.3g} m from the origin at rest, beyond the "
                         f"{MAX_EXTENT_M:.0e} m its positions are measured to; expected lengths "
                         "and moves (f) of a tree", source)


def _check_finite(run: Run, times: np.ndarray, tips: np.ndarray) -> None:
    """InputError naming ``run``'s angle file (or its tree, where it was simulated) when its
    angles or the tips they pose (K, G, 3) are not finite: angles of 1e308 read from a CSV
    posed tips of inf, reported under the simplified file's name (session 28's fuzzing)."""
    bad = ~np.isfinite(tips).all(axis=(1, 2))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"its angles pose tips that are not finite at t = {times[k]:g} s; "
                         "expected angles of a run that did not diverge (radians, unless "
                         "--degrees)", run.angles or run.name or None)


# --- two runs of one tree ----------------------------------------------------------

@dataclass
class AngleDifference:
    """How far two runs of one tree are apart, per branch.

    addresses  : [B] branch addresses (the first run's order)
    bend, rot  : (B,) max over time of |θ_a - θ_b|, rad
    bend_at, rot_at : (B,) the time (s) of the first sample where that maximum occurs
    """

    addresses: list[str]
    bend: np.ndarray
    rot: np.ndarray
    bend_at: np.ndarray
    rot_at: np.ndarray

    @property
    def largest(self) -> np.ndarray:
        """(B,) the larger of the bend and rotation differences per branch, rad."""
        return np.maximum(self.bend, self.rot)

    def worst(self) -> tuple[int, str]:
        """Index and component ("bend" or "rotation") of the largest difference (first of ties)."""
        j = int(np.argmax(self.largest))
        return j, "bend" if self.bend[j] >= self.rot[j] else "rotation"


def angle_differences(times_a: np.ndarray, addresses_a: list[str], bend_a: np.ndarray,
                      rot_a: np.ndarray, times_b: np.ndarray, addresses_b: list[str],
                      bend_b: np.ndarray, rot_b: np.ndarray, name_a: str = "the first CSV",
                      name_b: str = "the second CSV") -> AngleDifference:
    """Per-branch largest absolute angle difference of two runs of one tree.

    times_* (K,) s; bend_*, rot_* (K, B) rad with columns named by addresses_*.
    Run b's columns may come in another order. Raises InputError when the
    address sets or the times differ.
    """
    if sorted(addresses_a) != sorted(addresses_b):
        only_a = sorted(set(addresses_a) - set(addresses_b))
        only_b = sorted(set(addresses_b) - set(addresses_a))
        raise InputError(f"the two CSVs have different branches (only in {name_a}: "
                         f"{_examples(only_a) or 'none'}; only in {name_b}: "
                         f"{_examples(only_b) or 'none'}); expected two runs of one tree")
    check_same_times(times_a, times_b, name_a, name_b, thinned=False)
    column = {a: j for j, a in enumerate(addresses_b)}
    order = np.asarray([column[a] for a in addresses_a], dtype=np.int64)
    times = np.asarray(times_a, dtype=np.float64)
    db = np.abs(np.asarray(bend_a, np.float64) - np.asarray(bend_b, np.float64)[:, order])
    dr = np.abs(np.asarray(rot_a, np.float64) - np.asarray(rot_b, np.float64)[:, order])
    kb, kr = np.argmax(db, axis=0), np.argmax(dr, axis=0)
    cols = np.arange(db.shape[1])
    return AngleDifference(list(addresses_a), db[kb, cols], dr[kr, cols], times[kb], times[kr])


# --- helpers -------------------------------------------------------------------------

def _examples(items: list[str], n: int = 3) -> str:
    return ", ".join(items[:n]) + (", …" if len(items) > n else "")


def _span(t: np.ndarray) -> str:
    return f"{t[0]:g} to {t[-1]:g} s" if len(t) else "empty"


# --- bounds --------------------------------------------------------------------------

BOUND_OPTIONS = {"amplitude_error": "--max-amplitude-error", "period_error": "--max-period-error",
                 "tip_error": "--max-tip-error", "motion_error": "--max-motion-error",
                 "period_error_major": "--max-period-error-major",
                 "tip_error_max_m": "--max-tip-error-m"}


@dataclass
class Violation:
    """A headline figure above its bound, or undefined although a bound was given.

    figure : a key of BOUND_OPTIONS ("amplitude_error", "motion_error", ...)
    value  : the figure (NaN: undefined); limit : the bound
    at     : where the worst figure was found (None when undefined)
    """

    figure: str
    value: float
    limit: float
    at: Worst | None

    @property
    def option(self) -> str:
        return BOUND_OPTIONS[self.figure]

    def describe(self, simplified: str) -> str:
        """One line for people, e.g. ``amplitude error 0.31 > --max-amplitude-error 0.2 (...)``."""
        name = self.figure.replace("_", " ")
        if math.isnan(self.value):
            return (f"{simplified}: {name} is undefined (no component counts or no period is "
                    f"defined), so {self.option} {self.limit:g} cannot be met")
        where = f"group {self.at.address}" + (f" {self.at.component}" if self.at.component else "")
        return f"{simplified}: {name} {self.value:.4g} > {self.option} {self.limit:g} at {where}"


def check_bounds(report: Report, bounds: dict[str, float | None]) -> list[Violation]:
    """The headline figures of ``report`` that break their bounds.

    bounds : figure name (a key of BOUND_OPTIONS) -> bound or None.
    A figure above its bound breaks it; so does an undefined (NaN) figure, which
    a bound can never vouch for.
    """
    out = []
    for figure in BOUND_OPTIONS:
        limit = bounds.get(figure)
        if limit is None:
            continue
        value = getattr(report, figure)
        if not value <= limit:
            out.append(Violation(figure, value, float(limit), getattr(report, figure + "_at")))
    return out
