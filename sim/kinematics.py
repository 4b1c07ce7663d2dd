"""Branch positions and frames for given bend and rotation angles (model.md section 3).

Plain numpy, vectorised over branches of one depth level at a time (a branch
needs its parent's frame and tip), and over any leading sample axes: ``bend``
and ``rot`` of shape (..., B) give arrays of shape (..., B, 3) and
(..., B, 3, 3). Used for OBJ export, tip errors and rest heights; the time
stepping itself lives in `plantlod.sim.kernel`.

For every branch i, in parent-before-child order::

    S_i    = R_parent Rz(phi_i) Ry(alpha_i) Rot(u_i, theta_i)   swing frame
    R_i    = S_i Rz(psi_i)                                      branch frame
    base_i = tip_parent + R_parent o_i      (o_i from the origin for a root)
    tip_i  = base_i + L_i R_i e_z

with theta_i = sqrt(bend_i^2 + rot_i^2), u_i = (-rot_i, bend_i, 0) / theta_i and
Rot = I where theta_i = 0. Angles are radians, lengths metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantlod.lsys.tree import Tree
from .constants import REST_HEIGHT_ROUNDING


def float_angles(angles) -> np.ndarray:
    """``angles`` as an array of float32 or float64, kept as they are (runs kept as float32 are
    read in place; a float32 angle widens exactly where it meets a float64), else float64."""
    angles = np.asarray(angles)
    return angles if angles.dtype in (np.float32, np.float64) else angles.astype(np.float64)


def rot_z(angle: np.ndarray) -> np.ndarray:
    """Rotations about z by ``angle`` (radians), shape (..., 3, 3)."""
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 1] = c, -s
    out[..., 1, 0], out[..., 1, 1] = s, c
    out[..., 2, 2] = 1.0
    return out


def rot_y(angle: np.ndarray) -> np.ndarray:
    """Rotations about y by ``angle`` (radians), shape (..., 3, 3)."""
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 2] = c, s
    out[..., 1, 1] = 1.0
    out[..., 2, 0], out[..., 2, 2] = -s, c
    return out


def swing_rotation(bend: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Rot(u, theta) of model.md section 3 for angles of shape (...,): (..., 3, 3).

    theta = sqrt(bend^2 + rot^2), u = (-rot, bend, 0) / theta (Rodrigues' formula
    written out for an axis in the xy-plane); the identity where theta = 0.
    """
    bend = np.asarray(bend, dtype=np.float64)
    rot = np.asarray(rot, dtype=np.float64)
    theta = np.sqrt(bend * bend + rot * rot)     # as the kernel computes it
    moving = theta != 0
    safe = np.where(moving, theta, 1.0)
    ux = np.where(moving, -rot / safe, 0.0)
    uy = np.where(moving, bend / safe, 0.0)
    c, s = np.cos(theta), np.sin(theta)
    one_c = 1.0 - c
    out = np.empty(theta.shape + (3, 3))
    out[..., 0, 0] = c + one_c * ux * ux
    out[..., 0, 1] = one_c * ux * uy
    out[..., 0, 2] = s * uy
    out[..., 1, 0] = one_c * ux * uy
    out[..., 1, 1] = c + one_c * uy * uy
    out[..., 1, 2] = -s * ux
    out[..., 2, 0] = -s * uy
    out[..., 2, 1] = s * ux
    out[..., 2, 2] = c
    return out


def rest_swing_rotation(euler: np.ndarray) -> np.ndarray:
    """Rz(phi) Ry(alpha) for rest Euler angles (B, 3) = (phi, alpha, psi): (B, 3, 3).

    The part of a branch's swing frame relative to its parent frame that does
    not move; the kernel precomputes it once per run.
    """
    euler = np.asarray(euler, dtype=np.float64).reshape(-1, 3)
    return rot_z(euler[:, 0]) @ rot_y(euler[:, 1])


def rest_rotations(tree: Tree) -> tuple[np.ndarray, np.ndarray]:
    """(rest (B, 3, 3), twist (B,)): each branch's rest swing rotation relative to its parent
    frame, Rz(phi) Ry(alpha) Rz(beta), and the twist psi - beta (radians) that turns it into
    the branch frame, R_i = S_i Rz(psi - beta). beta is the branch's swing roll
    (`Tree.swing_roll`, 0 for every branch of a tree read from an ordinary L-system, where
    this is model.md 3's Rz(phi) Ry(alpha) and psi)."""
    euler = np.asarray(tree.euler, dtype=np.float64).reshape(-1, 3)
    rest = rest_swing_rotation(euler)
    if tree.swing_roll is None:
        return rest, euler[:, 2].copy()
    roll = np.asarray(tree.swing_roll, dtype=np.float64)
    return rest @ rot_z(roll), euler[:, 2] - roll


def depth_levels(parent: np.ndarray) -> list[np.ndarray]:
    """Branch indices grouped by depth (roots first); each level ascending, (n_d,) int64."""
    parent = np.asarray(parent, dtype=np.int64)
    depth = np.zeros(len(parent), dtype=np.int64)
    for i, p in enumerate(parent.tolist()):   # parent-before-child: one pass
        if p >= 0:
            depth[i] = depth[p] + 1
    if len(depth) == 0:
        return []
    return [np.flatnonzero(depth == d) for d in range(int(depth.max()) + 1)]


@dataclass(frozen=True)
class Pose:
    """Positions (m) and frames of every branch for one or more samples.

    base, tip : (..., B, 3) float64, world frame
    frame     : (..., B, 3, 3) branch frames R_i (columns: the branch's x, y, z axes)
    swing     : (..., B, 3, 3) swing frames S_i (columns x, y: the directions in
                which a force bends and rotates the branch)
    """

    base: np.ndarray
    tip: np.ndarray
    frame: np.ndarray
    swing: np.ndarray

    @property
    def R(self) -> np.ndarray:
        """The branch frames (same array as ``frame``)."""
        return self.frame

    @property
    def S(self) -> np.ndarray:
        """The swing frames (same array as ``swing``)."""
        return self.swing


def pose(tree: Tree, bend: np.ndarray, rot: np.ndarray) -> Pose:
    """The pose of ``tree`` at bend and rotation angles of shape (..., B), radians.

    Memory is about 200 bytes per branch and sample; split long runs into
    chunks of samples.
    """
    bend = np.asarray(bend, dtype=np.float64)
    rot = np.asarray(rot, dtype=np.float64)
    b = tree.n_branches
    if bend.shape != rot.shape or bend.shape[-1:] != (b,):
        raise ValueError(f"bend and rot must both have shape (..., {b})")
    lead = bend.shape[:-1]
    rest, twist_angle = rest_rotations(tree)
    local_swing = rest @ swing_rotation(bend, rot)                              # (..., B, 3, 3)
    twist = rot_z(twist_angle)                                                  # (B, 3, 3)
    offset = np.asarray(tree.offset, dtype=np.float64).reshape(-1, 3)
    length = np.asarray(tree.length, dtype=np.float64)
    parent = np.asarray(tree.parent, dtype=np.int64)

    swing = np.empty(lead + (b, 3, 3))
    frame = np.empty(lead + (b, 3, 3))
    base = np.empty(lead + (b, 3))
    tip = np.empty(lead + (b, 3))
    for idx in depth_levels(parent):
        roots = idx[parent[idx] < 0]
        kids = idx[parent[idx] >= 0]
        if len(roots):
            swing[..., roots, :, :] = local_swing[..., roots, :, :]
            base[..., roots, :] = offset[roots]
        if len(kids):
            p = parent[kids]
            rp = frame[..., p, :, :]
            swing[..., kids, :, :] = rp @ local_swing[..., kids, :, :]
            base[..., kids, :] = tip[..., p, :] + (rp @ offset[kids][..., None])[..., 0]
        frame[..., idx, :, :] = swing[..., idx, :, :] @ twist[idx]
        tip[..., idx, :] = base[..., idx, :] + length[idx, None] * frame[..., idx, :, :][..., 2]
    return Pose(base=base, tip=tip, frame=frame, swing=swing)


def rest_pose(tree: Tree) -> Pose:
    """The pose with every angle 0."""
    zeros = np.zeros(tree.n_branches)
    return pose(tree, zeros, zeros)


def rest_height(tree: Tree) -> float:
    """The largest tip z (m) at rest; 0.0 for a tree without branches, and for one whose
    highest tip is within rounding (REST_HEIGHT_ROUNDING of its largest coordinate) of
    z = 0: a tree lying flat (`&(90)`) has tips at z = 3e-17 m from cos(π/2), which no
    height can stand for (model.md 6 states tip errors as fractions of it)."""
    if tree.n_branches == 0:
        return 0.0
    tips = rest_pose(tree).tip
    height = float(tips[:, 2].max())
    if abs(height) <= REST_HEIGHT_ROUNDING * float(np.abs(tips).max()):
        return 0.0
    return height
