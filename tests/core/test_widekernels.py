"""The wide Newton kernels (:mod:`ltvmodels.core.widekernels`) against a dense solve.

The Newton matrix H = 2ΦᵀΦ + DᵀΛSΛD of the interior-point method is built
densely from its definition (one N·b × N·b matrix on a small problem) and
every kernel's solve of H X = F is compared with numpy's; the generic
(BLAS/LAPACK) kernel serves any order, the explicit-inverse one order 1.
"""

import numpy as np
import pytest

from ltvmodels.core import widekernels as wide


def newton_inputs(rng, N, n, p, order, pairs=False, pinned=()):
    """Random cone scalings and data of a Newton system with b = n·p coefficients."""
    K = n * p
    coeffs = np.array([-1.0, 1.0]) if order == 1 else np.array([1.0, -2.0, 1.0])
    R = N - order
    phi = rng.standard_normal((N, 2, p))
    w = rng.uniform(0.5, 2.0, K)
    pin = np.zeros(K)
    pin[list(pinned)] = 1.0
    if pairs:  # cones of width 2: a diagonal S per coefficient
        v, eta, s_coef = np.empty((0, K + 1)), np.empty(0), np.empty(0)
        penalty = rng.uniform(0.1, 5.0, R * K)
    else:
        v = np.empty((R, K + 1))
        v[:, 1:] = 0.5 * rng.standard_normal((R, K))
        v[:, 0] = np.sqrt(1.0 + np.sum(v[:, 1:] ** 2, axis=1))
        eta = rng.uniform(0.3, 3.0, R)
        v1sq = np.sum(v[:, 1:] ** 2, axis=1)
        s_coef = 8 * v[:, 0] ** 2 / (1 + 8 * v[:, 0] ** 2 * v1sq)
        penalty = np.empty(0)
    return phi, n, v, eta, s_coef, penalty, w, coeffs, 0, pin, np.empty((N, order + 1, K, K))


def dense_newton(phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pinned, L):
    N, _, p = phi.shape
    K = n_rep * p
    d = coeffs.shape[0] - 1
    H = np.zeros((N * K, N * K))
    for t in range(N):
        G = 2.0 * phi[t].T @ phi[t]
        H[t * K : (t + 1) * K, t * K : (t + 1) * K] += np.kron(np.eye(n_rep), G)
    for r in range(N - d):
        if penalty.size:
            P = np.diag(w**2 * penalty[r * K : (r + 1) * K])
        else:
            a = w * v[r, 1:]
            P = (np.diag(w**2) - s_coef[r] * np.outer(a, a)) / eta[r] ** 2
        for i in range(d + 1):
            for j in range(d + 1):
                block = coeffs[i] * coeffs[j] * P
                H[(r + i) * K : (r + i + 1) * K, (r + j) * K : (r + j + 1) * K] += block
    for t in range(N):
        for i in np.flatnonzero(pinned):
            H[t * K + i, :] = 0.0
            H[:, t * K + i] = 0.0
            H[t * K + i, t * K + i] = 1.0
    return H


CASES = [
    dict(order=1),
    dict(order=2),
    dict(order=1, pairs=True),
    dict(order=2, pairs=True),
    dict(order=1, pinned=(0, 7)),
    dict(order=2, pinned=(3,)),
    dict(order=1, pairs=True, pinned=(2, 11)),  # l1's blocks with constant coefficients
    dict(order=2, pairs=True, pinned=(5,)),
]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("kernel", ["generic", "first"])
def test_solve_matches_dense(case, kernel):
    if kernel == "first" and case["order"] != 1:
        pytest.skip("the explicit-inverse kernel is for first differences")
    rng = np.random.default_rng(len(str(case)))
    N, n, p = 9, 4, 5  # b = 20
    args = newton_inputs(rng, N, n, p, **case)
    H = dense_newton(*args)
    F = rng.standard_normal((N, n * p, 3))
    X = F.copy()
    L = args[-1]
    if kernel == "first":
        L, P = np.empty((N, 1, n * p, n * p)), np.empty((N, 2, n * p))
        assert wide.factor_newton_wide_first(*args[:-1], L, P)[0] > 0
        wide.solve_wide_first(L, P, X, args[7])
    else:
        with wide.one_blas_thread():
            assert wide.factor_newton_wide(*args)[0] > 0
        wide.solve_wide(L, X)
    expected = np.linalg.solve(H, F.reshape(N * n * p, 3)).reshape(X.shape)
    np.testing.assert_allclose(X, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("kernel", ["generic", "first"])
def test_indefinite_matrix_is_reported(kernel):
    rng = np.random.default_rng(3)
    args = list(newton_inputs(rng, 6, 4, 5, 1))
    args[4] = 50.0 * args[4]  # s_coef ‖v₁‖² > 1: S, and so H, indefinite
    args[0] = 1e-3 * args[0]
    with wide.one_blas_thread():
        if kernel == "first":
            worst, t = wide.factor_newton_wide_first(*args, np.empty((6, 2, 20)))
        else:
            worst, t = wide.factor_newton_wide(*args)
    assert worst < 0 and 0 <= t < 6


@pytest.mark.parametrize("pinned", [(), (4, 11)])
def test_first_kernel_odd_block_size(pinned):
    # b = 21: the inversion sweeps its pivots in pairs and the last one alone.
    rng = np.random.default_rng(5)
    N, n, p = 8, 3, 7
    args = newton_inputs(rng, N, n, p, 1, pinned=pinned)
    H = dense_newton(*args)
    F = rng.standard_normal((N, n * p, 2))
    X = F.copy()
    L, P = np.empty((N, 1, n * p, n * p)), np.empty((N, 2, n * p))
    assert wide.factor_newton_wide_first(*args[:-1], L, P)[0] > 0
    wide.solve_wide_first(L, P, X, args[7])
    expected = np.linalg.solve(H, F.reshape(N * n * p, 2)).reshape(X.shape)
    np.testing.assert_allclose(X, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize(
    ("n", "p", "last"),
    [(4, 5, 8), (4, 5, 9), (4, 5, 19), (3, 7, 20)],  # first or second of a pair; alone
)
@pytest.mark.parametrize("share", [0.4, 0.8])
def test_first_kernel_reports_a_failing_pivot_anywhere(n, p, last, share):
    """S_0 ≈ P_0 = η⁻²(Λ² − s(Λv₁)(Λv₁)ᵀ) with v₁ nonzero at entries 2 and ``last``:
    the pivots of its LDLᵀ factorization are positive up to ``last`` and there
    s(v₂² + v_last²) − 1 changes sign, so it is positive definite for share = 0.4 and
    not for 0.8 (the data part is a millionth of it)."""
    rng = np.random.default_rng(7)
    N = 4
    phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pin, _ = newton_inputs(rng, N, n, p, 1)
    phi = 1e-3 * phi
    v[0, 1:] = 0.0
    v[0, 1 + 2] = np.sqrt(0.5)
    v[0, 1 + last] = np.sqrt(share)
    s_coef[0] = 1.0
    b = n * p
    L, P = np.empty((N, 1, b, b)), np.empty((N, 2, b))
    args = (phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pin)
    worst, t = wide.factor_newton_wide_first(*args, L, P)
    H = dense_newton(*args, None)
    definite = np.linalg.eigvalsh(H[:b, :b]).min() > 0
    assert definite == (share < 0.5)
    assert (worst > 0) == definite
    if not definite:
        assert t == 0
