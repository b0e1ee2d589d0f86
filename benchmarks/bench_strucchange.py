"""Benchmark: break points of a regression, ours against R's strucchange ``breakpoints``.

Data: white noise y of T samples (seeded), the model y ~ 1 (a mean that may
change), 5 breaks, minimum segment h = 0.05 · T, the setting in which
strucchange's dynamic program takes about a minute at T = 2,000. Both find
the exact optimum; the breaks must be equal.

For each T: ``segment_regression(y, 1, n_changes=5, trim=0.05)`` here (best of
``--repeat``), and ``breakpoints(y ~ 1, h = 0.05, breaks = 5)`` in an R
subprocess, timed inside R (``system.time``: R's start and the data transfer
are not counted), stopped after ``--r-timeout`` seconds. Printed: both times,
the ratio, and whether the breaks agree; at the end, the largest T strucchange
finished within the time limit.

Run:  python benchmarks/bench_strucchange.py [--sizes 200 2000 10000] [--r-timeout 300]
Needs ``Rscript`` with strucchange (Debian: r-base-core, r-cran-strucchange).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import ltvmodels as ltv

BREAKS = 5
TRIM = 0.05

R_SCRIPT = """
suppressMessages(library(strucchange))
y <- scan("{data}", quiet = TRUE)
elapsed <- system.time(bp <- breakpoints(y ~ 1, h = {trim}, breaks = {breaks}))[["elapsed"]]
cat(elapsed, breakpoints(bp, breaks = {breaks})$breakpoints, "\\n")
"""


def ours(y: np.ndarray, repeat: int) -> tuple[float, list[int]]:
    """Best time of our exact segmentation, and its breaks (strucchange's numbering)."""
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = ltv.segment_regression(y, np.ones((y.size, 1)), n_changes=BREAKS, trim=TRIM)
        best = min(best, time.perf_counter() - start)
    return best, result.changepoints.tolist()


def strucchange(y: np.ndarray, timeout: float) -> tuple[float, list[int]] | None:
    """strucchange's time (inside R) and breaks, or None when it did not finish in time."""
    with tempfile.TemporaryDirectory() as directory:
        data = Path(directory) / "y.txt"
        np.savetxt(data, y)
        script = R_SCRIPT.format(data=data, trim=TRIM, breaks=BREAKS)
        try:
            run = subprocess.run(
                ["Rscript", "-e", script], capture_output=True, text=True, timeout=timeout
            )
        except subprocess.TimeoutExpired:
            return None
    if run.returncode != 0:
        raise RuntimeError(f"R failed: {run.stderr.strip()}")
    values = run.stdout.split()
    return float(values[0]), [int(v) for v in values[1:]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=int, default=[200, 2000, 10000])
    parser.add_argument("--r-timeout", type=float, default=300.0, help="seconds per R run")
    parser.add_argument("--repeat", type=int, default=3, help="runs of ours (best kept)")
    args = parser.parse_args()
    if shutil.which("Rscript") is None:
        raise SystemExit("Rscript is not installed (Debian: r-base-core, r-cran-strucchange)")
    ltv.segment_regression(np.random.default_rng(0).standard_normal(200), np.ones((200, 1)))
    print(f"white noise, y ~ 1, {BREAKS} breaks, h = {TRIM}")
    print(f"{'T':>7}  {'ours (s)':>10}  {'strucchange (s)':>15}  {'ratio':>8}  breaks equal")
    largest = None
    for T in args.sizes:
        y = np.random.default_rng(T).standard_normal(T)
        our_time, our_breaks = ours(y, args.repeat)
        peer = strucchange(y, args.r_timeout)
        if peer is None:
            print(f"{T:7d}  {our_time:10.4f}  {'> ' + str(args.r_timeout):>15}  {'':>8}  —")
            continue
        largest = T
        peer_time, peer_breaks = peer
        print(
            f"{T:7d}  {our_time:10.4f}  {peer_time:15.2f}  {peer_time / our_time:7.0f}x  "
            f"{our_breaks == peer_breaks} {our_breaks}"
        )
    print(f"largest T strucchange finished within {args.r_timeout:g} s: {largest}")


if __name__ == "__main__":
    main()
