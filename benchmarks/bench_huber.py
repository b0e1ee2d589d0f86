"""Benchmark: loss="huber" (or "laplace") against the squared loss, same data, norm and run.

norm="sq": the random-walk system (n = 2 states, m = 1 input) with 5 % of
the transitions hit by gross outliers (+5 standard deviations of the state in
one coordinate), λ = 30. norm="group": the jump-linear system (change in the
middle) with 5 % of the samples hit by +5σ (σ = 0.2, the noise level), λ = 8.
``fit(x, u, lam=λ, norm=norm)`` and ``fit(..., loss=loss)`` (default δ,
tol 1e-6) are timed after a warm-up that compiles the kernels. Prints the
times, the ratio and the number of steps (Newton steps for "sq", interior-point
iterations for "group"/"l1"). Targets (issue): the Huber fit within 5x the
squared-loss fit at T = 1e5 for "sq", within 3x at T = 1e4 for "group".

Run:  python benchmarks/bench_huber.py [--norm sq] [--sizes 10000 100000] [--repeat 3]
      python benchmarks/bench_huber.py --norm group --sizes 10000 [--loss laplace]
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
    parser.add_argument("--norm", choices=["sq", "group", "l1"], default="sq")
    parser.add_argument("--loss", choices=["huber", "laplace"], default="huber")
    args = parser.parse_args()
    norm, loss = args.norm, args.loss
    for T in args.sizes:
        rng = np.random.default_rng(0)
        hit = rng.choice(np.arange(1, T), size=T // 20, replace=False)
        if norm == "sq":
            data = ltv.systems.random_walk_system(T=T, seed=0)
            x = data.x.copy()
            x[hit, 0] += 5 * np.std(x[:, 0])
            lam = 30.0
        else:
            data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=0)
            x = data.x.copy()
            x[hit, rng.integers(0, 2, size=hit.size)] += 5 * 0.2
            lam = 8.0
        u = data.u
        ltv.fit(x[:200], u[:200], lam=lam, norm=norm, loss=loss)  # compile
        squared = best_time(lambda: ltv.fit(x, u, lam=lam, norm=norm), args.repeat)
        model = ltv.fit(x, u, lam=lam, norm=norm, loss=loss)
        robust = best_time(lambda: ltv.fit(x, u, lam=lam, norm=norm, loss=loss), args.repeat)
        inner = model.info.get("inner_iterations")
        outliers = model.info.get("n_outliers")
        print(
            f"norm={norm} T = {T:7d}: squared {squared:7.3f} s, {loss} {robust:7.3f} s "
            f"({model.status.iterations} steps"
            + (f", {inner} inner iterations" if inner else "")
            + (f", {outliers} outliers" if outliers is not None else "")
            + f"), ratio {robust / squared:5.1f}x"
        )


if __name__ == "__main__":
    main()
