"""The recordings the commands fit, read from DATA as their arguments choose them.

A state-space recording (``--state``, ``--input``, ``--weights``, ``--time``)
for ``fit``, ``segments`` and ``select-lambda``; one column of an AR model
(``--column``, ``--weights``) for ``ar`` and ``select-lambda --column``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from ..validation.arrays import LabelledSeries
from .data import read_columns
from .messages import DataError

__all__ = ["StateSpaceData", "ColumnData", "state_space_data", "column_data"]


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
    """

    label: str
    x: np.ndarray
    u: np.ndarray | None
    state_names: list[str]
    input_names: list[str]
    weights: np.ndarray | None
    time: np.ndarray | None

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
    """

    label: str
    names: list[str]
    y: np.ndarray
    weights: np.ndarray | None

    @property
    def series(self) -> LabelledSeries:
        """y with its columns' names, as the estimators take it: their errors then name
        the columns of the file."""
        return LabelledSeries(self.y, self.names)


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

    Raises
    ------
    DataError
        A column that cannot be read, or a missing weight.
    """
    weights = getattr(args, "weights", None)
    _, label, cols = read_columns(
        args.data,
        header=args.header,
        state=args.state,
        input=args.input,
        weights=weights,
        time=getattr(args, "time", None),
    )
    state_names, x = cols["state"]
    input_names, u = cols["input"] if cols["input"] is not None else ([], None)
    transition_weights = None
    if weights is not None:  # the equation predicting row t has the weight of row t
        (name,), values = cols["weights"]
        column = values[1:, 0]
        if not np.all(np.isfinite(column)):
            raise DataError(
                f"--weights: the weights must be observed, received a missing value in "
                f"column {name!r} at row {1 + int(np.flatnonzero(~np.isfinite(column))[0])}"
            )
        transition_weights = column
    time = None if cols.get("time") is None else cols["time"][1]
    if time is not None:  # the library's time rules, as for a pandas index
        from ..estimators.recordings import time_grid_of

        try:
            grid = time_grid_of(LabelledSeries(x, state_names, time), "--time")
        except ValueError as exc:
            text = str(exc).replace("(df.sort_index())", "(sort the file by that column)")
            raise DataError(text) from None
        if grid is None:  # the stamps 0, 1, … are consecutive rows: nothing to check
            return StateSpaceData(label, x, u, state_names, input_names, transition_weights, time)
        if grid.inserted:
            x = grid.spread(x[None])[0]
            u = None if u is None else grid.spread(u[None])[0]
            spread = grid.spread_rows(
                None if transition_weights is None else transition_weights[None], 1
            )
            transition_weights = None if spread is None else spread[0]
        time = grid.time
    return StateSpaceData(label, x, u, state_names, input_names, transition_weights, time)


def column_data(args: argparse.Namespace) -> ColumnData:
    """Read the column(s) of an AR model of order ``args.na`` from DATA.

    Parameters
    ----------
    args : argparse.Namespace
        ``data``, ``column``, ``na`` and ``weights``.

    Returns
    -------
    ColumnData

    Raises
    ------
    DataError
        A column that cannot be read, or a missing weight.
    """
    _, label, cols = read_columns(
        args.data, header=args.header, column=args.column, weights=args.weights
    )
    weights = None
    if cols["weights"] is not None:  # the equation predicting row t has row t's weight
        (name,), values = cols["weights"]
        weights = values[args.na :, 0]
        if not np.all(np.isfinite(weights)):
            raise DataError(
                f"--weights: the weights must be observed, received a missing value in "
                f"column {name!r} at row {args.na + int(np.flatnonzero(~np.isfinite(weights))[0])}"
            )
    names, y = cols["column"]
    return ColumnData(label, names, y, weights)
