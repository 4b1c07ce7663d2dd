"""Rolls of a level branch's frame about its chord: the one free turn of an explicit level's
swing frames (model.md 3 and 5).

A level branch's swing frame is fixed by its chord and its parent's chord wherever it leans
off its parent (α > 0). Where a group continues straight on from its parent group's tip
(α = 0), its swing frame is its parent's branch frame R_parent = S_parent Rz(ψ_parent), and
ψ_parent turns nothing else: the parent's own swing frame does not depend on it, its leaning
children's frames do not (φ takes the turn back), and its leaves are written in its frame.

That turn matters where the group's members are rolled against each other (phyllotaxis,
`/(137.5)` between trunk segments) and bend and rotate with different strengths: the group's
combined angles in W_0 then mix periods in proportions that change with the wind's
direction, which one branch with its own frame equal to W_0 cannot follow (its W_0
components are its own bend and rotation, one period each). Turned by γ, its W_0 components
mix its two periods too, y = C(γ) θ'. For each such group whose members are rolled, the
roll of its parent's frame is chosen from ROLL_CANDIDATES (a quarter turn: a quarter turn
more swings the same with the two strengths swapped) by the cost of
`explicit._searched_strengths` (the group's swing model in every direction, model.md 6's
measures against level 1's bounds): γ = 0 (the frame as before) is kept unless another
costs less by ROLL_GAIN.
"""

from __future__ import annotations

import numpy as np

from plantlod.compare.groups import carry_matrix
from plantlod.lsys.rotation import rot_z
from plantlod.lsys.tree import Tree

from .constants import ROLL_CANDIDATES, ROLL_GAIN, ROLL_MIN, ROLL_MIXED_PERIODS, STRAIGHT_ON


def straight_children(ch) -> list[tuple[int, int]]:
    """(parent group, child group) pairs where the child's chord continues its parent's
    chord exactly (α = 0 after model.md 2's 1e-9 rule; tested here as |z_p × z_c| <
    STRAIGHT_ON) and is its parent's only such child (a roll of the parent turns them all)."""
    z = ch.frame[:, :, 2]
    kids: dict[int, list[int]] = {}
    for c, p in enumerate(ch.parent_group.tolist()):
        if p >= 0 and z[p] @ z[c] > 0 and np.linalg.norm(np.cross(z[p], z[c])) < STRAIGHT_ON:
            kids.setdefault(p, []).append(c)
    return [(p, cs[0]) for p, cs in sorted(kids.items()) if len(cs) == 1]


def member_rolls(original: Tree, paths: list[np.ndarray], groups: list[int]) -> np.ndarray:
    """(n,) rad: for each group in ``groups``, the swing-weighted circular mean roll of its
    main-path members about W_0's axis, ½ arg Σ_j w_j exp(2i ρ_j), with ρ_j the turn of member
    j's rest swing frame about z (W_0ᵀ W_j, `path_rotations`) and w_j its static swing
    (Σ over 8 horizontal winds of |(θb, θr)|): the roll of the one frame that best stands for
    all of them (angles mod 180°, as C(γ + π) = -C(γ) swings the same)."""
    from plantlod.compare.groups import path_rotations

    from .constants import GROUP_SWING_DIRECTIONS
    from .static import horizontal_directions, static_angles, static_parts

    parts = static_parts(original, horizontal_directions(GROUP_SWING_DIRECTIONS))
    bend, rot = static_angles(original, parts.leaf + parts.drag)            # (D, B)
    swing = np.hypot(bend, rot).sum(axis=0)                                 # (B,)
    chosen = [np.asarray(paths[g], dtype=np.int64) for g in groups]
    turns = path_rotations(original, chosen)                                # (M, 3, 3)
    rho = np.arctan2(turns[:, 1, 0], turns[:, 0, 0])
    out = np.empty(len(chosen))
    at = 0
    for k, p in enumerate(chosen):
        phase = (swing[p] * np.exp(2j * rho[at:at + len(p)])).sum()
        at += len(p)
        out[k] = 0.5 * np.angle(phase) if abs(phase) > 0 else 0.0
    return out


def chord_rolls(original: Tree, paths: list[np.ndarray], ch, swing, dt: float,
                duration: float, damping_ratio: float = 0.0) -> np.ndarray:
    """(G,) rad: the roll of each group's chord frame (`explicit.chords`), 0 unless one of its
    straight-on children (`straight_children`) has members rolled against its root
    (`member_rolls` at least ROLL_MIN away from 0), swings with mixed periods, and one of
    ROLL_CANDIDATES lowers that child's search cost (module docstring). swing: the groups'
    `GroupSwing` (group order)."""
    from plantlod.sim.kinematics import rest_pose

    from .explicit import _searched_strengths

    g_count = len(paths)
    rolls = np.zeros(g_count)
    pairs = straight_children(ch)
    if not pairs:
        return rolls
    swinging = (swing.amplitudes > 0) & np.isfinite(swing.periods)          # (G, 2, D)
    longest = np.where(swinging, swing.periods, -np.inf).max(axis=(1, 2))
    shortest = np.where(swinging, swing.periods, np.inf).min(axis=(1, 2))
    pairs = [(p, c) for p, c in pairs
             if swinging[c].any() and longest[c] > ROLL_MIXED_PERIODS * shortest[c]]
    if not pairs:
        return rolls
    mean = member_rolls(original, paths, [c for _, c in pairs])
    keep = np.abs(mean) >= np.radians(ROLL_MIN)
    pairs = [pc for pc, k in zip(pairs, keep) if k]
    if not pairs:
        return rolls
    w0 = rest_pose(original).swing[np.array([int(paths[c][0]) for _, c in pairs])]   # (n, 3, 3)
    parent_frame = ch.frame[np.array([p for p, _ in pairs])]                           # (n, 3, 3)
    # candidates: rolls over a quarter turn (a quarter turn more swings the same with the two
    # strengths swapped, and the search picks strengths), 0 first
    gammas = np.broadcast_to(np.radians(np.asarray(ROLL_CANDIDATES, dtype=np.float64)),
                             (len(pairs), len(ROLL_CANDIDATES)))
    n, r = gammas.shape
    turns = np.einsum("nji,njk,nrkl->nril", w0, parent_frame, rot_z(gammas))          # (n, R, 3, 3)
    children = np.repeat(np.array([c for _, c in pairs]), r)
    a_max = swing.amplitudes.max(axis=(0, 1))
    _, cost = _searched_strengths(swing.take(children), carry_matrix(turns.reshape(-1, 3, 3)),
                                  a_max, dt, duration, damping_ratio, costs=True)
    cost = cost.reshape(n, r)
    for k, (p, _c) in enumerate(pairs):
        best = int(np.argmin(cost[k]))
        if cost[k, best] < (1.0 - ROLL_GAIN) * cost[k, 0]:
            rolls[p] = gammas[k, best]
    return rolls
