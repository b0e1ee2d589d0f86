"""Benchmark: the precompiled kernels against numba's own compilation of them, warm.

The kernels compiled at install (``ltvmodels.core.precompiled``, numba.pycc for a
generic CPU of the architecture) replace the first call's compilation; this
checks that they do not cost speed afterwards. Fresh processes alternate between
the two (``LTVMODELS_PRECOMPILED=1`` and ``=0``, numba's cache warm for the
latter: it runs once up front to fill it); each process fits every case once to
warm up, then times ``--repeat`` fits and keeps the best. Printed per case: the
median over ``--processes`` processes of each mode's best, their ratio
(precompiled / JIT), and whether the fitted coefficients agree bit for bit.

Run:  python benchmarks/bench_precompiled.py [--processes 4] [--repeat 10]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

# name: (system expression, fit options); every case is in the precompiled signatures
CASES = {
    "group T=2,000": ("jump_linear(T=2000, change_at=1000, seed=0)", "lam=17.0, norm='group'"),
    "group T=10,000": ("jump_linear(T=10000, change_at=5000, seed=0)", "lam=17.0, norm='group'"),
    "l1 T=10,000": ("jump_linear(T=10000, change_at=5000, seed=0)", "lam=17.0, norm='l1'"),
    "sq T=50,000": ("jump_linear(T=50000, change_at=25000, seed=0)", "lam=30.0"),
    "group n=3 m=2 T=2,000": (
        "random_walk_system(T=2000, n=3, m=2, seed=0)",
        "lam=20.0, norm='group'",
    ),
    "l1 n=3 m=2 T=10,000": ("random_walk_system(T=10000, n=3, m=2, seed=0)", "lam=20.0, norm='l1'"),
}

CHILD = """
import hashlib, json, sys, time
import ltvmodels as ltv
from ltvmodels.core import precompiled

cases, repeat = json.loads(sys.argv[1]), int(sys.argv[2])
out = {"status": precompiled.status()[1]}
for name, (system, options) in cases.items():
    data = eval("ltv.systems." + system)
    fit = eval("lambda: ltv.fit(data.x, data.u, compute_cov=False, " + options + ")")
    model = fit()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fit()
        times.append(time.perf_counter() - start)
    out[name] = (min(times), hashlib.sha256(model.k.tobytes()).hexdigest())
print(json.dumps(out))
"""


def run(precompiled: bool, repeat: int) -> dict:
    env = dict(os.environ, LTVMODELS_PRECOMPILED="1" if precompiled else "0")
    output = subprocess.run(
        [sys.executable, "-c", CHILD, json.dumps(CASES), str(repeat)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=1800,
    ).stdout
    return json.loads(output.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=10)
    args = parser.parse_args()
    run(False, 1)  # numba's cache filled for the JIT's processes
    runs: dict[bool, list[dict]] = {True: [], False: []}
    for _ in range(args.processes):
        for precompiled in (True, False):
            runs[precompiled].append(run(precompiled, args.repeat))
    print(f"precompiled kernels: {runs[True][0]['status']}")
    print(f"{'case':24} {'precompiled [ms]':>16} {'JIT [ms]':>10} {'ratio':>6}  same fit")
    for name in CASES:
        ours = statistics.median(r[name][0] for r in runs[True]) * 1e3
        jit = statistics.median(r[name][0] for r in runs[False]) * 1e3
        same = {r[name][1] for r in runs[True] + runs[False]}
        print(f"{name:24} {ours:16.2f} {jit:10.2f} {ours / jit:6.2f}  {len(same) == 1}")
    print(f"(median over {args.processes} processes each of the best of {args.repeat} fits)")


if __name__ == "__main__":
    main()
