"""The time-stepping kernel (model.md sections 3 and 4), compiled with numba.

This is the only module that imports numba; ``plantlod.sim`` does not import it,
so commands that do not simulate start without compiling anything.

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
       vb += k_FA (F_i . S_i e_x) - thb k_bs / 1000 - c vb;  thb += vb dt
       vr += k_FA (F_i . S_i e_y) - thr k_rs / 1000 - c vr;  thr += vr dt
   Every frame was computed from the old angles in pass 1, so updating a
   branch's angles in pass 2 does not change the step's forces.

Compiled with ``cache=True`` (the machine code is kept in __pycache__ and
loaded on later runs), without fastmath (results must not depend on the
compiler's reassociation), and with numpy's error model (a division by zero
gives inf or nan instead of raising, which the divergence check then reports).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from plantlod.lsys.tree import Tree

from .kinematics import rest_swing_rotation


@dataclass(frozen=True)
class KernelModel:
    """Per-run constants of a tree, flattened for the kernel.

    parent     : (B,) int64, -1 for a root
    rest       : (B, 9) float64, Q_i = Rz(phi) Ry(alpha) row-major
    cos_psi, sin_psi : (B,) float64
    absorbed   : (B,) k_FA
    propagated : (B,) k_fp
    bend_k, rot_k : (B,) k_bs / 1000 and k_rs / 1000: the velocity change per
                    step (rad/s) per radian of angle
    drag       : (B,) C_d * 2 pi r L (m^2)
    leaf_start : (B + 1,) int64, leaves of branch i are rows leaf_start[i]:leaf_start[i+1]
    leaf_scale : (F,) s_L * A_j (m^2), grouped by branch
    leaf_normal: (F, 3) rest normals in the branch frame, grouped by branch
    damping    : c (dimensionless, per step)
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
    damping: float


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
        self.acc = np.zeros((b, 3))
        self.drag = np.zeros((b, 3))


def prepare(tree: Tree, damping: float = 0.0) -> KernelModel:
    """Flatten ``tree`` into the kernel's arrays (see `KernelModel`)."""
    b = tree.n_branches
    euler = np.asarray(tree.euler, dtype=np.float64).reshape(b, 3)
    leaf_branch = np.asarray(tree.leaf_branch, dtype=np.int64)
    order = np.argsort(leaf_branch, kind="stable")   # keep file order within a branch
    counts = np.bincount(leaf_branch, minlength=b) if len(leaf_branch) else np.zeros(b, np.int64)
    leaf_start = np.zeros(b + 1, dtype=np.int64)
    np.cumsum(counts, out=leaf_start[1:])
    length = np.asarray(tree.length, dtype=np.float64)
    radius = np.asarray(tree.radius, dtype=np.float64)
    return KernelModel(
        parent=np.ascontiguousarray(tree.parent, dtype=np.int64),
        rest=np.ascontiguousarray(rest_swing_rotation(euler).reshape(b, 9)),
        cos_psi=np.cos(euler[:, 2]),
        sin_psi=np.sin(euler[:, 2]),
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
        damping=float(damping),
    )


@numba.njit(cache=True, error_model="numpy")
def _advance(parent, rest, cos_psi, sin_psi, absorbed, propagated, bend_k, rot_k, drag,
             leaf_start, leaf_scale, leaf_normal, damping,
             bend, rot, bend_vel, rot_vel, frame, swing_x, swing_y, acc, dragf,
             wind, dt, first_step, every, out_bend, out_rot, out_row):
    """Advance len(wind) steps; see `advance`. Returns (rows written, bad branch, bad step)."""
    n = parent.shape[0]
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
            q0 = rest[i, 0]; q1 = rest[i, 1]; q2 = rest[i, 2]
            q3 = rest[i, 3]; q4 = rest[i, 4]; q5 = rest[i, 5]
            q6 = rest[i, 6]; q7 = rest[i, 7]; q8 = rest[i, 8]
            if p >= 0:
                # M = R_parent Q_i
                a0 = frame[p, 0]; a1 = frame[p, 1]; a2 = frame[p, 2]
                a3 = frame[p, 3]; a4 = frame[p, 4]; a5 = frame[p, 5]
                a6 = frame[p, 6]; a7 = frame[p, 7]; a8 = frame[p, 8]
                m0 = a0 * q0 + a1 * q3 + a2 * q6
                m1 = a0 * q1 + a1 * q4 + a2 * q7
                m2 = a0 * q2 + a1 * q5 + a2 * q8
                m3 = a3 * q0 + a4 * q3 + a5 * q6
                m4 = a3 * q1 + a4 * q4 + a5 * q7
                m5 = a3 * q2 + a4 * q5 + a5 * q8
                m6 = a6 * q0 + a7 * q3 + a8 * q6
                m7 = a6 * q1 + a7 * q4 + a8 * q7
                m8 = a6 * q2 + a7 * q5 + a8 * q8
            else:
                m0 = q0; m1 = q1; m2 = q2
                m3 = q3; m4 = q4; m5 = q5
                m6 = q6; m7 = q7; m8 = q8
            tb = bend[i]
            tr = rot[i]
            theta = math.sqrt(tb * tb + tr * tr)
            if theta != 0.0:
                # S = M Rot(u, theta), u = (-tr, tb, 0) / theta
                ux = -tr / theta
                uy = tb / theta
                c = math.cos(theta)
                s = math.sin(theta)
                oc = 1.0 - c
                r00 = c + oc * ux * ux
                r01 = oc * ux * uy
                r02 = s * uy
                r11 = c + oc * uy * uy
                r12 = -s * ux
                # Rot = [[r00, r01, r02], [r01, r11, r12], [-r02, -r12, c]]
                s0 = m0 * r00 + m1 * r01 - m2 * r02
                s1 = m0 * r01 + m1 * r11 - m2 * r12
                s2 = m0 * r02 + m1 * r12 + m2 * c
                s3 = m3 * r00 + m4 * r01 - m5 * r02
                s4 = m3 * r01 + m4 * r11 - m5 * r12
                s5 = m3 * r02 + m4 * r12 + m5 * c
                s6 = m6 * r00 + m7 * r01 - m8 * r02
                s7 = m6 * r01 + m7 * r11 - m8 * r12
                s8 = m6 * r02 + m7 * r12 + m8 * c
            else:
                s0 = m0; s1 = m1; s2 = m2
                s3 = m3; s4 = m4; s5 = m5
                s6 = m6; s7 = m7; s8 = m8
            swing_x[i, 0] = s0; swing_x[i, 1] = s3; swing_x[i, 2] = s6
            swing_y[i, 0] = s1; swing_y[i, 1] = s4; swing_y[i, 2] = s7
            # R = S Rz(psi): x' = c x + s y, y' = -s x + c y, z' = z
            cp = cos_psi[i]
            sp = sin_psi[i]
            f0 = cp * s0 + sp * s1
            f1 = cp * s1 - sp * s0
            f3 = cp * s3 + sp * s4
            f4 = cp * s4 - sp * s3
            f6 = cp * s6 + sp * s7
            f7 = cp * s7 - sp * s6
            frame[i, 0] = f0; frame[i, 1] = f1; frame[i, 2] = s2
            frame[i, 3] = f3; frame[i, 4] = f4; frame[i, 5] = s5
            frame[i, 6] = f6; frame[i, 7] = f7; frame[i, 8] = s8

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
                # |R e_z x V^|, R e_z = (s2, s5, s8)
                cx = s5 * hz - s8 * hy
                cy = s8 * hx - s2 * hz
                cz = s2 * hy - s5 * hx
                g = drag[i] * speed2 * math.sqrt(cx * cx + cy * cy + cz * cz)
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
            vb = bend_vel[i]
            vr = rot_vel[i]
            vb = vb + kfa * fb - bend[i] * bend_k[i] - damping * vb
            vr = vr + kfa * fr - rot[i] * rot_k[i] - damping * vr
            tb = bend[i] + vb * dt
            tr = rot[i] + vr * dt
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
            out_row: int) -> tuple[int, int, int]:
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
    """
    wind = np.ascontiguousarray(wind, dtype=np.float64)
    return _advance(model.parent, model.rest, model.cos_psi, model.sin_psi,
                    model.absorbed, model.propagated, model.bend_k, model.rot_k,
                    model.drag, model.leaf_start, model.leaf_scale, model.leaf_normal,
                    model.damping,
                    state.bend, state.rot, state.bend_vel, state.rot_vel,
                    state.frame, state.swing_x, state.swing_y, state.acc, state.drag,
                    wind, float(dt), int(first_step), int(every), out_bend, out_rot,
                    int(out_row))
