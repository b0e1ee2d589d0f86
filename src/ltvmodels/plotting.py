"""Matplotlib figures of identified LTV models.

matplotlib is imported inside the functions, so ``import ltvmodels`` does not
load it. New figures are created as :class:`matplotlib.figure.Figure` objects
directly (not through :mod:`matplotlib.pyplot`), so nothing here needs a
display or a GUI backend: save them with ``fig.savefig(path)``; in Jupyter a
returned figure displays itself. To draw into a pyplot figure or axes, pass it
as ``fig`` / ``ax``.

The functions accept any model object with the attributes they use
(:class:`ltvmodels.LTVModel` has them all).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from . import _validate

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "plot_coefficients",
    "plot_activation",
    "plot_eigenvalues",
    "plot_poles",
    "plot_root_spectrogram",
    "plot_spectrogram",
    "plot_simulation",
    "plot_lambda_selection",
    "plot_model",
]

ESTIMATE_COLOR = "C0"


def _new_figure(figsize: tuple[float, float]) -> "Figure":
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def _new_axes(figsize: tuple[float, float]) -> "Axes":
    return _new_figure(figsize).add_subplot()


def _coefficient_names(n: int, m: int) -> list[list[str]]:
    return [[f"A[{i},{j}]" for j in range(n)] + [f"B[{i},{j}]" for j in range(m)]
            for i in range(n)]


def _model_theta(model: Any) -> np.ndarray:
    """(N, n, n + m) coefficients [A_t B_t] of ``model``."""
    for attr in ("A", "B"):
        if not hasattr(model, attr):
            raise TypeError(
                f"model: expected an object with attributes A (N, n, n) and B (N, n, m) "
                f"such as an LTVModel, received {type(model).__name__} without {attr!r}"
            )
    A = np.asarray(model.A, dtype=float)
    B = np.asarray(model.B, dtype=float)
    if A.ndim != 3 or A.shape[1] != A.shape[2]:
        raise ValueError(f"model.A: expected shape (N, n, n), received {A.shape}")
    if B.ndim != 3 or B.shape[:2] != A.shape[:2]:
        raise ValueError(f"model.B: expected shape {A.shape[:2] + ('m',)}, received {B.shape}")
    return np.concatenate([A, B], axis=2)


def _truth_theta(truth: Any, N: int, n: int, p: int) -> np.ndarray:
    """Coerce ``truth`` to (N, n, p) coefficients (a new array)."""
    K = n * p
    if hasattr(truth, "A") and hasattr(truth, "B"):
        A = np.asarray(truth.A, dtype=float)
        B = np.asarray(truth.B, dtype=float)
        if A.shape != (N, n, n) or B.shape != (N, n, p - n):
            raise ValueError(
                f"truth: expected A of shape {(N, n, n)} and B of shape {(N, n, p - n)} "
                f"(as the model), received A {A.shape} and B {B.shape}"
            )
        return np.concatenate([A, B], axis=2)
    arr = _validate.as_float_array(truth, "truth")
    if arr.shape == (N, K):
        return arr.reshape(N, n, p)
    if arr.shape == (N, n, p):
        return arr
    if arr.shape == (K,):
        return np.broadcast_to(arr.reshape(n, p), (N, n, p)).copy()
    raise ValueError(
        f"truth: expected an object with .A and .B, or an array of shape ({N}, {K}) "
        f"(true k_t per step), ({N}, {n}, {p}) or ({K},) (constant), received shape {arr.shape}"
    )


def plot_coefficients(model: Any, truth: Any = None, *, bands: bool = True,
                      fig: "Figure | None" = None) -> "Figure":
    """Plot every coefficient of [A_t B_t] over time, one subplot each.

    Parameters
    ----------
    model : LTVModel
        Identified model (any object with ``A`` (N, n, n), ``B`` (N, n, m) and
        optionally ``std()`` → (N, K) works).
    truth : object with ``.A``/``.B``, or array_like, optional
        True coefficients, drawn as dashed black lines: e.g. a
        :class:`ltvmodels.systems.SimulatedData` or another model (``A``
        (N, n, n), ``B`` (N, n, m)), an (N, K) array of parameter vectors
        k_t = ``np.hstack([A_t, B_t]).ravel()``, an (N, n, n + m) array, or a
        (K,) vector for constant coefficients.
    bands : bool, default True
        Shade ±2 posterior standard deviations (``model.std()``) around the
        estimates, when the model has covariances (``norm="sq"`` fits with
        ``compute_cov=True``); otherwise no bands are drawn.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new
        :class:`~matplotlib.figure.Figure` (no pyplot, no display needed).

    Returns
    -------
    matplotlib.figure.Figure
        With n × (n + m) axes in row-major order, titled ``"A[i,j]"`` /
        ``"B[i,j]"``; the x axis is the model index t = 0 … N − 1.

    Raises
    ------
    TypeError, ValueError
        If ``model`` lacks ``A``/``B`` or ``truth`` has the wrong shape.
    """
    if not isinstance(bands, bool):
        raise TypeError(f"bands: expected True or False, received {bands!r}")
    theta = _model_theta(model)
    N, n, p = theta.shape
    m = p - n
    truth_theta = None if truth is None else _truth_theta(truth, N, n, p)
    std = None
    if bands and callable(getattr(model, "std", None)):
        std = model.std()
        if std is not None:
            std = np.asarray(std, dtype=float)
            if std.shape != (N, n * p):
                raise ValueError(f"model.std(): expected shape {(N, n * p)}, received {std.shape}")
    if fig is None:
        fig = _new_figure((min(2.6 * p + 0.6, 18.0), min(1.9 * n + 0.5, 14.0)))
    else:
        fig.clear()
    axes = fig.subplots(n, p, sharex=True, squeeze=False)
    t = np.arange(N)
    names = _coefficient_names(n, m)
    for i in range(n):
        for j in range(p):
            ax = axes[i, j]
            est = theta[:, i, j]
            if std is not None:
                s = std[:, i * p + j]
                ax.fill_between(t, est - 2 * s, est + 2 * s, color=ESTIMATE_COLOR, alpha=0.25,
                                linewidth=0, label="±2σ")
            ax.plot(t, est, color=ESTIMATE_COLOR, linewidth=1.2, label="estimate")
            if truth_theta is not None:
                ax.plot(t, truth_theta[:, i, j], color="black", linestyle="--", linewidth=1.2,
                        label="truth")
            ax.set_title(names[i][j])
            ax.grid(True, alpha=0.3)
            if i == n - 1:
                ax.set_xlabel("t")
    axes[0, 0].legend(fontsize="small", loc="best")
    return fig


def plot_activation(model: Any, ax: "Axes | None" = None, *,
                    changepoints: Any = None) -> "Axes":
    """Plot the activation ‖(Dk)_t‖ of the model over time.

    Large values mark where the coefficients change (paper Section III); with
    a sparse norm they are the change points.

    Parameters
    ----------
    model : LTVModel
        Any object with ``activation()`` → (N − d,) (d the order of the
        difference operator).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.
    changepoints : array_like of int, optional
        Change points c to mark (e.g. :func:`ltvmodels.find_changepoints` of
        the model, or ``model.changepoints``), drawn as dashed red vertical
        lines at activation index t = c − ⌈d/2⌉, where a change between
        k_{c−1} and k_c shows (d the degree of the model's difference
        operator, 1 when it has none); an empty sequence draws a legend entry
        only.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure). Point t shows ‖(Dk)_t‖, where
        (Dk)_t = Σ_j c_j k_{t+j} involves k_t … k_{t+d}; for order 1 a jump
        between k_{c−1} and k_c shows at t = c − 1. ``ax.lines[0]`` is the
        activation, the change-point lines follow it.
    """
    if not callable(getattr(model, "activation", None)):
        raise TypeError(f"model: expected an object with an activation() method such as an "
                        f"LTVModel, received {type(model).__name__}")
    marks = None
    if changepoints is not None:
        marks = _validate.as_float_array(changepoints, "changepoints").ravel()
        if np.any(marks != np.round(marks)):
            raise ValueError(f"changepoints: expected integers, received {marks.tolist()}")
    act = np.asarray(model.activation(), dtype=float)
    if ax is None:
        ax = _new_axes((7.0, 2.8))
    ax.plot(np.arange(act.shape[0]), act, color=ESTIMATE_COLOR, linewidth=1.2,
            label=r"$\|(Dk)_t\|$")
    if marks is not None:
        coeffs = getattr(model, "coeffs", None)
        degree = 1 if coeffs is None else max(len(np.atleast_1d(coeffs)) - 1, 1)
        shift = (degree + 1) // 2
        for i, c in enumerate(marks.astype(int)):
            ax.axvline(c - shift, color="C3", linestyle="--", linewidth=1.0,
                       label="change points" if i == 0 else None)
        found = ", ".join(str(int(c)) for c in marks) if marks.size else "none"
        if not marks.size:
            ax.plot([], [], color="C3", linestyle="--", linewidth=1.0, label="change points")
        ax.legend(fontsize="small", loc="upper right", title=f"detected: {found}",
                  title_fontsize="small")
    ax.set_xlabel("t")
    ax.set_ylabel(r"$\|(Dk)_t\|$")
    ax.set_title("Activation")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    return ax


def plot_eigenvalues(model: Any, ax: "Axes | None" = None) -> "Axes":
    """Plot the magnitudes of the eigenvalues of A_t over time.

    Curve i is the i-th largest |λ(A_t)| at each t; the dotted line marks the
    frozen-time stability limit |λ| = 1.

    Parameters
    ----------
    model : LTVModel
        Any object with ``A`` (N, n, n).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure).
    """
    A = _validate.dynamics_matrices(model)
    mag = np.sort(np.abs(np.linalg.eigvals(A)), axis=1)[:, ::-1]  # (N, n), largest first
    if ax is None:
        ax = _new_axes((7.0, 2.8))
    t = np.arange(A.shape[0])
    for i in range(mag.shape[1]):
        ax.plot(t, mag[:, i], linewidth=1.2, label=rf"$|\lambda_{{{i + 1}}}(A_t)|$")
    ax.axhline(1.0, color="black", linestyle=":", linewidth=1.0, label=r"$|\lambda| = 1$")
    ax.set_xlabel("t")
    ax.set_ylabel(r"$|\lambda(A_t)|$")
    ax.set_title("Eigenvalue magnitudes of $A_t$")
    ax.set_ylim(bottom=0, top=max(1.1, float(mag.max(initial=0.0)) * 1.05))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    return ax


def plot_root_spectrogram(model: Any, fs: float, *, ax: "Axes | None" = None) -> "Axes":
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
        ``sample_index`` (N,).
    fs : float
        Sampling frequency (Hz); the time axis is ``sample_index / fs`` seconds.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure); the y axis spans 0 … fs/2.
    """
    if not callable(getattr(model, "root_spectrogram", None)) or not hasattr(
        model, "sample_index"
    ):
        raise TypeError(f"model: expected an AR/ARX model with root_spectrogram() and "
                        f"sample_index, received {type(model).__name__}")
    fs = _validate.positive_scalar(fs, "fs")
    freq = np.asarray(model.root_spectrogram(fs), dtype=float)
    time = np.asarray(model.sample_index, dtype=float) / fs
    if ax is None:
        ax = _new_axes((7.0, 3.2))
    for i in range(freq.shape[1]):
        ax.plot(time, freq[:, i], linestyle="none", marker=".", markersize=1.5,
                color=ESTIMATE_COLOR, label="pole frequencies" if i == 0 else None)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("frequency (Hz)")
    ax.set_title("Root spectrogram")
    ax.set_ylim(0, fs / 2)
    ax.grid(True, alpha=0.3)
    return ax


def plot_poles(model: Any, ax: "Axes | None" = None) -> "Axes":
    """Plot the eigenvalues of A_t in the complex plane with the unit circle.

    Every eigenvalue of every A_t is one dot, coloured by t, so a time-varying
    model shows its eigenvalues moving; outside the unit circle A_t is
    unstable at frozen time. :func:`plot_eigenvalues` shows the magnitudes
    over time instead.

    Parameters
    ----------
    model : LTVModel
        Any object with ``A`` (N, n, n).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure (with a
        colour bar for t).

    Returns
    -------
    matplotlib.axes.Axes
        The axes; ``ax.lines[0]`` is the unit circle and ``ax.collections[0]``
        the eigenvalues (N·n points), equal aspect ratio.
    """
    A = _validate.dynamics_matrices(model)
    new = ax is None
    if ax is None:
        ax = _new_axes((4.6, 4.0))
    eig = np.linalg.eigvals(A)  # (N, n)
    N, n = eig.shape
    phase = np.linspace(0.0, 2 * np.pi, 361)
    ax.plot(np.cos(phase), np.sin(phase), color="black", linestyle=":", linewidth=1.0,
            label="unit circle")
    times = np.repeat(np.arange(N), n)
    points = ax.scatter(eig.real.ravel(), eig.imag.ravel(), c=times, cmap="viridis", s=6,
                        label=r"$\lambda(A_t)$")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("Re λ")
    ax.set_ylabel("Im λ")
    ax.set_title("Eigenvalues of $A_t$")
    ax.grid(True, alpha=0.3)
    if new:
        ax.figure.colorbar(points, ax=ax, label="t")
    return ax


def plot_spectrogram(y: Any, fs: float, *, ax: "Axes | None" = None, nperseg: int = 256,
                     dynamic_range: float = 80.0) -> "Axes":
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

    arr = _validate.as_float_array(y, "y")
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim != 1 or arr.shape[0] < 8:
        raise ValueError(f"y: expected a 1-d signal of at least 8 samples, received shape "
                         f"{arr.shape}")
    fs = _validate.positive_scalar(fs, "fs")
    nperseg = min(_validate.integer(nperseg, "nperseg", minimum=8), arr.shape[0])
    dynamic_range = _validate.positive_scalar(dynamic_range, "dynamic_range")
    freq, time, power = spectrogram(arr, fs=fs, nperseg=nperseg, noverlap=(3 * nperseg) // 4)
    power_db = 10 * np.log10(power + 1e-300)
    top = float(power_db.max())
    if ax is None:
        ax = _new_axes((7.0, 3.2))
    ax.pcolormesh(time, freq, power_db, cmap="Greys", shading="auto",
                  vmin=top - dynamic_range, vmax=top)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("frequency (Hz)")
    ax.set_title("Spectrogram")
    return ax


def plot_simulation(data: Any, simulation: Any, *, start: int = 0, names: Any = None,
                    label: str = "simulation", fig: "Figure | None" = None) -> "Figure":
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
    x = _validate.as_float_array(data, "data")
    sim = _validate.as_float_array(simulation, "simulation")
    x = x[:, None] if x.ndim == 1 else x
    sim = sim[:, None] if sim.ndim == 1 else sim
    if x.ndim != 2 or x.shape[0] == 0:
        raise ValueError(f"data: expected shape (T, n) or (T,), received {x.shape}")
    T, n = x.shape
    start = _validate.integer(start, "start", minimum=0)
    if sim.ndim != 2 or sim.shape[1] != n:
        raise ValueError(f"simulation: expected shape (S, {n}) (one column per column of "
                         f"data), received {sim.shape}")
    S = sim.shape[0]
    if start + S > T:
        raise ValueError(f"simulation: rows start .. start + S = {start} .. {start + S} do not "
                         f"fit in the T = {T} rows of data")
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
        fig = _new_figure((8.0, min(1.9 * n + 0.6, 14.0)))
    else:
        fig.clear()
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    t_data = np.arange(T)
    t_sim = start + np.arange(S)
    with np.errstate(over="ignore", invalid="ignore"):
        err = sim - x[start:start + S]
        rms = np.sqrt(np.mean(err**2, axis=0)) if S else np.full(n, np.nan)
    for i, ax in enumerate(axes):
        ax.plot(t_data, x[:, i], color="black", linewidth=1.0, label="data")
        ax.plot(t_sim, sim[:, i], color=ESTIMATE_COLOR, linestyle="--", linewidth=1.2,
                label=label)
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


def plot_lambda_selection(selection: Any, ax: "Axes | None" = None) -> "Axes":
    """Plot a λ-selection curve: the criterion against λ, or the L-curve, the choice marked.

    Parameters
    ----------
    selection : LambdaSelection
        From :func:`ltvmodels.select_lambda` or
        :func:`ltvmodels.select_lambda_regression`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        See :meth:`ltvmodels.LambdaSelection.plot`.
    """
    from .selection import LambdaSelection

    if not isinstance(selection, LambdaSelection):
        raise TypeError(f"selection: expected a LambdaSelection (from select_lambda), received "
                        f"{type(selection).__name__}")
    return selection.plot(ax=ax)


def plot_model(model: Any, truth: Any = None, *, changepoints: Any = None,
               fig: "Figure | None" = None) -> "Figure":
    """Overview of a state-space model: coefficients, activation, eigenvalue magnitudes.

    The top part is :func:`plot_coefficients` (±2σ bands where the model has
    covariances, the truth dashed if given); below it
    :func:`plot_activation` with the change points marked and
    :func:`plot_eigenvalues` with the line |λ| = 1.

    Parameters
    ----------
    model : LTVModel
    truth : optional
        As in :func:`plot_coefficients`.
    changepoints : array_like of int, optional
        Change points to mark on the activation (default: ``model.changepoints``
        for models whose coefficients are piecewise constant by construction
        (norm "piecewise", "l0", "lti"), otherwise
        :func:`ltvmodels.find_changepoints` of the model).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.subfigs[0]`` holds the coefficient axes, ``fig.subfigs[1]`` the
        activation and eigenvalue axes.
    """
    theta = _model_theta(model)
    _, n, p = theta.shape
    if changepoints is None:
        from .changepoints import find_changepoints

        if getattr(model, "norm", None) in ("piecewise", "l0", "lti"):
            changepoints = np.asarray(model.changepoints)
        else:
            changepoints = find_changepoints(model)
    if fig is None:
        fig = _new_figure((min(2.6 * p + 0.6, 18.0), min(1.9 * n + 0.5, 14.0) + 2.8))
    else:
        fig.clear()
    top, bottom = fig.subfigures(2, 1, height_ratios=[min(1.9 * n + 0.5, 14.0), 2.8])
    plot_coefficients(model, truth=truth, fig=top)
    ax_act, ax_eig = bottom.subplots(1, 2)
    plot_activation(model, ax=ax_act, changepoints=changepoints)
    plot_eigenvalues(model, ax=ax_eig)
    return fig
