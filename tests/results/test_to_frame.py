"""model.to_frame(): the coefficients as a pandas DataFrame, named from the model."""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv

pd = pytest.importorskip("pandas")


def test_regression_frame_holds_k_and_its_standard_deviations():
    rng = np.random.default_rng(0)
    phi = rng.standard_normal((50, 2))
    y = phi @ np.array([[1.0, -0.5], [0.3, 0.8]]).T + 0.1 * rng.standard_normal((50, 2))
    model = ltv.fit_regression(y, phi, lam=5.0)
    frame = model.to_frame(std=True)
    assert frame.shape == (50, 8) and frame.index.name == "t"
    assert list(frame.columns[:4]) == ["y0:phi0", "y0:phi1", "y1:phi0", "y1:phi1"]
    np.testing.assert_array_equal(frame.iloc[:, :4].to_numpy(), model.k)
    np.testing.assert_array_equal(frame.iloc[:, 4:].to_numpy(), model.std())
    assert frame.columns[4] == "y0:phi0 std"
    sparse = ltv.fit_regression(y, phi, lam=5.0, norm="group")
    with pytest.raises(ValueError, match=r"^std: this model \(norm='group'\) has no "):
        sparse.to_frame(std=True)
    with pytest.raises(TypeError, match=r"^std: expected True or False"):
        model.to_frame(std="yes")


def test_ar_frame_names_the_lags():
    y = np.random.default_rng(1).standard_normal(120)
    model = ltv.fit_ar(y, 2, lam=10.0, constant=True)
    frame = model.to_frame()
    assert list(frame.columns) == ["y:y[t-1]", "y:y[t-2]", "y:1"]
    np.testing.assert_array_equal(frame.to_numpy(), model.k)


def test_state_space_frame_names_a_b_and_c():
    data = ltv.systems.jump_linear(T=80, change_at=40, seed=0)
    x = pd.DataFrame(data.x, columns=["p", "v"])
    model = ltv.fit(x, pd.DataFrame(data.u, columns=["f"]), lam=5.0, constant=True)
    frame = model.to_frame()
    assert list(frame.columns[:4]) == ["A[p,p]", "A[p,v]", "B[p,f]", "c[p]"]
    np.testing.assert_array_equal(frame["B[v,f]"].to_numpy(), model.B[:, 1, 0])
    np.testing.assert_array_equal(frame["c[v]"].to_numpy(), model.c[:, 1])


def test_regression_keeps_the_names_and_dates_of_its_data(tmp_path):
    rng = np.random.default_rng(0)
    months = pd.date_range("2000-01-01", periods=100, freq="MS")
    phi = pd.DataFrame(rng.standard_normal((100, 2)), columns=["gdp", "rate"], index=months)
    slope = np.where(np.arange(100) < 60, 1.0, -1.0)
    y = pd.Series(
        slope * phi["gdp"].to_numpy()
        + 2.0 * phi["rate"].to_numpy()
        + 0.05 * rng.standard_normal(100),
        name="inflation",
        index=months,
    )
    model = ltv.fit_regression(y, phi, lam=5.0, norm="group")
    assert model.output_names == ["inflation"] and model.regressor_names == ["gdp", "rate"]
    assert model.changepoints.tolist() == [60]
    assert model.changepoint_times[0] == np.datetime64("2005-01-01")
    frame = model.to_frame()
    assert list(frame.columns) == ["inflation:gdp", "inflation:rate"]
    assert frame.index[0] == pd.Timestamp("2000-01-01")
    model.save(tmp_path / "m.npz")
    loaded = ltv.load(tmp_path / "m.npz")
    assert loaded.regressor_names == ["gdp", "rate"]
    assert [ax.get_title() for ax in loaded.plot().axes] == ["inflation:gdp", "inflation:rate"]


def test_a_sparse_fit_forecasts_with_its_last_segments_uncertainty(tmp_path):
    """norm="group" has no posterior covariance: the forecast's coefficient uncertainty is
    the least-squares covariance of the last segment, exactly at step 1."""
    data = ltv.systems.jump_linear(seed=0)
    model = ltv.fit(data.x, data.u, lam=30.0, norm="group")
    assert model.changepoints.tolist() == [200]
    phi = np.c_[data.x[200:-1], data.u[200:-1]]
    unit = np.linalg.inv(phi.T @ phi)
    np.testing.assert_allclose(model.info["last_segment_unit_cov"], unit, rtol=1e-10)
    u0 = np.array([0.3])
    forecast = model.forecast(data.x[-1], u0[None, :])
    z = np.r_[data.x[-1], u0]
    expected = (
        np.diag(model.noise_var * (1.0 + z @ unit @ z)) + model.noise_cov - np.diag(model.noise_var)
    )
    np.testing.assert_allclose(forecast.cov[0], expected, rtol=1e-10)
    model.save(tmp_path / "m.npz")
    loaded = ltv.load(tmp_path / "m.npz")
    np.testing.assert_allclose(
        loaded.forecast(data.x[-1], u0[None, :]).cov[0], expected, rtol=1e-10
    )


def test_to_statespace_takes_dt_from_the_time_index():
    pytest.importorskip("control.statesp")
    data = ltv.systems.jump_linear(T=60, change_at=30, seed=0)
    hours = pd.date_range("2024-01-01", periods=60, freq="h")
    model = ltv.fit(pd.DataFrame(data.x, index=hours), pd.DataFrame(data.u, index=hours), lam=10.0)
    assert model.to_statespace().dt == 3600.0
    yearly = ltv.fit(pd.DataFrame(data.x, index=2000.0 + 0.5 * np.arange(60)), lam=10.0)
    assert yearly.to_statespace().dt == 0.5
    assert ltv.fit(data.x, data.u, lam=10.0).to_statespace().dt == 1.0
