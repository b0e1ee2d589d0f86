"""The sktime adapters: sktime's own conformance checks, and our answers through them.

``check_estimator`` runs every test sktime has for a forecaster and for a detector
on each configuration of ``get_test_params``. The adapters' forecasts, intervals,
quantiles and change points are compared with the library's functions called
directly (``fit_ar``/``fit_arx`` and ``forecast``, ``segment_regression``,
``fit_segments``, ``find_changepoints``) on the same data.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("sktime")

import ltvmodels as ltv  # noqa: E402
from ltvmodels.sktime import LTVChangePointDetector, LTVForecaster  # noqa: E402

# sktime's checks we leave out, each with its reason.
EXCLUDED = {
    LTVForecaster: [
        # Its data do not identify any AR(X) model: the univariate y is the ramp 0 … 24,
        # so y[t−1] − y[t−2] = 1 = the constant regressor, and each column of the
        # multivariate y is an X column plus 10 (both drawn from one seed), so y[t−1] − X[t−1]
        # is the constant. Our fit refuses such data with a SingularProblemError that names
        # the dependent combination of regressors, as every estimator of the library does,
        # instead of returning one of infinitely many answers.
        "test_update_with_exogenous_variables",
    ],
    LTVChangePointDetector: [],
}


@pytest.fixture(autouse=True)
def _quiet_sktime():
    """sktime announces a future change of its defaults on every fit; not ours to act on."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        yield


# Said by sktime's own checks, of its own code: predict_proba without the optional
# skpro, and pandas' coming change to concat's sorting inside sktime's evaluation.
@pytest.mark.filterwarnings("ignore:Forecasters' predict_proba requires skpro:UserWarning")
@pytest.mark.filterwarnings("ignore:Sorting by default when concatenating all DatetimeIndex")
@pytest.mark.parametrize("estimator", [LTVForecaster, LTVChangePointDetector])
def test_sktime_check_estimator(estimator):
    from sktime.utils.estimator_checks import check_estimator

    start = time.perf_counter()
    results = check_estimator(
        estimator, verbose=False, tests_to_exclude=EXCLUDED[estimator] or None
    )
    seconds = time.perf_counter() - start
    failed = {name: result for name, result in results.items() if result != "PASSED"}
    passed = len(results) - len(failed)
    print(f"{estimator.__name__}: {passed} of {len(results)} passed, {seconds:.0f} s")
    assert len(results) > 100  # the checks ran (their number depends on sktime's version)
    assert not failed, "\n".join(f"{name}: {result!r}"[:500] for name, result in failed.items())


# -- the forecaster against the library ------------------------------------------------------


def ar_series(T=150, seed=0, index=None):
    """An AR(2) whose resonance drifts, with a level (pandas Series)."""
    rng = np.random.default_rng(seed)
    y = np.zeros(T)
    for t in range(2, T):
        a1 = 1.2 + 0.4 * t / T
        y[t] = a1 * y[t - 1] - 0.8 * y[t - 2] + rng.standard_normal()
    return pd.Series(y + 5.0, index=index, name="level")


def test_forecasts_intervals_and_quantiles_are_those_of_fit_ar():
    y = ar_series()
    forecaster = LTVForecaster(na=2, lam=10.0, n_samples=600, seed=4).fit(y, fh=[1, 2, 3, 4, 5])
    model = ltv.fit_ar(y.to_numpy(), 2, lam=10.0, constant=True)
    direct = model.forecast(steps=5, level=0.8, n_samples=600, seed=4)
    np.testing.assert_allclose(forecaster.predict().to_numpy(), direct.mean[:, 0])
    np.testing.assert_allclose(forecaster.model_.k, model.k)
    interval = forecaster.predict_interval(coverage=0.8)
    np.testing.assert_allclose(interval[("level", 0.8, "lower")], direct.lower[:, 0])
    np.testing.assert_allclose(interval[("level", 0.8, "upper")], direct.upper[:, 0])
    quantiles = forecaster.predict_quantiles(alpha=[0.1, 0.5, 0.9])
    np.testing.assert_allclose(quantiles[("level", 0.1)], direct.lower[:, 0])
    np.testing.assert_allclose(quantiles[("level", 0.9)], direct.upper[:, 0])
    # the median: the Gaussian first step's mean, between the other quantiles after it
    assert quantiles[("level", 0.5)].iloc[0] == pytest.approx(direct.mean[0, 0])
    assert (quantiles[("level", 0.1)] < quantiles[("level", 0.5)]).all()
    assert (quantiles[("level", 0.5)] < quantiles[("level", 0.9)]).all()


def test_exogenous_forecasts_are_those_of_fit_arx():
    rng = np.random.default_rng(1)
    T = 140
    u = rng.standard_normal((T + 6, 1))
    y = np.zeros(T + 6)
    for t in range(1, T + 6):
        y[t] = 0.7 * y[t - 1] + (1.0 + t / T) * u[t - 1, 0] + 0.1 * rng.standard_normal()
    index = pd.date_range("2020-01-01", periods=T + 6, freq="D")
    Y, X = pd.Series(y, index=index), pd.DataFrame({"u": u[:, 0]}, index=index)
    forecaster = LTVForecaster(na=1, nb=2, nk=1, lam=20.0, constant=False, n_samples=400)
    forecaster.fit(Y[:T], X[:T], fh=[1, 2, 3, 4])
    predicted = forecaster.predict(X=X[T:])
    model = ltv.fit_arx(y[:T], u[:T], 1, 2, 1, lam=20.0)
    direct = model.forecast(steps=4, u=u[T : T + 4], n_samples=400, seed=0)
    np.testing.assert_allclose(predicted.to_numpy(), direct.mean[:, 0])
    assert list(predicted.index) == list(index[T : T + 4])
    with pytest.raises(ValueError, match=r"^X: expected .* pass X"):
        forecaster.predict(X=X[T : T + 1])  # a row short of step 4's input X[T+2]
    with pytest.raises(ValueError, match=r"^X: expected .* received None"):
        forecaster.predict()


def test_several_columns_are_a_var_model():
    rng = np.random.default_rng(2)
    y = np.zeros((120, 2))
    for t in range(1, 120):
        y[t] = np.array([[0.6, 0.2], [-0.1, 0.5]]) @ y[t - 1] + rng.standard_normal(2)
    frame = pd.DataFrame(y, columns=["a", "b"])
    predicted = LTVForecaster(na=1, lam=30.0).fit(frame, fh=[1, 2, 3]).predict()
    direct = ltv.fit_ar(y, 1, lam=30.0, constant=True).forecast(steps=3)
    assert list(predicted.columns) == ["a", "b"]
    np.testing.assert_allclose(predicted.to_numpy(), direct.mean)


def test_in_sample_predictions_are_the_one_step_predictions():
    y = ar_series(T=80)
    forecaster = LTVForecaster(na=2, lam=10.0).fit(y, fh=[-78, -10, -3, 0, 1])
    predicted = forecaster.predict()
    one_step = forecaster.model_.predict(y.to_numpy())  # y[2:]
    np.testing.assert_allclose(predicted.iloc[1:4].to_numpy(), one_step[[67, 74, 77]])
    assert np.isnan(predicted.iloc[0])  # sample 1: its lags y[−1] do not exist


@pytest.mark.parametrize("kind", ["range", "datetime", "period"])
def test_the_series_index_is_kept(kind):
    T = 90
    index = {
        "range": pd.RangeIndex(10, 10 + T),
        "datetime": pd.date_range("2001-01-31", periods=T, freq="ME"),
        "period": pd.period_range("1949-01", periods=T, freq="M"),  # as sktime's airline
    }[kind]
    y = ar_series(T=T, index=index)
    forecaster = LTVForecaster(na=2, lam=10.0, n_samples=200).fit(y, fh=[1, 2, 3])
    predicted = forecaster.predict()
    # the three samples after the last one, on the series' own axis
    expected = {
        "range": lambda: pd.RangeIndex(10 + T, 13 + T),
        "datetime": lambda: pd.date_range(index[-1], periods=4, freq="ME")[1:],
        "period": lambda: pd.period_range(index[-1] + 1, periods=3, freq="M"),
    }[kind]()
    assert list(predicted.index) == list(expected)
    model = ltv.fit_ar(y.to_numpy(), 2, lam=10.0, constant=True)
    direct = model.forecast(steps=3, n_samples=200)
    np.testing.assert_allclose(predicted.to_numpy(), direct.mean[:, 0])


def test_update_refits_on_all_the_data_or_keeps_the_model():
    y = ar_series(T=130)
    refit = LTVForecaster(na=2, lam=10.0).fit(y[:100], fh=[1, 2])
    refit.update(y[100:])
    np.testing.assert_allclose(
        refit.model_.k, ltv.fit_ar(y.to_numpy(), 2, lam=10.0, constant=True).k
    )
    kept = LTVForecaster(na=2, lam=10.0, update_mode="keep").fit(y[:100], fh=[1, 2])
    before = kept.model_.k.copy()
    kept.update(y[100:])
    np.testing.assert_array_equal(kept.model_.k, before)
    direct = kept.model_.forecast(y.to_numpy()[-2:], steps=2)  # from the new end
    np.testing.assert_allclose(kept.predict().to_numpy(), direct.mean[:, 0])


def test_the_forecaster_keeps_its_own_data_and_warns_of_nothing():
    """sktime's remember_data copy is off (it warns of a change of default when on); the
    forecaster's own copy serves updates and stays right when a user turns sktime's on."""
    y = ar_series(T=130)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        forecaster = LTVForecaster(na=2, lam=10.0).fit(y[:100], fh=[1, 2])
        forecaster.update(y[100:], update_params=False)
        predicted = forecaster.predict().to_numpy()
    direct = forecaster.model_.forecast(y.to_numpy()[-2:], steps=2)
    np.testing.assert_allclose(predicted, direct.mean[:, 0])
    remembering = LTVForecaster(na=2, lam=10.0).set_config(remember_data=True)
    remembering.fit(y[:100], fh=[1, 2]).update(y[100:])
    np.testing.assert_allclose(
        remembering.model_.k, ltv.fit_ar(y.to_numpy(), 2, lam=10.0, constant=True).k
    )


@pytest.mark.parametrize(
    ("options", "pattern"),
    [
        ({"na": 0}, r"^na: .*expected"),
        ({"update_mode": "online"}, r"^update_mode: "),
        ({"n_samples": 1}, r"^n_samples: "),
        ({"norm": "l2"}, r"norm"),
    ],
)
def test_invalid_options_name_the_argument(options, pattern):
    with pytest.raises(ValueError, match=pattern):
        LTVForecaster(lam=10.0, **options).fit(ar_series(T=60), fh=[1])


# -- the detector against the library --------------------------------------------------------


def mean_shifts(seed=0):
    rng = np.random.default_rng(seed)
    level = np.r_[np.zeros(70), 2.5 * np.ones(50), -1.0 * np.ones(60)]
    index = pd.date_range("2010-01-01", periods=level.size, freq="D")
    return pd.Series(level + rng.standard_normal(level.size), index=index)


def ar_switch(seed=0):
    rng = np.random.default_rng(seed)
    y = np.zeros(300)
    for t in range(1, 300):
        y[t] = (0.9 if t < 160 else -0.5) * y[t - 1] + rng.standard_normal()
    return pd.Series(y)


def test_exact_detector_is_segment_regression():
    x = mean_shifts()
    ones = np.ones((len(x), 1))
    found = LTVChangePointDetector(n_changes=2).fit(x).predict(x)
    assert list(found.columns) == ["ilocs"] and found["ilocs"].dtype == np.int64
    expected = ltv.segment_regression(x.to_numpy(), ones, n_changes=2).changepoints
    assert found["ilocs"].tolist() == list(expected) == [70, 120]
    times = LTVChangePointDetector(n_changes=2).fit(x).predict_times(x)
    assert list(times) == list(x.index[[70, 120]])
    by_bic = LTVChangePointDetector(penalty="bic", cost="normal").fit_predict(x)["ilocs"]
    bic = ltv.segment_regression(x.to_numpy(), ones, penalty="bic", cost="normal").changepoints
    assert by_bic.tolist() == list(bic)


def test_exact_ar_detector_is_fit_segments_on_the_lags():
    x = ar_switch()
    found = LTVChangePointDetector(na=1, n_changes=1).fit_predict(x)["ilocs"].tolist()
    y_out, phi = ltv.ar_regressors(x.to_numpy(), 1, constant=True)
    rows = ltv.segment_regression(y_out, phi, n_changes=1).changepoints
    model = ltv.fit_segments(x.to_numpy(), n_changes=1, constant=True)  # x[t+1] = a x[t] + c
    assert found == [int(rows[0]) + 1] == [int(model.changepoints[0]) + 1]
    assert abs(found[0] - 160) <= 3
    fixed = LTVChangePointDetector(na=1, n_changes=1, fixed=-1).fit_predict(x)["ilocs"]
    assert fixed.tolist() == [
        int(ltv.segment_regression(y_out, phi, n_changes=1, fixed=-1).changepoints[0]) + 1
    ]


def test_group_detector_is_find_changepoints_of_the_group_lasso():
    x = ar_switch(seed=3)
    found = LTVChangePointDetector(method="group", na=1, lam=20.0).fit_predict(x)["ilocs"]
    model = ltv.fit_ar(x.to_numpy(), 1, lam=20.0, norm="group", constant=True)
    expected = ltv.find_changepoints(model).sample_indices
    assert found.tolist() == list(expected) and len(expected) >= 1
    means = mean_shifts()
    found = LTVChangePointDetector(method="group", lam=30.0).fit_predict(means)["ilocs"]
    level = ltv.fit_regression(means.to_numpy(), np.ones((len(means), 1)), lam=30.0, norm="group")
    assert found.tolist() == list(ltv.find_changepoints(level).sample_indices)


def test_missing_samples_keep_their_positions():
    x = mean_shifts()
    gaps = x.copy()
    gaps.iloc[[5, 90, 150]] = np.nan
    found = LTVChangePointDetector(n_changes=2).fit_predict(gaps)["ilocs"].tolist()
    expected = ltv.segment_regression(gaps.to_numpy(), np.ones((len(x), 1)), n_changes=2)
    assert found == list(expected.changepoints)
    assert x.to_numpy()[5] == mean_shifts().to_numpy()[5]  # the caller's series untouched


def test_detector_errors_name_the_argument():
    x = mean_shifts()
    with pytest.raises(ValueError, match=r"^method: "):
        LTVChangePointDetector(method="dp").fit_predict(x)
    with pytest.raises(ValueError, match=r"^n_changes, penalty: expected None"):
        LTVChangePointDetector(method="group", n_changes=2).fit_predict(x)
    with pytest.raises(TypeError, match=r"^n_changes, penalty: expected one of them"):
        LTVChangePointDetector(n_changes=2, penalty=3.0).fit_predict(x)
