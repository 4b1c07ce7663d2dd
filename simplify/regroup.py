"""Level 1 regrouped where its fitted level misses: groups chosen by how the level moves.

The grouping (`grouping.merge_levels`) prices each merge from the original's statics and its
members' swing models, before any level exists; what it cannot price shows only once the
level is fitted and run (a member's bend turning its child's frame, forces a parent level
branch passes on, periods that beat; docs/simplify.md, "Limits"). So level 1 is fitted
(statics and motion, `explicit.explicit_system_text`), and its runs in simplify's
measurement winds, those where the original stays within 0.1 rad and its linear statics turn
no axis past it (the others only where these miss nothing: `missing_paths`), score every
level branch against level 1's bounds (`motion_fit.group_scores`, the worst of its motion,
period and tip figures over their bounds). Where branches miss, the main paths of their
groups are kept apart: level 1 merges those members into their parents' groups last, after
every other merge (`merge_levels`' kept_apart, `KEPT_APART_COST`; the count of every level
stays the same, so model.md 5's 60 % holds and the chain's counts do not change), and level
1 is fitted again. The kept-apart set grows with each attempt's missing groups; of the
`REGROUP_ATTEMPTS` fits, the level that ranks best in the same winds (`missing_paths`: the
winds it misses that a grouping can mend, then `bounds.form_rank`'s winds missed and worst
ratio; the first attempt on a tie) is kept, with the levels above it grouped on it (nested
as before). Trees of more than `REGROUP_MAX_BRANCHES` branches are grouped as they are (each
attempt costs a level-1 fit).

Where every such attempt still misses in some wind, level 1 is grouped again with a second
pricing, the mode misfit weighed while level 1 is merged too, at each weight of
`REGROUP_MISFIT_PRICINGS` in turn (150, then 1000; at most 3, then 2 fits, kept apart as
above), as long as no attempt holds in every wind: a group whose members' bend and rotation
parts cancel across their two periods answers with more than one branch can (`merge_costs.
ModeMisfit`, family sympodial trees whose k_bs and k_rs differ). At 150 a sympodial fork
whose main path runs to its rolled lateral can still be cheaper than two pairs along the
laterals that line up (family sympodial-209: 0 of 20 cases at 150, 12 at 1000). Weighed for
every tree it cost other kinds as many cases as it gained (docs/simplify.md, "Limits"); tried
as one more candidate, it is kept only where its level ranks better. A grouping already
fitted is not fitted again (where no merge's misfit differs, as along a straight chain, the
later pricings group as the first).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree

from .bounds import form_rank
from .constants import (MODE_MISFIT_WEIGHT, REGROUP_ATTEMPTS, REGROUP_MAX_BRANCHES,
                        REGROUP_MISFIT_PRICINGS, SMALL_ANGLE_LIMIT, STALK_BOUNDS)
from .evaluate import Runs
from .grouping import Grouping, merge_levels
from .motion_fit import group_scores, opposite_period_errors, within_turn

LevelText = tuple[str, Tree]


def missing_paths(tree: Tree, runs: Runs, stalk: bool) -> tuple[tuple, set[int]]:
    """The level's rank in ``runs``' winds and the members of the main paths of its missing
    groups, their roots left out: (rank, branches), each branch's merge into its parent's
    group being one its group needed.

    runs: the original's `Runs` read with ``tree``'s groups; a branch misses where its
    `group_scores` pass 1 in the winds a grouping can mend: those where the original stays
    within SMALL_ANGLE_LIMIT and its linear statics turn no branch's axis past
    MOTION_FIT_TURN (`motion_fit.within_turn`, the winds the motion fit runs). Where an axis
    turns further (a chain's top, a long lateral), the frames the tree below swings drive
    every group above it (docs/simplify.md, Limits 3), and no grouping tried mends that:
    those winds are ranked after the others, and keep groups apart only where the others
    miss nothing (else they would keep every merged member apart, and leave the regrouping
    nothing to choose between).
    rank: (winds missed that a grouping can mend, winds missed, worst ratio), the last two
    `bounds.form_rank` at level 1.

    A chain is also read in the opposite winds: where it is linear the reversed wind gives
    the negative response, whose period is the downward crossings'
    (`motion_fit.opposite_period_errors`); a group whose period there passes the level's
    bound misses, and each such wind counts as one more wind missed (a mendable one), its
    ratio in the worst. (Read for branching trees too, with their major components, it lost
    the tuning range 4 level-1 cases, bush3d-130 10 → 6 of 20.)
    """
    reports = runs.compare(tree, downward=stalk)
    largest = runs.largest_combined_angle()
    misses, worst = form_rank(list(zip(runs.winds, reports)), 1, largest, stalk)
    counted = [a <= SMALL_ANGLE_LIMIT for a in largest]
    linear = within_turn(runs.original, runs.winds)
    held = [c and lin for c, lin in zip(counted, linear)]
    scores = group_scores([r for r, h in zip(reports, held) if h], 1, stalk, tree.n_branches)
    mendable, _ = form_rank([(w, r) for w, r, h in zip(runs.winds, reports, held) if h], 1,
                            stalk=stalk)
    if stalk:
        bound = STALK_BOUNDS[1][1]
        for errors in opposite_period_errors(runs, tree, reports):
            if errors is None:
                continue
            ratios = errors / bound
            missed = int(ratios.max(initial=0.0) > 1.0)
            misses += missed
            mendable += missed
            worst = max(worst, float(ratios.max(initial=0.0)))
            scores = np.maximum(scores, ratios)
    if not (scores > 1.0).any():              # (nothing to mend: every counted wind's misses)
        scores = group_scores([r for r, c in zip(reports, counted) if c], 1, stalk,
                              tree.n_branches)
    paths = runs.gmap.paths                       # ``tree``'s groups, as the runs read them
    return ((mendable, misses, worst),
            {int(m) for s in np.flatnonzero(scores > 1.0) for m in paths[s][1:]})


def regrouped(original: Tree, groupings: list[Grouping], fit: Callable[[Grouping], LevelText],
              runs_for: Callable[[Tree], Runs],
              fitted: Callable[[int, int], None] | None = None
              ) -> tuple[list[Grouping], LevelText | None]:
    """Every level's grouping with level 1's chosen by its fitted level (module docstring),
    and level 1's (text, tree) for it; (``groupings``, None) where nothing was fitted here
    (a tree of one level or of more than REGROUP_MAX_BRANCHES branches).

    groupings: `merge_levels(original)` (to the last level, or to the one the caller fits);
    fit(grouping): level 1 fitted with ``grouping``
    (text, tree); runs_for(tree): the original's `Runs` in the measurement winds read with
    ``tree``'s groups (`motion_fit.shared_runs`). InputError from the first fit is raised;
    a later attempt that fails (a level that diverges) ends the attempts.
    fitted(k, most): called after the k-th fit of at most ``most`` (a progress display;
    simplify stood at 0 % for 10 s while they ran, a newcomer's first hour).
    """
    from .explicit import is_stalk                # (explicit imports grouping)

    if len(groupings) < 2 or original.n_branches > REGROUP_MAX_BRANCHES:
        return groupings, None
    stalk = is_stalk(original)
    up_to = len(groupings) - 1                    # (a single level's caller groups no coarser)
    best = None                                   # (rank, groupings, level)
    tried: set[bytes] = set()                     # level-1 groupings fitted
    pricings = ((MODE_MISFIT_WEIGHT, REGROUP_ATTEMPTS),) + tuple(
        ((w, w), attempts) for w, attempts in REGROUP_MISFIT_PRICINGS)
    most = sum(attempts for _, attempts in pricings)
    for pricing, (weight, attempts) in enumerate(pricings):
        if best is not None and best[0][0] == 0:  # it holds in every wind: nothing to try
            break
        kept_apart: set[int] = set()
        for attempt in range(attempts):
            if attempt or pricing:                # (the first: the caller's groupings)
                groupings = merge_levels(original, kept_apart=frozenset(kept_apart), up_to=up_to,
                                         misfit_weight=weight)
            if groupings[1].group.tobytes() in tried:
                break                             # (fitted already: the same level)
            tried.add(groupings[1].group.tobytes())
            try:
                level = fit(groupings[1])
                rank, missing = missing_paths(level[1], runs_for(level[1]), stalk)
            except InputError:
                if best is None:
                    raise
                break
            if fitted is not None:
                fitted(len(tried), most)
            if best is None or rank < best[0]:
                best = (rank, groupings, level)
            if not missing - kept_apart:          # nothing missing, or nothing new to keep apart
                break
            kept_apart |= missing
    return best[1], best[2]
