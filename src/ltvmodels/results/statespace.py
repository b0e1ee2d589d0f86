"""The state-space result: an identified LTV model x[t+1] = A_t x[t] + B_t u[t] + v_t."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ..core.simulation import simulate_affine
from ..errors import DivergenceWarning
from ..validation import arrays, options
from .base import LinearTimeVarying
from .forecast import (
    DEFAULT_SAMPLES,
    Forecast,
    forecast_model,
    forecast_options,
    noise_covariance,
    state_space_inputs,
)
from .record import FitRecord
from .regression import RegressionModel


class LTVModel(RegressionModel, LinearTimeVarying):
    """An identified linear time-varying model.

    Model index t maps (x[t], u[t]) to x[t+1], t = 0 … N-1 (N = T − 1 for T
    samples of data):

        x[t+1] = A_t x[t] + B_t u[t] + c_t + v_t,

    with c_t = 0 unless the model was fitted with ``constant=True``. The
    parameter vector is ``k[t] = np.hstack([A[t], B[t]]).ravel()``, or
    ``np.hstack([A[t], B[t], c[t][:, None]]).ravel()`` with an intercept. It
    is the :class:`RegressionModel` with y_t = x_{t+1} and φ_t = [x_t; u_t]
    (; 1).

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Parameter vectors, K = n·(n + m) (n·(n + m + 1) with an intercept).
    A : ndarray, shape (N, n, n)
    B : ndarray, shape (N, n, m)
    c : ndarray, shape (N, n)
        The intercepts c_t (zeros for a model without one).
    constant : bool
        Whether the model has an intercept c_t.
    cov : ndarray or None
        Posterior covariance of k_t, p = n + m (+ 1): shape (N, p, p) when the
        output rows are independent with a shared covariance (then
        Cov(k_t) = I_n ⊗ cov[t]); (N, n, p, p) when they are independent with
        covariances of their own (cov[t, i] is that of row i of Θ_t, e.g. with
        a noise variance per output); (N, K, K) when the rows are correlated.
        None if not computed. :meth:`cov_full` always returns (N, K, K)
        (O(N K²) memory); :meth:`std` (N, K).
    noise_var : ndarray, shape (n,), or None
        Noise variance σ_i² of each state equation (estimated or given; equal entries
        where the estimator assumes one variance for all outputs). None for
        coefficients given to the constructor.
    noise_cov : ndarray, shape (n, n), or None
        Noise covariance estimate (None for given coefficients).
    loglik : float or None
        Log (marginal) likelihood of the data under the model's probabilistic
        interpretation (see :func:`ltvmodels.fit`). None where it does not
        exist: for norm="group"/"l1" (no Gaussian model), a post-hoc prior
        correction, a prior that leaves parameters undetermined, a singular
        residual covariance (an exact fit: the likelihood is unbounded) and
        given coefficients; ``info["loglik_note"]`` says which.
    info : dict
        Solver details: objective, solver name, factorizations, and so on.
    status : FitStatus or None
        How the coefficients were computed (see :class:`~ltvmodels.FitStatus`).

    Parameters
    ----------
    k : array_like, shape (N, K)
        Parameter vectors k_t = ``np.hstack([A_t, B_t]).ravel()`` (with c_t as
        a last column when ``constant``).
    n_states, n_inputs : int
        n and m.
    fit : FitRecord, optional
        What the estimator computed besides k; default: nothing (given
        coefficients, e.g. ``LTVModel(k, 2, 1).simulate(x0, u)``).
    constant : bool
        Whether k holds an intercept c_t.
    """

    def __init__(
        self, k: np.ndarray, n_states: int, n_inputs: int, fit: FitRecord | None = None,
        constant: bool = False,
    ) -> None:
        n_states = options.integer(n_states, "n_states", minimum=1)
        n_inputs = options.integer(n_inputs, "n_inputs", minimum=0)
        constant = options.flag(constant, "constant")
        super().__init__(k, n_states, n_states + n_inputs + constant, fit)
        self.n_states = n_states
        self.n_inputs = n_inputs
        self.constant = constant

    # -- shapes -------------------------------------------------------------------
    @property
    def A(self) -> np.ndarray:
        """(N, n, n) state matrices."""
        return self.theta[:, :, : self.n_states]

    @property
    def B(self) -> np.ndarray:
        """(N, n, m) input matrices."""
        return self.theta[:, :, self.n_states : self.n_states + self.n_inputs]

    @property
    def c(self) -> np.ndarray:
        """(N, n) intercepts c_t (zeros without an intercept)."""
        if not self.constant:
            return np.zeros((self.N, self.n_states))
        return self.theta[:, :, -1]

    # -- use ----------------------------------------------------------------------
    def predict(self, x: Any, u: Any = None) -> np.ndarray:
        """One-step predictions x̂[t+1] = A_t x[t] + B_t u[t] + c_t.

        Parameters
        ----------
        x : array_like, shape (T, n) or (R, T, n), T = N + 1
            States (R trajectories); NaN gives NaN predictions.
        u : array_like, shape (T, m), (T,) or (R, T, m), or None when m = 0

        Returns
        -------
        ndarray, shape (T − 1, n), or (R, T − 1, n) for R trajectories
            Predictions of x[1:].
        """
        batch = arrays.is_batch(x)
        x, u = self._data(x, u)
        if x.shape[1] != self.N + 1:
            raise ValueError(
                f"x: expected T = {self.N + 1} time steps (the model has N = {self.N} "
                f"transitions), received {x.shape[1]}"
            )
        parts = [x[:, :-1], u[:, :-1]]
        if self.constant:
            parts.append(np.ones(x.shape[:2] + (1,))[:, :-1])
        out = np.einsum("tij,rtj->rti", self.theta, np.concatenate(parts, axis=2))
        return out if batch else out[0]

    def simulate(self, x0: Any, u: Any = None) -> np.ndarray:
        """Open-loop simulation from x0: x[t+1] = A_t x[t] + B_t u[t] + c_t.

        Parameters
        ----------
        x0 : array_like, shape (n,) or (R, n)
            Initial state(s); R initial states simulate R trajectories.
        u : array_like, shape (T, m), (T,) or (N, m) — T = N + 1 (the last
            input is unused) — or (R, T, m) / (R, N, m) for R trajectories, or
            None when the model has no inputs. A single input sequence is
            shared by all R initial states.

        Returns
        -------
        ndarray, shape (T, n), or (R, T, n) for (R, n) initial states

        Warns
        -----
        DivergenceWarning
            If the state overflows to inf (an unstable model).
        """
        x0 = arrays.as_float_array(x0, "x0")
        batch = x0.ndim == 2
        x0 = x0.reshape(-1, x0.shape[-1]) if batch else x0.ravel()[None]
        if x0.shape[1] != self.n_states:
            raise ValueError(
                f"x0: expected shape ({self.n_states},) or (R, {self.n_states}), received "
                f"{x0.shape if batch else x0.shape[1:]}"
            )
        R = x0.shape[0]
        if R == 0:
            raise ValueError("x0: expected at least one initial state, received shape "
                             f"{x0.shape}")
        if u is None:
            if self.n_inputs:
                raise ValueError(f"u: the model has {self.n_inputs} inputs, received None")
            u = np.zeros((1, self.N, 0))
        else:
            u = arrays.trajectories(u, "u")
            if np.isnan(u[:, : self.N]).any():  # the last row drives no transition
                raise ValueError("u: expected finite inputs for a simulation, received NaN")
            if u.shape[2] != self.n_inputs:
                raise ValueError(f"u: expected {self.n_inputs} columns, received {u.shape[2]}")
            if u.shape[1] not in (self.N, self.N + 1):
                raise ValueError(
                    f"u: expected {self.N + 1} (or {self.N}) rows, received {u.shape[1]}"
                )
            if u.shape[0] not in (1, R):
                raise ValueError(
                    f"u: expected one input sequence or {R} (one per initial state), "
                    f"received {u.shape[0]}"
                )
        A, B = np.ascontiguousarray(self.A), np.ascontiguousarray(self.B)
        c = np.ascontiguousarray(self.c)
        out = np.stack([
            simulate_affine(A, B, c, x0[r], np.ascontiguousarray(u[r % u.shape[0], : self.N]))
            for r in range(R)
        ])
        if not np.all(np.isfinite(out)):
            step = int(np.flatnonzero(~np.all(np.isfinite(out), axis=(0, 2)))[0])
            warnings.warn(
                f"the simulation diverged: the state is inf or NaN from time step {step} on "
                "(the model is unstable along these inputs)", DivergenceWarning, stacklevel=2,
            )
        return out if batch else out[0]

    def forecast(
        self, x0: Any, u: Any = None, *, steps: int | None = None, level: float = 0.95,
        n_samples: int = DEFAULT_SAMPLES, seed: Any = 0, noise_cov: Any = None,
    ) -> Forecast:
        """Forecast the states after the end of the data, with prediction intervals.

        From the last recorded state x0 = x[T−1] (= x[N]) the model continues
        x[t+1] = A_t x[t] + B_t u[t] + c_t + v_t for t = N, N+1, …: the
        coefficients after the data follow the recursion of the penalty's
        difference operator (order 1: they stay at the last estimate; order
        2: they continue its straight line), with their uncertainty (the
        posterior covariance of the last estimate and, for norm="sq", the
        drift σ_i²/λ² per step of the penalty's random walk); v_t has the
        covariance ``noise_cov``. The first step is exact and Gaussian, the
        others come from seeded Monte Carlo simulation, or are exact where
        the coefficients are certain (no covariance, no drift). See
        :mod:`ltvmodels.results.forecast` for the model and the method.

        Parameters
        ----------
        x0 : array_like, shape (n,)
            The state at the end of the data, x[T−1].
        u : array_like, shape (steps, m), or (steps,) when m = 1; None without inputs
            The future inputs u[T−1], u[T], …: row j drives the step from
            x[T−1+j] to x[T+j] (the data's last input u[T−1] drives no fitted
            transition, so it is the first one here).
        steps : int, optional
            Number of steps, >= 1. Required without inputs; with inputs it
            defaults to ``len(u)`` (and must equal it when given).
        level : float, default 0.95
            Probability of the central prediction intervals, in (0, 1).
        n_samples : int, default 2000
            Monte Carlo paths (rounded up to an even number: antithetic pairs).
        seed : int, numpy Generator or None, default 0
            Seed of the Monte Carlo draws (the same seed gives the same forecast).
        noise_cov : array_like, shape (n, n), optional
            Covariance of v_t (a variance or (n,) variances: a diagonal).
            Default: the model's ``noise_cov``; required for a model built
            from given coefficients.

        Returns
        -------
        Forecast
            ``mean``, ``lower``, ``upper`` (steps, n), ``cov`` (steps, n, n);
            row j is x[T+j] (``time`` = T … T + steps − 1, T = N + 1).

        Raises
        ------
        TypeError, ValueError
            Inputs of the wrong type or shape (the message names the
            argument); a model without a noise covariance and no
            ``noise_cov``; a norm="sq" model fitted with λ = 0 for some
            coefficient (its drift is unbounded).
        """
        x0, future, steps = state_space_inputs(x0, u, steps, n=self.n_states, m=self.n_inputs)
        level, n_samples, seed = forecast_options(level, n_samples, seed)
        noise = noise_covariance(noise_cov, self.noise_cov, self.n_states)
        known = np.concatenate([future, np.ones((steps, 1))], axis=1) if self.constant \
            else future
        return forecast_model(
            self, x0[None, :], known, level=level, n_samples=n_samples, seed=seed,
            noise_cov=noise, time=np.arange(self.N + 1, self.N + 1 + steps),
            names=self.state_names,
        )

    def _data(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        x, u = arrays.recordings(x, u)
        if x.shape[2] != self.n_states:
            raise ValueError(f"x: expected {self.n_states} columns, received {x.shape[2]}")
        if u.shape[2] != self.n_inputs:
            raise ValueError(f"u: expected {self.n_inputs} columns, received {u.shape[2]}")
        return x, u

    # -- persistence --------------------------------------------------------------
    def structure(self) -> dict:
        return {"n_states": self.n_states, "n_inputs": self.n_inputs, "constant": self.constant}

    @classmethod
    def from_structure(cls, k: np.ndarray, structure: dict, fit: FitRecord) -> LTVModel:
        return cls(k, structure["n_states"], structure["n_inputs"], fit,
                   constant=structure.get("constant", False))

    # -- display ------------------------------------------------------------------
    def _repr_sizes(self) -> str:
        extra = ", constant=True" if self.constant else ""
        return f"n_states={self.n_states}, n_inputs={self.n_inputs}{extra}"

    def plot(self, truth: Any = None, *, bands: bool = True, fig: Any = None):
        """Plot the coefficients of [A_t B_t] over time.

        See :func:`ltvmodels.plotting.plot_coefficients`; returns the Figure.
        """
        from ..plotting import plot_coefficients

        return plot_coefficients(self, truth=truth, bands=bands, fig=fig)
