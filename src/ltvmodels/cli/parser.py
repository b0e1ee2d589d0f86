"""The ``ltvmodels`` argument parser: subcommands, options and their types.

The command line uses :mod:`argparse` from the standard library: the
subcommands need nothing it lacks, and an extra dependency (click, typer) for
every user of the library is not justified. A small subclass makes its errors
one line. Building the parser imports nothing heavy, so that ``ltvmodels
--help`` answers at once.
"""

from __future__ import annotations

import argparse
from typing import NoReturn

import numpy as np

from .. import __version__
from ..apps.defaults import DEFAULT_DEMO_OUT, JUMP_LINEAR_LAM
from .messages import UsageError


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (no usage dump) and are raised, not exited."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: error: {message} (see '{self.prog} --help')")


def _int_at_least(minimum: int):
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
_positive_int = _int_at_least(1)


def _probability(text: str) -> float:
    """A probability strictly between 0 and 1 (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), received {text!r}")
    return value


def _positive_float_list(text: str) -> float | list[float]:
    """One number > 0, or comma-separated numbers > 0 (argparse type)."""
    values = [_positive_float(part) for part in text.split(",")]
    return values[0] if len(values) == 1 else values


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, received {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, received {text!r}")
    return value


def _lam_or_auto(text: str) -> float | str:
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


def _penalty(text: str) -> float | str:
    if text.strip().lower() in ("bic", "aic"):
        return text.strip().lower()
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number >= 0, 'bic' or 'aic', received {text!r}"
        ) from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(
            f"expected a finite number >= 0, 'bic' or 'aic', received {text!r}"
        )
    return value


_DATA_HELP = (
    "CSV file (header row optional; comma, semicolon or tab separated), '-' for CSV "
    "on standard input, or Parquet (.parquet, .pq; needs pandas and pyarrow); an "
    "empty cell, NA, N/A, NaN or null is a missing value"
)
_COLS_HELP = "comma-separated column names or 0-based indices"


def _add_state_options(p: argparse.ArgumentParser, *, required: bool = True) -> None:
    p.add_argument(
        "--state", required=required, metavar="COLS", help=f"state columns x ({_COLS_HELP})"
    )
    p.add_argument(
        "--input",
        metavar="COLS",
        default=None,
        help=f"input columns u ({_COLS_HELP}); none for an autonomous system",
    )


def _add_time_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--time",
        metavar="COL",
        default=None,
        help="column of the samples' times: numbers, or ISO 8601 dates "
        "(YYYY-MM-DD[THH:MM:SS]); change points are then also reported as times, "
        "and the model keeps them (model.time)",
    )


def _add_weights_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--weights",
        metavar="COL",
        default=None,
        help="column of weights >= 0: the weight of the equation that predicts row "
        "t is the column's value at row t (0 drops it; the first row's value is "
        "unused)",
    )


def _add_coef_out_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--coef-out",
        metavar="PATH",
        default=None,
        help="CSV file to write the coefficients to: one row per model step t, "
        "columns 'output:regressor' (and their standard deviations, where the "
        "model has them)",
    )


def _add_constant_option(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument(
        "--constant", action="store_true", help=f"include {what} (an intercept; default: none)"
    )


def _add_sparse_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--max-iter",
        type=_positive_int,
        default=10000,
        metavar="N",
        help="iteration limit of the group/l1 solvers (default: 10000)",
    )
    p.add_argument(
        "--tol",
        type=_positive_float,
        default=1e-6,
        help="relative tolerance of the group/l1 solvers (default: 1e-6)",
    )


def _add_outputs(p: argparse.ArgumentParser, *, out: str | None, plot: str) -> None:
    if out is not None:
        p.add_argument("--out", metavar="PATH", default=None, help=out)
    p.add_argument(
        "--plot",
        metavar="PATH",
        default=None,
        help=f"{plot} (image; format from the suffix, png without one)",
    )
    p.add_argument(
        "--json", action="store_true", help="print one JSON object instead of the text summary"
    )


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
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    fit = commands.add_parser(
        "fit",
        help="identify an LTV model from states and inputs in a data file",
        description="Identify x[t+1] = A_t x[t] + B_t u[t] (+ c_t) + v_t from a data file: "
        "print the lambda used, one-step prediction and open-loop simulation RMS, change "
        "points and solver status; optionally save the model and a figure. Missing values "
        "in the data leave out the transitions they touch.",
    )
    fit.add_argument("data", metavar="DATA", help=_DATA_HELP)
    _add_state_options(fit)
    fit.add_argument(
        "--norm",
        choices=["sq", "group", "l1"],
        default="sq",
        help="sq: slowly varying or smooth (default); group: piecewise constant "
        "(order 1) or linear (order 2); l1: sparse changes per coefficient",
    )
    fit.add_argument(
        "--order",
        type=_positive_int,
        default=1,
        help="order of the time difference penalized (default: 1)",
    )
    fit.add_argument(
        "--lam",
        type=_lam_or_auto,
        default="auto",
        metavar="{VALUE,auto}",
        help="regularization lambda, or auto: chosen by the norm's default "
        "criterion (marginal likelihood for sq, L-curve for group/l1; default)",
    )
    fit.add_argument(
        "--refine",
        action="store_true",
        help="two-step refinement: refit piecewise between the detected change points",
    )
    fit.add_argument(
        "--loss",
        choices=["squared", "huber", "laplace"],
        default="squared",
        help="loss of the residuals: squared (default), huber (robust to "
        "outliers) or laplace (absolute values, the most robust); with a robust "
        "loss, --lam auto is cross-validation scored with that loss",
    )
    fit.add_argument(
        "--huber-delta",
        type=_positive_float,
        default=None,
        metavar="D",
        help="Huber threshold in the units of the states (default: 1.345 x the "
        "robust scale of the squared-loss residuals)",
    )
    fit.add_argument(
        "--noise-var",
        type=_positive_float_list,
        default=None,
        metavar="V[,V...]",
        help="noise variance of the state equations, one or one per state "
        "(default: estimated); with --norm sq it scales a prior-free fit's "
        "likelihood and covariances",
    )
    _add_weights_option(fit)
    _add_time_option(fit)
    _add_constant_option(
        fit, "a time-varying constant term c_t in x[t+1] = A_t x[t] + B_t u[t] + c_t"
    )
    _add_sparse_options(fit)
    _add_coef_out_option(fit)
    _add_outputs(
        fit,
        out="model file to write (.npz; read it with ltvmodels.load or 'ltvmodels simulate')",
        plot="figure: coefficients with ±2σ bands, activation with change points, "
        "eigenvalue magnitudes",
    )

    seg = commands.add_parser(
        "segments",
        help="piecewise-constant model with exactly optimal change points",
        description="Fit a piecewise-constant LTV model whose change points are globally "
        "optimal: at most M changes (dynamic programming) or a penalty per change (PELT).",
    )
    seg.add_argument("data", metavar="DATA", help=_DATA_HELP)
    _add_state_options(seg)
    group = seg.add_mutually_exclusive_group()
    group.add_argument(
        "--n-changes", type=_nonnegative_int, default=None, metavar="M", help="at most M changes"
    )
    group.add_argument(
        "--penalty",
        type=_penalty,
        default=None,
        metavar="{B,bic,aic}",
        help="cost B >= 0 per change (in units of the residual sum of "
        "squares), or the rule bic or aic (default: bic)",
    )
    seg.add_argument(
        "--min-size",
        type=_positive_int,
        default=None,
        metavar="S",
        help="minimum segment length (default: n + m, or n + m + 1 with --constant)",
    )
    _add_weights_option(seg)
    _add_time_option(seg)
    _add_constant_option(seg, "a constant term c_t per segment")
    _add_coef_out_option(seg)
    _add_outputs(
        seg,
        out="model file to write (.npz)",
        plot="figure: coefficients, activation with change points, eigenvalues",
    )

    ar = commands.add_parser(
        "ar",
        help="time-varying AR model of one column and its root spectrogram",
        description="Fit a time-varying AR(na) model y[t] = sum_i a_{t,i} y[t-i] + e[t] to "
        "a column and report its root spectrogram (pole frequencies over time).",
    )
    ar.add_argument("data", metavar="DATA", help=_DATA_HELP)
    ar.add_argument(
        "--column",
        required=True,
        metavar="COL",
        help="the signal's column (name or 0-based index; several for a vector AR model)",
    )
    ar.add_argument("--na", type=_positive_int, required=True, help="AR order")
    ar.add_argument(
        "--fs",
        type=_positive_float,
        default=1.0,
        metavar="HZ",
        help="sampling frequency (default: 1, frequencies in cycles per sample)",
    )
    ar.add_argument(
        "--norm",
        choices=["sq", "group", "l1"],
        default="sq",
        help="penalty on the coefficient changes (default: sq)",
    )
    ar.add_argument(
        "--order",
        type=_positive_int,
        default=1,
        help="order of the time difference penalized (default: 1)",
    )
    ar.add_argument(
        "--lam",
        type=_lam_or_auto,
        default="auto",
        metavar="{VALUE,auto}",
        help="regularization lambda or auto (default: auto)",
    )
    ar.add_argument(
        "--noise-var",
        type=_positive_float_list,
        default=None,
        metavar="V[,V...]",
        help="noise variance, one or one per column (default: estimated)",
    )
    _add_weights_option(ar)
    _add_constant_option(ar, "a time-varying offset c_t")
    _add_sparse_options(ar)
    _add_coef_out_option(ar)
    _add_outputs(
        ar,
        out="model file to write (.npz)",
        plot="figure: root spectrogram over the short-time Fourier spectrogram",
    )

    sel = commands.add_parser(
        "select-lambda",
        help="choose lambda by a criterion and show its curve",
        description="Evaluate a criterion on a grid of lambda values (or numbers of changes "
        "for --norm l0) and report the choice; for state-space data (--state) or an AR "
        "model of a column (--column, --na).",
    )
    sel.add_argument("data", metavar="DATA", help=_DATA_HELP)
    sel.add_argument(
        "--state", metavar="COLS", default=None, help=f"state columns x ({_COLS_HELP})"
    )
    sel.add_argument("--input", metavar="COLS", default=None, help="input columns u")
    sel.add_argument(
        "--column",
        metavar="COL",
        default=None,
        help="instead of --state: the column of an AR model (with --na)",
    )
    sel.add_argument("--na", type=_positive_int, default=None, help="AR order (with --column)")
    sel.add_argument(
        "--norm",
        choices=["sq", "group", "l1", "l0"],
        default="sq",
        help="penalty (default: sq); l0 chooses the number of changes of 'ltvmodels segments'",
    )
    sel.add_argument(
        "--order",
        type=_positive_int,
        default=1,
        help="order of the time difference penalized (default: 1)",
    )
    sel.add_argument(
        "--method",
        default=None,
        help="criterion: sq: ml (default), gcv, lcurve, cv; group/l1: lcurve "
        "(default), cv; l0: bic (default), aic",
    )
    sel.add_argument(
        "--loss",
        choices=["squared", "huber", "laplace"],
        default="squared",
        help="loss of the residuals (as fit --loss); a robust loss takes the "
        "criterion cv, scored with that loss",
    )
    sel.add_argument(
        "--huber-delta",
        type=_positive_float,
        default=None,
        metavar="D",
        help="Huber threshold with --loss huber (default: the robust rule)",
    )
    _add_weights_option(sel)
    _add_constant_option(
        sel, "a constant term c_t in the models compared (as fit, segments or ar with --constant)"
    )
    _add_outputs(sel, out=None, plot="figure of the criterion (or L-curve) with the choice")

    for name, noun in (("simulate", "open-loop simulation"), ("predict", "one-step predictions")):
        sub = commands.add_parser(
            name,
            help=f"{noun} of a saved model on a data file",
            description=f"Load a model file (from fit, segments or ar) and compute its {noun} "
            "on a data file: "
            + (
                "from the first state (AR: the first na samples) with the data's inputs."
                if name == "simulate"
                else "of every sample from the measured data before it."
            )
            + " Data columns default to those the model was fitted on.",
        )
        sub.add_argument("model", metavar="MODEL", help="model file (.npz)")
        sub.add_argument("data", metavar="DATA", help=_DATA_HELP)
        sub.add_argument(
            "--state",
            "--column",
            dest="state",
            metavar="COLS",
            default=None,
            help="state columns (AR: output columns); default: those recorded in the model file",
        )
        sub.add_argument(
            "--input",
            metavar="COLS",
            default=None,
            help="input columns; default: those recorded in the model file",
        )
        _add_outputs(
            sub, out=f"CSV file to write: t and the {noun}", plot=f"figure: {noun} against the data"
        )

    fc = commands.add_parser(
        "forecast",
        help="forecast of a saved model after the end of its data, with intervals",
        description="Load a model file (from fit, segments or ar) and forecast the states "
        "(AR: the outputs) after the end of the data it was fitted on, with prediction "
        "intervals: the coefficients continue as the penalty's model says, their "
        "uncertainty and the noise propagate (see ltvmodels.LTVModel.forecast). Data "
        "columns default to those the model was fitted on.",
    )
    fc.add_argument("model", metavar="MODEL", help="model file (.npz)")
    fc.add_argument("data", metavar="DATA", help=_DATA_HELP)
    fc.add_argument(
        "--steps",
        type=_positive_int,
        required=True,
        metavar="H",
        help="number of samples to forecast",
    )
    fc.add_argument(
        "--level",
        type=_probability,
        default=0.95,
        metavar="P",
        help="probability of the prediction intervals (default: 0.95)",
    )
    fc.add_argument(
        "--future-input",
        metavar="FILE",
        default=None,
        help="models with inputs: a data file with the input columns after the "
        "end of DATA, one row per sample, at least H rows (a state-space model "
        "uses the first H - 1: its first step is driven by DATA's last input)",
    )
    fc.add_argument(
        "--seed",
        type=_nonnegative_int,
        default=0,
        help="seed of the Monte Carlo samples beyond the first step (default: 0)",
    )
    fc.add_argument(
        "--state",
        "--column",
        dest="state",
        metavar="COLS",
        default=None,
        help="state columns (AR: output columns); default: those recorded in the model file",
    )
    fc.add_argument(
        "--input",
        metavar="COLS",
        default=None,
        help="input columns (in DATA and --future-input); default: those "
        "recorded in the model file",
    )
    _add_outputs(
        fc,
        out="CSV file to write: t and, per state, the mean, lower and upper bound",
        plot="figure: the end of the data and the forecast with its band",
    )

    demo = commands.add_parser(
        "demo",
        help="run an example of the paper on built-in data, report and plot",
        description="Run an example on built-in data in seconds, print a report and write "
        "figures. jump-linear: the jump-linear system of the paper (Section VI, Fig. 1); "
        "robot: a two-link arm with friction and contact (Figs. 2-3); chirp: root "
        "spectrogram of a chirp by AR models; rl: model-based reinforcement learning on a "
        "cart-pole (Section VIII, Fig. 4); pendulum: the same with LTV and LTI models on "
        "gymnasium's Pendulum-v1 (needs gymnasium: pip install 'ltvmodels[rl]').",
    )
    demo.add_argument(
        "system", choices=list(DEFAULT_DEMO_OUT), help="jump-linear, robot, chirp, rl or pendulum"
    )
    demo.add_argument(
        "--seed", type=_nonnegative_int, default=0, help="seed of the simulation (default: 0)"
    )
    demo.add_argument(
        "--norm",
        choices=["group", "sq"],
        default=None,
        help="jump-linear only. group: piecewise-constant fit with two-step "
        "refinement, the paper's Fig. 1 (default); sq: slowly varying fit",
    )
    demo.add_argument(
        "--lam",
        type=_positive_float,
        default=None,
        help="jump-linear only: regularization lambda (default: "
        f"0.1·lambda_max for group, {JUMP_LINEAR_LAM:g} for sq)",
    )
    demo.add_argument(
        "--out",
        default=None,
        metavar="PATH",
        help="image file to write (default: ltvmodels-<system>.png; format from "
        "the suffix); robot writes <stem>_train and <stem>_validation",
    )
    demo.add_argument(
        "--quick",
        action="store_true",
        help="chirp, rl and pendulum only: a smaller problem (chirp: 2^12 "
        "samples; rl: 1 run of 4 iterations; pendulum: 1 initial state)",
    )
    demo.add_argument(
        "--full",
        action="store_true",
        help="rl: the paper's 20 runs of 14 iterations (default: 3 runs of 8); "
        "pendulum: 20 initial states of 40 iterations (default: 2 of 20)",
    )
    many = commands.add_parser(
        "fit-many",
        help="one model per unit of a long table (fleets, panels, many loops)",
        description="Fit one LTV model per unit of a long table (one row per unit and time "
        "step) on all local cores or a Dask cluster, and write one summary row per unit: "
        "lambda, noise variances, log-likelihood, one-step RMS, change points, status, "
        "seconds, or the error of a unit that failed (one bad unit never stops the others).",
    )
    many.add_argument(
        "data", metavar="DATA", help="CSV file ('-' for standard input) or Parquet (.parquet, .pq)"
    )
    many.add_argument("--by", required=True, metavar="COL", help="the unit column")
    many.add_argument(
        "--state", required=True, metavar="COLS", help="state columns x (comma-separated names)"
    )
    many.add_argument(
        "--input",
        metavar="COLS",
        default=None,
        help="input columns u (comma-separated names); none for an autonomous system",
    )
    many.add_argument(
        "--time",
        metavar="COL",
        default=None,
        help="column to sort each unit's rows by: numbers or dates (default: the rows' order)",
    )
    many.add_argument(
        "--method",
        choices=["fit", "segments", "lti"],
        default="fit",
        help="fit (default), segments (exact change points, BIC penalty unless "
        "--n-changes) or lti (least squares)",
    )
    # The estimator options default to None, so that one given to a method that does not
    # take it is an error (ltvmodels.cli.many); --method fit's defaults are the library's.
    many.add_argument(
        "--norm",
        choices=["sq", "group", "l1"],
        default=None,
        help="penalty of --method fit (default: sq)",
    )
    many.add_argument(
        "--order",
        type=_positive_int,
        default=None,
        help="--method fit: order of the time difference penalized (default: 1)",
    )
    many.add_argument(
        "--lam",
        type=_lam_or_auto,
        default=None,
        metavar="{VALUE,auto}",
        help="--method fit: regularization lambda, or auto: chosen per unit (default)",
    )
    many.add_argument(
        "--refine", action="store_true", default=None, help="--method fit: two-step refinement"
    )
    many.add_argument(
        "--loss",
        choices=["squared", "huber", "laplace"],
        default=None,
        help="--method fit or lti: loss of the residuals (default: squared)",
    )
    many.add_argument(
        "--n-changes",
        type=_nonnegative_int,
        default=None,
        metavar="M",
        help="--method segments: at most M changes per unit",
    )
    many.add_argument(
        "--weights",
        metavar="COL",
        default=None,
        help="column of weights >= 0 (row t weighs the transition to t + 1)",
    )
    _add_constant_option(many, "a constant term c_t")
    many.add_argument(
        "--out", metavar="PATH", default=None, help="summary file to write (.csv, or .parquet/.pq)"
    )
    many.add_argument(
        "--models-dir",
        metavar="DIR",
        default=None,
        help="directory for every unit's model file and the manifest "
        "(read it with ltvmodels.load_many)",
    )
    many.add_argument(
        "--jobs",
        type=_positive_int,
        default=None,
        metavar="N",
        help="local worker processes (default: all cores for a job large enough to gain "
        "from them; 1: this process)",
    )
    many.add_argument(
        "--stall-timeout",
        type=_positive_float,
        default=None,
        metavar="SECONDS",
        help="give up on the units without a result when no task has finished for this long "
        "(default: 600 s until a task has finished, then 60 s or 20 times the longest task; "
        "600 s on a Dask cluster)",
    )
    many.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="address of a Dask scheduler (e.g. tcp://host:8786) to fit on "
        "its workers instead (needs 'ltvmodels[dask]')",
    )
    many.add_argument(
        "--json", action="store_true", help="print one JSON object instead of the text summary"
    )
    return parser
