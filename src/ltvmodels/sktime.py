"""sktime adapters: our time-varying AR/ARX forecasts and change-point detectors in sktime.

Two estimators that follow sktime's extension templates, so that they compose
with sktime's pipelines, tuning, ``evaluate`` back-testing and detection
benchmarks:

* :class:`LTVForecaster` (a ``BaseForecaster``): the time-varying (V)AR(X)
  model of :func:`ltvmodels.fit_ar` / :func:`ltvmodels.fit_arx` fitted on
  ``y`` (one or several columns) and the exogenous ``X``; point forecasts,
  intervals and quantiles from :meth:`ltvmodels.ARXModel.forecast`, one-step
  in-sample predictions from the fitted coefficients.
* :class:`LTVChangePointDetector` (a ``BaseDetector``): the exact segmentation
  of :func:`ltvmodels.segment_regression` (dynamic programming for a known
  number of changes, PELT for a penalty) or the group-lasso detector
  (:func:`ltvmodels.find_changepoints` on a ``norm="group"`` fit), returning
  sktime's change-point format.

Needs sktime: ``pip install "ltvmodels[sktime]"``. ``import ltvmodels`` does not
import this module (nor sktime).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from .estimators.ar import ar_regressors, arx_regressors, fit_ar, fit_arx
from .estimators.changepoints import find_changepoints
from .estimators.regression import fit_regression
from .estimators.segments import segment_regression
from .results.arx import ARModel, ARXModel
from .results.forecast import Forecast
from .validation import options

try:
    from sktime.detection.base import BaseDetector
    from sktime.forecasting.base import BaseForecaster, ForecastingHorizon
except ImportError as exc:  # pragma: no cover - exercised without sktime only
    raise ImportError(
        "ltvmodels.sktime needs sktime >= 1.2: install ltvmodels[sktime] "
        "(pip install 'ltvmodels[sktime]')"
    ) from exc

__all__ = ["LTVForecaster", "LTVChangePointDetector"]

# The interval of a quantile α is the central one of probability |1 − 2α|; the median's
# (α = 0.5) has probability 0, which a Forecast does not take: this one is narrower than
# any gap between two of its samples (the bounds are the median to 1e-12 in probability).
MEDIAN_LEVEL = 1e-12

UPDATE_MODES = ("refit", "keep")
DETECTION_METHODS = ("exact", "group")


def _updated(seen: pd.DataFrame, new: pd.DataFrame | None) -> pd.DataFrame:
    """The data seen with the new samples: new values replace those at the same time."""
    if new is None or len(new) == 0:
        return seen
    kept = seen.loc[~seen.index.isin(new.index)]
    return pd.concat([kept, new]).sort_index()


def _told_of(error: ValueError, inner: tuple[str, ...], name: str) -> ValueError:
    """An error that names an argument of the function an adapter called (one of
    ``inner``), told of the adapter's own argument ``name``; other errors unchanged."""
    message = str(error)
    for argument in inner:
        if message.startswith((f"{argument}: ", f"{argument}[")):
            return type(error)(name + message[len(argument) :])
    return error


def _observed_end(seen: pd.DataFrame, L: int, name: str) -> np.ndarray:
    """The last L samples of the data seen, which a forecast starts from: all observed."""
    last = _as_array(seen.iloc[len(seen) - L :])
    missing = seen.index[len(seen) - L :][~np.isfinite(last).all(axis=1)]
    if len(missing):
        raise ValueError(
            f"{name}: expected observed values at the last {L} samples, which the forecast "
            f"starts from, received NaN or inf at {list(missing[:5])}; fill or drop these "
            f"samples before fitting, or update the forecaster with observed ones"
        )
    return last


def _as_array(frame: Any) -> Any:
    """A float copy of a DataFrame's values (None stays None); the caller's frame is untouched."""
    return None if frame is None else np.array(frame.to_numpy(dtype=float), dtype=float)


class LTVForecaster(BaseForecaster):
    """Forecasts of a time-varying (V)AR(X) model, for sktime.

    Fits y[t] = Σ_{i=1}^{na} A_{t,i} y[t−i] + Σ_{j=1}^{nb} B_{t,j} X[t−nk−j+1] (+ c_t) + e[t]
    with :func:`ltvmodels.fit_ar` (no ``X``) or :func:`ltvmodels.fit_arx` (with
    ``X``): the minimizer of Σ_t ‖y[t] − Θ_t φ_t‖² + R(DΘ), the penalty R of
    ``norm`` on the differences of the coefficients Θ_t. ``y`` with several
    columns is a vector model (VAR/VARX; with na = 1 the state-space model of
    :func:`ltvmodels.fit`). Forecasts continue the last coefficients as the
    penalty's model says (see :mod:`ltvmodels.results.forecast`): the mean,
    the central intervals and the quantiles are those of
    :meth:`ltvmodels.ARXModel.forecast` (exact and Gaussian at the first step,
    seeded Monte Carlo beyond it). In-sample horizons get the one-step
    predictions Θ_t φ_t (NaN for the first L = max(na, nk + nb − 1) samples,
    which have no lags); intervals are out of sample only.

    Parameters
    ----------
    na : int >= 1, default 2
        Number of lags of y.
    nb : int >= 1, default 1
        Number of lags of X (used only when ``X`` is given).
    nk : int >= 0, default 1
        Delay of X: the newest X in φ_t is X[t − nk] (0: X at the forecast time
        enters, so ``predict`` needs X at every step of the horizon).
    lam : float or "auto", default "auto"
        λ, as in :func:`ltvmodels.fit_ar` ("auto": chosen by the marginal
        likelihood for ``norm="sq"``).
    norm : {"sq", "group", "l1"}, default "sq"
        Penalty on the coefficient differences.
    order : int, default 1
        Order of the difference operator (1: random-walk coefficients, 2: linear trends).
    constant : bool, default True
        Include a time-varying constant c_t.
    loss : {"squared", "huber"}, default "squared"
        Data loss, as in :func:`ltvmodels.fit_ar`.
    update_mode : {"refit", "keep"}, default "refit"
        What ``update(y, update_params=True)`` does: "refit" fits the model on
        all the data seen (the estimate changes everywhere, as the exact
        smoother's does); "keep" keeps the coefficients and forecasts from the
        end of the new data (as ``update_params=False`` always does).
    n_samples : int >= 2, default 2000
        Monte Carlo paths of the forecast distribution beyond the first step.
    seed : int, default 0
        Seed of those paths: forecasts, intervals and quantiles of one call
        come from the same paths.

    Attributes
    ----------
    model_ : ARModel or ARXModel
        The fitted model (``fit_ar``/``fit_arx`` on the data seen).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from ltvmodels.sktime import LTVForecaster
    >>> rng = np.random.default_rng(0)
    >>> y = pd.Series(np.sin(np.arange(120) / 5) + 0.1 * rng.standard_normal(120))
    >>> forecaster = LTVForecaster(na=2, lam=30.0).fit(y, fh=[1, 2, 3])
    >>> forecaster.predict().shape
    (3,)
    """

    _tags = {
        "authors": ["ltvmodels developers"],
        "maintainers": ["ltvmodels developers"],
        "python_dependencies": ["ltvmodels"],
        "y_inner_mtype": "pd.DataFrame",
        "X_inner_mtype": "pd.DataFrame",
        "capability:multivariate": True,  # a VAR(X) model for several columns
        "capability:exogenous": True,
        "capability:insample": True,  # one-step predictions Θ_t φ_t
        "capability:pred_int": True,
        "capability:pred_int:insample": False,  # the forecast distribution starts after the data
        # NaN in y or X is a missing sample (rows that read it are left out); a forecast
        # needs the last L samples observed (it says so otherwise)
        "capability:missing_values": True,
        # X is read at every step up to the horizon (the lags of y are simulated through them)
        "capability:non_contiguous_X": False,
        "capability:update": True,
        "requires-fh-in-fit": False,
        "X-y-must-have-same-index": True,
        "property:randomness": "deterministic",  # Monte Carlo seeded by the seed parameter
    }
    # The forecaster keeps the data it has seen itself (``_y_seen``, ``_X_seen``): the
    # forecasts start from their last samples and "refit" fits them all. sktime's own
    # copy (``remember_data``) is not needed, and turning it off silences its warning
    # about that option's change of default.
    _config = {"remember_data": False}

    def __init__(
        self,
        na: int = 2,
        nb: int = 1,
        nk: int = 1,
        lam: Any = "auto",
        norm: Any = "sq",
        order: Any = 1,
        constant: bool = True,
        loss: Any = "squared",
        update_mode: str = "refit",
        n_samples: int = 2000,
        seed: int = 0,
    ) -> None:
        self.na = na
        self.nb = nb
        self.nk = nk
        self.lam = lam
        self.norm = norm
        self.order = order
        self.constant = constant
        self.loss = loss
        self.update_mode = update_mode
        self.n_samples = n_samples
        self.seed = seed
        super().__init__()
        # sktime's copy of the data, filled only where a user turns remember_data on
        self._y = self._X = None

    # -- fitting ---------------------------------------------------------------------------
    def _fit(self, y: pd.DataFrame, X: pd.DataFrame | None = None, fh: Any = None):
        """Fit the model to y (T, n) and X (T, m); see the class docstring for the objective."""
        self._na, self._nb, self._nk = options.lag_orders(
            self.na, self.nb, self.nk, min_na=1, min_nb=1
        )
        self._update_mode = options.choice(self.update_mode, "update_mode", UPDATE_MODES)
        self._n_samples = options.integer(self.n_samples, "n_samples", minimum=2)
        self._seed = options.integer(self.seed, "seed", minimum=0)
        self._y_seen, self._X_seen = y, X
        self._fit_model(y, X)
        return self

    def _fit_model(self, y: pd.DataFrame, X: pd.DataFrame | None) -> None:
        settings: dict[str, Any] = {
            "lam": self.lam,
            "norm": self.norm,
            "order": self.order,
            "constant": self.constant,
            "loss": self.loss,
        }
        y_values, x_values = _as_array(y), _as_array(X)
        model: ARXModel  # an ARModel without X
        if x_values is None:
            model = fit_ar(y_values, self._na, **settings)
        else:
            try:
                model = fit_arx(y_values, x_values, self._na, self._nb, self._nk, **settings)
            except ValueError as error:
                raise _told_of(error, ("u",), "X") from error
        self.model_ = model
        self._with_X = x_values is not None

    def _update(self, y: pd.DataFrame, X: pd.DataFrame | None = None, update_params: bool = True):
        """Add the new samples to the data seen; refit on them all (``update_mode="refit"``)
        or keep the coefficients."""
        self._y_seen = _updated(self._y_seen, y)
        if self._with_X:
            self._X_seen = _updated(self._X_seen, X)
        if update_params and self._update_mode == "refit":
            self._fit_model(self._y_seen, self._X_seen if self._with_X else None)
        return self

    # -- prediction ------------------------------------------------------------------------
    def _predict(self, fh: ForecastingHorizon, X: pd.DataFrame | None = None) -> pd.DataFrame:
        """Forecast means out of sample and one-step predictions in sample, at fh."""
        relative = self._relative_steps(fh)
        values = np.full((len(relative), self._y_seen.shape[1]), np.nan)
        ahead = relative >= 1
        if ahead.any():
            forecast = self._forecast(int(relative.max()), X, 0.5)
            values[ahead] = forecast.mean[relative[ahead] - 1]
        if (~ahead).any():
            values[~ahead] = self._in_sample(relative[~ahead])
        return pd.DataFrame(
            values, index=fh.to_absolute_index(self.cutoff), columns=self._get_columns()
        )

    def _predict_interval(
        self, fh: ForecastingHorizon, X: pd.DataFrame | None, coverage: list[float]
    ) -> pd.DataFrame:
        """Central intervals of probability ``coverage`` of the forecast distribution."""
        steps = self._relative_steps(fh) - 1
        columns = self._get_columns(method="predict_interval", coverage=coverage)
        values = np.empty((len(steps), len(columns)))
        names = list(self._get_varnames())
        for c in coverage:
            forecast = self._forecast(int(steps.max()) + 1, X, c)
            for j, name in enumerate(names):
                values[:, columns.get_loc((name, c, "lower"))] = forecast.lower[steps, j]
                values[:, columns.get_loc((name, c, "upper"))] = forecast.upper[steps, j]
        return pd.DataFrame(values, index=fh.to_absolute_index(self.cutoff), columns=columns)

    def _predict_quantiles(
        self, fh: ForecastingHorizon, X: pd.DataFrame | None, alpha: list[float]
    ) -> pd.DataFrame:
        """Quantiles α of the forecast distribution: a bound of its interval of level |1 − 2α|."""
        steps = self._relative_steps(fh) - 1
        columns = self._get_columns(method="predict_quantiles", alpha=alpha)
        values = np.empty((len(steps), len(columns)))
        names = list(self._get_varnames())
        for a in alpha:
            level = abs(1.0 - 2.0 * a) if a != 0.5 else MEDIAN_LEVEL
            forecast = self._forecast(int(steps.max()) + 1, X, level)
            bound = forecast.lower if a <= 0.5 else forecast.upper
            for j, name in enumerate(names):
                values[:, columns.get_loc((name, a))] = bound[steps, j]
        return pd.DataFrame(values, index=fh.to_absolute_index(self.cutoff), columns=columns)

    # -- helpers ---------------------------------------------------------------------------
    def _relative_steps(self, fh: ForecastingHorizon) -> np.ndarray:
        """fh as steps after the cutoff: 1 the next sample, 0 the last one seen, -1 before it."""
        return np.asarray(fh.to_relative(self.cutoff), dtype=np.int64)

    def _lag(self) -> int:
        model: ARXModel = self.model_
        return model.lag

    def _forecast(self, steps: int, X: pd.DataFrame | None, level: float) -> Forecast:
        """The forecast of ``steps`` samples after the data seen, from its last L samples."""
        L = self._lag()
        y_last = _observed_end(self._y_seen, L, "y")
        model: ARXModel = self.model_
        settings: dict[str, Any] = {
            "steps": steps,
            "level": level,
            "n_samples": self._n_samples,
            "seed": self._seed,
        }
        if isinstance(model, ARModel):  # no inputs
            return model.forecast(y_last, **settings)
        inputs = np.concatenate([_observed_end(self._X_seen, L, "X"), self._future_X(steps, X)])
        return model.forecast(y_last, inputs, **settings)

    def _future_X(self, steps: int, X: pd.DataFrame | None) -> np.ndarray:
        """X at the ``steps`` samples after the cutoff (rows no forecast reads are zeros)."""
        needed = max(steps - self._nk, 0)  # y[T+j] reads X up to X[T+j−nk]
        future = np.zeros((steps, len(self.model_.input_names)))
        if needed == 0:
            return future
        index = ForecastingHorizon(np.arange(1, steps + 1), is_relative=True).to_absolute_index(
            self.cutoff
        )
        if X is None:
            raise ValueError(
                f"X: expected the exogenous values at the {needed} samples after the end of "
                f"the data ({index[0]} … {index[needed - 1]}), because the model reads X up "
                f"to {self._nk} sample(s) before each forecast, received None; pass X to predict"
            )
        rows = X.reindex(index[:needed])
        missing = rows.index[rows.isna().any(axis=1).to_numpy()]
        if len(missing):
            raise ValueError(
                f"X: expected values at every sample from {index[0]} to {index[needed - 1]} "
                f"(the model reads X up to {self._nk} sample(s) before each forecast), received "
                f"none at {list(missing[:5])}; pass X covering these samples"
            )
        future[:needed] = rows.to_numpy(dtype=float)
        return future

    def _in_sample(self, relative: np.ndarray) -> np.ndarray:
        """One-step predictions Θ_t φ_t at samples T − 1 + relative (NaN before the first lag).

        Samples after the fitted data (an update that kept the coefficients) use the last Θ.
        """
        y = _as_array(self._y_seen)
        model: ARXModel = self.model_
        if self._with_X:
            _, phi = arx_regressors(
                y, _as_array(self._X_seen), self._na, self._nb, self._nk, constant=model.constant
            )
        else:
            _, phi = ar_regressors(y, self._na, constant=model.constant)
        L = model.lag
        rows = len(y) - 1 + relative - L  # the regression row of each sample
        theta = model.theta[np.clip(rows, 0, model.N - 1)]
        values = np.einsum("sij,sj->si", theta, phi[np.clip(rows, 0, len(phi) - 1)])
        values[(rows < 0) | (relative < -(len(y) - 1))] = np.nan
        return values

    @classmethod
    def get_test_params(cls, parameter_set: str = "default") -> list[dict[str, Any]]:
        """Configurations for sktime's checks: each a real use of the forecaster.

        An AR(2) with random-walk coefficients and fixed λ; a linear-trend (order 2) AR(1)
        with λ chosen by the marginal likelihood and a model kept on update; a group-lasso
        (piecewise-constant) AR(1) with X entering without delay and fewer Monte Carlo paths.

        Parameters
        ----------
        parameter_set : str, default "default"
            Name of the set (only "default").

        Returns
        -------
        list of dict
            Keyword arguments of :class:`LTVForecaster`.
        """
        return [
            {"na": 2, "lam": 10.0, "norm": "sq", "order": 1, "n_samples": 400},
            {"na": 1, "lam": "auto", "order": 2, "update_mode": "keep", "n_samples": 200},
            {"na": 1, "nk": 0, "lam": 5.0, "norm": "group", "n_samples": 200, "seed": 3},
        ]


class LTVChangePointDetector(BaseDetector):
    """Change points of a series' mean or AR model, for sktime.

    The series X (T, n) is the regression y_t = Θ_t φ_t + e_t with φ_t = 1
    (``na=0``: changes of the mean) or φ_t = [X[t−1]; …; X[t−na]; 1] (an AR(na)
    model with a constant, :func:`ltvmodels.ar_regressors`), and its changes
    are found by

    * ``method="exact"``: :func:`ltvmodels.segment_regression`, the global
      optimum of Σ_t ‖y_t − Θ_t φ_t‖² subject to at most ``n_changes`` changes
      (dynamic programming), or plus ``penalty`` per change (PELT); ``cost``
      and ``fixed`` as there;
    * ``method="group"``: a group-lasso fit (``norm="group"``, λ = ``lam``,
      :func:`ltvmodels.fit_regression` / :func:`ltvmodels.fit_ar`) and the peaks of its
      activation, :func:`ltvmodels.find_changepoints` (``threshold``,
      ``noise_factor``, ``min_distance``, ``max_changes``).

    ``predict`` returns sktime's change-point format: a DataFrame with column
    "ilocs", the position in X of the first sample produced under the new
    model (for an AR model, a change at regression row c is sample na + c),
    so that ``X.index[ilocs]`` is our ``changepoint_times``
    (:meth:`predict_times` gives them).

    Parameters
    ----------
    method : {"exact", "group"}, default "exact"
        Exact segmentation or the group-lasso detector.
    na : int >= 0, default 0
        0: piecewise-constant mean; >= 1: piecewise-constant AR(na) with a constant.
    n_changes : int, optional
        The number of changes (at most), for ``method="exact"``.
    penalty : float or {"bic", "aic", "lwz"}, optional
        β per change, or a rule, for ``method="exact"`` (default "bic" when
        ``n_changes`` is not given); with ``n_changes`` a rule chooses among 0 … n_changes.
    min_size : int, optional
        Minimum rows per segment (``method="exact"``), as in :func:`ltvmodels.segment_regression`.
    cost : {"rss", "normal"}, default "rss"
        Segment cost (``method="exact"``): "normal" also sees changes of the noise level.
    fixed : int, sequence of int, or None
        Columns of φ common to all segments (``method="exact"``), e.g. -1 the constant.
    lam : float, default 10.0
        λ of the group-lasso fit (``method="group"``).
    threshold, noise_factor, min_distance, max_changes
        The rules of :func:`ltvmodels.find_changepoints` (``method="group"``).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from ltvmodels.sktime import LTVChangePointDetector
    >>> rng = np.random.default_rng(0)
    >>> x = pd.Series(np.r_[np.zeros(60), 3 * np.ones(40)] + rng.standard_normal(100))
    >>> LTVChangePointDetector(n_changes=1).fit(x).predict(x)["ilocs"].tolist()
    [60]
    """

    _tags = {
        "authors": ["ltvmodels developers"],
        "maintainers": ["ltvmodels developers"],
        "python_dependencies": ["ltvmodels"],
        "task": "change_point_detection",
        "learning_type": "unsupervised",
        "capability:multivariate": True,  # a vector mean or a VAR model
        "capability:missing_values": True,  # a NaN row is left out of the data term
        "capability:update": False,
        "capability:variable_identification": False,
        "fit_is_empty": True,  # every series is segmented on its own
        "X_inner_mtype": "pd.DataFrame",
        "property:randomness": "deterministic",
    }

    def __init__(
        self,
        method: str = "exact",
        na: int = 0,
        n_changes: int | None = None,
        penalty: Any = None,
        min_size: int | None = None,
        cost: Any = "rss",
        fixed: Any = None,
        lam: float = 10.0,
        threshold: float = 0.25,
        noise_factor: float | None = 8.0,
        min_distance: int = 10,
        max_changes: int | None = None,
    ) -> None:
        self.method = method
        self.na = na
        self.n_changes = n_changes
        self.penalty = penalty
        self.min_size = min_size
        self.cost = cost
        self.fixed = fixed
        self.lam = lam
        self.threshold = threshold
        self.noise_factor = noise_factor
        self.min_distance = min_distance
        self.max_changes = max_changes
        super().__init__()

    def _fit(self, X: pd.DataFrame, y: Any = None):
        """Nothing to learn: each series is segmented by ``predict``."""
        return self

    def _predict(self, X: pd.DataFrame) -> pd.DataFrame:
        """The change points of X as sktime's "ilocs" (first sample of each new segment)."""
        return pd.DataFrame({"ilocs": pd.array(self._changepoints(X), dtype="int64")})

    def predict_times(self, X: pd.DataFrame | pd.Series) -> pd.Index:
        """The change points on X's own index: ``X.index[predict(X)["ilocs"]]``.

        Parameters
        ----------
        X : pandas.DataFrame or pandas.Series
            The series, as for ``predict``.

        Returns
        -------
        pandas.Index
            The index value of the first sample of each new segment.
        """
        return X.index[self.predict(X)["ilocs"].to_numpy()]

    def _changepoints(self, X: pd.DataFrame) -> np.ndarray:
        method = options.choice(self.method, "method", DETECTION_METHODS)
        na = options.integer(self.na, "na", minimum=0)
        try:
            return self._segment(_as_array(X), method, na)
        except ValueError as error:  # the series is X here, y and phi to the fits below
            raise _told_of(error, ("y", "phi"), "X") from error

    def _segment(self, series: np.ndarray, method: str, na: int) -> np.ndarray:
        if na == 0:
            y, phi = series, np.ones((len(series), 1))
        else:
            y, phi = ar_regressors(series, na, constant=True)
        if method == "exact":
            seg = segment_regression(
                y,
                phi,
                n_changes=self.n_changes,
                penalty=self.penalty,
                min_size=self.min_size,
                cost=self.cost,
                fixed=self.fixed,
            )
            return np.asarray(seg.changepoints, dtype=np.int64) + na
        if self.n_changes is not None or self.penalty is not None:
            raise ValueError(
                f"n_changes, penalty: expected None with method='group' (the group lasso's "
                f"changes are set by lam and max_changes), received n_changes={self.n_changes!r}"
                f", penalty={self.penalty!r}; use method='exact', or max_changes"
            )
        if na == 0:
            model = fit_regression(y, phi, lam=self.lam, norm="group")
        else:
            model = fit_ar(series, na, lam=self.lam, norm="group", constant=True)
        found = find_changepoints(
            model,
            threshold=self.threshold,
            noise_factor=self.noise_factor,
            min_distance=self.min_distance,
            max_changes=self.max_changes,
        )
        return np.asarray(found.sample_indices, dtype=np.int64)

    @classmethod
    def get_test_params(cls, parameter_set: str = "default") -> list[dict[str, Any]]:
        """Configurations for sktime's checks: each a real use of the detector.

        One change of the mean (dynamic programming); an AR(1) segmented by PELT with the
        BIC and the Gaussian cost (noise-level changes too); the group-lasso detector of
        an AR(1).

        Parameters
        ----------
        parameter_set : str, default "default"
            Name of the set (only "default").

        Returns
        -------
        list of dict
            Keyword arguments of :class:`LTVChangePointDetector`.
        """
        return [
            {"n_changes": 1},
            {"na": 1, "penalty": "bic", "cost": "normal"},
            {"method": "group", "na": 1, "lam": 5.0, "min_distance": 3},
        ]
