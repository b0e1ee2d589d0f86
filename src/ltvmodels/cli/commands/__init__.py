"""The subcommands of ``ltvmodels``: their list, and one module each.

:data:`COMMANDS` lists every subcommand with its one-line help (all that
``ltvmodels --help`` shows) and the module that defines it. A module defines
a :class:`~ltvmodels.cli.subcommand.Subcommand`: the description, the
options (``add_arguments(parser)``, with the shared ones of
:mod:`ltvmodels.cli.arguments`) and the work (``run(args)``, which returns
the report: a dict printed as JSON with ``--json``, and the lines of the
text summary); ``simulate`` and ``predict`` share :mod:`.replay`.

A module is imported by :func:`load_subcommand` when its subcommand is parsed,
its help shown or run, as the package root loads its names on first use:
``ltvmodels fit ...`` imports no other command's module. A module imports at
its top only what its options need; ``run`` imports the rest (the library's
estimators, models and figures, the command line's modules that read data,
compute the report and write files; the demo imports the applications in its
functions), so that ``ltvmodels CMD --help`` loads none of them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:  # pragma: no cover
    from ..subcommand import Subcommand

__all__ = ["Entry", "COMMANDS", "load_subcommand"]


class Entry(NamedTuple):
    """A subcommand in the list: its help line, and where its module defines it."""

    help: str
    module: str
    attribute: str = "COMMAND"


COMMANDS: dict[str, Entry] = {
    "fit": Entry("identify an LTV model from states and inputs in a data file", "fit"),
    "segments": Entry("piecewise-constant model with exactly optimal change points", "segments"),
    "ar": Entry("time-varying AR model of one column and its root spectrogram", "ar"),
    "select-lambda": Entry("choose lambda by a criterion and show its curve", "select_lambda"),
    "simulate": Entry("open-loop simulation of a saved model on a data file", "replay", "SIMULATE"),
    "predict": Entry("one-step predictions of a saved model on a data file", "replay", "PREDICT"),
    "forecast": Entry(
        "forecast of a saved model after the end of its data, with intervals", "forecast"
    ),
    "demo": Entry("run an example of the paper on built-in data, report and plot", "demo"),
    "fit-many": Entry(
        "one model per unit of a long table (fleets, panels, many loops)", "fit_many"
    ),
}
"""The subcommands by name, in the order ``ltvmodels --help`` lists them."""


def load_subcommand(name: str) -> Subcommand:
    """The subcommand ``name``, its module imported on first use.

    Parameters
    ----------
    name : str
        A key of :data:`COMMANDS`.

    Returns
    -------
    Subcommand
    """
    entry = COMMANDS[name]
    module = importlib.import_module(f"{__name__}.{entry.module}")
    command: Subcommand = getattr(module, entry.attribute)
    return command
