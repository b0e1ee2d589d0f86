"""Figures of a state-space model's coefficients: values, activation, eigenvalues, overview."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..validation import arrays
from .figure import ESTIMATE_COLOR, new_axes, new_figure
from .timeaxis import step_axis

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["plot_coefficients", "plot_activation", "plot_eigenvalues", "plot_poles", "plot_model"]

MODELS_WITH_CHANGEPOINTS = ("group", "l1", "piecewise", "l0", "lti")
"""Norms of the models whose ``changepoints`` were found by the fit itself."""

CHANGE_COLOR = "C3"
"""Colour of the change-point markers."""


def _own_changepoints(model: Any) -> np.ndarray | None:
    """The change points the fit of ``model`` found itself (sparse norms, and models
    piecewise constant by construction); None for the others (a squared-norm fit)."""
    if getattr(model, "norm", None) in MODELS_WITH_CHANGEPOINTS:
        return np.asarray(model.changepoints)
    return None


def _changepoint_steps(changepoints: ArrayLike, N: int) -> np.ndarray:
    """Change points as step indices 0 … N − 1 (a new array), or an error naming them."""
    marks = arrays.as_float_array(changepoints, "changepoints").ravel()
    if np.any(marks != np.round(marks)) or np.any(marks < 0) or np.any(marks > N - 1):
        raise ValueError(
            f"changepoints: expected step indices c (integers 0 … {N - 1}, as "
            f"model.changepoints), received {marks.tolist()}"
        )
    return marks.astype(int)


def _mark_changes(ax: Axes, positions: np.ndarray) -> None:
    """Dashed vertical lines at the change points' ``positions`` on the time axis (the
    first labelled for the legend)."""
    for i, position in enumerate(positions):
        ax.axvline(
            position,
            color=CHANGE_COLOR,
            linestyle="--",
            linewidth=1.0,
            label="change points" if i == 0 else None,
        )


def _model_theta(model: Any) -> tuple[np.ndarray, list[list[str]]]:
    """(N, n, p) coefficients of ``model`` and their panel titles (n lists of p).

    A state-space model ([A_t B_t]: "A[x0,x1]", "B[x0,u0]") or any regression
    model with ``theta`` (N, n, p) (titles from ``coefficient_names()``,
    "output:regressor").
    """
    if hasattr(model, "A") and hasattr(model, "B"):
        A = np.asarray(model.A, dtype=float)
        B = np.asarray(model.B, dtype=float)
        if A.ndim != 3 or A.shape[1] != A.shape[2]:
            raise ValueError(f"model.A: expected shape (N, n, n), received {A.shape}")
        if B.ndim != 3 or B.shape[:2] != A.shape[:2]:
            raise ValueError(f"model.B: expected shape {A.shape[:2] + ('m',)}, received {B.shape}")
        n, m = A.shape[1], B.shape[2]
        states = list(getattr(model, "state_names", [str(i) for i in range(n)]))
        inputs = list(getattr(model, "input_names", [str(j) for j in range(m)]))
        names = [
            [f"A[{states[i]},{states[j]}]" for j in range(n)]
            + [f"B[{states[i]},{inputs[j]}]" for j in range(m)]
            for i in range(n)
        ]
        return np.concatenate([A, B], axis=2), names
    if not hasattr(model, "theta"):
        raise TypeError(
            f"model: expected a model with coefficients (attributes A and B, or theta "
            f"(N, n, p)) such as an LTVModel or a RegressionModel, received "
            f"{type(model).__name__}"
        )
    theta = np.asarray(model.theta, dtype=float)
    if theta.ndim != 3:
        raise ValueError(f"model.theta: expected shape (N, n, p), received {theta.shape}")
    N, n, p = theta.shape
    flat = (
        list(model.coefficient_names())
        if callable(getattr(model, "coefficient_names", None))
        else [f"theta[{i},{j}]" for i in range(n) for j in range(p)]
    )
    return theta, [flat[i * p : (i + 1) * p] for i in range(n)]


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
    arr = arrays.as_float_array(truth, "truth")
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


def plot_coefficients(
    model: Any,
    truth: Any = None,
    *,
    bands: bool = True,
    changepoints: ArrayLike | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Plot every coefficient of [A_t B_t] (or of Θ_t) over time, one subplot each.

    The time axis is the data's (:mod:`ltvmodels.plotting.timeaxis`): dates on a
    date axis or numbers, labelled with the time axis' name, or the sample index
    ("sample") without one. Θ_t is drawn at the sample it produces (x[t + 1] of a
    state-space model, y[t] of a regression, y[lag + t] of an AR/ARX model), so a
    change shows where ``model.changepoint_times`` marks it. (For a state-space
    model that is one sample after ``model.step_times``, the time of x[t] that
    indexes ``model.to_frame()``.)

    Parameters
    ----------
    model : LTVModel, RegressionModel, ARModel, ARXModel
        Identified model: any object with ``A`` (N, n, n) and ``B`` (N, n, m),
        or with ``theta`` (N, n, p) (and ``coefficient_names()`` for the
        titles), and optionally ``std()`` → (N, K).
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
    changepoints : array_like of int, optional
        Change points c (step indices, as ``model.changepoints``) to mark with
        dashed red vertical lines at the sample each first produces (for the
        model's own: ``model.changepoint_times``). Default: those the model
        found itself (norms "group", "l1", "piecewise", "l0", "lti"); none for
        a squared-norm fit. An empty sequence marks none.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new
        :class:`~matplotlib.figure.Figure` (no pyplot, no display needed).

    Returns
    -------
    matplotlib.figure.Figure
        With n × (n + m) axes in row-major order, titled ``"A[x0,x1]"`` /
        ``"B[x0,u0]"`` by the model's state and input names (a regression:
        n × p axes titled "output:regressor"); in each, the estimate is
        ``ax.lines[0]`` (x data: the times of the N steps), the truth
        ``ax.lines[1]`` and the change points follow.

    Raises
    ------
    TypeError, ValueError
        If ``model`` lacks ``A``/``B`` or ``truth`` has the wrong shape.
    """
    if not isinstance(bands, bool):
        raise TypeError(f"bands: expected True or False, received {bands!r}")
    theta, names = _model_theta(model)
    N, n, p = theta.shape
    truth_theta = None if truth is None else _truth_theta(truth, N, n, p)
    if changepoints is None:
        changepoints = _own_changepoints(model)
    marks = None if changepoints is None else _changepoint_steps(changepoints, N)
    std = None
    if bands and callable(getattr(model, "std", None)):
        std = model.std()
        if std is not None:
            std = np.asarray(std, dtype=float)
            if getattr(model, "constant", False) and std.shape == (N, n * (p + 1)):
                # a model with intercepts c_t: the panels show [A_t B_t] only
                std = std.reshape(N, n, p + 1)[:, :, :p].reshape(N, n * p)
            if std.shape != (N, n * p):
                raise ValueError(f"model.std(): expected shape {(N, n * p)}, received {std.shape}")
    if fig is None:
        fig = new_figure((min(2.6 * p + 0.6, 18.0), min(1.9 * n + 0.5, 14.0)))
    else:
        fig.clear()
    axes = fig.subplots(n, p, sharex=True, squeeze=False)
    axis = step_axis(model, N)
    t = axis.values
    for i in range(n):
        for j in range(p):
            ax = axes[i, j]
            est = theta[:, i, j]
            if std is not None:
                s = std[:, i * p + j]
                ax.fill_between(
                    t,
                    est - 2 * s,
                    est + 2 * s,
                    color=ESTIMATE_COLOR,
                    alpha=0.25,
                    linewidth=0,
                    label="±2σ",
                )
            ax.plot(t, est, color=ESTIMATE_COLOR, linewidth=1.2, label="estimate")
            if truth_theta is not None:
                ax.plot(
                    t,
                    truth_theta[:, i, j],
                    color="black",
                    linestyle="--",
                    linewidth=1.2,
                    label="truth",
                )
            if marks is not None:
                _mark_changes(ax, t[marks])
            ax.set_title(names[i][j])
            ax.grid(True, alpha=0.3)
            if j == 0:
                ax.set_ylabel("coefficient")
            axis.draw_on(ax, label=i == n - 1)
    axes[0, 0].legend(fontsize="small", loc="best")
    return fig


def plot_activation(
    model: Any, ax: Axes | None = None, *, changepoints: ArrayLike | None = None
) -> Axes:
    """Plot the activation ‖(Dk)_t‖ of the model over time.

    Large values mark where the coefficients change (paper Section III); with
    a sparse norm they are the change points. The time axis is the data's, as
    in :func:`plot_coefficients`: point t, which compares k_t … k_{t+d}, is
    drawn where step t + ⌈d/2⌉ is (d the degree of the model's difference
    operator), so that a change between k_{c−1} and k_c peaks at step c, where
    its marker is.

    Parameters
    ----------
    model : LTVModel
        Any object with ``activation()`` → (N − d,) (d the order of the
        difference operator).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.
    changepoints : array_like of int, optional
        Change points c (step indices: e.g. :func:`ltvmodels.find_changepoints`
        of the model, or ``model.changepoints``), drawn as dashed red vertical
        lines at the sample step c produces (``model.changepoint_times`` for the
        model's own), where a change between k_{c−1} and k_c shows (activation
        index t = c − ⌈d/2⌉, d the degree of the model's difference operator, 1
        when it has none); the legend's title lists those times. An empty
        sequence draws a legend entry only.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure). Point t shows ‖(Dk)_t‖, where
        (Dk)_t = Σ_j c_j k_{t+j} involves k_t … k_{t+d}. ``ax.lines[0]`` is the
        activation, the change-point lines follow it.
    """
    if not callable(getattr(model, "activation", None)):
        raise TypeError(
            f"model: expected an object with an activation() method such as an "
            f"LTVModel, received {type(model).__name__}"
        )
    act = np.asarray(model.activation(), dtype=float)
    coeffs = getattr(model, "coeffs", None)
    degree = 1 if coeffs is None else max(len(np.atleast_1d(coeffs)) - 1, 1)
    shift = (degree + 1) // 2
    axis = step_axis(model, act.shape[0] + degree)  # N steps give N − d activations
    marks = None if changepoints is None else _changepoint_steps(changepoints, axis.values.size)
    if ax is None:
        ax = new_axes((7.0, 2.8))
    ax.plot(
        axis.values[shift : shift + act.shape[0]],
        act,
        color=ESTIMATE_COLOR,
        linewidth=1.2,
        label=r"$\|(Dk)_t\|$",
    )
    if marks is not None:
        _mark_changes(ax, axis.values[marks])
        found = ", ".join(axis.text(axis.values[marks])) if marks.size else "none"
        if not marks.size:  # a legend entry only
            ax.plot([], [], color=CHANGE_COLOR, linestyle="--", label="change points")
        ax.legend(
            fontsize="small", loc="upper right", title=f"detected: {found}", title_fontsize="small"
        )
    axis.draw_on(ax)
    ax.set_ylabel(r"$\|(Dk)_t\|$")
    ax.set_title("Activation")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    return ax


def _dynamics_eigenvalues(model: Any) -> tuple[np.ndarray, str, str]:
    """(eigenvalues (N, D), their symbol, their name): of A_t, or an AR/ARX model's poles
    (the eigenvalues of its companion matrix)."""
    if callable(getattr(model, "poles", None)) and not hasattr(model, "A"):
        eig = np.asarray(model.poles())
        if eig.ndim != 2:
            raise ValueError(f"model.poles(): expected shape (N, D), received {eig.shape}")
        return eig, "z_t", "poles of the AR model"
    return np.linalg.eigvals(arrays.dynamics_matrices(model)), "A_t", "eigenvalues of $A_t$"


def plot_eigenvalues(model: Any, ax: Axes | None = None) -> Axes:
    """Plot the magnitudes of the eigenvalues of A_t over time.

    Curve i is the i-th largest abs(λ(A_t)) at each t, on the data's time axis
    as in :func:`plot_coefficients`; the dotted line marks the frozen-time
    stability limit abs(λ) = 1.

    Parameters
    ----------
    model : LTVModel, ARModel, ARXModel
        Any object with ``A`` (N, n, n), or with ``poles()`` → (N, D) (AR/ARX
        models: the magnitudes of their poles).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure).
    """
    eig, symbol, title = _dynamics_eigenvalues(model)
    mag = np.sort(np.abs(eig), axis=1)[:, ::-1]  # (N, n), largest first
    if ax is None:
        ax = new_axes((7.0, 2.8))
    axis = step_axis(model, mag.shape[0])
    for i in range(mag.shape[1]):
        ax.plot(axis.values, mag[:, i], linewidth=1.2, label=rf"$|\lambda_{{{i + 1}}}|$")
    ax.axhline(1.0, color="black", linestyle=":", linewidth=1.0, label=r"$|\lambda| = 1$")
    axis.draw_on(ax)
    ax.set_ylabel(rf"$|\lambda({symbol})|$")
    ax.set_title(f"Magnitudes of the {title}")
    ax.set_ylim(bottom=0, top=max(1.1, float(mag.max(initial=0.0)) * 1.05))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    return ax


def plot_poles(model: Any, ax: Axes | None = None) -> Axes:
    """Plot the eigenvalues of A_t in the complex plane with the unit circle.

    Every eigenvalue of every A_t is one dot, coloured by t, so a time-varying
    model shows its eigenvalues moving; outside the unit circle A_t is
    unstable at frozen time. :func:`plot_eigenvalues` shows the magnitudes
    over time instead.

    Parameters
    ----------
    model : LTVModel, ARModel, ARXModel
        Any object with ``A`` (N, n, n), or with ``poles()`` → (N, D) (AR/ARX
        models: the eigenvalues of the companion matrix of their coefficients).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure (with a
        colour bar for t).

    Returns
    -------
    matplotlib.axes.Axes
        The axes; ``ax.lines[0]`` is the unit circle and ``ax.collections[0]``
        the eigenvalues (N·n points), equal aspect ratio.
    """
    eig, _, title = _dynamics_eigenvalues(model)
    title = title[0].upper() + title[1:]
    new = ax is None
    if ax is None:
        ax = new_axes((4.6, 4.0))
    N, n = eig.shape
    phase = np.linspace(0.0, 2 * np.pi, 361)
    ax.plot(
        np.cos(phase),
        np.sin(phase),
        color="black",
        linestyle=":",
        linewidth=1.0,
        label="unit circle",
    )
    times = np.repeat(np.arange(N), n)
    points = ax.scatter(
        eig.real.ravel(), eig.imag.ravel(), c=times, cmap="viridis", s=6, label=r"$\lambda(A_t)$"
    )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("Re λ")
    ax.set_ylabel("Im λ")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if new:
        ax.figure.colorbar(points, ax=ax, label="t")
    return ax


def plot_model(
    model: Any,
    truth: Any = None,
    *,
    changepoints: ArrayLike | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Overview of a state-space model: coefficients, activation, eigenvalue magnitudes.

    The top part is :func:`plot_coefficients` (±2σ bands where the model has
    covariances, the truth dashed if given); below it
    :func:`plot_activation` with the change points marked and
    :func:`plot_eigenvalues` with the line abs(λ) = 1.

    Parameters
    ----------
    model : LTVModel
        The fitted model.
    truth : optional
        As in :func:`plot_coefficients`.
    changepoints : array_like of int, optional
        Change points to mark on the coefficients and the activation.
        Default: the change points the model found itself
        (``model.changepoints`` for the sparse norms "group" and "l1", and for
        models piecewise constant by construction: "piecewise", "l0", "lti");
        none for a squared-norm fit, whose activation has no sparse peaks:
        pass ``changepoints=ltvmodels.find_changepoints(model)`` to mark the
        detected ones.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; it is cleared first. Default: a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.subfigs[0]`` holds the coefficient axes, ``fig.subfigs[1]`` the
        activation and eigenvalue axes.
    """
    theta, _ = _model_theta(model)
    _, n, p = theta.shape
    if changepoints is None:
        changepoints = _own_changepoints(model)
    if fig is None:
        fig = new_figure((min(2.6 * p + 0.6, 18.0), min(1.9 * n + 0.5, 14.0) + 2.8))
    else:
        fig.clear()
    top, bottom = fig.subfigures(
        2, 1, squeeze=False, height_ratios=[min(1.9 * n + 0.5, 14.0), 2.8]
    )[:, 0]
    plot_coefficients(
        model, truth=truth, changepoints=[] if changepoints is None else changepoints, fig=top
    )
    dynamics = hasattr(model, "A") or callable(getattr(model, "poles", None))
    axes = bottom.subplots(1, 2 if dynamics else 1, squeeze=False)[0]
    plot_activation(model, ax=axes[0], changepoints=changepoints)
    if dynamics:  # a regression has no dynamics to draw
        plot_eigenvalues(model, ax=axes[1])
    return fig
