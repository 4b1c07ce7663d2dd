"""What `grouping.merge_levels` asks of its groups as they merge, kept up to date merge by merge.

Groups are connected (model.md 5), so a child in its parent's group is one that merged into
it, and a child outside is the root of its own group, a group *hanging* from that parent.
The merge costs ask, for a group and for a group with one hanging group merged into it:

- the end of its main path (`MainPaths.end`): at each member the merged child with the
  smallest alpha (ties within ALPHA_TIE_TOL, then the lowest address; `pick_main_member`);
- for each member that groups hang from, the largest reach of those groups
  (`HangingReach.hanging`, for `merge_costs.TipMisses.miss`).

Read from the children each time, both cost a member's children per question, and a branch
with h children (a fan of laterals) is asked about h times per merge into it: h² per merge.
Kept per branch instead (its pick among merged children; its children ordered by reach with
the places of the first that still root a group), each costs the members on the path or the
members with hanging groups, whatever their children.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from plantlod.compare.constants import ALPHA_TIE_TOL
from plantlod.compare.groups import AddressKey, pick_main_member


class MainPaths:
    """Each branch's pick among its merged children, so that a main path is walked in its
    length. Index arrays are over the original's B branches."""

    def __init__(self, parent: Sequence[int], alpha: np.ndarray, keys: Sequence[AddressKey]):
        """parent: (B,) each branch's parent (-1: a root); alpha: (B,) rest alpha, rad;
        keys: (B,) address keys."""
        self.parent = parent
        self.alpha = alpha
        self.keys = keys
        b = len(parent)
        self.merged: list[list[int]] = [[] for _ in range(b)]   # children in the branch's group
        self.pick = [-1] * b                 # pick_main_member(merged[i]), or -1 where none
        self.smallest = [math.inf] * b       # the smallest alpha of merged[i]

    def joined(self, r: int) -> None:
        """The group rooted at r merged into its parent's group."""
        p = self.parent[r]
        self.pick[p] = r if self.pick[p] < 0 else self._with(p, self.pick[p], r)
        self.merged[p].append(r)
        self.smallest[p] = min(self.smallest[p], self.alpha[r])

    def end(self, u: int, extra: int = -1) -> int:
        """The end of the main path of the group rooted at u (its group tip), with the group
        rooted at ``extra`` (one hanging from u's group) merged into it."""
        cur = u
        while True:
            pick = self.pick[cur]
            if extra >= 0 and self.parent[extra] == cur:
                pick = extra if pick < 0 else self._with(cur, pick, extra)
            if pick < 0:
                return cur
            cur = pick

    def _with(self, cur: int, pick: int, extra: int) -> int:
        """pick_main_member(merged[cur] + [extra]), given ``pick``, the pick without ``extra``.
        Where ``extra``'s alpha is not below the smallest, the smallest stays and the tied set
        only gains ``extra``; the tie tolerance is not transitive, so a smaller alpha picks
        anew."""
        smallest = self.smallest[cur]
        if self.alpha[extra] < smallest:
            return pick_main_member(self.merged[cur] + [extra], self.alpha, self.keys)
        if self.alpha[extra] <= smallest + ALPHA_TIE_TOL and self.keys[extra] < self.keys[pick]:
            return extra
        return pick


class HangingReach:
    """For each group, its members that groups hang from, and the largest reach of the groups
    hanging from each.

    Each branch keeps its children by reach, largest first, and the places in that order of
    the first and the second child that still root a group (the second: for a merge that
    takes the first). Groups only ever merge, so both places only move on: amortised, a
    question costs the members asked about.
    """

    def __init__(self, children: Sequence[Sequence[int]], reach: Sequence[float],
                 owner: list[int]):
        """children: (B,) each branch's children; reach: (B,) the farthest point of each
        branch's subtree from its base, m (`TipMisses.reach`); owner: the caller's union-find,
        read only (a branch roots a group while owner[i] == i)."""
        self.reach = reach
        self.owner = owner
        self.order = [sorted(kids, key=lambda c: -reach[c]) for kids in children]
        b = len(children)
        self.first = [0] * b
        self.second = [0] * b
        self.attached = [[i] if children[i] else [] for i in range(b)]   # per group root

    def widest(self, m: int, skip: int = -1) -> float:
        """The largest reach of the groups hanging from branch m, the group rooted at ``skip``
        left out; -1.0 where none is left."""
        order, owner = self.order[m], self.owner
        n = len(order)
        i = self.first[m]
        while i < n and owner[order[i]] != order[i]:
            i += 1
        self.first[m] = i
        if i == n:
            return -1.0
        if order[i] != skip:
            return self.reach[order[i]]
        j = max(self.second[m], i + 1)
        while j < n and owner[order[j]] != order[j]:
            j += 1
        self.second[m] = j
        return self.reach[order[j]] if j < n else -1.0

    def hanging(self, u: int, extra: int = -1) -> list[tuple[int, float]]:
        """(m, widest reach at m) for every member m of the group rooted at u (with the group
        rooted at ``extra``, hanging from it, merged in) that groups hang from."""
        members = self.attached[u] if extra < 0 else self.attached[u] + self.attached[extra]
        return [(m, w) for m in members if (w := self.widest(m, extra)) >= 0.0]

    def joined(self, u: int, r: int) -> None:
        """The group rooted at r merged into the group rooted at u (owner already says so)."""
        self.attached[u] = [m for m in self.attached[u] + self.attached[r]
                            if self.widest(m) >= 0.0]
        self.attached[r] = []
