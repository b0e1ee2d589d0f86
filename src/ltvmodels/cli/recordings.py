"""The recordings the commands fit, read from DATA as their arguments choose them.

A state-space recording (``--state``, ``--input``, ``--weights``, ``--time``)
for ``fit``, ``segments`` and ``select-lambda``; the column(s) of an AR model
(``--column``, ``--weights``, ``--time``) for ``ar`` and ``select-lambda
--column``. A ``--time`` column follows the library's rules for a time index
(:mod:`ltvmodels.validation.time`), checked here once for every command: the
stamps must be strictly increasing, and stamps missing from their regular grid
become missing samples (NaN rows), with the library's warning.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..validation.arrays import LabelledSeries
from .arguments import regular_time
from .data import read_columns
from .messages import DataError

if TYPE_CHECKING:  # pragma: no cover
    from ..validation.time import TimeGrid

_Column = tuple[list[str], np.ndarray]
"""A column read from DATA: its names and values (T, k)."""

__all__ = [
    "StateSpaceData",
    "ColumnData",
    "RegressionData",
    "state_space_data",
    "column_data",
    "regression_data",
]


@dataclass(frozen=True)
class StateSpaceData:
    """The columns of a state-space recording.

    Attributes
    ----------
    label : str
        The data file as the reports name it.
    x : ndarray
        (T, n) states; NaN where missing.
    u : ndarray or None
        (T, m) inputs, None for an autonomous system.
    state_names, input_names : list of str
        The columns' names (no inputs: empty).
    weights : ndarray or None
        (T - 1,) the transitions' weights (``--weights``).
    time : ndarray or None
        (T,) the samples' times (``--time``).
    time_name : str or None
        The name of the ``--time`` column.
    """

    label: str
    x: np.ndarray
    u: np.ndarray | None
    state_names: list[str]
    input_names: list[str]
    weights: np.ndarray | None
    time: np.ndarray | None
    time_name: str | None = None

    @property
    def states(self) -> LabelledSeries:
        """x with its columns' names, as the estimators take it: their errors then name
        the columns of the file."""
        return LabelledSeries(self.x, self.state_names)

    @property
    def inputs(self) -> LabelledSeries | None:
        """u with its columns' names (None for an autonomous system)."""
        return None if self.u is None else LabelledSeries(self.u, self.input_names)


@dataclass(frozen=True)
class ColumnData:
    """The column(s) of an AR model.

    Attributes
    ----------
    label : str
        The data file as the reports name it.
    names : list of str
        The columns' names.
    y : ndarray
        (T, k) the samples; NaN where missing.
    weights : ndarray or None
        (T - na,) the weights of the equations (``--weights``).
    time : ndarray or None
        (T,) the samples' times (``--time``).
    """

    label: str
    names: list[str]
    y: np.ndarray
    weights: np.ndarray | None
    time: np.ndarray | None = None

    @property
    def series(self) -> LabelledSeries:
        """y with its columns' names, as the estimators take it: their errors then name
        the columns of the file."""
        return LabelledSeries(self.y, self.names)


@dataclass(frozen=True)
class RegressionData:
    """One regression equation y_t = θ_tᵀ φ_t + e_t read from DATA (``segments --response``).

    Attributes
    ----------
    label : str
        The data file as the reports name it.
    y : LabelledSeries
        (N, 1) the response, with its name and the rows' times (``--time``).
    phi : LabelledSeries
        (N, p) the regressors: the ``--regressors`` columns, then the response's
        ``--lags``, then the ``--constant`` column "const".
    weights : ndarray or None
        (N,) the rows' weights (``--weights``).
    """

    label: str
    y: LabelledSeries
    phi: LabelledSeries
    weights: np.ndarray | None

    @property
    def response_name(self) -> str:
        """The response's column name."""
        return (self.y.names or ["y"])[0]

    @property
    def regressor_names(self) -> list[str]:
        """The regressors' names, in the order of phi's columns."""
        return list(self.phi.names or [])


def state_space_data(args: argparse.Namespace) -> StateSpaceData:
    """Read the state-space columns that the arguments choose from DATA.

    Parameters
    ----------
    args : argparse.Namespace
        ``data``, ``state``, ``input`` and, where the command has them,
        ``weights`` and ``time``.

    Returns
    -------
    StateSpaceData
        On the regular grid of the ``--time`` stamps, if given.

    Raises
    ------
    DataError
        A column that cannot be read, a missing weight, or time stamps out of
        order or on no regular grid.
    """
    _, label, cols = read_columns(
        args.data,
        header=args.header,
        state=args.state,
        input=args.input,
        weights=getattr(args, "weights", None),
        time=getattr(args, "time", None),
    )
    state_names, x = cols["state"]
    input_names, u = cols["input"] if cols["input"] is not None else ([], None)
    weights = _equation_weights(cols["weights"], 1)  # a transition predicts x[t + 1]
    time, grid = _time_axis(cols["time"], x, state_names, args)
    time_name = None if cols.get("time") is None else cols["time"][0][0]
    if grid is not None:
        x, u, weights = _spread(grid, x), _spread(grid, u), _spread_weights(grid, weights, 1)
    return StateSpaceData(label, x, u, state_names, input_names, weights, time, time_name)


def column_data(args: argparse.Namespace) -> ColumnData:
    """Read the column(s) of an AR model of order ``args.na`` from DATA.

    Parameters
    ----------
    args : argparse.Namespace
        ``data``, ``column``, ``na``, ``weights`` and, where the command has it,
        ``time``.

    Returns
    -------
    ColumnData
        On the regular grid of the ``--time`` stamps, if given.

    Raises
    ------
    DataError
        A column that cannot be read, a missing weight, or time stamps out of
        order or on no regular grid.
    """
    _, label, cols = read_columns(
        args.data,
        header=args.header,
        column=args.column,
        weights=args.weights,
        time=getattr(args, "time", None),
    )
    names, y = cols["column"]
    weights = _equation_weights(cols["weights"], args.na)  # the first na rows are only lags
    time, grid = _time_axis(cols["time"], y, names, args)
    if grid is not None:
        y, weights = _spread(grid, y), _spread_weights(grid, weights, args.na)
    return ColumnData(label, names, y, weights, time)


def regression_data(args: argparse.Namespace) -> RegressionData:
    """Read the regression that ``--response``, ``--regressors``, ``--lags`` and
    ``--constant`` choose from DATA.

    The lags y_{t−l} are taken on the time grid (after missing stamps became
    missing rows), so the first max(lags) rows, which have no lagged values, are
    left out.

    Raises
    ------
    DataError
        A column that cannot be read, a response of several columns, no
        regressor at all, lags that leave no row, a missing weight, or time
        stamps out of order or on no regular grid.
    """
    _, label, cols = read_columns(
        args.data,
        header=args.header,
        response=args.response,
        regressors=args.regressors,
        weights=args.weights,
        time=args.time,
    )
    names, y = cols["response"]
    if len(names) != 1:
        raise DataError(
            f"--response: expected one column (the response y of the regression), "
            f"received {len(names)}: {', '.join(names)}"
        )
    regressor_names, phi = cols["regressors"] or ([], np.empty((y.shape[0], 0)))
    weights = _equation_weights(cols["weights"], 0)
    time, grid = _time_axis(cols["time"], y, names, args)
    if grid is not None:
        y, phi, weights = _spread(grid, y), _spread(grid, phi), _spread_weights(grid, weights, 0)
    lags = sorted(set(args.lags or []))
    first = max(lags, default=0)
    if first >= y.shape[0]:
        raise DataError(
            f"--lags: a lag of {first} rows leaves none of the {y.shape[0]} rows with its "
            "lagged values; use smaller lags"
        )
    lagged = [y[first - lag : y.shape[0] - lag] for lag in lags]
    columns = [phi[first:], *lagged]
    regressor_names = regressor_names + [f"{names[0]}[t-{lag}]" for lag in lags]
    if args.constant:
        columns.append(np.ones((y.shape[0] - first, 1)))
        regressor_names.append("const")
    if not regressor_names:
        raise DataError(
            "--regressors: the regression has no regressor; give --regressors COLS, "
            "--lags L (lagged responses) or --constant (a level per segment)"
        )
    time_name = None if cols["time"] is None else cols["time"][0][0]
    return RegressionData(
        label,
        LabelledSeries(y[first:], names, None if time is None else time[first:], time_name),
        LabelledSeries(np.hstack(columns), regressor_names),
        None if weights is None else weights[first:],
    )


def _equation_weights(column: _Column | None, lag: int) -> np.ndarray | None:
    """The ``--weights`` of the equations that predict rows lag, lag + 1, …: the equation
    predicting row t has the weight of row t. None without ``--weights``."""
    if column is None:
        return None
    (name,), values = column
    weights = values[lag:, 0]
    if not np.all(np.isfinite(weights)):
        raise DataError(
            f"--weights: the weights must be observed, received a missing value in column "
            f"{name!r} at row {lag + int(np.flatnonzero(~np.isfinite(weights))[0])}"
        )
    return weights


def _time_axis(
    column: _Column | None, values: np.ndarray, names: list[str], args: argparse.Namespace
) -> tuple[np.ndarray | None, TimeGrid | None]:
    """The samples' times of a ``--time`` column (None without one) and, where stamps are
    missing from their regular grid, that grid (its ``spread`` puts the rows on it).

    The library's time rules, as for a pandas index, with its warning where missing
    stamps become missing samples; ``--irregular``: the rows as they are.
    """
    regular = regular_time(args)
    if column is None:
        return None, None
    from ..estimators.recordings import time_grid_of

    stamps = column[1]
    try:
        grid = time_grid_of(LabelledSeries(values, names, stamps), "--time", regular)
    except ValueError as exc:
        raise DataError(_command_line_remedies(str(exc))) from None
    if grid is None:  # the stamps 0, 1, … are consecutive rows: nothing to check
        return stamps, None
    return grid.time, grid if grid.inserted else None


def _command_line_remedies(message: str) -> str:
    """A time-rule error of the library with the remedies of the command line (the file's
    rows and ``--irregular``, not pandas calls and ``regular=False``)."""
    return message.replace("(df.sort_index())", "(sort the file by that column)").replace(
        "(df.resample('D').mean(), df.asfreq('h'), …), or pass regular=False",
        "before reading it, or pass --irregular",
    )


def _spread(grid: TimeGrid, rows: np.ndarray | None) -> np.ndarray | None:
    """(rows, d) data rows on the grid (T, d), NaN where a stamp was missing."""
    return None if rows is None else grid.spread(rows[None])[0]


def _spread_weights(grid: TimeGrid, weights: np.ndarray | None, lag: int) -> np.ndarray | None:
    """The weights of the equations predicting rows lag, lag + 1, … on the grid."""
    spread = None if weights is None else grid.spread_rows(weights[None], lag)
    return None if spread is None else spread[0]
