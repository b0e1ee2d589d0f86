"""The state-space result: an identified LTV model x[t+1] = A_t x[t] + B_t u[t] + v_t."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.simulation import simulate_affine
from ..validation import arrays
from .base import LinearTimeVarying
from .record import FitRecord
from .regression import RegressionModel


class LTVModel(RegressionModel, LinearTimeVarying):
    """An identified linear time-varying model.

    Model index t maps (x[t], u[t]) to x[t+1], t = 0 … N-1 (N = T − 1 for T
    samples of data). The parameter vector is ``k[t] = np.hstack([A[t], B[t]]).ravel()``.
    It is the :class:`RegressionModel` with y_t = x_{t+1} and φ_t = [x_t; u_t].

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Parameter vectors, K = n·(n + m).
    A : ndarray, shape (N, n, n)
    B : ndarray, shape (N, n, m)
    cov : ndarray or None
        Posterior covariance of k_t: shape (N, p, p) with p = n + m when the
        output rows are independent with a shared covariance (then
        Cov(k_t) = I_n ⊗ cov[t]), otherwise (N, K, K). None if not computed.
        :meth:`cov_full` always returns (N, K, K); :meth:`std` (N, K).
    noise_var : float
        Noise variance σ² of the isotropic model (estimated or given).
    noise_cov : ndarray, shape (n, n)
        Noise covariance estimate.
    loglik : float
        Log (marginal) likelihood of the data under the model's probabilistic
        interpretation (see :func:`ltvmodels.fit`).
    info : dict
        Solver details: objective, solver name, factorizations, and so on.
    status : FitStatus or None
        How the coefficients were computed (see :class:`~ltvmodels.FitStatus`).

    Parameters
    ----------
    k : array_like, shape (N, K)
        Parameter vectors k_t = ``np.hstack([A_t, B_t]).ravel()``.
    n_states, n_inputs : int
        n and m.
    fit : FitRecord, optional
        What the estimator computed besides k; default: nothing (given
        coefficients, e.g. ``LTVModel(k, 2, 1).simulate(x0, u)``).
    """

    def __init__(
        self, k: np.ndarray, n_states: int, n_inputs: int, fit: FitRecord | None = None
    ) -> None:
        super().__init__(k, n_states, int(n_states) + int(n_inputs), fit)
        self.n_states = int(n_states)
        self.n_inputs = int(n_inputs)

    # -- shapes -------------------------------------------------------------------
    @property
    def A(self) -> np.ndarray:
        """(N, n, n) state matrices."""
        return self.theta[:, :, : self.n_states]

    @property
    def B(self) -> np.ndarray:
        """(N, n, m) input matrices."""
        return self.theta[:, :, self.n_states :]

    # -- use ----------------------------------------------------------------------
    def _check_length(self, T: int, name: str) -> None:
        if T != self.N + 1:
            raise ValueError(
                f"{name}: expected T = {self.N + 1} time steps (the model has N = {self.N} "
                f"transitions), received {T}"
            )

    def predict(self, x: Any, u: Any = None) -> np.ndarray:
        """One-step predictions x̂[t+1] = A_t x[t] + B_t u[t].

        Parameters
        ----------
        x : array_like, shape (T, n), T = N + 1
        u : array_like, shape (T, m) or (T,), or None when m = 0

        Returns
        -------
        ndarray, shape (T − 1, n)
            Predictions of x[1:].
        """
        x, u = self._data(x, u)
        self._check_length(x.shape[0], "x")
        phi = np.hstack([x[:-1], u[:-1]])
        return np.einsum("tij,tj->ti", self.theta, phi)

    def simulate(self, x0: Any, u: Any = None) -> np.ndarray:
        """Open-loop simulation from x0.

        Parameters
        ----------
        x0 : array_like, shape (n,)
        u : array_like, shape (T, m), (T,) or (N, m) — T = N + 1 (the last
            input is unused) — or None when the model has no inputs.

        Returns
        -------
        ndarray, shape (T, n)
        """
        x0 = arrays.as_float_array(x0, "x0").ravel()
        if x0.shape != (self.n_states,):
            raise ValueError(f"x0: expected shape ({self.n_states},), received {x0.shape}")
        if u is None:
            if self.n_inputs:
                raise ValueError(f"u: the model has {self.n_inputs} inputs, received None")
            u = np.zeros((self.N, 0))
        else:
            u = arrays.as_time_series(u, "u")
            if u.shape[1] != self.n_inputs:
                raise ValueError(f"u: expected {self.n_inputs} columns, received {u.shape[1]}")
            if u.shape[0] not in (self.N, self.N + 1):
                raise ValueError(
                    f"u: expected {self.N + 1} (or {self.N}) rows, received {u.shape[0]}"
                )
        return simulate_affine(
            np.ascontiguousarray(self.A), np.ascontiguousarray(self.B),
            np.zeros((self.N, self.n_states)), x0, np.ascontiguousarray(u[: self.N]),
        )

    def _data(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        x, u = arrays.state_and_input(x, u)
        if x.shape[1] != self.n_states:
            raise ValueError(f"x: expected {self.n_states} columns, received {x.shape[1]}")
        if u.shape[1] != self.n_inputs:
            raise ValueError(f"u: expected {self.n_inputs} columns, received {u.shape[1]}")
        return x, u

    # -- persistence --------------------------------------------------------------
    def structure(self) -> dict:
        return {"n_states": self.n_states, "n_inputs": self.n_inputs}

    @classmethod
    def from_structure(cls, k: np.ndarray, structure: dict, fit: FitRecord) -> LTVModel:
        return cls(k, structure["n_states"], structure["n_inputs"], fit)

    # -- display ------------------------------------------------------------------
    def _repr_sizes(self) -> str:
        return f"n_states={self.n_states}, n_inputs={self.n_inputs}"

    def plot(self, truth: Any = None, *, bands: bool = True, fig: Any = None):
        """Plot the coefficients of [A_t B_t] over time.

        See :func:`ltvmodels.plotting.plot_coefficients`; returns the Figure.
        """
        from ..plotting import plot_coefficients

        return plot_coefficients(self, truth=truth, bands=bands, fig=fig)
