"""Benchmark: the first call of each public entry point in a fresh process (numba compilation).

Every case runs twice, each time in a fresh interpreter:

* **cold**: numba's cache empty (``NUMBA_CACHE_DIR`` a new temporary
  directory), what the first use after installing the package costs;
* **warm**: the same cache directory, now filled by the cold run, what every
  later session costs.

Within each process it times ``import ltvmodels`` together with the first
access of the entry point (which loads its modules: numba, scipy, the
kernels), the first call and a second, identical call (the compiled code
alone). The data are the paper's jump-linear system (T = 400, n = 2, m = 1)
and, for one case, the random-walk system at T = 1e6 (n = 3, m = 2); they and
the fitted models some cases start from are made once, up front, and loaded
from files, so that nothing compiles before the timed call. Printed per case:
the import time, the first call cold (wall and process time) and warm, the
second call, and how many compiled specializations the cold run wrote to the
cache. A warm first call still pays numba's start-up in the process (its
typing and lowering registries, about 0.2–0.3 s).

Each case has a cache of its own, so a case pays for every kernel it uses
even if another case compiled it before (in one session, later entry points
reuse what earlier ones compiled).

Run:  python benchmarks/bench_first_use.py [--only fit] [--repeat 1] [--kernels]
          [--json out.json] [--compare before.json] [--skip-large]

``--kernels`` lists, for the cold run, the compile time of every kernel the
call compiled (numba's compile events; nested compilations indented).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

# name: (entry point accessed for the import time, setup code (untimed), the timed call)
CASES: dict[str, tuple[str, str, str]] = {
    "fit sq": ("ltv.fit", "", "ltv.fit(x, u, lam=30.0)"),
    "fit group": ("ltv.fit", "", "ltv.fit(x, u, lam=20.0, norm='group')"),
    "fit l1": ("ltv.fit", "", "ltv.fit(x, u, lam=20.0, norm='l1')"),
    "fit sq T=1e6": ("ltv.fit", "", "ltv.fit(xl, ul, lam=30.0)"),
    "fit_lti": ("ltv.fit_lti", "", "ltv.fit_lti(x, u)"),
    "fit_path group": (
        "ltv.fit_path",
        "",
        "ltv.fit_path(x, u, lams=[100.0, 30.0, 10.0], norm='group')",
    ),
    "fit_regression": (
        "ltv.fit_regression",
        "y_reg, phi = ltv.ar_regressors(y, na=2)",
        "ltv.fit_regression(y_reg, phi, lam=30.0)",
    ),
    "fit_ar": ("ltv.fit_ar", "", "ltv.fit_ar(y, na=2, lam=30.0)"),
    "fit_arx": ("ltv.fit_arx", "", "ltv.fit_arx(y, u, na=2, nb=1, nk=0, lam=30.0, constant=True)"),
    "fit_piecewise": ("ltv.fit_piecewise", "", "ltv.fit_piecewise(x, u, [200], order=1)"),
    "fit_segments M=1": ("ltv.fit_segments", "", "ltv.fit_segments(x, u, n_changes=1)"),
    "fit_segments M=3": ("ltv.fit_segments", "", "ltv.fit_segments(x, u, n_changes=3)"),
    "fit_segments PELT": ("ltv.fit_segments", "", "ltv.fit_segments(x, u)"),
    "find_changepoints": (
        "ltv.find_changepoints",
        "model = ltv.load(MODEL)",
        "ltv.find_changepoints(model)",
    ),
    "select_lambda sq ml": (
        "ltv.select_lambda",
        "",
        "ltv.select_lambda(x, u, norm='sq', method='ml')",
    ),
    "kalman_filter": ("ltv.kalman_filter", "", "ltv.kalman_filter(x, u, lam=30.0, noise_var=0.04)"),
    "kalman_smoother": (
        "ltv.kalman_smoother",
        "",
        "ltv.kalman_smoother(x, u, lam=30.0, noise_var=0.04)",
    ),
    "OnlineParameterFilter": (
        "ltv.OnlineParameterFilter",
        "",
        (
            "f = ltv.OnlineParameterFilter(2, 1, lam=30.0, noise_var=0.04)\n"
            "for t in range(60):\n"
            "    f.update(x[t], u[t], x[t + 1])"
        ),
    ),
    "LTVModel.predict": ("ltv.load", "model = ltv.load(MODEL)", "model.predict(x, u)"),
    "LTVModel.simulate": ("ltv.load", "model = ltv.load(MODEL)", "model.simulate(x[0], u)"),
    "ARXModel.simulate": ("ltv.load", "arx = ltv.load(ARX_MODEL)", "arx.simulate(y[:2], u)"),
    "ilqg": (
        "ltv.ilqg",
        ("model = ltv.load(MODEL)\nfrom ltvmodels.control import LinearDynamics, QuadraticCost"),
        (
            "dyn = LinearDynamics.through(model.A, model.B, x, u)\n"
            "ltv.ilqg(dyn, QuadraticCost(np.eye(2), np.eye(1), dyn.N), x[0], u,\n"
            "         u_bounds=(-1.0, 1.0))"
        ),
    ),
    "apps.rl.learn (demo)": (
        "__import__('ltvmodels.apps.rl').apps.rl.learn",
        "from ltvmodels.apps import rl",
        "rl.learn(rl.cartpole_task(horizon=100), 'ltv', iterations=2, seed=0)",
    ),
}
LARGE = {"fit sq T=1e6"}

CHILD = """
import json, time
import numpy as np
{listener}
t0 = time.perf_counter()
import ltvmodels as ltv
_entry = {entry}
t1 = time.perf_counter()
_data = np.load({data!r})
x, u, y, xl, ul = (_data[k] for k in ("x", "u", "y", "xl", "ul"))
MODEL, ARX_MODEL = {model!r}, {arx_model!r}
{setup}
def call():
{call}
t2, c2 = time.perf_counter(), time.process_time()
call()
t3, c3 = time.perf_counter(), time.process_time()
call()
t4 = time.perf_counter()
times = {{"import": t1 - t0, "first": t3 - t2, "first_cpu": c3 - c2, "second": t4 - t3}}
print(json.dumps({{**times{kernels}}}))
"""

# Records every numba compilation (dispatcher, argument types, duration, nesting).
LISTENER = """
from numba.core import event as _event
_compiles, _stack = [], []
class _Listener(_event.Listener):
    def on_start(self, ev):
        _stack.append(time.perf_counter())
    def on_end(self, ev):
        start = _stack.pop()
        d = ev.data.get("dispatcher")
        name = getattr(getattr(d, "py_func", None), "__qualname__", str(d))
        _compiles.append((len(_stack), time.perf_counter() - start, name, str(ev.data.get("args"))))
_event.register("numba:compile", _Listener())
"""


def run_case(name: str, cache: Path, files: dict[str, str], kernels: bool) -> dict:
    entry, setup, call = CASES[name]
    code = CHILD.format(
        listener=LISTENER if kernels else "",
        entry=entry,
        data=files["data"],
        model=files["model"],
        arx_model=files["arx_model"],
        setup=setup,
        call=textwrap.indent(call, "    "),
        kernels=', "kernels": _compiles' if kernels else "",
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=False
    )
    if out.returncode:
        raise RuntimeError(f"{name}: the child process failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def make_files(directory: Path, large: bool) -> dict[str, str]:
    """The data (.npz) and two fitted models, made with a cache of their own."""
    os.environ["NUMBA_CACHE_DIR"] = str(directory / "setup-cache")
    import numpy as np

    import ltvmodels as ltv
    from ltvmodels import systems

    data = systems.jump_linear(seed=0)
    y = data.x[:, 0].copy()
    big = systems.random_walk_system(T=10**6 if large else 10, seed=0)
    files = {
        "data": str(directory / "data.npz"),
        "model": str(directory / "model.npz"),
        "arx_model": str(directory / "arx.npz"),
    }
    np.savez(files["data"], x=data.x, u=data.u, y=y, xl=big.x, ul=big.u)
    ltv.fit(data.x, data.u, lam=30.0).save(files["model"])
    ltv.fit_arx(y, data.u, na=2, nb=1, nk=0, lam=30.0, constant=True).save(files["arx_model"])
    return files


def summarize(runs: list[dict]) -> dict:
    return {
        key: statistics.median(r[key] for r in runs)
        for key in ("import", "cold", "cold_cpu", "warm", "second", "specializations")
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--only",
        nargs="*",
        default=None,
        help="run the cases whose names contain one of these strings",
    )
    parser.add_argument("--repeat", type=int, default=1, help="cold/warm pairs per case")
    parser.add_argument(
        "--kernels",
        action="store_true",
        help="list the compile time of each kernel in the cold runs",
    )
    parser.add_argument("--skip-large", action="store_true", help="skip the T = 1e6 case")
    parser.add_argument("--json", help="write the results to this file")
    parser.add_argument("--compare", help="results of an earlier run (--json) to print beside")
    args = parser.parse_args()
    names = [n for n in CASES if args.only is None or any(s in n for s in args.only)]
    if args.skip_large:
        names = [n for n in names if n not in LARGE]
    before = json.loads(Path(args.compare).read_text()) if args.compare else {}

    results: dict[str, dict] = {}
    header = (
        f"{'case':22} {'import':>7} {'cold 1st':>9} {'(cpu)':>6} {'warm 1st':>9} "
        f"{'2nd call':>9} {'#spec':>5}"
    )
    print(header + ("   | before: the same columns" if before else ""))
    with tempfile.TemporaryDirectory(prefix="bench_first_use_") as tmp:
        tmp_path = Path(tmp)
        files = make_files(tmp_path, large=any(n in LARGE for n in names))
        for name in names:
            runs = []
            for rep in range(args.repeat):
                cache = tmp_path / f"cache-{len(results)}-{rep}"
                cold = run_case(name, cache, files, args.kernels)
                n_spec = len(list(cache.rglob("*.nbc")))
                warm = run_case(name, cache, files, False)
                runs.append(
                    {
                        "import": warm["import"],
                        "cold": cold["first"],
                        "cold_cpu": cold["first_cpu"],
                        "warm": warm["first"],
                        "second": min(cold["second"], warm["second"]),
                        "specializations": n_spec,
                    }
                )
                if args.kernels and rep == 0:
                    print(f"-- {name}: compilations in the cold run (> 0.05 s)")
                    for depth, seconds, kernel, types in cold["kernels"]:
                        if seconds > 0.05:
                            print(f"   {'  ' * depth}{seconds:6.2f} s  {kernel}  {types[:110]}")
            results[name] = r = summarize(runs)
            line = (
                f"{name:22} {r['import']:>7.2f} {r['cold']:>9.2f} {r['cold_cpu']:>6.2f} "
                f"{r['warm']:>9.3f} {r['second']:>9.4f} {r['specializations']:>5.0f}"
            )
            if name in before:
                b = before[name]
                line += (
                    f"   | before: {b['import']:>5.2f} {b['cold']:>6.2f} "
                    f"{b.get('cold_cpu', float('nan')):>6.2f} {b['warm']:>6.3f} "
                    f"{b['second']:>7.4f} {b['specializations']:>3.0f}"
                )
            print(line, flush=True)
    summary = (
        f"sum over cases: cold first calls {sum(r['cold'] for r in results.values()):.1f} s,"
        f" warm first calls {sum(r['warm'] for r in results.values()):.2f} s"
    )
    compared = [n for n in results if n in before]
    if compared:
        summary += (
            f" (before, same cases: {sum(before[n]['cold'] for n in compared):.1f} s, "
            f"{sum(before[n]['warm'] for n in compared):.2f} s)"
        )
    print(summary)
    print(
        f"(seconds; import = `import ltvmodels` + first access of the entry point, warm cache; "
        f"(cpu) = process time of the cold first call; median of {args.repeat}; "
        f"Python {sys.version.split()[0]}, {os.cpu_count()} cores)"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
