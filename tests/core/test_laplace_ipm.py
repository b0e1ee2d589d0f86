"""The Laplacian loss with a diagonal squared-difference penalty, all outputs at once.

:func:`fit_laplace_ipm_diagonal` is checked against an independent conic solver
(cvxpy with Clarabel) and against the output-by-output interior-point method
(:func:`fit_robust_ipm_squared`) on small problems with several outputs,
missing rows, row weights and first and second differences.
"""

from __future__ import annotations

import numpy as np
import pytest

from ltvmodels.core import robust_ipm
from ltvmodels.core.laplace import fit_laplace
from ltvmodels.core.problem import RegressionProblem
from ltvmodels.core.robust_ipm import fit_laplace_ipm_diagonal, fit_robust_ipm_squared

TOL = 1e-9


def _problem(seed: int, order: int, q: int = 2, n: int = 3, p: int = 2, N: int = 60):
    """A random problem with heavy-tailed noise, ~10 % missing rows and row weights."""
    rng = np.random.default_rng(seed)
    coeffs = np.array([-1.0, 1.0]) if order == 1 else np.array([1.0, -2.0, 1.0])
    observed = rng.random((N, q)) > 0.1
    scale = np.where(observed, rng.uniform(0.5, 2.0, (N, q)), 0.0)
    phi = rng.standard_normal((N, q, p)) * scale[:, :, None]
    y = (rng.standard_normal((N, q, n)) + rng.standard_t(1.5, (N, q, n))) * scale[:, :, None]
    problem = RegressionProblem(y=y, phi=phi, coeffs=coeffs, observed=observed, row_scale=scale)
    weight = rng.uniform(0.5, 20.0, (n, p))
    costs = np.repeat(scale[:, :, None], n, axis=2)
    start = 0.1 * rng.standard_normal((N, n, p))
    return problem, weight, costs, start


def _objective(problem, weight, costs, theta):
    """Σ s|r̃| + Σ_t (Dk)_tᵀ diag(w) (Dk)_t at Θ (N, n, p), by plain numpy."""
    r = problem.y - np.einsum("tjk,tik->tji", problem.phi, theta)
    d = len(problem.coeffs) - 1
    difference = sum(c * theta[lag : problem.N - d + lag] for lag, c in enumerate(problem.coeffs))
    return float(np.sum(costs * np.abs(r)) + np.sum(weight[None] * difference**2))


@pytest.mark.parametrize("seed, order", [(0, 1), (1, 2), (2, 1)])
def test_matches_clarabel(seed, order):
    cp = pytest.importorskip("cvxpy")
    problem, weight, costs, start = _problem(seed, order)
    results = fit_laplace_ipm_diagonal(problem, weight, costs, tol=TOL, max_iter=100, start=start)
    assert all(ip.converged for ip in results)
    theta = np.stack([ip.k for ip in results], axis=1)
    ours = _objective(problem, weight, costs, theta)
    assert ours == pytest.approx(sum(ip.objective for ip in results), rel=1e-12)
    N, q, n, p = problem.N, problem.q, problem.n, problem.p
    d = len(problem.coeffs) - 1
    k = cp.Variable((N, n * p))
    terms = []
    for i in range(n):
        ki = k[:, i * p : (i + 1) * p]
        for j in range(q):
            fitted = cp.sum(cp.multiply(problem.phi[:, j, :], ki), axis=1)
            terms.append(cp.sum(cp.multiply(costs[:, j, i], cp.abs(problem.y[:, j, i] - fitted))))
        difference = sum(c * ki[lag : N - d + lag] for lag, c in enumerate(problem.coeffs))
        terms.append(cp.sum(cp.multiply(np.sqrt(weight[i])[None, :], difference) ** 2))
    reference = cp.Problem(cp.Minimize(sum(terms)))
    reference.solve(solver=cp.CLARABEL, tol_gap_abs=1e-11, tol_gap_rel=1e-11, tol_feas=1e-11)
    assert ours == pytest.approx(reference.value, rel=1e-7)


@pytest.mark.parametrize("seed, order", [(3, 1), (4, 2)])
def test_matches_output_by_output(seed, order):
    """The same optimum (and dual pairing) as each output alone by the general method."""
    problem, weight, costs, start = _problem(seed, order)
    results = fit_laplace_ipm_diagonal(problem, weight, costs, tol=TOL, max_iter=100, start=start)
    for i, ip in enumerate(results):
        part = RegressionProblem(
            y=problem.y[:, :, i : i + 1],
            phi=problem.phi,
            coeffs=problem.coeffs,
            observed=problem.observed,
            row_scale=problem.row_scale,
        )
        alone = fit_robust_ipm_squared(
            part, weight[i], "laplace", costs[:, :, i], tol=TOL, max_iter=100, start=start[:, i]
        )
        assert ip.converged and alone.converged
        assert ip.objective == pytest.approx(alone.objective, rel=1e-8)
        assert ip.k.shape == alone.k.shape
        # the pairing ζ⁺ − ζ⁻ lies in the box [−c, c] (up to the stationarity residual
        # in b, c − ζ⁺ − ζ⁻) and agrees where the optimum fixes it
        assert np.all(np.abs(ip.psi) <= costs[:, :, i] + 1e-6 * costs.max())
        fixed = np.abs(alone.psi) < 0.5 * costs[:, :, i]  # not on a kink's edge
        assert np.allclose(ip.psi[fixed], alone.psi[fixed], atol=1e-4)


def test_kalman_directions_agree_with_the_factorization(monkeypatch):
    """A first difference solves the Newton systems by the Kalman form while its residual
    stays below KALMAN_RESIDUAL, then by the block Cholesky factorization: the same
    optimum as the factorization alone, which the Kalman form alone (no guard) misses
    here (its downdates cancel once the weights of the zero residuals grow large)."""
    problem, weight, costs, start = _problem(6, 1, q=1, p=3, N=200)
    calls = {"kalman": 0, "factor": 0}
    kalman_solve, factor = robust_ipm.WeightedRowsKalman.solve, robust_ipm.WeightedRowsFactor

    def counted_solve(self, *args, **kwargs):
        calls["kalman"] += 1
        return kalman_solve(self, *args, **kwargs)

    def counted_factor(*args, **kwargs):
        calls["factor"] += 1
        return factor(*args, **kwargs)

    monkeypatch.setattr(robust_ipm.WeightedRowsKalman, "solve", counted_solve)
    monkeypatch.setattr(robust_ipm, "WeightedRowsFactor", counted_factor)
    kalman = fit_laplace_ipm_diagonal(problem, weight, costs, tol=TOL, max_iter=100, start=start)
    assert calls["kalman"] > 0 and calls["factor"] > 0  # both routes taken
    monkeypatch.setattr(robust_ipm.WeightedRowsKalman, "applies", staticmethod(lambda c, w: False))
    factored = fit_laplace_ipm_diagonal(problem, weight, costs, tol=TOL, max_iter=100, start=start)
    for ip, ref in zip(kalman, factored, strict=True):
        assert ip.converged and ref.converged
        assert ip.objective == pytest.approx(ref.objective, rel=1e-9)
        np.testing.assert_allclose(ip.k, ref.k, atol=1e-6 * np.abs(ref.k).max())
    monkeypatch.setattr(robust_ipm.WeightedRowsKalman, "applies", staticmethod(lambda c, w: True))
    monkeypatch.setattr(robust_ipm, "KALMAN_RESIDUAL", np.inf)
    try:  # the directions' errors stall the iterations, or reach a zero slack
        unguarded = fit_laplace_ipm_diagonal(
            problem, weight, costs, tol=TOL, max_iter=100, start=start
        )
        failed = not all(ip.converged for ip in unguarded)
    except ZeroDivisionError:
        failed = True
    assert failed


def test_fit_laplace_matrix_and_vector_weight_agree():
    """A diagonal penalty given as a (K, K) matrix takes the same path as its (K,) diagonal."""
    problem, weight, _, start = _problem(5, 1)
    delta = np.ones(problem.n)
    vector = fit_laplace(problem, weight.ravel(), "sq", delta, max_iter=100, tol=1e-8, start=start)
    matrix = fit_laplace(
        problem, np.diag(weight.ravel()), "sq", delta, max_iter=100, tol=1e-8, start=start
    )
    assert vector.converged and matrix.converged and vector.rigorous
    assert np.array_equal(vector.theta, matrix.theta)
    costs = np.repeat(problem.row_scale[:, :, None], problem.n, axis=2)
    assert vector.objective == pytest.approx(_objective(problem, weight, costs, vector.theta))
