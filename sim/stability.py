"""The stability limit of the time step (model.md section 4, docs/model.md).

Each angle follows the linear recurrence theta_k = (2 - c - s) theta_{k-1}
- (1 - c) theta_{k-2} + (forcing), s = k dt / 1000, whose characteristic
polynomial z^2 - (2 - c - s) z + (1 - c) has both roots inside the unit circle
(or on it, for c = 0) exactly when k > 0, 0 <= c < 2 and s < 4 - 2c. A run that
breaks this for the bend strength k_bs or rotation strength k_rs of any branch
is refused before it starts. With a damping ratio ζ each branch has its own
c = 2 ζ arccos(1 - s/2) per component (`damping`), and the same rule holds with it:
s + 4 ζ arccos(1 - s/2) < 4, which bounds s by the root s*(ζ) of that sum (s* = 4
at ζ = 0).
"""

from __future__ import annotations

import math

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree

from .damping import Damping, as_damping

_STRENGTHS = (("bend_strength", "bend strength k_bs"), ("rotation_strength", "rotation strength k_rs"))


def _where(tree: Tree, i: int, field: str) -> str:
    """Branch ``i`` as a message names it for its ``field``: by its symbol where every branch
    of that symbol has its value (the symbol's declaration), else by its address (an override
    or a parametric module set it for this branch)."""
    values = np.asarray(getattr(tree, field))
    same = values[np.asarray(tree.symbol) == tree.symbol[i]]
    if np.all(same == values[i]):
        return f"branch symbol '{tree.symbol[i]}' (e.g. the branch at address {tree.address[i]})"
    return (f"the branch at address {tree.address[i]} (symbol '{tree.symbol[i]}'; a value of "
            "this branch alone: an override, a module's parameter or a tree file's own)")


def largest_stable_s(damping: Damping) -> float:
    """The bound on s = k Δt / 1000 of every component: 4 - 2c, or with a ratio ζ the root
    of s + 4 ζ arccos(1 - s/2) = 4 in (0, 4] (the sum rises with s; bisection to 1e-15)."""
    if not damping.ratio:
        return 4.0 - 2.0 * damping.c
    z = damping.ratio
    low, high = 0.0, 4.0
    for _ in range(200):
        mid = 0.5 * (low + high)
        if mid + 4.0 * z * math.acos(max(-1.0, 1.0 - mid / 2.0)) < 4.0:
            low = mid
        else:
            high = mid
        if high - low < 1e-15:
            break
    return low


def _check_strengths(tree: Tree) -> None:
    """Every k_bs and k_rs must be finite and > 0."""
    source = tree.where or None
    for field, label in _STRENGTHS:
        k = np.asarray(getattr(tree, field), dtype=np.float64)
        bad = np.flatnonzero(~(np.isfinite(k) & (k > 0)))
        if len(bad):
            i = int(bad[0])
            raise InputError(f"{_where(tree, i, field)} has {label} {k[i]:g}; it must be a finite "
                             "number > 0",
                             source)


def round_down(x: float, digits: int = 6) -> float:
    """``x`` > 0 rounded down to ``digits`` significant digits, for messages (``x`` itself
    where that is 0, not finite, or too small for the unit to be a double)."""
    if not (x > 0 and math.isfinite(x)):
        return x
    unit = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return math.floor(x / unit) * unit if unit > 0 else x


def largest_stable_dt(tree: Tree, damping: "float | Damping" = 0.0) -> float:
    """The stability limit (s) of the time step: s* * 1000 / max(k_bs, k_rs), s* = 4 - 2c
    (or `largest_stable_s` of a damping ratio).

    Every dt strictly below it is stable; dt equal to it is not (the limit is
    a strict inequality). ``inf`` for a tree without branches.
    """
    d = as_damping(damping)
    _check_strengths(tree)
    if tree.n_branches == 0:
        return math.inf
    k_max = max(float(np.max(tree.bend_strength)), float(np.max(tree.rotation_strength)))
    return largest_stable_s(d) * 1000.0 / k_max


def check_stability(tree: Tree, dt: float, damping: "float | Damping" = 0.0) -> None:
    """Raise `InputError` unless every branch is stable at time step ``dt`` (s) and damping
    (c, or a ratio ζ: a `Damping`).

    The message names the branch symbol with the largest s = k dt / 1000, an
    example address of it, and the largest stable dt of the whole tree.
    """
    d = as_damping(damping)
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"the time step dt must be a finite number > 0, got {dt:g}")
    _check_strengths(tree)
    if tree.n_branches == 0:
        return
    limit = largest_stable_s(d)
    worst_s, worst_i, worst_label, worst_k, worst_field = -math.inf, -1, "", 0.0, ""
    for field, label in _STRENGTHS:
        k = np.asarray(getattr(tree, field), dtype=np.float64)
        s = k * dt / 1000.0
        i = int(np.argmax(s))          # first branch with the largest s
        if s[i] > worst_s:
            worst_s, worst_i, worst_label, worst_k, worst_field = float(s[i]), i, label, float(k[i]), field
    if worst_s >= limit:
        bound = round_down(largest_stable_dt(tree, d))
        raise InputError(
            f"time step too large: {_where(tree, worst_i, worst_field)} has {worst_label} {worst_k:g}, "
            f"so s = k*dt/1000 = {worst_s:g} >= {limit:g}, the limit "
            f"{'without damping' if d.undamped else 'at ' + d.describe()} "
            f"(dt = {dt:g} s); "
            f"the run would blow up: use dt < {bound:.6g} s (the largest stable dt for this tree)",
            tree.where or None, tree.record_line(worst_i) if tree.where else None)
