"""The groups of an explicit level (model.md 5): merged from the tips, cheapest merge first.

Level 0 is every original branch on its own. Level k+1 merges groups of level k into their
parent groups until at most `LEVEL_RATIO` of level k's groups are left, so groups are
connected, nested level in level, and the chain ends with one group per root branch
(Beaudoin & Keyser 2004 merge from the tips too). A merge of the group rooted at r into the
group rooted at u costs

    (size_r + size_u) · max(MIN_MERGE_FACTOR, 1 + W apart(r, u) + W_t Δturn)

- ``size``: smallest first, so groups grow evenly from the tips toward the trunk;
- ``apart``: how far r's bend and rotation periods are from the W_0 components of u they
  land on (one level branch has one period per W_0 component, model.md 6; `PeriodGap`);
- ``Δturn``: how much the merge turns level branches against their group roots' frames.
  A level branch's swing frame is fixed by its chord and its parent's chord (model.md 3: x in
  their plane), so a merge that moves u's chord turns u's branch and every group hanging from
  it. Where a group root's bend and rotation strengths differ, its turned branch mixes two
  periods in each W_0 component, which no choice of its own strengths undoes; the turn of a
  group g costs |ln(k_bs/k_rs)| of its root times the mixing of its carry map C (the smaller
  of its largest diagonal and largest off-diagonal entry), and Δturn is that sum after the
  merge less before it (`FrameTurns`).

W = STRENGTH_MISMATCH_WEIGHT (one weight while level 1 is merged and a larger one for the
levels after it, as measured on the generated family; constants.py), W_t = FRAME_TURN_WEIGHT.
Merge costs change as neighbours merge; a popped merge whose cost has risen is pushed back
with its new cost (lazy greedy), so the cheapest merge under the current groups is taken.
Deterministic: ties go to the lower branch index.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from plantlod.compare.groups import pick_main_member, parse_address
from plantlod.lsys.tree import Tree

from .constants import FRAME_TURN_WEIGHT, LEVEL_RATIO, MIN_MERGE_FACTOR, STRENGTH_MISMATCH_WEIGHT


@dataclass(frozen=True)
class Grouping:
    """The groups of one level: (B0,) int64 group of every original branch, groups numbered
    in order of their root branch (parents before children), and (G,) the root branch of each."""

    group: np.ndarray
    root: np.ndarray

    @property
    def count(self) -> int:
        return int(self.root.shape[0])


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _carry_mixing(x0, y0, xs, ys) -> float:
    """How much a branch whose swing frame has axes (xs, ys) mixes bend and rotation when read
    in the frame (x0, y0): with M = W_0ᵀ W', C = [[M11, -M10], [-M01, M00]]
    (`compare.groups.carry_matrix`), min(max(|C00|, |C11|), max(|C01|, |C10|))."""
    m00, m01, m10, m11 = _dot(x0, xs), _dot(x0, ys), _dot(y0, xs), _dot(y0, ys)
    return min(max(abs(m11), abs(m00)), max(abs(m10), abs(m01)))


class PeriodGap:
    """apart(r, u) = max_c Σ_m |C[c, m]| |ln(k_m,r / k_c,u)| / Σ_m |C[c, m]|, with C the carry
    map of r's rest swing frame into u's and k_m the bend and rotation strengths of the roots:
    members whose components land on a W_0 component of another period beat against it."""

    def __init__(self, x_axis: list, y_axis: list, log_k: list):
        self.x_axis, self.y_axis, self.log_k = x_axis, y_axis, log_k
        self.cache: dict[tuple[int, int], float] = {}

    def __call__(self, r: int, u: int) -> float:
        if (r, u) in self.cache:
            return self.cache[r, u]
        xu, yu, xr, yr = self.x_axis[u], self.y_axis[u], self.x_axis[r], self.y_axis[r]
        c = ((abs(_dot(yu, yr)), abs(_dot(yu, xr))), (abs(_dot(xu, yr)), abs(_dot(xu, xr))))
        worst = 0.0
        for row in range(2):
            weight = c[row][0] + c[row][1]
            if weight <= 0:
                continue
            gap = [abs(self.log_k[r][m] - self.log_k[u][row]) for m in range(2)]
            gap = [g if math.isfinite(g) else 0.0 for g in gap]
            worst = max(worst, (c[row][0] * gap[0] + c[row][1] * gap[1]) / weight)
        self.cache[r, u] = worst
        return worst


class FrameTurns:
    """The turn cost of level branches against their group roots' frames (module docstring).

    base, tip (B, 3) rest positions; x_axis, y_axis: each branch's rest swing frame columns;
    gap (B,): |ln(k_bs/k_rs)| per branch."""

    def __init__(self, base: list, tip: list, x_axis: list, y_axis: list, gap: list):
        self.base, self.tip, self.x_axis, self.y_axis, self.gap = base, tip, x_axis, y_axis, gap

    def chord(self, root: int, end: int) -> tuple[float, float, float]:
        """Unit direction from ``root``'s base to ``end``'s tip."""
        d = [self.tip[end][i] - self.base[root][i] for i in range(3)]
        n = math.sqrt(_dot(d, d))
        return (0.0, 0.0, 1.0) if n == 0 else (d[0] / n, d[1] / n, d[2] / n)

    def cost(self, root: int, d, up) -> float:
        """gap × mixing of a level branch of direction ``d`` hanging from a parent of axis
        ``up``, read in ``root``'s rest swing frame. Its swing frame's x axis lies in the plane
        of up and d, away from up (model.md 3): x = (cos a d - up) / sin a."""
        if self.gap[root] == 0.0:
            return 0.0
        c = _dot(d, up)
        s2 = 1.0 - c * c
        if s2 < 1e-12:                           # straight on: the parent's own roll decides
            return 0.0
        s = math.sqrt(s2)
        xs = [(c * d[i] - up[i]) / s for i in range(3)]
        ys = [d[1] * xs[2] - d[2] * xs[1], d[2] * xs[0] - d[0] * xs[2], d[0] * xs[1] - d[1] * xs[0]]
        return self.gap[root] * _carry_mixing(self.x_axis[root], self.y_axis[root], xs, ys)


def merge_levels(tree: Tree, ratio: float = LEVEL_RATIO) -> list[Grouping]:
    """Level 0 (every branch alone) to the last level (one group per root branch).

    Each level has at most ``ratio`` times the groups of the level before it,
    except that a tree of several root branches ends with one group per root.
    """
    from plantlod.sim.kinematics import rest_pose

    b = tree.n_branches
    parent = np.asarray(tree.parent, dtype=np.int64).tolist()
    levels = [Grouping(np.arange(b, dtype=np.int64), np.arange(b, dtype=np.int64))]
    if b == 0:
        return levels
    pose = rest_pose(tree)
    x_axis = pose.swing[:, :, 0].tolist()
    y_axis = pose.swing[:, :, 1].tolist()
    with np.errstate(divide="ignore", invalid="ignore"):
        log_k = np.log(np.stack([np.asarray(tree.bend_strength, dtype=np.float64),
                                 np.asarray(tree.rotation_strength, dtype=np.float64)], axis=1))
    gap = np.abs(log_k[:, 0] - log_k[:, 1])
    gap = np.where(np.isfinite(gap), gap, 0.0).tolist()
    log_k = np.where(np.isfinite(log_k), log_k, np.nan).tolist()
    apart = PeriodGap(x_axis, y_axis, log_k)
    turns = FrameTurns(pose.base.tolist(), pose.tip.tolist(), x_axis, y_axis, gap)
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

    def main_end(u: int, extra: int = -1) -> int:
        """The end of u's main path, with group ``extra`` merged into it."""
        cur = u
        while True:
            kids = [c for c in children[cur] if find(c) == u or (extra >= 0 and find(c) == extra)]
            if not kids:
                return cur
            cur = pick_main_member(kids, alpha, keys)

    def up_axis(u: int):
        p = parent[u]
        if p < 0:
            return (0.0, 0.0, 1.0)
        g = find(p)
        return turns.chord(g, end[g])

    def cost(r: int, u: int) -> float:
        """The merge's cost factor (module docstring)."""
        old_u = turns.chord(u, end[u])
        old_r = turns.chord(r, end[r])
        new_u = turns.chord(u, main_end(u, r))
        axis_u = up_axis(u)
        before = turns.cost(u, old_u, axis_u) + turns.cost(r, old_r, old_u)
        after = turns.cost(u, new_u, axis_u)
        for c in hanging[u]:
            if c != r:
                d = turns.chord(c, end[c])
                before += turns.cost(c, d, old_u)
                after += turns.cost(c, d, new_u)
        for c in hanging[r]:
            d = turns.chord(c, end[c])
            before += turns.cost(c, d, old_r)
            after += turns.cost(c, d, new_u)
        return max(MIN_MERGE_FACTOR, 1.0 + weight * apart(r, u)
                   + FRAME_TURN_WEIGHT * (after - before))

    roots_left = set(range(b))
    while True:
        weight = STRENGTH_MISMATCH_WEIGHT[min(len(levels), len(STRENGTH_MISMATCH_WEIGHT)) - 1]
        count = len(roots_left)
        target = math.floor(ratio * count)
        mergeable = sorted(r for r in roots_left if parent[r] >= 0)
        if not mergeable:
            break
        heap = []
        for r in mergeable:
            u = find(parent[r])
            heap.append(((size[r] + size[u]) * cost(r, u), r))
        heapq.heapify(heap)
        while heap and len(roots_left) > max(target, 1):
            key, r = heapq.heappop(heap)
            if r not in roots_left:
                continue
            u = find(parent[r])
            now = (size[r] + size[u]) * cost(r, u)
            if now > key * (1.0 + 1e-12) and heap and now > heap[0][0]:
                heapq.heappush(heap, (now, r))        # dearer than when pushed: wait its turn
                continue
            new_end = main_end(u, r)
            owner[r] = u
            size[u] += size[r]
            end[u] = new_end
            hanging[u] = (hanging[u] - {r}) | hanging[r]
            roots_left.discard(r)
        group_root = np.array([find(i) for i in range(b)], dtype=np.int64)
        roots = np.array(sorted(roots_left), dtype=np.int64)
        number = np.full(b, -1, dtype=np.int64)
        number[roots] = np.arange(len(roots))
        levels.append(Grouping(number[group_root], roots))
        if len(roots_left) == count:
            break
    return levels
