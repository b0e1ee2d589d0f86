"""Benchmark: per-call time of small fits (the many-series use: thousands of short series).

Times ``ltv.fit`` on the paper's jump-linear system (n = 2, m = 1, a switch
at T/2) for the calls a loop over many short series repeats: the squared norm
at a fixed λ (with and without covariances), λ chosen by maximum marginal
likelihood (``lam="auto"``), and the group norm at a fixed λ. Each case is
called once to compile (numba) and warm up, then timed ``--repeat`` times in
a loop; printed is the best of ``--rounds`` rounds, in ms per call (the best
is the least disturbed by other work on the machine).

Run:  python benchmarks/bench_small_fits.py [--T 500] [--repeat 200] [--rounds 5]
          [--only auto] [--profile CASE]

``--profile CASE`` prints cProfile's 25 most expensive functions of that case
(by total and by cumulative time) instead of the timings.
"""

from __future__ import annotations

import argparse
import time

import ltvmodels as ltv

CASES = {
    "sq lam=10": dict(lam=10.0),
    "sq lam=10 no cov": dict(lam=10.0, compute_cov=False),
    "sq lam=auto": dict(lam="auto"),
    "group lam=10": dict(lam=10.0, norm="group"),
}


def per_call_ms(x, u, options: dict, repeat: int, rounds: int) -> float:
    """Best of ``rounds`` loops of ``repeat`` calls, in ms per call."""
    ltv.fit(x, u, **options)  # compile and warm up
    best = float("inf")
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(repeat):
            ltv.fit(x, u, **options)
        best = min(best, (time.perf_counter() - start) / repeat)
    return 1e3 * best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--T", type=int, default=500)
    parser.add_argument("--repeat", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--only", choices=sorted(CASES), nargs="*")
    parser.add_argument("--profile", choices=sorted(CASES))
    args = parser.parse_args()
    data = ltv.systems.jump_linear(T=args.T, change_at=args.T // 2, seed=0)
    x, u = data.x, data.u
    if args.profile:
        import cProfile
        import pstats

        options = CASES[args.profile]
        ltv.fit(x, u, **options)
        profiler = cProfile.Profile()
        profiler.enable()
        for _ in range(args.repeat):
            ltv.fit(x, u, **options)
        profiler.disable()
        stats = pstats.Stats(profiler)
        print(f"{stats.total_calls / args.repeat:.0f} calls per fit")
        stats.sort_stats("tottime").print_stats(25)
        stats.sort_stats("cumtime").print_stats(25)
        return
    print(f"jump-linear, T = {args.T}, n = 2, m = 1; best of {args.rounds} x {args.repeat}")
    for name in args.only or CASES:
        repeat = max(1, args.repeat // 10) if "auto" in name or "group" in name else args.repeat
        ms = per_call_ms(x, u, CASES[name], repeat, args.rounds)
        print(f"  fit {name:<20s} {ms:8.3f} ms per call")


if __name__ == "__main__":
    main()
