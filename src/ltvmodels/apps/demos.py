"""The demos of ``ltvmodels demo``: the paper's examples on built-in data, reported and plotted.

Each ``run_*_demo`` function runs one example in seconds, prints a report to a
stream, writes its figure(s) and returns what it computed: the jump-linear
system (paper Section VI, Fig. 1), the robot arm (Figs. 2–3), the root
spectrogram of a chirp, model-based reinforcement learning on a cart-pole
(Section VIII, Fig. 4) and on gymnasium's Pendulum-v1. The command line
(:mod:`ltvmodels.cli`) and the scripts in ``examples/`` call them.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from .. import plotting, systems
from ..estimators.ar import fit_ar
from ..estimators.changepoints import find_changepoints
from ..estimators.fit import fit, fit_lti, lambda_max
from ..plotting.figure import image_file, new_figure, save_figure
from . import gym_rl, rl, robot
from .defaults import DEFAULT_DEMO_OUT, JUMP_LINEAR_LAM

__all__ = [
    "run_jump_linear_demo",
    "run_robot_demo",
    "run_chirp_demo",
    "run_rl_demo",
    "run_pendulum_demo",
    "JUMP_LINEAR_LAM",
    "DEFAULT_DEMO_OUT",
]


def _rms(a: np.ndarray) -> float:
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.sqrt(np.mean(np.square(a))))


def _optional_output_path(out: Any) -> tuple[Path | None, str | None]:
    """:func:`~ltvmodels.plotting.figure.image_file` of ``out``, or (None, None) without one."""
    return image_file(out) if out is not None else (None, None)


def _report(
    lines: list[str], stream: TextIO, fig: Any, path: Path | None, fmt: str | None, dpi: int = 150
) -> None:
    """Write ``fig`` to ``path`` (if any), then print the demo's report."""
    if path is not None and fmt is not None:  # both or neither (_optional_output_path)
        save_figure(fig, path, fmt, dpi=dpi)
        lines.append(f"wrote {path}")
    print("\n".join(lines), file=stream)


def run_jump_linear_demo(
    *,
    seed: int = 0,
    norm: str = "group",
    lam: float | None = None,
    out: str | os.PathLike | None = DEFAULT_DEMO_OUT["jump-linear"],
    stream: TextIO | None = None,
) -> dict[str, Any]:
    """Simulate the paper's jump-linear system, fit it, report and plot.

    Simulates :func:`ltvmodels.systems.jump_linear` (T = 400, switch at
    t = 200, process and measurement noise σ = 0.2) and fits it. With
    ``norm="group"`` (the paper's Fig. 1) this is the group-lasso fit
    (the paper's piecewise constant problem, order 1) followed by the two-step refinement
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
        smallest λ giving the LTI model (:func:`ltvmodels.lambda_max`); for
        "sq" :data:`~ltvmodels.apps.defaults.JUMP_LINEAR_LAM` (30).
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
    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)

    data = systems.jump_linear(seed=seed)
    if norm == "group":
        if lam is None:
            lam = 0.1 * lambda_max(data.x, data.u, norm="group")
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
    jumps = data.changepoints  # the system's one switch
    c = int(jumps[0]) if jumps is not None and jumps.size else data.N
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
        lines.append(
            f"A_t at t = {t}: estimate {np.round(model.A[t], 3).tolist()}, "
            f"true {np.round(data.A[t], 3).tolist()}"
        )
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
        title = (
            f"Jump-linear system (paper Fig. 1): group lasso, λ = {lam:.3g}, refined\n"
            "±2σ band, first step orange, truth dashed"
        )
    else:
        title = f"Jump-linear system: norm='sq', order=1, λ = {lam:g}\n±2σ band, truth dashed"
    fig.suptitle(title, fontsize="medium")
    result["figure"] = fig
    result["out"] = path
    _report(lines, stream, fig, path, fmt)
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

    Runs :func:`ltvmodels.apps.robot.robot_experiment` (a two-link arm with Coulomb
    friction moving into a stiff wall; a piecewise-constant LTV model, group
    lasso of order 1, fitted to one run and simulated open loop on it and on a
    validation run with other torque noise) and writes the figures of
    :func:`ltvmodels.apps.robot.plot_robot_experiment`.

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
        ``experiment`` (:class:`~ltvmodels.apps.robot.RobotExperiment`),
        ``changepoints``, ``rms_train``, ``rms_validation``, ``figures``
        (train, validation) and ``out`` (the two Paths written, or None).

    Raises
    ------
    OutputPathError
        If the figures cannot be written (checked before the work).
    """
    stream = sys.stdout if stream is None else stream
    targets = None
    if out is not None:
        image_file(out)
        targets = [image_file(_demo_path(out, which)) for which in ("train", "validation")]
    seed = _nonnegative_seed(seed)
    result = robot.robot_experiment(seed=seed, validation_seed=seed + 1)
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
    figures = [robot.plot_robot_experiment(result, which) for which in ("train", "validation")]
    written = None
    if targets is not None:
        written = []
        for fig, (path, fmt) in zip(figures, targets, strict=True):
            save_figure(fig, path, fmt)
            written.append(path)
            lines.append(f"wrote {path}")
    print("\n".join(lines), file=stream)
    return {
        "experiment": result,
        "changepoints": result.changepoints,
        "rms_train": result.rms_train,
        "rms_validation": result.rms_validation,
        "figures": figures,
        "out": written,
    }


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

    Generates :func:`ltvmodels.systems.chirp` (fs = 16 kHz, T = 2¹⁴ samples),
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
    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)
    seed = _nonnegative_seed(seed)
    if not isinstance(quick, bool):
        raise TypeError(f"quick: expected True or False, received {quick!r}")
    T = 2**12 if quick else 2**14
    y, inst = systems.chirp(T, CHIRP_FS, seed=seed)
    fig = new_figure((10.0, 4.0))
    axes = fig.subplots(1, 2, sharey=True)
    models, errors, times = {}, {}, {}
    lines = [
        f"ltvmodels demo: root spectrogram of a two-component chirp, fs = {CHIRP_FS:g} Hz, "
        f"T = {T} samples, seed {seed}; AR(6), norm='sq', lambda^2 = 1e5"
    ]
    for ax, order in zip(axes, (1, 2), strict=True):
        start = time.perf_counter()
        model = fit_ar(y, na=6, lam=CHIRP_LAM, norm="sq", order=order)
        times[order] = time.perf_counter() - start
        freq = model.root_spectrogram(CHIRP_FS)
        target = inst[model.sample_index]
        errors[order] = float(np.mean(np.nanmin(np.abs(freq - target[:, None]), axis=1)))
        models[order] = model
        lines.append(
            f"order {order}: mean error {errors[order]:.2f} Hz between the "
            "instantaneous frequency and the nearest pole track; fit of "
            f"T = {T} samples in {times[order]:.3f} s"
        )
        plotting.plot_spectrogram(y, CHIRP_FS, ax=ax)
        plotting.plot_root_spectrogram(model, CHIRP_FS, ax=ax)
        ax.plot(
            np.arange(T) / CHIRP_FS,
            inst,
            color="C3",
            linestyle="--",
            linewidth=1.0,
            label="instantaneous frequency",
        )
        ax.set_title(f"AR(6), order {order}, λ² = 1e5: mean error {errors[order]:.1f} Hz")
        ax.legend(loc="upper left", fontsize="small", markerscale=6)
    axes[1].set_ylabel("")
    _report(lines, stream, fig, path, fmt)
    return {"y": y, "models": models, "errors": errors, "times": times, "figure": fig, "out": path}


def run_rl_demo(
    *,
    seed: int = 0,
    out: str | os.PathLike | None = DEFAULT_DEMO_OUT["rl"],
    size: str = "default",
    stream: TextIO | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Model-based reinforcement learning on a cart-pole (paper Section VIII, Fig. 4).

    Runs :func:`ltvmodels.apps.rl.run_experiment` (true, LTV, LTI and LTV-with-prior
    models learning to damp a pendulum on a cart), prints the table of median
    costs per iteration and writes :func:`ltvmodels.apps.rl.plot_experiment`.

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
        ``experiment`` (:class:`~ltvmodels.apps.rl.RLExperiment`), ``figure`` and
        ``out`` (the Path written, or None).

    Raises
    ------
    OutputPathError
        If ``out`` cannot be written (checked before the work).
    """
    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)
    seed = _nonnegative_seed(seed)
    if size not in ("default", "quick", "full"):
        raise ValueError(f"size: expected 'default', 'quick' or 'full', received {size!r}")
    runs, iterations = {"default": (None, None), "quick": (1, 4), "full": (20, 14)}[size]
    result = rl.run_experiment(
        quick=size != "full",
        runs=runs,
        iterations=iterations,
        seed=seed,
        models=rl.PAPER_MODELS,
        progress=progress,
    )
    med = result.median()
    lines = [
        "ltvmodels demo: model-based reinforcement learning on a cart-pole "
        f"(Bagge Carlson et al. 2018, Section VIII, Fig. 4), seed {seed}",
        f"median cost over {result.runs} Monte-Carlo runs of {result.iterations} learning "
        f"iterations ({result.elapsed:.1f} s):",
        result.table(),
        "final / optimum: "
        + ", ".join(f"{m} {med[m][-1] / result.optimum:.3f}" for m in result.models),
    ]
    fig = rl.plot_experiment(result)
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

    Runs :func:`ltvmodels.apps.gym_rl.run_pendulum_experiment` (LTV and LTI models
    learning to swing up the pendulum from ``env.reset`` rollouts), prints its
    table and writes :func:`ltvmodels.apps.gym_rl.plot_pendulum_experiment`.

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
        ``experiment`` (:class:`~ltvmodels.apps.gym_rl.PendulumExperiment`),
        ``figure`` and ``out`` (the Path written, or None).

    Raises
    ------
    OutputPathError
        If ``out`` cannot be written (checked before the work).
    ImportError
        Without gymnasium (install ``ltvmodels[rl]``).
    """
    stream = sys.stdout if stream is None else stream
    path, fmt = _optional_output_path(out)
    seed = _nonnegative_seed(seed)
    if size not in ("default", "quick", "full"):
        raise ValueError(f"size: expected 'default', 'quick' or 'full', received {size!r}")
    gym_rl.make_env().close()  # gymnasium is there (else ImportError) before the work
    runs, iterations = {"default": (2, 20), "quick": (1, 20), "full": (20, 40)}[size]
    result = gym_rl.run_pendulum_experiment(
        seeds=range(seed, seed + runs),
        iterations=iterations,
        models=("ltv", "lti"),
        progress=progress,
    )
    lines = [
        "ltvmodels demo: model-based reinforcement learning on gymnasium's Pendulum-v1 "
        f"(swing-up from env.reset/env.step rollouts), seeds {seed}-{seed + runs - 1} "
        f"({result.elapsed:.1f} s)",
        result.table(),
    ]
    fig = gym_rl.plot_pendulum_experiment(result)
    _report(lines, stream, fig, path, fmt)
    return {"experiment": result, "figure": fig, "out": path}


def _nonnegative_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0, received {seed!r}")
    return int(seed)
