"""``ltvmodels ar``: a time-varying AR model of a column and its root spectrogram."""

from __future__ import annotations

import argparse
import warnings
from typing import Any

import numpy as np

from .. import arguments as opt
from ..messages import running
from ..report import Report, fmt, info_subset, missing_text, noise_text, rms, rms_columns
from ..subcommand import Subcommand

__all__ = ["COMMAND", "add_arguments", "run"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``ar``."""
    opt.add_data(p)
    opt.add_column(
        p,
        "the signal's column (name or 0-based index; several for a vector AR model)",
        required=True,
    )
    opt.add_na(p, "AR order", required=True)
    p.add_argument(
        "--fs",
        type=opt.positive_float,
        default=None,
        metavar="HZ",
        help="sampling frequency: the frequencies are in its unit (Hz for samples per "
        "second); it scales the frequency axis only. Default: cycles per sample, or with "
        "--time cycles per unit of the time column (per day for dates)",
    )
    opt.add_time(p)
    opt.add_norm(p, "penalty on the coefficient changes (default: sq)")
    opt.add_order(p)
    opt.add_lam(p, "regularization lambda or auto (default: auto)")
    opt.add_noise_var(p, "noise variance, one or one per column (default: estimated)")
    opt.add_weights(p)
    opt.add_constant(p, "a time-varying offset c_t")
    opt.add_sparse_options(p)
    opt.add_coef_out(p)
    opt.add_outputs(
        p,
        out="model file to write (.npz)",
        plot="figure: root spectrogram over the short-time Fourier spectrogram",
    )


def run(args: argparse.Namespace) -> Report:
    """Fit the AR model, report its pole frequencies, and write the outputs asked for.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``ar`` arguments.

    Returns
    -------
    report : dict
        What ``--json`` prints.
    lines : list of str
        The text summary.
    """
    from ...estimators.ar import fit_ar
    from ..analysis import changepoint_report, lam_facts, lam_how, missing_values, predict
    from ..outputs import check_outputs, figure_errors, record_columns, write_outputs
    from ..recordings import column_data

    outputs = check_outputs(args, "model")
    data = column_data(args)
    names, y, label, T = data.names, data.y, data.label, data.y.shape[0]
    fs, frequency_unit = _frequency_scale(args.fs, data.time)
    what = "choosing lambda and fitting" if args.lam == "auto" else "fitting"
    with running(f"ltvmodels ar: {what}") as progress:  # the candidates of lam=auto
        model = fit_ar(
            data.series,
            args.na,
            lam=args.lam,
            norm=args.norm,
            order=args.order,
            constant=args.constant,
            max_iter=args.max_iter,
            tol=args.tol,
            weights=data.weights,
            noise_var=args.noise_var,
            progress=progress,
        )
        freq = model.root_spectrogram(fs)
    model = record_columns(model, {"output": names}, data.time)
    changepoint_facts, changepoint_line, _ = changepoint_report(model)
    prediction, ok = predict(model, y, None)
    err = prediction - y[model.lag :]
    valid = ok[:, None] & np.isfinite(y[model.lag :])
    counts = missing_values(names, y)
    any_missing = any(counts.values())
    n_missing = model.n_missing
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN tracks (real poles)
        tracks = np.nanmedian(freq, axis=0) if freq.size else np.zeros(0)
    facts = lam_facts(model, args.lam)
    report: dict[str, Any] = {
        "command": "ar",
        "data": label,
        "T": T,
        "column": names,
        "model": type(model).__name__,
        "N": model.N,
        "na": args.na,
        "fs": fs,
        "frequency_unit": frequency_unit,
        "norm": args.norm,
        "order": args.order,
        "constant": bool(model.constant),
        **facts,
        "n_missing": n_missing,
        "missing_values": counts,
        "rms": {"prediction": rms(err, valid), "prediction_per_output": rms_columns(err, valid)},
        "median_pole_frequencies": tracks,
        **changepoint_facts,
        "noise_var": None if model.noise_var is None else np.atleast_1d(model.noise_var),
        "loglik": model.loglik,
        "solver": model.info.get("solver"),
        "converged": model.info.get("converged"),
        "info": info_subset(model.info),
    }
    lines = [
        f"ltvmodels ar: {label}, T = {T} samples of {', '.join(names)}, fs = {fs:g} "
        f"(frequencies in {frequency_unit})",
        f"fit: AR({args.na}), norm={args.norm!r}, order={args.order}, lambda = "
        f"{fmt(float(facts['lam']))} ({lam_how(facts)})"
        + (", with a time-varying offset c_t" if args.constant else ""),
        model.summary(),
    ]
    if any_missing:
        lines.append(
            missing_text(
                n_missing,
                model.N,
                counts,
                "time steps",
                f"a step enters the fit only if y[t] and its {args.na} lags are observed",
            )
        )
    lines += [
        noise_text(model, names),
        f"one-step prediction RMS: {fmt(report['rms']['prediction'])} (samples {model.lag} "
        f"to {T - 1}" + ("; observed samples only" if any_missing else "") + ")",
        "root spectrogram: median frequency of each pole-pair track: "
        + (", ".join(fmt(float(f)) for f in tracks) if tracks.size else "(no complex poles)"),
        changepoint_line,
    ]
    fig = None
    if outputs.plot is not None:  # drawn before anything is written: it may fail
        from ...plotting import plot_root_spectrogram, plot_spectrogram

        # The short-time Fourier spectrogram's axis counts time from the first sample:
        # under the root spectrogram only for a series without --time.
        stft = y.shape[1] == 1 and T >= 8 and data.time is None
        with figure_errors():
            ax = None
            if stft and not any_missing:  # no short-time Fourier spectrum of missing samples
                ax = plot_spectrogram(y[:, 0], fs)
            # With --time and no --fs the figure takes the frequency unit from the time axis.
            ax = plot_root_spectrogram(model, fs if data.time is None else args.fs, ax=ax)
        ax.set_title(
            f"{label}: root spectrogram of AR({args.na}), norm={args.norm!r}, "
            f"order {args.order}, λ = {float(facts['lam']):.4g}"
            + (" (no spectrogram: missing samples)" if stft and any_missing else "")
        )
        if ax.get_legend_handles_labels()[1]:  # nothing labelled without complex poles
            ax.legend(loc="upper right", fontsize="small", markerscale=6)
        fig = ax.figure
    return write_outputs(outputs, report, lines, model=model, figure=fig)


def _frequency_scale(fs: float | None, time: np.ndarray | None) -> tuple[float, str]:
    """The sampling frequency the pole frequencies are scaled with, and their unit.

    ``--fs`` when given (it scales the frequencies only); else, with ``--time``,
    the samples per unit of the time column (per day for dates; the median step
    of its grid, e.g. about 30.4 days for a monthly series), else 1 (cycles per
    sample).
    """
    if fs is not None:
        return fs, "cycles per time unit of --fs"
    if time is None or time.size < 2:
        return 1.0, "cycles per sample"
    if np.issubdtype(time.dtype, np.datetime64):
        step = np.median(np.diff(time) / np.timedelta64(1, "D"))
        return 1.0 / float(step), "cycles per day"
    return 1.0 / float(np.median(np.diff(time))), "cycles per unit of the time column"


COMMAND = Subcommand(
    description="Fit a time-varying AR(na) model y[t] = sum_i a_{t,i} y[t-i] + e[t] to "
    "a column and report its root spectrogram (pole frequencies over time) and its change "
    "points (model steps, the samples of the data they lie at and, with --time, their "
    "times).",
    add_arguments=add_arguments,
    run=run,
)
