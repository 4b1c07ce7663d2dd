"""The lanes kernel: one tree structure stepped under W winds (or W parameter sets) at once.

The arithmetic of one branch and one step is the single-run kernel's
(`plantlod.sim.kernel`, model.md sections 3 and 4): the same `branch_math` and
`trig` functions, called here on `vec4.Vec4` values, 4 lanes (4 runs) in one
AVX register. Every Vec4 operation is one IEEE operation per lane and nothing
fuses a multiply and an add, so each lane gives the single run's bits.

Memory layout (docs/engine.md)::

    shared per branch      parent (B,)  rest (B, 9)  cos_psi, sin_psi (B,)  gain (B, 6)
    parameters             (B,) shared (broadcast), or (B, W) one value per lane
    state                  (B, W): lane index last; a block copies its 4 lanes to (B, 4)
                           arrays of its own while it runs, 4 lanes loaded as one Vec4
    scratch per block      frames (B, 9, 4), swing axes (B, 9, 4), forces (B, 3, 4)
    output                 (W, T, B): one run per lane, as the single kernel writes it

Work is split into fixed blocks of 4 lanes and the blocks are distributed over
threads with numba's ``prange``. A lane's arithmetic never depends on the other
lanes, on its block or on the thread that runs it, so the output is the same bit
for bit for any thread count. No branch depends on a lane's values: the parent
index, the leaf ranges and "has a gain matrix" are the same in every lane, and the
theta = 0 case of the rotation and the zero wind are selects. Compiled without
fastmath, with numpy's error model (docs/engine.md says what the generated code shows).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange
from numba.extending import overload

from . import jit  # noqa: F401  (branch_math and trig registered with numba)
from .branch_math import advance_angle, drag_magnitude, gained_forces, swing, times_rest, twist
from .ops import select
from .trig import INVPIO2, TINY, _kernels, sincos
from .vec4 import any_lane, isfinite4, lane, load, splat, store, vec4

@numba.njit(inline="always")
def sincos4(x):
    """`trig.sincos` of 4 angles, the same bits, faster when every lane has n = 0 (below
    about pi/4): the reduction is then the identity and is skipped (`trig.sincos1`)."""
    ax = abs(x)
    if any_lane(ax * INVPIO2 + 0.5 >= 1.0):
        return sincos(x)
    ks, kc = _kernels(ax, 0.0)
    return select(ax < TINY, x, select(x < 0.0, -ks, ks)), kc


# Lanes per block: one Vec4. `run_lanes` pads the lane count to a multiple of it.
BLOCK = 4


def param(a, i, l0):
    """Lanes l0 .. l0 + 3 of a parameter: a[i] broadcast (1-D, shared), or a[i, l0:l0 + 4]."""
    return a[i] if a.ndim == 1 else a[i, l0:l0 + BLOCK]


@overload(param)
def _param_overload(a, i, l0):
    if a.ndim == 1:
        return lambda a, i, l0: splat(a[i])
    return lambda a, i, l0: load(a, (i, l0))


@numba.njit(cache=True, error_model="numpy", parallel=True, nogil=True)
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
    W is a multiple of BLOCK; every 2-D array is C-contiguous.
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
        swing_axes = np.empty((n, 9, BLOCK))      # S_i e_x, S_i e_y, S_i e_z
        acc = np.empty((n, 3, BLOCK))
        dragf = np.empty((n, 3, BLOCK))
        # the block's state in arrays of its own: in the shared (B, W) planes two blocks'
        # lanes share a cache line, and two cores writing it would take turns (false sharing)
        bend_l = np.empty((n, BLOCK))
        rot_l = np.empty((n, BLOCK))
        vb_l = np.empty((n, BLOCK))
        vr_l = np.empty((n, BLOCK))
        for i in range(n):
            for k in range(BLOCK):
                bend_l[i, k] = bend[i, l0 + k]
                rot_l[i, k] = rot[i, l0 + k]
                vb_l[i, k] = bend_vel[i, l0 + k]
                vr_l[i, k] = rot_vel[i, l0 + k]
        rows = 0
        stopped = False
        for j in range(n_steps):
            wj = 0 if steady else j
            vx = vec4(wind[l0, wj, 0], wind[l0 + 1, wj, 0], wind[l0 + 2, wj, 0], wind[l0 + 3, wj, 0])
            vy = vec4(wind[l0, wj, 1], wind[l0 + 1, wj, 1], wind[l0 + 2, wj, 1], wind[l0 + 3, wj, 1])
            vz = vec4(wind[l0, wj, 2], wind[l0 + 1, wj, 2], wind[l0 + 2, wj, 2], wind[l0 + 3, wj, 2])
            speed = math.sqrt(vx * vx + vy * vy + vz * vz)
            blowing = speed > 0.0
            hx = select(blowing, vx / speed, 0.0)      # V^ = 0 where there is no wind
            hy = select(blowing, vy / speed, 0.0)
            hz = select(blowing, vz / speed, 0.0)
            speed2 = speed * speed

            # ---- pass 1: frames, leaf forces, drag (parent before child) ----
            for i in range(n):
                p = parent[i]
                if p >= 0:        # the same in every lane
                    m = times_rest((load(frame, (p, 0, 0)), load(frame, (p, 1, 0)),
                                    load(frame, (p, 2, 0)), load(frame, (p, 3, 0)),
                                    load(frame, (p, 4, 0)), load(frame, (p, 5, 0)),
                                    load(frame, (p, 6, 0)), load(frame, (p, 7, 0)),
                                    load(frame, (p, 8, 0))),
                                   (rest[i, 0], rest[i, 1], rest[i, 2], rest[i, 3], rest[i, 4],
                                    rest[i, 5], rest[i, 6], rest[i, 7], rest[i, 8]))
                else:
                    m = (splat(rest[i, 0]), splat(rest[i, 1]), splat(rest[i, 2]),
                         splat(rest[i, 3]), splat(rest[i, 4]), splat(rest[i, 5]),
                         splat(rest[i, 6]), splat(rest[i, 7]), splat(rest[i, 8]))
                tb = load(bend_l, (i, 0))
                tr = load(rot_l, (i, 0))
                theta = math.sqrt(tb * tb + tr * tr)
                s, c = sincos4(theta)
                sw = swing(m, tb, tr, theta, c, s)
                store(swing_axes, (i, 0, 0), sw[0]); store(swing_axes, (i, 1, 0), sw[3])
                store(swing_axes, (i, 2, 0), sw[6]); store(swing_axes, (i, 3, 0), sw[1])
                store(swing_axes, (i, 4, 0), sw[4]); store(swing_axes, (i, 5, 0), sw[7])
                if gained:                              # the z axis is read only with G
                    store(swing_axes, (i, 6, 0), sw[2]); store(swing_axes, (i, 7, 0), sw[5])
                    store(swing_axes, (i, 8, 0), sw[8])
                f = twist(sw, cos_psi[i], sin_psi[i])
                store(frame, (i, 0, 0), f[0]); store(frame, (i, 1, 0), f[1])
                store(frame, (i, 2, 0), f[2]); store(frame, (i, 3, 0), f[3])
                store(frame, (i, 4, 0), f[4]); store(frame, (i, 5, 0), f[5])
                store(frame, (i, 6, 0), f[6]); store(frame, (i, 7, 0), f[7])
                store(frame, (i, 8, 0), f[8])

                lx = splat(0.0)
                ly = splat(0.0)
                lz = splat(0.0)
                for leaf in range(leaf_start[i], leaf_start[i + 1]):
                    nx0 = leaf_normal[leaf, 0]
                    ny0 = leaf_normal[leaf, 1]
                    nz0 = leaf_normal[leaf, 2]
                    nx = f[0] * nx0 + f[1] * ny0 + f[2] * nz0
                    ny = f[3] * nx0 + f[4] * ny0 + f[5] * nz0
                    nz = f[6] * nx0 + f[7] * ny0 + f[8] * nz0
                    g = param(leaf_scale, leaf, l0) * (vx * nx + vy * ny + vz * nz)
                    lx += g * nx
                    ly += g * ny
                    lz += g * nz
                store(acc, (i, 0, 0), lx)
                store(acc, (i, 1, 0), ly)
                store(acc, (i, 2, 0), lz)

                g = drag_magnitude(sw, hx, hy, hz, param(drag, i, l0), speed2)
                store(dragf, (i, 0, 0), g * hx)
                store(dragf, (i, 1, 0), g * hy)
                store(dragf, (i, 2, 0), g * hz)

            # ---- pass 2: total forces (child before parent) and the update ----
            step = first_step + j
            for i in range(n - 1, -1, -1):
                p = parent[i]
                kfp = param(propagated, i, l0)
                fx = load(dragf, (i, 0, 0)) + kfp * load(acc, (i, 0, 0))
                fy = load(dragf, (i, 1, 0)) + kfp * load(acc, (i, 1, 0))
                fz = load(dragf, (i, 2, 0)) + kfp * load(acc, (i, 2, 0))
                if p >= 0:
                    store(acc, (p, 0, 0), load(acc, (p, 0, 0)) + fx)
                    store(acc, (p, 1, 0), load(acc, (p, 1, 0)) + fy)
                    store(acc, (p, 2, 0), load(acc, (p, 2, 0)) + fz)
                kfa = param(absorbed, i, l0)
                fb = (fx * load(swing_axes, (i, 0, 0)) + fy * load(swing_axes, (i, 1, 0))
                      + fz * load(swing_axes, (i, 2, 0)))
                fr = (fx * load(swing_axes, (i, 3, 0)) + fy * load(swing_axes, (i, 4, 0))
                      + fz * load(swing_axes, (i, 5, 0)))
                if gained:
                    fa = (fx * load(swing_axes, (i, 6, 0)) + fy * load(swing_axes, (i, 7, 0))
                          + fz * load(swing_axes, (i, 8, 0)))
                    fb, fr = gained_forces(gain[i, 0], gain[i, 1], gain[i, 2], gain[i, 3],
                                           gain[i, 4], gain[i, 5], fb, fr, fa)
                tb, vb = advance_angle(load(bend_l, (i, 0)), load(vb_l, (i, 0)), kfa, fb,
                                       param(bend_k, i, l0), param(damp_b, i, l0), dt)
                tr, vr = advance_angle(load(rot_l, (i, 0)), load(vr_l, (i, 0)), kfa, fr,
                                       param(rot_k, i, l0), param(damp_r, i, l0), dt)
                store(vb_l, (i, 0), vb)
                store(vr_l, (i, 0), vr)
                store(bend_l, (i, 0), tb)
                store(rot_l, (i, 0), tr)
                finite = isfinite4(tb) & isfinite4(tr)
                if any_lane(~finite):
                    for k in range(BLOCK):
                        if not lane(finite, k):
                            bad_branch[l0 + k] = i     # the loop runs downwards: ends at the lowest index
                            bad_step[l0 + k] = step
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
                bend[i, l0 + k] = bend_l[i, k]
                rot[i, l0 + k] = rot_l[i, k]
                bend_vel[i, l0 + k] = vb_l[i, k]
                rot_vel[i, l0 + k] = vr_l[i, k]
        for k in range(BLOCK):
            rows_written[l0 + k] = rows
