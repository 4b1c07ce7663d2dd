"""Swing rolls of a level's branches: a level branch's swing frame turned about its own rest
axis (`Tree.swing_roll`, the `swing_roll` key; docs/model.md, "Swing roll").

A level branch's swing frame is fixed by its chord and its parent's chord (model.md 3): it
bends in the plane of its lean and rotates across it. Where its group's members are rolled
against each other (phyllotaxis, `/(137.5)` between segments, a sympodial fork's turns) and
bend and rotate with different strengths, the group's combined angles in W_0 mix two periods
in proportions that change with the wind's direction. One branch whose swing axes sit where
its chord puts them reads in W_0 through its carry map C (`compare.groups.carry_matrix`) and
cannot mix them the same way; turned by β about its axis, it reads C Rz(β) θ' and can.

For each group that swings with mixed periods (ROLL_MIXED_PERIODS) and whose members' mean
roll (`member_rolls`) lies at least ROLL_MIN away from the branch's own, β is chosen from
ROLL_CANDIDATES (a quarter turn: a quarter turn more swings the same with the two strengths
swapped) and the members' mean roll itself, by the cost of `explicit.searched_strengths`
(the group's swing model in every direction, model.md 6's measures against level 1's
bounds); β = 0 is kept unless another costs less by ROLL_GAIN. Root groups are rolled too
(the three rolled shoots of a bush that has no trunk): session 10 left them unrolled, when
rolled trunks lost whole trees; since the motion fit they lose none (docs/simplify.md).
"""

from __future__ import annotations

import numpy as np

from plantlod.compare.groups import carry_matrix
from plantlod.lsys.rotation import rot_z
from plantlod.lsys.tree import Tree

from .constants import ROLL_CANDIDATES, ROLL_GAIN, ROLL_MIN, ROLL_MIXED_PERIODS


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


def swing_rolls(original: Tree, paths: list[np.ndarray], turn: np.ndarray, swing, dt: float,
                duration: float, damping_ratio: float = 0.0) -> np.ndarray:
    """(S,) degrees: the swing roll β of each level branch (module docstring), 0 where none.

    paths : each level branch's group main path (S,); turn (S, 3, 3): W_0ᵀ W' of each level
    branch before any roll (`compare.groups.swing_turns`); swing: the groups' `GroupSwing` in
    the same order. Degrees, so that the value written to the file reads back as the radians
    used here, np.radians(β): every candidate is a whole number of degrees.
    """
    from .explicit import searched_strengths

    out = np.zeros(len(paths))
    swinging = (swing.amplitudes > 0) & np.isfinite(swing.periods)          # (S, 2, D)
    longest = np.where(swinging, swing.periods, -np.inf).max(axis=(1, 2))
    shortest = np.where(swinging, swing.periods, np.inf).min(axis=(1, 2))
    mixed = np.flatnonzero(swinging.any(axis=(1, 2)) & (longest > ROLL_MIXED_PERIODS * shortest))
    if not len(mixed):
        return out
    # the members' mean roll against the branch's own (the roll of W_0ᵀ W' about z), mod 180°
    mean = member_rolls(original, paths, mixed.tolist())
    own = np.arctan2(turn[mixed, 1, 0] - turn[mixed, 0, 1], turn[mixed, 0, 0] + turn[mixed, 1, 1])
    apart = (mean - own + 0.5 * np.pi) % np.pi - 0.5 * np.pi
    keep = np.abs(apart) >= np.radians(ROLL_MIN)
    mixed, apart = mixed[keep], apart[keep]
    if not len(mixed):
        return out
    # candidates: the fixed quarter turn (0 first), then the members' mean roll mod 90°
    near = np.round(np.degrees((apart + 0.25 * np.pi) % (0.5 * np.pi) - 0.25 * np.pi))
    degrees = np.concatenate([np.broadcast_to(np.asarray(ROLL_CANDIDATES, dtype=np.float64),
                                              (len(mixed), len(ROLL_CANDIDATES))),
                              near[:, None]], axis=1)                       # (n, R)
    n, r = degrees.shape
    turns = turn[mixed][:, None] @ rot_z(np.radians(degrees))               # (n, R, 3, 3)
    a_max = swing.amplitudes.max(axis=(0, 1))
    _, cost = searched_strengths(swing.take(np.repeat(mixed, r)),
                                 carry_matrix(turns.reshape(-1, 3, 3)), a_max, dt, duration,
                                 damping_ratio, costs=True)
    cost = cost.reshape(n, r)
    best = np.argmin(cost, axis=1)
    better = cost[np.arange(n), best] < (1.0 - ROLL_GAIN) * cost[:, 0]
    out[mixed[better]] = degrees[np.arange(n), best][better]
    return out
