"""Gaussian priors as pseudo-measurements of the coefficients (paper Section IV).

A validated prior (built by :mod:`ltvmodels.estimators.priors` from a user's
:class:`~ltvmodels.Prior` or :class:`~ltvmodels.OutputPrior`) is a second,
independent measurement z_t = M_t k_t + noise with precision P_t: M_t = I
(parameters) or M_t = I_n ⊗ φ_tᵀ (the one-step output). The squared-norm
solver adds it to the normal equations; :func:`posthoc_correction` applies the
paper's correction step (its Kalman correction step) to smoothed estimates instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PriorTerm", "precision_matrix", "posthoc_correction"]


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


def precision_matrix(cov: np.ndarray) -> np.ndarray:
    """Inverse of a scalar / (d, d) / (N, d, d) covariance via Cholesky solves."""
    if cov.ndim == 0:
        return cov.reshape(()) ** -1.0
    L = np.linalg.cholesky(cov)
    eye = np.broadcast_to(np.eye(cov.shape[-1]), cov.shape)
    Linv = np.linalg.solve(L, eye)
    return np.swapaxes(Linv, -1, -2) @ Linv


def posthoc_correction(
    k: np.ndarray, cov: np.ndarray, prior: PriorTerm, phi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's repeated Kalman correction step on smoothed estimates.

    A measurement update with the prior as measurement z_t = M_t k_t + e_t,
    e_t ~ N(0, R_t):

        K̄_t = P_t M_tᵀ (M_t P_t M_tᵀ + R_t)⁻¹,  k̄_t = k_t + K̄_t (z_t − M_t k_t),
        P̄_t = P_t − K̄_t M_t P_t,

    with M_t = I (parameter prior, the paper's correction step exactly) or
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
