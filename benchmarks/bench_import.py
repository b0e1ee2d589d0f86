"""Benchmark: the time ``import ltvmodels`` and ``ltvmodels --help`` take, against numpy and scipy.

Each measurement runs in a fresh interpreter (the operating system's file cache
warm after a first untimed round); the peers and ours alternate so that slow
phases of the machine hit both. Printed: the median and the fastest of
``--repeat`` runs for

* ``import numpy, scipy.linalg`` (the reference: what any use of the library
  loads anyway),
* ``import ltvmodels`` (the target: at most 2× the reference),
* ``import ltvmodels`` and then one call of ``ltvmodels.fit`` on a small
  problem (the solvers load on first use; numba's cache is warm after the
  untimed round),
* ``ltvmodels --help`` (the whole process, as a user waits for it).

Run:  python benchmarks/bench_import.py [--repeat 15]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

IMPORT_TIME = "import time; t = time.perf_counter(); {stmt}; print(time.perf_counter() - t)"
CASES = {
    "import numpy, scipy.linalg": IMPORT_TIME.format(stmt="import numpy, scipy.linalg"),
    "import ltvmodels": IMPORT_TIME.format(stmt="import ltvmodels"),
    "import ltvmodels + first fit": IMPORT_TIME.format(
        stmt="import numpy, ltvmodels; ltvmodels.fit(numpy.random.default_rng(0)"
        ".standard_normal((50, 2)), lam=1.0)"
    ),
}


def in_process(code: str) -> float:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def whole_process(args: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(args, capture_output=True, check=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15, help="runs of each case")
    args = parser.parse_args()
    help_cmd = [sys.executable, "-m", "ltvmodels", "--help"]
    runs: dict[str, list[float]] = {name: [] for name in [*CASES, "ltvmodels --help"]}
    for round_ in range(args.repeat + 1):
        for name, code in CASES.items():
            value = in_process(code)
            if round_:  # the first round only warms the caches
                runs[name].append(value)
        value = whole_process(help_cmd)
        if round_:
            runs["ltvmodels --help"].append(value)
    reference = statistics.median(runs["import numpy, scipy.linalg"])
    print(f"{'':32} {'median [s]':>10} {'fastest [s]':>11} {'/ reference':>12}")
    for name, values in runs.items():
        median = statistics.median(values)
        print(f"{name:32} {median:>10.3f} {min(values):>11.3f} {median / reference:>11.2f}x")
    print(
        f"({args.repeat} runs each, Python {sys.version.split()[0]}; 'ltvmodels --help' is the "
        "whole process, the others the import statement in a fresh interpreter)"
    )


if __name__ == "__main__":
    main()
