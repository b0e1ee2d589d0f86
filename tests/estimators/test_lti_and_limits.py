"""``fit_lti`` (paper eq:ls) and the limits of ``fit`` in λ.

* fit_lti against numpy.linalg.lstsq, its noise covariance EᵀE/(N − p), the
  covariance Σ_v ⊗ (ΦᵀΦ)⁻¹ and the Gaussian log-likelihood;
* λ → ∞ with the first difference gives the LTI model; with the second
  difference the least-squares model whose coefficients are linear in time;
* λ → 0 interpolates: residuals → 0 like λ².
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from dense_reference import random_data, relerr, simulate_ltv
from scipy.stats import multivariate_normal

import ltvmodels as ltv


@pytest.mark.parametrize("n, m", [(2, 1), (3, 0), (1, 2)])
def test_fit_lti_equals_lstsq(n, m):
    x, u = random_data(31 + n + m, 40, n, m)
    model = ltv.fit_lti(x, u)
    U = np.zeros((40, 0)) if u is None else u
    phi = np.hstack([x[:-1], U[:-1]])
    y = x[1:]
    N, p = phi.shape
    theta, *_ = np.linalg.lstsq(phi, y, rcond=None)  # (p, n): y ≈ φ θ
    AB = theta.T
    assert model.A.shape == (N, n, n) and model.B.shape == (N, n, m)
    for t in (0, N // 2, N - 1):  # the same matrices at every time step
        np.testing.assert_allclose(model.A[t], AB[:, :n], rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(model.B[t], AB[:, n:], rtol=1e-10, atol=1e-12)
    assert np.ptp(model.k, axis=0).max() == 0.0
    E = y - phi @ theta
    noise_cov = E.T @ E / (N - p)
    np.testing.assert_allclose(model.noise_cov, noise_cov, rtol=1e-10)
    cov_k = np.kron(noise_cov, np.linalg.inv(phi.T @ phi))
    np.testing.assert_allclose(model.cov_full()[0], cov_k, rtol=1e-8, atol=1e-14)
    np.testing.assert_allclose(model.cov_full()[-1], cov_k, rtol=1e-8, atol=1e-14)
    # log-likelihood of the residuals at the ML noise covariance EᵀE / N
    ll = multivariate_normal(np.zeros(n), E.T @ E / N).logpdf(E).sum()
    assert model.loglik == pytest.approx(ll, rel=1e-10)
    assert model.changepoints.size == 0


def test_fit_lti_accepts_lists_and_dataframes():
    x, u = random_data(34, 30, 2, 1)
    a = ltv.fit_lti(x, u)
    b = ltv.fit_lti(x.tolist(), u[:, 0].tolist())
    c = ltv.fit_lti(pd.DataFrame(x, columns=["p", "v"]), pd.Series(u[:, 0]))
    np.testing.assert_array_equal(b.k, a.k)
    np.testing.assert_array_equal(c.k, a.k)


def test_fit_lti_recovers_true_system():
    rng = np.random.default_rng(35)
    A = np.array([[0.8, 0.2], [-0.1, 0.7]])
    B = np.array([[0.5], [1.0]])
    T = 2000
    x = np.zeros((T, 2))
    u = rng.standard_normal((T, 1))
    for t in range(T - 1):
        x[t + 1] = A @ x[t] + B @ u[t] + 0.01 * rng.standard_normal(2)
    model = ltv.fit_lti(x, u)
    np.testing.assert_allclose(model.A[0], A, atol=5e-3)
    np.testing.assert_allclose(model.B[0], B, atol=5e-3)
    np.testing.assert_allclose(model.noise_cov, 1e-4 * np.eye(2), atol=2e-5)


def test_lam_inf_equals_fit_lti():
    x, u, _ = simulate_ltv(36, T=50, n=2, m=1)
    lti = ltv.fit_lti(x, u)
    model = ltv.fit(x, u, lam=np.inf)
    assert relerr(model.A, lti.A) < 1e-10
    assert relerr(model.B, lti.B) < 1e-10


def _data_scale(x, u) -> float:
    """λ scale that makes λ² comparable to the per-step data Gram matrix."""
    phi = np.hstack([x[:-1], u[:-1]])
    return float(np.sqrt(np.mean(np.sum(phi**2, axis=1))))


def test_large_lam_approaches_lti_like_one_over_lam_squared():
    x, u, _ = simulate_ltv(37, T=50, n=2, m=1)
    lti = ltv.fit_lti(x, u)
    s = _data_scale(x, u)
    dev = []
    for lam in (1e2 * s, 1e3 * s):
        model = ltv.fit(x, u, lam=lam, order=1)
        dev.append(max(relerr(model.A, lti.A), relerr(model.B, lti.B)))
    assert dev[1] < 1e-3
    assert 30 < dev[0] / dev[1] < 300  # ∝ 1/λ²


def test_very_large_lam_warns_about_precision_and_points_to_inf():
    """The normal equations lose ~log10(λ²‖D‖²/mean φ²) digits: past 10 the fit warns,
    and where they are singular to working precision the error says to use lam=inf."""
    x, u, _ = simulate_ltv(1, T=50, n=2, m=1)
    lti = ltv.fit_lti(x, u)
    s = _data_scale(x, u)
    with pytest.warns(ltv.PrecisionWarning, match="lam=np.inf"):
        model = ltv.fit(x, u, lam=1e6 * s, order=1)
    assert model.info["digits_lost"] > 10
    # what remains is still close to the LTI limit (about 16 − digits_lost digits)
    assert relerr(model.A, lti.A) < 10.0 ** (model.info["digits_lost"] - 16 + 2)
    with pytest.raises(ltv.SingularProblemError, match="lam=np.inf"):
        ltv.fit(x, u, lam=1e8 * s, order=1)
    exact = ltv.fit(x, u, lam=np.inf, order=1)
    assert relerr(exact.A, lti.A) < 1e-12


def test_large_lam_second_order_gives_linear_trend_least_squares():
    """The null space of the second difference: k_t = a + b·t, fitted by least squares."""
    x, u, _ = simulate_ltv(38, T=50, n=2, m=1)
    phi = np.hstack([x[:-1], u[:-1]])
    N, p = phi.shape
    t = np.arange(N, dtype=float)
    Z = np.hstack([phi, phi * t[:, None]])
    coef, *_ = np.linalg.lstsq(Z, x[1:], rcond=None)  # (2p, n)
    k_trend = np.stack([(coef[:p] + coef[p:] * tt).T.ravel() for tt in t])
    model = ltv.fit(x, u, lam=1e4 * _data_scale(x, u), order=2)
    assert relerr(model.k, k_trend) < 1e-4
    assert relerr(ltv.fit(x, u, lam=1e3 * _data_scale(x, u), order=2).k, k_trend) > 1e-4


@pytest.mark.parametrize("order", [1, 2, [-1, 3, -3, 1]], ids=["order1", "order2", "poly3"])
def test_small_lam_interpolates(order):
    x, u, _ = simulate_ltv(39, T=50, n=2, m=1)
    res = []
    for lam in (1e-3, 1e-4):
        model = ltv.fit(x, u, lam=lam, order=order)
        res.append(np.linalg.norm(model.predict(x, u) - x[1:]) / np.linalg.norm(x[1:]))
    assert res[0] < 1e-4
    assert res[1] < 1e-6
    assert 30 < res[0] / res[1] < 300  # ∝ λ²
    lti = ltv.fit_lti(x, u)
    assert np.linalg.norm(lti.predict(x, u) - x[1:]) / np.linalg.norm(x[1:]) > 1e-2
