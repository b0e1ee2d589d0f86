"""Benchmark: what missing samples and several trajectories cost the squared-norm fit.

Two ratios, each timed in one process on the same system (the random-walk
system, n = 3, m = 2, K = 15 parameters, order 1, λ = 30, covariances on):

* ``fit(norm="sq")`` at T = 1e5 with 10 % of the samples missing (each
  missing sample removes the transitions into and out of it, so about 19 % of
  the transitions) against the complete record: target <= 1.2×;
* R = 10 trajectories of T = 1e4 as one (R, T, n) batch against one
  trajectory of T = 1e4: the Gram blocks Σ_r φφᵀ are summed before the same
  banded factorization, so the target is <= 3×.

Run:  python benchmarks/bench_recordings.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import ltvmodels as ltv
from ltvmodels.systems import random_walk_system

LAM = 30.0


def best_time(func, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)

    data = random_walk_system(T=100_000, seed=0)
    x, u = data.x, data.u
    gaps = x.copy()
    gaps[rng.random(len(x)) < 0.10] = np.nan
    ltv.fit(x[:200], u[:200], lam=LAM)  # compile outside the timings
    ltv.fit(gaps[:200], u[:200], lam=LAM)
    full = best_time(lambda: ltv.fit(x, u, lam=LAM), args.repeat)
    missing = best_time(lambda: ltv.fit(gaps, u, lam=LAM), args.repeat)
    left_out = ltv.fit(gaps, u, lam=LAM).info["n_missing"]
    print(
        f"T = 1e5, n = 3, m = 2: complete {full:.3f} s, 10 % of samples missing "
        f"({left_out} of {len(x) - 1} transitions left out) {missing:.3f} s: "
        f"ratio {missing / full:.2f} (target <= 1.2)"
    )

    R, T = 10, 10_000
    runs = [random_walk_system(T=T, seed=s) for s in range(R)]
    xb = np.stack([r.x for r in runs])
    ub = np.stack([r.u for r in runs])
    one = best_time(lambda: ltv.fit(xb[0], ub[0], lam=LAM), args.repeat)
    many = best_time(lambda: ltv.fit(xb, ub, lam=LAM), args.repeat)
    print(
        f"R = {R} trajectories of T = 1e4: one {one:.4f} s, the batch {many:.4f} s: "
        f"ratio {many / one:.2f} (target <= 3)"
    )


if __name__ == "__main__":
    main()
