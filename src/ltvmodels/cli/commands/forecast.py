"""``ltvmodels forecast``: a saved model's forecast after the end of its data, with intervals."""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import arguments as opt
from ..messages import DataError, user_errors
from ..report import Report, fmt, time_text
from ..subcommand import Subcommand

if TYPE_CHECKING:  # pragma: no cover
    from ..saved import ModelData

__all__ = ["COMMAND", "add_arguments", "run"]


def _probability(text: str) -> float:
    """A probability strictly between 0 and 1 (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), received {text!r}")
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``forecast``."""
    opt.add_model_file(p)
    opt.add_data(p)
    p.add_argument(
        "--steps",
        type=opt.positive_int,
        required=True,
        metavar="H",
        help="number of samples to forecast",
    )
    p.add_argument(
        "--level",
        type=_probability,
        default=0.95,
        metavar="P",
        help="probability of the prediction intervals (default: 0.95)",
    )
    p.add_argument(
        "--future-input",
        metavar="FILE",
        default=None,
        help="models with inputs: a data file with the input columns after the "
        "end of DATA, one row per sample (row j at the forecast sample T + j), as "
        "model.forecast(steps=H, u=...) takes them: a state-space model reads the "
        "first H - 1 (its first step is driven by DATA's last input), an ARX model "
        "the first H - nk; further rows are unused; its first line is read as DATA's "
        "(--header, --no-header)",
    )
    opt.add_seed(p, "seed of the Monte Carlo samples beyond the first step (default: 0)")
    opt.add_model_columns(
        p,
        "input columns (in DATA and --future-input); default: those recorded in the model file",
    )
    opt.add_outputs(
        p,
        out="CSV file to write: t and, per state, the mean, lower and upper bound",
        plot="figure: the end of the data and the forecast with its band",
    )


def run(args: argparse.Namespace) -> Report:
    """Forecast a saved model after the end of DATA (the data it was fitted on, or other
    data of the same length): DATA's last samples start it, as a model's own do in
    ``model.forecast(steps=H, u=future)``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``forecast`` arguments.

    Returns
    -------
    report : dict
        What ``--json`` prints.
    lines : list of str
        The text summary.
    """
    from ...results.description import DataTail
    from ...validation.arrays import representable
    from ..outputs import Table, check_outputs, figure_errors, write_outputs
    from ..saved import load_model, model_data

    outputs = check_outputs(args, "table")
    model = load_model(args.model)
    data = model_data(args, model)
    kind, y, u, lag, H = data.kind, data.y, data.u, data.lag, args.steps
    future = _future_inputs(args, data, model.future_input_rows(H))
    with user_errors(f"{data.label}: "):
        representable(y[-lag:], "--state" if kind == "ltv" else "--column", names=data.names)
    # DATA's end becomes the end of the model's data, and the model continues it as
    # model.forecast(steps=H, u=future) continues its own: one convention, one code path.
    tail = DataTail.of(y[None], None if u is None else u[None], model.tail_lengths)
    if tail is None:
        outputs, inputs = model.tail_lengths
        where = f"the last {_rows(outputs)} of its {'state' if kind == 'ltv' else 'output'} columns"
        where += f" and the last {_rows(inputs)} of its input columns" if inputs else ""
        raise DataError(
            f"{data.label}: the forecast continues the end of DATA, which has missing values "
            f"in the samples it starts from ({where}); give DATA whose last samples are observed"
        )
    continued = model.with_data(model.data.with_tail(tail))
    with user_errors():
        if future is None:
            forecast = continued.forecast(steps=H, level=args.level, seed=args.seed)
        else:
            forecast = continued.forecast(steps=H, u=future, level=args.level, seed=args.seed)
    names = data.names
    forecast = replace(forecast, names=names)  # the data's column names
    times = time_text(forecast.time)  # sample indices, or the dates of a dated model
    report: dict[str, Any] = {
        "command": "forecast",
        "model_file": str(args.model),
        "model": type(model).__name__,
        "data": data.label,
        "T": data.T,
        "columns": names,
        "steps": H,
        "level": args.level,
        "method": forecast.method,
        "time": times,
        "mean": forecast.mean.tolist(),
        "lower": forecast.lower.tolist(),
        "upper": forecast.upper.tolist(),
    }
    percent = f"{100 * args.level:g} %"
    lines = [
        f"ltvmodels forecast: {args.model} after {data.label} (T = {data.T} samples; "
        f"columns {', '.join(names)})",
        repr(model),
        f"{H} samples, t = {times[0]} to {times[-1]}; {percent} prediction "
        f"intervals ({'exact' if forecast.method == 'gaussian' else 'exact first step, '}"
        f"{'' if forecast.method == 'gaussian' else 'Monte Carlo beyond'})",
    ]
    shown = list(range(min(H, 3))) + ([H - 1] if H > 3 else [])
    for j in shown:
        cells = ", ".join(
            f"{name} {fmt(forecast.mean[j, i])} [{fmt(forecast.lower[j, i])}, "
            f"{fmt(forecast.upper[j, i])}]"
            for i, name in enumerate(names)
        )
        lines.append(f"  t = {times[j]}: {cells}")
    fig = None
    if outputs.plot is not None:
        with figure_errors(None):
            # the model's last samples, at their times: the forecast's are those after them
            end = model.N + model.produced_offset
            rows = min(len(y), end, max(4 * H, 50))
            fig = forecast.plot(history=y[-rows:], history_time=model.times_after(end - rows, rows))
            fig.suptitle(f"{args.model} after {data.label}: forecast, {percent} intervals")
    columns = [f"{name}{suffix}" for name in names for suffix in ("", "_lower", "_upper")]
    values = np.column_stack(
        [
            part[:, i]
            for i in range(len(names))
            for part in (forecast.mean, forecast.lower, forecast.upper)
        ]
    )
    table = Table(["t", *columns], values, row_labels=times)
    return write_outputs(outputs, report, lines, table=table, figure=fig)


def _rows(count: int) -> str:
    """``count`` rows in words: "row" for one, else "<count> rows"."""
    return "row" if count == 1 else f"{count} rows"


def _future_inputs(args: argparse.Namespace, data: ModelData, needed: int) -> np.ndarray | None:
    """The ``needed`` inputs after the end of DATA from --future-input (None for a model
    without inputs)."""
    from ..data import read_columns

    m = len(data.input_names)
    if not m:
        if args.future_input is not None:
            raise DataError("--future-input: the model has no inputs")
        return None
    if args.future_input is None:
        if needed == 0:
            return np.zeros((0, m))
        raise DataError(
            f"--future-input: the model has inputs ({', '.join(data.input_names)}"
            f"); give a data file with those columns for the {needed} samples "
            "after the end of the data"
        )
    rows, label, cols = read_columns(
        args.future_input, header=args.header, input=",".join(data.input_names)
    )
    values = cols["input"][1]
    if rows < needed:
        raise DataError(
            f"{label}: expected at least {needed} rows of future inputs for "
            f"--steps {args.steps}, received {rows}"
        )
    if not np.all(np.isfinite(values[:needed])):
        raise DataError(f"{label}: the future inputs must be observed (no missing values)")
    return values[:needed]


COMMAND = Subcommand(
    description="Load a model file (from fit, segments or ar) and forecast the states "
    "(AR: the outputs) after the end of DATA (the data it was fitted on, or other data "
    "of the same length), with prediction intervals: the coefficients continue as the "
    "penalty's model says, their uncertainty and the noise propagate. The same "
    "forecast as model.forecast(steps=H, u=future) in Python, DATA's last samples "
    "starting it. Data columns default to those the model was fitted on.",
    add_arguments=add_arguments,
    run=run,
)
