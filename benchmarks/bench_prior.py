"""Benchmark: the cart-pole learning loop with the learned mixture prior.

One run of ``ltvmodels.apps.rl.learn(cartpole_task(), "learned")`` with the
settings of ``examples/rl_cartpole.py`` (14 iterations, the first run of
``run_experiment(seed=0)``: the exploration noise of the first child of
``numpy.random.SeedSequence(0)``). From the fourth iteration on each fit is
``ltvmodels.fit(norm="sq", order=2)`` with the mixture's time-varying 24 × 24
prior, whose noise variance is the maximum of log p(y | prior, σ²) (see
``ltvmodels.core.squared``). Printed per run: the wall time, the best and the
spread (max − min) of ``--repeat`` runs, the rollout costs (the loop's
outcome), and from one more run under cProfile the time inside the σ² search,
the fits that searched and the σ² candidates each evaluated (the
factorizations of the data's normal equations the search made: one per
candidate).

``--compare SRC`` measures this checkout (the ``ltvmodels`` on the path) and
the package in the folder ``SRC`` (e.g. an export of another revision's
``src``) alternately, each run in a fresh process (compiled kernels from
numba's cache, a warm-up run untimed), so that both see the same load of the
machine; it prints both and the ratio of the best times.

Run:  python benchmarks/bench_prior.py [--repeat 3] [--iterations 14] [--seed 0]
          [--compare path/to/other/src] [--json out.json]
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import statistics
import subprocess
import sys
import time

import numpy as np

SEARCH = "_ml_noise_var_with_prior"  # the σ² search of core/squared.py, looked up by name


def one_run(iterations: int, seed: int):
    from ltvmodels.apps.rl import cartpole_task, learn

    child = np.random.SeedSequence(seed).spawn(1)[0]
    return learn(
        cartpole_task(), "learned", iterations=iterations, seed=np.random.default_rng(child)
    )


def candidates_per_search(iterations: int, seed: int) -> dict[str, list[int]]:
    """The data factorizations each σ² search made (one per candidate σ²), for the fits
    whose rows couple (the mixture's prior) and those whose rows decouple."""
    from ltvmodels.core.squared import SquaredSolver

    searches: list = []  # [frame, separable, count]; the frame kept so that ids stay unique
    solve = SquaredSolver.solve

    def counting(self, prior_scale, *, include_data=True, compute_cov=False):
        frame = sys._getframe(1)
        while frame is not None and frame.f_code.co_name != SEARCH:
            frame = frame.f_back
        if frame is not None and include_data:
            if not searches or searches[-1][0] is not frame:
                searches.append([frame, bool(self.separable), 0])
            searches[-1][2] += 1
        return solve(self, prior_scale, include_data=include_data, compute_cov=compute_cov)

    SquaredSolver.solve = counting  # type: ignore[method-assign]
    try:
        one_run(iterations, seed)
    finally:
        SquaredSolver.solve = solve  # type: ignore[method-assign]
    return {
        "coupled": [count for _, separable, count in searches if not separable],
        "rows": [count for _, separable, count in searches if separable],
    }


def measure(repeat: int, iterations: int, seed: int, profiled: bool = True) -> dict:
    """Times of ``repeat`` runs after a warm-up, the costs, and (``profiled``) one
    profiled run and the count of candidates."""
    one_run(min(iterations, 5), seed)  # compile / load the kernels, import scikit-learn
    times, costs = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = one_run(iterations, seed)
        times.append(time.perf_counter() - start)
        costs = result.costs.tolist()
    if not profiled:
        return {"times": times, "costs": costs}
    profile = cProfile.Profile()
    start = time.perf_counter()
    profile.enable()
    one_run(iterations, seed)
    profile.disable()
    profiled = time.perf_counter() - start
    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    search = [(v[1], v[3]) for k, v in stats.items() if k[2] == SEARCH]
    searches = sum(calls for calls, _ in search)
    search_time = sum(cum for _, cum in search)
    return {
        "times": times,
        "costs": costs,
        "profiled": profiled,
        "search_time": search_time,
        "searches": searches,
        "candidates": candidates_per_search(iterations, seed),
    }


def report(label: str, out: dict) -> None:
    times = out["times"]
    cand = out["candidates"]
    print(
        f"{label}: best {min(times):.2f} s, median {statistics.median(times):.2f} s, "
        f"spread {max(times) - min(times):.2f} s over {len(times)} runs"
    )
    print(
        f"  profiled run {out['profiled']:.2f} s, of which the sigma^2 search "
        f"{out['search_time']:.2f} s ({100 * out['search_time'] / out['profiled']:.0f} %) "
        f"in {out['searches']} fits"
    )
    for kind, label in (("coupled", "coupled rows (the mixture)"), ("rows", "separate rows")):
        if cand[kind]:
            print(
                f"  candidates per search, {label}: mean {np.mean(cand[kind]):.1f}, "
                f"min {min(cand[kind])}, max {max(cand[kind])} ({len(cand[kind])} fits)"
            )
    print("  costs: " + " ".join(f"{c:.4f}" for c in out["costs"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--iterations", type=int, default=14)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--compare", default=None, help="folder of another ltvmodels package")
    parser.add_argument("--json", default=None, help="write the measurements to this file")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--no-profile", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:  # one measurement in this process, as JSON on stdout
        out = measure(args.repeat, args.iterations, args.seed, not args.no_profile)
        print(json.dumps(out))
        return
    if args.compare is None:
        import ltvmodels

        out = measure(args.repeat, args.iterations, args.seed)
        report(ltvmodels.__file__, out)
        results = {"this": out}
    else:
        import ltvmodels

        here = os.path.dirname(os.path.dirname(ltvmodels.__file__))
        paths = {"this": here, "other": os.path.abspath(args.compare)}
        results: dict = {k: {"times": []} for k in paths}
        for rep in range(args.repeat):  # alternate, so both see the same load
            for key, path in paths.items():
                env = dict(os.environ, PYTHONPATH=path)
                command = [
                    sys.executable,
                    __file__,
                    "--child",
                    "--repeat",
                    "1",
                    "--iterations",
                    str(args.iterations),
                    "--seed",
                    str(args.seed),
                ]
                command += ["--no-profile"] if rep else []  # profiled once, in the first
                line = subprocess.run(
                    command, env=env, check=True, capture_output=True, text=True
                ).stdout.strip().splitlines()[-1]  # fmt: skip
                out = json.loads(line)
                acc = results[key]
                acc["times"] += out["times"]
                acc.update({k: v for k, v in out.items() if k != "times"})
                print(f"run {rep + 1} {key}: {out['times'][0]:.2f} s", flush=True)
        for key, path in paths.items():
            report(f"{key} ({path})", results[key])
        ratio = min(results["other"]["times"]) / min(results["this"]["times"])
        print(f"best other / best this: {ratio:.2f}")
        diff = np.max(np.abs(np.subtract(results["this"]["costs"], results["other"]["costs"])))
        print(f"largest difference of the rollout costs: {diff:.3g}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
