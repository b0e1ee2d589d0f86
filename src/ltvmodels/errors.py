"""Exceptions and warnings raised by ltvmodels.

Bad user input raises plain :class:`ValueError` / :class:`TypeError` (see
:mod:`ltvmodels.validation`); the classes here describe problems that only show
up once the data meet the model.
"""

from __future__ import annotations

import numpy as np


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


class ModelStructureWarning(UserWarning):
    """The model's structure looks wrong for the data.

    Issued for example when an AR/ARX model without an intercept is fitted to
    a series whose mean is clearly not zero; the message says what to change.
    """
