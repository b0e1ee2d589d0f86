"""``model.summary()``: a report with the fit's choices and a coefficient table, as text
(still a string) and as HTML for notebooks."""

from __future__ import annotations

import pickle
import re
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest
from dense_reference import simulate_ltv

import ltvmodels as ltv
from ltvmodels.results.summary import Summary

# Standard errors and estimates are shown to 4 significant digits.
SHOWN = 5e-4


def _jump_data(T: int = 120, change: int = 60, seed: int = 3):
    """A two-state system whose input gain jumps at ``change``, on a daily DatetimeIndex."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((T, 1))
    x = np.zeros((T, 2))
    A = np.array([[0.9, 0.1], [0.0, 0.8]])
    for t in range(T - 1):
        B = np.array([[0.0], [1.0 if t < change else 2.5]])
        x[t + 1] = A @ x[t] + B @ u[t] + 0.1 * rng.standard_normal(2)
    days = pd.date_range("2024-03-01", periods=T, freq="D")
    return (
        pd.DataFrame(x, index=days, columns=["pos", "vel"]),
        pd.DataFrame(u, index=days, columns=["force"]),
    )


def _field(summary: Summary, section: str, label: str) -> str:
    (found,) = [s for s in summary.sections if s.title == section]
    return dict(found.fields)[label]


def _tables(summary: Summary):
    (found,) = [s for s in summary.sections if s.title == "Coefficients"]
    return found.tables


def _check_segment_table(table, names, estimates, errors):
    """The rows are the coefficients with the model's estimates, errors and z-values, and
    each row is a line of the text report."""
    assert table.header == ("coefficient", "estimate", "std err", "z")
    assert [row[0] for row in table.rows] == names
    shown = np.array([[float(cell) for cell in row[1:]] for row in table.rows])
    np.testing.assert_allclose(shown[:, 0], estimates, rtol=SHOWN)
    np.testing.assert_allclose(shown[:, 1], errors, rtol=SHOWN)
    np.testing.assert_allclose(shown[:, 2], estimates / errors, rtol=5e-3)


def _text_has_row(text: str, row) -> bool:
    return re.search(r"\s+".join(map(re.escape, row)), text) is not None


def test_lti_table_shows_the_models_estimates_and_standard_errors():
    x, u, _ = simulate_ltv(5, T=80, n=2, m=1)
    model = ltv.fit_lti(x, u)
    summary = model.summary()
    (table,) = _tables(summary)
    assert table.caption == "constant over the steps 0–78"
    _check_segment_table(table, model.coefficient_names(), model.k[0], model.std()[0])
    assert all(_text_has_row(summary, row) for row in table.rows)
    assert "A[x0,x1]" in summary and "B[x1,u0]" in summary
    # n·p coefficients and n(n + 1)/2 noise covariance entries
    parameters = 2 * 3 + 3
    aic = float(_field(summary, "Criteria", "AIC"))
    assert aic == pytest.approx(-2 * model.loglik + 2 * parameters, rel=1e-5)
    bic = float(_field(summary, "Criteria", "BIC").split()[0])
    assert bic == pytest.approx(-2 * model.loglik + np.log(79) * parameters, rel=1e-5)
    assert _field(summary, "Model", "λ") == "∞ (constant coefficients)"
    assert _field(summary, "Noise", "variance").endswith("(estimated from the residuals)")


def test_piecewise_fit_has_one_block_per_segment_with_dates():
    x, u = _jump_data()
    model = ltv.fit_piecewise(x, u, [40, 80])
    summary = model.summary()
    # the change points' times: x[c + 1], the first state the new coefficients produce
    assert _field(summary, "Change points", "steps") == "40, 80"
    assert _field(summary, "Change points", "times") == "2024-04-11, 2024-05-21"
    tables = _tables(summary)
    assert [table.caption for table in tables] == [
        "segment 1 of 3: steps 0–39 (2024-03-02 – 2024-04-10)",
        "segment 2 of 3: steps 40–79 (2024-04-11 – 2024-05-20)",
        "segment 3 of 3: steps 80–118 (2024-05-21 – 2024-06-28)",
    ]
    for table, start in zip(tables, [0, 40, 80], strict=True):
        _check_segment_table(table, model.coefficient_names(), model.k[start], model.std()[start])
        assert f"  {table.caption}" in summary
    assert "B[vel,force]" in summary
    assert _field(summary, "Data", "time") == "2024-03-01 – 2024-06-28"
    assert _field(summary, "Data", "states") == "pos, vel"
    assert _field(summary, "Data", "inputs") == "force"
    assert _field(summary, "Model", "λ") == "∞ within the segments (change points given)"


def test_refined_auto_fit_says_how_lambda_was_chosen():
    x, u = _jump_data()
    model = ltv.fit(x, u, lam="auto", norm="group", refine=True)
    lam = model.info["first_step"]["lam"]
    assert model.info["lam_selection"]["method"] == "lcurve"
    summary = model.summary()
    assert _field(summary, "Model", "λ") == f"{lam:.4g} (L-curve), then refined piecewise"
    assert f"lam={lam:g} (group, then refined)" in repr(model)
    assert summary.startswith(repr(model))
    assert "found by a norm='group' fit" in _field(summary, "Model", "penalty")
    # the change points found count as parameters of the criteria
    changes = len(model.changepoints)
    assert changes >= 1
    assert _field(summary, "Criteria", "parameters").endswith(f"{changes} change point found")
    assert len(_tables(summary)) == changes + 1


def test_given_and_estimated_lambda_and_noise():
    x, u, _ = simulate_ltv(5, T=60, n=2, m=1)
    given = ltv.fit(x, u, lam=10.0, noise_var=0.04).summary()
    assert _field(given, "Model", "λ") == "10 (given)"
    assert _field(given, "Noise", "variance") == "x0 0.04, x1 0.04 (given)"
    assert _field(given, "Criteria", "log-likelihood").endswith("(log marginal likelihood)")
    assert _field(given, "Criteria", "AIC, BIC").startswith("not defined")
    chosen = ltv.fit(x, u, lam="auto")  # the marginal likelihood by default
    text = _field(chosen.summary(), "Model", "λ")
    assert text == f"{chosen.lam:.4g} (marginal likelihood)"
    assert _field(chosen.summary(), "Noise", "variance").endswith("(estimated)")


def test_smooth_fit_shows_first_last_min_max():
    x, u, _ = simulate_ltv(5, T=60, n=2, m=1)
    model = ltv.fit(x, u, lam=3.0)
    summary = model.summary()
    (table,) = _tables(summary)
    assert table.header == ("coefficient", "first", "last", "min", "max")
    shown = np.array([[float(cell) for cell in row[1:]] for row in table.rows])
    k = model.k
    expected = np.stack([k[0], k[-1], k.min(axis=0), k.max(axis=0)], axis=1)
    np.testing.assert_allclose(shown, expected, rtol=SHOWN)
    assert _field(summary, "Change points", "change points").startswith("every step")


def test_sparse_fit_reports_its_certificate_and_no_likelihood():
    x, u, _ = simulate_ltv(5, T=60, n=2, m=1)
    model = ltv.fit(x, u, lam=1.0, norm="group")
    assert "duality_gap" in model.status.details
    summary = model.summary()
    gap = model.status.details["duality_gap"]
    assert _field(summary, "Fit", "certificate").startswith(f"duality gap {gap:.3g}")
    assert _field(summary, "Fit", "iterations") == str(model.status.iterations)
    assert _field(summary, "Criteria", "log-likelihood").startswith("not defined (norm='group'")


def test_segmentation_states_its_choice():
    x, u = _jump_data()
    model = ltv.fit_segments(x, u, n_changes=1)
    summary = model.summary()
    assert _field(summary, "Model", "λ") == "none: 1 change (n_changes given)"
    assert _field(summary, "Fit", "status") == "optimal (success)"
    assert len(_tables(summary)) == 2


def test_ar_and_arx_models():
    rng = np.random.default_rng(0)
    y = np.zeros(150)
    for t in range(2, 150):
        a = 0.5 if t < 75 else -0.4
        y[t] = a * y[t - 1] + 0.2 * y[t - 2] + rng.standard_normal()
    ar = ltv.fit_ar(y, 2, lam=5.0, norm="group", refine=True)
    summary = ar.summary()
    assert _field(summary, "Model", "kind") == "AR, na = 2"
    assert _field(summary, "Data", "samples (T)") == "150"
    tables = _tables(summary)
    assert len(tables) == len(ar.changepoints) + 1
    for table, start in zip(tables, [0, *ar.changepoints], strict=True):
        _check_segment_table(table, ["y:y[t-1]", "y:y[t-2]"], ar.k[start], ar.std()[start])

    u = rng.standard_normal(150)
    arx = ltv.fit_arx(y, u, 1, 2, lam=np.inf)
    summary = arx.summary()
    assert _field(summary, "Model", "kind") == "ARX, na = 1, nb = 2, nk = 1"
    assert _field(summary, "Data", "inputs") == "u"
    (table,) = _tables(summary)
    assert [row[0] for row in table.rows] == arx.coefficient_names()
    _check_segment_table(table, arx.coefficient_names(), arx.k[0], arx.std()[0])


def test_regression_model():
    rng = np.random.default_rng(1)
    phi = rng.standard_normal((50, 2))
    y = phi @ np.array([1.5, -0.5]) + 0.1 * rng.standard_normal(50)
    model = ltv.fit_regression(y, phi, lam=np.inf)
    summary = model.summary()
    assert _field(summary, "Model", "kind") == "regression y_t = Θ_t φ_t + e_t"
    assert _field(summary, "Data", "regressors") == "phi0, phi1"
    (table,) = _tables(summary)
    _check_segment_table(table, model.coefficient_names(), model.k[0], model.std()[0])


def test_given_coefficients():
    model = ltv.LTVModel.from_arrays([[0.9, 0.1], [0.0, 0.8]], [[0.0], [1.0]], steps=5)
    summary = model.summary()
    assert _field(summary, "Fit", "status") == "— (coefficients given, not fitted)"
    (table,) = _tables(summary)
    assert table.rows[0] == ("A[x0,x0]", "0.9", "—", "—")


class _Tags(HTMLParser):
    """The tags of a document, checked to nest."""

    def __init__(self):
        super().__init__()
        self.open: list[str] = []
        self.seen: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.open.append(tag)
        self.seen.append(tag)

    def handle_endtag(self, tag):
        assert self.open and self.open.pop() == tag, f"</{tag}> closes nothing open"


def test_html_for_notebooks():
    x, u = _jump_data()
    x = x.rename(columns={"pos": "p<q"})  # a name that HTML must escape
    model = ltv.fit_piecewise(x, u, [60])
    page = model._repr_html_()
    assert page == model.summary()._repr_html_() == model.summary().as_html()
    tags = _Tags()
    tags.feed(page)
    tags.close()
    assert tags.open == []
    assert tags.seen.count("table") == 6 + 2  # six sections with fields, two segments
    assert "p&lt;q" in page and "p<q" not in page
    assert "A[p&lt;q,vel]" in page and "2024-04-30" in page


def test_summary_is_still_the_text():
    x, u, _ = simulate_ltv(5, T=40, n=2, m=1)
    model = ltv.fit(x, u, lam=2.0)
    summary = model.summary()
    text = summary.as_text()
    assert isinstance(summary, str) and type(text) is str
    assert str(summary) == text == summary and repr(summary) == text
    assert "Coefficients" in summary and text.startswith(repr(model))
    assert "\n".join(["before", summary]).endswith(text)
    copy = pickle.loads(pickle.dumps(summary))
    assert copy == summary and (copy.heading, copy.sections) == (summary.heading, summary.sections)
    assert not re.search(r"\bnan\b", text, re.IGNORECASE)
