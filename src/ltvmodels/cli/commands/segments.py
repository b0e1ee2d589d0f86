"""``ltvmodels segments``: a piecewise-constant model with exactly optimal change points."""

from __future__ import annotations

import argparse

from ..analysis import state_space_report
from ..messages import running
from ..outputs import Report, check_outputs, model_figure, record_columns, write_outputs
from ..recordings import state_space_data
from ..report import fmt

__all__ = ["run"]


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

    outputs = check_outputs(args, "model")
    data = state_space_data(args)
    how = (
        f"exactly optimal with at most {args.n_changes} changes (dynamic programming)"
        if args.n_changes is not None
        else f"penalty {args.penalty or 'bic'} per change (PELT)"
    )
    with running("ltvmodels segments: searching change points"):
        model = fit_segments(
            data.x,
            data.u,
            n_changes=args.n_changes,
            penalty=args.penalty,
            min_size=args.min_size,
            constant=args.constant,
            weights=data.weights,
        )
    record_columns(model, {"state": data.state_names, "input": data.input_names}, data.time)
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
