"""Linear static theory of the wind model at the rest geometry (model.md section 4).

Under a steady wind V = v V̂ a branch settles where its velocity update is 0:
θb = 1000 k_FA F·S e_x / k_bs and θr = 1000 k_FA F·S e_y / k_rs. For small
angles the frames are the rest frames, and the force splits into a part linear
in v (the leaves: f = s_L A (V·n̂) n̂) and a part in v² (the drag:
C_d v² 2π r L |z × V̂| V̂), each propagated down with k_fp:

    F_i = v F^L_i(V̂) + v² F^D_i(V̂)
    F^L_i = k_fp,i (Σ leaves on i  s_L A_j (n̂_j·V̂) n̂_j + Σ children F^L_c)
    F^D_i = C_d,i 2π r_i L_i |z_i × V̂| V̂ + k_fp,i Σ children F^D_c

This module computes F^L and F^D for a set of wind directions, and the angles
they give. `simplify` matches a level-n tree to the original with it; tests
check it against simulations run to equilibrium.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import rest_pose


@dataclass
class RestFrames:
    """World frames of every branch at rest.

    swing : (B, 3, 3) rest swing frames W_i (columns: the directions a force bends
            and rotates the branch in, and the branch axis before its twist ψ)
    axis  : (B, 3) unit branch axes R_i e_z
    base, tip : (B, 3) m
    frame : (B, 3, 3) branch frames R_i
    """

    swing: np.ndarray
    axis: np.ndarray
    base: np.ndarray
    tip: np.ndarray
    frame: np.ndarray


def rest_frames(tree: Tree) -> RestFrames:
    p = rest_pose(tree)
    return RestFrames(p.swing, p.frame[:, :, 2], p.base, p.tip, p.frame)


def horizontal_directions(count: int) -> np.ndarray:
    """``count`` unit horizontal wind directions at azimuths 0, 360/count, ... deg: (D, 3)."""
    az = np.arange(count) * (2.0 * math.pi / count)
    out = np.stack([np.cos(az), np.sin(az), np.zeros(count)], axis=1)
    out[np.abs(out) < 1e-15] = 0.0
    return out


def tilted_directions(count: int, elevation: float) -> np.ndarray:
    """``count`` azimuths (as `horizontal_directions`) at elevation +e, then at -e rad: (2 count, 3).

    A wind tilted by e out of the horizontal is what a group sees when the
    branches below it have turned it by e: all forces depend only on
    orientations, so turning a subtree by a rotation is the same as turning
    the wind by its inverse.
    """
    flat = horizontal_directions(count)
    out = []
    for e in (elevation, -elevation):
        d = flat * math.cos(e)
        d[:, 2] = math.sin(e)
        out.append(d)
    return np.concatenate(out)


def fit_directions(count: int, tilted: int, elevation: float) -> np.ndarray:
    """``count`` horizontal directions, then ``tilted`` azimuths at ±``elevation`` rad: (D, 3)."""
    if tilted == 0 or elevation == 0:
        return horizontal_directions(count)
    return np.concatenate([horizontal_directions(count), tilted_directions(tilted, elevation)])


def own_leaf_forces(tree: Tree, frames: RestFrames, directions: np.ndarray,
                    area: np.ndarray | None = None) -> np.ndarray:
    """Σ over each branch's leaves of s_L A (n̂·V̂) n̂ at v = 1: (D, B, 3) N per (m/s).

    area : (F,) leaf areas to use instead of the tree's (m^2)
    """
    d = directions.shape[0]
    out = np.zeros((d, tree.n_branches, 3))
    if tree.n_leaves == 0:
        return out
    area = tree.leaf_area if area is None else area
    normals = np.einsum("fij,fj->fi", frames.frame[tree.leaf_branch], tree.leaf_normal)  # (F, 3)
    along = directions @ normals.T                                           # (D, F)
    f = (tree.leaf_force_scale * area)[None, :, None] * along[:, :, None] * normals[None]
    for k in range(d):
        np.add.at(out[k], tree.leaf_branch, f[k])
    return out


def own_drag_shape(frames: RestFrames, directions: np.ndarray) -> np.ndarray:
    """|z_i × V̂| V̂ for every direction and branch: (D, B, 3), dimensionless.

    A branch's drag at speed v is C_d 2π r L v² times this.
    """
    sin = np.linalg.norm(np.cross(frames.axis[None, :, :], directions[:, None, :]), axis=-1)
    return sin[:, :, None] * directions[:, None, :]


def drag_area(tree: Tree) -> np.ndarray:
    """C_d 2π r L per branch: (B,) m^2."""
    return tree.drag_coefficient * 2.0 * math.pi * tree.radius * tree.length


def propagate(tree: Tree, own: np.ndarray, through_own: bool) -> np.ndarray:
    """Total forces from each branch's own forces: (D, B, 3).

    through_own True (leaves):  F_i = k_fp,i (own_i + Σ children F_c)
    through_own False (drag):   F_i = own_i + k_fp,i Σ children F_c
    """
    from .tree_sums import TreeSums

    return TreeSums(tree.parent).up(tree.force_propagated, own, through_own)


@dataclass
class StaticParts:
    """The two parts of every branch's total force at unit wind speed.

    leaf : (D, B, 3) F^L, N per (m/s)  (force at v: v F^L)
    drag : (D, B, 3) F^D, N per (m/s)^2 (force at v: v² F^D)
    """

    leaf: np.ndarray
    drag: np.ndarray


def static_parts(tree: Tree, directions: np.ndarray, frames: RestFrames | None = None) -> StaticParts:
    frames = rest_frames(tree) if frames is None else frames
    leaf = propagate(tree, own_leaf_forces(tree, frames, directions), through_own=True)
    drag_own = drag_area(tree)[None, :, None] * own_drag_shape(frames, directions)
    drag = propagate(tree, drag_own, through_own=False)
    return StaticParts(leaf, drag)


def angle_gains(tree: Tree, frames: RestFrames) -> np.ndarray:
    """Rows mapping a force to the static (θb, θr) of each branch: (B, 2, 3) rad per N.

    Row 0: 1000 k_FA / k_bs W_i e_x; row 1: 1000 k_FA / k_rs W_i e_y; for a level whose
    branches carry the gain matrix G of model.md 5 (`Tree.force_gain`), row 0 is
    1000 k_FA / k_bs W_i (G_bx, G_by, G_bz)ᵀ and row 1 likewise with G_r.
    """
    scale = 1000.0 * tree.force_absorbed
    out = np.empty((tree.n_branches, 2, 3))
    if tree.force_gain is None:
        out[:, 0] = (scale / tree.bend_strength)[:, None] * frames.swing[:, :, 0]
        out[:, 1] = (scale / tree.rotation_strength)[:, None] * frames.swing[:, :, 1]
        return out
    gain = np.asarray(tree.force_gain, dtype=np.float64).reshape(-1, 2, 3)
    rows = np.einsum("bij,bkj->bik", gain, frames.swing)                 # G Wᵀ: (B, 2, 3)
    out[:, 0] = (scale / tree.bend_strength)[:, None] * rows[:, 0]
    out[:, 1] = (scale / tree.rotation_strength)[:, None] * rows[:, 1]
    return out


def static_angles(tree: Tree, force: np.ndarray, frames: RestFrames | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Static (θb, θr) of every branch under total forces (D, B, 3): two (D, B) arrays, rad."""
    frames = rest_frames(tree) if frames is None else frames
    ang = np.einsum("bij,dbj->dbi", angle_gains(tree, frames), force)
    return ang[..., 0], ang[..., 1]


def static_angles_at(tree: Tree, parts: StaticParts, speed: float,
                     frames: RestFrames | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Static (θb, θr) (D, B) at wind speed ``speed`` m/s in the parts' directions."""
    return static_angles(tree, speed * parts.leaf + speed * speed * parts.drag, frames)


def wind_forces(tree: Tree, directions: np.ndarray, speeds, frames: RestFrames | None = None
                ) -> np.ndarray:
    """(W, B, 3) N: every branch's total force at rest (world axes) in W winds, each its own
    unit direction (W, 3) and speed (W,) m/s: v F^L + v² F^D (model.md 4, `static_parts`)."""
    frames = rest_frames(tree) if frames is None else frames
    parts = static_parts(tree, np.asarray(directions, dtype=np.float64), frames)
    v = np.asarray(speeds, dtype=np.float64)[:, None, None]
    return v * parts.leaf + v * v * parts.drag


def rotation_parts(bend: np.ndarray, rot: np.ndarray, frames: RestFrames) -> np.ndarray:
    """(..., B, 2, 3) each branch's rotation vector in world axes split into its bend part
    θb y and its rotation part -θr x, with (x, y) its rest swing frame's axes: model.md 3's
    ω = (-θr, θb, 0) in that frame is their sum. bend, rot (..., B) rad."""
    return np.stack([bend[..., None] * frames.swing[:, :, 1],
                     -rot[..., None] * frames.swing[:, :, 0]], axis=-2)


def turned_most(tree: Tree, directions: np.ndarray, speeds, frames: RestFrames | None = None
                ) -> np.ndarray:
    """(W,) the largest static turn, rad, of any branch's axis from its rest direction in each
    wind (unit world direction (W, 3), speed (W,) m/s): |(Σ_j ω_j) × a_i|, the sum over branch
    i and its ancestors, ω_j = θb_j y_j - θr_j x_j each one's own static rotation (linear
    statics, model.md 4) with (x_j, y_j) its rest swing frame's axes, and a_i branch i's rest
    axis (a turn about the axis itself moves nothing). A chain of many branches turns its top
    far more than any one branch or group turns."""
    from .tree_sums import TreeSums

    frames = rest_frames(tree) if frames is None else frames
    bend, rot = static_angles(tree, wind_forces(tree, directions, speeds, frames), frames)  # (W, B)
    omega = rotation_parts(bend, rot, frames).sum(axis=-2)                            # (W, B, 3)
    omega = TreeSums(tree.parent).down(np.ones(tree.n_branches), omega)    # + its ancestors'
    axis = frames.swing[:, :, 2]                                                      # (B, 3)
    return np.linalg.norm(np.cross(omega, axis[None]), axis=2).max(axis=1, initial=0.0)
