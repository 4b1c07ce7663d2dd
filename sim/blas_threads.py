"""BLAS on one thread while plantlod computes, so results do not depend on the core count.

OpenBLAS (numpy's and scipy's own copies) splits a long reduction, a dot product or a
norm of more than about 10,000 numbers, into one partial sum per thread, and adds the
partial sums: with another thread count the last bits differ. scipy's lsmr, inside the
refinement's `least_squares` (`plantlod.simplify.refine`), takes such norms of the
residual at every inner iteration, so a level of a few hundred branches came out a few
digits different on a 1-core and a 2-core machine (family mixed-143 and sympodial-146,
level 1; abop_1_24c's level 1 in its header's figures), against the brief's "identical
output for any thread count". The parallel work that matters (simulation, tips) is
numba's, with its own thread count (`plantlod.sim.lanes.thread_count`); what BLAS runs
is vector-sized, and its threads mostly spun against the other work: family
mixed-143's level 1 took 2.5 s with one BLAS thread and 8.9 s with two while another
job ran.

`one_blas_thread` limits every loaded BLAS library through threadpoolctl (the library
that scikit-learn uses for this; setting OPENBLAS_NUM_THREADS only works before numpy
is first imported), and puts the previous limits back on leaving.
"""

from __future__ import annotations

import contextlib
import functools
from typing import Callable, Iterator, TypeVar

F = TypeVar("F", bound=Callable)


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Inside: every BLAS library loaded in this process runs on one thread."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def with_one_blas_thread(function: F) -> F:
    """``function`` run inside `one_blas_thread` (a decorator for entry points)."""
    @functools.wraps(function)
    def wrapped(*args, **kwargs):
        with one_blas_thread():
            return function(*args, **kwargs)
    return wrapped  # type: ignore[return-value]
