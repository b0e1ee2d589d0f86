"""Learning to swing up Pendulum-v1 from batches of rollouts whose recorded states are noisy.

:func:`ltvmodels.apps.gym_rl.learn_pendulum` (the LTV model, quick-mode
iterations) with Gaussian sensor noise of standard deviation ``sd`` on the
recorded states that the models are fitted on (the controller and the returns
use the true states), its fits treating those states

* as exact (today's fits),
* by EM with the measurement variance estimated (``measurement_noise="estimate"``),
* by EM with the sensor's variance given (``measurement_noise=sd**2``).

Printed per noise level and treatment: how many runs end swung up, the median
final return of the incumbent and the time per run. Needs gymnasium.

Run:  python benchmarks/bench_noisy_pendulum.py [--seeds 0 1 2 3] [--sds 0.005 0.02]
      [--iterations 20]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from ltvmodels.apps.gym_rl import learn_pendulum


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3])
    parser.add_argument("--sds", nargs="+", type=float, default=[0.005, 0.02])
    parser.add_argument("--iterations", type=int, default=20)
    args = parser.parse_args()
    cases = [(0.0, "exact records", None)]
    for sd in args.sds:
        cases += [
            (sd, "as exact", None),
            (sd, "EM, estimated", "estimate"),
            (sd, "EM, given", sd**2),
        ]
    print(f"{len(args.seeds)} runs of {args.iterations} iterations each")
    print(f"{'sd':>6}  {'fits':<14} {'swung up':>8} {'median return':>14} {'s / run':>8}")
    for sd, name, measurement in cases:
        swung, final, seconds = [], [], []
        for seed in args.seeds:
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # EM's and the planner's convergence notes
                run = learn_pendulum(
                    "ltv",
                    seed=seed,
                    iterations=args.iterations,
                    state_noise_std=sd,
                    measurement_noise=measurement,
                )
            seconds.append(time.perf_counter() - start)
            swung.append(bool(run.swung_up[-1]))
            final.append(run.incumbent_returns[-1])
        print(
            f"{sd:6.3f}  {name:<14} {sum(swung):>4}/{len(swung):<3} "
            f"{np.median(final):14.1f} {np.mean(seconds):8.1f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
