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
    frames = rest_frames(original)
    parts = static_parts(original, directions, frames)
    out = []
    for force in (parts.leaf, parts.drag):
        bend, rot = static_angles(original, force, frames)
        cb, cr = combined_angles(original, gmap.paths, bend, rot)
        both = np.stack([cb, cr], axis=-1)
        out.append(both if gain is None else both * gain[None])
    return StaticTargets(directions, out[0], out[1], parts.leaf[:, gmap.roots])


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
