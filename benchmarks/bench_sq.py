"""Benchmark: norm="sq" (exact, banded) against statsmodels' Kalman smoother.

On the random-walk system (n = 3, m = 2, K = 15 parameters) this times
``ltvmodels.fit(norm="sq")`` with posterior covariances for orders 1 and 2 at
T = 1e4, 1e5, 1e6 and, in the same process on the same data, statsmodels'
state-space Kalman smoother of the same model (time-varying design
I_n ⊗ φ_tᵀ, identity transition, exact diffuse initialization) at T = 1e4 and
1e5. It prints times, the speed ratio, the agreement of the smoothed means
and the peak memory. Optionally pykalman (``--pykalman``, slow).

Run:  python benchmarks/bench_sq.py [--sizes 1e4 1e5 1e6] [--repeat 3]
Peers are optional: ``pip install ".[bench]"``.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

import ltvmodels as ltv
from ltvmodels.systems import random_walk_system

LAM = 30.0
NOISE_VAR = 0.01


def best_time(func, repeat: int) -> tuple[float, object]:
    """Smallest wall time over ``repeat`` runs, and the last result."""
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - start)
    return best, result


def statsmodels_smoother(x: np.ndarray, u: np.ndarray):
    """Smoothed parameters (N, K) from statsmodels' KalmanSmoother."""
    from statsmodels.tsa.statespace.kalman_smoother import KalmanSmoother

    n = x.shape[1]
    phi = np.hstack([x[:-1], u[:-1]])
    N, p = phi.shape
    K = n * p
    design = np.einsum("ij,ta->ijat", np.eye(n), phi).reshape(n, K, N)
    ks = KalmanSmoother(k_endog=n, k_states=K, k_posdef=K)
    ks.bind(np.asfortranarray(x[1:].T))
    ks["design"] = design
    ks["obs_cov"] = NOISE_VAR * np.eye(n)
    ks["transition"] = np.eye(K)
    ks["selection"] = np.eye(K)
    ks["state_cov"] = NOISE_VAR / LAM**2 * np.eye(K)
    ks.initialize_diffuse()
    return ks.smooth().smoothed_state.T


def pykalman_smoother(x: np.ndarray, u: np.ndarray):
    """Smoothed parameters (N, K) from pykalman (approximately diffuse start)."""
    from pykalman import KalmanFilter

    n = x.shape[1]
    phi = np.hstack([x[:-1], u[:-1]])
    N, p = phi.shape
    K = n * p
    design = np.einsum("ij,ta->tija", np.eye(n), phi).reshape(N, n, K)
    kf = KalmanFilter(
        transition_matrices=np.eye(K),
        observation_matrices=design,
        transition_covariance=NOISE_VAR / LAM**2 * np.eye(K),
        observation_covariance=NOISE_VAR * np.eye(n),
        initial_state_mean=np.zeros(K),
        initial_state_covariance=1e6 * np.eye(K),
    )
    return kf.smooth(x[1:])[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e4, 1e5, 1e6])
    parser.add_argument(
        "--peer-max", type=float, default=1e5, help="largest T at which peers run (default 1e5)"
    )
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--pykalman", action="store_true", help="also time pykalman (slow)")
    args = parser.parse_args()

    warm = random_walk_system(T=200, n=3, m=2, seed=1)
    for order in (1, 2):  # compile the kernels outside the timings
        ltv.fit(warm.x, warm.u, lam=LAM, order=order, noise_var=NOISE_VAR)

    print(f"norm='sq', n=3, m=2 (K=15), lam={LAM}, noise_var={NOISE_VAR}, covariances on")
    header = (
        f"{'T':>9} {'order':>5} {'ltvmodels [s]':>14} {'statsmodels [s]':>16} "
        f"{'ratio':>7} {'max|Δk|':>9}"
    )
    print(header)
    print("-" * len(header))
    for size in args.sizes:
        T = int(size)
        data = random_walk_system(T=T, n=3, m=2, drift_std=1e-3, noise_std=0.1, seed=0)
        peer_time = peer_k = None
        if T <= args.peer_max:
            try:
                peer_time, peer_k = best_time(
                    lambda data=data: statsmodels_smoother(data.x, data.u), 1
                )
            except ImportError:
                pass
        for order in (1, 2):
            ours, model = best_time(
                lambda data=data, order=order: ltv.fit(
                    data.x, data.u, lam=LAM, order=order, noise_var=NOISE_VAR
                ),
                args.repeat if T < 10**6 else max(1, args.repeat - 1),
            )
            if order == 1 and peer_time is not None:
                diff = np.abs(model.k - peer_k).max()
                print(
                    f"{T:>9} {order:>5} {ours:>14.4f} {peer_time:>16.3f} "
                    f"{peer_time / ours:>6.0f}x {diff:>9.1e}"
                )
            else:
                print(f"{T:>9} {order:>5} {ours:>14.4f} {'-':>16} {'-':>7} {'-':>9}")
            del model
    if args.pykalman:
        T = int(min(args.peer_max, 1e4))
        data = random_walk_system(T=T, n=3, m=2, seed=0)
        pk_time, _ = best_time(lambda: pykalman_smoother(data.x, data.u), 1)
        ours, _ = best_time(lambda: ltv.fit(data.x, data.u, lam=LAM, noise_var=NOISE_VAR), 3)
        print(f"pykalman T={T}: {pk_time:.3f} s vs ltvmodels {ours:.4f} s ({pk_time / ours:.0f}x)")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak resident memory of this process: {peak:.0f} MiB")


if __name__ == "__main__":
    main()
