"""``ltvmodels fit``: identify an LTV model from states and inputs in a data file."""

from __future__ import annotations

import argparse

from .. import arguments as opt
from ..messages import running
from ..report import Report, fmt, per_name
from ..subcommand import Subcommand

__all__ = ["COMMAND", "add_arguments", "run"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``fit``."""
    opt.add_data(p)
    opt.add_state_options(p)
    opt.add_norm(
        p,
        "sq: slowly varying or smooth (default); group: piecewise constant "
        "(order 1) or linear (order 2); l1: sparse changes per coefficient",
    )
    opt.add_order(p)
    opt.add_lam(
        p,
        "regularization lambda, or auto: chosen by the norm's default "
        "criterion (marginal likelihood for sq, L-curve for group/l1; default)",
    )
    opt.add_refine(p, "two-step refinement: refit piecewise between the detected change points")
    opt.add_loss(
        p,
        "loss of the residuals: squared (default), huber (robust to "
        "outliers) or laplace (absolute values, the most robust); with a robust "
        "loss, --lam auto is cross-validation scored with that loss",
    )
    opt.add_huber_delta(
        p,
        "Huber threshold in the units of the states (default: 1.345 x the "
        "robust scale of the squared-loss residuals)",
    )
    opt.add_noise_var(
        p,
        "noise variance of the state equations, one or one per state "
        "(default: estimated); with --norm sq it scales a prior-free fit's "
        "likelihood and covariances",
    )
    opt.add_measurement_noise(
        p,
        "the recorded states are noisy measurements: estimate the measurement-noise "
        "variance of each state, or give it (one or one per state); the model is fitted by "
        "EM with a Kalman smoother of the states (default: exact states)",
    )
    opt.add_measurement_loss(
        p,
        "with --measurement-noise: the measurement errors' loss; huber or student "
        "down-weight corrupted recorded samples (in both roles, target and regressor) and "
        "report them as sample outliers (default: squared)",
    )
    opt.add_weights(p)
    opt.add_time(p)
    opt.add_constant(p, "a time-varying constant term c_t in x[t+1] = A_t x[t] + B_t u[t] + c_t")
    opt.add_sparse_options(p)
    opt.add_coef_out(p)
    opt.add_outputs(
        p,
        out="model file to write (.npz; read it with ltvmodels.load or 'ltvmodels simulate')",
        plot="figure: coefficients with ±2σ bands, activation with change points, "
        "eigenvalue magnitudes",
    )


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
    from ..analysis import lam_facts, lam_how, state_space_report
    from ..outputs import check_outputs, model_figure, record_columns, write_outputs
    from ..recordings import state_space_data

    outputs = check_outputs(args, "model")
    data = state_space_data(args)
    what = "choosing lambda and fitting" if args.lam == "auto" else "fitting"
    with running(f"ltvmodels fit: {what}") as progress:  # the candidates of lam=auto
        model = fit(
            data.states,
            data.inputs,
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
            measurement_noise=args.measurement_noise,
            measurement_loss=args.measurement_loss,
        )
    model = record_columns(
        model,
        {"state": data.state_names, "input": data.input_names},
        data.time,
        data.time_name,
    )
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
        report.update(
            huber_delta=model.info["huber_delta"], n_beyond_delta=model.info["n_beyond_delta"]
        )
        lines.insert(
            2,
            f"loss: huber, delta = {per_name(data.state_names, model.info['huber_delta'])}"
            f"; {model.info['n_beyond_delta']} residuals beyond delta",
        )
    elif args.loss == "laplace":
        report.update(duality_gap=model.info["duality_gap"])
        lines.insert(
            2,
            f"loss: laplace (absolute residuals); relative duality gap "
            f"{model.info['duality_gap']:.1e}",
        )
    if model.outliers is not None:
        report["n_outliers"] = model.info["n_outliers"]
        lines.insert(
            3 if args.loss != "squared" else 2,
            f"outliers: {model.info['n_outliers']} residual entries beyond "
            f"{model.info['outlier_threshold']:g} robust scales (1.4826 MAD) of their state",
        )
    if model.measurement_noise is not None:
        report.update(
            measurement_noise=[float(v) for v in model.measurement_noise],
            em_iterations=int(model.info["em_iterations"]),
            em_converged=bool(model.info["em_converged"]),
            measurement_loss=str(model.info["measurement_loss"]),
            n_sample_outliers=int(model.info["n_sample_outliers"]),
        )
        lines.insert(
            2,
            f"measurement noise variance: {per_name(data.state_names, model.measurement_noise)}"
            f" ({model.info['measurement_noise']}); EM: {model.info['em_iterations']} "
            f"iterations, {'converged' if model.info['em_converged'] else 'not converged'}"
            f"; measurement loss {model.info['measurement_loss']}, "
            f"{model.info['n_sample_outliers']} sample outliers",
        )
    title = (
        f"{data.label}: norm={args.norm!r}, order={args.order}, "
        f"λ = {float(facts['lam']):.4g}" + (", refined" if args.refine else "")
    )
    fig = model_figure(outputs, model, changepoints, title)
    return write_outputs(outputs, report, lines, model=model, figure=fig)


COMMAND = Subcommand(
    description="Identify x[t+1] = A_t x[t] + B_t u[t] (+ c_t) + v_t from a data file: "
    "print the lambda used, one-step prediction and open-loop simulation RMS, change "
    "points and solver status; optionally save the model and a figure. Missing values "
    "in the data leave out the transitions they touch.",
    add_arguments=add_arguments,
    run=run,
)
