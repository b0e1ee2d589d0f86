"""The ``ltvmodels`` command (also ``python -m ltvmodels``).

Subcommands::

    ltvmodels fit DATA --state COLS [--input COLS] [--time COL] [--norm {sq,group,l1}]
                  [--order N] [--lam {VALUE,auto}] [--refine] [--constant] [--out MODEL.npz]
                  [--plot FIG] [--json]
    ltvmodels segments DATA --state COLS [--input COLS] [--time COL] [--n-changes M |
                  --penalty B] [--min-size S] [--constant] [--out MODEL.npz] [--plot FIG]
                  [--json]
    ltvmodels ar DATA --column C --na N [--time COL] [--fs HZ] [--norm ...] [--order N]
                  [--lam {VALUE,auto}] [--constant] [--out MODEL.npz] [--plot FIG] [--json]
    ltvmodels select-lambda DATA (--state COLS [--input COLS] | --column C --na N)
                  [--time COL] [--norm {sq,group,l1,l0}] [--order N] [--method M]
                  [--constant] [--plot FIG] [--json]
    ltvmodels simulate MODEL.npz DATA [--state COLS] [--input COLS] [--out SIM.csv]
                  [--plot FIG] [--json]
    ltvmodels predict MODEL.npz DATA [--state COLS] [--input COLS] [--out PRED.csv]
                  [--plot FIG] [--json]
    ltvmodels fit-many TABLE --by COL --state COLS [--input COLS] [--time COL]
                  [--lam {VALUE,auto}] [--out SUMMARY.csv] [--models-dir DIR] [--jobs N]
                  [--scheduler ADDRESS] [--json]
    ltvmodels demo {jump-linear,robot,chirp,rl,pendulum} [--seed S] [--out PATH] ...

DATA is a CSV file (comma, semicolon or tab separated, detected from the first
line; lines starting with ``#`` are comments), ``-`` for CSV on standard input,
or a Parquet file (``.parquet``, ``.pq``; needs pandas with pyarrow or
fastparquet). A CSV file's first line is its header of column names when a
field is not a number; a first line of numbers and missing values only is an
error unless ``--header`` (names) or ``--no-header`` (data) declares it (the
``fit-many`` TABLE always has a header). Columns are chosen by name
or 0-based index, comma-separated (``--state x1,x2``, ``--input 3``); only the
chosen columns must be numeric. An empty cell, ``NA``, ``N/A``, ``NaN`` or
``null`` (any case; Parquet: a null or NaN) is a missing value, which the fits
leave out: a transition enters only if x[t], u[t] and x[t+1] are observed (AR:
y[t] and its lags); the reports say how many were left out. Infinities are
errors. Without ``--input`` the system is autonomous. ``--time COL`` gives the
samples' times (numbers or ISO 8601 dates; see :mod:`.recordings`). A model written by
``fit``, ``segments`` or ``ar`` records its data columns, so ``simulate`` and
``predict`` find them in new data without ``--state``/``--input``.

Modules: :mod:`.parser` (the parser, a subparser per subcommand),
:mod:`.commands` (the list of subcommands, and one module per subcommand
with its options and its work), :mod:`.subcommand` (what such a module
defines), :mod:`.arguments` (the options several subcommands share),
:mod:`.data` (data files), :mod:`.recordings` (the columns a fit reads),
:mod:`.saved` (a saved model and its data), :mod:`.analysis` (what the
reports compute), :mod:`.report` (report values and JSON), :mod:`.outputs`
(the output files, written by one shared tail), :mod:`.messages` (one-line
user errors, progress); the demos are :mod:`ltvmodels.apps.demos`. Importing
this package, or asking for help, loads neither the solvers nor matplotlib
nor the applications: a subcommand imports them when it runs.

User errors (unknown options or columns, bad values, a missing or unreadable
file, data the model cannot use, an output path that cannot be written) print
one line to stderr and give exit status 2, without traceback; warnings of the
library are one line each on stderr. Long work (λ selection, sparse and L0
fits, the RL experiment) shows a progress line on stderr when it is a
terminal, and nothing when it is piped. ``--json`` prints one JSON object
(strict JSON: NaN and infinities become ``null``) instead of the text summary.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from collections.abc import Sequence

from ..errors import OutputPathError
from .commands import load_subcommand
from .messages import CommandError, DataError, UsageError, collect_warnings, one_line
from .parser import build_parser
from .report import jsonable

__all__ = ["main", "build_parser"]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``ltvmodels`` command; returns the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on a user error (one line on stderr), 130 when
        interrupted.
    """
    parser = build_parser()
    try:
        args, extras = parser.parse_known_args(None if argv is None else list(argv))
        if extras:  # reported by the subcommand, whose options the user is typing
            prog = f"{parser.prog} {args.command}"
            raise UsageError(
                f"{prog}: error: unrecognized arguments: {' '.join(extras)} (see '{prog} --help')"
            )
    except UsageError as exc:
        print(exc, file=sys.stderr)
        return 2
    except SystemExit as exc:  # --help / --version
        return exc.code if isinstance(exc.code, int) else 0

    # Headless: the figures are plain matplotlib Figures (no pyplot), but select
    # the non-interactive Agg backend anyway unless pyplot is already in use
    # (switching then would close the caller's figures).
    import matplotlib

    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")
    prog = f"ltvmodels {args.command}"
    try:
        with collect_warnings() as caught:
            # The command loads the solvers: only now that the arguments are known to be valid.
            report, lines = load_subcommand(args.command).run(args)
    except OutputPathError as exc:
        print(f"{prog}: error: --{one_line(exc)}", file=sys.stderr)
        return 2
    except (DataError, CommandError) as exc:
        print(f"{prog}: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    for text in caught:
        print(f"{prog}: warning: {text}", file=sys.stderr)
    try:
        if getattr(args, "json", False):
            report["warnings"] = caught
            print(json.dumps(jsonable(report), indent=2, allow_nan=False))
        elif lines:
            print("\n".join(lines))
        sys.stdout.flush()
    except BrokenPipeError:  # e.g. piped into `head`: stop quietly
        with contextlib.suppress(OSError, ValueError, AttributeError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
    return 0
