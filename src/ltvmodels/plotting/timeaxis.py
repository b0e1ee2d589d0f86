"""The time axis of the figures: the data's time stamps, or sample indices, and their units.

Every figure drawn over time places its points on the data's time axis: a
model's ``time`` (dates as datetime64, or numbers such as years), or the
sample indices 0, 1, … when it has none. Dates are drawn on a matplotlib date
axis (a date locator and a concise formatter, so that the tick labels stay
short and apart), numbers as numbers. The x label names the axis: the time
column's or index's name where the data had one, else "time"; "sample" for
sample indices.

A model step t is drawn at the sample it produces, ``t + model.produced_offset``
(y[t] of a regression, y[lag + t] of an AR/ARX model, x[t + 1] of a state-space
model), so that a change at step c shows at ``model.changepoint_times``, where
its markers are.

Frequencies (spectrograms) are in cycles per unit of the axis
(:func:`spectral_units`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..validation import arrays

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = [
    "SAMPLE_LABEL",
    "TIME_LABEL",
    "TimeAxis",
    "sample_axis",
    "step_axis",
    "given_axis",
    "spectral_units",
]

SAMPLE_LABEL = "sample"
"""The label of an axis of sample indices (data without a time axis)."""

TIME_LABEL = "time"
"""The label of a time axis whose name is not known."""

TIME_UNITS = ("year", "quarter", "month", "week", "day", "hour", "minute", "second")
"""Names of a numeric time axis (singular or plural) that are its unit: a yearly index
named "year" gives frequencies in cycles per year."""

TICK_SPACING_INCHES = 0.4
"""The width a date tick needs: a concise date label ("2021", "Feb", "12:00") and a gap."""

DAYS_PER_MONTH = 365.2425 / 12
"""The mean length of a calendar month (Gregorian), in days."""

SPANS = (("day", 86400.0), ("hour", 3600.0), ("minute", 60.0), ("second", 1.0))
"""Units of a fixed step of dates, largest first, in seconds: a step of at least a day
gives cycles per day, of at least an hour cycles per hour, and so on."""


@dataclass(frozen=True)
class TimeAxis:
    """Positions along a figure's time axis and the axis' name.

    Attributes
    ----------
    values : ndarray, shape (count,)
        datetime64[ns] dates, numbers, or sample indices (integers).
    label : str
        The x label: the time axis' name, :data:`TIME_LABEL` or :data:`SAMPLE_LABEL`.
    """

    values: np.ndarray
    label: str

    @property
    def dated(self) -> bool:
        """Whether the axis holds dates."""
        return np.issubdtype(self.values.dtype, np.datetime64)

    @property
    def samples(self) -> bool:
        """Whether the axis holds sample indices (no time axis)."""
        return self.label == SAMPLE_LABEL and np.issubdtype(self.values.dtype, np.integer)

    def draw_on(self, ax: Axes, *, label: bool = True) -> None:
        """Give ``ax`` this x axis: its label (unless ``label`` is False) and, for dates, a
        date locator with a concise formatter (short labels that do not overlap)."""
        if label:
            ax.set_xlabel(self.label)
        if self.dated:
            from matplotlib.dates import AutoDateLocator, ConciseDateFormatter

            locator = AutoDateLocator(minticks=2, maxticks=_date_ticks(ax))
            ax.xaxis.set_major_locator(locator)
            ax.xaxis.set_major_formatter(ConciseDateFormatter(locator))

    def at(self, samples: np.ndarray) -> np.ndarray:
        """The axis' positions at fractional sample indices (linear between samples)."""
        index = np.arange(self.values.size)
        if self.dated:
            nanoseconds = self.values.astype("datetime64[ns]").astype(np.int64)
            between = np.interp(samples, index, nanoseconds.astype(float))
            return np.round(between).astype(np.int64).view("datetime64[ns]")
        return np.interp(samples, index, self.values.astype(float))

    def text(self, positions: np.ndarray) -> list[str]:
        """Positions of this axis as text (legends): dates as YYYY-MM-DD (to the second with
        a time of day), sample indices as integers, numbers as numbers."""
        if np.issubdtype(np.asarray(positions).dtype, np.integer):
            return [str(int(value)) for value in positions]
        if not self.dated:
            return [f"{value:g}" for value in np.asarray(positions, dtype=float)]
        positions = np.asarray(positions).astype("datetime64[ns]")
        unit: Literal["D", "s"] = (
            "D" if np.all(positions.astype("datetime64[D]") == positions) else "s"
        )
        return [str(text) for text in np.datetime_as_string(positions, unit=unit)]


def _date_ticks(ax: Axes) -> int:
    """The most date ticks ``ax`` has room for: one per 0.4 inch of its width (a concise
    date label is at most five characters), 3 to 12."""
    inches = ax.bbox.width / ax.figure.dpi
    return int(np.clip(inches / TICK_SPACING_INCHES, 3, 12))


def sample_axis(model: Any, first: int, count: int) -> TimeAxis:
    """The data samples ``first`` … ``first + count − 1`` of ``model``: their times (its
    ``time``, named by ``model.data.time_name``), or their indices without a time axis."""
    time = getattr(model, "time", None)
    if time is None:
        return TimeAxis(np.arange(first, first + count), SAMPLE_LABEL)
    time = np.asarray(time)
    if time.ndim != 1 or time.size < first + count:
        raise ValueError(
            f"model.time: expected at least {first + count} times (one per sample of the "
            f"data), received shape {time.shape}"
        )
    name = getattr(getattr(model, "data", None), "time_name", None)
    return TimeAxis(time[first : first + count], name or TIME_LABEL)


def step_axis(model: Any, count: int) -> TimeAxis:
    """Where the model steps t = 0 … count − 1 are drawn: at the sample each produces,
    t + ``model.produced_offset`` (0 for an object without one)."""
    return sample_axis(model, int(getattr(model, "produced_offset", 0)), count)


def given_axis(time: Any, count: int, name: str) -> TimeAxis:
    """The time axis of ``count`` samples given by the argument ``name``.

    Parameters
    ----------
    time : array_like, shape (count,), or pandas Index or Series
        Dates (datetime64, pandas Timestamps; a time zone is converted to UTC) or
        numbers, strictly increasing. A pandas object's name labels the axis.
    count : int
        The number of samples.
    name : str
        The argument (for messages).

    Raises
    ------
    TypeError
        Times that are neither dates nor numbers.
    ValueError
        Another length, or times that do not increase.
    """
    label = TIME_LABEL
    if hasattr(time, "to_numpy"):  # a pandas Index or Series
        import pandas as pd

        index = pd.Index(time)
        label = TIME_LABEL if index.name is None else str(index.name)
        values = np.asarray(arrays.index_values(index))
    else:
        values = np.asarray(time)
    if values.dtype.kind == "M":
        values = values.astype("datetime64[ns]")
    elif values.dtype.kind not in "iuf":
        raise TypeError(
            f"{name}: expected dates (datetime64, pandas Timestamps) or numbers, received "
            f"{arrays.describe(time)}; convert the times (e.g. pandas.to_datetime)"
        )
    if values.shape != (count,):
        raise ValueError(
            f"{name}: expected {count} times (one per sample), received shape {values.shape}"
        )
    steps = np.diff(values)
    if not np.all(steps > np.zeros((), dtype=steps.dtype)):
        row = int(np.flatnonzero(~(steps > np.zeros((), dtype=steps.dtype)))[0]) + 1
        raise ValueError(
            f"{name}: expected strictly increasing times, received {values[row]} at row "
            f"{row} after {values[row - 1]}; sort the data by time"
        )
    return TimeAxis(values, label)


def spectral_units(axis: TimeAxis, fs: float | None) -> tuple[float, str, TimeAxis]:
    """The sampling frequency, its unit and the time axis of a spectrogram over ``axis``.

    With a given ``fs`` (Hz): that, "Hz", and ``axis`` (sample indices become
    seconds, sample / fs). Without: from the axis' step, in cycles per its unit —
    numbers: 1 / step, per the unit its name is (:data:`TIME_UNITS`, e.g. "year"),
    else per "time unit"; dates: per month for monthly data (1 / n for every n
    months), per year for quarterly or longer steps (12 / months), per business day
    for business days, per day, hour, minute or second for a fixed step (the largest
    of them the step spans); sample indices (or a single time): 1 cycle per sample.

    Returns
    -------
    fs : float
    unit : str
        "Hz", or "cycles per …".
    axis : TimeAxis
        The time axis to draw against.
    """
    if fs is not None:
        if axis.samples:
            return fs, "Hz", TimeAxis(axis.values / fs, "time (s)")
        return fs, "Hz", axis
    if axis.samples or axis.values.size < 2:
        return 1.0, "cycles per sample", axis
    if axis.dated:
        rate, unit = _dated_rate(axis.values)
        return rate, f"cycles per {unit}", axis
    step = float(np.median(np.diff(axis.values.astype(float))))
    word = axis.label.strip().lower()
    singular = word[:-1] if word.endswith("s") else word
    unit = singular if singular in TIME_UNITS else "time unit"
    return 1.0 / step, f"cycles per {unit}", axis


def _dated_rate(values: np.ndarray) -> tuple[float, str]:
    """Samples per unit of a regular date axis, and the unit (see :func:`spectral_units`)."""
    offset = _inferred_offset(values)
    months = _whole_months(values) if offset is None else _months_of(offset)
    if months is not None:
        return (12.0 / months, "year") if months >= 3 else (1.0 / months, "month")
    if offset is not None and offset.rule_code == "B":  # weekends are no samples
        return 1.0 / abs(int(offset.n)), "business day"
    seconds = _median_step_seconds(values)
    unit, span = next(((unit, span) for unit, span in SPANS if seconds >= span), SPANS[-1])
    return span / seconds, unit


def _whole_months(values: np.ndarray) -> int | None:
    """The whole calendar months of the median step of a date axis, or None."""
    days = _median_step_seconds(values) / 86400.0
    months = round(days / DAYS_PER_MONTH)
    # a month has 28 to 31 days: a step within 3 days of whole months is calendar months
    return months if months >= 1 and abs(days - months * DAYS_PER_MONTH) <= 3.0 else None


def _inferred_offset(values: np.ndarray) -> Any:
    """The pandas offset of the frequency pandas infers from the dates; None without one
    (fewer than 3 dates, none inferred, or no pandas)."""
    if values.size < 3:
        return None
    try:
        import pandas as pd
    except ImportError:  # pragma: no cover - pandas is installed wherever tests run
        return None
    with warnings.catch_warnings():  # pandas' notices about infer_freq's future return type
        warnings.simplefilter("ignore")
        frequency = pd.infer_freq(pd.DatetimeIndex(values))
    return None if frequency is None else pd.tseries.frequencies.to_offset(frequency)


def _months_of(offset: Any) -> int | None:
    """The calendar months of one step of a pandas offset; None for a fixed span (days,
    hours, business days, weeks, …)."""
    import pandas as pd

    months = {
        pd.offsets.MonthBegin: 1,
        pd.offsets.MonthEnd: 1,
        pd.offsets.BusinessMonthBegin: 1,
        pd.offsets.BusinessMonthEnd: 1,
        pd.offsets.QuarterBegin: 3,
        pd.offsets.QuarterEnd: 3,
        pd.offsets.BQuarterBegin: 3,
        pd.offsets.BQuarterEnd: 3,
        pd.offsets.YearBegin: 12,
        pd.offsets.YearEnd: 12,
        pd.offsets.BYearBegin: 12,
        pd.offsets.BYearEnd: 12,
    }.get(type(offset))
    return None if months is None else months * abs(int(offset.n))


def _median_step_seconds(values: np.ndarray) -> float:
    """The median step of a date axis, in seconds."""
    steps = np.diff(values.astype("datetime64[ns]")).astype(np.int64)
    return float(np.median(steps)) / 1e9
