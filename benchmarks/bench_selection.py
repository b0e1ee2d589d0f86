"""Benchmark: the cost of choosing λ against the cost of one fit.

On the jump-linear system, times ``select_lambda`` (its default search) for
each criterion and norm, and one ``fit`` at a typical λ — without covariances
("fit") and, for norm="sq", with them (the default) — each the best of
``--repeat`` runs after a warm-up that loads the compiled kernels, and prints
the ratios and the number of fits the selection made.

Run:  python benchmarks/bench_selection.py [--sizes 400 10000] [--repeat 3]
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
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    warm = ltv.systems.jump_linear(T=1000, change_at=500, seed=1)
    for norm, methods in CASES.items():  # load the compiled kernels outside the timings
        ltv.fit(warm.x, warm.u, lam=17.0, norm=norm)
        for method in methods:
            ltv.select_lambda(warm.x, warm.u, norm=norm, method=method)
    print(
        f"{'T':>6} {'norm':>5} {'method':>7} {'select [s]':>10} {'fits':>5} "
        f"{'one fit [s]':>11} {'ratio':>6} {'fit+cov [s]':>11} {'ratio':>6} {'lam':>9}"
    )
    for T in args.sizes:
        data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=0)
        for norm, methods in CASES.items():
            lam = 30.0 if norm == "sq" else 17.0
            one, _ = best_time(
                ltv.fit, data.x, data.u, lam=lam, norm=norm, compute_cov=False, repeat=args.repeat
            )
            with_cov, _ = best_time(ltv.fit, data.x, data.u, lam=lam, norm=norm, repeat=args.repeat)
            for method in methods:
                if T > 2000 and method == "cv" and norm != "sq":
                    continue  # n_folds times the L-curve's cost
                took, choice = best_time(
                    ltv.select_lambda, data.x, data.u, norm=norm, method=method, repeat=args.repeat
                )
                cov_columns = (
                    f"{with_cov:>11.4f} {took / with_cov:>6.1f}"
                    if norm == "sq"
                    else f"{'':>11} {'':>6}"
                )
                print(
                    f"{T:>6} {norm:>5} {method:>7} {took:>10.3f} {choice.n_fits:>5} "
                    f"{one:>11.4f} {took / one:>6.1f} {cov_columns} {choice.lam:>9.3g}"
                )


if __name__ == "__main__":
    main()
