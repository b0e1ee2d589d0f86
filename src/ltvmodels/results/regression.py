"""The general result: an identified time-varying regression y_t = Θ_t φ_t + e_t.

:class:`RegressionModel` is the result of :func:`ltvmodels.fit_regression` and
the base class of the state-space model (:mod:`.statespace`) and the AR/ARX
models (:mod:`.arx`).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from ..core.problem import activation, row_norms
from ..validation import arrays, options
from ..validation.arrays import describe
from ..validation.time import continued
from . import archive
from .description import DataDescription
from .model_summary import model_summary, order_text
from .record import FitRecord
from .summary import Summary

__all__ = ["RegressionModel"]

ModelT = TypeVar("ModelT", bound="RegressionModel")


class RegressionModel:
    """An identified time-varying regression y_t = Θ_t φ_t + e_t.

    The general result of :func:`ltvmodels.fit_regression`, and the base class
    of :class:`~ltvmodels.LTVModel` (φ_t = [x_t; u_t]) and the AR/ARX models
    (:class:`~ltvmodels.ARXModel`). Model index t = 0 … N − 1 is row t of the
    regression.
    The parameter vector is ``k[t] = theta[t].ravel()`` (rows of Θ_t
    concatenated).

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Parameter vectors, K = n·p.
    theta : ndarray, shape (N, n, p)
        Coefficient matrices Θ_t.
    cov : ndarray or None
        Posterior covariance of k_t: shape (N, p, p) when the output rows are
        independent with a shared covariance (then Cov(k_t) = I_n ⊗ cov[t]);
        (N, n, p, p) when they are independent with covariances of their own
        (cov[t, i] is that of row i of Θ_t, e.g. with a noise variance per
        output); (N, K, K) when the rows are correlated. None if not computed.
        :meth:`cov_full` always returns (N, K, K) (O(N K²) memory); :meth:`std`
        (N, K).
    noise_var : ndarray, shape (n,), or None
        Noise variance σ_i² of each output (estimated or given; equal entries
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
    states, states_std, measurement_noise, sample_outliers : ndarray or None
        Of a state-space fit with measurement noise (see :class:`~ltvmodels.LTVModel`);
        None otherwise.
    info : dict
        Solver details: objective, solver name, factorizations, and so on.
    status : FitStatus or None
        How the coefficients were computed and whether that met its tolerance
        (None for coefficients given to the constructor).
    data : DataDescription
        What the data said: the names of its signals, its time axis, the
        trajectories and the rows left out (:attr:`n_missing`); empty for
        coefficients given to the constructor. :meth:`with_data` gives a
        model with another description.

    Parameters
    ----------
    k : array_like, shape (N, K)
        Parameter vectors k_t = Θ_t.ravel(), K = n·p.
    n_outputs, n_regressors : int
        n and p.
    fit : FitRecord, optional
        What the estimator computed besides k (penalty, λ, covariances,
        noise, likelihood, status, ``info``); default: nothing (given
        coefficients).
    copy : bool
        False: a float64 numpy ``k`` is taken as it is, not copied (an
        estimator's own result, which nothing else holds: at T = 1e6 the copy
        was a third of a fit's memory); it must not be changed afterwards.
        Default True: the model keeps a copy.
    """

    def __init__(
        self,
        k: ArrayLike,
        n_outputs: int,
        n_regressors: int,
        fit: FitRecord | None = None,
        *,
        copy: bool = True,
    ) -> None:
        copy = options.flag(copy, "copy")
        if not copy and type(k) is np.ndarray and k.dtype == np.float64 and np.isfinite(k).all():
            self._k = k
        else:
            self._k = arrays.as_float_array(k, "k")  # a finite float64 copy
        self._n_outputs = options.integer(n_outputs, "n_outputs", minimum=1)
        self._n_regressors = options.integer(n_regressors, "n_regressors", minimum=1)
        if self._k.ndim != 2 or self._k.shape[1] != self._n_outputs * self._n_regressors:
            raise ValueError(
                f"k: expected shape (N, {self._n_outputs * self._n_regressors}) for "
                f"{self._n_outputs} outputs and {self._n_regressors} regressors, received "
                f"{self._k.shape}"
            )
        if self._k.shape[0] == 0:
            raise ValueError(f"k: expected at least one time step, received shape {self._k.shape}")
        fit = FitRecord() if fit is None else fit
        self.norm = fit.norm
        self.coeffs = None if fit.coeffs is None else np.asarray(fit.coeffs, dtype=float)
        self.lam = fit.lam
        self._cov = fit.cov
        n = self._n_outputs
        noise_var = None if fit.noise_var is None else np.asarray(fit.noise_var, dtype=float)
        if noise_var is not None:  # (n,) as given, or a shared variance repeated
            noise_var = (
                noise_var.copy()
                if noise_var.shape == (n,)
                else np.broadcast_to(noise_var, (n,)).copy()
            )
        self.noise_var = noise_var
        self.noise_cov = fit.noise_cov
        # NaN: files written before None marked a missing likelihood
        self.loglik = None if fit.loglik is None or np.isnan(fit.loglik) else float(fit.loglik)
        self.info = dict(fit.info)
        self._changepoints = fit.changepoints
        self.status = fit.status
        self.data = DataDescription() if fit.data is None else fit.data
        self.states = fit.states
        self.states_std = fit.states_std
        self.measurement_noise = fit.measurement_noise
        self.sample_outliers = fit.sample_outliers

    @property
    def record(self) -> FitRecord:
        """What the fit computed besides k, as one :class:`FitRecord` (for copies and files)."""
        return FitRecord(
            norm=self.norm,
            coeffs=self.coeffs,
            lam=self.lam,
            cov=self._cov,
            noise_var=self.noise_var,
            noise_cov=self.noise_cov,
            loglik=self.loglik,
            info=self.info,
            changepoints=self._changepoints,
            status=self.status,
            data=self.data,
            states=self.states,
            states_std=self.states_std,
            measurement_noise=self.measurement_noise,
            sample_outliers=self.sample_outliers,
        )

    def with_data(self: ModelT, data: DataDescription) -> ModelT:
        """This model with another description of its data (:attr:`data`); a new model
        sharing the coefficients' arrays (this one is unchanged)."""
        if not isinstance(data, DataDescription):
            raise TypeError(f"data: expected a DataDescription, received {describe(data)}")
        described = copy.copy(self)
        described.info = dict(self.info)
        described.data = data
        return described

    # -- shapes -------------------------------------------------------------------
    @property
    def N(self) -> int:
        """Number of model time steps (regression rows)."""
        return self._k.shape[0]

    @property
    def K(self) -> int:
        return self._k.shape[1]

    @property
    def n_outputs(self) -> int:
        """n, the number of outputs (rows of Θ_t)."""
        return self._n_outputs

    @property
    def n_regressors(self) -> int:
        """p, the number of regressors (columns of Θ_t)."""
        return self._n_regressors

    @property
    def k(self) -> np.ndarray:
        """(N, K) parameter vectors (read-only view)."""
        view = self._k.view()
        view.flags.writeable = False
        return view

    @property
    def theta(self) -> np.ndarray:
        """(N, n, p) coefficient matrices Θ_t (read-only view)."""
        return self.k.reshape(self.N, self.n_outputs, self.n_regressors)

    @property
    def order(self) -> np.ndarray | None:
        """Difference-operator coefficients c_0 … c_d of the penalty."""
        return self.coeffs

    # -- uncertainty --------------------------------------------------------------
    @property
    def cov(self) -> np.ndarray | None:
        """Posterior covariance of k_t: (N, p, p) if shared by the output rows, (N, n, p, p)
        if the rows are independent, else (N, K, K) (see the class docstring)."""
        if self._cov is None:
            return None
        c = self._cov
        if c.shared:
            return c.blocks[0] if c.row_scale is None else c.blocks[0] * c.row_scale[0]
        if c.row_group is not None:
            return c.rows(self.n_outputs)
        return self.cov_full()

    @property
    def outliers(self) -> np.ndarray | None:
        """Residual entries the fit judges outliers: beyond 3 robust scales of their output.

        Entry (t, i) is an outlier when abs(r_ti) > c · σ̂_i, with r = √w (y − Θφ) the
        residuals of the (weighted) fit, σ̂_i = 1.4826 · median abs(r_ti) over the
        observed entries of output i (about zero, not about the median: the
        model's noise has mean zero; entries the fit reproduces to 1e-8 of the
        largest abs(y_i) are left out of the median and never flagged) and c = 3
        (``info["outlier_threshold"]``; σ̂ is ``info["outlier_scale"]``). c is the
        two-sided 1 % Gaussian point 2.576 with a margin for the MAD's own
        error: measured on clean Gaussian data about 0.3 % of the entries are
        flagged, and more than 95 % of +5σ outliers in the outputs, with the
        squared, Huber and Laplace losses. Defined for every fit (any loss,
        norm, front-end), from the residuals at the fit (with
        ``measurement_noise``: the state equation's residuals at the smoothed
        states); None for given coefficients and for files written before it
        existed.

        Boolean, shape (N, n) — (R, N, n) for R trajectories — over model time
        steps and outputs; missing rows are False. Huber's linear region is
        :attr:`beyond_delta`.
        """
        return _row_mask(self.info.get("outliers") if "outlier_scale" in self.info else None)

    @property
    def beyond_delta(self) -> np.ndarray | None:
        """Residual entries in Huber's linear region, abs(r) > δ (``loss="huber"`` fits; else
        None): those whose pull on the fit the loss caps, not outliers (on Gaussian
        noise and the default δ = 1.345 σ̂ about 18 % of them; outliers are
        :attr:`outliers`). Shape as :attr:`outliers`."""
        if "beyond_delta" in self.info:
            return _row_mask(self.info["beyond_delta"])
        # files written before "outlier_scale" kept this mask as "outliers"
        return None if "outlier_scale" in self.info else _row_mask(self.info.get("outliers"))

    @property
    def cov_shared_by_rows(self) -> bool:
        """True when :attr:`cov` is the compact (N, p, p) form."""
        c = self._cov
        return c is not None and c.shared

    def cov_full(self) -> np.ndarray | None:
        """Posterior covariance of k_t as an (N, K, K) array (O(N K²) memory)."""
        if self._cov is None:
            return None
        return self._cov.full(self.n_outputs, self.n_regressors)

    def std(self) -> np.ndarray | None:
        """(N, K) posterior standard deviations of the entries of k_t."""
        c = self._cov
        if c is None:
            return None
        if c.row_group is None:
            var = np.diagonal(c.blocks, axis1=1, axis2=2)
        else:
            per_group = np.diagonal(c.blocks, axis1=2, axis2=3)  # (G, N, p)
            scales = c.scales(self.n_outputs)
            var = np.concatenate(
                [scales[i] * per_group[g] for i, g in enumerate(c.row_group)], axis=1
            )
        return np.sqrt(np.maximum(var, 0.0))

    # -- names, time and export ------------------------------------------------------
    @property
    def time(self) -> np.ndarray | None:
        """The time index of the data (a pandas index: dates as datetime64[ns], numbers,
        or time spans — a TimedeltaIndex, a timedelta ``time`` column of
        :func:`~ltvmodels.fit_many` — as float seconds), or None; for a state-space model
        one value per sample x[t], (N + 1,)."""
        value = self.data.time
        return None if value is None else np.array(value)

    def times_after(self, first: int, steps: int) -> np.ndarray:
        """Times of the samples ``first`` … ``first + steps − 1`` of the data's time axis.

        Sample indices without a time index; beyond the data, the time index
        continued on its regular grid (its step, or its calendar frequency:
        the months after a monthly series), else the sample indices as well.
        """
        index = np.arange(first, first + steps)
        time = self.time
        if time is None:
            return index
        known = index < time.size
        if known.all():
            return time[index]
        after = continued(time, int(index[-1]) - time.size + 1)
        if after is None:
            return index
        return np.concatenate([time, after])[index]

    @property
    def step_times(self) -> np.ndarray | None:
        """The time of each model step t, (N,): of its row (a regression), of x[t] (a
        state-space model), of y[lag + t] (AR/ARX); None without a time index."""
        time = self.time
        return None if time is None else time[self.step_offset : self.step_offset + self.N]

    @property
    def step_offset(self) -> int:
        """The sample of the data's time axis that model step 0 describes (0; AR/ARX: lag)."""
        return 0

    @property
    def produced_offset(self) -> int:
        """The sample of the data's time axis that model step t produces is t +
        ``produced_offset``: row t of a regression, y[lag + t] of an AR/ARX model (both
        :attr:`step_offset`), x[t + 1] of a state-space model."""
        return self.step_offset

    @property
    def changepoint_times(self) -> np.ndarray | None:
        """The times of the change points: the time of the first observation produced
        under the new coefficients. For change point c (the first step whose
        coefficients differ) that is y[c] of a regression, y[lag + c] of an AR/ARX
        model and x[c + 1] of a state-space model (the first state the new A_c, B_c
        map to); None without a time index or change points."""
        time, changepoints = self.time, self.changepoints
        if time is None or changepoints is None:
            return None
        return time[np.asarray(changepoints, dtype=int) + self.produced_offset]

    @property
    def output_names(self) -> list[str]:
        """Names of the n outputs (rows of Θ_t): the data's column names (a pandas y),
        else "y0", "y1", …"""
        return self._recorded("output", self.n_outputs) or [f"y{i}" for i in range(self.n_outputs)]

    @property
    def regressor_names(self) -> list[str]:
        """Names of the p regressors (columns of Θ_t): the data's column names (a pandas
        phi), else "phi0", "phi1", …"""
        return self._recorded("regressor", self.n_regressors) or [
            f"phi{j}" for j in range(self.n_regressors)
        ]

    def _recorded(self, key: str, count: int) -> list[str] | None:
        """The data's names of ``key`` (:attr:`data`) when they name ``count`` signals."""
        return self.data.names_of(key, count)

    @property
    def n_missing(self) -> int:
        """Rows of the data term left out for missing values (``data.n_missing``)."""
        return self.data.n_missing

    def coefficient_names(self) -> list[str]:
        """Names of the K entries of k_t, "output:regressor" in k's order (rows of Θ_t)."""
        return [f"{out}:{reg}" for out in self.output_names for reg in self.regressor_names]

    def to_frame(self, *, std: bool = False) -> Any:
        """The coefficients as a pandas DataFrame, one row per model time step.

        Column "output:regressor" holds Θ_t[output, regressor] (for a state-space
        model "x0:u0" is B_t[x0, u0]); the index is the model time step t,
        named "t", or, with a time index, the time of step t
        (:attr:`step_times`), named "time". Needs pandas (``pip install pandas``).

        Parameters
        ----------
        std : bool, default False
            Also the posterior standard deviations, in columns "output:regressor std"
            (after all the coefficients); only for models with a covariance.

        Returns
        -------
        pandas.DataFrame
            Shape (N, K) or (N, 2K).

        Raises
        ------
        ImportError
            pandas is not installed.
        ValueError
            ``std=True`` for a model without a covariance (e.g. norm="group").
        """
        try:
            import pandas as pd
        except ImportError:  # pragma: no cover - pandas is installed wherever tests run
            raise ImportError("to_frame needs pandas: pip install pandas") from None
        if not isinstance(std, bool):
            raise TypeError(f"std: expected True or False, received {std!r}")
        names = self.coefficient_names()
        times = self.step_times
        index = pd.RangeIndex(self.N, name="t") if times is None else pd.Index(times, name="time")
        frame = pd.DataFrame(np.array(self.k), columns=names, index=index)
        if std:
            deviations = self.std()
            if deviations is None:
                raise ValueError(
                    f"std: this model (norm={self.norm!r}) has no covariance; use std=False"
                )
            frame = pd.concat(
                [
                    frame,
                    pd.DataFrame(
                        deviations, columns=[f"{name} std" for name in names], index=frame.index
                    ),
                ],
                axis=1,
            )
        return frame

    def plot(
        self,
        truth: Any = None,
        *,
        bands: bool = True,
        changepoints: ArrayLike | None = None,
        fig: Any = None,
    ):
        """Plot the coefficients Θ_t (of a state-space model: [A_t B_t]) against the data's
        time axis, with ±2σ bands and the change points
        (:func:`ltvmodels.plotting.plot_coefficients`); returns the Figure."""
        from ..plotting import plot_coefficients

        return plot_coefficients(self, truth, bands=bands, changepoints=changepoints, fig=fig)

    # -- use ----------------------------------------------------------------------
    def predict(self, phi: ArrayLike) -> np.ndarray:
        """Predictions ŷ_t = Θ_t φ_t of the regression.

        Parameters
        ----------
        phi : array_like, shape (N, p), or (N,) when p = 1
            Regressors, one row per model time step.

        Returns
        -------
        ndarray, shape (N, n)
        """
        phi = arrays.regressor_rows(phi, self.N, self.n_regressors)
        return np.einsum("tij,tj->ti", self.theta, phi)

    def activation(self) -> np.ndarray:
        """‖(Dk)_t‖₂ for t = 0 … N − d − 1: how much the model changes (paper III-G).

        Uses the model's difference operator (first difference for LTI models).
        """
        coeffs = self.coeffs if self.coeffs is not None else np.array([-1.0, 1.0])
        return activation(self._k, coeffs)

    @property
    def changepoints(self) -> np.ndarray:
        """Indices c with k_c ≠ k_{c−1} (relative change above 1e-8 of the scale of k)."""
        if self._changepoints is not None:
            return self._changepoints
        step = row_norms(np.diff(self._k, axis=0))
        scale = max(float(np.abs(self._k).max(initial=0.0)), 1e-300)
        return np.flatnonzero(step > 1e-8 * scale) + 1

    # -- persistence --------------------------------------------------------------
    def structure(self) -> dict:
        """The sizes that, with k, rebuild the model (JSON-serializable; see :meth:`save`)."""
        return {"n_outputs": self.n_outputs, "n_regressors": self.n_regressors}

    @classmethod
    def from_structure(cls, k: np.ndarray, structure: dict, fit: FitRecord) -> RegressionModel:
        """The model with coefficients k, the sizes of :meth:`structure` and ``fit``."""
        return cls(k, structure["n_outputs"], structure["n_regressors"], fit)

    def save(self, path: str | Path) -> None:
        """Save to a NumPy ``.npz`` archive (lossless; :func:`ltvmodels.load` reads it)."""
        archive.write(self, path)

    # -- display ------------------------------------------------------------------
    def _repr_sizes(self) -> str:
        return f"n_outputs={self.n_outputs}, n_regressors={self.n_regressors}"

    def __repr__(self) -> str:
        lam = self.lam
        first = self.info.get("first_step")
        if isinstance(first, dict) and isinstance(first.get("lam"), (int, float)):
            # a refined fit: the λ of its first step, which chose the change points
            lam_text = f"{float(first['lam']):g} ({first.get('norm')}, then refined)"
        elif lam is None:
            lam_text = "None"
        else:
            lam_text = f"{float(lam):g}" if np.ndim(lam) == 0 else f"array{np.shape(lam)}"
        order = "-" if self.coeffs is None else order_text(self.coeffs)
        return (
            f"{type(self).__name__}(N={self.N}, {self._repr_sizes()}, "
            f"norm={self.norm!r}, order={order}, lam={lam_text}, "
            f"noise_var={_values_text(self.noise_var)}, loglik={_number_text(self.loglik)})"
        )

    def summary(self) -> Summary:
        """A report of the data, the penalty and λ, the fit, the noise, the criteria, the
        change points and the coefficients (see :mod:`ltvmodels.results.model_summary`).

        Returns
        -------
        Summary
            The text report, a ``str`` (``print`` it; its first line is the repr),
            with :meth:`~ltvmodels.results.summary.Summary.as_html` for notebooks.
        """
        return model_summary(self, kind=self._kind_text(), signals=self._signal_names())

    def _repr_html_(self) -> str:
        """What a notebook shows: the summary's HTML tables."""
        return self.summary().as_html()

    def _kind_text(self) -> str:
        """What kind of model this is, in words (the summary's "kind")."""
        return "regression y_t = Θ_t φ_t + e_t"

    def _signal_names(self) -> dict[str, list[str]]:
        """The signals' names by role, as the summary lists them."""
        return {"outputs": self.output_names, "regressors": self.regressor_names}


def _number_text(value: float | None) -> str:
    return "None" if value is None else f"{value:.6g}"


def _values_text(values: np.ndarray | None) -> str:
    """One number when all are equal, else the list (at 4 significant digits)."""
    if values is None:
        return "None"
    if values.size and np.all(values == values[0]):
        return f"{values[0]:.4g}"
    return "[" + ", ".join(f"{v:.4g}" for v in values) + "]"


def _row_mask(mask: Any) -> np.ndarray | None:
    """A (N, q, n) mask of residual entries as the models return it: (N, n), or (R, N, n)."""
    if mask is None:
        return None
    mask = np.asarray(mask, dtype=bool)
    return mask[:, 0, :] if mask.shape[1] == 1 else np.swapaxes(mask, 0, 1)
