"""``ltvmodels segments``: a piecewise-constant model with exactly optimal change points.

Two kinds of data: a state-space recording (``--state``, ``--input``: the
library's :func:`~ltvmodels.fit_segments`), or one regression equation
(``--response`` with ``--regressors``, ``--lags`` and ``--constant``:
:func:`~ltvmodels.segment_regression`), for which the report adds what R's
strucchange gives around the breaks: their confidence intervals
(``--confint``) and the information criteria for 0 … M changes.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from .. import arguments as opt
from ..messages import CommandError, running
from ..report import Report, fmt, time_text
from ..subcommand import Subcommand

__all__ = ["COMMAND", "add_arguments", "run"]


def _penalty(text: str) -> float | str:
    """A finite cost >= 0 per change, or a rule ``bic``, ``aic``, ``lwz`` (argparse type)."""
    if text.strip().lower() in ("bic", "aic", "lwz"):
        return text.strip().lower()
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number >= 0, 'bic', 'aic' or 'lwz', received {text!r}"
        ) from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(
            f"expected a finite number >= 0, 'bic', 'aic' or 'lwz', received {text!r}"
        )
    return value


def _level(text: str) -> float:
    """A coverage in (0, 1) (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        value = np.nan
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(
            f"expected a level in (0, 1), e.g. 0.95, received {text!r}"
        )
    return value


def _lags(text: str) -> list[int]:
    """Comma-separated lags >= 1 (argparse type)."""
    try:
        lags = [int(item) for item in text.split(",")]
    except ValueError:
        lags = []
    if not lags or min(lags) < 1:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated integers >= 1, e.g. 1,12, received {text!r}"
        )
    return lags


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``segments``."""
    opt.add_data(p)
    data = p.add_argument_group(
        "data", "a state-space recording (--state, --input) or one regression (--response)"
    )
    opt.add_state(data, required=False, help="state columns x (a state-space recording)")
    opt.add_input(data)
    data.add_argument(
        "--response",
        metavar="COL",
        default=None,
        help="instead of --state: the response y of one regression y_t = θ_t φ_t + e_t, "
        "whose regressors φ_t are --regressors, --lags and --constant",
    )
    data.add_argument(
        "--regressors", metavar="COLS", default=None, help="with --response: regressor columns"
    )
    data.add_argument(
        "--lags",
        type=_lags,
        default=None,
        metavar="L",
        help="with --response: the response's lags as regressors, e.g. 1,12 (y_{t-1}, "
        "y_{t-12}); the first max(L) rows are left out",
    )
    opt.add_n_changes(
        p, "at most M changes (with --penalty bic, aic or lwz: the number chosen among 0 … M)"
    )
    p.add_argument(
        "--penalty",
        type=_penalty,
        default=None,
        metavar="{B,bic,aic,lwz}",
        help="cost B >= 0 per change (in units of the segment cost), or the rule bic or aic "
        "(default: bic); with --n-changes M, the criterion bic, aic or lwz that chooses the "
        "number of changes among 0 … M, as strucchange's breakpoints",
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
    opt.add_constant(p, "a constant term c_t per segment (with --response: the regressor 'const')")
    p.add_argument(
        "--confint",
        type=_level,
        default=None,
        metavar="LEVEL",
        help="with --response: confidence intervals of the break dates at this level, "
        "e.g. 0.95 (Bai 1997, as R's strucchange)",
    )
    p.add_argument(
        "--fixed",
        metavar="COLS",
        default=None,
        help="regressor columns (names or 0-based indices among the regressors) whose "
        "coefficients are common to all segments: Bai and Perron's partial structural "
        "change (e.g. seasonal terms)",
    )
    p.add_argument(
        "--cost",
        choices=["rss", "normal"],
        default="rss",
        help="the cost of a segment: its residual sum of squares (default), or normal: "
        "the Gaussian likelihood with a noise variance per segment, which also finds "
        "changes of the noise level",
    )
    p.add_argument(
        "--test",
        choices=["supF", "aveF", "expF", "sequential"],
        default=None,
        help="with --response: test for structural breaks, as strucchange's sctest (supF, "
        "aveF, expF: one break against none) or Bai and Perron's sequential supF(l+1|l) "
        "tests; trimmed by --trim (default 0.15)",
    )
    opt.add_coef_out(p)
    opt.add_outputs(
        p,
        out="model file to write (.npz)",
        plot="figure: coefficients, activation with change points, eigenvalues "
        "(with --response: the coefficients per segment)",
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
    if (args.state is None) == (args.response is None):
        raise CommandError(
            "--state, --response: expected one of them (--state COLS for a state-space "
            "recording, --response COL for one regression), received "
            + ("both" if args.state is not None else "neither")
        )
    if args.response is not None:
        return _run_regression(args)
    for option in ("regressors", "lags", "confint", "test"):
        if getattr(args, option) is not None:
            raise CommandError(
                f"--{option}: it belongs to one regression (--response COL); with --state "
                "the change points are those of the whole state-space model"
            )
    from ...estimators.segments import fit_segments
    from ..analysis import state_space_report
    from ..outputs import check_outputs, model_figure, record_columns, write_outputs
    from ..recordings import state_space_data

    outputs = check_outputs(args, "model")
    data = state_space_data(args)
    if args.n_changes is not None and isinstance(args.penalty, str):
        how = (
            f"exactly optimal, the number of changes chosen by {args.penalty.upper()} "
            f"among 0 … {args.n_changes} (dynamic programming)"
        )
    elif args.n_changes is not None:
        how = f"exactly optimal with at most {args.n_changes} changes (dynamic programming)"
    else:
        how = f"penalty {args.penalty or 'bic'} per change (PELT)"
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
            fixed=_fixed(args.fixed, [*data.state_names, *data.input_names]),
            cost=args.cost,
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
            + (("cost_name", "segment_variances") if args.cost != "rss" else ())
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


def _fixed(text: str | None, names: list[str]) -> list[str | int] | None:
    """``--fixed``'s columns: each a regressor name, or a 0-based index among the
    regressors where it is not a name (the library checks both)."""
    if text is None:
        return None
    items = [item.strip() for item in text.split(",")]
    return [
        int(item) if item not in names and item.lstrip("-").isdigit() else item for item in items
    ]


def _test_report(test: Any) -> dict[str, Any]:
    """What ``--json`` reports of a break test."""
    report = {
        "kind": test.kind,
        "statistic": test.statistic,
        "pvalue": test.pvalue,
        "level": test.level,
        "reject": test.reject,
        "critical_value": test.critical_value,
    }
    if test.kind == "sequential":
        report.update(
            n_breaks=test.n_breaks,
            statistics=test.statistics,
            critical_values=test.critical_values,
            breaks=test.breaks,
        )
    else:
        report["break_index"] = test.break_index
        if test.break_time is not None:
            report["break_time"] = time_text(np.array([test.break_time]))[0]
    return report


def _run_regression(args: argparse.Namespace) -> Report:
    """``segments --response``: the exact segmentation of one regression, its break
    dates with intervals and the criteria for each number of changes."""
    from ...estimators.breaktest import break_test
    from ...estimators.segments import segment_regression
    from ..outputs import check_outputs, figure_errors, write_outputs
    from ..recordings import regression_data

    if args.input is not None:
        raise CommandError(
            "--input: it belongs to a state-space recording (--state); with --response "
            "give the regressors as --regressors COLS"
        )
    outputs = check_outputs(args, "model")
    data = regression_data(args)
    with running("ltvmodels segments: searching change points"):
        seg = segment_regression(
            data.y,
            data.phi,
            n_changes=args.n_changes,
            penalty=args.penalty,
            min_size=args.min_size,
            trim=args.trim,
            weights=data.weights,
            regular=opt.regular_time(args),
            fixed=_fixed(args.fixed, data.regressor_names),
            cost=args.cost,
        )
    test = None
    if args.test is not None:
        if args.fixed is not None:
            raise CommandError(
                "--test: the tests are for a regression whose coefficients all change at a "
                "break; leave out --fixed to test, or --test to segment a partial model"
            )
        test = break_test(
            data.y,
            data.phi,
            kind=args.test,
            trim=0.15 if args.trim is None else args.trim,
            weights=data.weights,
            regular=opt.regular_time(args),
        )
    level = 0.95 if args.confint is None else args.confint
    report: dict[str, Any] = {
        "command": "segments",
        "data": data.label,
        "response": data.response_name,
        "regressors": data.regressor_names,
        "rows": len(data.y),
        "changepoints": seg.changepoints,
        "cost": seg.cost,
        "objective": seg.objective,
        "n_changes": seg.n_changes,
        "penalty": seg.penalty,
        "penalty_rule": seg.penalty_rule,
        "min_size": seg.min_size,
        "solver": seg.solver,
        "cost_name": seg.cost_name,
    }
    if seg.segment_variances is not None:
        report["segment_variances"] = seg.segment_variances
    times = seg.changepoint_times
    if times is not None:
        report["changepoint_times"] = time_text(times)
    if args.confint is not None and seg.n_changes and seg.moments is not None:
        report["confint"] = {"level": level, "rows": seg.confint(level)}
        interval_times = seg.confint_times(level)
        if interval_times is not None:
            report["confint"]["times"] = [time_text(row) for row in interval_times]
    if seg.costs_by_n_changes is not None and seg.moments is not None:
        table = seg.criteria()
        report["criteria"] = {
            key: value for key, value in table.items() if key not in ("n_changes", "loglik")
        }
    if seg.fixed:
        report["fixed"] = [data.regressor_names[i] for i in seg.fixed]
    if test is not None:
        report["test"] = _test_report(test)
    regression = f"{data.response_name} ~ {' + '.join(data.regressor_names)}"
    lines = [f"ltvmodels segments: {data.label}, {regression}, {len(data.y)} rows"]
    lines += str(seg.summary(level)).splitlines()
    if test is not None:
        lines += str(test.summary()).splitlines()
    figure = None
    if outputs.plot is not None and seg.model is not None:
        with figure_errors():
            figure = seg.plot()
    return write_outputs(outputs, report, lines, model=seg.model, figure=figure)


COMMAND = Subcommand(
    description="Fit a piecewise-constant LTV model (--state) or regression (--response) "
    "whose change points are globally optimal: at most M changes (dynamic programming) "
    "or a penalty per change (PELT); with --response, the break dates' confidence "
    "intervals and the criteria for each number of changes.",
    add_arguments=add_arguments,
    run=run,
)
