"""Coercion and shape checks of array inputs: data, covariances, change points.

Each check raises :class:`ValueError` or :class:`TypeError` with a message that
names the argument, what was expected and what was received. Arrays are always
copied into fresh float64 arrays, so user data are never mutated and never
aliased by a returned model. Scalar options and counts are checked in
:mod:`ltvmodels.validation.options`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .time import TimeGrid, time_grid

__all__ = [
    "LabelledSeries",
    "describe",
    "as_float_array",
    "as_time_series",
    "trajectories",
    "LARGEST_DATA",
    "representable",
    "is_batch",
    "column_names",
    "distinct_columns",
    "time_index",
    "time_name",
    "index_values",
    "recordings",
    "row_weights",
    "timed",
    "aligned",
    "regressor_rows",
    "vector",
    "covariance",
    "mean_sequence",
    "initial_state_prior",
    "lagged_series",
    "lagged_recordings",
    "observed_columns",
    "model_series",
    "simulation_inputs",
    "dynamics_matrices",
    "activation_series",
    "changepoint_indices",
    "positive_grid",
    "count_grid",
]


@dataclass(frozen=True)
class LabelledSeries:
    """A (T, d) series with the column names and time index a pandas DataFrame carries.

    The estimators read it as they read a DataFrame (:func:`column_names`,
    :func:`time_index`), without the cost of building one: :func:`ltvmodels.fit_many`
    hands each unit's slice of a long table to the estimators this way.

    Attributes
    ----------
    values : ndarray, shape (T, d)
    names : list of str, optional
        The d column names.
    time : ndarray, shape (T,), optional
        Time stamps (datetime64, timedelta64 or numbers).
    time_name : str, optional
        The name of the time stamps (the table's time column).
    """

    values: np.ndarray
    names: list[str] | None = None
    time: np.ndarray | None = None
    time_name: str | None = None

    def __len__(self) -> int:
        return self.values.shape[0]

    def to_numpy(self) -> np.ndarray:
        return self.values

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        """The values for numpy (``np.asarray``): a labelled series is array-like, as the
        estimators' ``ArrayLike`` arguments say (the command line hands its columns to
        them this way)."""
        return np.array(self.values, dtype=dtype, copy=copy)


def describe(value: Any) -> str:
    """Short description of a received value for error messages."""
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape} and dtype {value.dtype}"
    if hasattr(value, "shape") and hasattr(value, "dtype"):
        return f"{type(value).__name__} of shape {tuple(value.shape)}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def _pandas_numbers(value: Any, name: str) -> np.ndarray:
    """The values of a pandas DataFrame or Series as floats, pandas' missing values
    (``pd.NA``, None, NaN) as NaN; a column holding anything else is a TypeError that
    names it."""
    frame = value.to_frame() if getattr(value, "ndim", 2) == 1 else value
    distinct_columns(frame.columns, name)  # a repeated label selects a table, not a column
    objects = [label for label in frame.columns if frame[label].dtype.kind not in "fiub"]
    if not objects:  # numbers (nullable ones too), booleans
        return frame.to_numpy(dtype=np.float64, na_value=np.nan).reshape(np.shape(value))
    for label in objects:
        column = frame[label]
        for row, item in column.items():
            is_missing = item is None or item is _pandas_na() or _is_nan(item)
            if not is_missing and (isinstance(item, (str, bytes, bool)) or not _is_real(item)):
                if getattr(value, "ndim", 2) == 1:
                    raise TypeError(
                        f"{name}: expected numbers, received {item!r} at {row!r}; convert "
                        "the series (pd.to_numeric) or pass numbers"
                    )
                raise TypeError(
                    f"{name}: column {label!r} holds values that are not numbers (e.g. "
                    f"{item!r} at {row!r}); pass only the numeric columns (select them, or "
                    "drop the others)"
                )
    numbers = frame.astype(object).where(frame.notna(), np.nan)
    return numbers.to_numpy(dtype=np.float64).reshape(np.shape(value))


def _pandas_na() -> Any:
    import pandas as pd  # (a pandas object was given: pandas is installed)

    return pd.NA


def _is_nan(item: Any) -> bool:
    return isinstance(item, (float, np.floating)) and bool(np.isnan(item))


def _is_real(item: Any) -> bool:
    return isinstance(item, (int, float, np.integer, np.floating))


def as_float_array(value: Any, name: str, *, missing: bool = False) -> np.ndarray:
    """Convert lists, numpy arrays and pandas objects to a new float64 array.

    Raises TypeError for values that are not numeric and ValueError for
    infinite entries, and for NaN unless ``missing`` (then NaN marks a missing
    sample, and the masked entries of a numpy masked array become NaN).
    """
    if type(value) is np.ndarray and value.dtype.kind in "fiu":
        # The common case, a plain numeric array: one copy and one pass when every
        # value is finite; otherwise the checks below. (Not by a finite sum: it
        # would warn of an overflow for large or infinite values.)
        arr = value.astype(np.float64)  # a copy
        if np.isfinite(arr).all():
            return arr
    if value is None:
        raise TypeError(f"{name}: expected an array of numbers, received None")
    source = value  # for its column names and row labels in messages
    if hasattr(value, "to_numpy") and hasattr(value, "index"):  # pandas DataFrame / Series
        value = _pandas_numbers(value, name)
    elif hasattr(value, "to_numpy"):  # e.g. an xarray DataArray
        value = value.to_numpy()
    if isinstance(value, np.ma.MaskedArray):
        if missing:  # masked entries are missing samples
            value = np.ma.filled(value.astype(float), np.nan)
        elif np.ma.getmaskarray(value).any():
            raise ValueError(
                f"{name}: received a masked array with masked entries, which cannot be missing "
                "here; pass the values to use (e.g. value.filled(...)) or a plain array"
            )
        else:
            value = np.ma.getdata(value)

    def expected() -> str:  # formatted only for an error: it costs more than the checks
        return f"{name}: expected an array of real numbers, received {describe(value)}"

    if isinstance(value, (str, bytes)):
        raise TypeError(expected())
    try:
        raw = np.asarray(value)
    except ValueError as exc:  # ragged nested sequences
        raise TypeError(expected()) from exc
    if np.iscomplexobj(raw):  # checked before the cast, which would only warn
        raise TypeError(f"{name}: expected real numbers, received complex values")
    if raw.dtype.kind in "USV":  # text (even "1.5") or raw bytes are not numbers
        raise TypeError(expected())
    try:
        arr = np.array(raw, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as exc:  # objects that are not numbers
        raise TypeError(expected()) from exc
    bad_values = np.isinf(arr) if missing else ~np.isfinite(arr)
    if np.any(bad_values):
        first = tuple(int(i) for i in np.argwhere(bad_values)[0])
        where = _entry_text(source, first, name)
        if missing:
            raise ValueError(
                f"{name}: expected finite values or NaN (missing), received inf (first "
                f"{where}); mark a missing sample with NaN"
            )
        raise ValueError(f"{name}: expected finite values, received NaN or inf (first {where})")
    return arr


def _entry_text(source: Any, position: tuple[int, ...], name: str) -> str:
    """Where the entry at ``position`` of the data ``source`` lies, as messages say it: in
    its named column (a table's, at its row's label) or at its array index."""
    index: Any = getattr(source, "index", None)
    labelled_rows = hasattr(index, "to_numpy")  # a pandas object's
    if len(position) == 1 and labelled_rows:  # a Series
        return f"at row {index[position[0]]!r}"
    if len(position) == 2:
        names = column_names(source, np.shape(source)[1], name)
        if names is not None:
            row = index[position[0]] if labelled_rows else position[0]
            return f"in column {names[position[1]]!r}, at row {row!r}"
    return f"at index {position}"


def _column_text(names: Sequence[str] | None, j: int) -> str:
    """Column j as messages name it: by its name where the data have names, else by its
    position."""
    return f"{j}" if names is None else f"{names[j]!r}"


def as_time_series(
    value: Any, name: str, *, allow_1d: bool = True, missing: bool = False
) -> np.ndarray:
    """Return a (T, d) float64 copy of a time series with time on axis 0.

    A 1-d input of length T becomes (T, 1) when ``allow_1d``; with ``missing``
    NaN marks a missing sample.
    """
    return _time_series_shape(as_float_array(value, name, missing=missing), name, allow_1d)


def _time_series_shape(arr: np.ndarray, name: str, allow_1d: bool) -> np.ndarray:
    """The shape checks of :func:`as_time_series` on a validated float64 array."""
    if arr.ndim == 1 and allow_1d:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(
            f"{name}: expected a 2-d array of shape (T, d) with time on axis 0, "
            f"received {arr.ndim}-d array of shape {arr.shape}"
        )
    if arr.shape[1] == 0:
        raise ValueError(f"{name}: expected at least one column, received shape {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError(f"{name}: expected at least one sample (row), received shape {arr.shape}")
    return arr


def trajectories(value: Any, name: str) -> np.ndarray:
    """Return an (R, T, d) float64 copy of R time-aligned trajectories; NaN = missing.

    Accepted: (T,) and (T, d) (one trajectory), (R, T, d), or a list of R
    equal-length arrays or DataFrames of shape (T, d) or (T,).
    """
    if (
        type(value) is np.ndarray
        and value.dtype.kind in "fiu"
        and value.ndim in (1, 2)
        and value.size
    ):
        # The common case, a plain numeric array, in a few passes (many short series
        # are fitted one after another); anything the checks below would reject
        # (inf, magnitudes out of range) goes through them for their message.
        arr = value.astype(np.float64)  # a copy: user data are never aliased
        scale = _column_scale(arr if arr.ndim == 2 else arr[:, None])
        if all(not (v > LARGEST_DATA or 0 < v < SMALLEST_DATA) for v in scale.tolist()):
            return _time_series_shape(arr, name, True)[None]  # NaN columns: missing data
    if isinstance(value, (list, tuple)) and value and all(hasattr(item, "shape") for item in value):
        parts = [as_time_series(item, f"{name}[{r}]", missing=True) for r, item in enumerate(value)]
        shapes = {part.shape for part in parts}
        if len(shapes) > 1:
            listed = ", ".join(str(part.shape) for part in parts[:4])
            raise ValueError(
                f"{name}: expected trajectories of equal length and width, received shapes "
                f"{listed}{', ...' if len(parts) > 4 else ''}; pad the shorter ones with "
                "NaN rows (missing samples) to a common length"
            )
        return representable(np.stack(parts), name)
    try:
        arr = as_float_array(value, name, missing=True)
    except TypeError as exc:
        if isinstance(value, (list, tuple)):
            raise TypeError(
                f"{exc}; trajectories of unequal length must be padded with NaN rows "
                "(missing samples) to a common length"
            ) from None
        raise
    if arr.ndim in (1, 2):
        series = _time_series_shape(arr, name, True)[None]
        return representable(series, name, names=column_names(value, series.shape[2], name))
    if arr.ndim != 3:
        raise ValueError(
            f"{name}: expected shape (T, d) with time on axis 0, or (R, T, d) for R "
            f"trajectories, received {arr.ndim}-d array of shape {arr.shape}"
        )
    if arr.shape[2] == 0:
        raise ValueError(f"{name}: expected at least one column, received shape {arr.shape}")
    if arr.shape[1] == 0:
        raise ValueError(
            f"{name}: expected at least one sample (time on axis 1 of an "
            f"(R, T, d) batch), received shape {arr.shape}"
        )
    return representable(arr, name)


# Data beyond these magnitudes cannot be fitted in float64: sums of squares of
# 1e100 over a million samples still fit below 1.8e308, squares of 1e-100 stay
# normal numbers. Scaling a column by a constant changes only its coefficients.
LARGEST_DATA = 1e100
SMALLEST_DATA = 1e-100


# Weights scale the rows by √w: within these the weighted data stay representable.
LIGHTEST_WEIGHT = 1e-50
HEAVIEST_WEIGHT = 1e50


def _column_scale(arr: np.ndarray) -> np.ndarray:
    """The largest magnitude in each column (last axis) of a non-empty array, NaN ignored
    (NaN for a column of NaN only)."""
    # max |v| = max(max v, −min v): two reductions of the values as given, without
    # an array of their magnitudes (as large as the data; the first touch of that
    # memory cost a one-off fit of 10⁶ steps 0.05 s).
    # numpy reduces a few long columns of a C-ordered array one short row at a time
    # (~10x slower than along rows). So blocks of rows are laid side by side first
    # (a free reshape): the reduction then runs over long contiguous rows, and one
    # short fold per block position is left. (A transposed copy of the array, the
    # other way round, costs as much as the rest together.)
    values = arr.reshape(-1, arr.shape[-1])
    rows, d = values.shape
    block = max(1, 4096 // max(d, 1))
    full = rows - rows % block

    def extreme(reduce) -> np.ndarray:
        parts = [reduce(values[full:], axis=0)] if full < rows else []  # the rest
        if full:
            folded = reduce(values[:full].reshape(full // block, block * d), axis=0)
            parts.append(reduce(folded.reshape(block, d), axis=0))
        return parts[0] if len(parts) == 1 else reduce(np.stack(parts), axis=0)

    return np.fmax(np.abs(extreme(np.fmax.reduce)), np.abs(extreme(np.fmin.reduce)))


def representable(
    arr: np.ndarray, name: str, *, small: bool = True, names: Sequence[str] | None = None
) -> np.ndarray:
    """Reject columns (last axis) whose magnitudes overflow or underflow when squared.

    A column that is all zero passes (the identifiability checks name it);
    ``small=False`` checks only the upper limit (for values where tiny is fine,
    e.g. a prior mean); ``names``, the columns' names, for the message (default:
    their positions). Returns ``arr``.
    """
    if arr.size == 0:
        return arr
    scale = _column_scale(arr)
    for bad, what in (
        (scale > LARGEST_DATA, "large"),
        ((scale > 0) & (scale < SMALLEST_DATA) & small, "small"),
    ):
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"{name}: column {_column_text(names, j)} has values of magnitude up to "
                f"{scale[j]:.3g}, too {what} "
                f"to fit in double precision (expected magnitudes between {SMALLEST_DATA:g} "
                f"and {LARGEST_DATA:g}); rescale it, e.g. divide by {scale[j]:.0e}: "
                "the fitted coefficients scale accordingly"
            )
    return arr


def is_batch(value: Any) -> bool:
    """Whether a value is given as several trajectories: 3-d, or a list of arrays."""
    if isinstance(value, (list, tuple)) and value and all(hasattr(v, "shape") for v in value):
        return True
    return np.ndim(value) == 3


def distinct_columns(labels: Any, name: str, *, used: Any = None) -> None:
    """Reject a table whose columns repeat a name (compared as text, as a model keeps its
    names): its signals could be told apart by position only, and python-control, plots
    and files know them by name.

    Parameters
    ----------
    labels : sequence
        The table's column labels.
    name : str
        The argument the table comes from (the start of the message).
    used : collection, optional
        Only these labels must be distinct (the columns a selection takes from a wider
        table); default: all.

    Raises
    ------
    ValueError
        Naming the repeated column and its first two positions in ``labels``.
    """
    texts = [str(label) for label in labels]
    if len(set(texts)) == len(texts):
        return
    wanted = None if used is None else {str(label) for label in used}
    first: dict[str, int] = {}
    for j, text in enumerate(texts):
        if wanted is not None and text not in wanted:
            continue
        if text in first:
            raise ValueError(
                f"{name}: column {text!r} appears twice (columns {first[text]} and {j}); "
                "rename one of them or drop the copy"
            )
        first[text] = j


def column_names(value: Any, count: int, name: str) -> list[str] | None:
    """The column names of a pandas DataFrame (or a named Series) with ``count`` columns,
    or the coordinate of an xarray DataArray's second dimension (its name for one
    dimension), as strings; None for anything else (arrays, lists, unnamed series).

    Raises
    ------
    ValueError
        Names that repeat (:func:`distinct_columns`; ``name`` is the argument).
    """
    if isinstance(value, LabelledSeries):
        names = value.names
        return _distinct(names, name) if names and len(names) == count else None
    dims = getattr(value, "dims", None)
    if isinstance(dims, tuple) and hasattr(value, "coords"):  # an xarray DataArray
        if len(dims) == 2 and dims[1] in value.coords and value.shape[1] == count:
            return _distinct(np.asarray(value.coords[dims[1]].values), name)
        label = getattr(value, "name", None)
        return [str(label)] if len(dims) == 1 and label is not None and count == 1 else None
    columns = getattr(value, "columns", None)
    if columns is not None and getattr(value, "ndim", 0) == 2 and len(columns) == count:
        return _distinct(columns, name)
    label = getattr(value, "name", None)
    if (
        label is not None
        and getattr(value, "ndim", 0) == 1
        and count == 1
        and hasattr(value, "index")
    ):
        return [str(label)]
    return None


def _distinct(labels: Any, name: str) -> list[str]:
    """The labels as text, checked by :func:`distinct_columns`."""
    distinct_columns(labels, name)
    return [str(label) for label in labels]


def time_index(value: Any, count: int) -> np.ndarray | None:
    """The index of a pandas object (or the coordinate of an xarray DataArray's first
    dimension) with ``count`` rows as an array: datetime64[ns] for
    dates (time zones dropped after conversion to UTC, periods at their start), float
    for numbers, float seconds for time spans (a TimedeltaIndex); None for other data
    and for the default index 0, 1, …"""
    if isinstance(value, LabelledSeries):
        if value.time is None or len(value.time) != count:
            return None
        return _time_values(np.asarray(value.time), count)
    index = getattr(value, "index", None)
    dims = getattr(value, "dims", None)
    if isinstance(dims, tuple) and dims and hasattr(value, "indexes"):  # an xarray DataArray
        index = value.indexes[dims[0]] if dims[0] in value.indexes else None
    if index is None or not hasattr(index, "to_numpy") or len(index) != count:
        return None
    return _time_values(index_values(index), count)


def time_name(value: Any) -> str | None:
    """The name of the time index of a pandas object (of the first dimension of an xarray
    DataArray, of a :class:`LabelledSeries`' stamps), as a string; None where it has none."""
    if isinstance(value, LabelledSeries):
        name = value.time_name
    else:
        dims = getattr(value, "dims", None)
        if isinstance(dims, tuple) and dims and hasattr(value, "indexes"):  # an xarray DataArray
            name = None if str(dims[0]) == "dim_0" else dims[0]  # "dim_0": xarray's default
        else:
            name = getattr(_pandas_index(value), "name", None)
    return None if name is None else str(name)


def index_values(index: Any) -> np.ndarray:
    """The values of a pandas Index as an array: periods at their start, dates with a time
    zone converted to UTC and the zone dropped."""
    if hasattr(index, "to_timestamp"):  # a PeriodIndex
        index = index.to_timestamp()
    if getattr(index, "tz", None) is not None:
        index = index.tz_convert("UTC").tz_localize(None)
    return index.to_numpy()


def _time_values(values: np.ndarray, count: int) -> np.ndarray | None:
    """Time stamps as a model keeps them: datetime64[ns] for dates, float for numbers and
    float seconds for time spans (a pandas TimedeltaIndex: its raw numbers would be in
    whatever unit numpy holds them); None for other values and for the default
    0, 1, …, count − 1."""
    if np.issubdtype(values.dtype, np.datetime64):
        return values.astype("datetime64[ns]")
    if np.issubdtype(values.dtype, np.timedelta64):
        return values / np.timedelta64(1, "s")
    if not np.issubdtype(values.dtype, np.number):
        return None
    values = values.astype(float)
    if np.array_equal(values, np.arange(count)):
        return None
    return values


def recordings(x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validate recorded states ``x`` and inputs ``u`` of R time-aligned trajectories.

    ``x``: (T, n), (T,), (R, T, n) or a list of R (T, n) arrays; ``u`` the same
    with m columns, or None. NaN marks a missing sample. Time must be on the
    axis of length T: a single trajectory with fewer rows than columns is
    rejected before anything is allocated (it is almost always transposed).

    Returns float64 copies x (R, T, n) and u (R, T, m) (m = 0 when None).
    """
    source, x = x, trajectories(x, "x")
    R, T, n = x.shape
    if T < n:
        shape = x.shape[1:] if R == 1 else x.shape
        raise ValueError(
            f"x: expected time on axis 0 (shape (T, n) with T > n, or (R, T, n)), received "
            f"shape {shape}: {T} time steps of {n} states. If time runs along the other "
            "axis, pass x.T"
        )
    if T < 2:
        raise ValueError(f"x: expected at least 2 time steps, received T={T}")
    observed_columns(x, "x", "state", source)
    if u is None:
        return x, np.zeros((R, T, 0))
    inputs, u = u, trajectories(u, "u")
    if u.shape[:2] != (R, T):
        expected = "" if R == 1 else f" in each of the {R} trajectories, shape ({R}, {T}, m)"
        received = u.shape[1:] if u.shape[0] == 1 else u.shape
        raise ValueError(
            f"u: expected {T} rows (one input per state sample, as x){expected}, "
            f"received shape {received}"
        )
    observed_columns(u, "u", "input", inputs)
    return x, u


def observed_columns(arr: np.ndarray, name: str, what: str, source: Any = None) -> None:
    """Reject a column (last axis of ``arr``, (R, T, d)) that has no observed sample in any
    trajectory: it leaves out every row of the data term it enters.

    Parameters
    ----------
    arr : ndarray, shape (R, T, d)
        Validated data, NaN = missing.
    name : str
        The argument (the start of the message).
    what : str
        What a column is ("state", "input", "output", "regressor").
    source : object, optional
        The data as given, whose column names (a table's) the message uses.

    Raises
    ------
    ValueError
        Naming the first such column.
    """
    if not np.isnan(arr.sum()):  # the common case: nothing missing
        return
    empty = np.all(np.isnan(arr), axis=(0, 1))
    if empty.any():
        j = int(np.flatnonzero(empty)[0])
        label = _column_text(column_names(source, arr.shape[2], name), j)
        raise ValueError(
            f"{name}: {what} {label} has no observed samples (all NaN); drop it or supply its data"
        )


def timed(value: Any, name: str, regular: bool = True) -> TimeGrid | None:
    """The checked time grid of one series' stamps (its pandas index), or None for data
    without a time index (see :mod:`ltvmodels.validation.time`; ``regular``: that of
    :func:`~ltvmodels.validation.time.time_grid`)."""
    index = _pandas_index(value)
    indexed = isinstance(value, LabelledSeries) or index is not None or hasattr(value, "dims")
    if not indexed or is_batch(value):
        return None
    stamps = time_index(value, len(value))
    if stamps is None:
        return None
    zone = getattr(index, "tz", None)
    if zone is not None:  # the grid of a zone's days is on its local clock
        local = value.index.tz_localize(None).to_numpy().astype("datetime64[ns]")
        return time_grid(local, name, zone, regular=regular)
    return time_grid(stamps, name, regular=regular)


def aligned(value: Any, other: Any, name: str, other_name: str) -> Any:
    """``other`` with its rows in the order of ``value``'s time stamps where both are
    pandas objects with time indexes holding the same stamps in another order; an error
    where their stamps differ. Other data are taken row by row as they are."""
    index, other_index = _pandas_index(value), _pandas_index(other)
    if index is None or other_index is None:
        return other
    if time_index(value, len(value)) is None or time_index(other, len(other)) is None:
        return other  # a default index: the rows are matched by position
    if len(index) == len(other_index) and index.equals(other_index):
        return other
    if len(index) == len(other_index) and index.sort_values().equals(other_index.sort_values()):
        return other.reindex(index)  # the same stamps, in another order: by label
    differences = [
        f"{owner} has {len(extra)} stamp{'s' if len(extra) > 1 else ''} that {lacking} "
        f"lacks, the first {extra[0]}"
        for owner, lacking, extra in (
            (other_name, name, other_index.difference(index)),
            (name, other_name, index.difference(other_index)),
        )
        if len(extra)
    ]
    detail = "; ".join(differences) or "the same stamps, repeated differently"
    raise ValueError(
        f"{other_name}: its time index differs from the index of {name} ({detail}); "
        f"give both the same stamps ({other_name}.reindex({name}.index), or select the "
        "common rows)"
    )


def _pandas_index(value: Any) -> Any:
    """The index of a pandas object, else None."""
    index = getattr(value, "index", None)
    return index if hasattr(index, "to_numpy") else None


def row_weights(weights: Any, R: int, N: int, name: str = "weights") -> np.ndarray | None:
    """Validate weights of N regression rows per trajectory: (N,) or (R, N), finite, >= 0.

    Returns an (R, N) float64 array, or None when ``weights`` is None.
    """
    if weights is None:
        return None
    w = as_float_array(weights, name)
    if w.shape == (N,):
        w = np.broadcast_to(w, (R, N)).copy()
    if w.shape != (R, N):
        expected = f"({N},)" + (f" or ({R}, {N})" if R > 1 else "")
        raise ValueError(
            f"{name}: expected shape {expected} (one weight per transition), received "
            f"shape {w.shape}"
        )
    if np.any(w < 0):
        raise ValueError(f"{name}: expected weights >= 0, received a minimum of {w.min():g}")
    positive = w[w > 0]
    if positive.size and not (
        LIGHTEST_WEIGHT <= positive.min() and positive.max() <= HEAVIEST_WEIGHT
    ):
        raise ValueError(
            f"{name}: expected weights of 0 or between {LIGHTEST_WEIGHT:g} and "
            f"{HEAVIEST_WEIGHT:g}, received values from {positive.min():g} to "
            f"{positive.max():g}; only their ratios and λ matter, so divide them by a common "
            "factor"
        )
    return w


def regressor_rows(value: Any, N: int, p: int, name: str = "phi") -> np.ndarray:
    """Regressors for a fitted regression: (N, p), or (N,) when p = 1; returns a copy."""
    arr = as_time_series(value, name, allow_1d=(p == 1))
    if arr.shape != (N, p):
        raise ValueError(
            f"{name}: expected shape ({N}, {p}) (one row of {p} regressors per model time "
            f"step), received shape {arr.shape}"
        )
    return arr


def vector(value: Any, name: str, size: int, *, missing: bool = False) -> np.ndarray:
    """Validate a finite (or, with ``missing``, NaN-marked) 1-d vector of the given length."""
    arr = as_float_array(value, name, missing=missing)
    if arr.ndim == 0 and size == 1:
        arr = arr.reshape(1)
    if arr.shape != (size,):
        raise ValueError(f"{name}: expected a vector of length {size}, received shape {arr.shape}")
    return arr


def covariance(value: Any, name: str, N: int, d: int) -> np.ndarray:
    """Validate a covariance given as scalar, (d, d) or (N, d, d).

    Returns an array of shape (), (d, d) or (N, d, d). Matrices must be
    symmetric positive definite (checked by a Cholesky factorization).
    """
    arr = as_float_array(value, name)
    if arr.ndim == 0:
        if arr <= 0:
            raise ValueError(f"{name}: expected a variance > 0, received {float(arr)}")
        return arr
    if arr.shape not in ((d, d), (N, d, d)):
        raise ValueError(
            f"{name}: expected a scalar, a ({d}, {d}) matrix or an ({N}, {d}, {d}) array, "
            f"received shape {arr.shape}"
        )
    if not np.allclose(arr, np.swapaxes(arr, -1, -2), rtol=1e-8, atol=1e-12 * np.abs(arr).max()):
        raise ValueError(f"{name}: expected symmetric covariance matrices")
    try:
        np.linalg.cholesky(arr)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name}: expected positive definite covariance matrices") from None
    return arr


def mean_sequence(value: Any, name: str, N: int, d: int) -> np.ndarray:
    """Validate a mean given as (d,) or (N, d); returns (N, d)."""
    arr = as_float_array(value, name)
    if arr.shape == (d,):
        return np.broadcast_to(arr, (N, d)).copy()
    if arr.shape != (N, d):
        raise ValueError(f"{name}: expected shape ({d},) or ({N}, {d}), received {arr.shape}")
    return arr


def initial_state_prior(
    init_mean: Any, init_cov: Any, degree: int, n: int, p: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """Validate a Gaussian prior on the initial state of the parameter random walk.

    The state of the realization of a degree-d difference operator is
    s_0 = (k_0, k_{-1}, …, k_{-d+1}); per output row i it is
    (θ_{0,i}, θ_{-1,i}, …) of size D = d·p, rows independent a priori with a
    shared covariance.

    Parameters
    ----------
    init_mean : array_like, shape (d, K), (K,) when d = 1, or None
        Row j is the mean of k_{-j}. None means zero (only with ``init_cov``).
    init_cov : float or array_like, shape (D, D), or None
        Covariance of one row's state; a scalar v means v·I. None (with
        ``init_mean`` None) selects the exact diffuse initialization.

    Returns
    -------
    None for the diffuse initialization, else (mean (D, n), cov (D, D)) with
    column i the mean of row i's state.
    """
    D, K = degree * p, n * p
    if init_cov is None:
        if init_mean is not None:
            raise ValueError(
                "init_cov: expected a covariance to go with init_mean (a scalar or a "
                f"({D}, {D}) matrix), received None"
            )
        return None
    cov = as_float_array(init_cov, "init_cov")
    if cov.ndim == 0:
        if cov <= 0:
            raise ValueError(f"init_cov: expected a variance > 0, received {float(cov)}")
        cov = float(cov) * np.eye(D)
    elif cov.shape != (D, D):
        raise ValueError(
            f"init_cov: expected a scalar or a ({D}, {D}) matrix (the covariance of one "
            f"output row's state: {degree} block(s) of {p} regressors), received shape "
            f"{cov.shape}"
        )
    if not np.allclose(cov, cov.T, rtol=1e-8, atol=1e-12 * np.abs(cov).max()):
        raise ValueError("init_cov: expected a symmetric covariance matrix")
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        raise ValueError("init_cov: expected a positive definite covariance matrix") from None
    cov = 0.5 * (cov + cov.T)
    if init_mean is None:
        return np.zeros((D, n)), cov
    mean = as_float_array(init_mean, "init_mean")
    if degree == 1 and mean.shape == (K,):
        mean = mean[None, :]
    if mean.shape != (degree, K):
        expected = f"({K},) or (1, {K})" if degree == 1 else f"({degree}, {K})"
        raise ValueError(
            f"init_mean: expected shape {expected} (row j: mean of k_(-j)), received "
            f"shape {mean.shape}"
        )
    # (d, n, p) → (d, p, n) → (D, n): column i stacks θ_{0,i}, θ_{-1,i}, …
    return np.ascontiguousarray(mean.reshape(degree, n, p).transpose(0, 2, 1).reshape(D, n)), cov


def lagged_series(
    y: Any,
    u: Any,
    lag: int,
    structure: str,
    *,
    n_inputs: int | None = None,
    require_inputs: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Validate AR/ARX data: y (T, n) or (T,), u (T, m) or (T,) or None; T > lag.

    ``u`` may be None unless ``require_inputs``; ``n_inputs`` (if given) is the
    required number of columns of ``u``. ``structure`` names the orders (e.g.
    "na = 2, nb = 1, nk = 1") in the too-short message. NaN marks a missing
    sample. Returns float64 copies, u of shape (T, 0) when None.
    """
    outputs, y = y, as_time_series(y, "y", allow_1d=True, missing=True)
    representable(y, "y", names=column_names(outputs, y.shape[1], "y"))
    T = y.shape[0]
    if u is None:
        if require_inputs:
            expected = f"({T}, {n_inputs})" if n_inputs else f"({T}, m) or ({T},)"
            raise TypeError(f"u: expected inputs of shape {expected}, received None")
        u = np.zeros((T, 0))
    else:
        inputs, u = u, as_time_series(u, "u", allow_1d=True, missing=True)
        representable(u, "u", names=column_names(inputs, u.shape[1], "u"))
        if u.shape[0] != T:
            raise ValueError(f"u: expected {T} rows (one per sample of y), received {u.shape[0]}")
        if n_inputs is not None and u.shape[1] != n_inputs:
            raise ValueError(f"u: expected {n_inputs} columns, received {u.shape[1]}")
    if T <= lag:
        raise ValueError(
            f"y: the series is shorter than the lag structure: {structure} reaches back "
            f"{lag} samples, so y needs more than {lag} samples, received T = {T}"
        )
    return y, u


def lagged_recordings(
    y: Any,
    u: Any,
    lag: int,
    structure: str,
    *,
    require_inputs: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """As :func:`lagged_series` for R trajectories with NaN = missing.

    ``y`` (T, n), (T,) or (R, T, n); ``u`` likewise or None. Returns float64
    copies y (R, T, n) and u (R, T, m) (m = 0 when None).
    """
    outputs, y = y, trajectories(y, "y")
    observed_columns(y, "y", "output", outputs)
    R, T, _ = y.shape
    if u is None:
        if require_inputs:
            raise TypeError(f"u: expected inputs of shape ({T}, m) or ({T},), received None")
        u = np.zeros((R, T, 0))
    else:
        inputs, u = u, trajectories(u, "u")
        if u.shape[:2] != (R, T):
            raise ValueError(
                f"u: expected {T} rows (one per sample of y)"
                + (f" for each of the {R} series" if R > 1 else "")
                + f", received shape {u.shape[1:] if u.shape[0] == 1 else u.shape}"
            )
        observed_columns(u, "u", "input", inputs)
    if T <= lag:
        raise ValueError(
            f"y: the series is shorter than the lag structure: {structure} reaches back "
            f"{lag} samples, so y needs more than {lag} samples, received T = {T}"
        )
    return y, u


def model_series(
    y: Any, u: Any, *, N: int, n: int, m: int, lag: int
) -> tuple[np.ndarray, np.ndarray]:
    """Data for a fitted AR/ARX model: y (N + lag, n), u (N + lag, m) (None if m = 0)."""
    y, u = lagged_series(y, u, lag, f"the model's lags ({lag})", n_inputs=m, require_inputs=m > 0)
    if y.shape[1] != n:
        raise ValueError(f"y: expected {n} columns (outputs), received {y.shape[1]}")
    if y.shape[0] != N + lag:
        raise ValueError(
            f"y: expected T = {N + lag} samples (the model has N = {N} time steps after "
            f"{lag} initial samples), received T = {y.shape[0]}"
        )
    return y, u


def simulation_inputs(
    y0: Any, u: Any, noise: Any, *, N: int, n: int, m: int, lag: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate an AR/ARX simulation: initial samples, inputs and noise.

    Returns y0 (lag, n), u (N + lag, m) and noise (N, n) (zeros when None).
    ``y0`` may be 1-d when n = 1 and None when lag = 0; ``noise`` 1-d when n = 1.
    """
    T = N + lag
    if y0 is None and lag == 0:
        y0 = np.zeros((0, n))
    else:
        y0 = as_float_array(y0, "y0")
        if y0.ndim == 1 and n == 1:
            y0 = y0[:, None]
        if y0.shape != (lag, n):
            expected = f"({lag}, {n})" + (f" or ({lag},)" if n == 1 else "")
            raise ValueError(
                f"y0: expected the {lag} initial samples y[0:{lag}], shape {expected}, "
                f"received shape {y0.shape}"
            )
    if u is None:
        if m:
            raise TypeError(f"u: expected inputs of shape ({T}, {m}), received None")
        u = np.zeros((T, 0))
    else:
        u = as_time_series(u, "u", allow_1d=True)
        if u.shape != (T, m):
            raise ValueError(
                f"u: expected shape ({T}, {m}) (T = {lag} initial + {N} simulated samples), "
                f"received shape {u.shape}"
            )
    if noise is None:
        noise = np.zeros((N, n))
    else:
        noise = as_float_array(noise, "noise")
        if noise.ndim == 1 and n == 1:
            noise = noise[:, None]
        if noise.shape != (N, n):
            expected = f"({N}, {n})" + (f" or ({N},)" if n == 1 else "")
            raise ValueError(
                f"noise: expected shape {expected} (one e[t] per simulated sample), received "
                f"shape {noise.shape}"
            )
    return y0, u, noise


def dynamics_matrices(model: Any) -> np.ndarray:
    """``model.A`` as a float array of shape (N, n, n), for any object that has one."""
    if not hasattr(model, "A"):
        raise TypeError(
            f"model: expected an object with attribute A (N, n, n) such as an "
            f"LTVModel, received {type(model).__name__}"
        )
    A = np.asarray(model.A, dtype=float)
    if A.ndim != 3 or A.shape[1] != A.shape[2]:
        raise ValueError(f"model.A: expected shape (N, n, n), received {A.shape}")
    return A


def activation_series(value: Any, name: str) -> np.ndarray:
    """Validate an activation a_t = ‖(Dk)_t‖: a 1-d array of finite numbers >= 0."""
    arr = as_float_array(value, name)
    if arr.ndim != 1:
        raise ValueError(
            f"{name}: expected an LTVModel or a 1-d activation array a_t = ‖(Dk)_t‖ "
            f"(for (Dk)_t of shape (L, K) use np.linalg.norm(Dk, axis=1)), received "
            f"{arr.ndim}-d array of shape {arr.shape}"
        )
    if arr.size and arr.min() < 0:
        raise ValueError(
            f"{name}: expected nonnegative activations (norms), received min {arr.min():g} "
            f"at index {int(arr.argmin())}"
        )
    return arr


def changepoint_indices(
    value: Any, N: int, *, last: int, note: str = "", name: str = "changepoints"
) -> np.ndarray:
    """Validate change points: integers in [1, ``last``], strictly increasing.

    A scalar is one change point; an empty sequence none. Unsorted or
    repeated values are an error (never silently sorted or deduplicated).
    Integral floats (200.0) are accepted; booleans are not. ``note`` is added
    to the range message (e.g. why ``last`` is N − 2).

    Returns
    -------
    ndarray of int64, shape (M,)
        A new array.
    """
    if value is None:
        raise TypeError(
            f"{name}: expected a sequence of integer change points (e.g. from "
            "ltvmodels.find_changepoints; [] for none), received None"
        )
    arr = as_float_array(value, name)
    if np.asarray(value.to_numpy() if hasattr(value, "to_numpy") else value).dtype == bool:
        raise TypeError(f"{name}: expected integers, received booleans ({describe(value)})")
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-d sequence of integers, received shape {arr.shape}")
    if np.any(arr != np.round(arr)):
        bad = arr[arr != np.round(arr)][0]
        raise ValueError(f"{name}: expected integers, received {bad:g}")
    outside = (arr < 1) | (arr > last)
    if outside.any():
        raise ValueError(
            f"{name}: expected model indices in [1, {last}] (a change point c starts a new "
            f"segment at model index c; N = {N} model steps{note}), received "
            f"{_integer_text(arr[outside][0])}"
        )
    out = arr.astype(np.int64)
    steps = np.diff(out)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise ValueError(
            f"{name}: expected strictly increasing indices without repeats, received "
            f"{int(out[i])} after {int(out[i - 1])} (position {i}); sort and deduplicate them"
        )
    return out


def _integer_text(value: float) -> str:
    """An integral float as an integer, or in exponent notation when huge."""
    return str(int(value)) if abs(value) < 1e15 else f"{value:g}"


def positive_grid(value: Any, name: str) -> np.ndarray:
    """A non-empty 1-d array of finite values > 0, sorted increasing (a λ grid)."""
    arr = as_float_array(value, name)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-d sequence, received shape {arr.shape}")
    if np.any(arr <= 0):
        raise ValueError(f"{name}: expected values > 0, received a minimum of {arr.min():g}")
    return np.unique(arr)


def count_grid(value: Any, name: str) -> np.ndarray:
    """A non-empty 1-d array of whole numbers >= 0, sorted increasing (numbers of changes)."""
    arr = as_float_array(value, name)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-d sequence, received shape {arr.shape}")
    if np.any(arr < 0) or np.any(arr != np.round(arr)):
        bad = arr[(arr < 0) | (arr != np.round(arr))][0]
        raise ValueError(f"{name}: expected whole numbers >= 0, received {bad:g}")
    return np.unique(arr.astype(np.int64))
