"""Many runs of one tree structure per call: W winds, or W parameter sets, as vector lanes.

    model = LaneModel.from_tree(tree)                       # shared arrays, built once
    bend, rot = run_lanes(model, winds, dt, steps)          # winds (W, 3) or (W, steps, 3)

Each lane is one run of model.md sections 3-4, with the same values the
single-run kernel gives (tests/test_sim_lanes.py checks them bit for bit). The
parameters a lane may change (k_FA, k_fp, k_bs, k_rs, drag, leaf scale) are
(B,) arrays shared by every lane unless `LaneModel.with_lane_parameters` gives
them a lane axis; the structure (parents, rest rotations, leaf normals) is
always shared, never copied per lane. The numba kernel is `lanes_kernel`; the layout and
what the compiler makes of it: docs/engine.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from plantlod.lsys.checks import real, real_array, shown_value, whole
from plantlod.lsys.errors import InputError, RunFailure
from plantlod.lsys.tree import Tree

from .engine_env import check_environment, check_jit_enabled, env_threads
from .damping import Damping
from .kernel import KernelModel, prepare   # numba: the engine compiles on first use
from .constants import MAX_TIME_STEPS, MAX_WIND_SPEED, SPEED_ROUNDING
from .run import check_held_angles, divergence_advice

LANE_PARAMETERS = ("absorbed", "propagated", "bend_k", "rot_k", "drag", "leaf_scale")


@dataclass(frozen=True)
class LaneModel(KernelModel):
    """A tree flattened for the lanes kernel: the fields of `kernel.KernelModel`, whose lane
    parameters (`LANE_PARAMETERS`) are (B,) (leaf_scale (F,)) when shared by every lane, or
    (B, W) ((F, W)) with one column per lane.
    """

    @classmethod
    def from_tree(cls, tree: Tree, damping: "float | Damping" = 0.0) -> "LaneModel":
        """damping: the coefficient c, or a `damping.Damping` (c or a damping ratio).
        A tree whose arrays break `Tree.check` is an `InputError`, not numpy's."""
        if not isinstance(tree, Tree):
            raise InputError(f"expected a Tree (plantlod.derive or read_tree), got "
                             f"{type(tree).__name__}")
        try:
            tree.check()
        except (ValueError, TypeError, AttributeError) as exc:
            raise tree.broken(exc) from None
        k = prepare(tree, damping)
        return cls(**{f: getattr(k, f) for f in cls.__dataclass_fields__})

    @property
    def n_branches(self) -> int:
        return int(self.parent.shape[0])

    @property
    def lanes(self) -> int | None:
        """The lane count fixed by per-lane parameters, None when all are shared."""
        for name in LANE_PARAMETERS:
            a = getattr(self, name)
            if a.ndim == 2:
                return int(a.shape[1])
        return None

    def with_lane_parameters(self, **columns: np.ndarray) -> "LaneModel":
        """A model whose named parameters have one value per lane.

        columns : name -> (B, W) array ((F, W) for leaf_scale), in the kernel's
                  units (bend_k = k_bs / 1000, drag = C_d 2 pi r L, leaf_scale = s_L A)
        """
        widths = set()
        changes = {}
        for name, value in columns.items():
            if name not in LANE_PARAMETERS:
                raise InputError(f"{name!r} is not a lane parameter; expected one of "
                                 f"{', '.join(LANE_PARAMETERS)}")
            try:                              # (strings were read as numbers)
                a = np.ascontiguousarray(real_array(value), dtype=np.float64)
            except (TypeError, ValueError):
                raise InputError(f"{name} per lane must be an array of numbers, got "
                                 f"{type(value).__name__}") from None
            if not np.all(np.isfinite(a)):
                raise InputError(f"{name} per lane must hold finite numbers")
            # strengths > 0 (model.md 4's stability rule needs them); the rest >= 0
            strength = name in ("bend_k", "rot_k")
            if not np.all(a > 0 if strength else a >= 0):
                raise InputError(f"{name} per lane must be "
                                 + ("> 0 (k_bs, k_rs / 1000)" if strength else ">= 0"))
            rows = getattr(self, name).shape[0]
            if a.ndim != 2 or a.shape[0] != rows:
                raise InputError(f"{name} per lane must have shape ({rows}, W), got {a.shape}")
            widths.add(a.shape[1])
            changes[name] = a
        if len(widths | ({self.lanes} if self.lanes else set())) > 1:
            raise InputError(f"lane parameters disagree on the lane count: {sorted(widths)}")
        return replace(self, **changes)


def check_lane_stability(model: LaneModel, dt: float) -> None:
    """Refuse (InputError) a time step at which some lane's bend or rotation of some branch
    is unstable (model.md 4: s = k dt / 1000 below `stability.largest_stable_s` of the
    model's damping), as `simulate` refuses it: lanes of changed strengths ran on, to angles
    of 1e6 rad."""
    from .stability import largest_stable_s

    limit = largest_stable_s(model.damping)
    for name in ("bend_k", "rot_k"):
        s = np.asarray(getattr(model, name)) * dt          # (B,) or (B, W): k / 1000 * dt
        if s.size and float(s.max()) >= limit:
            branch = int(np.unravel_index(int(np.argmax(s)), s.shape)[0])
            raise InputError(f"time step too large: branch {branch}'s {name} {float(s.max()) / dt:g} "
                             f"(k / 1000) gives s = k dt / 1000 = {float(s.max()):g} >= {limit:g}, "
                             f"the stability limit (model.md 4; dt = {dt:g} s)")


def thread_count(threads: int | None = None) -> int:
    """Threads to use: ``threads``, else $PLANTLOD_THREADS, else every core numba sees."""
    import numba

    if threads is None:
        threads = env_threads()
    limit = numba.config.NUMBA_NUM_THREADS
    if threads is None:
        return limit
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise InputError(f"the thread count must be a whole number >= 1, got "
                         f"{shown_value(threads)}")
    return min(int(threads), limit)


def _winds(winds, lanes: int | None, steps: int) -> np.ndarray:
    try:
        w = real_array(winds)
    except (TypeError, ValueError):
        raise InputError(f"winds must be numbers in m/s of shape (W, 3) or (W, {steps}, 3), "
                         f"got {shown_value(winds)}") from None
    if w.ndim == 1 and w.shape == (3,):
        w = w[None, :]
    if w.ndim == 2 and w.shape[1] == 3:
        # steady winds, as simulate refuses them (a series' samples are the caller's: a
        # gusty wind's, sampled by the API, may pass the limit where its mean does not)
        fastest = float(np.sqrt((w * w).sum(axis=1)).max(initial=0.0))
        if np.isfinite(fastest) and fastest > MAX_WIND_SPEED * (1.0 + SPEED_ROUNDING):
            raise InputError(f"a wind of {fastest:g} m/s; expected at most {MAX_WIND_SPEED:g} m/s")
        w = w[:, None, :]
    elif not (w.ndim == 3 and w.shape[2] == 3 and w.shape[1] in (1, steps)):
        raise InputError(f"winds must have shape (W, 3) or (W, {steps}, 3), got {w.shape}")
    if lanes is not None and w.shape[0] == 1 and lanes > 1:
        w = np.broadcast_to(w, (lanes,) + w.shape[1:])
    if lanes is not None and w.shape[0] != lanes:
        raise InputError(f"{w.shape[0]} winds for {lanes} lanes of parameters")
    if not np.all(np.isfinite(w)):
        raise InputError("wind components must be finite")
    return np.ascontiguousarray(w)


def new_state(model: LaneModel, lanes: int) -> np.ndarray:
    """The rest state of ``lanes`` runs: (W, 4, B) zeros, [theta_b, v_b, theta_r, v_r]."""
    return np.zeros((lanes, 4, model.n_branches))


def run_lanes(model: LaneModel, winds, dt: float, steps: int, *, every: int = 1,
              state: np.ndarray | None = None, threads: int | None = None,
              first_step: int = 1, addresses=None,
              lane_names=None) -> tuple[np.ndarray, np.ndarray]:
    """Step W runs of ``model`` by ``steps`` time steps of ``dt`` seconds.

    winds  : (W, 3) steady winds, or (W, steps, 3) the wind at the start of each
             step (V(t_{k-1}) for step k), m/s; one wind (3,) is one lane
    state  : optional (W, 4, B) float64 [theta_b, v_b, theta_r, v_r] (rad, rad/s),
             read as the start and updated in place, so a caller can run in pieces
             (numbering steps with ``first_step``); default: at rest
    every  : rows are kept after the steps k (counted from ``first_step``) with k % every == 0
    threads: see `thread_count`; the output does not depend on it
    Returns (bend, rotation), each (W, T, B) float64 radians, T the number of kept
    steps (steps // every when first_step = 1). Raises `RunFailure` naming the
    lane (as ``lane_names`` says, e.g. "the wind of 5 m/s toward 90°"; none for a single
    lane), step and branch (by address when ``addresses`` is given) where an angle
    stopped being finite, and `InputError` before any step for a dt at which some lane is
    unstable (`check_lane_stability`, model.md 4) or a steady wind past MAX_WIND_SPEED.
    """
    check_environment()          # (the API's callers too: NUMBA_NUM_THREADS=0 met numba's own
    check_jit_enabled()          # 28-line traceback where the commands refused it)
    from . import lanes_kernel   # numba, compiled on first use

    import numba

    if not isinstance(model, LaneModel):
        raise InputError(f"model must be a LaneModel (LaneModel.from_tree(tree)), got "
                         f"{type(model).__name__}")
    steps = whole("steps", steps, high=MAX_TIME_STEPS)
    every = whole("every", every, low=1)
    first_step = whole("first_step", first_step, low=1)
    dt = real("dt", dt, low=0.0, low_open=True)
    w = _winds(winds, model.lanes, steps)
    lanes, b = w.shape[0], model.n_branches
    check_lane_stability(model, dt)
    if state is None:
        state = new_state(model, lanes)
    if not isinstance(state, np.ndarray) or state.shape != (lanes, 4, b) \
            or state.dtype != np.float64:
        got = (f"{state.dtype} of shape {state.shape}" if isinstance(state, np.ndarray)
               else shown_value(state))
        raise InputError(f"state must be a float64 array of shape ({lanes}, 4, {b}), got {got}")
    if not state.flags.writeable:               # (it is updated in place: numpy's own error)
        raise InputError("state must be a writeable array (it is updated in place), got a "
                         "read-only one")
    if not np.isfinite(state).all():            # (reported as a divergence, with its advice)
        raise InputError("state must hold finite angles and velocities, got "
                         f"{float(state[~np.isfinite(state)][0])} in it")
    # lane index last in the kernel: (B, Wp) planes, Wp = W padded to whole blocks;
    # padding lanes repeat the last lane (their results are dropped)
    padded = -(-lanes // lanes_kernel.BLOCK) * lanes_kernel.BLOCK
    fill = np.r_[np.arange(lanes), np.full(padded - lanes, lanes - 1)] if lanes else np.arange(0)
    planes = [np.ascontiguousarray(state[fill, q, :].T) for q in range(4)]
    w = np.ascontiguousarray(w[fill])
    lane_model = _padded(model, fill)
    last = first_step + steps - 1
    rows = last // every - (first_step - 1) // every if steps else 0
    check_held_angles(rows, b, padded)
    out_bend = np.empty((padded, rows, b))
    out_rot = np.empty((padded, rows, b))
    bad_branch = np.full(padded, -1, dtype=np.int64)
    bad_step = np.full(padded, -1, dtype=np.int64)
    written = np.zeros(padded, dtype=np.int64)
    n_threads = thread_count(threads)
    before = numba.get_num_threads()
    numba.set_num_threads(n_threads)
    try:
        if steps and lanes:
            m = lane_model
            damp_b, damp_r = m.branch_damping(float(dt))
            lanes_kernel.run_lanes_kernel(
                m.parent, m.rest, m.cos_psi, m.sin_psi, m.absorbed, m.propagated, m.bend_k,
                m.rot_k, m.drag, m.leaf_start, m.leaf_scale, m.leaf_normal, m.gain,
                damp_b, damp_r,
                planes[0], planes[2], planes[1], planes[3],
                w, int(steps), float(dt), int(first_step), int(every), out_bend, out_rot, 0,
                bad_branch, bad_step, written)
    finally:
        numba.set_num_threads(before)
    for q in range(4):
        state[:, q, :] = planes[q].T[:lanes]
    bad_branch, bad_step = bad_branch[:lanes], bad_step[:lanes]
    bad = np.flatnonzero(bad_branch >= 0)
    if bad.size:
        lane = int(bad[np.argmin(bad_step[bad])])
        i, k = int(bad_branch[lane]), int(bad_step[lane])
        where = addresses[i] if addresses is not None else f"#{i}"
        which = (f" in {lane_names[lane]}," if lane_names is not None
                 else f" in lane {lane}," if lanes > 1 else "")
        raise RunFailure(f"simulation diverged at t={k * dt:.10g} s (step {k}){which} "
                         f"branch {where}: an angle is no longer finite; {divergence_advice(k)}")
    return out_bend[:lanes], out_rot[:lanes]


def _padded(model: LaneModel, fill: np.ndarray) -> LaneModel:
    """``model`` with its per-lane parameter columns taken at ``fill`` (shared ones as they are)."""
    changes = {name: np.ascontiguousarray(getattr(model, name)[:, fill])
               for name in LANE_PARAMETERS if getattr(model, name).ndim == 2}
    return replace(model, **changes) if changes else model
