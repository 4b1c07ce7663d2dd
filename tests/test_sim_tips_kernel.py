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


def test_tips_refuse_angles_of_the_wrong_shape():
    tree = build(parse_lsys((ROOT / "examples" / "stalk8.lsys").read_text(), "s")).tree
    with pytest.raises(ValueError):
        tips(tree, np.zeros((2, 3)), np.zeros((2, 3)), np.arange(2))
