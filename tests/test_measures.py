"""Error measures (model.md section 6), checked against sine waves of known amplitude
and period, crossings worked out by hand, and hand-computed reports."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from plantlod.lsys.errors import InputError
from plantlod.compare.measures import (
    amplitude, compare_groups, period, relative_error, tip_error, upward_crossings, window,
)

# Samples every 1e-4 s over 10.3 s. A period of 2 s puts the peaks of sin(pi t) on
# samples (t = 0.5 + 2k, 1.5 + 2k) where numpy's sin is exactly +-1.
DT = 1e-4
T = np.arange(103_001) * DT


# --- amplitude and period ---------------------------------------------------------

def test_sine_amplitude_is_exact_and_period_accurate():
    x = 0.3 + 0.05 * np.sin(np.pi * T)                 # amplitude 0.05, period 2 s, offset
    assert amplitude(x) == pytest.approx(0.05, abs=1e-15)
    # linear interpolation near a zero of a sine is exact to O(dt^2); the mean over
    # 5.15 periods is off 0.3 by ~1e-3 * amplitude, which shifts every crossing
    # alike and leaves their spacing alone
    assert period(T, x) == pytest.approx(2.0, abs=1e-9)


def test_columns_are_independent():
    cols = np.column_stack([
        0.05 * np.sin(np.pi * T),                       # P = 2
        2.0 * np.sin(2 * np.pi * T / 0.8 + 1.0),        # P = 0.8
        -1.5 * np.cos(2 * np.pi * T / 3.1),             # P = 3.1
        np.full_like(T, 0.7),                           # constant: no crossings
    ])
    per = period(T, cols)
    amp = amplitude(cols)
    assert per.shape == amp.shape == (4,)
    np.testing.assert_allclose(per[:3], [2.0, 0.8, 3.1], rtol=1e-7)
    assert math.isnan(per[3])
    np.testing.assert_allclose(amp, [0.05, 2.0, 1.5, 0.0], rtol=1e-7, atol=1e-15)
    for j in range(4):           # the vectorised form agrees with the column-by-column one
        c = upward_crossings(T, cols[:, j])[0]
        want = (c[-1] - c[0]) / (len(c) - 1) if len(c) >= 2 else math.nan
        np.testing.assert_equal(per[j], want)


def test_crossings_by_hand():
    # mean 0; up between samples 0,1 (-1 -> 1: t = 0.5) and 3,4 (-1 -> 3: a quarter of
    # the way, and t3 = 4, t4 = 6, so t = 4.5): period 4.0
    t = np.array([0.0, 1, 3, 4, 6, 7])
    x = np.array([-1.0, 1, -1, -1, 3, -1])
    np.testing.assert_allclose(upward_crossings(t, x)[0], [0.5, 4.5])
    assert period(t, x) == pytest.approx(4.0, abs=1e-15)
    # a sample equal to the mean ends a crossing (x[k-1] < mean <= x[k]) but does not
    # start one: mean 0, crossings at t = 1 and t = 5, period 4
    x = np.array([-1.0, 0, 1, 0, -1, 0, 1])
    t = np.arange(7.0)
    np.testing.assert_array_equal(upward_crossings(t, x)[0], [1.0, 5.0])
    assert period(t, x) == 4.0
    # one crossing: undefined
    assert math.isnan(period(np.arange(3.0), np.array([-1.0, 1.0, 1.0])))


def test_constant_signal_has_no_period():
    x = np.full(50, 0.1)                 # mean may differ from 0.1 by a rounding step
    assert amplitude(x) == 0.0
    assert math.isnan(period(np.arange(50.0), x))
    assert len(upward_crossings(np.arange(50.0), x)[0]) == 0


def test_nan_propagates_to_its_column_only():
    x = np.column_stack([np.sin(np.pi * T[:40001]), np.sin(np.pi * T[:40001])])
    x[100, 1] = np.nan
    amp, per = amplitude(x), period(T[:40001], x)
    assert amp[0] == pytest.approx(1.0, abs=1e-15) and math.isnan(amp[1])
    assert per[0] == pytest.approx(2.0, abs=1e-9) and math.isnan(per[1])


def test_relative_error_is_undefined_for_a_zero_reference():
    err = relative_error([1.1, 0.0, 1.0, 2.0], [1.0, 0.0, 0.0, np.nan])
    assert err[0] == pytest.approx(0.1, abs=1e-15)
    assert np.isnan(err[1:]).all()


def test_window():
    t = np.arange(11.0) * 0.5            # 0 .. 5 s
    assert window(t) == slice(0, 11)
    s = window(t, 1.0, 2.2)
    np.testing.assert_array_equal(t[s], [1.0, 1.5, 2.0])
    np.testing.assert_array_equal(t[window(t, 4.1)], [4.5, 5.0])
    with pytest.raises(InputError, match="after its end"):
        window(t, 3, 2)
    with pytest.raises(InputError, match="expected at least 2"):
        window(t, 1.1, 1.4)


# --- tip error ------------------------------------------------------------------------

def test_tip_error_by_hand():
    k = 4
    orig = np.zeros((k, 2, 3))
    simp = np.zeros((k, 2, 3))
    simp[:, 0] = [3.0, 4.0, 0.0]                       # |d| = 5 throughout
    simp[:, 1, 2] = [1.0, -1.0, 3.0, 0.0]              # RMS = sqrt(11 / 4)
    np.testing.assert_allclose(tip_error(orig, simp, 2.0), [2.5, math.sqrt(11 / 4) / 2.0])


# --- the report -------------------------------------------------------------------------

ADDR = ["0.0", "0.1", "0.2", "0.3"]
S = np.sin(np.pi * T)                 # extremes exactly +-1, period 2 s
S3 = np.sin(2 * np.pi * T / 2.5)      # period 2.5 s


def report_inputs():
    """Four groups. Original bend amplitudes 1, 0.01 (exactly 1 % of the largest: counts),
    0.0099 (does not count), 0.5; every original rotation is 0 (never counts)."""
    k = len(T)
    ob = np.column_stack([1.0 * S, 0.01 * S, 0.0099 * S, 0.5 * S])
    orr = np.zeros((k, 4))
    sb = np.column_stack([
        1.1 * S,                # amplitude error 0.1, period error 0
        0.01 * S3,              # amplitude error 0, period error |2.5 - 2| / 2 = 0.25
        0.0099 * 5 * S,         # amplitude error 4, but not counted
        np.zeros(k),            # amplitude error 1, period undefined
    ])
    sr = np.zeros((k, 4))
    sr[:, 2] = 0.3 * S          # rotation amplitude where the original has none
    tips_o = np.zeros((k, 4, 3))
    tips_s = np.zeros((k, 4, 3))
    tips_s[:, 1, 0] = 0.6       # |d| = 0.6 m all the time
    tips_s[:, 3, 1] = 0.3
    return T, ob, orr, sb, sr, tips_o, tips_s


def test_report_by_hand():
    rep = compare_groups(*report_inputs(), rest_height=3.0, addresses=ADDR)
    counted = [(g.bend.counted, g.rotation.counted) for g in rep.groups]
    assert counted == [(True, False), (True, False), (False, False), (True, False)]
    assert rep.largest_amplitude == 1.0
    assert [g.bend.amplitude_error for g in rep.groups] == pytest.approx([0.1, 0.0, 4.0, 1.0], abs=1e-12)
    assert rep.amplitude_error == pytest.approx(1.0)            # group 0.3; 0.2's 4.0 does not count
    assert rep.amplitude_error_at.address == "0.3" and rep.amplitude_error_at.component == "bend"
    assert rep.groups[1].bend.period_error == pytest.approx(0.25, abs=1e-8)
    assert rep.period_error == pytest.approx(0.25, abs=1e-8)
    assert rep.period_error_at.address == "0.1"
    assert [(w.address, w.component) for w in rep.undefined_periods] == [("0.3", "bend")]
    assert rep.tip_error == pytest.approx(0.2)                  # 0.6 m / 3 m
    assert rep.tip_error_at.address == "0.1"
    assert [g.tip_error for g in rep.groups] == pytest.approx([0.0, 0.2, 0.0, 0.1])
    # the uncounted original rotation: amplitude 0, its relative errors undefined
    assert rep.groups[2].rotation.amplitude_simplified == pytest.approx(0.3)
    assert math.isnan(rep.groups[2].rotation.amplitude_error)


def test_visible_motion_measures_by_hand():
    """model.md 6: motion error against A_max = 1, periods of the components >= 10 % of it."""
    rep = compare_groups(*report_inputs(), rest_height=3.0, addresses=ADDR)
    # |A_y - A_x| / 1 over counted components: 0.1 (0.0), 0 (0.1), 0.5 (0.3); 0.2 does not count
    assert rep.motion_error == pytest.approx(0.5, abs=1e-12)
    assert rep.motion_error_at.address == "0.3"
    # major components: 0.0 (A 1) and 0.3 (A 0.5, period undefined); 0.1 (A 0.01) is not
    # major, so its 25 % period error is left out: the only major period error is 0.0's 0
    assert rep.period_error_major == pytest.approx(0.0, abs=1e-8)
    assert rep.period_error_major_at.address == "0.0"
    # the largest tip distance: 0.6 m at group 0.1
    assert rep.tip_error_max_m == pytest.approx(0.6)
    assert rep.tip_error_max_m_at.address == "0.1"
    d = rep.to_dict()
    assert d["motion_error"] == pytest.approx(0.5) and d["tip_error_max_m"] == pytest.approx(0.6)


def test_tip_error_max_is_the_largest_distance_in_time():
    k = 5
    orig = np.zeros((k, 2, 3))
    simp = np.zeros((k, 2, 3))
    simp[:, 0, 0] = [0.0, 0.1, -0.4, 0.2, 0.0]      # largest |d| 0.4 m at one sample
    simp[:, 1] = [0.1, 0.1, 0.1]                    # |d| = sqrt(0.03) throughout
    rep = compare_groups(np.arange(k) * 0.1, np.zeros((k, 2)), np.zeros((k, 2)),
                         np.zeros((k, 2)), np.zeros((k, 2)), orig, simp, 1.0, ["a", "b"])
    assert rep.tip_error_max_m == pytest.approx(0.4) and rep.tip_error_max_m_at.address == "a"
    assert math.isnan(rep.motion_error) and math.isnan(rep.period_error_major)


def test_report_to_dict_is_json_ready():
    d = compare_groups(*report_inputs(), rest_height=3.0, addresses=ADDR).to_dict()
    text = json.dumps(d, allow_nan=False)          # no NaN or numpy scalars left
    back = json.loads(text)
    assert {"amplitude_error", "period_error", "tip_error", "groups"} <= set(back)
    assert [g["address"] for g in back["groups"]] == ADDR
    assert back["groups"][3]["bend"]["period_simplified"] is None
    assert back["groups"][0]["rotation"]["amplitude_error"] is None
    assert back["undefined_periods"] == [{"address": "0.3", "component": "bend"}]


def test_nothing_counts_when_the_original_is_still():
    t, ob, orr, sb, sr, to, ts = report_inputs()
    rep = compare_groups(t, 0 * ob, orr, sb, sr, to, ts, rest_height=3.0, addresses=ADDR)
    assert rep.largest_amplitude == 0.0
    assert not any(g.bend.counted or g.rotation.counted for g in rep.groups)
    assert math.isnan(rep.amplitude_error) and rep.amplitude_error_at is None
    assert math.isnan(rep.period_error) and rep.undefined_periods == []
    assert rep.tip_error == pytest.approx(0.2)      # tips count whatever the angles do
    d = rep.to_dict()
    assert d["amplitude_error"] is None and d["period_error"] is None


def test_rotation_component_counts_too():
    t, ob, orr, sb, sr, to, ts = report_inputs()
    orr[:, 0] = 2.0 * S                             # now the largest amplitude is 2
    sr[:, 0] = 1.0 * S                              # error 0.5
    rep = compare_groups(t, ob, orr, sb, sr, to, ts, rest_height=3.0, addresses=ADDR)
    assert rep.largest_amplitude == 2.0
    # 0.01 is now 0.5 % of the largest: 0.1's bend no longer counts
    assert [g.bend.counted for g in rep.groups] == [True, False, False, True]
    assert rep.groups[0].rotation.counted
    assert rep.amplitude_error == pytest.approx(1.0)
    assert rep.period_error == pytest.approx(0.0, abs=1e-9)


def test_bad_input_is_refused():
    t, ob, orr, sb, sr, to, ts = report_inputs()
    sb = sb.copy()
    sb[7, 2] = np.nan
    with pytest.raises(InputError, match="simplified bend is not finite at sample 7"):
        compare_groups(t, ob, orr, sb, sr, to, ts, rest_height=3.0, addresses=ADDR)
    with pytest.raises(InputError, match="expected t"):
        compare_groups(t, ob, orr, sr[:, :3], sr, to, ts, rest_height=3.0, addresses=ADDR)
    with pytest.raises(InputError, match="rest height"):
        compare_groups(t, ob, orr, sr, sr, to, ts, rest_height=0.0, addresses=ADDR)


@pytest.mark.parametrize("scale, moves", [(1e-13, False), (1e-12 / 0.99, True), (1e-10, True)])
def test_an_original_swinging_only_roundoff_does_not_move(scale, moves):
    """model.md 6: nothing counts when the largest original amplitude is 0. An amplitude of at
    most 1e-12 rad (STILL_AMPLITUDE) is float64 roundoff, read as 0 (a planar tree without drag
    in a wind across its plane swings 1e-17 rad; a level's 1e-3 rad against it read 8e8 %
    motion error). The same signals scaled above it count as before."""
    t, ob, orr, sb, sr, tips_o, tips_s = report_inputs()
    rep = compare_groups(t, scale * ob, orr, sb, sr, tips_o, tips_s, rest_height=3.0,
                         addresses=ADDR)
    counted = [g.bend.counted for g in rep.groups]
    if moves:
        assert rep.largest_amplitude == pytest.approx(scale)
        assert counted == [True, True, False, True]
        # 1.1 S against (scale) S: the level's whole swing over A_max
        assert rep.motion_error == pytest.approx((1.1 - scale) / scale, rel=1e-9)
    else:
        assert rep.largest_amplitude == 0.0 and counted == [False] * 4
        assert math.isnan(rep.motion_error) and math.isnan(rep.amplitude_error)
        assert rep.tip_error == pytest.approx(0.2)            # the tips still say how far they stray
