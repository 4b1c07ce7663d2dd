"""What a level must match: the groups of the original it stands for, and their static angles.

A level-n branch g stands for a group of original branches (`GroupMap`): its main path
P_g = (b_1 ... b_m) from the group root to its tip. Its targets are the original's
combined static angles (model.md 5) per unit speed and per unit speed squared,

    Θ_g(v, V̂) = v Θ^L_g(V̂) + v² Θ^D_g(V̂),   Θ_g = Σ_{b in P_g} (θb_b, θr_b) carried into g's frame

(leaf part and drag part, `static.static_parts`), and the leaf force at its root
branch, which the parent group receives.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantlod.lsys.tree import Tree

from plantlod.compare.groups import assign_groups, combined_angles, main_paths
from .constants import MEMBER_STATICS_KEPT
from .static import rest_frames, static_angles, static_parts


@dataclass
class GroupMap:
    """Which original branches each simplified branch stands for.

    groups : (B_orig,) int64 simplified-branch index of every original branch (-1: none)
    paths  : G main paths, (m_g,) int64 original branch indices each
    """

    groups: np.ndarray
    paths: list[np.ndarray]

    @property
    def roots(self) -> np.ndarray:
        return np.array([int(p[0]) for p in self.paths], dtype=np.int64)

    @property
    def tips(self) -> np.ndarray:
        return np.array([int(p[-1]) for p in self.paths], dtype=np.int64)


def group_map(original: Tree, simplified: Tree) -> GroupMap:
    groups = assign_groups(original, simplified)
    return GroupMap(groups, main_paths(original, groups, simplified.n_branches))


@dataclass
class StaticTargets:
    """The original's static combined angles and root forces per group.

    directions : (D, 3) unit wind directions
    leaf, drag : (D, G, 2) combined (Θb, Θr) per unit v and per unit v², rad
    root_leaf  : (D, G, 3) leaf part of the force at each group's root branch, N per (m/s)
    """

    directions: np.ndarray
    leaf: np.ndarray
    drag: np.ndarray
    root_leaf: np.ndarray


def static_targets(original: Tree, gmap: GroupMap, directions: np.ndarray,
                   gain: np.ndarray | None = None) -> StaticTargets:
    """The targets, combined angles in each group root's swing frame W_0 (model.md 5),
    each group's (bend, rotation) multiplied by ``gain`` (G, 2) where given."""
    leaf_force, members = member_statics(original, directions)
    out = []
    for bend, rot in members:
        cb, cr = combined_angles(original, gmap.paths, bend, rot)
        both = np.stack([cb, cr], axis=-1)
        out.append(both if gain is None else both * gain[None])
    return StaticTargets(directions, out[0], out[1], leaf_force[:, gmap.roots])


_member_statics: dict[bytes, tuple] = {}     # the last MEMBER_STATICS_KEPT, the most recent last


def member_statics(original: Tree, directions: np.ndarray):
    """The original's leaf force parts (D, B, 3) and every branch's static (θb, θr) (D, B) for
    its leaf part and its drag part (`static.static_parts`, `static.static_angles`), in
    ``directions`` (D, 3). They depend on the original alone: every level fitted to it (a
    chain's, a regrouping's, both leaf sets of one) reads them, so the last few are kept,
    keyed by a digest of the tree and the directions (read-only: shared)."""
    import hashlib

    from .evaluate import tree_digest

    directions = np.ascontiguousarray(directions, dtype=np.float64)
    key = hashlib.sha256(tree_digest(original) + repr(directions.shape).encode()
                         + directions.tobytes()).digest()
    known = _member_statics.pop(key, None)
    if known is None:
        frames = rest_frames(original)
        parts = static_parts(original, directions, frames)
        known = (parts.leaf, [static_angles(original, force, frames)
                              for force in (parts.leaf, parts.drag)])
        for array in (known[0], *known[1][0], *known[1][1]):
            array.setflags(write=False)
    _member_statics[key] = known
    for stale in list(_member_statics)[:-MEMBER_STATICS_KEPT]:
        _member_statics.pop(stale, None)
    return known


def group_strengths(original: Tree, gmap: GroupMap) -> tuple[np.ndarray, np.ndarray]:
    """k_bs' and k_rs' per group: (G,) each; the members' values where the main path is uniform.

    Where members differ, the mean over the main path (the combined angle
    sums the members' swings, each with its own period; the mean keeps the
    result between the members' periods and the tree stable wherever the
    original is).
    """
    kb = np.array([original.bend_strength[p].mean() for p in gmap.paths])
    kr = np.array([original.rotation_strength[p].mean() for p in gmap.paths])
    return kb, kr
