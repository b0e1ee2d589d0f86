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
from ltvmodels.core.laplace import certified_gap, fit_laplace
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


@pytest.mark.parametrize(
    "refinements, guard, factored",
    [
        (0, robust_ipm.KALMAN_RESIDUAL, True),  # the guard trips: the factorization takes over
        # the refinements replace every factorization
        (robust_ipm.KALMAN_REFINEMENTS, robust_ipm.KALMAN_RESIDUAL, False),
        # refinement fails for some predictors and one corrector here: those factor
        (robust_ipm.KALMAN_REFINEMENTS, 1e-14, True),
    ],
)
def test_kalman_directions_agree_with_the_factorization(monkeypatch, refinements, guard, factored):
    """A first difference solves the Newton systems by the Kalman form while its residual
    stays below KALMAN_RESIDUAL, then refines its solutions (KALMAN_REFINEMENTS replayed
    solves of the residual) or, where that fails, factors: the same optimum as the
    factorization alone, which the Kalman form alone (no guard) misses here (its
    downdates cancel once the weights of the zero residuals grow large)."""
    problem, weight, costs, start = _problem(6, 1, q=1, p=3, N=200)
    calls = {"kalman": 0, "replay": 0, "factor": 0}
    kalman_solve, factor = robust_ipm.WeightedRowsKalman.solve, robust_ipm.WeightedRowsFactor

    def counted_solve(self, *args, **kwargs):
        calls["kalman"] += 1
        calls["replay"] += bool(kwargs.get("replay"))
        return kalman_solve(self, *args, **kwargs)

    def counted_factor(*args, **kwargs):
        calls["factor"] += 1
        return factor(*args, **kwargs)

    monkeypatch.setattr(robust_ipm, "KALMAN_REFINEMENTS", refinements)
    monkeypatch.setattr(robust_ipm, "KALMAN_RESIDUAL", guard)
    monkeypatch.setattr(robust_ipm.WeightedRowsKalman, "solve", counted_solve)
    monkeypatch.setattr(robust_ipm, "WeightedRowsFactor", counted_factor)
    kalman = fit_laplace_ipm_diagonal(problem, weight, costs, tol=TOL, max_iter=100, start=start)
    assert calls["kalman"] > 0
    rounds = max(ip.iterations for ip in kalman)
    assert (calls["factor"] > 0) == factored
    if refinements > 0:  # replays beyond the correctors'
        assert calls["replay"] > rounds
    monkeypatch.setattr(robust_ipm.WeightedRowsKalman, "applies", staticmethod(lambda c, w: False))
    factored = fit_laplace_ipm_diagonal(problem, weight, costs, tol=TOL, max_iter=100, start=start)
    for ip, ref in zip(kalman, factored, strict=True):
        assert ip.converged and ref.converged
        assert ip.objective == pytest.approx(ref.objective, rel=1e-9)
        np.testing.assert_allclose(ip.k, ref.k, atol=1e-6 * np.abs(ref.k).max())
    monkeypatch.setattr(robust_ipm.WeightedRowsKalman, "applies", staticmethod(lambda c, w: True))
    monkeypatch.setattr(robust_ipm, "KALMAN_RESIDUAL", np.inf)
    # the directions' errors stall the iterations (or reach a zero slack: they stop there)
    unguarded = fit_laplace_ipm_diagonal(problem, weight, costs, tol=TOL, max_iter=100, start=start)
    assert not all(ip.converged for ip in unguarded)


def test_most_rows_fitted_exactly_at_the_start():
    """Most residuals exactly 0 at the start (median |r| = 0): the starting slacks stay
    positive (a slack scaled by that median vanished in b = |r| + slack, and the zero
    slack was divided by), and the optimum is certified by its own dual point."""
    rng = np.random.default_rng(7)
    N, q, n, p = 40, 1, 2, 2
    phi = rng.standard_normal((N, q, p))
    y = np.zeros((N, q, n))
    y[::4] = rng.standard_normal((N // 4, q, n))  # the other rows are fitted by k = 0
    problem = RegressionProblem(y=y, phi=phi, coeffs=np.array([-1.0, 1.0]))
    weight, costs = np.ones((n, p)), np.ones((N, q, n))
    results = fit_laplace_ipm_diagonal(
        problem, weight, costs, tol=TOL, max_iter=100, start=np.zeros((N, n, p))
    )
    assert all(ip.converged for ip in results)
    theta = np.stack([ip.k for ip in results], axis=1)
    psi = np.stack([ip.psi for ip in results], axis=2)  # costs 1: ψ itself
    objective, gap, rigorous = certified_gap(problem, theta, psi, weight.ravel(), "sq")
    assert rigorous and gap <= 1e-7
    assert objective == pytest.approx(_objective(problem, weight, costs, theta), rel=1e-12)


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
