"""What the command line tells the user besides the report: errors, warnings, progress.

User errors (unknown options or columns, bad values, a missing or unreadable
file, data the model cannot use) print one line to stderr and give exit status
2, without traceback; warnings of the library are one line each. Long work
shows a progress line on stderr (:func:`running`).
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from ..errors import OutputPathError, SingularProblemError

__all__ = [
    "UsageError",
    "DataError",
    "CommandError",
    "one_line",
    "user_errors",
    "collect_warnings",
    "running",
]


class UsageError(Exception):
    """A command-line usage error; its message is the one line to print."""


class DataError(ValueError):
    """A data or model file cannot be read or used (the message is one line)."""


def one_line(message: Any) -> str:
    """The text of ``message`` on one line (runs of white space made one space)."""
    return " ".join(str(message).split())


class CommandError(Exception):
    """A user error found while running a command; its message is one line."""


# Library argument names → what the user typed on the command line.
_OPTION_NAMES = {
    "x": "--state data",
    "u": "--input data",
    "y": "--column data",
    "lam": "--lam",
    "order": "--order",
    "max_iter": "--max-iter",
    "tol": "--tol",
    "n_changes": "--n-changes",
    "penalty": "--penalty",
    "min_size": "--min-size",
    "na": "--na",
    "fs": "--fs",
    "method": "--method",
    "x0": "--state data",
    "y0": "--column data",
    "loss": "--loss",
    "huber_delta": "--huber-delta",
    "noise_var": "--noise-var",
    "weights": "--weights",
}


@contextlib.contextmanager
def user_errors(context: str = "") -> Iterator[None]:
    """Turn the library's input errors into one-line command errors."""
    try:
        yield
    except (DataError, OutputPathError):
        raise
    except (
        ValueError,
        TypeError,
        NotImplementedError,
        SingularProblemError,
        np.linalg.LinAlgError,
    ) as exc:
        text = one_line(exc)
        name, sep, rest = text.partition(":")
        if sep and name in _OPTION_NAMES:
            text = f"{_OPTION_NAMES[name]}:{rest}"
        raise CommandError(f"{context}{text}") from None


@contextlib.contextmanager
def collect_warnings() -> Iterator[list[str]]:
    """Record warnings as one-line texts (printed by ``ltvmodels.cli.main``, listed in --json)."""
    caught: list[str] = []
    with warnings.catch_warnings(record=True) as records:
        warnings.simplefilter("always")
        try:
            yield caught
        finally:
            for record in records:
                text = f"{record.category.__name__}: {one_line(record.message)}"
                if text not in caught:
                    caught.append(text)


@contextlib.contextmanager
def running(label: str) -> Iterator[Callable[[int, int], None]]:
    """Run an estimator with a progress line, its input errors made user errors.

    Parameters
    ----------
    label : str
        What the progress line says (on stderr when it is a terminal).

    Yields
    ------
    callable
        ``progress(done, total)`` for the estimator's ``progress=`` (the
        candidates of ``lam="auto"``); it sets the line's count.
    """
    from ..progress import Progress

    with Progress(label) as bar, user_errors():

        def progress(done: int, total: int) -> None:
            bar.total, bar.done = total, done

        yield progress
