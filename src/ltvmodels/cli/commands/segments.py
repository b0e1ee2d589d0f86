"""``ltvmodels segments``: a piecewise-constant model with exactly optimal change points."""

from __future__ import annotations

import argparse

import numpy as np

from .. import arguments as opt
from ..messages import running
from ..report import Report, fmt
from ..subcommand import Subcommand

__all__ = ["COMMAND", "add_arguments", "run"]


def _penalty(text: str) -> float | str:
    """A finite cost >= 0 per change, or the rule ``bic`` or ``aic`` (argparse type)."""
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


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``segments``."""
    opt.add_data(p)
    opt.add_state_options(p)
    group = p.add_mutually_exclusive_group()
    opt.add_n_changes(group, "at most M changes")
    group.add_argument(
        "--penalty",
        type=_penalty,
        default=None,
        metavar="{B,bic,aic}",
        help="cost B >= 0 per change (in units of the residual sum of "
        "squares), or the rule bic or aic (default: bic)",
    )
    p.add_argument(
        "--min-size",
        type=opt.positive_int,
        default=None,
        metavar="S",
        help="minimum segment length (default: n + m, or n + m + 1 with --constant)",
    )
    p.add_argument(
        "--trim",
        type=float,
        default=None,
        metavar="H",
        help="minimum segment length as a fraction of the transitions, in (0, 0.5) "
        "(strucchange's h, e.g. 0.15); instead of --min-size",
    )
    opt.add_weights(p)
    opt.add_time(p)
    opt.add_constant(p, "a constant term c_t per segment")
    opt.add_coef_out(p)
    opt.add_outputs(
        p,
        out="model file to write (.npz)",
        plot="figure: coefficients, activation with change points, eigenvalues",
    )


def run(args: argparse.Namespace) -> Report:
    """Search the change points, report the model, and write the outputs asked for.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``segments`` arguments.

    Returns
    -------
    report : dict
        What ``--json`` prints.
    lines : list of str
        The text summary.
    """
    from ...estimators.segments import fit_segments
    from ..analysis import state_space_report
    from ..outputs import check_outputs, model_figure, record_columns, write_outputs
    from ..recordings import state_space_data

    outputs = check_outputs(args, "model")
    data = state_space_data(args)
    how = (
        f"exactly optimal with at most {args.n_changes} changes (dynamic programming)"
        if args.n_changes is not None
        else f"penalty {args.penalty or 'bic'} per change (PELT)"
    )
    with running("ltvmodels segments: searching change points"):
        model = fit_segments(
            data.states,
            data.inputs,
            n_changes=args.n_changes,
            penalty=args.penalty,
            min_size=args.min_size,
            trim=args.trim,
            constant=args.constant,
            weights=data.weights,
        )
    model = record_columns(
        model,
        {"state": data.state_names, "input": data.input_names},
        data.time,
        data.time_name,
    )
    report, lines, changepoints = state_space_report("segments", data, model)
    info = model.info
    report.update(
        {
            k: info.get(k)
            for k in ("cost", "objective", "n_changes", "penalty", "penalty_rule", "min_size")
        }
    )
    lines.insert(
        1,
        f"segments: {how}; min_size {info.get('min_size')}"
        + ("; with a constant term c_t per segment" if args.constant else ""),
    )
    lines.append(
        f"residual sum of squares {fmt(info['cost'])}, objective "
        f"{fmt(info['objective'])}, {info['n_changes']} changes"
        + (
            f", penalty {fmt(info['penalty'])} per change"
            if info.get("penalty") is not None
            else ""
        )
    )
    title = (
        f"{data.label}: piecewise-constant model, {info['n_changes']} changes at "
        f"{[int(c) for c in changepoints]}"
    )
    fig = model_figure(outputs, model, changepoints, title)
    return write_outputs(outputs, report, lines, model=model, figure=fig)


COMMAND = Subcommand(
    description="Fit a piecewise-constant LTV model whose change points are globally "
    "optimal: at most M changes (dynamic programming) or a penalty per change (PELT).",
    add_arguments=add_arguments,
    run=run,
)
