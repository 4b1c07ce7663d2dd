"""Wind objects: constant, keyframed (interpolation by hand, CSV errors), speed+azimuth, gusts."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from plantlod.lsys.errors import InputError
from plantlod.sim.constants import MAX_WIND_SPEED
from plantlod.sim.wind import ConstantWind, GustyWind, KeyframeWind, gust_peak_factor, wind_from_speed


def test_constant_wind_repeats_its_vector():
    out = ConstantWind((1.0, -2.0, 0.5)).sample(np.array([0.0, 3.0, -1.0]))
    assert out.shape == (3, 3) and out.tolist() == [[1.0, -2.0, 0.5]] * 3
    with pytest.raises(InputError):
        ConstantWind((1.0, math.inf, 0.0))


def test_keyframes_interpolate_linearly_and_hold_beyond_the_ends():
    wind = KeyframeWind([0.0, 2.0, 4.0], [[0, 0, 0], [2, 4, 0], [2, 0, -2]])
    got = wind.sample(np.array([-1.0, 0.0, 1.0, 2.0, 3.0, 3.5, 4.0, 10.0]))
    want = [[0, 0, 0], [0, 0, 0], [1, 2, 0], [2, 4, 0], [2, 2, -1], [2, 1, -1.5],
            [2, 0, -2], [2, 0, -2]]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)


def test_keyframe_csv_with_and_without_header():
    text = "t,vx,vy,vz\n0,0,0,0\n\n# a comment\n1, 3, 0, 0\n2,3,1,0.5\r\n"
    wind = KeyframeWind.from_csv(io.StringIO(text), "w.csv")
    assert wind.times.tolist() == [0.0, 1.0, 2.0]
    assert wind.sample(np.array([0.5, 1.5])).tolist() == [[1.5, 0, 0], [3, 0.5, 0.25]]
    bare = KeyframeWind.from_csv(io.StringIO("5,1,2,3\n"), "w.csv")
    assert bare.sample(np.array([0.0, 9.0])).tolist() == [[1, 2, 3], [1, 2, 3]]


@pytest.mark.parametrize("text,line,col,pattern", [
    ("t,vx,vy,vz\n0,1,2\n", 2, 1, "expected 4 numbers t,vx,vy,vz, got 3"),
    ("0,1,2,3\n1,1,x,3\n", 2, 5, "expected a finite number for vy, got 'x'"),
    ("0,1,2,3\n1, 1, nan,3\n", 2, 7, "for vy"),
    ("0,1,2,3\n2,1,2,3\n2,0,0,0\n", 3, 1, "strictly increasing: 2 after 2"),
    ("t,vx,vy,vz\nt,vx,vy,vz\n", 2, 1, "expected a finite number for t"),
    ("t,vx,vy,vz\n", 1, 1, "at least one keyframe"),
    ("", 1, 1, "at least one keyframe"),
])
def test_keyframe_csv_errors_are_located(text, line, col, pattern):
    with pytest.raises(InputError, match=pattern) as err:
        KeyframeWind.from_csv(io.StringIO(text), "w.csv")
    assert (err.value.file, err.value.line, err.value.col) == ("w.csv", line, col)


def test_wind_from_speed_azimuth_from_x_toward_y():
    assert wind_from_speed(5.0, 0.0).vector.tolist() == [5.0, 0.0, 0.0]
    assert wind_from_speed(5.0, 90.0).vector.tolist() == [0.0, 5.0, 0.0]     # exact zeros
    assert wind_from_speed(5.0, -90.0).vector.tolist() == [0.0, -5.0, 0.0]
    assert wind_from_speed(5.0, 540.0).vector.tolist() == [-5.0, 0.0, 0.0]
    np.testing.assert_allclose(wind_from_speed(2.0, 30.0).vector, [math.sqrt(3), 1.0, 0.0], atol=1e-15)
    with pytest.raises(InputError, match="wind speed"):
        wind_from_speed(-1.0, 0.0)


def test_gusts_are_repeatable_and_seed_dependent():
    base = ConstantWind((4.0, 3.0, 0.0))
    t = np.arange(0.0, 60.0, 0.05)
    a = GustyWind(base, seed=1, strength=0.3).sample(t)
    assert a.tobytes() == GustyWind(base, seed=1, strength=0.3).sample(t).tobytes()
    assert np.abs(a - GustyWind(base, seed=2, strength=0.3).sample(t)).max() > 0.1
    # the direction is the base wind's; the speed varies
    np.testing.assert_allclose(a[:, 0] * 3.0, a[:, 1] * 4.0, rtol=1e-14, atol=1e-14)
    speed = np.linalg.norm(a, axis=1)
    assert speed.min() < 4.5 < 5.5 < speed.max()
    # sampling a subset of times gives the same values (no hidden state)
    np.testing.assert_array_equal(GustyWind(base, seed=1, strength=0.3).sample(t[::7]), a[::7])


def test_gust_strength_is_the_rms_relative_fluctuation():
    gust = GustyWind(ConstantWind((1.0, 0.0, 0.0)), seed=3, strength=0.2)
    t = np.arange(0.0, 20000.0, 0.25)
    factor = gust.factor(t)
    assert factor.min() >= 0.0
    assert np.sqrt(np.mean((factor - 1.0) ** 2)) == pytest.approx(0.2, rel=0.1)
    assert np.mean(factor) == pytest.approx(1.0, abs=0.02)
    # zero strength: exactly the base wind; a strong gust is clipped at zero, never reversed
    calm = GustyWind(ConstantWind((2.0, 0, 0)), seed=3, strength=0.0).sample(t[:50])
    assert calm.tolist() == [[2.0, 0, 0]] * 50
    strong = GustyWind(ConstantWind((2.0, 0, 0)), seed=3, strength=3.0).sample(t)
    assert strong[:, 0].min() == 0.0



@pytest.mark.parametrize("seed", [0, 3, 11])
def test_gust_peak_factor_bounds_every_gust_and_is_nearly_reached(seed):
    """`gust_peak_factor` (what a scene checks before fitting levels for its gusts) is an
    upper bound of the factor at any time, and not a loose one: over a long run the factor
    comes within 40 % of it (M = 8 sines rarely all peak together)."""
    strength = 0.5
    t = np.arange(0.0, 20000.0, 0.05)
    factor = GustyWind(ConstantWind((1.0, 0.0, 0.0)), seed=seed, strength=strength).factor(t)
    bound = gust_peak_factor(strength)
    assert bound == 1.0 + strength * 4.0                 # sqrt(2 M), M = 8
    assert factor.max() <= bound
    assert factor.max() >= 1.0 + 0.6 * (bound - 1.0)


def test_every_kind_of_wind_is_held_to_the_largest_speed(tmp_path):
    """Only --wind-speed was held to MAX_WIND_SPEED: a vector, a keyframe row and gusts
    of 1e6 m/s or more ran with exit 0 and angles of 1e36 rad (session 23, found by fuzzing).
    A gust's bound is its peak factor times the base's fastest keyframe."""
    fast = MAX_WIND_SPEED * 1.001
    with pytest.raises(InputError, match="a wind of 1001 m/s; expected at most 1000"):
        ConstantWind((0.0, fast, 0.0))
    ConstantWind((0.0, MAX_WIND_SPEED, 0.0))
    with pytest.raises(InputError, match="a keyframe wind of 1001 m/s"):
        KeyframeWind([0.0, 1.0], [(1.0, 0, 0), (0, 0, fast)])
    with pytest.raises(InputError) as info:
        KeyframeWind.from_csv(io.StringIO("t,vx,vy,vz\n0,1,0,0\n1, 600,800.8,0\n"), "w.csv")
    assert (info.value.file, info.value.line, info.value.col) == ("w.csv", 3, 4)
    with pytest.raises(InputError, match="expected a finite number for vy") as info:
        KeyframeWind.from_csv(io.StringIO("0,1,\u0661,0\n"), "w.csv")   # (float() reads 1)
    assert (info.value.line, info.value.col) == (1, 5)
    base = KeyframeWind([0.0, 1.0], [(1.0, 0, 0), (200.0, 0, 0)])
    GustyWind(base, strength=1.0)                             # 200 (1 + 4) = 1000
    with pytest.raises(InputError, match="gusts of strength 1.01 reach a wind of 1008 m/s"):
        GustyWind(base, strength=1.01)

def test_gust_rejects_bad_parameters():
    base = ConstantWind((1.0, 0.0, 0.0))
    with pytest.raises(InputError, match="base must be a wind object"):
        GustyWind("abc")          # an AttributeError once the run began (session 22's fuzzing)
    with pytest.raises(InputError, match="seed"):
        GustyWind(base, seed=-1)
    with pytest.raises(InputError, match="strength"):
        GustyWind(base, seed=0, strength=-0.5)


@pytest.mark.parametrize("make, fragment", [
    (lambda b: KeyframeWind("a", "b"), "keyframe wind needs numbers: K times and one (vx, vy, vz) "
                                       "per time, got 'a' and 'b'"),
    (lambda b: KeyframeWind([0, 1], [[1, 0, 0], [2, 0]]), "keyframe wind needs numbers"),  # ragged
    (lambda b: GustyWind(b, strength="x"), "gust strength must be a number (an int or a float), got 'x'"),
    (lambda b: GustyWind(b, strength=None), "gust strength must be a number (an int or a float), got None"),
    (lambda b: GustyWind(b, components="x"), "gust components must be a whole number in [1, inf)"),
    (lambda b: GustyWind(b, components=2.5), "gust components must be a whole number"),
    (lambda b: GustyWind(b, seed=True), "gust seed must be a whole number in [0, inf), got True"),
    (lambda b: GustyWind(b, max_frequency=None), "gust max_frequency must be a number"),
])
def test_wind_objects_name_arguments_of_the_wrong_kind(make, fragment):
    """The documented wind classes raised numpy's ValueError or float's TypeError, and took
    seed=True as seed 1 (session 34's fuzzing of the API)."""
    with pytest.raises(InputError, match=__import__("re").escape(fragment)):
        make(ConstantWind((1.0, 0.0, 0.0)))
