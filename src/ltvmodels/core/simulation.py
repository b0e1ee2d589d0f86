"""Compiled simulation of x[t+1] = A_t x[t] + B_t u[t] + w_t (models and example systems)."""

from __future__ import annotations

import numba
import numpy as np

from .precompiled import attach

__all__ = ["simulate_affine"]


@numba.njit(cache=True)
def simulate_affine(A, B, w, x0, u):  # pragma: no cover - compiled
    """x[t+1] = A_t x[t] + B_t u[t] + w_t for t = 0 … N − 1 from x[0] = x0; returns (N + 1, n).

    A (N, n, n), B (N, n, m), w (N, n) (offsets or process noise), x0 (n,), u (N, m).
    """
    N, n, _ = A.shape
    m = B.shape[2]
    x = np.empty((N + 1, n))
    # Element by element: an array assignment (x[0] = x0) makes numba compile its
    # shape-mismatch error message, string formatting that took ~2 s on first use.
    for i in range(n):
        x[0, i] = x0[i]
    for t in range(N):
        for i in range(n):
            acc = w[t, i]
            for j in range(n):
                acc += A[t, i, j] * x[t, j]
            for j in range(m):
                acc += B[t, i, j] * u[t, j]
            x[t + 1, i] = acc
    return x


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
