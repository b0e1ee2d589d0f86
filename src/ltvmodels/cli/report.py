"""Values of a command's report: RMS errors, numbers, times and facts as text, and strict JSON."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np

__all__ = [
    "Report",
    "rms",
    "rms_columns",
    "jsonable",
    "info_subset",
    "per_name",
    "fmt",
    "time_text",
    "missing_text",
    "noise_text",
]

Report = tuple[dict[str, Any], list[str]]
"""What a command returns: the report (printed as JSON with ``--json``) and the text lines."""


def rms(a: np.ndarray, valid: np.ndarray | None = None) -> float:
    """RMS of ``a``, over the entries where ``valid`` (same shape) is True if given.

    NaN when no entry is valid; a NaN or inf of a valid entry (a diverging
    simulation) is kept, so that it shows.
    """
    if valid is not None:
        a = np.asarray(a)[valid]
    if np.size(a) == 0:
        return math.nan
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.sqrt(np.mean(np.square(a))))


def jsonable(value: Any) -> Any:
    """Plain JSON types: numpy → Python, NaN/inf → None, tuples → lists, paths → str."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (str, bool, int)):
        return value
    return str(value)


def info_subset(info: dict) -> dict:
    """The solver facts of ``model.info`` worth reporting (no large arrays)."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        if key == "first_step_k":
            continue
        if isinstance(value, np.ndarray) and value.size > 100:
            continue
        if key == "lam_selection" and isinstance(value, dict):
            value = {k: value[k] for k in ("method", "lam") if k in value}
        out[key] = value
    return out


def rms_columns(a: np.ndarray, valid: np.ndarray | None = None) -> list[float]:
    """RMS of each column of ``a`` (T, k), over its ``valid`` entries if given."""
    a = np.asarray(a)
    return [rms(a[:, j], None if valid is None else valid[:, j]) for j in range(a.shape[1])]


def per_name(names: list[str], values: Any) -> str:
    """``"x1 0.1, x2 0.2"``: a value per named column (one value: shared by all)."""
    values = np.atleast_1d(np.asarray(values, dtype=float))
    if values.size == 1 and len(names) != 1:
        return fmt(float(values[0]))
    return ", ".join(f"{n} {fmt(float(v))}" for n, v in zip(names, values, strict=True))


def fmt(value: float) -> str:
    """A number in 4 significant digits (``nan``, ``inf`` as they are)."""
    return f"{value:.4g}" if math.isfinite(value) else str(value)


def time_text(values: np.ndarray) -> list[str]:
    """Times as text: dates without a time of day as YYYY-MM-DD, else to the second; numbers
    as numbers."""
    if not np.issubdtype(values.dtype, np.datetime64):
        return [fmt(float(value)) for value in values]
    days = values.astype("datetime64[D]")
    unit: Literal["D", "s"] = "D" if np.all(days == values) else "s"
    return [str(text) for text in np.datetime_as_string(values, unit=unit)]


def missing_text(n_missing: int, N: int, counts: dict[str, int], noun: str, rule: str) -> str:
    """``missing: 5 of 199 transitions left out (missing values: x1 2, u 3; rule)``."""
    values = ", ".join(f"{name} {c}" for name, c in counts.items() if c)
    return f"missing: {n_missing} of {N} {noun} left out (missing values: {values}; {rule})"


def noise_text(model: Any, names: list[str]) -> str:
    """``noise variance: x1 0.01, x2 0.02 (estimated from the residuals)``, or ``(given)``
    where ``--noise-var`` set it."""
    how = "estimated from the residuals" if model.info.get("noise_var_estimated", True) else "given"
    return f"noise variance: {per_name(names, model.noise_var)} ({how})"
