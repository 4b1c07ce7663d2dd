"""The swing roll of a level's branch (docs/model.md, "Swing roll"): its swing frame turned about
its rest axis by β, S = R_parent Rz(φ) Ry(α) Rz(β) Rot(u, θ), its branch frame unchanged.

The kernels, the lanes engine, poses and tips are checked against the literal reference model
(tests/reference_model.py, extended by the one rotation), the parser against the key's rules,
and the tree file and archive against a round trip.
"""

from __future__ import annotations

import io
import math
import re
from dataclasses import replace

import numpy as np
import pytest

from plantlod.formats import npz, treefile
from plantlod.lsys.build import build
from plantlod.lsys.errors import InputError
from plantlod.lsys.parse import parse_lsys
from plantlod.sim.kinematics import pose, rest_pose
from plantlod.sim.lanes import LaneModel, run_lanes
from plantlod.sim.run import simulate_arrays
from plantlod.sim.tips_kernel import tips
from plantlod.sim.wind import ConstantWind

from reference_model import reference_pose, reference_simulate

ROLL_TREE = """\
name: rolls
derivation_length: 0
branching_angle: 30
force_absorbed: 0.01
force_propagated: 0.7
branch F: length=1 radius=0.02 bend_strength=100 rotation_strength=40
leaf L: area=0.01
axiom: F[+F L][-/(70)F L]F L
overrides:
  0: swing_roll=25
  3: swing_roll=-40 g_bx=0.01 g_by=0.004 g_bz=0.003 g_rx=-0.002 g_ry=0.012 g_rz=0.005
  9: swing_roll=110
"""


def roll_tree():
    return build(parse_lsys(ROLL_TREE, "rolls.lsys")).tree


def test_swing_roll_key_sets_radians_and_only_where_given():
    tree = roll_tree()
    expected = {"0": 25.0, "3": -40.0, "9": 110.0}
    for i, address in enumerate(tree.address):
        assert tree.swing_roll[i] == math.radians(expected.get(address, 0.0))
    plain = build(parse_lsys(ROLL_TREE.split("overrides:")[0], "plain.lsys")).tree
    assert plain.swing_roll is None


def test_swing_roll_is_not_a_declaration_key():
    text = ROLL_TREE.replace("rotation_strength=40", "rotation_strength=40 swing_roll=10")
    with pytest.raises(InputError, match="unknown key 'swing_roll'"):
        parse_lsys(text, "bad.lsys")


def test_a_swing_roll_leaves_the_rest_pose_and_turns_the_swing_frames():
    tree = roll_tree()
    plain = build(parse_lsys(ROLL_TREE.split("overrides:")[0], "plain.lsys")).tree
    rolled, unrolled = rest_pose(tree), rest_pose(plain)
    for field in ("frame", "base", "tip"):
        np.testing.assert_allclose(getattr(rolled, field), getattr(unrolled, field), atol=1e-12)
    turn = np.einsum("bji,bjk->bik", unrolled.swing, rolled.swing)
    np.testing.assert_allclose(turn[:, 0, 0], np.cos(tree.swing_roll), atol=1e-12)
    np.testing.assert_allclose(turn[:, 1, 0], np.sin(tree.swing_roll), atol=1e-12)


def test_poses_and_tips_match_the_reference_model():
    tree = roll_tree()
    rng = np.random.default_rng(3)
    bend, rot = rng.normal(0, 0.3, (2, tree.n_branches)), rng.normal(0, 0.3, (2, tree.n_branches))
    got = pose(tree, bend, rot)
    for k in range(2):
        bases, tip_ref, frames, swings = reference_pose(tree, bend[k], rot[k])
        np.testing.assert_allclose(got.tip[k], tip_ref, atol=1e-12)
        np.testing.assert_allclose(got.frame[k], frames, atol=1e-12)
        np.testing.assert_allclose(got.swing[k], swings, atol=1e-12)
    which = np.arange(tree.n_branches)
    np.testing.assert_allclose(tips(tree, bend, rot, which), got.tip, atol=1e-12)


def test_kernels_match_the_reference_model():
    tree = roll_tree()
    steps, dt, wind = 120, 0.01, (4.0, -2.0, 0.5)
    ref_b, ref_r = reference_simulate(tree, dt, steps, lambda t: wind)
    one = simulate_arrays(tree, dt, steps, ConstantWind(wind))
    np.testing.assert_allclose(one.bend, np.array(ref_b), rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(one.rot, np.array(ref_r), rtol=1e-9, atol=1e-13)
    bend, rot = run_lanes(LaneModel.from_tree(tree), [wind, (0.0, 3.0, 0.0)], dt, steps)
    assert np.array_equal(bend[0], one.bend[1:]) and np.array_equal(rot[0], one.rot[1:])
    # the roll matters: without it the same tree moves otherwise
    other = simulate_arrays(replace(tree, swing_roll=None), dt, steps, ConstantWind(wind))
    assert np.abs(other.bend - one.bend).max() > 1e-4


def test_tree_file_and_archive_keep_the_rolls():
    tree = roll_tree()
    text = "".join(treefile.iter_tree_lines(tree))
    assert '"swing_roll"' in text.splitlines()[0]            # the header lists the key
    again = treefile.read_tree(io.StringIO(text), "rolls.jsonl")
    np.testing.assert_array_equal(again.swing_roll, tree.swing_roll)
    archived = npz.read_tree_bytes(npz.tree_bytes(tree), "rolls.npz")
    np.testing.assert_array_equal(archived.swing_roll, tree.swing_roll)
    plain = replace(tree, swing_roll=None, force_gain=None)
    assert treefile.read_tree(io.StringIO("".join(treefile.iter_tree_lines(plain))),
                              "p.jsonl").swing_roll is None


def test_a_tree_file_refuses_a_roll_that_is_not_a_number():
    lines = "".join(treefile.iter_tree_lines(roll_tree())).splitlines(keepends=True)
    lines[2] = re.sub(r'"swing_roll": [-0-9.e]+', '"swing_roll": "x"', lines[2])
    with pytest.raises(InputError, match='"swing_roll" must be a number') as err:
        treefile.read_tree(io.StringIO("".join(lines)), "bad.jsonl")
    assert err.value.line == 3
