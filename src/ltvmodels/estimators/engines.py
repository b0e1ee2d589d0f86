"""Where :func:`ltvmodels.fit_many` runs its tasks: this process, a process pool, or Dask.

A task fits a list of units (``task(units)`` returns one result per unit and
never raises for a unit that fails: :mod:`.many` records the error). Every
engine here adds the same two guarantees:

* **one thread per worker**: each task runs with one BLAS/OpenMP thread
  (threadpoolctl) and one numba thread, restored afterwards, so that
  n workers use n cores, not n × cores;
* **a dead worker loses nothing else**: the units of a task whose worker
  process died (killed, out of memory) are retried once, each alone; a unit
  whose worker dies again is reported through ``lost(unit, message)``.

Process pool (:func:`run_processes`): a ``ProcessPoolExecutor`` (fork start on
Linux, spawn elsewhere; the caller runs no thread of its own while it forks). When a worker dies the
executor breaks; each worker marks the task it is running in a shared array,
so the tasks that were running are known: their units become suspects, the
tasks that had not started go to a fresh pool, and the suspects are retried
one by one in a one-process pool, where a second death names its unit.

Dask (:func:`run_dask`): tasks are submitted to a ``distributed.Client``. The
scheduler itself reruns the tasks of a lost worker (its ``allowed-failures``
setting, 3 by default); a task that still fails (``KilledWorker``) has its
units resubmitted one per task, once, and those that fail again run alone.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import Any

WORKER_DIED = (
    "the worker process fitting this unit died twice (killed, or out of memory?); "
    "fit it alone to see why"
)

# Of a process-pool worker: the shared array of running tasks and this worker's slot.
_running_tasks: Any = None
_slot = -1


@contextmanager
def single_threaded() -> Iterator[None]:
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
    """``task(units)`` with one thread (see :func:`single_threaded`)."""
    with single_threaded():
        return task(units)


def run_here(
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


def _start_worker(running_tasks: Any, counter: Any) -> None:
    """Initializer of a pool worker: claim a slot in the array of running tasks."""
    global _running_tasks, _slot
    with counter.get_lock():
        _slot = counter.value
        counter.value += 1
    _running_tasks = running_tasks


def _run_marked(task: Callable[[list], list], task_id: int, units: list) -> list:
    """Run a task in a pool worker, marking it as running in the shared array."""
    marked = _running_tasks is not None and 0 <= _slot < len(_running_tasks)
    if marked:
        _running_tasks[_slot] = task_id
    try:
        return run_task(task, units)
    finally:
        if marked:
            _running_tasks[_slot] = -1


def _context() -> Any:
    """Fork on Linux: workers start at once with the compiled kernels already loaded, and
    a script needs no ``if __name__ == "__main__"`` guard (spawned workers re-run the
    main module). Spawn elsewhere (macOS and Windows), where fork is unsafe or absent."""
    if sys.platform.startswith("linux"):
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")  # pragma: no cover - not on Linux


class _Pool:
    """A process pool with the shared array in which its workers mark their tasks."""

    def __init__(self, n_workers: int) -> None:
        context = _context()
        self.running = context.Array("q", [-1] * n_workers)
        counter = context.Value("q", 0)
        self.executor = ProcessPoolExecutor(
            n_workers,
            mp_context=context,
            initializer=_start_worker,
            initargs=(self.running, counter),
        )

    def running_tasks(self) -> set[int]:
        return {int(task_id) for task_id in self.running if task_id >= 0}

    def close(self) -> None:
        self.executor.shutdown(wait=True, cancel_futures=True)


def run_processes(
    task: Callable[[list], list],
    chunks: Sequence[list],
    n_workers: int,
    done: Callable[[list], None],
    lost: Callable[[Any, str], None],
) -> None:
    """Run the chunks on ``n_workers`` processes; ``done(results)`` as each finishes.

    ``task`` must be a module-level function (it is pickled by reference).
    The units of the tasks that were running when a worker died are retried
    once, each as a task of its own; those running when a worker dies again
    run one at a time in a one-process pool, where a death names its unit:
    ``lost(unit, message)``.
    """
    suspects = _run_pool(task, list(chunks), n_workers, done)
    suspects = _run_pool(task, [[unit] for units in suspects for unit in units], n_workers, done)
    for units in suspects:
        for dead in _run_pool(task, [units], 1, done):
            lost(dead[0], WORKER_DIED)


def _run_pool(
    task: Callable[[list], list], chunks: list[list], n_workers: int, done: Callable[[list], None]
) -> list[list]:
    """Run the chunks on a process pool, a fresh one after each worker death.

    Returns the chunks that were running when a worker died (the suspects).
    """
    pending = list(range(len(chunks)))
    suspects = []
    while pending:
        pool = _Pool(n_workers)
        futures = {pool.executor.submit(_run_marked, task, i, chunks[i]): i for i in pending}
        pending, reported = [], set()
        try:
            for future in as_completed(futures):
                done(future.result())
                reported.add(futures[future])
        except BrokenProcessPool:
            running = pool.running_tasks()
            for future, i in futures.items():
                if i in reported:
                    continue
                if future.done() and not future.cancelled() and future.exception() is None:
                    done(future.result())  # finished before the break
                elif i in running:
                    suspects.append(chunks[i])
                else:
                    pending.append(i)
        finally:
            pool.close()
    return suspects


def run_dask(
    client: Any,
    task: Callable[[list], list],
    chunks: Sequence[list],
    done: Callable[[list], None],
    lost: Callable[[Any, str], None],
) -> None:
    """Run the chunks as tasks of a ``distributed.Client``; ``done(results)`` as each finishes.

    A task that fails anyway (``KilledWorker`` after the scheduler's own
    retries, or a lost connection to its worker) has its units resubmitted
    once, one per task; a unit whose task fails again runs alone on the
    cluster (no other task of this run beside it), and if that fails too it
    is reported by ``lost`` — every task queued on a dying worker fails with
    it, so only a unit that fails alone is known to be the cause.
    """
    failures = _run_futures(client, task, chunks, done)
    failures = _run_futures(client, task, [[unit] for units, _ in failures for unit in units], done)
    for units, _ in failures:
        for units_again, exc in _run_futures(client, task, [units], done):
            lost(units_again[0], f"{WORKER_DIED} ({type(exc).__name__}: {exc})")


def _run_futures(
    client: Any, task: Callable[[list], list], chunks: Sequence[list], done: Callable[[list], None]
) -> list[tuple[list, BaseException]]:
    """Submit the chunks, report each result; returns the chunks whose task failed."""
    from distributed import as_completed as dask_completed

    if not chunks:
        return []
    futures = {client.submit(run_task, task, units, pure=False): units for units in chunks}
    failures: list[tuple[list, BaseException]] = []
    for future in dask_completed(list(futures)):
        try:
            results = future.result()
        except Exception as exc:  # the worker died, or the task could not run
            failures.append((futures[future], exc))
            continue
        done(results)
    return failures
