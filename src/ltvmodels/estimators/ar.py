"""Time-varying AR and ARX models: the front-ends and their regressors.

An ARX model with time-varying coefficients (VARX for vector y)

    y[t] = Σ_{i=1}^{na} A_{t,i} y[t−i] + Σ_{j=1}^{nb} B_{t,j} u[t−nk−j+1] + c_t + e[t],

y[t] ∈ R^n, u[t] ∈ R^m, is the regression y_t = Θ_t φ_t + e_t (ARCHITECTURE.md) with

    φ_t = [y[t−1]; …; y[t−na]; u[t−nk]; …; u[t−nk−nb+1]; 1],
    Θ_t = [A_{t,1} … A_{t,na}  B_{t,1} … B_{t,nb}  c_t]      (n × p),

p = n·na + m·nb (+ 1 with the constant term c_t). The rows of Θ_t share φ_t,
so every norm ("sq", "group", "l1") is solved by the same solvers as
:func:`ltvmodels.fit`; the regression starts at the first sample whose lags
all exist, t = L = max(na, nk + nb − 1), and has N = T − L rows: model index
j describes y[L + j] (``model.sample_index``).

* :func:`fit_ar`, :func:`fit_arx` — identify the model (:class:`ARModel`,
  :class:`ARXModel`);
* :func:`ar_regressors`, :func:`arx_regressors` — the (y, φ) pair, e.g. for
  :func:`ltvmodels.segment_regression` (exact L0 segmentation) or
  :func:`ltvmodels.fit_regression`;
* the models (:class:`~ltvmodels.ARXModel`, with ``root_spectrogram``: the
  frequencies of the poles of 1/A_t(z), A_t(z) = I − Σ_i A_{t,i} z^{−i}, over
  time) are in :mod:`ltvmodels.results.arx`.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..core.lags import lag_length, lag_regressor_names, lagged_regressors
from ..core.problem import weighted_problem
from ..errors import ModelStructureWarning, warn
from ..results.arx import ARModel, ARXModel
from ..results.description import DataDescription, DataTail
from ..validation import arrays, options
from ..validation.options import Loss, Norm, PriorMode
from ..validation.time import TimeGrid
from .recordings import time_grid_of
from .regression import fit_problem
from .spec import FitSpec

__all__ = ["ar_regressors", "arx_regressors", "fit_ar", "fit_arx"]


def _structure_text(na: int, nb: int, nk: int) -> str:
    return f"na = {na}" if nb == 0 else f"na = {na}, nb = {nb}, nk = {nk}"


def arx_regressors(
    y: ArrayLike, u: ArrayLike, na: int, nb: int, nk: int = 1, *, constant: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The regression (y_t, φ_t) of a (V)ARX model.

    Parameters
    ----------
    y : array_like, shape (T, n) or (T,)
        Outputs, time on axis 0. NaN marks a missing sample: every row that
        holds it (as output or lag) has NaN, which the estimators leave out.
    u : array_like, shape (T, m) or (T,)
        Inputs.
    na : int >= 0
        Number of output lags.
    nb : int >= 1
        Number of input lags.
    nk : int >= 0
        Input delay: the newest input in φ_t is u[t − nk].
    constant : bool
        Append a constant regressor 1 (a time-varying offset c_t).

    Returns
    -------
    y_out : ndarray, shape (N, n)
        y[L:], N = T − L, L = max(na, nk + nb − 1).
    phi : ndarray, shape (N, p)
        Rows φ_t = [y[t−1]; …; y[t−na]; u[t−nk]; …; u[t−nk−nb+1]; 1],
        p = n·na + m·nb (+ 1).

    Examples
    --------
    Exact L0 segmentation of an ARX model (the paper's problem with a known number of changes):

    >>> import numpy as np, ltvmodels as ltv
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(300); y = np.zeros(300)
    >>> for t in range(1, 300):
    ...     a = 0.9 if t < 150 else 0.3
    ...     y[t] = a * y[t - 1] + u[t - 1] + 0.01 * rng.standard_normal()
    >>> y_out, phi = ltv.arx_regressors(y, u, na=1, nb=1)
    >>> ltv.segment_regression(y_out, phi, n_changes=1).changepoints.tolist()
    [149]
    """
    na, nb, nk = options.lag_orders(na, nb, nk, min_na=0, min_nb=1)
    constant = options.flag(constant, "constant")
    y, u = arrays.lagged_series(
        y, u, lag_length(na, nb, nk), _structure_text(na, nb, nk), require_inputs=True
    )
    return lagged_regressors(y, u, na, nb, nk, constant)


def ar_regressors(
    y: ArrayLike, na: int, *, constant: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The regression (y_t, φ_t) of a (V)AR(na) model: y[na:] and [y[t−1]; …; y[t−na] (; 1)].

    Parameters
    ----------
    y : array_like, shape (T, n) or (T,)
        The series, time on axis 0.
    na : int >= 1
        Model order.
    constant : bool
        Append a constant regressor 1.

    Returns
    -------
    y_out : ndarray, shape (T − na, n)
    phi : ndarray, shape (T − na, n·na (+ 1))
    """
    na, _, _ = options.lag_orders(na, 0, 1, min_na=1, min_nb=0)
    constant = options.flag(constant, "constant")
    y, u = arrays.lagged_series(y, None, na, _structure_text(na, 0, 1))
    return lagged_regressors(y, u, na, 0, 1, constant)


# -- fitting ---------------------------------------------------------------------------


def fit_arx(
    y: ArrayLike,
    u: ArrayLike,
    na: int,
    nb: int,
    nk: int = 1,
    *,
    lam: float | ArrayLike | Literal["auto"],
    norm: Norm = "sq",
    order: int | ArrayLike = 1,
    constant: bool = False,
    prior: Any = None,
    prior_mode: PriorMode = "exact",
    noise_var: float | ArrayLike | None = None,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
    weights: ArrayLike | None = None,
    loss: Loss = "squared",
    huber_delta: float | ArrayLike | None = None,
    refine: bool = False,
    progress: Callable[[int, int], None] | None = None,
    regular: bool = True,
) -> ARXModel:
    r"""Identify a time-varying (V)ARX model.

    .. math::

        y_t = \sum_{i=1}^{n_a} A_{t,i}\, y_{t-i} + \sum_{j=1}^{n_b} B_{t,j}\, u_{t-n_k-j+1}
        \; (+\, c_t) + e_t,

    the regression of :func:`arx_regressors` solved by
    :func:`ltvmodels.fit_regression`. With ``norm="sq"`` the exact minimizer of

    .. math::

        \sum_{t=L}^{T-1} \lVert y_t - \Theta_t \varphi_t \rVert_2^2
        + \lambda^2 \sum_t \lVert (Dk)_t \rVert_2^2,
        \qquad k_t = \operatorname{vec}(\Theta_t^\top),

    with :math:`\Theta_t = [A_{t,1} \cdots A_{t,n_a} \; B_{t,1} \cdots B_{t,n_b} \; (c_t)]`,
    :math:`\varphi_t` the stacked lags and :math:`L` the first sample with all
    lags available, and with ``norm="group"`` / ``"l1"`` the penalty
    :math:`\lambda \sum_t \lVert (Dk)_t \rVert_2` or
    :math:`\lambda \sum_t \lVert (Dk)_t \rVert_1` (piecewise constant or linear
    coefficients), as in :func:`ltvmodels.fit`.

    Parameters
    ----------
    y : array_like, shape (T, n), (T,) or (R, T, n)
        Outputs, time on axis 0 (lists and pandas objects are accepted); R
        time-aligned experiments share the model; NaN marks a missing sample
        (a row enters the data term only if y[t] and all its lags are observed).
    u : array_like, shape (T, m), (T,) or (R, T, m)
        Inputs.
    na : int >= 0
        Number of output lags (0: a time-varying FIR model).
    nb : int >= 1
        Number of input lags.
    nk : int >= 0, default 1
        Input delay (0: direct feedthrough of u[t]).
    lam, norm, order, prior, prior_mode, noise_var, compute_cov, max_iter, tol, loss, huber_delta
        As in :func:`ltvmodels.fit`, with K = n·p parameters per time step,
        p = n·na + m·nb (+ 1).
    refine : bool
        The two-step refinement, as in :func:`ltvmodels.fit`: refit with the
        coefficients constant (order 1) or linear and continuous (order 2)
        between the change points of this fit (``info["first_step"]``
        summarizes the first fit).
    progress : callable, optional
        Called as ``progress(done, total)`` while ``lam="auto"`` chooses λ (see
        :func:`ltvmodels.select_lambda`).
    weights : array_like, shape (T − L,) or (R, T − L), optional
        Weights >= 0 of the regression rows (model time steps).
    constant : bool, default False
        Include a time-varying constant term c_t.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    ARXModel
        N = T − L time steps, L = max(na, nk + nb − 1); ``a``, ``b``, ``c``,
        ``predict``, ``simulate``, ``root_spectrogram``, and everything of a
        :class:`~ltvmodels.RegressionModel` (``theta``, ``cov``, ``loglik``, ...).

    Raises
    ------
    ValueError, TypeError
        Invalid input: na < 0, nb < 1, nk < 0, a series not longer than the
        lag structure, inputs of the wrong length, too few samples for the
        number of parameters, and the errors of :func:`ltvmodels.fit`.
    SingularProblemError
        The data do not identify the model (e.g. an input that is not exciting).
    """
    spec = FitSpec.from_arguments(locals())  # every option, checked once
    na, nb, nk = options.lag_orders(na, nb, nk, min_na=0, min_nb=1)
    constant = options.flag(constant, "constant")
    L = lag_length(na, nb, nk)
    y_data, u_data = y, arrays.aligned(y, u, "y", "u")
    y, u = arrays.lagged_recordings(
        y_data, u_data, L, _structure_text(na, nb, nk), require_inputs=True
    )
    y, u, weights, grid = _on_time_grid(y_data, y, u, weights, L, regular)
    if not constant:
        _warn_if_offset(y)
    n, m = y.shape[2], u.shape[2]
    factory = partial(ARXModel, n_outputs=n, n_inputs=m, na=na, nb=nb, nk=nk, constant=constant)
    model = _fit_lagged(
        y,
        u,
        na,
        nb,
        nk,
        constant,
        factory,
        spec,
        weights,
    )
    return _describe(model, y_data, u_data, y, u, grid)


def fit_ar(
    y: ArrayLike,
    na: int,
    *,
    lam: float | ArrayLike | Literal["auto"],
    norm: Norm = "sq",
    order: int | ArrayLike = 1,
    constant: bool = False,
    prior: Any = None,
    prior_mode: PriorMode = "exact",
    noise_var: float | ArrayLike | None = None,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
    weights: ArrayLike | None = None,
    loss: Loss = "squared",
    huber_delta: float | ArrayLike | None = None,
    refine: bool = False,
    progress: Callable[[int, int], None] | None = None,
    regular: bool = True,
) -> ARModel:
    r"""Identify a time-varying (V)AR(na) model y[t] = Σ_i A_{t,i} y[t−i] (+ c_t) + e[t].

    The regression of :func:`ar_regressors`, solved as in :func:`fit_arx`:
    the minimizer of

    .. math::

        \sum_{t=n_a}^{T-1}
        \Bigl\lVert y_t - \sum_{i=1}^{n_a} A_{t,i}\, y_{t-i} \; (-\, c_t) \Bigr\rVert_2^2 + R(Dk),

    with :math:`R(Dk) = \lambda^2 \sum_t \lVert (Dk)_t \rVert_2^2` for ``norm="sq"``,
    :math:`\lambda \sum_t \lVert (Dk)_t \rVert_2` for ``"group"`` and
    :math:`\lambda \sum_t \lVert (Dk)_t \rVert_1` for ``"l1"``. For a scalar series
    :meth:`ARModel.root_spectrogram` gives the resonance frequencies over time.

    Parameters
    ----------
    y : array_like, shape (T, n), (T,) or (R, T, n)
        The series, time on axis 0; R time-aligned series share the model.
        NaN marks a missing sample: a row enters the data term only if y[t]
        and all its lags are observed.
    na : int >= 1
        Model order.
    lam, norm, order, prior, prior_mode, noise_var, compute_cov, max_iter, tol, loss, huber_delta
        As in :func:`ltvmodels.fit`, with K = n·p, p = n·na (+ 1).
    refine : bool
        The two-step refinement, as in :func:`ltvmodels.fit`: refit with the
        coefficients constant (order 1) or linear and continuous (order 2)
        between the change points of this fit (``info["first_step"]``
        summarizes the first fit).
    progress : callable, optional
        Called as ``progress(done, total)`` while ``lam="auto"`` chooses λ (see
        :func:`ltvmodels.select_lambda`).
    weights : array_like, shape (T − na,) or (R, T − na), optional
        Weights >= 0 of the regression rows (model time steps).
    constant : bool, default False
        Include a time-varying constant term c_t.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    ARModel
        N = T − na time steps (model index j describes y[na + j]).

    Raises
    ------
    ValueError, TypeError
        na < 1, T <= na, too few samples for the number of parameters, and the
        errors of :func:`ltvmodels.fit`.

    Examples
    --------
    >>> import numpy as np, ltvmodels as ltv
    >>> fs, T = 1000.0, 2000
    >>> t = np.arange(T) / fs
    >>> rng = np.random.default_rng(0)
    >>> y = np.sin(2 * np.pi * 100 * t) + 0.01 * rng.standard_normal(T)
    >>> model = ltv.fit_ar(y, na=2, lam=100.0)
    >>> model.root_spectrogram(fs).shape
    (1998, 1)
    >>> bool(abs(np.median(model.root_spectrogram(fs)) - 100.0) < 1.0)
    True
    """
    spec = FitSpec.from_arguments(locals())  # every option, checked once
    na, _, _ = options.lag_orders(na, 0, 1, min_na=1, min_nb=0)
    constant = options.flag(constant, "constant")
    y_data = y
    y, u = arrays.lagged_recordings(y, None, na, _structure_text(na, 0, 1))
    y, u, weights, grid = _on_time_grid(y_data, y, u, weights, na, regular)
    if not constant:
        _warn_if_offset(y)
    factory = partial(ARModel, n_outputs=y.shape[2], na=na, constant=constant)
    model = _fit_lagged(
        y,
        u,
        na,
        0,
        1,
        constant,
        factory,
        spec,
        weights,
    )
    return _describe(model, y_data, None, y, u, grid)


def _on_time_grid(
    y_data: Any, y: np.ndarray, u: np.ndarray, weights: Any, lag: int, regular: Any
) -> tuple[np.ndarray, np.ndarray, Any, TimeGrid | None]:
    """The validated series y, u (R, T, ·) and the weights of their regression rows placed
    on the regular grid of y's time index (missing stamps become missing samples), and
    that grid (None without a time index; ``regular=False``: the rows as they are)."""
    grid = time_grid_of(y_data, "y", regular)
    if grid is None or grid.positions is None:
        return y, u, weights, grid
    w = arrays.row_weights(weights, y.shape[0], y.shape[1] - lag)
    return grid.spread(y), grid.spread(u), grid.spread_rows(w, lag), grid


def _describe(
    model: Any,
    y_data: Any,
    u_data: Any,
    y: np.ndarray,
    u: np.ndarray,
    grid: TimeGrid | None,
) -> Any:
    """``model`` with the description of its data: the column names of a pandas y (and
    u), the time grid of y (one series), the series, the regression rows left out and the
    end of the data that its forecast continues (validated y (R, T, n), u (R, T, m))."""
    names = {
        "output": arrays.column_names(y_data, y.shape[2], "y"),
        "input": None if u_data is None else arrays.column_names(u_data, model.n_inputs, "u"),
    }
    time = None if grid is None else grid.time
    # the model of this call (no one else holds it): described in place
    model.data = DataDescription.of(
        names,
        time,
        n_trajectories=y.shape[0],
        n_missing=model.n_missing,
        time_name=arrays.time_name(y_data),
        tail=DataTail.of(y, u, model.tail_lengths),
    )
    return model


# A mean farther from 0 than this many standard deviations is clearly not zero (a
# zero-mean stationary series almost never strays that far on average).
OFFSET_IN_STDS = 1.0
OFFSET_MIN_SAMPLES = 20


def _warn_if_offset(y: np.ndarray) -> None:
    """Warn when a series fitted without an intercept has a clearly non-zero mean.

    Without c_t the model y[t] = Σ A_i y[t−i] pulls the level towards 0, and
    the AR coefficients absorb it (near-unit roots, a wrong spectrum).
    """
    values = y.reshape(-1, y.shape[-1])
    for i in range(values.shape[1]):
        column = values[:, i][np.isfinite(values[:, i])]
        if column.size < OFFSET_MIN_SAMPLES:  # too few to tell a level from chance
            continue
        mean, std = float(np.mean(column)), float(np.std(column))
        if abs(mean) > OFFSET_IN_STDS * std:
            where = f"output {i} of y" if values.shape[1] > 1 else "y"
            warn(
                f"{where} has mean {mean:.4g}, {abs(mean) / max(std, 1e-300):.1f} standard "
                "deviations from 0, but the model has no intercept, so the coefficients must "
                "absorb the level; pass constant=True (or subtract the mean)",
                ModelStructureWarning,
            )


def _fit_lagged(
    y: np.ndarray,
    u: np.ndarray,
    na: int,
    nb: int,
    nk: int,
    constant: bool,
    factory: Any,
    spec: FitSpec,
    weights: Any,
) -> ARXModel:
    """Build the regression of validated AR/ARX data (R, T, ·) and run the shared core.

    A row enters the data term only if y[t] and all its lags are observed.
    """
    y_out, phi = lagged_regressors(y, u, na, nb, nk, constant)
    R, N = y_out.shape[:2]
    coeffs = options.difference_coefficients(spec.order, max_degree=N)
    w = arrays.row_weights(weights, R, N)
    L = lag_length(na, nb, nk)
    problem = weighted_problem(y_out, phi, coeffs, w)
    model = fit_problem(
        problem,
        spec,
        factory=factory,
        regressor_names=lag_regressor_names(y.shape[2], u.shape[2], na, nb, nk, constant),
        data_name="y",
        rows_note=f" (T = {y.shape[1]} samples, the first {L} only as lags)",
    )
    # the rows left out (the front-end adds the names and time)
    model.data = DataDescription.of(None, n_missing=problem.N * problem.q - problem.n_observed)
    return model
