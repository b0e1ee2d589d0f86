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
    # order 1: a change at c shows at activation index c − 1, drawn where step c is: at
    # sample c + 1, the first state the new coefficients produce (no time axis: samples)
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), np.arange(2, model.N + 1))
    assert [line.get_xdata()[0] for line in ax.lines[1:]] == [31, 61]
    assert ax.get_xlabel() == "sample"
    assert ax.get_legend() is not None and "31, 61" in ax.get_legend().get_title().get_text()
    ax = plotting.plot_activation(model, changepoints=found[:0])
    assert "none" in ax.get_legend().get_title().get_text()
    with pytest.raises(ValueError, match="changepoints"):
        plotting.plot_activation(model, changepoints=[1.5])
    with pytest.raises(ValueError, match=r"changepoints: expected step indices c \(integers 0"):
        plotting.plot_activation(model, changepoints=[model.N])


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
    assert list(segmented.changepoints) == [60]
    fig = plotting.plot_model(segmented)  # change points of the model itself, at x[c + 1]
    assert "61" in fig.subfigs[1].axes[0].get_legend().get_title().get_text()


def test_plot_model_marks_the_change_points_the_fit_found(data):
    """Plotting never detects change points itself: it draws those of the model, or given ones."""
    group = ltv.fit(data.x, data.u, lam=5.0, norm="group")
    assert group.changepoints.size
    fig = plotting.plot_model(group)
    legend = fig.subfigs[1].axes[0].get_legend().get_title().get_text()
    # at the first state each change produces, x[c + 1]
    assert legend == "detected: " + ", ".join(str(int(c) + 1) for c in group.changepoints)
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


# -- the data's time axis -----------------------------------------------------------------

TIME_AXES = ["daily", "monthly", "quarterly", "annual", "tenths", "none"]
"""Time axes of the data: a DatetimeIndex named "date" (daily), monthly ("MS") and quarterly
("QS") ones without a name, years as numbers in an index named "year", tenths of a time
unit, and none (sample indices)."""

LABELS = {
    "daily": "date",
    "monthly": "time",
    "quarterly": "time",
    "annual": "year",
    "tenths": "time",
    "none": "sample",
}
"""The x label of each time axis: its name, "time" without one, "sample" without an axis."""

RATES = {
    "daily": (1.0, "cycles per day"),
    "monthly": (1.0, "cycles per month"),
    "quarterly": (4.0, "cycles per year"),
    "annual": (1.0, "cycles per year"),
    "tenths": (10.0, "cycles per time unit"),
    "none": (1.0, "cycles per sample"),
}
"""The sampling rate of each time axis in cycles per its unit, and the frequency unit."""


def _time_index(kind, T):
    """The pandas index of T samples of a time axis of ``TIME_AXES`` (None: no axis)."""
    pd = pytest.importorskip("pandas")
    return {
        "daily": lambda: pd.date_range("2021-01-01", periods=T, freq="D", name="date"),
        "monthly": lambda: pd.date_range("1990-01-01", periods=T, freq="MS"),
        "quarterly": lambda: pd.date_range("1950-01-01", periods=T, freq="QS"),
        "annual": lambda: pd.Index(1900.0 + np.arange(T), name="year"),
        "tenths": lambda: pd.Index(0.1 * np.arange(T)),
        "none": lambda: None,
    }[kind]()


def _x(values):
    """matplotlib's x data of time values: date numbers for dates, else the values."""
    values = np.asarray(values)
    if np.issubdtype(values.dtype, np.datetime64):
        return matplotlib.dates.date2num(values)
    return values


def _samples(index, samples):
    """The x data of sample indices on the time axis ``index`` (None: the indices)."""
    return np.asarray(samples) if index is None else _x(index.to_numpy()[samples])


def _assert_time_axis(ax, kind):
    """Dates get a date locator and a concise formatter; numbers keep number ticks."""
    locator, formatter = ax.xaxis.get_major_locator(), ax.xaxis.get_major_formatter()
    dated = kind in ("daily", "monthly", "quarterly")
    assert isinstance(locator, matplotlib.dates.AutoDateLocator) == dated
    assert isinstance(formatter, matplotlib.dates.ConciseDateFormatter) == dated


def _recording(kind, T=120):
    """A jump-linear recording (change at step 60) as DataFrames on a time axis (arrays for
    "none"), and that axis."""
    data = systems.jump_linear(T=T, change_at=60, seed=0)
    index = _time_index(kind, T)
    if index is None:
        return data, data.x, data.u, None
    import pandas as pd

    x = pd.DataFrame(data.x, index=index, columns=["p", "v"])
    return data, x, pd.DataFrame(data.u, index=index, columns=["f"]), index


@pytest.mark.parametrize("kind", TIME_AXES)
def test_a_state_space_model_plots_against_its_time_axis(kind):
    """Coefficients, activation and eigenvalues are drawn at the times of the data (step t
    at x[t + 1], which it produces), the change points at model.changepoint_times."""
    data, x, u, index = _recording(kind)
    model = ltv.fit_segments(x, u, n_changes=1)
    assert list(model.changepoints) == [60]
    steps = _samples(index, np.arange(1, data.T))
    change = _samples(index, [61])
    if index is not None:
        np.testing.assert_array_equal(change, _x(model.changepoint_times))
    fig = model.plot()
    assert isinstance(fig, Figure)
    if index is not None:  # the data's column names
        assert [ax.get_title() for ax in fig.axes[:3]] == ["A[p,p]", "A[p,v]", "B[p,f]"]
    for ax in fig.axes:
        estimate, *marks = ax.lines
        np.testing.assert_allclose(estimate.get_xdata(orig=False), steps)
        assert [mark.get_xdata(orig=False)[0] for mark in marks] == list(change)
        _assert_time_axis(ax, kind)
    assert [ax.get_xlabel() for ax in fig.axes] == ["", "", "", *[LABELS[kind]] * 3]
    activation, eigenvalues = plotting.plot_model(model).subfigs[1].axes
    # order 1: activation index t compares k_t and k_{t+1}: drawn where step t + 1 is
    np.testing.assert_allclose(activation.lines[0].get_xdata(orig=False), steps[1:])
    np.testing.assert_allclose(activation.lines[1].get_xdata(orig=False)[0], change[0])
    title = activation.get_legend().get_title().get_text()
    expected = {"daily": "2021-03-03", "monthly": "1995-02-01", "quarterly": "1965-04-01"}
    assert title == "detected: " + expected.get(kind, f"{_samples(index, [61])[0]:g}")
    np.testing.assert_allclose(eigenvalues.lines[0].get_xdata(orig=False), steps)
    assert activation.get_xlabel() == eigenvalues.get_xlabel() == LABELS[kind]
    _assert_time_axis(activation, kind)


def test_a_regression_and_its_segmentation_plot_against_the_times_of_the_rows():
    """A regression's row t is y[t]: drawn at its date, a change at y[c]."""
    pd = pytest.importorskip("pandas")
    rng = np.random.default_rng(3)
    days = pd.date_range("2022-01-01", periods=150, freq="D", name="day")
    phi = pd.DataFrame({"price": rng.standard_normal(150), "1": np.ones(150)}, index=days)
    slope = np.where(np.arange(150) < 90, 1.0, -1.0)
    y = pd.Series(slope * phi["price"] + 0.05 * rng.standard_normal(150), index=days, name="sales")
    segmentation = ltv.segment_regression(y, phi, n_changes=1)
    assert list(segmentation.changepoints) == [90]
    fig = segmentation.plot()
    assert isinstance(fig, Figure)
    assert [ax.get_title() for ax in fig.axes] == ["sales:price", "sales:1"]
    for ax in fig.axes:
        estimate, mark = ax.lines
        np.testing.assert_allclose(estimate.get_xdata(orig=False), _x(days.to_numpy()))
        np.testing.assert_allclose(
            mark.get_xdata(orig=False), _x(segmentation.changepoint_times).repeat(2)
        )  # a vertical line: (x, x)
        assert ax.get_xlabel() == "day"
        _assert_time_axis(ax, "daily")


def _ar2_series(T=300, seed=1):
    rng = np.random.default_rng(seed)
    y = np.zeros(T)
    for t in range(2, T):
        y[t] = 1.5 * y[t - 1] - 0.9 * y[t - 2] + 0.1 * rng.standard_normal()
    return y


@pytest.mark.parametrize("kind", TIME_AXES)
def test_spectrograms_are_in_cycles_per_unit_of_the_time_axis(kind):
    """The root spectrogram and the spectrogram: frequencies in cycles per unit of the time
    axis (1 / its step), against that axis; an explicit fs keeps Hz."""
    pd = pytest.importorskip("pandas")
    y = _ar2_series()
    index = _time_index(kind, y.size)
    series = y if index is None else pd.Series(y, index=index, name="level")
    model = ltv.fit_ar(series, 2, lam=30.0)
    fs, unit = RATES[kind]
    fig = model.plot()
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert ax.get_ylabel() == f"frequency ({unit})" and ax.get_xlabel() == LABELS[kind]
    np.testing.assert_allclose(ax.get_ylim()[1], fs / 2, rtol=1e-12)
    per_sample = model.root_spectrogram(1.0)[:, 0]
    np.testing.assert_allclose(ax.lines[0].get_ydata(), per_sample * fs, rtol=1e-12)
    # step j describes y[2 + j]
    np.testing.assert_allclose(
        ax.lines[0].get_xdata(orig=False), _samples(index, np.arange(2, 300))
    )
    _assert_time_axis(ax, kind)
    ax = plotting.plot_spectrogram(series, nperseg=64)  # the time axis of a pandas series
    assert ax.get_ylabel() == f"frequency ({unit})" and ax.get_xlabel() == LABELS[kind]
    _assert_time_axis(ax, kind)
    edges = ax.collections[0].get_coordinates()  # cells around f = 0 … fs/2, fs/64 apart
    np.testing.assert_allclose(edges[..., 1].max(), fs / 2 + fs / 128, rtol=1e-9)
    inside = _samples(index, [0, 299])
    assert inside[0] < edges[..., 0].min() < edges[..., 0].max() < inside[1]
    assert plotting.plot_root_spectrogram(model, ax=ax) is ax  # drawn over it, same units
    if index is not None:  # the times given as an argument instead
        given = plotting.plot_spectrogram(y, nperseg=64, time=index)
        np.testing.assert_allclose(given.collections[0].get_coordinates(), edges)
    ax = model.plot(fs=100.0).axes[0]  # a given sampling frequency: Hz
    assert ax.get_ylabel() == "frequency (Hz)" and ax.get_ylim()[1] == 50.0
    assert ax.get_xlabel() == ("time (s)" if index is None else LABELS[kind])


@pytest.mark.parametrize("kind", TIME_AXES)
def test_a_forecast_and_its_history_share_the_time_axis(kind):
    data, x, u, index = _recording(kind)
    model = ltv.fit(x, u, lam=10.0)
    forecast = model.forecast(data.x[-1], np.zeros(5))
    fig = forecast.plot(history=data.x[-10:])
    assert isinstance(fig, Figure)
    for ax in fig.axes:
        history, joint, mean = ax.lines
        np.testing.assert_allclose(history.get_xdata(orig=False), _samples(index, range(110, 120)))
        np.testing.assert_allclose(mean.get_xdata(orig=False), _x(forecast.time))
        np.testing.assert_allclose(
            joint.get_xdata(orig=False), [_samples(index, [119])[0], _x(forecast.time[:1])[0]]
        )
        _assert_time_axis(ax, kind)
    assert fig.axes[-1].get_xlabel() == LABELS[kind]
    if index is not None:
        assert [ax.get_ylabel() for ax in fig.axes] == ["p", "v"]


def test_a_short_dated_forecast_takes_the_times_of_its_history():
    """Two monthly forecast dates do not tell a month from 31 days: the history's times are
    given (or come with a pandas history), never guessed."""
    data, x, u, index = _recording("monthly")
    model = ltv.fit(x, u, lam=10.0)
    forecast = model.forecast(data.x[-1], np.zeros(2))
    with pytest.raises(ValueError, match="^history_time: the times of the history cannot be"):
        forecast.plot(history=data.x[-10:])
    expected = _x(model.time[-10:])
    fig = forecast.plot(history=data.x[-10:], history_time=model.time[-10:])
    np.testing.assert_allclose(fig.axes[0].lines[0].get_xdata(orig=False), expected)
    fig = forecast.plot(history=x.iloc[-10:])  # a DataFrame's index
    np.testing.assert_allclose(fig.axes[0].lines[0].get_xdata(orig=False), expected)
    with pytest.raises(ValueError, match=r"^history_time: expected dates as the forecast's"):
        forecast.plot(history=data.x[-3:], history_time=[1.0, 2.0, 3.0])
    late = np.concatenate([model.time[-2:], forecast.time[:1]])
    with pytest.raises(ValueError, match=r"^history_time: expected times before the forecast"):
        forecast.plot(history=data.x[-3:], history_time=late)
    with pytest.raises(ValueError, match=r"^history_time: expected 3 times"):
        forecast.plot(history=data.x[-3:], history_time=model.time[-4:])


def test_a_simulation_is_drawn_against_the_times_of_the_data():
    pd = pytest.importorskip("pandas")
    data, x, u, index = _recording("daily")
    model = ltv.fit(x, u, lam=10.0)
    prediction = model.predict(data.x, data.u)
    fig = plotting.plot_simulation(x, prediction, start=1, label="one-step prediction")
    assert [ax.get_title().split(":")[0] for ax in fig.axes] == ["p", "v"]  # its columns
    data_line, prediction_line = fig.axes[0].lines
    np.testing.assert_allclose(data_line.get_xdata(orig=False), _x(index.to_numpy()))
    np.testing.assert_allclose(prediction_line.get_xdata(orig=False), _x(index.to_numpy()[1:]))
    assert fig.axes[-1].get_xlabel() == "date"
    _assert_time_axis(fig.axes[-1], "daily")
    years = pd.Index(1900.0 + np.arange(data.T), name="year")
    fig = plotting.plot_simulation(data.x, prediction, start=1, time=years)
    np.testing.assert_allclose(fig.axes[0].lines[1].get_xdata(), years[1:])
    assert fig.axes[-1].get_xlabel() == "year"
    with pytest.raises(ValueError, match=r"^time: expected 120 times \(one per sample\)"):
        plotting.plot_simulation(data.x, prediction, start=1, time=years[1:])
    with pytest.raises(ValueError, match=r"^time: expected strictly increasing times"):
        plotting.plot_simulation(data.x, prediction, start=1, time=years[::-1])
    with pytest.raises(TypeError, match=r"^time: expected dates .* or numbers"):
        plotting.plot_simulation(data.x, prediction, start=1, time=["a"] * data.T)


@pytest.mark.parametrize("freq", ["D", "MS", "QS"])
def test_date_tick_labels_do_not_overlap(freq):
    """Five narrow coefficient panels per row still get readable, separate date labels."""
    pd = pytest.importorskip("pandas")
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    rw = systems.random_walk_system(T=200, seed=0)  # n = 3, m = 2: five columns
    days = pd.date_range("2001-01-01", periods=rw.T, freq=freq)
    model = ltv.fit(pd.DataFrame(rw.x, index=days), pd.DataFrame(rw.u, index=days), lam=30.0)
    fig = plotting.plot_model(model)
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    bottom = [ax for ax in fig.axes if any(t.get_text() for t in ax.get_xticklabels())]
    assert len(bottom) == 5 + 2  # the last row of coefficients, activation, eigenvalues
    for ax in bottom:
        _assert_time_axis(ax, "daily")
        labels = [label for label in ax.get_xticklabels() if label.get_text()]
        boxes = sorted((label.get_window_extent(renderer) for label in labels), key=lambda b: b.x0)
        assert len(boxes) >= 2
        assert all(left.x1 < right.x0 for left, right in zip(boxes, boxes[1:]))


def test_the_time_axis_name_is_kept_with_the_model(tmp_path):
    """The index's (time column's) name is part of model.data: saved, loaded, and carried by
    fit_many's models; figures label their time axis with it."""
    pytest.importorskip("pandas")
    data, x, u, index = _recording("daily")
    model = ltv.fit(x, u, lam=10.0)
    assert model.data.time_name == "date"
    model.save(tmp_path / "m.npz")
    loaded = ltv.load(tmp_path / "m.npz")
    assert loaded.data.time_name == "date" and loaded.plot().axes[-1].get_xlabel() == "date"
    unnamed = ltv.fit(x.rename_axis(None), u.rename_axis(None), lam=10.0)
    assert unnamed.data.time_name is None and unnamed.plot().axes[-1].get_xlabel() == "time"
    frame = x.reset_index().assign(f=data.u[:, 0], unit="a")
    models = ltv.fit_many(
        frame, by="unit", state=["p", "v"], inputs="f", time="date", lam=10.0, n_jobs=1
    )
    assert models["a"].data.time_name == "date"
    assert models["a"].plot().axes[-1].get_xlabel() == "date"


def test_every_result_plot_returns_a_figure(data):
    """Models, forecasts and segmentations return their Figure already; the λ selection and
    the Kalman results do too, and a fig= fills a given figure where ax= existed."""
    selection = ltv.select_lambda(data.x, data.u, norm="sq", lams=[1.0, 10.0, 100.0])
    fig = selection.plot()
    assert isinstance(fig, Figure) and len(fig.axes) == 1
    ax = Figure().subplots(1, 2)[1]
    assert selection.plot(ax=ax) is ax.figure and len(ax.lines) >= 1
    given = Figure()
    given.add_subplot()
    assert selection.plot(fig=given) is given and len(given.axes) == 1
    with pytest.raises(TypeError, match=r"^fig, ax: expected one of them, received both"):
        selection.plot(ax=ax, fig=given)
    armodel = ltv.fit_ar(_ar2_series(), 2, lam=30.0)
    assert armodel.plot(fig=given) is given and given.axes[0].get_title().startswith("Root")
    for result in (
        ltv.kalman_filter(data.x, data.u, lam=30.0),
        ltv.kalman_smoother(data.x, data.u, lam=30.0),
    ):
        fig = result.plot(truth=data)
        assert isinstance(fig, Figure) and len(fig.axes) == 6
        assert all(len(ax.collections) == 1 for ax in fig.axes)  # the ±2σ bands
        np.testing.assert_array_equal(fig.axes[0].lines[0].get_xdata(), np.arange(1, data.T))
        full = np.sqrt(np.diagonal(result.cov_full(), axis1=1, axis2=2))
        np.testing.assert_allclose(result.std(), full, rtol=1e-12)
