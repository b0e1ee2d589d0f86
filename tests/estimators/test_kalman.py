"""Kalman filter / RTS smoother form of the squared-difference problem.

References: the banded solver (``ltvmodels.fit``), and dense numpy solutions of
the same Gaussian model built here from scratch.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

import ltvmodels as ltv
from ltvmodels.errors import SingularProblemError
from ltvmodels.estimators.kalman import (
    OnlineParameterFilter,
    kalman_filter,
    kalman_smoother,
    parameter_state_space,
)

# The last two: (z − 1)(z − 0.5) and twice it, so that |c_0| ≠ |c_d| and c_d ≠ 1.
ORDERS = [1, 2, 3, [0.5, -1.5, 1.0], [1.0, -3.0, 2.0]]


def simulate(seed: int, T: int = 80, n: int = 2, m: int = 1):
    """A stable LTV system with slowly varying A_t, driven by white noise."""
    rng = np.random.default_rng(seed)
    x = np.zeros((T, n))
    x[0] = rng.standard_normal(n)
    u = rng.standard_normal((T, m))
    B = rng.standard_normal((n, m))
    for t in range(T - 1):
        a = 0.6 + 0.3 * np.sin(2 * np.pi * t / T)
        A = np.array([[a, 0.2], [-0.3, 0.5]])[:n, :n]
        x[t + 1] = A @ x[t] + B @ u[t] + 0.2 * rng.standard_normal(n)
    return x, (u if m else None)


def rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def coefficients(order) -> np.ndarray:
    if np.ndim(order) == 0:
        c = np.array([1.0])
        for _ in range(order):
            c = np.convolve(c, [-1.0, 1.0])
        return c
    return np.asarray(order, float)


# -- the diffuse smoother is the banded solution ---------------------------------------


@pytest.mark.parametrize("order", ORDERS, ids=str)
@pytest.mark.parametrize("with_input", [True, False])
def test_smoother_equals_banded_solver(order, with_input):
    x, u = simulate(seed=1, m=1 if with_input else 0)
    lam, s2 = 4.0, 0.3
    sm = kalman_smoother(x, u, lam=lam, order=order, noise_var=s2)
    model = ltv.fit(x, u, lam=lam, order=order, noise_var=s2)
    assert sm.k.shape == model.k.shape and sm.cov.shape == model.cov.shape
    assert rel(sm.k, model.k) < 1e-8
    assert rel(sm.cov, model.cov) < 1e-8  # both include σ²
    assert rel(sm.cov_full(), model.cov_full()) < 1e-8
    np.testing.assert_allclose(sm.A, model.A, rtol=0, atol=1e-8 * np.abs(model.k).max())
    np.testing.assert_allclose(sm.B, model.B, rtol=0, atol=1e-8 * np.abs(model.k).max())
    # Same diffuse-likelihood convention (flat prior, unit density on k_0 … k_{d−1}).
    assert sm.loglik == pytest.approx(model.loglik, rel=1e-10, abs=1e-8)


@pytest.mark.parametrize("lam", [0.05, 300.0])
def test_smoother_extreme_lambda(lam):
    x, u = simulate(seed=2, T=150)
    sm = kalman_smoother(x, u, lam=lam, order=2)
    model = ltv.fit(x, u, lam=lam, order=2, noise_var=1.0)
    assert rel(sm.k, model.k) < 1e-7
    assert rel(sm.cov, model.cov) < 1e-7


def test_smoother_means_do_not_depend_on_noise_var():
    x, u = simulate(seed=3)
    a = kalman_smoother(x, u, lam=2.0, noise_var=1.0)
    b = kalman_smoother(x, u, lam=2.0, noise_var=0.01)
    np.testing.assert_allclose(a.k, b.k, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(b.cov, 0.01 * a.cov, rtol=1e-9)


# -- exact diffuse filtering -----------------------------------------------------------


@pytest.mark.parametrize("order", [1, 2, [0.5, -1.5, 1.0]], ids=str)
def test_filter_is_fit_on_truncated_data(order):
    x, u = simulate(seed=4, T=30)
    lam, s2 = 1.5, 0.5
    filt = kalman_filter(x, u, lam=lam, order=order, noise_var=s2)
    d, p = len(coefficients(order)) - 1, 3
    # The state (k_t … k_{t−d+1}) is identified by d·p generic measurements.
    assert filt.first_identified == d * p - 1
    assert np.all(np.isnan(filt.k[: d * p - 1])) and np.all(np.isnan(filt.cov[: d * p - 1]))
    assert np.all(np.isfinite(filt.k[d * p - 1 :]))
    for t in range(d * p - 1, x.shape[0] - 1):
        model = ltv.fit(x[: t + 2], u[: t + 2], lam=lam, order=order, noise_var=s2)
        assert rel(filt.k[t], model.k[-1]) < 1e-8, t
        assert rel(filt.cov[t], model.cov[-1]) < 1e-8, t
    # Whole-data log-likelihood: the same number as the banded solver's.
    model = ltv.fit(x, u, lam=lam, order=order, noise_var=s2)
    assert filt.loglik == pytest.approx(model.loglik, rel=1e-10)


def test_filter_last_step_equals_smoother_last_step():
    x, u = simulate(seed=5)
    filt = kalman_filter(x, u, lam=3.0, order=2)
    sm = kalman_smoother(x, u, lam=3.0, order=2)
    np.testing.assert_allclose(filt.k[-1], sm.k[-1], rtol=1e-12)
    np.testing.assert_allclose(filt.cov[-1], sm.cov[-1], rtol=1e-12)


# -- proper prior: dense MAP -----------------------------------------------------------


def dense_reference(x, u, lam, s2, coeffs, mean0, cov0):
    """Dense posterior of one row at a time over z = (k_{−d+1}, …, k_{N−1}).

    Prior: s_0 = (θ_0, θ_{−1}, …, θ_{−d+1}) ~ N(mean0[:, i], cov0) and the penalty
    (λ²/σ²) Σ ‖Σ_j c_j θ_{t+j}‖² over all N − 1 differences of z; data y_t = φ_tᵀ θ_t + e.
    Returns posterior means (N, K), the (N, p, p) covariance blocks of θ_t, log p(y).
    """
    phi = np.hstack([x[:-1], u[:-1]])
    y = x[1:]
    N, p = phi.shape
    n = y.shape[1]
    d = len(coeffs) - 1
    L = N + d - 1  # time steps in z; z index j ↔ time j − d + 1
    Phi = np.zeros((N, L * p))
    for t in range(N):
        Phi[t, (t + d - 1) * p : (t + d) * p] = phi[t]
    Dm = np.zeros((L - d, L))
    for r in range(L - d):
        Dm[r, r : r + d + 1] = coeffs
    Dk = np.kron(Dm, np.eye(p))
    E0 = np.zeros((d * p, L * p))  # s_0 = E0 z: block j of s_0 is θ_{−j}
    for j in range(d):
        E0[j * p : (j + 1) * p, (d - 1 - j) * p : (d - j) * p] = np.eye(p)
    prec_prior = lam**2 / s2 * Dk.T @ Dk + E0.T @ np.linalg.solve(cov0, E0)
    H = prec_prior + Phi.T @ Phi / s2
    cov_post = np.linalg.inv(H)
    cov_prior = np.linalg.inv(prec_prior)
    k = np.zeros((N, n, p))
    loglik = 0.0
    for i in range(n):
        b = E0.T @ np.linalg.solve(cov0, mean0[:, i])
        z = np.linalg.solve(H, b + Phi.T @ y[:, i] / s2)
        k[:, i] = z[(d - 1) * p :].reshape(N, p)
        z_prior = cov_prior @ b
        loglik += multivariate_normal.logpdf(
            y[:, i], Phi @ z_prior, s2 * np.eye(N) + Phi @ cov_prior @ Phi.T
        )
    idx = np.arange((d - 1) * p, L * p).reshape(N, p)
    covs = np.stack([cov_post[np.ix_(ix, ix)] for ix in idx])
    return k.reshape(N, n * p), covs, loglik


@pytest.mark.parametrize("order", [1, 2], ids=str)
def test_proper_prior_equals_dense_map(order):
    x, u = simulate(seed=6, T=25)
    n, p = 2, 3
    coeffs = coefficients(order)
    d = len(coeffs) - 1
    rng = np.random.default_rng(7)
    mean0 = rng.standard_normal((d, n * p))  # row j: mean of k_{−j}
    R = rng.standard_normal((d * p, d * p))
    cov0 = 0.5 * R @ R.T + 0.2 * np.eye(d * p)
    lam, s2 = 2.0, 0.4
    mean0_rows = mean0.reshape(d, n, p).transpose(0, 2, 1).reshape(d * p, n)
    k_ref, cov_ref, ll_ref = dense_reference(x, u, lam, s2, coeffs, mean0_rows, cov0)
    sm = kalman_smoother(x, u, lam=lam, order=order, noise_var=s2, init_mean=mean0, init_cov=cov0)
    assert rel(sm.k, k_ref) < 1e-9
    assert rel(sm.cov, cov_ref) < 1e-9
    assert sm.loglik == pytest.approx(ll_ref, rel=1e-10)
    # The filtered estimate at t is the dense posterior on the data up to t, and
    # a proper prior makes every step identified.
    filt = sm.filtered
    assert filt.first_identified == 0 and np.all(np.isfinite(filt.k))
    for t in [0, 1, 5, x.shape[0] - 2]:
        k_t, cov_t, _ = dense_reference(x[: t + 2], u[: t + 2], lam, s2, coeffs, mean0_rows, cov0)
        assert rel(filt.k[t], k_t[-1]) < 1e-9
        assert rel(filt.cov[t], cov_t[-1]) < 1e-9


def test_wide_prior_approaches_diffuse():
    x, u = simulate(seed=8)
    diffuse = kalman_smoother(x, u, lam=2.0)
    wide = kalman_smoother(x, u, lam=2.0, init_cov=1e8)
    assert rel(wide.k, diffuse.k) < 1e-5


# -- online form -----------------------------------------------------------------------


@pytest.mark.parametrize("prior", [False, True])
def test_online_filter_equals_batch(prior):
    x, u = simulate(seed=9, T=40)
    kwargs = dict(lam=2.0, order=2, noise_var=0.5)
    if prior:
        kwargs["init_cov"] = 3.0
    batch = kalman_filter(x, u, **kwargs)
    online = OnlineParameterFilter(2, 1, **kwargs)
    assert not online.identified and np.all(np.isnan(online.k))
    for t in range(x.shape[0] - 1):
        k_t = online.update(x[t], u[t], x[t + 1])
        np.testing.assert_allclose(k_t, batch.k[t], rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(online.cov, batch.cov[t], rtol=1e-12, atol=1e-14)
    assert online.n_updates == x.shape[0] - 1
    assert online.loglik == pytest.approx(batch.loglik, rel=1e-12)
    theta = batch.k[-1].reshape(2, 3)
    np.testing.assert_allclose(online.A, theta[:, :2])
    np.testing.assert_allclose(online.B, theta[:, 2:])


def test_online_autonomous_system():
    x, _ = simulate(seed=10, T=30, m=0)
    f = OnlineParameterFilter(2, lam=5.0)
    for t in range(x.shape[0] - 1):
        f.update(x[t], None, x[t + 1])
    np.testing.assert_allclose(f.k, kalman_filter(x, lam=5.0).k[-1], rtol=1e-12)
    assert f.B.shape == (2, 0)


# -- realization -----------------------------------------------------------------------


def test_realization_generates_the_penalized_differences():
    coeffs = np.array([0.5, -1.5, 1.0])
    ss = parameter_state_space(coeffs, 2, lam=4.0, noise_var=0.8)
    np.testing.assert_allclose(ss.F @ ss.F_inv, np.eye(4), atol=1e-15)
    np.testing.assert_allclose(ss.Q, 0.8 / (16.0 * 1.0) * np.eye(2))
    # k_{t+1} = F-recursion + w_t  ⇔  Σ_j c_j k_{t−1+j} = c_d w_t.
    rng = np.random.default_rng(11)
    s = rng.standard_normal(4)
    ks, ws = [s[2:], s[:2]], []
    for _ in range(10):
        w = rng.standard_normal(2)
        s = ss.F @ s + ss.G @ w
        ks.append(s[:2])
        ws.append(w)
    ks = np.array(ks)
    diffs = coeffs[0] * ks[:-2] + coeffs[1] * ks[1:-1] + coeffs[2] * ks[2:]
    np.testing.assert_allclose(diffs, coeffs[-1] * np.array(ws), atol=1e-12)
    # Order 2 is the paper's eq. dynsys2 in the coordinates (k_t, k_{t−1}).
    ss2 = parameter_state_space(2, 1, lam=1.0)
    np.testing.assert_array_equal(ss2.F, [[2.0, -1.0], [1.0, 0.0]])


# -- input checks ----------------------------------------------------------------------


def test_inputs_are_not_mutated():
    x, u = simulate(seed=12)
    x0, u0 = x.copy(), u.copy()
    kalman_smoother(x, u, lam=1.0, order=2)
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(u, u0)


@pytest.mark.parametrize(
    "kwargs, exc, text",
    [
        (dict(lam=np.ones(6)), TypeError, "lam: the Kalman filter/smoother supports a scalar"),
        (dict(lam=0.0), ValueError, "lam: expected a real number > 0"),
        (dict(lam=np.inf), ValueError, "lam: expected a finite"),
        (dict(lam=1.0, noise_var=-1.0), ValueError, "noise_var"),
        (dict(lam=1.0, order=0), ValueError, "order"),
        (dict(lam=1.0, init_mean=np.zeros(6)), ValueError, "init_cov: expected a covariance"),
        (
            dict(lam=1.0, init_cov=np.eye(4)),
            ValueError,
            r"init_cov: expected a scalar or a \(3, 3\)",
        ),
        (dict(lam=1.0, init_cov=-np.eye(3)), ValueError, "positive definite"),
        (
            dict(lam=1.0, init_cov=1.0, init_mean=np.zeros(5)),
            ValueError,
            "init_mean: expected shape",
        ),
        (
            dict(lam=1.0, order=2, init_cov=1.0, init_mean=np.zeros(6)),
            ValueError,
            r"init_mean: expected shape \(2, 6\)",
        ),
    ],
)
def test_bad_arguments(kwargs, exc, text):
    x, u = simulate(seed=13, T=20)
    with pytest.raises(exc, match=text):
        kalman_smoother(x, u, **kwargs)


def test_bad_data():
    x, u = simulate(seed=14, T=20)
    with pytest.raises(ValueError, match="too few samples"):
        kalman_smoother(x[:3], u[:3], lam=1.0)
    with pytest.raises(ValueError, match="u: expected 20 rows"):
        kalman_smoother(x, u[:-1], lam=1.0)
    x[3, 1] = np.inf  # NaN is a missing sample, inf an error
    with pytest.raises(ValueError, match="x: expected finite values or NaN"):
        kalman_filter(x, u, lam=1.0)


def test_unidentified_data_raise_in_smoother_and_give_nan_in_filter():
    x, _ = simulate(seed=15, T=30)
    u = np.zeros(30)  # B is invisible in the data
    filt = kalman_filter(x, u, lam=1.0)
    assert np.all(np.isnan(filt.k)) and filt.loglik is None and filt.first_identified == 29
    with pytest.raises(SingularProblemError, match="do not identify"):
        kalman_smoother(x, u, lam=1.0)


def test_online_bad_arguments():
    f = OnlineParameterFilter(2, 1, lam=1.0)
    with pytest.raises(ValueError, match="x_t: expected a vector of length 2"):
        f.update(np.zeros(3), np.zeros(1), np.zeros(2))
    with pytest.raises(TypeError, match="u_t: expected an array of numbers, received None"):
        f.update(np.zeros(2), None, np.zeros(2))
    with pytest.raises(ValueError, match="n_states"):
        OnlineParameterFilter(0, lam=1.0)
