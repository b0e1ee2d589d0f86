"""Benchmark: loss="huber" (or "laplace") against the squared loss, same data, norm and run.

norm="sq": the random-walk system (n = 3 states, m = 2 inputs) with 5 % of
the transitions hit by gross outliers (+5 standard deviations of the state in
one coordinate; ``--fraction``, ``--sigmas``), λ = 30. norm="group": the
jump-linear system (change in the middle) with 5 % of the samples hit by +5σ
(σ = 0.2, the noise level), λ = 8. ``fit(x, u, lam=λ, norm=norm)`` and
``fit(..., loss=loss)`` (default δ, tol 1e-6) are timed back to back in each
of ``--repeat`` rounds, after a warm-up that compiles the kernels. Prints the
best times, their ratio and the spread (min / median / max) of the rounds'
ratios, and the number of steps (Newton steps for "sq" Huber, interior-point
iterations otherwise). Other processes on the machine change the times, not
much the ratio of two fits timed back to back: compare ratios.

With ``--check-size T0`` (default 2000; 0 skips it) the same problem at
T = T0 is also solved by cvxpy with Clarabel (λ²Σ‖Dk‖² for "sq", the model's
δ for Huber), and the relative objective gap (ours − Clarabel) / Clarabel is
printed: the speed is only worth something at the same optimum.

Targets (issue): at T = 1e5 with norm="sq", Huber within 5x and Laplace within
10x the squared-loss fit; for "group", Huber within 3x at T = 1e4.

Run:  python benchmarks/bench_huber.py [--norm sq] [--sizes 10000 100000] [--repeat 5]
      python benchmarks/bench_huber.py --norm sq --sizes 100000 --loss laplace
      python benchmarks/bench_huber.py --norm group --sizes 10000 [--loss laplace]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import ltvmodels as ltv


def data_for(norm: str, T: int, fraction: float, sigmas: float):
    """(x, u, λ) of the benchmark problem of size T."""
    rng = np.random.default_rng(0)
    hit = rng.choice(np.arange(1, T), size=int(fraction * T), replace=False)
    if norm == "sq":
        data = ltv.systems.random_walk_system(T=T, seed=0)
        x = data.x.copy()
        x[hit, 0] += sigmas * np.std(x[:, 0])
        return x, data.u, 30.0
    data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=0)
    x = data.x.copy()
    x[hit, rng.integers(0, 2, size=hit.size)] += sigmas * 0.2
    return x, data.u, 8.0


def clarabel_objective(x, u, lam: float, norm: str, loss: str, delta) -> float:
    """The optimal value of the same problem by cvxpy with Clarabel."""
    import cvxpy as cp

    n, p = x.shape[1], x.shape[1] + u.shape[1]
    N = x.shape[0] - 1
    phi, y = np.hstack([x[:-1], u[:-1]]), x[1:]
    k = cp.Variable((N, n * p))
    terms = []
    for i in range(n):
        resid = y[:, i] - cp.sum(cp.multiply(phi, k[:, i * p : (i + 1) * p]), axis=1)
        terms.append(cp.sum(cp.huber(resid, delta[i]) if loss == "huber" else cp.abs(resid)))
    Dk = k[1:] - k[:-1]
    if norm == "sq":
        terms.append(lam**2 * cp.sum_squares(Dk))
    elif norm == "group":
        terms.append(lam * cp.sum(cp.norm(Dk, 2, axis=1)))
    else:
        terms.append(lam * cp.sum(cp.abs(Dk)))
    problem = cp.Problem(cp.Minimize(sum(terms)))
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    return float(problem.value)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--norm", choices=["sq", "group", "l1"], default="sq")
    parser.add_argument("--loss", choices=["huber", "laplace"], default="huber")
    parser.add_argument("--fraction", type=float, default=0.05, help="share of samples hit")
    parser.add_argument("--sigmas", type=float, default=5.0, help="outlier size in std. devs")
    parser.add_argument("--check-size", type=int, default=2000, help="T of the Clarabel check")
    args = parser.parse_args()
    norm, loss = args.norm, args.loss
    x0, u0, lam = data_for(norm, 200, args.fraction, args.sigmas)
    ltv.fit(x0, u0, lam=lam, norm=norm, loss=loss)  # compile
    print(
        f"norm={norm}, loss={loss}, {args.fraction:.0%} of samples hit by +{args.sigmas:g} sd, "
        f"lam = {lam:g}, {args.repeat} rounds"
    )
    for T in args.sizes:
        x, u, lam = data_for(norm, T, args.fraction, args.sigmas)
        squared_times, robust_times = [], []
        model = None
        for _ in range(args.repeat):
            start = time.perf_counter()
            ltv.fit(x, u, lam=lam, norm=norm)
            squared_times.append(time.perf_counter() - start)
            start = time.perf_counter()
            model = ltv.fit(x, u, lam=lam, norm=norm, loss=loss)
            robust_times.append(time.perf_counter() - start)
        assert model is not None
        ratios = np.array(robust_times) / np.array(squared_times)
        squared, robust = min(squared_times), min(robust_times)
        inner = model.info.get("inner_iterations")
        outliers = model.info.get("n_outliers")
        print(
            f"T = {T:7d}: squared {squared:7.3f} s, {loss} {robust:7.3f} s "
            f"({model.status.iterations} steps"
            + (f", {inner} inner iterations" if inner else "")
            + (f", {outliers} outliers" if outliers is not None else "")
            + f"), ratio of bests {robust / squared:5.1f}x, per round min/median/max "
            f"{ratios.min():.1f}/{np.median(ratios):.1f}/{ratios.max():.1f}x"
        )
    if args.check_size:
        T = args.check_size
        x, u, lam = data_for(norm, T, args.fraction, args.sigmas)
        model = ltv.fit(x, u, lam=lam, norm=norm, loss=loss)
        delta = model.info.get("huber_delta")
        reference = clarabel_objective(x, u, lam, norm, loss, delta)
        ours = model.info["objective"]
        print(
            f"T = {T:7d}: objective {ours:.10g}, Clarabel {reference:.10g}, "
            f"relative gap {(ours - reference) / abs(reference):+.2e} ({model.status.status})"
        )


if __name__ == "__main__":
    main()
