"""One BLAS thread for the package's hot paths, whatever the environment says.

The solver kernels are compiled (numba) and vectorised over parameter sets; BLAS threads only
fight them for the cores, and a multi-threaded BLAS sums in an order that depends on the number
of threads, so the same seed could stop at a different step on another machine or shell. Every
fit, resume and command-line call therefore runs inside :func:`single_blas_thread`
(threadpoolctl), so ``OMP_NUM_THREADS`` and friends neither change a chain nor its speed.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy  # noqa: F401  (load both BLAS libraries, numpy's and scipy's, before limiting:
import scipy.linalg  # noqa: F401  a library loaded inside the block would keep its threads)
from threadpoolctl import threadpool_limits


@contextmanager
def single_blas_thread():
    """Limit the BLAS thread pools (OpenBLAS, MKL, BLIS) to one thread inside the block."""
    with threadpool_limits(limits=1, user_api="blas"):
        yield
