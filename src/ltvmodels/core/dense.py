"""Small dense Cholesky factorization and solves, compiled (one copy for every kernel).

For the few-by-few systems inside compiled loops (the box QP of iLQG, the
feasibility test of segmentation, the Kalman recursions) explicit loops are
much faster than LAPACK calls, and much faster to compile than numba's
``np.linalg.solve``. The block-banded kernels of :mod:`.blockkernels` have their
own factorization (reciprocal pivots, block rows).
"""

from __future__ import annotations

import math

import numba

__all__ = ["cholesky", "cholesky_solve"]


@numba.njit(cache=True)
def cholesky(A, index, shift, L):  # pragma: no cover - compiled
    """Lower Cholesky factor of A[index][:, index] − shift·I into L[:d, :d], d = index.size.

    Entries are computed row by row, each as (A_ab − Σ_{j<b} L_aj L_bj) / L_bb
    with the sum in increasing j. Returns False (leaving L partly written) as
    soon as a pivot is not positive, i.e. when the matrix is not positive
    definite.
    """
    d = index.size
    for a in range(d):
        for b in range(a + 1):
            s = A[index[a], index[b]]
            if a == b:
                s -= shift
            for j in range(b):
                s -= L[a, j] * L[b, j]
            if a == b:
                if not s > 0.0:
                    return False
                L[a, a] = math.sqrt(s)
            else:
                L[a, b] = s / L[b, b]
    return True


@numba.njit(cache=True)
def cholesky_solve(L, d, rhs):  # pragma: no cover - compiled
    """Solve (L Lᵀ) X = rhs in place with the leading d × d factor of L; rhs is (d, r)."""
    r = rhs.shape[1]
    for col in range(r):
        for a in range(d):  # L z = b
            s = rhs[a, col]
            for j in range(a):
                s -= L[a, j] * rhs[j, col]
            rhs[a, col] = s / L[a, a]
        for a in range(d - 1, -1, -1):  # Lᵀ x = z
            s = rhs[a, col]
            for j in range(a + 1, d):
                s -= L[j, a] * rhs[j, col]
            rhs[a, col] = s / L[a, a]
