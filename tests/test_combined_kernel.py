"""compare.combined_kernel: one pass per sample, the bits of numpy's gathers, products and
``add.reduceat`` (the way `groups.combined_angles` summed before the kernel, kept here as
the literal reference)."""

from __future__ import annotations

import numpy as np
import pytest

from plantlod.compare.combined_kernel import combined


def _reference(bend, rot, members, starts, coefficients):
    """The numpy passes the kernel replaced: gather, multiply, add, add.reduceat."""
    c_bb, c_br, c_rb, c_rr = coefficients
    bj, rj = bend[:, members], rot[:, members]
    out_b = np.add.reduceat(bj * c_bb + rj * c_br, starts, axis=1)
    out_r = np.add.reduceat(bj * c_rb + rj * c_rr, starts, axis=1)
    return out_b, out_r


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_kernel_gives_numpys_bits_on_ragged_paths(dtype):
    """Paths of 1 to 300 members (numpy's pairwise sum changes its order at 8 and 128 terms),
    magnitudes over 16 decades so the order shows in the last bits, zeros and signs."""
    rng = np.random.default_rng(7)
    lengths = np.concatenate([np.arange(1, 20), [31, 64, 127, 128, 129, 130, 255, 256, 257, 300],
                              rng.integers(1, 12, 40)])
    members = rng.integers(0, 600, lengths.sum()).astype(np.int64)
    starts = (np.cumsum(lengths) - lengths).astype(np.int64)
    k = 9
    scale = 10.0 ** rng.uniform(-8, 8, (k, 600))
    bend = (rng.normal(size=(k, 600)) * scale).astype(dtype)
    rot = (rng.normal(size=(k, 600)) * scale).astype(dtype)
    bend[0] = 0.0
    rot[1, ::3] = -0.0
    coefficients = [np.ascontiguousarray(rng.normal(size=len(members)) * 10.0 ** rng.uniform(-3, 3, len(members)))
                    for _ in range(4)]
    coefficients[0][::5] = -1.0
    out_b, out_r = np.empty((k, len(lengths))), np.empty((k, len(lengths)))
    combined(bend, rot, members, starts, lengths.astype(np.int64), *coefficients, out_b, out_r)
    want_b, want_r = _reference(bend, rot, members, starts, coefficients)
    assert out_b.tobytes() == want_b.tobytes() and out_r.tobytes() == want_r.tobytes()
    # and the sums are the sums: a plain float64 sum of the same terms agrees to rounding
    terms = bend[:, members].astype(np.float64) * coefficients[0] + rot[:, members] * coefficients[1]
    plain = np.array([[terms[s, a:a + n].sum() for a, n in zip(starts, lengths)] for s in range(k)])
    np.testing.assert_allclose(out_b, plain, rtol=1e-9, atol=1e-9 * np.abs(terms).max())


def test_sums_of_negative_zeros_stay_negative_zero():
    """numpy's pairwise sum starts from -0.0: a path whose terms are all -0.0 sums to -0.0
    (a start from 0.0 gave +0.0 for paths of 2 to 8 members; found in review)."""
    lengths = np.arange(1, 12, dtype=np.int64)
    members = np.arange(lengths.sum(), dtype=np.int64)
    starts = (np.cumsum(lengths) - lengths).astype(np.int64)
    bend = np.full((2, len(members)), -0.0)
    rot = np.full((2, len(members)), -0.0)
    ones = [np.ones(len(members)) for _ in range(4)]
    out_b, out_r = np.empty((2, len(lengths))), np.empty((2, len(lengths)))
    combined(bend, rot, members, starts, lengths, *ones, out_b, out_r)
    want_b, want_r = _reference(bend, rot, members, starts, ones)
    assert np.all(np.signbit(want_b)) and out_b.tobytes() == want_b.tobytes()
    assert out_r.tobytes() == want_r.tobytes()
