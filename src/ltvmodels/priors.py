"""Gaussian priors on the coefficients or on the output (paper Section IV).

A prior is a second, independent measurement (paper eqs. postk–postcov):

* :class:`Prior` — k_t ~ N(μ_t, Σ_t): the term Σ_t ‖μ_t − k_t‖²_{Σ_t⁻¹} of
  paper eq. prioropt;
* :class:`OutputPrior` — x_{t+1} = A_t x_t + B_t u_t ~ N(ȳ_t, S_t): a belief
  about the model's one-step output, entering as an extra measurement update.

With ``prior_mode="exact"`` both enter the normal equations, weighted against
the data by the noise variance σ², and the MAP estimate of eq. prioropt is
obtained exactly. ``prior_mode="posthoc"`` applies the paper's repeated
correction to the smoothed estimates instead (kept for comparison; it is not
the MAP estimate).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _validate


class Prior:
    """Gaussian prior on the parameter vectors k_t = vec([A_tᵀ B_tᵀ]).

    Parameters
    ----------
    mean : array_like, shape (N, K) or (K,), or LTVModel
        Prior mean μ_t; a (K,) vector applies to every time step; a fitted
        :class:`~ltvmodels.LTVModel` (or any fitted model, e.g. from
        :func:`ltvmodels.fit_regression` or :func:`ltvmodels.fit_ar`) contributes
        its coefficients ``k``.
    cov : float or array_like, shape (K, K) or (N, K, K)
        Prior covariance Σ_t (a scalar means σ_0² I). Must be positive definite.

    Notes
    -----
    Shapes are checked against the data when the prior is used by
    :func:`ltvmodels.fit`. K = n·(n + m) and k_t is ``np.hstack([A_t, B_t]).ravel()``.
    """

    def __init__(self, mean: Any, cov: Any) -> None:
        if hasattr(mean, "k") and hasattr(mean, "theta"):
            mean = mean.k
        self.mean = _validate.as_float_array(mean, "mean")
        if self.mean.ndim not in (1, 2):
            raise ValueError(
                f"mean: expected shape (K,) or (N, K), received shape {self.mean.shape}"
            )
        self.cov = _validate.as_float_array(cov, "cov")
        if self.cov.ndim not in (0, 2, 3):
            raise ValueError(
                f"cov: expected a scalar, (K, K) or (N, K, K), received shape {self.cov.shape}"
            )

    def __repr__(self) -> str:
        return f"Prior(mean shape={self.mean.shape}, cov shape={self.cov.shape})"


class OutputPrior:
    """Gaussian prior on the model output y_t = A_t x_t + B_t u_t (≈ x_{t+1}).

    Parameters
    ----------
    mean : array_like, shape (N, n) or (n,)
        Prior mean ȳ_t of the one-step output.
    cov : float or array_like, shape (n, n) or (N, n, n)
        Its covariance S_t, positive definite.
    """

    def __init__(self, mean: Any, cov: Any) -> None:
        self.mean = _validate.as_float_array(mean, "mean")
        if self.mean.ndim not in (1, 2):
            raise ValueError(
                f"mean: expected shape (n,) or (N, n), received shape {self.mean.shape}"
            )
        self.cov = _validate.as_float_array(cov, "cov")
        if self.cov.ndim not in (0, 2, 3):
            raise ValueError(
                f"cov: expected a scalar, (n, n) or (N, n, n), received shape {self.cov.shape}"
            )

    def __repr__(self) -> str:
        return f"OutputPrior(mean shape={self.mean.shape}, cov shape={self.cov.shape})"


@dataclass
class PriorTerm:
    """A validated prior as a pseudo-measurement z_t = M_t k_t + noise.

    ``precision`` is the inverse covariance, shape (d, d) or (N, d, d), and
    ``mean`` is (N, d); ``on`` is "parameters" (M_t = I_K) or "output"
    (M_t = I_n ⊗ φ_tᵀ).
    """

    on: str
    precision: np.ndarray
    mean: np.ndarray

    def precision_at(self, N: int) -> np.ndarray:
        """Precision broadcast to (N, d, d) (a view, no copy)."""
        d = self.mean.shape[1]
        return np.broadcast_to(self.precision, (N, d, d))


def _precision(cov: np.ndarray) -> np.ndarray:
    """Inverse of a scalar / (d, d) / (N, d, d) covariance via Cholesky solves."""
    if cov.ndim == 0:
        return cov.reshape(()) ** -1.0
    L = np.linalg.cholesky(cov)
    eye = np.broadcast_to(np.eye(cov.shape[-1]), cov.shape)
    Linv = np.linalg.solve(L, eye)
    return np.swapaxes(Linv, -1, -2) @ Linv


def resolve(priors: Any, N: int, n: int, p: int) -> list[PriorTerm]:
    """Validate ``prior=`` of :func:`ltvmodels.fit` against the data sizes."""
    if priors is None:
        return []
    items = list(priors) if isinstance(priors, (list, tuple)) else [priors]
    terms = []
    K = n * p
    for item in items:
        if isinstance(item, Prior):
            on, d = "parameters", K
        elif isinstance(item, OutputPrior):
            on, d = "output", n
        else:
            raise TypeError(
                "prior: expected an ltvmodels.Prior, an ltvmodels.OutputPrior or a list of "
                f"them, received {type(item).__name__}"
            )
        label = "prior.mean" if on == "parameters" else "output prior mean"
        mean = _validate.mean_sequence(item.mean, label, N, d)
        cov = _validate.covariance(item.cov, label.replace("mean", "cov"), N, d)
        prec = _precision(cov)
        if prec.ndim == 0:
            prec = np.eye(d) * float(prec)
        terms.append(PriorTerm(on=on, precision=prec, mean=mean))
    return terms


def posthoc_correction(
    k: np.ndarray, cov: np.ndarray, prior: PriorTerm, phi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's repeated correction step (eqs. postk–postcov) on smoothed estimates.

    A measurement update with the prior as measurement z_t = M_t k_t + e_t,
    e_t ~ N(0, R_t):

        K̄_t = P_t M_tᵀ (M_t P_t M_tᵀ + R_t)⁻¹,  k̄_t = k_t + K̄_t (z_t − M_t k_t),
        P̄_t = P_t − K̄_t M_t P_t,

    with M_t = I (parameter prior, eqs. postk–postcov exactly) or
    M_t = I_n ⊗ φ_tᵀ (output prior).

    Parameters
    ----------
    k : ndarray, shape (N, K)
    cov : ndarray, shape (N, K, K)
        Smoothed covariances P_{t|N}.
    prior : PriorTerm
    phi : ndarray, shape (N, p)
        Regressors (used by output priors).
    """
    N, K = k.shape
    d = prior.mean.shape[1]
    if prior.on == "parameters":
        M = np.broadcast_to(np.eye(K), (N, K, K))
    else:
        M = np.einsum("ij,ta->tija", np.eye(d), phi).reshape(N, d, K)
    R = np.linalg.solve(prior.precision_at(N), np.broadcast_to(np.eye(d), (N, d, d)))
    PMt = cov @ np.swapaxes(M, 1, 2)  # (N, K, d)
    S = M @ PMt + R
    # K̄ = P Mᵀ S⁻¹ = (S⁻¹ M P)ᵀ since P and S are symmetric.
    gain = np.swapaxes(np.linalg.solve(S, np.swapaxes(PMt, 1, 2)), 1, 2)
    innovation = prior.mean - np.einsum("tij,tj->ti", M, k)
    k_new = k + np.einsum("tij,tj->ti", gain, innovation)
    cov_new = cov - gain @ np.swapaxes(PMt, 1, 2)
    return k_new, 0.5 * (cov_new + np.swapaxes(cov_new, 1, 2))
