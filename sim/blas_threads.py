"""BLAS on one thread where a long reduction decides a result, so it does not depend on the core count.

OpenBLAS (numpy's and scipy's own copies) splits a long reduction, a dot product or a
norm of more than about 10,000 numbers, into one partial sum per thread, and adds the
partial sums: with another thread count the last bits differ. scipy's lsmr, inside the
refinement's `least_squares` (`plantlod.simplify.refine`), takes such norms of the
residual at every inner iteration, so a level of a few hundred branches came out a few
digits different on a 1-core and a 2-core machine (family mixed-143 and sympodial-146,
level 1; abop_1_24c's level 1 in its header's figures), against the brief's "identical
output for any thread count". The parallel work that matters (simulation, tips) is
numba's, with its own thread count (`plantlod.sim.lanes.thread_count`); lsmr's BLAS work
is vector-sized, and its second thread mostly spun against the other work.

`one_blas_thread` limits every loaded BLAS library through threadpoolctl (the library
that scikit-learn uses for this; setting OPENBLAS_NUM_THREADS only works before numpy
is first imported), and puts the previous limits back on leaving. The refinement is the one
place that needs it: with it there alone, abop_2_6's chain of 12 levels, abop_1_24a's
level 1 and five family trees' levels 1 and 2 are byte-identical under 1 and 2 BLAS threads
(the fit's other BLAS calls gave the same bits in those runs).
"""

from __future__ import annotations

import contextlib
from typing import Iterator


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Inside: every BLAS library loaded in this process runs on one thread."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield
