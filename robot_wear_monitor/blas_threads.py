"""One BLAS thread per process: the monitor's linear algebra is small and many.

The estimator, intervals and trend multiply arrays of at most a few hundred rows, thousands of
times per replay.  A threaded BLAS (OpenBLAS starts one thread per core) wakes its threads for
each of them; on a busy 2-core machine the replay of 60 experiments took 2.8 s with the default
threads and 1.7 s with one (``bench/bench_replay.py``).  The entry points (the command line and
the nodes) call :func:`use_single_blas_thread` once; library users keep their own setting.
"""

from typing import Any

_LIMITER: Any = None


def use_single_blas_thread() -> None:
    """Limit BLAS to one thread for the rest of the process (threadpoolctl); idempotent."""
    global _LIMITER
    if _LIMITER is not None:
        return
    # the limit reaches the libraries loaded when it is set: scipy.linalg brings its own
    # OpenBLAS, so load it first
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_limits
    _LIMITER = threadpool_limits(limits=1, user_api='blas')
