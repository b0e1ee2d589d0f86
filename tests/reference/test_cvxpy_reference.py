"""``fit`` against an independent convex solver: cvxpy with Clarabel.

The objective is written out in cvxpy from the definition (paper eq:slow,
eq:smooth, eq:prioropt):

    Σ_t ‖x_{t+1} − A_t x_t − B_t u_t‖² + Σ_t (Dk)_tᵀ W (Dk)_t
    + σ² Σ_t ‖μ_t − k_t‖²_{Σ⁻¹} + σ² Σ_t ‖ȳ_t − Θ_t φ_t‖²_{S⁻¹}.
"""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import coefficients, difference_matrix, random_spd, relerr, simulate_ltv

import ltvmodels as ltv

cp = pytest.importorskip("cvxpy")
if "CLARABEL" not in cp.installed_solvers():  # pragma: no cover
    pytest.skip("cvxpy without the Clarabel solver", allow_module_level=True)


def cvxpy_solution(x, u, order, W_sqrt, *, priors=(), output_priors=(), sigma2=1.0):
    """Minimize the objective with cvxpy/Clarabel; W = W_sqrt W_sqrtᵀ."""
    phi = np.hstack([x[:-1], u[:-1]])
    y = x[1:]
    N, p = phi.shape
    n = y.shape[1]
    K = n * p
    D = difference_matrix(N, coefficients(order))
    k = cp.Variable((N, K))
    # Row i of Θ_t is k_t[i p:(i+1) p]; prediction (N, n).
    pred = cp.hstack(
        [
            cp.reshape(
                cp.sum(cp.multiply(k[:, i * p : (i + 1) * p], phi), axis=1), (N, 1), order="C"
            )
            for i in range(n)
        ]
    )
    obj = cp.sum_squares(y - pred) + cp.sum_squares((D @ k) @ W_sqrt)
    for mean, cov in priors:
        L_inv = np.linalg.inv(np.linalg.cholesky(cov))  # cov⁻¹ = L_invᵀ L_inv
        obj += sigma2 * cp.sum_squares((mean - k) @ L_inv.T)
    for mean, cov in output_priors:
        L_inv = np.linalg.inv(np.linalg.cholesky(cov))
        obj += sigma2 * cp.sum_squares((mean - pred) @ L_inv.T)
    problem = cp.Problem(cp.Minimize(obj))
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    assert problem.status == "optimal"
    return k.value, problem.value


def test_order2_vector_lam_matches_cvxpy():
    x, u, _ = simulate_ltv(21, T=25, n=2, m=1)
    K = 6
    lam = np.random.default_rng(0).uniform(0.5, 3.0, K)
    k_ref, value = cvxpy_solution(x, u, 2, np.diag(lam))
    model = ltv.fit(x, u, lam=lam, order=2)
    assert relerr(model.k, k_ref) < 1e-6
    assert model.info["objective"] == pytest.approx(value, rel=1e-6)


def test_poly3_scalar_lam_matches_cvxpy():
    x, u, _ = simulate_ltv(22, T=25, n=2, m=1)
    k_ref, value = cvxpy_solution(x, u, [-1, 3, -3, 1], 1.5 * np.eye(6))
    model = ltv.fit(x, u, lam=1.5, order=[-1, 3, -3, 1])
    assert relerr(model.k, k_ref) < 1e-6
    assert model.info["objective"] == pytest.approx(value, rel=1e-6)


def test_matrix_lam_with_parameter_and_output_priors_matches_cvxpy():
    rng = np.random.default_rng(1)
    x, u, k_true = simulate_ltv(23, T=25, n=2, m=1)
    N, K = k_true.shape
    G = rng.standard_normal((K, K))
    Lam = G @ G.T + np.eye(K)
    mu = k_true + 0.1 * rng.standard_normal(k_true.shape)
    S0 = random_spd(rng, K, 0.2)
    ybar = x[1:] + 0.05 * rng.standard_normal((N, 2))
    S1 = random_spd(rng, 2, 0.1)
    sigma2 = 0.3
    k_ref, value = cvxpy_solution(
        x,
        u,
        1,
        np.linalg.cholesky(Lam),
        priors=[(mu, S0)],
        output_priors=[(ybar, S1)],
        sigma2=sigma2,
    )
    model = ltv.fit(
        x,
        u,
        lam=Lam,
        order=1,
        prior=[ltv.Prior(mu, S0), ltv.OutputPrior(ybar, S1)],
        noise_var=sigma2,
    )
    assert relerr(model.k, k_ref) < 1e-6
    assert model.info["objective"] == pytest.approx(value, rel=1e-6)
