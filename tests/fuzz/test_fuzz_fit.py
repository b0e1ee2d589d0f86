"""Fuzz the state-space estimators: fit, fit_lti, fit_path, lambda_max, fit_piecewise,
fit_segments, the Kalman filter/smoother, the online filter and find_changepoints;
fit and fit_lti also with noisy recorded states (``measurement_noise``, EM).

Each test draws a data recipe (:func:`fuzz_strategies.datasets`: edge-case
shapes, dtypes, forms, non-finite and extreme values) and option values
(:func:`fuzz_strategies.options`: mostly valid, up to two invalid), makes the
call and hands it to :func:`fuzz_oracle.check_call`, which accepts only a
finite result (checked down to the model's covariances, likelihood,
predictions and simulation), a documented library error, or ``None`` where
documented.
"""

from __future__ import annotations

import numpy as np
from fuzz_oracle import check_call, expect, fail_result
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
    special_floats,
)
from hypothesis import strategies as st

import ltvmodels as ltv


def resolved(data, kw: dict) -> dict:
    """Option tokens replaced by values of the data's sizes."""
    sizes = dict(K=data.K(kw.get("constant", False)), n=data.n, N=data.N, R=data.R)
    return {k: resolve(v, **sizes) for k, v in kw.items()}


SPARSE_NORM = Opt(choice_of("group", "l1"), NORM.invalid)
FIT_OPTIONS = dict(order=ORDER, weights=WEIGHTS, constant=CONSTANT, refine=BOOL)


def fit_options(max_bad: int = 2) -> st.SearchStrategy:
    """Options of ltv.fit: the squared norm with priors, or a sparse norm with its solver."""
    sq = options(
        required=("lam",),
        max_bad=max_bad,
        lam=LAM,
        norm=NORM,
        noise_var=NOISE_VAR,
        compute_cov=BOOL,
        prior=PRIOR,
        prior_mode=PRIOR_MODE,
        **FIT_OPTIONS,
    )
    sparse = options(
        required=("lam", "norm", "max_iter"),
        max_bad=max_bad,
        lam=SPARSE_LAM,
        norm=SPARSE_NORM,
        max_iter=Opt(st.integers(1, 300), MAX_ITER.invalid),
        tol=TOL,
        **FIT_OPTIONS,
    )
    huber = options(
        required=("lam", "loss"),
        max_bad=max_bad,
        lam=LAM,
        loss=LOSS,
        huber_delta=HUBER_DELTA,
        max_iter=Opt(st.integers(1, 300), MAX_ITER.invalid),
        tol=TOL,
        **FIT_OPTIONS,
    )
    return st.one_of(sq, sparse, huber)


HUGE = Data(30, 2, 1, seed=1, scale=1e300)
"""Data scaled to 1e300 (their squares overflow): an explicit example of many tests."""
HUGE3 = Data(30, 3, 1, seed=1, scale=1e300)  # three states: a different failure path
TINY = Data(30, 2, 1, seed=1, scale=1e-300)
PLAIN = Data(30, 2, 1, seed=1)


@fuzz_test(
    datasets(),
    fit_options(),
    examples=2.0,
    valid=(datasets(forms=False), fit_options(0)),
    explicit=[
        (HUGE, {"lam": 1.0}),
        (HUGE3, {"lam": 1.0}),
        (TINY, {"lam": 1.0}),
        (HUGE, {"lam": "auto"}),
        (PLAIN, {"lam": 1.0, "norm": "group", "max_iter": 100}),
        (PLAIN, {"lam": 1.0, "norm": "l1", "max_iter": 100}),
        (HUGE, {"lam": 1.0, "norm": "group", "max_iter": 100}),
        (Data(2, 1, 0), {"lam": 1.0}),
        (Data(0, 1, 0), {"lam": 1.0}),
        (PLAIN, {"lam": 1.0, "prior": "@prior_ok", "prior_mode": "posthoc"}),
        (Data(30, 2, 1, defects=("nan_block",)), {"lam": 1.0, "refine": True}),
    ],
)
def test_fit(data, kwargs):
    """ltv.fit over every norm, order, λ form, prior, weight and data defect."""
    x, u = data.xu()
    check_call(ltv.fit, x, u, **resolved(data, kwargs))


LTI_OPTIONS = dict(weights=WEIGHTS, constant=CONSTANT, loss=LOSS, huber_delta=HUBER_DELTA)


@fuzz_test(
    datasets(),
    options(**LTI_OPTIONS),
    explicit=[
        (HUGE, {}),
        (HUGE3, {}),
        (TINY, {}),
        (Data(5, 2, 1), {"constant": True}),
        (PLAIN, {"loss": "huber"}),
    ],
    valid=(datasets(forms=False), options(max_bad=0, **LTI_OPTIONS)),
)
def test_fit_lti(data, kwargs):
    """ltv.fit_lti: least squares over edge-case data, weights and intercepts."""
    x, u = data.xu()
    check_call(ltv.fit_lti, x, u, **resolved(data, kwargs))


LAM_LISTS = Opt(
    st.lists(st.floats(0.05, 100.0), min_size=1, max_size=4),
    choice_of(
        [],
        [0.0],
        [-1.0, 2.0],
        [np.inf],
        [np.nan],
        [1e300],
        "abc",
        3.0,
        None,
        [[1.0], [2.0, 3.0]],
        ["1", "2"],
    ),
)


@fuzz_test(
    datasets(max_T=40),
    options(
        required=("lams", "max_iter"),
        lams=LAM_LISTS,
        norm=NORM,
        order=ORDER,
        constant=CONSTANT,
        weights=WEIGHTS,
        max_iter=Opt(st.integers(1, 200), MAX_ITER.invalid),
    ),
    examples=1.5,
)
def test_fit_path(data, kwargs):
    """ltv.fit_path: warm-started paths over λ lists of every kind."""
    x, u = data.xu()
    check_call(ltv.fit_path, x, u, **resolved(data, kwargs))


@fuzz_test(
    datasets(),
    options(required=("norm",), norm=SPARSE_NORM, order=ORDER, weights=WEIGHTS, constant=CONSTANT),
    explicit=[(HUGE, {"norm": "group"}), (TINY, {"norm": "l1"})],
)
def test_lambda_max(data, kwargs):
    """ltv.lambda_max: a finite λ >= 0 or a documented error."""
    x, u = data.xu()
    result = check_call(ltv.lambda_max, x, u, **resolved(data, kwargs))
    if result is not None:
        expect(
            np.ndim(result) == 0 and float(result) >= 0.0,
            "lambda_max",
            "invalid value",
            f"lambda_max returned {result!r}",
        )


CHANGEPOINTS = Opt(
    st.one_of(
        st.lists(st.integers(1, 58), max_size=3, unique=True).map(sorted),
        st.lists(st.integers(5, 30), max_size=1),
    ),
    st.one_of(
        st.lists(st.integers(-2, 62), min_size=1, max_size=4),
        choice_of(
            None,
            [1.5],
            ["3"],
            [np.nan],
            np.array([[5]]),
            [5, 5],
            [10, 5],
            7,
            np.array([3.0, 9.0]),
            [True],
        ),
    ),
)


@fuzz_test(
    datasets(),
    options(
        required=("changepoints",),
        changepoints=CHANGEPOINTS,
        order=Opt(choice_of(1, 2), choice_of(3, 0, "1", 1.5, None)),
        compute_cov=BOOL,
        weights=WEIGHTS,
        constant=CONSTANT,
    ),
    explicit=[
        (HUGE, {"changepoints": [10]}),
        (Data(7, 2, 1), {"changepoints": [3]}),
        (Data(8, 2, 1), {"changepoints": [3], "order": 2}),
    ],
)
def test_fit_piecewise(data, kwargs):
    """ltv.fit_piecewise: change points valid, out of range, unsorted, non-integer."""
    x, u = data.xu()
    check_call(ltv.fit_piecewise, x, u, **resolved(data, kwargs))


MEASUREMENT_NOISE = Opt(
    choice_of("estimate", "estimate", 0.01, 1.0, 1e-300, "@vec_n"),
    choice_of(0.0, -1.0, np.nan, np.inf, "@vec_wrong", "guess", True, [[0.1]]),
)
MEASUREMENT_OPTIONS = dict(
    measurement_noise=MEASUREMENT_NOISE,
    measurement_loss=Opt(choice_of("squared", "huber", "student"), choice_of("t", None, 1)),
    em_tol=TOL,
    em_max_iter=Opt(st.integers(0, 15), choice_of(-1, 1.5, "10", None, np.nan)),
    em_accelerate=BOOL,
    weights=WEIGHTS,
    constant=CONSTANT,
)


@fuzz_test(
    datasets(max_T=60),
    options(
        required=("lam", "measurement_noise"),
        lam=Opt(st.floats(0.5, 100.0), LAM.invalid),
        norm=NORM,
        order=ORDER,
        refine=BOOL,
        noise_var=NOISE_VAR,
        **MEASUREMENT_OPTIONS,
    ),
    examples=0.5,
    valid=(
        datasets(max_T=60, forms=False),
        options(
            required=("lam", "measurement_noise"),
            max_bad=0,
            lam=Opt(st.floats(0.5, 100.0), LAM.invalid),
            norm=NORM,
            order=ORDER,
            refine=BOOL,
            noise_var=NOISE_VAR,
            **MEASUREMENT_OPTIONS,
        ),
    ),
    explicit=[
        (HUGE, {"lam": 1.0, "measurement_noise": "estimate"}),
        (TINY, {"lam": 1.0, "measurement_noise": "estimate"}),
        (PLAIN, {"lam": 5.0, "measurement_noise": "estimate", "measurement_loss": "student"}),
        (Data(30, 2, 1, defects=("nan_block",)), {"lam": 5.0, "measurement_noise": 0.1}),
        (PLAIN, {"lam": 5.0, "norm": "group", "measurement_noise": "estimate"}),
    ],
)
def test_fit_measurement_noise(data, kwargs):
    """ltv.fit with noisy recorded states (EM): every loss, norm, gap and extreme."""
    x, u = data.xu()
    check_call(ltv.fit, x, u, **resolved(data, kwargs))


@fuzz_test(
    datasets(max_T=60),
    options(required=("measurement_noise",), **MEASUREMENT_OPTIONS),
    examples=0.5,
    explicit=[
        (HUGE, {"measurement_noise": "estimate"}),
        (Data(5, 2, 1), {"measurement_noise": 0.1}),
    ],
)
def test_fit_lti_measurement_noise(data, kwargs):
    """ltv.fit_lti with noisy recorded states (EM)."""
    x, u = data.xu()
    check_call(ltv.fit_lti, x, u, **resolved(data, kwargs))


PENALTY = Opt(
    st.one_of(st.floats(0.0, 50.0), choice_of("bic", "aic", 0.0, 0, 1e-300)),
    choice_of("BIC", "hq", "", -1.0, np.inf, np.nan, 1e300, None, True),
)


@fuzz_test(
    datasets(max_T=50),
    st.one_of(
        options(
            n_changes=counts(0, 4),
            min_size=counts(1, 10),
            compute_cov=BOOL,
            weights=WEIGHTS,
            constant=CONSTANT,
        ),
        options(
            penalty=PENALTY,
            min_size=counts(1, 10),
            compute_cov=BOOL,
            weights=WEIGHTS,
            constant=CONSTANT,
        ),
        options(n_changes=counts(0, 4), penalty=PENALTY),
    ),
    examples=1.5,
    explicit=[
        (Data(8, 2, 1), {"penalty": 0.0}),
        (PLAIN, {"penalty": 0.0}),
        (HUGE, {}),
        (TINY, {"n_changes": 1}),
        (Data(8, 2, 1), {"n_changes": 1}),
    ],
)
def test_fit_segments(data, kwargs):
    """ltv.fit_segments: dynamic programming and PELT with fuzzed counts and penalties."""
    x, u = data.xu()
    check_call(ltv.fit_segments, x, u, **resolved(data, kwargs))


KALMAN_LAM = Opt(
    st.floats(0.05, 300.0), st.one_of(special_floats(), choice_of("auto", [1.0, 2.0], "@vecK"))
)
INIT = Opt(
    choice_of("@zerosK+eye", "@dK+eye", "@none"),
    choice_of(
        "@nanK",
        "@wrongK",
        "@eye_wrong",
        "@cov0",
        "@cov_neg",
        "@cov_nan",
        "@cov_inf",
        "@cov_huge",
        "@mean_only",
    ),
)
KALMAN_NOISE = Opt(
    choice_of(1.0, 0.5, 1e-3), choice_of(0.0, -1.0, np.nan, np.inf, 1e-300, 1e300, "1", None)
)


def _kalman_kwargs(kwargs: dict, data) -> dict:
    """Resolve λ and the init token into lam, init_mean, init_cov."""
    out = dict(kwargs)
    order = out.get("order", 1)
    d = order if isinstance(order, (int, np.integer)) and not isinstance(order, bool) else 1
    d = int(d) if 0 < d < 5 else 1
    K, p = data.K(), data.n + data.m
    out["lam"] = resolve(out["lam"], K=K, n=data.n, N=data.N)
    token = out.pop("init", "@none")
    table = {
        "@zerosK+eye": (np.zeros(K), np.eye(p) if d == 1 else np.eye(d * p)),
        "@dK+eye": (np.zeros((d, K)), np.eye(d * p)),
        "@nanK": (np.full(K, np.nan), 1.0),
        "@wrongK": (np.zeros(K + 1), 1.0),
        "@eye_wrong": (None, np.eye(d * p + 1)),
        "@cov0": (None, 0.0),
        "@cov_neg": (None, -1.0),
        "@cov_nan": (None, np.nan),
        "@cov_inf": (None, np.inf),
        "@cov_huge": (None, 1e300),
        "@mean_only": (np.zeros(K), None),
    }
    if token in table:
        mean, cov = table[token]
        if mean is not None:
            out["init_mean"] = mean
        if cov is not None:
            out["init_cov"] = cov
    return out


KALMAN_OPTIONS = options(
    required=("lam",), lam=KALMAN_LAM, order=ORDER, noise_var=KALMAN_NOISE, init=INIT
)


@fuzz_test(
    datasets(batch=False),
    KALMAN_OPTIONS,
    st.booleans(),
    explicit=[(HUGE, {"lam": 1.0}, False), (HUGE, {"lam": 1.0}, True), (TINY, {"lam": 1.0}, True)],
)
def test_kalman(data, kwargs, smoother):
    """ltv.kalman_filter / kalman_smoother: NaN only before first_identified (documented)."""
    x, u = data.xu()
    fn = ltv.kalman_smoother if smoother else ltv.kalman_filter
    check_call(fn, x, u, **_kalman_kwargs(kwargs, data))


FEEDS = choice_of(
    "ok", "ok", "ok", "ok", "wrong_n", "wrong_m", "nan", "inf", "list", "none_u", "huge"
)


@fuzz_test(datasets(batch=False, forms=False), KALMAN_OPTIONS, FEEDS)
def test_online_filter(data, kwargs, feed):
    """ltv.OnlineParameterFilter: construction and updates with fuzzed samples."""
    x, u = data.clean()
    filt = check_call(ltv.OnlineParameterFilter, data.n, data.m, **_kalman_kwargs(kwargs, data))
    if filt is None:
        return
    identified = False
    for t in range(min(data.T - 1, 25)):
        xt, ut, xn = x[t], (u[t] if u is not None else None), x[t + 1]
        if feed == "wrong_n":
            xt = np.append(xt, 1.0)
        elif feed == "wrong_m" and ut is not None:
            ut = np.append(ut, 1.0)
        elif feed == "nan":
            xn = np.full_like(xn, np.nan)
        elif feed == "inf":
            xt = np.full_like(xt, np.inf)
        elif feed == "list":
            xt, xn = xt.tolist(), xn.tolist()
        elif feed == "none_u":
            ut = None
        elif feed == "huge":
            xt, xn = xt * 1e300, xn * 1e300
        k = check_call(
            filt.update,
            xt,
            ut,
            xn,
            label="OnlineParameterFilter.update",
            inspector=_online_inspector,
        )
        if k is None:
            break
        finite = bool(np.all(np.isfinite(k)))
        expect(
            finite or not identified,
            "OnlineParameterFilter.update",
            "non-finite value",
            f"the estimate became non-finite at t={t} after being identified: {k}",
        )
        identified = identified or finite


def _online_inspector(result, call, context):
    """update() returns k_t: NaN until identified (documented), never inf."""
    arr = np.asarray(result, dtype=float)
    if np.isinf(arr).any():
        fail_result(call, "non-finite value", f"update() returned inf: {arr}")
    return "finite"


ACTIVATION = st.one_of(
    st.lists(st.floats(0.0, 10.0), max_size=40).map(np.array),
    choice_of(
        [],
        [np.nan, 1.0],
        [np.inf, 1.0],
        [-1.0, 2.0],
        [[1.0, 2.0]],
        "abc",
        None,
        np.zeros(30),
        np.ones(30),
        [1e300] * 5,
        [1e-300] * 5,
        [0.0, 1e308, 1e308],
    ),
    st.just("@model"),
    st.just("@model"),
)


@fuzz_test(
    ACTIVATION,
    datasets(edge=False),
    options(
        threshold=Opt(
            choice_of(0.25, 0.0, 1.0, 0.5), choice_of(-0.1, 1.5, np.nan, np.inf, "0.5", None)
        ),
        noise_factor=Opt(
            choice_of(8.0, None, 0.0, 3.0), choice_of(-1.0, np.nan, np.inf, 1e300, "8")
        ),
        min_distance=counts(1, 20),
        max_changes=counts(0, 5),
        degree=Opt(choice_of(1, 2, 3), choice_of(0, -1, 1.5, "1")),
        min_level=Opt(choice_of(None, 0.0, 1e-12, 0.1), choice_of(-1.0, np.nan, np.inf, "0")),
    ),
)
def test_find_changepoints(activation, data, kwargs):
    """ltv.find_changepoints on fuzzed activations and on fitted models."""
    if isinstance(activation, str) and activation == "@model":
        x, u = data.xu()
        activation = ltv.fit(x, u, lam=5.0)
        kwargs = {k: v for k, v in kwargs.items() if k != "degree"}  # a model brings its own degree
    result = check_call(ltv.find_changepoints, activation, **kwargs)
    if result is not None:
        arr = np.asarray(result)
        expect(
            arr.ndim == 1 and arr.dtype.kind in "iu" and bool(np.all(np.diff(arr) > 0)),
            "find_changepoints",
            "invalid value",
            f"returned {arr!r}",
        )
