"""Real recordings: missing samples, several trajectories, weights, an intercept, u=None.

Every estimate is checked against a dense closed form built here from the raw
data (rows of missing transitions removed, trajectories stacked, rows scaled
by √w), independent of the library's banded solvers.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from dense_reference import coefficients, difference_matrix, relerr

import ltvmodels as ltv

ORDERS = [1, 2, [-1, 3, -3, 1]]
ORDER_IDS = ["order1", "order2", "cubic"]


def batch(seed, R=3, T=40, n=2, m=1, noise=0.05):
    """R trajectories of one slowly varying system, each with its own input and noise."""
    rng = np.random.default_rng(seed)
    x = np.zeros((R, T, n))
    u = rng.standard_normal((R, T, m))
    x[:, 0] = rng.standard_normal((R, n))
    for t in range(T - 1):
        a = 0.6 + 0.3 * np.sin(2 * np.pi * t / T)
        A = np.array([[a, 0.2], [-0.1, 0.5]])[:n, :n]
        B = np.ones((n, m)) * 0.5
        x[:, t + 1] = x[:, t] @ A.T + u[:, t] @ B.T + noise * rng.standard_normal((R, n))
    return x, u


def dense_fit(x, u, lam, coeffs, weights=None, constant=False):
    """argmin Σ_r Σ_t w_rt ‖x^r_{t+1} − Θ_t φ^r_t‖² + λ² ‖Dk‖² by dense normal equations.

    Rows with a non-finite entry are dropped. Returns k (N, K) and H⁻¹ (NK × NK).
    """
    x = x[None] if x.ndim == 2 else x
    u = u[None] if u.ndim == 2 else u
    R, T, n = x.shape
    cols = [x[:, :-1], u[:, :-1]] + ([np.ones((R, T - 1, 1))] if constant else [])
    phi, y = np.concatenate(cols, axis=2), x[:, 1:]
    N, p = T - 1, phi.shape[2]
    K = n * p
    w = np.ones((R, N)) if weights is None else weights
    rows, rhs = [], []
    for r in range(R):
        for t in range(N):
            if not (np.all(np.isfinite(phi[r, t])) and np.all(np.isfinite(y[r, t]))):
                continue
            for i in range(n):
                row = np.zeros(N * K)
                row[t * K + i * p : t * K + (i + 1) * p] = np.sqrt(w[r, t]) * phi[r, t]
                rows.append(row)
                rhs.append(np.sqrt(w[r, t]) * y[r, t, i])
    Phi, Y = np.array(rows), np.array(rhs)
    D = np.kron(difference_matrix(N, coeffs), np.eye(K))
    H = Phi.T @ Phi + lam**2 * D.T @ D
    k = np.linalg.solve(H, Phi.T @ Y)
    return k.reshape(N, K), np.linalg.inv(H)


def with_gaps(x, u, seed, fraction=0.1):
    rng = np.random.default_rng(seed)
    x, u = x.copy(), u.copy()
    x[rng.random(x.shape[:-1]) < fraction, rng.integers(x.shape[-1])] = np.nan
    u[rng.random(u.shape[:-1]) < fraction / 2] = np.nan
    return x, u


# -- the data term: missing rows, trajectories, weights --------------------------------------


@pytest.mark.parametrize("order", ORDERS, ids=ORDER_IDS)
def test_missing_samples_equal_dense_fit_with_rows_removed(order):
    x, u = batch(1, R=1)
    x, u = with_gaps(x[0], u[0], seed=2)
    coeffs = coefficients(order)
    model = ltv.fit(x, u, lam=3.0, order=order, noise_var=0.5)
    k, H_inv = dense_fit(x, u, 3.0, coeffs)
    assert relerr(model.k, k) < 1e-8
    N, K = k.shape
    blocks = np.stack([H_inv[t * K : (t + 1) * K, t * K : (t + 1) * K] for t in range(N)])
    assert relerr(model.cov_full(), 0.5 * blocks) < 1e-7
    assert model.n_missing > 0


@pytest.mark.parametrize("order", ORDERS, ids=ORDER_IDS)
def test_trajectories_and_weights_equal_dense_fit(order):
    x, u = batch(3, R=3)
    x, u = with_gaps(x, u, seed=4, fraction=0.05)
    w = np.random.default_rng(5).uniform(0.2, 2.0, (3, x.shape[1] - 1))
    coeffs = coefficients(order)
    k, _ = dense_fit(x, u, 2.0, coeffs, weights=w)
    model = ltv.fit(x, u, lam=2.0, order=order, weights=w)
    assert model.N == x.shape[1] - 1 and relerr(model.k, k) < 1e-8
    # a list of R arrays is the same batch; weights (N,) broadcast over the trajectories
    listed = ltv.fit(list(x), list(u), lam=2.0, order=order, weights=w)
    np.testing.assert_array_equal(listed.k, model.k)
    shared = ltv.fit(x, u, lam=2.0, order=order, weights=w[0])
    assert relerr(shared.k, dense_fit(x, u, 2.0, coeffs, weights=np.tile(w[0], (3, 1)))[0]) < 1e-8


def test_zero_weight_equals_missing_and_batch_equals_summed_gram():
    x, u = batch(6, R=2)
    w = np.ones((2, x.shape[1] - 1))
    w[0, 10:14] = 0.0
    xm = x.copy()
    xm[0, 11:14] = np.nan  # transitions 10 … 13 of trajectory 0 lose a sample
    a = ltv.fit(x, u, lam=2.0, weights=w)
    b = ltv.fit(xm, u, lam=2.0)
    np.testing.assert_allclose(a.k, b.k, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("gap", [1, 50])
def test_gaps_are_bridged_and_covariance_grows_there(gap):
    x, u = batch(7, R=1, T=160)
    x, u = x[0].copy(), u[0]
    x[60 : 60 + gap] = np.nan
    model = ltv.fit(x, u, lam=5.0)
    k, _ = dense_fit(x, u, 5.0, coefficients(1))
    assert relerr(model.k, k) < 1e-8
    assert np.all(np.isfinite(model.k))
    std = model.std()[:, 0]
    inside = std[60 : 59 + gap].max() if gap > 1 else std[59]
    assert inside > 1.2 * np.median(std[:40])
    assert model.n_missing == gap + 1


def test_missing_first_and_last_sample():
    x, u = batch(8, R=1)
    x, u = x[0].copy(), u[0].copy()
    x[0] = np.nan
    x[-1, 1] = np.nan
    model = ltv.fit(x, u, lam=2.0, order=2)
    assert relerr(model.k, dense_fit(x, u, 2.0, coefficients(2))[0]) < 1e-8
    lti = ltv.fit_lti(x, u)
    keep = np.all(np.isfinite(np.hstack([x[:-1], x[1:]])), axis=1)
    phi = np.hstack([x[:-1], u[:-1]])[keep]
    coef = np.linalg.lstsq(phi, x[1:][keep], rcond=None)[0].T
    np.testing.assert_allclose(lti.theta[0], coef, rtol=1e-10, atol=1e-12)
    assert lti.n_missing == 2


def test_records_joined_by_a_nan_row_are_independent_experiments():
    x, u = batch(9, R=2, T=30)
    joined_x = np.concatenate([x[0], np.full((1, 2), np.nan), x[1]])
    joined_u = np.concatenate([u[0], np.zeros((1, 1)), u[1]])
    a = ltv.fit_lti(joined_x, joined_u)
    b = ltv.fit_lti(x, u)  # the two records as a batch
    np.testing.assert_allclose(a.theta[0], b.theta[0], rtol=1e-10)


def test_missing_data_errors():
    x, u = batch(10, R=1)
    x, u = x[0], u[0]
    allnan = x.copy()
    allnan[:, 1] = np.nan
    with pytest.raises(ValueError, match=r"^x: state 1 has no observed samples"):
        ltv.fit(allnan, u, lam=1.0)
    sparse = np.full_like(x, np.nan)
    sparse[::7] = x[::7]
    with pytest.raises(ValueError, match=r"^x: too few observed samples: 0 of 39"):
        ltv.fit(sparse, u, lam=1.0)
    with pytest.raises(ValueError, match=r"^x: expected finite values or NaN"):
        ltv.fit(np.where(np.arange(40)[:, None] == 3, np.inf, x), u, lam=1.0)
    with pytest.raises(ValueError, match="pad the shorter ones with NaN"):
        ltv.fit([x, x[:-3]], [u, u[:-3]], lam=1.0)
    with pytest.raises(ValueError, match=r"^weights: expected weights >= 0"):
        ltv.fit(x, u, lam=1.0, weights=-np.ones(39))
    with pytest.raises(ValueError, match=r"^weights: expected shape \(39,\)"):
        ltv.fit(x, u, lam=1.0, weights=np.ones(40))


def test_transposed_input_fails_fast_without_allocating():
    x = np.random.default_rng(0).standard_normal((400, 2))
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"time on axis 0.*shape \(2, 400\).*pass x\.T"):
            ltv.fit(x.T, None, lam=30)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1e6  # the (K, K) weight of K = 400 * 402 states would be 200 GB


# -- noise per output -----------------------------------------------------------------------


def test_noise_variance_per_output_tracks_each_equation():
    rng = np.random.default_rng(11)
    T = 400
    x = np.zeros((T, 2))
    for t in range(T - 1):
        x[t + 1] = [0.8 * x[t, 0], 0.5 * x[t, 1]] + np.array([1.0, 0.1]) * rng.standard_normal(2)
    model = ltv.fit(x, None, lam=100.0)
    np.testing.assert_allclose(model.noise_var, [1.0, 0.01], rtol=0.2)
    # the estimate does not depend on the variances; std() scales with each σ_i
    given = ltv.fit(x, None, lam=100.0, noise_var=[1.0, 1.0])
    np.testing.assert_allclose(given.k, model.k, rtol=1e-12)
    ratio = model.std() / given.std()
    np.testing.assert_allclose(ratio[:, :2], np.sqrt(model.noise_var[0]), rtol=1e-10)
    np.testing.assert_allclose(ratio[:, 2:], np.sqrt(model.noise_var[1]), rtol=1e-10)
    # λ by marginal likelihood profiles each σ_i out: the scores are the models' logliks
    sel = ltv.select_lambda(x, None, lams=[10.0, 100.0])
    assert sel.scores[1] == pytest.approx(model.loglik, rel=1e-10)


# -- the intercept ----------------------------------------------------------------------------


def test_intercept_equals_an_extra_constant_input():
    x, u = batch(12, R=1)
    x, u = x[0] + 3.0, u[0]
    ones = np.hstack([u, np.ones((len(u), 1))])
    for norm, lam in (("sq", 2.0), ("group", 0.5), ("l1", 0.5)):
        a = ltv.fit(x, u, lam=lam, norm=norm, constant=True)
        b = ltv.fit(x, ones, lam=lam, norm=norm)
        np.testing.assert_allclose(a.k, b.k, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(a.c, b.B[:, :, 1], rtol=1e-7, atol=1e-9)
        assert a.constant and a.K == 2 * 4
    a, b = ltv.fit_lti(x, u, constant=True), ltv.fit_lti(x, ones)
    np.testing.assert_allclose(a.k, b.k, rtol=1e-10)
    a = ltv.fit_piecewise(x, u, [20], constant=True)
    np.testing.assert_allclose(a.k, ltv.fit_piecewise(x, ones, [20]).k, rtol=1e-10)
    a = ltv.fit_segments(x, u, n_changes=1, constant=True)
    b = ltv.fit_segments(x, ones, n_changes=1)
    np.testing.assert_array_equal(a.changepoints, b.changepoints)
    np.testing.assert_allclose(a.k, b.k, rtol=1e-10)
    sel_a = ltv.select_lambda(x, u, constant=True, lams=[1.0, 10.0])
    sel_b = ltv.select_lambda(x, ones, lams=[1.0, 10.0])
    np.testing.assert_allclose(sel_a.scores, sel_b.scores, rtol=1e-10)


def test_predict_and_simulate_include_the_intercept_and_take_batches():
    x, u = batch(13, R=3)
    model = ltv.fit(x + 1.0, u, lam=3.0, constant=True)
    pred = model.predict(x + 1.0, u)
    assert pred.shape == (3, model.N, 2)
    phi = np.concatenate([x[:, :-1] + 1.0, u[:, :-1], np.ones((3, model.N, 1))], axis=2)
    np.testing.assert_allclose(pred, np.einsum("tij,rtj->rti", model.theta, phi), rtol=1e-12)
    np.testing.assert_allclose(model.predict(x[0] + 1.0, u[0]), pred[0], rtol=1e-12)
    sims = model.simulate(x[:, 0] + 1.0, u)
    assert sims.shape == x.shape
    for r in range(3):
        xs = [x[r, 0] + 1.0]
        for t in range(model.N):
            xs.append(model.A[t] @ xs[-1] + model.B[t] @ u[r, t] + model.c[t])
        np.testing.assert_allclose(sims[r], np.array(xs), rtol=1e-10)
    # a saved model keeps its intercept
    assert ltv.LTVModel.from_structure(model.k, model.structure(), model.record).constant


# -- autonomous systems everywhere --------------------------------------------------------------


def test_every_estimator_takes_u_none():
    rng = np.random.default_rng(14)
    T = 120
    x = np.zeros((T, 2))
    for t in range(T - 1):
        a = 0.9 if t < 60 else -0.5
        x[t + 1] = [[a, 0.1], [0.0, 0.7]] @ x[t] + rng.standard_normal(2)
    n_params = 2 * 2
    for norm in ("sq", "group", "l1"):
        model = ltv.fit(x, None, lam=5.0 if norm == "sq" else 20.0, norm=norm)
        assert model.B.shape == (T - 1, 2, 0) and model.K == n_params
    lam = 0.5 * ltv.lambda_max(x, None, norm="group")
    refined = ltv.fit(x, None, lam=lam, norm="group", refine=True)
    assert refined.n_inputs == 0 and refined.norm == "piecewise"
    assert ltv.fit_lti(x).n_inputs == 0
    seg = ltv.fit_segments(x, None, n_changes=1, min_size=10)
    assert seg.changepoints.size == 1 and abs(int(seg.changepoints[0]) - 60) <= 5
    assert ltv.fit_piecewise(x, None, [60]).n_inputs == 0
    assert len(ltv.fit_path(x, None, lams=[5.0, 20.0], norm="group")) == 2
    for norm in ("sq", "group", "l0"):
        assert ltv.select_lambda(x, None, norm=norm).lam > 0
    assert ltv.lambda_max(x, None, norm="group") > 0
    filt = ltv.kalman_filter(x, None, lam=5.0)
    smooth = ltv.kalman_smoother(x, None, lam=5.0)
    np.testing.assert_allclose(
        smooth.k, ltv.fit(x, None, lam=5.0, noise_var=1.0).k, rtol=1e-8, atol=1e-10
    )
    assert filt.k.shape == (T - 1, n_params)
    online = ltv.OnlineParameterFilter(2, 0, lam=5.0)
    for t in range(T - 1):
        online.update(x[t], None, x[t + 1])
    np.testing.assert_allclose(online.k, filt.k[-1], rtol=1e-8)
    assert ltv.find_changepoints(ltv.fit(x, None, lam=20.0, norm="group")).size >= 1
    model = ltv.fit(x, None, lam=5.0)
    assert model.predict(x).shape == (T - 1, 2) and model.simulate(x[0]).shape == (T, 2)


def test_kalman_filters_skip_missing_samples():
    x, u = batch(15, R=1, T=60)
    x, u = x[0].copy(), u[0]
    x[20] = np.nan
    smooth = ltv.kalman_smoother(x, u, lam=3.0, noise_var=0.01)
    fit = ltv.fit(x, u, lam=3.0, noise_var=0.01)
    np.testing.assert_allclose(smooth.k, fit.k, rtol=1e-7, atol=1e-9)
    assert smooth.loglik == pytest.approx(fit.loglik, rel=1e-9)
    online = ltv.OnlineParameterFilter(2, 1, lam=3.0, noise_var=0.01)
    for t in range(59):
        online.update(x[t], u[t], x[t + 1])
    filt = ltv.kalman_filter(x, u, lam=3.0, noise_var=0.01)
    np.testing.assert_allclose(online.k, filt.k[-1], rtol=1e-8)


# -- the other estimators on batches and gaps ----------------------------------------------------


def test_segments_and_selection_on_batches_with_gaps():
    rng = np.random.default_rng(16)
    R, T = 4, 80
    x = np.zeros((R, T, 1))
    for t in range(T - 1):
        a = 0.9 if t < 40 else -0.5
        x[:, t + 1, 0] = a * x[:, t, 0] + rng.standard_normal(R)
    x[1, 10:13] = np.nan
    seg = ltv.fit_segments(x, None, n_changes=1)
    assert abs(int(seg.changepoints[0]) - 40) <= 2
    np.testing.assert_allclose(seg.A[0, 0, 0], 0.9, atol=0.1)
    # the cost sums the trajectories: one segment's RSS is the pooled least squares
    y, phi = x[:, 1:, 0], x[:, :-1, 0]
    keep = np.isfinite(y) & np.isfinite(phi)
    a = np.sum(phi[keep] * y[keep]) / np.sum(phi[keep] ** 2)
    assert seg.info["costs_by_n_changes"][0] == pytest.approx(
        np.sum((y[keep] - a * phi[keep]) ** 2), rel=1e-10
    )
    for method in ("ml", "gcv", "cv"):
        assert ltv.select_lambda(x, None, method=method).lam > 0
    assert ltv.fit(x, None, lam="auto", norm="group").info["lam_selection"]["lam"] > 0


def test_ar_with_missing_samples_and_several_series():
    rng = np.random.default_rng(17)
    y = np.zeros((3, 200))
    for t in range(2, 200):
        y[:, t] = 1.5 * y[:, t - 1] - 0.8 * y[:, t - 2] + rng.standard_normal(3)
    y_gap = y.copy()
    y_gap[0, 50] = np.nan
    model = ltv.fit_ar(y_gap[..., None], 2, lam=1e4, constant=True)
    # rows needing y[50] (as output or as one of its two lags) are left out
    assert model.n_missing == 3
    np.testing.assert_allclose(np.median(model.theta[:, 0, :2], axis=0), [1.5, -0.8], atol=0.1)
    y_out, phi = ltv.ar_regressors(y[1], 2)
    single = ltv.fit_ar(y[1], 2, lam=1e4)
    reg = ltv.fit_regression(y_out, phi, lam=1e4)
    np.testing.assert_allclose(single.k, reg.k, rtol=1e-10)


@pytest.mark.filterwarnings("ignore::ltvmodels.ModelStructureWarning")  # a level, by design
def test_ar_predictions_and_regressors_mark_missing_lags():
    rng = np.random.default_rng(18)
    y = np.cumsum(rng.standard_normal(60)) * 0.1
    model = ltv.fit_ar(y, 2, lam=100.0)
    gap = y.copy()
    gap[30] = np.nan
    pred = model.predict(gap)
    # ŷ[t] needs y[t−1], y[t−2]: model indices 29 and 30 (t = 31, 32) are NaN, no others
    assert np.flatnonzero(np.isnan(pred)).tolist() == [29, 30]
    np.testing.assert_allclose(np.delete(pred, [29, 30]), np.delete(model.predict(y), [29, 30]))
    y_out, phi = ltv.ar_regressors(gap, 2)
    bad = ~(np.isfinite(y_out).all(axis=1) & np.isfinite(phi).all(axis=1))
    assert np.flatnonzero(bad).tolist() == [28, 29, 30]
    reg = ltv.fit_regression(y_out, phi, lam=100.0)
    np.testing.assert_allclose(reg.k, ltv.fit_ar(gap, 2, lam=100.0).k, rtol=1e-10)


def test_simulation_ignores_the_unused_last_input():
    x, u = batch(19, R=1)
    model = ltv.fit(x[0], u[0], lam=3.0)
    last_missing = u[0].copy()
    last_missing[-1] = np.nan
    np.testing.assert_array_equal(
        model.simulate(x[0, 0], last_missing), model.simulate(x[0, 0], u[0])
    )
    with pytest.raises(ValueError, match="u: expected finite inputs"):
        model.simulate(x[0, 0], np.where(np.arange(40)[:, None] == 5, np.nan, u[0]))


def test_dataframe_column_names_name_the_model(tmp_path):
    """States and inputs keep their DataFrame column names through fit, save/load and the
    plots; arrays keep the default names."""
    pd = pytest.importorskip("pandas")
    data = ltv.systems.jump_linear(T=120, change_at=60, seed=0)
    x = pd.DataFrame(data.x, columns=["position", "velocity"])
    u = pd.DataFrame(data.u, columns=["force"])
    for model in (
        ltv.fit(x, u, lam=10.0),
        ltv.fit(x, u, lam=1.0, norm="group", refine=True),
        ltv.fit_lti(x, u),
        ltv.fit_piecewise(x, u, [60]),
        ltv.fit_segments(x, u, n_changes=1),
    ):
        assert model.state_names == ["position", "velocity"]
        assert model.input_names == ["force"]
    model = ltv.fit(x, u["force"], lam=10.0)  # a named Series
    assert model.input_names == ["force"]
    model.save(tmp_path / "m.npz")
    loaded = ltv.load(tmp_path / "m.npz")
    assert loaded.state_names == ["position", "velocity"] and loaded.input_names == ["force"]
    titles = [ax.get_title() for ax in loaded.plot().axes[:3]]
    assert titles == ["A[position,position]", "A[position,velocity]", "B[position,force]"]
    plain = ltv.fit(data.x, data.u, lam=10.0)
    assert plain.state_names == ["x0", "x1"] and not plain.data.names


def test_a_datetime_index_times_the_model(tmp_path):
    """The index of x is model.time; change point c is reported at the time of x[c + 1]
    (the first state the new coefficients produce); it survives save/load and indexes
    to_frame."""
    pd = pytest.importorskip("pandas")
    data = ltv.systems.jump_linear(T=120, change_at=60, seed=0)
    index = pd.date_range("2021-03-01", periods=120, freq="D", tz="Europe/Stockholm")
    x = pd.DataFrame(data.x, columns=["position", "velocity"], index=index)
    u = pd.Series(data.u[:, 0], name="force", index=index)
    model = ltv.fit(x, u, lam=30.0, norm="group")
    expected = index.tz_convert("UTC").tz_localize(None).to_numpy()
    np.testing.assert_array_equal(model.time, expected)
    assert model.changepoints.tolist() == [60]
    np.testing.assert_array_equal(model.changepoint_times, expected[[61]])
    model.save(tmp_path / "m.npz")
    loaded = ltv.load(tmp_path / "m.npz")
    np.testing.assert_array_equal(loaded.changepoint_times, expected[[61]])
    frame = loaded.to_frame()
    assert frame.index.name == "time" and frame.index[0] == pd.Timestamp(expected[0])
    # numbers keep their values; the default index 0 … T−1 is no time
    years = ltv.fit(pd.DataFrame(data.x, index=1900.0 + np.arange(120)), lam=10.0)
    assert years.time[0] == 1900.0
    assert ltv.fit(pd.DataFrame(data.x), lam=10.0).time is None
    assert ltv.fit(data.x, lam=10.0).changepoint_times is None


def test_a_forecast_continues_a_regular_time_index():
    pd = pytest.importorskip("pandas")
    import matplotlib

    matplotlib.use("Agg")
    data = ltv.systems.jump_linear(T=120, change_at=60, seed=0)
    days = pd.date_range("2021-01-01", periods=120, freq="D")
    model = ltv.fit(pd.DataFrame(data.x, index=days), pd.DataFrame(data.u, index=days), lam=10.0)
    forecast = model.forecast(data.x[-1], np.zeros(3))
    expected = (days[-1] + pd.to_timedelta([1, 2, 3], unit="D")).to_numpy()
    np.testing.assert_array_equal(forecast.time, expected)
    fig = forecast.plot(history=data.x[-10:])
    assert fig.axes[-1].get_xlabel() == "time"
    # stamps missing from the daily grid are missing samples: the calendar goes on
    gappy = days.delete(5).append(pd.DatetimeIndex(["2021-06-01"]))
    with pytest.warns(ltv.DataWarning, match="32 time stamps missing"):
        model = ltv.fit(
            pd.DataFrame(data.x, index=gappy), pd.DataFrame(data.u, index=gappy), lam=10.0
        )
    assert model.N == 151
    np.testing.assert_array_equal(
        model.forecast(data.x[-1], np.zeros(2)).time,
        pd.to_datetime(["2021-06-02", "2021-06-03"]).to_numpy(),
    )


def test_xarray_dataarrays_name_and_time_the_model():
    xr = pytest.importorskip("xarray")
    pd = pytest.importorskip("pandas")
    data = ltv.systems.jump_linear(T=120, change_at=60, seed=0)
    days = pd.date_range("2021-03-01", periods=120, freq="D")
    x = xr.DataArray(
        data.x, dims=("time", "state"), coords={"time": days, "state": ["position", "velocity"]}
    )
    u = xr.DataArray(data.u[:, 0], dims=("time",), coords={"time": days}, name="force")
    model = ltv.fit(x, u, lam=30.0, norm="group")
    assert model.state_names == ["position", "velocity"] and model.input_names == ["force"]
    np.testing.assert_array_equal(model.time, days.to_numpy())
    assert model.changepoint_times[0] == days[61]
