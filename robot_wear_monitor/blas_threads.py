"""
One BLAS thread per process: the monitor's linear algebra is small and many.

The estimator, intervals and trend multiply arrays of at most a few hundred rows, thousands of
times per replay.  A threaded BLAS (OpenBLAS starts one thread per core) wakes its threads for
each of them; on a busy 2-core machine the replay of 60 experiments took 2.8 s with the default
threads and 1.7 s with one (``bench/bench_replay.py``).  The entry points (the command line and
the nodes) call :func:`use_single_blas_thread` once; library users keep their own setting.

OpenBLAS also reads ``OPENBLAS_NUM_THREADS`` when it loads: with more than one thread it starts
its workers there, and each spins for a while before it sleeps, even when the limit comes
right after.  Numpy and scipy each load their own OpenBLAS: an entry point that calls
:func:`use_single_blas_thread` before it imports numpy saves about 0.1 s of CPU per process
(the function sets the variable unless it is set already).  With the variable at 1, a scipy
loaded later starts with one thread, so scipy is only imported here when the user set the
variable to something else.
"""

import os
from typing import Any

_LIMITER: Any = None


def use_single_blas_thread() -> None:
    """Limit BLAS to one thread for the rest of the process (threadpoolctl); idempotent."""
    global _LIMITER
    if _LIMITER is not None:
        return
    # read by OpenBLAS when numpy and scipy load it (no effect once loaded); inherited by the
    # worker processes of a batch
    os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
    # deferred import: load order (numpy after OPENBLAS_NUM_THREADS is set)
    import numpy  # noqa: F401
    if os.environ['OPENBLAS_NUM_THREADS'] != '1':
        # the limit reaches the libraries loaded when it is set, and scipy.linalg brings its
        # own OpenBLAS, which would read the other value if loaded later: load it first.
        # Otherwise skip it: the estimation path does not import scipy (0.14 s)
        # deferred import: load order (scipy's OpenBLAS before the limit, only when asked)
        import scipy.linalg  # noqa: F401
    # deferred import: start-up time (threadpoolctl: entry points only)
    from threadpoolctl import threadpool_limits
    _LIMITER = threadpool_limits(limits=1, user_api='blas')
