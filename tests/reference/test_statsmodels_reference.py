"""The banded solver and the Kalman smoother against statsmodels' state-space smoother.

statsmodels runs its own (Cython) Kalman filter and smoother, with exact diffuse
initialization, on the parameter random walk written as a state-space model:

    k_{t+1} = F k_t + G w_t,  w_t ~ N(0, σ²/λ² I),
    y_t = (I_n ⊗ φ_tᵀ) k_t + e_t,  e_t ~ N(0, σ² I),

with time-varying design (n × K × N). For order 1, F = I and G = I (K states);
for order 2 each output row gets the companion realization of
:func:`ltvmodels.estimators.kalman.parameter_state_space`.

Log-likelihood convention: statsmodels' diffuse log-likelihood is the limit of
log p(y) + (q/2) log κ under a N(0, κ I) prior on the q = d·K diffuse states,
which keeps a (2π)^{−q/2} factor; ltvmodels uses a flat prior with unit density.
So llf_statsmodels = loglik_ltvmodels − (q/2) log 2π exactly, and differences
between λ values agree.
"""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.estimators.kalman import kalman_smoother, parameter_state_space

sm = pytest.importorskip("statsmodels.api")
from statsmodels.tsa.statespace.mlemodel import MLEModel  # noqa: E402

LOG_2PI = np.log(2 * np.pi)


def statsmodels_smoother(x, u, lam, noise_var, order=1):
    """Run statsmodels on the model; returns (k (N, K), cov (N, K, K), llf, q).

    ``noise_var`` is σ² or one σ_i² per output: observation noise diag(σ_i²)
    and parameter drift σ_i²/λ² in row i.
    """
    x = np.asarray(x, float)
    u = np.asarray(u, float).reshape(len(x), -1)
    phi = np.hstack([x[:-1], u[:-1]])
    y = x[1:]
    N, p = phi.shape
    n = y.shape[1]
    var = np.broadcast_to(np.asarray(noise_var, dtype=float), (n,))
    if order == 1:  # the brief's form: identity transition, K states
        D, F, G, Q = p, np.eye(p), np.eye(p), 1.0 / lam**2 * np.eye(p)
    else:
        ss = parameter_state_space(order, p, lam=lam, noise_var=1.0)
        D, F, G, Q = ss.F.shape[0], ss.F, ss.G, ss.Q
    mod = MLEModel(y, k_states=n * D, k_posdef=n * p, initialization="diffuse")
    design = np.zeros((n, n * D, N))
    for i in range(n):
        design[i, i * D : i * D + p, :] = phi.T
    mod["design"] = design
    mod["transition"] = np.kron(np.eye(n), F)
    mod["selection"] = np.kron(np.eye(n), G)
    mod["state_cov"] = np.kron(np.diag(var), Q)
    mod["obs_cov"] = np.diag(var)
    res = mod.ssm.smooth()
    idx = np.concatenate([np.arange(i * D, i * D + p) for i in range(n)])  # the k_t blocks
    k = res.smoothed_state[idx].T
    cov = res.smoothed_state_cov[np.ix_(idx, idx)].transpose(2, 0, 1)
    return k, cov, float(mod.ssm.loglike()), n * D


def simulated_system(T=500, seed=0):
    rng = np.random.default_rng(seed)
    n = 2
    x = np.zeros((T, n))
    u = rng.standard_normal(T)
    for t in range(T - 1):
        a = 0.5 + 0.3 * np.sin(2 * np.pi * t / T)
        A = np.array([[a, 0.1], [-0.2, 0.7]])
        x[t + 1] = A @ x[t] + np.array([1.0, 0.5]) * u[t] + 0.1 * rng.standard_normal(n)
    return x, u


def rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def check(x, u, order, lams, noise_var, tol_k, tol_cov):
    lls = {}
    for lam in lams:
        k_sm, cov_sm, llf, q = statsmodels_smoother(x, u, lam, noise_var, order)
        model = ltv.fit(x, u, lam=lam, order=order, noise_var=noise_var)
        assert rel(model.k, k_sm) < tol_k
        assert rel(model.cov_full(), cov_sm) < tol_cov
        # Absolute log-likelihoods agree up to the (2π)^{−q/2} convention constant.
        assert llf == pytest.approx(model.loglik - 0.5 * q * LOG_2PI, rel=1e-9, abs=1e-6)
        if np.ndim(noise_var) == 0:  # the Kalman front-end takes one shared σ²
            ks = kalman_smoother(x, u, lam=lam, order=order, noise_var=noise_var)
            assert rel(ks.k, k_sm) < tol_k
            assert rel(ks.cov_full(), cov_sm) < tol_cov
            assert ks.loglik == pytest.approx(model.loglik, rel=1e-10)
        else:
            ks = model
        lls[lam] = (llf, model.loglik, ks.loglik)
    (a1, b1, c1), (a2, b2, c2) = lls.values()
    assert b1 - b2 == pytest.approx(a1 - a2, rel=1e-8, abs=1e-6)
    assert c1 - c2 == pytest.approx(a1 - a2, rel=1e-8, abs=1e-6)


@pytest.mark.parametrize("order", [1, 2])
def test_simulated_system(order):
    x, u = simulated_system()
    check(x, u, order, lams=(3.0, 30.0), noise_var=0.01, tol_k=1e-8, tol_cov=1e-6)


@pytest.mark.parametrize("order", [1, 2])
def test_tvp_var_macrodata(order):
    """TVP-VAR(1) of inflation, unemployment and the real interest rate with intercept."""
    data = sm.datasets.macrodata.load_pandas().data
    x = data[["infl", "unemp", "realint"]]  # DataFrame on purpose: the pandas path
    u = np.ones(len(x))  # B_t is the time-varying intercept
    sigma2 = ltv.fit(x, u, lam=10.0).noise_var  # a data-based σ², then held fixed
    check(x, u, order, lams=(3.0, 30.0), noise_var=sigma2, tol_k=1e-8, tol_cov=1e-6)


def test_missing_samples_match_statsmodels_nan_observations():
    """A missing x[s] removes transitions s − 1 and s: statsmodels with NaN observations there."""
    x, u = simulated_system(T=200, seed=3)
    x = x.copy()
    x[[40, 41, 120]] = np.nan
    noise_var = np.array([0.01, 0.02])
    model = ltv.fit(x, u, lam=10.0, noise_var=noise_var)
    # statsmodels: y_t = x[t+1] unobserved where x[t] or x[t+1] is missing; φ_t there is
    # irrelevant (set to 0)
    xs = np.nan_to_num(x)
    y = xs[1:].copy()
    gone = ~(np.all(np.isfinite(x[1:]), axis=1) & np.all(np.isfinite(x[:-1]), axis=1))
    y[gone] = np.nan
    k_sm, cov_sm, llf, q = statsmodels_smoother_y(
        y, np.hstack([xs[:-1], u[:-1, None]]), 10.0, noise_var
    )
    assert rel(model.k, k_sm) < 1e-8
    assert rel(model.cov_full(), cov_sm) < 1e-6
    assert llf == pytest.approx(model.loglik - 0.5 * q * LOG_2PI, rel=1e-9, abs=1e-6)
    assert model.n_missing == 5


def statsmodels_smoother_y(y, phi, lam, noise_var):
    """statsmodels' diffuse smoother of the order-1 random walk for given y (NaN = missing)."""
    N, p = phi.shape
    n = y.shape[1]
    mod = MLEModel(y, k_states=n * p, k_posdef=n * p, initialization="diffuse")
    design = np.zeros((n, n * p, N))
    for i in range(n):
        design[i, i * p : (i + 1) * p, :] = phi.T
    mod["design"] = design
    mod["transition"] = np.eye(n * p)
    mod["selection"] = np.eye(n * p)
    mod["state_cov"] = np.kron(np.diag(noise_var), np.eye(p) / lam**2)
    mod["obs_cov"] = np.diag(noise_var)
    res = mod.ssm.smooth()
    return (
        res.smoothed_state.T,
        res.smoothed_state_cov.transpose(2, 0, 1),
        float(mod.ssm.loglike()),
        n * p,
    )
