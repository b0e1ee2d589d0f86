"""Benchmark: sparse-change fits near λ_max, where the interior-point method can stall.

On the jump-linear system (T = 1000 and 2000, seeds 0–7), fits norm="group"
and "l1" with order 2 at λ = (0.3, 0.5, 0.7, 0.9) · λ_max and counts the fits
that converged by the interior-point method alone, those certified by the
active-set polish (``info["polished"]``), and those that still end with a
ConvergenceWarning; it prints the time of each polished or failed fit. With
``--clarabel`` it also solves every problem with cvxpy + Clarabel in the same
run and prints the largest relative objective gap (ours − Clarabel's) /
Clarabel's, and the total times of both.

Run:  python benchmarks/bench_stalls.py [--clarabel]
"""

from __future__ import annotations

import argparse
import time
import warnings

from bench_tv import cvxpy_solve

import ltvmodels as ltv


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--clarabel", action="store_true", help="compare every objective with cvxpy + Clarabel"
    )
    args = parser.parse_args()
    counts = {"interior point": 0, "polished": 0, "warning": 0}
    worst_gap, ours_total, peer_total = 0.0, 0.0, 0.0
    print(f"{'T':>5} {'seed':>4} {'lam/lam_max':>11} {'norm':>5} {'outcome':>10} {'time [s]':>8}")
    for T in (1000, 2000):
        for seed in range(8):
            data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
            for norm in ("group", "l1"):
                lam_max = ltv.lambda_max(data.x, data.u, norm=norm, order=2)
                for fraction in (0.3, 0.5, 0.7, 0.9):
                    lam = fraction * lam_max
                    start = time.perf_counter()
                    with warnings.catch_warnings(record=True) as caught:
                        warnings.simplefilter("always", ltv.ConvergenceWarning)
                        model = ltv.fit(
                            data.x, data.u, lam=lam, norm=norm, order=2, compute_cov=False
                        )
                    elapsed = time.perf_counter() - start
                    ours_total += elapsed
                    if caught:
                        outcome = "warning"
                    elif model.info["polished"]:
                        outcome = "polished"
                    else:
                        outcome = "interior point"
                    counts[outcome] += 1
                    gap = ""
                    if args.clarabel:
                        value, seconds = cvxpy_solve(
                            data.x, data.u, lam, norm, [1.0, -2.0, 1.0], "CLARABEL"
                        )
                        peer_total += seconds
                        relative = (model.info["objective"] - value) / value
                        worst_gap = max(worst_gap, relative)
                        gap = f" {relative:9.1e}"
                    if outcome != "interior point":
                        print(
                            f"{T:>5} {seed:>4} {fraction:>11} {norm:>5} {outcome:>10} "
                            f"{elapsed:>8.3f}{gap}"
                        )
    print(", ".join(f"{name}: {count}" for name, count in counts.items()))
    if args.clarabel:
        print(
            f"largest relative objective gap to Clarabel: {worst_gap:.1e}; total time ours "
            f"{ours_total:.2f} s, Clarabel {peer_total:.2f} s ({peer_total / ours_total:.1f}x)"
        )


if __name__ == "__main__":
    main()
