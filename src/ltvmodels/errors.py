"""Exceptions and warnings raised by ltvmodels, and :func:`warn`, which issues the warnings.

Bad user input raises plain :class:`ValueError` / :class:`TypeError` (see
:mod:`ltvmodels.validation`); the classes here describe problems that only show
up once the data meet the model.
"""

from __future__ import annotations

import os
import sys
import warnings
from typing import Any

import numpy as np

__all__ = [
    "SingularProblemError",
    "IdentifiabilityWarning",
    "PrecisionWarning",
    "ConvergenceWarning",
    "OutputPathError",
    "ModelFileError",
    "DivergenceWarning",
    "ModelStructureWarning",
    "DataWarning",
    "warn",
    "find_stack_level",
]

_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep
_PACKAGE = __name__.rpartition(".")[0]


def _in_package(frame: Any) -> bool:
    """Whether a frame runs the package's code.

    Its file lies in the package's directory, or, for code generated at run time
    (the ``__init__`` of a dataclass, file ``<string>``), it runs in a module of
    the package.
    """
    filename = frame.f_code.co_filename
    if filename.startswith("<"):
        module = frame.f_globals.get("__name__") or ""
        return module == _PACKAGE or module.startswith(_PACKAGE + ".")
    return os.path.abspath(filename).startswith(_PACKAGE_DIR)


def find_stack_level() -> int:
    """The ``stacklevel`` of the first frame outside ltvmodels, for :func:`warnings.warn`.

    Counted from the caller of this function, which must be the function that
    calls :func:`warnings.warn` (so that ``stacklevel=find_stack_level()`` there
    points the warning at the user's line, however deep in the package it
    arises). Where every frame is the package's (the ``ltvmodels`` command run
    as ``python -m ltvmodels``), the outermost one.
    """
    frame = sys._getframe(1)
    level = 1
    while frame.f_back is not None and _in_package(frame):
        frame = frame.f_back
        level += 1
    return level


def warn(message: str, category: type[Warning]) -> None:
    """Issue a warning at the user's line: the first caller outside ltvmodels.

    Every warning of the package goes through here, so where it is reported
    does not depend on how deep in the package it arises.
    """
    warnings.warn(message, category, stacklevel=find_stack_level())


class SingularProblemError(np.linalg.LinAlgError):
    """The estimation problem has no unique solution.

    Raised instead of returning an arbitrary minimizer. The message says which
    part of the data is insufficient and what to do (more excitation, a larger
    λ, a prior, fewer parameters). Subclasses :class:`numpy.linalg.LinAlgError`
    and therefore :class:`ValueError`.
    """


class IdentifiabilityWarning(UserWarning):
    """The data alone do not (or only barely) identify the parameters.

    Issued when a prior or the regularization decides directions that the
    data cannot, or when the problem is numerically ill-conditioned.
    """


class PrecisionWarning(UserWarning):
    """A result is computed, but with fewer correct digits than usual.

    Issued for example when λ is so large relative to the data that the normal
    equations lose many digits; the message says how many and what to do.
    """


class ConvergenceWarning(UserWarning):
    """An iterative solver stopped at its iteration limit before meeting its tolerance.

    The returned model is the last iterate; ``model.info`` reports the residuals.
    """


class OutputPathError(ValueError):
    """An output file cannot be written (missing directory, unsupported format, ...)."""


class ModelFileError(ValueError):
    """A file cannot be read as an ltvmodels model (not one, damaged, or invalid content).

    The message starts with ``path: <the file>`` and says what is wrong; the
    underlying exception, if any, is chained.
    """


class DivergenceWarning(UserWarning):
    """A simulation left the floating-point range (the model is unstable along the inputs).

    The returned trajectory holds inf or NaN from the step named in the message on.
    """


class DataWarning(UserWarning):
    """The data were read in a way worth knowing: e.g. time stamps missing from a
    regular grid were inserted as missing samples."""


class ModelStructureWarning(UserWarning):
    """The model's structure looks wrong for the data.

    Issued for example when an AR/ARX model without an intercept is fitted to
    a series whose mean is clearly not zero; the message says what to change.
    """
