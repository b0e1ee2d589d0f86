"""``ltvmodels.load``: a model file back into the model class that wrote it."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelFileError
from ..validation.arrays import LARGEST_DATA, describe
from ..validation.time import increasing
from . import archive
from .arx import ARModel, ARXModel
from .forecast import noise_covariance
from .regression import RegressionModel
from .statespace import LTVModel

__all__ = ["load"]

MODEL_TYPES = {cls.__name__: cls for cls in (RegressionModel, LTVModel, ARXModel, ARModel)}
"""The model classes a file can hold, by the name it records."""


def load(path: str | Path) -> RegressionModel:
    """Load a model written by :meth:`RegressionModel.save` (any model of this package).

    Reads files of the current format and of ltvmodels 0.1 (format version 1).

    Parameters
    ----------
    path : str or path-like
        The ``.npz`` model file.

    Returns
    -------
    RegressionModel
        An instance of the class that was saved (:class:`~ltvmodels.LTVModel`,
        :class:`~ltvmodels.RegressionModel`, :class:`~ltvmodels.ARModel`,
        :class:`~ltvmodels.ARXModel`).

    Raises
    ------
    TypeError
        ``path`` is not a path.
    FileNotFoundError, PermissionError, IsADirectoryError
        As for any file.
    ModelFileError
        (a ValueError) The file is not a model file, is damaged, or holds
        invalid content (an unknown format version or model type, shapes that
        do not fit, non-finite coefficients, negative noise variances, a noise
        covariance that is not symmetric positive semidefinite); the message
        names the file and the field.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"path: expected a file path (str or pathlib.Path), received {describe(path)}"
        )
    if os.path.isfile(path) and not zipfile.is_zipfile(path):
        raise ModelFileError(
            f"path: {path} is not an ltvmodels model file (model files are .npz archives "
            "written by model.save or the command line's --out)"
        )
    try:
        content = archive.read(path)
        cls = MODEL_TYPES.get(content.model_type)
        if cls is None:
            raise ValueError(
                f"path: {path} holds a model of unknown type {content.model_type!r} (known: "
                f"{sorted(MODEL_TYPES)})"
            )
        if not np.isrealobj(content.k) or not np.all(np.abs(content.k) <= LARGEST_DATA):
            raise ValueError(
                f"path: {path} holds coefficients that are not finite real numbers "
                f"of magnitude up to {LARGEST_DATA:g}"
            )
        model = cls.from_structure(content.k, content.structure, content.fit)
        problem = _invalid_record(model)
        if problem:
            raise ValueError(f"path: {path} holds an invalid {problem}")
        return model
    except (FileNotFoundError, PermissionError, IsADirectoryError):
        raise
    except Exception as exc:  # numpy, zipfile, json and our own checks: one error
        text = str(exc)
        if isinstance(exc, ValueError) and text.startswith(f"path: {path} "):
            raise ModelFileError(text) from exc
        if "pickle" in text:  # numpy's advice to load unsafely is not ours to give
            text = "it holds Python objects, which model files never do"
        raise ModelFileError(
            f"path: {path} is not a readable ltvmodels model file (written by model.save): "
            f"{type(exc).__name__}: {text}"
        ) from exc


def _invalid_record(model: RegressionModel) -> str | None:
    """What is wrong with a loaded model's fit record (None: nothing).

    A file can be edited or damaged in ways its structure does not reveal;
    everything the model later computes with is checked here.
    """
    N, n, p = model.N, model.n_outputs, model.n_regressors
    K = n * p
    fit = model.record
    if fit.coeffs is not None:
        c = np.asarray(fit.coeffs)
        if (
            c.ndim != 1
            or c.size < 2
            or c.size > N
            or not np.all(np.isfinite(c))
            or c[-1] == 0
            or abs(c.sum()) > 1e-8 * np.abs(c).sum()
        ):
            return f"difference operator 'coeffs' {c.tolist()}"
    if fit.changepoints is not None:
        cp = np.asarray(fit.changepoints)
        if (
            cp.ndim != 1
            or cp.dtype.kind not in "iu"
            or np.any(cp < 1)
            or np.any(cp > N - 1)
            or np.any(np.diff(cp) <= 0)
        ):
            return f"'changepoints' (expected increasing integers in [1, {N - 1}])"
    noise = _invalid_noise(fit.noise_var, fit.noise_cov, n)
    if noise:
        return noise
    time = model.data.time
    if time is not None and (
        time.ndim != 1 or time.dtype.kind not in "iufM" or not increasing(time)
    ):  # (forecasts continue it, to_statespace takes its step as dt)
        return "'data_time' (expected increasing numbers or dates, one per sample)"
    if fit.loglik is not None and not np.isfinite(fit.loglik):
        return f"'loglik' {fit.loglik}"
    if fit.lam is not None:
        lam = np.asarray(fit.lam)
        if lam.shape not in ((), (K,), (K, K)) or np.any(np.isnan(lam)) or np.any(lam < 0):
            return "'lam' (expected λ >= 0: a scalar, a (K,) vector or a (K, K) matrix)"
    cov = fit.cov
    if cov is not None:
        blocks = np.asarray(cov.blocks)
        if cov.row_group is None:
            expected_ok = blocks.shape == (N, K, K)
        else:
            group = np.asarray(cov.row_group)
            expected_ok = (
                blocks.ndim == 4
                and blocks.shape[1:] == (N, p, p)
                and group.shape == (n,)
                and group.dtype.kind in "iu"
                and bool(np.all((group >= 0) & (group < blocks.shape[0])))
            )
            if cov.row_scale is not None:
                scale = np.asarray(cov.row_scale)
                expected_ok &= scale.shape == (n,) and bool(np.all(np.isfinite(scale)))
        if not expected_ok or not np.all(np.isfinite(blocks)):
            return "covariance ('cov_blocks', 'cov_row_group', 'cov_row_scale')"
    tail = model.data.tail
    if tail is not None and not (  # a regression has no dynamics, so no end to continue
        isinstance(model, (LTVModel, ARXModel)) and tail.fits(model.tail_lengths, n, model.n_inputs)
    ):
        return "data tail ('data_tail_outputs', 'data_tail_inputs')"
    bad = _nan_entry(model.info)
    if bad:
        return f"'info' entry {bad!r} (NaN)"
    return None


def _invalid_noise(noise_var: Any, noise_cov: Any, n: int) -> str | None:
    """What is wrong with the noise of a loaded model of n outputs (None: nothing): the
    variances must be finite and >= 0, the covariance a symmetric positive semidefinite
    (n, n) matrix (forecasts draw from it)."""
    if noise_var is not None:
        v = np.asarray(noise_var, dtype=float)
        if v.shape != (n,):
            return f"'noise_var' (expected {n} variances, received shape {v.shape})"
        bad = np.flatnonzero(~(np.isfinite(v) & (v >= 0)))
        if bad.size:
            return (
                f"'noise_var' (expected {n} finite variances >= 0, received "
                f"{v[bad[0]]:g} at position {int(bad[0])})"
            )
    if noise_cov is not None:
        c = np.asarray(noise_cov)
        if c.shape != (n, n):
            return f"'noise_cov' (expected a ({n}, {n}) matrix, received shape {c.shape})"
        try:  # the check of a noise_cov given to forecast or from_arrays
            noise_covariance(c, None, n)
        except (TypeError, ValueError) as exc:
            return f"'noise_cov' ({str(exc).removeprefix('noise_cov: ')})"
    return None


def _nan_entry(value: object, key: str = "") -> str | None:
    """The key of the first NaN in nested info values (None: none).

    Infinities are kept: some entries document them (e.g. the cost of an
    infeasible number of changes).
    """
    if isinstance(value, dict):
        for k, v in value.items():
            found = _nan_entry(v, f"{key}.{k}" if key else str(k))
            if found:
                return found
        return None
    if isinstance(value, (list, tuple)):
        for v in value:
            found = _nan_entry(v, key)
            if found:
                return found
        return None
    if isinstance(value, np.ndarray):
        ok = value.dtype.kind not in "fc" or not bool(np.any(np.isnan(value)))
        return None if ok else key
    if isinstance(value, float) and np.isnan(value):
        return key
    return None
