"""Forecasts with prediction intervals: the states (outputs) after the end of the data.

:meth:`ltvmodels.LTVModel.forecast` and :meth:`ltvmodels.ARXModel.forecast`
return a :class:`Forecast`. Both models are the regression y_t = Θ_t φ_t + e_t
whose regressor φ_t holds past outputs (x_t for the state-space model, the
lags y[t−1] … y[t−na] for AR/ARX models) and known values (inputs, the
constant 1), so one propagation serves both (:func:`forecast_model`).

The model of the forecast
-------------------------
*Coefficients.* After the last estimate k_{N−1} the coefficients continue as
the penalty's model says: the difference operator c_0 … c_d of the fit
(``model.coeffs``; the first difference when there is none) defines the
recursion Σ_j c_j k_{t+j} = w_t. The mean path solves it with w = 0: order 1
stays at k_{N−1} (a random walk), order 2 continues the straight line through
k_{N−2}, k_{N−1}, any polynomial its own recursion (piecewise-constant and
segment models, coeffs [−1, 1], stay constant).

*Coefficient uncertainty* has two parts:

1. the posterior covariance of k_{N−1} (``model.cov`` at the last step); for
   norm="group"/"l1" (no posterior covariance) the least-squares covariance
   of the last segment's coefficients (order 1; none for robust losses). For
   order >= 2 the fit keeps the covariance of each k_t, not the joint one of
   the last d estimates, so the uncertainty of the estimated trend is not
   included: the error of k_{N−1} is carried forward unchanged (as if the
   last d estimates erred together). Intervals of order >= 2 models are
   therefore somewhat narrow at long horizons; for order 1 they are exact.
2. the drift w_t of the penalty's probabilistic model, norm="sq" only: the
   fit is the posterior mode of the model with noise σ_i² in equation i and
   (Dk)_t ~ N(0, σ_i² W⁻¹) in its row, W the penalty weight (λ² I for a
   scalar λ, diag(λ_j²) for a vector, Λ for a matrix; see
   :func:`ltvmodels.fit`). Each forecast step adds w_t / c_d through the
   recursion (order 1: k_{t+1} = k_t + w_t). The sparse norms, segmentations
   and piecewise fits have no probabilistic model of the changes: their
   forecasts hold no drift (the coefficients are taken to stay as they are),
   only the estimate's covariance where there is one.

*Noise.* Each step adds process noise v_t ~ N(0, ``noise_cov``).

Propagation
-----------
The first step is exact and Gaussian: with φ = [x0; u0 (; 1)] known,

    mean = Θ̄_N φ,   cov = (I_n ⊗ φᵀ) Cov(k_N) (I_n ⊗ φ) + noise_cov,

Cov(k_N) = Cov(k_{N−1}) + σ² W⁻¹ / c_d². Beyond it the state multiplies
uncertain coefficients, so the forecast is not Gaussian and its moments do not
close; it is computed by seeded Monte Carlo: ``n_samples`` coefficient paths
(the recursion above driven by Gaussian drift from a Gaussian k_{N−1}) and
noise sequences, drawn in antithetic pairs (each draw and its negative, so that
the sample mean is exact wherever the forecast is linear in the draws),
simulated through the model. ``mean`` and ``cov`` are the sample mean and
covariance, ``lower``/``upper`` the empirical quantiles (1 ∓ level)/2 of each
state (they capture the heavier tails that coefficient uncertainty gives). A
model without coefficient uncertainty (no covariance and no drift) is linear
and Gaussian: then every step is propagated exactly (mean and covariance by
the model's recursion, intervals mean ± z·sd) and nothing is sampled.
``Forecast.method`` says which was done.

The paths are simulated one step at a time and each step is summarized (mean,
covariance, quantiles) before the next, so the memory of a forecast grows
with ``n_samples`` (the paths of one step: n_samples × K numbers for the
coefficients) but not with ``steps`` × ``n_samples``; its result holds
O(steps · n · p) numbers. A forecast whose mean or interval overflows to inf
or NaN (an unstable model over a long horizon) warns with a
:class:`~ltvmodels.DivergenceWarning`, as ``simulate`` does.

Where a forecast starts
-----------------------
Both models forecast in two ways:

* from the end of their data, which a fitted model remembers
  (``model.data.tail``, a :class:`~ltvmodels.results.description.DataTail`):
  ``model.forecast(steps=H, u=future)``, where ``future`` holds only the
  inputs after the data, u[T], u[T+1], … (row j at the forecast sample T + j;
  see :func:`inputs_after_data` for how many rows H steps need);
* from a given start: ``model.forecast(x0, u)`` (a state-space model: x0 =
  x[T−1], u[0] = the last recorded input u[T−1]) or ``model.forecast(y_last,
  u)`` (AR/ARX: the last L samples and their inputs first).

The command line's ``forecast`` continues its DATA through the first way (the
end of DATA given to the model as the end of its data), so the two agree.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from statistics import NormalDist
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import DivergenceWarning, warn
from ..validation import arrays, options
from ..validation.arrays import describe
from .description import DataTail

__all__ = [
    "DEFAULT_SAMPLES",
    "Forecast",
    "forecast_options",
    "noise_covariance",
    "state_space_inputs",
    "lagged_inputs",
    "remembered_tail",
    "inputs_after_data",
    "forecast_model",
]

DEFAULT_SAMPLES = 2000
"""Default Monte Carlo sample count: the 95 % bounds' coverage error is about ±0.5 %
(the binomial error sqrt(0.025·0.975/2000) of each tail quantile)."""

METHODS = ("gaussian", "monte_carlo")
"""Values of :attr:`Forecast.method`."""


@dataclass(frozen=True, eq=False)
class Forecast:
    """A forecast of a model's states (outputs) after the end of the data.

    Returned by :meth:`ltvmodels.LTVModel.forecast` and
    :meth:`ltvmodels.ARXModel.forecast` (see :mod:`ltvmodels.results.forecast`
    for the model of the forecast and how it is propagated). Arrays are
    read-only.

    Attributes
    ----------
    mean : ndarray, shape (steps, n)
        Mean of the forecast; row j is the state (output) at ``time[j]``.
    lower, upper : ndarray, shape (steps, n)
        Bounds of the central prediction interval of probability ``level``
        of each state: mean ± z·sd where the forecast is Gaussian (the first
        step, and every step of ``method="gaussian"``), the empirical
        (1 ∓ level)/2 quantiles of the Monte Carlo samples elsewhere.
    cov : ndarray, shape (steps, n, n)
        Covariance of the forecast (exact, or the Monte Carlo sample covariance).
    level : float
        Probability of the intervals, in (0, 1).
    time : ndarray, shape (steps,)
        Sample index of each row in the data's time axis: the first forecast
        is the sample right after the data (x[T] for T recorded states, y[T]
        for an AR/ARX series of T samples). For a model with a regular time
        index (``model.time``, e.g. daily dates) the times continue it instead.
    names : list of str
        Names of the n states (``model.state_names``) or outputs ("y0", …).
    method : {"gaussian", "monte_carlo"}
        "gaussian": exact propagation of a model without coefficient
        uncertainty; "monte_carlo": the first step exact, the others from
        ``n_samples`` simulated paths.
    n_samples : int or None
        Number of Monte Carlo paths (None for "gaussian").
    coefficients : ndarray, shape (steps, n, p)
        The continued mean coefficients Θ̄_t used at each step (for an
        LTVModel [A_t B_t (c_t)]).
    time_name : str or None
        The name of the model's time axis (``model.data.time_name``; figures
        label their time axis with it), None where it had none.
    """

    mean: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    cov: np.ndarray
    level: float
    time: np.ndarray
    names: list[str]
    method: str
    n_samples: int | None = None
    coefficients: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 0)))
    time_name: str | None = None

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method: expected one of {METHODS}, received {self.method!r}")
        object.__setattr__(self, "level", options.interval_level(self.level, "level"))
        for name in ("mean", "lower", "upper", "cov", "coefficients"):
            value = np.array(getattr(self, name), dtype=float)  # a copy: the caller's stays theirs
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        time = np.array(self.time)
        time.flags.writeable = False
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "names", [str(name) for name in self.names])
        self._check_shapes()
        if self.method == "gaussian" and self.n_samples is not None:
            raise ValueError(
                f"n_samples: expected None for method='gaussian' (nothing is sampled), "
                f"received {self.n_samples!r}"
            )
        if self.method == "monte_carlo":
            object.__setattr__(
                self, "n_samples", options.integer(self.n_samples, "n_samples", minimum=2)
            )

    def _check_shapes(self) -> None:
        """Every array fits ``mean`` (steps, n); the message names the field that does not."""
        if self.mean.ndim != 2 or self.mean.shape[0] < 1:
            raise ValueError(
                f"mean: expected shape (steps, n) with steps >= 1, received shape {self.mean.shape}"
            )
        steps, n = self.mean.shape
        expected = {
            "lower": (steps, n),
            "upper": (steps, n),
            "cov": (steps, n, n),
            "time": (steps,),
        }
        for name, shape in expected.items():
            found = getattr(self, name).shape
            if found != shape:
                raise ValueError(
                    f"{name}: expected shape {shape} to fit mean {self.mean.shape}, "
                    f"received shape {found}"
                )
        if len(self.names) != n:
            raise ValueError(
                f"names: expected {n} names (one per column of mean), received {len(self.names)}"
            )
        coefficients = self.coefficients.shape
        if self.coefficients.size and (len(coefficients) != 3 or coefficients[:2] != (steps, n)):
            raise ValueError(
                f"coefficients: expected shape ({steps}, {n}, p) to fit mean {self.mean.shape}, "
                f"or an empty array, received shape {coefficients}"
            )

    @property
    def steps(self) -> int:
        """Number of forecast steps."""
        return self.mean.shape[0]

    def std(self) -> np.ndarray:
        """(steps, n) standard deviations of the forecast (square roots of diag ``cov``)."""
        return np.sqrt(np.maximum(np.diagonal(self.cov, axis1=1, axis2=2), 0.0))

    def to_frame(self) -> Any:
        """The forecast as a pandas DataFrame, one row per step.

        Columns "name" (the mean), "name lower" and "name upper" (the bounds of
        the ``level`` interval) for each state or output, in that order; the
        index is :attr:`time`, named "time" (or "t" for sample indices). Needs
        pandas (``pip install pandas``).

        Returns
        -------
        pandas.DataFrame
            Shape (steps, 3n).
        """
        try:
            import pandas as pd
        except ImportError:  # pragma: no cover - pandas is installed wherever tests run
            raise ImportError("to_frame needs pandas: pip install pandas") from None
        columns = {}
        for j, name in enumerate(self.names):
            columns[name] = self.mean[:, j]
            columns[f"{name} lower"] = self.lower[:, j]
            columns[f"{name} upper"] = self.upper[:, j]
        indices = np.issubdtype(self.time.dtype, np.integer)
        return pd.DataFrame(columns, index=pd.Index(self.time, name="t" if indices else "time"))

    def plot(
        self,
        history: ArrayLike | None = None,
        *,
        history_time: ArrayLike | None = None,
        fig: Any = None,
    ):
        """Plot the mean and the interval of each state, one subplot per state, at
        :attr:`time` (after ``history`` at ``history_time``, on the same axis).

        See :func:`ltvmodels.plotting.plot_forecast`; returns the Figure.
        """
        from ..plotting import plot_forecast

        return plot_forecast(self, history=history, history_time=history_time, fig=fig)

    def __repr__(self) -> str:
        samples = "" if self.n_samples is None else f", n_samples={self.n_samples}"
        return (
            f"Forecast(steps={self.steps}, n={self.mean.shape[1]}, level={self.level:g}, "
            f"method={self.method!r}{samples})"
        )


# -- the inputs of a forecast, checked in one place ------------------------------------------


def forecast_options(level: Any, n_samples: Any, seed: Any) -> tuple[float, int, Any]:
    """Validate ``level`` in (0, 1), ``n_samples`` >= 2 and ``seed``; returns them.

    The seed is returned as given after a check (a Generator is used as is),
    so that nothing is drawn from it unless the forecast samples.
    """
    level = options.interval_level(level, "level")
    n_samples = options.integer(n_samples, "n_samples", minimum=2)
    options.random_generator(seed)  # checks it; the generator is made when it is needed
    return level, n_samples, seed


def _forecast_steps(steps: Any, rows: int | None, lag: int = 0) -> int:
    """The number of steps: ``steps`` (an integer >= 1), or ``rows`` future inputs when None.

    ``rows`` is the number of future inputs given (None without inputs), the
    rows of u after its first ``lag`` (those at the samples that start the forecast).
    """
    after = f" after its first {lag}" if lag else ""
    if steps is None:
        if rows is None:
            raise TypeError(
                "steps: expected the number of steps to forecast (an integer >= 1) "
                "for a model without inputs, received None"
            )
        if rows < 1:
            raise ValueError(
                f"u: expected at least one future input (a row of u{after}), received none"
            )
        return rows
    steps = options.integer(steps, "steps", minimum=1)
    if rows is not None and rows != steps:
        raise ValueError(
            f"steps: expected {rows} (the number of future inputs: the rows of "
            f"u{after}) or None, received {steps}"
        )
    return steps


def noise_covariance(value: Any, model_value: np.ndarray | None, n: int) -> np.ndarray:
    """The process-noise covariance (n, n): ``value`` if given, else the model's own.

    Raises
    ------
    ValueError
        Neither is there (a model built from given coefficients), or ``value``
        is not a symmetric positive semidefinite (n, n) matrix (a scalar or an
        (n,) vector of variances is taken as a diagonal).
    """
    if value is None:
        if model_value is None:
            raise ValueError(
                "noise_cov: the model has no noise covariance (its coefficients "
                "were given, not fitted); pass noise_cov=, the covariance of "
                f"v_t, shape ({n}, {n})"
            )
        return np.array(model_value, dtype=float)
    cov = arrays.as_float_array(value, "noise_cov")
    if cov.ndim == 0 or cov.shape == (n,):
        cov = np.diag(np.broadcast_to(cov, (n,)))
    if cov.shape != (n, n):
        raise ValueError(
            f"noise_cov: expected a ({n}, {n}) covariance matrix, a variance or "
            f"({n},) variances, received shape {cov.shape}"
        )
    scale = max(float(np.abs(cov).max()), 1e-300)
    if not np.allclose(cov, cov.T, rtol=1e-10, atol=1e-12 * scale):
        raise ValueError("noise_cov: expected a symmetric matrix, received a non-symmetric one")
    eig_min = float(np.linalg.eigvalsh(cov).min())
    if eig_min < -1e-10 * scale:
        raise ValueError(
            f"noise_cov: expected a positive semidefinite matrix, received one "
            f"with eigenvalue {eig_min:g}"
        )
    return 0.5 * (cov + cov.T)


def state_space_inputs(
    x0: Any, u: Any, steps: Any, *, n: int, m: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """Validate the start and inputs of a state-space forecast.

    Returns x0 (n,), the future inputs (steps, m) and steps.
    """
    x0 = arrays.as_float_array(x0, "x0")
    if x0.shape != (n,):
        raise ValueError(
            f"x0: expected the state at the end of the data, shape ({n},), "
            f"received shape {x0.shape}"
        )
    arrays.representable(x0, "x0", small=False)  # beyond 1e100 the forecast overflows
    u, steps = _future_inputs(u, steps, m=m, lag=0, meaning="the future inputs")
    return x0, u, steps


def lagged_inputs(
    y_last: Any, u: Any, steps: Any, *, n: int, m: int, lag: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """Validate the last samples and the inputs of an AR/ARX forecast.

    Returns y_last (lag, n), u (lag + steps, m) and steps.
    """
    if y_last is None and lag == 0:
        y_last = np.zeros((0, n))
    else:
        y_last = arrays.as_float_array(y_last, "y_last")
        if y_last.ndim == 1 and n == 1:
            y_last = y_last[:, None]
        if y_last.shape != (lag, n):
            expected = f"({lag}, {n})" + (f" or ({lag},)" if n == 1 else "")
            raise ValueError(
                f"y_last: expected the last {lag} samples of y (oldest first), "
                f"shape {expected}, received shape {y_last.shape}"
            )
        arrays.representable(y_last, "y_last", small=False)
    u, steps = _future_inputs(
        u,
        steps,
        m=m,
        lag=lag,
        meaning=f"the inputs at the {lag} samples of y_last and at the forecast samples",
    )
    return y_last, u, steps


def _future_inputs(u: Any, steps: Any, *, m: int, lag: int, meaning: str) -> tuple[np.ndarray, int]:
    """Validate the inputs u (lag + steps, m) of a forecast, the first ``lag`` rows at
    the known samples that start it; ``meaning`` says what they are in the messages.

    Returns u (lag + steps, m) and steps.
    """
    if m == 0:
        if u is not None:
            raise ValueError(f"u: the model has no inputs, expected None, received {describe(u)}")
        steps = _forecast_steps(steps, None)
        return np.zeros((lag + steps, 0)), steps
    rows = "steps" if lag == 0 else f"{lag} + steps"
    if u is None:
        raise TypeError(f"u: expected {meaning}, shape ({rows}, {m}), received None")
    u = arrays.as_float_array(u, "u")
    if u.ndim == 1 and m == 1:
        u = u[:, None]
    if u.ndim != 2 or u.shape[1] != m or u.shape[0] < lag:
        expected = f"({rows}, {m})" + (f" or ({rows},)" if m == 1 else "")
        raise ValueError(f"u: expected {meaning}, shape {expected}, received shape {u.shape}")
    arrays.representable(u, "u", small=False)
    steps = _forecast_steps(steps, u.shape[0] - lag, lag)
    return u, steps


def remembered_tail(model: Any, name: str, instead: str) -> DataTail:
    """The end of ``model``'s data (``model.data.tail``), where a forecast without a
    given start begins.

    Parameters
    ----------
    model : LTVModel or ARXModel
        ``data``, ``tail_lengths`` (a, b), ``n_outputs``, ``n_inputs``.
    name, instead : str
        The argument that gives the start (x0, y_last) and what to pass in it,
        for the message.

    Raises
    ------
    TypeError
        The model does not remember the end of its data (the message says why
        and what to pass instead).
    ValueError
        The end it remembers does not fit it (a description given by ``with_data``).
    """
    lengths, n, m = model.tail_lengths, model.n_outputs, model.n_inputs
    tail = model.data.tail
    if tail is None and lengths == (0, 0):  # nothing before the first forecast is needed
        return DataTail(np.zeros((0, n)), np.zeros((0, m)))
    if tail is None:
        trajectories = model.data.n_trajectories
        if trajectories > 1:
            why = f"it was fitted on {trajectories} trajectories, each with an end of its own"
        else:
            why = (
                "a model keeps it when fitted on one series whose last samples are observed; "
                "this one was built from given coefficients, its data ended with a missing "
                "sample, or it was read from a model file written before models kept it"
            )
        raise TypeError(
            f"{name}: received None, and the model does not remember the end of its data to "
            f"start from ({why}); pass {name}=, {instead}"
        )
    if not tail.fits(lengths, n, m):
        a, b = lengths
        raise ValueError(
            f"data: the model's data tail holds outputs of shape {tail.outputs.shape} and "
            f"inputs of shape {tail.inputs.shape}, expected ({a}, {n}) and ({b}, {m}); give "
            "the model the tail of data it fits (DataTail.of with its tail_lengths)"
        )
    return tail


def inputs_after_data(
    u: Any, steps: Any, *, m: int, needed: Callable[[int], int], reach: str
) -> tuple[np.ndarray, int]:
    """Validate the inputs of a forecast from the end of the data: only those after it.

    ``u`` holds u[T], u[T+1], …: row j is the input at the forecast's sample
    T + j (``Forecast.time[j]``). The forecast of ``steps`` samples reads the
    first ``needed(steps)`` of them (a state-space model steps − 1: x[T] is
    driven by the recorded u[T−1]; an AR/ARX model steps − nk); up to
    ``steps`` rows are accepted, the rest unused. ``steps`` defaults to
    ``len(u)``.

    Parameters
    ----------
    u : array_like, shape (rows, m), or (rows,) for m = 1; None without inputs
    steps : int or None
    m : int
        The number of inputs.
    needed : callable
        ``needed(steps)``, the rows read by a forecast of ``steps`` samples.
    reach : str
        Why that many, for the messages.

    Returns
    -------
    future : ndarray, shape (needed(steps), m)
    steps : int
    """
    if m == 0:
        if u is not None:
            raise ValueError(f"u: the model has no inputs, expected None, received {describe(u)}")
        steps = _forecast_steps(steps, None)
        return np.zeros((0, 0)), steps
    if u is None:
        if steps is None:
            raise TypeError(
                "steps: expected the number of steps to forecast (an integer >= 1), or u, "
                "the inputs after the data (one row per step), received neither"
            )
        steps = options.integer(steps, "steps", minimum=1)
        rows = needed(steps)
        if rows:
            raise TypeError(
                f"u: expected the inputs after the data, {_rows_text(rows)}, shape ({rows}, {m}), "
                f"for steps={steps} ({reach}), received None"
            )
        return np.zeros((0, m)), steps
    u = arrays.as_float_array(u, "u")
    if u.ndim == 1 and m == 1:
        u = u[:, None]
    if u.ndim != 2 or u.shape[1] != m:
        expected = f"(rows, {m})" + (" or (rows,)" if m == 1 else "")
        raise ValueError(
            f"u: expected the inputs after the data, one row per forecast sample, shape "
            f"{expected}, received shape {u.shape}"
        )
    arrays.representable(u, "u", small=False)
    if steps is None:
        if u.shape[0] == 0:
            raise ValueError(
                "u: expected at least one input after the data (steps defaults to len(u)), "
                "received none"
            )
        steps = u.shape[0]
    steps = options.integer(steps, "steps", minimum=1)
    rows = needed(steps)
    if not rows <= u.shape[0] <= steps:
        accepted = f"; up to {steps}, one per forecast sample, are accepted" if rows < steps else ""
        raise ValueError(
            f"u: expected {rows} rows of inputs after the data for steps={steps}, "
            f"{_rows_text(rows)} ({reach}{accepted}), received {u.shape[0]}"
        )
    return u[:rows], steps


def _rows_text(rows: int) -> str:
    """The inputs u[T] … of ``rows`` rows after the data, in words."""
    if rows == 0:
        return "none"
    return "u[T]" if rows == 1 else f"u[T] … u[T+{rows - 1}]"


# -- the coefficients after the data ---------------------------------------------------------


def _continue_coefficients(k: np.ndarray, coeffs: np.ndarray, steps: int) -> np.ndarray:
    """The coefficients after the data: Σ_j c_j k_{t+j} = 0 solved forward.

    Parameters
    ----------
    k : ndarray, shape (N, K)
        Estimated coefficients; the last d = len(coeffs) − 1 start the recursion.
    coeffs : ndarray, shape (d + 1,)
        The difference operator c_0 … c_d (c_d ≠ 0, Σ c_j = 0).
    steps : int

    Returns
    -------
    ndarray, shape (steps, K)
        k_N … k_{N+steps−1}.
    """
    d = len(coeffs) - 1
    N = k.shape[0]
    if N < d:
        raise ValueError(
            f"the model has N = {N} time steps, fewer than the order d = {d} of "
            "its difference operator needs to continue its coefficients"
        )
    history = list(k[N - d :])
    out = np.empty((steps, k.shape[1]))
    for s in range(steps):
        nxt = -sum(coeffs[j] * history[j] for j in range(d)) / coeffs[d]
        out[s] = nxt
        history = history[1:] + [nxt]
    return out


def _end_coefficient_cov(model: Any) -> np.ndarray | None:
    """Cov(k_{N−1}), the posterior covariance of the last estimate, as a (K, K) array.

    Reads the compact ``model.cov``: (N, p, p) shared by the output rows
    (I_n ⊗ cov[-1]), (N, n, p, p) per row (block diagonal) or (N, K, K). A
    sparse-norm fit has no posterior covariance: then the least-squares
    covariance of its last segment, diag(σ_i²) ⊗ (Σ φφᵀ)⁻¹ over [c_last, N)
    (``info["last_segment_unit_cov"]``, order 1). None when the model has
    neither.
    """
    cov = model.cov
    n, p = model.n_outputs, model.n_regressors
    if cov is None:
        unit = model.info.get("last_segment_unit_cov")
        if unit is None or model.noise_var is None:
            return None
        return np.kron(
            np.diag(np.asarray(model.noise_var, dtype=float)), np.asarray(unit, dtype=float)
        )
    cov = np.asarray(cov, dtype=float)
    if model.cov_shared_by_rows:
        return np.kron(np.eye(n), cov[-1])
    if cov.ndim == 4:
        out = np.zeros((n, p, n, p))
        for i in range(n):
            out[i, :, i, :] = cov[-1, i]
        return out.reshape(n * p, n * p)
    return np.array(cov[-1])


def _drift_covariance(model: Any) -> np.ndarray | None:
    """The covariance σ² W⁻¹ of the penalty's (Dk)_t per step (norm="sq"), else None.

    Row i of Θ_t has drift σ_i² W⁻¹ (σ_i² = ``model.noise_var[i]``), W the
    penalty weight of ``model.lam``. Returned as a (K,) diagonal for a scalar
    or vector λ (λ_j = inf: no drift), a (K, K) matrix for a matrix λ.

    Raises
    ------
    ValueError
        A λ_j = 0 (or a singular matrix λ): the penalty leaves those
        coefficients free, so their drift, and the forecast interval, is
        unbounded.
    """
    if model.norm != "sq" or model.lam is None or model.noise_var is None:
        return None
    K = model.K
    W = options.penalty_weight(model.lam, K)
    scale = np.repeat(np.asarray(model.noise_var, dtype=float), model.n_regressors)  # σ² of k_j
    if W.ndim == 1:
        if np.any(W == 0):
            raise ValueError(
                f"lam: the model was fitted with λ = 0 for coefficient {int(np.argmax(W == 0))}, "
                "which leaves it free to change by any amount each step: its drift σ²/λ² and "
                "the forecast interval are unbounded; refit with λ > 0"
            )
        with np.errstate(divide="ignore"):
            return np.where(np.isinf(W), 0.0, scale / W)
    eig = np.linalg.eigvalsh(W)
    if eig.min() <= 1e-12 * max(float(eig.max()), 1e-300):
        raise ValueError(
            "lam: the model's weight matrix Λ is singular, which leaves some combinations of "
            "coefficients free to change by any amount each step: their drift σ²Λ⁻¹ and the "
            "forecast interval are unbounded; refit with a positive definite Λ"
        )
    root = np.sqrt(scale)
    return root[:, None] * np.linalg.inv(W) * root[None, :]


def _factor(cov: np.ndarray | None) -> np.ndarray | None:
    """A square root L (K, K) with L Lᵀ = cov (symmetric PSD; tiny negative eigenvalues
    clipped), a (K,) vector of standard deviations for a diagonal, None for zero."""
    if cov is None or not np.any(cov):
        return None
    if cov.ndim == 1:
        return np.sqrt(cov)
    eig, vec = np.linalg.eigh(0.5 * (cov + cov.T))
    return vec * np.sqrt(np.maximum(eig, 0.0))


def _as_matrix(cov: np.ndarray | None, K: int) -> np.ndarray:
    if cov is None:
        return np.zeros((K, K))
    return np.diag(cov) if cov.ndim == 1 else cov


# -- propagation -------------------------------------------------------------------------------


def forecast_model(
    model: Any,
    initial: np.ndarray,
    known: np.ndarray,
    *,
    level: float,
    n_samples: int,
    seed: Any,
    noise_cov: np.ndarray,
    time: np.ndarray,
    names: list[str],
) -> Forecast:
    """Forecast the regression y_t = Θ_t φ_t + e_t of a model whose φ_t holds past outputs.

    φ_t = [y_{t−1}; …; y_{t−L}; known_t]: the first n·L regressors are the
    last L outputs (newest first), the rest are known (inputs, the constant).

    Parameters
    ----------
    model : RegressionModel
        k (N, K), ``coeffs``, ``cov``, ``norm``, ``lam``, ``noise_var``.
    initial : ndarray, shape (L, n)
        The outputs before the first forecast, newest first (L = 0: none).
    known : ndarray, shape (steps, p − n·L)
        The known regressors of each forecast step.
    level : float
    n_samples : int
    seed : int, Generator or None
    noise_cov : ndarray, shape (n, n)
    time : ndarray, shape (steps,)
    names : list of str

    Returns
    -------
    Forecast
    """
    n, p, K = model.n_outputs, model.n_regressors, model.K
    steps = known.shape[0]
    coeffs = np.array([-1.0, 1.0]) if model.coeffs is None else np.asarray(model.coeffs, float)
    theta = _continue_coefficients(np.asarray(model.k), coeffs, steps).reshape(steps, n, p)
    coef_cov = _end_coefficient_cov(model)
    drift = _drift_covariance(model)
    if drift is not None:
        drift = drift / coeffs[-1] ** 2  # the recursion adds w_t / c_d
    z = NormalDist().inv_cdf(0.5 + level / 2)
    coef_factor, drift_factor = _factor(coef_cov), _factor(drift)
    # An unstable model overflows over a long horizon: one DivergenceWarning below says
    # so, instead of numpy's warnings from deep inside the propagation.
    with np.errstate(over="ignore", invalid="ignore"):
        # step 1, exact: Cov(k_N) = Cov(k_{N−1}) + drift; x0 and φ known
        phi0 = np.concatenate([initial.ravel(), known[0]])
        k_cov = _as_matrix(coef_cov, K) + _as_matrix(drift, K)
        lift = np.kron(np.eye(n), phi0[None, :])  # (n, K): Θ φ = (I ⊗ φᵀ) k
        mean0 = theta[0] @ phi0
        cov0 = lift @ k_cov @ lift.T + noise_cov
        if coef_factor is not None or drift_factor is not None:
            mean, cov, lower, upper, drawn = _monte_carlo(
                theta,
                coeffs,
                coef_factor,
                drift_factor,
                initial,
                known,
                _factor(noise_cov),
                level,
                n_samples,
                seed,
            )
            method = "monte_carlo"
        else:
            mean, cov = _gaussian(theta, initial, known, noise_cov)
            lower = upper = None
            method, drawn = "gaussian", None
        mean[0], cov[0] = mean0, cov0
        sd = np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))
        if lower is None:
            lower, upper = mean - z * sd, mean + z * sd
        else:
            lower[0], upper[0] = mean0 - z * sd[0], mean0 + z * sd[0]
    _warn_if_diverged(mean, lower, upper)
    return Forecast(
        mean=mean,
        lower=lower,
        upper=upper,
        cov=cov,
        level=level,
        time=time,
        names=names,
        method=method,
        n_samples=drawn,
        coefficients=theta,
        time_name=model.data.time_name,
    )


def _warn_if_diverged(mean: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
    """A :class:`~ltvmodels.DivergenceWarning` when the forecast overflowed (as ``simulate``)."""
    finite = np.isfinite(mean) & np.isfinite(lower) & np.isfinite(upper)
    if not finite.all():
        step = int(np.flatnonzero(~finite.all(axis=1))[0])
        warn(
            f"the forecast diverged: its mean or interval is inf or NaN from step {step} "
            "(counted from 0) on: the model is unstable along these inputs over this horizon; "
            "forecast fewer steps",
            DivergenceWarning,
        )


def _gaussian(
    theta: np.ndarray, initial: np.ndarray, known: np.ndarray, noise_cov: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Exact mean and covariance for known coefficients: the lag state's covariance recursion."""
    steps, n, _ = theta.shape
    L = initial.shape[0]
    D = n * L
    lags = initial.ravel().copy()
    P = np.zeros((D, D))  # covariance of the lag state [y_{t−1}; …; y_{t−L}]
    mean = np.empty((steps, n))
    cov = np.empty((steps, n, n))
    for s in range(steps):
        th = theta[s]
        mean[s] = th[:, :D] @ lags + th[:, D:] @ known[s]
        feed = th[:, :D]
        cov[s] = feed @ P @ feed.T + noise_cov
        if D:
            cross = feed @ P[:, : D - n]  # Cov(y_t, the lags kept)
            new = np.empty((D, D))
            new[:n, :n] = cov[s]
            new[:n, n:] = cross
            new[n:, :n] = cross.T
            new[n:, n:] = P[: D - n, : D - n]
            P = new
            lags = np.concatenate([mean[s], lags[: D - n]])
    return mean, cov


def _monte_carlo(
    theta, coeffs, coef_factor, drift_factor, initial, known, noise_factor, level, n_samples, seed
):
    """Sample mean, covariance and quantile bounds of simulated paths (antithetic pairs).

    The factors are square roots of Cov(k_{N−1}), of the drift per step (already divided by
    c_d²) and of the noise covariance (see :func:`_factor`; None for zero).
    """
    steps, n, p = theta.shape
    K = n * p
    L = initial.shape[0]
    D = n * L
    d = len(coeffs) - 1
    rng = options.random_generator(seed)
    half = (n_samples + 1) // 2
    S = 2 * half

    def draw(factor: np.ndarray | None, size: int) -> np.ndarray:
        """S antithetic draws of N(0, factor factorᵀ) (a diagonal factor as a vector)."""
        if factor is None:
            return np.zeros((S, size))
        g = rng.standard_normal((half, factor.shape[0] if factor.ndim == 1 else factor.shape[1]))
        g = g * factor if factor.ndim == 1 else g @ factor.T
        return np.concatenate([g, -g])

    error = draw(coef_factor, K)  # k_{N−1} − its estimate, carried by the recursion
    history = [error] * d  # the last d coefficient deviations
    lags = np.broadcast_to(initial.ravel(), (S, D)).copy()
    # Each step's paths are summarized before the next step is drawn: memory grows with
    # n_samples, not with steps × n_samples.
    mean = np.empty((steps, n))
    cov = np.empty((steps, n, n))
    lower = np.empty((steps, n))
    upper = np.empty((steps, n))
    for s in range(steps):
        # deviation of k at this step: Σ_j c_j dev_{t+j} = w_t, with w / c_d drawn as `drift`
        dev = -sum(coeffs[j] * history[j] for j in range(d)) / coeffs[d] + draw(drift_factor, K)
        history = history[1:] + [dev]
        phi = np.concatenate([lags, np.broadcast_to(known[s], (S, known.shape[1]))], axis=1)
        out = phi @ theta[s].T + np.einsum("sij,sj->si", dev.reshape(S, n, p), phi)
        sample = out + draw(noise_factor, n)  # (S, n): the paths at this step
        mean[s] = sample.mean(axis=0)
        centred = sample - mean[s]
        cov[s] = centred.T @ centred / (S - 1)
        lower[s], upper[s] = np.quantile(sample, [0.5 - level / 2, 0.5 + level / 2], axis=0)
        lags = np.concatenate([sample, lags[:, : D - n]], axis=1) if D else lags
    return mean, cov, lower, upper, S
