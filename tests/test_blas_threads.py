"""Levels do not depend on how many threads BLAS uses (sim/blas_threads.py).

OpenBLAS splits a long dot product into one partial sum per thread, so scipy's lsmr
(inside the refinement) gave other last bits with another thread count, and a level of
a few hundred branches came out different on a 1-core and a 2-core machine.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import threadpoolctl
from golden_util import family_tree


def blas_threads() -> set[int]:
    """The thread counts of every BLAS library loaded in this process."""
    return {info["num_threads"] for info in threadpoolctl.threadpool_info()
            if info["user_api"] == "blas"}


def test_one_blas_thread_inside_and_the_old_count_after():
    from plantlod.sim.blas_threads import one_blas_thread

    np.dot(np.ones(3), np.ones(3))                      # BLAS loaded
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads() == {2}
        with one_blas_thread():
            assert blas_threads() == {1}
        assert blas_threads() == {2}


def test_a_long_dot_product_does_depend_on_the_thread_count():
    """The premise, checked on this machine's BLAS: a sum of 230,000 products (a refinement
    residual's length for a level of ~2,400 branches) differs in its last bits between one
    and two threads. If a BLAS ever stops splitting, this test says so (and the guard is
    then only insurance)."""
    x = np.random.default_rng(0).standard_normal(230_000)
    sums = []
    for threads in (1, 2):
        with threadpoolctl.threadpool_limits(limits=threads, user_api="blas"):
            sums.append(float(np.dot(x, x)))
    # the exact sum, in order, with math.fsum: both are within rounding of it
    import math

    exact = math.fsum(x * x)
    assert all(abs(s - exact) <= 1e-10 * exact for s in sums)
    if sums[0] == sums[1]:
        pytest.skip("this BLAS gives one bit pattern for one and two threads")


def test_a_level_is_the_same_whatever_the_blas_thread_count():
    """Family mixed-143's level 1 (250 branches): its text differed between one and two BLAS
    threads before the refinement ran on one (sha256 0fb8e6... against 34758d...)."""
    from plantlod.simplify.pipeline import Options, simplify

    system, _tree = family_tree("mixed", 143)
    digests = []
    for threads in (2, 1):
        with threadpoolctl.threadpool_limits(limits=threads, user_api="blas"):
            text = simplify(system, Options(level=1, form="explicit")).text
        digests.append(hashlib.sha256(text.encode()).hexdigest())
    assert digests[0] == digests[1]
