"""``ltvmodels fit-many``: one model per unit of a long table (CSV or Parquet).

The table has one row per unit and time step; ``--by`` names the unit
column, ``--state``/``--input`` the columns of x and u, ``--time`` the column
each unit's rows are sorted by (dates or numbers). The summary (one row per
unit: see :attr:`ltvmodels.ModelSet.summary`) goes to ``--out`` (CSV, or
Parquet by its suffix); ``--models-dir`` keeps every model file and the
manifest that :func:`ltvmodels.load_many` reads. The options of the
estimator go to the ``--method`` that takes them (``_METHOD_OPTIONS``): one
given with another method is an error, as are outputs that cannot be
written, all before any unit is fitted.
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from typing import Any

from .. import arguments as opt
from ..messages import CommandError, DataError, user_errors
from ..report import Report
from ..subcommand import Subcommand

__all__ = ["COMMAND", "add_arguments", "run"]

# How many failed units the text summary lists (--json lists them all).
_LISTED_ERRORS = 5

# The estimator options of fit-many: their option, and the methods whose estimator takes
# them (the parser leaves them None when not given).
_METHOD_OPTIONS = {
    "lam": ("--lam", ("fit",)),
    "norm": ("--norm", ("fit",)),
    "order": ("--order", ("fit",)),
    "refine": ("--refine", ("fit",)),
    "loss": ("--loss", ("fit", "lti")),
    "n_changes": ("--n-changes", ("segments",)),
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``fit-many``."""
    opt.add_data(
        p,
        "CSV file with a header row of column names ('-' for standard input) or "
        "Parquet (.parquet, .pq)",
        header=False,
    )
    p.add_argument("--by", required=True, metavar="COL", help="the unit column")
    opt.add_state(p, help="state columns x (comma-separated names)")
    opt.add_input(p, "input columns u (comma-separated names); none for an autonomous system")
    opt.add_time(
        p,
        "times missing from a unit's regular grid become missing samples (a warning in "
        "the summary's warnings column). Default: the rows' order",
        rule="column of the time stamps: numbers, or ISO 8601 dates (YYYY-MM-DD[THH:MM:SS]) "
        "as for the other commands, by which each unit's rows are sorted",
    )
    p.add_argument(
        "--method",
        choices=["fit", "segments", "lti"],
        default="fit",
        help="fit (default), segments (exact change points, BIC penalty unless "
        "--n-changes) or lti (least squares)",
    )
    # The estimator options default to None, so that one given to a method that does not
    # take it is an error (_estimator_options); --method fit's defaults are the library's.
    opt.add_norm(p, "penalty of --method fit (default: sq)", default=None)
    opt.add_order(
        p, "--method fit: order of the time difference penalized (default: 1)", default=None
    )
    opt.add_lam(
        p, "--method fit: regularization lambda, or auto: chosen per unit (default)", default=None
    )
    opt.add_refine(p, "--method fit: two-step refinement", default=None)
    opt.add_loss(p, "--method fit or lti: loss of the residuals (default: squared)", default=None)
    opt.add_n_changes(p, "--method segments: at most M changes per unit")
    opt.add_weights(p, "column of weights >= 0 (row t weighs the transition to t + 1)")
    opt.add_constant(p, "a constant term c_t")
    opt.add_out(p, "summary file to write (.csv, or .parquet/.pq)")
    p.add_argument(
        "--models-dir",
        metavar="DIR",
        default=None,
        help="directory for every unit's model file and the manifest "
        "(read it with ltvmodels.load_many)",
    )
    p.add_argument(
        "--jobs",
        type=opt.positive_int,
        default=None,
        metavar="N",
        help="local worker processes (default: all cores for a job large enough to gain "
        "from them; 1: this process)",
    )
    p.add_argument(
        "--stall-timeout",
        type=opt.positive_float,
        default=None,
        metavar="SECONDS",
        help="give up on the units without a result when no task has finished for this long "
        "(default: 600 s until a task has finished, then 60 s or 20 times the longest task; "
        "600 s on a Dask cluster)",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="address of a Dask scheduler (e.g. tcp://host:8786) to fit on "
        "its workers instead (needs 'ltvmodels[dask]')",
    )
    opt.add_json(p)


def _read_table(path: str) -> Any:
    """The data file as a pandas DataFrame (CSV, '-' for standard input, or Parquet)."""
    from pathlib import Path

    from ..data import PARQUET_SUFFIXES

    try:
        import pandas as pd
    except ImportError:
        raise CommandError("fit-many needs pandas: pip install 'ltvmodels[pandas]'") from None
    if path != "-" and not Path(path).is_file():
        raise DataError(f"{path}: no such file")
    try:
        if path != "-" and Path(path).suffix.lower() in PARQUET_SUFFIXES:
            return pd.read_parquet(path)
        text = sys.stdin.read() if path == "-" else None
        if text is None:
            with open(path, encoding="utf-8-sig") as handle:
                first = handle.readline()
        else:
            first = text.lstrip("\ufeff").split("\n", 1)[0]
        separator = max(",;\t", key=first.count)  # as the other commands detect it
        source = io.StringIO(text) if text is not None else path
        return pd.read_csv(
            source,
            sep=separator,
            comment="#",
            encoding="utf-8-sig",
            na_values=["NA", "N/A", "NaN", "null", "na", "n/a", "nan"],
            # the numbers as written (pandas' default parser is off by an ulp on
            # about a third of them in some versions): the same fit as in Python
            float_precision="round_trip",
        )
    except (ValueError, OSError, ImportError) as exc:
        raise DataError(f"{path}: cannot read it as a table ({exc})") from None


def _columns(text: str | None) -> list[str]:
    """The names of a comma-separated ``--state``/``--input`` (none: empty)."""
    return [] if text is None else [name.strip() for name in text.split(",") if name.strip()]


def _parse_time_column(frame: Any, name: str | None, label: str) -> None:
    """Convert a text time column in place by the rule of every command's ``--time``
    (numbers, or ISO 8601 dates); numbers and dates stay as they are."""
    if name is None or name not in frame.columns or frame[name].dtype.kind in "biufM":
        return
    from ..data import parse_times

    column = frame[name]
    fields = ["" if missing else str(value) for value, missing in zip(column, column.isna())]
    frame[name] = parse_times(fields, label, name)


def _connect(address: str | None) -> Any:
    """A dask.distributed Client of the scheduler at ``address`` (None: no cluster)."""
    if address is None:
        return None
    try:
        from distributed import Client
    except ImportError:
        raise CommandError(
            "--scheduler needs dask.distributed: pip install 'ltvmodels[dask]'"
        ) from None
    try:
        return Client(address, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise CommandError(
            f"--scheduler: cannot connect to {address} ({exc}); start one "
            "with 'dask scheduler' and 'dask worker ADDRESS'"
        ) from None


def _estimator_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options of ``--method``'s estimator; an option it does not take is an error.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``fit-many`` arguments.

    Returns
    -------
    dict
        Keyword arguments of :func:`ltvmodels.fit_many` (``lam="auto"`` for
        ``--method fit`` without ``--lam``).

    Raises
    ------
    CommandError
        An option given with a method that would ignore it (e.g. ``--lam``
        with ``--method segments``); the message names both.
    """
    options: dict[str, Any] = {"constant": args.constant}
    for name, (flag, methods) in _METHOD_OPTIONS.items():
        value = getattr(args, name)
        if value is None:
            continue
        if args.method not in methods:
            raise CommandError(
                f"{flag}: not an option of --method {args.method}; it applies to --method "
                f"{' or '.join(methods)} (leave it out, or choose that method)"
            )
        options[name] = value
    if args.method == "fit":
        options.setdefault("lam", "auto")
    if args.weights is not None:
        options["weights"] = args.weights
    if not opt.regular_time(args):  # every method takes it; fit_many passes it to each unit
        options["regular"] = False
    return options


def run(args: argparse.Namespace) -> Report:
    """Run ``fit-many``: returns the report and the text summary.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``fit-many`` arguments.

    Returns
    -------
    report : dict
        What ``--json`` prints.
    lines : list of str
        The text summary.

    Raises
    ------
    CommandError, DataError, OutputPathError
        User errors (printed as one line, exit status 2). The options, the
        data and the outputs (``--out``, ``--models-dir``) are checked before
        any unit is fitted.
    """
    from ...estimators.many import fit_many
    from ...plotting.figure import output_file
    from ...results.manifest import output_directory

    options = _estimator_options(args)
    frame = _read_table(args.data)
    _parse_time_column(frame, args.time, args.data)
    if args.out is not None:
        output_file(args.out, "out")
    if args.models_dir is not None:
        output_directory(args.models_dir, "models-dir")
    client = _connect(args.scheduler)
    start = time.perf_counter()
    try:
        with user_errors():
            models = fit_many(
                frame,
                by=args.by,
                state=_columns(args.state),
                inputs=_columns(args.input) or None,
                time=args.time,
                engine=client,
                n_jobs=args.jobs,
                stall_timeout=args.stall_timeout,
                keep_models=False,
                models_dir=args.models_dir,
                method=args.method,
                **options,
            )
    finally:
        if client is not None:
            client.close()
    seconds = time.perf_counter() - start
    summary = models.summary
    n_units, n_failed = len(models.units), len(models.errors)
    where = (
        f"the cluster at {args.scheduler}"
        if args.scheduler
        else "this process"
        if args.jobs == 1
        else f"{args.jobs or 'all'} local processes"
    )
    lines = [
        f"fit-many: {n_units} units of {args.data} (by {args.by!r}): "
        f"{n_units - n_failed} fitted, {n_failed} failed, in {seconds:.1f} s "
        f"({n_units / max(seconds, 1e-9):.3g} units/s) on {where}"
    ]
    for unit, message in list(models.errors.items())[:_LISTED_ERRORS]:
        lines.append(f"  unit {unit!r}: {message}")
    if n_failed > _LISTED_ERRORS:
        lines.append(
            f"  ... and {n_failed - _LISTED_ERRORS} more (see the summary's 'error' column)"
        )
    warned = int(summary["warnings"].notna().sum()) if "warnings" in summary else 0
    if warned:
        lines.append(f"  {warned} units fitted with warnings (see the summary's 'warnings' column)")
    report: dict[str, Any] = {
        "n_units": n_units,
        "n_fitted": n_units - n_failed,
        "n_failed": n_failed,
        "n_warned": warned,
        "seconds": seconds,
        "errors": {str(unit): text for unit, text in models.errors.items()},
    }
    if args.out is not None:
        _write_summary(summary, args.out)
        report["summary"] = str(args.out)
        lines.append(f"summary: {args.out} (one row per unit)")
    if args.models_dir is not None:
        report["models_dir"] = str(args.models_dir)
        lines.append(f"models: {args.models_dir} (read them with ltvmodels.load_many)")
    return report, lines


def _write_summary(summary: Any, out: str) -> None:
    """The summary as CSV, or Parquet for a .parquet/.pq path."""
    from pathlib import Path

    from ..data import PARQUET_SUFFIXES

    path = Path(out)
    try:
        if path.suffix.lower() in PARQUET_SUFFIXES:
            summary.to_parquet(path)
        else:
            summary.to_csv(path)
    except (OSError, ImportError, ValueError) as exc:
        raise CommandError(f"--out: cannot write {path} ({exc})") from None


COMMAND = Subcommand(
    description="Fit one LTV model per unit of a long table (one row per unit and time "
    "step) on all local cores or a Dask cluster, and write one summary row per unit: "
    "lambda, noise variances, log-likelihood, one-step RMS, change points, status, "
    "seconds, or the error of a unit that failed (one bad unit never stops the others).",
    add_arguments=add_arguments,
    run=run,
)
