"""Estimators for fit_many's fault tests: they kill the worker process that runs them.

Module-level functions in an importable module, so that worker processes (forked
or spawned by a Dask nanny) can import them by name.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np

import ltvmodels as ltv


def die_on_marked(x, u=None, **options):
    """``fit``, except that data whose first sample is +1e6 kill their process every time."""
    if np.asarray(x)[0, 0] == 1e6:
        os.kill(os.getpid(), signal.SIGKILL)
    return ltv.fit(x, u, **options)


def die_once(x, u=None, *, marker: str, **options):
    """``fit``, except that the first call for data starting at +1e6 kills its process.

    ``marker`` is a file path: it exists once the process has been killed.
    """
    if np.asarray(x)[0, 0] == 1e6 and not Path(marker).exists():
        Path(marker).touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return ltv.fit(x, u, **options)


def report_threads(x, u=None, **options):
    """``fit``, recording in ``info`` the BLAS/OpenMP and numba threads it ran with."""
    import numba
    from threadpoolctl import threadpool_info

    model = ltv.fit(x, u, **options)
    model.info["blas_threads"] = max((pool["num_threads"] for pool in threadpool_info()), default=1)
    model.info["numba_threads"] = numba.get_num_threads()
    return model


def stop_on_marked(x, u=None, **options):
    """``fit``, except that data whose first sample is +1e6 stop their process (SIGSTOP)."""
    if np.asarray(x)[0, 0] == 1e6:
        os.kill(os.getpid(), signal.SIGSTOP)
    return ltv.fit(x, u, **options)
