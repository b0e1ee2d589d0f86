"""The time axis of recorded data: checked once, the same for every estimator.

A series whose rows carry time stamps (a pandas index, or the command line's
``--time`` column) is fitted as samples on a regular grid, in time order:

* the stamps must be strictly increasing: unsorted stamps are an error that
  names the first out-of-order row and says to sort; a repeated stamp is an
  error that names it;
* on a regular grid — a constant step (numbers, or a fixed span of time) or a
  calendar frequency (months, years, …, which pandas infers; dates with a
  time zone on their local clock) — stamps missing from the grid become
  missing samples: NaN rows are inserted where they are missing, counted in
  ``model.n_missing``; the estimators say how many in one
  :class:`~ltvmodels.DataWarning` (:attr:`TimeGrid.notice`);
* stamps on no regular grid are an error that says how to resample them, or
  to declare the rows consecutive samples: ``regular=False`` (every estimator
  takes it) keeps the stamps, in order, as the model's time axis and inserts
  nothing.

:class:`TimeGrid` holds the outcome: the grid's stamps and each data row's
place on it.
"""

from __future__ import annotations

import warnings
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["TimeGrid", "continued", "increasing", "preceding", "sampling_period", "time_grid"]

# Steps that differ from a multiple of the smallest one by less than this (relative)
# are on its grid: decimal steps such as 0.1 are not exact in binary.
STEP_TOLERANCE = 1e-9


@dataclass(frozen=True)
class TimeGrid:
    """The regular grid of a series' time stamps and where its rows lie on it.

    Attributes
    ----------
    time : ndarray, shape (T,)
        The stamps of the grid (datetime64[ns] or float).
    positions : ndarray of int, shape (rows,), or None
        The grid index of each data row; None where every stamp of the grid
        has a row (nothing inserted).
    """

    time: np.ndarray
    positions: np.ndarray | None = None

    @property
    def notice(self) -> str:
        """What was inserted, in words (for the warning of the estimator)."""
        count = self.inserted
        return (
            f"{count} time stamp{'s' if count > 1 else ''} missing from the regular grid of "
            f"its index ({_text(self.time[0])} to {_text(self.time[-1])}) were inserted as "
            "missing samples (NaN rows); model.n_missing counts what they leave out"
        )

    @property
    def inserted(self) -> int:
        """How many missing samples (NaN rows) the grid adds to the data."""
        return 0 if self.positions is None else self.time.size - self.positions.size

    def spread(self, rows: np.ndarray) -> np.ndarray:
        """``rows`` (R, rows, d) on the grid (R, T, d), NaN where the grid has no data."""
        if self.positions is None:
            return rows
        out = np.full((rows.shape[0], self.time.size, rows.shape[2]), np.nan)
        out[:, self.positions] = rows
        return out

    def spread_rows(self, weights: np.ndarray | None, lag: int) -> np.ndarray | None:
        """Weights (R, rows − lag) of the equations that predict rows lag, lag + 1, … from
        the ``lag`` rows before them (a transition: lag 1), on the grid (R, T − lag). An
        equation whose lags span inserted samples no longer exists: its weight is dropped
        (the grid's equations there have missing samples; weight 1)."""
        if weights is None or self.positions is None:
            return weights
        out = np.ones((weights.shape[0], self.time.size - lag))
        ends = self.positions[lag:]
        kept = ends - self.positions[: self.positions.size - lag] == lag
        out[:, ends[kept] - lag] = weights[:, kept]
        return out


def time_grid(stamps: np.ndarray, name: str, zone: Any = None, *, regular: bool = True) -> TimeGrid:
    """Check the time stamps of a series and place them on their regular grid.

    Parameters
    ----------
    stamps : ndarray, shape (rows,)
        datetime64 or float time stamps, one per row of the data ``name``: for
        dates with a time ``zone``, the local clock's (the grid of a daily series
        is in local days, whatever daylight saving time does).
    name : str
        The argument the stamps belong to (for messages).
    zone : tzinfo or str, optional
        The time zone of local ``stamps``; the grid's stamps are returned in UTC
        (without a zone), as a model keeps them.
    regular : bool, default True
        False: the rows are consecutive samples whatever their stamps (which must
        still increase); the grid is the stamps themselves, nothing is inserted.

    Returns
    -------
    TimeGrid

    Raises
    ------
    ValueError
        Repeated or unsorted stamps; stamps on no regular grid.
    """
    _check_order(stamps, name)
    if stamps.size < 3 or not regular:
        return TimeGrid(_in_utc(stamps, zone, name))
    grid = _fixed_step_grid(stamps)
    if grid is None and np.issubdtype(stamps.dtype, np.datetime64):
        grid = _calendar_grid(stamps)
    if grid is None:
        steps = np.diff(stamps)
        raise ValueError(
            f"{name}: the time index has no regular grid (steps from {_text(steps.min())} to "
            f"{_text(steps.max())}, not multiples of one step); resample it to one "
            "(df.resample('D').mean(), df.asfreq('h'), …), or pass regular=False to fit "
            "the rows as consecutive samples"
        )
    positions = None if grid.size == stamps.size else np.searchsorted(grid, stamps)
    return TimeGrid(_in_utc(grid, zone, name), positions)


def _in_utc(stamps: np.ndarray, zone: Any, name: str) -> np.ndarray:
    """Local ``stamps`` of ``zone`` in UTC (without a zone); other stamps as they are."""
    if zone is None:
        return stamps
    import pandas as pd

    local = pd.DatetimeIndex(stamps).tz_localize(zone, ambiguous="NaT", nonexistent="NaT")
    if local.hasnans:
        raise ValueError(
            f"{name}: a time stamp of the regular grid of its index does not exist or is "
            "ambiguous on the local clock (a daylight saving time change); convert the "
            "index to UTC first (df.tz_convert('UTC'))"
        )
    return local.tz_convert("UTC").tz_localize(None).to_numpy().astype("datetime64[ns]")


def continued(stamps: np.ndarray, count: int) -> np.ndarray | None:
    """The ``count`` stamps after the end of the regular grid ``stamps`` (a fixed step or a
    calendar frequency: a monthly series goes on with the next months), or None where the
    stamps are on no regular grid (or too few to tell)."""
    step = _grid_step(stamps)
    if step is not None:
        return stamps[-1] + step * np.arange(1, count + 1)
    if stamps.size < 3 or not np.issubdtype(stamps.dtype, np.datetime64):
        return None
    frequency = _frequency(stamps)
    if frequency is None:
        return None
    import pandas as pd  # (_frequency found one: pandas is there)

    after = pd.date_range(stamps[-1], periods=count + 1, freq=frequency)[1:]
    return after.to_numpy().astype("datetime64[ns]")


def preceding(stamps: np.ndarray, count: int) -> np.ndarray | None:
    """The ``count`` stamps before the start of the regular grid ``stamps``, oldest first, or
    None where they cannot be told for certain.

    Numbers go back by their step (at least two stamps); dates by the frequency pandas
    infers from at least three of them (two dates do not tell a month from 31 days) or,
    without one, by a fixed step.
    """
    dated = np.issubdtype(stamps.dtype, np.datetime64)
    if stamps.size < (3 if dated else 2):
        return None
    if dated and (frequency := _frequency(stamps)) is not None:
        import pandas as pd  # (_frequency found one: pandas is there)

        before = pd.date_range(end=stamps[0], periods=count + 1, freq=frequency)[:-1]
        return before.to_numpy().astype("datetime64[ns]")
    grid = _fixed_step_grid(stamps)
    if grid is None or grid.size != stamps.size:
        return None
    if dated:
        step = np.diff(stamps.astype("datetime64[ns]")).min()
    else:
        step = (stamps[-1] - stamps[0]) / (stamps.size - 1)  # the mean: no drift
    return stamps[0] - step * np.arange(count, 0, -1)


def sampling_period(stamps: np.ndarray) -> float | None:
    """The fixed step of increasing stamps without gaps, as a number: in the stamps' unit
    (seconds for dates); None for fewer than two stamps, stamps that do not increase, or
    steps that differ (a calendar frequency, an irregular axis). Steps equal up to the
    rounding of decimal steps such as 0.1 (:data:`STEP_TOLERANCE`) are one step: their
    mean."""
    step = _grid_step(stamps)
    if step is None:
        return None
    if np.issubdtype(stamps.dtype, np.datetime64):
        return float(step / np.timedelta64(1, "s"))
    return float(step)


def _grid_step(stamps: np.ndarray) -> Any:
    """The step of increasing stamps on a fixed-step grid without gaps (a timedelta64 for
    dates, else a float: the mean step, which does not drift), or None."""
    if stamps.size < 2 or not increasing(stamps):
        return None
    grid = _fixed_step_grid(stamps)
    if grid is None or grid.size != stamps.size:
        return None
    if np.issubdtype(stamps.dtype, np.datetime64):
        return np.diff(stamps.astype("datetime64[ns]")).min()
    return (stamps[-1] - stamps[0]) / (stamps.size - 1)


def increasing(stamps: np.ndarray) -> bool:
    """Whether the stamps increase strictly."""
    steps = np.diff(stamps)
    return bool(np.all(steps > np.zeros((), dtype=steps.dtype)))


def _check_order(stamps: np.ndarray, name: str) -> None:
    """Strictly increasing stamps, or an error naming the first row that is not."""
    if increasing(stamps):
        return
    steps = np.diff(stamps)
    zero = np.zeros((), dtype=steps.dtype)
    first = int(np.flatnonzero(~(steps > zero))[0]) + 1
    if steps[first - 1] == zero:
        raise ValueError(
            f"{name}: the time stamp {_text(stamps[first])} appears twice (rows {first - 1} "
            f"and {first}); each sample needs its own time: drop or average the duplicates "
            "(df[~df.index.duplicated()] or df.groupby(level=0).mean())"
        )
    raise ValueError(
        f"{name}: the time index is not sorted: row {first} ({_text(stamps[first])}) comes "
        f"after row {first - 1} ({_text(stamps[first - 1])}); sort the rows by time "
        "(df.sort_index())"
    )


def _fixed_step_grid(stamps: np.ndarray) -> np.ndarray | None:
    """The grid of the smallest step when every step is a multiple of it, else None."""
    dated = np.issubdtype(stamps.dtype, np.datetime64)
    values = stamps.astype("datetime64[ns]").astype(np.int64) if dated else stamps
    steps = np.diff(values)
    step = steps.min()
    multiples = steps / step
    rounded = np.round(multiples)
    if np.any(np.abs(multiples - rounded) > STEP_TOLERANCE * rounded):
        return None
    count = int(rounded.sum()) + 1
    if dated:
        return (values[0] + step * np.arange(count, dtype=np.int64)).view("datetime64[ns]")
    offsets = np.concatenate([[0], np.cumsum(rounded)])  # the stamps' places
    grid = values[0] + step * np.arange(count, dtype=float)
    grid[offsets.astype(int)] = values  # the given stamps exactly, the others by the step
    return grid


def _calendar_grid(stamps: np.ndarray) -> np.ndarray | None:
    """The grid of a calendar frequency (months, quarters, years, business days) that
    pandas infers from runs of consecutive stamps, if every stamp lies on it."""
    if _frequency(stamps) is not None:  # no gaps
        return stamps.astype("datetime64[ns]")
    import pandas as pd  # (without pandas _frequency is None: no calendar grid below)

    guesses = Counter(
        frequency
        for start in range(0, min(stamps.size - 2, 60))
        if (frequency := _frequency(stamps[start : start + 3])) is not None
    )
    index = pd.DatetimeIndex(stamps)
    for frequency, _ in guesses.most_common(2):
        grid = pd.date_range(index[0], index[-1], freq=frequency)
        if grid.size <= 100 * index.size and index.isin(grid).all():
            return grid.to_numpy().astype("datetime64[ns]")
    return None


def _frequency(stamps: np.ndarray) -> str | None:
    """The calendar frequency pandas infers from consecutive dates (None: none, or no
    pandas)."""
    try:
        import pandas as pd
    except ImportError:  # pragma: no cover - without pandas only fixed steps
        return None
    with warnings.catch_warnings():  # pandas' notices about infer_freq's future return type
        warnings.simplefilter("ignore")
        return pd.infer_freq(pd.DatetimeIndex(stamps))


def _text(value: Any) -> str:
    """A stamp or step as people read it."""
    if isinstance(value, np.datetime64):
        return str(value.astype("datetime64[s]")).replace("T00:00:00", "")
    if isinstance(value, np.timedelta64):
        return str(value.astype("timedelta64[s]"))
    return f"{float(value):g}"
