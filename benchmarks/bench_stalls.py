"""Benchmark: sparse-change fits near λ_max, where the interior-point method can stall.

On the jump-linear system (T = 1000 and 2000, seeds 0–7), fits norm="group"
and "l1" with order 2 at λ = (0.3, 0.5, 0.7, 0.9) · λ_max and counts the fits
that converged by the interior-point method alone, those certified by the
active-set polish (``info["polished"]``), and those that still end with a
ConvergenceWarning; it prints the time of each polished or failed fit.

Run:  python benchmarks/bench_stalls.py
"""

from __future__ import annotations

import time
import warnings

import ltvmodels as ltv


def main() -> None:
    counts = {"interior point": 0, "polished": 0, "warning": 0}
    print(f"{'T':>5} {'seed':>4} {'lam/lam_max':>11} {'norm':>5} {'outcome':>10} {'time [s]':>8}")
    for T in (1000, 2000):
        for seed in range(8):
            data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
            for norm in ("group", "l1"):
                lam_max = ltv.lambda_max(data.x, data.u, norm=norm, order=2)
                for fraction in (0.3, 0.5, 0.7, 0.9):
                    start = time.perf_counter()
                    with warnings.catch_warnings(record=True) as caught:
                        warnings.simplefilter("always", ltv.ConvergenceWarning)
                        model = ltv.fit(data.x, data.u, lam=fraction * lam_max, norm=norm,
                                        order=2)
                    elapsed = time.perf_counter() - start
                    if caught:
                        outcome = "warning"
                    elif model.info["polished"]:
                        outcome = "polished"
                    else:
                        outcome = "interior point"
                    counts[outcome] += 1
                    if outcome != "interior point":
                        print(f"{T:>5} {seed:>4} {fraction:>11} {norm:>5} {outcome:>10} "
                              f"{elapsed:>8.3f}")
    print(", ".join(f"{name}: {count}" for name, count in counts.items()))


if __name__ == "__main__":
    main()
