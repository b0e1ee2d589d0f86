"""Benchmark: the cost of choosing λ against the cost of one fit.

On the jump-linear system, times ``select_lambda`` (its default grid of 30
values) for each criterion and norm, and one ``fit`` at a typical λ, and
prints their ratio.

Run:  python benchmarks/bench_selection.py [--sizes 400 10000]
"""

from __future__ import annotations

import argparse
import time

import ltvmodels as ltv

CASES = {
    "sq": ("ml", "gcv", "lcurve", "cv"),
    "group": ("lcurve", "cv"),
    "l1": ("lcurve",),
}


def best_time(function, *arguments, repeat: int = 1, **options):
    """(best wall time over ``repeat`` calls, the last result)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = function(*arguments, **options)
        times.append(time.perf_counter() - start)
    return min(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=int, default=[400, 10000])
    args = parser.parse_args()
    warm = ltv.systems.jump_linear(T=1000, change_at=500, seed=1)
    for norm in CASES:  # compile the kernels outside the timings
        ltv.fit(warm.x, warm.u, lam=17.0, norm=norm)
    print(f"{'T':>6} {'norm':>5} {'method':>7} {'select [s]':>10} {'one fit [s]':>11} "
          f"{'ratio':>6} {'lam':>9}")
    for T in args.sizes:
        data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=0)
        repeat = 1 if T > 2000 else 2
        for norm, methods in CASES.items():
            lam = 30.0 if norm == "sq" else 17.0
            one, _ = best_time(ltv.fit, data.x, data.u, lam=lam, norm=norm, compute_cov=False,
                               repeat=3)
            for method in methods:
                if T > 2000 and method == "cv" and norm != "sq":
                    continue  # n_folds times the L-curve's cost
                took, choice = best_time(ltv.select_lambda, data.x, data.u, norm=norm,
                                         method=method, repeat=repeat)
                print(f"{T:>6} {norm:>5} {method:>7} {took:>10.3f} {one:>11.4f} "
                      f"{took / one:>6.0f} {choice.lam:>9.3g}")


if __name__ == "__main__":
    main()
