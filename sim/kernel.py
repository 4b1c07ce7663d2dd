"""The time-stepping kernel (model.md sections 3 and 4): compiled with numba, or interpreted.

`_advance` is plain Python over arrays. A run of more than `INTERPRET_BRANCH_STEPS`
(branch + leaf)-steps runs it compiled by numba (`compiled`; ``cache=True``, so the machine
code is loaded from __pycache__ after the first run); a shorter one runs it in the
interpreter over memoryviews, without importing numba at all, because loading numba
and the cached code (~0.3 s of CPU) costs more than interpreting a few thousand
branch-steps. Both give the same bits (every operation is one IEEE operation on
doubles, no fused multiply-add; tests/test_sim_kernel.py checks it), so the choice
only changes the time.

`prepare` turns a `Tree` into flat float64/int64 arrays (`KernelModel`) once per
run; `advance` then moves a `KernelState` forward by any number of steps,
writing every ``every``-th sample into caller-owned output arrays, so memory
does not grow with the length of a run.

One step, from t_{k-1} to t_k, with the wind V = V(t_{k-1}):

1. Forward pass over branches (parent before child): the swing frame
   S_i = R_parent Q_i Rot(u_i, theta_i) with Q_i = Rz(phi_i) Ry(alpha_i)
   precomputed, the branch frame R_i = S_i Rz(psi_i); the leaf forces
   f_j = s_L A_j (V . n_j') n_j' with n_j' = R_i n_j are summed per branch and
   the drag d_i = C_d v^2 (2 pi r L) |R_i e_z x V^| V^ is stored.
2. Backward pass (child before parent): F_i = d_i + k_fp (leaves_i + sum of
   children's F), added into the parent's sum; then the semi-implicit update
       vb += k_FA (F_i . S_i e_x) - thb k_bs / 1000 - c_b vb;  thb += vb dt
       vr += k_FA (F_i . S_i e_y) - thr k_rs / 1000 - c_r vr;  thr += vr dt
   or, for a tree whose branches carry the gain matrix G of model.md 5 (a level),
   with f = S_i^T F_i: vb += k_FA (G_b . f) - ...; vr += k_FA (G_r . f) - ...
   (a branch with G has k_FA = 1; one without has G = [[1, 0, 0], [0, 1, 0]], which
   gives the same bits as the first form). c_b, c_r per branch: `damping`.
   Every frame was computed from the old angles in pass 1, so updating a
   branch's angles in pass 2 does not change the step's forces.

sin and cos are `trig.sincos1` (`trig.sincos`, fdlibm's polynomials, the same bits in
every kernel).
Compiled without fastmath (results must not depend on the compiler's
reassociation), and with numpy's error model; the formulas never divide by zero
(the theta = 0 case of the rotation is a select), so the interpreter does not raise
where the compiled code would give inf or nan, and the divergence check reports both.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.tree import Tree

from .branch_math import advance_angle, drag_magnitude, gained_forces, swing, times_rest, twist
from .damping import Damping, as_damping, coefficients
from .engine_env import forced_kernel
from .kinematics import rest_rotations
from .trig import sincos1


@dataclass(frozen=True)
class KernelModel:
    """Per-run constants of a tree, flattened for the kernel.

    parent     : (B,) int64, -1 for a root
    rest       : (B, 9) float64, Q_i = Rz(phi) Ry(alpha) row-major (times Rz(beta) for a
                 branch with a swing roll beta, `kinematics.rest_rotations`)
    cos_psi, sin_psi : (B,) float64, of psi (psi - beta with a swing roll)
    absorbed   : (B,) k_FA
    propagated : (B,) k_fp
    bend_k, rot_k : (B,) k_bs / 1000 and k_rs / 1000: the velocity change per
                    step (rad/s) per radian of angle
    drag       : (B,) C_d * 2 pi r L (m^2)
    leaf_start : (B + 1,) int64, leaves of branch i are rows leaf_start[i]:leaf_start[i+1]
    leaf_scale : (F,) s_L * A_j (m^2), grouped by branch
    leaf_normal: (F, 3) rest normals in the branch frame, grouped by branch
    gain       : (B, 6) the gain matrix rows [G_bx G_by G_bz G_rx G_ry G_rz] per branch
                 (multiplied by k_FA), or (0, 6) when no branch has one (model.md 5)
    damping    : c or the damping ratio (`damping.Damping`); per-branch c from Δt
    """

    parent: np.ndarray
    rest: np.ndarray
    cos_psi: np.ndarray
    sin_psi: np.ndarray
    absorbed: np.ndarray
    propagated: np.ndarray
    bend_k: np.ndarray
    rot_k: np.ndarray
    drag: np.ndarray
    leaf_start: np.ndarray
    leaf_scale: np.ndarray
    leaf_normal: np.ndarray
    gain: np.ndarray
    damping: Damping

    @property
    def n_branches(self) -> int:
        return self.parent.shape[0]

    @property
    def n_leaves(self) -> int:
        return self.leaf_scale.shape[0]

    def branch_damping(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(c_b, c_r): per-branch damping of the bend and the rotation at time step ``dt``,
        the shapes of ``bend_k`` and ``rot_k``."""
        return coefficients(self.damping, self.bend_k, self.rot_k, dt)


class KernelState:
    """Angles and velocities of every branch, (B,) float64 each, plus scratch space.

    ``bend``/``rot`` are radians, ``bend_vel``/``rot_vel`` radians per second.
    Starts at rest (all zeros), as model.md's t0.
    """

    def __init__(self, n_branches: int):
        b = n_branches
        self.bend = np.zeros(b)
        self.rot = np.zeros(b)
        self.bend_vel = np.zeros(b)
        self.rot_vel = np.zeros(b)
        # scratch: branch frames (B, 9), swing x and y axes (B, 3), leaf-force sums
        # then accumulated child forces (B, 3), drag forces (B, 3)
        self.frame = np.zeros((b, 9))
        self.swing_x = np.zeros((b, 3))
        self.swing_y = np.zeros((b, 3))
        self.swing_z = np.zeros((b, 3))
        self.acc = np.zeros((b, 3))
        self.drag = np.zeros((b, 3))


def gain_rows(tree: Tree) -> np.ndarray:
    """(B, 6) float64 gain matrices of ``tree``'s branches, or (0, 6) when none has one."""
    gain = getattr(tree, "force_gain", None)
    if gain is None:
        return np.zeros((0, 6))
    return np.ascontiguousarray(np.asarray(gain, dtype=np.float64).reshape(tree.n_branches, 6))


def prepare(tree: Tree, damping: "float | Damping" = 0.0) -> KernelModel:
    """Flatten ``tree`` into the kernel's arrays (see `KernelModel`); damping: c or a `Damping`."""
    b = tree.n_branches
    rest, twist = rest_rotations(tree)
    leaf_branch = np.asarray(tree.leaf_branch, dtype=np.int64)
    order = np.argsort(leaf_branch, kind="stable")   # keep file order within a branch
    counts = np.bincount(leaf_branch, minlength=b) if len(leaf_branch) else np.zeros(b, np.int64)
    leaf_start = np.zeros(b + 1, dtype=np.int64)
    np.cumsum(counts, out=leaf_start[1:])
    length = np.asarray(tree.length, dtype=np.float64)
    radius = np.asarray(tree.radius, dtype=np.float64)
    return KernelModel(
        parent=np.ascontiguousarray(tree.parent, dtype=np.int64),
        rest=np.ascontiguousarray(rest.reshape(b, 9)),
        cos_psi=np.cos(twist),
        sin_psi=np.sin(twist),
        absorbed=np.ascontiguousarray(tree.force_absorbed, dtype=np.float64),
        propagated=np.ascontiguousarray(tree.force_propagated, dtype=np.float64),
        bend_k=np.asarray(tree.bend_strength, dtype=np.float64) / 1000.0,
        rot_k=np.asarray(tree.rotation_strength, dtype=np.float64) / 1000.0,
        drag=np.asarray(tree.drag_coefficient, dtype=np.float64) * (2.0 * math.pi) * radius * length,
        leaf_start=leaf_start,
        leaf_scale=np.ascontiguousarray(
            float(tree.leaf_force_scale) * np.asarray(tree.leaf_area, dtype=np.float64)[order]),
        leaf_normal=np.ascontiguousarray(
            np.asarray(tree.leaf_normal, dtype=np.float64).reshape(-1, 3)[order]),
        gain=gain_rows(tree),
        damping=as_damping(damping),
    )


def _advance(parent, rest, cos_psi, sin_psi, absorbed, propagated, bend_k, rot_k, drag,
             leaf_start, leaf_scale, leaf_normal, gain, damp_b, damp_r,
             bend, rot, bend_vel, rot_vel, frame, swing_x, swing_y, swing_z, acc, dragf,
             wind, dt, first_step, every, out_bend, out_rot, out_row):
    """Advance len(wind) steps; see `advance`. Returns (rows written, bad branch, bad step)."""
    n = parent.shape[0]
    gained = gain.shape[0] > 0
    rows = 0
    for j in range(wind.shape[0]):
        vx = wind[j, 0]
        vy = wind[j, 1]
        vz = wind[j, 2]
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        if speed > 0.0:
            hx = vx / speed
            hy = vy / speed
            hz = vz / speed
        else:
            hx = 0.0
            hy = 0.0
            hz = 0.0
        speed2 = speed * speed

        # ---- pass 1: frames, leaf forces, drag (parent before child) ----
        for i in range(n):
            p = parent[i]
            q = (rest[i, 0], rest[i, 1], rest[i, 2], rest[i, 3], rest[i, 4], rest[i, 5],
                 rest[i, 6], rest[i, 7], rest[i, 8])
            if p >= 0:
                m = times_rest((frame[p, 0], frame[p, 1], frame[p, 2], frame[p, 3], frame[p, 4],
                                frame[p, 5], frame[p, 6], frame[p, 7], frame[p, 8]), q)
            else:
                m = q
            tb = bend[i]
            tr = rot[i]
            theta = math.sqrt(tb * tb + tr * tr)
            s, c = sincos1(theta)
            sw = swing(m, tb, tr, theta, c, s)
            swing_x[i, 0] = sw[0]; swing_x[i, 1] = sw[3]; swing_x[i, 2] = sw[6]
            swing_y[i, 0] = sw[1]; swing_y[i, 1] = sw[4]; swing_y[i, 2] = sw[7]
            if gained:                                  # the z axis is read only with G
                swing_z[i, 0] = sw[2]; swing_z[i, 1] = sw[5]; swing_z[i, 2] = sw[8]
            f = twist(sw, cos_psi[i], sin_psi[i])
            for q_ in range(9):
                frame[i, q_] = f[q_]
            f0 = f[0]; f1 = f[1]; s2 = f[2]
            f3 = f[3]; f4 = f[4]; s5 = f[5]
            f6 = f[6]; f7 = f[7]; s8 = f[8]

            lx = 0.0
            ly = 0.0
            lz = 0.0
            for leaf in range(leaf_start[i], leaf_start[i + 1]):
                nx0 = leaf_normal[leaf, 0]
                ny0 = leaf_normal[leaf, 1]
                nz0 = leaf_normal[leaf, 2]
                nx = f0 * nx0 + f1 * ny0 + s2 * nz0
                ny = f3 * nx0 + f4 * ny0 + s5 * nz0
                nz = f6 * nx0 + f7 * ny0 + s8 * nz0
                g = leaf_scale[leaf] * (vx * nx + vy * ny + vz * nz)
                lx += g * nx
                ly += g * ny
                lz += g * nz
            acc[i, 0] = lx
            acc[i, 1] = ly
            acc[i, 2] = lz

            if speed > 0.0:
                g = drag_magnitude(sw, hx, hy, hz, drag[i], speed2)
                dragf[i, 0] = g * hx
                dragf[i, 1] = g * hy
                dragf[i, 2] = g * hz
            else:
                dragf[i, 0] = 0.0
                dragf[i, 1] = 0.0
                dragf[i, 2] = 0.0

        # ---- pass 2: total forces (child before parent) and the update ----
        bad = -1
        for i in range(n - 1, -1, -1):
            kfp = propagated[i]
            fx = dragf[i, 0] + kfp * acc[i, 0]
            fy = dragf[i, 1] + kfp * acc[i, 1]
            fz = dragf[i, 2] + kfp * acc[i, 2]
            p = parent[i]
            if p >= 0:
                acc[p, 0] += fx
                acc[p, 1] += fy
                acc[p, 2] += fz
            kfa = absorbed[i]
            fb = fx * swing_x[i, 0] + fy * swing_x[i, 1] + fz * swing_x[i, 2]
            fr = fx * swing_y[i, 0] + fy * swing_y[i, 1] + fz * swing_y[i, 2]
            if gained:
                fa = fx * swing_z[i, 0] + fy * swing_z[i, 1] + fz * swing_z[i, 2]
                fb, fr = gained_forces(gain[i, 0], gain[i, 1], gain[i, 2], gain[i, 3],
                                       gain[i, 4], gain[i, 5], fb, fr, fa)
            tb, vb = advance_angle(bend[i], bend_vel[i], kfa, fb, bend_k[i], damp_b[i], dt)
            tr, vr = advance_angle(rot[i], rot_vel[i], kfa, fr, rot_k[i], damp_r[i], dt)
            bend_vel[i] = vb
            rot_vel[i] = vr
            bend[i] = tb
            rot[i] = tr
            if not (math.isfinite(tb) and math.isfinite(tr)):
                bad = i            # the loop runs downwards: ends at the lowest index
        step = first_step + j
        if bad >= 0:
            return rows, bad, step
        if step % every == 0:
            r = out_row + rows
            for i in range(n):
                out_bend[r, i] = bend[i]
                out_rot[r, i] = rot[i]
            rows += 1
    return rows, -1, -1


def advance(model: KernelModel, state: KernelState, wind: np.ndarray, dt: float,
            first_step: int, every: int, out_bend: np.ndarray, out_rot: np.ndarray,
            out_row: int, engine: str | None = None) -> tuple[int, int, int]:
    """Advance ``state`` by K = len(wind) steps, numbered first_step .. first_step + K - 1.

    wind       : (K, 3) float64, m/s: the wind at the start of each step
                 (V(t_{k-1}) for step k)
    dt         : time step, s
    every      : after step k with k % every == 0, the angles are written to
                 row out_row + (rows written so far) of out_bend / out_rot,
                 (rows, B) float64 each; the caller leaves room for them
    Returns (rows written, bad branch, bad step): bad branch is -1, or the
    lowest index of a branch whose angle became non-finite at step "bad step";
    the state then holds that step's (non-finite) values and stepping stopped.
    engine     : "compiled", "interpreted" (the same bits) or None: `engine_for` this call
    """
    wind = np.ascontiguousarray(wind, dtype=np.float64)
    damp_b, damp_r = model.branch_damping(dt)
    args = (model.parent, model.rest, model.cos_psi, model.sin_psi,
            model.absorbed, model.propagated, model.bend_k, model.rot_k,
            model.drag, model.leaf_start, model.leaf_scale, model.leaf_normal,
            model.gain, damp_b, damp_r,
            state.bend, state.rot, state.bend_vel, state.rot_vel,
            state.frame, state.swing_x, state.swing_y, state.swing_z, state.acc, state.drag,
            wind)
    tail = (float(dt), int(first_step), int(every))
    if engine is None:
        engine = engine_for(model, wind.shape[0])
    if engine == "interpreted":
        global _interpreted_work
        _interpreted_work += (model.n_branches + model.n_leaves) * wind.shape[0]
        # memoryviews: element access gives Python floats and ints, several times
        # faster than numpy scalars, and the same doubles
        views = tuple(memoryview(np.ascontiguousarray(a)) for a in args)
        for a in (out_bend, out_rot) + args[15:25]:
            if not a.flags.c_contiguous:
                raise ValueError("state and output arrays must be C-contiguous")
        return _advance(*views, *tail, memoryview(out_bend), memoryview(out_rot), int(out_row))
    return compiled()(*args, *tail, out_bend, out_rot, int(out_row))


# A process interprets at most this many (branch + leaf)-steps in all (see the module's
# docstring): the interpreter does ~160,000 a second, so at most ~0.1 s, against ~0.3 s
# of CPU to load numba and the cached kernel. Past that budget (many short runs, as a
# calibration makes) every run is compiled.
INTERPRET_BRANCH_STEPS = 15_000

_compiled = None
_interpreted_work = 0


def engine_for(model: "KernelModel | Tree", steps: int) -> str:
    """"interpreted" while numba is not loaded and this run fits in what is left of the
    process's INTERPRET_BRANCH_STEPS (branches + leaves) x steps, else "compiled"; both
    give the same bits. $PLANTLOD_KERNEL (`constants.KERNEL_ENV`) = compiled or
    interpreted overrides it. model: anything with ``n_branches`` and ``n_leaves`` (the
    flattened tree, or the tree itself: flattening only to count is not needed)."""
    forced = forced_kernel()
    if forced is not None:
        return forced
    work = (model.n_branches + model.n_leaves) * steps
    if "numba" not in sys.modules and _interpreted_work + work <= INTERPRET_BRANCH_STEPS:
        return "interpreted"
    return "compiled"


def compiled():
    """`_advance` compiled by numba (loaded from the on-disk cache after the first time)."""
    global _compiled
    if _compiled is None:
        import numba

        from . import jit  # noqa: F401  (the shared formulas, registered with numba)

        _compiled = numba.njit(cache=True, error_model="numpy")(_advance)
    return _compiled
