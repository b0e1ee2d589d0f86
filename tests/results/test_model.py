"""The ``LTVModel`` result object: shapes, predict, simulate, persistence, display."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from dense_reference import random_data, simulate_ltv

import ltvmodels as ltv


def _models():
    x, u, k_true = simulate_ltv(71, T=40, n=2, m=1)
    K = 6
    lam_vec = np.linspace(0.5, 3.0, K)
    lam_vec[1] = np.inf
    prior = ltv.Prior(k_true, 0.05)
    return {
        "scalar-cov": ltv.fit(x, u, lam=2.0),
        "vector-lam": ltv.fit(x, u, lam=lam_vec, order=2),
        "matrix-lam": ltv.fit(x, u, lam=np.eye(K) * 3.0 + 0.5, order=1),
        "poly-order": ltv.fit(x, u, lam=1.5, order=[-1, 3, -3, 1]),
        "lti": ltv.fit_lti(x, u),
        "posthoc-prior": ltv.fit(x, u, lam=2.0, prior=prior, prior_mode="posthoc"),
        "exact-prior": ltv.fit(x, u, lam=2.0, prior=[prior, ltv.OutputPrior(x[1:], 0.1)]),
        "no-cov": ltv.fit(x, u, lam=2.0, compute_cov=False),
        "no-input": ltv.fit(x, None, lam=2.0, order=2),
        "row-groups": ltv.fit(x, u, lam=np.r_[1.0, 2.0, 0.5, 1.0, 2.0, 3.0]),
    }


MODELS = _models()


def _assert_same(a, b):
    """Every public array and attribute equal (NaN == NaN)."""
    for name in ("k", "A", "B", "theta", "noise_cov", "changepoints"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        assert getattr(a, name).dtype == getattr(b, name).dtype, name
    for name in ("N", "K", "n_states", "n_inputs", "n_regressors", "norm", "cov_shared_by_rows"):
        assert getattr(a, name) == getattr(b, name), name
    for name in ("noise_var", "loglik"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(np.asarray(a.lam), np.asarray(b.lam))
    assert np.ndim(a.lam) == np.ndim(b.lam)
    if a.coeffs is None:
        assert b.coeffs is None
    else:
        np.testing.assert_array_equal(a.coeffs, b.coeffs)
    if a.cov is None:
        assert b.cov is None and b.cov_full() is None
    else:
        np.testing.assert_array_equal(a.cov, b.cov)
        np.testing.assert_array_equal(a.cov_full(), b.cov_full())
        np.testing.assert_array_equal(a.std(), b.std())
    assert a.info.keys() == b.info.keys()
    for key in a.info:
        np.testing.assert_array_equal(a.info[key], b.info[key], err_msg=key)
    np.testing.assert_array_equal(a.activation(), b.activation())
    assert a.status == b.status
    assert repr(a) == repr(b)
    assert a.summary() == b.summary()


@pytest.mark.parametrize("name", list(MODELS))
def test_save_load_round_trip_is_lossless(tmp_path, name):
    model = MODELS[name]
    path = tmp_path / f"{name}.npz"
    model.save(path)
    loaded = ltv.load(path)
    _assert_same(model, loaded)
    # and once more through a str path
    model.save(str(tmp_path / "again.npz"))
    _assert_same(model, ltv.load(str(tmp_path / "again.npz")))
    # the loaded model works
    x, u, _ = simulate_ltv(71, T=40, n=2, m=1)
    uu = u if model.n_inputs else None
    np.testing.assert_array_equal(loaded.predict(x, uu), model.predict(x, uu))


def test_load_rejects_other_files(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, a=np.zeros(3))
    with pytest.raises(ValueError, match="path"):
        ltv.load(path)


@pytest.mark.parametrize("name", list(MODELS))
def test_shapes(name):
    model = MODELS[name]
    N, n = 39, 2
    m = model.n_inputs
    p = n + m
    K = n * p
    assert model.N == N and model.K == K and model.n_states == n
    assert model.k.shape == (N, K)
    assert model.A.shape == (N, n, n)
    assert model.B.shape == (N, n, m)
    assert model.theta.shape == (N, n, p)
    np.testing.assert_array_equal(model.theta.reshape(N, K), model.k)
    for t in (0, N - 1):
        np.testing.assert_array_equal(np.hstack([model.A[t], model.B[t]]).ravel(), model.k[t])
    assert model.noise_cov.shape == (n, n)
    assert model.noise_var.shape == (model.n_outputs,)
    if model.cov is not None:
        assert model.cov.shape in ((N, p, p), (N, n, p, p), (N, K, K))
        full = model.cov_full()
        if model.cov_shared_by_rows:
            assert model.cov.shape == (N, p, p)
        elif model.cov.shape == (N, n, p, p):  # independent rows: the diagonal blocks
            blocks = full.reshape(N, n, p, n, p)
            for i in range(n):
                np.testing.assert_array_equal(model.cov[:, i], blocks[:, i, :, i])
            assert not np.any(blocks[:, 0, :, 1])
        assert full.shape == (N, K, K)
        np.testing.assert_allclose(full, np.swapaxes(full, 1, 2), atol=1e-14)
        assert np.all(np.linalg.eigvalsh(full) > -1e-12)
        assert model.std().shape == (N, K)
        np.testing.assert_allclose(
            model.std(), np.sqrt(np.diagonal(full, axis1=1, axis2=2)), rtol=1e-12
        )
    d = 1 if model.coeffs is None else len(model.coeffs) - 1
    assert model.activation().shape == (N - d,)


def test_k_is_read_only():
    model = MODELS["scalar-cov"]
    with pytest.raises(ValueError):
        model.k[0, 0] = 1.0
    with pytest.raises(ValueError):
        model.A[0, 0, 0] = 1.0


@pytest.mark.parametrize("name", ["scalar-cov", "vector-lam", "lti", "no-input"])
def test_predict_equals_manual(name):
    model = MODELS[name]
    x, u, _ = simulate_ltv(72, T=40, n=2, m=1)
    uu = u if model.n_inputs else None
    pred = model.predict(x, uu)
    assert pred.shape == (39, 2)
    manual = np.array(
        [model.A[t] @ x[t] + (model.B[t] @ u[t] if model.n_inputs else 0.0) for t in range(39)]
    )
    np.testing.assert_allclose(pred, manual, rtol=1e-13, atol=1e-14)


@pytest.mark.parametrize("name", ["scalar-cov", "vector-lam", "lti", "no-input"])
def test_simulate_equals_manual_loop(name):
    model = MODELS[name]
    rng = np.random.default_rng(73)
    x0 = rng.standard_normal(2)
    u = rng.standard_normal((40, 1))
    uu = u if model.n_inputs else None
    sim = model.simulate(x0, uu)
    assert sim.shape == (40, 2)
    manual = np.empty((40, 2))
    manual[0] = x0
    for t in range(39):
        manual[t + 1] = model.A[t] @ manual[t] + (model.B[t] @ u[t] if model.n_inputs else 0.0)
    np.testing.assert_allclose(sim, manual, rtol=1e-12, atol=1e-14)
    if model.n_inputs:  # N rows of input are enough, and a 1-d input works
        np.testing.assert_array_equal(model.simulate(x0, u[:39]), sim)
        np.testing.assert_array_equal(model.simulate(x0, u[:, 0]), sim)
        np.testing.assert_array_equal(model.simulate(list(x0), u.tolist()), sim)


def test_simulate_reproduces_noise_free_data():
    """Data generated by the model itself are reproduced exactly by simulate."""
    model = MODELS["vector-lam"]
    rng = np.random.default_rng(74)
    u = rng.standard_normal((40, 1))
    x = np.empty((40, 2))
    x[0] = [1.0, -0.5]
    for t in range(39):
        x[t + 1] = model.A[t] @ x[t] + model.B[t] @ u[t]
    np.testing.assert_allclose(model.simulate(x[0], u), x, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(model.predict(x, u), x[1:], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    "call, pattern",
    [
        (lambda mdl, x, u: mdl.predict(x[:, :1], u), r"^x:"),
        (lambda mdl, x, u: mdl.predict(x[:-1], u[:-1]), r"^x: expected T = 40"),
        (lambda mdl, x, u: mdl.predict(x, None), r"^u:"),
        (lambda mdl, x, u: mdl.predict(x, np.hstack([u, u])), r"^u:"),
        (lambda mdl, x, u: mdl.simulate(np.zeros(3), u), r"^x0:"),
        (lambda mdl, x, u: mdl.simulate(np.zeros(2), None), r"^u:"),
        (lambda mdl, x, u: mdl.simulate(np.zeros(2), u[:30]), r"^u:"),
        (lambda mdl, x, u: mdl.simulate(np.zeros(2), np.hstack([u, u])), r"^u:"),
        (lambda mdl, x, u: mdl.simulate([np.nan, 0.0], u), r"^x0:"),
    ],
)
def test_predict_and_simulate_validate(call, pattern):
    model = MODELS["scalar-cov"]
    x, u = random_data(75, 40, 2, 1)
    with pytest.raises(ValueError, match=pattern):
        call(model, x, u)


def test_activation_and_changepoints():
    model = MODELS["vector-lam"]
    c = model.coeffs
    k = np.array(model.k)
    manual = np.linalg.norm(c[0] * k[:-2] + c[1] * k[1:-1] + c[2] * k[2:], axis=1)
    np.testing.assert_allclose(model.activation(), manual, rtol=1e-12)
    # a smooth fit changes at every step; an LTI model never
    np.testing.assert_array_equal(model.changepoints, np.arange(1, 39))
    assert MODELS["lti"].changepoints.size == 0
    np.testing.assert_allclose(MODELS["lti"].activation(), 0.0, atol=0)
    assert ltv.fit(*simulate_ltv(71, T=40, n=2, m=1)[:2], lam=np.inf).changepoints.size == 0


@pytest.mark.parametrize("name", list(MODELS))
def test_repr_and_summary(name):
    model = MODELS[name]
    text = repr(model)
    assert "N=39" in text and "n_states=2" in text and f"norm={model.norm!r}" in text
    assert f"n_inputs={model.n_inputs}" in text
    summary = model.summary()
    assert summary.startswith(text)


def test_info_contents():
    model = MODELS["scalar-cov"]
    for key in ("solver", "objective", "rss", "penalty", "noise_var_estimated"):
        assert key in model.info
    assert model.info["objective"] == pytest.approx(model.info["rss"] + model.info["penalty"])
    assert model.info["rss"] == pytest.approx(
        np.sum(
            (
                model.predict(*simulate_ltv(71, T=40, n=2, m=1)[:2])
                - simulate_ltv(71, T=40, n=2, m=1)[0][1:]
            )
            ** 2
        ),
        rel=1e-10,
    )


@pytest.mark.parametrize(
    "build",
    [
        lambda k, **kw: ltv.RegressionModel(k, 2, 3, **kw),
        lambda k, **kw: ltv.LTVModel(k, 2, 1, **kw),
        lambda k, **kw: ltv.ARXModel(k, 2, 1, 1, 1, 1, False, **kw),
        lambda k, **kw: ltv.ARModel(k, 2, 1, True, **kw),
    ],
)
def test_copy_false_takes_a_float_array_as_it_is(build):
    k = np.random.default_rng(0).standard_normal((7, 6))
    assert not np.shares_memory(build(k).k, k)  # the default: a copy
    assert np.shares_memory(build(k, copy=False).k, k)
    # anything else is converted and checked as always
    listed = build(k.tolist(), copy=False)
    np.testing.assert_array_equal(listed.k, k)
    bad = k.copy()
    bad[3, 2] = np.nan
    with pytest.raises(ValueError, match="k"):
        build(bad, copy=False)
    with pytest.raises(TypeError, match="copy"):
        build(k, copy="no")


def test_a_fitted_model_shares_no_memory_with_the_data():
    data = ltv.systems.jump_linear(T=200, change_at=100, seed=0)
    model = ltv.fit(data.x, data.u, lam=10.0)
    assert not np.shares_memory(model.k, data.x) and not np.shares_memory(model.k, data.u)


def test_a_model_with_huge_coefficients_summarizes_without_overflow():
    """Coefficients near 1e300 (finite, accepted): their change points and summary come
    without numpy's overflow warning (the squares of the differences overflowed)."""
    k = 0.3 * np.random.default_rng(0).standard_normal((8, 4)) * 1e300
    model = ltv.LTVModel(k, 2, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(model.changepoints, np.arange(1, 8))
        assert "change" in model.summary().lower()
