"""Benchmark: norm="group" / "l1" against cvxpy with Clarabel (and SCS).

On the jump-linear system of the paper (switch in the middle, σ = 0.2), at
T = 400, 2000, 10000, 100000 and λ = 17, this times ``ltvmodels.fit`` (default
tolerance) and cvxpy on the same problem in the same process, alternately,
``--repeat`` runs each, and prints the best times, iterations, the ratio of the
best times and the range of the ratios of the single repeats (the spread a
shared machine causes), and the relative objective gap to Clarabel's optimum,
for order 1 and 2 and both norms. cvxpy runs up to
``--max-reference-T`` (default 10000; it needs minutes and gigabytes beyond).

With ``--wide`` it instead times wider models — jump systems with n = 4, 5, 6
states and m = 2, 2, 4 inputs (K = 24, 35, 60 parameters per step; A switches
between two random stable matrices at T/2, σ = 0.2, λ = 5, order 1) at
T = 1000 and 4000 — and prints the solver the dispatch chose. ``--systems``
replaces those (n, m), e.g. ``--norms l1 --systems 16,8 10,6`` for l1 with
24 and 16 regressors per output (its Newton blocks are (n + m) × (n + m));
``--T`` replaces the two lengths.

Run:  python benchmarks/bench_tv.py [--sizes 400 2000 10000 100000] [--scs]
          [--norms group l1] [--orders 1 2] [--repeat 3]
          [--wide [--systems 4,2 5,2 6,4] [--T 1000 4000]]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from bench_sq import best_time

import ltvmodels as ltv
from ltvmodels.core.problem import state_space_problem

LAM = 17.0
WIDE = [(4, 2), (5, 2), (6, 4)]  # (n, m) of --wide
WIDE_LAM = 5.0


def wide_jump(n: int, m: int, T: int, seed: int = 0):
    """x (T, n), u (T, m): A switches between two random stable matrices at T/2."""
    rng = np.random.default_rng(seed)

    def stable():
        A = rng.standard_normal((n, n))
        return 0.9 * A / np.abs(np.linalg.eigvals(A)).max()

    A1, A2, B = stable(), stable(), rng.standard_normal((n, m))
    u = rng.standard_normal((T, m))
    x = np.zeros((T, n))
    for t in range(T - 1):
        x[t + 1] = (A1 if t < T // 2 else A2) @ x[t] + B @ u[t] + 0.2 * rng.standard_normal(n)
    return x, u


def wide(args) -> None:
    """The --wide table."""
    print(f"lam = {WIDE_LAM}, jump systems, order 1, tol = 1e-6")
    header = (
        f"{'norm':>5} {'n':>2} {'m':>2} {'K':>3} {'T':>5} {'solver':>14} {'ours [s]':>9} "
        f"{'iters':>6} {'Clarabel [s]':>12} {'ratio':>7} {'rel. gap':>9}"
    )
    print(header)
    print("-" * len(header))
    for norm in args.norms:
        for n, m in args.systems:
            for T in args.T:
                x, u = wide_jump(n, m, T)

                def ours():
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", ltv.ConvergenceWarning)
                        return ltv.fit(
                            x, u, lam=WIDE_LAM, norm=norm, compute_cov=False, max_iter=100_000
                        )

                ours()  # compile the kernels for this block size outside the timing
                took, model = best_time(ours, args.repeat)
                t_ref, (ref, _) = best_time(
                    lambda: cvxpy_solve(x, u, WIDE_LAM, norm, [-1.0, 1.0], "CLARABEL"), args.repeat
                )
                gap = (model.info["objective"] - ref) / abs(ref)
                line = (
                    f"{norm:>5} {n:>2} {m:>2} {n * (n + m):>3} {T:>5} "
                    f"{model.info['solver'][:14]:>14} {took:>9.3f} "
                    f"{model.info['iterations']:>6} {t_ref:>12.3f} {t_ref / took:>6.2f}x "
                    f"{gap:>9.1e}"
                )
                if not model.info["converged"]:
                    line += " (not converged)"
                print(line, flush=True)


def cvxpy_solve(x, u, lam, norm, coeffs, solver):
    """Optimal value and wall time (canonicalization included) of the cvxpy model."""
    import cvxpy as cp

    pb = state_space_problem(x, u, np.asarray(coeffs, float))
    N, n, p = pb.N, pb.n, pb.p
    phi, y = pb.phi[:, 0], pb.y[:, 0]  # one trajectory: (N, p) and (N, n)
    start = time.perf_counter()
    theta = cp.Variable((N, n * p))
    fitted = [cp.sum(cp.multiply(theta[:, i * p : (i + 1) * p], phi), axis=1) for i in range(n)]
    loss = sum(cp.sum_squares(y[:, i] - fitted[i]) for i in range(n))
    d = len(coeffs) - 1
    Dk = sum(coeffs[j] * theta[j : N - d + j, :] for j in range(d + 1))
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
    parser.add_argument(
        "--repeat",
        type=int,
        default=3,
        help="runs of each solver (ours and Clarabel); the best counts",
    )
    parser.add_argument("--norms", nargs="+", default=["group", "l1"], choices=["group", "l1"])
    parser.add_argument("--orders", nargs="+", type=int, default=[1, 2], choices=[1, 2])
    parser.add_argument(
        "--max-reference-T", type=int, default=10000, help="largest T at which cvxpy is run"
    )
    parser.add_argument(
        "--wide", action="store_true", help="time wider models (K = 24, 35, 60) instead"
    )
    parser.add_argument(
        "--systems",
        nargs="+",
        type=lambda text: tuple(int(v) for v in text.split(",")),
        default=WIDE,
        help="(n, m) of the --wide jump systems, as n,m",
    )
    parser.add_argument("--T", nargs="+", type=int, default=[1000, 4000], help="--wide lengths")
    args = parser.parse_args()
    if args.wide:
        wide(args)
        return

    warm = ltv.systems.jump_linear(T=1000, change_at=500, seed=1)
    for norm in ("group", "l1"):  # compile the kernels outside the timings
        for order in (1, 2):
            ltv.fit(warm.x, warm.u, lam=LAM, norm=norm, order=order)

    header = (
        f"{'norm':>5} {'order':>5} {'T':>6} {'ours [s]':>9} {'iters':>6} "
        f"{'Clarabel [s]':>12} {'ratio':>7} {'per repeat':>13} {'rel. gap':>9}"
        + ("  SCS [s]" if args.scs else "")
    )
    print(f"lam = {LAM}, jump-linear system (n=2, m=1), tol = 1e-6")
    print(header)
    print("-" * len(header))
    for norm in args.norms:
        for order in args.orders:
            coeffs = [-1.0, 1.0] if order == 1 else [1.0, -2.0, 1.0]
            for T in args.sizes:
                data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=0)
                # Ours and Clarabel alternate, so that both see the same load; each
                # repeat gives a ratio, and their range is the spread.
                times, ref_times = [], []
                ref = float("nan")
                for _ in range(args.repeat):
                    start = time.perf_counter()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", ltv.ConvergenceWarning)
                        model = ltv.fit(data.x, data.u, lam=LAM, norm=norm, order=order)
                    times.append(time.perf_counter() - start)
                    if T <= args.max_reference_T:
                        try:
                            ref, t_ref = cvxpy_solve(data.x, data.u, LAM, norm, coeffs, "CLARABEL")
                        except ImportError:
                            continue
                        ref_times.append(t_ref)
                ours = min(times)
                t_ref = min(ref_times, default=float("nan"))
                ratios = [r / o for o, r in zip(times, ref_times)] or [float("nan")]
                gap = (model.info["objective"] - ref) / abs(ref)
                line = (
                    f"{norm:>5} {order:>5} {T:>6} {ours:>9.3f} {model.info['iterations']:>6} "
                    f"{t_ref:>12.3f} {t_ref / ours:>6.2f}x {min(ratios):>6.2f}-{max(ratios):<6.2f} "
                    f"{gap:>9.1e}"
                )
                if not model.info["converged"]:
                    line += " (not converged)"
                if args.scs and T <= args.max_reference_T:
                    _, t_scs = cvxpy_solve(data.x, data.u, LAM, norm, coeffs, "SCS")
                    line += f" {t_scs:>8.2f}"
                print(line)


if __name__ == "__main__":
    main()
