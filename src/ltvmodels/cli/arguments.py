"""The options that several subcommands share, defined once, and their value types.

Each subcommand's module adds its options with its ``add_arguments(parser)``;
an option that several commands take is added by a function here, with the
same flag, type, default and metavar everywhere. Its help is the shared one
unless a command says more (``help=``). Errors of the value types are one
line (``argparse.ArgumentTypeError``). Nothing here imports more than numpy,
so that ``ltvmodels --help`` answers at once.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from .messages import CommandError

__all__ = [
    "positive_int",
    "positive_float",
    "add_data",
    "add_model_file",
    "add_state",
    "add_input",
    "add_state_options",
    "add_model_columns",
    "add_column",
    "add_na",
    "add_time",
    "regular_time",
    "add_weights",
    "add_constant",
    "add_norm",
    "add_order",
    "add_lam",
    "add_refine",
    "add_loss",
    "add_huber_delta",
    "add_noise_var",
    "add_n_changes",
    "add_sparse_options",
    "add_seed",
    "add_coef_out",
    "add_out",
    "add_json",
    "add_outputs",
]


class _Container(Protocol):
    """What options are added to: a parser, or a group of mutually exclusive options."""

    def add_argument(self, *name_or_flags: str, **kwargs: Any) -> argparse.Action: ...


def _int_at_least(minimum: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected an integer >= {minimum}, received {text!r}"
            ) from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, received {value}")
        return value

    return parse


_nonnegative_int = _int_at_least(0)
"""An argparse type: an integer >= 0."""
positive_int = _int_at_least(1)
"""An argparse type: an integer >= 1."""


def positive_float(text: str) -> float:
    """A finite number > 0 (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, received {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, received {text!r}")
    return value


def _positive_float_list(text: str) -> float | list[float]:
    """One number > 0, or comma-separated numbers > 0 (argparse type)."""
    values = [positive_float(part) for part in text.split(",")]
    return values[0] if len(values) == 1 else values


def _lam_or_auto(text: str) -> float | str:
    """A finite λ >= 0, or ``auto`` in any case (argparse type)."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number >= 0 or 'auto', received {text!r}"
        ) from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(
            f"expected a finite number >= 0 or 'auto', received {text!r}"
        )
    return value


_DATA_HELP = (
    "CSV file (a header row of column names, or --no-header; comma, semicolon or tab "
    "separated), '-' for CSV on standard input, or Parquet (.parquet, .pq; needs pandas "
    "and pyarrow); an empty cell, NA, N/A, NaN or null is a missing value"
)
_COLS_HELP = "comma-separated column names or 0-based indices"
_MODEL_COLUMNS_HELP = (
    "state columns (AR: output columns); default: those recorded in the model file"
)


def add_data(p: _Container, help: str = _DATA_HELP, *, header: bool = True) -> None:
    """The positional DATA: a CSV or Parquet file, or '-' for CSV on standard input; with
    ``header``, ``--header``/``--no-header``: how to read a CSV's first line."""
    p.add_argument("data", metavar="DATA", help=help)
    if header:
        p.add_argument(
            "--header",
            action=argparse.BooleanOptionalAction,
            default=None,
            help="whether the first line of a CSV file names the columns (default: it "
            "does when a field is not a number; a first line of numbers and missing "
            "values only must be declared: --header for names, --no-header for data, "
            "whose columns are then selected by 0-based index)",
        )


def add_model_file(p: _Container) -> None:
    """The positional MODEL: a model file written by ``fit``, ``segments`` or ``ar``."""
    p.add_argument("model", metavar="MODEL", help="model file (.npz)")


def add_state(
    p: _Container, *, required: bool = True, help: str = f"state columns x ({_COLS_HELP})"
) -> None:
    """``--state COLS``: the state columns x."""
    p.add_argument("--state", required=required, metavar="COLS", default=None, help=help)


def add_input(
    p: _Container,
    help: str = f"input columns u ({_COLS_HELP}); none for an autonomous system",
) -> None:
    """``--input COLS``: the input columns u (default: none)."""
    p.add_argument("--input", metavar="COLS", default=None, help=help)


def add_state_options(p: _Container) -> None:
    """``--state`` (required) and ``--input`` of a fit on state-space data."""
    add_state(p)
    add_input(p)


def add_model_columns(p: _Container, input_help: str) -> None:
    """``--state``/``--column`` and ``--input`` of a saved model's data (default: recorded)."""
    p.add_argument(
        "--state", "--column", dest="state", metavar="COLS", default=None, help=_MODEL_COLUMNS_HELP
    )
    add_input(p, input_help)


def add_column(p: _Container, help: str, *, required: bool = False) -> None:
    """``--column COL``: the column(s) of an AR model."""
    p.add_argument("--column", required=required, metavar="COL", default=None, help=help)


def add_na(p: _Container, help: str, *, required: bool = False) -> None:
    """``--na N``: the order of an AR model."""
    p.add_argument("--na", type=positive_int, required=required, default=None, help=help)


_TIME_RULE = (
    "column of the samples' times: numbers, or ISO 8601 dates (YYYY-MM-DD[THH:MM:SS]), "
    "strictly increasing; times missing from their regular grid become missing samples"
)


def add_time(
    p: _Container,
    effect: str = "change points are then also reported at the time of their first "
    "sample, --coef-out is indexed by time, and the model keeps the times (model.time)",
    *,
    rule: str = _TIME_RULE,
) -> None:
    """``--time COL``: the column of the samples' times (its ``rule``; the same for every
    command that fits one series) and what it changes in the command (``effect``); and
    ``--irregular``, which declares the rows consecutive samples whatever their times."""
    p.add_argument("--time", metavar="COL", default=None, help=f"{rule}; {effect}")
    p.add_argument(
        "--irregular",
        action="store_true",
        help="with --time: the rows are consecutive samples whatever their times (which "
        "must still increase); nothing is inserted, and the model keeps the times "
        "(regular=False in Python). Default: the times must lie on a regular grid",
    )


def regular_time(args: argparse.Namespace) -> bool:
    """Whether the ``--time`` stamps must lie on a regular grid: False where
    ``--irregular`` declares the rows consecutive (``regular=`` of the library)."""
    if not getattr(args, "irregular", False):
        return True
    if getattr(args, "time", None) is None:
        raise CommandError("--irregular: it says how to read the --time column; give --time")
    return False


def add_weights(
    p: _Container,
    help: str = "column of weights >= 0: the weight of the equation that predicts row "
    "t is the column's value at row t (0 drops it; the first row's value is unused)",
) -> None:
    """``--weights COL``: the column of the equations' weights."""
    p.add_argument("--weights", metavar="COL", default=None, help=help)


def add_constant(p: _Container, what: str) -> None:
    """``--constant``: include ``what`` (an intercept) in the model."""
    p.add_argument(
        "--constant", action="store_true", help=f"include {what} (an intercept; default: none)"
    )


def add_norm(
    p: _Container,
    help: str,
    *,
    choices: Sequence[str] = ("sq", "group", "l1"),
    default: str | None = "sq",
) -> None:
    """``--norm``: the penalty on the coefficients' changes."""
    p.add_argument("--norm", choices=list(choices), default=default, help=help)


def add_order(
    p: _Container,
    help: str = "order of the time difference penalized (default: 1)",
    *,
    default: int | None = 1,
) -> None:
    """``--order N``: the order of the time difference penalized."""
    p.add_argument("--order", type=positive_int, default=default, help=help)


def add_lam(p: _Container, help: str, *, default: str | None = "auto") -> None:
    """``--lam {VALUE,auto}``: λ, or ``auto`` to choose it by a criterion."""
    p.add_argument("--lam", type=_lam_or_auto, default=default, metavar="{VALUE,auto}", help=help)


def add_refine(p: _Container, help: str, *, default: bool | None = False) -> None:
    """``--refine``: the two-step refinement."""
    p.add_argument("--refine", action="store_true", default=default, help=help)


def add_loss(p: _Container, help: str, *, default: str | None = "squared") -> None:
    """``--loss``: the loss of the residuals."""
    p.add_argument("--loss", choices=["squared", "huber", "laplace"], default=default, help=help)


def add_huber_delta(p: _Container, help: str) -> None:
    """``--huber-delta D``: the Huber threshold (default: a robust rule)."""
    p.add_argument("--huber-delta", type=positive_float, default=None, metavar="D", help=help)


def add_noise_var(p: _Container, help: str) -> None:
    """``--noise-var V[,V...]``: the noise variance(s) (default: estimated)."""
    p.add_argument(
        "--noise-var", type=_positive_float_list, default=None, metavar="V[,V...]", help=help
    )


def _estimate_or_variances(text: str) -> str | float | list[float]:
    """``estimate``, or one or comma-separated numbers > 0 (argparse type)."""
    if text.strip().lower() == "estimate":
        return "estimate"
    try:
        return _positive_float_list(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected 'estimate' or variances > 0 (V or V,V,...), received {text!r}"
        ) from None


def add_measurement_noise(p: _Container, help: str) -> None:
    """``--measurement-noise {estimate,V[,V...]}``: noisy recorded states (default: exact)."""
    p.add_argument(
        "--measurement-noise",
        type=_estimate_or_variances,
        default=None,
        metavar="{estimate,V[,V...]}",
        help=help,
    )


def add_measurement_loss(p: _Container, help: str) -> None:
    """``--measurement-loss {squared,huber,student}``: the measurement model's loss."""
    p.add_argument(
        "--measurement-loss",
        choices=("squared", "huber", "student"),
        default="squared",
        help=help,
    )


def add_n_changes(p: _Container, help: str) -> None:
    """``--n-changes M``: at most M change points."""
    p.add_argument("--n-changes", type=_nonnegative_int, default=None, metavar="M", help=help)


def add_sparse_options(p: _Container) -> None:
    """``--max-iter`` and ``--tol`` of the group/l1 solvers."""
    p.add_argument(
        "--max-iter",
        type=positive_int,
        default=10000,
        metavar="N",
        help="iteration limit of the group/l1 solvers (default: 10000)",
    )
    p.add_argument(
        "--tol",
        type=positive_float,
        default=1e-6,
        help="relative tolerance of the group/l1 solvers (default: 1e-6)",
    )


def add_seed(p: _Container, help: str) -> None:
    """``--seed S``: a random seed >= 0 (default: 0)."""
    p.add_argument("--seed", type=_nonnegative_int, default=0, help=help)


def add_coef_out(p: _Container) -> None:
    """``--coef-out PATH``: a CSV file of the fitted coefficients."""
    p.add_argument(
        "--coef-out",
        metavar="PATH",
        default=None,
        help="CSV file to write the coefficients to: one row per model step t, "
        "columns 'output:regressor' (and their standard deviations, where the "
        "model has them)",
    )


def add_out(p: _Container, help: str) -> None:
    """``--out PATH``: the file the command writes."""
    p.add_argument("--out", metavar="PATH", default=None, help=help)


def add_json(p: _Container) -> None:
    """``--json``: the report as one JSON object."""
    p.add_argument(
        "--json", action="store_true", help="print one JSON object instead of the text summary"
    )


def add_outputs(p: _Container, *, out: str | None, plot: str) -> None:
    """``--out`` (unless ``out`` is None), ``--plot`` and ``--json``, with their helps.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    out : str or None
        What ``--out`` writes; None for a command without ``--out``.
    plot : str
        What the figure shows.
    """
    if out is not None:
        add_out(p, out)
    p.add_argument(
        "--plot",
        metavar="PATH",
        default=None,
        help=f"{plot} (image; format from the suffix, png without one)",
    )
    add_json(p)
