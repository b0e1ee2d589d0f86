"""The time axis of pandas data: sorted, without duplicates, on a regular grid, in every estimator.

Unsorted or repeated stamps are errors that say how to fix them; stamps missing
from a regular grid (a fixed step or a calendar frequency) become missing
samples, with a DataWarning; stamps on no grid are an error.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.validation.time import time_grid

pd = pytest.importorskip("pandas")

D = ltv.systems.jump_linear(T=200, change_at=100, seed=0)
DAYS = pd.date_range("2024-01-01", periods=200, freq="D")
X = pd.DataFrame(D.x, index=DAYS, columns=["p", "v"])
U = pd.DataFrame(D.u, index=DAYS, columns=["f"])
GAP = DAYS[80:95]


def blanked(frame, stamps):
    """``frame`` with NaN rows at ``stamps``."""
    out = frame.copy()
    out.loc[stamps] = np.nan
    return out


def state_fits(x, u, **extra):
    return {
        "fit": lambda: ltv.fit(x, u, lam=10.0, **extra),
        "fit group": lambda: ltv.fit(x, u, lam=2.0, norm="group", **extra),
        "fit_lti": lambda: ltv.fit_lti(x, u, **extra),
        "fit_piecewise": lambda: ltv.fit_piecewise(x, u, [100], **extra),
        "fit_segments": lambda: ltv.fit_segments(x, u, n_changes=1, **extra),
        "select_lambda": lambda: ltv.select_lambda(x, u, method="gcv", **extra),
    }


PHI = pd.DataFrame({"lag": X["p"].shift(1).fillna(0.0)})  # a regressor of the full series


def series_fits(y, **extra):
    # the rows of y: by stamp for days of DAYS, else by position (other stamps, same rows)
    phi = PHI.loc[y.index] if y.index.isin(PHI.index).all() else PHI.set_axis(y.index)
    if y.isna().any():  # blanked rows: the regressor is missing there too
        phi = phi.where(y.notna(), np.nan)
    return {
        "fit_regression": lambda: ltv.fit_regression(y, phi, lam=10.0, **extra),
        "segment_regression": lambda: ltv.segment_regression(y, phi, n_changes=1, **extra),
        "fit_ar": lambda: ltv.fit_ar(y, 2, lam=10.0, **extra),
        "fit_arx": lambda: ltv.fit_arx(y, phi, 1, 1, lam=10.0, **extra),
    }


def all_fits(x, u, **extra):
    return {**state_fits(x, u, **extra), **series_fits(x["p"], **extra)}


@pytest.mark.parametrize("name", sorted(all_fits(X, U)))
def test_unsorted_stamps_are_an_error_naming_the_row(name):
    order = np.r_[0:50, 51, 50, 52:200]
    with pytest.raises(ValueError, match=r"time index is not sorted: row 51 \(2024-02-20\)"):
        all_fits(X.iloc[order], U.iloc[order])[name]()


@pytest.mark.parametrize("name", sorted(all_fits(X, U)))
def test_a_repeated_stamp_is_an_error_naming_it(name):
    index = DAYS.delete(60).insert(60, DAYS[59])
    x, u = X.set_axis(index), U.set_axis(index)
    with pytest.raises(ValueError, match=r"2024-02-29 appears twice \(rows 59 and 60\)"):
        all_fits(x, u)[name]()


@pytest.mark.parametrize("name", sorted(all_fits(X, U)))
def test_stamps_missing_from_the_grid_are_missing_samples(name):
    # The gappy index gives the fit of the same data on the full grid with NaN rows.
    gappy = all_fits(X.drop(GAP), U.drop(GAP))[name]
    full = all_fits(blanked(X, GAP), blanked(U, GAP))[name]
    with pytest.warns(ltv.DataWarning, match="15 time stamps missing from the regular grid"):
        model = gappy()
    reference = full()
    if isinstance(model, ltv.LambdaSelection):
        assert model.lam == pytest.approx(reference.lam, rel=1e-12)
        return
    model = getattr(model, "model", model)  # a Segmentation's model
    reference = getattr(reference, "model", reference)
    np.testing.assert_allclose(model.k, reference.k, rtol=0, atol=1e-12)
    assert model.n_missing == reference.n_missing > 0
    np.testing.assert_array_equal(model.time, reference.time)


def test_calendar_grids_months_and_a_decimal_step():
    months = pd.date_range("2000-01-01", periods=120, freq="MS")
    y = pd.Series(D.x[:120, 0], index=months)
    with pytest.warns(ltv.DataWarning, match="3 time stamps missing"):
        model = ltv.fit_ar(y.drop(months[50:53]), 2, lam=100.0)
    np.testing.assert_array_equal(model.time, months.to_numpy())
    assert model.n_missing == 5  # the rows whose sample or lags fall in the gap
    tenths = np.round(np.arange(100) * 0.1, 10)
    x = pd.DataFrame(D.x[:100], index=tenths).drop(index=[2.0, 2.1])
    with pytest.warns(ltv.DataWarning, match="2 time stamps missing"):
        model = ltv.fit(x, lam=10.0)
    np.testing.assert_allclose(model.time, tenths)


def test_stamps_on_no_grid_are_an_error_that_says_how_to_resample():
    stamps = np.cumsum(np.random.default_rng(1).uniform(0.5, 1.5, 200))
    with pytest.raises(ValueError, match=r"no regular grid .*df\.resample.*regular=False"):
        ltv.fit(X.set_axis(stamps), lam=10.0)
    assert ltv.fit(X.set_axis(stamps).to_numpy(), lam=10.0).time is None  # rows consecutive


def the_model(result):
    return getattr(result, "model", result)  # a Segmentation's model


@pytest.mark.parametrize("name", sorted(all_fits(X, U)))
def test_regular_false_fits_the_rows_as_consecutive_and_keeps_their_stamps(name):
    days = np.cumsum(np.r_[0, np.random.default_rng(3).uniform(0.5, 1.5, 199)])  # no grid
    stamps = DAYS[0] + pd.to_timedelta(days, "D")
    irregular = all_fits(X.set_axis(stamps), U.set_axis(stamps), regular=False)[name]
    plain = all_fits(X, U)[name]  # the same rows on a regular daily grid
    gappy = all_fits(X.drop(GAP), U.drop(GAP), regular=False)[name]
    with warnings.catch_warnings():
        warnings.simplefilter("error", ltv.DataWarning)  # nothing is inserted: no notice
        model, gappy_model = irregular(), gappy()
    reference = plain()
    if isinstance(model, ltv.LambdaSelection):
        assert model.lam == pytest.approx(reference.lam, rel=1e-12)
        return
    model, reference, gappy_model = map(the_model, (model, reference, gappy_model))
    np.testing.assert_allclose(model.k, reference.k, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(model.time, stamps.to_numpy())
    assert gappy_model.n_missing == 0  # the rows around the gap are taken as consecutive
    np.testing.assert_array_equal(gappy_model.time, DAYS.drop(GAP).to_numpy())
    with pytest.raises(ValueError, match="time index is not sorted"):  # order still counts
        all_fits(X.iloc[::-1], U.iloc[::-1], regular=False)[name]()
    with pytest.raises(TypeError, match="regular"):
        all_fits(X, U, regular="no")[name]()


def test_regular_false_in_the_other_front_ends():
    stamps = np.cumsum(np.random.default_rng(2).uniform(0.5, 1.5, 200))
    x, u = X.set_axis(stamps), U.set_axis(stamps)
    with pytest.raises(ValueError, match="no regular grid"):
        ltv.kalman_smoother(x, u, lam=10.0)
    values = (D.x, D.u)
    for function, options in (
        (ltv.kalman_smoother, {"lam": 10.0}),
        (ltv.kalman_filter, {"lam": 10.0}),
        (ltv.fit_path, {"lams": [1.0, 10.0]}),
    ):
        ours, plain = function(x, u, regular=False, **options), function(*values, **options)
        first, second = (ours[-1], plain[-1]) if isinstance(ours, list) else (ours, plain)
        np.testing.assert_allclose(first.k, second.k, rtol=0, atol=1e-12)
    assert ltv.lambda_max(x, u, norm="group", regular=False) == pytest.approx(
        ltv.lambda_max(*values, norm="group"), rel=1e-12
    )
    y = x["p"]
    phi = PHI.set_axis(stamps)
    selection = ltv.select_lambda_regression(y, phi, method="gcv", regular=False)
    assert selection.lam == pytest.approx(
        ltv.select_lambda_regression(y.to_numpy(), phi.to_numpy(), method="gcv").lam, rel=1e-12
    )
    prior = ltv.GMMPrior(x, u, n_components=1, regular=False)
    reference = ltv.GMMPrior(*values, n_components=1)
    np.testing.assert_allclose(prior.A, reference.A, rtol=1e-10)
    with pytest.raises(ValueError, match="no regular grid"):
        ltv.GMMPrior(x, u, n_components=1)


def test_inputs_are_matched_to_the_states_by_their_stamps():
    ordered = ltv.fit(X, U, lam=10.0)
    shuffled = ltv.fit(X, U.iloc[::-1], lam=10.0)
    np.testing.assert_array_equal(shuffled.k, ordered.k)
    with pytest.raises(ValueError, match=r"u: its time index differs from the index of x"):
        ltv.fit(X, U.set_axis(DAYS + pd.Timedelta(hours=1)), lam=10.0)
    positional = ltv.fit(X, U.reset_index(drop=True), lam=10.0)  # no stamps: by position
    np.testing.assert_array_equal(positional.k, ordered.k)
    with pytest.raises(ValueError, match=r"\(u has 15 stamps that x lacks, the first 2024-03-21"):
        with pytest.warns(ltv.DataWarning):  # (x's own gap, announced before u is matched)
            ltv.fit(X.drop(GAP), U, lam=10.0)  # the inputs of the dropped days still there
    with pytest.raises(ValueError, match=r"\(x has 1 stamp that u lacks, the first 2024-01-01"):
        ltv.fit(X, U.iloc[1:], lam=10.0)


def test_weights_follow_their_transitions_onto_the_grid():
    weights = np.linspace(0.5, 2.0, 199)
    kept = ~DAYS.isin(GAP)
    with pytest.warns(ltv.DataWarning):
        gappy = ltv.fit(X[kept], U[kept], lam=10.0, weights=weights[kept[:-1]][: kept.sum() - 1])
    spread = np.ones(199)
    rows = np.flatnonzero(kept)
    consecutive = np.diff(rows) == 1
    spread[rows[:-1][consecutive]] = weights[kept[:-1]][: kept.sum() - 1][consecutive]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ltv.DataWarning)
        full = ltv.fit(blanked(X, GAP), blanked(U, GAP), lam=10.0, weights=spread)
    np.testing.assert_allclose(gappy.k, full.k, rtol=0, atol=1e-12)


def test_a_zone_keeps_its_local_days_across_daylight_saving_time():
    local = pd.date_range("2024-03-20", periods=200, freq="D", tz="Europe/Stockholm")
    x = X.set_axis(local)
    model = ltv.fit(x, lam=10.0)  # 23-hour and 25-hour days are one day each
    assert model.time.size == 200 and model.n_missing == 0
    with pytest.warns(ltv.DataWarning, match="1 time stamp missing"):
        gappy = ltv.fit(x.drop(local[10]), lam=10.0)
    np.testing.assert_array_equal(gappy.time, model.time)


def test_the_grid_of_stamps_directly():
    grid = time_grid(np.array([0.0, 1.0, 3.0, 4.0]), "t")
    np.testing.assert_array_equal(grid.time, [0.0, 1.0, 2.0, 3.0, 4.0])
    assert grid.inserted == 1 and grid.positions.tolist() == [0, 1, 3, 4]
    rows = grid.spread(np.arange(4.0).reshape(1, 4, 1))[0, :, 0]
    np.testing.assert_array_equal(np.isnan(rows), [False, False, True, False, False])
    assert time_grid(np.array([0.0, 1.0]), "t").inserted == 0


def test_fit_many_checks_each_units_stamps():
    rows = []
    for unit in range(2):
        stamps = DAYS[:120].delete(30) if unit else DAYS[:120]
        for t, stamp in enumerate(stamps):
            rows.append({"unit": unit, "day": stamp, "p": D.x[t, 0], "v": D.x[t, 1]})
    table = pd.DataFrame(rows)
    ms = ltv.fit_many(table, by="unit", state=["p", "v"], time="day", lam=10.0, n_jobs=1)
    assert ms.summary.loc[0, "missing"] == 0 and ms.summary.loc[1, "missing"] == 2
    assert "DataWarning: x: 1 time stamp missing" in ms.summary.loc[1, "warnings"]
    twice = pd.concat([table, table.iloc[[5]]])
    ms = ltv.fit_many(twice, by="unit", state=["p", "v"], time="day", lam=10.0, n_jobs=1)
    assert 0 in ms.errors and "duplicated time stamp" in ms.errors[0] and 1 not in ms.errors


def test_the_command_line_keeps_the_same_rules(tmp_path, capsys):
    from ltvmodels.cli import main

    table = pd.DataFrame({"day": DAYS.strftime("%Y-%m-%d"), "p": D.x[:, 0], "v": D.x[:, 1]})
    swapped = table.iloc[np.r_[0:50, 51, 50, 52:200]]
    swapped.to_csv(tmp_path / "swapped.csv", index=False)
    argv = ["--state", "p,v", "--time", "day", "--lam", "10", "--json"]
    assert main(["fit", str(tmp_path / "swapped.csv"), *argv]) == 2
    assert "--time: the time index is not sorted: row 51" in capsys.readouterr().err
    table.drop(range(80, 95)).to_csv(tmp_path / "gappy.csv", index=False)
    assert main(["fit", str(tmp_path / "gappy.csv"), *argv]) == 0
    out = capsys.readouterr()
    assert "15 time stamps missing" in out.err
    import json

    report = json.loads(out.out)
    assert report["T"] == 200 and report["n_missing"] == 16


def test_a_mixture_prior_is_on_the_grid_of_the_fit():
    pytest.importorskip("sklearn")
    x, u = X.drop(GAP), U.drop(GAP)
    with pytest.warns(ltv.DataWarning):
        prior = ltv.GMMPrior(x, u, n_components=1, seed=0)
    with pytest.warns(ltv.DataWarning):
        along = prior.at(x, u)
    with pytest.warns(ltv.DataWarning):
        model = ltv.fit(x, u, lam=10.0, prior=along)
    assert model.N == len(DAYS) - 1
    with pytest.raises(ValueError, match="time index is not sorted"):
        ltv.GMMPrior(X.iloc[::-1], U.iloc[::-1])


@pytest.mark.parametrize(
    ("index", "expected"),
    [
        (pd.date_range("2000-01-01", periods=120, freq="MS"), ["2010-01-01", "2010-02-01"]),
        (pd.date_range("1900-01-01", periods=120, freq="YS"), ["2020-01-01", "2021-01-01"]),
        (
            pd.date_range("2024-01-01", periods=120, freq="h"),
            ["2024-01-06 00:00", "2024-01-06 01:00"],
        ),
    ],
)
def test_forecasts_continue_the_calendar(index, expected):
    y = pd.Series(D.x[:120, 0], index=index)
    forecast = ltv.fit_ar(y, 2, lam=100.0).forecast(y.iloc[-2:], steps=2)
    np.testing.assert_array_equal(forecast.time, pd.to_datetime(expected).to_numpy())


def test_forecasts_continue_a_decimal_step_and_the_command_line_a_month(tmp_path, capsys):
    y = pd.Series(D.x[:150, 0], index=np.round(np.arange(150) * 0.1, 10))
    forecast = ltv.fit_ar(y, 2, lam=100.0).forecast(y.iloc[-2:], steps=3)
    np.testing.assert_allclose(forecast.time, [15.0, 15.1, 15.2], rtol=0, atol=1e-12)
    from ltvmodels.cli import main

    months = pd.date_range("2000-01-01", periods=120, freq="MS").strftime("%Y-%m-%d")
    path = tmp_path / "monthly.csv"
    pd.DataFrame({"date": months, "p": D.x[:120, 0], "v": D.x[:120, 1]}).to_csv(path, index=False)
    model = tmp_path / "m.npz"
    argv = [
        "fit",
        str(path),
        "--state",
        "p,v",
        "--time",
        "date",
        "--lam",
        "30",
        "--out",
        str(model),
    ]
    assert main(argv) == 0
    capsys.readouterr()
    assert main(["forecast", str(model), str(path), "--steps", "2", "--json"]) == 0
    import json

    assert json.loads(capsys.readouterr().out)["time"] == ["2010-01-01", "2010-02-01"]


def test_a_forecast_is_a_frame_on_the_data_calendar():
    months = pd.date_range("2000-01-01", periods=120, freq="MS")
    y = pd.Series(D.x[:120, 0], index=months, name="level")
    forecast = ltv.fit_ar(y, 2, lam=100.0).forecast(y.iloc[-2:], steps=3, level=0.9)
    frame = forecast.to_frame()
    assert list(frame.columns) == ["level", "level lower", "level upper"]
    assert frame.index.name == "time" and frame.index[0] == pd.Timestamp("2010-01-01")
    np.testing.assert_array_equal(frame["level"].to_numpy(), forecast.mean[:, 0])
    np.testing.assert_array_equal(frame["level upper"].to_numpy(), forecast.upper[:, 0])
    plain = ltv.fit_ar(D.x[:120, 0], 2, lam=100.0).forecast(D.x[118:120, 0], steps=2)
    assert plain.to_frame().index.name == "t" and plain.to_frame().index[0] == 120


def test_a_segmentation_of_a_dated_regression_dates_its_changes():
    y = pd.Series(np.r_[np.ones(100), 3 * np.ones(100)] * D.u[:, 0], index=DAYS)
    phi = pd.DataFrame({"u": D.u[:, 0]}, index=DAYS)
    seg = ltv.segment_regression(y, phi, n_changes=1)
    assert seg.changepoints.tolist() == [100]
    assert seg.changepoint_times[0] == DAYS[100]  # y[c], the first row of the new segment
    np.testing.assert_array_equal(seg.model.changepoint_times, seg.changepoint_times)
    assert (
        ltv.segment_regression(y.to_numpy(), phi.to_numpy(), n_changes=1).changepoint_times is None
    )


def test_a_table_is_read_column_by_column():
    # A text column is named; pandas' missing values (pd.NA, None) are missing samples.
    table = X.assign(label="k")
    with pytest.raises(TypeError, match=r"x: column 'label' holds values that are not numbers"):
        ltv.fit(table, lam=10.0)
    with pytest.raises(TypeError, match=r"y: expected numbers, received '1\.5'"):
        ltv.fit_ar(pd.Series(["1.5"] * 50), 2, lam=10.0)
    reference = ltv.fit(blanked(X, DAYS[3:4]), lam=10.0)
    objects = X.astype(object)
    objects.iloc[3] = pd.NA
    nullable = X.astype("Float64")
    nullable.iloc[3] = pd.NA
    for table in (objects, nullable):
        model = ltv.fit(table, lam=10.0)
        np.testing.assert_array_equal(model.k, reference.k)
        assert model.n_missing == 2


def test_a_refined_fit_shows_the_lambda_that_chose_its_changes():
    model = ltv.fit(D.x, D.u, lam="auto", norm="group", refine=True)
    chosen = model.info["lam_selection"]["lam"]
    assert f"lam={chosen:g} (group, then refined)" in repr(model)
    assert "lam=inf" not in repr(model) and model.norm == "piecewise"


def test_a_forecast_level_needs_a_representable_tail():
    model = ltv.fit(D.x, D.u, lam=10.0)
    with pytest.raises(ValueError, match="level: expected a probability in \\(0, 1\\) whose tails"):
        model.forecast(D.x[-1], np.zeros(3), level=1 - 1e-16)
    assert model.forecast(D.x[-1], np.zeros(3), level=1 - 1e-12).upper.shape == (3, 2)


def test_the_command_line_never_writes_over_its_data_and_says_a_given_noise_variance(
    tmp_path, capsys
):
    from ltvmodels.cli import main

    path = tmp_path / "data.csv"
    pd.DataFrame({"p": D.x[:, 0], "v": D.x[:, 1], "f": D.u[:, 0]}).to_csv(path, index=False)
    before = path.read_text()
    argv = ["fit", str(path), "--state", "p,v", "--input", "f", "--lam", "10"]
    assert main([*argv, "--coef-out", str(path)]) == 2
    assert "coef-out:" in capsys.readouterr().err and path.read_text() == before
    assert main([*argv, "--noise-var", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "noise variance: p 0.1, v 0.1 (given)" in out
    assert main(argv) == 0 and "(estimated from the residuals)" in capsys.readouterr().out


def test_each_trajectory_of_a_list_is_checked_and_placed_on_its_grid():
    second = X + 0.01
    with pytest.raises(ValueError, match=r"x\[1\]: the time index is not sorted: row 51"):
        ltv.fit([X, second.iloc[np.r_[0:50, 51, 50, 52:200]]], lam=10.0)
    with pytest.raises(ValueError, match=r"x\[1\]: its columns \['a', 'b'\] differ"):
        ltv.fit([X, second.set_axis(["a", "b"], axis=1)], lam=10.0)
    with pytest.warns(ltv.DataWarning, match="15 time stamps missing"):
        gappy = ltv.fit([X.drop(GAP), second.drop(GAP)], [U.drop(GAP), U.drop(GAP)], lam=10.0)
    full = ltv.fit([blanked(X, GAP), blanked(second, GAP)], [blanked(U, GAP)] * 2, lam=10.0)
    np.testing.assert_allclose(gappy.k, full.k, rtol=0, atol=1e-12)
    assert gappy.n_missing == full.n_missing == 32 and gappy.data.n_trajectories == 2
    assert gappy.state_names == ["p", "v"] and gappy.input_names == ["f"]  # the tables' names


def test_the_command_line_forecast_of_an_arx_model_is_the_model_forecast(tmp_path, capsys):
    # The inputs of the forecast: the recorded ones at the lags, then the future ones.
    from ltvmodels.cli import main

    rng = np.random.default_rng(0)
    u = rng.standard_normal(200)
    y = np.zeros(200)
    for t in range(2, 200):
        y[t] = 0.5 * y[t - 1] - 0.2 * y[t - 2] + 1.5 * u[t - 1] + 0.05 * rng.standard_normal()
    model = ltv.fit_arx(pd.Series(y, name="y"), pd.Series(u, name="u"), 2, 1, lam=100.0)
    model.save(tmp_path / "arx.npz")
    pd.DataFrame({"y": y, "u": u}).to_csv(tmp_path / "data.csv", index=False)
    future = rng.standard_normal(3)
    pd.DataFrame({"u": future}).to_csv(tmp_path / "future.csv", index=False)
    argv = ["forecast", str(tmp_path / "arx.npz"), str(tmp_path / "data.csv"), "--steps", "3"]
    assert main([*argv, "--future-input", str(tmp_path / "future.csv"), "--json"]) == 0
    import json

    report = json.loads(capsys.readouterr().out)
    expected = model.forecast(y[-model.lag :], np.r_[u[-model.lag :], future], steps=3)
    np.testing.assert_allclose(np.array(report["mean"])[:, 0], expected.mean[:, 0], rtol=1e-12)


def test_fit_many_passes_regular_to_each_unit():
    rows = []
    for unit in range(2):
        d = ltv.systems.jump_linear(T=100, change_at=50, seed=unit)
        t = np.cumsum(np.random.default_rng(unit).uniform(0.5, 1.5, 100))
        rows.append(pd.DataFrame({"unit": unit, "t": t, "p": d.x[:, 0], "v": d.x[:, 1]}))
    table = pd.concat(rows)
    options = dict(by="unit", state=["p", "v"], time="t", lam=10.0, n_jobs=1, progress=False)
    refused = ltv.fit_many(table, **options)
    assert set(refused.errors) == {0, 1}
    assert all("regular=False" in message for message in refused.errors.values())
    models = ltv.fit_many(table, regular=False, **options)
    assert not models.errors
    for unit, rows_of_unit in zip(range(2), rows):
        plain = ltv.fit(rows_of_unit[["p", "v"]].to_numpy(), lam=10.0)
        np.testing.assert_allclose(models[unit].k, plain.k, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(models[unit].time, rows_of_unit["t"].to_numpy())


# -- the parity matrix: every estimator x every kind of index -> the documented outcome --
T_MATRIX = 200
INDEX_KINDS = {
    "daily": ("ok", DAYS),
    "hourly": ("ok", pd.date_range("2024-01-01", periods=T_MATRIX, freq="h")),
    "month-start": ("ok", pd.date_range("1990-01-01", periods=T_MATRIX, freq="MS")),
    "year-start": ("ok", pd.date_range("1800-01-01", periods=T_MATRIX, freq="YS")),
    "numeric regular": ("ok", pd.Index(1950.0 + 0.5 * np.arange(T_MATRIX))),
    "numeric with gaps": (
        "gap",
        pd.Index(np.delete(np.arange(T_MATRIX + 5.0), [40, 41, 90, 91, 92])),
    ),
    "gappy daily": (
        "gap",
        DAYS[:50].append(DAYS[55:]).append(pd.date_range(DAYS[-1], periods=6)[1:]),
    ),
    "shuffled": ("unsorted", DAYS[np.r_[1, 0, 2:T_MATRIX]]),
    "duplicated": ("duplicated", DAYS[np.r_[0, 0, 2:T_MATRIX]]),
    "irregular": (
        "no grid",
        DAYS[0]
        + pd.to_timedelta(np.cumsum(np.random.default_rng(5).uniform(0.5, 1.5, T_MATRIX)), "D"),
    ),
}
OUTCOMES = {
    "unsorted": "time index is not sorted",
    "duplicated": "appears twice",
    "no grid": "has no regular grid",
}


def every_estimator(x, u):
    """Each estimator that reads data, on states x and inputs u (the AR/regression ones on
    x's first column)."""
    fits = all_fits(x, u)
    fits["kalman_smoother"] = lambda: ltv.kalman_smoother(x, u, lam=10.0)
    fits["select_lambda_regression"] = lambda: ltv.select_lambda_regression(
        x["p"], x["v"], method="gcv"
    )
    fits["GMMPrior"] = lambda: ltv.GMMPrior(x, u, n_components=1)
    return fits


@pytest.mark.parametrize("kind", sorted(INDEX_KINDS))
def test_every_estimator_keeps_the_time_rules_on_every_kind_of_index(kind):
    outcome, index = INDEX_KINDS[kind]
    x, u = X.set_axis(index), U.set_axis(index)
    for name, run in every_estimator(x, u).items():
        if outcome in OUTCOMES:
            with pytest.raises(ValueError, match=OUTCOMES[outcome]):
                run()
            continue
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = run()
        notices = [w for w in caught if issubclass(w.category, ltv.DataWarning)]
        assert len(notices) == (outcome == "gap"), (name, [str(w.message) for w in notices])
        model = getattr(result, "model", result)
        if hasattr(model, "n_missing") and hasattr(model, "time"):
            assert (model.n_missing > 0) == (outcome == "gap"), name
            if outcome == "ok":
                expected = index.to_numpy()
                if np.issubdtype(expected.dtype, np.datetime64):
                    expected = expected.astype("datetime64[ns]")
                np.testing.assert_array_equal(model.time, expected, err_msg=name)


def test_a_decimal_step_is_the_sampling_period_and_continues_in_forecasts():
    # np.arange(T) * 0.1 has steps that differ in their last bits: to_statespace took
    # them for an irregular axis and exported dt = 1.
    pytest.importorskip("control.statesp")
    x = pd.DataFrame(D.x, index=np.arange(200) * 0.1, columns=["p", "v"])
    model = ltv.fit(x, U.set_axis(x.index), lam=10.0)
    assert model.to_statespace().dt == pytest.approx(0.1, rel=1e-12)
    forecast = model.forecast(D.x[-1], D.u[-3:], noise_cov=np.eye(2))
    np.testing.assert_allclose(forecast.time, [20.0, 20.1, 20.2], rtol=0, atol=1e-12)


def test_time_spans_are_kept_in_seconds():
    # A TimedeltaIndex of 10 ms was kept in numpy's raw unit (10000.0 microseconds):
    # model.time, forecast times and the exported dt were in that unit.
    pytest.importorskip("control.statesp")
    spans = pd.to_timedelta(np.arange(200) * 10, unit="ms")
    model = ltv.fit(X.set_axis(spans), U.set_axis(spans), lam=10.0)
    np.testing.assert_allclose(model.time, np.arange(200) * 0.01, rtol=0, atol=1e-12)
    assert model.to_statespace().dt == pytest.approx(0.01, rel=1e-12)
    forecast = model.forecast(D.x[-1], D.u[-2:], noise_cov=np.eye(2))
    np.testing.assert_allclose(forecast.time, [2.0, 2.01], rtol=0, atol=1e-12)
    with pytest.warns(ltv.DataWarning, match="2 time stamps missing"):  # on the grid as numbers
        gappy = ltv.fit(X.set_axis(spans).drop(spans[[50, 51]]), lam=10.0)
    np.testing.assert_allclose(gappy.time, model.time, rtol=0, atol=1e-12)


def test_fit_many_keeps_a_time_span_column_in_seconds():
    # The column's nanoseconds became the models' times and the summary's change times.
    spans = pd.to_timedelta(np.arange(200) * 10, unit="ms")
    table = pd.DataFrame({"unit": "a", "t": spans, "p": D.x[:, 0], "v": D.x[:, 1], "f": D.u[:, 0]})
    ms = ltv.fit_many(
        table,
        by="unit",
        state=["p", "v"],
        inputs="f",
        time="t",
        method="segments",
        n_changes=1,
        n_jobs=1,
    )
    model = ms["a"]
    np.testing.assert_allclose(model.time, np.arange(200) * 0.01, rtol=0, atol=1e-12)
    (change,) = ms.summary.loc["a", "change_times"]
    assert change == pytest.approx(model.changepoint_times[0]) and 0.5 < change < 1.5


def test_fit_many_rejects_a_used_column_name_that_the_table_repeats():
    # frame["p"] is then a table, and the split failed with an AttributeError.
    table = pd.DataFrame(np.c_[np.zeros(200), D.x, D.x[:, 0]], columns=["unit", "p", "v", "p"])
    with pytest.raises(ValueError, match=r"^state: column 'p' appears twice \(columns 1 and 3\)"):
        ltv.fit_many(table, by="unit", state=["p", "v"], lam=10.0, n_jobs=1)
    unused = table.set_axis(["unit", "p", "note", "note"], axis=1)  # a repeat left aside
    assert ltv.fit_many(unused, by="unit", state=["p"], lam=10.0, n_jobs=1).errors == {}


@pytest.mark.parametrize(
    "call, message",
    [
        (
            lambda x, u: ltv.fit(
                x.assign(v=np.where(np.arange(200) == 3, np.inf, x["v"])), u, lam=1.0
            ),
            r"^x: expected finite values or NaN \(missing\), received inf \(first in column "
            r"'v', at row Timestamp\('2024-01-04 00:00:00'\)\)",
        ),
        (
            lambda x, u: ltv.fit(x.assign(v=x["v"] * 1e200), u, lam=1.0),
            r"^x: column 'v' has values of magnitude up to .* too large",
        ),
        (
            lambda x, u: ltv.fit(x.assign(v=np.nan), u, lam=1.0),
            r"^x: state 'v' has no observed samples",
        ),
        (
            lambda x, u: ltv.fit(x, u.assign(f=np.nan), lam=1.0),
            r"^u: input 'f' has no observed samples",
        ),
        (
            lambda x, u: ltv.fit_regression(x[["p"]], x.assign(v=np.nan), lam=1.0),
            r"^phi: regressor 'v' has no observed samples",
        ),
        (
            lambda x, u: ltv.fit_ar(x.assign(v=np.nan), 1, lam=1.0),
            r"^y: output 'v' has no observed samples",
        ),
        (
            lambda x, u: ltv.fit_arx(x["p"], u.assign(f=np.nan), 1, 1, lam=1.0),
            r"^u: input 'f' has no observed samples",
        ),
        (
            lambda x, u: ltv.ar_regressors(x.assign(v=x["v"] * 1e-200), 1),
            r"^y: column 'v' has values of magnitude up to .* too small",
        ),
    ],
)
def test_every_rejection_of_a_table_names_the_column(call, message):
    # They said "column 1", "state 1" (positions), "at index (3, 1)", or blamed y for a
    # regressor that is never observed ("too few observed samples").
    with pytest.raises(ValueError, match=message):
        call(X, U)


def test_fit_many_names_the_column_of_a_unit_that_fails():
    table = pd.DataFrame({"unit": "a", "p": D.x[:, 0], "v": D.x[:, 1] * 1e200})
    ms = ltv.fit_many(table, by="unit", state=["p", "v"], lam=10.0, n_jobs=1)
    assert "x: column 'v' has values of magnitude up to" in ms.errors["a"]
