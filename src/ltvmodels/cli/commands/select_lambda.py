"""``ltvmodels select-lambda``: choose λ by a criterion and show its curve."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from .. import arguments as opt
from ..messages import CommandError, running, user_errors
from ..report import Report, fmt, missing_text
from ..subcommand import Subcommand

__all__ = ["COMMAND", "add_arguments", "run"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``select-lambda``: state-space data, or the column of an AR model."""
    opt.add_data(p)
    opt.add_state(p, required=False)
    opt.add_input(p, "input columns u")
    opt.add_column(p, "instead of --state: the column of an AR model (with --na)")
    opt.add_na(p, "AR order (with --column)")
    opt.add_norm(
        p,
        "penalty (default: sq); l0 chooses the number of changes of 'ltvmodels segments'",
        choices=("sq", "group", "l1", "l0"),
    )
    opt.add_order(p)
    p.add_argument(
        "--method",
        default=None,
        help="criterion: sq: ml (default), gcv, lcurve, cv; group/l1: lcurve "
        "(default), cv; l0: bic (default), aic",
    )
    opt.add_loss(
        p,
        "loss of the residuals (as fit --loss); a robust loss takes the "
        "criterion cv, scored with that loss",
    )
    opt.add_huber_delta(p, "Huber threshold with --loss huber (default: the robust rule)")
    opt.add_weights(p)
    opt.add_time(p, "the models compared are those of fit --time or ar --time")
    opt.add_constant(
        p, "a constant term c_t in the models compared (as fit, segments or ar with --constant)"
    )
    opt.add_outputs(p, out=None, plot="figure of the criterion (or L-curve) with the choice")


def run(args: argparse.Namespace) -> Report:
    """Evaluate the criterion on the candidates, report the choice and draw the curve.

    For state-space data (``--state``) or an AR model of a column
    (``--column``, ``--na``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``select-lambda`` arguments.

    Returns
    -------
    report : dict
        What ``--json`` prints.
    lines : list of str
        The text summary.
    """
    from ...estimators.selection import select_lambda, select_lambda_regression
    from ...validation.arrays import LabelledSeries
    from ..analysis import missing_transitions, missing_values, transition_terms
    from ..outputs import check_outputs, write_outputs
    from ..recordings import column_data, state_space_data

    outputs = check_outputs(args, None)
    if args.column is not None:
        if args.state is not None or args.input is not None:
            raise CommandError("--column: an AR model takes no --state or --input")
        if args.na is None:
            raise CommandError("--na: the AR order is required with --column")
        columns = column_data(args)
        label, names, y = columns.label, columns.names, columns.y
        T = y.shape[0]
        y_out, phi, left_out = _ar_rows(y, args.na, args.constant)
        n_missing, N, counts = (
            int(np.count_nonzero(left_out)),
            y_out.shape[0],
            missing_values(names, y),
        )
        missing_rule = (
            "time steps",
            f"a step enters only if y[t] and its {args.na} lags are observed",
        )
        data_facts: dict[str, Any] = {"column": names, "na": args.na}
        what = f"AR({args.na}) of {', '.join(names)}"
    else:
        if args.state is None:
            raise CommandError(
                "--state: expected the state columns (or --column and --na for an AR model)"
            )
        if args.na is not None:
            raise CommandError("--na: applies with --column (an AR model) only")
        data = state_space_data(args)
        label, x, u = data.label, data.x, data.u
        T = x.shape[0]
        n_missing, N, counts = (
            missing_transitions(x, u),
            T - 1,
            missing_values(data.state_names + data.input_names, x, u),
        )
        missing_rule = (
            "transitions",
            f"a transition enters only if {transition_terms(u)} are observed",
        )
        data_facts = {"state": data.state_names, "input": data.input_names}
        what = (
            f"states {', '.join(data.state_names)}; "
            f"inputs {', '.join(data.input_names) or '(none)'}"
        )
    with running("ltvmodels select-lambda: evaluating the candidates") as progress:
        robust = {"loss": args.loss, "huber_delta": args.huber_delta}
        if args.column is not None:
            selection = select_lambda_regression(
                LabelledSeries(y_out, names),
                phi,
                norm=args.norm,
                order=args.order,
                method=args.method,
                progress=progress,
                weights=columns.weights,
                **robust,
            )
        elif args.norm == "l0":  # one dynamic program: no steps to count
            selection = select_lambda(
                data.states,
                data.inputs,
                norm=args.norm,
                method=args.method,
                constant=args.constant,
                weights=data.weights,
                **robust,
            )
        else:
            selection = select_lambda(
                data.states,
                data.inputs,
                norm=args.norm,
                order=args.order,
                method=args.method,
                progress=progress,
                constant=args.constant,
                weights=data.weights,
                **robust,
            )
    is_l0 = selection.norm == "l0"
    report: dict[str, Any] = {
        "command": "select-lambda",
        "data": label,
        "T": T,
        **data_facts,
        "norm": selection.norm,
        "order": None if is_l0 else args.order,
        "constant": args.constant,
        "n_missing": n_missing,
        "missing_values": counts,
        "method": selection.method,
        ("n_changes" if is_l0 else "lam"): int(selection.lam) if is_l0 else selection.lam,
        "candidates": selection.lams.astype(int) if is_l0 else selection.lams,
        "scores": selection.scores,
        "maximize": selection.maximize,
    }
    best = "maximum" if selection.maximize else "minimum"
    chosen = (
        f"number of changes {int(selection.lam)}" if is_l0 else f"lambda = {fmt(selection.lam)}"
    )
    lines = [
        f"ltvmodels select-lambda: {label}, T = {T} samples; {what}",
        f"norm={selection.norm!r}"
        + ("" if is_l0 else f", order={args.order}")
        + (", with a constant term c_t" if args.constant else "")
        + f", criterion {selection.method!r} ({best} over {len(selection.lams)} candidates"
        + ("" if is_l0 else ": a coarse grid, refined where the criterion peaks")
        + ")",
    ]
    if any(counts.values()):
        lines.append(missing_text(n_missing, N, counts, *missing_rule))
    lines += [
        f"chosen: {chosen}",
        "",
        f"{'number of changes' if is_l0 else 'lambda':>18}  {selection.method}",
    ]
    nearest = int(np.argmin(np.abs(selection.lams - selection.lam)))
    for i, (lam, score) in enumerate(zip(selection.lams, selection.scores, strict=True)):
        # not scored: a skipped candidate, or one off the L-curve (no bend, or λ >= λ_max)
        shown = fmt(float(score)) if np.isfinite(score) else "-"
        lines.append(f"{fmt(float(lam)):>18}  {shown}" + ("   <- chosen" if i == nearest else ""))
    if not np.all(np.isfinite(selection.scores)):
        lines.append(
            "(-: not scored: a singular candidate, or for the L-curve one where it "
            "does not bend or the penalty is 0)"
        )
    fig = None
    if outputs.plot is not None:
        from ...plotting import plot_lambda_selection

        fig = plot_lambda_selection(selection).figure
    return write_outputs(outputs, report, lines, figure=fig)


def _ar_rows(y: np.ndarray, na: int, constant: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of an AR(na) model: targets, regressors, and which rows are left out.

    ``ar_regressors`` takes finite data: the missing samples are filled in,
    then the rows whose target or lags are missing are left out (NaN), as
    ``fit_ar`` does.
    """
    from ...estimators.ar import ar_regressors

    filled = np.where(np.isfinite(y), y, 0.0)
    with user_errors():
        y_out, phi = ar_regressors(
            filled[:, 0] if y.shape[1] == 1 else filled, na, constant=constant
        )
    y_out, phi = np.array(y_out, dtype=float), np.array(phi, dtype=float)
    count = np.concatenate([[0], np.cumsum(~np.all(np.isfinite(y), axis=1))])
    t = na + np.arange(y_out.shape[0])
    left_out = count[t + 1] - count[t - na] > 0
    y_out[left_out], phi[left_out] = np.nan, np.nan
    return y_out, phi, left_out


COMMAND = Subcommand(
    description="Evaluate a criterion on a grid of lambda values (or numbers of changes "
    "for --norm l0) and report the choice; for state-space data (--state) or an AR "
    "model of a column (--column, --na).",
    add_arguments=add_arguments,
    run=run,
)
