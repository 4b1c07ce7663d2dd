"""simplify/merged_groups.py against the literal rules it keeps up to date: on random trees
(fans among them, alphas tied within and just outside ALPHA_TIE_TOL) merged in random order,
every main-path end and every hanging reach equals the one read afresh from the children."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from plantlod.compare.constants import ALPHA_TIE_TOL
from plantlod.compare.groups import pick_main_member
from plantlod.simplify.merged_groups import HangingReach, MainPaths


@st.composite
def merged_trees(draw):
    """A random tree (a fan where the draw says so), alphas drawn from a few values with
    offsets around the tie tolerance, address keys in a random order, reaches, and an order
    of merges."""
    b = draw(st.integers(2, 40))
    fan = draw(st.booleans())
    parent = [-1] + [draw(st.integers(0, 0 if fan and i % 3 else i - 1)) for i in range(1, b)]
    base = draw(st.lists(st.sampled_from([0.0, 0.3, 0.5]), min_size=b, max_size=b))
    offset = draw(st.lists(st.sampled_from([0.0, 0.4, 0.8, 1.2, 2.5]), min_size=b, max_size=b))
    alpha = np.array([a + o * ALPHA_TIE_TOL for a, o in zip(base, offset)])
    keys = draw(st.permutations(list(range(b))))
    reach = draw(st.lists(st.sampled_from([0.0, 0.5, 1.0, 1.5, 2.0]), min_size=b, max_size=b))
    picks = draw(st.lists(st.integers(0, 10 ** 6), min_size=b, max_size=b))
    return parent, alpha, [((k,), 0) for k in keys], reach, picks


def _find(owner, i):
    while owner[i] != i:
        i = owner[i]
    return i


def _literal_end(parent, children, owner, alpha, keys, u, extra):
    """The main path's end read from the children: model.md 5's rule, step by step."""
    cur = u
    while True:
        kids = [c for c in children[cur] if _find(owner, c) == u
                or (extra >= 0 and _find(owner, c) == extra)]
        if not kids:
            return cur
        cur = pick_main_member(kids, alpha, keys)


def _literal_hanging(parent, children, owner, reach, u, extra):
    """{member m: the largest reach of the groups hanging from m} of u's group (with extra's)."""
    group = {u} | ({extra} if extra >= 0 else set())
    out = {}
    for m in range(len(parent)):
        if _find(owner, m) not in group:
            continue
        hanging = [reach[c] for c in children[m] if owner[c] == c and c not in group]
        if hanging:
            out[m] = max(hanging)
    return out


@settings(max_examples=150, deadline=None)
@given(merged_trees())
def test_main_ends_and_hanging_reaches_are_the_literal_ones(case):
    parent, alpha, keys, reach, picks = case
    b = len(parent)
    children = [[] for _ in range(b)]
    for i, p in enumerate(parent):
        if p >= 0:
            children[p].append(i)
    owner = list(range(b))
    paths = MainPaths(parent, alpha, keys)
    reaches = HangingReach(children, reach, owner)
    for pick in picks:
        hanging = [r for r in range(b) if owner[r] == r and parent[r] >= 0]
        if not hanging:
            break
        for r in hanging:                       # every merge the grouping could price now
            u = _find(owner, parent[r])
            for group, extra in ((u, r), (u, -1), (r, -1)):
                assert paths.end(group, extra) == _literal_end(parent, children, owner, alpha,
                                                               keys, group, extra)
                assert dict(reaches.hanging(group, extra)) == _literal_hanging(
                    parent, children, owner, reach, group, extra)
        r = hanging[pick % len(hanging)]
        u = _find(owner, parent[r])
        owner[r] = u
        paths.joined(r)
        reaches.joined(u, r)
