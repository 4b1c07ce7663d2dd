"""A chain's explicit levels fitted in several processes (`simplify --levels`, `--jobs`).

Once level 1's groups are settled (`pipeline.settle_level_one`: the regrouping, where the
tree has one), every level of a chain is an independent fit of the same original, its
groupings and its runs in the measurement winds (`pipeline.ChainShare`): the levels can be
fitted in any order and anywhere, and each one's text is the same bytes. One process used
about 1.2 of two cores on abop_1_24c (the kernels are parallel, the fits are not), so the
levels are shared out between this process and ``jobs - 1`` spawned workers
(`plantlod.sim.workers.run_jobs`):

- this process takes levels from the front (level 1, the largest, first), the workers from
  the back (the coarsest, smallest first): each process' memory peaks with its largest
  level and the peaks add up (issue 21 bounds the chain at 2 GB; abop_1_24c: 1.87 GB in
  two processes, 2.5 GB with level 2 fitted beside level 1);
- a worker is given the system, the original tree, its groupings and the options, and asks
  for the original's runs (float32 angles, 0.13 GB at 4,096 branches) when its first
  level's motion fit needs them, once this process has simulated them: the original is
  simulated once;
- the levels come back as `LevelOutcome` (the text and the figures the command prints), in
  level order, a worker's error raised and its warnings warned here as if the level had
  been fitted here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterator

from plantlod.lsys.system import LSystem
from plantlod.sim.workers import run_jobs

from .evaluate import Summary
from .explicit import is_stalk
from .pipeline import ChainShare, Options, Result, settle_level_one, simplify_explicit


@dataclass(frozen=True)
class LevelOutcome:
    """What `simplify --levels` writes and prints of one level: its text, the branch counts
    (original, level), its worst figures over the measurement winds (`evaluate.Summary`:
    a stalk's amplitude and period, a branching tree's motion and major period, the tip
    error; NaN where nothing counted) and whether the original is a stalk (which of them the
    line shows, as --level's does), the largest tip error (max) in metres over the
    measurement winds, and the notes and warnings its measurement gave
    (`pipeline.Result.notes`: those about the original, such as aliased or missing periods,
    come with every level alike)."""

    level: int
    text: str
    branches: tuple[int, int]
    worst: Summary
    stalk: bool
    tip_max_m: float
    notes: tuple[str, ...] = ()

    @classmethod
    def of(cls, level: int, result: Result) -> "LevelOutcome":
        tip_m = max((r.tip_error_max_m for _w, r in result.reports
                     if math.isfinite(r.tip_error_max_m)), default=math.nan)
        return cls(level, result.text, (result.original.n_branches, result.tree.n_branches),
                   result.summary, is_stalk(result.original), float(tip_m), tuple(result.notes))


def chain_levels(system: LSystem, options: list[Options], shared: ChainShare,
                 jobs: int = 1) -> Iterator[LevelOutcome]:
    """Every level of ``options`` (levels 1 to the last, in order, one `Options` each, equal
    but for the level) as a `LevelOutcome`, in level order, fitted in ``jobs`` processes
    (this one and jobs - 1 workers; 1: all here, in order). ``shared``: the chain's
    `pipeline.chain_share`. The outcomes are the same for any ``jobs``."""
    if not options:
        return
    settle_level_one(system, options[0], shared)
    by_level = {o.level: o for o in options}
    payload = (system, by_level, shared.original, shared.groupings)
    for _k, outcome in run_jobs(min(by_level), max(by_level), _fitter(system, by_level, shared),
                                jobs - 1, _worker_fitter, payload,
                                {"runs": lambda: shared.measure}):
        yield outcome


def _fitter(system: LSystem, by_level: dict[int, Options],
            shared: ChainShare) -> Callable[[int], LevelOutcome]:
    def fit(k: int) -> LevelOutcome:
        return LevelOutcome.of(k, simplify_explicit(system, by_level[k], shared=shared))

    return fit


class _AskedRuns:
    """A worker's stand-in for `pipeline.InBackground`: the original's runs, asked for when
    first needed (a worker given no level never asks)."""

    def __init__(self, ask):
        self._ask, self._runs = ask, None

    def result(self) -> list:
        if self._runs is None:
            self._runs = self._ask("runs")
        return self._runs


def _worker_fitter(payload: tuple, ask) -> Callable[[int], LevelOutcome]:
    """In a worker (`sim.workers`): fit(level) over the chain the payload describes."""
    system, by_level, original, groupings = payload
    shared = ChainShare(original, groupings, _AskedRuns(ask), regrouped=True)
    return _fitter(system, by_level, shared)
