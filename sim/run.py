"""Run a simulation: chunks of sampled angles from a tree, a wind and a time step.

`simulate` yields `Samples` chunks whose rows are the steps k = 0, every,
2*every, ... up to and including ``steps`` (the last row is the last multiple of
``every`` not above ``steps``; the final step itself is written only when
``every`` divides ``steps``). Row k holds the angles at t_k = k * dt; row 0 is
t0 = 0 with every angle 0. Memory stays bounded: each chunk holds at most
``chunk`` rows, and the wind is sampled a bounded number of steps at a time.

The kernel (numba) is imported on first use, so importing this module is cheap.
"""

from __future__ import annotations

import math
from typing import Iterator, NamedTuple

import numpy as np

from .constants import SIM_CHUNK_VALUES
from .constants import SIM_STEPS_PER_CALL
from .constants import MAX_HELD_ANGLE_BYTES
from plantlod.lsys.errors import InputError, RunFailure
from plantlod.lsys.tree import Tree

from .damping import Damping, as_damping
from .stability import check_stability
from .wind import wind_samples
from .wind import Wind


class Samples(NamedTuple):
    """One chunk of output rows: times (m,) s; bend and rot (m, B) radians."""

    times: np.ndarray
    bend: np.ndarray
    rot: np.ndarray


def step_count(dt: float, duration: float, dt_name: str = "dt",
               duration_name: str = "duration") -> int:
    """round(duration / dt): the steps of a run of ``duration`` s at ``dt`` s (finite floats).
    InputError, naming the options as the caller calls them, where dt is below MIN_TIME_STEP,
    the duration negative, or the run longer than MAX_TIME_STEPS (the one check for the API
    and simplify)."""
    from .constants import MAX_TIME_STEPS, MIN_TIME_STEP

    if not MIN_TIME_STEP <= dt < math.inf:
        raise InputError(f"{dt_name} {dt:g} s: expected a time step of at least "
                         f"{MIN_TIME_STEP:g} s")
    if not duration >= 0:                             # (NaN included)
        raise InputError(f"{duration_name} {duration:g} s: expected a duration of at least 0 s")
    if not duration / dt <= MAX_TIME_STEPS:
        raise InputError(f"{duration_name} {duration:g} s at {dt_name} {dt:g} s gives more than "
                         f"{MAX_TIME_STEPS:,} steps, the limit of one run")
    return int(round(duration / dt))


def refuse_no_step(steps: int, dt: float, duration: float, dt_name: str = "dt",
                   duration_name: str = "duration") -> None:
    """InputError where a positive ``duration`` rounds to no step at ``dt`` (`step_count`'s
    ``steps``): it ran 0 steps without a word (a new user's first hour, session 42). A
    duration of 0 asks for the rest pose alone. (simplify says its own "fewer than 8 steps".)"""
    if steps == 0 and duration > 0:
        raise InputError(f"{duration_name} {duration:g} s at {dt_name} {dt:g} s gives no time "
                         "step (duration / dt rounds to 0); give a longer duration, or 0 for the "
                         "rest pose alone")


def default_chunk(n_branches: int) -> int:
    """Rows per chunk for a tree of ``n_branches``: about SIM_CHUNK_VALUES values per array."""
    return max(1, SIM_CHUNK_VALUES // max(n_branches, 1))


def _check_counts(steps: int, every: int, chunk: int) -> None:
    for name, value, low in (("steps", steps, 0), ("every", every, 1), ("chunk", chunk, 1)):
        if not isinstance(value, (int, np.integer)) or value < low:
            raise InputError(f"{name} must be an integer >= {low}, got {value!r}")


def simulate(tree: Tree, dt: float, steps: int, wind: Wind, every: int = 1,
             damping: "float | Damping" = 0.0, chunk: int | None = None) -> Iterator[Samples]:
    """Simulate ``steps`` time steps of ``dt`` seconds; yield chunks of sampled angles.

    wind    : any object with ``sample(times (K,)) -> (K, 3)`` (`plantlod.sim.wind`)
    every   : keep the rows of steps k with k % every == 0 (k = 0 included)
    damping : the velocity damping c of model.md section 4, 0 <= c < 2, or a `Damping`
              (c or a damping ratio ζ)
    chunk   : rows per yielded chunk at most (default `default_chunk`)
    Raises `InputError` before the first chunk for an unstable dt or bad
    parameters, and `RunFailure` when an angle stops being finite (the chunks
    before it have been yielded by then).
    """
    chunk = default_chunk(tree.n_branches) if chunk is None else chunk
    _check_counts(steps, every, chunk)
    damping = as_damping(damping)
    check_stability(tree, dt, damping)
    return _chunks(tree, float(dt), int(steps), wind, int(every), damping, int(chunk))


def _chunks(tree: Tree, dt: float, steps: int, wind: Wind, every: int, damping: Damping,
            chunk: int) -> Iterator[Samples]:
    from . import kernel

    b = tree.n_branches
    model = kernel.prepare(tree, damping)
    engine = kernel.engine_for(model, steps)      # one engine for the whole run
    state = kernel.KernelState(b)
    total_rows = steps // every + 1
    emitted = 0
    step = 0                      # steps done so far
    while emitted < total_rows:
        rows = min(chunk, total_rows - emitted)
        out_bend = np.empty((rows, b))
        out_rot = np.empty((rows, b))
        filled = 0
        if emitted == 0:           # t0: at rest
            out_bend[0] = 0.0
            out_rot[0] = 0.0
            filled = 1
        while filled < rows:
            # steps to the row after the next `rows - filled` multiples of every
            n = min((rows - filled) * every - step % every, SIM_STEPS_PER_CALL)
            ks = np.arange(step, step + n, dtype=np.float64)   # step k uses V(t_{k-1})
            samples = wind_samples(wind, ks * dt)
            written, bad, bad_step = kernel.advance(model, state, samples, dt, step + 1,
                                                    every, out_bend, out_rot, filled, engine)
            filled += written
            if bad >= 0:
                if filled:
                    yield Samples(_times(emitted, filled, every, dt), out_bend[:filled], out_rot[:filled])
                raise RunFailure(f"simulation diverged at t={bad_step * dt:.10g} s (step {bad_step}) "
                                 f"in branch {tree.address[bad]}: an angle is no longer finite; "
                                 f"{divergence_advice(bad_step)}")
            step += n
        yield Samples(_times(emitted, rows, every, dt), out_bend, out_rot)
        emitted += rows


def divergence_advice(step: int) -> str:
    """What to change after a run diverged at ``step``: a stable step (checked before the run)
    that is no longer finite within FIRST_STEPS_DIVERGED steps was given a force out of
    range, a value of the tree far too large (radius = 1e300 was told to lower force_absorbed,
    the wind or dt; an L-system fuzzing round); later, the swing grew past what the model
    holds."""
    from .constants import FIRST_STEPS_DIVERGED

    if step <= FIRST_STEPS_DIVERGED:
        return ("its force was out of range from the start: look for a value of the tree far "
                "too large (a branch's radius, length or drag_coefficient, a leaf's area, "
                "force_propagated or force_absorbed), or lower the wind")
    return "lower force_absorbed, the wind or dt"


def _times(first_row: int, rows: int, every: int, dt: float) -> np.ndarray:
    """t = k * dt for the rows first_row .. first_row + rows - 1 (k = row * every)."""
    return np.arange(first_row, first_row + rows, dtype=np.float64) * every * dt


def check_held_angles(rows: int, branches: int, lanes: int = 1) -> None:
    """Refuse (InputError) bend and rotation arrays of (lanes, rows, branches) float64 that
    would pass MAX_HELD_ANGLE_BYTES, before they are allocated."""
    held = 2 * lanes * rows * branches * 8
    if held > MAX_HELD_ANGLE_BYTES:
        raise InputError(f"the run would hold {held / 1e9:,.1f} GB of angles in memory "
                         f"({lanes:,} x {rows:,} rows x {branches:,} branches), more than the "
                         f"limit of {MAX_HELD_ANGLE_BYTES / 1e9:g} GB; expected fewer steps, "
                         "winds or branches (plantlod simulate streams any length to a file)")


def simulate_arrays(tree: Tree, dt: float, steps: int, wind: Wind, every: int = 1,
                    damping: "float | Damping" = 0.0) -> Samples:
    """The whole run as one `Samples`: times (m,), bend and rot (m, B), m = steps // every + 1.

    Raises `InputError` before running when the arrays would pass MAX_HELD_ANGLE_BYTES
    (streaming `simulate` has no such limit)."""
    check_held_angles(steps // max(every, 1) + 1, tree.n_branches)
    parts = list(simulate(tree, dt, steps, wind, every=every, damping=damping))
    return Samples(np.concatenate([p.times for p in parts]),
                   np.concatenate([p.bend for p in parts]),
                   np.concatenate([p.rot for p in parts]))
