"""Record the outputs of every public entry point, or compare them with a recording.

For a refactoring that must not change results: record on the tree before the
change, compare on the tree after it.

    python tests/reference/record_outputs.py record build/outputs-before.pkl
    python tests/reference/record_outputs.py compare build/outputs-before.pkl

Each case calls one entry point on small seeded data and keeps a snapshot of
what it returns (every public attribute of a result, recursively; arrays as
arrays), the text of ``repr`` and ``summary()``, and the category and text of
every warning (not its file and line). The command-line cases keep the
printed output and the files written. ``compare`` prints each case that
differs (with the largest difference of its arrays) and the counts; it exits
with 1 when a case differs.
"""

from __future__ import annotations

import contextlib
import io
import os
import pickle
import re
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import ltvmodels as ltv

# Attributes that are not results (methods and plotting) or that repeat others.
SKIP = {"plot", "record"}
# Entries that are run times (they differ from run to run), and their text.
TIMES = {"seconds", "elapsed"}
TIME_TEXT = re.compile(r"(elapsed=|in )[0-9.]+ ?s\b( \([0-9.]+ units/s\))?")


def without_times(value: Any) -> Any:
    """``value`` with its run times replaced by "<time>" (see :data:`TIMES`)."""
    if isinstance(value, str):
        return TIME_TEXT.sub(r"\1<time>", value)
    if isinstance(value, list):
        return [without_times(item) for item in value]
    if not isinstance(value, dict):
        return value
    out = {key: "<time>" if key in TIMES else without_times(item) for key, item in value.items()}
    if "pandas" in value and "seconds" in value.get("columns", []):
        column = value["columns"].index("seconds")
        out["values"] = [row[:column] + ["<time>"] + row[column + 1 :] for row in value["values"]]
    return out


def snapshot(value: Any, depth: int = 0) -> Any:
    """A comparable copy of ``value``: plain data, arrays, and objects' public attributes."""
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes)):
        return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, dict):
        return {str(key): snapshot(item, depth + 1) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [snapshot(item, depth + 1) for item in value]
    module = type(value).__module__
    if module.startswith("pandas"):
        frame = value.to_frame() if hasattr(value, "to_frame") and value.ndim == 1 else value
        if hasattr(frame, "columns"):
            return {
                "pandas": type(value).__name__,
                "index": [str(item) for item in frame.index],
                "columns": [str(item) for item in frame.columns],
                "values": [[str(item) for item in row] for row in frame.to_numpy(dtype=object)],
            }
        return {"pandas": type(value).__name__, "text": str(value)}
    if isinstance(value, (Path, type)) or callable(value) or depth > 4:
        return f"<{type(value).__name__}>"
    if not module.startswith("ltvmodels"):
        return repr(value)
    out: dict[str, Any] = {"__class__": type(value).__name__, "__repr__": repr(value)}
    for name in dir(value):
        if name.startswith("_") or name in SKIP:
            continue
        try:
            item = getattr(value, name)
        except Exception as exc:  # an attribute that raises is an output too
            out[name] = f"raises {type(exc).__name__}: {exc}"
            continue
        if callable(item):
            if name in ("summary", "std", "activation", "to_frame"):
                try:
                    out[f"{name}()"] = snapshot(item(), depth + 1)
                except Exception as exc:
                    out[f"{name}()"] = f"raises {type(exc).__name__}: {exc}"
            continue
        out[name] = snapshot(item, depth + 1)
    return out


def run_case(call: Callable[[], Any]) -> dict:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = snapshot(call())
        except Exception as exc:
            result = f"raises {type(exc).__name__}: {exc}"
    return {
        "result": result,
        "warnings": sorted(f"{w.category.__name__}: {w.message}" for w in caught),
    }


# -- the data ---------------------------------------------------------------------
def jump(T: int = 80, seed: int = 0):
    d = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
    return d.x, d.u


def frame(T: int = 60):
    import pandas as pd

    x, u = jump(T)
    index = pd.date_range("2024-01-01", periods=T, freq="h")
    return (
        pd.DataFrame(x, index=index, columns=["pos", "vel"]),
        pd.DataFrame(u, index=index, columns=["force"]),
    )


def cases() -> dict[str, Callable[[], Any]]:
    x, u = jump()
    x3 = np.stack([jump(seed=s)[0] for s in range(3)])
    u3 = np.stack([jump(seed=s)[1] for s in range(3)])
    gappy = x.copy()
    gappy[10:14] = np.nan
    gappy[30, 1] = np.nan
    weights = np.linspace(0.5, 2.0, len(x) - 1)
    y = x[1:, 0]
    phi = np.column_stack([x[:-1], u[:-1]])
    rng = np.random.default_rng(3)
    series = np.cumsum(rng.standard_normal(150)) * 0.1 + np.sin(np.arange(150) / 7)
    ext = rng.standard_normal((150, 1))
    prior_model = ltv.fit_lti(x, u)
    c: dict[str, Callable[[], Any]] = {}
    for norm in ("sq", "l1", "group"):
        for order in (1, 2):
            lam = {"sq": 10.0, "l1": 2.0, "group": 2.0}[norm]
            c[f"fit {norm} order {order}"] = lambda n=norm, o=order, la=lam: ltv.fit(
                x, u, lam=la, norm=n, order=o
            )
    c["fit sq auto"] = lambda: ltv.fit(x, u, lam="auto")
    c["fit l1 auto"] = lambda: ltv.fit(x, u, lam="auto", norm="l1")
    c["fit l1 refine"] = lambda: ltv.fit(x, u, lam=2.0, norm="l1", refine=True)
    c["fit group refine"] = lambda: ltv.fit(x, u, lam=2.0, norm="group", refine=True)
    c["fit sq vector lam"] = lambda: ltv.fit(x, u, lam=np.arange(1.0, 7.0))
    c["fit sq matrix lam"] = lambda: ltv.fit(x, u, lam=np.diag(np.arange(1.0, 7.0)))
    c["fit coeffs order"] = lambda: ltv.fit(x, u, lam=5.0, order=[1.0, -2.0, 1.0])
    c["fit prior exact"] = lambda: ltv.fit(x, u, lam=10.0, prior=ltv.Prior(prior_model, 0.1))
    for mode in ("exact", "posthoc"):
        c[f"fit prior {mode}"] = lambda m=mode: ltv.fit(
            x, u, lam=10.0, prior=ltv.Prior(prior_model, 0.1), prior_mode=m
        )
    c["fit noise_var"] = lambda: ltv.fit(x, u, lam=10.0, noise_var=[0.01, 0.02])
    c["fit no cov"] = lambda: ltv.fit(x, u, lam=10.0, compute_cov=False)
    c["fit weights"] = lambda: ltv.fit(x, u, lam=10.0, weights=weights)
    c["fit constant"] = lambda: ltv.fit(x, u, lam=10.0, constant=True)
    c["fit constant l1"] = lambda: ltv.fit(x, u, lam=2.0, norm="l1", constant=True)
    for loss in ("huber", "laplace"):
        for norm in ("sq", "l1", "group"):
            c[f"fit {loss} {norm}"] = lambda lo=loss, n=norm: ltv.fit(
                x, u, lam=2.0 if n != "sq" else 10.0, norm=n, loss=lo
            )
    c["fit huber delta"] = lambda: ltv.fit(x, u, lam=10.0, loss="huber", huber_delta=0.05)
    c["fit huber auto"] = lambda: ltv.fit(x, u, lam="auto", loss="huber")
    c["fit trajectories"] = lambda: ltv.fit(x3, u3, lam=10.0)
    c["fit trajectories l1"] = lambda: ltv.fit(x3, u3, lam=2.0, norm="l1")
    c["fit missing"] = lambda: ltv.fit(gappy, u, lam=10.0)
    c["fit missing l1"] = lambda: ltv.fit(gappy, u, lam=2.0, norm="l1")
    c["fit autonomous"] = lambda: ltv.fit(x, lam=10.0)
    c["fit dataframe"] = lambda: ltv.fit(*frame(), lam=10.0)
    c["fit dataframe auto"] = lambda: ltv.fit(*frame(), lam="auto")
    c["fit max_iter warning"] = lambda: ltv.fit(x, u, lam=2.0, norm="l1", max_iter=2)
    c["fit error lam"] = lambda: ltv.fit(x, u, lam=-1.0)
    c["fit error norm"] = lambda: ltv.fit(x, u, lam=1.0, norm="l3")
    c["fit error loss"] = lambda: ltv.fit(x, u, lam=1.0, loss="cauchy")
    c["fit error shapes"] = lambda: ltv.fit(x, u[:-3], lam=1.0)
    c["fit_lti"] = lambda: ltv.fit_lti(x, u)
    c["fit_lti huber"] = lambda: ltv.fit_lti(x, u, loss="huber")
    c["fit_lti constant"] = lambda: ltv.fit_lti(x, u, constant=True)
    c["fit_path"] = lambda: ltv.fit_path(x, u, lams=[0.5, 2.0, 8.0], norm="l1")
    c["lambda_max l1"] = lambda: ltv.lambda_max(x, u, norm="l1")
    c["lambda_max group"] = lambda: ltv.lambda_max(x, u, norm="group", order=2)
    c["fit_regression"] = lambda: ltv.fit_regression(y, phi, lam=10.0)
    c["fit_regression l1 huber"] = lambda: ltv.fit_regression(
        y, phi, lam=2.0, norm="l1", loss="huber"
    )
    c["fit_regression auto"] = lambda: ltv.fit_regression(y, phi, lam="auto")
    c["fit_ar"] = lambda: ltv.fit_ar(series, 2, lam=10.0)
    c["fit_ar constant l1"] = lambda: ltv.fit_ar(series, 2, lam=2.0, norm="l1", constant=True)
    c["fit_ar auto"] = lambda: ltv.fit_ar(series, 2, lam="auto")
    c["fit_arx"] = lambda: ltv.fit_arx(series, ext, 2, 1, lam=10.0)
    c["fit_arx laplace"] = lambda: ltv.fit_arx(series, ext, 1, 2, 0, lam=10.0, loss="laplace")
    c["ar_regressors"] = lambda: ltv.ar_regressors(series[:20], 2)
    c["arx_regressors"] = lambda: ltv.arx_regressors(series[:20], ext[:20], 2, 1)
    c["fit_piecewise"] = lambda: ltv.fit_piecewise(x, u, [40])
    c["fit_piecewise huber"] = lambda: ltv.fit_piecewise(x, u, [40], loss="huber")
    c["fit_segments n"] = lambda: ltv.fit_segments(x, u, n_changes=1)
    c["fit_segments bic"] = lambda: ltv.fit_segments(x, u, penalty="bic")
    c["fit_segments trajectories"] = lambda: ltv.fit_segments(x3, u3, n_changes=1)
    c["segment_regression"] = lambda: ltv.segment_regression(y, phi, n_changes=1)
    c["noise_variance_estimate"] = lambda: ltv.noise_variance_estimate(y, phi)
    c["find_changepoints"] = lambda: ltv.find_changepoints(ltv.fit(x, u, lam=2.0, norm="l1"))
    for method in ("ml", "cv", "gcv", "lcurve"):
        c[f"select_lambda sq {method}"] = lambda me=method: ltv.select_lambda(
            x, u, method=me, lams=np.logspace(-1, 3, 6)
        )
    c["select_lambda l1"] = lambda: ltv.select_lambda(x, u, norm="l1")
    c["select_lambda huber"] = lambda: ltv.select_lambda(x, u, loss="huber", method="cv")
    c["select_lambda_regression"] = lambda: ltv.select_lambda_regression(y, phi)
    c["Prior"] = lambda: ltv.Prior(prior_model, 0.1)
    c["OutputPrior"] = lambda: ltv.OutputPrior(np.zeros(3), 1.0)
    c["GMMPrior"] = lambda: ltv.GMMPrior(x, u, n_components=2, seed=0)
    c["fit GMMPrior"] = lambda: ltv.fit(x, u, lam=10.0, prior=ltv.GMMPrior(x, u, seed=0).at(x, u))
    c["kalman_filter"] = lambda: ltv.kalman_filter(x, u, lam=10.0)
    c["kalman_smoother"] = lambda: ltv.kalman_smoother(x, u, lam=10.0, order=2)
    c["OnlineParameterFilter"] = lambda: online(x, u)
    c["forecast"] = lambda: ltv.fit(x, u, lam=10.0).forecast(x[-1], u[-5:], steps=5, level=0.9)
    c["simulate"] = lambda: ltv.fit(x, u, lam=10.0).simulate(x[0], u)
    c["predict"] = lambda: ltv.fit(x, u, lam=10.0).predict(x, u)
    c["to_statespace"] = lambda: ltv.fit(x, u, lam=10.0).to_statespace(5)
    c["save load"] = lambda: save_and_load(ltv.fit(*frame(), lam=2.0, norm="l1", constant=True))
    c["save load ar"] = lambda: save_and_load(ltv.fit_ar(series, 2, lam=10.0))
    c["fit_many"] = lambda: ltv.fit_many(
        {unit: jump(T=60, seed=unit) for unit in range(4)}, lam=10.0, n_jobs=1, progress=False
    )
    c["fit_many auto l1"] = lambda: ltv.fit_many(
        {unit: jump(T=60, seed=unit) for unit in range(3)},
        lam="auto",
        norm="l1",
        n_jobs=1,
        progress=False,
    )
    c["ilqg"] = lambda: ilqg_case()
    c["robot experiment"] = lambda: robot_case()
    c["rl experiment"] = lambda: rl_case()
    return c


def online(x, u):
    flt = ltv.OnlineParameterFilter(2, 1, lam=10.0)
    return [flt.update(x[t], u[t], x[t + 1]) for t in range(10)]


def save_and_load(model):
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "model.npz"
        model.save(path)
        return ltv.load(path)


def ilqg_case():
    from ltvmodels.control import QuadraticCost

    model = ltv.fit(*jump(), lam=10.0)
    cost = QuadraticCost(np.eye(2), 0.1 * np.eye(1), model.N)
    return ltv.ilqg(model, cost, np.array([1.0, 0.0]), np.zeros((model.N, 1)), max_iter=20)


def robot_case():
    from ltvmodels.apps import robot

    return robot.robot_experiment(seed=0)


def rl_case():
    from ltvmodels.apps import rl

    return rl.run_experiment(quick=True, runs=1, iterations=2, seed=0)


# -- the command line ---------------------------------------------------------------
def cli_cases() -> dict[str, list[str]]:
    return {
        "cli fit": [
            "fit",
            "{data}",
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--lam",
            "10",
            "--out",
            "{dir}/m.npz",
        ],
        "cli fit json": [
            "fit",
            "{data}",
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--lam",
            "2",
            "--norm",
            "l1",
            "--json",
        ],
        "cli fit auto": [
            "fit",
            "{data}",
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--lam",
            "auto",
            "--coef-out",
            "{dir}/coef.csv",
        ],
        "cli fit huber": [
            "fit",
            "{data}",
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--lam",
            "10",
            "--loss",
            "huber",
        ],
        "cli segments": [
            "segments",
            "{data}",
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--n-changes",
            "1",
        ],
        "cli ar": ["ar", "{data}", "--column", "x1", "--na", "2", "--lam", "10"],
        "cli select-lambda": [
            "select-lambda",
            "{data}",
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--method",
            "gcv",
        ],
        "cli simulate": ["simulate", "{dir}/m.npz", "{data}", "--state", "x1,x2", "--input", "u1"],
        "cli predict": ["predict", "{dir}/m.npz", "{data}", "--state", "x1,x2", "--input", "u1"],
        "cli forecast": [
            "forecast",
            "{dir}/m.npz",
            "{data}",
            "--steps",
            "3",
            "--future-input",
            "{future}",
            "--state",
            "x1,x2",
            "--input",
            "u1",
        ],
        "cli fit-many": [
            "fit-many",
            "{long}",
            "--by",
            "unit",
            "--state",
            "x1,x2",
            "--lam",
            "10",
            "--jobs",
            "1",
        ],
        "cli error": ["fit", "{data}", "--state", "x1,x2", "--input", "u1", "--lam", "-1"],
    }


def run_cli(argv: list[str], directory: str) -> dict:
    from ltvmodels.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
    written = {}
    for path in sorted(Path(directory).iterdir()):
        if path.suffix == ".csv" and path.name not in ("data.csv", "long.csv", "future.csv"):
            written[path.name] = path.read_text()
    return {
        "code": code,
        "stdout": out.getvalue().replace(directory, "{dir}"),
        "stderr": err.getvalue().replace(directory, "{dir}"),
        "files": written,
    }


def record_cli() -> dict:
    import pandas as pd

    results = {}
    with tempfile.TemporaryDirectory() as directory:
        x, u = jump()
        data = Path(directory) / "data.csv"
        pd.DataFrame({"x1": x[:, 0], "x2": x[:, 1], "u1": u[:, 0]}).to_csv(data, index=False)
        future = Path(directory) / "future.csv"
        pd.DataFrame({"u1": [0.1, -0.2, 0.3]}).to_csv(future, index=False)
        long = Path(directory) / "long.csv"
        parts = []
        for unit in range(3):
            xs, _ = jump(T=50, seed=unit)
            parts.append(pd.DataFrame({"unit": unit, "x1": xs[:, 0], "x2": xs[:, 1]}))
        pd.concat(parts).to_csv(long, index=False)
        for name, template in cli_cases().items():
            argv = [
                part.format(data=data, long=long, future=future, dir=directory) for part in template
            ]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                results[name] = run_cli(argv, directory)
    return results


# -- record and compare --------------------------------------------------------------
def record() -> dict:
    os.environ.setdefault("MPLBACKEND", "Agg")
    results = {name: run_case(call) for name, call in cases().items()}
    results.update(record_cli())
    return without_times(results)


def differences(before: Any, after: Any, where: str = "") -> list[str]:
    """Where ``after`` differs from ``before`` (with the largest array difference)."""
    if isinstance(before, np.ndarray) or isinstance(after, np.ndarray):
        a, b = np.asarray(before), np.asarray(after)
        if a.shape != b.shape or a.dtype.kind != b.dtype.kind:
            return [f"{where}: shape/dtype {a.shape} {a.dtype} -> {b.shape} {b.dtype}"]
        if a.dtype.kind in "fc":
            if np.array_equal(a, b, equal_nan=True):
                return []
            return [f"{where}: max |diff| {np.nanmax(np.abs(a - b)):.3g}"]
        return [] if np.array_equal(a, b) else [f"{where}: values differ"]
    if isinstance(before, dict) and isinstance(after, dict):
        found = []
        for key in sorted(set(before) | set(after)):
            if key not in before or key not in after:
                found.append(f"{where}.{key}: only {'after' if key in after else 'before'}")
            else:
                found += differences(before[key], after[key], f"{where}.{key}")
        return found
    if isinstance(before, list) and isinstance(after, list) and len(before) == len(after):
        found = []
        for i, (a, b) in enumerate(zip(before, after)):
            found += differences(a, b, f"{where}[{i}]")
        return found
    if isinstance(before, float) and isinstance(after, float):
        same = before == after or (np.isnan(before) and np.isnan(after))
        return [] if same else [f"{where}: {before!r} -> {after!r}"]
    return [] if before == after else [f"{where}: {str(before)[:80]!r} -> {str(after)[:80]!r}"]


def main() -> int:
    if len(sys.argv) != 3 or sys.argv[1] not in ("record", "compare"):
        print(__doc__)
        return 2
    mode, path = sys.argv[1], Path(sys.argv[2])
    results = record()
    if mode == "record":
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(pickle.dumps(results))
        print(f"recorded {len(results)} cases to {path}")
        return 0
    before = pickle.loads(path.read_bytes())
    differing = 0
    for name in sorted(set(before) | set(results)):
        if name not in before or name not in results:
            print(f"{name}: only {'after' if name in results else 'before'}")
            differing += 1
            continue
        found = differences(before[name], results[name])
        if found:
            differing += 1
            print(f"{name}: {len(found)} differences")
            for line in found[:8]:
                print(f"    {line}")
    print(f"{len(results) - differing} of {len(results)} cases identical, {differing} differ")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
