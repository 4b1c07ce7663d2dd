"""Checks of the reference model (tests/reference_model.py) against hand-computed
values, closed forms and scipy's independent rotation code (model.md sections 2-4)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from plantlod.lsys.system import BranchSymbol, LeafSymbol, LSystem, Override
from plantlod.lsys.tree import Tree

from reference_model import (
    reference_pose,
    reference_simulate,
    reference_turtle,
    rot_axis,
    rot_x,
    rot_y,
    rot_z,
    tree_from_reference,
)

# --- builders ------------------------------------------------------------------

RADIUS = 0.02
K_BS = 200.0
K_RS = 100.0
K_FA = 0.005
K_FP = 0.7
C_D = 0.0015


def make_system(branching=90.0, rotation=None, overrides=(), branch_kwargs=None):
    """An LSystem with branch symbol F (length 1) and leaf symbol L (area 0.01)."""
    branch = BranchSymbol("F", length=1.0, radius=RADIUS, bend_strength=K_BS,
                          rotation_strength=K_RS, **(branch_kwargs or {}))
    return LSystem(
        derivation_length=0, branching_angle=branching,
        rotation_angle=branching if rotation is None else rotation,
        force_absorbed=K_FA, force_propagated=K_FP, axiom=(),
        branches=(branch,), leaves=(LeafSymbol("L", area=0.01),),
        overrides=tuple(overrides), drag_coefficient=C_D,
    )


_MODULE = re.compile(r"\s*(\S)(?:\(([^)]*)\))?")


def modules_of(text):
    """'F+(30)F' -> [('F', (), '0'), ('+', (30.0,), '1'), ('F', (), '2')]."""
    out, pos = [], 0
    text = text.strip()
    while pos < len(text):
        m = _MODULE.match(text, pos)
        args = tuple(float(a) for a in m.group(2).split(",")) if m.group(2) else ()
        out.append((m.group(1), args, str(len(out))))
        pos = m.end()
        while pos < len(text) and text[pos].isspace():
            pos += 1
    return out


def turtle(text, **kw):
    return reference_turtle(make_system(**kw), modules_of(text))


def make_tree(parent, euler, offset=None, length=None, leaves=(), leaf_force_scale=1.0,
              radius=RADIUS, k_bs=K_BS, k_rs=K_RS, k_fa=K_FA, k_fp=K_FP, c_d=C_D):
    """A Tree built field by field; leaves are (branch, area, normal) triples."""
    b = len(parent)
    full = lambda v: np.full(b, float(v))  # noqa: E731
    return Tree(
        address=[str(i) for i in range(b)], symbol=["F"] * b,
        parent=np.array(parent, dtype=np.int64),
        length=np.array(length if length is not None else [1.0] * b, dtype=np.float64),
        radius=full(radius), bend_strength=full(k_bs), rotation_strength=full(k_rs),
        force_absorbed=full(k_fa), force_propagated=full(k_fp), drag_coefficient=full(c_d),
        euler=np.array(euler, dtype=np.float64).reshape(b, 3),
        offset=np.array(offset if offset is not None else [[0.0] * 3] * b,
                        dtype=np.float64).reshape(b, 3),
        leaf_branch=np.array([lf[0] for lf in leaves], dtype=np.int64),
        leaf_area=np.array([lf[1] for lf in leaves], dtype=np.float64),
        leaf_normal=np.array([lf[2] for lf in leaves], dtype=np.float64).reshape(len(leaves), 3),
        leaf_address=[str(i) for i in range(len(leaves))],
        leaf_force_scale=leaf_force_scale,
    )


def close(a, b, tol=1e-12):
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=0, atol=tol)


def same_angle(a, b, tol=1e-12):
    """Angles equal modulo 2 pi."""
    d = (a - b) % (2 * math.pi)
    return min(d, 2 * math.pi - d) < tol


# --- rotation helpers against scipy --------------------------------------------

@pytest.mark.parametrize("angle", [0.3, -1.2, math.pi / 2, 3.0])
def test_elementary_rotations_match_scipy(angle):
    for fn, axis in ((rot_x, "x"), (rot_y, "y"), (rot_z, "z")):
        assert close(fn(angle), Rotation.from_euler(axis, angle).as_matrix(), 1e-15)
    u = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    assert close(rot_axis(list(u), angle), Rotation.from_rotvec(angle * u).as_matrix(), 1e-15)


# --- turtle (model.md section 2) --------------------------------------------------

def test_f_plus_f_right_angle():
    bs = turtle("F+F", branching=90.0)["branches"]
    assert [b["parent"] for b in bs] == [-1, 0]
    assert bs[0]["alpha"] == 0.0 and bs[0]["base"] == [0.0, 0.0, 0.0]
    assert close(bs[0]["tip"], [0, 0, 1])
    assert abs(bs[1]["alpha"] - math.pi / 2) < 1e-15
    assert same_angle(bs[1]["phi"], 0.0) and same_angle(bs[1]["psi"], 0.0)
    assert close(bs[1]["base"], [0, 0, 1])
    assert close(bs[1]["tip"], [1, 0, 1])          # heading turned from +z to +x
    # M = Ry(90): columns x = (0,0,-1), y = (0,1,0), z = (1,0,0)
    assert close(bs[1]["frame"], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    assert close(bs[1]["offset"], [0, 0, 0])


def test_straight_continuation_alpha_exactly_zero():
    for text in ("FF", "F+(1e-12)F", "F&(1e-12)F"):
        b = turtle(text)["branches"][1]
        assert b["alpha"] == 0.0 and b["phi"] == 0.0, text
        assert abs(b["psi"]) < 1e-12
    # a pure roll is a degenerate Q = Rz(90): alpha 0, phi 0, the roll in psi
    b = turtle("F/(90)F")["branches"][1]
    assert (b["alpha"], b["phi"]) == (0.0, 0.0)
    assert abs(b["psi"] - math.pi / 2) < 1e-15


def test_turn_around_alpha_exactly_pi():
    bs = turtle("F|F")["branches"]
    assert bs[1]["alpha"] == math.pi and bs[1]["phi"] == 0.0
    assert same_angle(bs[1]["psi"], 0.0)
    assert close(bs[1]["tip"], [0, 0, 0])          # back down to the origin
    # Q = Ry(pi) Rz(90) = [[0,1,0],[1,0,0],[0,0,-1]]: psi = atan2(1, 0) = pi/2
    b = turtle("F|/(90)F")["branches"][1]
    assert b["alpha"] == math.pi and abs(b["psi"] - math.pi / 2) < 1e-15


def test_minus_branch_has_phi_and_psi_pi():
    # Ry(-30 deg) = Rz(pi) Ry(30 deg) Rz(pi)
    b = turtle("F-F", branching=30.0)["branches"][1]
    assert abs(b["alpha"] - math.pi / 6) < 1e-15
    assert same_angle(b["phi"], math.pi) and same_angle(b["psi"], math.pi)
    assert close(b["tip"], [-0.5, 0, 1 + math.sqrt(3) / 2])


@settings(max_examples=60, deadline=None)
@given(phi=st.floats(-179, 179), alpha=st.floats(0.5, 179.5), psi=st.floats(-179, 179))
def test_zyz_recovers_turn_sequence(phi, alpha, psi):
    # M <- M Rz(phi) Ry(alpha) Rz(psi) is exactly the ZYZ product
    b = turtle(f"F/({phi!r})+({alpha!r})/({psi!r})F")["branches"][1]
    assert abs(b["alpha"] - math.radians(alpha)) < 1e-12
    assert same_angle(b["phi"], math.radians(phi), 1e-12)
    assert same_angle(b["psi"], math.radians(psi), 1e-12)
    expected = Rotation.from_euler("ZYZ", [phi, alpha, psi], degrees=True).as_matrix()
    assert close(b["frame"], expected)


def test_move_offsets():
    # root moved up: the offset is from the origin
    b = turtle("f(2)F")["branches"][0]
    assert close(b["offset"], [0, 0, 2]) and close(b["base"], [0, 0, 2]) and close(b["tip"], [0, 0, 3])
    assert close(turtle("fF")["branches"][0]["offset"], [0, 0, 1])   # default move 1
    # a root always measures its offset in the world frame
    assert close(turtle("+(90)f(2)F")["branches"][0]["offset"], [2, 0, 0])
    # offset along the parent's own heading, in the parent frame
    bs = turtle("+(90)Ff(0.5)F")["branches"]
    assert close(bs[1]["base"], [1.5, 0, 0]) and close(bs[1]["offset"], [0, 0, 0.5])
    # sideways move: in the parent frame (= world here)
    bs = turtle("F+(90)f(2)-(90)F")["branches"]
    assert close(bs[1]["base"], [2, 0, 1]) and close(bs[1]["offset"], [2, 0, 0])
    assert bs[1]["alpha"] == 0.0


def test_leaf_normals_and_areas():
    lv = turtle("F+(90)L")["leaves"]
    assert lv[0]["branch"] == 0 and close(lv[0]["normal"], [0, 0, -1])   # Ry(90) e_x
    assert close(turtle("+(90)FL")["leaves"][0]["normal"], [1, 0, 0])      # same frame as branch
    assert close(turtle("F/(90)L")["leaves"][0]["normal"], [0, 1, 0])
    lv = turtle("L F L(0.3) [F L]")["leaves"]
    assert [(x["address"], x["branch"], x["area"]) for x in lv] == [("2", 0, 0.3), ("5", 1, 0.01)]


def test_dollar_makes_x_horizontal():
    # h = Rz(30) Ry(45) e_z; x = z_w x h / |.| = (-sin 30, cos 30, 0)
    n = turtle("F/(30)+(45)$L")["leaves"][0]["normal"]
    assert close(n, [-0.5, math.sqrt(3) / 2, 0])
    # heading vertical: unchanged
    n = turtle("F/(30)$L")["leaves"][0]["normal"]
    assert close(n, [math.sqrt(3) / 2, 0.5, 0])
    # the heading itself is kept: next branch's tip unchanged by $
    with_dollar = turtle("F/(30)+(45)$F")["branches"][1]["tip"]
    without = turtle("F/(30)+(45)F")["branches"][1]["tip"]
    assert close(with_dollar, without)


def test_brackets_radius_and_parents():
    bs = turtle("F[+F][!(0.05)-F]F")["branches"]
    assert [b["parent"] for b in bs] == [-1, 0, 0, 0]
    assert [b["radius"] for b in bs] == [RADIUS, RADIUS, 0.05, RADIUS]
    assert close(bs[3]["base"], [0, 0, 1]) and close(bs[3]["tip"], [0, 0, 2])
    assert bs[3]["alpha"] == 0.0
    assert close(bs[1]["tip"], [1, 0, 1]) and close(bs[2]["tip"], [-1, 0, 1])
    # `!` alone does nothing; a setting lasts to the end of its bracket
    bs = turtle("!(0.1)F!F[!(0.2)F]F")["branches"]
    assert [b["radius"] for b in bs] == [0.1, 0.1, 0.2, 0.1]
    bs = turtle("[F]F")["branches"]
    assert [b["parent"] for b in bs] == [-1, -1] and close(bs[1]["base"], [0, 0, 0])


def test_parameters_overrides_and_suffixes():
    sys_ = make_system(branch_kwargs={"force_absorbed": 0.009},
                       overrides=[Override((2,), (("drag_coefficient", 0.003), ("length", 2.0))),
                                  Override((3,), (("area", 0.5),))])
    mods = [("F", (0.5,), "0"), ("F", (), "1"), ("F", (4.0,), "2"), ("L", (0.2,), "3"),
            ("F", (), "4"), ("F", (), "4"), ("F", (), "4")]
    out = reference_turtle(sys_, mods)
    bs = out["branches"]
    assert [b["length"] for b in bs] == [0.5, 1.0, 2.0, 1.0, 1.0, 1.0]
    assert [b["drag_coefficient"] for b in bs] == [C_D, C_D, 0.003, C_D, C_D, C_D]
    assert all(b["force_absorbed"] == 0.009 for b in bs)            # symbol beats header
    assert all(b["force_propagated"] == K_FP for b in bs)           # header default
    assert [b["address"] for b in bs] == ["0", "1", "2", "4", "4:1", "4:2"]
    assert out["leaves"][0]["area"] == 0.5
    assert close(bs[-1]["tip"], [0, 0, 6.5])


def test_zero_pose_reproduces_turtle():
    text = "F(0.7)[+(25)F/(40)L[&(60)f(0.3)F]^(20)F]-(10)F|F[\\(70)+(80)F$F]f(0.2)F"
    out = turtle(text, branching=35.0, rotation=50.0)
    tree = tree_from_reference(out)
    tree.check()
    b = tree.n_branches
    bases, tips, frames, swings = reference_pose(tree, [0.0] * b, [0.0] * b)
    for i, br in enumerate(out["branches"]):
        assert close(bases[i], br["base"]) and close(tips[i], br["tip"])
        assert close(frames[i], br["frame"])
        # at rest the swing frame is R_i Rz(-psi_i)
        assert close(swings[i], np.asarray(br["frame"]) @ rot_z(-br["psi"]))


# --- pose (model.md section 3) ----------------------------------------------------

def test_single_branch_bend_and_rotation():
    tree = make_tree([-1], [[0, 0, 0]])
    _, tips, _, _ = reference_pose(tree, [0.3], [0.0])
    assert close(tips[0], [math.sin(0.3), 0, math.cos(0.3)])
    _, tips, _, _ = reference_pose(tree, [0.0], [0.3])
    assert close(tips[0], [0, math.sin(0.3), math.cos(0.3)])
    th = 0.3 * math.sqrt(2)
    _, tips, frames, swings = reference_pose(tree, [0.3], [0.3])
    s = math.sin(th) / math.sqrt(2)
    assert close(tips[0], [s, s, math.cos(th)])
    # no twist: a rotation about the horizontal axis (-0.3, 0.3, 0)/|.|
    expected = Rotation.from_rotvec([-0.3, 0.3, 0.0]).as_matrix()
    assert close(frames[0], expected) and close(swings[0], expected)


def test_chain_and_offset_follow_parent():
    tree = make_tree([-1, 0], [[0, 0, 0], [0, 0, 0]], offset=[[0, 0, 0], [0, 0, 0.5]])
    bases, tips, _, _ = reference_pose(tree, [0.2, 0.1], [0.0, 0.0])
    assert close(bases[1], [1.5 * math.sin(0.2), 0, 1.5 * math.cos(0.2)])
    assert close(tips[1], [1.5 * math.sin(0.2) + math.sin(0.3), 0,
                           1.5 * math.cos(0.2) + math.cos(0.3)])


def test_bend_moves_away_from_parent_axis():
    a = math.pi / 6
    # '+' branch leaning toward +x (phi = 0): bending adds to alpha
    tree = make_tree([-1, 0], [[0, 0, 0], [0, a, 0]])
    _, tips, _, _ = reference_pose(tree, [0.0, 0.1], [0.0, 0.0])
    assert close(tips[1], [math.sin(a + 0.1), 0, 1 + math.cos(a + 0.1)])
    # '-' branch (phi = psi = pi): leaning toward -x, bends further toward -x
    tree = make_tree([-1, 0], [[0, 0, 0], [math.pi, a, math.pi]])
    _, tips, _, _ = reference_pose(tree, [0.0, 0.1], [0.0, 0.0])
    assert close(tips[1], [-math.sin(a + 0.1), 0, 1 + math.cos(a + 0.1)])
    # branch turned 90 degrees about the parent (phi = pi/2): leans toward +y;
    # rotation swings it sideways toward -x (the swing frame's y = Rz(90) e_y)
    tree = make_tree([-1, 0], [[0, 0, 0], [math.pi / 2, a, 0]])
    _, tips, _, _ = reference_pose(tree, [0.0, 0.1], [0.0, 0.0])
    assert close(tips[1], [0, math.sin(a + 0.1), 1 + math.cos(a + 0.1)])
    _, tips, _, _ = reference_pose(tree, [0.0, 0.0], [0.0, 0.1])
    # Rz(90) Ry(a) Rx(-0.1) e_z = Rz(90) (cos0.1 sin a, sin 0.1, cos0.1 cos a)
    assert close(tips[1], [-math.sin(0.1), math.cos(0.1) * math.sin(a),
                           1 + math.cos(0.1) * math.cos(a)])


# --- simulation (model.md sections 3 and 4) ------------------------------------------

def constant_wind(v):
    return lambda t: v


def stalk_with_leaf():
    """One vertical branch, one leaf of area 0.01 facing +x."""
    return make_tree([-1], [[0, 0, 0]], leaves=[(0, 0.01, [1.0, 0.0, 0.0])])


def bend_push(theta, vx, area=0.01, s_l=1.0, k_fa=K_FA):
    """k_FA (F . S e_x) for the leafed vertical stalk bent by theta, wind (vx,0,0).

    Leaf normal n = (cos, 0, -sin) = S e_x: leaf part k_fp s_L A vx cos(theta);
    drag |axis x x^| = cos(theta), projected on S e_x another cos(theta).
    """
    lateral = 2 * math.pi * RADIUS * 1.0
    return k_fa * (K_FP * s_l * area * vx * math.cos(theta)
                   + C_D * vx * vx * lateral * math.cos(theta) ** 2)


def test_zero_wind_gives_exact_zeros():
    out = turtle("F[+FL][-F/(30)FL]FL")
    tree = tree_from_reference(out)
    bend, rot = reference_simulate(tree, 0.01, 50, constant_wind((0.0, 0.0, 0.0)))
    assert len(bend) == 51 and all(len(row) == tree.n_branches for row in bend)
    assert all(x == 0.0 for row in bend + rot for x in row)


def test_single_stalk_matches_scalar_recurrence():
    """Whole trajectory against the scalar form of the equations for this tree."""
    vx, dt, c, s_l = 60.0, 0.02, 0.05, 0.5
    tree = stalk_with_leaf()
    tree.leaf_force_scale = s_l
    bend, rot = reference_simulate(tree, dt, 200, constant_wind((vx, 0.0, 0.0)), damping=c)
    theta = vel = largest = 0.0
    for k in range(1, 201):
        vel = vel + bend_push(theta, vx, s_l=s_l) - theta * K_BS / 1000 - c * vel
        theta = theta + vel * dt
        assert abs(bend[k][0] - theta) < 1e-13
        assert rot[k][0] == 0.0
        largest = max(largest, theta)
    assert largest > 0.02        # a deflection large enough for the cosines to matter


def test_first_step_propagates_force_down_a_stalk():
    vx, dt = 3.0, 0.01
    tree = make_tree([-1, 0], [[0, 0, 0], [0, 0, 0]], leaves=[(1, 0.01, [1.0, 0.0, 0.0])])
    bend, rot = reference_simulate(tree, dt, 1, constant_wind((vx, 0.0, 0.0)))
    drag = C_D * vx ** 2 * 2 * math.pi * RADIUS * 1.0
    f_top = drag + K_FP * 0.01 * vx
    f_root = drag + K_FP * f_top
    assert abs(bend[1][1] - K_FA * f_top * dt) < 1e-16
    assert abs(bend[1][0] - K_FA * f_root * dt) < 1e-16
    assert rot[1] == [0.0, 0.0]


def test_first_step_sums_children_and_projects_on_swing_axes():
    """Root with a leaning child (alpha = 30 deg, no leaf) and a straight child with a leaf."""
    vx, dt, a = 4.0, 0.01, math.pi / 6
    tree = make_tree([-1, 0, 0], [[0, 0, 0], [0, a, 0], [0, 0, 0]],
                     leaves=[(2, 0.02, [1.0, 0.0, 0.0])])
    bend, rot = reference_simulate(tree, dt, 1, constant_wind((vx, 0.0, 0.0)))
    drag_full = C_D * vx ** 2 * 2 * math.pi * RADIUS * 1.0
    f_lean = drag_full * math.cos(a)               # |axis x x^| = cos 30 deg, along +x
    f_straight = drag_full + K_FP * 0.02 * vx
    f_root = drag_full + K_FP * (f_lean + f_straight)
    assert abs(bend[1][0] - K_FA * f_root * dt) < 1e-16
    assert abs(bend[1][1] - K_FA * f_lean * math.cos(a) * dt) < 1e-16   # S e_x = Ry(30) e_x
    assert abs(bend[1][2] - K_FA * f_straight * dt) < 1e-16
    assert rot[1] == [0.0, 0.0, 0.0]


def test_leaf_normal_turns_with_branch_roll():
    """A rolled branch (psi = 90 deg, as drawn by '/(90)F') carries its leaf normal to +y."""
    vy, dt = 3.0, 0.01
    tree = make_tree([-1], [[0, 0, math.pi / 2]], leaves=[(0, 0.01, [1.0, 0.0, 0.0])])
    bend, rot = reference_simulate(tree, dt, 1, constant_wind((0.0, vy, 0.0)))
    force = C_D * vy ** 2 * 2 * math.pi * RADIUS + K_FP * 0.01 * vy
    assert abs(rot[1][0] - K_FA * force * dt) < 1e-16
    assert abs(bend[1][0]) < 1e-20


def test_wind_sampled_at_start_of_each_step():
    times = []

    def gust(t):
        times.append(t)
        return (5.0, 0.0, 0.0) if t == 0.0 else (0.0, 0.0, 0.0)

    bend, _ = reference_simulate(stalk_with_leaf(), 0.25, 4, gust)
    assert times == [0.0, 0.25, 0.5, 0.75]
    v1 = bend_push(0.0, 5.0)                 # step 1 already uses V(t0)
    assert abs(bend[1][0] - v1 * 0.25) < 1e-16
    v2 = v1 - bend[1][0] * K_BS / 1000       # no wind afterwards: spring only
    assert abs(bend[2][0] - (bend[1][0] + v2 * 0.25)) < 1e-16


def test_damped_equilibrium_small_force():
    vx, dt, c = 2.0, 0.1, 0.3                # s = k_bs dt / 1000 = 0.02
    bend, _ = reference_simulate(stalk_with_leaf(), dt, 400, constant_wind((vx, 0.0, 0.0)), damping=c)
    force = K_FP * 0.01 * vx + C_D * vx ** 2 * 2 * math.pi * RADIUS   # F . e_x at rest
    expected = 1000 * K_FA * force / K_BS
    assert abs(bend[-1][0] - expected) < 1e-6 * expected
    assert abs(bend[-1][0] - bend[-2][0]) < 1e-12


def test_damped_equilibrium_large_force_follows_pose():
    """The force turns with the branch: equilibrium solves theta = 1000 push(theta) / k_bs."""
    vx, dt, c, k_fa = 30.0, 0.1, 0.3, 0.4
    tree = make_tree([-1], [[0, 0, 0]], leaves=[(0, 0.01, [1.0, 0.0, 0.0])], k_fa=k_fa)
    bend, _ = reference_simulate(tree, dt, 600, constant_wind((vx, 0.0, 0.0)), damping=c)
    lo, hi = 0.0, math.pi / 2                # bisection on a monotone function
    for _ in range(200):
        mid = (lo + hi) / 2
        if mid - 1000 * bend_push(mid, vx, k_fa=k_fa) / K_BS < 0:
            lo = mid
        else:
            hi = mid
    assert abs(bend[-1][0] - lo) < 1e-9
    linear = 1000 * bend_push(0.0, vx, k_fa=k_fa) / K_BS
    assert lo < 0.9 * linear                 # the cosine factors matter at this size


def test_undamped_oscillation_closed_form_and_period():
    vx, dt, steps = 1.0, 0.1, 400
    s = K_BS * dt / 1000
    bend, _ = reference_simulate(stalk_with_leaf(), dt, steps, constant_wind((vx, 0.0, 0.0)))
    # linear recurrence th_k = (2 - s) th_{k-1} - th_{k-2} + s th*, th_0 = 0, th_1 = s th*
    th_star = 1000 * bend_push(0.0, vx) / K_BS
    w = math.acos(1 - s / 2)
    for k in range(steps + 1):
        exact = th_star * (1 - math.cos(k * w) + s / (2 * math.sin(w)) * math.sin(k * w))
        assert abs(bend[k][0] - exact) < 1e-6 * th_star
    # period from upward crossings of the mean (model.md 6), against 2 pi dt / arccos(1 - s/2)
    x = [row[0] for row in bend]
    mean = sum(x) / len(x)
    crossings = [(k - 1 + (mean - x[k - 1]) / (x[k] - x[k - 1])) * dt
                 for k in range(1, len(x)) if x[k - 1] < mean <= x[k]]
    period = (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    assert len(crossings) >= 5
    assert abs(period - 2 * math.pi * dt / w) < 0.005 * period


def test_rotation_answers_wind_along_y():
    vy, dt, c = 2.0, 0.1, 0.3
    tree = make_tree([-1], [[0, 0, 0]], leaves=[(0, 0.01, [0.0, 1.0, 0.0])])
    bend, rot = reference_simulate(tree, dt, 400, constant_wind((0.0, vy, 0.0)), damping=c)
    assert all(row[0] == 0.0 for row in bend)
    force = K_FP * 0.01 * vy + C_D * vy ** 2 * 2 * math.pi * RADIUS
    expected = 1000 * K_FA * force / K_RS    # k_rs, not k_bs
    assert abs(rot[-1][0] - expected) < 1e-6 * expected
    _, tips, _, _ = reference_pose(tree, [0.0], rot[-1])
    assert tips[0][1] > 0 and abs(tips[0][0]) < 1e-15   # swung toward +y
