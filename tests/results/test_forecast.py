"""Forecasts with prediction intervals: ``LTVModel.forecast``, ``ARXModel.forecast``, ``Forecast``.

The first step is checked against its closed form, the Monte Carlo steps
against an independent simulation, the exact (Gaussian) path against the
model's simulation, and the intervals' coverage on systems drawn from the
model's own assumptions (random-walk coefficients with drift σ/λ).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from dense_reference import simulate_ltv, weight_matrix
from scipy.linalg import solve_discrete_lyapunov

import ltvmodels as ltv

# -- data -------------------------------------------------------------------------------------

SIGMA = np.array([0.1, 0.2])  # noise of the two state equations


def random_walk_system(seed: int, T: int, H: int, lam: float, sigma=SIGMA):
    """x (T + H, 2), u (T + H, 1) from the model of norm="sq", order 1.

    x[t+1] = Θ_t [x_t; u_t] + v_t, v_t ~ N(0, diag σ²), and each row i of Θ
    takes a random-walk step of covariance σ_i²/λ² I after every transition.
    The first T samples are the data, the last H the future to forecast.
    """
    rng = np.random.default_rng(seed)
    n, m = 2, 1
    theta = np.hstack(
        [0.5 * np.eye(n) + 0.1 * rng.standard_normal((n, n)), rng.standard_normal((n, m))]
    )
    x = np.zeros((T + H, n))
    u = rng.standard_normal((T + H, m))
    x[0] = rng.standard_normal(n)
    for t in range(T + H - 1):
        x[t + 1] = theta @ np.r_[x[t], u[t]] + sigma * rng.standard_normal(n)
        theta = theta + (sigma / lam)[:, None] * rng.standard_normal(theta.shape)
    return x, u


@pytest.fixture(scope="module")
def data():
    x, u, _ = simulate_ltv(5, T=50, n=2, m=1)
    return x, u


def closed_form_step(model, x0, u0, W=None):
    """Mean and covariance of the first forecast step, built here from the model's arrays."""
    n, p = model.n_outputs, model.n_regressors
    phi = np.concatenate([x0, np.atleast_1d(u0), [1.0] if model.constant else []])
    cov_k = model.cov_full()[-1]
    if W is not None:  # drift σ_i² W⁻¹ in row i
        root = np.sqrt(np.repeat(model.noise_var, p))
        cov_k = cov_k + root[:, None] * np.linalg.inv(W) * root[None, :]
    lift = np.kron(np.eye(n), phi)
    return model.theta[-1] @ phi, lift @ cov_k @ lift.T + model.noise_cov


# -- the first step: exact --------------------------------------------------------------------


@pytest.mark.parametrize(
    "lam, constant",
    [
        (3.0, False),
        (3.0, True),
        (np.array([1.0, 2.0, np.inf, 1.5, 0.7, 3.0]), False),
        (np.eye(6) * 4.0 + 0.5, False),
    ],
)
def test_first_step_is_the_closed_form(data, lam, constant):
    x, u = data
    noise_var = 0.02 if np.ndim(lam) == 2 else np.array([0.01, 0.04])
    model = ltv.fit(x, u, lam=lam, noise_var=noise_var, constant=constant)
    u_future = np.array([[0.3], [-1.0], [0.5]])
    f = model.forecast(x[-1], u_future, level=0.9)
    assert f.method == "monte_carlo" and f.mean.shape == (3, 2) and f.cov.shape == (3, 2, 2)
    W = weight_matrix(lam, model.K)
    W[np.isinf(W)] = 1e300  # λ_j = inf: no drift of coefficient j
    mean, cov = closed_form_step(model, x[-1], u_future[0], W)
    np.testing.assert_allclose(f.mean[0], mean, rtol=1e-12)
    np.testing.assert_allclose(f.cov[0], cov, rtol=1e-10)
    z = 1.6448536269514722  # the 95 % quantile of N(0, 1): a central 90 % interval
    sd = np.sqrt(np.diag(cov))
    np.testing.assert_allclose(f.lower[0], mean - z * sd, rtol=1e-12)
    np.testing.assert_allclose(f.upper[0], mean + z * sd, rtol=1e-12)


def test_first_step_without_drift_uses_the_estimates_covariance(data):
    x, u = data
    for model in (ltv.fit_lti(x, u), ltv.fit_piecewise(x, u, [20])):
        f = model.forecast(x[-1], [[0.2], [0.1]])
        mean, cov = closed_form_step(model, x[-1], 0.2)
        np.testing.assert_allclose(f.mean[0], mean, rtol=1e-12)
        np.testing.assert_allclose(f.cov[0], cov, rtol=1e-10)


def test_monte_carlo_steps_agree_with_an_independent_simulation(data):
    x, u = data
    lam = 4.0
    model = ltv.fit(x, u, lam=lam)
    u_future = np.array([[0.5], [-0.8], [1.2]])
    f = model.forecast(x[-1], u_future, n_samples=100_000, seed=1)
    # the same model simulated here: k_{N−1} ~ N(k̂, P), k_{t+1} = k_t + w_t, w ~ N(0, σ_i²/λ²)
    rng = np.random.default_rng(99)
    S, n, p = 100_000, 2, 3
    k = rng.multivariate_normal(model.k[-1], model.cov_full()[-1], size=S)
    drift_sd = np.repeat(np.sqrt(model.noise_var), p) / lam
    noise = np.linalg.cholesky(model.noise_cov)
    state = np.broadcast_to(x[-1], (S, n))
    paths = []
    for s in range(3):
        k = k + drift_sd * rng.standard_normal((S, n * p))
        phi = np.concatenate([state, np.broadcast_to(u_future[s], (S, 1))], axis=1)
        state = (
            np.einsum("sij,sj->si", k.reshape(S, n, p), phi) + rng.standard_normal((S, n)) @ noise.T
        )
        paths.append(state)
    paths = np.array(paths)
    sd = paths.std(axis=1)
    np.testing.assert_allclose(f.mean, paths.mean(axis=1), atol=0.02 * sd.max())
    np.testing.assert_allclose(f.std(), sd, rtol=0.02)
    lo, hi = np.quantile(paths, [0.025, 0.975], axis=1)
    np.testing.assert_allclose(f.lower[1:], lo[1:], atol=0.03 * sd.max())
    np.testing.assert_allclose(f.upper[1:], hi[1:], atol=0.03 * sd.max())


# -- calibration ------------------------------------------------------------------------------

CAL_T, CAL_H, CAL_LAM = 40, 5, 4.0


def coverage(seeds, *, n_samples, drift=True):
    """Fraction of future states inside the intervals: {level: (H,) over seeds and states}."""
    hits = {0.8: [], 0.95: []}
    for seed in seeds:
        x, u = random_walk_system(seed, CAL_T, CAL_H, CAL_LAM)
        model = ltv.fit(x[:CAL_T], u[:CAL_T], lam=CAL_LAM)
        if not drift:  # the same estimate and covariance, without the random walk ahead
            model = ltv.LTVModel(model.k, 2, 1, dataclasses.replace(model.record, norm="lti"))
        future = x[CAL_T:]
        for level, found in hits.items():
            f = model.forecast(
                x[CAL_T - 1],
                u[CAL_T - 1 : CAL_T - 1 + CAL_H],
                level=level,
                n_samples=n_samples,
                seed=seed,
            )
            found.append((f.lower <= future) & (future <= f.upper))
    return {level: np.mean(found, axis=(0, 2)) for level, found in hits.items()}


def test_intervals_are_calibrated_on_the_models_own_assumptions():
    # 400 systems x 2 states per level; the binomial sd of a coverage is 0.8 % at 0.95 and
    # 1.4 % at 0.8, and the noise variance estimated from 39 transitions costs about 1 %
    found = coverage(range(400), n_samples=1000)
    for level, tol in ((0.8, 0.05), (0.95, 0.035)):
        for step in (0, 4):  # steps 1 and 5
            assert abs(found[level][step] - level) < tol, (level, step + 1, found[level])


def test_calibration_needs_the_drift():
    """Without the random walk after the data the 95 % intervals cover clearly less."""
    found = coverage(range(200), n_samples=500, drift=False)
    assert found[0.95][4] < 0.9


@pytest.mark.slow
def test_intervals_are_calibrated_many_systems():
    found = coverage(range(1000, 4000), n_samples=4000)
    for level in (0.8, 0.95):
        for step in range(CAL_H):
            assert abs(found[level][step] - level) < 0.02, (level, step + 1, found[level])


# -- the continued coefficients and the exact path --------------------------------------------


def test_order_2_continues_the_trend(data):
    x, u = data
    model = ltv.fit(x, u, lam=20.0, order=2)
    f = model.forecast(x[-1], np.zeros((4, 1)))
    slope = model.theta[-1] - model.theta[-2]
    expected = model.theta[-1] + np.arange(1, 5)[:, None, None] * slope
    np.testing.assert_allclose(f.coefficients, expected, rtol=1e-10, atol=1e-12)
    cubic = ltv.fit(x, u, lam=20.0, order=[-1, 3, -3, 1])  # continues the quadratic
    f = cubic.forecast(x[-1], np.zeros((3, 1)))
    k = cubic.theta[-3:]
    for s in range(3):
        k = np.concatenate([k, [3 * k[-1] - 3 * k[-2] + k[-3]]])
        np.testing.assert_allclose(f.coefficients[s], k[-1], rtol=1e-10, atol=1e-12)
    first = ltv.fit(x, u, lam=20.0)  # order 1: stays at the last estimate
    f = first.forecast(x[-1], np.zeros((3, 1)))
    np.testing.assert_array_equal(f.coefficients, np.broadcast_to(first.theta[-1], (3, 2, 3)))


def test_sparse_models_stay_constant_and_forecast_exactly(data):
    x, u = data
    model = ltv.fit(x, u, lam=1.0, norm="group")
    # without the last segment's least-squares uncertainty (no covariance, no drift) the
    # forecast is linear and Gaussian
    del model.info["last_segment_unit_cov"]
    u_future = np.array([[1.0], [0.0], [-1.0]])
    f = model.forecast(x[-1], u_future)
    assert f.method == "gaussian" and f.n_samples is None
    A, B = model.A[-1], model.B[-1]
    Q = model.noise_cov
    np.testing.assert_allclose(f.mean[0], A @ x[-1] + B @ u_future[0], rtol=1e-12)
    np.testing.assert_allclose(f.mean[1], A @ f.mean[0] + B @ u_future[1], rtol=1e-12)
    np.testing.assert_allclose(f.cov[1], A @ Q @ A.T + Q, rtol=1e-12)
    np.testing.assert_allclose(f.cov[2], A @ (A @ Q @ A.T + Q) @ A.T + Q, rtol=1e-12)


def test_inputs_and_intercept_follow_the_models_simulation():
    """With given coefficients and no noise the forecast is the model's simulation."""
    rng = np.random.default_rng(3)
    n, m, N, steps = 3, 2, 12, 5
    A = 0.4 * rng.standard_normal((n, n))
    B = rng.standard_normal((n, m))
    c = rng.standard_normal(n)
    k = np.broadcast_to(np.hstack([A, B, c[:, None]]).ravel(), (N + steps, n * (n + m + 1)))
    long = ltv.LTVModel(k, n, m, constant=True)
    short = ltv.LTVModel(k[:N], n, m, constant=True)
    u = rng.standard_normal((N + steps, m))
    x = long.simulate(rng.standard_normal(n), u)  # (N + steps + 1, n)
    f = short.forecast(x[N], u[N:], noise_cov=np.zeros((n, n)))
    np.testing.assert_allclose(f.mean, x[N + 1 :], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(f.time, np.arange(N + 1, N + 1 + steps))
    assert f.names == ["x0", "x1", "x2"]
    np.testing.assert_array_equal(f.lower, f.mean)
    f = short.forecast(x[N], u[N:], noise_cov=0.5)  # a variance: the diagonal 0.5 I
    np.testing.assert_allclose(f.cov[0], 0.5 * np.eye(n))


def test_fitted_intercept_enters_the_forecast(data):
    x, u = data
    model = ltv.fit(x + 2.0, u, lam=5.0, constant=True)
    f = model.forecast(x[-1] + 2.0, [[0.1]])
    mean, cov = closed_form_step(model, x[-1] + 2.0, 0.1, weight_matrix(5.0, model.K))
    np.testing.assert_allclose(f.mean[0], mean, rtol=1e-12)
    np.testing.assert_allclose(f.cov[0], cov, rtol=1e-10)
    assert f.coefficients.shape == (1, 2, 4)


def test_no_input_model_needs_steps(data):
    x, _ = data
    model = ltv.fit(x, None, lam=5.0)
    f = model.forecast(x[-1], steps=3)
    assert f.mean.shape == (3, 2)
    np.testing.assert_allclose(f.mean[0], model.A[-1] @ x[-1], rtol=1e-12)


def test_seeded_reproducible_and_inputs_untouched(data):
    x, u = data
    model = ltv.fit(x, u, lam=5.0)
    x0, uf = x[-1].copy(), np.array([[0.1], [0.2], [0.3]])
    before = (x0.copy(), uf.copy())
    a = model.forecast(x0, uf, seed=7)
    b = model.forecast(x0, uf, seed=7)
    c = model.forecast(x0, uf, seed=8)
    np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(a.upper, b.upper)
    assert not np.array_equal(a.upper[1:], c.upper[1:])
    np.testing.assert_array_equal(a.mean[0], c.mean[0])  # the exact step draws nothing
    np.testing.assert_array_equal(x0, before[0])
    np.testing.assert_array_equal(uf, before[1])
    assert a.n_samples == 2000 and model.forecast(x0, uf, n_samples=11).n_samples == 12
    with pytest.raises(ValueError):
        a.mean[0, 0] = 1.0
    assert np.all(a.lower < a.mean) and np.all(a.mean < a.upper)
    assert repr(a) == "Forecast(steps=3, n=2, level=0.95, method='monte_carlo', n_samples=2000)"


# -- input validation -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, error, pattern",
    [
        ({"steps": 0}, ValueError, r"steps: expected an integer >= 1, received 0"),
        ({"steps": 2}, ValueError, r"steps: expected 3 \(the number of future inputs"),
        ({"level": 1.5}, ValueError, r"level: expected a probability in \(0, 1\).*received 1.5"),
        ({"level": 0.0}, ValueError, r"level: expected a probability in \(0, 1\)"),
        ({"level": "high"}, TypeError, r"level: expected a probability"),
        ({"n_samples": 1}, ValueError, r"n_samples: expected an integer >= 2, received 1"),
        ({"seed": -1}, TypeError, r"seed: expected a non-negative integer"),
        ({"noise_cov": np.ones((3, 3))}, ValueError, r"noise_cov: expected a \(2, 2\)"),
        ({"noise_cov": [[1.0, 0.0], [0.0, -1.0]]}, ValueError, r"noise_cov: .*positive semidef"),
        (
            {"x0": [1.0, 2.0, 3.0]},
            ValueError,
            r"x0: expected .* shape \(2,\), received shape \(3,\)",
        ),
        ({"x0": [1.0, np.nan]}, ValueError, r"x0: expected finite values"),
        (
            {"u": None},
            TypeError,
            r"u: expected the future inputs, shape \(steps, 1\).*received None",
        ),
        (
            {"u": np.ones((3, 2))},
            ValueError,
            r"u: expected .*shape \(steps, 1\) or \(steps,\), "
            r"received shape \(3, 2\)",
        ),
        ({"u": np.ones((0, 1))}, ValueError, r"u: expected at least one future input"),
    ],
)
def test_forecast_validates_its_inputs(data, kwargs, error, pattern):
    x, u = data
    model = ltv.fit(x, u, lam=5.0)
    call = {"x0": x[-1], "u": np.ones((3, 1)), **kwargs}
    with pytest.raises(error, match=pattern):
        model.forecast(call.pop("x0"), call.pop("u"), **call)


def test_forecast_validation_of_the_model(data):
    x, u = data
    no_input = ltv.fit(x, None, lam=5.0)
    with pytest.raises(TypeError, match=r"steps: expected the number of steps .* received None"):
        no_input.forecast(x[-1])
    with pytest.raises(ValueError, match=r"u: the model has no inputs, expected None"):
        no_input.forecast(x[-1], np.ones((2, 1)))
    given = ltv.LTVModel(no_input.k, 2, 0)
    with pytest.raises(ValueError, match=r"noise_cov: the model has no noise covariance"):
        given.forecast(x[-1], steps=2)
    fitted = ltv.fit(x, u, lam=1.0)  # as if fitted with coefficient 1 free in time:
    free = ltv.LTVModel(
        fitted.k,
        2,
        1,
        dataclasses.replace(fitted.record, lam=np.array([1.0, 0.0, 1.0, 1.0, 1.0, 1.0])),
    )
    with pytest.raises(ValueError, match=r"lam: .*λ = 0 for coefficient 1.*unbounded"):
        free.forecast(x[-1], [[0.0]])


# -- AR/ARX -----------------------------------------------------------------------------------


def test_ar_forecast_first_step_and_trend():
    rng = np.random.default_rng(2)
    y = np.zeros(200)
    for t in range(2, 200):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.1 * rng.standard_normal()
    model = ltv.fit_ar(y, 2, lam=10.0)
    f = model.forecast(y[-2:], steps=6, level=0.8)
    assert f.mean.shape == (6, 1) and f.cov.shape == (6, 1, 1)
    np.testing.assert_array_equal(f.time, np.arange(200, 206))
    assert f.names == ["y"]  # the model's output_names
    phi = np.array([y[-1], y[-2]])  # φ = [y[t−1], y[t−2]]
    drift = model.noise_var[0] / 10.0**2
    var = phi @ (model.cov_full()[-1] + drift * np.eye(2)) @ phi + model.noise_var[0]
    np.testing.assert_allclose(f.mean[0, 0], model.theta[-1, 0] @ phi, rtol=1e-12)
    np.testing.assert_allclose(f.cov[0, 0, 0], var, rtol=1e-10)
    with pytest.raises(ValueError, match=r"y_last: expected the last 2 samples of y"):
        model.forecast(y[-3:], steps=2)
    with pytest.raises(TypeError, match=r"steps: expected the number of steps"):
        model.forecast(y[-2:], steps=None)


def test_arx_forecast_follows_the_models_simulation():
    """Given coefficients, no noise: the forecast continues the simulation (lags aligned)."""
    rng = np.random.default_rng(4)
    n, m, na, nb, nk = 2, 1, 2, 2, 1
    p = n * na + m * nb + 1
    theta = 0.3 * rng.standard_normal((n, p))
    N, steps = 15, 4
    L = max(na, nk + nb - 1)
    long = ltv.ARXModel(np.broadcast_to(theta.ravel(), (N + steps, n * p)), n, m, na, nb, nk, True)
    short = ltv.ARXModel(np.broadcast_to(theta.ravel(), (N, n * p)), n, m, na, nb, nk, True)
    u = rng.standard_normal((N + steps + L, m))
    y = long.simulate(rng.standard_normal((L, n)), u)  # (L + N + steps, n)
    T = N + L
    f = short.forecast(y[T - L : T], u[T - L :], noise_cov=np.zeros((n, n)))
    assert f.method == "gaussian" and f.mean.shape == (steps, n)
    np.testing.assert_allclose(f.mean, y[T:], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(f.time, np.arange(T, T + steps))
    with pytest.raises(ValueError, match=r"steps: expected 4"):
        short.forecast(y[T - L : T], u[T - L :], steps=3, noise_cov=np.eye(n))
    with pytest.raises(TypeError, match=r"u: expected the inputs at the 2 samples of y_last"):
        short.forecast(y[T - L : T], None, steps=3, noise_cov=np.eye(n))


def test_fitted_arx_forecast_has_intervals():
    rng = np.random.default_rng(5)
    u = rng.standard_normal(300)
    y = np.zeros(300)
    for t in range(2, 300):
        y[t] = 0.6 * y[t - 1] + 0.8 * u[t - 1] + 0.05 * rng.standard_normal()
    model = ltv.fit_arx(y, u, 1, 1, 1, lam=20.0)
    u_more = np.r_[u[-1:], rng.standard_normal(5)]
    f = model.forecast(y[-1:], u_more)
    assert f.mean.shape == (5, 1) and f.method == "monte_carlo"
    assert np.all(f.upper - f.lower > 0)
    phi = np.array([y[-1], u[-1]])
    np.testing.assert_allclose(f.mean[0, 0], model.theta[-1, 0] @ phi, rtol=1e-12)


# -- the figure -------------------------------------------------------------------------------


def test_forecast_plot_draws_mean_and_band(data):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    x, u = data
    model = ltv.fit(x, u, lam=5.0)
    f = model.forecast(x[-1], np.zeros((8, 1)))
    fig = f.plot(history=x[-20:])
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    assert [ax.get_ylabel() for ax in fig.axes] == ["x0", "x1"]
    assert fig.axes[-1].get_xlabel() == "sample"  # no time axis: sample indices
    for ax in fig.axes:
        assert len(ax.collections) == 1  # the band
        assert any(np.array_equal(line.get_xdata(), f.time) for line in ax.lines)
    fig.canvas.draw()
    again = ltv.plotting.plot_forecast(f, fig=fig)  # redraws into the same figure
    assert again is fig and len(fig.axes) == 2
    with pytest.raises(ValueError, match=r"history: expected shape \(H, 2\)"):
        f.plot(history=np.zeros((5, 3)))
    with pytest.raises(TypeError, match=r"forecast: expected a Forecast"):
        ltv.plotting.plot_forecast(np.zeros(3))


def test_an_ar2_forecast_with_noise_has_the_closed_form_mean_and_covariance():
    # y[t] = a1 y[t-1] + a2 y[t-2] + e[t], Var e = σ²: the h-step forecast variance is
    # σ² Σ_{j<h} ψ_j², with ψ_0 = 1, ψ_1 = a1, ψ_2 = a1² + a2 (it needs the covariance
    # between y[T] and the lags it shares with y[T+1]).
    a1, a2, s2 = 0.6, -0.3, 0.5
    model = ltv.ARModel(
        np.tile([a1, a2], (50, 1)),
        1,
        2,
        False,
        ltv.FitRecord(noise_var=np.array([s2]), noise_cov=np.array([[s2]])),
    )
    forecast = model.forecast(np.array([0.2, -0.1]), steps=3)  # y[T-2], y[T-1]
    assert forecast.method == "gaussian"
    psi = [1.0, a1, a1 * a1 + a2]
    variances = [s2 * sum(p * p for p in psi[:h]) for h in (1, 2, 3)]
    np.testing.assert_allclose(forecast.cov[:, 0, 0], variances, rtol=1e-12)  # 0.5, 0.68, 0.6818
    means = [a1 * -0.1 + a2 * 0.2]
    means.append(a1 * means[0] + a2 * -0.1)
    means.append(a1 * means[1] + a2 * means[0])
    np.testing.assert_allclose(forecast.mean[:, 0], means, rtol=1e-12)


# -- from the end of the data: forecast(steps=H, u=future) ------------------------------------


def test_a_fitted_model_continues_the_end_of_its_data(data):
    """The report: forecast(x0, u) needed u[0] to be the last recorded input. Now a fitted
    model remembers x[T−1] and u[T−1], and u holds only the inputs after the data."""
    x, u = data
    future = np.array([[0.3], [-1.0], [0.5], [0.2]])  # u[T] … u[T+3]
    for model in (
        ltv.fit(x, u, lam=5.0),
        ltv.fit(x, u, lam=1.0, norm="group", refine=True),
        ltv.fit_lti(x, u),
        ltv.fit_piecewise(x, u, [20]),
        ltv.fit_segments(x, u, n_changes=1),
    ):
        np.testing.assert_array_equal(model.data.tail.outputs, x[-1:])
        np.testing.assert_array_equal(model.data.tail.inputs, u[-1:])
        assert model.tail_lengths == (1, 1) and model.future_input_rows(5) == 4
        # x[T] = A x[T−1] + B u[T−1]: the recorded input first, then u[T] … u[T+3]
        explicit = model.forecast(x[-1], np.r_[u[-1:], future], level=0.9, seed=3)
        for rows in (future, np.r_[future, [[7.0]]]):  # a 5th row, u[T+4], is unused
            continued = model.forecast(steps=5, u=rows, level=0.9, seed=3)
            for name in ("mean", "lower", "upper", "cov", "time"):
                np.testing.assert_array_equal(getattr(continued, name), getattr(explicit, name))
    model = ltv.fit(x, u, lam=5.0)
    one = model.forecast(steps=1)  # x[T] needs no input after the data
    np.testing.assert_allclose(one.mean[0], model.theta[-1] @ np.r_[x[-1], u[-1]], rtol=1e-12)
    assert model.forecast(u=future).steps == 4  # steps defaults to len(u)
    autonomous = ltv.fit(x, None, lam=5.0)
    np.testing.assert_array_equal(
        autonomous.forecast(steps=3).mean, autonomous.forecast(x[-1], steps=3).mean
    )


@pytest.mark.parametrize(
    "kwargs, error, pattern",
    [
        (
            {"steps": 5, "u": np.ones((3, 1))},
            ValueError,
            r"u: expected 4 rows of inputs after the data for steps=5, u\[T\] … u\[T\+3\] "
            r"\(x\[T\] is driven by the last recorded input u\[T−1\].*up to 5.*received 3",
        ),
        ({"steps": 5, "u": np.ones((6, 1))}, ValueError, r"u: expected 4 rows .*received 6"),
        (
            {"steps": 5},
            TypeError,
            r"u: expected the inputs after the data, u\[T\] … u\[T\+3\], shape \(4, 1\), "
            r"for steps=5 .*received None",
        ),
        ({}, TypeError, r"steps: expected the number of steps .* or u, .*received neither"),
        ({"u": np.ones((0, 1))}, ValueError, r"u: expected at least one input after the data"),
        ({"u": np.ones((3, 2))}, ValueError, r"u: expected the inputs after the data.*\(3, 2\)"),
        ({"u": [[1.0], [np.nan]]}, ValueError, r"u: expected finite values"),
    ],
)
def test_inputs_after_the_data_are_checked(data, kwargs, error, pattern):
    x, u = data
    model = ltv.fit(x, u, lam=5.0)
    with pytest.raises(error, match=pattern):
        model.forecast(**kwargs)


def test_models_without_one_end_ask_for_x0_and_say_why(data):
    x, u = data
    missing_state, missing_input = x.copy(), u.copy()
    missing_state[-1, 0] = np.nan
    missing_input[-1] = np.nan
    cases = [
        ("it was fitted on 2 trajectories", ltv.fit(np.stack([x, x]), np.stack([u, u]), lam=5.0)),
        (
            "built from given coefficients",
            ltv.LTVModel.from_arrays(np.eye(2) * 0.5, [[0.0], [1.0]], steps=5, noise_cov=0.1),
        ),
        ("its data ended with a missing sample", ltv.fit(missing_state, u, lam=5.0)),
        ("its data ended with a missing sample", ltv.fit(x, missing_input, lam=5.0)),
    ]
    for why, model in cases:
        assert model.data.tail is None
        with pytest.raises(TypeError, match=rf"x0: received None, .*\(.*{why}.*pass x0=, the"):
            model.forecast(steps=2, u=[[0.0]])
        assert model.forecast(x[-2], [[0.5], [0.0]]).mean.shape == (2, 2)  # explicit x0 works


def test_ar_and_arx_models_continue_the_end_of_their_data():
    rng = np.random.default_rng(6)
    T = 300
    u = rng.standard_normal(T)
    y = np.zeros(T)
    for t in range(3, T):
        y[t] = 0.5 * y[t - 1] + u[t - 2] + 0.3 * u[t - 3] + 0.05 * rng.standard_normal()
    arx = ltv.fit_arx(y, u, 1, 2, 2, lam=30.0)  # y[t] reads y[t−1], u[t−2], u[t−3]: L = 3
    assert arx.lag == 3 and arx.tail_lengths == (1, 3) and arx.future_input_rows(5) == 3
    np.testing.assert_array_equal(arx.data.tail.outputs, y[-1:, None])
    np.testing.assert_array_equal(arx.data.tail.inputs, u[-3:, None])
    future = rng.standard_normal(5)  # u[T] … u[T+4]; y[T+4] reads up to u[T+2]
    explicit = arx.forecast(y[-3:], np.r_[u[-3:], future], seed=2)
    for rows in (future[:3], future):
        continued = arx.forecast(steps=5, u=rows, seed=2)
        np.testing.assert_array_equal(continued.mean, explicit.mean)
        np.testing.assert_array_equal(continued.upper, explicit.upper)
    with pytest.raises(
        ValueError, match=r"u: expected 3 rows .*reads the inputs up to u\[T\+j−2\]"
    ):
        arx.forecast(steps=5, u=future[:2])
    ar = ltv.fit_ar(y, 2, lam=30.0)
    np.testing.assert_array_equal(ar.data.tail.outputs, y[-2:, None])
    np.testing.assert_array_equal(ar.forecast(steps=4).mean, ar.forecast(y[-2:], steps=4).mean)
    gap = y.copy()
    gap[-2] = np.nan  # y[T−2] is a lag of y[T]
    with pytest.raises(TypeError, match=r"y_last: received None, .*pass y_last=, the last 2"):
        ltv.fit_ar(gap, 2, lam=30.0).forecast(steps=2)
    old = y.copy()
    old[-3] = np.nan  # older than every lag of y[T]: the end is still whole
    assert ltv.fit_ar(old, 2, lam=30.0).data.tail is not None


# -- the Forecast itself -----------------------------------------------------------------------


def test_a_diverging_forecast_warns_as_simulate_does():
    """Probe: a long horizon overflowed to inf/NaN without a word; simulate warned."""
    unstable = ltv.LTVModel.from_arrays(np.eye(2) * 3.0, steps=700, noise_cov=1.0)
    with pytest.warns(ltv.DivergenceWarning, match="the simulation diverged"):
        unstable.simulate([1.0, 1.0], None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gaussian = unstable.forecast([1.0, 1.0], steps=700)
    assert [w.category for w in caught] == [ltv.DivergenceWarning]  # numpy's stay quiet
    step = int(np.flatnonzero(~np.isfinite(gaussian.upper).all(axis=1))[0])
    assert f"inf or NaN from step {step} (counted from 0)" in str(caught[0].message)
    x, u, _ = simulate_ltv(1, T=60, n=2, m=1)
    sampled = ltv.fit(3.0 * x, u, lam=5.0)  # coefficient uncertainty: Monte Carlo
    blown = ltv.LTVModel(3.0 * sampled.k, 2, 1, sampled.record)
    with pytest.warns(ltv.DivergenceWarning, match="the forecast diverged"):
        assert blown.forecast(x[-1], np.zeros((700, 1)), n_samples=10).method == "monte_carlo"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sampled.forecast(x[-1], np.zeros((5, 1)))  # a finite forecast says nothing


def test_long_horizons_do_not_keep_every_path():
    """Probe: memory grew with steps × n_samples (20,000 steps peaked at 2 GB). The paths of
    one step are summarized before the next: 1500 steps × 2000 paths peaked at 145 MB (their
    samples, deviations and quantiles); now at 1 MB, that of one step."""
    import tracemalloc

    rng = np.random.default_rng(0)
    x = np.zeros((400, 2))
    for t in range(399):
        x[t + 1] = 0.5 * x[t] + 0.1 * rng.standard_normal(2)
    model = ltv.fit_lti(x)
    tracemalloc.start()
    try:
        forecast = model.forecast(x[-1], steps=1500, n_samples=2000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert forecast.method == "monte_carlo" and np.all(np.isfinite(forecast.upper))
    assert peak < 16e6, f"peak {peak / 1e6:.1f} MB"
    # far ahead: the model's stationary law (mean 0, covariance P = A P Aᵀ + Q), widened a
    # little by the uncertainty of A
    stationary = solve_discrete_lyapunov(model.A[-1], model.noise_cov)
    np.testing.assert_allclose(forecast.mean[-1], 0.0, atol=0.02)
    np.testing.assert_allclose(forecast.std()[-1], np.sqrt(np.diag(stationary)), rtol=0.08)


@pytest.mark.parametrize(
    "changes, error, pattern",
    [
        ({"level": 7.0}, ValueError, r"level: expected a probability in \(0, 1\).*received 7.0"),
        ({"level": "high"}, TypeError, r"level: expected a probability in \(0, 1\)"),
        ({"mean": np.zeros(3)}, ValueError, r"mean: expected shape \(steps, n\).*received shape"),
        ({"lower": np.zeros((3, 1))}, ValueError, r"lower: expected shape \(3, 2\) to fit mean"),
        ({"upper": np.zeros((2, 2))}, ValueError, r"upper: expected shape \(3, 2\)"),
        ({"cov": np.zeros((3, 2))}, ValueError, r"cov: expected shape \(3, 2, 2\)"),
        ({"time": np.arange(4)}, ValueError, r"time: expected shape \(3,\)"),
        ({"names": ["a"]}, ValueError, r"names: expected 2 names .*received 1"),
        ({"n_samples": 100}, ValueError, r"n_samples: expected None for method='gaussian'"),
        (
            {"method": "monte_carlo", "n_samples": 1},
            ValueError,
            r"n_samples: expected an integer >= 2",
        ),
        (
            {"coefficients": np.ones((3, 1, 2))},
            ValueError,
            r"coefficients: expected shape \(3, 2, p\)",
        ),
    ],
)
def test_the_forecast_constructor_checks_its_fields(changes, error, pattern):
    """Probe: Forecast(...) accepted mismatched shapes and level=7.0."""
    fields = {
        "mean": np.zeros((3, 2)),
        "lower": -np.ones((3, 2)),
        "upper": np.ones((3, 2)),
        "cov": np.broadcast_to(np.eye(2), (3, 2, 2)),
        "level": 0.9,
        "time": np.arange(3),
        "names": ["a", "b"],
        "method": "gaussian",
    }
    assert ltv.Forecast(**fields).steps == 3
    with pytest.raises(error, match=pattern):
        ltv.Forecast(**{**fields, **changes})
