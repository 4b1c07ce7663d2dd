"""The compiled tips (sim/tips_kernel.py) against the numpy pose of model.md section 3."""

from __future__ import annotations

import numpy as np
import pytest

from golden_util import ROOT
from plantlod.lsys.build import build
from plantlod.lsys.parse import parse_lsys
from plantlod.sim.kinematics import pose
from plantlod.sim.tips_kernel import tips


@pytest.mark.parametrize("name", ["eval/bush3d.lsys", "eval/sympodial.lsys", "abop_1_25.lsys"])
def test_tips_equal_the_numpy_pose(name):
    system = parse_lsys((ROOT / "examples" / name).read_text(), name)
    tree = build(system).tree
    rng = np.random.default_rng(5)
    bend = rng.uniform(-0.4, 0.4, size=(7, tree.n_branches))
    rot = rng.uniform(-0.4, 0.4, size=(7, tree.n_branches))
    rot[0] = bend[0] = 0.0                                  # rest, and theta = 0 exactly
    which = rng.choice(tree.n_branches, size=min(50, tree.n_branches), replace=False)
    expected = pose(tree, bend, rot).tip[:, which]
    np.testing.assert_allclose(tips(tree, bend, rot, which), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("count", [1, 5, 40])
def test_tips_of_a_few_branches_walk_only_their_ancestors_and_agree_bit_for_bit(count):
    from plantlod.sim.tips_kernel import ancestors_of

    tree = build(parse_lsys((ROOT / "examples" / "abop_1_25.lsys").read_text(), "t")).tree
    rng = np.random.default_rng(count)
    bend = rng.uniform(-0.4, 0.4, size=(5, tree.n_branches))
    rot = rng.uniform(-0.4, 0.4, size=(5, tree.n_branches))
    which = rng.choice(tree.n_branches, size=count, replace=False)
    keep = ancestors_of(np.asarray(tree.parent), which)
    # the closure by a slow walk up from each branch
    slow = set()
    for b in which:
        while b >= 0:
            slow.add(int(b))
            b = int(tree.parent[b])
    assert keep.tolist() == sorted(slow) and len(keep) < tree.n_branches
    everything = tips(tree, bend, rot, np.arange(tree.n_branches))
    np.testing.assert_array_equal(tips(tree, bend, rot, which), everything[:, which])


def test_tips_refuse_angles_of_the_wrong_shape():
    tree = build(parse_lsys((ROOT / "examples" / "stalk8.lsys").read_text(), "s")).tree
    with pytest.raises(ValueError):
        tips(tree, np.zeros((2, 3)), np.zeros((2, 3)), np.arange(2))


def test_float32_runs_give_the_tips_of_their_float64_copies_bit_for_bit():
    """`evaluate.Runs` keeps the original's runs in float32 and reads them without a float64
    copy: the kernel widens each angle itself (exact), for every branch and for a few."""
    tree = build(parse_lsys((ROOT / "examples" / "abop_1_25.lsys").read_text(), "t")).tree
    rng = np.random.default_rng(8)
    bend = rng.uniform(-0.4, 0.4, size=(6, tree.n_branches)).astype(np.float32)
    rot = rng.uniform(-0.4, 0.4, size=(6, tree.n_branches)).astype(np.float32)
    for which in (np.arange(tree.n_branches), rng.choice(tree.n_branches, 7, replace=False)):
        wide = tips(tree, bend.astype(np.float64), rot.astype(np.float64), which)
        assert np.array_equal(tips(tree, bend, rot, which), wide)
