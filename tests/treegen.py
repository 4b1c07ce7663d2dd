"""Trees built directly from arrays, for simulation tests and benchmarks.

No parser or turtle involved: every factory fills the `Tree` arrays of
lsys/tree.py itself. Rest rotations are ZYZ Euler angles (phi, alpha, psi)
relative to the parent frame (model.md section 2): a turn ``+(d)`` is
(0, d, 0) and ``-(d)`` is (pi, d, pi).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

from plantlod.lsys.tree import Tree


def make_tree(parent, euler=None, *, length=1.0, radius=0.02, bend_strength=100.0,
              rotation_strength=100.0, force_absorbed=0.01, force_propagated=0.7,
              drag_coefficient=0.0015, offset=None, leaf_branch=(), leaf_area=0.01,
              leaf_normal=None, leaf_force_scale=1.0, address=None, symbol="F") -> Tree:
    """A `Tree` from per-branch values (scalars are broadcast to every branch / leaf).

    parent : (B,) ints, parent before child; euler : (B, 3) (phi, alpha, psi)
    radians, default all 0 (a straight continuation). Leaves: leaf_branch (F,),
    leaf_area scalar or (F,), leaf_normal (F, 3), default e_x.
    Addresses default to "0", "1", ...; the symbol to "F" for every branch.
    """
    parent = np.asarray(parent, dtype=np.int64).reshape(-1)
    b = len(parent)

    def per_branch(value):
        return np.broadcast_to(np.asarray(value, dtype=np.float64), (b,)).copy()

    leaf_branch = np.asarray(leaf_branch, dtype=np.int64).reshape(-1)
    f = len(leaf_branch)
    if leaf_normal is None:
        leaf_normal = np.tile([1.0, 0.0, 0.0], (f, 1))
    tree = Tree(
        address=list(address) if address is not None else [str(i) for i in range(b)],
        symbol=[symbol] * b if isinstance(symbol, str) else list(symbol),
        parent=parent,
        length=per_branch(length),
        radius=per_branch(radius),
        bend_strength=per_branch(bend_strength),
        rotation_strength=per_branch(rotation_strength),
        force_absorbed=per_branch(force_absorbed),
        force_propagated=per_branch(force_propagated),
        drag_coefficient=per_branch(drag_coefficient),
        euler=np.zeros((b, 3)) if euler is None else np.asarray(euler, dtype=np.float64).reshape(b, 3),
        offset=np.zeros((b, 3)) if offset is None else np.asarray(offset, dtype=np.float64).reshape(b, 3),
        leaf_branch=leaf_branch,
        leaf_area=np.broadcast_to(np.asarray(leaf_area, dtype=np.float64), (f,)).copy(),
        leaf_normal=np.asarray(leaf_normal, dtype=np.float64).reshape(f, 3),
        leaf_address=[f"leaf{j}" for j in range(f)],
        leaf_force_scale=float(leaf_force_scale),
        source="treegen",
    )
    tree.check()
    return tree


def stalk(n: int, *, length=1.0, leaf_area=0.01, leaf_normal=(1.0, 0.0, 0.0), **kw) -> Tree:
    """A straight vertical chain of n branches with one leaf on the top branch."""
    return make_tree(np.arange(n) - 1, length=length, leaf_branch=[n - 1], leaf_area=leaf_area,
                     leaf_normal=[leaf_normal], **kw)


def y_tree(angle: float = math.radians(30), **kw) -> Tree:
    """A vertical trunk with two children turned by +angle and -angle in the xz-plane.

    The tree is symmetric under the mirror x -> -x, which swaps branches 1
    and 2; each child carries one leaf whose normal is the child's x axis.
    """
    euler = [[0.0, 0.0, 0.0], [0.0, angle, 0.0], [math.pi, angle, math.pi]]
    return make_tree([-1, 0, 0], euler, leaf_branch=[1, 2],
                     leaf_normal=[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], **kw)


def abop_124a(n: int, delta_deg: float = 25.7, **kw) -> Tree:
    """The branch structure of ABOP Fig. 1.24a, F -> F[+F]F[-F]F, after n steps: 5^n branches.

    Built structurally, not by a turtle: each branch becomes a chain
    F0 F2 F4 with F1 (+delta) on F0 and F3 (-delta) on F2, the chain's first
    branch takes the old branch's parent and rest rotation, and the old
    branch's children hang from F4 (which ends where the old tip did).
    Addresses follow model.md section 1 (successor indices 0, 3, 5, 8, 10).
    Lengths are 1 / 3^n so the tree stays about 1 m tall; branches end up in
    depth-first (parent-before-child) order with one leaf on every branch
    that has no children.
    """
    d = math.radians(delta_deg)
    plus, minus, straight = (0.0, d, 0.0), (math.pi, d, math.pi), (0.0, 0.0, 0.0)
    # a branch: (address, rest euler, children)
    root = ("0", straight, [])

    def expand(node):
        address, euler, kids = node
        kids = [expand(k) for k in kids]
        f4 = (address + ".10", straight, kids)
        f3 = (address + ".8", minus, [])
        f2 = (address + ".5", straight, [f3, f4])
        f1 = (address + ".3", plus, [])
        return (address + ".0", euler, [f1, f2])

    for _ in range(n):
        root = expand(root)
    addresses, eulers, parents = [], [], []
    stack = [(root, -1)]
    while stack:
        (address, euler, kids), p = stack.pop()
        parents.append(p)
        addresses.append(address)
        eulers.append(euler)
        me = len(parents) - 1
        stack.extend((k, me) for k in reversed(kids))
    parents_arr = np.asarray(parents)
    has_child = np.zeros(len(parents), dtype=bool)
    has_child[parents_arr[parents_arr >= 0]] = True
    leaves = np.flatnonzero(~has_child)
    kw.setdefault("length", 1.0 / 3 ** n)
    kw.setdefault("radius", 0.01)
    return make_tree(parents_arr, eulers, address=addresses, leaf_branch=leaves, **kw)


@st.composite
def random_trees(draw, max_branches: int = 7, max_leaves: int = 4, dt: float = 0.01) -> Tree:
    """Small random trees, stable at time step ``dt`` for any damping in [0, 1].

    Any parent-before-child shape, rest rotations anywhere (alpha in [0, pi]),
    offsets, per-branch parameters, and leaves with random unit normals.
    """
    b = draw(st.integers(1, max_branches))
    floats = lambda lo, hi: st.floats(lo, hi, allow_nan=False, allow_infinity=False)  # noqa: E731
    parent = [-1] + [draw(st.integers(-1, i - 1)) for i in range(1, b)]
    euler = [[draw(floats(-math.pi, math.pi)), draw(floats(0.0, math.pi)),
              draw(floats(-math.pi, math.pi))] for _ in range(b)]
    offset = [[draw(floats(-0.3, 0.3)) for _ in range(3)] if draw(st.booleans()) else [0.0] * 3
              for _ in range(b)]
    k_max = 0.95 * 2.0 * 1000.0 / dt          # s < 2 = 4 - 2c for c <= 1
    per = lambda lo, hi: [draw(floats(lo, hi)) for _ in range(b)]  # noqa: E731
    # mostly soft branches (angles of tenths of a radian), sometimes up to the limit
    strengths = lambda: [draw(st.one_of(floats(20.0, 400.0), floats(400.0, k_max)))  # noqa: E731
                         for _ in range(b)]
    n_leaves = draw(st.integers(0, max_leaves))
    normals = []
    for _ in range(n_leaves):
        v = np.array([draw(floats(-1, 1)) for _ in range(3)])
        if np.linalg.norm(v) < 0.1:
            v = np.array([1.0, 0.0, 0.0])
        normals.append(v / np.linalg.norm(v))
    return make_tree(
        parent, euler, offset=offset,
        length=per(0.1, 2.0), radius=per(0.005, 0.1),
        bend_strength=strengths(), rotation_strength=strengths(),
        force_absorbed=per(0.0, 0.3), force_propagated=per(0.0, 1.0),
        drag_coefficient=per(0.0, 0.05),
        leaf_branch=[draw(st.integers(0, b - 1)) for _ in range(n_leaves)],
        leaf_area=[draw(floats(0.0, 0.2)) for _ in range(n_leaves)],
        leaf_normal=np.array(normals).reshape(n_leaves, 3),
        leaf_force_scale=draw(floats(0.5, 2.0)),
    )
