"""Data files of the command line: CSV (a file or standard input) and Parquet, by column.

DATA is a CSV file (comma, semicolon or tab separated, detected from the first
line; lines starting with ``#`` are comments), ``-`` for CSV on standard input,
or a Parquet file (``.parquet``, ``.pq``; needs pandas with pyarrow or
fastparquet). Columns are chosen by name or 0-based index, comma-separated; only
the chosen columns must be numeric.

The first line of a CSV file is its header of column names when one of its
fields is not a number. A first line of numbers and missing values only is
ambiguous — a header ``0,1,2`` as pandas writes integer column names, or the
first data row — and an error unless ``--header`` (it names the columns) or
``--no-header`` (it is data; the columns are named by their 0-based index)
says which; both options also override the rule above.
An empty cell, ``NA``, ``N/A``, ``NaN`` or ``null`` (any case) is a missing value
and reads as NaN (Parquet: a null or NaN); the estimators leave out the
transitions it touches. Infinities are errors.
"""

from __future__ import annotations

import csv
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import OutputPathError
from .messages import DataError, one_line

__all__ = ["PARQUET_SUFFIXES", "parse_times", "read_columns", "write_csv"]

PARQUET_SUFFIXES = (".parquet", ".pq")
_MISSING_TOKENS = ("", "na", "n/a", "nan", "null")
"""CSV fields (compared in lower case, after stripping) that mark a missing value."""
_MISSING_HELP = "an empty cell, NA, N/A, NaN or null"


@dataclass
class _Source:
    """An opened data source: column names and a reader of selected columns."""

    label: str
    names: list[str]
    read: Callable[[list[int]], np.ndarray]
    text: Callable[[int], list[str]]  # one column's fields as text ("" where missing)


def _display(path: Any) -> str:
    return "standard input" if str(path) == "-" else str(path)


def _open_source(path: Any, header: bool | None) -> _Source:
    """Open DATA (CSV, '-' for CSV on stdin, or Parquet) and read its column names;
    ``header`` says whether a CSV's first line names the columns (None: see the module
    docstring)."""
    label = _display(path)
    if str(path) != "-":
        p = Path(path)
        if not p.exists():
            raise DataError(f"{label}: no such file")
        if p.is_dir():
            raise DataError(f"{label}: is a directory, expected a data file")
        if p.suffix.lower() in PARQUET_SUFFIXES:
            if header is not None:
                raise DataError(
                    f"--{'' if header else 'no-'}header: {label} is a Parquet file, whose "
                    "columns always have names; leave the option out"
                )
            return _open_parquet(p)
        try:
            with open(p, encoding="utf-8-sig", newline="") as fh:
                text = fh.read()
        except UnicodeDecodeError:
            raise DataError(f"{label}: not a UTF-8 text (CSV) file") from None
        except OSError as exc:
            raise DataError(f"{label}: cannot read: {exc.strerror or exc}") from None
    else:
        text = sys.stdin.read()
        if text.startswith("\ufeff"):
            text = text[1:]
    return _parse_csv(text, label, header)


def _open_parquet(path: Path) -> _Source:
    try:
        import pandas as pd
    except ImportError:
        raise DataError(
            f"{path}: reading Parquet needs pandas with pyarrow or fastparquet "
            "(pip install pandas pyarrow), or convert the data to CSV"
        ) from None
    try:
        frame = pd.read_parquet(path)
    except ImportError:
        raise DataError(
            f"{path}: reading Parquet needs pyarrow or fastparquet (pip install "
            "pyarrow), or convert the data to CSV"
        ) from None
    except Exception as exc:  # pyarrow raises its own error types on corrupt files
        raise DataError(f"{path}: cannot read as Parquet: {one_line(exc)}") from None
    names = [str(c) for c in frame.columns]

    def read(indices: list[int]) -> np.ndarray:
        out = np.empty((len(frame), len(indices)))
        for j, i in enumerate(indices):
            column = frame.iloc[:, i]
            try:  # nulls (None, pd.NA, NaT) are missing values: NaN
                out[:, j] = column.to_numpy(dtype=float, na_value=np.nan)
            except (TypeError, ValueError):
                raise DataError(
                    f"{path}: column {names[i]!r} is not numeric (dtype {column.dtype})"
                ) from None
            bad = np.isinf(out[:, j])
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                raise DataError(
                    f"{path}: row {row}, column {names[i]!r}: value "
                    f"{float(out[row, j])} is not finite; expected a finite number, "
                    "or a null or NaN for a missing value"
                )
        return out

    def text(index: int) -> list[str]:
        column = frame.iloc[:, index]
        return [
            "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)
            for value in column.astype(object).where(column.notna(), None)
        ]

    return _Source(str(path), names, read, text)


def _is_missing(text: str) -> bool:
    """Whether a (stripped) CSV field marks a missing value."""
    return text.lower() in _MISSING_TOKENS


def _is_number(text: str) -> bool:
    """Whether a CSV field is a number or a missing value (a data field, not a name)."""
    if _is_missing(text):
        return True
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_csv(text: str, label: str, header: bool | None) -> _Source:
    """Split CSV text into rows (lazily converted per column) and find the header."""
    lines = text.splitlines()
    numbered = [
        (i + 1, line)
        for i, line in enumerate(lines)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not numbered:
        raise DataError(f"{label}: empty file (no header and no data rows)")
    first = numbered[0][1]
    counts = {d: first.count(d) for d in (",", ";", "\t")}
    delimiter = max(counts, key=lambda d: counts[d]) if any(counts.values()) else ","
    reader = csv.reader([line for _, line in numbered], delimiter=delimiter)
    try:
        rows = [[field.strip() for field in row] for row in reader]
    except csv.Error as exc:
        raise DataError(f"{label}: not a valid CSV file: {exc}") from None
    has_header = _has_header(rows[0], numbered[0], label) if header is None else header
    if has_header:
        names = rows[0]
        data_rows, line_numbers = rows[1:], [n for n, _ in numbered[1:]]
    else:
        names = [str(i) for i in range(len(rows[0]))]
        data_rows, line_numbers = rows, [n for n, _ in numbered]
    if not data_rows:
        raise DataError(f"{label}: no data rows after the header")
    width = len(names)
    for row, line in zip(data_rows, line_numbers, strict=True):
        if len(row) != width:
            raise DataError(
                f"{label}, line {line}: expected {width} fields (as the "
                f"{'header' if has_header else 'first row'}), received {len(row)}"
            )

    def read(indices: list[int]) -> np.ndarray:
        out = np.empty((len(data_rows), len(indices)))
        for j, i in enumerate(indices):
            for r, row in enumerate(data_rows):
                field = row[i]
                if _is_missing(field):
                    out[r, j] = math.nan
                    continue
                try:
                    value = float(field)
                except ValueError:
                    raise DataError(
                        f"{label}, line {line_numbers[r]}, column {names[i]!r}: "
                        f"{field!r} is not a number; expected a number, or "
                        f"{_MISSING_HELP} for a missing value"
                    ) from None
                if math.isinf(value):
                    raise DataError(
                        f"{label}, line {line_numbers[r]}, column {names[i]!r}: "
                        f"{field!r} is not finite; expected a finite number, or "
                        f"{_MISSING_HELP} for a missing value"
                    )
                out[r, j] = value  # float() also reads 'nan', '-nan': missing
        return out

    def column_text(index: int) -> list[str]:
        return ["" if _is_missing(row[index]) else row[index] for row in data_rows]

    return _Source(label, names, read, column_text)


def _has_header(fields: list[str], first: tuple[int, str], label: str) -> bool:
    """Whether a CSV's first line (its ``fields``; ``first``: its number and text) is a
    header: yes when a field is not a number; a line of numbers and missing values only
    is an error, which says how to declare it."""
    if not all(_is_number(field) for field in fields):
        return True
    number, line = first
    shown = line if len(line) <= 40 else line[:37] + "..."
    raise DataError(
        f"{label}, line {number}: the first line {shown!r} holds only numbers and missing "
        "values, so it could be column names or data; pass --header if it names the "
        "columns, --no-header if it is the first data row"
    )


def _resolve(source: _Source, spec: str, option: str) -> list[int]:
    """Column indices of a comma-separated list of names or 0-based indices."""
    tokens = [token.strip() for token in spec.split(",")]
    if not spec.strip() or any(token == "" for token in tokens):
        raise DataError(
            f"{option}: expected comma-separated column names or 0-based indices, received {spec!r}"
        )
    indices = []
    for token in tokens:
        matches = [i for i, name in enumerate(source.names) if name == token]
        if len(matches) > 1:
            raise DataError(
                f"{option}: column name {token!r} appears {len(matches)} times in "
                f"{source.label}; select it by index"
            )
        if matches:
            indices.append(matches[0])
        elif token.isdigit() and int(token) < len(source.names):
            indices.append(int(token))
        else:
            shown = ", ".join(source.names[:20]) + (", ..." if len(source.names) > 20 else "")
            what = "index" if token.isdigit() else "column"
            raise DataError(f"{option}: no {what} {token!r} in {source.label} (columns: {shown})")
    if len(set(indices)) != len(indices):
        raise DataError(f"{option}: a column is selected twice in {spec!r}")
    for position, i in enumerate(indices):  # (selected by index: names need not differ)
        same = [j for j in indices[:position] if source.names[j] == source.names[i]]
        if same:
            raise DataError(
                f"{option}: columns {same[0]} and {i} of {source.label} are both named "
                f"{source.names[i]!r}, and the model names its signals by their columns; "
                "rename one of them in the file"
            )
    return indices


def read_columns(
    path: Any, *, header: bool | None, **selections: str | None
) -> tuple[int, str, dict[str, Any]]:
    """Read the selected numeric columns of DATA (see the module docstring).

    ``header`` says whether a CSV file's first line names its columns (``--header``,
    ``--no-header``; None: when a field is not a number, see the module docstring).
    ``selections`` maps an option name (``state="x1,x2"``) to comma-separated
    column names or 0-based indices, or None. Returns (T, the file's label,
    {option: (names, values (T, k)) or None}). A column may be in one
    selection only; every user error is a :class:`DataError`.
    """
    source = _open_source(path, header)
    resolved: dict[str, list[int] | None] = {}
    seen: dict[int, str] = {}
    for key, spec in selections.items():
        if spec is None:
            resolved[key] = None
            continue
        option = "--" + key.replace("_", "-")
        chosen = _resolve(source, spec, option)
        for i in chosen:
            if i in seen:
                raise DataError(
                    f"{option}: column {source.names[i]!r} is also selected by {seen[i]}"
                )
            seen[i] = option
        resolved[key] = chosen
    columns: dict[str, Any] = {}
    T = 0
    for key, indices in resolved.items():
        if indices is None:
            columns[key] = None
            continue
        if key == "time":  # dates or numbers, see parse_times
            if len(indices) != 1:
                raise DataError(f"--time: expected one column, received {selections[key]!r}")
            values = parse_times(source.text(indices[0]), source.label, source.names[indices[0]])
        else:
            values = source.read(indices)
        T = values.shape[0]
        columns[key] = ([source.names[i] for i in indices], values)
    return T, source.label, columns


def parse_times(fields: list[str], label: str, name: str) -> np.ndarray:
    """A time column: numbers (float), or ISO 8601 dates and times (datetime64[ns]).

    Every field must be given (a time cannot be missing) and of one kind: the
    rule of every command's ``--time``.

    Parameters
    ----------
    fields : list of str
        The column's fields as text, "" where missing.
    label, name : str
        The data file and the column, as the messages name them.

    Returns
    -------
    ndarray, shape (T,)
        float or datetime64[ns].

    Raises
    ------
    DataError
        A missing time, or a field that is neither a number nor an ISO 8601 date.
    """
    if "" in fields:
        row = fields.index("")
        raise DataError(
            f"{label}, column {name!r}: the time of row {row} is missing; every "
            "sample needs its time"
        )
    try:
        return np.array([float(field) for field in fields])
    except ValueError:
        pass
    try:
        return np.array([np.datetime64(field) for field in fields]).astype("datetime64[ns]")
    except ValueError as exc:
        raise DataError(
            f"{label}, column {name!r}: {one_line(exc)}; expected numbers or ISO "
            "8601 dates and times (YYYY-MM-DD, YYYY-MM-DDTHH:MM:SS)"
        ) from None


def write_csv(
    path: Path, names: list[str], columns: np.ndarray, option: str, index: list[str] | None = None
) -> None:
    """Write a header and rows of numbers (12 significant digits) as CSV; with ``index``
    (one text per row, e.g. dates) as the first column."""
    try:
        with open(path, "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            writer.writerow(names)
            for r, row in enumerate(columns):
                cells = [f"{v:.12g}" for v in row]
                writer.writerow(cells if index is None else [index[r], *cells])
    except OSError as exc:
        raise OutputPathError(
            f"{option}: cannot write {str(path)!r}: {exc.strerror or exc}"
        ) from exc
