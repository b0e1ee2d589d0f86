"""Fuzz the sktime adapters: LTVForecaster and LTVChangePointDetector.

sktime's ``check_estimator`` (``tests/test_sktime.py``) checks the adapters'
interface on sktime's own clean data. Here the data recipes of
:mod:`fuzz_strategies` (extreme scales, NaN blocks, constant and duplicated
columns, short series) reach the adapters as pandas objects with a range, a
datetime or a period index, and their parameters are drawn valid or invalid.
Each call goes through :func:`fuzz_oracle.check_call`: a finite result (point
forecasts, intervals, quantiles, forecasts after ``update``; change points
inside the series, in increasing order) or a documented library error. The
data go to sktime as it accepts them (a float DataFrame of the right length),
so that every error comes from our side of the adapter.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from fuzz_oracle import check_call, expect
from fuzz_strategies import (
    CONSTANT,
    LAM,
    LOSS,
    NORM,
    ORDER,
    Data,
    Opt,
    choice_of,
    datasets,
    fuzz_test,
    options,
)
from hypothesis import strategies as st

pytest.importorskip("sktime")

from ltvmodels.sktime import LTVChangePointDetector, LTVForecaster  # noqa: E402

UNSET = object()
"""A parameter the call leaves at the adapter's default."""

INDEXES = ["range", "range", "datetime", "period"]


def _frame(values: np.ndarray, index: str, columns: str = "y") -> pd.DataFrame:
    """(T, k) values as a DataFrame with the drawn kind of index."""
    T = values.shape[0]
    if index == "datetime":
        labels: pd.Index = pd.date_range("2020-01-01", periods=T, freq="D")
    elif index == "period":
        labels = pd.period_range("2000-01", periods=T, freq="M")
    else:
        labels = pd.RangeIndex(T)
    names = [f"{columns}{j}" for j in range(values.shape[1])]
    return pd.DataFrame(values, index=labels, columns=names)


def _chosen(params: dict) -> dict:
    return {name: value for name, value in params.items() if value is not UNSET}


def ltv_forecaster(
    y: pd.DataFrame,
    X: pd.DataFrame | None,
    new: int,
    fh: list,
    *,
    na=UNSET,
    nb=UNSET,
    nk=UNSET,
    lam=UNSET,
    norm=UNSET,
    order=UNSET,
    constant=UNSET,
    loss=UNSET,
    update_mode=UNSET,
    n_samples=UNSET,
    seed=UNSET,
) -> tuple:
    """Fit LTVForecaster to all but the last ``new`` rows, forecast ``fh``, update, forecast.

    Returns the point forecasts, the 80 % intervals and the 10 %/50 %/90 %
    quantiles after the fit, and the point forecasts after ``update`` with the
    ``new`` rows.
    """
    forecaster = LTVForecaster(
        **_chosen(
            dict(
                na=na,
                nb=nb,
                nk=nk,
                lam=lam,
                norm=norm,
                order=order,
                constant=constant,
                loss=loss,
                update_mode=update_mode,
                n_samples=n_samples,
                seed=seed,
            )
        )
    )
    T = len(y) - new
    horizon = max(fh)
    past_X = None if X is None else X.iloc[:T]
    future_X = None if X is None else X.iloc[T : T + horizon]
    forecaster.fit(y.iloc[:T], X=past_X, fh=fh)
    point = forecaster.predict(X=future_X)
    interval = forecaster.predict_interval(X=future_X, coverage=0.8)
    quantiles = forecaster.predict_quantiles(X=future_X, alpha=[0.1, 0.5, 0.9])
    expect(
        bool(np.all(np.diff(quantiles.to_numpy().reshape(len(fh), -1, 3), axis=-1) >= 0)),
        "ltv_forecaster",
        "quantiles out of order",
        "the 10 %, 50 % and 90 % quantiles of a forecast are not increasing",
    )
    if new:
        forecaster.update(y.iloc[T:], X=None if X is None else X.iloc[T : T + new])
        updated_X = None if X is None else X.iloc[T + new : T + new + horizon]
        after = forecaster.predict(X=updated_X).to_numpy()
    else:
        after = point.to_numpy()
    return point.to_numpy(), interval.to_numpy(), quantiles.to_numpy(), after


LAG = Opt(st.integers(1, 3), choice_of(0, -1, 1.5, "2", None, True, 10**6, np.nan))
FORECAST_LOSS = Opt(choice_of("squared", "huber"), LOSS.invalid)


def forecaster_options(max_bad: int = 2) -> st.SearchStrategy:
    return options(
        required=("lam",),  # as in the other fuzz tests: an error may name λ ("auto" too)
        max_bad=max_bad,
        na=LAG,
        nb=LAG,
        nk=Opt(st.integers(0, 2), choice_of(-1, 1.5, "1", None)),
        lam=Opt(st.one_of(st.just("auto"), LAM.valid), LAM.invalid),
        norm=NORM,
        order=ORDER,
        constant=CONSTANT,
        loss=FORECAST_LOSS,
        update_mode=Opt(choice_of("refit", "keep"), choice_of("online", "", None, 1)),
        n_samples=Opt(choice_of(2, 50, 300), choice_of(1, 0, -5, 2.5, "100", None)),
        seed=Opt(st.integers(0, 2**16), choice_of(-1, 1.5, "0")),
    )


@st.composite
def forecast_cases(draw, max_bad: int = 2, edge: bool = True):
    data = draw(datasets(batch=False, forms=False, edge=edge, min_T=8, max_T=60, max_n=2))
    horizon = draw(st.integers(1, 4))
    new = draw(st.sampled_from([0, 0, 1, 3]))
    index = draw(st.sampled_from(INDEXES))
    fh = sorted(draw(st.sets(st.integers(1, horizon), min_size=1, max_size=horizon)) | {horizon})
    return data, new, index, fh, draw(forecaster_options(max_bad))


def _forecast_data(data: Data, horizon: int, index: str) -> tuple:
    """y (T rows) and X (T + horizon rows: predict needs X over the horizon) as frames."""
    x, u = data.xu()
    x = np.asarray(x, dtype=float).reshape(data.T, -1)
    y = _frame(x, index, "y")
    if u is None:
        return y, None
    u = np.asarray(u, dtype=float).reshape(-1, data.m)
    # sktime aligns X with y by the index: a length defect becomes missing samples
    u = np.vstack([u[: data.T], np.full((max(data.T - len(u), 0), data.m), np.nan)])
    rng = np.random.default_rng(data.seed + 2)
    extra = rng.standard_normal((horizon, u.shape[1]))
    return y, _frame(np.vstack([u, extra]), index, "x")


@fuzz_test(forecast_cases(), examples=1.0, valid=(forecast_cases(0, edge=False),))
def test_ltv_forecaster(case):
    """LTVForecaster: fit, predict, predict_interval, predict_quantiles, update."""
    data, new, index, fh, kwargs = case
    y, X = _forecast_data(data, max(fh), index)
    check_call(ltv_forecaster, y, X, new, fh, label="LTVForecaster", **kwargs)


def ltv_detector(
    X: pd.DataFrame,
    *,
    method=UNSET,
    na=UNSET,
    n_changes=UNSET,
    penalty=UNSET,
    min_size=UNSET,
    cost=UNSET,
    fixed=UNSET,
    lam=UNSET,
    threshold=UNSET,
    noise_factor=UNSET,
    min_distance=UNSET,
    max_changes=UNSET,
) -> np.ndarray:
    """The change points LTVChangePointDetector finds in X (sktime's "ilocs")."""
    detector = LTVChangePointDetector(
        **_chosen(
            dict(
                method=method,
                na=na,
                n_changes=n_changes,
                penalty=penalty,
                min_size=min_size,
                cost=cost,
                fixed=fixed,
                lam=lam,
                threshold=threshold,
                noise_factor=noise_factor,
                min_distance=min_distance,
                max_changes=max_changes,
            )
        )
    )
    ilocs = detector.fit(X).predict(X)["ilocs"].to_numpy()
    times = detector.predict_times(X)
    label = "LTVChangePointDetector"
    expect(
        bool(np.all((ilocs > 0) & (ilocs < len(X)))),
        label,
        "change point outside the series",
        f"ilocs {ilocs.tolist()} for a series of {len(X)} samples",
    )
    expect(bool(np.all(np.diff(ilocs) > 0)), label, "change points not increasing", str(ilocs))
    expect(
        list(times) == list(X.index[ilocs]),
        label,
        "predict_times differs from the index at ilocs",
        f"{list(times)[:4]} against {list(X.index[ilocs])[:4]}",
    )
    return ilocs.astype(float)


def detector_options(max_bad: int = 2) -> st.SearchStrategy:
    exact = options(
        required=("method",),
        max_bad=max_bad,
        method=Opt(st.just("exact"), choice_of("EXACT", "pelt", "", None, 1)),
        na=Opt(st.integers(0, 2), choice_of(-1, 1.5, "1", None)),
        n_changes=Opt(choice_of(None, 0, 1, 3), choice_of(-1, 1.5, "2", np.nan)),
        penalty=Opt(
            choice_of(None, "bic", "aic", "lwz", 5.0, 50.0),
            choice_of(-1.0, np.nan, np.inf, "BIC", "mbic", [1.0]),
        ),
        min_size=Opt(choice_of(None, 3, 8), choice_of(0, -2, 2.5, "5")),
        cost=Opt(choice_of("rss", "normal"), choice_of("l2", "", None, 1)),
        fixed=Opt(choice_of(None, -1, 0), choice_of(99, "c", 1.5, [0, 0, 0, 0])),
    )
    group = options(
        required=("method",),
        max_bad=max_bad,
        method=Opt(st.just("group"), choice_of("Group", "l1", "sq")),
        na=Opt(st.integers(0, 2), choice_of(-1, 1.5, "1", None)),
        lam=Opt(choice_of(1.0, 10.0, 100.0), choice_of(0.0, -1.0, np.nan, np.inf, "auto", "x")),
        threshold=Opt(choice_of(0.1, 0.25, 0.9), choice_of(-0.5, 1.5, np.nan, "x")),
        noise_factor=Opt(choice_of(None, 2.0, 8.0), choice_of(-1.0, np.nan, "x")),
        min_distance=Opt(choice_of(1, 5, 10), choice_of(0, -1, 2.5, "3")),
        max_changes=Opt(choice_of(None, 1, 4), choice_of(-1, 1.5, "2")),
    )
    return st.one_of(exact, group)


@st.composite
def detector_cases(draw, max_bad: int = 2, edge: bool = True):
    data = draw(datasets(inputs=False, batch=False, forms=False, edge=edge, min_T=2, max_n=2))
    return data, draw(st.sampled_from(INDEXES)), draw(detector_options(max_bad))


@fuzz_test(detector_cases(), examples=1.0, valid=(detector_cases(0, edge=False),))
def test_ltv_change_point_detector(case):
    """LTVChangePointDetector: exact segmentation and the group-lasso detector."""
    data, index, kwargs = case
    x = np.asarray(data.x(), dtype=float).reshape(data.T, -1)
    check_call(ltv_detector, _frame(x, index, "x"), label="LTVChangePointDetector", **kwargs)
