"""General regressions (fit_regression), AR/ARX/VARX models and the root spectrogram.

References are independent of the library: dense normal equations, numpy's
lstsq, statsmodels' AutoReg, numpy.roots, explicit simulation loops, and the
analytic instantaneous frequency of a chirp.
"""

from __future__ import annotations

import importlib.util
import warnings
from pathlib import Path

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.estimators.segments import segment_regression
from ltvmodels.systems import chirp

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


# -- helpers -------------------------------------------------------------------------------


def _dense_regression(y, phi, lam, coeffs):
    """argmin Σ‖y_t − Θ_t φ_t‖² + λ² Σ‖(Dk)_t‖² by dense normal equations; (N, n, p)."""
    N, n = y.shape
    p = phi.shape[1]
    K = n * p
    rows = np.zeros((N * n, N * K))
    for t in range(N):
        rows[t * n : (t + 1) * n, t * K : (t + 1) * K] = np.kron(np.eye(n), phi[t])
    d = len(coeffs) - 1
    D = np.zeros((N - d, N))
    for t in range(N - d):
        D[t, t : t + d + 1] = coeffs
    H = rows.T @ rows + lam**2 * np.kron(D.T @ D, np.eye(K))
    k = np.linalg.solve(H, rows.T @ y.ravel())
    return k.reshape(N, n, p)


def _tv_ar2(T, seed, noise=0.05):
    """y[t] = a1_t y[t−1] + a2_t y[t−2] + e[t]: poles r e^{±iω_t}, ω_t slowly varying."""
    rng = np.random.default_rng(seed)
    omega = np.linspace(0.3, 1.2, T)
    r = 0.9
    a1, a2 = 2 * r * np.cos(omega), -(r**2) * np.ones(T)
    y = np.zeros(T)
    e = noise * rng.standard_normal(T)
    for t in range(2, T):  # reference simulation loop, independent of the library
        y[t] = a1[t] * y[t - 1] + a2[t] * y[t - 2] + e[t]
    return y, np.column_stack([a1, a2]), e


def _track_error(model, y_inst, fs):
    """Mean over time of |nearest root-spectrogram frequency − instantaneous frequency|."""
    freq = model.root_spectrogram(fs)
    target = y_inst[model.sample_index]
    return float(np.mean(np.nanmin(np.abs(freq - target[:, None]), axis=1)))


# -- fit_regression --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(lam=3.0),
        dict(lam=3.0, order=2),
        dict(lam=np.r_[1.0, np.inf, 2.0, 0.5, 1.0, 3.0], order=1),
        dict(lam=2.0, prior=ltv.Prior(np.zeros(6), 0.5)),
        dict(lam=2.0, norm="group"),
        dict(lam=1.0, norm="l1", order=2),
    ],
    ids=["sq", "sq-order2", "sq-vector-lam", "sq-prior", "group", "l1"],
)
def test_fit_regression_equals_state_space_fit(ltv_data, kwargs):
    x, u, _ = ltv_data
    ss = ltv.fit(x, u, **kwargs)
    reg = ltv.fit_regression(x[1:], np.hstack([x[:-1], u[:-1]]), **kwargs)
    assert type(reg) is ltv.RegressionModel
    assert reg.theta.shape == (x.shape[0] - 1, 2, 3)
    np.testing.assert_allclose(reg.theta, ss.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(reg.k, ss.k, rtol=1e-9, atol=1e-12)
    assert reg.noise_var == pytest.approx(ss.noise_var, rel=1e-9)
    if ss.cov is None:
        assert reg.cov is None
    else:
        np.testing.assert_allclose(reg.cov, ss.cov, rtol=1e-9, atol=1e-14)
        assert reg.loglik == pytest.approx(ss.loglik, rel=1e-9)
    np.testing.assert_array_equal(reg.changepoints, ss.changepoints)
    phi = np.hstack([x[:-1], u[:-1]])
    np.testing.assert_allclose(reg.predict(phi), ss.predict(x, u), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("n, p, order", [(3, 1, 1), (1, 4, 2), (2, 5, 1)])
def test_fit_regression_matches_dense_reference(n, p, order):
    rng = np.random.default_rng(n * 10 + p)
    N = 35
    phi = rng.standard_normal((N, p))
    y = rng.standard_normal((N, n))
    coeffs = np.array([-1.0, 1.0]) if order == 1 else np.array([1.0, -2.0, 1.0])
    model = ltv.fit_regression(y[:, 0] if n == 1 else y, phi, lam=1.7, order=order)
    np.testing.assert_allclose(
        model.theta, _dense_regression(y, phi, 1.7, coeffs), rtol=1e-8, atol=1e-10
    )
    # one noise variance per output: the rows share a (N, p, p) covariance only when n = 1,
    # else each row has its own (N, n, p, p), the diagonal blocks of cov_full()
    assert model.cov.shape == ((N, p, p) if n == 1 else (N, n, p, p))
    full = model.cov_full().reshape(N, n, p, n, p)
    for i in range(n):
        np.testing.assert_array_equal(model.cov[:, i] if n > 1 else model.cov, full[:, i, :, i])
    assert model.std().shape == (N, n * p)
    with pytest.raises(AttributeError):
        model.A  # noqa: B018 - a general regression has no state-space split


def test_fit_regression_errors():
    rng = np.random.default_rng(0)
    y, phi = rng.standard_normal(30), rng.standard_normal((30, 2))
    with pytest.raises(ValueError, match="phi: expected 30 rows"):
        ltv.fit_regression(y, phi[:-1], lam=1.0)
    with pytest.raises(ValueError, match="y: too few samples: 3 regression rows"):
        ltv.fit_regression(y[:3], phi[:3], lam=1.0, order=2)
    with pytest.raises(ValueError, match="norm"):
        ltv.fit_regression(y, phi, lam=1.0, norm="l2")
    with pytest.raises(ValueError, match="lam"):
        ltv.fit_regression(y, phi, lam=-1.0)
    model = ltv.fit_regression(y, phi, lam=1.0)
    with pytest.raises(ValueError, match=r"phi: expected shape \(30, 2\)"):
        model.predict(phi[:, :1])
    with pytest.raises(ltv.SingularProblemError, match="phi0"):
        ltv.fit_regression(y, np.column_stack([phi[:, 0], 2 * phi[:, 0]]), lam=1.0)


# -- AR / ARX: regressors, recovery, LTI limit ------------------------------------------------


def test_regressors_layout():
    y = np.arange(10.0)
    u = 100 + np.arange(10.0)
    y_out, phi = ltv.arx_regressors(y, u, na=2, nb=2, nk=2, constant=True)
    L = 3  # max(na, nk + nb − 1)
    np.testing.assert_array_equal(y_out[:, 0], y[L:])
    t = np.arange(L, 10)
    np.testing.assert_array_equal(
        phi, np.column_stack([y[t - 1], y[t - 2], u[t - 2], u[t - 3], np.ones(t.size)])
    )
    y_out, phi = ltv.ar_regressors(np.column_stack([y, -y]), na=2)
    np.testing.assert_array_equal(phi[0], [1, -1, 0, 0])  # [y[1]; y[0]] at t = 2
    _, phi = ltv.arx_regressors(y, u, na=0, nb=1, nk=0)  # FIR with feedthrough: φ_t = u[t]
    np.testing.assert_array_equal(phi[:, 0], u)


@pytest.mark.parametrize("order", [1, 2])
def test_time_varying_ar_coefficients_are_recovered(order):
    y, a_true, _ = _tv_ar2(3000, seed=1)
    model = ltv.fit_ar(y, na=2, lam=20.0 if order == 1 else 3000.0, order=order)
    assert isinstance(model, ltv.ARModel) and model.a.shape == (2998, 2)
    assert model.b.shape == (2998, 0) and model.c is None
    err = np.abs(model.a - a_true[2:])
    assert err[100:-100].mean() < 0.03, err.mean(axis=0)
    # root spectrogram: the pole angle ω_t
    freq = model.root_spectrogram(2 * np.pi)  # fs = 2π: frequencies in rad/sample
    omega = np.linspace(0.3, 1.2, 3000)[2:]
    assert np.abs(freq[100:-100, 0] - omega[100:-100]).mean() < 0.02


def test_time_varying_arx_with_constant_is_recovered():
    rng = np.random.default_rng(3)
    T = 2000
    u = rng.standard_normal(T)
    a = np.linspace(0.8, 0.3, T)
    b = 1.0 + 0.5 * np.sin(np.linspace(0, np.pi, T))
    c = 0.5
    y = np.zeros(T)
    for t in range(2, T):
        y[t] = a[t] * y[t - 1] + b[t] * u[t - 2] + c + 0.02 * rng.standard_normal()
    model = ltv.fit_arx(y, u, na=1, nb=1, nk=2, lam=20.0, constant=True)
    assert model.lag == 2 and model.theta.shape == (T - 2, 1, 3)
    np.testing.assert_array_equal(model.sample_index, np.arange(2, T))
    assert np.abs(model.a[:, 0] - a[2:])[50:-50].max() < 0.03
    assert np.abs(model.b[:, 0] - b[2:])[50:-50].max() < 0.03
    assert np.abs(model.c - c)[50:-50].max() < 0.03


# compared with AutoReg without a trend too, on a series with a level: the warning is expected
@pytest.mark.filterwarnings("ignore::ltvmodels.errors.ModelStructureWarning")
def test_lti_limit_equals_least_squares_and_autoreg():
    from statsmodels.tsa.ar_model import AutoReg

    rng = np.random.default_rng(5)
    T = 400
    y = np.zeros(T)
    for t in range(3, T):
        y[t] = 0.5 * y[t - 1] - 0.3 * y[t - 2] + 0.1 * y[t - 3] + 1.0 + rng.standard_normal()
    for constant, trend in ((False, "n"), (True, "c")):
        ref = AutoReg(y, lags=3, trend=trend).fit().params  # [const,] a1, a2, a3
        ref = np.r_[ref[1:], ref[0]] if constant else ref
        y_out, phi = ltv.ar_regressors(y, 3, constant=constant)
        lstsq = np.linalg.lstsq(phi, y_out[:, 0], rcond=None)[0]
        np.testing.assert_allclose(lstsq, ref, rtol=1e-10)
        exact = ltv.fit_ar(y, 3, lam=np.inf, constant=constant)  # constant coefficients
        np.testing.assert_allclose(
            exact.theta[:, 0, :], np.broadcast_to(ref, (T - 3, ref.size)), rtol=1e-8, atol=1e-10
        )
        large = ltv.fit_ar(y, 3, lam=1e4, constant=constant, compute_cov=False)
        np.testing.assert_allclose(large.theta[:, 0, :], exact.theta[:, 0, :], atol=1e-4)
        group = ltv.fit_ar(y, 3, lam=1e6, norm="group", constant=constant)
        np.testing.assert_allclose(group.theta[:, 0, :], exact.theta[:, 0, :], atol=1e-8)


def test_varx_equals_state_space_fit_and_eigenvalues():
    """VARX(1, 1) with nk = 1 is the state-space model with x = y: same Θ_t, poles = eig(A_t)."""
    data = ltv.systems.random_walk_system(T=300, n=2, m=1, seed=4)
    ss = ltv.fit(data.x, data.u, lam=5.0, order=2)
    model = ltv.fit_arx(data.x, data.u, na=1, nb=1, lam=5.0, order=2)
    np.testing.assert_allclose(model.theta, ss.theta, rtol=1e-9, atol=1e-12)
    assert model.a.shape == (299, 2, 2) and model.b.shape == (299, 2, 1)
    np.testing.assert_allclose(model.a, ss.A, rtol=1e-12)
    eig = np.linalg.eigvals(ss.A)
    np.testing.assert_allclose(
        np.sort_complex(model.poles()), np.sort_complex(eig), rtol=1e-9, atol=1e-12
    )
    np.testing.assert_allclose(
        model.predict(data.x, data.u), ss.predict(data.x, data.u), rtol=1e-9, atol=1e-12
    )


def test_var2_coefficients_are_recovered():
    rng = np.random.default_rng(8)
    T = 3000
    s = np.linspace(0, 1, T)
    A1 = np.stack([np.array([[0.8 * np.cos(np.pi * si), 0.3], [-0.3, 0.4]]) for si in s])
    A2 = np.broadcast_to(np.array([[-0.2, 0.0], [0.1, -0.2]]), (T, 2, 2))
    y = np.zeros((T, 2))
    for t in range(2, T):
        y[t] = A1[t] @ y[t - 1] + A2[t] @ y[t - 2] + 0.1 * rng.standard_normal(2)
    model = ltv.fit_ar(y, na=2, lam=30.0)
    assert model.a.shape == (T - 2, 2, 4) and model.root_spectrogram(1.0).shape == (T - 2, 2)
    true = np.concatenate([A1, A2], axis=2)[2:]
    error = np.abs(model.a - true)[100:-100].mean()
    lti = ltv.fit_ar(y, na=2, lam=np.inf)
    assert error < 0.04 and error < 0.5 * np.abs(lti.a - true)[100:-100].mean()


# -- root spectrogram ---------------------------------------------------------------------


def test_root_spectrogram_against_numpy_roots():
    rng = np.random.default_rng(2)
    N, na, fs = 50, 6, 100.0
    a = 0.4 * rng.standard_normal((N, na))
    model = ltv.ARModel(a, 1, na, False, ltv.FitRecord(norm="sq", lam=1.0))
    freq = model.root_spectrogram(fs)
    assert freq.shape == (N, na // 2)
    for t in range(N):
        roots = np.roots(np.r_[1.0, -a[t]])  # z^na − Σ a_i z^(na−i)
        pos = np.sort(np.angle(roots[roots.imag > 1e-12]) * fs / (2 * np.pi))
        expected = np.full(na // 2, np.nan)
        expected[: pos.size] = pos
        np.testing.assert_allclose(freq[t], expected, rtol=1e-8, atol=1e-8)
    assert np.isnan(freq).any() and np.isfinite(freq).any()  # some real poles in the draw
    poles = model.poles()
    assert poles.shape == (N, na)
    np.testing.assert_allclose(np.prod(-poles, axis=1).real * (-1) ** na, -a[:, -1], rtol=1e-8)


def test_root_spectrogram_known_resonance():
    fs, f0, r = 8000.0, 1234.0, 0.97
    w = 2 * np.pi * f0 / fs
    k = np.tile([2 * r * np.cos(w), -(r**2)], (10, 1))
    model = ltv.ARModel(k, 1, 2, False, ltv.FitRecord(norm="sq", lam=1.0))
    np.testing.assert_allclose(model.root_spectrogram(fs), f0, rtol=1e-12)
    np.testing.assert_allclose(np.abs(model.poles()), r, rtol=1e-12)
    with pytest.raises(ValueError, match="fs"):
        model.root_spectrogram(0.0)


@pytest.mark.parametrize("order, bound", [(1, 20.0), (2, 20.0)])
def test_chirp_root_spectrogram_tracks_instantaneous_frequency(order, bound):
    """Paper-level check: T = 2^14 at 16 kHz, AR(6), λ² = 1e5, mean error < 20 Hz."""
    fs = 16000.0
    y, inst = chirp(2**14, fs)
    model = ltv.fit_ar(y, na=6, lam=np.sqrt(1e5), norm="sq", order=order)
    assert model.root_spectrogram(fs).shape == (2**14 - 6, 3)
    error = _track_error(model, inst, fs)
    assert error < bound, error


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_chirp_sparse_norms_run_through_the_same_solvers(norm):
    fs = 16000.0
    y, inst = chirp(2**11, fs)
    model = ltv.fit_ar(y, na=6, lam=3.0, norm=norm, order=1, tol=1e-5)
    assert model.info["converged"] and model.norm == norm
    assert _track_error(model, inst, fs) < 20.0  # piecewise-constant tracks of a chirp


# -- segmentation and change points ----------------------------------------------------------


def test_ar_regressors_with_exact_segmentation_and_group_norm():
    rng = np.random.default_rng(6)
    T, c = 1200, 700
    y = np.zeros(T)
    for t in range(2, T):
        a = (1.5, -0.9) if t < c else (0.2, 0.5)
        y[t] = a[0] * y[t - 1] + a[1] * y[t - 2] + 0.1 * rng.standard_normal()
    y_out, phi = ltv.ar_regressors(y, 2)
    seg = segment_regression(y_out, phi, n_changes=1)
    assert seg.changepoints.tolist() == [c - 2]  # regression row of y[c]
    model = ltv.fit_ar(y, 2, lam=5.0, norm="group")
    assert (
        abs(
            int(model.changepoints[np.argmax(model.activation()[model.changepoints - 1])]) - (c - 2)
        )
        <= 2
    )
    assert abs(int(ltv.find_changepoints(model, max_changes=1)[0]) - (c - 2)) <= 2


# -- predict, simulate, save/load, plot -----------------------------------------------------


def test_predict_and_simulate_against_explicit_loops():
    rng = np.random.default_rng(9)
    T = 120
    u = rng.standard_normal((T, 2))
    y = rng.standard_normal((T, 2))
    model = ltv.fit_arx(y, u, na=2, nb=2, nk=0, lam=1.0, constant=True)
    L, N = model.lag, model.N
    assert L == 2 and N == T - 2
    A = model.a.reshape(N, 2, 2, 2)  # (t, out, lag, in)
    B = model.b.reshape(N, 2, 2, 2)
    pred = np.zeros((N, 2))
    for j in range(N):
        t = L + j
        pred[j] = (
            A[j, :, 0] @ y[t - 1]
            + A[j, :, 1] @ y[t - 2]
            + B[j, :, 0] @ u[t]
            + B[j, :, 1] @ u[t - 1]
            + model.c[j]
        )
    np.testing.assert_allclose(model.predict(y, u), pred, rtol=1e-12, atol=1e-12)
    # simulating with the one-step residuals as noise reproduces the data
    resid = y[L:] - pred
    np.testing.assert_allclose(model.simulate(y[:L], u, noise=resid), y, rtol=1e-9, atol=1e-9)
    # noise-free simulation: the explicit recursion
    sim = model.simulate(y[:L], u)
    ref = y.copy()
    for j in range(N):
        t = L + j
        ref[t] = (
            A[j, :, 0] @ ref[t - 1]
            + A[j, :, 1] @ ref[t - 2]
            + B[j, :, 0] @ u[t]
            + B[j, :, 1] @ u[t - 1]
            + model.c[j]
        )
    np.testing.assert_allclose(sim, ref, rtol=1e-9, atol=1e-12)


def test_ar_predict_and_simulate_scalar():
    y, a_true, e = _tv_ar2(300, seed=4)
    model = ltv.ARModel(a_true[2:], 1, 2, False, ltv.FitRecord(norm="sq", lam=1.0))
    sim = model.simulate(y[:2], noise=e[2:])
    assert sim.shape == (300,)
    np.testing.assert_allclose(sim, y, rtol=1e-10, atol=1e-12)
    pred = model.predict(y)
    np.testing.assert_allclose(pred, y[2:] - e[2:], rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("kind", ["regression", "ar", "arx", "ar-group"])
def test_save_load_round_trip(tmp_path, kind):
    rng = np.random.default_rng(1)
    y, u = rng.standard_normal((80, 2)), rng.standard_normal(80)
    model = {
        "regression": lambda: ltv.fit_regression(y, rng.standard_normal((80, 3)), lam=2.0),
        "ar": lambda: ltv.fit_ar(y[:, 0], 3, lam=2.0, constant=True),
        "arx": lambda: ltv.fit_arx(y, u, 1, 2, nk=0, lam=2.0, order=2),
        "ar-group": lambda: ltv.fit_ar(y, 1, lam=2.0, norm="group"),
    }[kind]()
    path = tmp_path / "m.npz"
    model.save(path)
    loaded = ltv.load(path)
    assert type(loaded) is type(model)
    assert repr(loaded) == repr(model)
    np.testing.assert_array_equal(loaded.k, model.k)
    np.testing.assert_array_equal(loaded.changepoints, model.changepoints)
    if model.cov is not None:
        np.testing.assert_array_equal(loaded.cov, model.cov)
    if isinstance(model, ltv.ARXModel):
        for name in ("na", "nb", "nk", "constant", "n_inputs", "lag"):
            assert getattr(loaded, name) == getattr(model, name)
        np.testing.assert_array_equal(loaded.root_spectrogram(10.0), model.root_spectrogram(10.0))


def test_load_reads_files_without_model_type(tmp_path, ltv_data):
    """Files written before model types existed load as LTVModel."""
    import json

    x, u, _ = ltv_data
    model = ltv.fit(x, u, lam=2.0)
    model.save(tmp_path / "m.npz")
    with np.load(tmp_path / "m.npz") as data:
        arrays = {key: data[key] for key in data.files}
    meta = json.loads(str(arrays["meta"]))
    del meta["model_type"]
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "old.npz", **arrays)
    loaded = ltv.load(tmp_path / "old.npz")
    assert type(loaded) is ltv.LTVModel
    np.testing.assert_array_equal(loaded.A, model.A)
    meta["model_type"] = "Unknown"
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(ValueError, match="unknown type 'Unknown'"):
        ltv.load(tmp_path / "bad.npz")


def test_plot_root_spectrogram():
    y, _, _ = _tv_ar2(500, seed=2)
    model = ltv.fit_ar(y, 4, lam=50.0)
    fig = model.plot(fs=100.0)  # a Figure, as every result's plot()
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time (s)" and ax.get_ylim() == (0.0, 50.0)
    assert len(ax.lines) == 2  # (n·na) // 2 tracks
    with pytest.raises(TypeError, match="root_spectrogram"):
        ltv.plotting.plot_root_spectrogram(ltv.fit_regression(y, y, lam=1.0), 1.0)


# -- errors --------------------------------------------------------------------------------


def test_ar_arx_errors():
    rng = np.random.default_rng(0)
    y, u = rng.standard_normal(50), rng.standard_normal(50)
    for bad in (0, -1):
        with pytest.raises(ValueError, match="na: expected an integer >= 1"):
            ltv.fit_ar(y, bad, lam=1.0)
    for bad in (1.5, True, "2"):
        with pytest.raises(ValueError, match="na: expected an integer"):
            ltv.fit_ar(y, bad, lam=1.0)
    with pytest.raises(ValueError, match="na: expected an integer >= 0"):
        ltv.fit_arx(y, u, -1, 1, lam=1.0)
    with pytest.raises(ValueError, match="nb: expected an integer >= 1"):
        ltv.fit_arx(y, u, 1, 0, lam=1.0)
    with pytest.raises(ValueError, match="nk: expected an integer >= 0"):
        ltv.fit_arx(y, u, 1, 1, nk=-1, lam=1.0)
    with pytest.raises(ValueError, match="y: the series is shorter than the lag structure"):
        ltv.fit_ar(y[:4], 4, lam=1.0)
    with pytest.raises(ValueError, match=r"nb = 3, nk = 5 reaches back 7 samples"):
        ltv.fit_arx(y[:7], u[:7], 2, 3, nk=5, lam=1.0)
    with pytest.raises(ValueError, match="y: too few samples: 2 regression rows"):
        ltv.fit_ar(y[:6], 4, lam=1.0)
    with pytest.raises(ValueError, match="u: expected 50 rows"):
        ltv.fit_arx(y, u[:-1], 1, 1, lam=1.0)
    with pytest.raises(TypeError, match="u: expected inputs"):
        ltv.fit_arx(y, None, 1, 1, lam=1.0)
    with pytest.raises(TypeError, match="constant: expected True or False"):
        ltv.fit_ar(y, 2, lam=1.0, constant=1)
    with pytest.raises(ValueError, match="y: expected finite values or NaN"):
        ltv.fit_ar(np.r_[y[:-1], np.inf], 2, lam=1.0)
    model = ltv.fit_arx(y, u, 2, 1, lam=1.0)
    with pytest.raises(ValueError, match="y: expected T = 50 samples"):
        model.predict(y[:-1], u[:-1])
    with pytest.raises(ValueError, match="u: expected 50 rows"):
        model.predict(y, u[:-1])
    with pytest.raises(ValueError, match=r"y0: expected the 2 initial samples"):
        model.simulate(y[:3], u)
    with pytest.raises(ValueError, match=r"u: expected shape \(50, 1\)"):
        model.simulate(y[:2], u[:-1])
    with pytest.raises(ValueError, match=r"noise: expected shape \(48, 1\) or \(48,\)"):
        model.simulate(y[:2], u, noise=np.zeros(47))
    with pytest.raises(ValueError, match="y: expected 1 columns"):
        ltv.fit_ar(y, 2, lam=1.0).predict(np.column_stack([y, y]))


# -- example -------------------------------------------------------------------------------


def test_chirp_example_runs_quick(tmp_path, capsys):
    spec = importlib.util.spec_from_file_location(
        "chirp_spectrogram", EXAMPLES / "chirp_spectrogram.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path / "chirp.png"
    assert module.main(["--out", str(out), "--quick"]) == 0
    assert out.stat().st_size > 10_000
    text = capsys.readouterr().out
    assert "order 1: mean error" in text and "order 2: mean error" in text


def test_an_ar_model_without_intercept_on_a_series_with_a_level_warns():
    """statsmodels' yearly sunspots: mean 49.7, 1.2 standard deviations from 0."""
    sm = pytest.importorskip("statsmodels.api")
    sunspots = sm.datasets.sunspots.load_pandas().data["SUNACTIVITY"].to_numpy()
    with pytest.warns(
        ltv.errors.ModelStructureWarning,
        match=r"^y has mean 49.75, 1.2 "
        r"standard deviations from 0, .* pass constant=True",
    ):
        ltv.fit_ar(sunspots, 2, lam=10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ltv.errors.ModelStructureWarning)
        ltv.fit_ar(sunspots, 2, lam=10.0, constant=True)
        ltv.fit_ar(sunspots - sunspots.mean(), 2, lam=10.0)
        u = np.random.default_rng(0).standard_normal(sunspots.size)
        with pytest.warns(ltv.errors.ModelStructureWarning):
            ltv.fit_arx(sunspots, u, 2, 1, lam=10.0)


def test_fit_regression_refine_refits_each_segment_by_least_squares():
    rng = np.random.default_rng(3)
    phi = rng.standard_normal((300, 2))
    theta = np.where(np.arange(300)[:, None] < 120, [1.0, -0.5], [0.2, 0.7])
    y = np.sum(theta * phi, axis=1) + 0.05 * rng.standard_normal(300)
    first = ltv.fit_regression(y, phi, lam=5.0, norm="group")
    model = ltv.fit_regression(y, phi, lam=5.0, norm="group", refine=True)
    assert model.norm == "piecewise" and model.changepoints.tolist() == [120]
    assert model.info["first_step"]["changepoints"] == first.changepoints.tolist()
    np.testing.assert_array_equal(model.info["first_step_k"], first.k)
    for start, stop in model.info["segments"]:  # independent: lstsq per segment
        expected, *_ = np.linalg.lstsq(phi[start:stop], y[start:stop], rcond=None)
        np.testing.assert_allclose(
            model.theta[start:stop, 0], np.tile(expected, (stop - start, 1)), rtol=0, atol=1e-12
        )
    assert model.std() is not None  # the refit's covariance
    robust = ltv.fit_regression(y, phi, lam=5.0, norm="group", refine=True, loss="huber")
    assert robust.info["loss"] == "huber" and robust.changepoints.tolist() == [120]
    with pytest.raises(TypeError, match=r"^refine: expected True or False"):
        ltv.fit_regression(y, phi, lam=5.0, refine="yes")


def test_ar_models_keep_the_name_and_index_of_their_series():
    """statsmodels' yearly sunspots as a named Series indexed by year: the lags are named
    after it, change c is reported at the year of y[na + c], forecasts continue the years."""
    sm = pytest.importorskip("statsmodels.api")
    pd = pytest.importorskip("pandas")
    table = sm.datasets.sunspots.load_pandas().data
    y = pd.Series(table["SUNACTIVITY"].to_numpy(), index=table["YEAR"].to_numpy(), name="sunspots")
    model = ltv.fit_ar(y, 2, lam=10.0, constant=True, norm="group")
    assert model.regressor_names == ["sunspots[t-1]", "sunspots[t-2]", "1"]
    c = int(model.changepoints[0])
    assert model.changepoint_times[0] == y.index[2 + c]
    assert model.to_frame().index[0] == y.index[2]
    forecast = model.forecast(y.to_numpy()[-2:], steps=2)
    np.testing.assert_array_equal(forecast.time, [y.index[-1] + 1, y.index[-1] + 2])
    assert forecast.names == ["sunspots"]
    u = pd.DataFrame({"rain": np.random.default_rng(0).standard_normal(len(y))}, index=y.index)
    arx = ltv.fit_arx(y, u, 2, 1, lam=10.0, constant=True)
    assert arx.regressor_names == ["sunspots[t-1]", "sunspots[t-2]", "rain[t-1]", "1"]
