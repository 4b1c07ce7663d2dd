"""Tilted winds: why simplify matches them, and that it does (docs/simplify.md, "Tilt").

When the branches below a group swing, they turn the whole group, and every
force in the model depends on orientations only: a subtree turned by a rotation
R feels exactly the forces a resting subtree feels in the wind R^T V. The
independent references are the simulation kernel (generalised forces read off
one step from a posed state) and simulations run with damping to equilibrium.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from plantlod.formats.lsys_file import read_lsys
from plantlod.lsys.build import build
from plantlod.sim.kernel import KernelState, advance, prepare
from plantlod.sim.kinematics import pose, rest_pose
from plantlod.sim.run import simulate_arrays
from plantlod.sim.wind import ConstantWind, wind_from_speed
from plantlod.simplify.closed_form import closed_form
from plantlod.compare.groups import combined_angles
from plantlod.compare.measures import amplitude
from plantlod.simplify.static import (fit_directions, static_angles, static_angles_at,
                                      static_parts, tilted_directions)

from simplify_util import DT, settled, settled_combined, small_case, written_tree
from test_simplify_static import simplified_stalk


def generalised_forces(tree, bend, rot, wind):
    """(F·S e_x, F·S e_y) (B,) each at the posed state, from one kernel step with zero velocity:
    the velocity after the step is k_FA f - θ k / 1000."""
    model = prepare(tree)
    state = KernelState(tree.n_branches)
    state.bend[:] = bend
    state.rot[:] = rot
    out = np.zeros((1, tree.n_branches))
    advance(model, state, np.asarray([wind], dtype=np.float64), DT, 1, 2, out, out.copy(), 0)
    kfa = np.asarray(tree.force_absorbed)
    fb = (state.bend_vel + bend * np.asarray(tree.bend_strength) / 1000.0) / kfa
    fr = (state.rot_vel + rot * np.asarray(tree.rotation_strength) / 1000.0) / kfa
    return fb, fr


def subtree(tree, root):
    inside = np.zeros(tree.n_branches, dtype=bool)
    inside[root] = True
    for i in range(root + 1, tree.n_branches):     # parents come before children
        if tree.parent[i] >= 0 and inside[tree.parent[i]]:
            inside[i] = True
    return inside


def test_tilted_directions_are_unit_vectors_at_the_elevation():
    d = tilted_directions(4, 0.2)
    assert d.shape == (8, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(np.arcsin(d[:, 2]), [0.2] * 4 + [-0.2] * 4, rtol=1e-14)
    np.testing.assert_allclose(np.degrees(np.arctan2(d[:4, 1], d[:4, 0])) % 360,
                               [0, 90, 180, 270], atol=1e-12)
    assert fit_directions(16, 8, 0.2).shape == (32, 3)
    assert fit_directions(16, 0, 0.2).shape == (16, 3)


@pytest.mark.parametrize("name, steps", [("abop_1_24a", 2), ("abop_2_6", 4), ("abop_1_24c", 2)])
def test_a_turned_subtree_feels_the_wind_turned_back(name, steps):
    system = replace(read_lsys(f"examples/{name}.lsys"), derivation_length=steps)
    tree = build(system).tree
    wind = np.array([3.0, 1.0, 0.0])
    # turn one branch with children by a bend and a rotation; everything above it turns too
    turned = next(i for i in range(tree.n_branches)
                  if tree.parent[i] >= 0 and np.sum(tree.parent == i) >= 2)
    bend = np.zeros(tree.n_branches)
    rot = np.zeros(tree.n_branches)
    bend[turned], rot[turned] = 0.3, -0.2
    fb, fr = generalised_forces(tree, bend, rot, wind)
    # the world rotation of the turned subtree, and the wind it sees at rest
    r = pose(tree, bend, rot).frame[turned] @ rest_pose(tree).frame[turned].T
    seen = r.T @ wind
    speed = float(np.linalg.norm(seen))
    parts = static_parts(tree, (seen / speed)[None])
    force = speed * parts.leaf + speed ** 2 * parts.drag                 # (1, B, 3)
    sb, sr = static_angles(tree, force)
    # static_angles gives 1000 k_FA f / k; undo the gain to compare forces
    gb = sb[0] * np.asarray(tree.bend_strength) / (1000.0 * np.asarray(tree.force_absorbed))
    gr = sr[0] * np.asarray(tree.rotation_strength) / (1000.0 * np.asarray(tree.force_absorbed))
    inside = subtree(tree, turned)
    assert inside.sum() >= 3
    scale = max(np.abs(fb[inside]).max(), np.abs(fr[inside]).max())
    np.testing.assert_allclose(fb[inside], gb[inside], atol=1e-12 * scale)
    np.testing.assert_allclose(fr[inside], gr[inside], atol=1e-12 * scale)
    # ...and it is not the horizontal wind's answer: the tilt matters
    horizontal = static_parts(tree, (wind / np.linalg.norm(wind))[None])
    hb, _ = static_angles(tree, np.linalg.norm(wind) * horizontal.leaf
                          + np.linalg.norm(wind) ** 2 * horizontal.drag)
    assert np.abs(hb[0] - sb[0])[inside].max() > 0.01 * np.abs(sb[0][inside]).max()


@pytest.mark.parametrize("name, steps", [("abop_1_24a", 2), ("abop_2_6", 4)])
def test_static_theory_holds_for_tilted_winds(name, steps):
    system = replace(read_lsys(f"examples/{name}.lsys"), derivation_length=steps)
    tree = build(system).tree
    directions = tilted_directions(2, 0.3)
    parts = static_parts(tree, directions)
    speed = 0.5
    bend, rot = static_angles_at(tree, parts, speed)
    for k in range(len(directions)):
        want = np.stack(settled(tree, ConstantWind(speed * directions[k])), axis=-1)
        np.testing.assert_allclose(np.stack([bend[k], rot[k]], axis=-1), want,
                                   atol=1e-3 * np.abs(want).max())


@pytest.mark.parametrize("level", [1, 2])
def test_stalk_groups_settle_right_in_tilted_winds(level):
    # a straight stalk is matched exactly in every direction, tilted ones included
    original, tree, gmap, _ = simplified_stalk(level)
    for elevation, azimuth in ((0.3, 0.0), (-0.4, 2.0)):
        v = 4.0 * np.array([math.cos(elevation) * math.cos(azimuth),
                            math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])
        want = settled_combined(original, gmap, ConstantWind(v))
        got = np.stack(settled(tree, ConstantWind(v)), axis=-1)
        np.testing.assert_allclose(got, want, atol=2e-3 * np.abs(want).max(), rtol=2e-3)


@pytest.mark.parametrize("name, steps", [("abop_1_24a", 4), ("abop_1_24c", 3)])
def test_level_1_sways_like_the_original_for_20_seconds(name, steps):
    # The level-1 target for branching trees (amplitude within 10 %), here with a
    # margin (5 %), over a whole 20 s run from rest, where the resonant drive of the tilt
    # has time to grow: 2 m/s toward 0 deg and 10 m/s toward 45 deg. (Measured: 0.09 % and
    # 1.25 % for abop_1_24a at N = 4, 1.5 % and 4.5 % for abop_1_24c at N = 3.)
    original, skeleton, skel_tree, gmap = small_case(name, steps)
    tree = written_tree(skeleton, closed_form(original, skel_tree, gmap))
    for speed, direction in ((2.0, 0.0), (10.0, 45.0)):
        wind = wind_from_speed(speed, direction)
        o = simulate_arrays(original, DT, 2000, wind, every=2)
        s = simulate_arrays(tree, DT, 2000, wind, every=2)
        cb, cr = combined_angles(original, gmap.paths, o.bend, o.rot)
        want = np.stack([amplitude(cb), amplitude(cr)], axis=-1)
        got = np.stack([amplitude(s.bend), amplitude(s.rot)], axis=-1)
        counted = want >= 0.01 * want.max()
        assert counted.sum() >= 50
        assert np.max(np.abs(got - want)[counted] / want[counted]) < 0.05
