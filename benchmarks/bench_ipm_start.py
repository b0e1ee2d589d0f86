"""Benchmark: interior-point iterations from the feasible start against k = 0.

On the jump-linear system (T = 400, 2000, 10000; seeds 0 and 1; norms "group"
and "l1"; λ = 3, 17, 60), counts the iterations of the interior-point method
for orders 1 and 2, once from its default start (the primal-dual feasible
quadratic fit) and once from k = 0 with z = e, and checks that both reach the
same objective.

Run:  python benchmarks/bench_ipm_start.py
"""

from __future__ import annotations

import numpy as np

import ltvmodels as ltv
from ltvmodels.core import ipm
from ltvmodels.core.problem import state_space_problem


def main() -> None:
    print(f"{'order':>5} {'fits':>5} {'feasible start':>15} {'k = 0':>7} {'max rel. diff':>14}")
    for order, coeffs in ((1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])):
        counts = {"feasible": 0, "zero": 0}
        fits, worst = 0, 0.0
        for T in (400, 2000, 10000):
            for seed in (0, 1):
                data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
                pb = state_space_problem(data.x, data.u, np.array(coeffs))
                for norm in ("group", "l1"):
                    for lam in (3.0, 17.0, 60.0):
                        weights = np.full(pb.K, lam)
                        start = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6)
                        zero = ipm.fit_sparse_ipm(
                            pb, weights, norm, tol=1e-6, k0=np.zeros((pb.N, pb.K))
                        )
                        counts["feasible"] += start.iterations
                        counts["zero"] += zero.iterations
                        worst = max(
                            worst, abs(start.objective - zero.objective) / abs(zero.objective)
                        )
                        fits += 1
        print(f"{order:>5} {fits:>5} {counts['feasible']:>15} {counts['zero']:>7} {worst:>14.1e}")


if __name__ == "__main__":
    main()
