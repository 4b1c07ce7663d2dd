"""The gain matrix of a level's branch (model.md 5) and the damping ratio (model.md 4).

Both kernels and the lanes engine are checked against the literal reference model
(tests/reference_model.py, which reads the equations as written), the damping ratio
against the continuous oscillator's decay, and the parser against the rules of the
gain keys (all six, never with force_absorbed).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from plantlod.formats.lsys_file import read_lsys
from plantlod.lsys.build import build
from plantlod.lsys.errors import InputError
from plantlod.lsys.parse import parse_lsys
from plantlod.sim.damping import Damping, as_damping
from plantlod.sim.lanes import LaneModel, run_lanes
from plantlod.sim.run import simulate_arrays
from plantlod.sim.stability import check_stability, largest_stable_dt
from plantlod.sim.wind import ConstantWind

from reference_model import reference_simulate

GAIN_TREE = """\
name: gains
derivation_length: 0
branching_angle: 30
force_absorbed: 0.01
force_propagated: 0.7
branch F: length=1 radius=0.02 bend_strength=100 rotation_strength=60
leaf L: area=0.01
axiom: F[+F L][-/(70)F L]F L
overrides:
  3: g_bx=0.01 g_by=0.004 g_bz=0.003 g_rx=-0.002 g_ry=0.012 g_rz=0.005
  9: g_bx=0.002 g_by=-0.001 g_bz=0.0 g_rx=0.0 g_ry=0.02 g_rz=-0.004
"""


def gain_tree():
    return build(parse_lsys(GAIN_TREE, "gains.lsys")).tree


def test_gain_keys_set_rows_and_replace_k_fa():
    tree = gain_tree()
    assert tree.force_gain is not None and tree.force_gain.shape == (4, 6)
    with_gain = [i for i, a in enumerate(tree.address) if a in ("3", "9")]
    assert len(with_gain) == 2
    for i in range(4):
        if i in with_gain:
            assert tree.force_absorbed[i] == 1.0
        else:
            assert tree.force_absorbed[i] == 0.01
            assert list(tree.force_gain[i]) == [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]


@pytest.mark.parametrize("line, message", [
    ("  3: g_bx=1 g_by=0 g_bz=0 g_rx=0 g_ry=1", "lacks g_rz"),
    ("  3: g_bx=1 g_by=0 g_bz=0 g_rx=0 g_ry=1 g_rz=0 force_absorbed=0.1", "both a gain matrix"),
])
def test_gain_keys_all_six_and_no_k_fa(line, message):
    text = GAIN_TREE.split("overrides:")[0] + "overrides:\n" + line + "\n"
    with pytest.raises(InputError, match=message) as err:
        parse_lsys(text, "bad.lsys")
    assert err.value.line == text.count("\n")     # the override's own line


@pytest.mark.parametrize("damping", [0.0, 0.05, Damping(ratio=0.07)])
def test_kernels_match_the_reference_model(damping):
    tree = gain_tree()
    steps, dt, wind = 120, 0.01, (4.0, -2.0, 0.5)
    ratio = damping.ratio if isinstance(damping, Damping) else None
    c = 0.0 if isinstance(damping, Damping) else damping
    ref_b, ref_r = reference_simulate(tree, dt, steps, lambda t: wind, damping=c,
                                      damping_ratio=ratio)
    one = simulate_arrays(tree, dt, steps, ConstantWind(wind), damping=damping)
    np.testing.assert_allclose(one.bend, np.array(ref_b), rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(one.rot, np.array(ref_r), rtol=1e-9, atol=1e-13)
    bend, rot = run_lanes(LaneModel.from_tree(tree, damping), [wind, (0.0, 3.0, 0.0)], dt, steps)
    assert np.array_equal(bend[0], one.bend[1:]) and np.array_equal(rot[0], one.rot[1:])


def test_identity_gain_is_the_original_model_bit_for_bit():
    """G = [[1, 0, 0], [0, 1, 0]] on every branch gives the same bits as k_FA alone."""
    tree = gain_tree()
    plain = build(parse_lsys(GAIN_TREE.split("overrides:")[0], "plain.lsys")).tree
    tree.force_gain[:] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
    tree.force_absorbed[:] = plain.force_absorbed
    a = simulate_arrays(tree, 0.01, 200, ConstantWind((5.0, 1.0, 0.0)))
    b = simulate_arrays(plain, 0.01, 200, ConstantWind((5.0, 1.0, 0.0)))
    assert np.array_equal(a.bend, b.bend) and np.array_equal(a.rot, b.rot)


# one branch with a gain matrix and one leaf (k_fp 1, no drag): its force is the leaf's
ONE_GAIN_BRANCH = """\
name: one
derivation_length: 0
branching_angle: 30
force_absorbed: 0.01
force_propagated: 1
drag_coefficient: 0
branch F: length=1 radius=0.02 bend_strength=200 rotation_strength=100
leaf L: area=0.02
axiom: F[/(30)+(50)L]
overrides:
  0: g_bx=0.004 g_by=0.003 g_bz=0.002 g_rx=0.001 g_ry=0.005 g_rz=-0.003
"""


def test_gain_static_angle_closed_form():
    """A single branch with G under a steady leaf force settles at 1000 G f / k per component."""
    tree = build(parse_lsys(ONE_GAIN_BRANCH, "one.lsys")).tree
    v = np.array([0.3, 0.2, 0.1])              # small: the frame barely moves
    n = np.asarray(tree.leaf_normal[0])        # branch frame = world at rest (no turn)
    f = 0.02 * (v @ n) * n                     # leaf force, k_fp = 1, S = I at rest
    g = tree.force_gain[0].reshape(2, 3)
    expect = 1000.0 * (g @ f) / np.array([200.0, 100.0])
    run = simulate_arrays(tree, 0.01, 20000, ConstantWind(v), damping=Damping(ratio=0.3))
    np.testing.assert_allclose([run.bend[-1, 0], run.rot[-1, 0]], expect, rtol=2e-3)
    # the linear statics read G too (simplify.static.angle_gains), exactly
    from plantlod.simplify.static import static_angles

    bend, rot = static_angles(tree, f[None, None, :])
    np.testing.assert_allclose([bend[0, 0], rot[0, 0]], expect, rtol=1e-12)


def test_damping_ratio_decays_like_the_continuous_oscillator():
    """A free swing's peaks fall by exp(-2 pi zeta / sqrt(1 - zeta^2)) per period."""
    text = """\
name: free
derivation_length: 0
branching_angle: 30
force_absorbed: 0.01
force_propagated: 0.7
branch F: length=1 radius=0.02 bend_strength=40 rotation_strength=40
leaf L: area=0.01
axiom: F L
"""
    tree = build(parse_lsys(text, "free.lsys")).tree
    dt, zeta = 0.01, 0.05
    # push for a few steps, then let it swing freely
    wind = np.zeros((6000, 3))
    wind[:5] = (30.0, 0.0, 0.0)
    from plantlod.sim.wind import KeyframeWind   # noqa: F401  (wind kinds are sim.wind's)
    bend, _ = run_lanes(LaneModel.from_tree(tree, Damping(ratio=zeta)), wind[None], dt, 6000)
    x = bend[0, 10:, 0]
    peaks = [x[k] for k in range(1, len(x) - 1) if x[k - 1] < x[k] >= x[k + 1] and x[k] > 0]
    ratios = np.array(peaks[1:6]) / np.array(peaks[:5])
    expect = math.exp(-2.0 * math.pi * zeta / math.sqrt(1.0 - zeta * zeta))
    np.testing.assert_allclose(ratios, expect, rtol=5e-3)


def test_damping_and_ratio_together_are_an_error():
    with pytest.raises(InputError, match="not both"):
        as_damping(0.1, 0.05)
    with pytest.raises(InputError, match="damping ratio"):
        as_damping(0.0, -0.1)


def test_stability_with_a_ratio():
    """The limit s + 4 zeta arccos(1 - s/2) < 4: just below it runs, at it is refused."""
    tree = gain_tree()
    d = Damping(ratio=0.1)
    limit = largest_stable_dt(tree, d)
    s = limit * 100.0 / 1000.0                       # k_max = 100
    assert abs(s + 4 * 0.1 * math.acos(1 - s / 2) - 4.0) < 1e-9
    check_stability(tree, limit * 0.999, d)
    with pytest.raises(InputError, match="time step too large"):
        check_stability(tree, limit * 1.001, d)
    assert limit < largest_stable_dt(tree, 0.0)


def test_example_file_reads(tmp_path):
    path = tmp_path / "g.lsys"
    path.write_text(GAIN_TREE)
    assert read_lsys(str(path)).overrides


def test_api_takes_a_damping_ratio():
    """plantlod.simulate(..., damping_ratio=) runs as the kernel does with Damping(ratio=)."""
    import plantlod

    tree = gain_tree()
    a = plantlod.simulate(tree, (3.0, 0.0, 0.0), dt=0.01, steps=50, damping_ratio=0.05)
    b = simulate_arrays(tree, 0.01, 50, ConstantWind((3.0, 0.0, 0.0)), damping=Damping(ratio=0.05))
    assert np.array_equal(a.bend, b.bend)
    with pytest.raises(InputError, match="not both"):
        plantlod.simulate(tree, (3.0, 0.0, 0.0), dt=0.01, steps=5, damping=0.1, damping_ratio=0.05)
