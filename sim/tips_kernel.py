"""Branch tips over many samples, compiled with numba (model.md section 3).

`kinematics.pose` computes every frame of every sample with numpy, a depth level at a
time; for the long runs that `simplify` and `compare` measure (tens of thousands of
branches, hundreds of samples) its batched 3×3 products dominate their cost. This
kernel walks the branches parent before child for each sample and keeps only what a
tip needs (the branch frame and the tip), with the same formulas:

    S_i = R_parent Q_i Rot(u_i, θ_i),  R_i = S_i Rz(ψ_i),
    base_i = tip_parent + R_parent o_i,  tip_i = base_i + L_i R_i e_z

(Q_i = Rz(φ_i) Ry(α_i); Rot as `kinematics.swing_rotation`; R_i only through R_i e_z = S_i e_z
and R_parent Q_i = S_parent (Rz(ψ_parent) Q_i), so only swing frames are kept), with sin and cos from
`trig.sincos1` as in the stepping kernels. No fastmath: the tips agree with `pose`
(numpy's sin and cos) to rounding (tests/test_sim_tips_kernel.py).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from plantlod.lsys.tree import Tree

from . import jit  # noqa: F401  (trig.sincos registered with numba)
from .kinematics import float_angles, rest_rotations, rot_z
from .trig import sincos1


@numba.njit(cache=True, error_model="numpy", parallel=True)
def _tips(parent, rest, offset, length, bend, rot, column, which, out):
    """rest (n, 3, 3): Rz(ψ_parent) Q_i (Q_i alone for a root); offset (n, 3): Rz(ψ_parent) o_i;
    column (n,): branch i's column in bend and rot (K, B).
    A branch frame R_i = S_i Rz(ψ_i) enters its tip only as R_i e_z = S_i e_z and its
    children only as R_i Q_c = S_i (Rz(ψ_i) Q_c), so the swing frames S are all it keeps."""
    samples = bend.shape[0]
    n = parent.shape[0]
    for k in numba.prange(samples):
        swing = np.empty((n, 3, 3))
        tip = np.empty((n, 3))
        local = np.empty((3, 3))
        rmat = np.empty((3, 3))
        for i in range(n):
            b, r = np.float64(bend[k, column[i]]), np.float64(rot[k, column[i]])   # (float32 widened)
            theta = math.sqrt(b * b + r * r)
            ux = 0.0
            uy = 0.0
            if theta != 0.0:
                ux = -r / theta
                uy = b / theta
            s, c = sincos1(theta)
            one_c = 1.0 - c
            rmat[0, 0] = c + one_c * ux * ux
            rmat[0, 1] = one_c * ux * uy
            rmat[0, 2] = s * uy
            rmat[1, 0] = one_c * ux * uy
            rmat[1, 1] = c + one_c * uy * uy
            rmat[1, 2] = -s * ux
            rmat[2, 0] = -s * uy
            rmat[2, 1] = s * ux
            rmat[2, 2] = c
            for a in range(3):                      # local = (Rz(psi_parent) Q_i) Rot
                for bb in range(3):
                    local[a, bb] = rest[i, a, 0] * rmat[0, bb] + rest[i, a, 1] * rmat[1, bb] \
                        + rest[i, a, 2] * rmat[2, bb]
            p = parent[i]
            if p < 0:
                for a in range(3):
                    for bb in range(3):
                        swing[i, a, bb] = local[a, bb]
                    tip[i, a] = offset[i, a]
            else:
                for a in range(3):
                    for bb in range(3):
                        swing[i, a, bb] = swing[p, a, 0] * local[0, bb] + swing[p, a, 1] * local[1, bb] \
                            + swing[p, a, 2] * local[2, bb]
                    tip[i, a] = tip[p, a] + (swing[p, a, 0] * offset[i, 0] + swing[p, a, 1] * offset[i, 1]
                                             + swing[p, a, 2] * offset[i, 2])
            for a in range(3):
                tip[i, a] += length[i] * swing[i, a, 2]
        for j in range(which.shape[0]):
            for a in range(3):
                out[k, j, a] = tip[which[j], a]


def tips(tree: Tree, bend: np.ndarray, rot: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Tips (K, len(which), 3) m of branches ``which`` for angles bend, rot (K, B) rad
    (float32 or float64, read as they are: the kernel widens each angle, exactly, so
    float32 runs give the tips of their float64 copies without copying them)."""
    bend = np.ascontiguousarray(float_angles(bend))
    rot = np.ascontiguousarray(float_angles(rot))
    which = np.ascontiguousarray(which, dtype=np.int64)
    b = tree.n_branches
    if bend.ndim != 2 or bend.shape != rot.shape or bend.shape[1] != b:
        raise ValueError(f"bend and rot must both have shape (K, {b})")
    rest, twist_angle = rest_rotations(tree)                    # Q = Rz(phi) Ry(alpha) [Rz(beta)]
    out = np.empty((bend.shape[0], len(which), 3))
    if b == 0 or bend.shape[0] == 0:
        return out
    parent = np.asarray(tree.parent, dtype=np.int64)
    offset = np.asarray(tree.offset, dtype=np.float64).reshape(-1, 3)
    length = np.asarray(tree.length, dtype=np.float64)
    keep = ancestors_of(parent, which)          # (the kernel reads their columns in place)
    if len(keep) < b:           # only the branches on the way to ``which``: the same tips
        new_index = np.full(b, -1, dtype=np.int64)
        new_index[keep] = np.arange(len(keep))
        up = parent[keep]
        parent = np.where(up >= 0, new_index[np.maximum(up, 0)], -1)
        rest, twist_angle = rest[keep], twist_angle[keep]
        offset, length = offset[keep], length[keep]
        which = new_index[which]
    # each branch's rest rotation and offset seen from its parent's swing frame
    twist = rot_z(twist_angle)                                  # (n, 3, 3) Rz(psi)
    has = parent >= 0
    rest[has] = twist[parent[has]] @ rest[has]
    offset = offset.copy()
    offset[has] = np.einsum("nij,nj->ni", twist[parent[has]], offset[has])
    _tips(parent, np.ascontiguousarray(rest), np.ascontiguousarray(offset),
          np.ascontiguousarray(length), bend, rot, np.ascontiguousarray(keep, dtype=np.int64),
          which, out)
    return out


def ancestors_of(parent: np.ndarray, which: np.ndarray) -> np.ndarray:
    """The branches ``which`` and all their ancestors, ascending (parent (B,) before child)."""
    need = np.zeros(len(parent), dtype=bool)
    need[which] = True
    frontier = np.unique(which)
    while len(frontier):
        up = parent[frontier]
        up = up[up >= 0]
        frontier = np.unique(up[~need[up]])
        need[frontier] = True
    return np.flatnonzero(need)
