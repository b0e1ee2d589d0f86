"""The model file: a NumPy ``.npz`` archive of the coefficients, the fit record and the sizes.

Members: ``k``, ``lam``, optionally ``noise_cov`` (absent: not estimated), ``coeffs``,
``cov_blocks``/``cov_row_group`` (the compact covariance), ``changepoints``,
array-valued ``info`` entries as ``info__<key>``, and ``meta``: one JSON text
with the format version, the model class, its sizes (``model.structure()``),
``norm``, ``noise_var``, ``loglik`` (null where not estimated or not defined),
the JSON part of ``info``, (from version 2) the fit status and (from version
3) the data description (``model.data``: names, trajectories, missing rows;
its time axis is the member ``data_time``, the end of the data that forecasts
continue, where the model has one, the optional members ``data_tail_outputs``
and ``data_tail_inputs``). Files are read with ``allow_pickle=False``: loading
a model never executes code from the file.

Version history: 1 (ltvmodels 0.1), 2 (adds the fit status), 3 (adds the data
description, which earlier versions kept in ``info`` as "signal_names", "time"
and "n_missing"; the data tail members were added later as optional members of
version 3: files without them load with no tail, and readers that predate them
ignore them; so are ``states``, ``states_std``, ``measurement_noise`` and
``sample_outliers``, the smoothed states, their standard deviations, the
measurement-noise variances and the samples judged corrupted of a fit with
measurement noise). Earlier versions are read too: the status of a version-1 file is
reconstructed from ``info``, the description of version 1 and 2 files from
those ``info`` entries.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.covariance import CovarianceBlocks
from ..validation.arrays import describe
from .description import DataDescription, DataTail
from .record import FitRecord, FitStatus, iterative_status

__all__ = ["ModelFile", "write", "read"]

FORMAT_VERSION = 3
READABLE_VERSIONS = (1, 2, 3)

# How version-1 files name the solvers that need no iterations, or search exactly.
_CLOSED_FORM_SOLVERS = (
    "block-banded Cholesky (exact)",
    "least-squares (QR)",
    "piecewise least squares",
    "closed form (lam >= lambda_max)",
)
_SEARCH_SOLVERS = ("dynamic programming", "PELT")
_DETAIL_KEYS = (
    "duality_gap",
    "primal_residual",
    "dual_residual",
    "polished",
    "rho",
    "n_factorizations",
    "lambda_max",
)


_MEASUREMENT_MEMBERS = ("states", "states_std", "measurement_noise", "sample_outliers")
"""The optional members of a fit with measurement noise (files without them: exact states)."""


@dataclass
class ModelFile:
    """The contents of a model file, ready to rebuild the model."""

    model_type: str
    k: np.ndarray
    structure: dict
    fit: FitRecord


def write(model: Any, path: str | Path) -> None:
    """Write ``model`` (any model of :mod:`ltvmodels.results`) to ``path``."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"path: expected a file path (str or pathlib.Path), received {describe(path)}"
        )
    fit = model.record
    arrays: dict[str, np.ndarray] = {"k": np.asarray(model.k)}
    if fit.noise_cov is not None:
        arrays["noise_cov"] = fit.noise_cov
    if fit.coeffs is not None:
        arrays["coeffs"] = fit.coeffs
    if fit.lam is not None:
        arrays["lam"] = np.asarray(fit.lam, dtype=float)
    if fit.cov is not None:
        arrays["cov_blocks"] = fit.cov.blocks
        if fit.cov.row_group is not None:
            arrays["cov_row_group"] = fit.cov.row_group
        if fit.cov.row_scale is not None:
            arrays["cov_row_scale"] = fit.cov.row_scale
    if fit.changepoints is not None:
        arrays["changepoints"] = fit.changepoints
    info_json, info_arrays = _split_info(fit.info)
    arrays.update({f"info__{key}": value for key, value in info_arrays.items()})
    meta = {
        "format_version": FORMAT_VERSION,
        "model_type": type(model).__name__,
        **model.structure(),
        "norm": fit.norm,
        "noise_var": None
        if fit.noise_var is None
        else np.asarray(fit.noise_var, dtype=float).tolist(),
        "loglik": fit.loglik,
        "info": info_json,
        "status": None if fit.status is None else fit.status.to_dict(),
        "data": None if fit.data is None else fit.data.to_json(),
    }
    if fit.data is not None and fit.data.time is not None:
        arrays["data_time"] = fit.data.time
    if fit.data is not None and fit.data.tail is not None:
        arrays["data_tail_outputs"] = fit.data.tail.outputs
        arrays["data_tail_inputs"] = fit.data.tail.inputs
    for name in _MEASUREMENT_MEMBERS:  # a fit with measurement noise (optional members)
        value = getattr(fit, name)
        if value is not None:
            kind = bool if name == "sample_outliers" else float
            arrays[name] = np.asarray(value, dtype=kind)
    arrays["meta"] = np.array(json.dumps(meta))
    with open(path, "wb") as fh:
        # mypy matches the unpacked names against savez's keyword allow_pickle (numpy >= 2.1),
        # which none of them is
        np.savez(fh, **arrays)  # type: ignore[arg-type]


def read(path: str | Path) -> ModelFile:
    """Read a model file of any readable version (see the module docstring)."""
    with np.load(path, allow_pickle=False) as data:
        files = set(data.files)
        if "meta" not in files or "k" not in files:
            raise ValueError(f"path: {path} is not an ltvmodels model file (no 'meta'/'k' entries)")
        meta = json.loads(str(data["meta"]))
        version = meta.get("format_version")
        if version not in READABLE_VERSIONS:
            raise ValueError(
                f"path: {path} has unsupported model file version {version} (this ltvmodels "
                f"reads versions {', '.join(map(str, READABLE_VERSIONS))})"
            )
        cov = None
        if "cov_blocks" in files:
            row_group = data["cov_row_group"] if "cov_row_group" in files else None
            row_scale = data["cov_row_scale"] if "cov_row_scale" in files else None
            cov = CovarianceBlocks(data["cov_blocks"], row_group, row_scale)
        info = dict(meta["info"])
        info.update({key[len("info__") :]: data[key] for key in files if key.startswith("info__")})
        if version == 1:
            status = _status_from_info(info)
        else:
            status = None if meta["status"] is None else FitStatus.from_dict(meta["status"])
        lam = data["lam"] if "lam" in files else None
        if version < 3:
            description = _description_from_info(info)
        elif meta.get("data") is None:
            description = None
        else:
            time = data["data_time"] if "data_time" in files else None
            tail = None
            if {"data_tail_outputs", "data_tail_inputs"} <= files:
                tail = DataTail(data["data_tail_outputs"], data["data_tail_inputs"])
            description = DataDescription.from_json(meta["data"], time, tail)
        fit = FitRecord(
            norm=meta["norm"],
            coeffs=data["coeffs"] if "coeffs" in files else None,
            lam=_lam_value(lam),
            cov=cov,
            noise_var=_estimated(meta["noise_var"]),
            noise_cov=_estimated(data["noise_cov"]) if "noise_cov" in files else None,
            loglik=meta["loglik"],
            info=info,
            changepoints=data["changepoints"] if "changepoints" in files else None,
            status=status,
            data=description,
            **{name: data[name] for name in _MEASUREMENT_MEMBERS if name in files},
        )
        # Files written before model types were recorded hold state-space models.
        return ModelFile(meta.get("model_type", "LTVModel"), data["k"], meta, fit)


def _lam_value(lam: np.ndarray | None) -> Any:
    """λ as the fit stored it: a float, an array, or None (given coefficients; older files
    wrote NaN)."""
    if lam is None or (lam.ndim == 0 and np.isnan(lam)):
        return None
    return float(lam) if lam.ndim == 0 else lam


def _estimated(value: Any) -> Any:
    """None for a quantity not estimated (older files wrote NaN for it), else ``value``."""
    if value is None or np.all(np.isnan(np.asarray(value, dtype=float))):
        return None
    return value


def _split_info(info: dict) -> tuple[dict, dict]:
    """Separate arrays (saved as npz members) from JSON-serializable values."""
    plain, arrays = {}, {}
    for key, value in info.items():
        if isinstance(value, np.ndarray):
            arrays[key] = value
        elif isinstance(value, np.generic):
            plain[key] = value.item()
        else:
            plain[key] = value
    json.dumps(plain)  # fail early (TypeError) on values that cannot be stored
    return plain, arrays


def _description_from_info(info: dict) -> DataDescription:
    """The data description of a version 1 or 2 file, from (and out of) its ``info``."""
    return DataDescription.of(
        info.pop("signal_names", None),
        info.pop("time", None),
        n_missing=info.pop("n_missing", 0),
    )


def _status_from_info(info: dict) -> FitStatus | None:
    """The fit status of a version-1 file, from the solver facts in its ``info``.

    Version 1 did not record whether an interior-point fit that missed its
    tolerance stalled or ran out of iterations; such fits read as ``max_iter``.
    """
    solver = info.get("solver")
    if not isinstance(solver, str):
        return None
    if solver in _CLOSED_FORM_SOLVERS:
        status = "closed_form"
    elif solver in _SEARCH_SOLVERS:
        status = "optimal"
    else:
        status = iterative_status(
            bool(info.get("converged", False)), polished=bool(info.get("polished", False))
        )
    objective = info.get("objective", info.get("rss", float("nan")))
    details = {key: info[key] for key in _DETAIL_KEYS if key in info}
    return FitStatus(status, solver, int(info.get("iterations", 0)), float(objective), details)
