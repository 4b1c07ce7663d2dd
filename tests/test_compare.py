"""The library side of `plantlod compare` (compare/runs.py), on synthetic runs.

Angle signals are sine waves of known amplitude and period, so every figure of
the report is known in closed form; tips are recomputed here with scipy's
Rotation (an independent reading of model.md section 3), never with plantlod's
kinematics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantlod.lsys.errors import InputError
from plantlod.compare.runs import (
    Run, angle_differences, angles_in_tree_order, check_bounds, compare_runs,
)
from treegen import make_tree

# 1 ms samples over 10 s: the peaks of sin(2 pi t / P) for P = 2 and P = 2.5 fall on samples.
DT = 1e-3
T = np.arange(10_001) * DT


def two_stalks():
    """The original: two straight 1 m branches 0.0, 0.1; the simplified: one 2 m branch 0."""
    original = make_tree([-1, 0], address=["0.0", "0.1"], length=1.0)
    simplified = make_tree([-1], address=["0"], length=2.0)
    return original, simplified


def sine(amplitude, period_s, phase=0.0):
    return amplitude * np.sin(2 * np.pi * T / period_s + phase)


def chain_tip(lengths, bends, rots):
    """Tips (K, 3) of a straight chain (all rest angles 0) by composing rotation vectors (-θr, θb, 0).

    bends, rots: one (K,) signal per branch of the chain.
    """
    frame = None
    tip = 0.0
    for length, b, r in zip(lengths, bends, rots):
        b, r = np.broadcast_arrays(np.asarray(b, float), np.asarray(r, float))
        turn = Rotation.from_rotvec(np.column_stack([-r, b, np.zeros_like(b)]))
        frame = turn if frame is None else frame * turn
        tip = tip + length * frame.apply([0.0, 0.0, 1.0])
    return tip


def rms_distance(a, b):
    return math.sqrt(np.mean(np.sum((a - b) ** 2, axis=1)))


def test_sine_waves_give_the_closed_form_report():
    original, simplified = two_stalks()
    # Original: both branches bend in phase with period 2 s, amplitudes 0.03 and 0.02, so
    # the combined bend (a straight stalk: the plain sum) has amplitude 0.05 and period 2.
    # Branch 0 also rotates: amplitude 0.01, period 2. Simplified: bend 0.04 at period
    # 2.5 s, rotation 0.012 at period 2 s.
    ob = np.column_stack([sine(0.03, 2.0), sine(0.02, 2.0)])
    orr = np.column_stack([sine(0.01, 2.0), np.zeros_like(T)])
    sb = sine(0.04, 2.5)[:, None]
    sr = sine(0.012, 2.0)[:, None]
    comp = compare_runs(Run(original, T, ob, orr, "orig"), Run(simplified, T, sb, sr, "simp"))
    r = comp.report
    g = r.groups[0]
    assert g.address == "0"
    assert comp.unassigned == 0 and comp.groups.tolist() == [0, 0]
    assert [p.tolist() for p in comp.paths] == [[0, 1]]
    assert g.bend.amplitude_original == pytest.approx(0.05, abs=1e-12)
    assert g.bend.amplitude_simplified == pytest.approx(0.04, abs=1e-12)
    assert g.bend.amplitude_error == pytest.approx(0.2, abs=1e-9)           # |0.04 - 0.05| / 0.05
    assert g.bend.period_original == pytest.approx(2.0, abs=1e-6)
    assert g.bend.period_simplified == pytest.approx(2.5, abs=1e-6)
    assert g.bend.period_error == pytest.approx(0.25, abs=1e-6)             # |2.5 - 2| / 2
    assert g.rotation.amplitude_error == pytest.approx(0.2, abs=1e-9)       # |0.012 - 0.01| / 0.01
    assert g.rotation.period_error == pytest.approx(0.0, abs=1e-6)
    # 0.01 >= 1 % of the largest amplitude 0.05: both components count
    assert g.bend.counted and g.rotation.counted
    assert r.amplitude_error == pytest.approx(0.2, abs=1e-9)
    assert r.period_error == pytest.approx(0.25, abs=1e-6)
    assert (r.period_error_at.address, r.period_error_at.component) == ("0", "bend")
    # tip error: RMS over time of the tip distance, over the rest height 2 m
    want = rms_distance(chain_tip([1, 1], ob.T, orr.T), chain_tip([2], sb.T, sr.T)) / 2.0
    assert g.tip_error == pytest.approx(want, rel=1e-9)
    assert r.rest_height == 2.0 and (r.t0, r.t1) == (0.0, T[-1])
    # the combined angles cover the whole run, for plots
    np.testing.assert_allclose(comp.combined_bend[:, 0], ob.sum(axis=1), atol=1e-15)
    np.testing.assert_allclose(comp.combined_rot[:, 0], orr[:, 0], atol=1e-15)


def test_window_limits_the_figures():
    original, simplified = two_stalks()
    # amplitude 0.05 before t = 5 s and 0.1 after it, in the original only
    ob = np.column_stack([np.where(T <= 5.0, sine(0.05, 2.0), sine(0.1, 2.0)), np.zeros_like(T)])
    sb = sine(0.05, 2.0)[:, None]
    zeros2, zeros1 = np.zeros((len(T), 2)), np.zeros((len(T), 1))
    o, s = Run(original, T, ob, zeros2, "o"), Run(simplified, T, sb, zeros1, "s")
    early = compare_runs(o, s, 0.0, 5.0).report
    late = compare_runs(o, s, 5.0, None).report
    assert early.groups[0].bend.amplitude_error == pytest.approx(0.0, abs=1e-12)
    assert late.groups[0].bend.amplitude_error == pytest.approx(0.5, abs=1e-9)   # |0.05 - 0.1| / 0.1
    assert (early.t0, early.t1) == (0.0, 5.0) and late.t0 == 5.0
    with pytest.raises(InputError, match="window"):
        compare_runs(o, s, 20.0, 30.0)


def test_branching_group_main_path_and_tip():
    # Original: 0.0 (trunk), 0.1 a side branch turned by +30 deg, 0.2 straight on top of 0.0;
    # the simplified tree has one branch 0 standing for all three. The main path takes the
    # straight child (alpha 0 < 30 deg): [0.0, 0.2], so the group tip is 0.2's tip.
    euler = [[0, 0, 0], [0, math.radians(30), 0], [0, 0, 0]]
    original = make_tree([-1, 0, 0], euler, address=["0.0", "0.1", "0.2"])
    simplified = make_tree([-1], address=["0"], length=2.0)
    ob = np.column_stack([sine(0.02, 2.0), sine(0.5, 2.0), sine(0.03, 2.0)])
    zeros3, zeros1 = np.zeros((len(T), 3)), np.zeros((len(T), 1))
    comp = compare_runs(Run(original, T, ob, zeros3, "o"),
                        Run(simplified, T, sine(0.05, 2.0)[:, None], zeros1, "s"))
    assert [p.tolist() for p in comp.paths] == [[0, 2]]
    g = comp.report.groups[0]
    assert g.bend.amplitude_original == pytest.approx(0.05, abs=1e-12)       # 0.02 + 0.03, not 0.1's
    # the two chains (1 m + 1 m and one 2 m branch) bend by the same total angle but not
    # alike: the tip distance is what the hand computation says
    want = rms_distance(chain_tip([1, 1], ob[:, [0, 2]].T, [0, 0]),
                        chain_tip([2], [0.05 * np.sin(np.pi * T)], [0])) / 2.0
    assert g.tip_error == pytest.approx(want, rel=1e-9)


def test_times_must_match():
    original, simplified = two_stalks()
    z2, z1 = np.zeros((len(T), 2)), np.zeros((len(T), 1))
    o = Run(original, T, z2, z2, "a.csv")
    with pytest.raises(InputError, match="same span with the same --dt"):
        compare_runs(o, Run(simplified, T[:-1], z1[:-1], z1[:-1], "b.csv"))
    with pytest.raises(InputError, match=r"sample 3 .* same times"):
        shifted = T.copy()
        shifted[3:] += 1e-6
        compare_runs(o, Run(simplified, shifted, z1, z1, "b.csv"))
    # ten significant digits (what the CSV keeps) is close enough
    rounded = np.array([float(f"{t:.10g}") for t in T * 1.0000000001])
    compare_runs(o, Run(simplified, rounded, z1, z1, "b.csv"))


def test_csv_columns_are_matched_to_the_tree():
    original, _ = two_stalks()
    bend = np.array([[1.0, 2.0]])
    rot = np.array([[3.0, 4.0]])
    b, r = angles_in_tree_order(original, ["0.1", "0.0"], bend, rot, "x.csv")
    assert b.tolist() == [[2.0, 1.0]] and r.tolist() == [[4.0, 3.0]]
    with pytest.raises(InputError, match=r"no columns for branch\(es\) 0.1") as info:
        angles_in_tree_order(original, ["0.0", "0.2"], bend, rot, "x.csv")
    assert "0.2" in str(info.value) and info.value.file == "x.csv"


def test_bounds():
    original, simplified = two_stalks()
    ob = np.column_stack([sine(0.03, 2.0), sine(0.02, 2.0)])
    z2, z1 = np.zeros((len(T), 2)), np.zeros((len(T), 1))
    report = compare_runs(Run(original, T, ob, z2, "o"),
                          Run(simplified, T, sine(0.04, 2.5)[:, None], z1, "s")).report
    # amplitude error 0.2 and period error 0.25 (as above)
    assert check_bounds(report, {"amplitude_error": 0.2001, "period_error": 0.2501}) == []
    broken = check_bounds(report, {"amplitude_error": 0.19, "period_error": 0.3, "tip_error": None})
    assert [v.figure for v in broken] == ["amplitude_error"]
    assert broken[0].limit == 0.19 and broken[0].at.address == "0"
    line = broken[0].describe("s.lsys")
    assert line.startswith("s.lsys: amplitude error 0.2 > --max-amplitude-error 0.19 at group 0 bend")
    # nothing moves: the figures are undefined, and a bound cannot vouch for them
    still = compare_runs(Run(original, T, z2, z2, "o"), Run(simplified, T, z1, z1, "s")).report
    broken = check_bounds(still, {"period_error": 1.0})
    assert len(broken) == 1 and math.isnan(broken[0].value)
    assert "undefined" in broken[0].describe("s")


def test_angle_differences_by_hand():
    times = np.array([0.0, 0.5, 1.0])
    bend_a = np.array([[0, 0], [0.1, 0.2], [0.3, -0.1]])
    rot_a = np.zeros((3, 2))
    # b's columns come in the other order: (0.1, 0.0)
    bend_b = np.array([[0, 0], [0.25, 0.1], [-0.1, 0.3]])
    rot_b = np.array([[0, 0], [0, 0.02], [0, 0]])
    d = angle_differences(times, ["0.0", "0.1"], bend_a, rot_a, times, ["0.1", "0.0"], bend_b, rot_b)
    # branch 0.0: bend a (0, 0.1, 0.3) vs b (0, 0.1, 0.3) -> 0; rot 0 vs (0, 0.02, 0) -> 0.02 at 0.5
    # branch 0.1: bend a (0, 0.2, -0.1) vs b (0, 0.25, -0.1) -> 0.05 at 0.5
    np.testing.assert_allclose(d.bend, [0.0, 0.05], atol=1e-15)
    np.testing.assert_allclose(d.rot, [0.02, 0.0], atol=1e-15)
    assert d.rot_at[0] == 0.5 and d.bend_at[1] == 0.5
    assert d.worst() == (1, "bend")
    with pytest.raises(InputError, match="different branches"):
        angle_differences(times, ["0.0", "0.1"], bend_a, rot_a, times, ["0.0", "0.2"], bend_b, rot_b)
