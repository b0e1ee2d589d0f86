"""Benchmark: exact L0 segmentation (fit_segments) against ruptures' Dynp and Pelt.

Data: a switching state-space system x[t+1] = A_s x[t] + B_s u[t] + v[t] whose
(A_s, B_s) (random, stable) change at M evenly spaced times, M = 1 and 3.
ruptures applies to single-output regressions, so the comparison uses one
state and two inputs (n = 1, m = 2, p = 3): ruptures' ``model="linear"`` cost
of a segment is the residual sum of squares of the least-squares regression of
signal[:, 0] on signal[:, 1:], and with signal = [x[1:], x[:-1], u[:-1]] that
is exactly our segment cost. Both run exactly (ruptures ``jump=1``) with the
same minimum segment size (ours by default: p = 3) on the same data in the
same process:

* Dynp vs ``fit_segments(x, u, n_changes=M)``, M = 1, 3;
* Pelt vs ``fit_segments(x, u, penalty=β)`` with the same β (our "bic" value
  for the data).

Printed: times, ratio, breakpoints and costs (Dynp: residual sum of squares;
Pelt: cost + β·#changes), ruptures' costs recomputed with its own cost
object. Then our multi-output timings (n = 3, m = 2) at the same sizes and the
penalized fit at T = 1e4.

With ``--peer strucchange``: break points of a regression against R's
strucchange ``breakpoints``. White noise y of T samples (seeded), the model
y ~ 1 (a mean that may change), 5 breaks, minimum segment h = 0.05 · T, the
setting in which strucchange's dynamic program takes about a minute at
T = 2,000. Both find the exact optimum; the breaks must be equal. For each T:
``segment_regression(y, 1, n_changes=5, trim=0.05)`` here (best of
``--repeat``), and ``breakpoints(y ~ 1, h = 0.05, breaks = 5)`` in an R
subprocess, timed inside R (``system.time``: R's start and the data transfer
are not counted), stopped after ``--r-timeout`` seconds. Printed: both times,
the ratio, and whether the breaks agree; at the end, the largest T
strucchange finished within the time limit. Then the supF test of one break
on the same series: ``break_test(y, 1, kind="supF", trim=0.15)`` against
``sctest(Fstats(y ~ 1, from = 0.15), type = "supF")`` (timed inside R), the
statistics and the break location compared.

Run:  python benchmarks/bench_segments.py [--sizes 400 1000 2000] [--changes 1 3]
      [--large 10000] [--repeat 3] [--no-ruptures]
      python benchmarks/bench_segments.py --peer strucchange [--sizes 200 2000 10000]
      [--r-timeout 300]
ruptures is an optional dependency: ``pip install ".[bench]"``. Its exact
Dynp with M = 3 takes about 15 s at T = 1000 and 80 s at T = 2000.
strucchange needs ``Rscript`` (Debian: r-base-core, r-cran-strucchange).
"""

from __future__ import annotations

import argparse
import itertools
import shutil
import subprocess
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np

import ltvmodels as ltv


def switching_system(T: int, n: int, m: int, n_changes: int, seed: int = 0, noise: float = 0.1):
    """x (T, n), u (T, m) and the true change points of a random switching system."""
    rng = np.random.default_rng(seed)
    changes = [int(c) for c in np.linspace(0, T - 1, n_changes + 2)[1:-1]]
    u = rng.standard_normal((T, m))
    x = np.zeros((T, n))
    bounds = [0, *changes, T - 1]
    for a, b in itertools.pairwise(bounds):
        A = rng.standard_normal((n, n))
        A *= 0.9 / np.abs(np.linalg.eigvals(A)).max()
        B = rng.standard_normal((n, m))
        for t in range(a, b):
            x[t + 1] = A @ x[t] + B @ u[t] + noise * rng.standard_normal(n)
    return x, u, changes


def best_time(func, repeat: int):
    """Smallest wall time over ``repeat`` runs, and the last result."""
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - start)
    return best, result


def once(func):
    start = time.perf_counter()
    result = func()
    return time.perf_counter() - start, result


def ruptures_cost(signal: np.ndarray, bkps: list[int]) -> float:
    """Σ of ruptures' CostLinear over the segments of ``bkps`` (ends, last = N)."""
    import ruptures as rpt

    cost = rpt.costs.CostLinear().fit(signal)
    return float(sum(cost.error(a, b) for a, b in itertools.pairwise([0, *bkps])))


def ruptures_dynp(signal: np.ndarray, n_bkps: int) -> list[int]:
    """ruptures' exact Dynp (jump=1, min_size=3); breakpoints are segment ends, last = N."""
    import ruptures as rpt

    return rpt.Dynp(model="linear", min_size=3, jump=1).fit(signal).predict(n_bkps=n_bkps)


def ruptures_pelt(signal: np.ndarray, pen: float) -> list[int]:
    """ruptures' exact Pelt (jump=1, min_size=3)."""
    import ruptures as rpt

    return rpt.Pelt(model="linear", min_size=3, jump=1).fit(signal).predict(pen=pen)


def short(points) -> str:
    return "[" + " ".join(str(int(c)) for c in points) + "]"


BREAKS = 5
TRIM = 0.05

R_TEST_SCRIPT = """
suppressMessages(library(strucchange))
y <- scan("{data}", quiet = TRUE)
elapsed <- system.time(test <- sctest(fs <- Fstats(y ~ 1, from = 0.15), type = "supF"))
cat(elapsed[["elapsed"]], sprintf("%.10g", test$statistic), fs$breakpoint, "\\n")
"""

R_SCRIPT = """
suppressMessages(library(strucchange))
y <- scan("{data}", quiet = TRUE)
elapsed <- system.time(bp <- breakpoints(y ~ 1, h = {trim}, breaks = {breaks}))[["elapsed"]]
cat(elapsed, breakpoints(bp, breaks = {breaks})$breakpoints, "\\n")
"""


def ours_breakpoints(y: np.ndarray, repeat: int) -> tuple[float, list[int]]:
    """Best time of our exact segmentation, and its breaks (strucchange's numbering)."""
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = ltv.segment_regression(y, np.ones((y.size, 1)), n_changes=BREAKS, trim=TRIM)
        best = min(best, time.perf_counter() - start)
    return best, result.changepoints.tolist()


def strucchange(
    y: np.ndarray, timeout: float, template: str = R_SCRIPT
) -> tuple[float, list[float]] | None:
    """strucchange's time (inside R) and what ``template`` prints after it (the breaks),
    or None when it did not finish in time."""
    with tempfile.TemporaryDirectory() as directory:
        data = Path(directory) / "y.txt"
        np.savetxt(data, y)
        script = template.format(data=data, trim=TRIM, breaks=BREAKS)
        try:
            run = subprocess.run(
                ["Rscript", "-e", script], capture_output=True, text=True, timeout=timeout
            )
        except subprocess.TimeoutExpired:
            return None
    if run.returncode != 0:
        raise RuntimeError(f"R failed: {run.stderr.strip()}")
    values = run.stdout.split()
    return float(values[0]), [float(v) for v in values[1:]]


def strucchange_comparison(sizes: list[int], repeat: int, r_timeout: float) -> None:
    """Print ours against strucchange's breakpoints at each T (see the module docstring)."""
    if shutil.which("Rscript") is None:
        raise SystemExit("Rscript is not installed (Debian: r-base-core, r-cran-strucchange)")
    ltv.segment_regression(np.random.default_rng(0).standard_normal(200), np.ones((200, 1)))
    print(f"white noise, y ~ 1, {BREAKS} breaks, h = {TRIM}")
    print(f"{'T':>7}  {'ours (s)':>10}  {'strucchange (s)':>15}  {'ratio':>8}  breaks equal")
    largest = None
    for T in sizes:
        y = np.random.default_rng(T).standard_normal(T)
        our_time, our_breaks = ours_breakpoints(y, repeat)
        peer = strucchange(y, r_timeout)
        if peer is None:
            print(f"{T:7d}  {our_time:10.4f}  {'> ' + str(r_timeout):>15}  {'':>8}  —")
            continue
        largest = T
        peer_time, peer_breaks = peer[0], [int(v) for v in peer[1]]
        print(
            f"{T:7d}  {our_time:10.4f}  {peer_time:15.2f}  {peer_time / our_time:7.0f}x  "
            f"{our_breaks == peer_breaks} {our_breaks}"
        )
    print(f"largest T strucchange finished within {r_timeout:g} s: {largest}")
    print("\nsupF test of one break, y ~ 1, trim 0.15 (the same series)")
    print(f"{'T':>7}  {'ours (s)':>10}  {'strucchange (s)':>15}  {'ratio':>8}  equal")
    ltv.break_test(np.random.default_rng(0).standard_normal(200), np.ones(200))
    for T in sizes:
        y = np.random.default_rng(T).standard_normal(T)
        ones = np.ones(T)
        our_time, test = best_time(partial(ltv.break_test, y, ones, kind="supF"), repeat)
        peer = strucchange(y, r_timeout, R_TEST_SCRIPT)
        if peer is None:
            print(f"{T:7d}  {our_time:10.5f}  {'> ' + str(r_timeout):>15}")
            continue
        peer_time, (statistic, location) = peer
        same = abs(test.statistic - statistic) <= 1e-6 * abs(statistic) and (
            test.break_index == int(location)
        )
        print(
            f"{T:7d}  {our_time:10.5f}  {peer_time:15.3f}  {peer_time / our_time:7.0f}x  "
            f"{same} (supF {test.statistic:.6g} at {test.break_index})"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--peer", choices=["ruptures", "strucchange"], default="ruptures", help="the peer"
    )
    parser.add_argument(
        "--sizes",
        nargs="+",
        type=int,
        default=None,
        help="T (default: 400 1000 2000; with --peer strucchange: 200 2000 10000)",
    )
    parser.add_argument("--r-timeout", type=float, default=300.0, help="seconds per R run")
    parser.add_argument("--changes", nargs="+", type=int, default=[1, 3])
    parser.add_argument("--large", type=int, default=10000, help="T of the penalized run (0: skip)")
    parser.add_argument("--repeat", type=int, default=3, help="runs of ours (best time kept)")
    parser.add_argument("--no-ruptures", action="store_true", help="time ours only")
    args = parser.parse_args()
    if args.peer == "strucchange":
        strucchange_comparison(args.sizes or [200, 2000, 10000], args.repeat, args.r_timeout)
        return
    args.sizes = args.sizes or [400, 1000, 2000]

    rpt = None
    if not args.no_ruptures:
        try:
            import ruptures as rpt
        except ImportError:
            print("ruptures not installed: timing ours only (pip install ruptures)")

    x, u, _ = switching_system(60, 1, 2, 1)  # compile the kernels outside the timings
    ltv.fit_segments(x, u, n_changes=1)
    ltv.fit_segments(x, u, penalty="bic")

    print("single output (n = 1, m = 2, p = 3), min_size = 3, ruptures jump = 1 (exact)")
    header = (
        f"{'method':8} {'T':>5} {'M':>2} {'ours s':>8} {'rupt. s':>8} {'ratio':>7}  "
        f"{'cost ours':>12} {'cost rupt.':>12} {'rel.diff':>8}  breakpoints ours / ruptures"
    )
    print(header)
    print("-" * len(header))
    for T, M in itertools.product(args.sizes, args.changes):
        x, u, truth = switching_system(T, 1, 2, M, seed=T + M)
        signal = np.column_stack([x[1:, 0], x[:-1], u[:-1]])
        t_ours, model = best_time(partial(ltv.fit_segments, x, u, n_changes=M), args.repeat)
        ours_cost = model.info["cost"]
        row = f"{'Dynp':8} {T:5d} {M:2d} {t_ours:8.4f} "
        if rpt is not None:
            t_r, bkps = once(partial(ruptures_dynp, signal, M))
            r_cost = ruptures_cost(signal, bkps)
            row += (
                f"{t_r:8.2f} {t_r / t_ours:7.0f}  {ours_cost:12.6f} {r_cost:12.6f} "
                f"{abs(ours_cost - r_cost) / r_cost:8.1e}  "
                f"{short(model.changepoints)} / {short(bkps[:-1])}"
            )
        else:
            row += f"{'-':>8} {'-':>7}  {ours_cost:12.6f}  {short(model.changepoints)}"
        print(row, f"(true {short(truth)})", flush=True)

        beta = ltv.fit_segments(x, u, penalty="bic").info["penalty"]
        t_ours, model = best_time(partial(ltv.fit_segments, x, u, penalty=beta), args.repeat)
        ours_obj = model.info["objective"]
        row = f"{'Pelt':8} {T:5d} {M:2d} {t_ours:8.4f} "
        if rpt is not None:
            t_r, bkps = once(partial(ruptures_pelt, signal, beta))
            r_obj = ruptures_cost(signal, bkps) + beta * (len(bkps) - 1)
            row += (
                f"{t_r:8.2f} {t_r / t_ours:7.0f}  {ours_obj:12.6f} {r_obj:12.6f} "
                f"{abs(ours_obj - r_obj) / r_obj:8.1e}  "
                f"{short(model.changepoints)} / {short(bkps[:-1])}"
            )
        else:
            row += f"{'-':>8} {'-':>7}  {ours_obj:12.6f}  {short(model.changepoints)}"
        print(row, f"(β = {beta:.4g})", flush=True)

    print()
    print("multi-output (n = 3, m = 2, p = 5, K = 15), ours only; times in s")
    print(f"{'T':>6} {'M':>2} {'DP n_changes=M':>15} {'PELT bic':>9}  found (DP / PELT)")
    for T, M in itertools.product(args.sizes, args.changes):
        x, u, truth = switching_system(T, 3, 2, M, seed=T + M)
        t_dp, dp = best_time(partial(ltv.fit_segments, x, u, n_changes=M), args.repeat)
        t_pelt, pelt = best_time(partial(ltv.fit_segments, x, u, penalty="bic"), args.repeat)
        print(
            f"{T:6d} {M:2d} {t_dp:15.4f} {t_pelt:9.4f}  {short(dp.changepoints)} / "
            f"{short(pelt.changepoints)} (true {short(truth)})",
            flush=True,
        )

    if args.large:
        T = args.large
        print()
        print(f"penalized (bic) at T = {T}, ours only; times in s")
        print(f"{'n':>2} {'m':>2} {'M true':>6} {'PELT':>8}  found")
        for (n, m), M in itertools.product([(1, 2), (3, 2)], [3, 9]):
            x, u, truth = switching_system(T, n, m, M, seed=M)
            t, model = best_time(partial(ltv.fit_segments, x, u, penalty="bic"), args.repeat)
            ok = "= true" if model.changepoints.tolist() == truth else f"true {short(truth)}"
            print(f"{n:2d} {m:2d} {M:6d} {t:8.3f}  {short(model.changepoints)} ({ok})", flush=True)


if __name__ == "__main__":
    main()
