"""Damping of the velocity update (model.md section 4): a coefficient c, or a damping ratio ζ.

A run damps every angle's velocity by c per step, ``v <- v + ... - c v``. Either
all branches share one c (the thesis has c = 0), or the run gives a damping ratio
ζ and each branch damps each component by its own period P (model.md 4):

    c_b,i = 4π ζ Δt / P_b,i = 2 ζ arccos(1 - s_b,i / 2),   s_b,i = k_bs,i Δt / 1000

(the second form from P = 2π Δt / arccos(1 - s/2)), and likewise c_r,i from k_rs,i.
For small c this is the continuous oscillator's ratio: the velocity decays by
(1 - c) a step, 2 ζ ω a second. Giving both c and ζ is an error.

`Damping` carries the choice; `coefficients` turns it into per-branch (B,) (or
per-lane (B, W)) arrays once Δt is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.checks import real
from plantlod.lsys.errors import InputError

from .constants import MAX_DAMPING_RATIO


@dataclass(frozen=True)
class Damping:
    """c (per step, 0 <= c < 2) or ζ (dimensionless, >= 0); at most one of them non-zero."""

    c: float = 0.0
    ratio: float = 0.0

    @property
    def undamped(self) -> bool:
        """No damping at all (the thesis' model)."""
        return not self.ratio and not self.c

    def describe(self) -> str:
        """``damping ratio 0.05`` / ``damping c = 0.01`` / ``undamped``, for messages and headers."""
        if self.ratio:
            return f"damping ratio {self.ratio:g}"
        return f"damping c = {self.c:g}" if self.c else "undamped"


def as_damping(damping: "float | Damping | None" = 0.0, ratio: float | None = None) -> Damping:
    """A checked `Damping` from a coefficient c (or a `Damping`) and an optional ratio ζ.

    Raises InputError for c outside [0, 2), ζ outside [0, MAX_DAMPING_RATIO], or both given.
    """
    if isinstance(damping, Damping):
        base = damping
    else:
        c = 0.0 if damping is None else real("damping", damping)
        if not (math.isfinite(c) and 0.0 <= c < 2.0):
            raise InputError(f"damping must be a number in [0, 2), got {c:g}")
        base = Damping(c=c)
    if ratio is not None:
        z = real("the damping ratio", ratio)
        if not (math.isfinite(z) and 0.0 <= z <= MAX_DAMPING_RATIO):
            raise InputError(f"the damping ratio must be a number in [0, {MAX_DAMPING_RATIO:g}], "
                             f"got {z:.12g}")
        if base.c != 0.0 or (base.ratio and base.ratio != z):
            raise InputError("give either the damping c or the damping ratio ζ, not both")
        base = Damping(c=0.0, ratio=z)
    if base.ratio and not (math.isfinite(base.ratio) and 0.0 <= base.ratio <= MAX_DAMPING_RATIO):
        raise InputError(f"the damping ratio must be a number in [0, {MAX_DAMPING_RATIO:g}], "
                         f"got {base.ratio:.12g}")
    return base


def step_angle(half_s) -> np.ndarray:
    """ω Δt = arccos(1 - s/2) (rad), the phase an undamped branch swings by in one step of
    model.md 4 (s = k Δt / 1000, given as s/2), any shape; its period is P = 2π Δt / ω Δt.
    Where s >= 4 (an unstable step, refused elsewhere) the arccos argument is clipped."""
    return np.arccos(np.clip(1.0 - np.asarray(half_s, dtype=np.float64), -1.0, 1.0))


def period_of_strength(strength, dt: float) -> np.ndarray:
    """Model.md 4's undamped period P = 2π Δt / arccos(1 - k Δt / 2000) (s) of a branch of
    strength k (any shape), `step_angle`'s phase a step; infinite where k Δt / 2000 is lost
    to rounding (1 - s/2 is 1: the step moves nothing), without a division warning."""
    with np.errstate(divide="ignore"):
        return 2.0 * math.pi * dt / step_angle(np.asarray(strength) * dt / 2000.0)


def ratio_coefficient(velocity_gain: np.ndarray, dt: float, ratio: float) -> np.ndarray:
    """c = 2 ζ arccos(1 - s/2) with s = velocity_gain Δt (velocity_gain = k / 1000), any shape."""
    s = np.asarray(velocity_gain, dtype=np.float64) * float(dt)
    return 2.0 * float(ratio) * step_angle(s / 2.0)


def coefficients(damping: Damping, bend_k: np.ndarray, rot_k: np.ndarray, dt: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Per-branch c for the bend and the rotation, the shapes of ``bend_k`` and ``rot_k``.

    bend_k, rot_k : k_bs / 1000 and k_rs / 1000, (B,) or (B, W)
    """
    if damping.ratio:
        return (np.ascontiguousarray(ratio_coefficient(bend_k, dt, damping.ratio)),
                np.ascontiguousarray(ratio_coefficient(rot_k, dt, damping.ratio)))
    return (np.full(np.shape(bend_k), float(damping.c)), np.full(np.shape(rot_k), float(damping.c)))
