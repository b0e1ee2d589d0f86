"""Benchmark: norm="sq" on wide models (many states), T = 1000.

Times ``ltvmodels.fit(x, lam=10)`` (scalar λ, covariances on) for n = 30, 60
and 100 states of a stable autonomous system, after a warm-up that compiles
the kernels for the block size, and prints the peak resident memory. The cost
should grow as O(N·n·p³) with p = n; dense K × K work (K = n²) would dominate
otherwise.

Run:  python benchmarks/bench_wide.py [--sizes 30 60 100]
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

import ltvmodels as ltv


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[30, 60, 100])
    parser.add_argument("--T", type=int, default=1000)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    for n in args.sizes:
        x = np.zeros((args.T, n))
        for t in range(args.T - 1):
            x[t + 1] = 0.5 * x[t] + rng.standard_normal(n)
        ltv.fit(x[: n + 20], None, lam=10.0)  # compile for this block size
        start = time.perf_counter()
        ltv.fit(x, None, lam=10.0)
        elapsed = time.perf_counter() - start
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"n = {n:4d} (K = {n * n:6d}): {elapsed:6.2f} s, peak memory so far {peak:6.0f} MB")


if __name__ == "__main__":
    main()
