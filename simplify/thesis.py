"""The thesis' rules for a level-n tree (Flannery 2003), kept to show what the derived rules gain.

For a stalk of 2^N equal branches the thesis makes the new branch as long as
the branches it replaces together, sets k_fp,new = k_fp^(n+1), keeps k_bs and
k_rs, and adjusts the leaf force by experiment. Here, for any tree:

- length: the summed length of the group's main path (per branch);
- k_fp: k_fp^(n+1) of the branch's own value;
- k_FA, k_bs, k_rs, C_d: unchanged;
- the leaf force: one leaf force scale s_L for the whole file, matched (least
  squares over horizontal directions) on the leaf part of the static angle of
  the *top group*, the group whose tip is highest at rest.
"""

from __future__ import annotations

import numpy as np

from plantlod.lsys.tree import Tree

from .targets import GroupMap, static_targets
from .closed_form import LevelParameters
from .static import horizontal_directions, rest_frames, static_angles, static_parts


def top_group(original: Tree, gmap: GroupMap) -> int:
    """The group whose tip is highest at rest (ties: the lowest index)."""
    z = rest_frames(original).tip[gmap.tips, 2]
    return int(np.flatnonzero(z >= z.max())[0])


def thesis_parameters(original: Tree, skeleton: Tree, gmap: GroupMap, level: int,
                      directions: np.ndarray | None = None) -> tuple[LevelParameters, float]:
    """Per-branch values and the leaf force scale s_L of the thesis' rules.

    Returns (parameters, leaf force scale): the scale multiplies the file's s_L.
    """
    directions = horizontal_directions(16) if directions is None else directions
    lengths = np.array([original.length[p].sum() for p in gmap.paths])
    kfp = skeleton.force_propagated ** (level + 1)
    branch = {"length": lengths, "force_propagated": kfp}

    trial = Tree(**{**skeleton.__dict__})
    trial.length, trial.force_propagated = lengths, kfp
    top = top_group(original, gmap)
    target = static_targets(original, gmap, directions).leaf[:, top]        # (D, 2)
    bend, rot = static_angles(trial, static_parts(trial, directions).leaf)
    got = np.stack([bend[:, top], rot[:, top]], axis=-1)                     # (D, 2)
    gg = float(np.sum(got * got))
    scale = float(np.sum(got * target)) / gg if gg > 0 else 1.0
    if not scale > 0:
        scale = 1.0
    return LevelParameters(branch, {}), scale
