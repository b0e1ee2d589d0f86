"""Fuzz the regression front-ends: fit_regression, fit_ar, fit_arx, ar_regressors,
arx_regressors, segment_regression and noise_variance_estimate.

The data recipes of :mod:`fuzz_strategies` give (y, φ) pairs (y_t = x[t+1],
φ_t = [x[t]; u[t]]) and series for the AR/ARX models in every form and with
every defect; orders, lags (na, nb, nk), λ, norms, weights and priors are
drawn valid or invalid. :func:`fuzz_oracle.check_call` judges each outcome.
"""

from __future__ import annotations

import warnings

import numpy as np
from fuzz_oracle import check_call, expect
from fuzz_strategies import (
    BOOL,
    CONSTANT,
    HUBER_DELTA,
    LAM,
    LOSS,
    MAX_ITER,
    NOISE_VAR,
    NORM,
    ORDER,
    PRIOR,
    PRIOR_MODE,
    SPARSE_LAM,
    TOL,
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

SPARSE_NORM = Opt(choice_of("group", "l1"), NORM.invalid)
HUGE = Data(30, 2, 1, seed=1, scale=1e300)
TINY = Data(30, 2, 1, seed=1, scale=1e-300)


def regression_options(max_bad: int = 2) -> st.SearchStrategy:
    common = dict(order=ORDER, weights=WEIGHTS)
    sq = options(
        required=("lam",),
        max_bad=max_bad,
        lam=LAM,
        norm=NORM,
        noise_var=NOISE_VAR,
        compute_cov=BOOL,
        prior=PRIOR,
        prior_mode=PRIOR_MODE,
        **common,
    )
    sparse = options(
        required=("lam", "norm", "max_iter"),
        max_bad=max_bad,
        lam=SPARSE_LAM,
        norm=SPARSE_NORM,
        max_iter=Opt(st.integers(1, 300), MAX_ITER.invalid),
        tol=TOL,
        **common,
    )
    huber = options(
        required=("lam", "loss"),
        max_bad=max_bad,
        lam=LAM,
        loss=LOSS,
        huber_delta=HUBER_DELTA,
        tol=TOL,
        **common,
    )
    return st.one_of(sq, sparse, huber)


def _resolve_all(kwargs: dict, *, K: int, n: int, N: int, R: int) -> dict:
    return {k: resolve(v, K=K, n=n, N=N, R=R) for k, v in kwargs.items()}


@fuzz_test(
    datasets(),
    regression_options(),
    examples=1.5,
    valid=(datasets(forms=False), regression_options(0)),
    explicit=[
        (Data(1, 1, 1), {"lam": 1.0}),
        (Data(0, 1, 1), {"lam": 1.0}),
        (HUGE, {"lam": 1.0}),
        (TINY, {"lam": "auto"}),
        (Data(2, 1, 1), {"lam": 1.0, "order": 2}),
    ],
)
def test_fit_regression(data, kwargs):
    """ltv.fit_regression(y, phi): the general problem behind every front-end."""
    y, phi = data.regression()
    p = data.n + data.m
    kw = _resolve_all(kwargs, K=data.n * p, n=data.n, N=data.N, R=data.R)
    check_call(ltv.fit_regression, y, phi, **kw)


NA = Opt(st.integers(1, 3), choice_of(0, -1, 1.5, "2", None, True, 10**6, np.nan))


def ar_options(max_bad: int = 2) -> st.SearchStrategy:
    return st.one_of(
        options(
            required=("lam", "na"),
            max_bad=max_bad,
            na=NA,
            lam=LAM,
            norm=NORM,
            order=ORDER,
            constant=CONSTANT,
            weights=WEIGHTS,
            noise_var=NOISE_VAR,
            compute_cov=BOOL,
            prior=PRIOR,
        ),
        options(
            required=("lam", "na", "norm", "max_iter"),
            max_bad=max_bad,
            na=NA,
            lam=SPARSE_LAM,
            norm=SPARSE_NORM,
            order=ORDER,
            constant=CONSTANT,
            max_iter=Opt(st.integers(1, 300), MAX_ITER.invalid),
            tol=TOL,
        ),
        options(
            required=("lam", "na", "loss"),
            max_bad=max_bad,
            na=NA,
            lam=LAM,
            loss=LOSS,
            huber_delta=HUBER_DELTA,
            constant=CONSTANT,
            weights=WEIGHTS,
        ),
    )


@fuzz_test(
    datasets(inputs=False),
    ar_options(),
    examples=1.5,
    valid=(datasets(inputs=False, forms=False), ar_options(0)),
    explicit=[
        (Data(30, 1, 0, seed=1, scale=1e300), {"na": 2, "lam": 1.0}),
        (Data(3, 1, 0), {"na": 2, "lam": 1.0}),
        (Data(30, 1, 0, seed=1), {"na": 2, "lam": 1.0, "norm": "group", "max_iter": 50}),
    ],
)
def test_fit_ar(data, kwargs):
    """ltv.fit_ar: time-varying (V)AR models, root spectrogram and simulation included."""
    y = data.x()
    if data.n == 1 and not data.R and isinstance(y, np.ndarray) and y.ndim == 2:
        y = y[:, 0]
    kw = dict(kwargs)
    na = kw.pop("na")
    na_int = na if isinstance(na, int) and not isinstance(na, bool) and 0 < na < 10 else 1
    p = data.n * na_int + int(kw.get("constant", False) is True)
    kw = _resolve_all(kw, K=data.n * p, n=data.n, N=max(data.T - na_int, 0), R=data.R)
    check_call(ltv.fit_ar, y, na, **kw)


def arx_options(max_bad: int = 2) -> st.SearchStrategy:
    return options(
        required=("lam", "na", "nb"),
        max_bad=max_bad,
        na=Opt(st.integers(0, 2), NA.invalid),
        nb=Opt(st.integers(1, 2), NA.invalid),
        nk=Opt(st.integers(0, 2), choice_of(-1, 1.5, "1", None)),
        lam=LAM,
        norm=NORM,
        order=ORDER,
        constant=CONSTANT,
        weights=WEIGHTS,
    )


@fuzz_test(datasets(), arx_options(), examples=1.5, valid=(datasets(forms=False), arx_options(0)))
def test_fit_arx(data, kwargs):
    """ltv.fit_arx: (V)ARX models with fuzzed lag structures."""
    y, u = data.xu()
    if u is None:
        u = np.random.default_rng(data.seed).standard_normal(data.T)
    kw = dict(kwargs)
    na, nb = kw.pop("na"), kw.pop("nb")
    K = data.n * (data.n * 2 + max(data.m, 1) * 2 + 1)
    kw = _resolve_all(kw, K=K, n=data.n, N=data.N, R=data.R)
    if kw.get("norm") in ("group", "l1"):
        kw["max_iter"] = 200
    check_call(ltv.fit_arx, y, u, na, nb, **kw)


@fuzz_test(
    datasets(),
    options(required=("na",), na=NA, constant=CONSTANT),
    options(
        required=("na", "nb"),
        na=Opt(st.integers(0, 3), NA.invalid),
        nb=Opt(st.integers(1, 3), NA.invalid),
        nk=Opt(st.integers(0, 3), choice_of(-1, 1.5, "1", None)),
        constant=CONSTANT,
    ),
)
def test_lag_regressors(data, ar_kwargs, arx_kwargs):
    """ltv.ar_regressors / arx_regressors: shapes, NaN rows for missing samples."""
    y, u = data.xu()
    kw = dict(ar_kwargs)
    result = check_call(ltv.ar_regressors, y, kw.pop("na"), **kw, inspector=_regressor_inspector)
    del result
    kw = dict(arx_kwargs)
    na, nb = kw.pop("na"), kw.pop("nb")
    check_call(
        ltv.arx_regressors,
        y,
        u if u is not None else data.x(),
        na,
        nb,
        **kw,
        inspector=_regressor_inspector,
    )


def _regressor_inspector(result, call, context):
    """(y_out, phi): rows are NaN only where a sample they hold is missing (documented)."""
    y_out, phi = result
    y_out, phi = np.asarray(y_out), np.asarray(phi)
    expect(
        y_out.shape[0] == phi.shape[0],
        call.label,
        "inconsistent shapes",
        f"y_out {y_out.shape} and phi {phi.shape}",
    )
    for name, arr in (("y_out", y_out), ("phi", phi)):
        expect(not np.isinf(arr).any(), call.label, "non-finite value", f"{name} holds inf")
    return "finite"


TRIM = Opt(
    st.one_of(st.floats(0.01, 0.49), st.just(0.15)),
    choice_of(0.0, 0.5, -0.1, 1.0, np.nan, "h", True),
)
SEG_PENALTY = Opt(
    st.one_of(st.floats(0.0, 50.0), choice_of("bic", "aic", 0.0)),
    choice_of("BIC", "hq", -1.0, np.inf, np.nan, 1e300, None, True),
)


@fuzz_test(
    datasets(max_T=50),
    st.one_of(
        options(n_changes=counts(0, 4), min_size=counts(1, 10), weights=WEIGHTS),
        options(penalty=SEG_PENALTY, min_size=counts(1, 10), weights=WEIGHTS),
        options(n_changes=counts(0, 4), trim=TRIM, regular=BOOL),
    ),
    valid=(
        datasets(max_T=50, forms=False),
        st.one_of(
            options(max_bad=0, n_changes=counts(0, 4), min_size=counts(1, 10), weights=WEIGHTS),
            options(max_bad=0, penalty=SEG_PENALTY, min_size=counts(1, 10)),
        ),
    ),
    explicit=[(Data(8, 2, 1), {"penalty": 0.0}), (HUGE, {}), (TINY, {"n_changes": 2})],
)
def test_segment_regression(data, kwargs):
    """ltv.segment_regression: exact L0 segmentation of any regression."""
    y, phi = data.regression()
    kw = {k: resolve(v, K=1, n=data.n, N=data.N, R=data.R) for k, v in kwargs.items()}
    result = check_call(ltv.segment_regression, y, phi, **kw)
    if result is None or result.moments is None or result.n_changes == 0 or data.n != 1:
        return
    # break-date intervals: around their break, or NaN where they cannot be computed
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        intervals = result.confint()
    np.testing.assert_array_equal(intervals[:, 1], result.changepoints)
    found = ~np.isnan(intervals[:, 0])
    assert np.all(intervals[found, 0] <= intervals[found, 1])
    assert np.all(intervals[found, 1] <= intervals[found, 2])


@fuzz_test(
    datasets(),
    options(min_size=counts(1, 30)),
    valid=(datasets(forms=False), options(max_bad=0, min_size=counts(1, 30))),
    explicit=[(HUGE, {}), (TINY, {}), (Data(3, 2, 1), {})],
)
def test_noise_variance_estimate(data, kwargs):
    """ltv.noise_variance_estimate: a finite σ̂² >= 0 or a documented error."""
    y, phi = data.regression()
    result = check_call(ltv.noise_variance_estimate, y, phi, **kwargs)
    if result is not None:
        expect(
            float(result) >= 0.0, "noise_variance_estimate", "invalid value", f"returned {result!r}"
        )


BREAK_KIND = Opt(choice_of("supF", "aveF", "expF", "sequential"), choice_of("SupF", "F", 1, None))
BREAK_TRIM = Opt(
    st.one_of(st.floats(0.05, 0.3), choice_of(0.05, 0.1, 0.15, 0.2, 0.25)),
    choice_of(0.0, 0.5, -0.1, np.nan, "h", True),
)
SEGMENT_COST = Opt(choice_of("rss", "normal"), choice_of("RSS", "gauss", 1, None, True))


@fuzz_test(
    datasets(max_T=60),
    st.one_of(
        options(kind=BREAK_KIND, trim=BREAK_TRIM, weights=WEIGHTS),
        options(
            kind=BREAK_KIND,
            trim=BREAK_TRIM,
            level=Opt(choice_of(0.05, 0.1, 0.01), choice_of(0.0, 1.5, "5%", np.nan)),
        ),
    ),
    explicit=[(HUGE, {}), (TINY, {}), (Data(40, 1, 1), {"kind": "sequential"})],
)
def test_break_test(data, kwargs):
    """ltv.break_test: a statistic with its p-value (or critical values), or a documented
    error."""
    y, phi = data.regression()
    kw = {k: resolve(v, K=1, n=data.n, N=data.N, R=data.R) for k, v in kwargs.items()}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # candidates left out, documented
        result = check_call(ltv.break_test, y, phi, **kw)
    if result is None:
        return
    assert np.isfinite(result.statistic)
    if result.kind == "sequential":
        assert 0 <= result.n_breaks <= len(result.statistics)
    else:
        assert 0.0 <= result.pvalue <= 1.0


@fuzz_test(
    datasets(max_T=50),
    options(n_changes=counts(0, 3), cost=SEGMENT_COST, min_size=counts(1, 12)),
)
def test_segment_regression_costs(data, kwargs):
    """ltv.segment_regression with the Gaussian cost: a segmentation or a documented error."""
    y, phi = data.regression()
    kw = {k: resolve(v, K=1, n=data.n, N=data.N, R=data.R) for k, v in kwargs.items()}
    check_call(ltv.segment_regression, y, phi, **kw)
