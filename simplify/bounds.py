"""How far a level's measured figures are from its bounds (issue 12's LEVEL_BOUNDS; a
stalk's relative ones, STALK_BOUNDS, issue 21): the score `simplify --form auto` ranks forms
by and the motion fit keeps its best round by."""

from __future__ import annotations

import math

from plantlod.compare.measures import Report

from .constants import LEVEL_BOUNDS, SMALL_ANGLE_LIMIT, STALK_BOUNDS
from .evaluate import WindCase


def _counted_winds(reports: list, largest_angles: list[float] | None) -> list[bool]:
    """Per wind, whether the bounds apply: the original's largest combined angle is within
    SMALL_ANGLE_LIMIT; every wind where none is (or no angles are given)."""
    small = [a <= SMALL_ANGLE_LIMIT for a in largest_angles] if largest_angles else []
    if len(small) != len(reports) or not any(small):
        small = [True] * len(reports)
    return small


def bounds_score(reports: list[tuple[WindCase, Report]], level: int,
                 largest_angles: list[float] | None = None, stalk: bool = False) -> float:
    """The worst ratio of a visible-motion figure to its bound (LEVEL_BOUNDS) over the winds:
    <= 1 when the level meets its bounds. Winds where the original's combined angles pass
    SMALL_ANGLE_LIMIT (``largest_angles``, per wind) are left out, as the bounds hold only
    below it (issue 12), unless every wind passes it. ``stalk``: a chain's relative
    amplitude and period errors against STALK_BOUNDS in place of the motion error and the
    major period error (issue 21's targets for stalks)."""
    motion, period, tip = LEVEL_BOUNDS[min(level, max(LEVEL_BOUNDS))]
    if stalk:
        motion, period = STALK_BOUNDS[min(level, max(STALK_BOUNDS))]
    small = _counted_winds(reports, largest_angles)
    worst = 0.0
    for (_wind, r), counts in zip(reports, small):
        if not counts:
            continue
        figures = (r.amplitude_error, r.period_error) if stalk else (r.motion_error,
                                                                     r.period_error_major)
        for value, limit in ((figures[0], motion), (figures[1], period), (r.tip_error, tip)):
            if math.isfinite(value):
                worst = max(worst, value / limit)
    return worst


def form_rank(reports: list[tuple[WindCase, Report]], level: int,
              largest_angles: list[float] | None = None, stalk: bool = False) -> tuple[int, float]:
    """How `--form auto` ranks two forms that both miss their bounds: first by the winds in
    which a form misses them (a viewer sees the level in every wind, so the form that holds
    in more of them wins), then by `bounds_score`. The winds counted as `bounds_score`
    counts them."""
    small = _counted_winds(reports, largest_angles)
    misses = sum(1 for item, counts in zip(reports, small)
                 if counts and bounds_score([item], level, stalk=stalk) > 1.0)
    return misses, bounds_score(reports, level, largest_angles, stalk)
