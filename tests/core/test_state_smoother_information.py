"""The curvature of the measurement model's log-likelihood against its Fisher information.

``benchmarks/bench_noisy.py`` (part 6) bounds the error of any consistent
estimator from noisy states by the inverse of the negative Hessian of the
log-likelihood that :func:`smooth_states` returns. This checks that curvature
on the scalar AR(1)-plus-noise model

    x_{t+1} = a x_t + w_t,  w_t ~ N(0, q),   y_t = x_t + e_t,  e_t ~ N(0, r),

against its exact asymptotic Fisher information per sample (Whittle): with the
spectral density of y, f(ω) = q / (1 − 2a cos ω + a²) + r,

    I_jk = (1 / 4π) ∫_{−π}^{π} ∂_j f ∂_k f / f² dω,

so that −∇² log p(y) / T → I for θ = (a, q, r) as T grows.
"""

from __future__ import annotations

import numpy as np

from ltvmodels.core.state_smoother import prior_variance, smooth_states

A_TRUE, Q_TRUE, R_TRUE = 0.8, 0.04, 0.04
T = 20000


def _simulate(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.empty(T)
    x[0] = rng.standard_normal() * np.sqrt(Q_TRUE / (1 - A_TRUE**2))  # stationary start
    w = rng.standard_normal(T - 1) * np.sqrt(Q_TRUE)
    for t in range(T - 1):
        x[t + 1] = A_TRUE * x[t] + w[t]
    return x + rng.standard_normal(T) * np.sqrt(R_TRUE)


def _loglik(theta: np.ndarray, y: np.ndarray, kappa: float) -> float:
    a, q, r = theta
    N = T - 1
    return smooth_states(
        np.full((N, 1, 1), a),
        np.zeros((1, N, 1)),
        np.ones((1, N), bool),
        np.full((1, N), q),
        y.reshape(1, T, 1),
        np.full((1, T, 1), r),
        kappa,
    ).loglik


def _whittle_information(a: float, q: float, r: float) -> np.ndarray:
    # the integrand is smooth and 2π-periodic: the rectangle rule is spectrally accurate
    omega = np.linspace(-np.pi, np.pi, 4096, endpoint=False)
    d = 1 - 2 * a * np.cos(omega) + a**2
    f = q / d + r
    grad = np.stack([q * (2 * np.cos(omega) - 2 * a) / d**2, 1 / d, np.ones_like(omega)])
    return (grad[:, None] * grad[None, :] / f**2).mean(axis=2) / 2  # (1/4π)·2π·mean


def _negative_hessian(y: np.ndarray) -> np.ndarray:
    theta = np.array([A_TRUE, Q_TRUE, R_TRUE])
    step = np.array([1e-3, 4e-5, 4e-5])
    kappa = prior_variance(y)
    E = np.diag(step)
    H = np.empty((3, 3))
    for i in range(3):
        for j in range(i + 1):
            H[i, j] = H[j, i] = (
                _loglik(theta + E[i] + E[j], y, kappa)
                - _loglik(theta + E[i] - E[j], y, kappa)
                - _loglik(theta - E[i] + E[j], y, kappa)
                + _loglik(theta - E[i] - E[j], y, kappa)
            ) / (4 * step[i] * step[j])
    return -H


def test_whittle_information_is_positive_definite_and_has_the_known_ar1_limit():
    # r → 0 leaves the AR(1) with known q: the information about a is 1 / (1 − a²)
    info = _whittle_information(A_TRUE, Q_TRUE, 1e-12)
    assert np.isclose(info[0, 0], 1 / (1 - A_TRUE**2), rtol=1e-6)
    assert np.linalg.eigvalsh(_whittle_information(A_TRUE, Q_TRUE, R_TRUE)).min() > 0


def test_loglik_curvature_matches_the_fisher_information():
    expected = _whittle_information(A_TRUE, Q_TRUE, R_TRUE)
    observed = np.mean([_negative_hessian(_simulate(seed)) for seed in range(6)], axis=0) / T
    # the asymptotic variances, which the benchmark turns into its error bound
    var_expected = np.diag(np.linalg.inv(expected))
    var_observed = np.diag(np.linalg.inv(observed))
    np.testing.assert_allclose(var_observed, var_expected, rtol=0.1)
    np.testing.assert_allclose(observed, expected, rtol=0.1, atol=0.02 * np.abs(expected).max())
