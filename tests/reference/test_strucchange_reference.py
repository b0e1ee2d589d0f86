"""Break-date confidence intervals against R's strucchange (``confint.breakpointsfull``).

The reference values, with their data, are in ``strucchange/confint.json``, written by
``strucchange/confint.R``: Nile ~ 1, the UK seat-belt regression
(log10 deaths ~ lag 1 + lag 12, ``h = 0.1``), and two generated series (two breaks;
one break with a noise level that changes). Where ``Rscript`` and strucchange are
installed, the script is also run live and its values compared to ours.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from r_reference import run_r_script

import ltvmodels as ltv

HERE = Path(__file__).parent / "strucchange"


def matrix(value: dict) -> np.ndarray:
    values = np.array([np.nan if v is None else v for v in value["values"]], dtype=float)
    return values.reshape(value["rows"], value["cols"])


def intervals(value: dict) -> np.ndarray:
    return matrix(value).reshape(-1, 3)


def our_segmentation(case: dict) -> ltv.Segmentation:
    y = np.asarray(case["y"], dtype=float)
    regressors = matrix(case["X"]) if case["X"]["cols"] else np.zeros((y.size, 0))
    phi = np.column_stack([np.ones(y.size), regressors])
    return ltv.segment_regression(y, phi, n_changes=len(case["breakpoints"]), trim=case["h"][0])


def check_case(case: dict) -> None:
    segmentation = our_segmentation(case)
    np.testing.assert_array_equal(segmentation.changepoints, case["breakpoints"])
    np.testing.assert_array_equal(segmentation.confint(0.95), intervals(case["confint_95"]))
    np.testing.assert_array_equal(segmentation.confint(0.90), intervals(case["confint_90"]))
    np.testing.assert_array_equal(
        segmentation.confint(0.95, het_reg=False, het_err=False),
        intervals(case["confint_95_homogeneous"]),
    )
    # each segment's coefficients and their covariance (coef, vcov.breakpointsfull)
    coefficients = segmentation.moments["coefficients"][:, :, 0]
    np.testing.assert_allclose(coefficients, matrix(case["coef"]), rtol=1e-9, atol=1e-12)
    covariances = np.array([matrix(v) for v in case["vcov"]])
    np.testing.assert_allclose(segmentation.vcov(), covariances, rtol=1e-8, atol=1e-15)
    frame = segmentation.to_frame()
    np.testing.assert_allclose(frame["std_err"], np.sqrt(np.diagonal(covariances, 0, 1, 2)).ravel())


REFERENCE = json.loads((HERE / "confint.json").read_text())


@pytest.mark.parametrize("case", REFERENCE["cases"], ids=lambda case: case["name"])
def test_break_date_intervals_equal_strucchange(case):
    check_case(case)


def test_break_date_intervals_equal_a_live_strucchange():
    live = run_r_script(HERE / "confint.R")
    for case in live["cases"]:
        check_case(case)


def test_intervals_are_dated_and_refused_where_they_cannot_be():
    case = REFERENCE["cases"][0]  # the Nile, 1871-1970
    years = np.arange(1871, 1971)
    import pandas as pd

    y = pd.Series(case["y"], index=pd.Index(years.astype(float), name="year"))
    segmentation = ltv.segment_regression(y, np.ones((100, 1)), n_changes=1, min_size=15)
    np.testing.assert_array_equal(segmentation.confint_times(), [[1896.0, 1899.0, 1903.0]])
    with pytest.raises(ValueError, match="level: expected a probability"):
        segmentation.confint(1.5)
    none = ltv.segment_regression(y, np.ones((100, 1)), n_changes=0)
    with pytest.raises(ValueError, match="no change points"):
        none.confint()
    two_outputs = ltv.segment_regression(
        np.column_stack([case["y"], case["y"]]), np.ones((100, 1)), n_changes=1
    )
    with pytest.raises(ValueError, match="for one regression equation"):
        two_outputs.confint()


def test_the_rss_and_bic_table_equals_strucchange_and_lwz_its_formula():
    # strucchange's summary(breakpoints(y ~ ylag1 + ylag12, h = 0.1), breaks = 8) on the
    # seat-belt data: the RSS of the optimal segmentation with 0 … 8 breaks and its
    # BIC, which counts the coefficients, the break dates and the noise variance; it
    # picks 0 breaks.
    case = next(case for case in REFERENCE["cases"] if case["name"] == "seatbelt")
    y = np.asarray(case["y"])
    phi = np.column_stack([np.ones(y.size), matrix(case["X"])])
    segmentation = ltv.segment_regression(y, phi, n_changes=8, trim=0.1)  # h = 0.1: 18 rows
    assert segmentation.min_size == 18
    table = segmentation.criteria()
    np.testing.assert_allclose(table["rss"], case["rss_table"], rtol=1e-9)
    np.testing.assert_allclose(table["bic"], case["bic_table"], rtol=1e-9)
    assert table["best_bic"] == int(np.argmin(case["bic_table"])) == 0
    n, m = y.size, np.arange(9)
    free = 3 * (m + 1) + m  # LWZ's p*: the coefficients and the break dates
    lwz = np.log(table["rss"] / (n - free)) + free * 0.299 * np.log(n) ** 2.1 / n
    np.testing.assert_allclose(table["lwz"], lwz, rtol=1e-12)
    with pytest.raises(ValueError, match="found with a penalty"):
        ltv.segment_regression(y, phi, penalty="bic", min_size=18).criteria()
    # strucchange's breakpoints(bp) picks by that BIC; so does n_changes=8 with penalty="bic"
    chosen = ltv.segment_regression(y, phi, n_changes=8, trim=0.1, penalty="bic")
    assert chosen.n_changes == 0 and chosen.penalty_rule == "bic" and chosen.penalty is None
    np.testing.assert_allclose(chosen.costs_by_n_changes, case["rss_table"], rtol=1e-9)


def test_trim_is_a_fraction_of_the_rows_and_excludes_min_size():
    y = np.asarray(REFERENCE["cases"][0]["y"])
    ones = np.ones((y.size, 1))
    assert ltv.segment_regression(y, ones, n_changes=1, trim=0.15).min_size == 15
    assert ltv.segment_regression(y, ones, n_changes=1, trim=0.001).min_size == 1  # p
    with pytest.raises(ValueError, match="trim, min_size: both give"):
        ltv.segment_regression(y, ones, n_changes=1, trim=0.15, min_size=15)
    with pytest.raises(ValueError, match=r"trim: expected a fraction of the rows in \(0, 0.5\)"):
        ltv.segment_regression(y, ones, n_changes=1, trim=0.5)
    d = ltv.systems.jump_linear(seed=0)
    model = ltv.fit_segments(d.x, d.u, n_changes=1, trim=0.15)
    assert model.info["min_size"] == int(0.15 * 399)


def test_the_summary_reports_the_breaks_their_intervals_and_the_criteria():
    case = REFERENCE["cases"][0]  # the Nile, 1871-1970
    import pandas as pd

    y = pd.Series(case["y"], index=pd.Index(np.arange(1871.0, 1971.0), name="year"))
    segmentation = ltv.segment_regression(y, np.ones((100, 1)), n_changes=2, trim=0.15)
    report = segmentation.summary()
    lines = report.splitlines()
    header = next(line for line in lines if "95 % from" in line).split()
    assert header[:5] == ["break", "95", "%", "from", "row"]
    first = next(line for line in lines if line.strip().startswith("1 "))
    lower, row, upper = segmentation.confint()[0]
    assert first.split()[1:4] == [f"{lower:g}", f"{row:g}", f"{upper:g}"]
    assert "BIC picks            1" in report  # as strucchange: one break for the Nile
    assert "segment 1 of 3" in report  # the model's coefficients per segment
    assert "<table" in segmentation._repr_html_()
