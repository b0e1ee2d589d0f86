"""``ltvmodels.load``: a model file back into the model class that wrote it."""

from __future__ import annotations

from pathlib import Path

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
    """
    content = archive.read(path)
    cls = MODEL_TYPES.get(content.model_type)
    if cls is None:
        raise ValueError(
            f"path: {path} holds a model of unknown type {content.model_type!r} (known: "
            f"{sorted(MODEL_TYPES)})"
        )
    return cls.from_structure(content.k, content.structure, content.fit)
