"""The stability limit of the time step (model.md section 4, docs/model.md).

Each angle follows the linear recurrence theta_k = (2 - c - s) theta_{k-1}
- (1 - c) theta_{k-2} + (forcing), s = k dt / 1000, whose characteristic
polynomial z^2 - (2 - c - s) z + (1 - c) has both roots inside the unit circle
(or on it, for c = 0) exactly when k > 0, 0 <= c < 2 and s < 4 - 2c. A run that
breaks this for the bend strength k_bs or rotation strength k_rs of any branch
is refused before it starts.
"""

from __future__ import annotations

import math

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree

_STRENGTHS = (("bend_strength", "bend strength k_bs"), ("rotation_strength", "rotation strength k_rs"))


def _where(tree: Tree, i: int) -> str:
    return f"branch symbol '{tree.symbol[i]}' (e.g. the branch at address {tree.address[i]})"


def _check_damping(damping: float) -> float:
    c = float(damping)
    if not (math.isfinite(c) and 0.0 <= c < 2.0):
        raise InputError(f"damping must be a number in [0, 2), got {c:g}")
    return c


def _check_strengths(tree: Tree) -> None:
    """Every k_bs and k_rs must be finite and > 0."""
    source = tree.source or None
    for field, label in _STRENGTHS:
        k = np.asarray(getattr(tree, field), dtype=np.float64)
        bad = np.flatnonzero(~(np.isfinite(k) & (k > 0)))
        if len(bad):
            i = int(bad[0])
            raise InputError(f"{_where(tree, i)} has {label} {k[i]:g}; it must be a finite number > 0",
                             source)


def _round_down(x: float, digits: int = 6) -> float:
    """``x`` > 0 rounded down to ``digits`` significant digits, for messages."""
    unit = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return math.floor(x / unit) * unit


def largest_stable_dt(tree: Tree, damping: float = 0.0) -> float:
    """The stability limit (s) of the time step: (4 - 2c) * 1000 / max(k_bs, k_rs).

    Every dt strictly below it is stable; dt equal to it is not (the limit is
    a strict inequality). ``inf`` for a tree without branches.
    """
    c = _check_damping(damping)
    _check_strengths(tree)
    if tree.n_branches == 0:
        return math.inf
    k_max = max(float(np.max(tree.bend_strength)), float(np.max(tree.rotation_strength)))
    return (4.0 - 2.0 * c) * 1000.0 / k_max


def check_stability(tree: Tree, dt: float, damping: float = 0.0) -> None:
    """Raise `InputError` unless every branch is stable at time step ``dt`` (s) and damping c.

    The message names the branch symbol with the largest s = k dt / 1000, an
    example address of it, and the largest stable dt of the whole tree.
    """
    c = _check_damping(damping)
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"the time step dt must be a finite number > 0, got {dt:g}")
    _check_strengths(tree)
    if tree.n_branches == 0:
        return
    limit = 4.0 - 2.0 * c
    worst_s, worst_i, worst_label, worst_k = -math.inf, -1, "", 0.0
    for field, label in _STRENGTHS:
        k = np.asarray(getattr(tree, field), dtype=np.float64)
        s = k * dt / 1000.0
        i = int(np.argmax(s))          # first branch with the largest s
        if s[i] > worst_s:
            worst_s, worst_i, worst_label, worst_k = float(s[i]), i, label, float(k[i])
    if worst_s >= limit:
        bound = _round_down(largest_stable_dt(tree, c))
        raise InputError(
            f"time step too large: {_where(tree, worst_i)} has {worst_label} {worst_k:g}, "
            f"so s = k*dt/1000 = {worst_s:g} >= 4 - 2c = {limit:g} (dt = {dt:g} s, damping c = {c:g}); "
            f"the run would blow up: use dt < {bound:.6g} s (the largest stable dt for this tree)",
            tree.source or None)
