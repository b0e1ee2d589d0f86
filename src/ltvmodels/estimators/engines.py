"""Where :func:`ltvmodels.fit_many` runs its tasks: this process, a process pool, or Dask.

A task fits a list of units (``task(units)`` returns one result per unit and
never raises for a unit that fails: :mod:`.many` records the error). Every
engine here adds the same guarantees:

* **one thread per worker**: each task runs with one BLAS/OpenMP thread
  (threadpoolctl) and one numba thread, restored afterwards, so that
  n workers use n cores, not n × cores;
* **a dead worker loses nothing else**: the units of the tasks that were
  running when a worker process died (killed, out of memory) are retried
  once, each alone; a unit whose worker dies again is reported through
  ``lost(unit, message)``;
* **a bounded wait**: when no task finishes for ``stall_timeout`` seconds (a
  worker stopped or hung), the run stops, and every unit without a result is
  reported through ``lost`` with a message that says so. No call here blocks
  without a timeout.

Local processes (:func:`run_local`): a few units are fitted here first, which
measures what a unit costs; a job that would not finish sooner on a pool
(worker start-up included) is finished here, and a larger one is cut into
tasks of about :attr:`Sizing.task_seconds` each and run on loky's reusable
process pool. Loky starts its workers as fresh interpreters (no fork of this
process, so it is safe while this process runs threads, and a script needs
no ``if __name__ == "__main__"`` guard), keeps them for the next call, detects
a dead worker and never deadlocks on shutdown. At most two tasks per worker
are submitted at a time (one running, one ready, so that no worker waits for
this process between tasks): when a worker dies, loky fails every task in
flight and starts fresh workers, and the tasks in flight are the suspects.
Their units are retried one per task, and those in flight when a worker dies
again are run alone, where a death names its unit. A task's results come
back as a file that this process maps (:mod:`.pool_results`).

Dask (:func:`run_dask`): tasks are submitted to a ``distributed.Client``. The
scheduler itself reruns the tasks of a lost worker (its ``allowed-failures``
setting, 3 by default); a task that still fails (``KilledWorker``) has its
units resubmitted one per task, once, and those that fail again run alone.
"""

from __future__ import annotations

import atexit
import os
import shutil
import statistics
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import pool_results

__all__ = [
    "WORKER_DIED",
    "STALLED",
    "Sizing",
    "run_task",
    "default_jobs",
    "even_chunks",
    "run_local",
    "shutdown_pool",
    "run_dask",
    "dask_completed",
]

WORKER_DIED = (
    "the worker process fitting this unit died twice (killed, or out of memory?); "
    "fit it alone to see why"
)
STALLED = (
    "no result from the {where} for {seconds:g} s (a worker stopped or hung?), "
    "so fit_many stopped before fitting this unit; fit it alone, or pass a larger "
    "stall_timeout if its fits are that slow"
)
KEPT_DYING = (
    "the worker processes died {count} times in this run (they cannot start, or the "
    "machine is out of memory?), so fit_many stopped before fitting this unit; run "
    "with n_jobs=1 to see the error"
)

POOL = "worker processes"

# How long loky keeps idle workers for the next call (seconds).
IDLE_WORKERS_SECONDS = 300.0


@dataclass(frozen=True)
class Sizing:
    """How :func:`run_local` measures a job and cuts it into tasks.

    Attributes
    ----------
    probe_units, probe_seconds : int, float
        Units fitted in this process before deciding: at least 3, then more
        until ``probe_units`` or ``probe_seconds`` of fitting (the first unit,
        which may load compiled kernels, is not counted in the estimate).
    cold_start_seconds : float
        What starting the workers costs when none are running: a fresh
        interpreter per worker imports numpy, numba and the package and loads
        the compiled kernels (measured 1.0-1.3 s for two workers on two cores).
    warm_start_seconds : float
        The same when loky's workers from an earlier call are still running.
    task_overhead_seconds : float
        Sending a task and its results between processes.
    task_seconds : float
        The length a task aims at: long against its overhead, short enough
        to balance the workers.
    tasks_per_worker : int
        At least this many tasks per worker (balance at the end of a job).
    min_speedup : float
        The pool runs only when it is predicted this many times faster than
        this process, so that a mistaken prediction costs little.
    """

    probe_units: int = 10
    probe_seconds: float = 0.05
    cold_start_seconds: float = 1.5
    warm_start_seconds: float = 0.02
    task_overhead_seconds: float = 0.002
    task_seconds: float = 0.1
    tasks_per_worker: int = 4
    min_speedup: float = 1.25


SIZING = Sizing()


@contextmanager
def _single_threaded() -> Iterator[None]:
    """Run the body with one BLAS/OpenMP thread and one numba thread; restore both after."""
    import numba
    from threadpoolctl import threadpool_limits

    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        numba.set_num_threads(previous)


def run_task(task: Callable[[list], list], units: list) -> list:
    """``task(units)`` with one thread (see :func:`_single_threaded`)."""
    with _single_threaded():
        return task(units)


def _run_task_to_file(task: Callable[[list], list], units: list, directory: str) -> str:
    """In a pool worker: run the task; its results go to a file (:mod:`.pool_results`)."""
    return pool_results.write(run_task(task, units), directory)


def _run_here(
    task: Callable[[list], list], chunks: Sequence[list], done: Callable[[list], None]
) -> None:
    """Run every chunk in this process, in order; ``done(results)`` after each."""
    for units in chunks:
        done(run_task(task, units))


def default_jobs() -> int:
    """The cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


# Units per task at most where no unit was timed (a dead worker's task is retried unit by unit).
MAX_UNITS_PER_TASK = 256


def even_chunks(units: list, workers: int, tasks_per_worker: int) -> list[list]:
    """``units`` in chunks: ``tasks_per_worker`` per worker or more, of at most
    :data:`MAX_UNITS_PER_TASK` units each."""
    n_tasks = max(workers * tasks_per_worker, -(-len(units) // MAX_UNITS_PER_TASK))
    return _chunked(units, max(1, min(len(units), n_tasks)))


def _chunked(units: list, n_tasks: int) -> list[list]:
    """``units`` in ``n_tasks`` consecutive chunks of nearly equal size."""
    bounds = np.linspace(0, len(units), n_tasks + 1).round().astype(int)
    return [units[a:b] for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


# -- local processes ----------------------------------------------------------------------
def run_local(
    task: Callable[[list], list],
    units: list,
    n_workers: int,
    done: Callable[[list], None],
    lost: Callable[[Any, str], None],
    *,
    adaptive: bool,
    stall_timeout: float | None = None,
    sizing: Sizing = SIZING,
) -> None:
    """Run ``task`` over ``units`` on ``n_workers`` local processes (or here).

    ``done(results)`` after each task; ``lost(unit, message)`` for a unit
    that killed its worker twice, or that had no result when the pool stalled
    (see :func:`_run_processes`).

    ``adaptive``: fit the first units here to measure a unit's cost, predict
    the time of the rest here and on the pool (:class:`Sizing`), and run them
    where they finish sooner; on the pool, in tasks of about
    ``sizing.task_seconds``. Otherwise every unit runs on the pool, in
    ``sizing.tasks_per_worker`` tasks per worker or more.
    """
    if n_workers <= 1 or len(units) <= 1:
        _run_here(task, [units], done)
        return
    if not adaptive:
        chunks = even_chunks(units, n_workers, sizing.tasks_per_worker)
        _run_processes(task, chunks, n_workers, done, lost, stall_timeout=stall_timeout)
        return
    seconds: list[float] = []
    with _single_threaded():  # (entered once: it costs milliseconds, more than a small fit)
        while len(seconds) < len(units) and (
            len(seconds) < 3
            or (len(seconds) < sizing.probe_units and sum(seconds[1:]) < sizing.probe_seconds)
        ):
            start = time.perf_counter()
            done(task([units[len(seconds)]]))
            seconds.append(time.perf_counter() - start)
        rest = units[len(seconds) :]
        if not rest:
            return
        unit_seconds = statistics.median(seconds[1:])
        here = unit_seconds * len(rest)
        per_task = max(1, round(sizing.task_seconds / max(unit_seconds, 1e-9)))
        n_tasks = min(
            len(rest), max(-(-len(rest) // per_task), n_workers * sizing.tasks_per_worker)
        )
        warm = _pool_is_warm(n_workers)
        start_up = sizing.warm_start_seconds if warm else sizing.cold_start_seconds
        on_pool = start_up + (here + n_tasks * sizing.task_overhead_seconds) / n_workers
        if here < sizing.min_speedup * on_pool:
            done(task(rest))
            return
    chunks = _chunked(rest, n_tasks)
    _run_processes(task, chunks, n_workers, done, lost, stall_timeout=stall_timeout)


def _executor(n_workers: int) -> Any:
    """Loky's reusable process pool with ``n_workers`` workers (a fresh one after a break)."""
    from loky import get_reusable_executor

    _pool.executor = get_reusable_executor(max_workers=n_workers, timeout=IDLE_WORKERS_SECONDS)
    return _pool.executor


@dataclass
class _PoolState:
    """Loky's pool as the runs here left it: its workers, alive until when (time.monotonic())."""

    workers: int = 0
    until: float = 0.0
    exit_hook: bool = False  # ours registered (after loky's, so that it runs first)
    executor: Any = None  # the last one (asking loky for it again could restart it)


_pool = _PoolState()


def _pool_is_warm(n_workers: int) -> bool:
    """Whether the workers of an earlier pool run are still alive, ``n_workers`` of them."""
    return _pool.workers == n_workers and time.monotonic() < _pool.until


def _kill_workers_at_exit() -> None:
    """At interpreter exit, before loky waits for its workers to stop: kill ours.

    Loky's exit hook asks idle workers to stop and waits for them; a worker
    that was stopped (SIGSTOP) while idle would never answer, and the exit
    would hang. Killing our pool's workers first makes that wait short.
    """
    if _pool.executor is not None:
        _pool.executor.shutdown(wait=False, kill_workers=True)


def _at_exit_before_loky() -> None:
    """Register :func:`_kill_workers_at_exit` to run before loky's own exit hook.

    Loky registers its hook with ``threading._register_atexit`` (when its
    first executor starts); those hooks run in reverse order and before
    ``atexit``'s, so a later registration there runs first.
    """
    register = getattr(threading, "_register_atexit", None)
    if register is None:  # pragma: no cover - not CPython
        atexit.register(_kill_workers_at_exit)
    else:
        register(_kill_workers_at_exit)


def shutdown_pool() -> None:
    """Stop the workers that :func:`_run_processes` keeps for the next call (if any)."""
    _pool.workers = 0
    if _pool.executor is not None:
        _kill_workers(_pool.executor)


def _kill_workers(executor: Any, timeout: float = 10.0) -> None:
    """Kill the pool's workers (a stopped one too) and wait for that, at most ``timeout`` s."""
    killer = threading.Thread(
        target=executor.shutdown, kwargs={"wait": True, "kill_workers": True}, daemon=True
    )
    killer.start()
    killer.join(timeout)


class _Stalled(Exception):
    """The pool stopped answering (or kept dying); ``units`` have no result."""

    def __init__(self, units: list, message: str) -> None:
        super().__init__(message)
        self.units = units
        self.message = message


def _run_processes(
    task: Callable[[list], list],
    chunks: Sequence[list],
    n_workers: int,
    done: Callable[[list], None],
    lost: Callable[[Any, str], None],
    *,
    stall_timeout: float | None = None,
    max_breaks: int = 20,
) -> None:
    """Run the chunks on loky's pool of ``n_workers`` processes; ``done(results)`` as each finishes.

    ``task`` must be picklable (loky pickles it with cloudpickle). The units
    of the tasks in flight when a worker died are retried once, each as a task
    of its own; those in flight when a worker dies again run alone, where a
    death names its unit: ``lost(unit, message)``. When no task finishes for
    ``stall_timeout`` seconds, or the pool breaks ``max_breaks`` times, the
    workers are killed and every unit without a result is ``lost``. Default
    ``stall_timeout``: 600 s until a task has finished, then 60 s or 20 times
    the longest task so far, whichever is longer.
    """
    run = _PoolRun(task, n_workers, done, stall_timeout, max_breaks)
    _pool.workers = 0
    try:
        suspects = run.stage(list(chunks), width=2 * n_workers)
        singles = [[unit] for units in suspects for unit in units]
        suspects = run.stage(singles, width=2 * n_workers)
        for position, units in enumerate(suspects):
            run.later = suspects[position + 1 :]
            for dead in run.stage([units], width=1):
                lost(dead[0], WORKER_DIED)
    except _Stalled as stalled:
        for unit in stalled.units:
            lost(unit, stalled.message)
        return
    finally:
        shutil.rmtree(run.directory, ignore_errors=True)
    _pool.workers, _pool.until = n_workers, time.monotonic() + IDLE_WORKERS_SECONDS - 1


class _PoolRun:
    """One :func:`_run_processes` call: its pool, its wait limit and how often the pool broke."""

    def __init__(
        self,
        task: Callable[[list], list],
        n_workers: int,
        done: Callable[[list], None],
        stall_timeout: float | None,
        max_breaks: int,
    ) -> None:
        self.task = task
        self.n_workers = n_workers
        self.done = done
        self.stall_timeout = stall_timeout
        self.max_breaks = max_breaks
        self.breaks = 0
        self.longest_task = 0.0
        self.directory = pool_results.new_directory()
        self.later: list[list] = []  # chunks of later stages (reported if the pool stalls)

    def wait_limit(self) -> float:
        """How long to wait for the next finished task."""
        if self.stall_timeout is not None:
            return self.stall_timeout
        return max(60.0, 20 * self.longest_task) if self.longest_task else 600.0

    def stage(self, chunks: list[list], width: int) -> list[list]:
        """Run ``chunks`` with at most ``width`` in flight; returns those in flight at a break."""
        pending = deque(chunks)
        in_flight: dict[Future, tuple[list, float]] = {}
        suspects: list[list] = []
        executor = _executor(self.n_workers)
        while pending or in_flight:
            while pending and len(in_flight) < width:
                units = pending.popleft()
                try:
                    future = executor.submit(_run_task_to_file, self.task, units, self.directory)
                except (BrokenProcessPool, RuntimeError):  # broken, or shut down: a fresh pool
                    pending.appendleft(units)
                    executor = self._after_break(executor, in_flight, pending, suspects)
                    continue
                in_flight[future] = (units, time.monotonic())
                if not _pool.exit_hook:  # loky registered its exit hook at this first submit
                    _pool.exit_hook = True
                    _at_exit_before_loky()
            limit = self.wait_limit()
            finished, _ = wait(in_flight, timeout=limit, return_when=FIRST_COMPLETED)
            if not finished:
                _kill_workers(executor)
                message = STALLED.format(where=POOL, seconds=limit)
                self._give_up(message, in_flight, pending, suspects)
            broken = False
            for future in finished:
                units, submitted = in_flight.pop(future)
                try:
                    path = future.result()
                except BrokenProcessPool:  # its worker, or another one, died
                    suspects.append(units)
                    broken = True
                    continue
                self.longest_task = max(self.longest_task, time.monotonic() - submitted)
                self.done(pool_results.read(path))
            if broken:  # loky fails every task in flight and starts fresh workers
                executor = self._after_break(executor, in_flight, pending, suspects)
        return suspects

    def _after_break(
        self,
        executor: Any,
        in_flight: dict[Future, tuple[list, float]],
        pending: deque,
        suspects: list[list],
    ) -> Any:
        """Collect the tasks in flight when the pool broke (results or suspects); a fresh pool."""
        self.breaks += 1
        limit = self.wait_limit()
        finished, unfinished = wait(in_flight, timeout=limit)
        for future in finished:
            if future.exception() is None:
                self.done(pool_results.read(future.result()))  # it finished before the break
            else:
                suspects.append(in_flight[future][0])
        if unfinished or self.breaks >= self.max_breaks:
            _kill_workers(executor)
            left = {future: in_flight[future] for future in unfinished}
            message = (
                STALLED.format(where=POOL, seconds=limit)
                if unfinished
                else KEPT_DYING.format(count=self.breaks)
            )
            self._give_up(message, left, pending, suspects)
        in_flight.clear()
        return _executor(self.n_workers)

    def _give_up(
        self,
        message: str,
        in_flight: dict[Future, tuple[list, float]],
        pending: deque,
        suspects: list[list],
    ) -> None:
        chunks = [*(units for units, _ in in_flight.values()), *pending, *suspects, *self.later]
        raise _Stalled([unit for units in chunks for unit in units], message)


# -- Dask ---------------------------------------------------------------------------------
def run_dask(
    client: Any,
    task: Callable[[list], list],
    chunks: Sequence[list],
    done: Callable[[list], None],
    lost: Callable[[Any, str], None],
    *,
    stall_timeout: float,
) -> None:
    """Run the chunks as tasks of a ``distributed.Client``; ``done(results)`` as each finishes.

    A task that fails anyway (``KilledWorker`` after the scheduler's own
    retries, or a lost connection to its worker) has its units resubmitted
    once, one per task; a unit whose task fails again runs alone on the
    cluster (no other task of this run beside it), and if that fails too it
    is reported by ``lost`` — every task queued on a dying worker fails with
    it, so only a unit that fails alone is known to be the cause. When no
    task finishes for ``stall_timeout`` seconds, the tasks left are cancelled
    and their units ``lost``.
    """
    try:
        failures = _run_futures(client, task, chunks, done, stall_timeout)
        singles = [[unit] for units, _ in failures for unit in units]
        failures = _run_futures(client, task, singles, done, stall_timeout)
        for position, (units, _) in enumerate(failures):
            later = [units for units, _ in failures[position + 1 :]]
            for units_again, exc in _run_futures(client, task, [units], done, stall_timeout, later):
                lost(units_again[0], f"{WORKER_DIED} ({type(exc).__name__}: {exc})")
    except _Stalled as stalled:
        for unit in stalled.units:
            lost(unit, stalled.message)


def _run_futures(
    client: Any,
    task: Callable[[list], list],
    chunks: Sequence[list],
    done: Callable[[list], None],
    stall_timeout: float,
    later: Sequence[list] = (),
) -> list[tuple[list, BaseException]]:
    """Submit the chunks, report each result; returns the chunks whose task failed."""
    from distributed import as_completed as dask_as_completed

    if not chunks:
        return []
    futures = {client.submit(run_task, task, units, pure=False): units for units in chunks}
    failures: list[tuple[list, BaseException]] = []
    try:
        for future in dask_completed(dask_as_completed(list(futures)), stall_timeout):
            try:
                results = future.result()
            except Exception as exc:  # the worker died, or the task could not run
                failures.append((futures.pop(future), exc))
                continue
            futures.pop(future)
            done(results)
    except TimeoutError:
        client.cancel(list(futures))
        chunks_left = [*futures.values(), *(units for units, _ in failures), *later]
        raise _Stalled(
            [unit for units in chunks_left for unit in units],
            STALLED.format(where="Dask workers", seconds=stall_timeout),
        ) from None
    return failures


def dask_completed(queue: Any, stall_timeout: float) -> Iterator[Any]:
    """The futures of a ``distributed.as_completed`` queue as they finish (the queue may grow).

    Raises ``TimeoutError`` when none finishes for ``stall_timeout`` seconds.
    """
    last = time.monotonic()
    while not queue.is_empty():
        batch = queue.next_batch(block=False)
        if batch:
            last = time.monotonic()
            yield from batch
        elif time.monotonic() - last > stall_timeout:
            raise TimeoutError(f"no Dask task finished for {stall_timeout:g} s")
        else:
            time.sleep(0.01)
