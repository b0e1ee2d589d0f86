"""What a subcommand's module gives the parser: its description, options and work."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import NamedTuple

from .report import Report

__all__ = ["Subcommand"]


class Subcommand(NamedTuple):
    """One subcommand of ``ltvmodels``, as its module defines it.

    Its name and one-line help are listed in :data:`ltvmodels.cli.commands.COMMANDS`,
    which ``ltvmodels --help`` shows without importing the module.

    Attributes
    ----------
    description : str
        The paragraph of ``ltvmodels NAME --help``.
    add_arguments : callable
        ``add_arguments(parser)`` adds the subcommand's options to its parser.
    run : callable
        ``run(args)`` does the work and returns the report and the text
        lines; it imports the library's estimators, models and figures.
    """

    description: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], Report]
