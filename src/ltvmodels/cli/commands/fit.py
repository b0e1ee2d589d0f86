"""``ltvmodels fit``: identify an LTV model from states and inputs in a data file."""

from __future__ import annotations

import argparse

from ..analysis import lam_facts, lam_how, state_space_report
from ..messages import running
from ..outputs import Report, check_outputs, model_figure, record_columns, write_outputs
from ..recordings import state_space_data
from ..report import fmt, per_name

__all__ = ["run"]


def run(args: argparse.Namespace) -> Report:
    """Fit the model, report it, and write the model, coefficients and figure asked for.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``fit`` arguments.

    Returns
    -------
    report : dict
        What ``--json`` prints.
    lines : list of str
        The text summary.
    """
    from ...estimators.fit import fit

    outputs = check_outputs(args, "model")
    data = state_space_data(args)
    what = "choosing lambda and fitting" if args.lam == "auto" else "fitting"
    with running(f"ltvmodels fit: {what}") as progress:  # the candidates of lam=auto
        model = fit(
            data.x,
            data.u,
            lam=args.lam,
            norm=args.norm,
            order=args.order,
            refine=args.refine,
            max_iter=args.max_iter,
            tol=args.tol,
            constant=args.constant,
            loss=args.loss,
            huber_delta=args.huber_delta,
            noise_var=args.noise_var,
            weights=data.weights,
            progress=progress,
        )
    record_columns(model, {"state": data.state_names, "input": data.input_names}, data.time)
    report, lines, changepoints = state_space_report("fit", data, model)
    facts = lam_facts(model, args.lam)
    report.update(facts, norm=args.norm, order=args.order, refine=args.refine, loss=args.loss)
    lines.insert(
        1,
        f"fit: norm={args.norm!r}, order={args.order}, lambda = "
        f"{fmt(float(facts['lam']))} ({lam_how(facts)})"
        + (", with a constant term c_t" if args.constant else "")
        + (", then the two-step refinement" if args.refine else ""),
    )
    if args.loss == "huber":
        report.update(huber_delta=model.info["huber_delta"], n_outliers=model.info["n_outliers"])
        lines.insert(
            2,
            f"loss: huber, delta = {per_name(data.state_names, model.info['huber_delta'])}"
            f"; {model.info['n_outliers']} residuals beyond delta (outliers)",
        )
    elif args.loss == "laplace":
        report.update(duality_gap=model.info["duality_gap"])
        lines.insert(
            2,
            f"loss: laplace (absolute residuals); relative duality gap "
            f"{model.info['duality_gap']:.1e}",
        )
    title = (
        f"{data.label}: norm={args.norm!r}, order={args.order}, "
        f"λ = {float(facts['lam']):.4g}" + (", refined" if args.refine else "")
    )
    fig = model_figure(outputs, model, changepoints, title)
    return write_outputs(outputs, report, lines, model=model, figure=fig)
