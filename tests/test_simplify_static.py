"""Static theory and closed-form parameters against simulations run to equilibrium and hand values.

The independent reference for a static angle is the simulation itself, run with
damping until it settles (damping changes no equilibrium: the velocity update
is 0 where 1000 k_FA F = k θ). Weak winds keep the angles small, where the
linear theory of simplify/static.py holds to second order in the angle.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from plantlod.formats.lsys_file import read_lsys
from plantlod.lsys.build import build
from plantlod.simplify.targets import group_map
from plantlod.simplify.closed_form import closed_form
from plantlod.simplify.levels import level_system, write_parameters
from plantlod.simplify.static import horizontal_directions, static_angles_at, static_parts
from plantlod.simplify.thesis import thesis_parameters
from plantlod.sim.wind import wind_from_speed
from simplify_util import (assert_close_where_counted, level_case, settled, settled_combined,
                           written_tree)

P = 0.7                   # stalk8's k_fp
KFA = 0.005               # stalk8's k_FA
CD = 0.0015               # stalk8's C_d


def simplified_stalk(level, system=None):
    system = read_lsys("examples/stalk8.lsys") if system is None else system
    original, skeleton, skeleton_tree, gmap = level_case(system, level)
    params = closed_form(original, skeleton_tree, gmap)
    out = write_parameters(skeleton, params.branch, params.leaf_areas)
    return original, build(out).tree, gmap, out


@pytest.mark.parametrize("name, steps, speed", [("stalk8", 3, 0.5), ("abop_1_24a", 2, 0.3),
                                                 ("abop_2_6", 4, 0.5)])
def test_static_theory_matches_settled_simulation(name, steps, speed):
    system = replace(read_lsys(f"examples/{name}.lsys"), derivation_length=steps)
    tree = build(system).tree
    directions = horizontal_directions(8)
    parts = static_parts(tree, directions)
    bend, rot = static_angles_at(tree, parts, speed)
    for k in (0, 1, 3):                           # 0, 45 and 135 degrees
        b, r = settled(tree, wind_from_speed(speed, 45.0 * k))
        scale = max(np.abs(b).max(), np.abs(r).max())
        np.testing.assert_allclose(bend[k], b, atol=1e-3 * scale)
        np.testing.assert_allclose(rot[k], r, atol=1e-3 * scale)


def test_stalk_closed_form_by_hand_level_1():
    # Group of 2 branches, leaf force X from above: the original's combined leaf angle is
    # a (p + p^2) X and its root passes p^2 X down. The simplified branch gives
    # κ' p' X: with p' = p^2 (the right force passed down), κ' = k_FA (1 + p) / p.
    # Drag d = C_d 2πrL per branch: the top group needs a(2 + p) d, so its drag area is
    # c' = p (2 + p) d / (1 + p); every lower group receives d / (1 + p) too little drag
    # from above and makes it up: c' = 2 p d. With L' = 2L: C_d' = c' / (2π r 2L).
    _, tree, _, out = simplified_stalk(1)
    np.testing.assert_array_equal(tree.length, [2, 2, 2, 2])
    np.testing.assert_array_equal(tree.bend_strength, [20, 20, 20, 20])
    np.testing.assert_allclose(tree.force_absorbed, KFA * (1 + P) / P, rtol=1e-11)
    np.testing.assert_allclose(tree.force_propagated, P ** 2, rtol=1e-11)
    top = CD * P * (2 + P) / (1 + P) / 2
    np.testing.assert_allclose(tree.drag_coefficient, [P * CD, P * CD, P * CD, top], rtol=1e-11)
    # one value per symbol where it suffices, an override for the top branch's drag
    assert [o.address for o in out.overrides] == [(0, 1, 1)]


def test_stalk_closed_form_level_2_passes_force_with_k_fp_to_the_fourth():
    # A merged chain of m = 4 branches attenuates what comes from above by p^4 (= p^(2^n)),
    # and its leaf angle is a (p + p^2 + p^3 + p^4) X.
    _, tree, _, _ = simplified_stalk(2)
    np.testing.assert_allclose(tree.force_propagated, P ** 4, rtol=1e-11)
    np.testing.assert_allclose(tree.force_absorbed, KFA * (P + P**2 + P**3 + P**4) / P**4,
                               rtol=1e-11)
    np.testing.assert_array_equal(tree.length, [4, 4])


@pytest.mark.parametrize("level", [1, 2])
@pytest.mark.parametrize("leaf_scale, speed", [(1.0, 0.5), (0.0, 3.0)])
def test_stalk_groups_settle_at_the_originals_combined_angles(level, leaf_scale, speed):
    # leaf_scale 0: drag only, so the v^2 part is checked on its own.
    system = replace(read_lsys("examples/stalk8.lsys"), leaf_force_scale=leaf_scale)
    original, tree, gmap, _ = simplified_stalk(level, system)
    for direction in (0.0, 90.0, 30.0):
        wind = wind_from_speed(speed, direction)
        want = settled_combined(original, gmap, wind)
        got = np.stack(settled(tree, wind), axis=-1)
        scale = np.abs(want).max()
        assert scale > 0
        np.testing.assert_allclose(got, want, atol=2e-3 * scale, rtol=2e-3)


def test_branching_level_1_settles_near_the_original():
    # abop_1_24a at N = 3 (125 branches): level 1 with equivalent leaves. The leaf part
    # is matched exactly; the drag part, tiny at 0.3 m/s, in the least-squares sense.
    system = replace(read_lsys("examples/abop_1_24a.lsys"), derivation_length=3)
    assert level_system(system, 1, equivalent_leaves=True)[1] == ["F"]
    original, skeleton, skeleton_tree, gmap = level_case(system)
    tree = written_tree(skeleton, closed_form(original, skeleton_tree, gmap))
    wind = wind_from_speed(0.3, 0.0)
    assert_close_where_counted(settled(tree, wind)[0], settled_combined(original, gmap, wind)[:, 0],
                               0.01)


@pytest.mark.parametrize("level", [1, 2])
def test_thesis_rules_by_hand(level):
    # Summed length 2^n, k_fp^(n+1), strengths, k_FA and C_d unchanged; the leaf force
    # scale makes the top group's leaf angle right: a p^(n+1) s A = a (p + ... + p^m) A.
    system = read_lsys("examples/stalk8.lsys")
    original = build(system).tree
    skeleton, _ = level_system(system, level, equivalent_leaves=False)
    skeleton_tree = build(skeleton).tree
    params, scale = thesis_parameters(original, skeleton_tree, group_map(original, skeleton_tree),
                                      level)
    m = 2 ** level
    np.testing.assert_allclose(params.branch["length"], m)
    np.testing.assert_allclose(params.branch["force_propagated"], P ** (level + 1), rtol=1e-12)
    assert set(params.branch) == {"length", "force_propagated"}
    assert scale == pytest.approx(sum(P ** j for j in range(1, m + 1)) / P ** (level + 1),
                                  rel=1e-9)


def test_turned_most_is_the_posed_turn_of_the_most_turned_axis():
    """`static.turned_most` (linear statics) against model.md 3's kinematics: the tree posed at
    EPS x its static angles, each branch's axis turned from its rest direction, over EPS."""
    from plantlod.lsys.parse import parse_lsys
    from plantlod.sim.kinematics import pose
    from plantlod.simplify.static import rest_frames, turned_most

    from test_grouping_terms import CHAIN

    text = CHAIN.replace("&(15) F /(40) G", "&(25) F [+(40) G L] /(40) G")   # a lateral too
    assert text != CHAIN
    tree = build(parse_lsys(text, "t.lsys")).tree
    frames = rest_frames(tree)
    az = np.radians([0.0, 37.0, 90.0, 200.0])
    directions = np.stack([np.cos(az), np.sin(az), np.zeros(4)], axis=1)
    speeds = [0.5, 3.0, 11.0, 20.0]
    eps = 1e-6
    rest = pose(tree, np.zeros(tree.n_branches), np.zeros(tree.n_branches))
    expected = []
    for d, v in zip(directions, speeds):
        parts = static_parts(tree, d[None], frames)
        bend, rot = static_angles_at(tree, parts, v, frames)
        posed = pose(tree, eps * bend[0], eps * rot[0])
        axis0 = rest.frame[:, :, 2]
        axis1 = posed.frame[:, :, 2]
        turn = np.linalg.norm(np.cross(axis0, axis1), axis=1) / eps
        expected.append(turn.max())
    assert turned_most(tree, directions, speeds) == pytest.approx(expected, rel=1e-4)
