"""``ltvmodels demo``: run an example of the paper on built-in data, report and plot.

The only command that uses the applications (:mod:`ltvmodels.apps`); it
imports them when it runs.
"""

from __future__ import annotations

import argparse

from ..messages import CommandError
from ..outputs import Report

__all__ = ["run"]


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
