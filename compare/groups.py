"""Which original branches a simplified branch stands for (model.md section 5).

A level-n simplification derives N - n steps where the original derives N, and
addresses are stable across derivation lengths, so the simplified branch with
address a stands for the *group* of original branches whose addresses begin
with a. This module finds the groups, the main path through each group, the
group's combined bend and rotation angles, and its tip.

Addresses are strings ``"a0.a1.….ak"``, optionally followed by ``":j"`` for
the j-th further branch that interpretation draws under one address. The
suffix is part of a branch's identity (two branches of one tree never share a
full address) but not of the prefix test: ``"0.1:1"`` and ``"0.1"`` both have
the base address (0, 1). Addresses order as (base tuple of integers, suffix),
so 1.9 comes before 1.10 and 0.1 before 0.1:1.

Group indices are simplified-branch indices: group g is the group of the
simplified tree's branch g, and arrays over groups have G = B_simplified
columns.
"""

from __future__ import annotations

import functools

import numpy as np

from .constants import ALPHA_TIE_TOL
from plantlod.lsys.derived import ragged_arange
from plantlod.lsys.errors import InputError
from plantlod.lsys.rotation import rot_z
from plantlod.sim.kinematics import float_angles, rest_rotations
from plantlod.lsys.tree import Tree

# How many offending addresses an error message lists before "…".
_MESSAGE_EXAMPLES = 3

AddressKey = tuple[tuple[int, ...], int]


# --- addresses --------------------------------------------------------------------

@functools.lru_cache(maxsize=1 << 17)
def parse_address(text: str) -> AddressKey:
    """``"a0.a1.….ak[:j]"`` -> ((a0, …, ak), j), with j = 0 when there is no suffix.

    The result is also the sort key of the address. Raises InputError on
    anything else.
    """
    base, colon, suffix = text.partition(":")
    try:
        parts = tuple(int(p) for p in base.split("."))
        j = int(suffix) if colon else 0
    except ValueError:
        raise InputError(f"bad branch address {text!r}: expected integers separated by '.', "
                         f"optionally followed by ':j'") from None
    if any(p < 0 for p in parts) or j < 0 or (colon and j == 0):
        raise InputError(f"bad branch address {text!r}: expected non-negative integers "
                         f"and a suffix ':j' with j >= 1")
    return parts, j


def _parse_tree_addresses(tree: Tree, which: str) -> list[AddressKey]:
    """Parsed addresses of every branch of ``tree``; all of one length and unique."""
    keys = [parse_address(a) for a in tree.address]
    lengths = {len(base) for base, _ in keys}
    if len(lengths) > 1:
        raise InputError(f"the {which} tree's branch addresses have {sorted(lengths)} components; "
                         f"expected one length (every module of one derivation step has k+1)")
    seen: dict[AddressKey, int] = {}
    for i, key in enumerate(keys):
        if key in seen:
            raise InputError(f"the {which} tree has two branches with address {tree.address[i]}; "
                             f"expected unique addresses (use ':j' suffixes for extra branches)")
        seen[key] = i
    return keys


def _examples(items: list[str]) -> str:
    shown = ", ".join(items[:_MESSAGE_EXAMPLES])
    return shown + (", …" if len(items) > _MESSAGE_EXAMPLES else "")


# --- groups -----------------------------------------------------------------------

def _correspond_reversed(orig_keys, simp_keys, depth_o: int) -> bool:
    """Whether the trees read the other way round would correspond as far as addresses say:
    every address of the (shallower) original begins one of the simplified tree's. Unrelated
    trees were asked whether they were given the other way round (an API fuzzing round)."""
    prefixes = {base[:depth_o] for base, _ in simp_keys}
    return all(base in prefixes for base, _ in orig_keys)


def assign_groups(original: Tree, simplified: Tree) -> np.ndarray:
    """The group of every original branch: (B_orig,) int64 simplified-branch indices.

    Original branch i belongs to:
      1. the simplified branch with exactly its full address, if there is one
         (a level-0 simplification keeps every ``":j"`` branch apart);
      2. else the simplified branch whose base address is a prefix of i's base
         address; when interpretation drew several simplified branches under
         that address (``a``, ``a:1``, …) the first one, ``a``, or the one
         with the lowest suffix;
      3. else (i lies under an apex that draws nothing at step N - n) the group
         of its parent branch, which is decided first since parents come before
         children;
      4. else -1: a root branch drawn under an apex, or a branch hanging only
         from such branches. It belongs to no group; `main_paths` and the
         error measures leave it out, and callers can count them with
         ``(groups < 0).sum()``.

    Raises InputError when the trees do not correspond: unparsable or duplicate
    addresses, the simplified addresses longer than the original's, or a
    simplified branch whose group is empty (which is also what different
    axioms or unrelated files produce).
    """
    if simplified.n_branches == 0:
        raise InputError("the simplified tree has no branches; expected at least one to compare")
    if simplified.group_root:
        return assign_stated_groups(original, simplified)
    orig_keys = _parse_tree_addresses(original, "original")
    simp_keys = _parse_tree_addresses(simplified, "simplified")
    depth_o = len(orig_keys[0][0]) if orig_keys else 0
    depth_s = len(simp_keys[0][0])
    if orig_keys and depth_s > depth_o:
        raise InputError(
            f"the simplified tree's addresses have {depth_s} components, more than the original's "
            f"{depth_o}; expected the simplified tree to be derived in fewer steps"
            + (" (are the original and the simplified tree given the other way round?)"
               if _correspond_reversed(orig_keys, simp_keys, depth_o) else ""))

    exact = {key: s for s, key in enumerate(simp_keys)}
    by_base: dict[tuple[int, ...], int] = {}
    for s, (base, suffix) in enumerate(simp_keys):
        if base not in by_base or suffix < simp_keys[by_base[base]][1]:
            by_base[base] = s

    parent = np.asarray(original.parent, dtype=np.int64).tolist()
    found: list[int] = []
    for i, key in enumerate(orig_keys):
        s = exact.get(key)
        if s is None:
            s = by_base.get(key[0][:depth_s])
        if s is None:
            s = found[parent[i]] if parent[i] >= 0 else -1
        found.append(s)
    groups = np.asarray(found, dtype=np.int64).reshape(-1)

    sizes = np.bincount(groups[groups >= 0], minlength=simplified.n_branches)
    empty = [simplified.address[s] for s in np.flatnonzero(sizes == 0)]
    if len(empty) == simplified.n_branches:
        raise InputError(
            f"the trees share no addresses: no original branch address (e.g. "
            f"{_examples(original.address)}) begins with a simplified one (e.g. "
            f"{_examples(simplified.address)}); expected a simplification of the same L-system")
    if empty:
        raise InputError(
            f"simplified branch(es) {_examples(empty)} stand for no branch of the original; "
            f"expected every simplified address to begin some original branch's address")
    return groups


def assign_stated_groups(original: Tree, simplified: Tree) -> np.ndarray:
    """Groups of an explicit-form tree (model.md 5): (B_orig,) simplified-branch indices.

    Every simplified branch names the original branch rooting its group
    (`Tree.group_root`); an original branch belongs to the group of its nearest
    ancestor-or-self that roots a group. The groups must be connected and cover
    every original branch exactly once: a root named twice, an unknown address,
    or an original root branch under no stated root is an `InputError`.
    """
    index = {a: i for i, a in enumerate(original.address)}
    owner = np.full(original.n_branches, -1, dtype=np.int64)
    lines = simplified.group_line

    def at(s: int) -> dict:
        """The InputError location of simplified branch s's groups: line, where known."""
        line = lines[s] if s < len(lines) and lines[s] > 0 else None
        return {"file": simplified.where or None, "line": line, "col": 1 if line else None}

    for s, root in enumerate(simplified.group_root):
        i = index.get(root)
        if i is None:
            raise InputError(f"simplified branch {simplified.address[s]} stands for the group at "
                             f"{root}, which is no branch of the original; expected the original "
                             f"that the file was simplified from", **at(s))
        if owner[i] >= 0:
            raise InputError(f"the original branch {root} roots two groups (simplified branches "
                             f"{simplified.address[owner[i]]} and {simplified.address[s]})", **at(s))
        owner[i] = s
    parent = np.asarray(original.parent, dtype=np.int64)
    groups = owner.copy()
    for i in range(original.n_branches):            # parents come before children
        if groups[i] < 0:
            if parent[i] < 0:
                raise InputError(f"the original's root branch {original.address[i]} belongs to no "
                                 f"group; expected the groups to cover every branch")
            groups[i] = groups[parent[i]]
    # the level is the groups' tree (model.md 5: each branch the chord of its group): a branch
    # hangs from the branch whose group holds its root's parent (two roots swapped in a
    # groups: section were measured as they stood, 18x the errors, without a word)
    simp_parent = np.asarray(simplified.parent, dtype=np.int64)
    for s, root in enumerate(simplified.group_root):
        above = parent[index[root]]
        expected = groups[above] if above >= 0 else -1
        if simp_parent[s] != expected:
            drawn = (f"hangs from simplified branch {simplified.address[simp_parent[s]]}"
                     if simp_parent[s] >= 0 else "is a root")
            holds = (f"the group of simplified branch {simplified.address[expected]}"
                     if expected >= 0 else "no group (it is the original's root)")
            raise InputError(f"simplified branch {simplified.address[s]} {drawn}, but its group "
                             f"root {root} hangs in the original from {holds}; expected each "
                             f"branch to hang as its group does (are two roots swapped?)", **at(s))
    return groups


def pick_main_member(candidates: list[int], alpha: np.ndarray,
                     keys: list[AddressKey]) -> int:
    """The candidate with the smallest alpha; those within ALPHA_TIE_TOL of it tie; then lowest address."""
    smallest = min(alpha[c] for c in candidates)
    tied = [c for c in candidates if alpha[c] <= smallest + ALPHA_TIE_TOL]
    return min(tied, key=lambda c: keys[c])


def main_paths(original: Tree, groups: np.ndarray, n_groups: int | None = None) -> list[np.ndarray]:
    """The main path of every group: a list of G (m_g,) int64 arrays of original branch indices.

    A path starts at the group's root branch (the member whose parent is
    outside the group; of several, the smallest rest alpha, then the lowest
    address) and steps, at each member, to its child in the group with the
    smallest rest alpha (ties within ALPHA_TIE_TOL: the lowest address) until
    the member has no child in the group. Every member's parent is the member
    before it. ``n_groups`` defaults to ``groups.max() + 1``; an empty group
    gets an empty path; branches with group -1 are ignored.
    """
    groups = np.asarray(groups, dtype=np.int64)
    if groups.shape != (original.n_branches,):
        raise ValueError(f"groups must have shape ({original.n_branches},), got {groups.shape}")
    if n_groups is None:
        n_groups = int(groups.max()) + 1 if len(groups) else 0
    g_count = n_groups
    keys = [parse_address(a) for a in original.address]
    alpha = np.asarray(original.euler, dtype=np.float64).reshape(-1, 3)[:, 1]
    parent = np.asarray(original.parent, dtype=np.int64)
    gl = groups.tolist()

    roots: list[list[int]] = [[] for _ in range(g_count)]
    kids_in_group: list[list[int]] = [[] for _ in range(original.n_branches)]
    for i, (p, g) in enumerate(zip(parent.tolist(), gl)):
        if g < 0:
            continue
        if p >= 0 and gl[p] == g:
            kids_in_group[p].append(i)
        else:
            roots[g].append(i)

    paths = []
    for g in range(g_count):
        path: list[int] = []
        if roots[g]:
            cur = pick_main_member(roots[g], alpha, keys)
            path.append(cur)
            while kids_in_group[cur]:
                cur = pick_main_member(kids_in_group[cur], alpha, keys)
                path.append(cur)
        paths.append(np.asarray(path, dtype=np.int64))
    return paths


# --- combined angles --------------------------------------------------------------

def path_rotations(original: Tree, paths: list[np.ndarray]) -> np.ndarray:
    """W_0^T W_j for every member j of every path, concatenated in path order: (M, 3, 3).

    M is the total number of path members. W_j = R_parent,rest Rz(phi_j) Ry(alpha_j)
    is member j's rest swing frame and W_0 that of its path's first member.
    Along a path each member's parent is the previous member, so with
    Q_i = Rz(phi_i) Ry(alpha_i) Rz(psi_i)::

        W_0^T W_0 = I
        W_0^T W_j = Rz(psi_0) Q_1 … Q_(j-1) Rz(phi_j) Ry(alpha_j)

    which needs only the paths' own rest angles, never world frames. Computed
    for all paths at once, one path position at a time.
    """
    members = _concatenate(paths)
    rest, twist_angle = rest_rotations(original)
    swing = rest[members]                                 # (M, 3, 3) Rz(phi) Ry(alpha) [Rz(beta)]
    twist = rot_z(twist_angle[members])                   # (M, 3, 3) Rz(psi) [Rz(psi - beta)]
    lengths = np.array([len(p) for p in paths], dtype=np.int64)
    position = ragged_arange(lengths)                        # (M,) index within its path
    out = np.empty((len(members), 3, 3))
    frame = np.empty((len(members), 3, 3))                # W_0^T R_j, member j's branch frame
    first = position == 0
    out[first] = np.eye(3)
    frame[first] = twist[first]
    for j in range(1, int(lengths.max(initial=0))):
        at = np.flatnonzero(position == j)                # members j of the paths that long
        out[at] = frame[at - 1] @ swing[at]               # at - 1: the same path's member j-1
        frame[at] = out[at] @ twist[at]
    return out


def combined_angles(original: Tree, paths: list[np.ndarray],
                    bend: np.ndarray, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The combined angles (Θb, Θr) of every group, radians.

    bend, rot : (K, B) or (B,) the original's bend and rotation angles, radians
    returns   : two arrays (K, G) (or (G,) for (B,) input); 0 for an empty path

    Θb = Ω_y and Θr = -Ω_x with Ω = Σ_j M_j ω_j over the group's main-path
    members j, M_j = W_0^T W_j (`path_rotations`, computed once per member) and
    ω_j = (-θr_j, θb_j, 0) the member's rotation vector in its rest swing frame
    W_j, carried into the root's W_0. Written out:

        Θb = Σ_j M_j[1,1] θb_j - M_j[1,0] θr_j
        Θr = Σ_j M_j[0,0] θr_j - M_j[0,1] θb_j

    For a straight stalk every M_j is I and these are the plain sums. Members
    are added in path order, so results do not depend on chunking.
    """
    bend, rot = float_angles(bend), float_angles(rot)   # float32 runs are read as they are
    b = original.n_branches
    if bend.shape != rot.shape or bend.ndim not in (1, 2) or bend.shape[-1] != b:
        raise ValueError(f"bend and rot must both have shape (K, {b}) or ({b},); "
                         f"got {bend.shape} and {rot.shape}")
    bend2, rot2 = np.atleast_2d(bend), np.atleast_2d(rot)
    k = bend2.shape[0]
    members = _concatenate(paths)
    m = path_rotations(original, paths)
    lengths = np.array([len(p) for p in paths], dtype=np.int64)
    filled = np.flatnonzero(lengths > 0)                  # groups with a path
    theta_b = np.zeros((k, len(paths)))
    theta_r = np.zeros((k, len(paths)))
    if len(members):
        from .combined_kernel import combined

        # each member's angles in their own precision, the products float64 (a float32
        # angle widens exactly), so float32 runs give the bits their float64 copies would
        out_b, out_r = np.empty((k, len(filled))), np.empty((k, len(filled)))
        combined(np.ascontiguousarray(bend2), np.ascontiguousarray(rot2), members,
                 (np.cumsum(lengths) - lengths)[filled], lengths[filled],
                 *(np.ascontiguousarray(c) for c in (m[:, 1, 1], -m[:, 1, 0], -m[:, 0, 1], m[:, 0, 0])),
                 out_b, out_r)
        theta_b[:, filled], theta_r[:, filled] = out_b, out_r
    if bend.ndim == 1:
        return theta_b[0], theta_r[0]
    return theta_b, theta_r


def swing_turns(original: Tree, simplified: Tree, paths: list[np.ndarray]) -> np.ndarray:
    """W_0^T W'_g for every group g: (G, 3, 3), from the simplified branch's rest swing frame
    W'_g to its group root's W_0 (world frames at rest). The identity where they agree (the
    grammar form's straight groups); an explicit-form chord turns its frame."""
    from plantlod.sim.kinematics import rest_pose

    w0 = rest_pose(original).swing[np.array([int(p[0]) for p in paths], dtype=np.int64)]
    w1 = rest_pose(simplified).swing
    return np.einsum("gji,gjk->gik", w0, w1)


def carry_matrix(turn: np.ndarray) -> np.ndarray:
    """(G, 2, 2) maps of (θb, θr) carried by ``turn`` (G, 3, 3) into another swing frame, as
    `combined_angles` carries a member: Ω = M ω, ω = (-θr, θb, 0); Θb = Ω_y, Θr = -Ω_x, so

        [Θb, Θr] = [[M_11, -M_10], [-M_01, M_00]] [θb, θr]."""
    return np.stack([np.stack([turn[:, 1, 1], -turn[:, 1, 0]], -1),
                     np.stack([-turn[:, 0, 1], turn[:, 0, 0]], -1)], 1)


def carry_angles(turn: np.ndarray, bend: np.ndarray, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angles (..., G) of one-member paths carried by ``turn`` (G, 3, 3) (`carry_matrix`)."""
    c = carry_matrix(turn)
    return c[:, 0, 0] * bend + c[:, 0, 1] * rot, c[:, 1, 0] * bend + c[:, 1, 1] * rot


def _concatenate(paths: list[np.ndarray]) -> np.ndarray:
    """All path members in path order, (M,) int64."""
    if not paths:
        return np.zeros(0, dtype=np.int64)
    return np.concatenate([np.asarray(p, dtype=np.int64) for p in paths])


def group_tips(paths: list[np.ndarray], tips: np.ndarray) -> np.ndarray:
    """Each group's tip: the tip of its main path's last branch.

    tips    : (..., B, 3) posed branch tips of the original (e.g. `Pose.tip`), m
    returns : (..., G, 3)

    Raises ValueError for an empty path (a group with no members has no tip).
    """
    if any(len(p) == 0 for p in paths):
        raise ValueError("a group with an empty main path has no tip")
    last = np.asarray([int(p[-1]) for p in paths], dtype=np.int64)
    return np.asarray(tips)[..., last, :]
