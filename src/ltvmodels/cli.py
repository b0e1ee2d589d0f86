"""The ``ltvmodels`` command (also ``python -m ltvmodels``).

Subcommands::

    ltvmodels fit DATA --state COLS [--input COLS] [--norm {sq,group,l1}] [--order N]
                  [--lam {VALUE,auto}] [--refine] [--out MODEL.npz] [--plot FIG] [--json]
    ltvmodels segments DATA --state COLS [--input COLS] [--n-changes M | --penalty B]
                  [--min-size S] [--out MODEL.npz] [--plot FIG] [--json]
    ltvmodels ar DATA --column C --na N [--fs HZ] [--norm ...] [--order N] [--lam {VALUE,auto}]
                  [--out MODEL.npz] [--plot FIG] [--json]
    ltvmodels select-lambda DATA (--state COLS [--input COLS] | --column C --na N)
                  [--norm {sq,group,l1,l0}] [--order N] [--method M] [--plot FIG] [--json]
    ltvmodels simulate MODEL.npz DATA [--state COLS] [--input COLS] [--out SIM.csv]
                  [--plot FIG] [--json]
    ltvmodels predict MODEL.npz DATA [--state COLS] [--input COLS] [--out PRED.csv]
                  [--plot FIG] [--json]
    ltvmodels demo {jump-linear,robot,chirp,rl,pendulum} [--seed S] [--out PATH] ...

DATA is a CSV file (comma, semicolon or tab separated, detected from the first
line; a header row of column names is optional; lines starting with ``#`` are
comments), ``-`` for CSV on standard input, or a Parquet file (``.parquet``,
``.pq``; needs pandas with pyarrow or fastparquet). Columns are chosen by name
or 0-based index, comma-separated (``--state x1,x2``, ``--input 3``); only the
chosen columns must be numeric. A model written by ``fit``, ``segments`` or
``ar`` records its data columns, so ``simulate`` and ``predict`` find them in
new data without ``--state``/``--input``.

The command line uses :mod:`argparse` from the standard library: the
subcommands need nothing it lacks, and an extra dependency (click, typer) for
every user of the library is not justified. A small subclass makes its errors
one line.

User errors (unknown options or columns, bad values, a missing or unreadable
file, data the model cannot use, an output path that cannot be written) print
one line to stderr and give exit status 2, without traceback; warnings of the
library are one line each on stderr. Long work (λ selection, sparse and L0
fits, the RL experiment) shows a progress line on stderr when it is a
terminal, and nothing when it is piped. ``--json`` prints one JSON object
(strict JSON: NaN and infinities become ``null``) instead of the text summary.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import math
import os
import sys
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, NoReturn, Sequence, TextIO

import numpy as np

__all__ = [
    "main",
    "build_parser",
    "run_jump_linear_demo",
    "run_robot_demo",
    "run_chirp_demo",
    "run_rl_demo",
    "run_pendulum_demo",
    "DataError",
    "OutputPathError",
    "JUMP_LINEAR_LAM",
    "DEFAULT_JUMP_LINEAR_OUT",
]

JUMP_LINEAR_LAM = 30.0
"""Fixed λ of the jump-linear demo (norm="sq", order=1).

Chosen by comparing λ ∈ {1, 3, 5, 10, 20, 30, 50, 100, 300} on seeds 0, 1, 2:
λ = 30 gave the smallest RMS coefficient error for all three seeds (about
0.05–0.06; λ = 10 and λ = 100 roughly double it, least-squares LTI triples it)
and lies at or next to the maximum of the log marginal likelihood
(``model.loglik``). The figure shows the expected trade-off of the squared
norm: low noise in the constant segments, the jump smoothed over about 50
steps. (The ``group`` norm, once available, recovers the jump sharply.)
"""

DEFAULT_JUMP_LINEAR_OUT = "ltvmodels-jump-linear.png"
DEFAULT_DEMO_OUT = {
    "jump-linear": DEFAULT_JUMP_LINEAR_OUT,
    "robot": "ltvmodels-robot.png",
    "chirp": "ltvmodels-chirp.png",
    "rl": "ltvmodels-rl.png",
    "pendulum": "ltvmodels-pendulum.png",
}
"""Default image file of each demo (the robot demo writes ``<stem>_train`` and
``<stem>_validation`` next to it)."""


class OutputPathError(ValueError):
    """The output path cannot be written (missing directory, unsupported format, ...)."""


class _UsageError(Exception):
    """A command-line usage error; its message is the one line to print."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (no usage dump) and are raised, not exited."""

    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{self.prog}: error: {message} (see '{self.prog} --help')")


# -- output path -------------------------------------------------------------------
def _image_format(path: Path) -> str:
    """Format from the file suffix ('png' without suffix); OutputPathError if unsupported."""
    from matplotlib.backend_bases import FigureCanvasBase

    supported = FigureCanvasBase.get_supported_filetypes()
    suffix = path.suffix.lower().lstrip(".")
    if not suffix:
        return "png"
    if suffix not in supported:
        raise OutputPathError(
            f"out: unsupported image format {path.suffix!r} in {str(path)!r} "
            f"(expected one of: {', '.join('.' + s for s in sorted(supported))})"
        )
    return suffix


def _check_file_path(out: Any, option: str = "out") -> Path:
    """Validate a path to write (any file type) before any work is done."""
    if not isinstance(out, (str, os.PathLike)) or str(out) == "":
        raise OutputPathError(f"{option}: expected a file path, received {out!r}")
    path = Path(out)
    if path.is_dir():
        raise OutputPathError(f"{option}: {str(path)!r} is a directory; expected a file path")
    parent = path.parent
    if not parent.is_dir():
        raise OutputPathError(f"{option}: cannot write {str(path)!r}: directory "
                              f"{str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise OutputPathError(f"{option}: cannot write {str(path)!r}: directory "
                              f"{str(parent)!r} is not writable")
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputPathError(f"{option}: cannot write {str(path)!r}: file is not writable")
    return path


def _optional_output_path(out: Any) -> tuple[Path | None, str | None]:
    """:func:`_check_output_path` of ``out``, or (None, None) when no file is wanted."""
    return _check_output_path(out) if out is not None else (None, None)


def _report(lines: list[str], stream: TextIO, fig: Any, path: Path | None,
            fmt: str | None, dpi: int = 120) -> None:
    """Write ``fig`` to ``path`` (if any), then print the demo's report."""
    if path is not None:
        _save_figure(fig, path, fmt, dpi=dpi)
        lines.append(f"wrote {path}")
    print("\n".join(lines), file=stream)


def _check_output_path(out: Any, option: str = "out") -> tuple[Path, str]:
    """Validate an image path before any work is done; return (path, format)."""
    path = _check_file_path(out, option)
    try:
        return path, _image_format(path)
    except OutputPathError as exc:
        raise OutputPathError(f"{option}:{str(exc).split(':', 1)[1]}") from None


def _save_figure(fig: Any, path: Path, fmt: str, option: str = "out", dpi: int = 110) -> None:
    """``fig.savefig`` with write errors as OutputPathError."""
    try:
        fig.savefig(path, format=fmt, dpi=dpi)
    except OSError as exc:
        reason = exc.strerror or exc
        raise OutputPathError(f"{option}: cannot write {str(path)!r}: {reason}") from exc


def _rms(a: np.ndarray) -> float:
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.sqrt(np.mean(np.square(a))))


# -- demos -------------------------------------------------------------------------
def run_jump_linear_demo(
    *,
    seed: int = 0,
    norm: str = "group",
    lam: float | None = None,
    out: str | os.PathLike | None = DEFAULT_JUMP_LINEAR_OUT,
    stream: TextIO | None = None,
) -> dict[str, Any]:
    """Simulate the paper's jump-linear system, fit it, report and plot.

    Simulates :func:`ltvmodels.systems.jump_linear` (T = 400, switch at
    t = 200, process and measurement noise σ = 0.2) and fits it. With
    ``norm="group"`` (the paper's Fig. 1) this is the group-lasso fit
    (eq. pwconstant, order 1) followed by the two-step refinement
    (``refine=True``); with ``norm="sq"`` a slowly varying fit. It writes a report
    (the model summary, RMS coefficient error against the truth and in-sample
    one-step prediction RMS, each compared with the least-squares LTI model and
    the true coefficients) and saves a figure of the estimated coefficients
    with ±2σ bands against the truth.

    Parameters
    ----------
    seed : int, default 0
        Seed of the simulation.
    norm : {"group", "sq"}
        The penalty.
    lam : float, optional
        Regularization λ. Default: for "group" 0.1·λ_max, where λ_max is the
        smallest λ giving the LTI model (``info["lambda_max"]``; automatic
        selection by the L-curve is planned); for "sq"
        :data:`JUMP_LINEAR_LAM` (30).
    out : str or path-like or None, default ``"ltvmodels-jump-linear.png"``
        Image file to write (format from the suffix; png without one);
        None writes no file.
    stream : text stream, optional
        Where the report goes (default ``sys.stdout``).

    Returns
    -------
    dict
        ``data`` (:class:`~ltvmodels.systems.SimulatedData`), ``model``,
        ``lti`` (the LTI fit), ``coef_rms``, ``coef_rms_lti``, ``pred_rms``,
        ``pred_rms_lti``, ``pred_rms_truth`` (floats), ``figure`` and ``out``
        (the Path written, or None).

    Raises
    ------
    OutputPathError
        If ``out`` cannot be written (checked before fitting).
    """
    from . import plotting, systems
    from .changepoints import find_changepoints
    from .fit import fit, fit_lti

    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)

    data = systems.jump_linear(seed=seed)
    if norm == "group":
        if lam is None:
            lam = 0.1 * fit(data.x, data.u, lam=1.0, norm="group").info["lambda_max"]
        model = fit(data.x, data.u, lam=lam, norm="group", order=1, refine=True)
        first_k = model.info["first_step_k"]
        found = model.changepoints
    else:
        lam = JUMP_LINEAR_LAM if lam is None else lam
        model = fit(data.x, data.u, lam=lam, norm="sq", order=1)
        found = find_changepoints(model)
    lti = fit_lti(data.x, data.u)
    x_next = data.x[1:]
    truth_pred = np.einsum("tij,tj->ti", data.theta, np.hstack([data.x[:-1], data.u[:-1]]))
    result: dict[str, Any] = {
        "data": data,
        "model": model,
        "changepoints": found,
        "lam": lam,
        "lti": lti,
        "coef_rms": _rms(model.k - data.k),
        "coef_rms_lti": _rms(lti.k - data.k),
        "pred_rms": _rms(model.predict(data.x, data.u) - x_next),
        "pred_rms_lti": _rms(lti.predict(data.x, data.u) - x_next),
        "pred_rms_truth": _rms(truth_pred - x_next),
    }
    c = int(data.changepoints[0]) if data.changepoints.size else data.N
    before, after = max(c // 2, 0), min((c + data.N) // 2, data.N - 1)
    lines = [
        f"ltvmodels demo: jump-linear system (Bagge Carlson et al. 2018, Section VI), seed {seed}",
        f"  T = {data.T} samples, n = {data.n} states, m = {data.m} input; A_t switches at "
        f"t = {c}; process and measurement noise sigma = {data.noise_std:g}",
        f"  fit: norm={norm!r}, order=1, lambda = {lam:.4g}"
        + (", then the two-step refinement" if norm == "group" else ""),
        "",
        model.summary(),
        "",
        f"change points found: {[int(v) for v in found]} (true: {c})",
        "",
    ]
    for t in (before, after):
        lines.append(f"A_t at t = {t}: estimate {np.round(model.A[t], 3).tolist()}, "
                     f"true {np.round(data.A[t], 3).tolist()}")
    lines += [
        "",
        "                           LTV fit   LTI least squares   true coefficients",
        f"coefficient RMS error    {result['coef_rms']:8.4f}   {result['coef_rms_lti']:17.4f}"
        f"   {0.0:17.4f}",
        f"one-step prediction RMS  {result['pred_rms']:8.4f}   {result['pred_rms_lti']:17.4f}"
        f"   {result['pred_rms_truth']:17.4f}",
        "(one-step prediction RMS is in-sample, on the noisy recorded states)",
    ]
    fig = plotting.plot_coefficients(model, truth=data)
    if norm == "group":
        for ax, first_step in zip(fig.axes, first_k.T, strict=False):
            ax.plot(first_step, color="tab:orange", lw=0.9, alpha=0.8, label="first step")
        fig.axes[0].legend(fontsize=7, loc="lower left")
        title = (f"Jump-linear system (paper Fig. 1): group lasso, λ = {lam:.3g}, refined "
                 "(±2σ), first step orange, truth dashed")
    else:
        title = f"Jump-linear system: norm='sq', order=1, λ = {lam:g} (±2σ, truth dashed)"
    fig.suptitle(title)
    result["figure"] = fig
    result["out"] = path
    _report(lines, stream, fig, path, fmt, dpi=110)
    return result


def _demo_path(out: Any, suffix: str) -> Path:
    """``<stem>_<suffix><ext>`` next to ``out`` (png when it has no suffix)."""
    path = Path(out)
    return path.with_name(f"{path.stem}_{suffix}{path.suffix or '.png'}")


def run_robot_demo(
    *,
    seed: int = 0,
    out: str | os.PathLike | None = DEFAULT_DEMO_OUT["robot"],
    stream: TextIO | None = None,
) -> dict[str, Any]:
    """Run the paper's robot example (Figs. 2–3), report and write both figures.

    Runs :func:`ltvmodels.robot.robot_experiment` (a two-link arm with Coulomb
    friction moving into a stiff wall; a piecewise-constant LTV model, group
    lasso of order 1, fitted to one run and simulated open loop on it and on a
    validation run with other torque noise) and writes the figures of
    :func:`ltvmodels.robot.plot_robot_experiment`.

    Parameters
    ----------
    seed : int, default 0
        Torque-noise seed of the training run; the validation run uses
        ``seed + 1``.
    out : str or path-like or None, default ``"ltvmodels-robot.png"``
        Base name of the figures: ``<stem>_train<suffix>`` and
        ``<stem>_validation<suffix>`` are written next to it (png without a
        suffix); None writes no file.
    stream : text stream, optional
        Where the report goes (default ``sys.stdout``).

    Returns
    -------
    dict
        ``experiment`` (:class:`~ltvmodels.robot.RobotExperiment`),
        ``changepoints``, ``rms_train``, ``rms_validation``, ``figures``
        (train, validation) and ``out`` (the two Paths written, or None).

    Raises
    ------
    OutputPathError
        If the figures cannot be written (checked before the work).
    """
    from .robot import plot_robot_experiment, robot_experiment

    stream = sys.stdout if stream is None else stream
    targets = None
    if out is not None:
        _check_output_path(out)
        targets = [_check_output_path(_demo_path(out, which)) for which in ("train", "validation")]
    seed = _nonnegative_seed(seed)
    result = robot_experiment(seed=seed, validation_seed=seed + 1)
    train, val = result.train, result.validation
    lines = [
        "ltvmodels demo: two-link arm with Coulomb friction and a stiff wall "
        f"(Bagge Carlson et al. 2018, Figs. 2-3), seeds {seed} and {seed + 1}",
        f"  T = {result.x_train.shape[0]} samples, 4 states (q, dq/dt), 3 inputs (2 torques "
        "and a constant), normalized; fit: norm='group', order=1",
        "",
        result.model.summary(),
        "",
        f"training run: dq2/dt changes sign at {train.sign_change_index}, contact at "
        f"{train.contact_index}; validation run: {val.sign_change_index}, {val.contact_index}",
        f"change points found: {[int(c) for c in result.changepoints]}",
        f"open-loop simulation RMS (normalized): training {result.rms_train:.3f}, "
        f"validation {result.rms_validation:.3f}",
    ]
    figures = [plot_robot_experiment(result, which) for which in ("train", "validation")]
    written = None
    if targets is not None:
        written = []
        for fig, (path, fmt) in zip(figures, targets, strict=True):
            _save_figure(fig, path, fmt)
            written.append(path)
            lines.append(f"wrote {path}")
    print("\n".join(lines), file=stream)
    return {"experiment": result, "changepoints": result.changepoints,
            "rms_train": result.rms_train, "rms_validation": result.rms_validation,
            "figures": figures, "out": written}


CHIRP_FS = 16000.0
"""Sampling frequency of the chirp demo (Hz)."""
CHIRP_LAM = float(np.sqrt(1e5))
"""λ of the chirp demo's AR(6) fits (λ² = 1e5, as the reference implementation)."""


def run_chirp_demo(
    *,
    seed: int = 0,
    out: str | os.PathLike | None = DEFAULT_DEMO_OUT["chirp"],
    quick: bool = False,
    stream: TextIO | None = None,
) -> dict[str, Any]:
    """Root spectrogram of a two-component chirp by time-varying AR(6) models.

    Generates :func:`ltvmodels.ar.chirp` (fs = 16 kHz, T = 2¹⁴ samples),
    fits AR(6) models with ``norm="sq"``, λ² = 1e5, for difference orders 1
    and 2 (:func:`ltvmodels.fit_ar`) and draws their root spectrograms
    (:func:`ltvmodels.plotting.plot_root_spectrogram`) over the short-time
    Fourier spectrogram (:func:`ltvmodels.plotting.plot_spectrogram`) with
    the first component's instantaneous frequency dashed. Reports the mean
    distance between that frequency and the nearest pole track, and the fit
    times.

    Parameters
    ----------
    seed : int, default 0
        Noise seed of the chirp.
    out : str or path-like or None, default ``"ltvmodels-chirp.png"``
        Image file to write (format from the suffix); None writes no file.
    quick : bool, default False
        A shorter record (T = 2¹²) for a fast check.
    stream : text stream, optional
        Where the report goes (default ``sys.stdout``).

    Returns
    -------
    dict
        ``y`` (the signal), ``models`` ({1: ARModel, 2: ARModel}),
        ``errors`` ({order: mean error in Hz}), ``times`` ({order: seconds}),
        ``figure`` and ``out`` (the Path written, or None).

    Raises
    ------
    OutputPathError
        If ``out`` cannot be written (checked before the work).
    """
    from . import plotting
    from .ar import chirp, fit_ar

    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)
    seed = _nonnegative_seed(seed)
    if not isinstance(quick, bool):
        raise TypeError(f"quick: expected True or False, received {quick!r}")
    T = 2**12 if quick else 2**14
    y, inst = chirp(T, CHIRP_FS, seed=seed)
    fig = plotting._new_figure((10.0, 4.0))
    axes = fig.subplots(1, 2, sharey=True)
    models, errors, times = {}, {}, {}
    lines = [f"ltvmodels demo: root spectrogram of a two-component chirp, fs = {CHIRP_FS:g} Hz, "
             f"T = {T} samples, seed {seed}; AR(6), norm='sq', lambda^2 = 1e5"]
    for ax, order in zip(axes, (1, 2), strict=True):
        start = time.perf_counter()
        model = fit_ar(y, na=6, lam=CHIRP_LAM, norm="sq", order=order)
        times[order] = time.perf_counter() - start
        freq = model.root_spectrogram(CHIRP_FS)
        target = inst[model.sample_index]
        errors[order] = float(np.mean(np.nanmin(np.abs(freq - target[:, None]), axis=1)))
        models[order] = model
        lines.append(f"order {order}: mean error {errors[order]:.2f} Hz between the "
                     "instantaneous frequency and the nearest pole track; fit of "
                     f"T = {T} samples in {times[order]:.3f} s")
        plotting.plot_spectrogram(y, CHIRP_FS, ax=ax)
        plotting.plot_root_spectrogram(model, CHIRP_FS, ax=ax)
        ax.plot(np.arange(T) / CHIRP_FS, inst, color="C3", linestyle="--", linewidth=1.0,
                label="instantaneous frequency")
        ax.set_title(f"AR(6), order {order}, λ² = 1e5: mean error {errors[order]:.1f} Hz")
        ax.legend(loc="upper left", fontsize="small", markerscale=6)
    axes[1].set_ylabel("")
    _report(lines, stream, fig, path, fmt)
    return {"y": y, "models": models, "errors": errors, "times": times, "figure": fig,
            "out": path}


def run_rl_demo(
    *,
    seed: int = 0,
    out: str | os.PathLike | None = DEFAULT_DEMO_OUT["rl"],
    size: str = "default",
    stream: TextIO | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Model-based reinforcement learning on a cart-pole (paper Section VIII, Fig. 4).

    Runs :func:`ltvmodels.rl.run_experiment` (true, LTV, LTI and LTV-with-prior
    models learning to damp a pendulum on a cart), prints the table of median
    costs per iteration and writes :func:`ltvmodels.rl.plot_experiment`.

    Parameters
    ----------
    seed : int, default 0
        Seed of the experiment.
    out : str or path-like or None, default ``"ltvmodels-rl.png"``
        Image file to write (format from the suffix); None writes no file.
    size : {"default", "quick", "full"}
        "default": the library's quick mode (3 runs of 8 iterations, seconds);
        "quick": 1 run of 4 iterations (a smoke test); "full": the paper's 20
        runs of 14 iterations (minutes).
    stream : text stream, optional
        Where the report goes (default ``sys.stdout``).
    progress : callable, optional
        Called with a line of text after each Monte-Carlo run.

    Returns
    -------
    dict
        ``experiment`` (:class:`~ltvmodels.rl.RLExperiment`), ``figure`` and
        ``out`` (the Path written, or None).

    Raises
    ------
    OutputPathError
        If ``out`` cannot be written (checked before the work).
    """
    from .rl import plot_experiment, run_experiment

    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)
    seed = _nonnegative_seed(seed)
    if size not in ("default", "quick", "full"):
        raise ValueError(f"size: expected 'default', 'quick' or 'full', received {size!r}")
    runs, iterations = {"default": (None, None), "quick": (1, 4), "full": (20, 14)}[size]
    result = run_experiment(quick=size != "full", runs=runs, iterations=iterations, seed=seed,
                            progress=progress)
    med = result.median()
    lines = [
        "ltvmodels demo: model-based reinforcement learning on a cart-pole "
        f"(Bagge Carlson et al. 2018, Section VIII, Fig. 4), seed {seed}",
        f"median cost over {result.runs} Monte-Carlo runs of {result.iterations} learning "
        f"iterations ({result.elapsed:.1f} s):",
        result.table(),
        "final / optimum: " + ", ".join(f"{m} {med[m][-1] / result.optimum:.3f}"
                                        for m in result.models),
    ]
    fig = plot_experiment(result)
    _report(lines, stream, fig, path, fmt)
    return {"experiment": result, "figure": fig, "out": path}


def run_pendulum_demo(
    *,
    seed: int = 0,
    out: str | os.PathLike | None = DEFAULT_DEMO_OUT["pendulum"],
    size: str = "default",
    stream: TextIO | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Model-based reinforcement learning on gymnasium's Pendulum-v1 (needs gymnasium).

    Runs :func:`ltvmodels.gym_rl.run_pendulum_experiment` (LTV and LTI models
    learning to swing up the pendulum from ``env.reset`` rollouts), prints its
    table and writes :func:`ltvmodels.gym_rl.plot_pendulum_experiment`.

    Parameters
    ----------
    seed : int, default 0
        First ``env.reset`` seed; the runs use seeds ``seed``, ``seed + 1``, ...
    out : str or path-like or None, default ``"ltvmodels-pendulum.png"``
        Image file to write (format from the suffix); None writes no file.
    size : {"default", "quick", "full"}
        "default": 2 initial states, 20 iterations (seconds); "quick": 1 initial
        state, 20 iterations; "full": 20 initial states, 40 iterations (minutes).
    stream : text stream, optional
        Where the report goes (default ``sys.stdout``).
    progress : callable, optional
        Called with a line of text after each run.

    Returns
    -------
    dict
        ``experiment`` (:class:`~ltvmodels.gym_rl.PendulumExperiment`),
        ``figure`` and ``out`` (the Path written, or None).

    Raises
    ------
    OutputPathError
        If ``out`` cannot be written (checked before the work).
    ImportError
        Without gymnasium (install ``ltvmodels[rl]``).
    """
    from .gym_rl import make_env, plot_pendulum_experiment, run_pendulum_experiment

    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)
    seed = _nonnegative_seed(seed)
    if size not in ("default", "quick", "full"):
        raise ValueError(f"size: expected 'default', 'quick' or 'full', received {size!r}")
    make_env().close()  # gymnasium is there (else ImportError) before the work
    runs, iterations = {"default": (2, 20), "quick": (1, 20), "full": (20, 40)}[size]
    result = run_pendulum_experiment(seeds=range(seed, seed + runs), iterations=iterations,
                                     progress=progress)
    lines = [
        "ltvmodels demo: model-based reinforcement learning on gymnasium's Pendulum-v1 "
        f"(swing-up from env.reset/env.step rollouts), seeds {seed}-{seed + runs - 1} "
        f"({result.elapsed:.1f} s)",
        result.table(),
    ]
    fig = plot_pendulum_experiment(result)
    _report(lines, stream, fig, path, fmt)
    return {"experiment": result, "figure": fig, "out": path}


def _nonnegative_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0, received {seed!r}")
    return int(seed)


# -- data files ------------------------------------------------------------------------
class DataError(ValueError):
    """A data or model file cannot be read or used (the message is one line)."""


PARQUET_SUFFIXES = (".parquet", ".pq")


@dataclass
class _Source:
    """An opened data source: column names and a reader of selected columns."""

    label: str
    names: list[str]
    read: Callable[[list[int]], np.ndarray]


def _display(path: Any) -> str:
    return "standard input" if str(path) == "-" else str(path)


def _open_source(path: Any) -> _Source:
    """Open DATA (CSV, '-' for CSV on stdin, or Parquet) and read its column names."""
    label = _display(path)
    if str(path) != "-":
        p = Path(path)
        if not p.exists():
            raise DataError(f"{label}: no such file")
        if p.is_dir():
            raise DataError(f"{label}: is a directory, expected a data file")
        if p.suffix.lower() in PARQUET_SUFFIXES:
            return _open_parquet(p)
        try:
            with open(p, encoding="utf-8-sig", newline="") as fh:
                text = fh.read()
        except UnicodeDecodeError:
            raise DataError(f"{label}: not a UTF-8 text (CSV) file") from None
        except OSError as exc:
            raise DataError(f"{label}: cannot read: {exc.strerror or exc}") from None
    else:
        text = sys.stdin.read()
        if text.startswith("\ufeff"):
            text = text[1:]
    return _parse_csv(text, label)


def _open_parquet(path: Path) -> _Source:
    try:
        import pandas as pd
    except ImportError:
        raise DataError(f"{path}: reading Parquet needs pandas with pyarrow or fastparquet "
                        "(pip install pandas pyarrow), or convert the data to CSV") from None
    try:
        frame = pd.read_parquet(path)
    except ImportError:
        raise DataError(f"{path}: reading Parquet needs pyarrow or fastparquet (pip install "
                        "pyarrow), or convert the data to CSV") from None
    except Exception as exc:  # pyarrow raises its own error types on corrupt files
        raise DataError(f"{path}: cannot read as Parquet: {_one_line(exc)}") from None
    names = [str(c) for c in frame.columns]

    def read(indices: list[int]) -> np.ndarray:
        out = np.empty((len(frame), len(indices)))
        for j, i in enumerate(indices):
            column = frame.iloc[:, i]
            try:
                out[:, j] = column.to_numpy(dtype=float)
            except (TypeError, ValueError):
                raise DataError(f"{path}: column {names[i]!r} is not numeric "
                                f"(dtype {column.dtype})") from None
            bad = ~np.isfinite(out[:, j])
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                raise DataError(f"{path}: row {row}, column {names[i]!r}: value "
                                f"{out[row, j]!r} is missing or not finite (missing data are "
                                "not supported)")
        return out

    return _Source(str(path), names, read)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_csv(text: str, label: str) -> _Source:
    """Split CSV text into rows (lazily converted per column) and find the header."""
    lines = text.splitlines()
    numbered = [(i + 1, line) for i, line in enumerate(lines)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise DataError(f"{label}: empty file (no header and no data rows)")
    first = numbered[0][1]
    counts = {d: first.count(d) for d in (",", ";", "\t")}
    delimiter = max(counts, key=lambda d: counts[d]) if any(counts.values()) else ","
    reader = csv.reader([line for _, line in numbered], delimiter=delimiter)
    try:
        rows = [[field.strip() for field in row] for row in reader]
    except csv.Error as exc:
        raise DataError(f"{label}: not a valid CSV file: {exc}") from None
    header = rows[0]
    has_header = not all(_is_number(field) for field in header)
    if has_header:
        names = header
        data_rows, line_numbers = rows[1:], [n for n, _ in numbered[1:]]
    else:
        names = [str(i) for i in range(len(header))]
        data_rows, line_numbers = rows, [n for n, _ in numbered]
    if not data_rows:
        raise DataError(f"{label}: no data rows after the header")
    width = len(names)
    for row, line in zip(data_rows, line_numbers, strict=True):
        if len(row) != width:
            raise DataError(f"{label}, line {line}: expected {width} fields (as the "
                            f"{'header' if has_header else 'first row'}), received {len(row)}")

    def read(indices: list[int]) -> np.ndarray:
        out = np.empty((len(data_rows), len(indices)))
        for j, i in enumerate(indices):
            for r, row in enumerate(data_rows):
                field = row[i]
                try:
                    value = float(field)
                except ValueError:
                    what = ("empty value (missing data are not supported)" if field == ""
                            else f"{field!r} is not a number")
                    raise DataError(f"{label}, line {line_numbers[r]}, column {names[i]!r}: "
                                    f"{what}") from None
                if not math.isfinite(value):
                    raise DataError(f"{label}, line {line_numbers[r]}, column {names[i]!r}: "
                                    f"{field!r} is not finite (missing data are not "
                                    "supported)")
                out[r, j] = value
        return out

    return _Source(label, names, read)


def _resolve(source: _Source, spec: str, option: str) -> list[int]:
    """Column indices of a comma-separated list of names or 0-based indices."""
    tokens = [token.strip() for token in spec.split(",")]
    if not spec.strip() or any(token == "" for token in tokens):
        raise DataError(f"{option}: expected comma-separated column names or 0-based "
                        f"indices, received {spec!r}")
    indices = []
    for token in tokens:
        matches = [i for i, name in enumerate(source.names) if name == token]
        if len(matches) > 1:
            raise DataError(f"{option}: column name {token!r} appears {len(matches)} times in "
                            f"{source.label}; select it by index")
        if matches:
            indices.append(matches[0])
        elif token.isdigit() and int(token) < len(source.names):
            indices.append(int(token))
        else:
            shown = ", ".join(source.names[:20]) + (", ..." if len(source.names) > 20 else "")
            what = "index" if token.isdigit() else "column"
            raise DataError(f"{option}: no {what} {token!r} in {source.label} (columns: "
                            f"{shown})")
    if len(set(indices)) != len(indices):
        raise DataError(f"{option}: a column is selected twice in {spec!r}")
    return indices


def _read_columns(path: Any, **selections: str | None) -> tuple[int, str, dict[str, Any]]:
    """Read the selected numeric columns of DATA (see the module docstring).

    ``selections`` maps an option name (``state="x1,x2"``) to comma-separated
    column names or 0-based indices, or None. Returns (T, the file's label,
    {option: (names, values (T, k)) or None}). A column may be in one
    selection only; every user error is a :class:`DataError`.
    """
    source = _open_source(path)
    resolved: dict[str, list[int] | None] = {}
    seen: dict[int, str] = {}
    for key, spec in selections.items():
        if spec is None:
            resolved[key] = None
            continue
        option = "--" + key.replace("_", "-")
        indices = _resolve(source, spec, option)
        for i in indices:
            if i in seen:
                raise DataError(f"{option}: column {source.names[i]!r} is also selected by "
                                f"{seen[i]}")
            seen[i] = option
        resolved[key] = indices
    columns: dict[str, Any] = {}
    T = 0
    for key, indices in resolved.items():
        if indices is None:
            columns[key] = None
            continue
        values = source.read(indices)
        T = values.shape[0]
        columns[key] = ([source.names[i] for i in indices], values)
    return T, source.label, columns


def _write_csv(path: Path, names: list[str], columns: np.ndarray, option: str) -> None:
    """Write a header and rows of numbers (12 significant digits) as CSV."""
    try:
        with open(path, "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            writer.writerow(names)
            for row in columns:
                writer.writerow([f"{v:.12g}" for v in row])
    except OSError as exc:
        raise OutputPathError(f"{option}: cannot write {str(path)!r}: "
                              f"{exc.strerror or exc}") from exc


# -- progress, warnings, errors, JSON --------------------------------------------------
def _is_terminal(stream: Any) -> bool:
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # closed stream
        return False


class _Progress:
    """A one-line progress indicator on stderr, drawn only when stderr is a terminal.

    Without ``total`` a spinner with the elapsed time; with ``total`` a bar
    advanced by :meth:`advance`. Nothing is drawn during the first ``delay``
    seconds, so quick work shows nothing; the line is erased at the end.
    """

    WIDTH = 24
    SPIN = "|/-\\"

    def __init__(self, label: str, total: int | None = None, *, stream: Any = None,
                 delay: float = 0.5, interval: float = 0.1) -> None:
        self.label = label
        self.total = total
        self.done = 0
        self.stream = sys.stderr if stream is None else stream
        self.enabled = _is_terminal(self.stream)
        self.delay = delay
        self.interval = interval
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._start = 0.0
        self._drawn = 0

    def __enter__(self) -> _Progress:
        self._start = time.perf_counter()
        if self.enabled:
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            if self._drawn:
                self.stream.write("\r" + " " * self._drawn + "\r")
                self.stream.flush()

    def advance(self, step: int = 1) -> None:
        """Count ``step`` more units of work done."""
        self.done += step

    def line(self) -> str:
        """The text of the indicator now."""
        elapsed = time.perf_counter() - self._start
        if self.total:
            filled = int(self.WIDTH * min(self.done, self.total) / self.total)
            bar = "#" * filled + "." * (self.WIDTH - filled)
            return f"{self.label} [{bar}] {self.done}/{self.total} {elapsed:.0f} s"
        spin = self.SPIN[int(elapsed / self.interval) % len(self.SPIN)]
        return f"{self.label} {spin} {elapsed:.0f} s"

    def _run(self) -> None:
        if self._stop.wait(self.delay):
            return
        last = ""
        while True:
            text = self.line()
            if text != last:
                self.stream.write("\r" + text.ljust(self._drawn))
                self.stream.flush()
                self._drawn = max(self._drawn, len(text))
                last = text
            if self._stop.wait(self.interval):
                return


def _one_line(message: Any) -> str:
    return " ".join(str(message).split())


class _CommandError(Exception):
    """A user error found while running a command; its message is one line."""


# Library argument names → what the user typed on the command line.
_OPTION_NAMES = {
    "x": "--state data", "u": "--input data", "y": "--column data", "lam": "--lam",
    "order": "--order", "max_iter": "--max-iter", "tol": "--tol", "n_changes": "--n-changes",
    "penalty": "--penalty", "min_size": "--min-size", "na": "--na", "fs": "--fs",
    "method": "--method", "x0": "--state data", "y0": "--column data",
}


@contextlib.contextmanager
def _user_errors(context: str = "") -> Iterator[None]:
    """Turn the library's input errors into one-line command errors."""
    from .errors import SingularProblemError

    try:
        yield
    except (DataError, OutputPathError):
        raise
    except (ValueError, TypeError, NotImplementedError, SingularProblemError,
            np.linalg.LinAlgError) as exc:
        text = _one_line(exc)
        name, sep, rest = text.partition(":")
        if sep and name in _OPTION_NAMES:
            text = f"{_OPTION_NAMES[name]}:{rest}"
        raise _CommandError(f"{context}{text}") from None


@contextlib.contextmanager
def _collect_warnings() -> Iterator[list[str]]:
    """Record warnings as one-line texts (printed by :func:`main`, listed in --json)."""
    caught: list[str] = []
    with warnings.catch_warnings(record=True) as records:
        warnings.simplefilter("always")
        try:
            yield caught
        finally:
            for record in records:
                text = f"{record.category.__name__}: {_one_line(record.message)}"
                if text not in caught:
                    caught.append(text)


def _jsonable(value: Any) -> Any:
    """Plain JSON types: numpy → Python, NaN/inf → None, tuples → lists, paths → str."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (str, bool, int)):
        return value
    return str(value)


def _info_subset(info: dict) -> dict:
    """The solver facts of ``model.info`` worth reporting (no large arrays)."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        if key in ("first_step_k", "data_columns"):
            continue
        if isinstance(value, np.ndarray) and value.size > 100:
            continue
        if key == "lam_selection" and isinstance(value, dict):
            value = {k: value[k] for k in ("method", "lam") if k in value}
        out[key] = value
    return out


def _rms_columns(a: np.ndarray) -> list[float]:
    with np.errstate(over="ignore", invalid="ignore"):
        return [float(v) for v in np.sqrt(np.mean(np.square(a), axis=0))]


def _fmt(value: float) -> str:
    return f"{value:.4g}" if math.isfinite(value) else str(value)


# -- commands --------------------------------------------------------------------------
Report = tuple[dict[str, Any], list[str]]


def _outputs(args: argparse.Namespace, *, image: str = "plot", file: str | None = "out"
             ) -> tuple[Path | None, tuple[Path, str] | None]:
    """Check ``--out`` (any file) and ``--plot`` (an image) before any work."""
    out = getattr(args, file, None) if file else None
    plot = getattr(args, image, None)
    return (_check_file_path(out, file) if out is not None else None,
            _check_output_path(plot, image) if plot is not None else None)


def _state_space_data(args: argparse.Namespace) -> tuple[str, np.ndarray, np.ndarray | None,
                                                         list[str], list[str]]:
    """(label, x (T, n), u (T, m) or None, state names, input names) of DATA."""
    T, label, cols = _read_columns(args.data, state=args.state, input=args.input)
    state_names, x = cols["state"]
    input_names, u = cols["input"] if cols["input"] is not None else ([], None)
    return label, x, u, state_names, input_names


def _detected_changepoints(model: Any) -> tuple[np.ndarray, str]:
    """Change points of a model and how they were found."""
    from .changepoints import find_changepoints

    if model.norm in ("piecewise", "l0", "lti"):
        return np.asarray(model.changepoints, dtype=int), "segment boundaries of the model"
    with _user_errors("change points: "):
        found = find_changepoints(model)
    return found, "peaks of the activation ||(Dk)_t|| (ltvmodels.find_changepoints)"


def _lam_facts(model: Any, requested: Any) -> dict[str, Any]:
    """λ used (of the first step for a refined model) and how it was chosen."""
    from .selection import DEFAULT_METHOD

    first = model.info.get("first_step")
    lam = first["lam"] if isinstance(first, dict) and "lam" in first else model.lam
    facts: dict[str, Any] = {"lam": lam if np.ndim(lam) == 0 else np.asarray(lam)}
    if requested == "auto":
        selection = model.info.get("lam_selection") or {}
        norm = first["norm"] if isinstance(first, dict) else model.norm
        facts["lam_method"] = selection.get("method", DEFAULT_METHOD.get(norm))
    return facts


def _state_space_report(command: str, label: str, model: Any, x: np.ndarray,
                        u: np.ndarray | None, state_names: list[str],
                        input_names: list[str]) -> tuple[dict[str, Any], list[str], Any]:
    """The facts common to ``fit`` and ``segments``: RMS, change points, solver."""
    with _user_errors():
        prediction = model.predict(x, u)
        simulation = model.simulate(x[0], u)
    pred_rms = _rms_columns(prediction - x[1:])
    sim_rms = _rms_columns(simulation - x)
    changepoints, rule = _detected_changepoints(model)
    info = model.info
    report: dict[str, Any] = {
        "command": command, "data": label, "T": x.shape[0], "state": state_names,
        "input": input_names, "model": type(model).__name__, "N": model.N,
        "norm": model.norm, "order": None if model.coeffs is None else len(model.coeffs) - 1,
        "rms": {"prediction": _rms(prediction - x[1:]), "simulation": _rms(simulation - x),
                "prediction_per_state": pred_rms, "simulation_per_state": sim_rms},
        "changepoints": changepoints, "changepoint_rule": rule,
        "noise_var": model.noise_var, "loglik": model.loglik,
        "solver": info.get("solver"), "converged": info.get("converged"),
        "iterations": info.get("iterations"), "info": _info_subset(info),
    }
    per = ", ".join(f"{n} {_fmt(v)}" for n, v in zip(state_names, pred_rms, strict=True))
    per_sim = ", ".join(f"{n} {_fmt(v)}" for n, v in zip(state_names, sim_rms, strict=True))
    status = ""
    if info.get("converged") is not None:
        status = ", converged" if info["converged"] else ", NOT converged (see the warnings)"
    if info.get("iterations") is not None:
        status += f", {info['iterations']} iterations"
    lines = [
        f"ltvmodels {command}: {label}, T = {x.shape[0]} samples; states "
        f"{', '.join(state_names)}; inputs {', '.join(input_names) or '(none)'}",
        model.summary(),
        f"solver: {info.get('solver', '?')}{status}",
        f"one-step prediction RMS: {_fmt(report['rms']['prediction'])} ({per})",
        f"open-loop simulation RMS: {_fmt(report['rms']['simulation'])} ({per_sim}; from "
        "the first state with the recorded inputs)",
        f"change points: {[int(c) for c in changepoints]} ({rule})",
    ]
    return report, lines, changepoints


def _save_model(model: Any, path: Path | None, report: dict, lines: list[str]) -> None:
    if path is None:
        return
    try:
        model.save(path)
    except OSError as exc:
        raise OutputPathError(f"out: cannot write {str(path)!r}: {exc.strerror or exc}") from exc
    report.setdefault("files", {})["model"] = str(path)
    lines.append(f"wrote {path}")


def _save_plot(fig: Any, target: tuple[Path, str] | None, report: dict,
               lines: list[str]) -> None:
    if target is None:
        return
    _save_figure(fig, target[0], target[1], option="plot")
    report.setdefault("files", {})["plot"] = str(target[0])
    lines.append(f"wrote {target[0]}")


def _cmd_fit(args: argparse.Namespace) -> Report:
    from .fit import fit
    from .plotting import plot_model

    out, plot = _outputs(args)
    label, x, u, state_names, input_names = _state_space_data(args)
    what = "choosing lambda and fitting" if args.lam == "auto" else "fitting"
    with _Progress(f"ltvmodels fit: {what}"), _user_errors():
        model = fit(x, u, lam=args.lam, norm=args.norm, order=args.order, refine=args.refine,
                    max_iter=args.max_iter, tol=args.tol)
    model.info["data_columns"] = {"state": state_names, "input": input_names}
    report, lines, changepoints = _state_space_report("fit", label, model, x, u, state_names,
                                                      input_names)
    facts = _lam_facts(model, args.lam)
    report.update(facts, norm=args.norm, order=args.order, refine=args.refine)
    how = (f"chosen by lam=auto, criterion {facts['lam_method']!r}" if args.lam == "auto"
           else "given")
    lines.insert(1, f"fit: norm={args.norm!r}, order={args.order}, lambda = "
                    f"{_fmt(float(facts['lam']))} ({how})"
                 + (", then the two-step refinement" if args.refine else ""))
    _save_model(model, out, report, lines)
    if plot is not None:
        fig = plot_model(model, changepoints=changepoints)
        fig.suptitle(f"{label}: norm={args.norm!r}, order={args.order}, "
                     f"λ = {float(facts['lam']):.4g}" + (", refined" if args.refine else ""))
        _save_plot(fig, plot, report, lines)
    return report, lines


def _cmd_segments(args: argparse.Namespace) -> Report:
    from .plotting import plot_model
    from .segments import fit_segments

    out, plot = _outputs(args)
    label, x, u, state_names, input_names = _state_space_data(args)
    how = (f"exactly optimal with at most {args.n_changes} changes (dynamic programming)"
           if args.n_changes is not None else
           f"penalty {args.penalty or 'bic'} per change (PELT)")
    with _Progress("ltvmodels segments: searching change points"), _user_errors():
        model = fit_segments(x, u, n_changes=args.n_changes, penalty=args.penalty,
                             min_size=args.min_size)
    model.info["data_columns"] = {"state": state_names, "input": input_names}
    report, lines, changepoints = _state_space_report("segments", label, model, x, u,
                                                      state_names, input_names)
    info = model.info
    report.update({k: info.get(k) for k in ("cost", "objective", "n_changes", "penalty",
                                            "penalty_rule", "min_size")})
    lines.insert(1, f"segments: {how}; min_size {info.get('min_size')}")
    lines.append(f"residual sum of squares {_fmt(info['cost'])}, objective "
                 f"{_fmt(info['objective'])}, {info['n_changes']} changes"
                 + (f", penalty {_fmt(info['penalty'])} per change"
                    if info.get("penalty") is not None else ""))
    _save_model(model, out, report, lines)
    if plot is not None:
        fig = plot_model(model, changepoints=changepoints)
        fig.suptitle(f"{label}: piecewise-constant model, {info['n_changes']} changes at "
                     f"{[int(c) for c in changepoints]}")
        _save_plot(fig, plot, report, lines)
    return report, lines


def _cmd_ar(args: argparse.Namespace) -> Report:
    from . import plotting
    from .ar import fit_ar

    out, plot = _outputs(args)
    T, label, cols = _read_columns(args.data, column=args.column)
    names, y = cols["column"]
    what = "choosing lambda and fitting" if args.lam == "auto" else "fitting"
    with _Progress(f"ltvmodels ar: {what}"), _user_errors():
        model = fit_ar(y[:, 0] if y.shape[1] == 1 else y, args.na, lam=args.lam,
                       norm=args.norm, order=args.order, constant=args.constant,
                       max_iter=args.max_iter, tol=args.tol)
        prediction = model.predict(y[:, 0] if y.shape[1] == 1 else y)
        freq = model.root_spectrogram(args.fs)
    model.info["data_columns"] = {"output": names}
    prediction = prediction.reshape(model.N, -1)
    err = prediction - y[model.lag:]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN tracks (real poles)
        tracks = np.nanmedian(freq, axis=0) if freq.size else np.zeros(0)
    facts = _lam_facts(model, args.lam)
    report: dict[str, Any] = {
        "command": "ar", "data": label, "T": T, "column": names, "model": type(model).__name__,
        "N": model.N, "na": args.na, "fs": args.fs, "norm": args.norm, "order": args.order,
        **facts, "rms": {"prediction": _rms(err), "prediction_per_output": _rms_columns(err)},
        "median_pole_frequencies": tracks, "noise_var": model.noise_var,
        "loglik": model.loglik, "solver": model.info.get("solver"),
        "converged": model.info.get("converged"), "info": _info_subset(model.info),
    }
    how = (f"chosen by lam=auto, criterion {facts['lam_method']!r}" if args.lam == "auto"
           else "given")
    lines = [
        f"ltvmodels ar: {label}, T = {T} samples of {', '.join(names)}, fs = {args.fs:g}",
        f"fit: AR({args.na}), norm={args.norm!r}, order={args.order}, lambda = "
        f"{_fmt(float(facts['lam']))} ({how})",
        model.summary(),
        f"one-step prediction RMS: {_fmt(report['rms']['prediction'])} (samples {model.lag} "
        f"to {T - 1})",
        "root spectrogram: median frequency of each pole-pair track: "
        + (", ".join(_fmt(float(f)) for f in tracks) if tracks.size else "(no complex poles)"),
    ]
    _save_model(model, out, report, lines)
    if plot is not None:
        ax = None
        if y.shape[1] == 1 and T >= 8:
            ax = plotting.plot_spectrogram(y[:, 0], args.fs)
        ax = plotting.plot_root_spectrogram(model, args.fs, ax=ax)
        ax.set_title(f"{label}: root spectrogram of AR({args.na}), norm={args.norm!r}, "
                     f"order {args.order}, λ = {float(facts['lam']):.4g}")
        ax.legend(loc="upper right", fontsize="small", markerscale=6)
        _save_plot(ax.figure, plot, report, lines)
    return report, lines


def _cmd_select_lambda(args: argparse.Namespace) -> Report:
    from .ar import ar_regressors
    from .plotting import plot_lambda_selection
    from .selection import select_lambda, select_lambda_regression

    _, plot = _outputs(args, file=None)
    if args.column is not None:
        if args.state is not None or args.input is not None:
            raise _CommandError("--column: an AR model takes no --state or --input")
        if args.na is None:
            raise _CommandError("--na: the AR order is required with --column")
        T, label, cols = _read_columns(args.data, column=args.column)
        names, y = cols["column"]
        with _user_errors():
            y_out, phi = ar_regressors(y[:, 0] if y.shape[1] == 1 else y, args.na)
        data_facts = {"column": names, "na": args.na}
        what = f"AR({args.na}) of {', '.join(names)}"
    else:
        if args.state is None:
            raise _CommandError("--state: expected the state columns (or --column and --na "
                                "for an AR model)")
        if args.na is not None:
            raise _CommandError("--na: applies with --column (an AR model) only")
        label, x, u, state_names, input_names = _state_space_data(args)
        T = x.shape[0]
        data_facts = {"state": state_names, "input": input_names}
        what = (f"states {', '.join(state_names)}; inputs "
                f"{', '.join(input_names) or '(none)'}")
    with _Progress("ltvmodels select-lambda: evaluating the candidates") as bar, \
            _user_errors():

        def progress(done: int, total: int) -> None:
            bar.total, bar.done = total, done

        if args.column is not None:
            selection = select_lambda_regression(y_out, phi, norm=args.norm, order=args.order,
                                                 method=args.method, progress=progress)
        elif args.norm == "l0":  # one dynamic program: no steps to count
            selection = select_lambda(x, u, norm=args.norm, method=args.method)
        else:
            selection = select_lambda(x, u, norm=args.norm, order=args.order,
                                      method=args.method, progress=progress)
    is_l0 = selection.norm == "l0"
    report: dict[str, Any] = {
        "command": "select-lambda", "data": label, "T": T, **data_facts,
        "norm": selection.norm, "order": None if is_l0 else args.order,
        "method": selection.method,
        ("n_changes" if is_l0 else "lam"): int(selection.lam) if is_l0 else selection.lam,
        "candidates": selection.lams.astype(int) if is_l0 else selection.lams,
        "scores": selection.scores,
        "maximize": selection.maximize,
    }
    best = "maximum" if selection.maximize else "minimum"
    chosen = (f"number of changes {int(selection.lam)}" if is_l0
              else f"lambda = {_fmt(selection.lam)}")
    lines = [
        f"ltvmodels select-lambda: {label}, T = {T} samples; {what}",
        f"norm={selection.norm!r}" + ("" if is_l0 else f", order={args.order}")
        + f", criterion {selection.method!r} ({best} over {len(selection.lams)} candidates"
        + ("" if is_l0 or selection.method in ("lcurve", "cv") else ", then refined") + ")",
        f"chosen: {chosen}",
        "",
        f"{'number of changes' if is_l0 else 'lambda':>18}  {selection.method}",
    ]
    nearest = int(np.argmin(np.abs(selection.lams - selection.lam)))
    for i, (lam, score) in enumerate(zip(selection.lams, selection.scores, strict=True)):
        lines.append(f"{_fmt(float(lam)):>18}  {_fmt(float(score))}"
                     + ("   <- chosen" if i == nearest and (is_l0 or selection.method in
                                                              ("lcurve", "cv")) else ""))
    if plot is not None:
        _save_plot(plot_lambda_selection(selection).figure, plot, report, lines)
    return report, lines


def _load_model(path: str) -> Any:
    from .models import load

    p = Path(path)
    if not p.exists():
        raise DataError(f"{path}: no such file")
    if p.is_dir():
        raise DataError(f"{path}: is a directory, expected a model file (.npz)")
    import zipfile

    if not zipfile.is_zipfile(p):
        raise DataError(f"{path}: not an ltvmodels model file (expected an .npz archive written "
                        "by 'ltvmodels fit --out' or model.save)")
    try:
        return load(p)
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except Exception as exc:  # a damaged archive, or not one of ours
        text = _one_line(exc)
        if text.startswith("path: "):  # ltvmodels.load's own messages
            text = text[len("path: "):]
            text = text[len(str(p)) + 1:] if text.startswith(f"{p} ") else text
            text = text.removeprefix("is ")
            raise DataError(f"{path}: {text}") from None
        raise DataError(f"{path}: not an ltvmodels model file ({type(exc).__name__}: "
                        f"{text})") from None


def _model_data(args: argparse.Namespace, model: Any) -> dict[str, Any]:
    """Read the columns a loaded model needs from DATA and check their sizes."""
    from .ar import ARModel, ARXModel
    from .models import LTVModel

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
        raise DataError(f"{args.model}: a {type(model).__name__} has no dynamics to "
                        f"{args.command} (expected a model from fit, segments or ar)")
    state = args.state if args.state is not None else _spec(recorded.get(out_key))
    inputs = args.input if args.input is not None else _spec(recorded.get("input"))
    if state is None:
        raise DataError(f"--state: {args.model} does not record its data columns; give "
                        f"--state (and --input) to choose them in the data")
    if m and inputs is None:
        raise DataError(f"--input: the model has {m} inputs; give --input to choose their "
                        "columns in the data")
    if not m and args.input is not None:
        raise DataError(f"--input: the model has no inputs, received {args.input!r}")
    T, label, cols = _read_columns(args.data, state=state, input=inputs if m else None)
    names, y = cols["state"]
    if y.shape[1] != n:
        what = "states" if kind == "ltv" else "outputs"
        raise DataError(f"--state: the model has {n} {what}, received {y.shape[1]} columns "
                        f"({', '.join(names)})")
    u = None
    input_names: list[str] = []
    if m:
        input_names, u = cols["input"]
        if u.shape[1] != m:
            raise DataError(f"--input: the model has {m} inputs, received {u.shape[1]} "
                            f"columns ({', '.join(input_names)})")
    expected = model.N + lag
    if T != expected:
        steps = (f"N = {model.N} transitions" if kind == "ltv"
                 else f"N = {model.N} time steps after {lag} initial samples")
        raise DataError(f"{label}: expected T = {expected} rows (the model has {steps}), "
                        f"received {T}")
    return {"kind": kind, "label": label, "T": T, "y": y, "u": u, "names": names,
            "input_names": input_names, "lag": lag}


def _spec(names: Any) -> str | None:
    if not names:
        return None
    return ",".join(str(name) for name in names)


def _cmd_simulate_or_predict(args: argparse.Namespace) -> Report:
    from .plotting import plot_simulation

    out, plot = _outputs(args)
    model = _load_model(args.model)
    data = _model_data(args, model)
    kind, y, u, lag = data["kind"], data["y"], data["u"], data["lag"]
    simulate = args.command == "simulate"
    with _user_errors():
        if kind == "ltv":
            result = model.simulate(y[0], u) if simulate else model.predict(y, u)
        else:
            series = y[:, 0] if y.shape[1] == 1 else y
            extra = () if kind == "ar" else (u,)
            result = (model.simulate(series[:lag], *extra) if simulate
                      else model.predict(series, *extra))
    result = np.asarray(result, dtype=float).reshape(-1, y.shape[1])
    start = 0 if simulate and kind == "ltv" else (1 if kind == "ltv" else lag)
    if simulate and kind != "ltv":  # y[0:lag] are the given initial samples
        result, start = result[lag:], lag
    err = result - y[start:start + result.shape[0]]
    noun = "open-loop simulation" if simulate else "one-step prediction"
    rms = _rms(err)
    per = _rms_columns(err)
    report: dict[str, Any] = {
        "command": args.command, "model_file": str(args.model), "model": type(model).__name__,
        "data": data["label"], "T": data["T"], "columns": data["names"],
        "input": data["input_names"], "start": start, "rows": result.shape[0],
        "rms": rms, "rms_per_column": per,
    }
    with np.errstate(over="ignore", invalid="ignore"):
        diverged = not np.all(np.isfinite(result))
    lines = [
        f"ltvmodels {args.command}: {args.model} on {data['label']} (T = {data['T']} samples; "
        f"columns {', '.join(data['names'])}; inputs {', '.join(data['input_names']) or '(none)'})",
        repr(model),
        f"{noun} of samples {start} to {start + result.shape[0] - 1}"
        + ((" from the recorded initial " + ("state" if kind == "ltv" else "samples")
            + (" with the recorded inputs" if u is not None else "")) if simulate
           else " from the recorded data"),
        f"RMS error: {_fmt(rms)} ("
        + ", ".join(f"{n} {_fmt(v)}" for n, v in zip(data["names"], per, strict=True)) + ")"
        + ("; the simulation diverges (non-finite values)" if diverged else ""),
    ]
    if out is not None:
        table = np.column_stack([np.arange(start, start + result.shape[0]), result])
        _write_csv(out, ["t", *data["names"]], table, "out")
        report.setdefault("files", {})["out"] = str(out)
        lines.append(f"wrote {out}")
    if plot is not None:
        fig = plot_simulation(y, result, start=start, names=data["names"], label=noun)
        fig.suptitle(f"{args.model} on {data['label']}: {noun}")
        _save_plot(fig, plot, report, lines)
    return report, lines


def _cmd_demo(args: argparse.Namespace) -> Report:
    system = args.system
    if system != "jump-linear":
        for option, value in (("--norm", args.norm), ("--lam", args.lam)):
            if value is not None:
                raise _CommandError(f"{option}: applies to the jump-linear demo only")
    if args.quick and system not in ("chirp", "rl", "pendulum"):
        raise _CommandError("--quick: applies to the chirp, rl and pendulum demos only")
    if args.full and system not in ("rl", "pendulum"):
        raise _CommandError("--full: applies to the rl and pendulum demos only")
    if args.quick and args.full:
        raise _CommandError("--quick, --full: expected one of them, received both")
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
            with _Progress("ltvmodels demo pendulum: runs", total=runs) as bar:
                run_pendulum_demo(seed=args.seed, out=out, size=size,
                                  progress=lambda _line: bar.advance())
        except ImportError as exc:
            raise _CommandError(f"demo pendulum: {exc}") from None
    else:
        from .rl import QUICK_RUNS

        size = "full" if args.full else ("quick" if args.quick else "default")
        runs = {"default": QUICK_RUNS, "quick": 1, "full": 20}[size]
        with _Progress("ltvmodels demo rl: Monte-Carlo runs", total=runs) as bar:
            run_rl_demo(seed=args.seed, out=out, size=size,
                        progress=lambda _line: bar.advance())
    return {}, []


# -- command line --------------------------------------------------------------------
def _int_at_least(minimum: int):
    """An argparse type: an integer >= ``minimum``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected an integer >= {minimum}, received {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(
                f"expected an integer >= {minimum}, received {value}")
        return value
    return parse


_nonnegative_int = _int_at_least(0)
_positive_int = _int_at_least(1)


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, received {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, received {text!r}")
    return value


def _lam_or_auto(text: str) -> float | str:
    if text.strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0 or 'auto', received "
                                         f"{text!r}") from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0 or 'auto', received "
                                         f"{text!r}")
    return value


def _penalty(text: str) -> float | str:
    if text.strip().lower() in ("bic", "aic"):
        return text.strip().lower()
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, 'bic' or 'aic', received "
                                         f"{text!r}") from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, 'bic' or 'aic', "
                                         f"received {text!r}")
    return value


_DATA_HELP = ("CSV file (header row optional; comma, semicolon or tab separated), '-' for CSV "
              "on standard input, or Parquet (.parquet, .pq; needs pandas and pyarrow)")
_COLS_HELP = "comma-separated column names or 0-based indices"


def _add_state_options(p: argparse.ArgumentParser, *, required: bool = True) -> None:
    p.add_argument("--state", required=required, metavar="COLS",
                   help=f"state columns x ({_COLS_HELP})")
    p.add_argument("--input", metavar="COLS", default=None,
                   help=f"input columns u ({_COLS_HELP}); none for an autonomous system")


def _add_sparse_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--max-iter", type=_positive_int, default=10000, metavar="N",
                   help="iteration limit of the group/l1 solvers (default: 10000)")
    p.add_argument("--tol", type=_positive_float, default=1e-6,
                   help="relative tolerance of the group/l1 solvers (default: 1e-6)")


def _add_outputs(p: argparse.ArgumentParser, *, out: str | None, plot: str) -> None:
    if out is not None:
        p.add_argument("--out", metavar="PATH", default=None, help=out)
    p.add_argument("--plot", metavar="PATH", default=None,
                   help=f"{plot} (image; format from the suffix, png without one)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object instead of the text summary")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``ltvmodels`` command.

    Returns
    -------
    argparse.ArgumentParser
        Its ``error`` raises instead of exiting (see :func:`main`).
    """
    from . import __version__

    parser = _Parser(
        prog="ltvmodels",
        description="Identification of linear time-varying (LTV) models "
        "x[t+1] = A_t x[t] + B_t u[t] + v_t by convex optimization.",
    )
    parser.add_argument("--version", action="version", version=f"ltvmodels {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    fit = commands.add_parser(
        "fit", help="identify an LTV model from states and inputs in a data file",
        description="Identify x[t+1] = A_t x[t] + B_t u[t] + v_t from a data file: print "
        "the lambda used, one-step prediction and open-loop simulation RMS, change points "
        "and solver status; optionally save the model and a figure.",
    )
    fit.add_argument("data", metavar="DATA", help=_DATA_HELP)
    _add_state_options(fit)
    fit.add_argument("--norm", choices=["sq", "group", "l1"], default="sq",
                     help="sq: slowly varying or smooth (default); group: piecewise constant "
                     "(order 1) or linear (order 2); l1: sparse changes per coefficient")
    fit.add_argument("--order", type=_positive_int, default=1,
                     help="order of the time difference penalized (default: 1)")
    fit.add_argument("--lam", type=_lam_or_auto, default="auto", metavar="{VALUE,auto}",
                     help="regularization lambda, or auto: chosen by the norm's default "
                     "criterion (marginal likelihood for sq, L-curve for group/l1; default)")
    fit.add_argument("--refine", action="store_true",
                     help="two-step refinement: refit piecewise between the detected change "
                     "points")
    _add_sparse_options(fit)
    _add_outputs(fit, out="model file to write (.npz; read it with ltvmodels.load or "
                 "'ltvmodels simulate')",
                 plot="figure: coefficients with ±2σ bands, activation with change points, "
                 "eigenvalue magnitudes")

    seg = commands.add_parser(
        "segments", help="piecewise-constant model with exactly optimal change points",
        description="Fit a piecewise-constant LTV model whose change points are globally "
        "optimal: at most M changes (dynamic programming) or a penalty per change (PELT).",
    )
    seg.add_argument("data", metavar="DATA", help=_DATA_HELP)
    _add_state_options(seg)
    group = seg.add_mutually_exclusive_group()
    group.add_argument("--n-changes", type=_nonnegative_int, default=None, metavar="M",
                       help="at most M changes")
    group.add_argument("--penalty", type=_penalty, default=None, metavar="{B,bic,aic}",
                       help="cost B >= 0 per change (in units of the residual sum of "
                       "squares), or the rule bic or aic (default: bic)")
    seg.add_argument("--min-size", type=_positive_int, default=None, metavar="S",
                     help="minimum segment length (default: n + m)")
    _add_outputs(seg, out="model file to write (.npz)",
                 plot="figure: coefficients, activation with change points, eigenvalues")

    ar = commands.add_parser(
        "ar", help="time-varying AR model of one column and its root spectrogram",
        description="Fit a time-varying AR(na) model y[t] = sum_i a_{t,i} y[t-i] + e[t] to "
        "a column and report its root spectrogram (pole frequencies over time).",
    )
    ar.add_argument("data", metavar="DATA", help=_DATA_HELP)
    ar.add_argument("--column", required=True, metavar="COL",
                    help="the signal's column (name or 0-based index; several for a "
                    "vector AR model)")
    ar.add_argument("--na", type=_positive_int, required=True, help="AR order")
    ar.add_argument("--fs", type=_positive_float, default=1.0, metavar="HZ",
                    help="sampling frequency (default: 1, frequencies in cycles per sample)")
    ar.add_argument("--norm", choices=["sq", "group", "l1"], default="sq",
                    help="penalty on the coefficient changes (default: sq)")
    ar.add_argument("--order", type=_positive_int, default=1,
                    help="order of the time difference penalized (default: 1)")
    ar.add_argument("--lam", type=_lam_or_auto, default="auto", metavar="{VALUE,auto}",
                    help="regularization lambda or auto (default: auto)")
    ar.add_argument("--constant", action="store_true", help="include a time-varying offset")
    _add_sparse_options(ar)
    _add_outputs(ar, out="model file to write (.npz)",
                 plot="figure: root spectrogram over the short-time Fourier spectrogram")

    sel = commands.add_parser(
        "select-lambda", help="choose lambda by a criterion and show its curve",
        description="Evaluate a criterion on a grid of lambda values (or numbers of changes "
        "for --norm l0) and report the choice; for state-space data (--state) or an AR "
        "model of a column (--column, --na).",
    )
    sel.add_argument("data", metavar="DATA", help=_DATA_HELP)
    sel.add_argument("--state", metavar="COLS", default=None,
                     help=f"state columns x ({_COLS_HELP})")
    sel.add_argument("--input", metavar="COLS", default=None, help="input columns u")
    sel.add_argument("--column", metavar="COL", default=None,
                     help="instead of --state: the column of an AR model (with --na)")
    sel.add_argument("--na", type=_positive_int, default=None, help="AR order (with --column)")
    sel.add_argument("--norm", choices=["sq", "group", "l1", "l0"], default="sq",
                     help="penalty (default: sq); l0 chooses the number of changes of "
                     "'ltvmodels segments'")
    sel.add_argument("--order", type=_positive_int, default=1,
                     help="order of the time difference penalized (default: 1)")
    sel.add_argument("--method", default=None,
                     help="criterion: sq: ml (default), gcv, lcurve, cv; group/l1: lcurve "
                     "(default), cv; l0: bic (default), aic")
    _add_outputs(sel, out=None, plot="figure of the criterion (or L-curve) with the choice")

    for name, noun in (("simulate", "open-loop simulation"),
                       ("predict", "one-step predictions")):
        sub = commands.add_parser(
            name, help=f"{noun} of a saved model on a data file",
            description=f"Load a model file (from fit, segments or ar) and compute its {noun} "
            "on a data file: "
            + ("from the first state (AR: the first na samples) with the data's inputs."
               if name == "simulate" else "of every sample from the measured data before it.")
            + " Data columns default to those the model was fitted on.",
        )
        sub.add_argument("model", metavar="MODEL", help="model file (.npz)")
        sub.add_argument("data", metavar="DATA", help=_DATA_HELP)
        sub.add_argument("--state", "--column", dest="state", metavar="COLS", default=None,
                         help="state columns (AR: output columns); default: those recorded "
                         "in the model file")
        sub.add_argument("--input", metavar="COLS", default=None,
                         help="input columns; default: those recorded in the model file")
        _add_outputs(sub, out=f"CSV file to write: t and the {noun}",
                     plot=f"figure: {noun} against the data")

    demo = commands.add_parser(
        "demo", help="run an example of the paper on built-in data, report and plot",
        description="Run an example on built-in data in seconds, print a report and write "
        "figures. jump-linear: the jump-linear system of the paper (Section VI, Fig. 1); "
        "robot: a two-link arm with friction and contact (Figs. 2-3); chirp: root "
        "spectrogram of a chirp by AR models; rl: model-based reinforcement learning on a "
        "cart-pole (Section VIII, Fig. 4); pendulum: the same with LTV and LTI models on "
        "gymnasium's Pendulum-v1 (needs gymnasium: pip install 'ltvmodels[rl]').",
    )
    demo.add_argument("system", choices=list(DEFAULT_DEMO_OUT),
                      help="jump-linear, robot, chirp, rl or pendulum")
    demo.add_argument("--seed", type=_nonnegative_int, default=0,
                      help="seed of the simulation (default: 0)")
    demo.add_argument("--norm", choices=["group", "sq"], default=None,
                      help="jump-linear only. group: piecewise-constant fit with two-step "
                      "refinement, the paper's Fig. 1 (default); sq: slowly varying fit")
    demo.add_argument("--lam", type=_positive_float, default=None,
                      help="jump-linear only: regularization lambda (default: "
                      f"0.1·lambda_max for group, {JUMP_LINEAR_LAM:g} for sq)")
    demo.add_argument("--out", default=None, metavar="PATH",
                      help="image file to write (default: ltvmodels-<system>.png; format from "
                      "the suffix); robot writes <stem>_train and <stem>_validation")
    demo.add_argument("--quick", action="store_true",
                      help="chirp, rl and pendulum only: a smaller problem (chirp: 2^12 "
                      "samples; rl: 1 run of 4 iterations; pendulum: 1 initial state)")
    demo.add_argument("--full", action="store_true",
                      help="rl: the paper's 20 runs of 14 iterations (default: 3 runs of 8); "
                      "pendulum: 20 initial states of 40 iterations (default: 2 of 20)")
    return parser


_COMMANDS: dict[str, Callable[[argparse.Namespace], Report]] = {
    "fit": _cmd_fit,
    "segments": _cmd_segments,
    "ar": _cmd_ar,
    "select-lambda": _cmd_select_lambda,
    "simulate": _cmd_simulate_or_predict,
    "predict": _cmd_simulate_or_predict,
    "demo": _cmd_demo,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``ltvmodels`` command; returns the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on a user error (one line on stderr), 130 when
        interrupted.
    """
    parser = build_parser()
    try:
        args, extras = parser.parse_known_args(None if argv is None else list(argv))
        if extras:  # reported by the subcommand, whose options the user is typing
            prog = f"{parser.prog} {args.command}"
            raise _UsageError(f"{prog}: error: unrecognized arguments: {' '.join(extras)} "
                              f"(see '{prog} --help')")
    except _UsageError as exc:
        print(exc, file=sys.stderr)
        return 2
    except SystemExit as exc:  # --help / --version
        return exc.code if isinstance(exc.code, int) else 0

    # Headless: the figures are plain matplotlib Figures (no pyplot), but select
    # the non-interactive Agg backend anyway unless pyplot is already in use
    # (switching then would close the caller's figures).
    import matplotlib

    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")

    prog = f"ltvmodels {args.command}"
    try:
        with _collect_warnings() as caught:
            report, lines = _COMMANDS[args.command](args)
    except OutputPathError as exc:
        print(f"{prog}: error: --{_one_line(exc)}", file=sys.stderr)
        return 2
    except (DataError, _CommandError) as exc:
        print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    for text in caught:
        print(f"{prog}: warning: {text}", file=sys.stderr)
    try:
        if getattr(args, "json", False):
            report["warnings"] = caught
            print(json.dumps(_jsonable(report), indent=2, allow_nan=False))
        elif lines:
            print("\n".join(lines))
        sys.stdout.flush()
    except BrokenPipeError:  # e.g. piped into `head`: stop quietly
        with contextlib.suppress(OSError, ValueError, AttributeError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
    return 0
