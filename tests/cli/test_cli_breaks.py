"""``ltvmodels segments --response``: one regression's breaks, their intervals and criteria,
equal to the library's (and so to strucchange's, tests/reference)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.cli import main

pd = pytest.importorskip("pandas")


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def seatbelt_csv(tmp_path_factory):
    """log10 of the UK driver deaths with a date column, as a user's file would have it."""
    deaths = np.log10(ltv.datasets.uk_driver_deaths())
    frame = pd.DataFrame({"month": deaths.index.strftime("%Y-%m-%d"), "y": deaths.to_numpy()})
    path = tmp_path_factory.mktemp("breaks") / "seatbelt.csv"
    frame.to_csv(path, index=False)
    return path, deaths


def test_seatbelt_regression_equals_the_library(seatbelt_csv, capsys):
    path, deaths = seatbelt_csv
    argv = ["segments", path, "--response", "y", "--lags", "1,12", "--constant", "--time"]
    argv += ["month", "--n-changes", "2", "--trim", "0.1", "--confint", "0.9", "--json"]
    code, out, err = _run(argv, capsys)
    assert code == 0, err
    report = json.loads(out)
    # the library on the same regression: y_t on y_{t-1}, y_{t-12} and 1, from 1970 on
    values = deaths.to_numpy()
    phi = np.column_stack([values[11:-1], values[:-12], np.ones(values.size - 12)])
    y = pd.Series(values[12:], index=deaths.index[12:])
    seg = ltv.segment_regression(y, phi, n_changes=2, trim=0.1)
    assert report["regressors"] == ["y[t-1]", "y[t-12]", "const"]
    assert report["changepoints"] == seg.changepoints.tolist() == [46, 157]
    assert report["changepoint_times"] == ["1973-11-01", "1983-02-01"]
    np.testing.assert_array_equal(report["confint"]["rows"], seg.confint(0.9))
    assert report["confint"]["times"][0][1] == "1973-11-01"
    np.testing.assert_allclose(report["criteria"]["bic"], seg.criteria()["bic"], rtol=1e-12)
    assert report["criteria"]["best_bic"] == 0


def test_text_report_has_the_intervals_and_the_criteria(seatbelt_csv, capsys):
    path, _ = seatbelt_csv
    argv = ["segments", path, "--response", "y", "--lags", "1,12", "--constant"]
    code, out, err = _run([*argv, "--n-changes", "2", "--trim", "0.1", "--confint", "0.95"], capsys)
    assert code == 0, err
    assert "y ~ y[t-1] + y[t-12] + const" in out
    assert "33   46   56" in out  # strucchange's 95 % interval of the first break
    assert "BIC picks            0" in out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--state", "y"], "--state, --response: expected one of them"),
        ([], "--regressors: the regression has no regressor"),
        (["--constant", "--input", "month"], "--input: it belongs to a state-space recording"),
        (["--constant", "--confint", "1.5"], "--confint: expected a level in (0, 1)"),
        (["--constant", "--lags", "0"], "--lags: expected comma-separated integers >= 1"),
        (["--constant", "--lags", "500"], "--lags: a lag of 500 rows leaves none"),
    ],
)
def test_regression_errors(seatbelt_csv, capsys, extra, message):
    path, _ = seatbelt_csv
    code, _, err = _run(["segments", path, "--response", "y", *extra], capsys)
    assert code == 2 and message in err, err


def test_regression_options_need_a_response(seatbelt_csv, capsys):
    path, _ = seatbelt_csv
    code, _, err = _run(["segments", path, "--state", "y", "--confint", "0.9"], capsys)
    assert code == 2 and "--confint: it belongs to one regression" in err


def _seatbelt_regression(deaths):
    values = deaths.to_numpy()
    phi = np.column_stack([values[11:-1], values[:-12], np.ones(values.size - 12)])
    return pd.Series(values[12:], index=deaths.index[12:]), phi


@pytest.mark.parametrize("kind", ["supF", "sequential"])
def test_break_test_equals_the_library(seatbelt_csv, capsys, kind):
    path, deaths = seatbelt_csv
    argv = ["segments", path, "--response", "y", "--lags", "1,12", "--constant", "--time"]
    code, out, err = _run([*argv, "month", "--trim", "0.1", "--test", kind, "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)["test"]
    y, phi = _seatbelt_regression(deaths)
    test = ltv.break_test(y, phi, kind=kind, trim=0.1)
    assert report["statistic"] == pytest.approx(test.statistic, rel=1e-12)
    if kind == "supF":  # strucchange: supF 19.333, p = 0.0067, at 46
        assert report["pvalue"] == pytest.approx(test.pvalue, rel=1e-12)
        assert report["break_index"] == 46 and report["break_time"] == "1973-11-01"
    else:
        assert report["n_breaks"] == test.n_breaks
        np.testing.assert_allclose(report["statistics"], test.statistics, rtol=1e-12)


def test_fixed_regressors_by_name_and_index(seatbelt_csv, capsys):
    path, deaths = seatbelt_csv
    argv = ["segments", path, "--response", "y", "--lags", "1,12", "--constant"]
    argv += ["--n-changes", "2", "--trim", "0.1", "--json", "--fixed"]
    code, out, err = _run([*argv, "y[t-12],2"], capsys)
    assert code == 0, err
    report = json.loads(out)
    y, phi = _seatbelt_regression(deaths)
    seg = ltv.segment_regression(y.to_numpy(), phi, n_changes=2, trim=0.1, fixed=[1, 2])
    assert report["fixed"] == ["y[t-12]", "const"]
    assert report["changepoints"] == seg.changepoints.tolist()
    assert report["cost"] == pytest.approx(seg.cost, rel=1e-12)
    code, _, err = _run([*argv, "y[t-12]", "--test", "supF"], capsys)
    assert code == 2 and "--test: the tests are for a regression whose coefficients" in err
    code, _, err = _run([*argv, "nonesuch"], capsys)
    assert code == 2 and "fixed: expected" in err and "nonesuch" in err


def test_fixed_inputs_of_a_state_space_recording(tmp_path, capsys):
    data = ltv.systems.jump_linear(seed=0)
    path = tmp_path / "jl.csv"
    frame = pd.DataFrame({"x1": data.x[:, 0], "x2": data.x[:, 1], "u": data.u[:, 0]})
    frame.to_csv(path, index=False)
    argv = ["segments", path, "--state", "x1,x2", "--input", "u", "--n-changes", "1"]
    code, out, err = _run([*argv, "--fixed", "u", "--json"], capsys)
    assert code == 0, err
    model = ltv.fit_segments(data.x, data.u, n_changes=1, fixed=[2])
    report = json.loads(out)
    assert report["changepoints"] == model.changepoints.tolist() == [200]
    assert report["cost"] == pytest.approx(model.info["cost"], rel=1e-12)


def test_cost_normal_finds_a_change_of_the_noise_level(tmp_path, capsys):
    rng = np.random.default_rng(2)
    level = np.r_[rng.normal(0, 1, 300), rng.normal(0, 3, 300)]
    path = tmp_path / "noise.csv"
    pd.DataFrame({"level": level}).to_csv(path, index=False)
    argv = ["segments", path, "--response", "level", "--constant", "--n-changes", "3"]
    code, out, err = _run([*argv, "--cost", "normal", "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    seg = ltv.segment_regression(level, np.ones(600), n_changes=3, cost="normal")
    assert report["cost_name"] == "normal" and report["changepoints"] == seg.changepoints.tolist()
    np.testing.assert_allclose(report["segment_variances"], seg.segment_variances, rtol=1e-12)
    table = seg.criteria()
    assert report["criteria"]["best_bic"] == table["best_bic"]
    assert "lwz" not in report["criteria"]  # one noise variance for all segments is LWZ's model
    # a state-space recording: x[t+1] = 0.5 x[t] + e with the noise level changing
    x = np.zeros(600)
    for t in range(599):
        x[t + 1] = 0.5 * x[t] + (1.0 if t < 300 else 3.0) * rng.standard_normal()
    pd.DataFrame({"x": x}).to_csv(path, index=False)
    code, out, err = _run(
        ["segments", path, "--state", "x", "--n-changes", "1", "--cost", "normal", "--json"], capsys
    )
    assert code == 0, err
    report = json.loads(out)
    model = ltv.fit_segments(x, n_changes=1, cost="normal")
    assert report["changepoints"] == model.changepoints.tolist()
    assert abs(report["changepoints"][0] - 300) <= 12
    assert report["cost_name"] == "normal"


def test_bic_chooses_the_number_of_breaks_as_strucchange(seatbelt_csv, capsys):
    path, _ = seatbelt_csv
    argv = ["segments", path, "--response", "y", "--lags", "1,12", "--constant", "--trim", "0.1"]
    code, out, err = _run([*argv, "--n-changes", "8", "--penalty", "bic", "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["n_changes"] == 0 and report["penalty_rule"] == "bic"  # strucchange: 0
    code, out, err = _run([*argv, "--n-changes", "8", "--penalty", "lwz"], capsys)
    assert code == 0, err
    assert "LWZ picks among 0 … 8" in out
