"""Stress fit_many's engines: kill (or stop) a worker at a random moment of each run.

Run as a script; it prints one JSON line per repetition (the test that runs it
reads them with a deadline per line, so that a hang fails the test, not the suite):

    python tests/many/pool_stress.py --engine local --repetitions 200
    python tests/many/pool_stress.py --engine dask --repetitions 50
    python tests/many/pool_stress.py --engine local --stop        # SIGSTOP, not SIGKILL

Each repetition fits ``--units`` jump-linear units (n_jobs=2, or a
``LocalCluster`` of two worker processes), while a thread waits a random time
(uniform over a run's usual length) and kills one worker process. The line
says how many units were fitted, how many recorded as errors, and whether
every fitted model equals the one fitted in this process.
"""

from __future__ import annotations

import argparse
import faulthandler
import json
import os
import random
import signal
import threading
import time
from pathlib import Path

import numpy as np

import ltvmodels as ltv


def make_units(n_units: int, T: int) -> dict:
    return {
        unit: (d.x, d.u)
        for unit, d in enumerate(
            ltv.systems.jump_linear(T=T, change_at=T // 2, seed=unit) for unit in range(n_units)
        )
    }


def loky_workers() -> list[int]:
    """The loky worker processes among this process's children."""
    me, workers = os.getpid(), []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            command = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        parent = int(stat.rsplit(")", 1)[1].split()[1])
        if parent == me and b"popen_loky" in command:
            workers.append(int(entry.name))
    return workers


def new_cluster():
    """A ``LocalCluster`` of two worker processes, and its client."""
    import dask
    import distributed

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        )
    return cluster, distributed.Client(cluster)


def dask_worker_pids(client) -> list[int] | None:
    """The cluster's two worker processes; None when one has not come back in 60 s.

    (A nanny whose worker was killed may fail to start a new one: "name taken"
    while the scheduler still knows the old worker. That is the test cluster's
    trouble, not the engine's: the run then starts a new cluster.)
    """
    try:
        client.wait_for_workers(2, timeout=60)
    except TimeoutError:
        return None
    pids = client.run(os.getpid, on_error="return").values()
    return [pid for pid in pids if isinstance(pid, int)]


def close(cluster, client) -> None:
    client.close(timeout=60)
    cluster.close(timeout=60)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--engine", choices=["local", "dask"], default="local")
    parser.add_argument("--repetitions", type=int, default=200)
    parser.add_argument("--units", type=int, default=200)
    parser.add_argument("--T", type=int, default=300)
    parser.add_argument("--stop", action="store_true", help="SIGSTOP a worker instead")
    parser.add_argument("--stall-timeout", type=float, default=None)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    faulthandler.register(signal.SIGUSR1, all_threads=True)  # kill -USR1 PID: the stacks
    rng = random.Random(args.seed)
    data = make_units(args.units, args.T)
    reference = ltv.fit_many(data, lam="auto", n_jobs=1)
    options = {"lam": "auto", "stall_timeout": args.stall_timeout}
    cluster = client = None
    if args.engine == "dask":
        cluster, client = new_cluster()
        options["engine"] = client
    else:
        options["n_jobs"] = 2
    new_clusters = 0
    try:
        ltv.fit_many(data, **options)  # the workers exist from here on
        start = time.perf_counter()
        ltv.fit_many(data, **options)
        usual = time.perf_counter() - start  # a run's length with warm workers
        for repetition in range(args.repetitions):
            if client is not None:
                pids = dask_worker_pids(client)
                if pids is None:
                    close(cluster, client)
                    cluster, client = new_cluster()
                    options["engine"] = client
                    new_clusters += 1
                    pids = dask_worker_pids(client) or []
            else:
                pids = loky_workers()
            victim = rng.choice(pids) if pids else None
            delay = rng.uniform(0.0, usual)
            signal_number = signal.SIGSTOP if args.stop else signal.SIGKILL

            def strike(victim=victim, delay=delay, signal_number=signal_number):
                time.sleep(delay)
                if victim is not None:
                    try:
                        os.kill(victim, signal_number)
                    except ProcessLookupError:
                        pass

            killer = threading.Thread(target=strike, daemon=True)
            start = time.perf_counter()
            killer.start()
            ms = ltv.fit_many(data, **options)
            seconds = time.perf_counter() - start
            killer.join()
            equal = all(np.array_equal(ms[unit].k, reference[unit].k) for unit in ms)
            print(
                json.dumps(
                    {
                        "repetition": repetition,
                        "fitted": len(ms),
                        "errors": len(ms.errors),
                        "accounted": len(ms) + len(ms.errors) == args.units,
                        "equal": equal,
                        "seconds": round(seconds, 3),
                        "delay": round(delay, 3),
                        "new_clusters": new_clusters,
                        "messages": sorted({message[:60] for message in ms.errors.values()}),
                    }
                ),
                flush=True,
            )
    finally:
        if client is not None:
            close(cluster, client)


if __name__ == "__main__":
    main()
