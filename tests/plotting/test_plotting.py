"""Figures: ltvmodels.plotting (headless, Agg backend)."""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import ltvmodels as ltv  # noqa: E402
from ltvmodels import plotting, systems  # noqa: E402

TITLES = ["A[x0,x0]", "A[x0,x1]", "B[x0,u0]", "A[x1,x0]", "A[x1,x1]", "B[x1,u0]"]


@pytest.fixture(scope="module")
def data():
    return systems.jump_linear(T=120, change_at=60, seed=0)


@pytest.fixture(scope="module")
def model(data):
    return ltv.fit(data.x, data.u, lam=30.0)


def test_plot_coefficients_grid_bands_truth(model, data):
    fig = plotting.plot_coefficients(model, truth=data)
    assert isinstance(fig, Figure)
    assert len(fig.axes) == 6  # n rows x (n + m) columns
    assert [ax.get_title() for ax in fig.axes] == TITLES
    for ax in fig.axes:
        assert len(ax.collections) == 1  # the ±2σ band
        est, truth = ax.lines
        assert truth.get_linestyle() == "--"
        assert matplotlib.colors.to_hex(truth.get_color()) == "#000000"
        assert len(est.get_xdata()) == model.N
    np.testing.assert_array_equal(fig.axes[3].lines[1].get_ydata(), data.A[:, 1, 0])
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    assert buf.getvalue()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_coefficients_without_truth_or_bands(model):
    fig = plotting.plot_coefficients(model, bands=False)
    assert len(fig.axes) == 6
    assert all(len(ax.collections) == 0 and len(ax.lines) == 1 for ax in fig.axes)


def test_plot_coefficients_no_covariance_no_bands(data):
    model = ltv.fit(data.x, data.u, lam=30.0, compute_cov=False)
    fig = plotting.plot_coefficients(model, truth=data.k)
    assert all(len(ax.collections) == 0 and len(ax.lines) == 2 for ax in fig.axes)


def test_plot_coefficients_truth_forms(model, data):
    for truth in (data.k, data.theta, data.k[0], data):
        fig = plotting.plot_coefficients(model, truth=truth)
        np.testing.assert_array_equal(fig.axes[0].lines[1].get_ydata()[:1], [0.95])
    with pytest.raises(ValueError, match="truth"):
        plotting.plot_coefficients(model, truth=np.zeros((5, 6)))
    with pytest.raises(TypeError, match="model"):
        plotting.plot_coefficients(object())
    with pytest.raises(TypeError, match="bands"):
        plotting.plot_coefficients(model, bands="yes")


def test_plot_coefficients_into_given_figure_and_method(model, data):
    fig = Figure()
    fig.add_subplot()
    out = plotting.plot_coefficients(model, truth=data, fig=fig)
    assert out is fig and len(fig.axes) == 6
    fig2 = model.plot(truth=data)
    assert isinstance(fig2, Figure) and len(fig2.axes) == 6


def test_plot_coefficients_three_states_two_inputs():
    rw = systems.random_walk_system(T=200, seed=0)
    model = ltv.fit(rw.x, rw.u, lam=100.0)
    fig = plotting.plot_coefficients(model, truth=rw)
    assert len(fig.axes) == 15
    assert fig.axes[4].get_title() == "B[x0,u1]"


def test_plot_coefficients_lti_model(data):
    fig = plotting.plot_coefficients(ltv.fit_lti(data.x, data.u), truth=data)
    assert len(fig.axes) == 6 and len(fig.axes[0].collections) == 1


def test_plot_activation(model):
    ax = plotting.plot_activation(model)
    assert isinstance(ax, Axes) and len(ax.figure.axes) == 1
    np.testing.assert_allclose(ax.lines[0].get_ydata(), model.activation())
    fig = Figure()
    axes = fig.subplots(1, 2)
    assert plotting.plot_activation(model, ax=axes[1]) is axes[1]
    assert len(axes[1].lines) == 1 and len(axes[0].lines) == 0


def test_plot_eigenvalues(model):
    ax = plotting.plot_eigenvalues(model)
    assert isinstance(ax, Axes) and len(ax.figure.axes) == 1
    assert len(ax.lines) == 3  # |λ_1|, |λ_2| and the line |λ| = 1
    np.testing.assert_array_equal(ax.lines[-1].get_ydata(), [1.0, 1.0])
    expected = np.sort(np.abs(np.linalg.eigvals(model.A)), axis=1)[:, ::-1]
    np.testing.assert_allclose(ax.lines[0].get_ydata(), expected[:, 0])
    with pytest.raises(TypeError, match="model"):
        plotting.plot_eigenvalues(object())


def test_plot_activation_marks_changepoints(model):
    found = ltv.find_changepoints(model)
    ax = plotting.plot_activation(model, changepoints=[30, 60])
    np.testing.assert_allclose(ax.lines[0].get_ydata(), model.activation())
    # order 1: a change at c shows at activation index c − 1
    assert [line.get_xdata()[0] for line in ax.lines[1:]] == [29, 59]
    assert ax.get_legend() is not None and "30, 60" in ax.get_legend().get_title().get_text()
    ax = plotting.plot_activation(model, changepoints=found[:0])
    assert "none" in ax.get_legend().get_title().get_text()
    with pytest.raises(ValueError, match="changepoints"):
        plotting.plot_activation(model, changepoints=[1.5])


def test_plot_poles_unit_circle(model):
    ax = plotting.plot_poles(model)
    assert isinstance(ax, Axes)
    circle = ax.lines[0]
    np.testing.assert_allclose(np.hypot(circle.get_xdata(), circle.get_ydata()), 1.0)
    assert ax.collections[0].get_offsets().shape == (model.N * 2, 2)
    assert len(ax.figure.axes) == 2  # with the colour bar for t
    with pytest.raises(TypeError, match="model"):
        plotting.plot_poles(object())


def test_plot_simulation_and_prediction(model, data):
    sim = model.simulate(data.x[0], data.u)
    fig = plotting.plot_simulation(data.x, sim, names=["q", "v"])
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    rms = np.sqrt(np.mean((sim[:, 1] - data.x[:, 1]) ** 2))
    assert fig.axes[1].get_title() == f"v: RMS error {rms:.3g}"
    pred = model.predict(data.x, data.u)
    fig = plotting.plot_simulation(data.x, pred, start=1, label="one-step prediction")
    data_line, pred_line = fig.axes[0].lines
    np.testing.assert_array_equal(pred_line.get_xdata(), np.arange(1, data.T))
    assert pred_line.get_label() == "one-step prediction"
    fig = plotting.plot_simulation(data.x[:, 0], np.full(data.T, 1e300))  # diverging: no error
    assert len(fig.axes) == 1
    with pytest.raises(ValueError, match="simulation"):
        plotting.plot_simulation(data.x, pred, start=2)
    with pytest.raises(ValueError, match="simulation"):
        plotting.plot_simulation(data.x, pred[:, :1])
    with pytest.raises(ValueError, match="names"):
        plotting.plot_simulation(data.x, sim, names=["only one"])


def test_plot_lambda_selection(data):
    selection = ltv.select_lambda(data.x, data.u, norm="sq", lams=[1.0, 10.0, 100.0])
    ax = plotting.plot_lambda_selection(selection)
    assert isinstance(ax, Axes) and "choosing lam" in ax.get_title()
    with pytest.raises(TypeError, match="selection"):
        plotting.plot_lambda_selection(3.0)


def test_plot_spectrogram_under_root_spectrogram():
    y, _ = ltv.systems.chirp(2**11, seed=0)
    ax = plotting.plot_spectrogram(y, 16000.0)
    assert isinstance(ax, Axes) and len(ax.collections) == 1
    armodel = ltv.fit_ar(y, na=4, lam=300.0)
    assert plotting.plot_root_spectrogram(armodel, 16000.0, ax=ax) is ax
    assert ax.get_ylim()[1] == 8000.0
    with pytest.raises(ValueError, match="y"):
        plotting.plot_spectrogram(np.zeros((10, 2)), 1.0)
    with pytest.raises(ValueError, match="fs"):
        plotting.plot_spectrogram(y, -1.0)


def test_plot_model_overview(model, data):
    fig = plotting.plot_model(model, truth=data, changepoints=[60])
    assert isinstance(fig, Figure) and len(fig.subfigs) == 2
    assert len(fig.subfigs[0].axes) == 6 and len(fig.subfigs[1].axes) == 2
    activation_ax, eig_ax = fig.subfigs[1].axes
    assert activation_ax.get_title() == "Activation" and eig_ax.lines[-1].get_ydata()[0] == 1.0
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    assert buf.getvalue()[:8] == b"\x89PNG\r\n\x1a\n"
    segmented = ltv.fit_segments(data.x, data.u, n_changes=1)
    fig = plotting.plot_model(segmented)  # change points of the model itself
    assert "60" in fig.subfigs[1].axes[0].get_legend().get_title().get_text()


def test_plot_model_marks_the_change_points_the_fit_found(data):
    """Plotting never detects change points itself: it draws those of the model, or given ones."""
    group = ltv.fit(data.x, data.u, lam=5.0, norm="group")
    assert group.changepoints.size
    fig = plotting.plot_model(group)
    legend = fig.subfigs[1].axes[0].get_legend().get_title().get_text()
    assert legend == "detected: " + ", ".join(str(int(c)) for c in group.changepoints)
    smooth = ltv.fit(data.x, data.u, lam=10.0)  # norm="sq": no change points of its own
    activation_ax = plotting.plot_model(smooth).subfigs[1].axes[0]
    assert activation_ax.get_legend() is None and len(activation_ax.lines) == 1
    found = ltv.find_changepoints(smooth)
    activation_ax = plotting.plot_model(smooth, changepoints=found).subfigs[1].axes[0]
    assert len(activation_ax.lines) == 1 + len(found)


def test_every_model_kind_plots():
    """Regression and AR models: coefficients named "output:regressor", AR poles from the
    companion matrix (they used to be refused)."""
    rng = np.random.default_rng(0)
    phi = rng.standard_normal((100, 2))
    y = phi @ np.array([1.0, 2.0]) + 0.1 * rng.standard_normal(100)
    regression = ltv.fit_regression(y, phi, lam=5.0)
    fig = regression.plot()
    assert [ax.get_title() for ax in fig.axes] == ["y0:phi0", "y0:phi1"]
    assert len(fig.axes[0].collections) == 1  # the ±2σ band
    series = rng.standard_normal(200)
    ar = ltv.fit_ar(series, 2, lam=10.0)
    fig = plotting.plot_coefficients(ar)
    assert [ax.get_title() for ax in fig.axes] == ["y:y[t-1]", "y:y[t-2]"]
    ax = plotting.plot_poles(ar)
    assert ax.get_title() == "Poles of the AR model"
    np.testing.assert_allclose(
        np.sort_complex(ax.collections[0].get_offsets()[:2] @ np.array([1, 1j])),
        np.sort_complex(ar.poles()[0]),
    )
    with pytest.raises(TypeError, match=r"^model: expected a model with coefficients"):
        plotting.plot_coefficients(object())
    # overviews: a regression has no dynamics panel, an AR model shows its pole magnitudes
    assert len(plotting.plot_model(regression).subfigs[1].axes) == 1
    bottom = plotting.plot_model(ar).subfigs[1].axes
    assert bottom[1].get_title() == "Magnitudes of the poles of the AR model"
    segmentation = ltv.segment_regression(y, phi, n_changes=1)
    assert [ax.get_title() for ax in segmentation.plot().axes] == ["y0:phi0", "y0:phi1"]


def test_root_spectrogram_takes_its_units_from_the_time_index():
    pd = pytest.importorskip("pandas")
    rng = np.random.default_rng(1)
    y = np.zeros(300)
    for t in range(2, 300):
        y[t] = 1.5 * y[t - 1] - 0.9 * y[t - 2] + 0.1 * rng.standard_normal()
    yearly = ltv.fit_ar(pd.Series(y, index=1700.0 + np.arange(300), name="level"), 2, lam=30.0)
    ax = yearly.plot().axes[0]
    assert ax.get_ylabel() == "frequency (cycles per unit of time)"
    assert ax.get_xlabel() == "time" and ax.lines[0].get_xdata()[0] == 1702.0
    daily = ltv.fit_ar(
        pd.Series(y, index=pd.date_range("2020-01-01", periods=300, freq="2D")), 2, lam=30.0
    )
    ax = daily.plot().axes[0]
    assert ax.get_ylabel() == "frequency (cycles per day)" and ax.get_ylim()[1] == 0.25
    ax = yearly.plot(fs=100.0).axes[0]  # an explicit sampling frequency keeps seconds and Hz
    assert ax.get_ylabel() == "frequency (Hz)" and ax.get_xlabel() == "time (s)"
    plain = ltv.fit_ar(y, 2, lam=30.0)
    assert plain.plot().axes[0].get_ylabel() == "frequency (cycles per sample)"
