"""AR and ARX results: time-varying (V)AR(X) models, their poles and root spectrogram.

    y[t] = Σ_{i=1}^{na} A_{t,i} y[t−i] + Σ_{j=1}^{nb} B_{t,j} u[t−nk−j+1] + c_t + e[t]

(:mod:`ltvmodels.core.lags` for the regression behind it; fitted by
:func:`ltvmodels.fit_ar` and :func:`ltvmodels.fit_arx`).
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike

from ..core.lags import lag_length, lag_regressor_names, lagged_regressors
from ..validation import arrays, options
from .forecast import (
    DEFAULT_SAMPLES,
    Forecast,
    forecast_model,
    forecast_options,
    inputs_after_data,
    lagged_inputs,
    noise_covariance,
    remembered_tail,
)
from .record import FitRecord
from .regression import RegressionModel

__all__ = ["ARXModel", "ARModel"]


@numba.njit(cache=True)
def _simulate_arx(theta, y, u, noise, na, nb, nk, lag, constant):  # pragma: no cover
    """y[lag + t] = Θ_t φ_t + noise[t] for t = 0 … N − 1, in place on y (T, n)."""
    N, n, _ = theta.shape
    m = u.shape[1]
    for t in range(N):
        s = lag + t
        for i in range(n):
            acc = noise[t, i]
            col = 0
            for i_lag in range(1, na + 1):
                for j in range(n):
                    acc += theta[t, i, col] * y[s - i_lag, j]
                    col += 1
            for j_lag in range(nb):
                for j in range(m):
                    acc += theta[t, i, col] * u[s - nk - j_lag, j]
                    col += 1
            if constant:
                acc += theta[t, i, col]
            y[s, i] = acc
    return y


class ARXModel(RegressionModel):
    """An identified time-varying (V)ARX model (see :func:`ltvmodels.fit_arx`).

    Model index j = 0 … N − 1 describes y[L + j] (``sample_index``),
    L = max(na, nk + nb − 1). For a scalar output (n = 1) the coefficient
    arrays and predictions drop the output axis.

    Attributes
    ----------
    na, nb, nk : int
        Orders and input delay.
    constant : bool
        Whether the model has a constant term c_t.
    n_inputs : int
        m, the number of inputs.
    theta : ndarray, shape (N, n, p)
        [A_{t,1} … A_{t,na}  B_{t,1} … B_{t,nb}  c_t].

    All attributes of :class:`~ltvmodels.RegressionModel` (``k``, ``cov``,
    ``noise_var``, ``loglik``, ``info``, ``save``, ...) are available.

    Parameters
    ----------
    k : array_like, shape (N, K)
        Parameter vectors k_t = Θ_t.ravel(), K = n·p, p = n·na + m·nb (+ 1).
    n_outputs, n_inputs : int
        n >= 1 and m >= 0.
    na, nb, nk : int
        The orders and the input delay, integers >= 0.
    constant : bool
        Whether Θ_t ends with the constant term c_t.
    fit : FitRecord, optional
        What the estimator computed besides k; default: nothing (given coefficients).
    copy : bool
        False: take a float64 ``k`` as it is (see :class:`~ltvmodels.RegressionModel`).
    """

    def __init__(
        self,
        k: ArrayLike,
        n_outputs: int,
        n_inputs: int,
        na: int,
        nb: int,
        nk: int,
        constant: bool,
        fit: FitRecord | None = None,
        *,
        copy: bool = True,
    ) -> None:
        self.n_inputs = options.integer(n_inputs, "n_inputs", minimum=0)
        self.na, self.nb, self.nk = options.lag_orders(na, nb, nk, min_na=0, min_nb=0)
        self.constant = options.flag(constant, "constant")
        n_outputs = options.integer(n_outputs, "n_outputs", minimum=1)
        p = n_outputs * self.na + self.n_inputs * self.nb + int(self.constant)
        super().__init__(k, n_outputs, p, fit, copy=copy)

    # -- structure --------------------------------------------------------------------
    @property
    def output_names(self) -> list[str]:
        """The data's column names (a pandas y), else "y" for one output, "y0", "y1", …"""
        return self._recorded("output", self.n_outputs) or (
            ["y"] if self.n_outputs == 1 else [f"y{i}" for i in range(self.n_outputs)]
        )

    @property
    def input_names(self) -> list[str]:
        """The data's column names (a pandas u), else "u" for one input, "u0", "u1", …"""
        return self._recorded("input", self.n_inputs) or (
            ["u"] if self.n_inputs == 1 else [f"u{i}" for i in range(self.n_inputs)]
        )

    @property
    def regressor_names(self) -> list[str]:
        """The lagged regressors: "y[t-1]", …, "u[t-nk]", …, "1" (see :func:`ar_regressors`),
        with the signals' names."""
        return lag_regressor_names(
            self.n_outputs,
            self.n_inputs,
            self.na,
            self.nb,
            self.nk,
            self.constant,
            output_names=self.output_names,
            input_names=self.input_names,
        )

    @property
    def step_offset(self) -> int:
        """Model step t describes y[lag + t]: the offset is the lag."""
        return self.lag

    @property
    def lag(self) -> int:
        """L = max(na, nk + nb − 1): the number of initial samples used only as lags."""
        return lag_length(self.na, self.nb, self.nk)

    @property
    def sample_index(self) -> np.ndarray:
        """(N,) the sample t of y[t] that model index j describes: t = L + j."""
        return np.arange(self.lag, self.lag + self.N)

    def _squeeze(self, arr: np.ndarray) -> np.ndarray:
        return arr[:, 0] if self.n_outputs == 1 else arr

    @property
    def a(self) -> np.ndarray:
        """Output-lag coefficients [A_{t,1} … A_{t,na}]: (N, n, n·na), or (N, na) for n = 1.

        ``a[t, i, (l − 1)·n + j]`` multiplies y_j[t − l] in output i.
        """
        return self._squeeze(self.theta[:, :, : self.n_outputs * self.na])

    @property
    def b(self) -> np.ndarray:
        """Input-lag coefficients [B_{t,1} … B_{t,nb}]: (N, n, m·nb), or (N, m·nb) for n = 1.

        ``b[t, i, l·m + j]`` multiplies u_j[t − nk − l] in output i, l = 0 … nb − 1.
        """
        start = self.n_outputs * self.na
        return self._squeeze(self.theta[:, :, start : start + self.n_inputs * self.nb])

    @property
    def c(self) -> np.ndarray | None:
        """Constant term c_t: (N, n), or (N,) for n = 1; None without a constant."""
        if not self.constant:
            return None
        return self._squeeze(self.theta[:, :, -1])

    # -- poles ------------------------------------------------------------------------
    def poles(self) -> np.ndarray:
        """Poles of 1/A_t(z), A_t(z) = I − Σ_i A_{t,i} z^{−i}, over time.

        The eigenvalues of the (n·na × n·na) companion matrix of each A_t
        (the roots of z^na − Σ_i a_{t,i} z^{na−i} for scalar y), computed for
        all t in one batched eigenvalue call.

        Returns
        -------
        ndarray of complex, shape (N, n·na)
            Sorted by angle in (−π, π] at each t.
        """
        n, na, N = self.n_outputs, self.na, self.N
        D = n * na
        if D == 0:
            return np.zeros((N, 0), dtype=complex)
        companion = np.zeros((N, D, D))
        companion[:, :n, :] = self.theta[:, :, :D]
        companion[:, n:, : D - n] = np.eye(D - n)
        poles = np.linalg.eigvals(companion)
        return np.take_along_axis(poles, np.argsort(np.angle(poles), axis=1), axis=1)

    def root_spectrogram(self, fs: float) -> np.ndarray:
        """Frequencies of the poles of 1/A_t(z) over time (a parametric spectrogram).

        One frequency per complex-conjugate pair of poles, f = angle(z)·fs/(2π)
        for the pole z with Im z > 0, sorted increasing at each t. Real poles
        (at 0 or fs/2) are not resonances and give no frequency: slots left
        over when poles are real are NaN (at the end of the row). Poles close
        to the unit circle are sharp spectral peaks; see :meth:`poles` for the
        radii.

        Parameters
        ----------
        fs : float
            Sampling frequency; the result is in its units (Hz for fs in Hz).

        Returns
        -------
        ndarray, shape (N, (n·na) // 2)
            Row j belongs to sample ``sample_index[j]`` (time sample_index[j] / fs).
        """
        fs = options.positive_scalar(fs, "fs")
        poles = self.poles()
        freq = np.where(poles.imag > 0, np.angle(poles) * (fs / (2 * np.pi)), np.nan)
        return np.sort(freq, axis=1)[:, : poles.shape[1] // 2]  # NaNs sort last

    # -- use --------------------------------------------------------------------------
    def predict(self, y: ArrayLike, u: ArrayLike | None = None) -> np.ndarray:
        """One-step predictions ŷ[t] = Θ_t φ_t from measured data, t = L … T − 1.

        Parameters
        ----------
        y : array_like, shape (T, n) or (T,), T = N + L
            Measured outputs (as fitted, or new data of the same length); NaN
            (missing) gives NaN for every prediction that needs that sample.
        u : array_like, shape (T, m) or (T,); None for an AR model.

        Returns
        -------
        ndarray, shape (N, n), or (N,) for n = 1
            Predictions of y[L:].
        """
        y, u = arrays.model_series(y, u, N=self.N, n=self.n_outputs, m=self.n_inputs, lag=self.lag)
        _, phi = lagged_regressors(y, u, self.na, self.nb, self.nk, self.constant)
        return self._squeeze(np.einsum("tij,tj->ti", self.theta, phi))

    def simulate(
        self, y0: ArrayLike, u: ArrayLike | None = None, noise: ArrayLike | None = None
    ) -> np.ndarray:
        """Simulate the model from initial samples: y[t] = Θ_t φ_t + noise[t − L].

        Parameters
        ----------
        y0 : array_like, shape (L, n) or (L,) for n = 1
            The initial samples y[0:L] (None when L = 0).
        u : array_like, shape (T, m) or (T,), T = N + L; None for an AR model.
        noise : array_like, shape (N, n) or (N,) for n = 1, optional
            e[t] added at t = L … T − 1 (e.g. seeded white noise to simulate the
            stochastic process); default zero (the noise-free response).

        Returns
        -------
        ndarray, shape (T, n), or (T,) for n = 1
            y[0:L] = y0, then the simulated samples.
        """
        y0, u, noise = arrays.simulation_inputs(
            y0, u, noise, N=self.N, n=self.n_outputs, m=self.n_inputs, lag=self.lag
        )
        y = np.zeros((self.N + self.lag, self.n_outputs))
        y[: self.lag] = y0
        _simulate_arx(
            np.ascontiguousarray(self.theta),
            y,
            u,
            noise,
            self.na,
            self.nb,
            self.nk,
            self.lag,
            self.constant,
        )
        return y[:, 0] if self.n_outputs == 1 else y

    @property
    def tail_lengths(self) -> tuple[int, int]:
        """(na, nk + nb − 1): a forecast continues from the last na outputs and the last
        inputs its regressors reach at the samples after the data (none without
        inputs); see :class:`~ltvmodels.results.description.DataTail`."""
        return self.na, self._input_memory

    @property
    def _input_memory(self) -> int:
        """The recorded inputs that samples after the data still read: y[T] reads
        u[T−nk−nb+1] … u[T−nk], so the last nk + nb − 1 (none without inputs)."""
        return self.nk + self.nb - 1 if self.n_inputs and self.nb else 0

    def future_input_rows(self, steps: int) -> int:
        """The inputs after the data that ``forecast(steps=steps, u=…)`` reads: steps − nk
        (y[T+j] reads the inputs up to u[T+j−nk]); 0 without inputs."""
        return max(int(steps) - self.nk, 0) if self.n_inputs and self.nb else 0

    def forecast(
        self,
        y_last: ArrayLike | None = None,
        u: ArrayLike | None = None,
        *,
        steps: int | None = None,
        level: float = 0.95,
        n_samples: int = DEFAULT_SAMPLES,
        seed: int | np.random.Generator | None = 0,
        noise_cov: float | ArrayLike | None = None,
    ) -> Forecast:
        """Forecast the outputs after the end of the data, with prediction intervals.

        The AR/ARX counterpart of :meth:`ltvmodels.LTVModel.forecast`: for a
        series of T = N + L samples the model continues
        y[t] = Θ_t φ_t + e[t] for t = T, T+1, …, from the last samples of y
        (L = ``lag``), with the coefficients continued by the penalty's
        difference operator, their uncertainty (the last estimate's posterior
        covariance and, for norm="sq", the drift σ²/λ² per step) and noise
        of covariance ``noise_cov``. The first step is exact and Gaussian,
        the others come from seeded Monte Carlo simulation (exact where the
        coefficients are certain). See :mod:`ltvmodels.results.forecast`.

        Two ways to say where it starts:

        ``forecast(steps=H, u=future)``
            From the end of the data the model was fitted on (it remembers
            the last na outputs and the last nk + nb − 1 inputs:
            ``model.data.tail``); ``u`` holds only the inputs after the data,
            u[T] … u[T+H−1−nk]: H − nk rows (up to H accepted, the rest
            unused).
        ``forecast(y_last, u)``
            From the given last L samples y[T−L] … y[T−1]; ``u`` = u[T−L] …
            u[T+H−1]: L + H rows, the recorded inputs first (the last nk
            unused).

        The first form needs a model that remembers the end of its data: one
        fitted on a single series whose last samples are observed.

        Parameters
        ----------
        y_last : array_like, shape (L, n), or (L,) for n = 1, optional
            The last L samples y[T−L] … y[T−1], oldest first (as ``y0`` of
            :meth:`simulate`). Default: the end of the data the model
            remembers (then ``u`` holds only the inputs after the data).
        u : array_like, shape (rows, m), or (rows,) for m = 1; None for an AR model
            With ``y_last``: the inputs at the samples of ``y_last`` and at
            the forecast samples, u[T−L] … u[T+steps−1], L + steps rows (the
            rows that no regressor reaches, with nk >= 1 the last nk, are
            unused, as in :meth:`simulate`). Without it: only the inputs after
            the data, u[T], u[T+1], … (row j at the forecast sample y[T+j]);
            ``steps − nk`` rows are read (``future_input_rows``), up to
            ``steps`` accepted.
        steps : int, optional
            Number of samples to forecast, >= 1. Required for an AR model;
            with inputs it defaults to ``len(u) − L`` with ``y_last``, to
            ``len(u)`` without (and with ``y_last`` must equal it).
        level : float, default 0.95
            Probability of the central prediction intervals, in (0, 1).
        n_samples : int, default 2000
            Monte Carlo paths (rounded up to an even number: antithetic pairs).
        seed : int, numpy Generator or None, default 0
            Seed of the Monte Carlo draws.
        noise_cov : array_like, shape (n, n), optional
            Covariance of e[t]; default the model's ``noise_cov``.

        Returns
        -------
        Forecast
            ``mean``, ``lower``, ``upper`` of shape (steps, n) and ``cov``
            (steps, n, n) — with the output axis also for n = 1, unlike
            :meth:`predict` — for y[T] … y[T+steps−1] (``time``).

        Raises
        ------
        TypeError, ValueError
            As :meth:`ltvmodels.LTVModel.forecast`: the message names the
            argument; no ``y_last`` for a model that does not remember the
            end of its data.

        Warns
        -----
        DivergenceWarning
            If the forecast overflows to inf or NaN.
        """
        n, m, L = self.n_outputs, self.n_inputs, self.lag
        memory = self._input_memory
        if y_last is None and L > 0:
            tail = remembered_tail(
                self,
                "y_last",
                f"the last {L} samples of y (oldest first), with u starting at their {L} "
                "recorded inputs",
            )
            reach = (
                f"y[T+j] reads the inputs up to u[T+j−{self.nk}]"
                if self.nk
                else "y[T+j] reads u[T+j]"
            )
            future, steps = inputs_after_data(
                u, steps, m=m, needed=self.future_input_rows, reach=reach
            )
            lags = tail.outputs
            inputs = np.concatenate([tail.inputs, future]) if m else np.zeros((steps, 0))
        else:  # with L = 0 nothing before the forecast is needed: both forms are one
            y_last, u, steps = lagged_inputs(y_last, u, steps, n=n, m=m, lag=L)
            lags = y_last[L - self.na :]
            inputs = u[L - memory :]
        level, n_samples, seed = forecast_options(level, n_samples, seed)
        noise = noise_covariance(noise_cov, self.noise_cov, n)
        # φ = [y[t−1]; …; y[t−na]; u[t−nk]; …; u[t−nk−nb+1]; 1]; inputs row memory + s is
        # sample T + s
        columns = (
            [inputs[memory - self.nk - j : memory - self.nk - j + steps] for j in range(self.nb)]
            if m
            else []
        )
        if self.constant:
            columns.append(np.ones((steps, 1)))
        known = np.concatenate(columns, axis=1) if columns else np.zeros((steps, 0))
        initial = lags[::-1]  # the lags y[T−1], …, y[T−na], newest first
        T = self.N + L
        return forecast_model(
            self,
            np.ascontiguousarray(initial),
            known,
            level=level,
            n_samples=n_samples,
            seed=seed,
            noise_cov=noise,
            time=self.times_after(T, steps),
            names=self.output_names,
        )

    # A different plot from the regression's (the roots, not the coefficients): its own
    # arguments.
    def plot(  # type: ignore[override]
        self, fs: float | None = None, ax: Any = None, *, fig: Any = None
    ):
        """Plot the root spectrogram against the data's time axis; see
        :func:`ltvmodels.plotting.plot_root_spectrogram` (``fs`` None: frequencies in
        cycles per unit of the model's time axis, or per sample).

        Returns the Figure (as every result's ``plot``): ``fig`` (cleared, one axes)
        when given, the figure of ``ax`` when given, else a new one.
        """
        from ..plotting import plot_root_spectrogram
        from ..plotting.figure import axes_in

        return plot_root_spectrogram(self, fs, ax=axes_in(fig, ax)).figure

    # -- persistence and display ------------------------------------------------------
    def structure(self) -> dict:
        return {
            "n_outputs": self.n_outputs,
            "n_inputs": self.n_inputs,
            "na": self.na,
            "nb": self.nb,
            "nk": self.nk,
            "constant": self.constant,
        }

    @classmethod
    def from_structure(cls, k: np.ndarray, structure: dict, fit: FitRecord) -> ARXModel:
        s = structure
        return cls(k, s["n_outputs"], s["n_inputs"], s["na"], s["nb"], s["nk"], s["constant"], fit)

    def _repr_sizes(self) -> str:
        return (
            f"n_outputs={self.n_outputs}, n_inputs={self.n_inputs}, na={self.na}, "
            f"nb={self.nb}, nk={self.nk}, constant={self.constant}"
        )

    def _kind_text(self) -> str:
        constant = ", with a constant c_t" if self.constant else ""
        return f"ARX, na = {self.na}, nb = {self.nb}, nk = {self.nk}{constant}"

    def _signal_names(self) -> dict[str, list[str]]:
        return {"outputs": self.output_names, "inputs": self.input_names}


class ARModel(ARXModel):
    """An identified time-varying (V)AR model: an :class:`ARXModel` without inputs.

    ``predict(y)``, ``simulate(y0, noise=None)`` and ``root_spectrogram(fs)``
    → (N, (n·na) // 2) are those of :class:`ARXModel`; ``b`` is empty.
    """

    def __init__(
        self,
        k: ArrayLike,
        n_outputs: int,
        na: int,
        constant: bool,
        fit: FitRecord | None = None,
        *,
        copy: bool = True,
    ) -> None:
        super().__init__(k, n_outputs, 0, na, 0, 1, constant, fit, copy=copy)

    # An AR model has no inputs: its predict, simulate and forecast leave u out.
    def predict(self, y: ArrayLike) -> np.ndarray:  # type: ignore[override]
        """One-step predictions ŷ[t] = Σ_i A_{t,i} y[t−i] (+ c_t), t = na … T − 1.

        Parameters
        ----------
        y : array_like, shape (T, n) or (T,), T = N + na

        Returns
        -------
        ndarray, shape (N, n), or (N,) for n = 1
        """
        return super().predict(y, None)

    def simulate(self, y0: ArrayLike, noise: ArrayLike | None = None) -> np.ndarray:  # type: ignore[override]
        """Simulate y[t] = Σ_i A_{t,i} y[t−i] (+ c_t) + noise[t − na] from y[0:na] = y0.

        Parameters
        ----------
        y0 : array_like, shape (na, n) or (na,) for n = 1
        noise : array_like, shape (N, n) or (N,) for n = 1, optional
            Default zero (the free response).

        Returns
        -------
        ndarray, shape (N + na, n), or (N + na,) for n = 1
        """
        return super().simulate(y0, None, noise)

    def forecast(  # type: ignore[override]
        self,
        y_last: ArrayLike | None = None,
        *,
        steps: int,
        level: float = 0.95,
        n_samples: int = DEFAULT_SAMPLES,
        seed: int | np.random.Generator | None = 0,
        noise_cov: float | ArrayLike | None = None,
    ) -> Forecast:
        """Forecast y[T] … y[T+steps−1] from the last na samples y_last (na, n) or (na,),
        or (``y_last`` None) from the end of the data the model remembers.

        :meth:`ARXModel.forecast` without inputs; ``steps`` is required.
        """
        return super().forecast(
            y_last,
            None,
            steps=steps,
            level=level,
            n_samples=n_samples,
            seed=seed,
            noise_cov=noise_cov,
        )

    def structure(self) -> dict:
        return {"n_outputs": self.n_outputs, "na": self.na, "constant": self.constant}

    @classmethod
    def from_structure(cls, k: np.ndarray, structure: dict, fit: FitRecord) -> ARModel:
        s = structure
        return cls(k, s["n_outputs"], s["na"], s["constant"], fit)

    def _repr_sizes(self) -> str:
        return f"n_outputs={self.n_outputs}, na={self.na}, constant={self.constant}"

    def _kind_text(self) -> str:
        return f"AR, na = {self.na}" + (", with a constant c_t" if self.constant else "")

    def _signal_names(self) -> dict[str, list[str]]:
        return {"outputs": self.output_names}
