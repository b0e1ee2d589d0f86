"""The ``ltvmodels`` command (also ``python -m ltvmodels``).

Subcommands::

    ltvmodels demo jump-linear [--seed S] [--lam L] [--out PATH]

The command line uses :mod:`argparse` from the standard library: a handful of
options does not justify an extra dependency (click, typer) for every user.

User errors (unknown options, bad values, an output path that cannot be
written) print one line to stderr and give exit status 2, without traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any, NoReturn, Sequence, TextIO

import numpy as np

__all__ = ["main", "run_jump_linear_demo", "JUMP_LINEAR_LAM", "DEFAULT_JUMP_LINEAR_OUT"]

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


def _check_output_path(out: Any) -> tuple[Path, str]:
    """Validate an output file path before any work is done; return (path, format)."""
    if not isinstance(out, (str, os.PathLike)) or str(out) == "":
        raise OutputPathError(f"out: expected a file path, received {out!r}")
    path = Path(out)
    if path.is_dir():
        raise OutputPathError(f"out: {str(path)!r} is a directory; expected a file path")
    parent = path.parent
    if not parent.is_dir():
        raise OutputPathError(f"out: cannot write {str(path)!r}: directory {str(parent)!r} "
                              "does not exist")
    if not os.access(parent, os.W_OK):
        raise OutputPathError(f"out: cannot write {str(path)!r}: directory {str(parent)!r} "
                              "is not writable")
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputPathError(f"out: cannot write {str(path)!r}: file is not writable")
    return path, _image_format(path)


def _rms(a: np.ndarray) -> float:
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
    path, fmt = _check_output_path(out) if out is not None else (None, None)

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
    result["out"] = None
    if path is not None:
        try:
            fig.savefig(path, format=fmt, dpi=110)
        except OSError as exc:
            reason = exc.strerror or exc
            raise OutputPathError(f"out: cannot write {str(path)!r}: {reason}") from exc
        result["out"] = path
        lines.append(f"wrote {path}")
    print("\n".join(lines), file=stream)
    return result


# -- command line --------------------------------------------------------------------
def _nonnegative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, received {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, received {value}")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, received {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, received {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``ltvmodels`` command."""
    from . import __version__

    parser = _Parser(
        prog="ltvmodels",
        description="Identification of linear time-varying (LTV) models "
        "x[t+1] = A_t x[t] + B_t u[t] + v_t by convex optimization.",
    )
    parser.add_argument("--version", action="version", version=f"ltvmodels {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    demo = commands.add_parser(
        "demo", help="simulate an example system, identify it, report and plot",
        description="Simulate an example system from the paper, identify it, print a report "
        "and write a figure of the estimated coefficients against the truth.",
    )
    demo.add_argument("system", choices=["jump-linear"],
                      help="jump-linear: the jump-linear system of the paper (Section VI)")
    demo.add_argument("--seed", type=_nonnegative_int, default=0,
                      help="seed of the simulation (default: 0)")
    demo.add_argument("--norm", choices=["group", "sq"], default="group",
                      help="group: piecewise-constant fit with two-step refinement, the "
                      "paper's Fig. 1 (default); sq: slowly varying fit")
    demo.add_argument("--lam", type=_positive_float, default=None,
                      help="regularization lambda (default: 0.1·lambda_max for group, "
                      f"{JUMP_LINEAR_LAM:g} for sq)")
    demo.add_argument("--out", default=DEFAULT_JUMP_LINEAR_OUT, metavar="PATH",
                      help=f"image file to write (default: {DEFAULT_JUMP_LINEAR_OUT}; "
                      "format from the suffix)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``ltvmodels`` command; returns the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on a usage error (one line on stderr).
    """
    parser = build_parser()
    try:
        args = parser.parse_args(None if argv is None else list(argv))
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

    if args.command == "demo" and args.system == "jump-linear":
        try:
            run_jump_linear_demo(seed=args.seed, norm=args.norm, lam=args.lam, out=args.out)
        except OutputPathError as exc:
            print(f"ltvmodels demo: error: --{exc}", file=sys.stderr)
            return 2
        return 0
    raise AssertionError(f"unhandled command {args.command!r}")  # pragma: no cover
