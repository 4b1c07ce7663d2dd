"""glTF 2.0 out (pygltflib): one node per branch in the branch hierarchy, its rotation animated.

Layout of the file (docs/export.md):

    scene -> "plantlod" root node: rotation -90 deg about x (the model's +Z up -> glTF's +Y up)
             -> one node per root branch, then its children, as the tree's hierarchy:
                translation = the branch's base in its parent's frame (the parent's tip
                              L_parent e_z plus the offset o_i; for a root, o_i),
                rotation    = R_parent^T R_i (model.md 3), one channel sampled at --fps
                -> "mesh" child: a shared unit cylinder scaled to (r, r, L) (scale stays
                   on this leaf node, so it never reaches the children)
                -> "leaf" children: a shared unit quad scaled to its area, facing its normal

Metres, seconds. The poses come from `plantlod.sim.kinematics.pose`, the model's own.
"""

from __future__ import annotations

import math

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import pose

from .constants import GLTF_CYLINDER_SIDES

UP = np.array([-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)])    # (x, y, z, w): -90 deg about x


def quaternions(m: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4) as (x, y, z, w), w >= 0."""
    m = np.asarray(m, dtype=np.float64)
    t = np.trace(m, axis1=-2, axis2=-1)
    q = np.empty(m.shape[:-2] + (4,))
    # Shepperd's method, branch by the largest diagonal term, vectorised
    cases = np.stack([t, m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]], axis=-1).argmax(axis=-1)
    for c in range(4):
        sel = cases == c
        if not sel.any():
            continue
        r = m[sel]
        if c == 0:
            s = np.sqrt(1.0 + r[:, 0, 0] + r[:, 1, 1] + r[:, 2, 2]) * 2
            v = np.stack([(r[:, 2, 1] - r[:, 1, 2]) / s, (r[:, 0, 2] - r[:, 2, 0]) / s,
                          (r[:, 1, 0] - r[:, 0, 1]) / s, 0.25 * s], axis=-1)
        elif c == 1:
            s = np.sqrt(1.0 + r[:, 0, 0] - r[:, 1, 1] - r[:, 2, 2]) * 2
            v = np.stack([0.25 * s, (r[:, 0, 1] + r[:, 1, 0]) / s, (r[:, 0, 2] + r[:, 2, 0]) / s,
                          (r[:, 2, 1] - r[:, 1, 2]) / s], axis=-1)
        elif c == 2:
            s = np.sqrt(1.0 + r[:, 1, 1] - r[:, 0, 0] - r[:, 2, 2]) * 2
            v = np.stack([(r[:, 0, 1] + r[:, 1, 0]) / s, 0.25 * s, (r[:, 1, 2] + r[:, 2, 1]) / s,
                          (r[:, 0, 2] - r[:, 2, 0]) / s], axis=-1)
        else:
            s = np.sqrt(1.0 + r[:, 2, 2] - r[:, 0, 0] - r[:, 1, 1]) * 2
            v = np.stack([(r[:, 0, 2] + r[:, 2, 0]) / s, (r[:, 1, 2] + r[:, 2, 1]) / s, 0.25 * s,
                          (r[:, 1, 0] - r[:, 0, 1]) / s], axis=-1)
        q[sel] = v
    q *= np.where(q[..., 3:4] < 0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def resample(times: np.ndarray, values: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Frames at k / fps within the run, each column of ``values`` (K, B) linearly interpolated."""
    frames = np.arange(int(math.floor(times[-1] * fps + 1e-9)) + 1) / fps
    out = np.empty((len(frames), values.shape[1]))
    for b in range(values.shape[1]):
        out[:, b] = np.interp(frames, times, values[:, b])
    return frames, out


def local_transforms(tree: Tree, bend: np.ndarray, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame and branch: rotation R_parent^T R_i (F, B, 3, 3) and translation (B, 3) (rest)."""
    p = pose(tree, bend, rot)
    parent = np.asarray(tree.parent, dtype=np.int64)
    frame = p.frame
    if not np.isfinite(frame).all():          # angles past what the rotations hold (1e300 rad)
        raise InputError("the angles give branch frames that are not finite numbers; expected "
                         "angles in radians (or --degrees)")
    local = frame.copy()
    has = parent >= 0
    local[:, has] = np.einsum("fbji,fbjk->fbik", frame[:, parent[has]], frame[:, has])
    translation = np.asarray(tree.offset, dtype=np.float64).reshape(-1, 3).copy()
    length = np.asarray(tree.length, dtype=np.float64)
    translation[has, 2] += length[parent[has]]
    return local, translation


def _unit_cylinder(sides: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (V, 3), normals (V, 3) and triangles (T, 3) of a radius-1 tube from z = 0 to 1."""
    a = np.arange(sides) * 2 * math.pi / sides
    ring = np.stack([np.cos(a), np.sin(a), np.zeros(sides)], axis=1)
    vertices = np.concatenate([ring, ring + [0.0, 0.0, 1.0]]).astype(np.float32)
    normals = np.concatenate([ring, ring]).astype(np.float32)
    i = np.arange(sides)
    j = (i + 1) % sides
    tri = np.concatenate([np.stack([i, j, i + sides], 1), np.stack([j, j + sides, i + sides], 1)])
    return vertices, normals, tri.astype(np.uint32)


def _unit_quad() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A unit-area square in the leaf's plane: normal +x, spanning y and z from its stalk."""
    v = np.array([[0, -0.5, 0], [0, 0.5, 0], [0, 0.5, 1], [0, -0.5, 1]], dtype=np.float32)
    n = np.tile(np.array([[1.0, 0.0, 0.0]], dtype=np.float32), (4, 1))
    return v, n, np.array([[0, 1, 2], [0, 2, 3], [0, 2, 1], [0, 3, 2]], dtype=np.uint32)


def gltf_document(tree: Tree, times: np.ndarray, bend: np.ndarray, rot: np.ndarray,
                  fps: float = 30.0, frames: tuple[int, int] | None = None):
    """A pygltflib.GLTF2 of ``tree`` moving by ``bend``/``rot`` (K, B) radians at ``times`` (K,) s."""
    import pygltflib as g

    t_frames, b = resample(times, bend, fps)
    _, r = resample(times, rot, fps)
    if frames is not None:
        t_frames, b, r = t_frames[frames[0]:frames[1]], b[frames[0]:frames[1]], r[frames[0]:frames[1]]
        t_frames = t_frames - t_frames[0]
    local, translation = local_transforms(tree, b, r)
    quats = quaternions(local).astype(np.float32)                  # (F, B, 4)
    blob = bytearray()
    views, accessors = [], []

    def add(array: np.ndarray, target=None, minmax=False) -> int:
        data = np.ascontiguousarray(array)
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=data.nbytes,
                                  target=target))
        blob.extend(data.tobytes())
        kind = {1: g.SCALAR, 3: g.VEC3, 4: g.VEC4}[1 if data.ndim == 1 else data.shape[1]]
        comp = g.UNSIGNED_INT if data.dtype == np.uint32 else g.FLOAT
        acc = g.Accessor(bufferView=len(views) - 1, componentType=comp, count=len(data), type=kind)
        if minmax:
            acc.min = np.atleast_1d(data.min(axis=0)).astype(float).tolist()
            acc.max = np.atleast_1d(data.max(axis=0)).astype(float).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    meshes = []
    for vertices, normals, tris in (_unit_cylinder(GLTF_CYLINDER_SIDES), _unit_quad()):
        pos = add(vertices, g.ARRAY_BUFFER, minmax=True)
        nor = add(normals, g.ARRAY_BUFFER)
        idx = add(tris.reshape(-1), g.ELEMENT_ARRAY_BUFFER)
        meshes.append(g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=pos, NORMAL=nor),
                                                     indices=idx)]))
    nodes = [g.Node(name="plantlod", rotation=UP.tolist(), children=[])]
    branch_node = []
    for i in range(tree.n_branches):
        branch_node.append(len(nodes))
        q = quats[0, i].astype(float).tolist()
        nodes.append(g.Node(name=tree.address[i], translation=translation[i].tolist(), rotation=q,
                            children=[]))
    parent = np.asarray(tree.parent, dtype=np.int64)
    for i in range(tree.n_branches):
        node = nodes[branch_node[i]]
        (nodes[0] if parent[i] < 0 else nodes[branch_node[parent[i]]]).children.append(branch_node[i])
        r_i, l_i = float(tree.radius[i]), float(tree.length[i])
        node.children.append(len(nodes))
        nodes.append(g.Node(name=f"{tree.address[i]} mesh", mesh=0, scale=[r_i, r_i, l_i]))
    normals = np.asarray(tree.leaf_normal, dtype=np.float64).reshape(-1, 3)
    for k, (on, area) in enumerate(zip(np.asarray(tree.leaf_branch), np.asarray(tree.leaf_area))):
        n = normals[k] / np.linalg.norm(normals[k])
        z = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        y = np.cross(z, n)
        y /= np.linalg.norm(y)
        frame = np.stack([n, y, np.cross(n, y)], axis=1)            # quad's x to the normal
        side = math.sqrt(max(float(area), 0.0))
        nodes[branch_node[on]].children.append(len(nodes))
        nodes.append(g.Node(name=f"leaf {k}", mesh=1, translation=[0.0, 0.0, float(tree.length[on])],
                            rotation=quaternions(frame).astype(float).tolist(),
                            scale=[side, side, side]))
    time_acc = add(t_frames.astype(np.float32), minmax=True)
    samplers, channels = [], []
    for i in range(tree.n_branches):
        if np.all(quats[:, i] == quats[0, i]):
            continue                                               # a branch that never moves
        samplers.append(g.AnimationSampler(input=time_acc, output=add(quats[:, i]),
                                           interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1,
                                           target=g.AnimationChannelTarget(node=branch_node[i],
                                                                           path="rotation")))
    doc = g.GLTF2(asset=g.Asset(generator="plantlod", version="2.0",
                                  extras={"plantlod": {"branches": int(tree.n_branches)}}), scene=0,
                  scenes=[g.Scene(nodes=[0])], nodes=nodes, meshes=meshes,
                  accessors=accessors, bufferViews=views,
                  buffers=[g.Buffer(byteLength=len(blob))],
                  animations=[g.Animation(name="wind", samplers=samplers, channels=channels)]
                  if channels else [])
    doc.set_binary_blob(bytes(blob))
    return doc


def gltf_bytes(doc, binary: bool) -> bytes:
    """The file's bytes: GLB, or glTF JSON with the buffer embedded as a data URI."""
    import pygltflib as g

    if binary:
        return b"".join(doc.save_to_bytes())
    doc.convert_buffers(g.BufferFormat.DATAURI)
    return doc.gltf_to_json().encode("utf-8")
