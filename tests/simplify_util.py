"""Shared helpers of the simplify tests: level-n cases, settled runs, the counted-component check.

Imported top-level by the test modules (tests/ is on pytest's path, as for
`golden_util` and `treegen`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from plantlod.formats.lsys_file import read_lsys, write_lsys
from plantlod.lsys.build import build
from plantlod.lsys.parse import parse_lsys
from plantlod.simplify.targets import group_map
from plantlod.compare.groups import combined_angles
from plantlod.simplify.levels import level_system, write_parameters
from plantlod.sim.run import simulate_arrays

DT = 0.01
SETTLE_STEPS = 3000       # damping 0.02 per step: transients fall by ~e^-30
DAMPING = 0.02


def assert_close_where_counted(got, want, rtol):
    """Relative agreement on the components that section 6 counts (>= 1 % of the largest);
    at least 10 of them, so the check cannot pass on an almost empty selection."""
    counted = np.abs(want) >= 0.01 * np.abs(want).max()
    assert counted.sum() >= 10
    assert np.max(np.abs(got - want)[counted] / np.abs(want)[counted]) < rtol


def settled(tree, wind):
    """(bend, rot) (B,) at the end of a damped run in ``wind`` (a sim.wind object): the
    static angles (damping changes no equilibrium)."""
    s = simulate_arrays(tree, DT, SETTLE_STEPS, wind, every=SETTLE_STEPS, damping=DAMPING)
    return s.bend[-1], s.rot[-1]


def settled_combined(original, gmap, wind):
    """The original's settled combined angles (G, 2) in ``wind``."""
    b, r = settled(original, wind)
    cb, cr = combined_angles(original, gmap.paths, b, r)
    return np.stack([cb, cr], axis=-1)


def level_case(system, level=1):
    """(original tree, level-n skeleton system with equivalent leaves, its tree, group map)."""
    original = build(system).tree
    skeleton, _ = level_system(system, level, equivalent_leaves=True)
    skel_tree = build(skeleton).tree
    return original, skeleton, skel_tree, group_map(original, skel_tree)


def small_case(name, steps, level=1):
    """`level_case` of examples/NAME.lsys derived only ``steps`` steps (a small tree)."""
    system = replace(read_lsys(f"examples/{name}.lsys"), derivation_length=steps)
    return level_case(system, level)


def written_tree(skeleton, params):
    """The tree of the file `write_parameters` makes of ``params``, read back through its text."""
    text = write_lsys(write_parameters(skeleton, params.branch, params.leaf_areas))
    return build(parse_lsys(text)).tree
