"""The terms of an explicit grouping's merge cost (simplify/grouping.py, docs/simplify.md "Groups").

- `PeriodGap`: how far a merged group's periods are from the W_0 components they land on;
- `FrameTurns`: how much a merge turns level branches against their group roots' frames;
- `TipMisses`: how far a group's rigid chord puts the points it carries from the original's;
- `ShareSpread`: how far a group's period moves with the wind (chains);
- `ModeMisfit`: how far one branch falls short of a group whose members' parts cancel;
- `CrossingSkew`: how far apart a group's upward and downward crossings pace (chains).

Each works on the original tree's rest geometry (and, for the tip misses and the skew, its
linear statics; the skew also on each strength's response from rest)
and on plain Python numbers: `merge_levels` calls them tens of thousands of times.
"""

from __future__ import annotations

import math

import numpy as np

from plantlod.compare.measures import period
from plantlod.lsys.tree import Tree

from .constants import (SHARE_SPREAD_FLOOR, SIMPLIFY_DT, SIMPLIFY_DURATION, SIMPLIFY_EVERY,
                        SIMPLIFY_WIND_RANGE, SMALL_ANGLE_LIMIT)
from .static import (RestFrames, horizontal_directions, rest_frames, rotation_parts, static_angles_at,
                     static_parts)
from .swing_model import unit_response


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _carry_mixing(x0, y0, xs, ys) -> float:
    """How much a branch whose swing frame has axes (xs, ys) mixes bend and rotation when read
    in the frame (x0, y0): with M = W_0ᵀ W', C = [[M11, -M10], [-M01, M00]]
    (`compare.groups.carry_matrix`), min(max(|C00|, |C11|), max(|C01|, |C10|))."""
    m00, m01, m10, m11 = _dot(x0, xs), _dot(x0, ys), _dot(y0, xs), _dot(y0, ys)
    return min(max(abs(m11), abs(m00)), max(abs(m10), abs(m01)))


def path_up(parent: list[int], root: int, end: int) -> list[int]:
    """The branches from ``end`` up to ``root`` (both included), ``end`` first: a main path
    from its tip. ValueError where ``end`` does not descend from ``root``."""
    path = [end]
    while path[-1] != root:
        up = parent[path[-1]]
        if up < 0:
            raise ValueError(f"branch {end} does not descend from branch {root}")
        path.append(up)
    return path


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


class TipMisses:
    """How far a group's rigid chord puts the points it carries from where the original's are,
    in linear statics (model.md 6's tip error, estimated before anything is fitted).

    A level branch turns by its main path's summed rotation ω_P about its root's base. The
    original's members turn about their own bases, and a group hanging from member m of the
    group turns only with the members from the root to m. So, with ω_j the static rotation
    vectors (world axes) of the original's branches in the strongest wind simplify measures
    (SIMPLIFY_WIND_RANGE's top, toward x and toward y),

        miss(g) = |Σ_{j in P} ω_j × (base_j - base_g)|                  (the chord's tip)
                + max_c |ω_P - Σ_{j in g, j ≤ m_c} ω_j| (|tip_m_c - base_g| + reach(c))

    over the groups c hanging from g at members m_c (reach: the farthest point of c's subtree
    from its base). Both parts are norms over the two winds. ``scale`` (at most 1) shrinks them
    to the strongest winds the bounds hold in: where the tree's most turned branch passes
    SMALL_ANGLE_LIMIT / 2 (the static half of a swing from rest that reaches the limit), to
    that.
    """

    def __init__(self, tree: Tree, parent: list[int], children: list[list[int]],
                 frames: RestFrames | None = None):
        """parent, children: the tree's, as lists; frames: its `static.rest_frames` where the
        caller has them."""
        frames = rest_frames(tree) if frames is None else frames
        directions = horizontal_directions(4)[:2]                        # toward x and y
        bend, rot = static_angles_at(tree, static_parts(tree, directions, frames),
                                     SIMPLIFY_WIND_RANGE[1], frames)     # (2, B)
        omega = rotation_parts(bend, rot, frames).sum(axis=-2)          # (2, B, 3)
        # running sums from the root down, per wind: A_i = Σ ω_j and X_i = Σ ω_j × base_j over
        # i and its ancestors, so that sums along a group's chains are differences
        from .tree_sums import TreeSums

        base = frames.base
        down = TreeSums(np.asarray(parent, dtype=np.int64))
        ones = np.ones(len(parent))
        turned = down.down(ones, omega)
        crossed = down.down(ones, np.cross(omega, base[None]))
        most = float(np.sqrt((turned ** 2).sum(axis=2)).max(initial=0.0))
        self.turned = turned.transpose(1, 0, 2).reshape(len(parent), 6).tolist()
        self.crossed = crossed.transpose(1, 0, 2).reshape(len(parent), 6).tolist()
        self.base = base.tolist()
        self.tip = frames.tip.tolist()
        reach = [0.0] * len(parent)
        for i in range(len(parent) - 1, -1, -1):                         # children after parents
            far = math.dist(self.tip[i], self.base[i])
            for c in children[i]:
                far = max(far, math.dist(self.base[c], self.base[i]) + reach[c])
            reach[i] = far
        self.reach = reach
        self.parent = parent
        self.scale = 0.0 if most == 0 else min(1.0, 0.5 * SMALL_ANGLE_LIMIT / most)

    def miss(self, root: int, end: int, hanging) -> float:
        """miss(g) in metres times ``scale`` for the group rooted at ``root`` whose main path
        ends at ``end``; ``hanging``: (m, reach) for each member m that child groups hang from,
        with the largest reach(c) of those groups (the max over c at one m is the max of
        their terms, exactly: sums and products by a positive number round monotonely, so a
        fan of hundreds of groups on one member costs one term). Groups are connected, so the
        members from the root to any member m are m's ancestors below the root's parent q:
        ω_P = A_end - A_q, Σ_{j in P} ω_j × base_j = X_end - X_q, and the rotation a group
        hanging from m misses is ω_P - (A_m - A_q) = A_end - A_m."""
        q = self.parent[root]
        a_end, x_end = self.turned[end], self.crossed[end]
        a_q = self.turned[q] if q >= 0 else (0.0,) * 6
        x_q = self.crossed[q] if q >= 0 else (0.0,) * 6
        b0 = self.base[root]
        offset = 0.0                                # |Σ ω_j × (base_j - base_g)|², both winds
        for k in (0, 3):
            w0, w1, w2 = a_end[k] - a_q[k], a_end[k + 1] - a_q[k + 1], a_end[k + 2] - a_q[k + 2]
            c0 = x_end[k] - x_q[k] - (w1 * b0[2] - w2 * b0[1])
            c1 = x_end[k + 1] - x_q[k + 1] - (w2 * b0[0] - w0 * b0[2])
            c2 = x_end[k + 2] - x_q[k + 2] - (w0 * b0[1] - w1 * b0[0])
            offset += c0 * c0 + c1 * c1 + c2 * c2
        worst = 0.0
        for m, reach in hanging:
            a_m = self.turned[m]
            d0, d1, d2 = a_end[0] - a_m[0], a_end[1] - a_m[1], a_end[2] - a_m[2]
            d3, d4, d5 = a_end[3] - a_m[3], a_end[4] - a_m[4], a_end[5] - a_m[5]
            d = d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3 + d4 * d4 + d5 * d5
            if d > 0.0:
                worst = max(worst, math.sqrt(d) * (math.dist(self.tip[m], b0) + reach))
        return self.scale * (math.sqrt(offset) + worst)


class ShareSpread:
    """How far a group's period moves with the wind: the spread, over wind loadings, of the
    swing-weighted mean log-strength of its main path in each W_0 component.

    A level branch has one period per W_0 component (model.md 6). Its group's component swings
    as the sum of its members' parts (`explicit.dominant_strengths`), each with its own period
    and a size that is its static angle carried into W_0. Where those shares stay the same
    whatever the wind, one period (fitted to their sum) serves every wind, however different
    the members; where they change (the leaf force, ~v, drives the top of a stalk and the
    drag, ~v², its whole length; another wind direction loads other members), the sum's
    period moves and one branch cannot follow it. With θ_m,j(l) member j's static angles in
    loading l (m: bend, rotation), C_j its carry map into the root's frame W_0 (model.md 5)
    and k_m,j its strengths:

        λ_c(l) = Σ_j Σ_m |C_j[c, m] θ_m,j(l)| ln k_m,j / Σ_j Σ_m |C_j[c, m] θ_m,j(l)|

    over the main path (a weighted mean: it stays within the members' strengths, whatever
    signs their parts have); spread = max_c (max_l λ_c(l) - min_l λ_c(l)) over the loadings
    where the component's parts, summed in size (Σ_j Σ_m |C_j[c, m] θ_m,j(l)|, the weights
    above), are at least SHARE_SPREAD_FLOOR of the group's largest such sum at that speed.
    (Where parts cancel, that sum is larger than the component's static swing: a period
    mix counts even where the static angles sum to little, since the parts swing apart.) Loadings: speeds low, sqrt(low high) and high of
    SIMPLIFY_WIND_RANGE, four directions (0, 45, 90, 135 deg). C_j[c, m] θ_m,j = e_c · ω_m,j
    with ω_b,j = θb_j y_j and ω_r,j = -θr_j x_j (world axes) and e_b = y_0, e_r = -x_0 the
    root's axes, so each member's parts are kept as world vectors and read per root.
    """

    def __init__(self, tree: Tree, parent: list[int], frames: RestFrames):
        low, high = SIMPLIFY_WIND_RANGE
        directions = horizontal_directions(8)[:4]
        parts = static_parts(tree, directions, frames)
        k = np.stack([np.asarray(tree.bend_strength, dtype=np.float64),
                      np.asarray(tree.rotation_strength, dtype=np.float64)], axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.log_k = np.where(k > 0, np.log(np.where(k > 0, k, 1.0)), 0.0)   # (B, 2)
        vectors = [rotation_parts(*static_angles_at(tree, parts, speed, frames), frames)
                   for speed in (low, math.sqrt(low * high), high)]               # (D, B, m, 3)
        # (B, S, D, m, 3): each member's bend and rotation parts, world vectors
        self.parts = np.stack(vectors, axis=0).transpose(2, 0, 1, 3, 4).copy()
        self.parent = parent
        self.axes = np.stack([frames.swing[:, :, 1], -frames.swing[:, :, 0]], axis=1)  # (B, c, 3)
        self.cache: dict[tuple[int, int], float] = {}

    def __call__(self, root: int, end: int) -> float:
        """The spread of the group rooted at ``root`` whose main path ends at ``end`` (the
        path: ``end`` and its ancestors up to ``root``)."""
        key = (root, end)
        if key in self.cache:
            return self.cache[key]
        path = path_up(self.parent, root, end)
        size = np.abs(np.einsum("jsdmk,ck->jcsdm", self.parts[path], self.axes[root]))
        den = size.sum(axis=(0, 4))                                               # (c, S, D)
        num = np.einsum("jcsdm,jm->csd", size, self.log_k[path])
        floor = SHARE_SPREAD_FLOOR * den.max(axis=(0, 2), keepdims=True)
        ok = (den >= floor) & (den > 0)
        worst = 0.0
        for c in range(2):
            if ok[c].sum() > 1:
                lam = num[c][ok[c]] / den[c][ok[c]]
                worst = max(worst, float(lam.max() - lam.min()))
        self.cache[key] = worst
        return worst


class ModeMisfit:
    """How far the best single branch misses a group's swing split between its two periods.

    In the linear regime each main-path member j swings from rest with its bend strength's
    period in its bend part and its rotation strength's in its rotation part (ShareSpread's
    parts: ω_b,j = θb_j y_j and ω_r,j = -θr_j x_j, world vectors, read on the root's axes
    e_b = y_0, e_r = -x_0). Summed over the path per loading l, the group answers with
    M_b (2 × L) at the bend period and M_r at the rotation period. A level branch answers
    with u_b g_bᵀ and u_r g_rᵀ: one readout direction per period, u_b ⊥ u_r (its swing axes
    read in W_0, turned together by a roll), each of rank 1, and its statics S = M_b + M_r
    fitted; so at best P_b = u uᵀ S, and the misfit ‖u uᵀ S - M_b‖ (= ‖P_r - M_r‖) is least
    for u the eigenvector of the least eigenvalue λ of A = S Sᵀ - S M_bᵀ - M_b Sᵀ:

        misfit² = λ_min(A) + ‖M_b‖²,  per speed, over the loadings of ShareSpread's winds.

    A member alone, or members whose parts line up (a straight stalk's bend and rotation),
    give 0; a lateral rolled and pitched against its parent whose parts cancel across the
    two periods does not (family sympodial-209's pair [38, 40]: 36 % of its static swing,
    docs/simplify.md, "Limits"). The cost is the largest over speeds of misfit / the tree's
    largest static turn at that speed (|Σ ω| from the root to any branch, over the loadings:
    it reads against what a viewer sees), times the path's largest |ln(k_bs / k_rs)|: where
    the two periods are one, how a swing splits between them does not matter.
    """

    def __init__(self, shares: ShareSpread, parent: list[int]):
        from .tree_sums import TreeSums

        self.shares = shares
        self.parent = parent
        total = shares.parts.sum(axis=3)                                           # (B, S, D, 3)
        b, s, d = total.shape[:3]
        turns = TreeSums(np.asarray(parent, dtype=np.int64)).down(
            np.ones(b), total.reshape(b, s * d, 3).transpose(1, 0, 2))           # (S·D, B, 3)
        self.largest = np.sqrt((turns ** 2).sum(axis=2)).reshape(s, d, b).max(axis=(1, 2))
        gap = np.abs(shares.log_k[:, 0] - shares.log_k[:, 1])
        self.gap = np.where(np.isfinite(gap), gap, 0.0)                           # (B,)
        self.cache: dict[tuple[int, int], float] = {}

    def __call__(self, root: int, end: int) -> float:
        """The cost of the group rooted at ``root`` whose main path ends at ``end``."""
        key = (root, end)
        if key in self.cache:
            return self.cache[key]
        path = path_up(self.parent, root, end)
        gap = float(self.gap[path].max())
        worst = 0.0
        if gap > 0.0 and len(path) > 1:
            m = np.einsum("jsdmk,ck->scdm", self.shares.parts[path],
                          self.shares.axes[root])                                 # (S, c, D, m)
            for s in range(m.shape[0]):
                if self.largest[s] <= 0:
                    continue
                bend = m[s, :, :, 0]
                total = bend + m[s, :, :, 1]
                a = total @ total.T - total @ bend.T - bend @ total.T
                squared = float(np.linalg.eigvalsh(a)[0] + (bend * bend).sum())
                worst = max(worst, math.sqrt(max(squared, 0.0)) / self.largest[s])
        self.cache[key] = worst * gap
        return self.cache[key]


class CrossingSkew:
    """How far apart a group's upward and downward crossings pace: the least period error one
    branch can have both ways.

    model.md 6 reads a period from the upward crossings of the mean; a wind from the opposite
    side turns a linear response over, so it reads the downward ones. A level branch swings
    with one period per component, the same both ways; a group whose members have other
    periods swings as their sum, a beat, whose crossings bunch where its members fall out of
    step, so over a window of a few periods its two paces differ (family stalk-0, members of
    k_rs 48.4 and 56.4: 2.81 s upward, 2.96 s downward). No strength serves both within the
    stalks' 1 % then. In the linear regime member j swings from rest as its static part times
    the unit response of its strength (`swing_model.unit_response`), so the group's component c
    in loading l is

        x_c(t; l) = Σ_j Σ_m (e_c · ω_m,j(l)) u(t; k_m,j)

    (ShareSpread's parts and axes), and the skew is |P_up - P_down| / (P_up + P_down) of it,
    the largest over the loadings whose parts reach SHARE_SPREAD_FLOOR of the group's largest
    (as in ShareSpread). Window and step: simplify's measurement runs (SIMPLIFY_DURATION,
    SIMPLIFY_DT, read every SIMPLIFY_EVERY-th step; undamped). A lone branch, or members of
    one strength, give 0.
    """

    def __init__(self, shares: ShareSpread, tree: Tree, parent: list[int]):
        self.shares = shares
        self.parent = parent
        steps = int(round(SIMPLIFY_DURATION / SIMPLIFY_DT))
        k = np.stack([np.asarray(tree.bend_strength, dtype=np.float64),
                      np.asarray(tree.rotation_strength, dtype=np.float64)], axis=1)   # (B, m)
        values, index = np.unique(k, return_inverse=True)
        response = unit_response(values, SIMPLIFY_DT, steps, every=SIMPLIFY_EVERY)     # (K, U)
        self.times = np.arange(response.shape[0]) * (SIMPLIFY_DT * SIMPLIFY_EVERY)
        self.response = response
        self.index = index.reshape(k.shape)                                            # (B, m)
        self.cache: dict[tuple[int, int], float] = {}

    def __call__(self, root: int, end: int) -> float:
        """The skew of the group rooted at ``root`` whose main path ends at ``end``: the
        largest of `skews` over the loadings that count (0 where none does)."""
        key = (root, end)
        if key not in self.cache:
            skew = self.skews(root, end)
            skew = skew[np.isfinite(skew)]
            self.cache[key] = float(skew.max()) if skew.size else 0.0
        return self.cache[key]

    def skews(self, root: int, end: int) -> np.ndarray:
        """(c, S, D) |P_up - P_down| / (P_up + P_down) of the group's component c (bend,
        rotation) in each loading (ShareSpread's speeds S and directions D); NaN where the
        component's parts do not reach the floor, or a period is undefined."""
        path = path_up(self.parent, root, end)
        part = np.einsum("jsdmk,ck->csdjm", self.shares.parts[path], self.shares.axes[root])
        out = np.full(part.shape[:3], np.nan)
        if len(set(self.index[path].ravel().tolist())) < 2:
            out[:] = 0.0                              # one strength: one period, both ways
            return out
        size = np.abs(part).sum(axis=(3, 4))                                          # (c, S, D)
        ok = (size >= SHARE_SPREAD_FLOOR * size.max(axis=(0, 2), keepdims=True)) & (size > 0)
        if ok.any():
            u = self.response[:, self.index[path].ravel()]                            # (K, j·m)
            x = u @ part[ok].reshape(-1, len(path) * 2).T                             # (K, L)
            with np.errstate(invalid="ignore"):
                up, down = period(self.times, x), period(self.times, -x)
                out[ok] = np.abs(up - down) / (up + down)
        return out
