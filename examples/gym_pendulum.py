"""
Model-based reinforcement learning on gymnasium's Pendulum-v1 with LTV vs LTI models
====================================================================================

The loop of ``examples/rl_cartpole.py`` on a simulator nobody here wrote: the
pendulum of gymnasium (torque bounded to ±2, episodes of 200 steps, swing-up)
is only reset and stepped. Each learning iteration rolls out the current
controller 8 times from the same initial state (once without noise: the
controller whose return is reported; 7 times with seeded exploration noise),
fits an LTV model (``norm="sq"``, ``order=2``, λ = 0.01) or an LTI model on
that batch of rollouts (x of shape (8, 201, 2)) of the best controller so far,
linearizes through its noise-free rollout and re-optimizes the controller
with bounded, trust-region iLQG on a smooth surrogate of the pendulum's cost
(see :mod:`ltvmodels.apps.gym_rl`). Performance is gymnasium's own episode
return. Prints the table (median return per iteration, seeds swung up at the
end, median iterations to swing-up, median, quartiles and mean of the final
return, next to gymnasium's usual good return of about −150) and writes the
learning curves. Headless; needs gymnasium (``pip install "ltvmodels[rl]"``).

Usage::

    python examples/gym_pendulum.py [--out gym_pendulum.png] [--quick] [--seeds 20]
                                    [--iterations 40]

The default (20 initial states ``env.reset(seed=0…19)``, 40 iterations of 8
episodes) takes about 70 s on two cores for the LTV and LTI models and 10 more
minutes for the LTV model with the learned prior (a Gaussian mixture of all
earlier iterations' rollouts, ``ltvmodels.GMMPrior``; needs scikit-learn,
else it is left out); ``--quick`` runs 2 initial states for 20 iterations. Result of the default
(``python examples/gym_pendulum.py``):

=========================================  ==============  ==============  ==============
                                           LTV             LTI             LTV + learned
=========================================  ==============  ==============  ==============
seeds swung up at the end                  20/20           4/20            20/20
median iterations to swing-up (for good)   7.5             19.5            10.5
median final return                        −123            −907            −124
final return, 25 % / 75 % quantiles        −216 / −117     −1168 / −398    −224 / −118
mean final return                          −128            −816            −159
=========================================  ==============  ==============  ==============

The LTV model swings up every initial state; the LTI model, fitted on the
same rollouts, swings up 4; with the learned prior the LTV model swings up
all 20 too, but later.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ltvmodels.apps.gym_rl import (
    PENDULUM_MODELS,
    plot_pendulum_experiment,
    run_pendulum_experiment,
)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out", default="gym_pendulum.png", help="image file to write (default: gym_pendulum.png)"
    )
    parser.add_argument(
        "--quick", action="store_true", help="quick mode: 2 initial states, 20 iterations"
    )
    parser.add_argument(
        "--seeds",
        type=int,
        default=None,
        help="number of initial states: env.reset seeds 0 … SEEDS-1 "
        "(default 20; quick mode: seeds 7 and 19)",
    )
    parser.add_argument(
        "--iterations",
        type=int,
        default=None,
        help="learning iterations per run, 8 episodes each (default 40, or 20 with --quick)",
    )
    args = parser.parse_args(argv)
    if args.seeds is not None and args.seeds < 1:
        parser.error(f"--seeds: expected an integer >= 1, received {args.seeds}")
    if args.iterations is not None and args.iterations < 1:
        parser.error(f"--iterations: expected an integer >= 1, received {args.iterations}")
    out = Path(args.out)
    if not out.parent.is_dir():
        print(f"error: --out: the folder {str(out.parent)!r} does not exist", file=sys.stderr)
        return 2
    try:
        import gymnasium  # noqa: F401
    except ImportError:
        print(
            "error: this example needs gymnasium: install ltvmodels[rl] "
            "(pip install 'ltvmodels[rl]')",
            file=sys.stderr,
        )
        return 2
    try:
        import sklearn  # noqa: F401

        models = PENDULUM_MODELS
    except ImportError:
        models = ("ltv", "lti")
        print(
            "scikit-learn is not installed: the arm with the learned prior is left out "
            "(pip install 'ltvmodels[gmm]')"
        )
    start = time.perf_counter()
    seeds = None if args.seeds is None else range(args.seeds)
    result = run_pendulum_experiment(
        quick=args.quick, seeds=seeds, iterations=args.iterations, models=models, progress=print
    )
    print()
    print(result.table())
    fig = plot_pendulum_experiment(result)
    fig.savefig(out, dpi=120)
    print(f"wrote {out} ({time.perf_counter() - start:.1f} s)")
    return 0


if __name__ == "__main__":
    # Exit only on failure: the documentation's gallery runs this file in-process.
    if status := main():
        raise SystemExit(status)
