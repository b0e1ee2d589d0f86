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

__all__ = ["plot_coefficients", "plot_activation", "plot_eigenvalues", "plot_root_spectrogram"]

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


def plot_activation(model: Any, ax: "Axes | None" = None) -> "Axes":
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

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure). Point t shows ‖(Dk)_t‖, where
        (Dk)_t = Σ_j c_j k_{t+j} involves k_t … k_{t+d}; for order 1 a jump
        between k_{c−1} and k_c shows at t = c − 1.
    """
    if not callable(getattr(model, "activation", None)):
        raise TypeError(f"model: expected an object with an activation() method such as an "
                        f"LTVModel, received {type(model).__name__}")
    act = np.asarray(model.activation(), dtype=float)
    if ax is None:
        ax = _new_axes((7.0, 2.8))
    ax.plot(np.arange(act.shape[0]), act, color=ESTIMATE_COLOR, linewidth=1.2)
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
    if not hasattr(model, "A"):
        raise TypeError(f"model: expected an object with attribute A (N, n, n) such as an "
                        f"LTVModel, received {type(model).__name__}")
    A = np.asarray(model.A, dtype=float)
    if A.ndim != 3 or A.shape[1] != A.shape[2]:
        raise ValueError(f"model.A: expected shape (N, n, n), received {A.shape}")
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
