"""fit_many's process pool under faults: workers killed at random moments, or stopped.

Every scenario runs in a child process whose output is read with a deadline per
line, so that a hang fails the test (the child is killed) instead of blocking
the suite. The random-kill runs (``pool_stress.py``) are marked slow: run them
with ``python -m pytest -m slow tests/many/test_pool_faults.py``.
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

pytest.importorskip("pandas")

HERE = Path(__file__).resolve().parent
STRESS = HERE / "pool_stress.py"


def child_lines(arguments: list[str], *, line_deadline: float, total_deadline: float) -> list:
    """Run ``python arguments...`` and return its JSON lines; fail if any line is late."""
    environment = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent), *sys.path]))
    child = subprocess.Popen(
        [sys.executable, *arguments],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment,
    )
    lines, start = [], time.monotonic()
    try:
        while True:
            ready, _, _ = select.select([child.stdout], [], [], line_deadline)
            if not ready:
                child.send_signal(signal.SIGUSR1)  # pool_stress.py then prints its stacks
                time.sleep(2)
                child.kill()
                _, errors = child.communicate(timeout=60)
                own = [line for line in errors.splitlines() if not line.startswith("20")]
                pytest.fail(  # (its stderr without Dask's dated log lines: stacks, errors)
                    f"no output for {line_deadline} s after {len(lines)} lines: a hang; "
                    "its stderr:\n" + "\n".join(own[-150:])
                )
            line = child.stdout.readline()
            if not line:
                break
            lines.append(json.loads(line))
            if time.monotonic() - start > total_deadline:
                pytest.fail(f"over {total_deadline} s after {len(lines)} lines")
        child.wait(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait(timeout=60)
    assert child.returncode == 0, child.stderr.read()
    return lines


STOPPED_WORKER = textwrap.dedent(
    """
    import json, os
    from pathlib import Path
    import ltvmodels as ltv
    from many_methods import stop_on_marked
    from test_fit_many import marked_units

    data = marked_units(40, {37})  # in the last task: the tasks before it finish first
    ltv.fit_many(data, lam=10.0, n_jobs=2)  # the workers are running from here on
    start = __import__("time").perf_counter()
    ms = ltv.fit_many(data, method=stop_on_marked, lam=10.0, n_jobs=2, stall_timeout=3.0)
    seconds = __import__("time").perf_counter() - start
    stopped = []  # children of this process still stopped (state T)
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == os.getpid() and fields[0] == "T":
                stopped.append(int(entry.name))
    same = all((ms[u].k == ltv.fit(*data[u], lam=10.0).k).all() for u in ms)
    print(json.dumps({"errors": {str(k): v for k, v in ms.errors.items()}, "fitted": list(ms),
                      "seconds": seconds, "stopped": stopped, "same": bool(same)}))
    """
)


def test_a_stopped_worker_is_detected_by_the_bounded_wait():
    (report,) = child_lines(
        ["-c", STOPPED_WORKER, str(HERE)], line_deadline=120, total_deadline=120
    )
    errors = report["errors"]
    assert "37" in errors
    assert all("no result from the worker processes for 3 s" in text for text in errors.values())
    assert len(errors) + len(report["fitted"]) == 40 and len(report["fitted"]) >= 35
    assert report["same"]
    assert report["stopped"] == []  # the stopped worker was killed, not left behind
    assert report["seconds"] < 30


def stress_lines(*arguments: str, repetitions: int, line_deadline: float) -> list:
    lines = child_lines(
        [str(STRESS), "--repetitions", str(repetitions), *arguments],
        line_deadline=line_deadline,
        total_deadline=repetitions * line_deadline,
    )
    assert len(lines) == repetitions
    return lines


@pytest.mark.slow
def test_a_worker_killed_at_a_random_moment_loses_nothing():
    lines = stress_lines("--engine", "local", repetitions=200, line_deadline=60)
    assert all(line["accounted"] and line["equal"] for line in lines)
    assert sum(line["errors"] for line in lines) == 0  # one kill a run: every unit retried


@pytest.mark.slow
def test_a_dask_worker_killed_at_a_random_moment_loses_nothing():
    pytest.importorskip("distributed")
    lines = stress_lines(
        "--engine", "dask", "--stall-timeout", "60", repetitions=50, line_deadline=300
    )
    assert all(line["accounted"] and line["equal"] for line in lines)


@pytest.mark.slow
def test_a_worker_stopped_at_a_random_moment_never_hangs():
    lines = stress_lines("--stop", "--stall-timeout", "3", repetitions=20, line_deadline=60)
    assert all(line["accounted"] and line["equal"] for line in lines)
    assert all(
        all(
            message.startswith("no result from the worker processes")
            for message in line["messages"]
        )
        for line in lines
    )


UNGUARDED_SCRIPT = textwrap.dedent(
    """
    import sys
    import ltvmodels as ltv

    print("top level", flush=True)  # a worker that re-ran this script would print it again


    def doubled_lam_fit(x, u=None, *, lam):  # defined in the script: sent by value
        return ltv.fit(x, u, lam=2 * lam)


    data = {i: (d.x, d.u) for i, d in enumerate(
        ltv.systems.jump_linear(T=60, change_at=30, seed=i) for i in range(12))}
    ms = ltv.fit_many(data, method=doubled_lam_fit, lam=5.0, n_jobs=2)
    same = all((ms[i].k == ltv.fit(*data[i], lam=10.0).k).all() for i in data)
    print('{"fitted": %d, "same": %s}' % (len(ms), "true" if same else "false"), flush=True)
    """
)


def test_a_script_needs_no_main_guard(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text(UNGUARDED_SCRIPT)
    environment = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300, env=environment
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "top level" and len(lines) == 2  # the workers did not run the script
    assert json.loads(lines[1]) == {"fitted": 12, "same": True}


EXIT_WITH_STOPPED_WORKERS = textwrap.dedent(
    """
    import os, signal
    import ltvmodels as ltv
    from pool_stress import loky_workers, make_units

    ltv.fit_many(make_units(40, 100), lam=10.0, n_jobs=2)
    for pid in loky_workers():  # stopped while idle, after the run
        os.kill(pid, signal.SIGSTOP)
    print('{"stopped": %d}' % len(loky_workers()), flush=True)
    """
)


def test_the_interpreter_exits_with_stopped_idle_workers():
    """Loky waits for its idle workers at exit; stopped ones are killed first."""
    start = time.monotonic()
    (report,) = child_lines(
        ["-c", EXIT_WITH_STOPPED_WORKERS], line_deadline=120, total_deadline=120
    )
    assert report["stopped"] == 2
    assert time.monotonic() - start < 60
