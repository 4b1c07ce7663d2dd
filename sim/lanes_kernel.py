"""The lanes kernel: one tree structure stepped under W winds (or W parameter sets) at once.

The arithmetic of one branch and one step is the single-run kernel's
(`plantlod.sim.kernel`, model.md sections 3 and 4), written so that the
innermost loop runs over **lanes** l = 0 .. W-1 on contiguous arrays: the same
branch of W copies of the tree, with no dependency between them. LLVM turns
such loops into vector instructions (4 doubles per AVX2 register).

Memory layout (docs/engine.md)::

    shared per branch      parent (B,)  rest (B, 9)  cos_psi, sin_psi (B,)
    parameters             (B,) shared, or (B, W) one value per lane
    state, scratch         (B, W) / (B, 9, W) / (B, 3, W): lane index last
    output                 (W, T, B): one run per lane, as the single kernel writes it

Work is split into fixed blocks of lanes (``block`` lanes each, the last one
shorter) and the blocks are distributed over threads with numba's ``prange``.
A lane's arithmetic never depends on the other lanes, on its block or on the
thread that runs it, so the output is the same bit for bit for any thread count.

The per-branch arithmetic is `branch_math`'s, shared with the single kernel; cos
and sin are computed in a lane loop of their own. Compiled without fastmath, with
numpy's error model (docs/engine.md says what LLVM made of the lane loops).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange
from numba.extending import overload

from .branch_math import advance_angle, drag_magnitude, gained_forces, swing, times_rest, twist


def param(a, i, lane):
    """``a[i]`` for a parameter shared by all lanes (1-D), ``a[i, lane]`` for one per lane (2-D)."""
    return a[i] if a.ndim == 1 else a[i, lane]


@overload(param, inline="always")
def _param_overload(a, i, lane):
    if a.ndim == 1:
        return lambda a, i, lane: a[i]
    return lambda a, i, lane: a[i, lane]


# Lanes per block: a compile-time constant, so that every lane loop has a known trip
# count that LLVM turns into whole vector instructions (4 doubles per AVX2 register)
# with no scalar remainder. `run_lanes` pads the lane count to a multiple of it.
BLOCK = 4


@numba.njit(cache=True, error_model="numpy", parallel=True)
def run_lanes_kernel(parent, rest, cos_psi, sin_psi, absorbed, propagated, bend_k, rot_k, drag,
                     leaf_start, leaf_scale, leaf_normal, gain, damp_b, damp_r,
                     bend, rot, bend_vel, rot_vel,
                     wind, n_steps, dt, first_step, every, out_bend, out_rot, out_row,
                     bad_branch, bad_step, rows_written):
    """Advance every lane by ``n_steps`` steps; see `plantlod.sim.lanes.run_lanes`.

    parent, rest, cos_psi, sin_psi, leaf_start : the tree's structure (as in `kernel.KernelModel`)
    absorbed, propagated, bend_k, rot_k, drag  : (B,) or (B, W)
    leaf_scale, leaf_normal                    : (F,) or (F, W); (F, 3)
    gain       : (B, 6) gain matrices (model.md 5) shared by every lane, or (0, 6) for none
    damp_b, damp_r : (B,) or (B, W) per-branch damping c of the bend and the rotation
    bend, rot, bend_vel, rot_vel               : (B, W) state, updated in place
    wind       : (W, n_steps, 3) m/s, the wind at the start of each step, or (W, 1, 3) steady
    W is a multiple of BLOCK.
    out_bend, out_rot : (W, rows, B); after step k with k % every == 0 the angles
                 go to row out_row + (rows written so far)
    bad_branch, bad_step, rows_written : (W,) int64 outputs per lane (-1: none)
    """
    n = parent.shape[0]
    w_total = bend.shape[1]
    steady = wind.shape[1] == 1
    gained = gain.shape[0] > 0
    n_blocks = w_total // BLOCK        # the caller pads W to a multiple of BLOCK
    for blk in prange(n_blocks):
        l0 = blk * BLOCK
        frame = np.empty((n, 9, BLOCK))
        swx = np.empty((n, 3, BLOCK))
        swy = np.empty((n, 3, BLOCK))
        swz = np.empty((n, 3, BLOCK))
        acc = np.empty((n, 3, BLOCK))
        dragf = np.empty((n, 3, BLOCK))
        vx = np.empty(BLOCK); vy = np.empty(BLOCK); vz = np.empty(BLOCK)
        hx = np.empty(BLOCK); hy = np.empty(BLOCK); hz = np.empty(BLOCK)
        sp2 = np.empty(BLOCK)
        cth = np.empty(BLOCK); sth = np.empty(BLOCK); th = np.empty(BLOCK)
        # the block's state in arrays of its own: LLVM then knows that no store
        # into them changes another array, which lets it vectorise the lane loops
        bend_l = np.empty((n, BLOCK)); rot_l = np.empty((n, BLOCK))
        vb_l = np.empty((n, BLOCK)); vr_l = np.empty((n, BLOCK))
        for i in range(n):
            for k in range(BLOCK):
                bend_l[i, k] = bend[i, l0 + k]; rot_l[i, k] = rot[i, l0 + k]
                vb_l[i, k] = bend_vel[i, l0 + k]; vr_l[i, k] = rot_vel[i, l0 + k]
        rows = 0
        stopped = False
        for j in range(n_steps):
            wj = 0 if steady else j
            for k in range(BLOCK):
                l = l0 + k
                x = wind[l, wj, 0]; y = wind[l, wj, 1]; z = wind[l, wj, 2]
                sp = math.sqrt(x * x + y * y + z * z)
                vx[k] = x; vy[k] = y; vz[k] = z
                if sp > 0.0:
                    hx[k] = x / sp; hy[k] = y / sp; hz[k] = z / sp
                else:
                    hx[k] = 0.0; hy[k] = 0.0; hz[k] = 0.0
                sp2[k] = sp * sp

            # ---- pass 1: frames, leaf forces, drag (parent before child) ----
            for i in range(n):
                p = parent[i]
                q = (rest[i, 0], rest[i, 1], rest[i, 2], rest[i, 3], rest[i, 4], rest[i, 5],
                     rest[i, 6], rest[i, 7], rest[i, 8])
                cp = cos_psi[i]
                spsi = sin_psi[i]
                for k in range(BLOCK):
                    tb = bend_l[i, k]
                    tr = rot_l[i, k]
                    t = math.sqrt(tb * tb + tr * tr)
                    th[k] = t
                for k in range(BLOCK):
                    cth[k] = math.cos(th[k])
                    sth[k] = math.sin(th[k])
                for k in range(BLOCK):
                    l = l0 + k
                    if p >= 0:
                        m = times_rest((frame[p, 0, k], frame[p, 1, k], frame[p, 2, k],
                                        frame[p, 3, k], frame[p, 4, k], frame[p, 5, k],
                                        frame[p, 6, k], frame[p, 7, k], frame[p, 8, k]), q)
                    else:
                        m = q
                    sw = swing(m, bend_l[i, k], rot_l[i, k], th[k], cth[k], sth[k])
                    swx[i, 0, k] = sw[0]; swx[i, 1, k] = sw[3]; swx[i, 2, k] = sw[6]
                    swy[i, 0, k] = sw[1]; swy[i, 1, k] = sw[4]; swy[i, 2, k] = sw[7]
                    swz[i, 0, k] = sw[2]; swz[i, 1, k] = sw[5]; swz[i, 2, k] = sw[8]
                    f = twist(sw, cp, spsi)
                    for q_ in range(9):
                        frame[i, q_, k] = f[q_]
                    acc[i, 0, k] = 0.0
                    acc[i, 1, k] = 0.0
                    acc[i, 2, k] = 0.0
                    # zero where there is no wind (V^ = 0)
                    g = drag_magnitude(sw, hx[k], hy[k], hz[k], param(drag, i, l), sp2[k])
                    dragf[i, 0, k] = g * hx[k]
                    dragf[i, 1, k] = g * hy[k]
                    dragf[i, 2, k] = g * hz[k]
                for leaf in range(leaf_start[i], leaf_start[i + 1]):
                    nx0 = leaf_normal[leaf, 0]
                    ny0 = leaf_normal[leaf, 1]
                    nz0 = leaf_normal[leaf, 2]
                    for k in range(BLOCK):
                        l = l0 + k
                        nx = frame[i, 0, k] * nx0 + frame[i, 1, k] * ny0 + frame[i, 2, k] * nz0
                        ny = frame[i, 3, k] * nx0 + frame[i, 4, k] * ny0 + frame[i, 5, k] * nz0
                        nz = frame[i, 6, k] * nx0 + frame[i, 7, k] * ny0 + frame[i, 8, k] * nz0
                        g = param(leaf_scale, leaf, l) * (vx[k] * nx + vy[k] * ny + vz[k] * nz)
                        acc[i, 0, k] += g * nx
                        acc[i, 1, k] += g * ny
                        acc[i, 2, k] += g * nz

            # ---- pass 2: total forces (child before parent) and the update ----
            step = first_step + j
            for i in range(n - 1, -1, -1):
                p = parent[i]
                for k in range(BLOCK):
                    l = l0 + k
                    kfp = param(propagated, i, l)
                    fx = dragf[i, 0, k] + kfp * acc[i, 0, k]
                    fy = dragf[i, 1, k] + kfp * acc[i, 1, k]
                    fz = dragf[i, 2, k] + kfp * acc[i, 2, k]
                    if p >= 0:
                        acc[p, 0, k] += fx
                        acc[p, 1, k] += fy
                        acc[p, 2, k] += fz
                    kfa = param(absorbed, i, l)
                    fb = fx * swx[i, 0, k] + fy * swx[i, 1, k] + fz * swx[i, 2, k]
                    fr = fx * swy[i, 0, k] + fy * swy[i, 1, k] + fz * swy[i, 2, k]
                    if gained:
                        fa = fx * swz[i, 0, k] + fy * swz[i, 1, k] + fz * swz[i, 2, k]
                        fb, fr = gained_forces(gain[i, 0], gain[i, 1], gain[i, 2], gain[i, 3],
                                               gain[i, 4], gain[i, 5], fb, fr, fa)
                    tb, vb = advance_angle(bend_l[i, k], vb_l[i, k], kfa, fb, param(bend_k, i, l),
                                           param(damp_b, i, l), dt)
                    tr, vr = advance_angle(rot_l[i, k], vr_l[i, k], kfa, fr, param(rot_k, i, l),
                                           param(damp_r, i, l), dt)
                    vb_l[i, k] = vb
                    vr_l[i, k] = vr
                    bend_l[i, k] = tb
                    rot_l[i, k] = tr
                for k in range(BLOCK):
                    l = l0 + k
                    if not (math.isfinite(bend_l[i, k]) and math.isfinite(rot_l[i, k])):
                        bad_branch[l] = i      # the loop runs downwards: ends at the lowest index
                        bad_step[l] = step
                        stopped = True
            if stopped:
                break
            if step % every == 0:
                r = out_row + rows
                for k in range(BLOCK):
                    l = l0 + k
                    for i in range(n):
                        out_bend[l, r, i] = bend_l[i, k]
                        out_rot[l, r, i] = rot_l[i, k]
                rows += 1
        for i in range(n):
            for k in range(BLOCK):
                bend[i, l0 + k] = bend_l[i, k]; rot[i, l0 + k] = rot_l[i, k]
                bend_vel[i, l0 + k] = vb_l[i, k]; rot_vel[i, l0 + k] = vr_l[i, k]
        for k in range(BLOCK):
            rows_written[l0 + k] = rows
