"""Fuzz the result objects and the small public pieces: LTVModel (constructor, predict,
simulate, save), AR/ARX models (predict, simulate, root_spectrogram), RegressionModel.predict,
Prior/OutputPrior, the example systems and ilqg.

A handful of models are fitted once per session (clean data, every kind of
estimator); the tests then call their methods with fuzzed arguments
(shapes, dtypes, NaN/inf, wrong lengths, batches) and hand each call to
:func:`fuzz_oracle.check_call`.
"""

from __future__ import annotations

import os
import re

import numpy as np
import pytest
from fuzz_oracle import (
    DOCUMENTED_OS_ERRORS,
    check_call,
    diverged,
    expect,
    fail_result,
    tmpdir,
)
from fuzz_strategies import choice_of, fitted, fuzz_test
from hypothesis import strategies as st

import ltvmodels as ltv

LTV_KINDS = ["sq", "sq_constant", "group", "autonomous", "lti", "segments"]

ARRAY_VARIANTS = [
    "ok",
    "ok",
    "ok",
    "nan_row",
    "inf",
    "short",
    "long",
    "wide",
    "narrow",
    "1d",
    "list",
    "int",
    "str",
    "none",
    "scalar",
    "batch",
    "batch_list",
    "empty",
    "huge",
    "complex",
    "object",
    "masked",
    "transposed",
    "bool",
    "ragged_batch",
]


def variant(base: np.ndarray, kind: str):
    """A fuzzed version of a correct (T, d) argument."""
    a = base.copy()
    if kind == "ok":
        return a
    if kind == "nan_row" and a.size:
        a[min(1, len(a) - 1)] = np.nan
        return a
    if kind == "inf" and a.size:
        a.flat[0] = np.inf
        return a
    if kind == "short":
        return a[:-1]
    if kind == "long":
        return np.vstack([a, a[:1]]) if a.ndim == 2 else np.concatenate([a, a[:1]])
    if kind == "wide":
        return np.column_stack([a, a[:, :1]]) if a.ndim == 2 else a[:, None].repeat(2, 1)
    if kind == "narrow":
        return a[:, :-1] if a.ndim == 2 else a[:0]
    if kind == "1d":
        return a.ravel()
    if kind == "list":
        return a.tolist()
    if kind == "int":
        return np.nan_to_num(a).round().astype(int)
    if kind == "str":
        return a.astype(str)
    if kind == "none":
        return None
    if kind == "scalar":
        return 1.0
    if kind == "batch":
        return np.stack([a, a + 0.1])
    if kind == "batch_list":
        return [a, a + 0.1]
    if kind == "ragged_batch":
        return [a, a[:-1]]
    if kind == "empty":
        return a[:0]
    if kind == "huge":
        return a * 1e300
    if kind == "complex":
        return a + 1j
    if kind == "object":
        return a.astype(object)
    if kind == "masked":
        m = np.ma.masked_array(a, mask=np.zeros(a.shape, dtype=bool))
        if a.size:
            m.mask.flat[0] = True
        return m
    if kind == "transposed":
        return a.T
    if kind == "bool":
        return a > 0
    raise AssertionError(kind)


def _fresh(shape, seed=3):
    return np.random.default_rng(seed).standard_normal(shape)


@fuzz_test(
    st.sampled_from(LTV_KINDS),
    st.sampled_from(ARRAY_VARIANTS),
    st.sampled_from(ARRAY_VARIANTS),
    examples=2.0,
)
def test_ltv_predict_simulate(kind, x_variant, u_variant):
    """LTVModel.predict(x, u) and simulate(x0, u) with fuzzed arguments."""
    model = fitted(kind)
    N, n, m = model.N, model.n_states, model.n_inputs
    x = _fresh((N + 1, n))
    u = _fresh((N + 1, m)) if m else np.zeros((N + 1, 0))
    xv = variant(x, x_variant)
    uv = (
        variant(u, u_variant)
        if m
        else (None if u_variant in ("ok", "none") else variant(_fresh((N + 1, 1)), u_variant))
    )
    check_call(model.predict, xv, uv, label="LTVModel.predict", inspector=_predict_inspector)
    x0 = variant(x[:1], x_variant)
    x0 = x0[0] if isinstance(x0, np.ndarray) and x0.ndim == 2 and x0.shape[0] == 1 else x0
    check_call(model.simulate, x0, uv, label="LTVModel.simulate", inspector=_simulate_inspector)


def _predict_inspector(result, call, context):
    """Predictions: NaN only where the data are NaN (documented), never inf from finite data."""
    arr = np.asarray(result, dtype=float)
    args = call.args
    data_finite = all(_all_finite(a) for a in args if a is not None)
    if data_finite and not np.all(np.isfinite(arr)):
        scale = max(_max_abs(a) for a in args if a is not None)
        if scale < 1e100:
            fail_result(call, "non-finite value", "predictions of finite data are NaN/inf")
    return "finite"


def _simulate_inspector(result, call, context):
    """Simulations: finite, or inf/NaN together with a DivergenceWarning (documented)."""
    arr = np.asarray(result, dtype=float)
    if not np.all(np.isfinite(arr)) and not diverged(call):
        fail_result(
            call,
            "non-finite value",
            "the simulation is NaN/inf without an error or a DivergenceWarning",
        )
    return "finite"


def _all_finite(a) -> bool:
    """Whether an argument holds finite numbers only (masked entries count as missing)."""
    if np.ma.isMaskedArray(a) and np.ma.getmaskarray(a).any():
        return False
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        return False
    return bool(np.all(np.isfinite(arr)))


def _max_abs(a) -> float:
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        return 0.0
    return float(np.nanmax(np.abs(arr), initial=0.0))


ARX_KINDS = ["ar", "var", "arx"]


@fuzz_test(
    st.sampled_from(ARX_KINDS),
    st.sampled_from(ARRAY_VARIANTS),
    st.sampled_from(ARRAY_VARIANTS),
    st.one_of(st.floats(0.1, 1e4), choice_of(0.0, -1.0, np.nan, np.inf, "1", None, 1e300, 1e-300)),
    st.sampled_from([None, "ok", "nan", "short", "inf", "huge"]),
)
def test_arx_methods(kind, y_variant, u_variant, fs, noise):
    """ARXModel.predict / simulate / root_spectrogram / poles with fuzzed arguments."""
    model = fitted(kind)
    n, m, L, N = model.n_outputs, model.n_inputs, model.lag, model.N
    y = _fresh((N + L, n))
    y = y[:, 0] if n == 1 else y
    u = _fresh((N + L, m)) if m else None
    yv = variant(y, y_variant)
    uv = variant(u, u_variant) if m else None
    args = (yv, uv) if m else (yv,)
    check_call(model.predict, *args, label="ARXModel.predict", inspector=_predict_inspector)
    y0 = yv[:L] if isinstance(yv, (np.ndarray, list)) else yv
    noise_arg = {}
    if noise is not None:
        e = _fresh((N, n)) * 0.1
        e = e[:, 0] if n == 1 else e
        noise_arg["noise"] = {
            "ok": e,
            "nan": e * np.nan,
            "short": e[:-1],
            "inf": e + np.inf,
            "huge": e * 1e305,
        }[noise]
    sim_args = (y0, uv) if m else (y0,)
    check_call(
        model.simulate,
        *sim_args,
        **noise_arg,
        label="ARXModel.simulate",
        inspector=_simulate_inspector,
    )
    check_call(
        model.root_spectrogram,
        fs,
        label="ARXModel.root_spectrogram",
        inspector=_spectrogram_inspector,
    )


def _spectrogram_inspector(result, call, context):
    arr = np.asarray(result, dtype=float)
    if np.isinf(arr).any():
        fail_result(call, "non-finite value", "root_spectrogram holds inf")
    return "finite"


@fuzz_test(st.sampled_from(["regression", "sq", "ar"]), st.sampled_from(ARRAY_VARIANTS))
def test_regression_predict(kind, phi_variant):
    """RegressionModel.predict(phi) (the base-class method, also on subclasses)."""
    model = fitted(kind)
    phi = _fresh((model.N, model.n_regressors))
    base_predict = ltv.RegressionModel.predict.__get__(model)  # the base-class method, bound
    check_call(
        base_predict,
        variant(phi, phi_variant),
        label="RegressionModel.predict",
        inspector=_predict_inspector,
    )


K_VARIANTS = [
    "ok",
    "ok",
    "nan",
    "inf",
    "huge",
    "wrong_K",
    "1d",
    "3d",
    "empty",
    "str",
    "list",
    "int",
    "zero_rows",
]


@fuzz_test(
    st.sampled_from(K_VARIANTS),
    st.integers(1, 3),
    st.integers(0, 2),
    st.one_of(st.booleans(), choice_of(None, "yes", 2, np.bool_(True))),
    st.one_of(st.integers(1, 3), choice_of(0, -1, 1.5, "2", None)),
    st.sampled_from(ARRAY_VARIANTS),
    st.one_of(st.booleans(), choice_of(None, "no", 0)),
)
def test_ltv_model_constructor(k_variant, n, m, constant, n_states_arg, x_variant, copy):
    """LTVModel(k, n_states, n_inputs, constant=..., copy=...) with fuzzed k, then
    simulate/predict."""
    p = n + m + (1 if constant is True else 0)
    N = 8
    k = 0.3 * _fresh((N, n * p))
    k = {
        "ok": k,
        "nan": k * np.nan,
        "inf": k + np.inf,
        "huge": k * 1e300,
        "wrong_K": k[:, :-1] if k.shape[1] > 1 else np.zeros((N, 5)),
        "1d": k.ravel(),
        "3d": k[None],
        "empty": np.zeros((0, n * p)),
        "str": k.astype(str),
        "list": k.tolist(),
        "int": np.ones((N, n * p), dtype=int),
        "zero_rows": k[:0],
    }[k_variant]
    n_arg = n if n_states_arg == 1 else n_states_arg
    model = check_call(
        ltv.LTVModel,
        k,
        n_arg,
        m,
        constant=constant,
        copy=copy,
        label="LTVModel",
        inspector=_constructed_inspector,
    )
    if model is None:
        return
    x = _fresh((model.N + 1, model.n_states))
    u = _fresh((model.N + 1, model.n_inputs)) if model.n_inputs else None
    check_call(
        model.predict,
        variant(x, x_variant),
        u,
        label="LTVModel.predict",
        inspector=_predict_inspector,
    )
    check_call(model.simulate, x[0], u, label="LTVModel.simulate", inspector=_simulate_inspector)
    check_call(repr, model, label="repr(LTVModel)", inspector=_text_inspector)
    check_call(model.summary, label="LTVModel.summary", inspector=_text_inspector)


def _constructed_inspector(result, call, context):
    """A model built from given coefficients: finite k; nothing estimated (None documented)."""
    expect(
        bool(np.all(np.isfinite(result.k))),
        call.label,
        "non-finite value",
        "LTVModel accepted non-finite coefficients k",
    )
    return "finite+None"


def _text_inspector(result, call, context):
    """repr/summary: text without NaN (None is how a missing value shows)."""
    expect(
        isinstance(result, str) and not re.search(r"\bnan\b", result, re.IGNORECASE),
        call.label,
        "NaN shown in text",
        str(result)[:200],
    )
    return "finite"


PATHS = [
    "ok",
    "ok",
    "nested_missing_dir",
    "directory",
    "int",
    "none",
    "bytes",
    "pathlike",
    "no_suffix",
    "txt_suffix",
    "empty_string",
    "file_object",
    "unicode",
]


@fuzz_test(
    st.sampled_from(["sq", "group", "ar", "arx", "regression", "segments", "var", "sq_constant"]),
    st.sampled_from(PATHS),
)
def test_save_load_roundtrip(kind, path_kind):
    """model.save(path) with fuzzed paths; a saved model loads back identical and usable."""
    import pathlib

    model = fitted(kind)
    with tmpdir() as d:
        path = {
            "ok": os.path.join(d, "m.npz"),
            "nested_missing_dir": os.path.join(d, "a", "m.npz"),
            "directory": d,
            "int": 3,
            "none": None,
            "bytes": os.path.join(d, "m.npz").encode(),
            "pathlike": pathlib.Path(d) / "m.npz",
            "no_suffix": os.path.join(d, "model"),
            "txt_suffix": os.path.join(d, "m.txt"),
            "empty_string": "",
            "file_object": None,
            "unicode": os.path.join(d, "modèl ✓.npz"),
        }[path_kind]
        if path_kind == "file_object":
            fh = open(os.path.join(d, "f.npz"), "wb")  # noqa: SIM115 - closed below
            path = fh
        saved = []
        # a path that cannot be opened raises the file's OSError, as for any file
        check_call(
            model.save,
            path,
            label="RegressionModel.save",
            allow=DOCUMENTED_OS_ERRORS,
            inspector=lambda result, call, context: saved.append(result) or "finite",
        )
        if path_kind == "file_object":
            fh.close()
        if saved:
            expect(
                saved == [None],
                "RegressionModel.save",
                "unexpected result",
                f"save returned {saved[0]!r}",
            )
            loaded = check_call(ltv.load, path, label="load")
            expect(
                loaded is not None
                and type(loaded) is type(model)
                and np.array_equal(loaded.k, model.k),
                "load",
                "round trip",
                f"a {kind} model saved to a {path_kind} path did not load back identical",
            )


@fuzz_test(
    st.integers(1, 4),
    st.integers(1, 6),
    st.sampled_from(
        [
            "zeros",
            "nan",
            "inf",
            "NK",
            "wrong",
            "str",
            "none",
            "model",
            "huge",
            "masked",
            "list",
            "3d",
        ]
    ),
    st.sampled_from(
        [
            "1",
            "0",
            "-1",
            "nan",
            "inf",
            "eye",
            "neg_eye",
            "nonsym",
            "NKK",
            "wrong",
            "str",
            "none",
            "tiny",
            "huge",
            "singular",
            "3d_wrong",
        ]
    ),
    st.booleans(),
)
def test_prior_constructors(n, N, mean_kind, cov_kind, output):
    """ltv.Prior(mean, cov) / ltv.OutputPrior(mean, cov) with fuzzed means and covariances."""
    K = n if output else n * (n + 1)
    mean = {
        "zeros": np.zeros(K),
        "nan": np.full(K, np.nan),
        "inf": np.full(K, np.inf),
        "NK": np.zeros((N, K)),
        "wrong": np.zeros(K + 1),
        "str": ["a"] * K,
        "none": None,
        "model": fitted("lti") if not output else np.zeros(K),
        "huge": np.full(K, 1e300),
        "masked": np.ma.masked_array(np.zeros(K), mask=[True] + [False] * (K - 1)),
        "list": [0.0] * K,
        "3d": np.zeros((1, N, K)),
    }[mean_kind]
    M = np.eye(K)
    M2 = np.eye(K).copy()
    if K > 1:
        M2[0, 1] = 5.0
    cov = {
        "1": 1.0,
        "0": 0.0,
        "-1": -1.0,
        "nan": np.nan,
        "inf": np.inf,
        "eye": M,
        "neg_eye": -M,
        "nonsym": M2,
        "NKK": np.broadcast_to(M, (N, K, K)).copy(),
        "wrong": np.eye(K + 1),
        "str": "1",
        "none": None,
        "tiny": 1e-300 * M,
        "huge": 1e300 * M,
        "singular": np.zeros((K, K)),
        "3d_wrong": np.ones((N, K, K + 1)),
    }[cov_kind]
    cls = ltv.OutputPrior if output else ltv.Prior
    check_call(cls, mean, cov, label=cls.__name__)


@fuzz_test(
    st.sampled_from(["jump_linear", "random_walk_system", "chirp"]),
    st.one_of(st.integers(2, 80), choice_of(0, 1, -1, 1.5, "10", None)),
    choice_of(0, 1, 7, -1, None, "0", 2**70, np.random.default_rng(0)),
    st.one_of(choice_of(0.1, 0.0, -0.1, np.nan, np.inf, 1e300)),
)
def test_systems(name, T, seed_value, noise):
    """ltvmodels.systems: the seeded example data sets with fuzzed sizes and seeds."""
    fn = getattr(ltv.systems, name)
    kwargs = {"T": T, "seed": seed_value}
    if name != "chirp":
        kwargs["noise_std"] = noise
    if name == "jump_linear" and isinstance(T, int) and not isinstance(T, bool):
        kwargs["change_at"] = max(T // 2, 0)
    check_call(fn, **kwargs, label=f"systems.{name}", inspector=_system_inspector)


def _system_inspector(result, call, context):
    for name in ("x", "u", "A", "B", "k"):
        value = getattr(result, name, None)
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            expect(
                bool(np.all(np.isfinite(value))),
                call.label,
                "non-finite value",
                f"{name} holds NaN/inf",
            )
    return "finite"


@fuzz_test(
    st.sampled_from(["sq", "lti", "group"]),
    st.sampled_from(["ok", "ok", "nan", "inf", "wrong", "huge", "list", "none"]),
    st.one_of(
        choice_of(
            None,
            (-1.0, 1.0),
            (-np.inf, np.inf),
            (1.0, -1.0),
            (np.nan, 1.0),
            (0.0, 0.0),
            "x",
            (-1.0,),
            5.0,
        )
    ),
    st.one_of(choice_of(None, 0.5, 10.0, 0.0, -1.0, np.nan, np.inf, 1e-300)),
    st.one_of(st.integers(1, 20), choice_of(0, -1, 1.5, None)),
    st.one_of(choice_of(1e-8, 0.0, -1.0, np.nan, 1.0)),
)
def test_ilqg(kind, x0_kind, u_bounds, trust_region, max_iter, tol):
    """ltv.ilqg on fitted LTV models with fuzzed initial states, bounds and trust regions."""
    from ltvmodels.control import QuadraticCost

    model = fitted(kind)
    n, m, N = model.n_states, model.n_inputs, model.N
    x0 = {
        "ok": np.ones(n),
        "nan": np.full(n, np.nan),
        "inf": np.full(n, np.inf),
        "wrong": np.ones(n + 1),
        "huge": np.full(n, 1e300),
        "list": [1.0] * n,
        "none": None,
    }[x0_kind]
    cost = QuadraticCost(np.eye(n), np.eye(m), N)
    kwargs = {"u_bounds": u_bounds, "trust_region": trust_region, "max_iter": max_iter, "tol": tol}
    kwargs = {k: v for k, v in kwargs.items() if v is not None}
    check_call(
        ltv.ilqg,
        model,
        cost,
        x0,
        np.zeros((N, m)),
        **kwargs,
        label="ilqg",
        allow=(np.linalg.LinAlgError,),
        inspector=_ilqg_inspector,
    )


def _ilqg_inspector(result, call, context):
    for name in ("x", "u", "K", "cost"):
        value = getattr(result, name, None)
        if value is not None:
            expect(
                bool(np.all(np.isfinite(np.asarray(value, dtype=float)))),
                call.label,
                "non-finite value",
                f"ILQGResult.{name} holds NaN/inf",
            )
    return "finite"


@fuzz_test(
    st.sampled_from(LTV_KINDS),
    st.sampled_from(ARRAY_VARIANTS),
    st.sampled_from(ARRAY_VARIANTS),
    st.one_of(st.integers(-2, 8), choice_of(None, 2.5, "3", np.inf, True)),
    st.one_of(st.floats(0.01, 0.99), choice_of(0.0, 1.0, -0.5, np.nan, "0.9", None)),
)
def test_ltv_forecast(kind, x_variant, u_variant, steps, level):
    """LTVModel.forecast(x0, u, steps=, level=) with fuzzed arguments."""
    model = fitted(kind)
    n, m = model.n_states, model.n_inputs
    x0 = variant(_fresh((1, n)), x_variant)
    x0 = x0[0] if isinstance(x0, np.ndarray) and x0.ndim == 2 and x0.shape[0] == 1 else x0
    u = (
        variant(_fresh((5, m)), u_variant)
        if m
        else (None if u_variant in ("ok", "none") else variant(_fresh((5, 1)), u_variant))
    )
    check_call(
        model.forecast,
        x0,
        u,
        steps=steps,
        level=level,
        n_samples=100,
        label="LTVModel.forecast",
        inspector=_forecast_inspector,
    )


@fuzz_test(
    st.sampled_from(ARX_KINDS),
    st.sampled_from(ARRAY_VARIANTS),
    st.one_of(st.integers(-1, 6), choice_of(None, 1.5)),
)
def test_arx_forecast(kind, y_variant, steps):
    """ARModel/ARXModel.forecast from the last samples, with fuzzed arguments."""
    model = fitted(kind)
    n, m, L = model.n_outputs, model.n_inputs, model.lag
    y_last = variant(_fresh((L, n)), y_variant)
    if m:
        u = _fresh((L + 4, m))
        check_call(
            model.forecast,
            y_last,
            u,
            steps=steps,
            n_samples=100,
            label="ARXModel.forecast",
            inspector=_forecast_inspector,
        )
    else:
        check_call(
            model.forecast,
            y_last,
            steps=steps,
            n_samples=100,
            label="ARModel.forecast",
            inspector=_forecast_inspector,
        )


def _forecast_inspector(result, call, context):
    """A forecast: finite mean, bounds and covariances, lower <= upper."""
    for name in ("mean", "lower", "upper", "cov"):
        arr = np.asarray(getattr(result, name), dtype=float)
        if not np.all(np.isfinite(arr)):
            fail_result(call, "non-finite value", f"forecast.{name} holds NaN/inf")
    if np.any(np.asarray(result.lower) > np.asarray(result.upper)):
        fail_result(call, "invalid value", "forecast.lower > forecast.upper")
    return "finite"


@fuzz_test(
    st.sampled_from(ARRAY_VARIANTS),
    st.sampled_from(ARRAY_VARIANTS + ["absent"]),
    st.sampled_from(ARRAY_VARIANTS + ["absent"]),
    st.one_of(st.integers(-1, 6), choice_of(None, 2.5, "4", True)),
    st.one_of(st.integers(0, 4), choice_of(None, [-1.0, 1.0], [0.0, 0.0], "2")),
    st.sampled_from(["absent", "eye", "scalar", "negative", "wrong_shape"]),
    valid=(
        st.sampled_from(["ok", "list", "int", "huge"]),
        st.sampled_from(["ok", "list", "absent"]),
        st.sampled_from(["ok", "absent"]),
        choice_of(None, 4),
        choice_of(None, 1, 2, [-1.0, 1.0]),
        st.sampled_from(["absent", "eye", "scalar"]),
    ),
)
def test_from_arrays(a_variant, b_variant, c_variant, steps, order, noise):
    """LTVModel.from_arrays(A, B, c=, steps=, order=, noise_cov=) with fuzzed arguments."""
    n, m, N = 2, 1, 4
    A = variant(_fresh((N, n, n)) * 0.3, a_variant)
    B = None if b_variant == "absent" else variant(_fresh((N, n, m)), b_variant)
    c = None if c_variant == "absent" else variant(_fresh((N, n)), c_variant)
    noise_cov = {
        "absent": None,
        "eye": np.eye(n),
        "scalar": 0.1,
        "negative": -np.eye(n),
        "wrong_shape": np.eye(n + 1),
    }[noise]
    check_call(
        ltv.LTVModel.from_arrays,
        A,
        B,
        c=c,
        steps=steps,
        order=order,
        noise_cov=noise_cov,
        label="LTVModel.from_arrays",
        inspector=_from_arrays_inspector,
    )


def _from_arrays_inspector(result, call, context):
    """A model from arrays: finite coefficients of consistent shapes that simulate."""
    N, n, m = result.N, result.n_states, result.n_inputs
    expect(
        result.A.shape == (N, n, n) and result.B.shape == (N, n, m),
        call.label,
        "invalid value",
        f"A {result.A.shape} and B {result.B.shape} do not fit N, n, m",
    )
    if not np.all(np.isfinite(result.k)):
        fail_result(call, "non-finite value", "the model's coefficients hold NaN/inf")
    result.simulate(np.zeros(n), np.zeros((N, m)) if m else None)
    return "finite"


@fuzz_test(
    st.sampled_from(LTV_KINDS),
    st.one_of(st.integers(-200, 200), choice_of(1.5, "0", None, True, np.int64(2))),
    st.one_of(st.floats(1e-6, 1e6), choice_of(None, 0.0, -1.0, np.nan, np.inf, True, "0.1")),
    choice_of(False, True, None, "yes"),
    valid=(
        st.sampled_from(LTV_KINDS),
        st.integers(-3, 3),
        st.one_of(st.floats(1e-6, 1e6), st.none()),
        st.booleans(),
    ),
)
def test_to_statespace_and_frame(kind, t, dt, std):
    """LTVModel.to_statespace(t, dt=) and to_frame() on fitted models."""
    pytest.importorskip("control")
    pytest.importorskip("pandas")
    model = fitted(kind)
    check_call(
        model.to_statespace,
        t,
        dt=dt,
        label="LTVModel.to_statespace",
        inspector=_statespace_inspector,
    )
    check_call(model.to_frame, std=std, label="LTVModel.to_frame", inspector=_frame_inspector)


def _statespace_inspector(result, call, context):
    """A python-control system with finite matrices and a positive step."""
    for name in ("A", "B", "C", "D"):
        if not np.all(np.isfinite(np.asarray(getattr(result, name), dtype=float))):
            fail_result(call, "non-finite value", f"StateSpace.{name} holds NaN/inf")
    expect(
        result.dt is True or result.dt > 0,
        call.label,
        "invalid value",
        f"StateSpace.dt = {result.dt!r}",
    )
    return "finite"


def _frame_inspector(result, call, context):
    """One row per time step and one column per coefficient, all finite."""
    k = call.fn.__self__.k
    columns = 2 * k.shape[1] if call.kwargs["std"] else k.shape[1]
    expect(
        result.shape == (k.shape[0], columns),
        call.label,
        "invalid value",
        f"to_frame shape {result.shape} for k of shape {k.shape}",
    )
    if not np.all(np.isfinite(result.to_numpy(dtype=float))):
        fail_result(call, "non-finite value", "to_frame holds NaN/inf")
    return "finite"
