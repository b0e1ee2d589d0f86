"""Figures of signals: a simulation or prediction against data, forecasts, spectrograms."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..validation import arrays, options
from .figure import ESTIMATE_COLOR, new_axes, new_figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["plot_simulation", "plot_forecast", "plot_root_spectrogram", "plot_spectrogram"]


def plot_simulation(
    data: ArrayLike,
    simulation: ArrayLike,
    *,
    start: int = 0,
    names: Sequence[str] | None = None,
    label: str = "simulation",
    fig: Figure | None = None,
) -> Figure:
    """Plot a simulation or prediction against the recorded data, one subplot per signal.

    Parameters
    ----------
    data : array_like, shape (T, n) or (T,)
        Recorded signals (e.g. the states x), drawn solid.
    simulation : array_like, shape (S, n) or (S,)
        Simulated or predicted signals, drawn dashed; row j belongs to time
        ``start + j`` of ``data`` (``model.simulate(x[0], u)``: start 0;
        ``model.predict(x, u)``, predictions of x[1:]: start 1; AR models:
        ``model.lag``).
    start : int, default 0
        Time index of the first row of ``simulation``, with
        ``start + S <= T``.
    names : sequence of str, optional
        Titles of the n subplots (default "x[0]", "x[1]", …).
    label : str, default "simulation"
        Legend label of the dashed curves (e.g. "one-step prediction").
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
        With n axes stacked vertically (shared time axis); each title gives
        the RMS error of the simulation against the data over its rows.

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
    if names is None:
        names = [f"x[{i}]" for i in range(n)]
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
    t_data = np.arange(T)
    t_sim = start + np.arange(S)
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
    axes[-1].set_xlabel("t")
    axes[0].legend(fontsize="small", loc="best")
    return fig


def plot_forecast(
    forecast: Any, *, history: ArrayLike | None = None, fig: Figure | None = None
) -> Figure:
    """Plot a forecast: its mean and prediction interval, one subplot per state (output).

    Parameters
    ----------
    forecast : Forecast
        From :meth:`ltvmodels.LTVModel.forecast` or
        :meth:`ltvmodels.ARXModel.forecast` (any object with ``mean``,
        ``lower``, ``upper`` (steps, n), ``time`` (steps,), ``level`` and
        ``names``).
    history : array_like, shape (H, n) or (H,), optional
        Recorded samples leading up to the forecast, drawn solid in black:
        row i belongs to time ``time[0] − (H − i)·Δ`` with Δ one sample (for a
        dated forecast the step between its first two times) (pass the end of
        the data, e.g. ``x[-50:]``). A line joins the last of them to the
        first forecast.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
        With n axes stacked vertically (shared time axis "t"), each with the
        state's name as y label, the mean as a line and the interval as a
        band (``ax.collections[0]``).

    Raises
    ------
    TypeError, ValueError
        A ``forecast`` without those attributes, or a ``history`` whose
        columns do not match.
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
    time = np.asarray(forecast.time)
    dated = np.issubdtype(time.dtype, np.datetime64)
    if not dated:
        time = time.astype(float)
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
            # one sample per step before the forecast (for dates: the forecast's step)
            step = (
                (time[1] - time[0])
                if dated and steps > 1
                else (np.timedelta64(1, "D") if dated else 1.0)
            )
            t_past = time[0] - (past.shape[0] - np.arange(past.shape[0])) * step
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
    axes[-1].set_xlabel("time" if dated else "t")
    if dated:
        fig.autofmt_xdate()
    axes[0].set_title(f"Forecast, {steps} step{'s' if steps > 1 else ''}", fontsize="medium")
    axes[0].legend(fontsize="small", loc="best")
    return fig


def plot_root_spectrogram(model: Any, fs: float | None = None, *, ax: Axes | None = None) -> Axes:
    """Plot the root spectrogram of an AR/ARX model: pole frequencies over time.

    Each complex-conjugate pair of poles of 1/A_t(z) is one dot per time step
    at its frequency (:meth:`ltvmodels.ARXModel.root_spectrogram`), so the
    resonances of the time-varying model appear as tracks, a parametric
    counterpart of a spectrogram (draw it over
    :func:`scipy.signal.spectrogram` for comparison).

    Parameters
    ----------
    model : ARModel or ARXModel
        Any object with ``root_spectrogram(fs)`` → (N, r) and
        ``sample_index`` (N,) (and, optionally, ``step_times``: the time index
        of the data).
    fs : float, optional
        Sampling frequency (Hz); the time axis is then ``sample_index / fs``
        seconds. Default: from the model's time index when it is regular —
        dates: cycles per day against the dates; numbers (e.g. years): cycles
        per unit of the index against it — else cycles per sample against the
        sample.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure); the y axis spans 0 … fs/2.
    """
    if not callable(getattr(model, "root_spectrogram", None)) or not hasattr(model, "sample_index"):
        raise TypeError(
            f"model: expected an AR/ARX model with root_spectrogram() and "
            f"sample_index, received {type(model).__name__}"
        )
    if fs is not None:
        fs = options.positive_scalar(fs, "fs")
        time = np.asarray(model.sample_index, dtype=float) / fs
        time_label, unit = "time (s)", "Hz"
    else:
        fs, time, time_label, unit = _index_frequency(model)
    freq = np.asarray(model.root_spectrogram(fs), dtype=float)
    if ax is None:
        ax = new_axes((7.0, 3.2))
    for i in range(freq.shape[1]):
        ax.plot(
            time,
            freq[:, i],
            linestyle="none",
            marker=".",
            markersize=1.5,
            color=ESTIMATE_COLOR,
            label="pole frequencies" if i == 0 else None,
        )
    ax.set_xlabel(time_label)
    ax.set_ylabel(f"frequency ({unit})")
    ax.set_title("Root spectrogram")
    ax.set_ylim(0, fs / 2)
    ax.grid(True, alpha=0.3)
    return ax


def _index_frequency(model: Any) -> tuple[float, np.ndarray, str, str]:
    """(fs, time axis, its label, the frequency unit) from a model's regular time index."""
    times = getattr(model, "step_times", None)
    samples = np.asarray(model.sample_index, dtype=float)
    if times is None or len(times) < 2:
        return 1.0, samples, "sample", "cycles per sample"
    steps = np.diff(times)
    if np.any(steps != steps[0]):
        return 1.0, samples, "sample", "cycles per sample"
    if np.issubdtype(times.dtype, np.datetime64):
        day = float(steps[0] / np.timedelta64(1, "D"))
        return 1.0 / day, times, "time", "cycles per day"
    return 1.0 / float(steps[0]), times, "time", "cycles per unit of time"


def plot_spectrogram(
    y: ArrayLike,
    fs: float,
    *,
    ax: Axes | None = None,
    nperseg: int = 256,
    dynamic_range: float = 80.0,
) -> Axes:
    """Draw the short-time Fourier spectrogram of a scalar signal in grey.

    The non-parametric counterpart of :func:`plot_root_spectrogram`; draw the
    root spectrogram over it (same ``ax``) to compare them. Uses
    :func:`scipy.signal.spectrogram` with 75 % overlapping Hann windows.

    Parameters
    ----------
    y : array_like, shape (T,) or (T, 1)
        The signal.
    fs : float
        Sampling frequency (Hz).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.
    nperseg : int, default 256
        Window length (samples), >= 8; shortened to T for short signals.
    dynamic_range : float, default 80.0
        Power range shown (dB below the maximum), > 0.

    Returns
    -------
    matplotlib.axes.Axes
        With the spectrogram as ``ax.collections[0]`` (a QuadMesh); the axes
        are time (s) and frequency (Hz).
    """
    from scipy.signal import spectrogram

    arr = arrays.as_float_array(y, "y")
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim != 1 or arr.shape[0] < 8:
        raise ValueError(
            f"y: expected a 1-d signal of at least 8 samples, received shape {arr.shape}"
        )
    fs = options.positive_scalar(fs, "fs")
    nperseg = min(options.integer(nperseg, "nperseg", minimum=8), arr.shape[0])
    dynamic_range = options.positive_scalar(dynamic_range, "dynamic_range")
    freq, time, power = spectrogram(arr, fs=fs, nperseg=nperseg, noverlap=(3 * nperseg) // 4)
    power_db = 10 * np.log10(power + 1e-300)
    top = float(power_db.max())
    if ax is None:
        ax = new_axes((7.0, 3.2))
    ax.pcolormesh(
        time, freq, power_db, cmap="Greys", shading="auto", vmin=top - dynamic_range, vmax=top
    )
    ax.set_xlabel("time (s)")
    ax.set_ylabel("frequency (Hz)")
    ax.set_title("Spectrogram")
    return ax
