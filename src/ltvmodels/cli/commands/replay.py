"""``ltvmodels simulate`` and ``ltvmodels predict``: a saved model run on a data file.

The two commands differ only in what they compute (an open-loop simulation
from the first samples, or one-step predictions from the data before each
sample): their options, report, table and figure are the same.
"""

from __future__ import annotations

import argparse
import functools
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import arguments as opt
from ..messages import DataError, user_errors
from ..report import Report, fmt, per_name, rms, rms_columns
from ..subcommand import Subcommand

if TYPE_CHECKING:  # pragma: no cover
    from ..saved import ModelData

__all__ = ["SIMULATE", "PREDICT", "add_arguments", "run"]


def add_arguments(p: argparse.ArgumentParser, noun: str) -> None:
    """The options of ``simulate`` and ``predict``; ``noun`` says what the command computes."""
    opt.add_model_file(p)
    opt.add_data(p)
    opt.add_model_columns(p, "input columns; default: those recorded in the model file")
    opt.add_outputs(
        p, out=f"CSV file to write: t and the {noun}", plot=f"figure: {noun} against the data"
    )


def run(args: argparse.Namespace) -> Report:
    """Simulate (``simulate``) or predict (``predict``) a saved model on a data file.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``simulate`` or ``predict`` arguments (``args.command``
        says which).

    Returns
    -------
    report : dict
        What ``--json`` prints.
    lines : list of str
        The text summary.
    """
    from ..analysis import predict
    from ..outputs import Table, check_outputs, figure_errors, write_outputs
    from ..saved import load_model, model_data

    outputs = check_outputs(args, "table")
    model = load_model(args.model)
    data = model_data(args, model)
    kind, y, u = data.kind, data.y, data.u
    simulate = args.command == "simulate"
    if simulate:
        result, start = _simulation(model, data)
        computed = np.ones(result.shape[0], dtype=bool)
    else:  # NaN where a regressor is missing
        result, computed = predict(model, y, u)
        start = 1 if kind == "ltv" else data.lag
    target = y[start : start + result.shape[0]]
    err = result - target
    valid = computed[:, None] & np.isfinite(target)
    noun = "open-loop simulation" if simulate else "one-step prediction"
    total_rms = rms(err, valid)
    per = rms_columns(err, valid)
    left_out = int(valid.size - np.count_nonzero(valid))
    report: dict[str, Any] = {
        "command": args.command,
        "model_file": str(args.model),
        "model": type(model).__name__,
        "data": data.label,
        "T": data.T,
        "columns": data.names,
        "input": data.input_names,
        "start": start,
        "rows": result.shape[0],
        "rms": total_rms,
        "rms_per_column": per,
        "n_left_out": left_out,
        "n_not_computed": int(np.count_nonzero(~computed)),
    }
    with np.errstate(over="ignore", invalid="ignore"):
        diverged = simulate and not np.all(np.isfinite(result))
    lines = [
        f"ltvmodels {args.command}: {args.model} on {data.label} (T = {data.T} samples; "
        f"columns {', '.join(data.names)}; inputs {', '.join(data.input_names) or '(none)'})",
        repr(model),
        f"{noun} of samples {start} to {start + result.shape[0] - 1}"
        + (
            (
                " from the recorded initial "
                + ("state" if kind == "ltv" else "samples")
                + (" with the recorded inputs" if u is not None else "")
            )
            if simulate
            else " from the recorded data"
        )
        + (
            f"; {report['n_not_computed']} not computed (they need a missing sample)"
            if report["n_not_computed"]
            else ""
        ),
        f"RMS error: {fmt(total_rms)} ({per_name(data.names, per)})"
        + (f"; {left_out} of {valid.size} values left out (missing data)" if left_out else "")
        + ("; the simulation diverges (non-finite values)" if diverged else ""),
    ]
    fig = None
    if outputs.plot is not None:  # drawn before anything is written: it may fail
        from ...plotting import plot_simulation

        limit = (
            "missing values"
            if np.isnan(y).any() or report["n_not_computed"]
            else "a diverging simulation"
            if diverged
            else None
        )
        with figure_errors(limit):
            fig = plot_simulation(y, result, start=start, names=data.names, label=noun)
        fig.suptitle(f"{args.model} on {data.label}: {noun}")
    table = Table(
        ["t", *data.names],
        np.column_stack([np.arange(start, start + result.shape[0]), result]),
    )
    return write_outputs(outputs, report, lines, table=table, figure=fig)


def _simulation(model: Any, data: ModelData) -> tuple[np.ndarray, int]:
    """The open-loop simulation (rows, columns) and its first sample.

    A state-space model starts from the first state; an AR/ARX model from the
    first ``lag`` samples, which are not part of the result.
    """
    _check_simulation_data(data, model)
    kind, y, u, lag = data.kind, data.y, data.u, data.lag
    with user_errors():
        if kind == "ltv":
            result = model.simulate(y[0], None if u is None else u[: model.N])
        else:
            series = y[:, 0] if y.shape[1] == 1 else y
            extra = () if kind == "ar" else (u,)
            result = model.simulate(series[:lag], *extra)
    result = np.asarray(result, dtype=float).reshape(-1, y.shape[1])
    if kind != "ltv":  # y[0:lag] are the given initial samples
        return result[lag:], lag
    return result, 0


def _check_simulation_data(data: ModelData, model: Any) -> None:
    """An open-loop simulation needs the initial state (samples) and every input."""
    from ...validation.arrays import representable
    from ..analysis import first_missing

    ltv = data.kind == "ltv"
    u = data.u
    with user_errors(f"{data.label}: "):  # as predict checks them: no inf in the report
        representable(data.y, "--state" if ltv else "--column", names=data.names)
        if u is not None:
            representable(u, "--input", names=data.input_names)
    if u is not None and ltv:
        u = u[: model.N]  # u[T-1] drives no transition
    missing = first_missing(u, data.input_names)
    if missing is not None:
        raise DataError(
            f"--input: {data.label}: input {missing[1]} is missing at sample "
            f"{missing[0]}; an open-loop simulation needs every input (fill it "
            "in, or use 'ltvmodels predict', which leaves out the predictions "
            "that need a missing sample)"
        )
    missing = first_missing(data.y[: data.lag], data.names)
    if missing is not None:
        what = "initial state" if ltv else f"initial samples (the first {data.lag})"
        raise DataError(
            f"{'--state' if ltv else '--column'}: {data.label}: the {what} "
            f"must be observed, received a missing value of {missing[1]} at "
            f"sample {missing[0]}; the simulation starts from "
            f"{'it' if ltv else 'them'} (fill it in)"
        )


def _subcommand(noun: str, how: str) -> Subcommand:
    """``simulate`` or ``predict``: ``noun`` is what it computes, ``how`` from what."""
    return Subcommand(
        description=f"Load a model file (from fit, segments or ar) and compute its {noun} "
        f"on a data file: {how} Data columns default to those the model was fitted on.",
        add_arguments=functools.partial(add_arguments, noun=noun),
        run=run,
    )


SIMULATE = _subcommand(
    "open-loop simulation",
    "from the first state (AR: the first na samples) with the data's inputs.",
)
PREDICT = _subcommand("one-step predictions", "of every sample from the measured data before it.")
