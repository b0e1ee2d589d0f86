"""
Model-based reinforcement learning of a pendulum on a cart (paper Section VIII, Fig. 4)
=======================================================================================

The pendulum starts close to upright and falls; the controller moves the cart
(force bounded to ±3 N) to damp the swing about the hanging position, under a
quadratic cost over T = 500 steps. Each learning iteration rolls out the
current controller with exploration noise, fits a dynamics model along the
rollout and re-optimizes the controller with bounded, trust-region iLQG. Five
models are compared over Monte-Carlo runs: the true model (the simulator's
Jacobians), an LTV model (norm="sq", order=2), an LTI model, the LTV model
with a prior (the true model linearized along the rollout), and the LTV model
with a prior learned from the earlier rollouts (a Gaussian mixture of their
transitions, ``ltvmodels.GMMPrior``; needs scikit-learn, ``pip install
'ltvmodels[gmm]'``, else that curve is left out). Prints the table of median
costs per iteration and writes the figure (median and inter-quartile band).
Headless: no display needed.

Usage::

    python examples/rl_cartpole.py [--out rl_cartpole.png] [--quick] [--seed 0] [--runs 8]

The default of 8 Monte-Carlo runs takes about 2.5 min on two cores (the
learned prior's curve 80 % of it); ``--runs 20`` is the paper's figure.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ltvmodels.apps.rl import MODELS, PAPER_MODELS, plot_experiment, run_experiment


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out", default="rl_cartpole.png", help="image file to write (default: rl_cartpole.png)"
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="quick mode: 3 runs of 8 iterations (unless --runs is given)",
    )
    parser.add_argument("--seed", type=int, default=0, help="experiment seed (default: 0)")
    parser.add_argument(
        "--runs",
        type=int,
        default=None,
        help="Monte-Carlo runs (default: 8, or 3 with --quick; the paper: 20)",
    )
    args = parser.parse_args(argv)
    if args.seed < 0:
        parser.error(f"--seed: expected an integer >= 0, received {args.seed}")
    if args.runs is not None and args.runs < 1:
        parser.error(f"--runs: expected an integer >= 1, received {args.runs}")
    out = Path(args.out)
    if not out.parent.is_dir():
        print(f"error: --out: the folder {str(out.parent)!r} does not exist", file=sys.stderr)
        return 2
    start = time.perf_counter()
    runs = args.runs if args.runs is not None or args.quick else 8
    try:
        import sklearn  # noqa: F401

        models = MODELS
    except ImportError:
        models = PAPER_MODELS
        print(
            "scikit-learn is not installed: the curve of the learned prior is left out "
            "(pip install 'ltvmodels[gmm]')"
        )
    result = run_experiment(
        quick=args.quick, runs=runs, seed=args.seed, models=models, progress=print
    )
    print(f"\nMedian cost over {result.runs} runs (seed {result.seed}):")
    print(result.table())
    med = result.median()
    last = {m: med[m][-1] for m in result.models}
    print(
        "final / optimum: "
        + ", ".join(f"{m} {last[m] / result.optimum:.3f}" for m in result.models)
    )
    fig = plot_experiment(result)
    fig.savefig(out, dpi=120)
    print(f"wrote {out} ({time.perf_counter() - start:.1f} s)")
    return 0


if __name__ == "__main__":
    # Exit only on failure: the documentation's gallery runs this file in-process.
    if status := main():
        raise SystemExit(status)
