"""Robust measurement losses of the measurement model: IRLS weights inside EM.

The measurement model of :mod:`ltvmodels.core.state_smoother` with a heavy-tailed
measurement noise: each recorded entry y_ti = x_ti + e_ti has its own precision
weight ω_ti, so that the Kalman smoother sees the variance σ_{e,i}² / ω_ti. Both
losses are handled as a lower bound on the log-likelihood that EM raises block by
block (a generalized EM, a minorize–maximize scheme): with q(x) the Gaussian
posterior of the states, s_ti = E_q[(y_ti − x_ti)²] / σ_{e,i}² (the standardized
expected squared residual, which includes Var(x_ti | y)) and, per observed entry,

* ``"student"``: e_ti / σ_{e,i} ~ Student-t with ν degrees of freedom, written as
  the scale mixture e | τ ~ N(0, σ²/τ), τ ~ Gamma(ν/2, rate ν/2). The bound is the
  variational (evidence) lower bound with the mean-field q(x) q(τ): its q(τ) is
  Gamma(a, b), a = (ν + 1)/2, b = (ν + s)/2, and ω = E[τ] = (ν + 1)/(ν + s). At
  the smoother's q(x) the bound is

      log p_G(y; σ²/ω) + Σ [½(ψ(a) − log b − log ω) − KL(Gamma(a, b) ‖ Gamma(ν/2, ν/2))],

  with log p_G the Gaussian likelihood that the smoother computes at the
  variances σ²/ω. A weight decays as 1/s: an entry 25σ off keeps ω ≈ 0.008 (ν = 4).
* ``"huber"``: the unnormalized density exp(−ρ_δ(e/σ)) / (σ√(2π)) with Huber's
  ρ_δ (δ = 1.345), through its half-quadratic form ρ_δ(r) = min_{0<ω<=1}
  ω r²/2 + δ²/(2ω) − δ²/2, so that ω = min(1, δ/√s) and the bound is

      log p_G(y; σ²/ω) − Σ [½ log ω + δ²/(2ω) − δ²/2].

  Huber's weight decays as 1/√s: an entry 25σ off keeps ω ≈ 0.054.

Every update (the states, the weights, the coefficients, σ_w², and σ_e² by its
weighted update σ_{e,i}² = mean over observed entries of ω_ti E[(y_ti − x_ti)²])
maximizes the bound in its block, so the bound never decreases. ``"squared"`` is
ω = 1 (the Gaussian model, the bound its likelihood).

:func:`sample_outliers` marks the samples judged corrupted: a sample (r, t) whose
standardized smoothed measurement residual |y_ti − E[x_ti | y]| / √(σ_{e,i}² +
Var(x_ti | y)) exceeds :data:`OUTLIER_THRESHOLD` in any observed state.
"""

from __future__ import annotations

import numpy as np
from scipy.special import digamma, gammaln

from ..validation.options import MEASUREMENT_LOSSES

__all__ = [
    "MEASUREMENT_LOSSES",
    "HUBER_DELTA",
    "STUDENT_DOF",
    "OUTLIER_THRESHOLD",
    "standardized_square",
    "measurement_weights",
    "bound_correction",
    "sample_outliers",
]

HUBER_DELTA = 1.345
"""Huber's δ in units of σ_e (95 % efficiency at Gaussian noise)."""

STUDENT_DOF = 4.0
"""ν of the Student-t measurement noise (Lange, Little and Taylor's robust choice)."""

OUTLIER_THRESHOLD = 3.0
"""A sample is an outlier where a standardized measurement residual exceeds this."""


def standardized_square(
    y: np.ndarray, mean: np.ndarray, var: np.ndarray, noise_var: np.ndarray
) -> np.ndarray:
    """s_ti = E[(y_ti − x_ti)²] / σ_{e,i}² = ((y − m)² + Var(x)) / σ_e², 0 where y is NaN.

    ``y``, ``mean``, ``var`` (R, T, n): recorded states, smoothed means and variances;
    ``noise_var`` (n,): σ_e².
    """
    observed = np.isfinite(y)
    square = np.where(observed, (np.nan_to_num(y) - mean) ** 2 + var, 0.0)
    return square / noise_var


def measurement_weights(loss: str, s: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """The weights ω (R, T, n) that maximize the bound of ``loss`` given s (module
    docstring); 1 where an entry is unobserved (it enters no update)."""
    if loss == "huber":
        w = np.minimum(1.0, HUBER_DELTA / np.sqrt(np.maximum(s, 1e-300)))
    elif loss == "student":
        w = (STUDENT_DOF + 1.0) / (STUDENT_DOF + s)
    else:
        w = np.ones_like(s)
    return np.where(observed, w, 1.0)


def bound_correction(
    loss: str, weights: np.ndarray, s: np.ndarray | None, observed: np.ndarray
) -> float:
    """The bound less the Gaussian likelihood log p_G(y; σ²/ω) (module docstring), at the
    weights ``weights`` and, for ``"student"``, the s that made them (q(τ))."""
    if loss == "huber":
        w = weights[observed]
        d2 = HUBER_DELTA**2
        return float(-np.sum(0.5 * np.log(w) + d2 / (2.0 * w) - d2 / 2.0))
    if loss == "student":
        assert s is not None  # internal: the weights were made from s
        nu = STUDENT_DOF
        a = 0.5 * (nu + 1.0)
        b = 0.5 * (nu + s[observed])
        half = 0.5 * nu
        mean_log = digamma(a) - np.log(b)
        # KL(Gamma(a, b) ‖ Gamma(ν/2, ν/2)), shape–rate
        kl = (
            (a - half) * digamma(a)
            - gammaln(a)
            + gammaln(half)
            + half * (np.log(b) - np.log(half))
            + a * (half - b) / b
        )
        return float(np.sum(0.5 * (mean_log - np.log(a / b)) - kl))
    return 0.0


def sample_outliers(
    y: np.ndarray, mean: np.ndarray, var: np.ndarray, noise_var: np.ndarray
) -> np.ndarray:
    """(R, T) booleans: samples with a standardized smoothed measurement residual
    |y − E[x]| / √(σ_e² + Var(x)) above :data:`OUTLIER_THRESHOLD` in an observed state."""
    observed = np.isfinite(y)
    z = np.abs(np.nan_to_num(y) - mean) / np.sqrt(noise_var + var)
    return np.any(observed & (z > OUTLIER_THRESHOLD), axis=2)
