"""Benchmark: loss="huber" against the squared loss (norm="sq"), same data, same run.

The random-walk system (n = 2 states, m = 1 input) with 5 % of the
transitions hit by gross outliers (+5 standard deviations of the state in one
coordinate); ``fit(x, u, lam=λ)`` and ``fit(..., loss="huber")`` (default δ,
tol 1e-6) are timed after a warm-up that compiles the kernels. Prints the
times, the ratio and the number of reweighting steps. Target (issue): the
Huber fit at T = 1e5 within 5x the squared-loss fit.

Run:  python benchmarks/bench_huber.py [--sizes 10000 100000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import ltvmodels as ltv


def best_time(function, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    for T in args.sizes:
        data = ltv.systems.random_walk_system(T=T, seed=0)
        rng = np.random.default_rng(0)
        x = data.x.copy()
        hit = rng.choice(T, size=T // 20, replace=False)
        x[hit, 0] += 5 * np.std(x[:, 0])
        ltv.fit(x[:200], data.u[:200], lam=30.0, loss="huber")  # compile
        squared = best_time(lambda: ltv.fit(x, data.u, lam=30.0), args.repeat)
        model = ltv.fit(x, data.u, lam=30.0, loss="huber")
        huber = best_time(lambda: ltv.fit(x, data.u, lam=30.0, loss="huber"), args.repeat)
        print(f"T = {T:7d}: squared {squared:7.3f} s, huber {huber:7.3f} s "
              f"({model.status.iterations} steps, {model.info['n_outliers']} outliers), "
              f"ratio {huber / squared:5.1f}x")


if __name__ == "__main__":
    main()
