"""The ``ltvmodels`` argument parser: one subparser per subcommand.

The command line uses :mod:`argparse` from the standard library: the
subcommands need nothing it lacks, and an extra dependency (click, typer) for
every user of the library is not justified. A small subclass makes its errors
one line. The subcommands and their options are defined by their modules
(:mod:`ltvmodels.cli.commands`); a subcommand's module is imported, and its
options added, only when it is parsed or its help shown, so that
``ltvmodels --help`` and ``ltvmodels CMD --help`` answer at once and load
nothing that another command needs (the demo's options load the
applications).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any, NoReturn

from .. import __version__
from .commands import COMMANDS, load_subcommand
from .messages import UsageError

__all__ = ["Parser", "build_parser"]


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (no usage dump) and are raised, not exited."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: error: {message} (see '{self.prog} --help')")


class _SubcommandParser(Parser):
    """A subcommand's parser, completed from the subcommand's module the first time it is used.

    Parameters
    ----------
    command : str, optional
        The subcommand: its module gives the description and adds the
        options once, before the parser first parses or formats its usage or
        help.
    *args, **kwargs
        Those of :class:`argparse.ArgumentParser`.
    """

    def __init__(self, *args: Any, command: str | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._incomplete = command

    def _complete(self) -> None:
        if self._incomplete is not None:
            command, self._incomplete = load_subcommand(self._incomplete), None
            self.description = command.description
            command.add_arguments(self)

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: Any = None
    ) -> tuple[Any, list[str]]:
        self._complete()
        return super().parse_known_args(args, namespace)

    def format_usage(self) -> str:
        self._complete()
        return super().format_usage()

    def format_help(self) -> str:
        self._complete()
        return super().format_help()


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``ltvmodels`` command.

    Returns
    -------
    argparse.ArgumentParser
        Its ``error`` raises instead of exiting (see :func:`main`).
    """
    parser = Parser(
        prog="ltvmodels",
        description="Identification of linear time-varying (LTV) models "
        "x[t+1] = A_t x[t] + B_t u[t] + v_t by convex optimization.",
    )
    parser.add_argument("--version", action="version", version=f"ltvmodels {__version__}")
    subparsers = parser.add_subparsers(
        dest="command", metavar="COMMAND", required=True, parser_class=_SubcommandParser
    )
    for name, entry in COMMANDS.items():
        subparsers.add_parser(name, help=entry.help, command=name)
    return parser
