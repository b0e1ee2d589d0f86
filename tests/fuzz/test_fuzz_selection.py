"""Fuzz the choice of λ: select_lambda, select_lambda_regression and fit(lam="auto").

Norms "sq", "group", "l1" and "l0", every criterion (ml, gcv, lcurve, cv,
bic, aic) and invalid ones, candidate grids (valid, non-positive, NaN,
strings), fold counts, progress callbacks and the data recipes of
:mod:`fuzz_strategies`. The oracle requires a finite chosen λ > 0, finite
candidates and finite scores (:func:`fuzz_oracle.inspect_selection`), or a
documented error. These calls fit once per candidate, so they run fewer
examples than the other tests.
"""

from __future__ import annotations

import numpy as np
from fuzz_oracle import check_call
from fuzz_strategies import (
    CONSTANT,
    ORDER,
    WEIGHTS,
    Data,
    Opt,
    choice_of,
    counts,
    datasets,
    fuzz_test,
    options,
    resolve,
)
from hypothesis import strategies as st

import ltvmodels as ltv

METHODS = {
    "sq": ["ml", "gcv", "lcurve", "cv"],
    "group": ["lcurve", "cv"],
    "l1": ["lcurve", "cv"],
    "l0": ["bic", "aic"],
}

INVALID_METHOD = choice_of("ML", "bic", "gcv", "", "aic", None, 3, "lcurve ")
GRID = Opt(
    st.one_of(
        st.lists(st.floats(0.1, 100.0), min_size=2, max_size=6, unique=True),
        choice_of([1.0, 10.0, 100.0], np.logspace(-1, 2, 5)),
    ),
    choice_of(
        [],
        [0.0, 1.0],
        [-1.0, 1.0],
        [np.nan, 1.0],
        [np.inf, 1.0],
        "abc",
        5.0,
        [[1.0, 2.0]],
        [1e300, 1e-300],
        [1.0, 1.0],
    ),
)
COUNT_GRID = Opt(
    st.lists(st.integers(0, 4), min_size=1, max_size=4, unique=True),
    choice_of([], [-1], [1.5], ["2"], [10**6], 3),
)


def _progress(done, total):
    assert 0 <= done <= total


PROGRESS = Opt(choice_of(_progress, None), choice_of("bar", 3))


@st.composite
def selection_options(draw, max_bad: int = 2):
    """A norm, a matching (or, among the invalid draws, a foreign) criterion and options."""
    norm = draw(st.sampled_from(["sq", "sq", "group", "l1", "l0"]))
    method = Opt(choice_of(None, *METHODS[norm]), INVALID_METHOD)
    common = dict(method=method, weights=WEIGHTS, constant=CONSTANT, progress=PROGRESS)
    if norm == "l0":
        kw = draw(options(max_bad=max_bad, lams=COUNT_GRID, max_changes=counts(0, 4), **common))
    else:
        kw = draw(
            options(
                max_bad=max_bad,
                lams=GRID,
                order=ORDER,
                n_folds=Opt(st.integers(2, 5), choice_of(1, 0, -1, 1.5, "3", None, 10**6)),
                **common,
            )
        )
    if "progress" in kw and norm == "l0":
        kw.pop("progress")
    if draw(st.booleans()) or max_bad == 0:
        kw["norm"] = norm
    else:
        kw["norm"] = draw(choice_of("SQ", "l2", "", None, "piecewise"))
    return kw


HUGE = Data(30, 2, 1, seed=1, scale=1e300)
TINY = Data(30, 2, 1, seed=1, scale=1e-300)


@fuzz_test(
    datasets(max_T=40),
    selection_options(),
    examples=0.75,
    valid=(datasets(max_T=40, forms=False), selection_options(0)),
    explicit=[
        (HUGE, {"norm": "sq"}),
        (HUGE, {"norm": "group"}),
        (TINY, {"norm": "sq"}),
        (HUGE, {"norm": "l0"}),
        (Data(30, 2, 1, seed=1), {"norm": "l0"}),
    ],
)
def test_select_lambda(data, kwargs):
    """ltv.select_lambda on state-space data."""
    x, u = data.xu()
    kw = {
        k: resolve(v, K=data.K(kwargs.get("constant", False)), n=data.n, N=data.N, R=data.R)
        for k, v in kwargs.items()
    }
    check_call(ltv.select_lambda, x, u, **kw)


@st.composite
def regression_selection_options(draw, max_bad: int = 2):
    kw = draw(selection_options(max_bad))
    kw.pop("constant", None)
    kw.pop("max_changes", None)
    if kw.get("norm") == "l0":  # select_lambda_regression has no "l0"
        kw["norm"] = "sq"
        kw.pop("lams", None)
        kw["method"] = draw(choice_of(None, "ml", "gcv"))
    return kw


@fuzz_test(
    datasets(max_T=40),
    regression_selection_options(),
    examples=0.5,
    valid=(datasets(max_T=40, forms=False), regression_selection_options(0)),
    explicit=[(HUGE, {"norm": "sq"}), (TINY, {"norm": "group"})],
)
def test_select_lambda_regression(data, kwargs):
    """ltv.select_lambda_regression on (y, phi)."""
    y, phi = data.regression()
    kw = {k: resolve(v, K=1, n=data.n, N=data.N, R=data.R) for k, v in kwargs.items()}
    check_call(ltv.select_lambda_regression, y, phi, **kw)


@fuzz_test(
    datasets(max_T=40, forms=False),
    options(
        norm=Opt(choice_of("sq", "group", "l1"), choice_of("l0")),
        order=ORDER,
        constant=CONSTANT,
        refine=Opt(choice_of(False, True), choice_of(1)),
        progress=PROGRESS,
    ),
    examples=0.75,
    explicit=[(HUGE, {}), (HUGE, {"norm": "l1"})],
)
def test_fit_lam_auto(data, kwargs):
    """ltv.fit(lam="auto"): the selection inside a fit (with its progress callback)."""
    x, u = data.xu()
    kw = dict(kwargs)
    if kw.get("norm") in ("group", "l1"):
        kw["max_iter"] = 200
    check_call(ltv.fit, x, u, lam="auto", **kw)
