"""Posed trees as triangle meshes and Wavefront OBJ text (docs/compare.md, "OBJ files").

Every branch becomes an open tapered cylinder (a tube of `OBJ_SIDES` sides),
every leaf a square of area A (two triangles) facing along its normal. Several
trees are placed side by side along world x, as in the thesis' figure 4
(original, level 1, level 2 at one time). Positions are metres, world z up.

Mesh layout of one tree (``tree_mesh``), which tests and other tools may rely on:

- branch i owns vertices ``2 s i .. 2 s i + 2s - 1`` (s = sides): first its
  base ring, then its top ring; ring vertex j lies at
  ``centre + r (cos(2πj/s) x_i + sin(2πj/s) y_i)`` with x_i, y_i the first two
  columns of the branch frame R_i, centre the branch's base (radius r_i) or tip
  (radius `top_radius`); faces ``2 s i .. 2 s i + 2s - 1`` are its sides,
  wound so that their normals point outward;
- then leaf f owns the 4 vertices ``4 f .. 4 f + 3`` (after all branches) and
  two faces: a square of side sqrt(A) with one edge centred on its branch's
  tip, reaching out along the branch axis (projected into the leaf's plane)
  and wound so that its normal is the posed leaf normal R_i n_f
  (corners in `_leaf_quads`). The model gives a leaf no position along its
  branch; it is read after the branch is drawn, so it is drawn at the tip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import Pose, pose

from .constants import OBJ_DIGITS, OBJ_SIDES
from .constants import OBJ_LAYOUT_MARGIN
from .constants import OBJ_TIP_TAPER
_PARALLEL_TOL = 1e-12     # leaf normal along the branch axis: choose another in-plane direction


@dataclass
class Mesh:
    """A named triangle mesh: vertices (V, 3) float64 m, faces (T, 3) int64 (0-based)."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray

    def moved(self, dx: float) -> "Mesh":
        """The same mesh translated by dx along world x."""
        return Mesh(self.name, self.vertices + np.array([dx, 0.0, 0.0]), self.faces)


def top_radius(tree: Tree) -> np.ndarray:
    """Radius at the top of every branch, (B,) m.

    The largest radius of the branch's children, but never more than its own
    radius; a branch without children narrows to OBJ_TIP_TAPER times its radius.
    """
    radius = np.asarray(tree.radius, dtype=np.float64)
    top = OBJ_TIP_TAPER * radius
    widest_child = np.full(len(radius), -np.inf)
    parent = np.asarray(tree.parent, dtype=np.int64)
    kids = parent >= 0
    np.maximum.at(widest_child, parent[kids], radius[kids])
    has_kids = np.isfinite(widest_child)
    top[has_kids] = np.minimum(radius[has_kids], widest_child[has_kids])
    return top


def tree_mesh(tree: Tree, bend: np.ndarray, rot: np.ndarray, name: str = "tree",
              sides: int = OBJ_SIDES) -> Mesh:
    """The mesh of ``tree`` posed at bend and rotation angles (B,) rad (layout: module docstring)."""
    posed = pose(tree, np.asarray(bend, np.float64), np.asarray(rot, np.float64))
    tubes_v, tubes_f = _branch_tubes(tree, posed, sides)
    leaves_v, leaves_f = _leaf_quads(tree, posed)
    vertices = np.concatenate([tubes_v, leaves_v])
    faces = np.concatenate([tubes_f, leaves_f + len(tubes_v)])
    return Mesh(name, vertices, faces)


def _branch_tubes(tree: Tree, posed: Pose, sides: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (2 s B, 3) and faces (2 s B, 3) of every branch's tube."""
    b = tree.n_branches
    angle = 2.0 * math.pi * np.arange(sides) / sides
    c, s = np.cos(angle), np.sin(angle)
    x_axis, y_axis = posed.frame[:, :, 0], posed.frame[:, :, 1]          # (B, 3)
    around = c[None, :, None] * x_axis[:, None, :] + s[None, :, None] * y_axis[:, None, :]  # (B, s, 3)
    base_ring = posed.base[:, None, :] + np.asarray(tree.radius)[:, None, None] * around
    top_ring = posed.tip[:, None, :] + top_radius(tree)[:, None, None] * around
    vertices = np.stack([base_ring, top_ring], axis=1).reshape(2 * sides * b, 3)

    j = np.arange(sides)
    nxt = (j + 1) % sides
    first = np.arange(b)[:, None] * 2 * sides                               # (B, 1)
    b0, b1 = first + j, first + nxt                                         # base ring
    t0, t1 = first + sides + j, first + sides + nxt                         # top ring
    faces = np.stack([np.stack([b0, b1, t1], axis=-1),
                      np.stack([b0, t1, t0], axis=-1)], axis=2)             # (B, s, 2, 3)
    return vertices, faces.reshape(-1, 3).astype(np.int64)


def _leaf_quads(tree: Tree, posed: Pose) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (4 F, 3) and faces (2 F, 3) of every leaf's square.

    With c the tip of the leaf's branch, n its posed unit normal, u the branch
    axis projected into the leaf plane (unit), v = n x u and side d = sqrt(A),
    h = d / 2, the corners are c - h v, c + h v, c + d u + h v, c + d u - h v.
    """
    f = tree.n_leaves
    if f == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    branch = np.asarray(tree.leaf_branch, dtype=np.int64)
    frame = posed.frame[branch]                                              # (F, 3, 3)
    normal = (frame @ np.asarray(tree.leaf_normal, np.float64)[..., None])[..., 0]
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    u = _in_plane(frame[:, :, 2], normal)
    v = np.cross(normal, u)
    side = np.sqrt(np.asarray(tree.leaf_area, dtype=np.float64))[:, None]
    c = posed.tip[branch]
    corners = np.stack([c - side / 2 * v, c + side / 2 * v,
                        c + side * u + side / 2 * v, c + side * u - side / 2 * v], axis=1)
    first = 4 * np.arange(f)[:, None]
    # (0, 2, 1) and (0, 3, 2): (p2 - p0) x (p1 - p0) points along +n
    faces = np.stack([first + [0, 2, 1], first + [0, 3, 2]], axis=1)
    return corners.reshape(4 * f, 3), faces.reshape(-1, 3).astype(np.int64)


def _in_plane(axis: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Unit vectors (F, 3): axis (F, 3) minus its part along normal; e_z or e_x where that vanishes."""
    u = axis - np.sum(axis * normal, axis=1, keepdims=True) * normal
    size = np.linalg.norm(u, axis=1)
    flat = size < _PARALLEL_TOL
    if flat.any():
        fallback = np.where(np.abs(normal[flat, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
        w = fallback - np.sum(fallback * normal[flat], axis=1, keepdims=True) * normal[flat]
        u[flat] = w
        size[flat] = np.linalg.norm(w, axis=1)
    return u / size[:, None]


# --- several trees side by side ------------------------------------------------------

def side_by_side_offsets(rest_meshes: list[Mesh], heights: list[float]) -> list[float]:
    """x translations (m) that put trees next to each other, left to right.

    The first tree stays where it is; each next one is moved so that its rest
    mesh's smallest x lies OBJ_LAYOUT_MARGIN x the tallest rest height to the right
    of the previous tree's largest rest x. Rest extents, so that the trees stay
    put from frame to frame of an animation.
    """
    margin = OBJ_LAYOUT_MARGIN * max([h for h in heights if h > 0], default=1.0)
    offsets: list[float] = []
    right = 0.0
    for i, mesh in enumerate(rest_meshes):
        if len(mesh.vertices) == 0:
            offsets.append(right if i else 0.0)
            continue
        lo, hi = float(mesh.vertices[:, 0].min()), float(mesh.vertices[:, 0].max())
        dx = 0.0 if i == 0 else right + margin - lo
        offsets.append(dx)
        right = hi + dx
    return offsets


def obj_text(meshes: list[Mesh], digits: int = OBJ_DIGITS) -> str:
    """Wavefront OBJ text of the meshes, one ``o NAME`` object each, in order.

    Written by trimesh (`trimesh.exchange.obj.export_obj`) with no header,
    normals, colours or textures and ``digits`` decimals; coordinates are
    rounded first so that -0 never appears. Identical meshes give identical text.
    """
    import trimesh
    from trimesh.exchange.obj import export_obj

    names = [m.name for m in meshes]
    if len(set(names)) != len(names):
        raise ValueError(f"mesh names must be unique (trimesh would rename them): {names}")
    scene = trimesh.Scene()
    for mesh in meshes:
        vertices = np.round(mesh.vertices, digits) + 0.0       # -0.0 + 0.0 is 0.0
        scene.add_geometry(trimesh.Trimesh(vertices=vertices, faces=mesh.faces, process=False),
                           geom_name=mesh.name, node_name=mesh.name)
    return export_obj(scene, include_normals=False, include_color=False, include_texture=False,
                      header=None, digits=digits)


def posed_meshes(trees: list[Tree], names: list[str], bends: list[np.ndarray],
                 rots: list[np.ndarray], offsets: list[float]) -> list[Mesh]:
    """Each tree posed at its angles (B,) rad, named, and moved by its x offset (m)."""
    return [tree_mesh(t, b, r, name).moved(dx)
            for t, name, b, r, dx in zip(trees, names, bends, rots, offsets)]


def rest_layout(trees: list[Tree], heights: list[float]) -> list[float]:
    """`side_by_side_offsets` of the trees' rest meshes."""
    rest = [tree_mesh(t, np.zeros(t.n_branches), np.zeros(t.n_branches)) for t in trees]
    return side_by_side_offsets(rest, heights)
