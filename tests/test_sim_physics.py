"""The simulation's physics against closed forms and hand computations.

Nothing here compares the code with its own earlier output: expected values
come from the linear recurrence of model.md section 4 (period, equilibrium,
amplitude, stability limit), from scalar equations solved with scipy, from
first steps worked out by hand, and from mirror symmetry.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from plantlod.lsys.errors import InputError
from plantlod.sim import kernel
from plantlod.sim.kinematics import pose, rest_height
from plantlod.sim.run import simulate_arrays
from plantlod.sim.stability import check_stability, largest_stable_dt
from plantlod.sim.wind import ConstantWind, GustyWind, KeyframeWind, wind_from_speed

from reference_model import reference_pose
from treegen import make_tree, random_trees, stalk, y_tree

DT = 0.01


def upward_crossings(x: np.ndarray, level: float, dt: float) -> np.ndarray:
    """Times where x rises through ``level`` (x[k-1] < level <= x[k]), linearly interpolated."""
    k = np.flatnonzero((x[:-1] < level) & (x[1:] >= level)) + 1
    frac = (level - x[k - 1]) / (x[k] - x[k - 1])
    return (k - 1 + frac) * dt


def one_leaf_branch(k_bs=100.0, k_rs=100.0, k_fa=0.01, area=0.01, normal=(1.0, 0.0, 0.0)):
    """A vertical branch with a leaf of the given normal and no drag (k_fp = 1)."""
    return stalk(1, bend_strength=k_bs, rotation_strength=k_rs, force_absorbed=k_fa,
                 force_propagated=1.0, drag_coefficient=0.0, leaf_area=area, leaf_normal=normal)


# --- a single branch under a (nearly) constant force ------------------------------------

@pytest.mark.parametrize("axis", ["bend", "rot"])
def test_single_branch_period_equilibrium_and_amplitude(axis):
    # Leaf normal along the swing axis being driven, wind along it: the force
    # along that axis is k_fp A v cos(theta) ~ A v for theta ~ 1e-3 rad.
    k = 100.0 if axis == "bend" else 250.0
    other = 170.0
    area, v, k_fa = 0.01, 1.0, 0.01
    if axis == "bend":
        tree = one_leaf_branch(k_bs=k, k_rs=other, k_fa=k_fa, area=area, normal=(1, 0, 0))
        wind = ConstantWind((v, 0.0, 0.0))
    else:
        tree = one_leaf_branch(k_bs=other, k_rs=k, k_fa=k_fa, area=area, normal=(0, 1, 0))
        wind = ConstantWind((0.0, v, 0.0))
    steps = 40_000
    out = simulate_arrays(tree, DT, steps, wind)
    x = (out.bend if axis == "bend" else out.rot)[:, 0]
    quiet = out.rot if axis == "bend" else out.bend
    assert np.abs(quiet).max() <= 1e-15

    s = k * DT / 1000.0
    period = 2 * math.pi * DT / math.acos(1 - s / 2)          # model.md section 4
    equilibrium = 1000.0 * k_fa * area * v / k
    amplitude = equilibrium * 2.0 / math.sqrt(4.0 - s)        # from x_0 = 0, v_0 = 0

    crossings = upward_crossings(x, x.mean(), DT)
    assert len(crossings) > 150
    measured = (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    assert measured == pytest.approx(period, rel=1e-5)
    assert (x.max() + x.min()) / 2 == pytest.approx(equilibrium, rel=1e-3)
    assert (x.max() - x.min()) / 2 == pytest.approx(amplitude, rel=1e-3)


def test_damped_period_matches_the_damped_recurrence():
    # theta_k = (2 - c - s) theta_{k-1} - (1 - c) theta_{k-2} + g dt: roots
    # sqrt(1 - c) exp(+-i w) with cos w = (2 - c - s) / (2 sqrt(1 - c)), so
    # the crossings of the equilibrium are 2 pi dt / w apart. c = 0.1 and
    # s = 0.02 make that 4.5 % longer than the undamped period.
    c, k = 0.1, 2000.0
    tree = one_leaf_branch(k_bs=k)
    out = simulate_arrays(tree, DT, 300, ConstantWind((1.0, 0.0, 0.0)), damping=c)
    s = k * DT / 1000.0
    w = math.acos((2 - c - s) / (2 * math.sqrt(1 - c)))
    equilibrium = 1000.0 * 0.01 * 0.01 * 1.0 / k
    crossings = upward_crossings(out.bend[:, 0], equilibrium, DT)[:6]
    measured = (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    assert measured == pytest.approx(2 * math.pi * DT / w, rel=5e-4)
    assert measured > 1.04 * 2 * math.pi * DT / math.acos(1 - s / 2)
    assert out.bend[-1, 0] == pytest.approx(equilibrium, rel=1e-5)   # 0.95^300 of the start left


def test_damped_leaf_equilibrium_solves_the_nonlinear_balance():
    # n^ = S e_x turns with the branch: the bend force is k_fp A v cos(theta),
    # so the rest point solves theta = G cos(theta), G = 1000 k_FA A v / k_bs.
    k, k_fa, area, v = 100.0, 0.08, 0.1, 10.0
    tree = one_leaf_branch(k_bs=k, k_fa=k_fa, area=area)
    out = simulate_arrays(tree, DT, 2000, ConstantWind((v, 0.0, 0.0)), damping=0.1)
    g = 1000.0 * k_fa * area * v / k
    theta = brentq(lambda t: t - g * math.cos(t), 0.0, math.pi / 2, xtol=1e-15)
    assert out.bend[-1, 0] == pytest.approx(theta, abs=1e-9)
    assert theta < 0.9 * g            # the cosine matters: not the linear answer


def test_damped_drag_equilibrium_uses_lateral_area_and_sine():
    # No leaves; wind along x. Drag C_d v^2 (2 pi r L) |z x V^| V^ with
    # |z x x^| = cos(theta) and V^ . S e_x = cos(theta): theta = G cos^2(theta).
    k, k_fa, c_d, r, length, v = 120.0, 0.9, 0.0015, 0.05, 1.3, 10.0
    tree = make_tree([-1], length=length, radius=r, drag_coefficient=c_d, bend_strength=k,
                     rotation_strength=k, force_absorbed=k_fa)
    out = simulate_arrays(tree, DT, 2500, ConstantWind((v, 0.0, 0.0)), damping=0.1)
    g = 1000.0 * k_fa * c_d * v**2 * 2 * math.pi * r * length / k
    theta = brentq(lambda t: t - g * math.cos(t) ** 2, 0.0, math.pi / 2, xtol=1e-15)
    assert out.bend[-1, 0] == pytest.approx(theta, abs=1e-9)
    assert abs(out.rot[-1, 0]) <= 1e-15


# --- first steps by hand ---------------------------------------------------------------

def test_first_step_propagates_leaf_force_with_k_fp_per_node():
    # Two stacked branches, leaf (normal e_x) on the top one, no drag, s_L = 1.5.
    # Step 1 from rest: vb = k_FA F . e_x, theta = dt vb, with
    # F_top = k_fp s_L A v and F_bottom = k_fp F_top.
    k_fa, k_fp, area, v, s_l = 0.03, 0.6, 0.02, 4.0, 1.5
    tree = stalk(2, force_absorbed=k_fa, force_propagated=k_fp, drag_coefficient=0.0,
                 leaf_area=area, leaf_force_scale=s_l)
    out = simulate_arrays(tree, DT, 1, ConstantWind((v, 0.0, 0.0)))
    top = DT * k_fa * k_fp * s_l * area * v
    assert out.bend[1].tolist() == pytest.approx([top * k_fp, top], rel=1e-14)
    assert out.rot[1].tolist() == [0.0, 0.0]


@pytest.mark.parametrize("wind,bend_factor,rot_factor", [
    ((3.0, 0.0, 0.0), 1.0, 0.0),
    ((0.0, 3.0, 0.0), 0.0, 1.0),
    # 3 m/s tilted 30 degrees up from +x: |z x V^| = cos 30, V^ . e_x = cos 30
    ((3.0 * math.cos(math.pi / 6), 0.0, 3.0 * math.sin(math.pi / 6)), 0.75, 0.0),
    ((0.0, 0.0, 3.0), 0.0, 0.0),      # along the branch: no drag at all
])
def test_first_step_drag_by_hand(wind, bend_factor, rot_factor):
    k_fa, c_d, r, length = 0.2, 0.004, 0.03, 1.7
    tree = make_tree([-1], length=length, radius=r, drag_coefficient=c_d, force_absorbed=k_fa)
    out = simulate_arrays(tree, DT, 1, ConstantWind(wind))
    drag = c_d * 9.0 * 2 * math.pi * r * length          # v^2 = 9
    assert out.bend[1, 0] == pytest.approx(DT * k_fa * drag * bend_factor, rel=1e-13, abs=1e-300)
    assert out.rot[1, 0] == pytest.approx(DT * k_fa * drag * rot_factor, rel=1e-13, abs=1e-300)


def test_step_k_uses_the_wind_at_the_start_of_the_step():
    # Wind 0 at t0 and 2 m/s from t1 = dt on: step 1 sees no wind, step 2
    # is the first step of a constant 2 m/s run.
    tree = one_leaf_branch()
    ramp = KeyframeWind([0.0, DT], [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    ramped = simulate_arrays(tree, DT, 5, ramp)
    steady = simulate_arrays(tree, DT, 4, ConstantWind((2.0, 0.0, 0.0)))
    assert ramped.bend[1, 0] == 0.0
    np.testing.assert_array_equal(ramped.bend[1:, 0], steady.bend[:, 0])


# --- zero wind and symmetry ---------------------------------------------------------

@settings(max_examples=25, deadline=None)
@given(tree=random_trees(), damping=st.sampled_from([0.0, 0.5]))
def test_zero_wind_leaves_every_angle_exactly_zero(tree, damping):
    out = simulate_arrays(tree, DT, 30, ConstantWind((0.0, 0.0, 0.0)), damping=damping)
    assert not out.bend.any() and not out.rot.any()


def symmetric_y_tree():
    return y_tree(math.radians(35), bend_strength=[80.0, 120.0, 120.0],
                  rotation_strength=[90.0, 60.0, 60.0], force_absorbed=0.3,
                  drag_coefficient=0.05, leaf_area=0.05)


def test_wind_across_the_y_plane_moves_mirror_branches_symmetrically():
    # The Y lies in the xz-plane; x -> -x swaps its arms and keeps a wind
    # along y. Mirror arms bend alike and swing sideways the same way in the
    # world, which is opposite rotation angles (their swing y axes are opposite).
    wind = GustyWind(wind_from_speed(6.0, 90.0), seed=5, strength=0.4)
    out = simulate_arrays(symmetric_y_tree(), DT, 400, wind)
    assert np.abs(out.rot[:, 1]).max() > 0.05 and np.abs(out.bend[:, 1]).max() > 0.01
    np.testing.assert_allclose(out.bend[:, 1], out.bend[:, 2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.rot[:, 1], -out.rot[:, 2], rtol=0, atol=1e-12)
    assert np.abs(out.bend[:, 0]).max() <= 1e-12      # the trunk does not lean along x


def test_wind_in_the_y_plane_gives_no_sideways_swing():
    # y -> -y maps every branch to itself and keeps a wind along x.
    wind = GustyWind(wind_from_speed(6.0, 0.0), seed=5, strength=0.4)
    out = simulate_arrays(symmetric_y_tree(), DT, 400, wind)
    assert np.abs(out.bend).max() > 0.05
    assert np.abs(out.rot).max() <= 1e-12


# --- stability -------------------------------------------------------------------------

def test_largest_stable_dt_by_hand():
    tree = y_tree(bend_strength=[100.0, 200.0, 150.0], rotation_strength=[250.0, 50.0, 50.0])
    assert largest_stable_dt(tree, 0.0) == pytest.approx(4000.0 / 250.0)
    assert largest_stable_dt(tree, 0.5) == pytest.approx(3000.0 / 250.0)
    assert largest_stable_dt(make_tree([]), 0.0) == math.inf


def test_stability_refusal_names_symbol_address_and_dt():
    tree = make_tree([-1, 0, 0], bend_strength=[100.0, 200.0, 5000.0],
                     address=["0", "0.1", "0.2"], symbol=["F", "F", "G"])
    check_stability(tree, 0.79, 0.0)                       # s = 3.95 < 4
    with pytest.raises(InputError) as err:
        check_stability(tree, 0.8, 0.0)                    # s = 4 for G
    message = str(err.value)
    assert "'G'" in message and "0.2" in message and "bend strength" in message
    assert "dt < 0.8 s" in message and "\n" not in message
    with pytest.raises(InputError, match="dt < 0.6 s"):
        check_stability(tree, 0.7, 0.5)                    # s = 3.5 >= 3


@pytest.mark.parametrize("kwargs,dt,damping,pattern", [
    ({"bend_strength": [100.0, 0.0]}, 0.01, 0.0, "bend strength k_bs 0; it must be"),
    ({"rotation_strength": [-5.0, 100.0]}, 0.01, 0.0, "rotation strength k_rs -5"),
    ({}, 0.01, 2.0, r"damping must be a number in \[0, 2\)"),
    ({}, 0.01, -0.1, "damping must be"),
    ({}, 0.0, 0.0, "time step dt must be"),
    ({}, math.nan, 0.0, "time step dt must be"),
])
def test_bad_strengths_damping_and_dt_are_refused(kwargs, dt, damping, pattern):
    tree = make_tree([-1, 0], **kwargs)
    with pytest.raises(InputError, match=pattern):
        check_stability(tree, dt, damping)


@pytest.mark.parametrize("damping", [0.0, 0.6])
def test_the_stability_limit_is_where_the_scheme_starts_to_grow(damping):
    # Drive one branch straight through the kernel (past the refusal) just
    # inside and just outside s = 4 - 2c: bounded versus exploding.
    limit_dt = largest_stable_dt(one_leaf_branch(k_bs=200.0, k_rs=200.0), damping)
    peaks = []
    for factor in (0.98, 1.02):
        tree = one_leaf_branch(k_bs=200.0, k_rs=200.0)
        model, state = kernel.prepare(tree, damping), kernel.KernelState(1)
        wind = np.tile([1.0, 0.0, 0.0], (3000, 1))
        out = np.empty((1, 1))
        kernel.advance(model, state, wind, factor * limit_dt, 1, 10**9, out, out.copy(), 0)
        peaks.append(abs(state.bend[0]))
    equilibrium = 1000.0 * 0.01 * 0.01 / 200.0
    assert peaks[0] < 10 * equilibrium
    assert not peaks[1] < 1e6 * equilibrium          # huge, inf or nan


# --- kinematics ------------------------------------------------------------------------

def test_bent_stalk_tips_lie_on_the_polygon_arc():
    n, theta = 5, 0.2
    tree = stalk(n, length=0.5)
    bend = pose(tree, np.full(n, theta), np.zeros(n))
    sideways = pose(tree, np.zeros(n), np.full(n, theta))
    k = np.arange(1, n + 1)
    arc = 0.5 * np.cumsum(np.stack([np.sin(k * theta), np.zeros(n), np.cos(k * theta)], axis=1), axis=0)
    np.testing.assert_allclose(bend.tip, arc, atol=1e-14)
    np.testing.assert_allclose(sideways.tip, arc[:, [1, 0, 2]], atol=1e-14)   # toward +y
    np.testing.assert_allclose(bend.base[1:], bend.tip[:-1], atol=0)


def test_a_branch_tilts_toward_bend_rot_without_twist():
    tree = stalk(1, length=2.0)
    b, r = 0.3, -0.4
    p = pose(tree, np.array([b]), np.array([r]))
    theta, beta = math.hypot(b, r), math.atan2(r, b)
    want = 2.0 * np.array([math.sin(theta) * math.cos(beta), math.sin(theta) * math.sin(beta),
                           math.cos(theta)])
    np.testing.assert_allclose(p.tip[0], want, atol=1e-15)
    axis = np.array([-r, b, 0.0])
    np.testing.assert_allclose(p.frame[0] @ axis, axis, atol=1e-15)   # turned about u only


def test_rest_pose_of_y_tree_and_offsets_by_hand():
    d = math.radians(35)
    tree = y_tree(d)
    p = pose(tree, np.zeros(3), np.zeros(3))
    np.testing.assert_allclose(p.tip, [[0, 0, 1], [math.sin(d), 0, 1 + math.cos(d)],
                                       [-math.sin(d), 0, 1 + math.cos(d)]], atol=1e-15)
    assert rest_height(tree) == pytest.approx(1 + math.cos(d), abs=1e-15)
    # A parent turned 90 degrees (its z axis along world x, its x axis along
    # world -z) and a child offset 0.5 along the parent's x.
    tilted = make_tree([-1, 0], [[0.0, math.pi / 2, 0.0], [0.0, 0.0, 0.0]],
                       offset=[[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])
    q = pose(tilted, np.zeros(2), np.zeros(2))
    np.testing.assert_allclose(q.base[1], [1.0, 0.0, -0.5], atol=1e-15)
    np.testing.assert_allclose(q.tip[1], [2.0, 0.0, -0.5], atol=1e-15)
    assert rest_height(stalk(4, length=0.25)) == pytest.approx(1.0)


@settings(max_examples=30, deadline=None)
@given(tree=random_trees(), data=st.data())
def test_pose_matches_reference_pose_and_batches(tree, data):
    b = tree.n_branches
    angles = st.lists(st.floats(-3, 3), min_size=b, max_size=b)
    bend = np.array([data.draw(angles) for _ in range(3)])
    rot = np.array([data.draw(angles) for _ in range(3)])
    batch = pose(tree, bend, rot)
    for t in range(3):
        base, tip, frames, swings = reference_pose(tree, bend[t].tolist(), rot[t].tolist())
        np.testing.assert_allclose(batch.base[t], np.array(base), atol=1e-12)
        np.testing.assert_allclose(batch.tip[t], np.array(tip), atol=1e-12)
        np.testing.assert_allclose(batch.frame[t], np.array(frames), atol=1e-12)
        np.testing.assert_allclose(batch.swing[t], np.array(swings), atol=1e-12)
        single = pose(tree, bend[t], rot[t])
        np.testing.assert_array_equal(single.tip, batch.tip[t])



def test_a_tilt_past_the_limit_reads_past_it():
    """"tilts 1 rad … beyond 1 rad" read as no excess (session 42): the tilt is shown with
    as many digits as show it above the limit, 3 at least."""
    from plantlod.sim.angle_range import LargeAngle

    for tilt, shown in ((1.0004, "1.0004"), (1.2345, "1.23"), (57.29578, "57.3")):
        message = LargeAngle(time=2.5, address="0.1", tilt=tilt).message("a.csv")
        assert message.startswith(f"a.csv: branch 0.1 tilts {shown} rad at t = 2.5 s, "
                                  "beyond 1 rad")
