"""``fit(norm="sq")`` against the dense closed form (paper eq:closedform).

k = (Φ̃ᵀΦ̃ + D̃ᵀW̃D̃)⁻¹ Φ̃ᵀỸ and Cov(k) = σ² (Φ̃ᵀΦ̃ + D̃ᵀW̃D̃)⁻¹ are built with plain
numpy in ``dense_reference.py`` (no package code), for first, second and
third-order (polynomial) differences, with and without inputs, and scalar,
vector and matrix weights. Where the fit estimates σ², the reference
computes its own estimate from the dense solution (``ml_noise_var``:
σ̂_i² = (RSS_i + penalty_i) / (N − diffuse unknowns of row i), the maximizer
of the dense likelihood) rather than borrowing the model's ``noise_var``.
"""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import DenseProblem, diag_blocks, random_data, relerr, row_scale

import ltvmodels as ltv

ORDERS = [1, 2, [-1, 3, -3, 1]]
ORDER_IDS = ["order1", "order2", "poly3"]
TOL = 1e-8


def make_lam(kind: str, K: int, seed: int):
    rng = np.random.default_rng(seed)
    if kind == "scalar":
        return 1.3
    if kind == "vector":
        return rng.uniform(0.3, 3.0, K)
    G = rng.standard_normal((K, K))
    return G @ G.T / K + 0.2 * np.eye(K)


@pytest.mark.parametrize("order", ORDERS, ids=ORDER_IDS)
@pytest.mark.parametrize("m", [0, 2], ids=["no-input", "2-inputs"])
@pytest.mark.parametrize("kind", ["scalar", "vector", "matrix"])
def test_fit_equals_dense_closed_form(order, m, kind):
    n, T = 2, 25
    x, u = random_data(100 + m, T, n, m)
    K = n * (n + m)
    lam = make_lam(kind, K, seed=7)
    model = ltv.fit(x, u, lam=lam, order=order)
    ref = DenseProblem(x, u, order, lam)
    k, H_inv = ref.solve()
    N = T - 1
    assert model.k.shape == (N, K)
    assert relerr(model.k, k) < TOL
    # σ̂² from the dense solution: one per output, shared where a matrix λ couples the rows
    s2 = ref.ml_noise_var()
    np.testing.assert_allclose(model.noise_var, s2, rtol=1e-10)
    assert (s2[0] == s2[1]) == (kind == "matrix")
    # Posterior covariances: σ̂² × diagonal blocks of the dense inverse.
    assert relerr(model.cov_full(), row_scale(s2, n, n + m) * diag_blocks(H_inv, N, K)) < TOL
    # The layout k_t = hstack([A_t, B_t]).ravel().
    theta = k.reshape(N, n, n + m)
    np.testing.assert_allclose(model.A, theta[:, :, :n], rtol=0, atol=TOL * np.abs(k).max())
    np.testing.assert_allclose(model.B, theta[:, :, n:], rtol=0, atol=TOL * np.abs(k).max())
    # The objective reported in info is the value of the cost at the optimum.
    assert model.info["objective"] == pytest.approx(ref.objective(k), rel=1e-9)


def test_scalar_lam_covariance_is_compact_and_shared_by_rows():
    """With one noise variance for all outputs the rows share one (N, p, p) covariance."""
    x, u = random_data(3, 30, 3, 1)
    model = ltv.fit(x, u, lam=2.0, noise_var=0.3)
    N, n, p = 29, 3, 4
    assert model.cov.shape == (N, p, p)
    # estimated per output, the rows' covariances differ by their σ_i²
    own = ltv.fit(x, u, lam=2.0)
    assert own.cov.shape == (N, n, p, p) and len(set(own.noise_var)) == n
    ref = DenseProblem(x, u, 1, 2.0)
    _, H_inv = ref.solve()
    np.testing.assert_allclose(own.noise_var, ref.ml_noise_var(), rtol=1e-10)
    assert (
        relerr(own.cov_full(), row_scale(ref.ml_noise_var(), n, p) * diag_blocks(H_inv, N, n * p))
        < TOL
    )
    full = 0.3 * diag_blocks(H_inv, N, n * p)
    for i in range(n):  # every output row has the same p × p block, rows independent
        sl = slice(i * p, (i + 1) * p)
        assert relerr(model.cov, full[:, sl, sl]) < TOL
    assert np.abs(full[:, :p, p:]).max() < 1e-12 * np.abs(full).max()
    np.testing.assert_allclose(model.std(), np.sqrt(np.diagonal(full, axis1=1, axis2=2)), rtol=1e-8)


def test_given_noise_var_scales_covariance_only():
    x, u = random_data(4, 30, 2, 1)
    a = ltv.fit(x, u, lam=1.5, noise_var=0.25)
    b = ltv.fit(x, u, lam=1.5, noise_var=4.0)
    ref = DenseProblem(x, u, 1, 1.5)
    k, H_inv = ref.solve()
    assert relerr(a.k, k) < TOL and relerr(b.k, k) < TOL
    assert np.all(a.noise_var == 0.25) and np.all(b.noise_var == 4.0)
    assert relerr(a.cov_full(), 0.25 * diag_blocks(H_inv, 29, 6)) < TOL
    assert relerr(b.cov_full(), 4.0 * diag_blocks(H_inv, 29, 6)) < TOL


def test_compute_cov_false_gives_same_estimate_without_cov():
    x, u = random_data(5, 30, 2, 1)
    a = ltv.fit(x, u, lam=1.5, order=2)
    b = ltv.fit(x, u, lam=1.5, order=2, compute_cov=False)
    assert b.cov is None and b.cov_full() is None and b.std() is None
    np.testing.assert_allclose(b.k, a.k, rtol=1e-12, atol=1e-14)
    assert b.noise_var == pytest.approx(a.noise_var, rel=1e-12)
    assert b.loglik == pytest.approx(a.loglik, rel=1e-12)


@pytest.mark.parametrize("order", [1, 2, [-1, 3, -3, 1]], ids=ORDER_IDS)
@pytest.mark.parametrize("const_idx", [[1], [2, 5], [2, 5, 8]], ids=["one", "two", "whole-column"])
def test_constant_coefficients_equal_shared_unknown_reference(order, const_idx):
    """λ_j = inf: coefficient j is one unknown shared by every time step."""
    n, m, T = 3, 0, 30
    x, u = random_data(6, T, n, m)
    x = np.hstack([x[:, :2], random_data(7, T, 1, 0)[0]])
    K = n * n
    lam = np.random.default_rng(8).uniform(0.5, 2.0, K)
    lam[const_idx] = np.inf
    model = ltv.fit(x, u, lam=lam, order=order)
    ref = DenseProblem(x, u, order, lam)
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < TOL
    assert np.ptp(model.k[:, const_idx], axis=0).max() == 0.0  # exactly constant
    s2 = ref.ml_noise_var()  # a constant coefficient is one diffuse unknown of its row
    np.testing.assert_allclose(model.noise_var, s2, rtol=1e-10)
    assert relerr(model.cov_full(), row_scale(s2, n, n) * diag_blocks(H_inv, T - 1, K)) < TOL


def test_constant_input_column_with_inputs():
    """A whole input column constant (every row): B constant, A varying."""
    n, m, T = 2, 1, 40
    x, u = random_data(9, T, n, m)
    K = n * (n + m)
    lam = np.full(K, 1.2)
    lam[[2, 5]] = np.inf  # B[0, 0] and B[1, 0]
    model = ltv.fit(x, u, lam=lam, order=2)
    ref = DenseProblem(x, u, 2, lam)
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < TOL
    assert np.ptp(model.B, axis=0).max() == 0.0
    s2 = ref.ml_noise_var()
    np.testing.assert_allclose(model.noise_var, s2, rtol=1e-10)
    assert relerr(model.cov_full(), row_scale(s2, n, n + m) * diag_blocks(H_inv, T - 1, K)) < TOL


def test_free_coefficient_interpolates_exactly():
    """λ = 0 for the only coefficient of a scalar system: a_t = x_{t+1} / x_t."""
    x, _ = random_data(10, 20, 1, 0)
    model = ltv.fit(x, lam=[0.0], noise_var=1.0)
    np.testing.assert_allclose(model.A[:, 0, 0], x[1:, 0] / x[:-1, 0], rtol=1e-10)
    ref = DenseProblem(x, None, 1, [0.0])
    k, H_inv = ref.solve()
    assert relerr(model.cov_full(), diag_blocks(H_inv, 19, 1)) < TOL


@pytest.mark.parametrize("order, coeffs", [(2, [1, -2, 1]), (3, [-1, 3, -3, 1]), (1, [-1, 1])])
def test_integer_order_equals_its_coefficients(order, coeffs):
    x, u = random_data(11, 30, 2, 1)
    a = ltv.fit(x, u, lam=2.0, order=order)
    b = ltv.fit(x, u, lam=2.0, order=coeffs)
    np.testing.assert_allclose(a.k, b.k, rtol=1e-12, atol=1e-13)
    np.testing.assert_array_equal(a.coeffs, np.asarray(coeffs, float))


def test_other_polynomials_equal_dense_reference():
    """Polynomials with roots other than 1 (Proposition 1): (z−1)(z+1), (z−1)(z−0.5), (z−1)(z−2)."""
    x, u = random_data(12, 30, 2, 1)
    for coeffs in ([-1.0, 0.0, 1.0], [0.5, -1.5, 1.0], [2.0, -3.0, 1.0]):
        model = ltv.fit(x, u, lam=1.7, order=coeffs)
        ref = DenseProblem(x, u, coeffs, 1.7)
        k, H_inv = ref.solve()
        assert relerr(model.k, k) < TOL, coeffs
        s2 = ref.ml_noise_var()
        np.testing.assert_allclose(model.noise_var, s2, rtol=1e-10, err_msg=str(coeffs))
        assert relerr(model.cov_full(), row_scale(s2, 2, 3) * diag_blocks(H_inv, 29, 6)) < TOL


def test_scalar_lam_equals_isotropic_matrix_and_vector():
    x, u = random_data(13, 30, 2, 1)
    K = 6
    a = ltv.fit(x, u, lam=1.7)
    b = ltv.fit(x, u, lam=np.full(K, 1.7))
    c = ltv.fit(x, u, lam=1.7**2 * np.eye(K))
    np.testing.assert_allclose(b.k, a.k, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(c.k, a.k, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(c.cov_full(), a.cov_full(), rtol=1e-10, atol=1e-14)
    assert c.loglik == pytest.approx(a.loglik, rel=1e-10)
    assert b.loglik == pytest.approx(a.loglik, rel=1e-10)


@pytest.mark.parametrize("pattern", ["all-rows-equal", "two-groups"])
def test_vector_lam_rows_sharing_a_factorization(pattern):
    """Rows of Θ with identical weights share one system; the others get their own."""
    n, m, T = 3, 1, 30
    x, u = random_data(14, T, n, m)
    v = np.array([1.0, 2.0, 0.5, 3.0])
    lam = np.tile(v, n) if pattern == "all-rows-equal" else np.r_[v, v, 2 * v]
    model = ltv.fit(x, u, lam=lam, noise_var=0.5)
    k, H_inv = DenseProblem(x, u, 1, lam).solve()
    full = 0.5 * diag_blocks(H_inv, T - 1, n * (n + m))  # the given σ²
    assert relerr(model.k, k) < TOL
    assert relerr(model.cov_full(), full) < TOL
    assert relerr(model.std(), np.sqrt(np.diagonal(full, axis1=1, axis2=2))) < TOL
    assert model.cov_shared_by_rows == (pattern == "all-rows-equal")


@pytest.mark.parametrize("compute_cov", [False, True])
def test_squared_norm_equals_scipys_banded_cholesky(compute_cov):
    """The normal equations H θ_i = Φᵀy_i, H = blkdiag φ_tφ_tᵀ + λ²DᵀD ⊗ I_p (order 1),
    in LAPACK's banded storage, solved by scipy.linalg.cholesky_banded: the same θ."""
    from scipy.linalg import cho_solve_banded, cholesky_banded

    data = ltv.systems.random_walk_system(T=300, n=3, m=2, seed=4)
    lam = 7.0
    phi, y = np.hstack([data.x[:-1], data.u[:-1]]), data.x[1:]
    N, p = phi.shape
    dtd = np.full(N, 2.0)
    dtd[[0, -1]] = 1.0
    ab = np.zeros((p + 1, N * p))  # ab[a − b, t·p + b] = H[t·p + a, t·p + b]
    for offset in range(p):
        b = np.arange(p - offset)
        ab[offset].reshape(N, p)[:, b] = phi[:, b + offset] * phi[:, b]
    ab[0] += np.repeat(lam**2 * dtd, p)
    ab[p, : (N - 1) * p] = -(lam**2)
    rhs = (phi[:, :, None] * y[:, None, :]).reshape(N * p, -1)
    theta = cho_solve_banded((cholesky_banded(ab, lower=True), True), rhs)
    expected = theta.reshape(N, p, -1).transpose(0, 2, 1)  # (N, n, p)
    model = ltv.fit(data.x, data.u, lam=lam, compute_cov=compute_cov)
    np.testing.assert_allclose(model.k.reshape(N, 3, p), expected, rtol=1e-10, atol=1e-12)
