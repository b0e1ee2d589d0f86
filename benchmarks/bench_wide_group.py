"""Benchmark: norm="group" with many parameters per time step, against cvxpy + Clarabel.

Jump systems with n states and m inputs (K = n(n + m) = 35: n = 5, m = 2;
K = 60: n = 6, m = 4; A switches between two random stable matrices at T/2,
σ = 0.2, order 1, see ``bench_tv.wide_jump``) at T = 1000 and 4000, with λ a
fraction of λ_max (``--fraction``, default 0.1: a few changes). Ours
(``ltvmodels.fit``, tol = 1e-6) and cvxpy + Clarabel run alternately in the same
process, ``--repeat`` times each; printed are the route the dispatch chose
(``--route`` forces the interior point or ADMM, for measuring the crossover),
the best times, the ratio of the best times and the range of the ratios of the
single repeats (the spread a shared machine causes), the iterations, the
relative objective gap to Clarabel's optimum and the certificate: the
relative duality gap and whether the fit converged.

Run:  python benchmarks/bench_wide_group.py [--sizes 35 60] [--T 1000 4000]
          [--fraction 0.1] [--repeat 2] [--route auto|ipm|admm]
"""

from __future__ import annotations

import argparse
import time
import warnings

from bench_tv import cvxpy_solve, wide_jump

import ltvmodels as ltv
from ltvmodels.core import sparse

SYSTEMS = {35: (5, 2), 60: (6, 4), 24: (4, 2), 48: (6, 2)}  # K: (n, m)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[35, 60], choices=sorted(SYSTEMS))
    parser.add_argument("--T", type=int, nargs="+", default=[1000, 4000])
    parser.add_argument("--fraction", type=float, default=0.1, help="λ / λ_max")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--route", default="auto", choices=["auto", "ipm", "admm"])
    parser.add_argument("--no-reference", action="store_true", help="skip cvxpy")
    args = parser.parse_args()
    if args.route == "ipm":
        sparse.GROUP_IPM_MAX_K = 10**9
    elif args.route == "admm":
        sparse.GROUP_IPM_MAX_K = 0
    print(
        f"norm='group', order 1, tol = 1e-6, lam = {args.fraction} lambda_max, route {args.route}"
    )
    header = (
        f"{'K':>3} {'T':>5} {'route':>14} {'ours [s]':>9} {'iters':>6} {'Clarabel [s]':>12} "
        f"{'ratio':>7} {'per repeat':>13} {'rel. gap':>9} {'certificate':>12}"
    )
    print(header)
    print("-" * len(header))
    for K in args.sizes:
        n, m = SYSTEMS[K]
        for T in args.T:
            x, u = wide_jump(n, m, T)
            lam_max = ltv.fit(x, u, lam=1e12, norm="group", compute_cov=False).info["lambda_max"]
            lam = args.fraction * lam_max

            def ours(x=x, u=u, lam=lam):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ltv.ConvergenceWarning)
                    return ltv.fit(x, u, lam=lam, norm="group", compute_cov=False, max_iter=100_000)

            ours_small = wide_jump(n, m, 200)
            with warnings.catch_warnings():  # compile for this block size outside the timings
                warnings.simplefilter("ignore", ltv.ConvergenceWarning)
                ltv.fit(*ours_small, lam=lam, norm="group", compute_cov=False)
            times, ref_times = [], []
            ref = float("nan")
            for _ in range(args.repeat):
                start = time.perf_counter()
                model = ours()
                times.append(time.perf_counter() - start)
                if not args.no_reference:
                    ref, t_ref = cvxpy_solve(x, u, lam, "group", [-1.0, 1.0], "CLARABEL")
                    ref_times.append(t_ref)
            best = min(times)
            t_ref = min(ref_times, default=float("nan"))
            ratios = [r / o for o, r in zip(times, ref_times)] or [float("nan")]
            info = model.info
            gap = (info["objective"] - ref) / abs(ref)
            certificate = info["duality_gap"] / max(abs(info["objective"]), 1e-300)
            changes = len(model.changepoints)
            print(
                f"{K:>3} {T:>5} {info['solver'][:14]:>14} {best:>9.3f} {info['iterations']:>6} "
                f"{t_ref:>12.3f} {t_ref / best:>6.2f}x {min(ratios):>6.2f}-{max(ratios):<6.2f} "
                f"{gap:>9.1e} {certificate:>8.1e} {'ok' if info['converged'] else 'NO'}"
                f"  ({changes} changes)",
                flush=True,
            )


if __name__ == "__main__":
    main()
