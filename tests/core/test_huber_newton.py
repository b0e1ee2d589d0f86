"""The compiled Huber iteration (diagonal squared-difference penalty, no priors).

Its exact line search (:func:`line_minimum`, shared with the Python path) is
checked against a brute-force search of the same piecewise quadratic; the
iteration (one pass for the KKT residuals and the Newton rows, the line
search on the residuals alone) against an independent conic solver (cvxpy
with Clarabel) on problems with several outputs and rows per step, missing
rows, row weights and gross outliers; its certificate and objective at
unconverged iterates (computed on residuals kept across steps) against plain
numpy from scratch.
"""

from __future__ import annotations

import numpy as np
import pytest

from ltvmodels.core import huber
from ltvmodels.core.problem import RegressionProblem


def _line_value(alpha, r, g, limits, a, b):
    """Σ h_δ̃(r − αg) + 2αb + α²a by plain numpy."""
    return float(huber.huber_loss(r - alpha * g, limits).sum() + 2.0 * alpha * b + alpha**2 * a)


@pytest.mark.parametrize("seed", range(6))
def test_line_minimum_matches_a_brute_force_search(seed):
    rng = np.random.default_rng(seed)
    N, q = 200, 2
    r = rng.standard_normal((N, q)) * rng.choice([0.3, 3.0], size=(N, q))
    g = rng.standard_normal((N, q)) * rng.uniform(0.1, 2.0)
    limits = rng.uniform(0.2, 1.0, (N, q))
    a = float(rng.uniform(0.0, 50.0))
    b = float(rng.uniform(-50.0, 50.0))
    alpha = huber.line_minimum(r, g, limits, a, b)
    assert 0.0 <= alpha <= 1.0
    grid = np.linspace(0.0, 1.0, 20001)
    values = np.array([_line_value(x, r, g, limits, a, b) for x in grid])
    best = int(np.argmin(values))
    # f is convex: the minimizer lies within one grid cell of the grid's best
    # point, and no point of the grid is lower than f(α)
    assert abs(alpha - grid[best]) <= 1.0 / 20000 + 1e-12
    assert _line_value(alpha, r, g, limits, a, b) <= values[best] + 1e-12 * abs(values[best])


def test_line_minimum_ends_a_line_that_rises_at_once():
    r = np.array([[0.5], [-0.2]])
    g = -r  # the residuals grow along the direction
    limits = np.ones((2, 1))
    assert huber.line_minimum(r, g, limits, 1.0, 0.0) == 0.0
    assert huber.line_minimum(r, np.zeros_like(r), limits, 1.0, -5.0) == 1.0


def _problem(seed: int, order: int, N: int = 120):
    """Several outputs, two rows per step, ~10 % missing rows, row weights, gross outliers."""
    rng = np.random.default_rng(seed)
    q, n, p = 2, 3, 2
    coeffs = np.array([-1.0, 1.0]) if order == 1 else np.array([1.0, -2.0, 1.0])
    observed = rng.random((N, q)) > 0.1
    scale = np.where(observed, rng.uniform(0.5, 2.0, (N, q)), 0.0)
    phi = rng.standard_normal((N, q, p)) * scale[:, :, None]
    k = np.cumsum(0.05 * rng.standard_normal((N, n, p)), axis=0)
    y = np.einsum("tjk,tik->tji", phi, k) + 0.1 * rng.standard_normal((N, q, n))
    hit = rng.random((N, q, n)) < 0.08
    y = np.where(hit, y + rng.choice([-3.0, 3.0], size=y.shape), y) * scale[:, :, None]
    problem = RegressionProblem(y=y, phi=phi, coeffs=coeffs, observed=observed, row_scale=scale)
    weight = rng.uniform(5.0, 50.0, n * p)
    delta = np.array([0.1, 0.15, 0.2])
    return problem, weight, delta


def _clarabel(problem, weight, delta):
    cp = pytest.importorskip("cvxpy")
    N, q, n, p = problem.N, problem.q, problem.n, problem.p
    d = len(problem.coeffs) - 1
    k = cp.Variable((N, n * p))
    terms = []
    for i in range(n):
        ki = k[:, i * p : (i + 1) * p]
        for j in range(q):
            # rows scaled by s: h_{δs}(s r) = s² h_δ(r) in the units of y
            rows = np.flatnonzero(problem.observed[:, j] & (problem.row_scale[:, j] > 0))
            s = problem.row_scale[rows, j]
            fitted = cp.sum(cp.multiply(problem.phi[rows, j, :], ki[rows]), axis=1)
            resid = cp.multiply(1.0 / s, problem.y[rows, j, i] - fitted)
            terms.append(cp.sum(cp.multiply(s**2, cp.huber(resid, delta[i]))))
    Dk = sum(c * k[lag : N - d + lag] for lag, c in enumerate(problem.coeffs))
    terms.append(cp.sum(cp.multiply(np.tile(weight, (N - d, 1)), cp.square(Dk))))
    value = cp.Problem(cp.Minimize(sum(terms)))
    value.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    return float(value.value), np.asarray(k.value).reshape(N, n, p)


@pytest.mark.parametrize("seed, order", [(0, 1), (1, 2), (2, 1)])
def test_compiled_iteration_reaches_the_clarabel_optimum(seed, order):
    problem, weight, delta = _problem(seed, order)
    fit = huber.fit_huber(problem, weight, delta, tol=1e-10)
    assert fit.converged and fit.kkt_residual <= 1e-10
    optimum, k = _clarabel(problem, weight, delta)
    assert fit.objective == pytest.approx(optimum, rel=1e-8)
    np.testing.assert_allclose(fit.theta, k, atol=1e-5)
    r = problem.residuals(fit.theta)
    beyond = (np.abs(r) > delta * problem.row_scale[:, :, None]) & problem.observed[:, :, None]
    np.testing.assert_array_equal(fit.outliers, beyond)
    assert beyond.any()  # the case under test


def test_first_difference_solves_agree_with_the_block_factorization(monkeypatch):
    """A first difference solves the Newton systems by the Kalman form; the outputs it
    leaves (here: all) go to the block Cholesky factorization, and both routes reach
    the same certified fit (rounding may move the last step's KKT residual across
    the tolerance: one step more or less)."""
    problem, weight, delta = _problem(0, 1)
    kalman = huber.fit_huber(problem, weight, delta, tol=1e-10)
    calls = []

    def leave_all(self, phi, a, targets, w, coeffs, active, out, max_reduction):
        calls.append(int(np.count_nonzero(active)))
        return np.array(active, dtype=bool)

    monkeypatch.setattr(huber.WeightedRowsKalman, "solve", leave_all)
    factored = huber.fit_huber(problem, weight, delta, tol=1e-10)
    assert calls and factored.converged and kalman.converged
    assert abs(factored.iterations - kalman.iterations) <= 1
    assert factored.objective == pytest.approx(kalman.objective, rel=1e-12)
    np.testing.assert_allclose(factored.theta, kalman.theta, rtol=0, atol=1e-8)


def test_majorize_minimize_fallback_reaches_the_clarabel_optimum(monkeypatch):
    """Where the Newton direction gives no decrease, an output takes the
    majorize–minimize step (a squared-loss fit with Huber's weights, by the block
    factorization) instead. Forced here: two of the Kalman form's Newton solutions
    are reflected through 0, which points most outputs uphill; the fit still
    reaches the optimum and its certificate."""
    problem, weight, delta = _problem(1, 1)
    solve, factor = huber.WeightedRowsKalman.solve, huber.WeightedRowsFactor.__init__
    newton, majorizer = [], []

    def reflected(self, phi, a, targets, w, coeffs, active, out, max_reduction):
        unsolved = solve(self, phi, a, targets, w, coeffs, active, out, max_reduction=max_reduction)
        newton.append(int(np.count_nonzero(active)))
        if len(newton) in (2, 3):
            out[active] *= -1.0
        return unsolved

    def counted(self, *args, **kwargs):
        majorizer.append(1)
        factor(self, *args, **kwargs)

    monkeypatch.setattr(huber.WeightedRowsKalman, "solve", reflected)
    monkeypatch.setattr(huber.WeightedRowsFactor, "__init__", counted)
    fit = huber.fit_huber(problem, weight, delta, tol=1e-10)
    assert majorizer  # the case under test: a first difference factors only there
    assert fit.converged and fit.kkt_residual <= 1e-10
    optimum, k = _clarabel(problem, weight, delta)
    assert fit.objective == pytest.approx(optimum, rel=1e-8)
    np.testing.assert_allclose(fit.theta, k, atol=1e-5)


def _kkt_and_objective(problem, weight, delta, theta):
    """Relative ‖∇F‖∞ per output and F at theta (N, n, p), by plain numpy."""
    N, n, p = problem.N, problem.n, problem.p
    d = len(problem.coeffs) - 1
    thresholds = delta * problem.row_scale[:, :, None]
    r = problem.residuals(theta)
    psi = np.clip(r, -thresholds, thresholds)
    data = -2.0 * np.einsum("tji,tjk->tik", psi, problem.phi)  # (N, n, p)
    w = weight.reshape(n, p)
    Dk = sum(c * theta[lag : N - d + lag] for lag, c in enumerate(problem.coeffs))
    penalty = np.zeros_like(theta)
    for lag, c in enumerate(problem.coeffs):
        penalty[lag : N - d + lag] += 2.0 * c * w * Dk
    largest = np.maximum(np.abs(data).max(axis=(0, 2)), np.abs(penalty).max(axis=(0, 2)))
    kkt = np.abs(data + penalty).max(axis=(0, 2)) / largest
    objective = huber.huber_loss(r, thresholds).sum() + np.sum(w * Dk * Dk)
    return kkt, float(objective)


@pytest.mark.parametrize("seed, order", [(3, 1), (4, 2)])
def test_iterates_certificate_and_objective_match_plain_numpy(seed, order):
    """The compiled pass evaluates the KKT residual on residuals kept across steps (each
    step updates them by −αφᵀd) and, for a first difference, without the loop over
    lags; after 1, 2 and 3 steps (not yet converged) its certificate and objective
    are those of the iterate, formed from scratch."""
    problem, weight, delta = _problem(seed, order)
    for steps in (1, 2, 3):
        fit = huber.fit_huber(problem, weight, delta, tol=1e-10, max_iter=steps)
        kkt, objective = _kkt_and_objective(problem, weight, delta, fit.theta)
        assert fit.iterations == steps and not fit.converged
        assert fit.kkt_residual == pytest.approx(kkt.max(), rel=1e-6)
        assert fit.objective == pytest.approx(objective, rel=1e-12)
    fit = huber.fit_huber(problem, weight, delta, tol=1e-10)
    kkt, objective = _kkt_and_objective(problem, weight, delta, fit.theta)
    assert fit.converged and kkt.max() <= 1e-9
    assert fit.objective == pytest.approx(objective, rel=1e-12)


@pytest.mark.parametrize("n", [1, 3])
def test_the_start_is_not_changed(n):
    """The compiled iteration reads the start into its own layout, which for one output
    is the start's own memory: it must copy it all the same."""
    rng = np.random.default_rng(n)
    N, p = 300, 2
    phi = rng.standard_normal((N, 1, p))
    y = rng.standard_normal((N, 1, n)) + np.where(rng.random((N, 1, n)) < 0.05, 8.0, 0.0)
    problem = RegressionProblem(y=y, phi=phi, coeffs=np.array([-1.0, 1.0]))
    start = rng.standard_normal((N, n, p))
    given = start.copy()
    fit = huber.fit_huber(problem, np.full(n * p, 50.0), np.full(n, 0.5), start=start)
    assert fit.converged
    np.testing.assert_array_equal(start, given)
