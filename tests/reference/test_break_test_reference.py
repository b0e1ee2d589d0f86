"""supF, aveF and expF tests against R's strucchange (``Fstats`` + ``sctest``).

The reference values, with their data, are in ``strucchange/tests.json``, written by
``strucchange/tests.R``: the Nile, the UK seat-belt regression (``from = 0.1``), the
two generated series of ``confint.R`` and one without a break, and a grid of
Hansen's (1997) p-values (``pvalue.Fstats``). Where ``Rscript`` and strucchange are
installed, the script is also run live and its values compared to ours.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from r_reference import run_r_script

import ltvmodels as ltv
from ltvmodels.core import breaktests

HERE = Path(__file__).parent / "strucchange"
REFERENCE = json.loads((HERE / "tests.json").read_text())
KINDS = ("supF", "aveF", "expF")


def regression(case: dict) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(case["y"], dtype=float)
    X = case["X"]
    regressors = (
        np.reshape(X["values"], (X["rows"], X["cols"])) if X["cols"] else np.zeros((y.size, 0))
    )
    return y, np.column_stack([np.ones(y.size), regressors])


def check_case(case: dict) -> None:
    y, phi = regression(case)
    for kind, statistic, pvalue in zip(KINDS, case["statistics"], case["pvalues"]):
        test = ltv.break_test(y, phi, kind=kind, trim=case["from"][0])
        assert test.break_index == case["breakpoint"][0]
        assert test.f_rows[0] == case["first"][0]
        np.testing.assert_allclose(test.f_statistics, case["fstats"], rtol=1e-6)
        np.testing.assert_allclose(test.statistic, statistic, rtol=1e-6)
        np.testing.assert_allclose(test.lam, case["lambda"][0], rtol=1e-12)
        # strucchange's own p-value: Hansen's polynomial as it is, also past its peak
        raw = breaktests.hansen_pvalue(test.statistic, kind, phi.shape[1], test.lam, monotone=False)
        np.testing.assert_allclose(raw, pvalue, atol=1e-3)
        # ours holds the polynomial at its peak: equal below it, smaller past it (where
        # strucchange's rises back towards 1 for a clear break)
        assert test.pvalue == raw or test.pvalue < min(raw, 1e-3)


@pytest.mark.parametrize("case", REFERENCE["cases"], ids=lambda case: case["name"])
def test_f_statistics_and_tests_equal_strucchange(case):
    check_case(case)


def test_the_seatbelt_supf_is_strucchanges():
    case = next(case for case in REFERENCE["cases"] if case["name"] == "seatbelt")
    y, phi = regression(case)
    test = ltv.break_test(y, phi, trim=0.1)
    assert (round(test.statistic, 3), round(test.pvalue, 4), test.break_index) == (
        19.333,
        0.0067,
        46,
    )


def test_the_tests_equal_a_live_strucchange():
    live = run_r_script(HERE / "tests.R")
    for case in live["cases"]:
        check_case(case)
    check_pvalue_grid(live["pvalues"])


def check_pvalue_grid(grid: dict) -> None:
    points = zip(grid["statistic"], grid["k"], grid["lambda"], grid["type"], grid["pvalue"])
    for statistic, k, lam, kind, expected in points:
        raw = breaktests.hansen_pvalue(statistic, kind, int(k), lam, monotone=False)
        np.testing.assert_allclose(raw, expected, rtol=1e-12, atol=1e-14)
        ours = breaktests.hansen_pvalue(statistic, kind, int(k), lam)
        # held at the polynomial's peak: never above strucchange's, equal below the peak
        assert ours <= raw + 1e-15
        if ours != raw:
            assert statistic > 5 and raw > ours


def test_hansen_pvalues_equal_strucchanges_pvalue_fstats():
    check_pvalue_grid(REFERENCE["pvalues"])
    changed = sum(
        abs(breaktests.hansen_pvalue(s, t, int(k), lam) - p) > 1e-10
        for s, k, lam, t, p in zip(
            *(REFERENCE["pvalues"][key] for key in ("statistic", "k", "lambda", "type", "pvalue"))
        )
    )
    assert changed < 0.05 * len(REFERENCE["pvalues"]["pvalue"])  # only the large statistics


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("k", [1, 12, 40])
def test_hansen_pvalues_decrease_with_the_statistic(kind, k):
    x = np.linspace(0.0, 400.0, 161)
    for lam in (0.005, 0.2, 0.495, 1.0, 1.0004, 32.1, 1e5):
        p = np.array([breaktests.hansen_pvalue(v, kind, k, lam) for v in x])
        assert np.all((p >= 0) & (p <= 1))
        assert np.all(np.diff(p) <= 1e-15)
        assert p[0] > 0.5 > p[-1]


def test_the_critical_value_has_the_level_as_its_pvalue():
    case = REFERENCE["cases"][1]
    y, phi = regression(case)
    for kind in KINDS:
        test = ltv.break_test(y, phi, kind=kind, trim=0.1, level=0.01)
        p = breaktests.fstats_pvalue(test.critical_value, kind, 3, y.size, test.lam)
        assert p == pytest.approx(0.01, abs=1e-9)
        assert test.reject == (test.statistic > test.critical_value)


def test_the_tables_load_from_the_installed_package():
    from importlib import resources

    names = [entry.name for entry in resources.files("ltvmodels.core").joinpath("tables").iterdir()]
    assert {
        "hansen_1997_sup.txt",
        "hansen_1997_ave.txt",
        "hansen_1997_exp.txt",
        "bai_perron_2003.txt",
    } <= set(names)
    assert breaktests.hansen_table("supF").shape == (1000, 3)
    assert breaktests.hansen_table("expF").shape == (1000, 5)
