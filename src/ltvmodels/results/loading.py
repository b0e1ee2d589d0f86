"""``ltvmodels.load``: a model file back into the model class that wrote it."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import ModelFileError
from ..validation.arrays import describe
from . import archive
from .arx import ARModel, ARXModel
from .regression import RegressionModel
from .statespace import LTVModel

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
        do not fit, non-finite coefficients); the message names the file.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"path: expected a file path (str or pathlib.Path), received {describe(path)}"
        )
    try:
        content = archive.read(path)
        cls = MODEL_TYPES.get(content.model_type)
        if cls is None:
            raise ValueError(
                f"path: {path} holds a model of unknown type {content.model_type!r} (known: "
                f"{sorted(MODEL_TYPES)})"
            )
        if not np.all(np.isfinite(np.asarray(content.k, dtype=float))):
            raise ValueError(f"path: {path} holds coefficients that are NaN or infinite")
        return cls.from_structure(content.k, content.structure, content.fit)
    except (FileNotFoundError, PermissionError, IsADirectoryError):
        raise
    except Exception as exc:  # numpy, zipfile, json and our own checks: one error
        text = str(exc)
        if isinstance(exc, ValueError) and text.startswith(f"path: {path} "):
            raise ModelFileError(text) from exc
        raise ModelFileError(
            f"path: {path} is not a readable ltvmodels model file (written by model.save): "
            f"{type(exc).__name__}: {text}"
        ) from exc
