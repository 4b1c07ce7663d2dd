"""sim/trig.py: the one sin/cos of every kernel, against libm (math.sin, math.cos).

The stated bound: at most 1 ulp from glibc over [-4pi, 4pi] (10^6 points), small
angles 1e-300 .. 1e-3, [-1e5, 1e5] (TESTED_RANGE) and the doubles nearest k pi/2;
compiled (float and Vec4) and pure-Python runs of the formula agree bit for bit.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numba
import numpy as np
import pytest

from plantlod.sim import jit, vec4  # noqa: F401  (jit: sincos registered with numba)
from plantlod.sim.lanes_kernel import sincos4
from plantlod.sim.trig import INVPIO2, TESTED_RANGE, sincos, sincos1

# pi to 60 digits, for the doubles nearest k pi / 2
PI = Fraction("3.14159265358979323846264338327950288419716939937510582097494")


def _scalar_kernel(fn):
    """A compiled loop calling ``fn`` (sincos or sincos1) on each float of x."""
    def run(x, s, c):
        for i in range(x.shape[0]):
            a, b = fn(x[i])
            s[i] = a
            c[i] = b
    return numba.njit(run)


def _packed_kernel(fn):
    """A compiled loop calling ``fn`` (sincos or sincos4) on 4 floats of x at a time."""
    def run(x, s, c):
        for i in range(0, x.shape[0] - x.shape[0] % 4, 4):
            a, b = fn(vec4.load(x, i))
            vec4.store(s, i, a)
            vec4.store(c, i, b)
    return numba.njit(run)


_scalar, _packed = _scalar_kernel(sincos), _packed_kernel(sincos)
_scalar_fast, _packed_fast = _scalar_kernel(sincos1), _packed_kernel(sincos4)


def _compiled(x):
    x = np.ascontiguousarray(x, dtype=np.float64)
    s, c = np.empty_like(x), np.empty_like(x)
    _scalar(x, s, c)
    return s, c


def _libm(x):
    return (np.array([math.sin(v) for v in x.tolist()]),
            np.array([math.cos(v) for v in x.tolist()]))


def _ulps(got, want):
    """|got - want| in units of the last place of want (0 where both are equal)."""
    diff = np.abs(got - want)
    return np.where(diff == 0, 0.0, diff / np.spacing(np.abs(want)))


def _points() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(22)
    small = np.logspace(-300, -3, 100_000)
    near = [float(k * PI / 2) for k in range(-1000, 1001)]
    near = np.array(near + [math.nextafter(v, math.inf) for v in near]
                    + [math.nextafter(v, -math.inf) for v in near])
    return {
        "[-4pi, 4pi]": np.linspace(-4 * math.pi, 4 * math.pi, 1_000_000),
        "1e-300 .. 1e-3": np.concatenate([small, -small]),
        "|x| <= 1e5": rng.uniform(-TESTED_RANGE, TESTED_RANGE, 100_000),
        "near k pi/2": near,
    }


@pytest.mark.parametrize("name", list(_points()))
def test_within_one_ulp_of_libm(name):
    x = _points()[name]
    s, c = _compiled(x)
    ls, lc = _libm(x)
    assert _ulps(s, ls).max() <= 1.0, name
    assert _ulps(c, lc).max() <= 1.0, name


def test_exact_at_zero_and_symmetric():
    s, c = _compiled(np.array([0.0, -0.0]))
    assert s[0] == 0.0 and c[0] == 1.0 and c[1] == 1.0
    assert math.copysign(1.0, s[1]) == -1.0            # sin(-0) = -0, as libm
    x = np.linspace(0.0, 40.0, 200_001)
    sp, cp = _compiled(x)
    sn, cn = _compiled(-x)
    assert np.array_equal(sn, -sp) and np.array_equal(cn, cp)


def test_nan_and_inf_give_nan():
    s, c = _compiled(np.array([math.nan, math.inf, -math.inf]))
    assert np.isnan(s).all() and np.isnan(c).all()


def test_python_reference_agrees_bit_for_bit():
    x = np.concatenate([v[:: max(1, len(v) // 5000)] for v in _points().values()])
    s, c = _compiled(x)
    ref = [sincos(v) for v in x.tolist()]     # the interpreter
    assert np.array_equal(s, [r[0] for r in ref])
    assert np.array_equal(c, [r[1] for r in ref])


def test_vec4_lanes_equal_the_scalar_formula():
    x = np.concatenate(list(_points().values()))
    x = x[: len(x) - len(x) % 4]
    s, c = _compiled(x)
    s4, c4 = np.empty_like(x), np.empty_like(x)
    _packed(x, s4, c4)
    assert np.array_equal(s, s4) and np.array_equal(c, c4)


def test_fast_paths_give_the_same_bits():
    """sincos1 (one float) and lanes_kernel.sincos4 skip the reduction where n = 0."""
    edge = 0.5 / INVPIO2                     # where n turns from 0 to 1
    near = [edge]
    for _ in range(40):
        near = [math.nextafter(near[0], 0.0)] + near + [math.nextafter(near[-1], 4.0)]
    x = np.concatenate([np.linspace(-1.0, 1.0, 100_001), near, -np.array(near), [0.0, -0.0],
                        _points()["1e-300 .. 1e-3"]])
    x = x[: len(x) - len(x) % 4]
    s, c = _compiled(x)
    for fn in (_scalar_fast, _packed_fast):
        s1, c1 = np.empty_like(x), np.empty_like(x)
        fn(x, s1, c1)
        assert np.array_equal(s.view(np.int64), s1.view(np.int64)), fn
        assert np.array_equal(c.view(np.int64), c1.view(np.int64)), fn
    ref = [sincos1(v) for v in x[::50].tolist()]
    assert np.array_equal(s[::50], [r[0] for r in ref]) and np.array_equal(c[::50], [r[1] for r in ref])


def test_generated_code_is_packed_and_unfused():
    scalar_fn, packed_fn = _scalar_kernel(sincos), _packed_kernel(sincos)
    scalar_fn(np.zeros(4), np.zeros(4), np.zeros(4))
    packed_fn(np.zeros(4), np.zeros(4), np.zeros(4))
    scalar = scalar_fn.inspect_asm(scalar_fn.signatures[0])
    packed = packed_fn.inspect_asm(packed_fn.signatures[0])
    for asm in (scalar, packed):
        assert "vfmadd" not in asm and "vfmsub" not in asm and "vfnmadd" not in asm
        assert not any("call" in line and "sin" in line for line in asm.splitlines())
    assert "vmulpd" in packed and "ymm" in packed
