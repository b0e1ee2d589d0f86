"""The state-space result: an identified LTV model x[t+1] = A_t x[t] + B_t u[t] + v_t."""

from __future__ import annotations

from numbers import Integral
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..core.simulation import simulate_affine
from ..errors import DivergenceWarning, warn
from ..validation import arrays, memory, options
from ..validation.arrays import LARGEST_DATA, describe
from ..validation.time import increasing, sampling_period
from .base import LinearTimeVarying
from .forecast import (
    DEFAULT_SAMPLES,
    Forecast,
    forecast_model,
    forecast_options,
    inputs_after_data,
    noise_covariance,
    remembered_tail,
    state_space_inputs,
)
from .record import FitRecord
from .regression import RegressionModel

__all__ = ["LTVModel"]


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
    states : ndarray or None
        With ``measurement_noise`` (see :func:`ltvmodels.fit`): the smoothed states
        E[x_t | recorded x], shape (T, n) or (R, T, n) as the recorded x (on its
        regular time grid), finite everywhere, also at missing entries. None when the
        states were taken as exact.
    states_std : ndarray or None
        Their standard deviations (same shape), or None.
    measurement_noise : ndarray, shape (n,), or None
        The measurement-noise variance of each state (estimated or given); None
        for exact states.
    sample_outliers : ndarray of bool, shape (T,) or (R, T), or None
        With ``measurement_noise``: the recorded samples judged corrupted, those
        with a standardized smoothed measurement residual
        abs(x_ti − E[x_ti | x]) / √(σ_{e,i}² + Var(x_ti | x)) above 3 in an observed
        state (``info["sample_outlier_threshold"]``), whatever the
        ``measurement_loss``; None for exact states.

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
    copy : bool
        False: take a float64 ``k`` as it is (see :class:`~ltvmodels.RegressionModel`).

    See Also
    --------
    from_arrays : a model from known matrices A_t, B_t (and c_t).
    to_statespace : the model at one step as a python-control ``StateSpace``.
    """

    def __init__(
        self,
        k: ArrayLike,
        n_states: int,
        n_inputs: int,
        fit: FitRecord | None = None,
        constant: bool = False,
        *,
        copy: bool = True,
    ) -> None:
        n_states = options.integer(n_states, "n_states", minimum=1)
        n_inputs = options.integer(n_inputs, "n_inputs", minimum=0)
        constant = options.flag(constant, "constant")
        super().__init__(k, n_states, n_states + n_inputs + constant, fit, copy=copy)
        self.n_states = n_states
        self.n_inputs = n_inputs
        self.constant = constant

    # x[t + 1] is produced by step t: the state-space timing, not RegressionModel's (which
    # comes first in the method resolution order)
    produced_offset = LinearTimeVarying.produced_offset

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

    # -- names ----------------------------------------------------------------------
    @property
    def output_names(self) -> list[str]:
        """The states (the outputs of x[t+1] = A_t x[t] + …)."""
        return self.state_names

    @property
    def regressor_names(self) -> list[str]:
        """The states, the inputs and "1" for the intercept."""
        return self.state_names + self.input_names + (["1"] if self.constant else [])

    def coefficient_names(self) -> list[str]:
        """Names of the entries of k_t in its order: "A[x0,x1]", "B[x0,u0]", "c[x0]"."""
        names = []
        for out in self.state_names:
            names += [f"A[{out},{state}]" for state in self.state_names]
            names += [f"B[{out},{name}]" for name in self.input_names]
            names += [f"c[{out}]"] if self.constant else []
        return names

    def _index_step(self) -> float:
        """The step of a regular time index (dates in seconds), else 1; an error for a time
        index that does not increase (set by hand or in an edited file: a fit checks it)."""
        time = self.time
        if time is None or time.size < 2:
            return 1.0
        step = sampling_period(time)
        if step is not None:
            return step
        if not increasing(time):
            raise ValueError(
                f"dt: the model's time index (model.time, from {time[0]} to {time[-1]}) does "
                "not increase, so its step is no sampling period; pass dt=, the sampling "
                "period > 0"
            )
        return 1.0

    @classmethod
    def from_arrays(
        cls,
        A: ArrayLike,
        B: ArrayLike | None = None,
        *,
        c: ArrayLike | None = None,
        steps: int | None = None,
        noise_cov: float | ArrayLike | None = None,
        order: int | ArrayLike | None = None,
    ) -> LTVModel:
        """A model with known coefficients: x[t+1] = A_t x[t] + B_t u[t] (+ c_t) + v_t.

        The model of a known (e.g. physical or linearized) system, or another
        model's coefficients, as an :class:`LTVModel`: it simulates, predicts,
        forecasts (with ``noise_cov``), plots, saves and loads like a fitted
        one, and serves as the mean of a :class:`~ltvmodels.Prior`. Like
        coefficients given to the constructor, it records no fit: ``norm``,
        ``lam``, ``cov``, ``loglik`` and ``status`` are None.

        Parameters
        ----------
        A : array_like, shape (N, n, n), or (n, n) with ``steps``
            State matrices A_t; one (n, n) matrix is repeated over ``steps``
            time steps.
        B : array_like, shape (N, n, m) or (n, m), optional
            Input matrices B_t (an (n, m) matrix is used at every step).
            Default: no inputs (m = 0).
        c : array_like, shape (N, n) or (n,), optional
            Intercepts c_t (an (n,) vector at every step); given, the model has
            ``constant=True`` (even if c is zero). Default: no intercept.
        steps : int, optional
            N, the number of time steps (transitions), >= 1. Required when A is
            one (n, n) matrix; with an (N, n, n) A it may be given and must
            equal N. The model stores N·K coefficients (K = n·(n + m), + n
            with ``c``): a ``steps`` whose coefficients would exceed the
            machine's physical memory is an error, before anything is
            allocated.
        noise_cov : array_like, shape (n, n), optional
            Covariance of the process noise v_t (a scalar or (n,) variances: a
            diagonal); symmetric positive semidefinite. Stored as
            ``noise_cov`` (and its diagonal as ``noise_var``) for
            :meth:`forecast`. Default: None (``forecast`` then needs its own
            ``noise_cov=``).
        order : int or array_like, optional
            The difference operator that continues the coefficients after the
            end in :meth:`forecast` and that :meth:`activation` applies, as in
            :func:`ltvmodels.fit`: an integer d >= 1 (at most N − 1) or
            coefficients c_0 … c_d. Default: None, the first difference, as
            for every model without a penalty (the coefficients stay at A_{N−1},
            B_{N−1} after the end).

        Returns
        -------
        LTVModel
            ``A``, ``B``, ``c`` equal to the given matrices, ``n_inputs`` = m,
            ``constant`` = (c is not None).

        Raises
        ------
        TypeError
            An argument that is not an array of real numbers (or an integer
            for ``steps``, ``order``).
        ValueError
            A shape that does not fit the others, non-finite entries or
            magnitudes above 1e100 (which model files reject), an invalid
            ``noise_cov`` or ``order``, ``steps`` whose coefficients (N·K
            numbers) would not fit in the machine's physical memory; the
            message names the argument.

        Examples
        --------
        >>> import numpy as np
        >>> import ltvmodels as ltv
        >>> model = ltv.LTVModel.from_arrays([[0.9, 0.1], [0.0, 0.8]], [[0.0], [1.0]], steps=50)
        >>> model.simulate([1.0, 0.0], np.ones(50)).shape
        (51, 2)
        """
        A = _coefficient_array(A, "A")
        if A.ndim not in (2, 3) or A.shape[-1] != A.shape[-2] or A.shape[-1] == 0:
            raise ValueError(
                f"A: expected shape (N, n, n) or (n, n) with n >= 1, received shape {A.shape}"
            )
        if steps is not None:
            steps = options.integer(steps, "steps", minimum=1)
        if A.ndim == 2:
            if steps is None:
                raise ValueError(
                    f"steps: required when A is one {A.shape} matrix (it is "
                    "repeated over steps time steps); pass steps=N, or A of shape "
                    f"(N, {A.shape[0]}, {A.shape[1]})"
                )
            A = np.broadcast_to(A, (steps,) + A.shape)
        elif A.shape[0] == 0:
            raise ValueError(f"A: expected at least one time step, received shape {A.shape}")
        elif steps is not None and steps != A.shape[0]:
            raise ValueError(
                f"steps: expected None or {A.shape[0]} (the length of A, shape "
                f"{A.shape}), received {steps}"
            )
        N, n = A.shape[0], A.shape[1]
        if B is None:
            B = np.zeros((N, n, 0))
        else:
            B = _coefficient_array(B, "B")
            if B.ndim not in (2, 3) or B.shape[-2] != n or (B.ndim == 3 and B.shape[0] != N):
                raise ValueError(
                    f"B: expected shape ({N}, {n}, m) or ({n}, m) for A with N = "
                    f"{N} steps and n = {n} states, received shape {B.shape}"
                )
            B = np.broadcast_to(B, (N,) + B.shape[-2:])
        parts = [A, B]
        if c is not None:
            c = _coefficient_array(c, "c")
            if c.ndim not in (1, 2) or c.shape[-1] != n or (c.ndim == 2 and c.shape[0] != N):
                raise ValueError(
                    f"c: expected shape ({N}, {n}) or ({n},) for A with N = {N} "
                    f"steps and n = {n} states, received shape {c.shape}"
                )
            parts.append(np.broadcast_to(c, (N, n))[:, :, None])
        coeffs = None if order is None else options.difference_coefficients(order, max_degree=N - 1)
        if coeffs is not None and coeffs.size > N:  # model files hold at most N coefficients
            raise ValueError(
                f"order: expected at most {N} coefficients (degree N − 1 = {N - 1}) "
                f"for a model of N = {N} steps, received {coeffs.size}"
            )
        noise = None if noise_cov is None else noise_covariance(noise_cov, None, n)
        K = n * (n + B.shape[2] + (c is not None))
        if steps is not None:  # A repeated over ``steps``: the first array of that size is k
            memory.affordable_count(
                steps,
                "steps",
                item_bytes=K * np.dtype(np.float64).itemsize,
                what=f"the coefficients of {steps} steps ({K} numbers each)",
                remedy="pass fewer steps",
            )
        fit = FitRecord(
            coeffs=coeffs,
            noise_cov=noise,
            noise_var=None if noise is None else np.diag(noise).copy(),
        )
        k = np.concatenate(parts, axis=2).reshape(N, -1)
        return cls(k, n, B.shape[2], fit, constant=c is not None)

    # -- use ----------------------------------------------------------------------
    def predict(self, x: ArrayLike, u: ArrayLike | None = None) -> np.ndarray:
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

    def simulate(self, x0: ArrayLike, u: ArrayLike | None = None) -> np.ndarray:
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
            raise ValueError(f"x0: expected at least one initial state, received shape {x0.shape}")
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
        out = np.stack(
            [
                simulate_affine(A, B, c, x0[r], np.ascontiguousarray(u[r % u.shape[0], : self.N]))
                for r in range(R)
            ]
        )
        if not np.all(np.isfinite(out)):
            step = int(np.flatnonzero(~np.all(np.isfinite(out), axis=(0, 2)))[0])
            warn(
                f"the simulation diverged: the state is inf or NaN from time step {step} on "
                "(the model is unstable along these inputs)",
                DivergenceWarning,
            )
        return out if batch else out[0]

    @property
    def tail_lengths(self) -> tuple[int, int]:
        """(1, 1): a forecast continues from the last state x[T−1] and the last input
        u[T−1] (which drives x[T]); see :class:`~ltvmodels.results.description.DataTail`."""
        return 1, 1

    def future_input_rows(self, steps: int) -> int:
        """The inputs after the data that ``forecast(steps=steps, u=…)`` reads: steps − 1
        (u[T] … u[T+steps−2]; x[T] is driven by the recorded u[T−1]), 0 without inputs."""
        return max(int(steps) - 1, 0) if self.n_inputs else 0

    def forecast(
        self,
        x0: ArrayLike | None = None,
        u: ArrayLike | None = None,
        *,
        steps: int | None = None,
        level: float = 0.95,
        n_samples: int = DEFAULT_SAMPLES,
        seed: int | np.random.Generator | None = 0,
        noise_cov: float | ArrayLike | None = None,
    ) -> Forecast:
        """Forecast the states after the end of the data, with prediction intervals.

        For T recorded states x[0] … x[T−1] (N = T − 1 transitions) the model
        continues x[t+1] = A_t x[t] + B_t u[t] + c_t + v_t for t = T−1, T, …:
        the first forecast is x[T] = A x[T−1] + B u[T−1] (+ c) + v, driven by
        the last *recorded* input u[T−1] (the data's last input drives no
        fitted transition). The coefficients after the data follow the
        recursion of the penalty's difference operator (order 1: they stay
        at the last estimate; order 2: they continue its straight line),
        with their uncertainty (the posterior covariance of the last estimate
        and, for norm="sq", the drift σ_i²/λ² per step of the penalty's random
        walk); v_t has the covariance ``noise_cov``. The first step is exact
        and Gaussian, the others come from seeded Monte Carlo simulation, or
        are exact where the coefficients are certain (no covariance, no
        drift). See :mod:`ltvmodels.results.forecast` for the model and the
        method.

        Two ways to say where it starts, with the same timing:

        ``forecast(steps=H, u=future)``
            From the end of the data the model was fitted on (it remembers
            x[T−1] and u[T−1]: ``model.data.tail``); ``u`` holds only the
            inputs after the data, u[T] … u[T+H−2]: H − 1 rows (an H-th,
            u[T+H−1], is accepted and unused).
        ``forecast(x0, u)``
            From a given state x0 = x[T−1]; ``u`` = u[T−1], u[T], …, u[T+H−2]:
            H rows, the last recorded input first.

        The first form needs a model that remembers the end of its data: one
        fitted on a single series whose last state and input are observed
        (not several trajectories, not ``from_arrays``).

        Parameters
        ----------
        x0 : array_like, shape (n,), optional
            The state at the end of the data, x[T−1]. Default: the one the
            model remembers (then ``u`` holds only the inputs after the data).
        u : array_like, shape (rows, m), or (rows,) when m = 1; None without inputs
            With ``x0``: the inputs u[T−1], u[T], … (steps rows): row j drives
            the step from x[T−1+j] to x[T+j], the first is the last recorded
            input. Without ``x0``: only the inputs after the data, u[T], u[T+1],
            … (row j at the forecast sample x[T+j]); ``steps − 1`` rows are
            read (``future_input_rows``), ``steps`` are accepted; None for one
            step.
        steps : int, optional
            Number of steps, >= 1. Required without inputs; with inputs it
            defaults to ``len(u)`` (and with ``x0`` must equal it when given).
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
            argument); no ``x0`` for a model that does not remember the end
            of its data; a model without a noise covariance and no
            ``noise_cov``; a norm="sq" model fitted with λ = 0 for some
            coefficient (its drift is unbounded).

        Warns
        -----
        DivergenceWarning
            If the forecast overflows to inf or NaN (an unstable model over a
            long horizon).

        Examples
        --------
        Continue the data the model was fitted on for 5 steps, given the
        inputs u[T] … u[T+3] after it; the same forecast from an explicit
        start takes the last recorded input first:

        >>> model = ltv.fit(x, u, lam=10.0)                          # doctest: +SKIP
        >>> f = model.forecast(steps=5, u=future[:4])                # doctest: +SKIP
        >>> g = model.forecast(x[-1], np.r_[u[-1:], future[:4]])     # doctest: +SKIP
        """
        n, m = self.n_states, self.n_inputs
        if x0 is None:
            tail = remembered_tail(
                self,
                "x0",
                f"the state x[T−1] at the end of the data, shape ({n},), with u starting at "
                "the last recorded input u[T−1]",
            )
            future, steps = inputs_after_data(
                u,
                steps,
                m=m,
                needed=self.future_input_rows,
                reach="x[T] is driven by the last recorded input u[T−1], which the model "
                "keeps, so x[T+j] needs u[T+j−1]",
            )
            start = tail.outputs[-1]
            # u[T−1] from the data, then those after it: the explicit form's inputs
            inputs = np.concatenate([tail.inputs, future]) if m else np.zeros((steps, 0))
        else:
            start, inputs, steps = state_space_inputs(x0, u, steps, n=n, m=m)
        level, n_samples, seed = forecast_options(level, n_samples, seed)
        noise = noise_covariance(noise_cov, self.noise_cov, n)
        known = np.concatenate([inputs, np.ones((steps, 1))], axis=1) if self.constant else inputs
        return forecast_model(
            self,
            start[None, :],
            known,
            level=level,
            n_samples=n_samples,
            seed=seed,
            noise_cov=noise,
            time=self.times_after(self.N + 1, steps),
            names=self.state_names,
        )

    def to_statespace(self, t: int = -1, *, dt: float | None = None) -> Any:
        """The model at step t as a discrete-time python-control ``StateSpace``.

        The frozen system of model step t,

            x[k+1] = A_t x[k] + B_t u[k],   y[k] = x[k],

        i.e. ``control.StateSpace(A_t, B_t, I_n, 0, dt)``: all states are the
        outputs (C = I_n, D = 0), so it can be analysed (poles, gains,
        controllability, LQR design) and simulated with python-control's
        tools. python-control is an optional dependency: ``pip install
        'ltvmodels[control]'``.

        The intercept: a model with ``constant=True`` has
        x[t+1] = A_t x[t] + B_t u[t] + c_t, which is not of this form; c_t is
        appended as an extra, last input column, B = [B_t c_t] (n, m + 1)
        with input label ``"const"`` (``"const_"`` if an input has that
        name), and the system equals the model when that input is held at 1
        (keep it in mind for gains and controllability, which then count it
        as an input).

        Signal names: python-control names a signal of a system "sys.u" and
        keeps one signal per name, so a name with a "." (``"pos.x"``, or a
        float column name ``1.5``) is exported with "_" for each "."
        (``"pos_x"``, ``"1_5"``), and a label that then repeats an earlier one
        of the same kind gets "_" appended until it is new. The model's own
        names are unchanged.

        Parameters
        ----------
        t : int, default -1
            The model step, -N <= t < N; negative values count from the end
            as in Python indexing (-1: the last step, N − 1).
        dt : float, optional
            Sampling period of the discrete-time system, > 0. Default: the
            step of the model's time index when it is regular (numbers: in
            their unit, e.g. 0.1 for an index 0, 0.1, 0.2, …; dates and time
            spans: in seconds), else 1 (one model step).

        Returns
        -------
        control.StateSpace
            A (n, n) = ``model.A[t]``; B (n, m) = ``model.B[t]``, or
            [B_t c_t] (n, m + 1) with the intercept; C = I_n; D = 0 of B's
            shape; ``dt``; labelled with ``state_names`` (states and outputs) and
            ``input_names`` (+ ``"const"``), as python-control takes them (see
            above), named ``"ltv_t<t>"`` with t
            counted from 0. A model without inputs (m = 0, no intercept)
            gives a system with zero inputs (B of shape (n, 0)).

        Raises
        ------
        ImportError
            python-control is not installed.
        TypeError
            ``t`` is not an integer, ``dt`` not a real number.
        ValueError
            ``t`` outside [-N, N − 1], ``dt`` not > 0; no ``dt`` for a model
            whose time index does not increase (set by hand, e.g. with
            :meth:`with_data`: a fit checks the time order).

        Examples
        --------
        The poles of the last step (the eigenvalues of A_{N−1}); the first
        step with a sampling period of 10 ms, and its steady-state gain:

        >>> sys_last = model.to_statespace()             # doctest: +SKIP
        >>> sys_last.poles()                             # doctest: +SKIP
        >>> model.to_statespace(0, dt=0.01).dcgain()     # doctest: +SKIP
        """
        if isinstance(t, (bool, np.bool_)) or not isinstance(t, Integral):
            raise TypeError(
                f"t: expected an integer model step in [{-self.N}, {self.N - 1}], "
                f"received {describe(t)}"
            )
        if not -self.N <= t < self.N:
            raise ValueError(
                f"t: expected a model step in [{-self.N}, {self.N - 1}] (the model "
                f"has N = {self.N} steps; negative steps count from the end), "
                f"received {int(t)}"
            )
        step = int(t) % self.N
        dt = self._index_step() if dt is None else options.positive_scalar(dt, "dt")
        missing = (
            "to_statespace needs python-control (the package 'control', >= 0.9.4): "
            "install it with pip install 'ltvmodels[control]' (or pip install control)"
        )
        try:
            import control
        except ImportError as exc:
            raise ImportError(missing) from exc
        if not hasattr(control, "StateSpace"):  # a directory named control/ on sys.path
            raise ImportError(
                f"{missing}; the module 'control' found "
                f"({getattr(control, '__path__', None) or control}) is not it"
            )
        n = self.n_states
        B = self.theta[step, :, n:]  # [B_t] or [B_t c_t]
        states = _signal_labels(self.state_names)
        return control.StateSpace(
            np.array(self.A[step]),
            np.array(B),
            np.eye(n),
            np.zeros((n, B.shape[1])),
            dt,
            inputs=_signal_labels(self.input_names + (["const"] if self.constant else [])),
            outputs=states,
            states=states,
            name=f"ltv_t{step}",
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
        return cls(
            k,
            structure["n_states"],
            structure["n_inputs"],
            fit,
            constant=structure.get("constant", False),
        )

    # -- display ------------------------------------------------------------------
    def _repr_sizes(self) -> str:
        extra = ", constant=True" if self.constant else ""
        return f"n_states={self.n_states}, n_inputs={self.n_inputs}{extra}"

    def _kind_text(self) -> str:
        inputs = " + B_t u[t]" if self.n_inputs else ""
        constant = " + c_t" if self.constant else ""
        return f"state space x[t+1] = A_t x[t]{inputs}{constant} + v_t"

    def _signal_names(self) -> dict[str, list[str]]:
        return {"states": self.state_names, "inputs": self.input_names}


def _signal_labels(names: list[str]) -> list[str]:
    """Signal names as python-control takes them, in their order.

    python-control rejects a "." in a signal name (it separates a system's name from
    its signal's, "sys.u") and keeps one signal per name: each "." becomes "_", and a
    name that then repeats an earlier one gets "_" appended until it is new (so an
    intercept input "const" becomes "const_" next to an input named "const").
    """
    labels: list[str] = []
    for name in names:
        label = name.replace(".", "_")
        while label in labels:
            label += "_"
        labels.append(label)
    return labels


def _coefficient_array(value: Any, name: str) -> np.ndarray:
    """A finite float64 copy of given coefficients, of magnitude up to ``LARGEST_DATA``."""
    arr = arrays.as_float_array(value, name)
    if arr.size and np.abs(arr).max() > LARGEST_DATA:
        raise ValueError(
            f"{name}: expected finite values of magnitude up to {LARGEST_DATA:g}, "
            f"received values up to {np.abs(arr).max():.3g}"
        )
    return arr
