"""The noise variance estimated with priors (``noise_var=None``) against a dense brute force.

With priors, σ² maximizes log p(y | prior, σ²) within a factor 1e3 of the
prior-free estimate, found from the likelihood's derivative. The references:
a dense grid of the Gaussian log-likelihood (scipy's multivariate normal, see
dense_reference.DenseProblem.loglik_with_prior) refined by a bounded scalar
search on the dense value, and the coefficients of the fit given that σ².
"""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import DenseProblem, random_spd, simulate_ltv
from scipy.optimize import minimize_scalar

import ltvmodels as ltv

# The search stops at steps below 1e-6 in log σ²; the dense references are refined to 1e-8.
RTOL_VAR = 1e-5


@pytest.fixture(scope="module")
def system():
    x, u, k_true = simulate_ltv(71, T=30, n=2, m=1)
    rng = np.random.default_rng(72)
    N, K = k_true.shape
    cov_t = np.stack([random_spd(rng, K, 0.1) for _ in range(N)])  # couples the rows
    return dict(x=x, u=u, mu=k_true + 0.05 * rng.standard_normal(k_true.shape), cov_t=cov_t)


def dense_ml(s, order, prior_args, center):
    """The dense maximum of log p(y | prior, σ²): a grid over ±2 in log σ², then a bounded
    search in the best cell. Returns (σ², value, the grid's values)."""

    def loglik(v):
        return DenseProblem(
            s["x"], s["u"], order, 2.0, sigma2=np.exp(v), param_priors=[prior_args]
        ).loglik_with_prior()

    grid = np.log(center) + np.linspace(-2.0, 2.0, 41)
    values = np.array([loglik(v) for v in grid])
    best = int(np.argmax(values))
    assert 0 < best < grid.size - 1, "the reference's grid does not bracket the maximum"
    res = minimize_scalar(
        lambda v: -loglik(v),
        bounds=(grid[best - 1], grid[best + 1]),
        method="bounded",
        options={"xatol": 1e-8},
    )
    return float(np.exp(res.x)), -float(res.fun), values


@pytest.mark.parametrize("order", [1, 2])
def test_time_varying_prior_noise_var_is_the_dense_maximum(system, order):
    s = system
    prior = ltv.Prior(s["mu"], s["cov_t"])
    model = ltv.fit(s["x"], s["u"], lam=2.0, order=order, prior=prior)
    assert not model.info["row_separable"]
    s2 = float(model.noise_var[0])
    ref, value, grid_values = dense_ml(s, order, (s["mu"], s["cov_t"]), s2)
    assert s2 == pytest.approx(ref, rel=RTOL_VAR)
    assert model.loglik == pytest.approx(value, abs=1e-7)
    assert model.loglik >= grid_values.max() - 1e-9
    # the coefficients of the fit at the reference's σ²
    at_ref = ltv.fit(s["x"], s["u"], lam=2.0, order=order, prior=prior, noise_var=ref)
    np.testing.assert_allclose(model.k, at_ref.k, rtol=1e-5, atol=1e-8)
    # a few evaluations, each two factorizations (a search on the value took 25-30)
    assert 1 <= model.info["noise_var_evaluations"] <= 10


def test_rows_with_time_varying_priors_each_at_their_maximum(system):
    """A prior that does not couple the rows: each σ_i² maximizes its row's likelihood."""
    s = system
    N, K = s["mu"].shape
    p = K // 2
    cov = np.zeros_like(s["cov_t"])
    for i in range(2):  # block diagonal by output rows
        rows = slice(i * p, (i + 1) * p)
        cov[:, rows, rows] = s["cov_t"][:, rows, rows] * (1.0 + i)
    prior = ltv.Prior(s["mu"], cov)
    model = ltv.fit(s["x"], s["u"], lam=2.0, prior=prior)
    assert model.info["row_separable"]
    s2 = np.array(model.noise_var)
    assert s2[0] != s2[1]
    ref = DenseProblem(s["x"], s["u"], 1, 2.0, sigma2=s2, param_priors=[(s["mu"], cov)])
    assert model.loglik == pytest.approx(ref.loglik_with_prior(), rel=1e-9)
    for i in range(2):
        for factor in (1.0 - 1e-3, 1.0 + 1e-3):
            moved = s2.copy()
            moved[i] *= factor
            other = DenseProblem(
                s["x"], s["u"], 1, 2.0, sigma2=moved, param_priors=[(s["mu"], cov)]
            ).loglik_with_prior()
            assert other < model.loglik
    assert model.info["noise_var_evaluations"] <= 12


def test_maximum_beyond_the_range_stops_at_its_bound():
    """Near-exact data of an LTI system and a tight prior far from it: the likelihood
    rises beyond 1e3 times the prior-free estimate, and the estimate is that bound."""
    rng = np.random.default_rng(73)
    T, n = 40, 2
    A, B = np.array([[0.9, 0.2], [-0.1, 0.8]]), np.array([[1.0], [0.5]])
    u = rng.standard_normal((T, 1))
    x = np.zeros((T, n))
    x[0] = rng.standard_normal(n)
    for t in range(T - 1):
        x[t + 1] = A @ x[t] + B @ u[t] + 1e-4 * rng.standard_normal(n)
    k = np.hstack([A, B]).ravel()
    N, K = T - 1, k.size
    C = rng.standard_normal((N, K, K))
    cov_t = 1e-4 * (C @ np.swapaxes(C, 1, 2) / K + 0.1 * np.eye(K))  # couples the rows
    prior = ltv.Prior(np.tile(k + 0.3, (N, 1)), cov_t)
    free = ltv.fit(x, u, lam=2.0)
    guess = float(np.mean(free.noise_var))  # the prior-free estimate (rows of equal size)
    model = ltv.fit(x, u, lam=2.0, prior=prior)
    s2 = float(model.noise_var[0])
    assert s2 == pytest.approx(1e3 * guess, rel=1e-6)
    beyond = ltv.fit(x, u, lam=2.0, prior=prior, noise_var=1.01 * s2)
    inside = ltv.fit(x, u, lam=2.0, prior=prior, noise_var=0.99 * s2)
    assert inside.loglik < model.loglik < beyond.loglik
    assert model.info["noise_var_evaluations"] <= 4
