"""sim/vec4.py: packed arithmetic that equals the scalar loop bit for bit."""

from __future__ import annotations

import math

import numba
import numpy as np

from plantlod.sim import vec4 as V


@numba.njit(cache=True)
def _scalar(a, b, c, out):
    n, w = a.shape
    for i in range(n):
        for k in range(w):
            x = a[i, k]
            y = b[i, k]
            z = c[i]
            t = x * y - z / (1.0 + y * y)
            u = math.sqrt(x * x + y * y) + 0.5 * t
            out[i, k] = u if t > 0.0 else -u - x
            out[i, k] += math.floor(t) if t != 0.0 else 0.0


@numba.njit(cache=True)
def _packed(a, b, c, out):
    n, w = a.shape
    for i in range(n):
        for l0 in range(0, w, 4):
            x = V.load(a, (i, l0))
            y = V.load(b, (i, l0))
            z = c[i]
            t = x * y - z / (1.0 + y * y)
            u = V.vsqrt(x * x + y * y) + 0.5 * t
            o = V.select(t > 0.0, u, -u - x)
            o += V.select(t != 0.0, V.floor(t), 0.0)
            V.store(out, (i, l0), o)


@numba.njit(cache=True)
def _lanes(a):
    v = V.vec4(a[0], a[1], a[2], a[3])
    s = V.splat(a[4])
    m = (v > s) & ~(v == 0.0) | (v != v)
    return (V.lane(v * s, 0), V.lane(v * s, 3), V.lane(m, 0), V.lane(m, 1), V.any_lane(m),
            V.lane(abs(-v), 2), V.any_lane(~V.isfinite4(v)))


def test_packed_equals_scalar_bit_for_bit():
    rng = np.random.default_rng(4)
    a = rng.normal(size=(50, 8))
    b = rng.normal(size=(50, 8)) * 1e3
    c = rng.normal(size=50)
    a[0, :4] = [0.0, -0.0, 1e-310, math.inf]
    b[0, :4] = [0.0, 1.0, -1e-310, 1.0]
    one, four = np.empty_like(a), np.empty_like(a)
    _scalar(a, b, c, one)
    _packed(a, b, c, four)
    assert np.array_equal(one.view(np.int64), four.view(np.int64)) or \
        np.array_equal(one, four, equal_nan=True)


def test_lanes_masks_and_broadcast():
    got = _lanes(np.array([1.0, -2.0, 3.0, math.nan, 2.0]))
    assert got[0] == 2.0 and math.isnan(got[1])
    assert got[2] is False and got[3] is False and got[4] is True
    assert got[5] == 3.0 and got[6] is True


def test_generated_code_is_packed():
    fresh = numba.njit(_packed.py_func)        # inspect_asm needs code compiled here, not cached
    a = np.ones((1, 4))
    fresh(a, a, np.ones(1), np.empty_like(a))
    asm = fresh.inspect_asm(fresh.signatures[0])
    for op in ("vmulpd", "vaddpd", "vsubpd", "vdivpd", "vsqrtpd"):
        assert op in asm, op
    assert "vroundpd" in asm or "vrndscalepd" in asm     # floor (AVX, AVX-512)
    assert "ymm" in asm
    assert "vfmadd" not in asm and "vfmsub" not in asm
