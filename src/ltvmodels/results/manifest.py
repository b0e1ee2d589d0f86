"""``manifest.json``: how a model set on disk names its units, model files and summary.

A model-set directory (:meth:`ltvmodels.ModelSet.save`,
``fit_many(models_dir=...)``) holds one ``.npz`` model file per fitted unit
and ``manifest.json``, a JSON object::

    {"format": 2, "by": "unit", "units": [
        {"unit": "m0", "file": "unit-000000.npz", "error": null, "summary": {...}},
        {"unit": {"type": "pandas.Timestamp", "value": "2024-01-01T00:00:00"},
         "file": null, "error": "ValueError: ...", "summary": {...}}]}

one entry per unit in input order: the unit, the name of its model file in
the directory (null when not fitted or not kept), its error (null when
fitted) and its summary record without the unit.

Units keep their type: a string, an integer, a float, a bool or null are
stored as themselves (numpy integers, floats and bools as their Python
equivalents); the other supported types as ``{"type": ..., "value": ...}``
(see :data:`UNIT_TYPES`). Format 1 (ltvmodels 0.3 development versions)
stored units that are not strings or numbers as their text; it is still read.

The manifest is encoded completely before it is written, and written under a
temporary name in the same directory that then replaces ``manifest.json``: a
failure never leaves a half-written manifest.
"""

from __future__ import annotations

import datetime
import json
import os
import sys
import uuid
from collections.abc import Iterable
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any

import numpy as np

from ..errors import ModelFileError, OutputPathError

__all__ = [
    "MANIFEST",
    "check_units",
    "model_file_name",
    "plain_file_name",
    "output_directory",
    "manifest_text",
    "write_manifest",
    "read_manifest",
]

MANIFEST = "manifest.json"
FORMAT_VERSION = 2
READ_FORMATS = (1, 2)

UNIT_TYPES = (
    "str, int, float, bool, None (numpy integers, floats and bools too), datetime.datetime, "
    "datetime.date, datetime.time, datetime.timedelta, pandas.Timestamp (with its time "
    "zone), pandas.Timedelta, numpy.datetime64, numpy.timedelta64, uuid.UUID, and tuples "
    "of these"
)
"""The types of units a manifest stores (as the error messages list them)."""


# -- units --------------------------------------------------------------------------------
def _type_name(value: Any) -> str:
    """``module.Name`` of a value's type (``builtins.`` left out)."""
    kind = type(value)
    return (
        kind.__qualname__
        if kind.__module__ == "builtins"
        else f"{kind.__module__}.{kind.__qualname__}"
    )


def _zone_name(zone: Any) -> str | None:
    """The IANA name of a time zone (zoneinfo, pytz, UTC), or None for a fixed offset."""
    if zone is None:
        return None
    name = getattr(zone, "key", None) or getattr(zone, "zone", None)
    if isinstance(name, str):
        return name
    if zone is datetime.timezone.utc or str(zone) == "UTC":
        return "UTC"
    return None


def _encoded_instant(kind: str, instant: datetime.datetime) -> dict:
    """A date and time (``pandas.Timestamp`` or ``datetime.datetime``) with its time zone."""
    encoded = {"type": kind, "value": instant.isoformat()}
    zone = _zone_name(instant.tzinfo)
    if zone is not None:
        encoded["tz"] = zone
    return encoded


def _encode_unit(unit: Any) -> Any:
    """A unit as the manifest stores it (see the module docstring).

    Parameters
    ----------
    unit : hashable
        A unit of a model set.

    Returns
    -------
    str, int, float, bool, None or dict
        The unit itself for JSON's own types, ``{"type": ..., "value": ...}``
        for the others.

    Raises
    ------
    TypeError
        A unit of a type the manifest cannot store (:data:`UNIT_TYPES`).
    """
    if unit is None or type(unit) in (str, bool, int, float):
        return unit
    if isinstance(unit, (bool, np.bool_)):
        return bool(unit)
    if isinstance(unit, str):  # numpy.str_ and other subclasses
        return str(unit)
    pandas = sys.modules.get("pandas")  # a pandas value means pandas is imported
    if pandas is not None:
        if isinstance(unit, pandas.Timestamp):
            return _encoded_instant("pandas.Timestamp", unit)
        if isinstance(unit, pandas.Timedelta):
            return {"type": "pandas.Timedelta", "value": unit.isoformat()}
    if isinstance(unit, np.timedelta64):  # a numpy integer too
        return {
            "type": "numpy.timedelta64",
            "value": int(unit.astype(np.int64)),
            "dtype": str(unit.dtype),
        }
    if isinstance(unit, (int, np.integer)):
        return int(unit)
    if isinstance(unit, (float, np.floating)) and not isinstance(unit, np.longdouble):
        return float(unit)
    if isinstance(unit, datetime.datetime):
        return _encoded_instant("datetime.datetime", unit)
    if isinstance(unit, datetime.date):
        return {"type": "datetime.date", "value": unit.isoformat()}
    if isinstance(unit, datetime.time) and unit.tzinfo is None:
        return {"type": "datetime.time", "value": unit.isoformat()}
    if isinstance(unit, datetime.timedelta):
        return {
            "type": "datetime.timedelta",
            "value": [unit.days, unit.seconds, unit.microseconds],
        }
    if isinstance(unit, np.datetime64):
        return {
            "type": "numpy.datetime64",
            "value": str(np.datetime_as_string(unit)),
            "dtype": str(unit.dtype),
        }
    if isinstance(unit, uuid.UUID):
        return {"type": "uuid.UUID", "value": str(unit)}
    if isinstance(unit, tuple) and type(unit) is tuple:
        return {"type": "tuple", "value": [_encode_unit(item) for item in unit]}
    raise TypeError(
        f"unit {_short_repr(unit)} is of type {_type_name(unit)}, which a model set's "
        f"manifest cannot store; supported unit types: {UNIT_TYPES}; relabel the units "
        "(e.g. as text)"
    )


def _decode_unit(value: Any) -> Any:
    """The unit that :func:`_encode_unit` stored as ``value``.

    Parameters
    ----------
    value : str, int, float, bool, None or dict
        A unit as the manifest stores it.

    Returns
    -------
    hashable
        The unit.

    Raises
    ------
    ValueError
        ``value`` is not an encoded unit (the message says why).
    """
    if value is None or type(value) in (str, bool, int, float):
        return value
    if not isinstance(value, dict):
        raise ValueError(
            f"expected a text, a number, a bool, null or an object {{type, value}}, "
            f"received {_short_repr(value)} ({_type_name(value)})"
        )
    kind: Any = value.get("type")
    text: Any = value.get("value")
    try:
        if kind == "pandas.Timestamp":
            import pandas as pd

            stamp = pd.Timestamp(text)
            return stamp if "tz" not in value else stamp.tz_convert(value["tz"])
        if kind == "pandas.Timedelta":
            import pandas as pd

            return pd.Timedelta(text)
        if kind == "datetime.datetime":
            moment = datetime.datetime.fromisoformat(text)
            return moment if "tz" not in value else moment.astimezone(_time_zone(value["tz"]))
        if kind == "datetime.date":
            return datetime.date.fromisoformat(text)
        if kind == "datetime.time":
            return datetime.time.fromisoformat(text)
        if kind == "datetime.timedelta":
            days, seconds, microseconds = text
            return datetime.timedelta(days=days, seconds=seconds, microseconds=microseconds)
        if kind == "numpy.datetime64":
            return np.datetime64(text).astype(np.dtype(value["dtype"]))
        if kind == "numpy.timedelta64":
            if type(text) is not int:
                raise TypeError(f"expected an integer count, received {text!r}")
            return np.int64(text).astype(np.dtype(value["dtype"]))
        if kind == "uuid.UUID":
            return uuid.UUID(text)
        if kind == "tuple":
            if not isinstance(text, list):
                raise TypeError(f"expected a list of units, received {text!r}")
            return tuple(_decode_unit(item) for item in text)
    except (TypeError, ValueError, KeyError, OverflowError, ImportError) as exc:
        raise ValueError(f"{_short_repr(value)} is not a valid {kind} ({exc})") from None
    raise ValueError(f"unknown unit type {kind!r} in {_short_repr(value)}")


def _time_zone(name: Any) -> datetime.tzinfo:
    """The time zone called ``name`` (an IANA name such as "Europe/Paris", or "UTC")."""
    if name == "UTC":
        return datetime.timezone.utc
    from zoneinfo import ZoneInfo

    return ZoneInfo(name)


def check_units(units: Iterable, name: str) -> None:
    """Raise, before anything is written, if a manifest cannot store one of ``units``.

    Parameters
    ----------
    units : iterable
        The units of a model set.
    name : str
        The argument the units come from (the start of the message).

    Raises
    ------
    TypeError
        A unit of a type the manifest cannot store; the message names it,
        its type and the supported types.
    """
    for unit in units:
        try:
            _encode_unit(unit)
        except TypeError as exc:
            raise TypeError(f"{name}: {exc}") from None


def _short_repr(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# -- model file names ------------------------------------------------------------------------
def model_file_name(position: int) -> str:
    """The model file of the unit at ``position`` in the input order.

    Parameters
    ----------
    position : int
        The unit's position.

    Returns
    -------
    str
        ``unit-<position, six digits or more>.npz``.
    """
    return f"unit-{position:06d}.npz"


def plain_file_name(name: Any) -> bool:
    """Whether ``name`` names a file inside a directory: no separator, drive, ``.`` or ``..``.

    Parameters
    ----------
    name : object
        A file name read from a manifest.

    Returns
    -------
    bool
        True for a non-empty text that is its own last path component on
        POSIX and on Windows.
    """
    return (
        isinstance(name, str)
        and name not in ("", ".", "..")
        and "\x00" not in name
        and PurePosixPath(name).name == name
        and PureWindowsPath(name).name == name
    )


# -- the directory -------------------------------------------------------------------------------
def output_directory(directory: Any, name: str) -> Path:
    """Create a model-set directory (and its parents) or say why it cannot be one.

    Parameters
    ----------
    directory : str or path-like
        The directory.
    name : str
        The argument it comes from (the start of the messages).

    Returns
    -------
    pathlib.Path
        The directory, which exists and is writable.

    Raises
    ------
    TypeError
        ``directory`` is not a path.
    OutputPathError
        It is an existing file, cannot be created, or cannot be written.
    """
    if not isinstance(directory, (str, os.PathLike)):
        raise TypeError(
            f"{name}: expected a directory path (str or pathlib.Path), received "
            f"{_short_repr(directory)} ({_type_name(directory)})"
        )
    path = Path(directory)
    what_to_do = "pass an existing directory or one that can be created"
    if path.exists() and not path.is_dir():
        raise OutputPathError(
            f"{name}: {str(path)!r} is an existing file, not a directory; {what_to_do}"
        )
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(
            f"{name}: cannot create the directory {str(path)!r} "
            f"({exc.strerror or type(exc).__name__}); {what_to_do}"
        ) from exc
    if not os.access(path, os.W_OK | os.X_OK):
        raise OutputPathError(
            f"{name}: cannot write in the directory {str(path)!r} (permission denied); "
            f"{what_to_do} and that this user may write"
        )
    return path


# -- writing ---------------------------------------------------------------------------------------
def _summary_value(value: Any) -> Any:
    """A summary value that JSON cannot hold, as JSON keeps it (``json.dumps``'s default)."""
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    if isinstance(value, (datetime.date, datetime.time)):
        return value.isoformat()
    if isinstance(value, (set, frozenset, tuple)):
        return list(value)
    return str(value)


def manifest_text(by: str, entries: list[dict]) -> str:
    """The JSON text of a manifest of ``entries`` (units encoded, summaries without "unit").

    Parameters
    ----------
    by : str
        The name of the unit column.
    entries : list of dict
        Per unit: ``unit`` (as the model set has it), ``file``, ``error`` and
        ``summary`` (its record).

    Returns
    -------
    str
        The manifest; summary values JSON cannot hold are written as text
        (numpy values and arrays as numbers and lists, dates in ISO format).

    Raises
    ------
    TypeError
        A unit the manifest cannot store (:func:`_encode_unit`).
    """
    stored = [
        {
            "unit": _encode_unit(entry["unit"]),
            "file": entry["file"],
            "error": entry["error"],
            "summary": {key: value for key, value in entry["summary"].items() if key != "unit"},
        }
        for entry in entries
    ]
    manifest = {"format": FORMAT_VERSION, "by": by, "units": stored}
    return json.dumps(manifest, indent=1, allow_nan=True, default=_summary_value)


def write_manifest(directory: Path, text: str) -> None:
    """Write ``text`` as ``directory / manifest.json``, atomically (a temporary file, renamed).

    Parameters
    ----------
    directory : pathlib.Path
        The model-set directory.
    text : str
        The manifest (:func:`manifest_text`).

    Raises
    ------
    OutputPathError
        It cannot be written (the message names the directory).
    """
    temporary = directory / f".{MANIFEST}.{os.getpid()}.{uuid.uuid4().hex}.tmp"
    try:
        handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            stream.write(text)
        os.replace(temporary, directory / MANIFEST)
    except OSError as exc:
        if temporary.exists():
            temporary.unlink()
        raise OutputPathError(
            f"directory: cannot write {str(directory / MANIFEST)!r} "
            f"({exc.strerror or type(exc).__name__}); pass a directory this user may write, "
            "on a disk with free space"
        ) from exc


# -- reading ---------------------------------------------------------------------------------------
ENTRY_KEYS = ("unit", "file", "error", "summary")


def read_manifest(path: Path) -> tuple[str, list, list[dict], dict, dict]:
    """Read and check a manifest (format 1 or 2).

    Parameters
    ----------
    path : pathlib.Path
        The ``manifest.json`` file.

    Returns
    -------
    by : str
        The name of the unit column.
    units : list
        Every unit, in input order.
    records : list of dict
        Their summary records (with the unit under "unit").
    errors : dict
        ``{unit: message}`` of the units that failed.
    files : dict
        ``{unit: file name}`` of the units with a model file.

    Raises
    ------
    ModelFileError
        Not JSON, an unknown format, or a damaged entry: the message names
        the file, the entry (its index and unit) and the problem.
    """
    damaged = "restore the file or write the model set again (ModelSet.save)"
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: not a model-set manifest ({exc}); {damaged}") from None
    if not isinstance(manifest, dict):
        raise ModelFileError(
            f"{path}: not a model-set manifest (a JSON {_type_name(manifest)}, expected an "
            f"object); {damaged}"
        )
    version = manifest.get("format")
    if type(version) is not int or version not in READ_FORMATS:
        raise ModelFileError(
            f"{path}: unknown model-set format {version!r} (this version reads formats "
            f"{', '.join(str(v) for v in READ_FORMATS)}); read it with the ltvmodels that wrote it"
        )
    by = manifest.get("by", "unit")
    if not isinstance(by, str):
        raise ModelFileError(f"{path}: 'by' must be a text, received {_short_repr(by)}; {damaged}")
    entries = manifest.get("units")
    if not isinstance(entries, list):
        raise ModelFileError(
            f"{path}: 'units' must be a list of entries, received "
            f"{_short_repr(entries)} ({_type_name(entries)}); {damaged}"
        )
    units: list = []
    records: list[dict] = []
    errors: dict = {}
    files: dict = {}
    positions: dict = {}
    for index, entry in enumerate(entries):
        where = f"{path}: entry {index}"
        if not isinstance(entry, dict):
            raise ModelFileError(
                f"{where}: expected an object with {', '.join(ENTRY_KEYS)}, received "
                f"{_short_repr(entry)} ({_type_name(entry)}); {damaged}"
            )
        missing = [key for key in ENTRY_KEYS if key not in entry]
        if "unit" in missing:
            raise ModelFileError(f"{where}: no 'unit'; {damaged}")
        try:
            unit = _decode_unit(entry["unit"]) if version >= 2 else entry["unit"]
        except ValueError as exc:
            raise ModelFileError(f"{where}: invalid unit: {exc}; {damaged}") from None
        if not _is_hashable(unit):
            raise ModelFileError(
                f"{where}: unit {_short_repr(entry['unit'])} is not a valid unit (a "
                f"{_type_name(unit)}); {damaged}"
            )
        where = f"{where} (unit {_short_repr(unit)})"
        if missing:
            raise ModelFileError(
                f"{where}: no {', '.join(repr(key) for key in missing)}; {damaged}"
            )
        if unit in positions:
            raise ModelFileError(f"{where}: the unit is also entry {positions[unit]}; {damaged}")
        file, error, summary = entry["file"], entry["error"], entry["summary"]
        if file is not None and not plain_file_name(file):
            raise ModelFileError(
                f"{where}: 'file' must be null or the name of a file in the directory "
                f"(no path), received {_short_repr(file)}; {damaged}"
            )
        if error is not None and not isinstance(error, str):
            raise ModelFileError(
                f"{where}: 'error' must be null or a text, received {_short_repr(error)}; {damaged}"
            )
        if file is not None and error:
            raise ModelFileError(f"{where}: has both a model file and an error; {damaged}")
        if not isinstance(summary, dict):
            raise ModelFileError(
                f"{where}: 'summary' must be an object, received {_short_repr(summary)} "
                f"({_type_name(summary)}); {damaged}"
            )
        positions[unit] = index
        units.append(unit)
        records.append(summary if version == 1 else {"unit": unit, **summary})
        if error:
            errors[unit] = error
        if file is not None:
            files[unit] = file
    return by, units, records, errors, files


def _is_hashable(value: Any) -> bool:
    try:
        hash(value)
    except TypeError:
        return False
    return True
