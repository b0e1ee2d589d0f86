"""The subcommands: read the data, run the library, report, save models and figures.

Each command function takes the parsed arguments and returns its report: a
dict (printed as JSON with ``--json``) and the lines of the text summary;
:data:`COMMANDS` maps the subcommand names to them.
"""

from __future__ import annotations

import argparse
import warnings
import zipfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..apps.defaults import DEFAULT_DEMO_OUT
from ..apps.demos import (
    run_chirp_demo,
    run_jump_linear_demo,
    run_pendulum_demo,
    run_rl_demo,
    run_robot_demo,
)
from ..apps.rl import QUICK_RUNS
from ..estimators.ar import ar_regressors, fit_ar
from ..estimators.changepoints import find_changepoints
from ..estimators.fit import fit
from ..estimators.segments import fit_segments
from ..estimators.selection import (
    DEFAULT_METHOD,
    select_lambda,
    select_lambda_regression,
)
from ..plotting import (
    plot_lambda_selection,
    plot_model,
    plot_root_spectrogram,
    plot_simulation,
    plot_spectrogram,
)
from ..progress import Progress
from ..results.arx import ARModel, ARXModel
from ..results.loading import load
from ..results.statespace import LTVModel
from ..validation.arrays import representable
from .data import read_columns
from .many import cmd_fit_many
from .messages import CommandError, DataError, one_line, user_errors
from .outputs import (
    Report,
    Table,
    check_outputs,
    figure_errors,
    record_columns,
    write_outputs,
)
from .report import fmt, info_subset, per_name, rms, rms_columns


def _state_space_data(
    args: argparse.Namespace,
) -> tuple[str, np.ndarray, np.ndarray | None, list[str], list[str]]:
    """(label, x (T, n), u (T, m) or None, state names, input names) of DATA; with
    ``--weights`` the transitions' weights are left in ``args.transition_weights``."""
    weights = getattr(args, "weights", None)
    T, label, cols = read_columns(
        args.data,
        state=args.state,
        input=args.input,
        weights=weights,
        time=getattr(args, "time", None),
    )
    args.time_values = None if cols.get("time") is None else cols["time"][1]
    state_names, x = cols["state"]
    input_names, u = cols["input"] if cols["input"] is not None else ([], None)
    args.transition_weights = None
    if weights is not None:  # the equation predicting row t has the weight of row t
        column = cols["weights"][1][1:, 0]
        if not np.all(np.isfinite(column)):
            raise DataError(
                f"--weights: the weights must be observed, received a missing "
                f"value at row {1 + int(np.flatnonzero(~np.isfinite(column))[0])}"
            )
        args.transition_weights = column
    return label, x, u, state_names, input_names


def _detected_changepoints(model: Any) -> tuple[np.ndarray, str]:
    """Change points of a model and how they were found."""

    if model.norm in ("piecewise", "l0", "lti"):
        return np.asarray(model.changepoints, dtype=int), "segment boundaries of the model"
    with user_errors("change points: "):
        found = find_changepoints(model)
    return found, "peaks of the activation ||(Dk)_t|| (ltvmodels.find_changepoints)"


def _lam_facts(model: Any, requested: Any) -> dict[str, Any]:
    """λ used (of the first step for a refined model) and how it was chosen."""

    first = model.info.get("first_step")
    lam = first["lam"] if isinstance(first, dict) and "lam" in first else model.lam
    facts: dict[str, Any] = {"lam": lam if np.ndim(lam) == 0 else np.asarray(lam)}
    if requested == "auto":
        selection = model.info.get("lam_selection") or {}
        norm = first["norm"] if isinstance(first, dict) else model.norm
        facts["lam_method"] = selection.get("method", DEFAULT_METHOD.get(norm))
    return facts


def _missing_values(names: list[str], *columns: np.ndarray | None) -> dict[str, int]:
    """The number of missing values (NaN) of each selected data column, by name."""
    arrays = [c for c in columns if c is not None and c.size]
    counts = (
        np.concatenate([np.sum(np.isnan(c), axis=0) for c in arrays]) if arrays else np.zeros(0)
    )
    return {name: int(c) for name, c in zip(names, counts, strict=True)}


def _observed_rows(x: np.ndarray, u: np.ndarray | None) -> np.ndarray:
    """(T,) whether x[t] and u[t] are observed (no NaN)."""
    ok = np.all(np.isfinite(x), axis=1)
    return ok if u is None else ok & np.all(np.isfinite(u), axis=1)


def _missing_transitions(x: np.ndarray, u: np.ndarray | None) -> int:
    """Transitions t → t+1 left out of a fit: x[t], u[t] or x[t+1] not observed."""
    ok = _observed_rows(x, u)[:-1] & np.all(np.isfinite(x[1:]), axis=1)
    return int(ok.size - np.count_nonzero(ok))


def _lags_observed(model: Any, y: np.ndarray, u: np.ndarray | None) -> np.ndarray:
    """(N,) whether the lags of step j of an AR/ARX model (sample lag + j) are observed."""
    t = model.lag + np.arange(model.N)

    def observed(series: np.ndarray | None, first: int, stop: int) -> np.ndarray:
        """Whether rows t + first, ..., t + stop - 1 of ``series`` are all observed."""
        if series is None or stop <= first:
            return np.ones(t.size, dtype=bool)
        count = np.concatenate([[0], np.cumsum(~np.all(np.isfinite(series), axis=1))])
        return count[t + stop] - count[t + first] == 0

    ok = observed(y, -model.na, 0)
    if not isinstance(model, ARModel):
        ok &= observed(u, 1 - model.nk - model.nb, 1 - model.nk)
    return ok


def _predict(model: Any, y: np.ndarray, u: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """One-step predictions (N, n) and (N,) whether each one could be computed.

    A prediction needs its regressors observed (LTV: x[t] and u[t]; AR/ARX:
    the lags); the others are NaN. An AR/ARX model's predict takes finite data
    only: missing samples are filled with 0 for it, and the predictions that
    use them are set to NaN.
    """
    if isinstance(model, LTVModel):
        ok = _observed_rows(y, u)[:-1]
        with user_errors():
            prediction = np.array(model.predict(y, u), dtype=float).reshape(model.N, -1)
    else:
        ok = _lags_observed(model, y, u)
        filled = np.where(np.isfinite(y), y, 0.0)
        series = filled[:, 0] if filled.shape[1] == 1 else filled
        with user_errors():
            if isinstance(model, ARModel) or u is None:  # u is None for an AR model only
                prediction = model.predict(series)
            else:
                prediction = model.predict(series, np.where(np.isfinite(u), u, 0.0))
        prediction = np.array(prediction, dtype=float).reshape(model.N, -1)
    prediction[~ok] = np.nan
    return prediction, ok


def _first_missing(values: np.ndarray | None, names: list[str]) -> tuple[int, str] | None:
    """(sample, column name) of the first missing value, or None."""
    if values is None:
        return None
    bad = np.argwhere(np.isnan(values))
    return None if not bad.size else (int(bad[0, 0]), names[int(bad[0, 1])])


def _missing_text(n_missing: int, N: int, counts: dict[str, int], noun: str, rule: str) -> str:
    """``missing: 5 of 199 transitions left out (missing values: x1 2, u 3; rule)``."""
    values = ", ".join(f"{name} {c}" for name, c in counts.items() if c)
    return f"missing: {n_missing} of {N} {noun} left out (missing values: {values}; {rule})"


def _noise_text(model: Any, names: list[str]) -> str:
    return f"noise variance: {per_name(names, model.noise_var)} (estimated from the residuals)"


def _state_space_report(
    command: str,
    label: str,
    model: Any,
    x: np.ndarray,
    u: np.ndarray | None,
    state_names: list[str],
    input_names: list[str],
) -> tuple[dict[str, Any], list[str], Any]:
    """The facts common to ``fit`` and ``segments``: RMS, missing data, change points, solver."""
    counts = _missing_values(state_names + input_names, x, u)
    any_missing = any(counts.values())
    prediction, ok = _predict(model, x, u)
    valid = ok[:, None] & np.isfinite(x[1:])
    pred_rms = rms_columns(prediction - x[1:], valid)
    u_sim = None if u is None else u[: model.N]  # u[T-1] drives no transition
    blocked_u = _first_missing(u_sim, input_names)
    blocked_x = _first_missing(x[:1], state_names)
    if blocked_u is not None:
        skipped = (
            f"input {blocked_u[1]} is missing at sample {blocked_u[0]}; a simulation "
            "needs every input"
        )
    elif blocked_x is not None:
        skipped = f"the initial state is missing ({blocked_x[1]} at sample 0)"
    else:
        skipped = None
    if skipped is None:
        with user_errors():
            simulation = model.simulate(x[0], u_sim)
        sim_valid = np.isfinite(x)
        sim_rms: list[float] | None = rms_columns(simulation - x, sim_valid)
        sim_total: float | None = rms(simulation - x, sim_valid)
    else:
        sim_rms = sim_total = None
    changepoints, rule = _detected_changepoints(model)
    info = model.info
    n_missing = info.get("n_missing")
    n_missing = _missing_transitions(x, u) if n_missing is None else int(n_missing)
    report: dict[str, Any] = {
        "command": command,
        "data": label,
        "T": x.shape[0],
        "state": state_names,
        "input": input_names,
        "model": type(model).__name__,
        "N": model.N,
        "norm": model.norm,
        "order": None if model.coeffs is None else len(model.coeffs) - 1,
        "constant": bool(model.constant),
        "n_missing": n_missing,
        "missing_values": counts,
        "rms": {
            "prediction": rms(prediction - x[1:], valid),
            "simulation": sim_total,
            "prediction_per_state": pred_rms,
            "simulation_per_state": sim_rms,
        },
        "changepoints": changepoints,
        "changepoint_rule": rule,
        "noise_var": np.atleast_1d(model.noise_var),
        "loglik": model.loglik,
        "solver": info.get("solver"),
        "converged": info.get("converged"),
        "iterations": info.get("iterations"),
        "info": info_subset(info),
    }
    if skipped is not None:
        report["rms"]["simulation_skipped"] = skipped
    status = ""
    if info.get("converged") is not None:
        status = ", converged" if info["converged"] else ", NOT converged (see the warnings)"
    if info.get("iterations") is not None:
        status += f", {info['iterations']} iterations"
    observed_only = "; observed samples only" if any_missing else ""
    lines = [
        f"ltvmodels {command}: {label}, T = {x.shape[0]} samples; states "
        f"{', '.join(state_names)}; inputs {', '.join(input_names) or '(none)'}",
        model.summary(),
        f"solver: {info.get('solver', '?')}{status}",
    ]
    if any_missing:
        entry = "x[t], u[t] and x[t+1] are" if u is not None else "x[t] and x[t+1] are"
        lines.append(
            _missing_text(
                n_missing,
                model.N,
                counts,
                "transitions",
                f"a transition enters the fit only if {entry} observed",
            )
        )
    lines += [
        _noise_text(model, state_names),
        f"one-step prediction RMS: {fmt(report['rms']['prediction'])} "
        f"({per_name(state_names, pred_rms)}{observed_only})",
        (
            f"open-loop simulation RMS: {fmt(sim_total)} ({per_name(state_names, sim_rms)}; "
            "from the first state"
            + (" with the recorded inputs" if u is not None else "")
            + f"{observed_only})"
        )
        if sim_total is not None
        else f"open-loop simulation: not computed ({skipped})",
        f"change points: {[int(c) for c in changepoints]} ({rule})",
    ]
    time = model.time
    if time is not None and len(changepoints):  # change c at the time of x[c]
        times = _time_text(time[np.asarray(changepoints, dtype=int)])
        report["changepoint_times"] = times
        lines[-1] += f"; at times {', '.join(times)}"
    return report, lines, changepoints


def _time_text(values: np.ndarray) -> list[str]:
    """Times as text: dates without a time of day as YYYY-MM-DD, else to the second; numbers
    as numbers."""
    if not np.issubdtype(values.dtype, np.datetime64):
        return [fmt(float(value)) for value in values]
    days = values.astype("datetime64[D]")
    unit: Literal["D", "s"] = "D" if np.all(days == values) else "s"
    return [str(text) for text in np.datetime_as_string(values, unit=unit)]


def _cmd_fit(args: argparse.Namespace) -> Report:

    outputs = check_outputs(args, "model")
    label, x, u, state_names, input_names = _state_space_data(args)
    what = "choosing lambda and fitting" if args.lam == "auto" else "fitting"
    with Progress(f"ltvmodels fit: {what}") as bar, user_errors():

        def progress(done: int, total: int) -> None:  # the candidates of lam=auto
            bar.total, bar.done = total, done

        model = fit(
            x,
            u,
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
            weights=args.transition_weights,
            progress=progress,
        )
    record_columns(model, {"state": state_names, "input": input_names}, args.time_values)
    report, lines, changepoints = _state_space_report(
        "fit", label, model, x, u, state_names, input_names
    )
    facts = _lam_facts(model, args.lam)
    report.update(facts, norm=args.norm, order=args.order, refine=args.refine, loss=args.loss)
    how = (
        f"chosen by lam=auto, criterion {facts['lam_method']!r}" if args.lam == "auto" else "given"
    )
    lines.insert(
        1,
        f"fit: norm={args.norm!r}, order={args.order}, lambda = "
        f"{fmt(float(facts['lam']))} ({how})"
        + (", with a constant term c_t" if args.constant else "")
        + (", then the two-step refinement" if args.refine else ""),
    )
    if args.loss == "huber":
        report.update(huber_delta=model.info["huber_delta"], n_outliers=model.info["n_outliers"])
        lines.insert(
            2,
            f"loss: huber, delta = {per_name(state_names, model.info['huber_delta'])}"
            f"; {model.info['n_outliers']} residuals beyond delta (outliers)",
        )
    elif args.loss == "laplace":
        report.update(duality_gap=model.info["duality_gap"])
        lines.insert(
            2,
            f"loss: laplace (absolute residuals); relative duality gap "
            f"{model.info['duality_gap']:.1e}",
        )
    fig = None
    if outputs.plot is not None:  # drawn before anything is written: it may fail
        with figure_errors("a model with a constant term c_t" if model.constant else None):
            fig = plot_model(model, changepoints=changepoints)
        fig.suptitle(
            f"{label}: norm={args.norm!r}, order={args.order}, "
            f"λ = {float(facts['lam']):.4g}" + (", refined" if args.refine else "")
        )
    return write_outputs(outputs, report, lines, model=model, figure=fig)


def _cmd_segments(args: argparse.Namespace) -> Report:

    outputs = check_outputs(args, "model")
    label, x, u, state_names, input_names = _state_space_data(args)
    how = (
        f"exactly optimal with at most {args.n_changes} changes (dynamic programming)"
        if args.n_changes is not None
        else f"penalty {args.penalty or 'bic'} per change (PELT)"
    )
    with Progress("ltvmodels segments: searching change points"), user_errors():
        model = fit_segments(
            x,
            u,
            n_changes=args.n_changes,
            penalty=args.penalty,
            min_size=args.min_size,
            constant=args.constant,
            weights=args.transition_weights,
        )
    record_columns(model, {"state": state_names, "input": input_names}, args.time_values)
    report, lines, changepoints = _state_space_report(
        "segments", label, model, x, u, state_names, input_names
    )
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
    fig = None
    if outputs.plot is not None:  # drawn before anything is written: it may fail
        with figure_errors("a model with a constant term c_t" if model.constant else None):
            fig = plot_model(model, changepoints=changepoints)
        fig.suptitle(
            f"{label}: piecewise-constant model, {info['n_changes']} changes at "
            f"{[int(c) for c in changepoints]}"
        )
    return write_outputs(outputs, report, lines, model=model, figure=fig)


def _cmd_ar(args: argparse.Namespace) -> Report:

    outputs = check_outputs(args, "model")
    T, label, cols = read_columns(args.data, column=args.column, weights=args.weights)
    names, y = cols["column"]
    weights = None
    if cols["weights"] is not None:  # the equation predicting row t has row t's weight
        weights = cols["weights"][1][args.na :, 0]
        if not np.all(np.isfinite(weights)):
            raise DataError("--weights: the weights must be observed (no missing values)")
    what = "choosing lambda and fitting" if args.lam == "auto" else "fitting"
    with Progress(f"ltvmodels ar: {what}") as bar, user_errors():

        def progress(done: int, total: int) -> None:  # the candidates of lam=auto
            bar.total, bar.done = total, done

        model = fit_ar(
            y[:, 0] if y.shape[1] == 1 else y,
            args.na,
            lam=args.lam,
            norm=args.norm,
            order=args.order,
            constant=args.constant,
            max_iter=args.max_iter,
            tol=args.tol,
            weights=weights,
            noise_var=args.noise_var,
            progress=progress,
        )
        freq = model.root_spectrogram(args.fs)
    record_columns(model, {"output": names})
    prediction, ok = _predict(model, y, None)
    err = prediction - y[model.lag :]
    valid = ok[:, None] & np.isfinite(y[model.lag :])
    counts = _missing_values(names, y)
    any_missing = any(counts.values())
    n_missing = model.info.get("n_missing")
    n_missing = (
        int(np.count_nonzero(~np.all(valid, axis=1))) if n_missing is None else int(n_missing)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN tracks (real poles)
        tracks = np.nanmedian(freq, axis=0) if freq.size else np.zeros(0)
    facts = _lam_facts(model, args.lam)
    report: dict[str, Any] = {
        "command": "ar",
        "data": label,
        "T": T,
        "column": names,
        "model": type(model).__name__,
        "N": model.N,
        "na": args.na,
        "fs": args.fs,
        "norm": args.norm,
        "order": args.order,
        "constant": bool(model.constant),
        **facts,
        "n_missing": n_missing,
        "missing_values": counts,
        "rms": {"prediction": rms(err, valid), "prediction_per_output": rms_columns(err, valid)},
        "median_pole_frequencies": tracks,
        "noise_var": None if model.noise_var is None else np.atleast_1d(model.noise_var),
        "loglik": model.loglik,
        "solver": model.info.get("solver"),
        "converged": model.info.get("converged"),
        "info": info_subset(model.info),
    }
    how = (
        f"chosen by lam=auto, criterion {facts['lam_method']!r}" if args.lam == "auto" else "given"
    )
    lines = [
        f"ltvmodels ar: {label}, T = {T} samples of {', '.join(names)}, fs = {args.fs:g}",
        f"fit: AR({args.na}), norm={args.norm!r}, order={args.order}, lambda = "
        f"{fmt(float(facts['lam']))} ({how})"
        + (", with a time-varying offset c_t" if args.constant else ""),
        model.summary(),
    ]
    if any_missing:
        lines.append(
            _missing_text(
                n_missing,
                model.N,
                counts,
                "time steps",
                f"a step enters the fit only if y[t] and its {args.na} lags are observed",
            )
        )
    lines += [
        _noise_text(model, names),
        f"one-step prediction RMS: {fmt(report['rms']['prediction'])} (samples {model.lag} "
        f"to {T - 1}" + ("; observed samples only" if any_missing else "") + ")",
        "root spectrogram: median frequency of each pole-pair track: "
        + (", ".join(fmt(float(f)) for f in tracks) if tracks.size else "(no complex poles)"),
    ]
    fig = None
    if outputs.plot is not None:  # drawn before anything is written: it may fail
        stft = y.shape[1] == 1 and T >= 8
        with figure_errors():
            ax = None
            if stft and not any_missing:  # no short-time Fourier spectrum of missing samples
                ax = plot_spectrogram(y[:, 0], args.fs)
            ax = plot_root_spectrogram(model, args.fs, ax=ax)
        ax.set_title(
            f"{label}: root spectrogram of AR({args.na}), norm={args.norm!r}, "
            f"order {args.order}, λ = {float(facts['lam']):.4g}"
            + (" (no spectrogram: missing samples)" if stft and any_missing else "")
        )
        if ax.get_legend_handles_labels()[1]:  # nothing labelled without complex poles
            ax.legend(loc="upper right", fontsize="small", markerscale=6)
        fig = ax.figure
    return write_outputs(outputs, report, lines, model=model, figure=fig)


def _cmd_select_lambda(args: argparse.Namespace) -> Report:

    outputs = check_outputs(args, None)
    if args.column is not None:
        if args.state is not None or args.input is not None:
            raise CommandError("--column: an AR model takes no --state or --input")
        if args.na is None:
            raise CommandError("--na: the AR order is required with --column")
        T, label, cols = read_columns(args.data, column=args.column, weights=args.weights)
        row_weights = None
        if cols["weights"] is not None:  # the equation predicting row t has row t's weight
            row_weights = cols["weights"][1][args.na :, 0]
            if not np.all(np.isfinite(row_weights)):
                raise DataError("--weights: the weights must be observed (no missing values)")
        names, y = cols["column"]
        # ar_regressors takes finite data: fill missing samples, then leave out (NaN) the
        # rows whose target or lags are missing, as fit_ar does
        filled = np.where(np.isfinite(y), y, 0.0)
        with user_errors():
            y_out, phi = ar_regressors(
                filled[:, 0] if y.shape[1] == 1 else filled, args.na, constant=args.constant
            )
        y_out, phi = np.array(y_out, dtype=float), np.array(phi, dtype=float)
        count = np.concatenate([[0], np.cumsum(~np.all(np.isfinite(y), axis=1))])
        t = args.na + np.arange(y_out.shape[0])
        left_out = count[t + 1] - count[t - args.na] > 0
        y_out[left_out], phi[left_out] = np.nan, np.nan
        n_missing, N, counts = (
            int(np.count_nonzero(left_out)),
            y_out.shape[0],
            _missing_values(names, y),
        )
        missing_rule = (
            "time steps",
            f"a step enters only if y[t] and its {args.na} lags are observed",
        )
        data_facts = {"column": names, "na": args.na}
        what = f"AR({args.na}) of {', '.join(names)}"
    else:
        if args.state is None:
            raise CommandError(
                "--state: expected the state columns (or --column and --na for an AR model)"
            )
        if args.na is not None:
            raise CommandError("--na: applies with --column (an AR model) only")
        label, x, u, state_names, input_names = _state_space_data(args)
        T = x.shape[0]
        n_missing, N, counts = (
            _missing_transitions(x, u),
            T - 1,
            _missing_values(state_names + input_names, x, u),
        )
        entry = "x[t], u[t] and x[t+1] are" if u is not None else "x[t] and x[t+1] are"
        missing_rule = ("transitions", f"a transition enters only if {entry} observed")
        data_facts = {"state": state_names, "input": input_names}
        what = f"states {', '.join(state_names)}; inputs {', '.join(input_names) or '(none)'}"
    with Progress("ltvmodels select-lambda: evaluating the candidates") as bar, user_errors():

        def progress(done: int, total: int) -> None:
            bar.total, bar.done = total, done

        robust = {"loss": args.loss, "huber_delta": args.huber_delta}
        if args.column is not None:
            selection = select_lambda_regression(
                y_out,
                phi,
                norm=args.norm,
                order=args.order,
                method=args.method,
                progress=progress,
                weights=row_weights,
                **robust,
            )
        elif args.norm == "l0":  # one dynamic program: no steps to count
            selection = select_lambda(
                x,
                u,
                norm=args.norm,
                method=args.method,
                constant=args.constant,
                weights=args.transition_weights,
                **robust,
            )
        else:
            selection = select_lambda(
                x,
                u,
                norm=args.norm,
                order=args.order,
                method=args.method,
                progress=progress,
                constant=args.constant,
                weights=args.transition_weights,
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
        lines.append(_missing_text(n_missing, N, counts, *missing_rule))
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
    fig = None if outputs.plot is None else plot_lambda_selection(selection).figure
    return write_outputs(outputs, report, lines, figure=fig)


def _load_model(path: str) -> Any:

    p = Path(path)
    if not p.exists():
        raise DataError(f"{path}: no such file")
    if p.is_dir():
        raise DataError(f"{path}: is a directory, expected a model file (.npz)")
    if not zipfile.is_zipfile(p):
        raise DataError(
            f"{path}: not an ltvmodels model file (expected an .npz archive written "
            "by 'ltvmodels fit --out' or model.save)"
        )
    try:
        return load(p)
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except Exception as exc:  # a damaged archive, or not one of ours
        text = one_line(exc)
        if text.startswith("path: "):  # ltvmodels.load's own messages
            text = text[len("path: ") :]
            text = text[len(str(p)) + 1 :] if text.startswith(f"{p} ") else text
            text = text.removeprefix("is ")
            raise DataError(f"{path}: {text}") from None
        raise DataError(
            f"{path}: not an ltvmodels model file ({type(exc).__name__}: {text})"
        ) from None


def _model_data(args: argparse.Namespace, model: Any) -> dict[str, Any]:
    """Read the columns a loaded model needs from DATA and check their sizes."""

    recorded = model.info.get("data_columns")
    recorded = recorded if isinstance(recorded, dict) else {}
    if isinstance(model, LTVModel):
        kind, n, m, lag = "ltv", model.n_states, model.n_inputs, 1
        out_key = "state"
    elif isinstance(model, ARXModel):
        kind = "ar" if isinstance(model, ARModel) else "arx"
        n, m, lag = model.n_outputs, model.n_inputs, model.lag
        out_key = "output"
    else:
        raise DataError(
            f"{args.model}: a {type(model).__name__} has no dynamics to "
            f"{args.command} (expected a model from fit, segments or ar)"
        )
    state = args.state if args.state is not None else _spec(recorded.get(out_key))
    inputs = args.input if args.input is not None else _spec(recorded.get("input"))
    if state is None:
        raise DataError(
            f"--state: {args.model} does not record its data columns; give "
            f"--state (and --input) to choose them in the data"
        )
    if m and inputs is None:
        raise DataError(
            f"--input: the model has {m} inputs; give --input to choose their columns in the data"
        )
    if not m and args.input is not None:
        raise DataError(f"--input: the model has no inputs, received {args.input!r}")
    T, label, cols = read_columns(args.data, state=state, input=inputs if m else None)
    names, y = cols["state"]
    if y.shape[1] != n:
        what = "states" if kind == "ltv" else "outputs"
        raise DataError(
            f"--state: the model has {n} {what}, received {y.shape[1]} columns ({', '.join(names)})"
        )
    u = None
    input_names: list[str] = []
    if m:
        input_names, u = cols["input"]
        if u.shape[1] != m:
            raise DataError(
                f"--input: the model has {m} inputs, received {u.shape[1]} "
                f"columns ({', '.join(input_names)})"
            )
    expected = model.N + lag
    if T != expected:
        steps = (
            f"N = {model.N} transitions"
            if kind == "ltv"
            else f"N = {model.N} time steps after {lag} initial samples"
        )
        raise DataError(
            f"{label}: expected T = {expected} rows (the model has {steps}), received {T}"
        )
    return {
        "kind": kind,
        "label": label,
        "T": T,
        "y": y,
        "u": u,
        "names": names,
        "input_names": input_names,
        "lag": lag,
    }


def _spec(names: Any) -> str | None:
    if not names:
        return None
    return ",".join(str(name) for name in names)


def _check_simulation_data(data: dict[str, Any], model: Any) -> None:
    """An open-loop simulation needs the initial state (samples) and every input."""
    ltv = data["kind"] == "ltv"
    u = data["u"]
    with user_errors(f"{data['label']}: "):  # as predict checks them: no inf in the report
        representable(data["y"], "--state" if ltv else "--column")
        if u is not None:
            representable(u, "--input")
    if u is not None and ltv:
        u = u[: model.N]  # u[T-1] drives no transition
    missing = _first_missing(u, data["input_names"])
    if missing is not None:
        raise DataError(
            f"--input: {data['label']}: input {missing[1]} is missing at sample "
            f"{missing[0]}; an open-loop simulation needs every input (fill it "
            "in, or use 'ltvmodels predict', which leaves out the predictions "
            "that need a missing sample)"
        )
    missing = _first_missing(data["y"][: data["lag"]], data["names"])
    if missing is not None:
        what = "initial state" if ltv else f"initial samples (the first {data['lag']})"
        raise DataError(
            f"{'--state' if ltv else '--column'}: {data['label']}: the {what} "
            f"must be observed, received a missing value of {missing[1]} at "
            f"sample {missing[0]}; the simulation starts from "
            f"{'it' if ltv else 'them'} (fill it in)"
        )


def _cmd_simulate_or_predict(args: argparse.Namespace) -> Report:

    outputs = check_outputs(args, "table")
    model = _load_model(args.model)
    data = _model_data(args, model)
    kind, y, u, lag = data["kind"], data["y"], data["u"], data["lag"]
    simulate = args.command == "simulate"
    if simulate:
        _check_simulation_data(data, model)
        with user_errors():
            if kind == "ltv":
                result = model.simulate(y[0], None if u is None else u[: model.N])
            else:
                series = y[:, 0] if y.shape[1] == 1 else y
                extra = () if kind == "ar" else (u,)
                result = model.simulate(series[:lag], *extra)
        result = np.asarray(result, dtype=float).reshape(-1, y.shape[1])
        start = 0 if kind == "ltv" else lag
        if kind != "ltv":  # y[0:lag] are the given initial samples
            result = result[lag:]
        computed = np.ones(result.shape[0], dtype=bool)
    else:  # NaN where a regressor is missing
        result, computed = _predict(model, y, u)
        start = 1 if kind == "ltv" else lag
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
        "data": data["label"],
        "T": data["T"],
        "columns": data["names"],
        "input": data["input_names"],
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
        f"ltvmodels {args.command}: {args.model} on {data['label']} (T = {data['T']} samples; "
        f"columns {', '.join(data['names'])}; inputs {', '.join(data['input_names']) or '(none)'})",
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
        f"RMS error: {fmt(total_rms)} ({per_name(data['names'], per)})"
        + (f"; {left_out} of {valid.size} values left out (missing data)" if left_out else "")
        + ("; the simulation diverges (non-finite values)" if diverged else ""),
    ]
    fig = None
    if outputs.plot is not None:  # drawn before anything is written: it may fail
        limit = (
            "missing values"
            if np.isnan(y).any() or report["n_not_computed"]
            else "a diverging simulation"
            if diverged
            else None
        )
        with figure_errors(limit):
            fig = plot_simulation(y, result, start=start, names=data["names"], label=noun)
        fig.suptitle(f"{args.model} on {data['label']}: {noun}")
    table = Table(
        ["t", *data["names"]],
        np.column_stack([np.arange(start, start + result.shape[0]), result]),
    )
    return write_outputs(outputs, report, lines, table=table, figure=fig)


def _cmd_forecast(args: argparse.Namespace) -> Report:
    """Forecast a saved model after the end of the data it was fitted on."""
    outputs = check_outputs(args, "table")
    model = _load_model(args.model)
    data = _model_data(args, model)
    kind, y, u, lag, H = data["kind"], data["y"], data["u"], data["lag"], args.steps
    future = _future_inputs(args, model, data, H)
    with user_errors(f"{data['label']}: "):
        representable(y[-lag:], "--state" if kind == "ltv" else "--column")
    with user_errors():
        if kind == "ltv":
            inputs = (
                None if u is None or future is None else np.concatenate([u[-1:], future[: H - 1]])
            )
            forecast = model.forecast(y[-1], inputs, steps=H, level=args.level, seed=args.seed)
        elif kind == "arx" and future is not None:  # an ARX model has inputs: future is set
            forecast = model.forecast(
                y[-lag:],
                np.concatenate([u[-lag:], future[:H]]),
                steps=H,
                level=args.level,
                seed=args.seed,
            )
        else:
            forecast = model.forecast(y[-lag:], steps=H, level=args.level, seed=args.seed)
    names = data["names"]
    forecast = replace(forecast, names=names)  # the data's column names
    report: dict[str, Any] = {
        "command": "forecast",
        "model_file": str(args.model),
        "model": type(model).__name__,
        "data": data["label"],
        "T": data["T"],
        "columns": names,
        "steps": H,
        "level": args.level,
        "method": forecast.method,
        "time": _time_text(forecast.time),
        "mean": forecast.mean.tolist(),
        "lower": forecast.lower.tolist(),
        "upper": forecast.upper.tolist(),
    }
    percent = f"{100 * args.level:g} %"
    times = _time_text(forecast.time)  # sample indices, or the dates of a dated model
    lines = [
        f"ltvmodels forecast: {args.model} after {data['label']} (T = {data['T']} samples; "
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
            history = y[-min(len(y), max(4 * H, 50)) :]
            fig = forecast.plot(history=history)
            fig.suptitle(f"{args.model} after {data['label']}: forecast, {percent} intervals")
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


def _future_inputs(
    args: argparse.Namespace, model: Any, data: dict[str, Any], H: int
) -> np.ndarray | None:
    """The inputs after the end of DATA from --future-input (None for a model without)."""
    m = len(data["input_names"])
    if not m:
        if args.future_input is not None:
            raise DataError("--future-input: the model has no inputs")
        return None
    needed = H - 1 if data["kind"] == "ltv" else H
    if args.future_input is None:
        if needed == 0:
            return np.zeros((0, m))
        raise DataError(
            f"--future-input: the model has inputs ({', '.join(data['input_names'])}"
            f"); give a data file with those columns for the {needed} samples "
            "after the end of the data"
        )
    rows, label, cols = read_columns(args.future_input, input=",".join(data["input_names"]))
    values = cols["input"][1]
    if rows < needed:
        raise DataError(
            f"{label}: expected at least {needed} rows of future inputs for "
            f"--steps {H}, received {rows}"
        )
    if not np.all(np.isfinite(values[:needed])):
        raise DataError(f"{label}: the future inputs must be observed (no missing values)")
    return values


def _cmd_demo(args: argparse.Namespace) -> Report:
    system = args.system
    if system != "jump-linear":
        for option, value in (("--norm", args.norm), ("--lam", args.lam)):
            if value is not None:
                raise CommandError(f"{option}: applies to the jump-linear demo only")
    if args.quick and system not in ("chirp", "rl", "pendulum"):
        raise CommandError("--quick: applies to the chirp, rl and pendulum demos only")
    if args.full and system not in ("rl", "pendulum"):
        raise CommandError("--full: applies to the rl and pendulum demos only")
    if args.quick and args.full:
        raise CommandError("--quick, --full: expected one of them, received both")
    out = DEFAULT_DEMO_OUT[system] if args.out is None else args.out
    if system == "jump-linear":
        run_jump_linear_demo(seed=args.seed, norm=args.norm or "group", lam=args.lam, out=out)
    elif system == "robot":
        run_robot_demo(seed=args.seed, out=out)
    elif system == "chirp":
        run_chirp_demo(seed=args.seed, out=out, quick=args.quick)
    elif system == "pendulum":
        size = "full" if args.full else ("quick" if args.quick else "default")
        runs = {"default": 2, "quick": 1, "full": 20}[size]
        try:
            with Progress("ltvmodels demo pendulum: runs", total=runs) as bar:
                run_pendulum_demo(
                    seed=args.seed, out=out, size=size, progress=lambda _line: bar.advance()
                )
        except ImportError as exc:
            raise CommandError(f"demo pendulum: {exc}") from None
    else:
        size = "full" if args.full else ("quick" if args.quick else "default")
        runs = {"default": QUICK_RUNS, "quick": 1, "full": 20}[size]
        with Progress("ltvmodels demo rl: Monte-Carlo runs", total=runs) as bar:
            run_rl_demo(seed=args.seed, out=out, size=size, progress=lambda _line: bar.advance())
    return {}, []


COMMANDS: dict[str, Callable[[argparse.Namespace], Report]] = {
    "fit": _cmd_fit,
    "segments": _cmd_segments,
    "ar": _cmd_ar,
    "select-lambda": _cmd_select_lambda,
    "simulate": _cmd_simulate_or_predict,
    "predict": _cmd_simulate_or_predict,
    "forecast": _cmd_forecast,
    "demo": _cmd_demo,
    "fit-many": cmd_fit_many,
}
"""The subcommands by name: each returns (report dict, text lines)."""
