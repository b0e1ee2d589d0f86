"""Results of the Kalman filter and smoother of the parameter random walk.

Produced by :func:`ltvmodels.kalman_filter` and :func:`ltvmodels.kalman_smoother`
(the recursions are in :mod:`ltvmodels.core.kalman`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.covariance import CovarianceBlocks
from .base import LinearTimeVarying

__all__ = ["KalmanFilterResult", "KalmanSmootherResult"]


class _ParameterAccess(LinearTimeVarying):
    """A_t, B_t and the full covariance from ``k`` (N, K), ``cov`` (N, p, p), ``n_states``."""

    k: np.ndarray
    cov: np.ndarray

    if TYPE_CHECKING:  # a field of the filter's result, a property of the smoother's

        @property
        def n_states(self) -> int: ...

    @property
    def A(self) -> np.ndarray:
        """(N, n, n) state matrices A_t."""
        n = self.n_states
        return self.k.reshape(self.k.shape[0], n, -1)[:, :, :n]

    @property
    def B(self) -> np.ndarray:
        """(N, n, m) input matrices B_t."""
        n = self.n_states
        return self.k.reshape(self.k.shape[0], n, -1)[:, :, n:]

    def cov_full(self) -> np.ndarray:
        """(N, K, K) covariance of k_t, I_n ⊗ cov[t]."""
        n = self.n_states
        shared = CovarianceBlocks(self.cov[None], np.zeros(n, dtype=int))
        return shared.full(n, self.cov.shape[1])

    def std(self) -> np.ndarray:
        """(N, K) standard deviations of the entries of k_t (every row of Θ_t has those
        of ``cov``); NaN where ``k`` is."""
        per_row = np.sqrt(np.maximum(np.diagonal(self.cov, axis1=1, axis2=2), 0.0))
        return np.tile(per_row, (1, self.n_states))

    def plot(self, truth: Any = None, *, bands: bool = True, fig: Any = None):
        """Plot the estimates of [A_t B_t] over time with ±2σ bands (step t at the sample
        x[t + 1] it produces); see :func:`ltvmodels.plotting.plot_coefficients`. Returns
        the Figure."""
        from ..plotting import plot_coefficients

        return plot_coefficients(self, truth, bands=bands, fig=fig)


@dataclass(frozen=True)
class KalmanFilterResult(_ParameterAccess):
    """Filtered parameter estimates k_{t|t} = E[k_t | y_0 … y_t].

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Filtered means, k_t = Θ_t.ravel() (rows of [A_t B_t] concatenated).
        NaN at the time steps where the diffuse filter has not yet identified the
        state (k_t, …, k_{t−d+1}), i.e. before ``first_identified``.
    cov : ndarray, shape (N, p, p)
        Filtered covariance of one row θ_{t,i} of Θ_t (σ² included); all rows share
        it and are independent, so Cov(k_t | y_0 … y_t) = I_n ⊗ cov[t]. NaN where
        ``k`` is.
    loglik : float or None
        Log-likelihood of all N observations (prediction-error decomposition);
        None if the state is never identified.
    first_identified : int
        First time step with finite estimates (0 with a proper prior); N if none.
    noise_var : float
        σ² used.
    lam : float
        λ used.
    coeffs : ndarray, shape (d + 1,)
        Difference-operator coefficients c_0 … c_d.
    n_states : int
        n, the number of output rows.

    Properties ``A`` (N, n, n) and ``B`` (N, n, m) give [A_t B_t] from ``k``;
    ``cov_full()`` the (N, K, K) covariance.
    """

    k: np.ndarray
    cov: np.ndarray
    loglik: float | None
    first_identified: int
    noise_var: float
    lam: float
    coeffs: np.ndarray
    n_states: int


@dataclass(frozen=True)
class KalmanSmootherResult(_ParameterAccess):
    """Smoothed parameter estimates k_{t|N} = E[k_t | y_0 … y_{N−1}].

    With the default diffuse initialization these equal the minimizer of
    Σ_t ‖y_t − Θ_t φ_t‖² + λ² Σ_t ‖(Dk)_t‖² (:func:`ltvmodels.fit`).

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Smoothed means.
    cov : ndarray, shape (N, p, p)
        Smoothed covariance of one row θ_{t,i} (σ² included), shared by all rows:
        Cov(k_t | y) = I_n ⊗ cov[t].
    loglik : float or None
        Log-likelihood (see the module notes on the diffuse convention); None
        if the state is never identified.
    filtered : KalmanFilterResult
        The forward pass.

    Properties ``A`` (N, n, n) and ``B`` (N, n, m) give [A_t B_t] from ``k``;
    ``cov_full()`` the (N, K, K) covariance.
    """

    k: np.ndarray
    cov: np.ndarray
    loglik: float | None
    filtered: KalmanFilterResult

    @property
    def n_states(self) -> int:
        """n, the number of output rows."""
        return self.filtered.n_states
