"""Combined angles of every group over many samples, compiled with numba (model.md 5).

`groups.combined_angles` sums each group's main-path members' carried angles,

    Θb_g = Σ_j (M_j[1,1] θb_j - M_j[1,0] θr_j),   Θr_g = Σ_j (M_j[0,0] θr_j - M_j[0,1] θb_j),

for every sample. With numpy that was ten passes over (samples × members) arrays (gathers,
products, numpy's ``add.reduceat``); this kernel makes one, and adds each group's terms in
the order ``add.reduceat`` adds a segment (its first term plus numpy's pairwise sum of the
rest, `_pairwise`), so the sums are the same bits as before (tests/test_combined_kernel.py
checks both against numpy on ragged paths of 1 to 300 members).
"""

from __future__ import annotations

import numba
import numpy as np

# numpy's pairwise summation (numpy/_core/src/umath/loops_utils.h.src): below 8 terms a
# plain loop from -0.0, up to this many eight running sums, beyond it halves
_PAIRWISE_BLOCK = 128


@numba.njit(cache=True, error_model="numpy")
def _pairwise(terms, lo, n):
    """Σ terms[lo:lo + n] added as numpy's pairwise_sum adds them."""
    if n < 8:
        res = -0.0                  # (numpy's start: a sum of -0.0 terms stays -0.0)
        for i in range(lo, lo + n):
            res += terms[i]
        return res
    if n <= _PAIRWISE_BLOCK:
        r0, r1, r2, r3 = terms[lo], terms[lo + 1], terms[lo + 2], terms[lo + 3]
        r4, r5, r6, r7 = terms[lo + 4], terms[lo + 5], terms[lo + 6], terms[lo + 7]
        i = 8
        stop = n - n % 8
        while i < stop:
            r0 += terms[lo + i]
            r1 += terms[lo + i + 1]
            r2 += terms[lo + i + 2]
            r3 += terms[lo + i + 3]
            r4 += terms[lo + i + 4]
            r5 += terms[lo + i + 5]
            r6 += terms[lo + i + 6]
            r7 += terms[lo + i + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += terms[lo + i]
            i += 1
        return res
    half = n // 2
    half -= half % 8
    return _pairwise(terms, lo, half) + _pairwise(terms, lo + half, n - half)


@numba.njit(cache=True, error_model="numpy", parallel=True)
def combined(bend, rot, members, starts, lengths, c_bb, c_br, c_rb, c_rr, out_b, out_r):
    """out_b, out_r (K, G) float64: the combined angles of the groups whose main paths are
    members[starts[g]:starts[g] + lengths[g]] (lengths >= 1), from bend, rot (K, B) (float32
    or float64, each angle widened exactly) and each member's carry coefficients c (M,)."""
    samples = bend.shape[0]
    groups = starts.shape[0]
    total = members.shape[0]
    for k in numba.prange(samples):
        tb = np.empty(total)
        tr = np.empty(total)
        for j in range(total):
            b = np.float64(bend[k, members[j]])
            r = np.float64(rot[k, members[j]])
            tb[j] = b * c_bb[j] + r * c_br[j]
            tr[j] = b * c_rb[j] + r * c_rr[j]
        for g in range(groups):
            s, n = starts[g], lengths[g]
            if n == 1:
                out_b[k, g] = tb[s]
                out_r[k, g] = tr[s]
            else:
                out_b[k, g] = tb[s] + _pairwise(tb, s + 1, n - 1)
                out_r[k, g] = tr[s] + _pairwise(tr, s + 1, n - 1)
