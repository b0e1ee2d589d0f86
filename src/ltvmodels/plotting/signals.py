"""Figures of signals: a simulation or prediction against data, forecasts, spectrograms."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..validation import arrays, options
from ..validation.time import preceding
from .figure import ESTIMATE_COLOR, new_axes, new_figure
from .timeaxis import SAMPLE_LABEL, TIME_LABEL, TimeAxis, given_axis, spectral_units, step_axis

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "plot_simulation",
    "plot_states",
    "plot_forecast",
    "plot_root_spectrogram",
    "plot_spectrogram",
]


def plot_simulation(
    data: ArrayLike,
    simulation: ArrayLike,
    *,
    start: int = 0,
    names: Sequence[str] | None = None,
    label: str = "simulation",
    time: ArrayLike | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Plot a simulation or prediction against the recorded data, one subplot per signal.

    Parameters
    ----------
    data : array_like, shape (T, n) or (T,)
        Recorded signals (e.g. the states x), drawn solid. A pandas DataFrame
        (or named Series) names the subplots with its columns and, with a time
        index, gives the time axis.
    simulation : array_like, shape (S, n) or (S,)
        Simulated or predicted signals, drawn dashed; row j belongs to time
        ``start + j`` of ``data`` (``model.simulate(x[0], u)``: start 0;
        ``model.predict(x, u)``, predictions of x[1:]: start 1; AR models:
        ``model.lag``).
    start : int, default 0
        Time index of the first row of ``simulation``, with
        ``start + S <= T``.
    names : sequence of str, optional
        Titles of the n subplots. Default: the columns of a pandas ``data``,
        else "x[0]", "x[1]", ….
    label : str, default "simulation"
        Legend label of the dashed curves (e.g. "one-step prediction").
    time : array_like, shape (T,), or pandas Index, optional
        The time of each row of ``data`` (dates or numbers, increasing; e.g.
        ``model.time``); a pandas Index names the axis. Default: the time
        index of a pandas ``data``, else the sample indices ("sample").
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
        With n axes stacked vertically (shared time axis: dates on a date
        axis, numbers, or samples); each title gives the RMS error of the
        simulation against the data over its rows.

    Raises
    ------
    TypeError, ValueError
        Shapes that do not match (the message names the argument).
    """
    x = arrays.as_float_array(data, "data")
    sim = arrays.as_float_array(simulation, "simulation")
    x = x[:, None] if x.ndim == 1 else x
    sim = sim[:, None] if sim.ndim == 1 else sim
    if x.ndim != 2 or x.shape[0] == 0:
        raise ValueError(f"data: expected shape (T, n) or (T,), received {x.shape}")
    T, n = x.shape
    start = options.integer(start, "start", minimum=0)
    if sim.ndim != 2 or sim.shape[1] != n:
        raise ValueError(
            f"simulation: expected shape (S, {n}) (one column per column of "
            f"data), received {sim.shape}"
        )
    S = sim.shape[0]
    if start + S > T:
        raise ValueError(
            f"simulation: rows start .. start + S = {start} .. {start + S} do not "
            f"fit in the T = {T} rows of data"
        )
    axis = _series_axis(data, time, T, "time")
    if names is None:
        names = arrays.column_names(data, n, "data") or [f"x[{i}]" for i in range(n)]
    else:
        if isinstance(names, str):
            raise TypeError(f"names: expected a sequence of {n} strings, received {names!r}")
        names = [str(name) for name in names]
        if len(names) != n:
            raise ValueError(f"names: expected {n} names, received {len(names)}")
    if not isinstance(label, str):
        raise TypeError(f"label: expected a string, received {label!r}")
    if fig is None:
        fig = new_figure((8.0, min(1.9 * n + 0.6, 14.0)))
    else:
        fig.clear()
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    t_data = axis.values
    t_sim = axis.values[start : start + S]
    with np.errstate(over="ignore", invalid="ignore"):
        err = sim - x[start : start + S]
        rms = np.sqrt(np.mean(err**2, axis=0)) if S else np.full(n, np.nan)
    for i, ax in enumerate(axes):
        ax.plot(t_data, x[:, i], color="black", linewidth=1.0, label="data")
        ax.plot(t_sim, sim[:, i], color=ESTIMATE_COLOR, linestyle="--", linewidth=1.2, label=label)
        ax.set_title(f"{names[i]}: RMS error {rms[i]:.3g}", fontsize="medium")
        ax.grid(True, alpha=0.3)
        finite = np.concatenate([x[:, i], sim[:, i][np.isfinite(sim[:, i])]])
        span = float(np.ptp(x[:, i])) or 1.0
        # keep a diverging simulation from flattening the data
        low = max(float(finite.min()), x[:, i].min() - 2 * span)
        high = min(float(finite.max()), x[:, i].max() + 2 * span)
        pad = 0.05 * ((high - low) or 1.0)
        ax.set_ylim(low - pad, high + pad)
        axis.draw_on(ax, label=ax is axes[-1])
    axes[0].legend(fontsize="small", loc="best")
    return fig


def plot_states(
    model: Any,
    x: ArrayLike,
    *,
    trajectory: int = 0,
    band: float = 2.0,
    time: ArrayLike | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Plot the recorded states against the smoothed ones of a fit with measurement noise.

    Parameters
    ----------
    model : LTVModel
        A model fitted with ``measurement_noise`` (it has ``states`` and
        ``states_std``; see :func:`ltvmodels.fit`).
    x : array_like, shape (T, n) or (R, T, n)
        The recorded states the model was fitted to (NaN = missing), drawn as
        dots; a pandas DataFrame names the subplots and gives the time axis.
    trajectory : int, default 0
        Which trajectory to draw, for R trajectories.
    band : float, default 2.0
        Half-width of the shaded band around the smoothed states, in their
        standard deviations (0: no band).
    time : array_like, shape (T,), optional
        The time of each row (default: the index of a pandas ``x``, else the
        sample indices).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
        One axis per state; each title gives the RMS difference between the
        recorded and the smoothed values and the estimated measurement noise σ.
        The samples in ``model.sample_outliers`` are marked by red crosses.

    Raises
    ------
    TypeError, ValueError
        A model without smoothed states, or shapes that do not match.
    """
    states = getattr(model, "states", None)
    std = getattr(model, "states_std", None)
    if states is None or std is None:
        raise ValueError(
            "model: expected a model fitted with measurement_noise (with smoothed states), "
            "received one whose states were taken as exact; fit it with "
            "measurement_noise='estimate'"
        )
    values = arrays.as_float_array(x, "x", missing=True)
    states, std = np.asarray(states), np.asarray(std)
    flagged = getattr(model, "sample_outliers", None)
    flagged = np.zeros(states.shape[:-1], bool) if flagged is None else np.asarray(flagged)
    if values.shape != states.shape:
        raise ValueError(
            f"x: expected the recorded states of the fit, shape {states.shape}, received "
            f"{values.shape}"
        )
    if states.ndim == 3:
        trajectory = options.integer(trajectory, "trajectory", minimum=0)
        if trajectory >= values.shape[0]:
            raise ValueError(
                f"trajectory: expected an index below {values.shape[0]}, received {trajectory}"
            )
        values, states, std = values[trajectory], states[trajectory], std[trajectory]
        flagged = flagged[trajectory]
    band = options.nonnegative_scalar(band, "band")
    single = states.ndim == 2  # a pandas x (one trajectory) gives the time axis
    T, n = values.shape
    axis = _series_axis(x if single else values, time, T, "time")
    names = (
        arrays.column_names(x, n, "x")
        or list(getattr(model, "state_names", []))
        or [f"x[{i}]" for i in range(n)]
    )
    noise = np.sqrt(np.asarray(model.measurement_noise, dtype=float))
    if fig is None:
        fig = new_figure((8.0, min(1.9 * n + 0.6, 14.0)))
    else:
        fig.clear()
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    t = axis.values
    for i, ax in enumerate(axes):
        seen = np.isfinite(values[:, i])
        rms = np.sqrt(np.mean((values[seen, i] - states[seen, i]) ** 2)) if seen.any() else np.nan
        ax.plot(t, values[:, i], ".", color="0.45", markersize=2.5, label="recorded")
        if flagged.any():
            ax.plot(
                t[flagged],
                values[flagged, i],
                "x",
                color="tab:red",
                markersize=5,
                label="sample outlier",
            )
        ax.plot(t, states[:, i], color=ESTIMATE_COLOR, linewidth=1.2, label="smoothed")
        if band > 0:
            ax.fill_between(
                t,
                states[:, i] - band * std[:, i],
                states[:, i] + band * std[:, i],
                color=ESTIMATE_COLOR,
                alpha=0.2,
                linewidth=0,
                label=f"± {band:g} std",
            )
        ax.set_title(
            f"{names[i]}: RMS(recorded − smoothed) {rms:.3g}, noise σ {noise[i]:.3g}",
            fontsize="medium",
        )
        ax.grid(True, alpha=0.3)
        axis.draw_on(ax, label=ax is axes[-1])
    axes[0].legend(fontsize="small", loc="best")
    return fig


def _series_axis(data: Any, time: Any, count: int, name: str) -> TimeAxis:
    """The time axis of ``count`` rows of ``data``: ``time`` (the argument ``name``) when
    given, else the time index of a pandas ``data``, else the sample indices."""
    if time is not None:
        return given_axis(time, count, name)
    stamps = arrays.time_index(data, count)
    if stamps is None:
        return TimeAxis(np.arange(count), SAMPLE_LABEL)
    return TimeAxis(stamps, arrays.time_name(data) or TIME_LABEL)


def plot_forecast(
    forecast: Any,
    *,
    history: ArrayLike | None = None,
    history_time: ArrayLike | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Plot a forecast: its mean and prediction interval, one subplot per state (output).

    The forecast is drawn at its times (``forecast.time``: the model's time axis
    continued, dates on a date axis, or sample indices), the history before it
    on the same axis.

    Parameters
    ----------
    forecast : Forecast
        From :meth:`ltvmodels.LTVModel.forecast` or
        :meth:`ltvmodels.ARXModel.forecast` (any object with ``mean``,
        ``lower``, ``upper`` (steps, n), ``time`` (steps,), ``level`` and
        ``names``; optionally ``time_name``, the name of the time axis).
    history : array_like, shape (H, n) or (H,), optional
        Recorded samples leading up to the forecast, drawn solid in black
        (pass the end of the data, e.g. ``x[-50:]``, or of a pandas
        DataFrame, whose index gives their times). A line joins the last of
        them to the first forecast.
    history_time : array_like, shape (H,), or pandas Index, optional
        The times of the rows of ``history`` (e.g. ``model.time[-50:]``).
        Default: the index of a pandas ``history``; else the samples before
        ``forecast.time`` on its grid: sample indices, the step of numbers,
        the frequency of dates (which at least three forecast times tell;
        pass ``history_time`` for a shorter dated forecast).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
        With n axes stacked vertically (a shared time axis, labelled with
        ``forecast.time_name``, else the name of a pandas ``history_time``'s
        index, else "time", or "sample" for sample indices), each with the
        state's name as y label, the mean as a line and the interval as a
        band (``ax.collections[0]``).

    Raises
    ------
    TypeError, ValueError
        A ``forecast`` without those attributes, a ``history`` whose columns
        do not match, or history times that are not of the forecast's kind,
        do not come before it, or cannot be told.
    """
    needed = ("mean", "lower", "upper", "time", "level", "names")
    if not all(hasattr(forecast, name) for name in needed):
        raise TypeError(
            f"forecast: expected a Forecast (from model.forecast), received "
            f"{type(forecast).__name__}"
        )
    mean = np.asarray(forecast.mean, dtype=float)
    lower = np.asarray(forecast.lower, dtype=float)
    upper = np.asarray(forecast.upper, dtype=float)
    axis = _forecast_axis(np.asarray(forecast.time), getattr(forecast, "time_name", None))
    time = axis.values
    steps, n = mean.shape
    names = list(forecast.names)
    past = None
    if history is not None:
        past = arrays.as_float_array(history, "history", missing=True)
        past = past[:, None] if past.ndim == 1 else past
        if past.ndim != 2 or past.shape[1] != n:
            raise ValueError(
                f"history: expected shape (H, {n}) (one column per state of the "
                f"forecast), received {past.shape}"
            )
        past_axis = _history_axis(history, history_time, past.shape[0], axis)
        if axis.label == TIME_LABEL:  # a forecast without the name of its axis
            axis = TimeAxis(axis.values, past_axis.label)
    if fig is None:
        fig = new_figure((8.0, min(1.9 * n + 0.6, 14.0)))
    else:
        fig.clear()
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    band = f"{100 * float(forecast.level):g} % interval"
    for i, ax in enumerate(axes):
        ax.fill_between(
            time,
            lower[:, i],
            upper[:, i],
            color=ESTIMATE_COLOR,
            alpha=0.25,
            linewidth=0,
            label=band,
        )
        if past is not None and past.shape[0]:
            t_past = past_axis.values
            ax.plot(t_past, past[:, i], color="black", linewidth=1.0, label="data")
            ax.plot(
                [t_past[-1], time[0]],
                [past[-1, i], mean[0, i]],
                color=ESTIMATE_COLOR,
                linewidth=1.0,
                linestyle=":",
            )
        ax.plot(
            time,
            mean[:, i],
            color=ESTIMATE_COLOR,
            linewidth=1.2,
            marker="." if steps < 30 else None,
            label="forecast mean",
        )
        ax.set_ylabel(names[i])
        ax.grid(True, alpha=0.3)
        axis.draw_on(ax, label=ax is axes[-1])
    axes[0].set_title(f"Forecast, {steps} step{'s' if steps > 1 else ''}", fontsize="medium")
    axes[0].legend(fontsize="small", loc="best")
    return fig


def _forecast_axis(time: np.ndarray, name: str | None) -> TimeAxis:
    """The time axis of a forecast's times: dates or numbers (named ``name``), or sample
    indices (integers)."""
    if np.issubdtype(time.dtype, np.integer):
        return TimeAxis(time, SAMPLE_LABEL)
    if np.issubdtype(time.dtype, np.datetime64):
        return TimeAxis(time.astype("datetime64[ns]"), name or TIME_LABEL)
    return TimeAxis(time.astype(float), name or TIME_LABEL)


def _history_axis(history: Any, history_time: Any, count: int, forecast: TimeAxis) -> TimeAxis:
    """The times of the ``count`` rows of a forecast's history (see :func:`plot_forecast`)."""
    if history_time is not None or arrays.time_index(history, count) is not None:
        axis = _series_axis(history, history_time, count, "history_time")
        if axis.dated != forecast.dated:
            kinds = ("numbers", "dates")
            raise ValueError(
                f"history_time: expected {kinds[forecast.dated]} as the forecast's times, "
                f"received {kinds[axis.dated]}; pass the times of the history on the "
                "forecast's time axis (e.g. model.time[-H:])"
            )
        if count and not axis.values[-1] < forecast.values[0]:
            raise ValueError(
                f"history_time: expected times before the forecast's first "
                f"({forecast.text(forecast.values[:1])[0]}), received "
                f"{axis.text(axis.values[-1:])[0]} for the last row of history"
            )
        return axis
    if forecast.samples:
        return TimeAxis(forecast.values[0] - np.arange(count, 0, -1), SAMPLE_LABEL)
    before = preceding(forecast.values, count)
    if before is None:
        times = ", ".join(forecast.text(forecast.values))
        raise ValueError(
            f"history_time: the times of the history cannot be told from the "
            f"forecast's {forecast.values.size} time(s) ({times}); "
            "pass them (history_time=model.time[-H:] for the last H samples) or a "
            "pandas history with its time index"
        )
    return TimeAxis(before, forecast.label)


def plot_root_spectrogram(model: Any, fs: float | None = None, *, ax: Axes | None = None) -> Axes:
    """Plot the root spectrogram of an AR/ARX model: pole frequencies over time.

    Each complex-conjugate pair of poles of 1/A_t(z) is one dot per time step
    at its frequency (:meth:`ltvmodels.ARXModel.root_spectrogram`), so the
    resonances of the time-varying model appear as tracks, a parametric
    counterpart of a spectrogram (draw it over :func:`plot_spectrogram` for
    comparison: give both the same ``fs``, or none).

    Parameters
    ----------
    model : ARModel or ARXModel
        Any object with ``root_spectrogram(fs)`` → (N, r) and
        ``sample_index`` (N,) (and, optionally, ``time``: the time axis of the
        data, and ``data.time_name``, its name).
    fs : float, optional
        Sampling frequency in Hz: frequencies in Hz; without a time axis the
        time axis is then ``sample_index / fs`` seconds. Default: from the
        model's time axis — numbers (e.g. years): 1 / step, in cycles per the
        unit its name is ("year", "month", "day", …; else "time unit");
        dates: cycles per month for monthly data, per year for quarterly or
        yearly data, per day (hour, …) for a fixed step — else cycles per
        sample against the sample (:func:`ltvmodels.plotting.timeaxis.spectral_units`).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure); the y axis spans 0 … fs/2,
        labelled "frequency (unit)"; the x axis is the data's time axis (dates
        on a date axis, labelled with its name), where step j is drawn at the
        time of y[lag + j], the sample it describes.
    """
    if not callable(getattr(model, "root_spectrogram", None)) or not hasattr(model, "sample_index"):
        raise TypeError(
            f"model: expected an AR/ARX model with root_spectrogram() and "
            f"sample_index, received {type(model).__name__}"
        )
    if fs is not None:
        fs = options.positive_scalar(fs, "fs")
    # step j describes y[lag + j]: its produced sample, where step_axis draws it
    fs, unit, axis = spectral_units(step_axis(model, len(model.sample_index)), fs)
    freq = np.asarray(model.root_spectrogram(fs), dtype=float)
    if ax is None:
        ax = new_axes((7.0, 3.2))
    for i in range(freq.shape[1]):
        ax.plot(
            axis.values,
            freq[:, i],
            linestyle="none",
            marker=".",
            markersize=1.5,
            color=ESTIMATE_COLOR,
            label="pole frequencies" if i == 0 else None,
        )
    axis.draw_on(ax)
    ax.set_ylabel(f"frequency ({unit})")
    outputs = getattr(model, "output_names", None)
    ax.set_title("Root spectrogram" + (f" of {', '.join(outputs)}" if outputs else ""))
    ax.set_ylim(0, fs / 2)
    ax.grid(True, alpha=0.3)
    return ax


def plot_spectrogram(
    y: ArrayLike,
    fs: float | None = None,
    *,
    ax: Axes | None = None,
    nperseg: int = 256,
    dynamic_range: float = 80.0,
    time: ArrayLike | None = None,
) -> Axes:
    """Draw the short-time Fourier spectrogram of a scalar signal in grey.

    The non-parametric counterpart of :func:`plot_root_spectrogram`; draw the
    root spectrogram over it (same ``ax``, same ``fs`` or none) to compare
    them. Uses :func:`scipy.signal.spectrogram` with 75 % overlapping Hann
    windows.

    Parameters
    ----------
    y : array_like, shape (T,) or (T, 1)
        The signal; a pandas Series with a time index gives the time axis.
    fs : float, optional
        Sampling frequency in Hz: frequencies in Hz, and without a time axis
        times in seconds. Default: from the time axis, in cycles per its unit
        as :func:`plot_root_spectrogram`; without one, cycles per sample.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.
    nperseg : int, default 256
        Window length (samples), >= 8; shortened to T for short signals.
    dynamic_range : float, default 80.0
        Power range shown (dB below the maximum), > 0.
    time : array_like, shape (T,), or pandas Index, optional
        The time of each sample (dates or numbers, increasing; e.g.
        ``model.time``); a pandas Index names the axis. Default: the time
        index of a pandas ``y``, else none (sample indices, or seconds with
        ``fs``).

    Returns
    -------
    matplotlib.axes.Axes
        With the spectrogram as ``ax.collections[0]`` (a QuadMesh) at the
        windows' centres on the time axis, frequency 0 … fs/2 labelled
        "frequency (unit)".
    """
    from scipy.signal import spectrogram

    arr = arrays.as_float_array(y, "y")
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim != 1 or arr.shape[0] < 8:
        raise ValueError(
            f"y: expected a 1-d signal of at least 8 samples, received shape {arr.shape}"
        )
    if fs is not None:
        fs = options.positive_scalar(fs, "fs")
    nperseg = min(options.integer(nperseg, "nperseg", minimum=8), arr.shape[0])
    dynamic_range = options.positive_scalar(dynamic_range, "dynamic_range")
    fs, unit, axis = spectral_units(_series_axis(y, time, arr.shape[0], "time"), fs)
    # in samples and cycles per sample, then on the time axis and in its unit
    freq, centres, power = spectrogram(arr, fs=1.0, nperseg=nperseg, noverlap=(3 * nperseg) // 4)
    power_db = 10 * np.log10(power + 1e-300)
    top = float(power_db.max())
    if ax is None:
        ax = new_axes((7.0, 3.2))
    ax.pcolormesh(
        axis.at(centres),
        freq * fs,
        power_db,
        cmap="Greys",
        shading="auto",
        vmin=top - dynamic_range,
        vmax=top,
    )
    axis.draw_on(ax)
    ax.set_ylabel(f"frequency ({unit})")
    name = arrays.column_names(y, 1, "y")
    ax.set_title("Spectrogram" + (f" of {name[0]}" if name else ""))
    return ax
