"""``ltvmodels demo``: run an example of the paper on built-in data, report and plot.

The only command that uses the applications (:mod:`ltvmodels.apps`): it
imports them inside its functions, when its options are added (the demos'
names and defaults) or when it runs, so that no other command loads them.
"""

from __future__ import annotations

import argparse

from .. import arguments as opt
from ..messages import CommandError
from ..report import Report
from ..subcommand import Subcommand

__all__ = ["COMMAND", "add_arguments", "run"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``demo``."""
    from ...apps.defaults import DEFAULT_DEMO_OUT, JUMP_LINEAR_LAM

    p.add_argument(
        "system", choices=list(DEFAULT_DEMO_OUT), help="jump-linear, robot, chirp, rl or pendulum"
    )
    opt.add_seed(p, "seed of the simulation (default: 0)")
    opt.add_norm(
        p,
        "jump-linear only. group: piecewise-constant fit with two-step "
        "refinement, the paper's Fig. 1 (default); sq: slowly varying fit",
        choices=("group", "sq"),
        default=None,
    )
    p.add_argument(
        "--lam",
        type=opt.positive_float,
        default=None,
        help="jump-linear only: regularization lambda (default: "
        f"0.1·lambda_max for group, {JUMP_LINEAR_LAM:g} for sq)",
    )
    opt.add_out(
        p,
        "image file to write (default: ltvmodels-<system>.png; format from "
        "the suffix); robot writes <stem>_train and <stem>_validation",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="chirp, rl and pendulum only: a smaller problem (chirp: 2^12 "
        "samples; rl: 1 run of 4 iterations; pendulum: 1 initial state)",
    )
    p.add_argument(
        "--full",
        action="store_true",
        help="rl: the paper's 20 runs of 14 iterations (default: 3 runs of 8); "
        "pendulum: 20 initial states of 40 iterations (default: 2 of 20)",
    )


def run(args: argparse.Namespace) -> Report:
    """Run the demo; it prints its own report and writes its figures.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``demo`` arguments.

    Returns
    -------
    report, lines : dict, list of str
        Empty: the demo has printed what it reports.

    Raises
    ------
    CommandError
        An option of another demo, or ``--quick`` with ``--full``.
    """
    from ...apps.defaults import DEFAULT_DEMO_OUT
    from ...apps.demos import (
        run_chirp_demo,
        run_jump_linear_demo,
        run_pendulum_demo,
        run_rl_demo,
        run_robot_demo,
    )
    from ...apps.rl import QUICK_RUNS
    from ...progress import Progress

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
    size = "full" if args.full else ("quick" if args.quick else "default")  # rl and pendulum
    if system == "jump-linear":
        run_jump_linear_demo(seed=args.seed, norm=args.norm or "group", lam=args.lam, out=out)
    elif system == "robot":
        run_robot_demo(seed=args.seed, out=out)
    elif system == "chirp":
        run_chirp_demo(seed=args.seed, out=out, quick=args.quick)
    elif system == "pendulum":
        runs = {"default": 2, "quick": 1, "full": 20}[size]
        try:
            with Progress("ltvmodels demo pendulum: runs", total=runs) as bar:
                run_pendulum_demo(
                    seed=args.seed, out=out, size=size, progress=lambda _line: bar.advance()
                )
        except ImportError as exc:
            raise CommandError(f"demo pendulum: {exc}") from None
    else:
        runs = {"default": QUICK_RUNS, "quick": 1, "full": 20}[size]
        with Progress("ltvmodels demo rl: Monte-Carlo runs", total=runs) as bar:
            run_rl_demo(seed=args.seed, out=out, size=size, progress=lambda _line: bar.advance())
    return {}, []


COMMAND = Subcommand(
    description="Run an example on built-in data in seconds, print a report and write "
    "figures. jump-linear: the jump-linear system of the paper (Section VI, Fig. 1); "
    "robot: a two-link arm with friction and contact (Figs. 2-3); chirp: root "
    "spectrogram of a chirp by AR models; rl: model-based reinforcement learning on a "
    "cart-pole (Section VIII, Fig. 4); pendulum: the same with LTV and LTI models on "
    "gymnasium's Pendulum-v1 (needs gymnasium: pip install 'ltvmodels[rl]').",
    add_arguments=add_arguments,
    run=run,
)
