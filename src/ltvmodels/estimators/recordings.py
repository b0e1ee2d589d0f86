"""Recorded data → the regression problem every state-space estimator solves.

One place turns what users record — one or several time-aligned trajectories
(R, T, n), NaN for missing samples, weights per transition, an optional
intercept — into a :class:`~ltvmodels.core.problem.RegressionProblem`:

    x^r[t+1] = A_t x^r[t] + B_t u^r[t] (+ c_t) + v^r_t,   r = 1 … R,

with Θ_t = [A_t B_t (c_t)] shared by the trajectories. A transition enters
the data term only if x[t], u[t] and x[t+1] are all observed; its squared
residual counts ``weights[r, t]`` times. The coefficients of steps without
data are still estimated: the penalty carries them across the gap.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.problem import RegressionProblem, state_space_problem, weighted_problem
from ..errors import DataWarning, warn
from ..results.base import signal_names
from ..results.description import DataDescription, DataTail
from ..validation import arrays, options
from ..validation.time import TimeGrid

__all__ = [
    "StateSpaceData",
    "state_space_data",
    "regression_data",
    "time_grid_of",
    "timed_recordings",
    "regression_problem",
    "require_enough_data",
]


@dataclass(frozen=True)
class StateSpaceData:
    """A validated recording and its regression problem.

    Attributes
    ----------
    problem : RegressionProblem
        y_t = x[t+1], φ_t = [x[t]; u[t] (; 1)], q = R rows per step.
    x, u : ndarray, shapes (R, T, n) and (R, T, m)
        The validated data (NaN = missing).
    weights : ndarray, shape (R, T − 1), or None
    constant : bool
    state_names, input_names : list of str or None
        The column names of pandas inputs (None: the data had none).
    time : ndarray, shape (T,), or None
        The index of a pandas ``x`` (dates as datetime64[ns], numbers, or time
        spans as seconds).
    time_name : str or None
        The name of that index.
    """

    problem: RegressionProblem
    x: np.ndarray
    u: np.ndarray
    weights: np.ndarray | None
    constant: bool
    state_names: list[str] | None = None
    input_names: list[str] | None = None
    time: np.ndarray | None = None
    time_name: str | None = None

    @property
    def n(self) -> int:
        return self.x.shape[2]

    @property
    def m(self) -> int:
        return self.u.shape[2]

    @property
    def inputs(self) -> np.ndarray | None:
        """u, or None for an autonomous system (m = 0), to pass on to another estimator."""
        return self.u if self.m else None

    @property
    def regressor_names(self) -> list[str]:
        """Names of the columns of φ_t: the states' and inputs' names (x0 …, u0 … by
        default), and "1" for the intercept."""
        states = self.state_names or signal_names("x", self.n)
        inputs = self.input_names or signal_names("u", self.m)
        return states + inputs + (["1"] if self.constant else [])

    @property
    def description(self) -> DataDescription:
        """What the data say (a fitted model's ``data``): the column names of pandas
        states and inputs, the index of x (T,), the trajectories and missing transitions."""
        return DataDescription.of(
            {"state": self.state_names, "input": self.input_names if self.m else None},
            self.time,
            n_trajectories=self.x.shape[0],
            n_missing=self.n_missing,
            time_name=self.time_name,
        )

    def describe(self, model: Any) -> Any:
        """``model`` (a new model of this fit, no one else holds it) described in place:
        :attr:`description` becomes its ``data``, with the end of the data that its
        forecast continues (none for several trajectories or a missing last sample): with
        measurement noise, the smoothed states (``model.states``), not the recorded ones."""
        states = getattr(model, "states", None)
        x = self.x if states is None else np.reshape(states, self.x.shape)
        tail = DataTail.of(x, self.u, model.tail_lengths)
        model.data = self.description.with_tail(tail)
        return model

    @property
    def n_missing(self) -> int:
        """Transitions (of all trajectories) left out of the data term."""
        return self.problem.N * self.problem.q - self.problem.n_observed


def state_space_data(
    x: Any,
    u: Any,
    *,
    order: Any = 1,
    weights: Any = None,
    constant: Any = False,
    regular: Any = True,
) -> StateSpaceData:
    """Validate a recording and build its regression problem (see the module docstring).

    Parameters
    ----------
    x : array_like, shape (T, n), (T,), (R, T, n), or a list of R (T, n) arrays
        States; NaN marks a missing sample.
    u : array_like, same layouts with m columns, or None
        Inputs.
    order : int or sequence of float
        The difference operator (see :func:`ltvmodels.fit`).
    weights : array_like, shape (T − 1,) or (R, T − 1), optional
        Weights >= 0 of the transitions' squared residuals.
    constant : bool
        Add an intercept c_t to every state equation.
    regular : bool, default True
        Whether a time index must lie on a regular grid (stamps missing from it
        become missing samples); False: the rows are consecutive samples, their
        (increasing) stamps the time axis (:mod:`ltvmodels.validation.time`).
    """
    x_data, u_data = x, u
    x, u, grid = timed_recordings(x_data, u_data, regular)
    R, T, _ = x.shape
    w = arrays.row_weights(weights, R, T - 1)
    if grid is not None:  # missing stamps of a regular grid become missing samples
        x, u, w = grid.spread(x), grid.spread(u), grid.spread_rows(w, 1)
        T = x.shape[1]
    coeffs = options.difference_coefficients(order, max_degree=T)
    constant = options.flag(constant, "constant")
    problem = state_space_problem(x, u, coeffs, weights=w, constant=constant)
    return StateSpaceData(
        problem,
        x,
        u,
        w,
        constant,
        state_names=arrays.column_names(_first_table(x_data), x.shape[2], "x"),
        input_names=arrays.column_names(_first_table(u_data), u.shape[2], "u"),
        time=None if grid is None else grid.time,
        time_name=arrays.time_name(x_data),
    )


def timed_recordings(
    x: Any, u: Any, regular: Any = True
) -> tuple[np.ndarray, np.ndarray, TimeGrid | None]:
    """:func:`ltvmodels.validation.arrays.recordings` of x and u (matched to x by their
    time stamps), and the regular grid of x's time index (None without one; its
    :meth:`~ltvmodels.validation.time.TimeGrid.spread` puts the rows on it;
    ``regular``: see :func:`state_space_data`)."""
    if _indexed_trajectories(x):
        x, u = _trajectories_on_their_grids(x, u, regular)
    grid = time_grid_of(x, "x", regular)
    x, u = arrays.recordings(x, arrays.aligned(x, u, "x", "u"))
    return x, u, grid


def _first_table(value: Any) -> Any:
    """The first of a list of pandas trajectories (whose columns every one shares, as
    :func:`_trajectories_on_their_grids` checks), where its names are; else ``value``."""
    return value[0] if _indexed_trajectories(value) else value


def _indexed_trajectories(x: Any) -> bool:
    """Whether x is a list of R pandas trajectories (each with its own index)."""
    return isinstance(x, (list, tuple)) and bool(x) and all(hasattr(i, "columns") for i in x)


def _trajectories_on_their_grids(xs: Any, us: Any, regular: Any) -> tuple[list, Any]:
    """A list of pandas trajectories (and their inputs), each checked as one series is:
    the same columns as the first, its time stamps in order and without repeats, the
    inputs matched by stamp, the missing stamps of its regular grid as NaN rows (the
    trajectories must then still have a common length)."""
    first = [str(c) for c in xs[0].columns]
    if not isinstance(us, (list, tuple)):
        us = [None] * len(xs) if us is None else us
    states, inputs = [], []
    for r, (x, u) in enumerate(zip(xs, us)):
        if [str(c) for c in x.columns] != first:
            raise ValueError(
                f"x[{r}]: its columns {[str(c) for c in x.columns]} differ from those of "
                f"x[0], {first}; give every trajectory the same state columns"
            )
        u = arrays.aligned(x, u, f"x[{r}]", f"u[{r}]")
        grid = time_grid_of(x, f"x[{r}]", regular)
        if grid is not None and grid.inserted:  # the trajectory's rows on its grid
            x = grid.spread(arrays.as_time_series(x, f"x[{r}]", missing=True)[None])[0]
            if u is not None:
                u = grid.spread(arrays.as_time_series(u, f"u[{r}]", missing=True)[None])[0]
        states.append(x)
        inputs.append(u)
    return states, None if all(u is None for u in inputs) else inputs


def time_grid_of(value: Any, name: str, regular: Any = True) -> TimeGrid | None:
    """The checked regular grid of a series' time index (None without one), with a
    :class:`~ltvmodels.DataWarning` where missing stamps become missing samples
    (``regular``: see :func:`state_space_data`; checked here, where every front-end's
    time axis passes)."""
    grid = arrays.timed(value, name, options.flag(regular, "regular"))
    if grid is not None and grid.inserted:
        warn(f"{name}: {grid.notice}", DataWarning)
    return grid


def regression_problem(
    y: Any, phi: Any, *, order: Any = 1, weights: Any = None, regular: Any = True
) -> RegressionProblem:
    """Validate regression data and build its problem: y_t = Θ_t φ_t + e_t.

    ``y`` (N, n), (N,) or (R, N, n) and ``phi`` (N, p), (N,) or (R, N, p), NaN =
    missing (a row enters the data term only if y_t and φ_t are observed);
    ``weights`` (N,) or (R, N). The rows of a y with a time index are placed on
    its regular grid (:mod:`ltvmodels.validation.time`; ``regular``: see
    :func:`state_space_data`); :func:`regression_data` records that grid.
    """
    return regression_data(y, phi, order=order, weights=weights, regular=regular)[0]


def regression_data(
    y: Any, phi: Any, *, order: Any = 1, weights: Any = None, regular: Any = True
) -> tuple[RegressionProblem, DataDescription]:
    """:func:`regression_problem` and the description of its data (a fitted model's
    ``data``): the column names of a pandas y and phi, the time grid of y (one series),
    the series and the rows left out."""
    phi = arrays.aligned(y, phi, "y", "phi")
    grid = time_grid_of(y, "y", regular)
    names = {"output": y, "regressor": phi}
    y = arrays.trajectories(y, "y")
    phi = arrays.trajectories(phi, "phi")
    arrays.observed_columns(y, "y", "output", names["output"])
    arrays.observed_columns(phi, "phi", "regressor", names["regressor"])
    if phi.shape[:2] != y.shape[:2]:
        expected = y.shape[1] if y.shape[0] == 1 else y.shape[:2]
        received = phi.shape[1] if phi.shape[0] == 1 else phi.shape[:2]
        raise ValueError(
            f"phi: expected {expected} rows (one regressor vector per row of y), "
            f"received {received}"
        )
    w = arrays.row_weights(weights, y.shape[0], y.shape[1])
    if grid is not None:  # missing stamps of a regular grid become missing rows
        y, phi, w = grid.spread(y), grid.spread(phi), grid.spread_rows(w, 0)
    coeffs = options.difference_coefficients(order, max_degree=y.shape[1])
    problem = weighted_problem(y, phi, coeffs, w)
    description = DataDescription.of(
        {
            "output": arrays.column_names(names["output"], problem.n, "y"),
            "regressor": arrays.column_names(names["regressor"], problem.p, "phi"),
        },
        None if grid is None else grid.time,
        n_trajectories=problem.q,
        n_missing=problem.N * problem.q - problem.n_observed,
        time_name=arrays.time_name(names["output"]),
    )
    return problem, description


def require_enough_data(problem: RegressionProblem, data_name: str, rows_note: str = "") -> None:
    """Enough observed rows to identify p regressors per output with the penalty's degree.

    ``data_name`` is the argument blamed: "x" counts transitions (T = N + 1),
    anything else regression rows (``rows_note`` says how they relate to the
    series, e.g. for AR).
    """
    counts = {"observed": problem.n_observed, "n_rows": problem.N * problem.q}
    if data_name == "x":
        options.enough_samples(problem.N, problem.p, problem.degree, **counts)
    else:
        options.enough_rows(problem.N, problem.p, problem.degree, data_name, rows_note, **counts)
