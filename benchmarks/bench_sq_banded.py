"""Benchmark: norm="sq" against scipy's banded Cholesky of the same normal equations.

On the random-walk system (n = 3 states, m = 2 inputs: p = 5 regressors,
K = 15 parameters per step; order 1, λ = 30) this times, in one process on
the same data:

* ``ltvmodels.fit(x, u, norm="sq", compute_cov=False)`` and with covariances
  (from the raw arrays: validation, regressors, factorization, solution);
* scipy: the normal equations H θ_i = Φᵀ y_i (H = blkdiag_t φ_tφ_tᵀ + λ²DᵀD ⊗ I_p,
  one matrix for the n output rows) assembled in LAPACK's banded storage with
  numpy from φ and y, then ``scipy.linalg.cholesky_banded`` and
  ``cho_solve_banded`` — the time with the assembly, and of factor + solve
  alone;

and the time to stream the fit's arrays once through memory: the bytes of x
and u read and of θ (and the covariance blocks) written, at the bandwidth of a
large ``np.copyto`` measured here. Each time is the best of ``--repeat`` runs;
max |Δθ| is the agreement of the two solutions.

``--one-shot`` instead times the same ``fit(..., compute_cov=False)`` as a
script's only call: each repeat starts a fresh interpreter (numba's cache
already filled by this process's warm-up), makes the data, and times the
first fit; another fresh interpreter measures the fit's peak traced
allocations (tracemalloc: peak during the call less what was traced before
it, divided by T). The same call repeated in this process gives the repeated
best. Printed: one-shot best and spread, repeated best and spread, the
ratio of the bests, its range and the ratio of the medians (a one-shot call
that found its memory already mapped by chance makes the best fast, not the
median), the peak bytes per step, and what the memory alone costs: the median time
a fresh interpreter takes, after making the same data, to write as many bytes as
the fit's traced peak for the first time (without the fit's work), and the ratio
of the repeated best plus that write to the repeated best. Each fresh interpreter
starts ``--pause`` seconds after the last one ended: memory that a process freed a
moment ago can come back to the next one already mapped by the host (a virtual
machine whose host reclaims the guest's free memory takes about 2 s to do so),
which made a one-shot call as fast as a repeated one by chance.

Run:  python benchmarks/bench_sq_banded.py [--sizes 1e4 1e5 1e6] [--repeat 3]
      python benchmarks/bench_sq_banded.py --one-shot [--sizes 1e6] [--repeat 5] [--pause 3]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import textwrap
import time

import numpy as np
from bench_sq import best_time
from scipy.linalg import cho_solve_banded, cholesky_banded

import ltvmodels as ltv
from ltvmodels.systems import random_walk_system

LAM = 30.0


def banded_normal_equations(phi: np.ndarray, y: np.ndarray, lam: float):
    """H in lower banded storage (p + 1, N·p) and the right-hand sides Φᵀy (N·p, n).

    Order 1: (DᵀD)_tt = 1 at the ends and 2 inside, (DᵀD)_{t+1,t} = −1, so H's
    diagonal block t is φ_tφ_tᵀ + λ²(DᵀD)_tt I and its off-diagonal block the
    scaled identity −λ² I, at band offset p.
    """
    N, p = phi.shape
    dtd = np.full(N, 2.0)
    dtd[[0, -1]] = 1.0
    ab = np.zeros((p + 1, N * p))
    for offset in range(p):  # ab[a − b, t·p + b] = H[t·p + a, t·p + b], a >= b
        b = np.arange(p - offset)
        ab[offset].reshape(N, p)[:, b] = phi[:, b + offset] * phi[:, b]
    ab[0] += np.repeat(lam**2 * dtd, p)
    ab[p, : (N - 1) * p] = -(lam**2)
    rhs = (phi[:, :, None] * y[:, None, :]).reshape(N * p, y.shape[1])
    return ab, rhs


def scipy_solve(phi, y, lam, ab=None, rhs=None):
    """θ (N, n, p) by scipy's banded Cholesky (assembling H unless given)."""
    if ab is None:
        ab, rhs = banded_normal_equations(phi, y, lam)
    factor = cholesky_banded(ab, lower=True)
    theta = cho_solve_banded((factor, True), rhs)
    N, p = phi.shape
    return theta.reshape(N, p, -1).transpose(0, 2, 1)


def factor_and_solve_time(phi: np.ndarray, y: np.ndarray, repeat: int) -> float:
    """scipy's best time for the factorization and solve alone (H assembled before)."""
    ab, rhs = banded_normal_equations(phi, y, LAM)
    seconds, _ = best_time(lambda: scipy_solve(phi, y, LAM, ab, rhs), repeat)
    return seconds


def bandwidth(megabytes: int = 800) -> float:
    """Bytes read and written per second by a large np.copyto (best of 3)."""
    source = np.ones(megabytes * 2**20 // 8)
    target = np.empty_like(source)
    seconds, _ = best_time(lambda: np.copyto(target, source), 3)
    return 2 * source.nbytes / seconds


# The child process of --one-shot: data made outside the timing, then one fit.
ONE_SHOT = textwrap.dedent(
    """
    import sys, time, tracemalloc
    import ltvmodels as ltv
    from ltvmodels.systems import random_walk_system

    T, lam, mode = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
    traced = mode == "traced"
    data = random_walk_system(T=T, n=3, m=2, drift_std=1e-3, noise_std=0.1, seed=0)
    fit = ltv.fit  # the lazy import of the estimators, outside the timing
    if mode.startswith("touch="):  # the first write of that many bytes, nothing else
        import numpy as np
        block = np.empty(int(mode[6:]) // 8)
        start = time.perf_counter()
        block.fill(0.0)
        print(time.perf_counter() - start, 0)
        sys.exit()
    if traced:
        tracemalloc.start()
        before = tracemalloc.get_traced_memory()[0]
    start = time.perf_counter()
    model = fit(data.x, data.u, lam=lam, norm="sq", compute_cov=False)
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] - before if traced else 0
    print(seconds, peak)
    """
)


ONE_SHOT_TIMEOUT = 600.0  # seconds a fresh process may take before the benchmark gives up


def one_shot(T: int, mode: str, pause: float = 0.0) -> tuple[float, int]:
    """Wall time of the fit as a fresh process's only call (``mode`` "fit"), and its peak
    traced bytes ("traced"), or of the first write of B bytes after making the data
    ("touch=B"); the process started ``pause`` seconds from now."""
    time.sleep(pause)
    done = subprocess.run(
        [sys.executable, "-c", ONE_SHOT, str(T), str(LAM), mode],
        capture_output=True,
        text=True,
        check=True,
        timeout=ONE_SHOT_TIMEOUT,
    )
    seconds, peak = done.stdout.split()
    return float(seconds), int(peak)


def one_shot_rows(sizes: list[float], repeat: int, pause: float) -> None:
    """The --one-shot table: fresh process against the same call repeated in this one."""
    header = (
        f"{'T':>8} {'one-shot [s]':>13} {'spread':>13} {'repeated [s]':>13} {'spread':>13} "
        f"{'ratio':>6} {'ratio range':>12} {'medians':>8} {'peak B/step':>11} "
        f"{'peak write [s]':>14} {'+write':>6}"
    )
    print(header)
    print("-" * len(header))
    for size in sizes:
        T = int(size)
        fresh = [one_shot(T, "fit", pause=pause)[0] for _ in range(repeat)]
        _, peak = one_shot(T, "traced")
        touch = [one_shot(T, f"touch={peak}", pause=pause)[0] for _ in range(repeat)]
        data = random_walk_system(T=T, n=3, m=2, drift_std=1e-3, noise_std=0.1, seed=0)
        again = []
        for _ in range(repeat):
            start = time.perf_counter()
            ltv.fit(data.x, data.u, lam=LAM, norm="sq", compute_cov=False)
            again.append(time.perf_counter() - start)
        print(
            f"{T:>8} {min(fresh):>13.3f} {min(fresh):>6.2f}–{max(fresh):<6.2f} "
            f"{min(again):>13.3f} {min(again):>6.2f}–{max(again):<6.2f} "
            f"{min(fresh) / min(again):>5.2f}x "
            f"{min(fresh) / max(again):>5.2f}–{max(fresh) / min(again):<5.2f} "
            f"{np.median(fresh) / np.median(again):>7.2f}x "
            f"{peak / T:>11.0f} "
            f"{np.median(touch):>14.3f} {(min(again) + np.median(touch)) / min(again):>5.2f}x",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e4, 1e5, 1e6])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--one-shot",
        action="store_true",
        help="time the fit (no covariances) in fresh processes against repeated calls",
    )
    parser.add_argument(
        "--pause",
        type=float,
        default=3.0,
        help="seconds between --one-shot processes (0: as fast as they come)",
    )
    args = parser.parse_args()
    warm = random_walk_system(T=2000, n=3, m=2, seed=1)
    ltv.fit(warm.x, warm.u, lam=LAM)  # compile the kernels outside the timings
    ltv.fit(warm.x, warm.u, lam=LAM, compute_cov=False)
    if args.one_shot:
        print(
            f"norm='sq', n=3, m=2 (p=5, K=15), order 1, lam={LAM}, no covariances; "
            f"{args.pause:g} s between fresh processes"
        )
        one_shot_rows(args.sizes, args.repeat, args.pause)
        return
    speed = bandwidth()
    print(
        f"norm='sq', n=3, m=2 (p=5, K=15), order 1, lam={LAM}; memory copy "
        f"{speed / 1e9:.1f} GB/s (read + write)"
    )
    header = (
        f"{'T':>8} {'ours [s]':>9} {'+cov [s]':>9} {'scipy [s]':>10} {'factor+solve':>12} "
        f"{'ratio':>6} {'ratio f+s':>9} {'stream [s]':>10} {'/stream':>8} "
        f"{'+cov/str.':>9} {'max|Δθ|':>8}"
    )
    print(header)
    print("-" * len(header))
    for size in args.sizes:
        T = int(size)
        data = random_walk_system(T=T, n=3, m=2, drift_std=1e-3, noise_std=0.1, seed=0)
        x, u = data.x, data.u
        ours, model = best_time(lambda: ltv.fit(x, u, lam=LAM, compute_cov=False), args.repeat)
        theta = model.k.reshape(T - 1, 3, 5)
        del model
        with_cov, model = best_time(lambda: ltv.fit(x, u, lam=LAM), args.repeat)
        cov_bytes = model.cov.nbytes  # the (N, n, p, p) blocks the model holds
        del model
        phi, y = np.hstack([x[:-1], u[:-1]]), x[1:]
        peer, reference = best_time(lambda: scipy_solve(phi, y, LAM), args.repeat)
        factor_solve = factor_and_solve_time(phi, y, args.repeat)
        streamed = x.nbytes + u.nbytes + theta.nbytes
        stream = streamed / speed  # each byte read or written once
        stream_cov = (streamed + cov_bytes) / speed
        print(
            f"{T:>8} {ours:>9.4f} {with_cov:>9.4f} {peer:>10.4f} {factor_solve:>12.4f} "
            f"{peer / ours:>5.1f}x {factor_solve / ours:>8.1f}x {stream:>10.4f} "
            f"{ours / stream:>7.0f}x {with_cov / stream_cov:>8.0f}x "
            f"{np.abs(theta - reference).max():>8.1e}",
            flush=True,
        )


if __name__ == "__main__":
    main()
