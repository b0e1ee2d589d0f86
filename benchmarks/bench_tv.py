"""Benchmark: norm="group" / "l1" against cvxpy with Clarabel (and SCS).

On the jump-linear system of the paper (switch in the middle, σ = 0.2), at
T = 400, 2000, 10000, 100000 and λ = 17, this times ``ltvmodels.fit`` (default
tolerance) and cvxpy on the same problem in the same process, each the best
of ``--repeat`` runs, and prints times, iterations and the relative objective gap to
Clarabel's optimum, for order 1 and 2 and both norms. cvxpy runs up to
``--max-reference-T`` (default 10000; it needs minutes and gigabytes beyond).

Run:  python benchmarks/bench_tv.py [--sizes 400 2000 10000 100000] [--scs]
          [--norms group l1] [--orders 1 2] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import ltvmodels as ltv
from ltvmodels.core.problem import state_space_problem

LAM = 17.0


def cvxpy_solve(x, u, lam, norm, coeffs, solver):
    """Optimal value and wall time (canonicalization included) of the cvxpy model."""
    import cvxpy as cp

    pb = state_space_problem(x, u, np.asarray(coeffs, float))
    N, n, p = pb.N, pb.n, pb.p
    phi, y = pb.phi[:, 0], pb.y[:, 0]  # one trajectory: (N, p) and (N, n)
    start = time.perf_counter()
    theta = cp.Variable((N, n * p))
    fitted = [cp.sum(cp.multiply(theta[:, i * p:(i + 1) * p], phi), axis=1) for i in range(n)]
    loss = sum(cp.sum_squares(y[:, i] - fitted[i]) for i in range(n))
    d = len(coeffs) - 1
    Dk = sum(coeffs[j] * theta[j:N - d + j, :] for j in range(d + 1))
    reg = cp.sum(cp.norm(Dk, 2, axis=1)) if norm == "group" else cp.sum(cp.abs(Dk))
    problem = cp.Problem(cp.Minimize(loss + lam * reg))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem.solve(solver=solver)
    return problem.value, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=int, default=[400, 2000, 10000, 100000])
    parser.add_argument("--scs", action="store_true", help="also time SCS (slow)")
    parser.add_argument("--repeat", type=int, default=3,
                        help="runs of each solver (ours and Clarabel); the best counts")
    parser.add_argument("--norms", nargs="+", default=["group", "l1"], choices=["group", "l1"])
    parser.add_argument("--orders", nargs="+", type=int, default=[1, 2], choices=[1, 2])
    parser.add_argument("--max-reference-T", type=int, default=10000,
                        help="largest T at which cvxpy is run")
    args = parser.parse_args()

    warm = ltv.systems.jump_linear(T=1000, change_at=500, seed=1)
    for norm in ("group", "l1"):  # compile the kernels outside the timings
        for order in (1, 2):
            ltv.fit(warm.x, warm.u, lam=LAM, norm=norm, order=order)

    header = (f"{'norm':>5} {'order':>5} {'T':>6} {'ours [s]':>9} {'iters':>6} "
              f"{'Clarabel [s]':>12} {'ratio':>7} {'rel. gap':>9}"
              + ("  SCS [s]" if args.scs else ""))
    print(f"lam = {LAM}, jump-linear system (n=2, m=1), tol = 1e-6")
    print(header)
    print("-" * len(header))
    for norm in args.norms:
        for order in args.orders:
            coeffs = [-1.0, 1.0] if order == 1 else [1.0, -2.0, 1.0]
            for T in args.sizes:
                data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=0)
                times = []
                for _ in range(args.repeat):
                    start = time.perf_counter()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", ltv.ConvergenceWarning)
                        model = ltv.fit(data.x, data.u, lam=LAM, norm=norm, order=order)
                    times.append(time.perf_counter() - start)
                ours = min(times)
                ref = t_ref = float("nan")
                if T <= args.max_reference_T:
                    try:
                        runs = [cvxpy_solve(data.x, data.u, LAM, norm, coeffs, "CLARABEL")
                                for _ in range(args.repeat)]
                        ref, t_ref = runs[0][0], min(t for _, t in runs)
                    except ImportError:
                        pass
                gap = (model.info["objective"] - ref) / abs(ref)
                line = (f"{norm:>5} {order:>5} {T:>6} {ours:>9.3f} {model.info['iterations']:>6} "
                        f"{t_ref:>12.3f} {t_ref / ours:>6.2f}x {gap:>9.1e}")
                if not model.info["converged"]:
                    line += " (not converged)"
                if args.scs and T <= args.max_reference_T:
                    _, t_scs = cvxpy_solve(data.x, data.u, LAM, norm, coeffs, "SCS")
                    line += f" {t_scs:>8.2f}"
                print(line)


if __name__ == "__main__":
    main()
