"""Write the manifest of the ahead-of-time compiled kernels (``precompiled.json``).

Runs the first calls that the precompiled kernels serve (:data:`WORKLOADS`) in a
fresh process with an empty numba cache and the precompiled kernels switched
off, records the signature of every kernel of ``ltvmodels.core`` that numba
compiled (its compile events; also those compiled as another kernel's callee:
Python may call them directly later, which then compiles nothing here but would
with the precompiled callers), and writes them, with the workloads' code, to
``src/ltvmodels/core/precompiled.json``. The build
(:func:`ltvmodels.core.precompiled.build`, run by ``setup.py``) compiles
exactly these signatures.

Run it after changing a kernel's arguments or adding a kernel to these paths
(``tests/core/test_precompiled.py`` fails on a first call that compiles), then
reinstall (``pip install -e .``).

Run:  python tools/update_precompiled.py
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "src" / "ltvmodels" / "core" / "precompiled.json"

# The first calls served: each norm on the paper's jump-linear system (T = 400, n = 2,
# m = 1, as in benchmarks/bench_first_use.py) and on random-walk systems of the usual
# sizes, alone, with each robust loss and with a second-order difference, and λ chosen
# automatically on the former. Small blocks take kernels compiled
# for their size (core/banded.py, kernel_size: p = n + m for "sq" and "l1", n·p for
# "group" up to 8; larger "group" blocks share one set), so each (n, m) with a new
# block size adds kernels.
SIZES = [(1, 1), (2, 2), (3, 1), (3, 2), (4, 2)]
WORKLOADS = f"""
import ltvmodels as ltv
series = [ltv.systems.jump_linear(T=400, change_at=200, seed=0)]
series += [ltv.systems.random_walk_system(T=400, n=n, m=m, seed=0) for n, m in {SIZES}]
models = []
for data in series:
    for norm, lam in (("sq", 30.0), ("group", 20.0), ("l1", 20.0)):
        models.append(ltv.fit(data.x, data.u, lam=lam, norm=norm))
        models.append(ltv.fit(data.x, data.u, lam=lam, norm=norm, compute_cov=False))
data = series[0]  # λ chosen by each norm's default criterion, and the README's example
models += [ltv.fit(data.x, data.u, lam="auto", norm=norm) for norm in ("sq", "group", "l1")]
models.append(ltv.fit(data.x, data.u, lam="auto", norm="group", refine=True))
# the robust losses and the second-order difference of every norm (but the largest
# system's group fits: their blocks are factored by LAPACK's Cholesky, whose calls
# cannot be linked into the extension and compile at first use, about 2.5 s)
for data in series:
    for norm, lam in (("sq", 30.0), ("group", 20.0), ("l1", 20.0)):
        if norm != "group" or data is not series[-1]:
            for options in ({{"loss": "huber"}}, {{"loss": "laplace"}}, {{"order": 2}}):
                models.append(ltv.fit(data.x, data.u, lam=lam, norm=norm, **options))
# a selection long enough for the warm starts' polish (ipm.WARM_POLISH_MIN_WORK)
data = ltv.systems.jump_linear(T=2000, change_at=1000, seed=0)
models.append(ltv.fit(data.x, data.u, lam="auto", norm="group"))
"""

RECORDER = """
import json, re, sys
from numba.core import event, types

found = {}

class Recorder(event.Listener):
    def on_start(self, ev):
        dispatcher, args = ev.data["dispatcher"], ev.data["args"]
        module = dispatcher.py_func.__module__
        # literal arguments come from compiled callers only, never from Python
        if module.startswith("ltvmodels.core.") and not any(
            isinstance(a, types.Literal) for a in args
        ):
            found[(module, dispatcher.py_func.__name__, str(args))] = args

    def on_end(self, ev):
        pass

event.register("numba:compile", Recorder())
exec(compile(sys.argv[1], "<workloads>", "exec"))
entries = []
for (module, name, _), args in sorted(found.items()):
    dispatcher = getattr(sys.modules[module], name)
    compiled = dispatcher.overloads[tuple(args)]
    # a kernel that calls LAPACK through a symbol registered at run time (widekernels'
    # ltvmodels_dpotrf, llvm.add_symbol) cannot be linked into an extension module
    if re.search(r"^declare .*@ltvmodels_", compiled.library.get_llvm_str(), re.MULTILINE):
        continue
    signature = compiled.signature
    entries.append(
        {
            "module": module,
            "function": name,
            "args": [repr(a) for a in signature.args],
            "return": repr(signature.return_type),
        }
    )
print(json.dumps(entries))
"""


def main() -> None:
    env = dict(os.environ, NUMBA_CACHE_DIR=tempfile.mkdtemp(), LTVMODELS_PRECOMPILED="0")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    run = subprocess.run(
        [sys.executable, "-c", RECORDER, WORKLOADS],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    if run.returncode != 0:
        sys.exit(f"the workloads failed:\n{run.stderr}")
    output = run.stdout
    entries = json.loads(output.strip().splitlines()[-1])
    # the workloads go with the list: the tests run them to check that nothing compiles
    lines = WORKLOADS.strip().splitlines()
    MANIFEST.write_text(json.dumps({"workloads": lines, "kernels": entries}, indent=1) + "\n")
    print(f"{len(entries)} signatures of {len({e['function'] for e in entries})} kernels")
    print(f"written to {MANIFEST.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
