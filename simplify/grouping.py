"""The groups of an explicit level (model.md 5): merged from the tips, cheapest merge first.

Level 0 is every original branch on its own. Level k+1 merges groups of level k into their
parent groups until at most `LEVEL_RATIO` of level k's groups are left, so groups are
connected, nested level in level, and the chain ends with one group per root branch
(Beaudoin & Keyser 2004 merge from the tips too). A merge of the group rooted at r into the
group rooted at u costs

    size · max(MIN_MERGE_FACTOR, 1 + W apart(r, u) + W_s spread + W_t Δturn + W_m Δmiss
                                  + W_f misfit + W_k skew)

- ``size``: size_r + size_u, smallest first, so groups grow evenly from the tips toward the
  trunk; size_r alone where r goes beside u's main path (u's level branch stays as it was, and
  r's members leave the measures: twigs go first, as LOD prunes them);
- ``apart``: how far r's bend and rotation periods are from the W_0 components of u they
  land on (one level branch has one period per W_0 component, model.md 6; `PeriodGap`),
  where r joins u's main path; 0 where r goes beside it (its members then leave the
  combined angle, and nothing of theirs is measured);
- ``spread``: how far the merged group's period moves with the wind (`ShareSpread`): its
  members' shares of its swing change where the leaf force (~v) drives a stalk's top and
  the drag (~v²) its length, or where another wind direction loads other members, so a
  group across that change has no one period, however its members' strengths compare. 0
  where r goes beside u. A chain has neither turns nor hanging groups, so the periods are
  all its merges can spoil: W_s = SHARE_SPREAD_WEIGHT outweighs the size term, and its top,
  where the leaf leads, stays unmerged while the length below merges (family stalk-9 at
  level 1: the top 13 branches alone). A branching tree weighs it with
  SHARE_SPREAD_BRANCHING_WEIGHT, while level 1 is merged only (docs/simplify.md, "Groups").
- ``Δturn``: how much the merge turns level branches against their group roots' frames.
  A level branch's swing frame is fixed by its chord and its parent's chord (model.md 3: x in
  their plane), so a merge that moves u's chord turns u's branch and every group hanging from
  it. Where a group root's bend and rotation strengths differ, its turned branch mixes two
  periods in each W_0 component, which no choice of its own strengths undoes; the turn of a
  group g costs |ln(k_bs/k_rs)| of its root times the mixing of its carry map C (the smaller
  of its largest diagonal and largest off-diagonal entry), and Δturn is that sum after the
  merge less before it (`FrameTurns`).
- ``Δmiss``: how much farther the merged group's rigid chord puts the tips it carries from the
  original's than the two groups did, in linear statics and in units of the level's tip bound
  (`TipMisses`). A chord swinging by its members' summed angle overshoots their tip, and a
  group hanging from a member part-way up the chord swings with the members above that member
  too; the lever is the hanging subtree's reach, so merging a trunk's segments moves the tips
  of every branch hung from them (family monopodial-1 at level 1: a 1.9 % of the height tip
  error at 10 m/s without this term, 0.1 % with it). Stalks (chains) have no hanging groups
  and are held to relative bounds; they go without it.

- ``misfit``: how far the best single branch misses the merged group's swing split between
  its two periods (`ModeMisfit`): a lateral rolled and pitched against its parent whose
  bend and rotation parts cancel across the periods answers with a matrix of rank 2 per
  period, and a level branch with one of rank 1. 0 where r goes beside u. Weighed only
  after level 1 (W_f = MODE_MISFIT_WEIGHT): at level 1 it formed other groups that missed
  for other reasons (docs/simplify.md, "Groups").

- ``skew`` (chains only): how far apart the merged group's upward and downward crossings pace
  over simplify's measurement window (`CrossingSkew`): members of other periods beat, and a
  wind from the other side reads the downward pace (model.md 6 reads upward crossings, and
  turns a linear response over), which one branch's single period cannot also hold within a
  stalk's 1 % (family stalk-0: a pair of k_rs 48.4 and 56.4 paced 2.81 s and 2.96 s). 0 where
  r goes beside u. W_k = CROSSING_SKEW_WEIGHT.

The terms are computed in simplify/merge_costs.py. Once level 1 is fitted, the members of
groups whose level branch missed its bounds can be kept apart (`merge_levels`' kept_apart:
level 1 takes their merges last) and the levels grouped again (simplify/regroup.py).
W = STRENGTH_MISMATCH_WEIGHT (one weight while level 1 is merged and a larger one for the
levels after it, as measured on the generated family; constants.py), W_t = FRAME_TURN_WEIGHT,
W_m = TIP_MISS_WEIGHT (likewise a pair).
Merge costs change as neighbours merge. After each merge the merges into the merged group
and of it are pushed again with their new costs (a twig becomes a side merge once its
branch's continuation has joined), and a popped merge whose cost has risen since it was
pushed goes back with its new cost (lazy greedy), so the cheapest merge under the current
groups is taken.
Deterministic: ties go to the lower branch index.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from plantlod.compare.groups import parse_address
from plantlod.lsys.tree import Tree

from .constants import (CROSSING_SKEW_WEIGHT, FRAME_TURN_WEIGHT, KEPT_APART_COST, LEVEL_BOUNDS,
                        LEVEL_RATIO, MIN_MERGE_FACTOR, MODE_MISFIT_WEIGHT,
                        SHARE_SPREAD_BRANCHING_WEIGHT, SHARE_SPREAD_WEIGHT,
                        STRENGTH_MISMATCH_WEIGHT, TIP_MISS_WEIGHT)
from .merge_costs import CrossingSkew, FrameTurns, ModeMisfit, PeriodGap, ShareSpread, TipMisses
from .merged_groups import HangingReach, MainPaths
from .static import rest_frames


@dataclass(frozen=True)
class Grouping:
    """The groups of one level: (B0,) int64 group of every original branch, groups numbered
    in order of their root branch (parents before children), and (G,) the root branch of each."""

    group: np.ndarray
    root: np.ndarray

    @property
    def count(self) -> int:
        return int(self.root.shape[0])


def level_counts(tree: Tree, ratio: float = LEVEL_RATIO) -> list[int]:
    """The group count of every level `merge_levels` makes, level 0 (every branch) to the last,
    from the counts alone: each level merges until it has max(⌊ratio c⌋, 1) groups of the c
    before it, or one per root branch where that is more (a group whose root has a parent
    can always merge), and the levels end at one group per root branch."""
    roots = int(np.count_nonzero(np.asarray(tree.parent) < 0))
    counts = [tree.n_branches]
    while counts[-1] > roots:
        counts.append(max(math.floor(ratio * counts[-1]), 1, roots))
    return counts


def merge_levels(tree: Tree, ratio: float = LEVEL_RATIO,
                 kept_apart: frozenset[int] = frozenset(), up_to: int | None = None,
                 misfit_weight: tuple[float, float] = MODE_MISFIT_WEIGHT) -> list[Grouping]:
    """Level 0 (every branch alone) to the last level (one group per root branch), or to
    level ``up_to`` where given (the levels before it are the same either way).

    Each level has at most ``ratio`` times the groups of the level before it,
    except that a tree of several root branches ends with one group per root.
    kept_apart: branches whose merge into their parent's group level 1 takes last, after
    every other merge (`regroup`: the main paths of level-1 groups whose fit missed); the
    count of every level stays the same.
    misfit_weight: W_f while level 1 is merged and after it (`regroup` tries level 1 priced
    with the mode misfit too, where the default grouping's level misses).
    """
    if not isinstance(tree, Tree):            # (an LSystem met an AttributeError; docs/api.md)
        from plantlod.lsys.errors import InputError

        raise InputError(f"merge_levels takes a Tree (plantlod.derive of an L-system), got "
                         f"{type(tree).__name__}")
    b = tree.n_branches
    parent = np.asarray(tree.parent, dtype=np.int64).tolist()
    levels = [Grouping(np.arange(b, dtype=np.int64), np.arange(b, dtype=np.int64))]
    if b == 0:
        return levels
    frames = rest_frames(tree)                   # shared by the three cost terms
    x_axis = frames.swing[:, :, 0].tolist()
    y_axis = frames.swing[:, :, 1].tolist()
    with np.errstate(divide="ignore", invalid="ignore"):
        log_k = np.log(np.stack([np.asarray(tree.bend_strength, dtype=np.float64),
                                 np.asarray(tree.rotation_strength, dtype=np.float64)], axis=1))
    gap = np.abs(log_k[:, 0] - log_k[:, 1])
    gap = np.where(np.isfinite(gap), gap, 0.0).tolist()
    log_k = np.where(np.isfinite(log_k), log_k, np.nan).tolist()
    apart = PeriodGap(x_axis, y_axis, log_k)
    turns = FrameTurns(frames.base.tolist(), frames.tip.tolist(), x_axis, y_axis, gap)
    alpha = np.asarray(tree.euler, dtype=np.float64).reshape(-1, 3)[:, 1]
    keys = [parse_address(a) for a in tree.address]
    children: list[list[int]] = [[] for _ in range(b)]
    for i, p in enumerate(parent):
        if p >= 0:
            children[p].append(i)

    owner = list(range(b))                       # union-find; a group is named by its root
    size = [1] * b
    end = list(range(b))                         # the last branch of each group's main path
    hanging: list[set[int]] = [set(children[i]) for i in range(b)]   # child groups' roots

    def find(i: int) -> int:
        while owner[i] != i:
            owner[i] = owner[owner[i]]
            i = owner[i]
        return i

    chords: dict[int, tuple[int, tuple[float, float, float]]] = {}

    def chord_of(g: int) -> tuple[float, float, float]:
        """Group g's chord direction (`FrameTurns.chord`), kept until g changes."""
        known = chords.get(g)
        if known is None or known[0] != version[g]:
            known = (version[g], turns.chord(g, end[g]))
            chords[g] = known
        return known[1]

    def up_axis(u: int):
        p = parent[u]
        if p < 0:
            return (0.0, 0.0, 1.0)
        return chord_of(find(p))

    def tip_miss(u: int, extra: int = -1, tip: int = -1) -> float:
        """`TipMisses.miss` of u's group (with ``extra`` merged into it; ``tip``: its main
        path's end where the caller has it), as a fraction of the level's tip bound."""
        key = (u, extra, version[u], version[extra] if extra >= 0 else 0)
        if key not in miss_cache:
            miss_cache[key] = misses.miss(u, paths.end(u, extra) if tip < 0 else tip,
                                          hanging_reach.hanging(u, extra))
        return miss_cache[key] / tip_bound

    def merge_key(r: int, u: int) -> tuple[float, int]:
        """The merge's cost (module docstring), its size times its factor, and the end of
        the merged group's main path."""
        old_u = chord_of(u)
        old_r = chord_of(r)
        new_end = paths.end(u, r)
        beside = new_end == end[u]               # u's main path stays as it is
        new_u = old_u if beside else turns.chord(u, new_end)
        axis_u = up_axis(u)
        before = turns.cost(u, old_u, axis_u) + turns.cost(r, old_r, old_u)
        after = turns.cost(u, new_u, axis_u)
        if not beside:                           # (beside, u's other groups keep their turn)
            for c in hanging[u]:
                if c != r:
                    d = chord_of(c)
                    before += turns.cost(c, d, old_u)
                    after += turns.cost(c, d, new_u)
        for c in hanging[r]:
            d = chord_of(c)
            before += turns.cost(c, d, old_r)
            after += turns.cost(c, d, new_u)
        missed = 0.0
        if tip_weight > 0:
            missed = tip_miss(u, r, new_end) - tip_miss(u) - tip_miss(r)
        # a group merged beside u's main path leaves the measures (model.md 6 reads main
        # paths): its periods beat against nothing, and u's level branch stays as it was
        gap = 0.0 if beside else apart(r, u)
        spread = 0.0 if beside or share_weight == 0 else shares(u, new_end)
        misfit = 0.0 if beside or level_misfit == 0 else modes(u, new_end)
        skew = 0.0 if beside or skews is None else skews(u, new_end)
        factor = max(MIN_MERGE_FACTOR, 1.0 + weight * gap + share_weight * spread
                     + level_misfit * misfit + skew_weight * skew
                     + FRAME_TURN_WEIGHT * (after - before) + tip_weight * missed)
        last = KEPT_APART_COST if len(levels) == 1 and r in kept_apart else 0.0
        return last + (size[r] if beside else size[r] + size[u]) * factor, new_end

    from .explicit import is_stalk           # (explicit imports this module)
    stalk = is_stalk(tree)
    misses = (TipMisses(tree, parent, children, frames)
              if max(TIP_MISS_WEIGHT) > 0 and not stalk else None)
    miss_cache: dict[tuple[int, int, int, int], float] = {}
    paths = MainPaths(parent, alpha, keys)
    hanging_reach = HangingReach(children, misses.reach, owner) if misses is not None else None
    shares = ShareSpread(tree, parent, frames)
    modes = ModeMisfit(shares, parent)
    skews = CrossingSkew(shares, tree, parent) if stalk and max(CROSSING_SKEW_WEIGHT) > 0 else None
    version = [0] * b                            # bumped when a group changes
    roots_left = set(range(b))
    def at_level(weights: tuple) -> float:
        """The entry of a per-level weight (level 1's, then the levels after it) for the level
        being merged."""
        return weights[min(len(levels), len(weights)) - 1]

    while up_to is None or len(levels) <= up_to:
        tip_bound = LEVEL_BOUNDS[min(len(levels), max(LEVEL_BOUNDS))][2]
        tip_weight = 0.0 if misses is None else at_level(TIP_MISS_WEIGHT)
        weight = at_level(STRENGTH_MISMATCH_WEIGHT)
        share_weight = SHARE_SPREAD_WEIGHT if stalk else at_level(SHARE_SPREAD_BRANCHING_WEIGHT)
        level_misfit = at_level(misfit_weight)
        skew_weight = at_level(CROSSING_SKEW_WEIGHT)
        count = len(roots_left)
        target = math.floor(ratio * count)
        mergeable = sorted(r for r in roots_left if parent[r] >= 0)
        if not mergeable:
            break
        heap = []
        for r in mergeable:
            u = find(parent[r])
            heap.append((merge_key(r, u)[0], r))
        heapq.heapify(heap)
        while heap and len(roots_left) > max(target, 1):
            key, r = heapq.heappop(heap)
            if r not in roots_left:
                continue
            u = find(parent[r])
            now, new_end = merge_key(r, u)
            if now > key * (1.0 + 1e-12) and heap and now > heap[0][0]:
                heapq.heappush(heap, (now, r))        # dearer than when pushed: wait its turn
                continue
            owner[r] = u
            paths.joined(r)
            size[u] += size[r]
            end[u] = new_end
            hanging[u] = (hanging[u] - {r}) | hanging[r]
            if hanging_reach is not None:          # (read by the tip miss alone)
                hanging_reach.joined(u, r)
            roots_left.discard(r)
            version[u] += 1
            # the merges into u and of u have new costs: pushed again with them, so that a
            # cheaper one is taken in its turn (older entries stay, checked when popped)
            for c in sorted(hanging[u]) + ([u] if parent[u] >= 0 else []):
                heapq.heappush(heap, (merge_key(c, find(parent[c]))[0], c))
        group_root = np.array([find(i) for i in range(b)], dtype=np.int64)
        roots = np.array(sorted(roots_left), dtype=np.int64)
        number = np.full(b, -1, dtype=np.int64)
        number[roots] = np.arange(len(roots))
        levels.append(Grouping(number[group_root], roots))
        if len(roots_left) == count:
            break
    return levels
