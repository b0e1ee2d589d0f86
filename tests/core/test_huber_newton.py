"""The compiled Huber iteration (diagonal squared-difference penalty, no priors).

Its exact line search (:func:`line_minimum`, shared with the Python path) is
checked against a brute-force search of the same piecewise quadratic; the
iteration (one pass for the KKT residuals and the Newton rows, the line
search on the residuals alone) against an independent conic solver (cvxpy
with Clarabel) on problems with several outputs and rows per step, missing
rows, row weights and gross outliers.
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

    def leave_all(self, phi, a, targets, w, coeffs, active, out):
        calls.append(int(np.count_nonzero(active)))
        return np.array(active, dtype=bool)

    monkeypatch.setattr(huber.WeightedRowsKalman, "solve", leave_all)
    factored = huber.fit_huber(problem, weight, delta, tol=1e-10)
    assert calls and factored.converged and kalman.converged
    assert abs(factored.iterations - kalman.iterations) <= 1
    assert factored.objective == pytest.approx(kalman.objective, rel=1e-12)
    np.testing.assert_allclose(factored.theta, kalman.theta, rtol=0, atol=1e-8)


def _state_arrays(problem, weight, delta, seed):
    """The compiled state pass's inputs at a point k near the fit, laid out per output."""
    rng = np.random.default_rng(seed)
    N, n, p = problem.N, problem.n, problem.p
    thresholds = delta[None, None, :] * problem.row_scale[:, :, None]
    k = rng.standard_normal((n, N, p)) * 0.1
    return dict(
        phi=np.ascontiguousarray(problem.phi),
        y=np.ascontiguousarray(problem.y.transpose(2, 0, 1)),
        limits=np.ascontiguousarray(thresholds.transpose(2, 0, 1)),
        k=k,
        w=weight.reshape(n, p).copy(),
        coeffs=np.asarray(problem.coeffs, dtype=float),
    )


def _state(s, damping, known_resid=None):
    """(KKT residuals, a, targets, rhs, residuals) of the state pass at s['k']."""
    n, N, q = s["y"].shape
    p = s["phi"].shape[2]
    out, a, targets = np.empty(n), np.empty((N, q, n)), np.empty((N, q, n))
    rhs = np.empty((n, N, p, 1))
    resid = np.empty((n, N, q)) if known_resid is None else known_resid.copy()
    known = np.full(n, known_resid is not None)
    on = np.ones(n, dtype=bool)
    huber._newton_state(
        s["phi"], s["y"], s["limits"], s["k"], s["w"], s["coeffs"], damping, on, on,
        out, a, targets, rhs, resid, known,
    )  # fmt: skip
    assert known.all()
    return out, a, targets, rhs, resid


@pytest.mark.parametrize("seed", [0, 3])
def test_first_difference_passes_equal_the_general_ones(seed):
    """The state pass and the line search's direction pass have a first-difference form
    (no ring buffer, no loop over lags): the same sums in the same order as the
    general form, so the same bits."""
    problem, weight, delta = _problem(seed, 1)
    s = _state_arrays(problem, weight, delta, seed)
    damping = np.array([0.0, 1e-2, 1.0])
    n = s["k"].shape[0]
    for c in range(n):
        general, first = [], []
        for kernel, into in (
            (huber._difference_state, general),
            (huber._first_difference_state, first),
        ):
            N, q = s["y"].shape[1:]
            a, targets = np.zeros((N, q, n)), np.zeros((N, q, n))
            rhs, resid = np.zeros((n, N, s["phi"].shape[2], 1)), np.zeros((n, N, q))
            value = kernel(
                s["phi"], s["y"], s["limits"], s["k"], s["w"], s["coeffs"], damping,
                np.ones(n, dtype=bool), a, targets, rhs, resid, np.zeros(n, dtype=bool), c,
            )  # fmt: skip
            into.extend([value, a, targets, rhs, resid])
        for x, z in zip(general, first):
            np.testing.assert_array_equal(x, z)
    model = s["k"] + 0.01 * np.random.default_rng(seed).standard_normal(s["k"].shape)
    for c in range(n):
        g1, g2 = np.empty(s["y"].shape[1:]), np.empty(s["y"].shape[1:])
        one = huber._direction(s["phi"], s["k"][c], model[c], s["w"][c], s["coeffs"], g1)
        two = huber._first_difference_direction(
            s["phi"], s["k"][c], model[c], s["w"][c], s["coeffs"], g2
        )
        assert one == two
        np.testing.assert_array_equal(g1, g2)
        # and both against plain numpy: g = φᵀd, the penalty along the line
        d = model[c] - s["k"][c]
        np.testing.assert_allclose(g1, np.einsum("tjk,tk->tj", s["phi"], d), rtol=1e-12)
        Dd, Dk = np.diff(d, axis=0), np.diff(s["k"][c], axis=0)
        expected = [
            np.sum(s["w"][c] * Dd * Dd),
            np.sum(s["w"][c] * Dd * Dk),
            np.sum(s["w"][c] * Dk * Dk),
        ]
        np.testing.assert_allclose(one, expected, rtol=1e-12)


@pytest.mark.parametrize("order", [1, 2])
def test_state_pass_reads_the_residuals_it_is_given(order):
    """Given the residuals at k (kept across steps), the state pass forms the same KKT
    residuals and Newton rows as from k itself, to rounding; without them it forms
    and stores y − φk."""
    problem, weight, delta = _problem(4, order)
    s = _state_arrays(problem, weight, delta, 4)
    damping = np.array([0.0, 1e-2, 1.0])
    formed = _state(s, damping)
    np.testing.assert_allclose(
        formed[4], s["y"] - np.einsum("tjk,ctk->ctj", s["phi"], s["k"]), rtol=0, atol=1e-12
    )
    # residuals off by rounding, as a step's update r − αg leaves them
    nudged = formed[4] * (1 + 1e-15)
    given = _state(s, damping, known_resid=nudged)
    np.testing.assert_array_equal(given[4], nudged)  # read, not formed again
    np.testing.assert_allclose(given[0], formed[0], rtol=1e-9, atol=1e-13)
    for x, z in zip(formed[1:4], given[1:4]):
        np.testing.assert_allclose(x, z, rtol=1e-9, atol=1e-12)


def test_majorizer_fallback_forms_the_residuals_again(monkeypatch):
    """A line search that finds no decrease falls back to the majorize–minimize step,
    from k (the line search has overwritten the kept residuals with the trial
    point's): the fit with every output's first line search refused reaches the
    same certified optimum, its objective that of its own residuals."""
    problem, weight, delta = _problem(5, 1)
    plain = huber.fit_huber(problem, weight, delta, tol=1e-10)
    search = huber._line_search
    refused = set()

    def refuse_first(phi, limits, k, model, w, coeffs, r, g):
        alpha, value, trial = search(phi, limits, k, model, w, coeffs, r, g)
        if k.ctypes.data not in refused:  # each output's k: its own memory
            refused.add(k.ctypes.data)
            return 0.0, value, value
        return alpha, value, trial

    steps = []
    majorizer = huber._majorizer_step

    def record(phi, y, limits, k, w, coeffs, c, a, targets, model, *rest):
        start = k[c].copy()
        factors = majorizer(phi, y, limits, k, w, coeffs, c, a, targets, model, *rest)
        steps.append((c, start, model[c, :, :, 0].copy()))
        return factors

    monkeypatch.setattr(huber, "_line_search", refuse_first)
    monkeypatch.setattr(huber, "_majorizer_step", record)
    fit = huber.fit_huber(problem, weight, delta, tol=1e-10)
    assert len(refused) == problem.n and fit.converged
    # each fallback is the majorize-minimize step from k (the Python path's)
    thresholds = delta * problem.row_scale[:, :, None]
    assert len(steps) == problem.n
    for c, start, step in steps:
        output = huber._output_problem(problem, c)
        quadratic = huber._OutputQuadratic(problem, weight, weight, c, [], 1.0)
        r = output.y[:, :, 0] - np.einsum("tjk,tk->tj", problem.phi, start)
        expected = huber._reweighted_fit(output, quadratic, r, thresholds[:, :, c], 1.0)
        np.testing.assert_allclose(step, expected, rtol=0, atol=1e-9)
    assert fit.objective == pytest.approx(plain.objective, rel=1e-10)
    r = problem.residuals(fit.theta)
    direct = huber.huber_loss(r, thresholds).sum() + sum(
        float(np.sum(weight.reshape(problem.n, -1)[i] * np.diff(fit.theta[:, i], axis=0) ** 2))
        for i in range(problem.n)
    )
    assert fit.objective == pytest.approx(direct, rel=1e-12)
