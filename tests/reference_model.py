"""A slow, literal reference implementation of model.md sections 2-4.

This module is an independent reading of the model contract (the team's model.md,
restated in docs/model.md), written for
tests: the production turtle (lsys/turtle.py) and simulation kernel (sim/) are
checked against it. It uses nothing but plain Python floats and lists, 3x3
matrices as nested lists (row-major: ``M[row][col]``), the ``math`` module, and
one module / one branch at a time. Clarity over speed: a tree of a few dozen
branches simulates a few hundred steps in well under a second.

Conventions (model.md preamble): vectors are world-frame column vectors, world
z is up; angles in module parameters and in the ``LSystem`` header are degrees,
everything computed here is radians. Lengths are metres, areas m^2, wind m/s.

Public API:
  reference_turtle(system, modules)          model.md section 2
  reference_pose(tree, bend, rot)            model.md section 3
  reference_simulate(tree, dt, steps, wind_fn, damping=0.0)
                                             model.md sections 3 and 4
  tree_from_reference(turtle, leaf_force_scale=1.0, source="")
      builds a ``plantlod.lsys.tree.Tree`` from a `reference_turtle` result.
"""

from __future__ import annotations

import math

import numpy as np

from plantlod.lsys.constants import DEFAULT_MOVE_LENGTH, ZYZ_DEGENERATE_TOL
from plantlod.lsys.tree import Tree

# `$` leaves the turtle unchanged when the heading is this close to vertical
# (|z_world x h| below it; lsys-format.md / the brief: "within 1e-9").
from plantlod.lsys.constants import DOLLAR_VERTICAL_TOL


# --- tiny 3-vector and 3x3-matrix helpers -------------------------------------
# A vector is a list of 3 floats; a matrix is a list of 3 rows of 3 floats.

def identity():
    """The 3x3 identity matrix."""
    return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def mat_mul(a, b):
    """Matrix product a b of two 3x3 matrices."""
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    """Transpose of a 3x3 matrix."""
    return [[a[j][i] for j in range(3)] for i in range(3)]


def mat_vec(a, v):
    """Matrix-vector product a v (3x3 times 3-vector)."""
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]


def column(a, j):
    """Column j of a 3x3 matrix as a 3-vector (0: x, 1: y, 2: z axis)."""
    return [a[0][j], a[1][j], a[2][j]]


def add(u, v):
    return [u[0] + v[0], u[1] + v[1], u[2] + v[2]]


def sub(u, v):
    return [u[0] - v[0], u[1] - v[1], u[2] - v[2]]


def scale(s, v):
    return [s * v[0], s * v[1], s * v[2]]


def dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def cross(u, v):
    return [u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0]]


def norm(v):
    return math.sqrt(dot(v, v))


# --- elementary rotations (right-handed) ---------------------------------------

def rot_x(a):
    """Rotation by a radians about the x axis."""
    c, s = math.cos(a), math.sin(a)
    return [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]


def rot_y(a):
    """Rotation by a radians about the y axis (takes +z toward +x)."""
    c, s = math.cos(a), math.sin(a)
    return [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]


def rot_z(a):
    """Rotation by a radians about the z axis (takes +x toward +y)."""
    c, s = math.cos(a), math.sin(a)
    return [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]


def rot_axis(u, theta):
    """Rodrigues' rotation by theta radians about the unit axis u (model.md 3).

    R = cos(theta) I + sin(theta) [u]x + (1 - cos(theta)) u u^T.
    """
    c, s = math.cos(theta), math.sin(theta)
    t = 1.0 - c
    x, y, z = u
    return [[c + t * x * x, t * x * y - s * z, t * x * z + s * y],
            [t * y * x + s * z, c + t * y * y, t * y * z - s * x],
            [t * z * x - s * y, t * z * y + s * x, c + t * z * z]]


def zyz_angles(q):
    """ZYZ Euler angles (phi, alpha, psi) of a rotation matrix q (model.md 2).

    q = Rz(phi) Ry(alpha) Rz(psi) with alpha in [0, pi]:
      h = hypot(q[0][2], q[1][2]);
      alpha = atan2(h, q[2][2]), phi = atan2(q[1][2], q[0][2]),
      psi = atan2(q[2][1], -q[2][0]);
      where h < 1e-9: alpha = exactly 0 (q[2][2] > 0) or pi, phi = 0,
      psi = atan2(q[1][0], q[0][0]) (alpha = 0) or atan2(q[1][0], -q[0][0]) (pi).
    """
    h = math.hypot(q[0][2], q[1][2])
    if h < ZYZ_DEGENERATE_TOL:
        if q[2][2] > 0:
            return 0.0, 0.0, math.atan2(q[1][0], q[0][0])
        return 0.0, math.pi, math.atan2(q[1][0], -q[0][0])
    alpha = math.atan2(h, q[2][2])
    phi = math.atan2(q[1][2], q[0][2])
    psi = math.atan2(q[2][1], -q[2][0])
    return phi, alpha, psi


# --- section 2: the turtle -----------------------------------------------------

def _address_tuple(address):
    """The address text "0.1.2" as (0, 1, 2), the key form of `LSystem.overrides`."""
    return tuple(int(part) for part in address.split("."))


def _angle_param(params, default_degrees):
    """A turn's angle in radians: its first parameter (degrees) or the default."""
    return math.radians(params[0] if params else default_degrees)


def _dollar(m):
    """ABOP's `$`: roll about the heading h so that x is horizontal (model.md 2).

    x = z_world x h / |z_world x h|, y = h x x; unchanged when h is vertical
    within DOLLAR_VERTICAL_TOL.
    """
    h = column(m, 2)
    zx = cross([0.0, 0.0, 1.0], h)
    n = norm(zx)
    if n < DOLLAR_VERTICAL_TOL:
        return m
    x = scale(1.0 / n, zx)
    y = cross(h, x)
    return [[x[i], y[i], h[i]] for i in range(3)]


def _branch_values(system, symbol, params, radius_setting, override):
    """Resolve one branch's parameters (lsys-format.md "Overrides" precedence).

    override > module parameter (length) / `!` setting (radius) > symbol
    declaration > header (force_absorbed, force_propagated, drag_coefficient).
    """
    values = {
        "length": float(params[0]) if params else symbol.length,
        "radius": radius_setting if radius_setting is not None else symbol.radius,
        "bend_strength": symbol.bend_strength,
        "rotation_strength": symbol.rotation_strength,
        "force_absorbed": (symbol.force_absorbed if symbol.force_absorbed is not None
                           else system.force_absorbed),
        "force_propagated": (symbol.force_propagated if symbol.force_propagated is not None
                             else system.force_propagated),
        "drag_coefficient": (symbol.drag_coefficient if symbol.drag_coefficient is not None
                             else system.drag_coefficient),
    }
    for key in values:
        if key in override:
            values[key] = override[key]
    return {key: float(v) for key, v in values.items()}


def reference_turtle(system, modules):
    """Interpret a derived string with the turtle of model.md section 2.

    `system` is a `plantlod.lsys.system.LSystem`; `modules` is a list of
    (char: str, params: tuple[float, ...], address: str) for the final
    (interpreted) string. Turn parameters are degrees.

    Returns a dict with
      'branches': list (parent before child, in drawing order) of dicts with keys
          address (str, ":j" suffix for the j-th further branch under one
          address), symbol, parent (index or -1), length (m), radius (m),
          bend_strength, rotation_strength, force_absorbed, force_propagated,
          drag_coefficient, phi, alpha, psi (ZYZ angles of Q = R_parent^T M,
          radians), offset (3-list, parent frame, m), base and tip (3-lists,
          world, m), frame (3x3 nested list: the world frame R_i = M at rest);
      'leaves': list of dicts with keys address, branch (index), area (m^2),
          normal (3-list, unit, in the branch's frame).
    A leaf read while no branch is current is dropped.
    Overrides apply to every branch (leaf) drawn by a module at their address.
    """
    overrides = {tuple(o.address): dict(o.values) for o in system.overrides}
    branches = []
    leaves = []
    drawn_per_address = {}

    # The whole turtle state: position, orientation (columns x, y, z = heading),
    # current branch (-1: none) and the `!` radius setting (None: unset).
    pos = [0.0, 0.0, 0.0]
    m = identity()
    current = -1
    radius_setting = None
    stack = []

    for char, params, address in modules:
        if char == "[":
            stack.append((list(pos), [row[:] for row in m], current, radius_setting))
        elif char == "]":
            pos, m, current, radius_setting = stack.pop()
        elif char in "+-":
            a = _angle_param(params, system.branching_angle)
            m = mat_mul(m, rot_y(a if char == "+" else -a))
        elif char in "&^":
            a = _angle_param(params, system.branching_angle)
            m = mat_mul(m, rot_x(a if char == "&" else -a))
        elif char in "/\\":
            a = _angle_param(params, system.rotation_angle)
            m = mat_mul(m, rot_z(a if char == "/" else -a))
        elif char == "|":
            m = mat_mul(m, rot_y(math.pi))
        elif char == "$":
            m = _dollar(m)
        elif char == "!":
            if params:
                radius_setting = float(params[0])
        elif char == "f":
            step = float(params[0]) if params else DEFAULT_MOVE_LENGTH
            pos = add(pos, scale(step, column(m, 2)))
        elif system.branch_symbol(char) is not None:
            symbol = system.branch_symbol(char)
            override = overrides.get(_address_tuple(address), {})
            values = _branch_values(system, symbol, params, radius_setting, override)
            if current < 0:
                r_parent, parent_tip = identity(), [0.0, 0.0, 0.0]
            else:
                r_parent, parent_tip = branches[current]["frame"], branches[current]["tip"]
            phi, alpha, psi = zyz_angles(mat_mul(transpose(r_parent), m))
            offset = mat_vec(transpose(r_parent), sub(pos, parent_tip))
            tip = add(pos, scale(values["length"], column(m, 2)))
            count = drawn_per_address.get(address, 0)
            drawn_per_address[address] = count + 1
            branch = {
                "address": address if count == 0 else f"{address}:{count}",
                "symbol": char,
                "parent": current,
                **values,
                "phi": phi, "alpha": alpha, "psi": psi,
                "offset": offset,
                "base": list(pos),
                "tip": tip,
                "frame": [row[:] for row in m],
            }
            branches.append(branch)
            current = len(branches) - 1
            pos = list(tip)
        elif system.leaf_symbol(char) is not None:
            if current < 0:
                continue  # a leaf without a branch is dropped (model.md 2)
            override = overrides.get(_address_tuple(address), {})
            area = float(params[0]) if params else system.leaf_symbol(char).area
            area = float(override.get("area", area))
            normal = mat_vec(transpose(branches[current]["frame"]), column(m, 0))
            leaves.append({"address": address, "branch": current,
                           "area": area, "normal": normal})
        # any other character is a plain module: the turtle ignores it
    return {"branches": branches, "leaves": leaves}


def tree_from_reference(turtle, leaf_force_scale=1.0, source=""):
    """Build a `plantlod.lsys.tree.Tree` from a `reference_turtle` result."""
    bs, ls = turtle["branches"], turtle["leaves"]

    def column_of(key):
        return np.array([b[key] for b in bs], dtype=np.float64)

    return Tree(
        address=[b["address"] for b in bs],
        symbol=[b["symbol"] for b in bs],
        parent=np.array([b["parent"] for b in bs], dtype=np.int64),
        length=column_of("length"),
        radius=column_of("radius"),
        bend_strength=column_of("bend_strength"),
        rotation_strength=column_of("rotation_strength"),
        force_absorbed=column_of("force_absorbed"),
        force_propagated=column_of("force_propagated"),
        drag_coefficient=column_of("drag_coefficient"),
        euler=np.array([[b["phi"], b["alpha"], b["psi"]] for b in bs],
                       dtype=np.float64).reshape(len(bs), 3),
        offset=np.array([b["offset"] for b in bs], dtype=np.float64).reshape(len(bs), 3),
        leaf_branch=np.array([leaf["branch"] for leaf in ls], dtype=np.int64),
        leaf_area=np.array([leaf["area"] for leaf in ls], dtype=np.float64),
        leaf_normal=np.array([leaf["normal"] for leaf in ls], dtype=np.float64).reshape(len(ls), 3),
        leaf_address=[leaf["address"] for leaf in ls],
        leaf_force_scale=float(leaf_force_scale),
        source=source,
    )


# --- section 3: kinematics -----------------------------------------------------

def _swing_rotation(theta_b, theta_r):
    """Rot(u, theta) with theta = hypot(theta_b, theta_r), u = (-theta_r, theta_b, 0)/theta.

    The identity when theta = 0 (model.md 3).
    """
    theta = math.hypot(theta_b, theta_r)
    if theta == 0.0:
        return identity()
    return rot_axis([-theta_r / theta, theta_b / theta, 0.0], theta)


def reference_pose(tree, bend, rot):
    """Pose a tree at bend angles `bend` and rotation angles `rot` (model.md 3).

    `tree` is a `plantlod.lsys.tree.Tree`; `bend` and `rot` are sequences of B
    angles (radians). In parent-before-child order:
      S_i = R_parent Rz(phi_i) Ry(alpha_i) Rot(u_i, theta_i)   (swing frame)
      R_i = S_i Rz(psi_i)                                      (branch frame)
    or, for a branch with a swing roll beta_i (`Tree.swing_roll`, a level's key),
      S_i = R_parent Rz(phi_i) Ry(alpha_i) Rz(beta_i) Rot(u_i, theta_i),  R_i = S_i Rz(psi_i - beta_i)
      base_i = tip_parent + R_parent o_i   (o_i from the origin for a root)
      tip_i = base_i + L_i R_i e_z
    Returns (bases, tips, frames, swings): lists of B 3-lists (world, m) and
    B 3x3 nested lists (world R_i and S_i).
    """
    bases, tips, frames, swings = [], [], [], []
    for i in range(tree.n_branches):
        parent = int(tree.parent[i])
        phi, alpha, psi = (float(a) for a in tree.euler[i])
        roll = getattr(tree, "swing_roll", None)
        beta = 0.0 if roll is None else float(roll[i])
        offset = [float(x) for x in tree.offset[i]]
        if parent < 0:
            r_parent, parent_tip = identity(), [0.0, 0.0, 0.0]
        else:
            r_parent, parent_tip = frames[parent], tips[parent]
        swing = mat_mul(mat_mul(mat_mul(mat_mul(r_parent, rot_z(phi)), rot_y(alpha)), rot_z(beta)),
                        _swing_rotation(float(bend[i]), float(rot[i])))
        frame = mat_mul(swing, rot_z(psi - beta))
        base = add(parent_tip, mat_vec(r_parent, offset))
        tip = add(base, scale(float(tree.length[i]), column(frame, 2)))
        bases.append(base)
        tips.append(tip)
        frames.append(frame)
        swings.append(swing)
    return bases, tips, frames, swings


# --- section 4: forces and time stepping ----------------------------------------

def reference_forces(tree, frames, wind):
    """Total force F_i on every branch for one pose and wind (model.md 4).

    `frames` are the world branch frames R_i of `reference_pose`; `wind` is the
    world wind vector V (m/s). With v = |V| and V^ = V / v:
      leaf force  f_j = s_L A_j (V . n^_j) n^_j,  n^_j = R_branch n_j
      drag        d_i = C_d,i v^2 (2 pi r_i L_i) |R_i e_z x V^| V^   (0 when v = 0)
      total       F_i = d_i + k_fp,i (sum of leaf forces on i + sum of children F_c)
    Returns a list of B force 3-vectors (world).
    """
    b_count = tree.n_branches
    wind = [float(w) for w in wind]
    speed = norm(wind)
    gathered = [[0.0, 0.0, 0.0] for _ in range(b_count)]   # leaf + child forces
    for j in range(tree.n_leaves):
        i = int(tree.leaf_branch[j])
        n_hat = mat_vec(frames[i], [float(x) for x in tree.leaf_normal[j]])
        f = scale(float(tree.leaf_force_scale) * float(tree.leaf_area[j]) * dot(wind, n_hat), n_hat)
        gathered[i] = add(gathered[i], f)
    forces = [None] * b_count
    for i in reversed(range(b_count)):   # children have larger indices than parents
        if speed == 0.0:
            drag = [0.0, 0.0, 0.0]
        else:
            v_hat = scale(1.0 / speed, wind)
            area = 2.0 * math.pi * float(tree.radius[i]) * float(tree.length[i])
            sin_angle = norm(cross(column(frames[i], 2), v_hat))
            drag = scale(float(tree.drag_coefficient[i]) * speed * speed * area * sin_angle, v_hat)
        forces[i] = add(drag, scale(float(tree.force_propagated[i]), gathered[i]))
        parent = int(tree.parent[i])
        if parent >= 0:
            gathered[parent] = add(gathered[parent], forces[i])
    return forces


def reference_simulate(tree, dt, steps, wind_fn, damping=0.0, damping_ratio=None):
    """Simulate a tree in the wind (model.md sections 3 and 4).

    `wind_fn(t)` gives the world wind vector (3 floats, m/s) at time t (s).
    Step k (1..steps) advances every branch at once from t_{k-1} to t_k = k dt,
    using the pose and the wind V((k-1) dt) of t_{k-1}:
      vb <- vb + k_FA (F . S e_x) - theta_b k_bs / 1000 - c vb;  theta_b <- theta_b + vb dt
      vr <- vr + k_FA (F . S e_y) - theta_r k_rs / 1000 - c vr;  theta_r <- theta_r + vr dt
    with c = `damping`; or, with `damping_ratio` ζ, each branch's c_b = 4 pi ζ dt / P_b with
    P_b = 2 pi dt / arccos(1 - k_bs dt / 2000) (and c_r from k_rs), model.md 4 as written.
    A branch with a gain matrix G (tree.force_gain row [G_bx G_by G_bz G_rx G_ry G_rz],
    model.md 5) pushes with G (S^T F) in place of k_FA (F . S e_x, F . S e_y).
    Returns (bend, rot): lists of steps + 1 lists of B
    angles (radians); row 0 is t0 = 0, all zeros. No stability check is made.
    """
    def period(k):
        return 2.0 * math.pi * dt / math.acos(1.0 - k * dt / 1000.0 / 2.0)

    damp_b, damp_r = [damping] * tree.n_branches, [damping] * tree.n_branches
    if damping_ratio is not None:
        damp_b = [4.0 * math.pi * damping_ratio * dt / period(float(k)) for k in tree.bend_strength]
        damp_r = [4.0 * math.pi * damping_ratio * dt / period(float(k))
                  for k in tree.rotation_strength]
    gain = getattr(tree, "force_gain", None)
    b_count = tree.n_branches
    theta_b, theta_r = [0.0] * b_count, [0.0] * b_count
    vel_b, vel_r = [0.0] * b_count, [0.0] * b_count
    bend, rot = [list(theta_b)], [list(theta_r)]
    for k in range(1, steps + 1):
        wind = wind_fn((k - 1) * dt)
        _, _, frames, swings = reference_pose(tree, theta_b, theta_r)
        forces = reference_forces(tree, frames, wind)
        new_b, new_r = [0.0] * b_count, [0.0] * b_count
        for i in range(b_count):
            k_fa = float(tree.force_absorbed[i])
            f = [dot(forces[i], column(swings[i], j)) for j in range(3)]    # S^T F
            if gain is None:
                push_b = k_fa * f[0]
                push_r = k_fa * f[1]
            else:
                g = [float(x) for x in gain[i]]
                push_b = k_fa * (g[0] * f[0] + g[1] * f[1] + g[2] * f[2])
                push_r = k_fa * (g[3] * f[0] + g[4] * f[1] + g[5] * f[2])
            vel_b[i] = (vel_b[i] + push_b - theta_b[i] * float(tree.bend_strength[i]) / 1000.0
                        - damp_b[i] * vel_b[i])
            vel_r[i] = (vel_r[i] + push_r - theta_r[i] * float(tree.rotation_strength[i]) / 1000.0
                        - damp_r[i] * vel_r[i])
            new_b[i] = theta_b[i] + vel_b[i] * dt
            new_r[i] = theta_r[i] + vel_r[i] * dt
        theta_b, theta_r = new_b, new_r
        bend.append(list(theta_b))
        rot.append(list(theta_r))
    return bend, rot
