"""The ``ltvmodels`` command: ltvmodels.cli and ``python -m ltvmodels``."""

from __future__ import annotations

import subprocess
import sys

import pytest

import ltvmodels
from ltvmodels.apps.defaults import JUMP_LINEAR_LAM
from ltvmodels.apps.demos import run_jump_linear_demo
from ltvmodels.cli import main
from ltvmodels.errors import OutputPathError

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _is_png(path) -> bool:
    return path.is_file() and path.stat().st_size > 1000 and path.read_bytes()[:8] == PNG_MAGIC


def test_demo_writes_png_to_current_directory(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "jump-linear"]) == 0
    out, err = capsys.readouterr()
    assert _is_png(tmp_path / "ltvmodels-jump-linear.png")
    assert "LTVModel(N=399, n_states=2, n_inputs=1, norm='piecewise'" in out  # summary()
    assert "change points found: [200] (true: 200)" in out
    assert "norm='group', order=1, lambda = " in out
    assert "coefficient RMS error" in out and "one-step prediction RMS" in out
    assert "wrote ltvmodels-jump-linear.png" in out


def test_demo_out_option(tmp_path, capsys):
    target = tmp_path / "sub dir" / "fig.png"
    target.parent.mkdir()
    assert main(["demo", "jump-linear", "--out", str(target), "--seed", "1", "--lam", "20"]) == 0
    assert _is_png(target)
    out = capsys.readouterr().out
    assert "seed 1" in out and "lambda = 20" in out


def test_demo_via_python_m(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "ltvmodels", "demo", "jump-linear"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert "LTVModel(" in proc.stdout and "coefficient RMS error" in proc.stdout
    assert _is_png(tmp_path / "ltvmodels-jump-linear.png")


def test_bad_option_via_python_m(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "ltvmodels", "demo", "jump-linear", "--bogus"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--bogus" in lines[0], proc.stderr


@pytest.mark.parametrize(
    "argv, needle",
    [
        ([], "COMMAND"),
        (["demo"], "system"),
        (["demo", "no-such-system"], "no-such-system"),
        (["demo", "jump-linear", "--bogus"], "--bogus"),
        (["demo", "jump-linear", "--seed", "x"], "--seed"),
        (["demo", "jump-linear", "--seed", "-3"], "--seed"),
        (["demo", "jump-linear", "--lam", "-1"], "--lam"),
        (["demo", "jump-linear", "--lam", "inf"], "--lam"),
        (["demo", "jump-linear", "--out", "{tmp}/missing/x.png"], "does not exist"),
        (["demo", "jump-linear", "--out", "{tmp}"], "is a directory"),
        (["demo", "jump-linear", "--out", "{tmp}/x.nosuchformat"], "unsupported image format"),
    ],
)
def test_user_errors_exit_2_with_one_line(argv, needle, tmp_path, capsys):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("ltvmodels") and needle in lines[0]
    assert "Traceback" not in err
    assert not list(tmp_path.glob("**/*.png"))


def test_help_and_version(capsys):
    assert main(["--version"]) == 0
    assert ltvmodels.__version__ in capsys.readouterr().out
    assert main(["demo", "--help"]) == 0
    assert "jump-linear" in capsys.readouterr().out


def test_demo_function_results(tmp_path):
    import io

    stream = io.StringIO()
    result = run_jump_linear_demo(norm="sq", out=None, stream=stream)
    assert result["out"] is None and "wrote" not in stream.getvalue()
    assert result["coef_rms"] < 0.1
    assert result["coef_rms"] < 0.5 * result["coef_rms_lti"]
    assert result["pred_rms"] < result["pred_rms_lti"]
    assert result["model"].lam == JUMP_LINEAR_LAM
    assert len(result["figure"].axes) == 6
    with pytest.raises(OutputPathError, match="^out:"):
        run_jump_linear_demo(out=tmp_path / "missing" / "x.png", stream=stream)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_demo_default_is_paper_fig1(seed):
    """Group lasso + two-step refinement finds the switch within ±3 samples of 200."""
    import io

    result = run_jump_linear_demo(seed=seed, out=None, stream=io.StringIO())
    model = result["model"]
    assert model.norm == "piecewise" and model.info["first_step"]["norm"] == "group"
    assert model.info["first_step"]["converged"]
    assert len(result["changepoints"]) == 1 and abs(int(result["changepoints"][0]) - 200) <= 3
    assert result["coef_rms"] < 0.5 * result["coef_rms_lti"]


# -- fit / segments / ar / select-lambda / simulate / predict on data files -------------
import csv  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402

import numpy as np  # noqa: E402

from ltvmodels import systems  # noqa: E402
from ltvmodels.cli.report import jsonable  # noqa: E402
from ltvmodels.progress import Progress  # noqa: E402


def _read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A CSV of the jump-linear system (T = 200, switch at 100) with a text column."""
    root = tmp_path_factory.mktemp("cli")
    data = systems.jump_linear(T=200, change_at=100, seed=0)
    with open(root / "data.csv", "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["time", "label", "x1", "x2", "u"])
        for t in range(data.T):
            writer.writerow(
                [
                    t,
                    "before" if t < 100 else "after",
                    *(f"{v:.10g}" for v in data.x[t]),
                    f"{data.u[t, 0]:.10g}",
                ]
            )
    return root, data


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_fit_model_file_then_simulate_and_predict(workdir, capsys):
    root, data = workdir
    model_path, fig, sim_csv, pred_csv = (
        root / n for n in ("m.npz", "fit.png", "sim.csv", "pred.csv")
    )
    code, out, err = _run(
        [
            "fit",
            root / "data.csv",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--norm",
            "group",
            "--lam",
            "auto",
            "--refine",
            "--out",
            model_path,
            "--plot",
            fig,
        ],
        capsys,
    )
    assert code == 0, err
    assert "fit: norm='group', order=1, lambda = " in out and "criterion 'lcurve'" in out
    assert "two-step refinement" in out
    assert "change points: [100]" in out
    assert "one-step prediction RMS" in out and "open-loop simulation RMS" in out
    assert f"wrote {model_path}" in out and _is_png(fig)
    model = ltvmodels.load(model_path)
    assert dict(model.data.names) == {"state": ("x1", "x2"), "input": ("u",)}

    # the model file records its columns: no --state/--input needed
    code, out, err = _run(
        ["simulate", model_path, root / "data.csv", "--out", sim_csv, "--plot", root / "sim.png"],
        capsys,
    )
    assert code == 0, err
    assert "open-loop simulation of samples 0 to 199" in out and "RMS error" in out
    header, table = _read_csv(sim_csv)
    assert header == ["t", "x1", "x2"] and table.shape == (200, 3)
    np.testing.assert_allclose(
        table[:, 1:], model.simulate(data.x[0], data.u), rtol=1e-9, atol=1e-9
    )
    assert _is_png(root / "sim.png")

    code, out, err = _run(
        ["predict", model_path, root / "data.csv", "--out", pred_csv, "--json"], capsys
    )
    assert code == 0, err
    report = json.loads(out)
    assert report["start"] == 1 and report["rows"] == 199 and report["columns"] == ["x1", "x2"]
    header, table = _read_csv(pred_csv)
    np.testing.assert_array_equal(table[:, 0], np.arange(1, 200))
    np.testing.assert_allclose(table[:, 1:], model.predict(data.x, data.u), rtol=1e-9, atol=1e-9)
    assert report["rms"] == pytest.approx(np.sqrt(np.mean((table[:, 1:] - data.x[1:]) ** 2)))


def test_fit_json_is_strict_json(workdir, capsys):
    root, _ = workdir
    code, out, err = _run(
        [
            "fit",
            root / "data.csv",
            "--state",
            "2,3",
            "--input",
            "u",
            "--norm",
            "sq",
            "--lam",
            "30",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    assert "NaN" not in out and "Infinity" not in out
    report = json.loads(out)
    assert report["lam"] == 30.0 and report["norm"] == "sq" and report["order"] == 1
    assert report["state"] == ["x1", "x2"] and report["input"] == ["u"]
    assert isinstance(report["changepoints"], list)
    assert report["changepoint_rule"].startswith("peaks of the activation")
    assert report["converged"] is True and report["info"]["solver"].startswith("block-banded")
    assert set(report["rms"]) >= {"prediction", "simulation"}
    assert isinstance(report["loglik"], float) and report["warnings"] == []
    # group lasso: no likelihood (NaN) → null; auto λ records the criterion
    code, out, _ = _run(
        ["fit", root / "data.csv", "--state", "x1,x2", "--input", "u", "--norm", "l1", "--json"],
        capsys,
    )
    report = json.loads(out)
    assert code == 0 and report["loglik"] is None and report["lam_method"] == "lcurve"


def test_segments_ar_select_lambda(workdir, capsys):
    root, _ = workdir
    code, out, err = _run(
        [
            "segments",
            root / "data.csv",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--n-changes",
            "1",
            "--plot",
            root / "seg.png",
            "--out",
            root / "seg.npz",
        ],
        capsys,
    )
    assert code == 0, err
    assert "change points: [100]" in out and "dynamic programming" in out
    assert _is_png(root / "seg.png") and ltvmodels.load(root / "seg.npz").norm == "l0"
    code, out, _ = _run(
        [
            "segments",
            root / "data.csv",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--penalty",
            "bic",
            "--json",
        ],
        capsys,
    )
    report = json.loads(out)
    assert code == 0 and report["changepoints"] == [100] and report["penalty_rule"] == "bic"

    code, out, err = _run(
        [
            "select-lambda",
            root / "data.csv",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--plot",
            root / "sel.png",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    report = json.loads(out)
    assert report["method"] == "ml" and report["lam"] > 0
    assert len(report["candidates"]) == len(report["scores"]) >= 8  # a coarse grid, refined
    assert _is_png(root / "sel.png")
    code, out, _ = _run(
        ["select-lambda", root / "data.csv", "--state", "x1,x2", "--input", "u", "--norm", "l0"],
        capsys,
    )
    assert code == 0 and "chosen: number of changes 1" in out


def test_ar_root_spectrogram_and_model_file(tmp_path, capsys):
    y, _ = ltvmodels.systems.chirp(2**11, seed=0)
    np.savetxt(tmp_path / "chirp.csv", y[:, None], header="y", comments="")
    code, out, err = _run(
        [
            "ar",
            tmp_path / "chirp.csv",
            "--column",
            "y",
            "--na",
            "4",
            "--fs",
            "16000",
            "--lam",
            "300",
            "--plot",
            tmp_path / "ar.png",
            "--out",
            tmp_path / "ar.npz",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    report = json.loads(out)
    low, high = report["median_pole_frequencies"]
    assert 2000 < low < 3000 and 4800 < high < 5200
    assert _is_png(tmp_path / "ar.png")
    code, out, err = _run(["simulate", tmp_path / "ar.npz", tmp_path / "chirp.csv"], capsys)
    assert code == 0 and "open-loop simulation of samples 4 to 2047" in out, err
    code, out, err = _run(["predict", tmp_path / "ar.npz", tmp_path / "chirp.csv"], capsys)
    assert code == 0 and "one-step prediction of samples 4 to 2047" in out, err


def test_headerless_csv_stdin_and_semicolons(tmp_path, monkeypatch, capsys):
    data = systems.jump_linear(T=60, change_at=30, seed=1)
    text = "\n".join(";".join(f"{v:.10g}" for v in row) for row in np.hstack([data.x, data.u]))
    monkeypatch.setattr(sys, "stdin", io.StringIO("# a comment\n" + text + "\n"))
    code, out, err = _run(
        ["fit", "-", "--no-header", "--state", "0,1", "--input", "2", "--lam", "10", "--json"],
        capsys,
    )
    assert code == 0, err
    report = json.loads(out)
    assert report["data"] == "standard input" and report["T"] == 60
    assert report["state"] == ["0", "1"]


def test_parquet_through_pandas(workdir, tmp_path, capsys):
    """A real Parquet file (written and read by pandas with pyarrow; skipped without it)."""
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    _, data = workdir
    frame = pd.DataFrame(
        {"x1": data.x[:, 0], "x2": data.x[:, 1], "u": data.u[:, 0], "note": ["a"] * data.T}
    )
    frame.to_parquet(tmp_path / "d.parquet")
    code, out, err = _run(
        [
            "fit",
            tmp_path / "d.parquet",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--lam",
            "30",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    report = json.loads(out)
    assert report["T"] == data.T
    # the same numbers as the fit of the arrays themselves
    direct = ltvmodels.fit(data.x, data.u, lam=30.0)
    assert report["noise_var"] == pytest.approx(list(direct.noise_var), rel=1e-12)
    code, out, err = _run(["fit", tmp_path / "d.parquet", "--state", "note"], capsys)
    assert code == 2 and "column 'note' is not numeric" in err


def test_parquet_without_an_engine_says_what_to_install(workdir, tmp_path, capsys):
    """Without pyarrow/fastparquet a .parquet file is a clean user error (exit 2)."""
    pytest.importorskip("pandas")
    for engine in ("pyarrow", "fastparquet"):
        try:
            __import__(engine)
        except ImportError:
            continue
        pytest.skip(f"{engine} is installed: Parquet can be read here")
    (tmp_path / "d.parquet").write_bytes(b"PAR1")
    code, _, err = _run(["fit", tmp_path / "d.parquet", "--state", "x1"], capsys)
    assert code == 2 and "pyarrow" in err and "d.parquet" in err, err


def test_warnings_are_one_line_each(workdir, capsys):
    root, _ = workdir
    code, out, err = _run(
        [
            "fit",
            root / "data.csv",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--norm",
            "group",
            "--lam",
            "3",
            "--max-iter",
            "1",
        ],
        capsys,
    )
    assert code == 0
    lines = err.strip().splitlines()
    assert lines and all(line.startswith("ltvmodels fit: warning: ") for line in lines), err
    assert "ConvergenceWarning" in err and "NOT converged" in out


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["fit", "{tmp}/missing.csv", "--state", "x1"], "missing.csv: no such file"),
        (["fit", "{tmp}", "--state", "x1"], "is a directory"),
        (["fit", "{data}", "--state", "x1,x9"], "--state: no column 'x9'"),
        (["fit", "{data}", "--state", "x1", "--input", "7"], "--input: no index '7'"),
        (["fit", "{data}", "--state", "x1,x2", "--input", "x2"], "also selected by --state"),
        (["fit", "{data}", "--state", "label"], "'before' is not a number"),
        (["fit", "{data}", "--state", "x1", "--norm", "l2"], "--norm"),
        (["fit", "{data}", "--state", "x1", "--lam", "lots"], "--lam"),
        (["fit", "{data}", "--state", "x1", "--order", "0"], "--order"),
        (["fit", "{data}"], "--state"),
        (["fit", "{data}", "--state", "x1", "--bogus"], "--bogus"),
        (["fit", "{data}", "--state", "x1", "--plot", "{tmp}/no/f.png"], "--plot: cannot write"),
        (["fit", "{data}", "--state", "x1", "--plot", "{tmp}/f.nosuch"], "--plot: unsupported"),
        (["fit", "{data}", "--state", "x1", "--out", "{tmp}/no/m.npz"], "--out: cannot write"),
        (
            ["fit", "{bad}", "--state", "a,b"],
            "bad.csv, line 3, column 'b': 'x' is not a number; expected a number, or an empty "
            "cell, NA, N/A, NaN or null for a missing value",
        ),
        (["fit", "{inf}", "--state", "b"], "inf.csv, line 3, column 'b': 'inf' is not finite"),
        (
            ["fit", "{inf}", "--state", "a"],
            "inf.csv, line 4, column 'a': '-Infinity' is not "
            "finite; expected a finite number, or an empty cell",
        ),
        (
            ["simulate", "{model}", "{gap}"],
            "--input: "
            "{gap}: input u is missing at sample 5; "
            "an open-loop simulation needs every input",
        ),
        (
            ["simulate", "{model}", "{gap0}"],
            "--state: "
            "{gap0}: the initial state must be "
            "observed, received a missing value of x2 at sample 0",
        ),
        (["fit", "{data}", "--state", "x1", "--constant", "yes"], "unrecognized arguments: yes"),
        (["fit", "{ragged}", "--state", "a"], "ragged.csv, line 3: expected 2 fields"),
        (["fit", "{data}", "--state", "time,x1", "--lam", "0", "--order", "3"], "singular"),
        (["fit", "{tmp}/d.parquet", "--state", "a"], "d.parquet"),
        (
            ["segments", "{data}", "--state", "x1", "--n-changes", "1", "--penalty", "2"],
            "n_changes, penalty: expected one of them",
        ),
        (["segments", "{data}", "--state", "x1", "--n-changes", "500"], "--n-changes: 500"),
        (["ar", "{data}", "--column", "x1", "--na", "500"], "--column data: the series is"),
        (
            ["select-lambda", "{data}", "--state", "x1", "--norm", "group", "--method", "ml"],
            "--method: expected one of",
        ),
        (["select-lambda", "{data}"], "--state: expected the state columns"),
        (["simulate", "{tmp}/none.npz", "{data}"], "none.npz: no such file"),
        (["simulate", "{data}", "{data}"], "not an ltvmodels model file"),
        (["simulate", "{model}", "{short}"], "expected T = 200 rows"),
        (["predict", "{model}", "{data}", "--state", "x1"], "the model has 2 states"),
        (["predict", "{model}", "{data}", "--input", "zz"], "--input: no column 'zz'"),
        (["demo", "robot", "--norm", "sq"], "--norm: applies to the jump-linear demo only"),
        (["demo", "robot", "--quick"], "--quick"),
        (["demo", "chirp", "--full"], "--full"),
    ],
)
def test_data_commands_user_errors_exit_2(argv, needle, workdir, tmp_path, capsys):
    root, data = workdir
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n3,x\n5,6\n")
    (tmp_path / "inf.csv").write_text("a,b\n1,2\n3,inf\n-Infinity,6\n")
    rows = [f"{a:.10g},{b:.10g},{c:.10g}" for a, b, c in np.hstack([data.x, data.u])]
    gap, gap0 = rows.copy(), rows.copy()
    gap[5] = gap[5].rsplit(",", 1)[0] + ",NA"  # u[5]
    gap0[0] = gap0[0].split(",")[0] + ",," + gap0[0].rsplit(",", 1)[1]  # x2[0]
    (tmp_path / "gap.csv").write_text("x1,x2,u\n" + "\n".join(gap) + "\n")
    (tmp_path / "gap0.csv").write_text("x1,x2,u\n" + "\n".join(gap0) + "\n")
    (tmp_path / "ragged.csv").write_text("a,b\n1,2\n3\n")
    (tmp_path / "d.parquet").write_bytes(b"not parquet")
    (tmp_path / "short.csv").write_text("x1,x2,u\n" + "1,2,3\n" * 50)
    model = tmp_path / "model.npz"
    if "{model}" in argv:
        fitted = ltvmodels.fit(data.x, data.u, lam=10.0)
        fitted = fitted.with_data(fitted.data.renamed({"state": ["x1", "x2"], "input": ["u"]}))
        fitted.save(model)
    subs = {
        "{tmp}": str(tmp_path),
        "{data}": str(root / "data.csv"),
        "{model}": str(model),
        "{bad}": str(tmp_path / "bad.csv"),
        "{ragged}": str(tmp_path / "ragged.csv"),
        "{short}": str(tmp_path / "short.csv"),
        "{inf}": str(tmp_path / "inf.csv"),
        "{gap}": str(tmp_path / "gap.csv"),
        "{gap0}": str(tmp_path / "gap0.csv"),
    }
    for key, value in subs.items():
        argv = [a.replace(key, value) for a in argv]
        needle = needle.replace(key, value)
    code, out, err = _run(argv, capsys)
    assert code == 2, (out, err)
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"ltvmodels {argv[0]}: error: ") and needle in lines[0], lines[0]
    assert not list(tmp_path.glob("*.png"))


def test_user_error_via_python_m_has_no_traceback(workdir):
    root, _ = workdir
    proc = subprocess.run(
        [sys.executable, "-m", "ltvmodels", "fit", str(root / "data.csv"), "--state", "nope"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.strip() == (
        f"ltvmodels fit: error: --state: no column 'nope' in "
        f"{root / 'data.csv'} (columns: time, label, x1, x2, u)"
    )


@pytest.mark.parametrize(
    "argv, figures",
    [
        (["demo", "robot", "--out", "{tmp}/r.png"], ["r_train.png", "r_validation.png"]),
        (["demo", "chirp", "--quick", "--out", "{tmp}/c.png"], ["c.png"]),
        (["demo", "rl", "--quick", "--out", "{tmp}/rl.png"], ["rl.png"]),
    ],
)
def test_other_demos_write_pngs(argv, figures, tmp_path, capsys):
    code, out, err = _run([a.replace("{tmp}", str(tmp_path)) for a in argv], capsys)
    assert code == 0, err
    for name in figures:
        assert _is_png(tmp_path / name) and f"wrote {tmp_path / name}" in out


def test_demo_default_output_names(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "chirp", "--quick"]) == 0
    assert _is_png(tmp_path / "ltvmodels-chirp.png")
    assert "order 2: mean error" in capsys.readouterr().out


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_only_on_a_terminal():
    import time as _time

    tty = _Terminal()
    with Progress("working", total=4, stream=tty, delay=0.0, interval=0.01) as bar:
        bar.advance(2)
        _time.sleep(0.1)
    text = tty.getvalue()
    assert "working [############............] 2/4" in text
    assert text.endswith("\r")  # the line is erased at the end
    piped = io.StringIO()
    with Progress("working", stream=piped, delay=0.0, interval=0.01):
        _time.sleep(0.05)
    assert piped.getvalue() == ""


def test_jsonable_converts_numpy_and_non_finite():
    value = {
        "a": np.float64(np.nan),
        "b": np.array([1.0, np.inf]),
        "c": np.int64(3),
        "d": (np.bool_(True), None),
        4: float("-inf"),
    }
    assert jsonable(value) == {"a": None, "b": [1.0, None], "c": 3, "d": [True, None], "4": None}
    json.dumps(jsonable(value), allow_nan=False)


def test_help_lists_every_subcommand(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in ("fit", "segments", "ar", "select-lambda", "simulate", "predict", "demo"):
        assert command in out
    assert main(["demo", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(s in out for s in ("jump-linear", "robot", "chirp", "rl"))


# -- missing values, --constant, autonomous systems ------------------------------------
MISSING_CELLS = {
    (10, 0): "",
    (50, 2): "NA",
    (120, 1): "NaN",
    (150, 0): "n/a",
    (170, 1): "nan",
    (30, 2): "null",
}
"""(row, column) of x1, x2, u → the text of a missing cell in missing.csv."""


@pytest.fixture(scope="module")
def missing_csv(workdir):
    """workdir's data with six missing cells written six ways, and the same array with NaN."""
    root, data = workdir
    values = np.hstack([data.x, data.u])
    cells = [[f"{v:.10g}" for v in row] for row in values]
    for (t, j), text in MISSING_CELLS.items():
        cells[t][j] = text
        values[t, j] = np.nan
    with open(root / "missing.csv", "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["x1", "x2", "u"])
        writer.writerows(cells)
    return root / "missing.csv", values[:, :2], values[:, 2:]


def _complete_transitions(x, u):
    ok = np.all(np.isfinite(x[:-1]), axis=1) & np.all(np.isfinite(x[1:]), axis=1)
    return ok if u is None else ok & np.all(np.isfinite(u[:-1]), axis=1)


def test_fit_with_missing_values_matches_the_api(missing_csv, tmp_path, capsys):
    path, x, u = missing_csv
    n_missing = int(np.sum(~_complete_transitions(x, u)))
    assert n_missing == 10  # x1: 2 + 2 transitions, x2: 2 + 2, u: 1 + 1
    code, out, err = _run(
        [
            "fit",
            path,
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--lam",
            "10",
            "--out",
            tmp_path / "m.npz",
        ],
        capsys,
    )
    assert code == 0, err
    assert (
        f"missing: {n_missing} of 199 transitions left out (missing values: x1 2, x2 2, "
        "u 2; a transition enters the fit only if x[t], u[t] and x[t+1] are observed)"
    ) in out
    assert "one-step prediction RMS: " in out and "observed samples only" in out
    assert "open-loop simulation: not computed (input u is missing at sample 30" in out
    saved = ltvmodels.load(tmp_path / "m.npz")
    api = ltvmodels.fit(x, u, lam=10.0)
    assert api.n_missing == n_missing
    assert np.all(np.isfinite(saved.k)) and np.allclose(saved.k, api.k)

    code, out, err = _run(
        ["fit", path, "--state", "x1,x2", "--input", "u", "--lam", "10", "--json"], capsys
    )
    report = json.loads(out)
    assert code == 0 and report["n_missing"] == n_missing
    assert report["missing_values"] == {"x1": 2, "x2": 2, "u": 2}
    pred = api.predict(x, u)  # NaN where x[t] or u[t] is missing
    valid = np.isfinite(pred) & np.isfinite(x[1:])  # every observed target value
    assert np.count_nonzero(~valid) == 2 * 6 + 4  # 6 rows not computed, 4 targets missing
    expected = np.sqrt(np.mean((pred - x[1:])[valid] ** 2))
    assert report["rms"]["prediction"] == pytest.approx(expected)
    assert report["rms"]["simulation"] is None and "input u" in report["rms"]["simulation_skipped"]


def test_segments_ar_select_lambda_with_missing_values(missing_csv, capsys):
    path, x, u = missing_csv
    code, out, err = _run(
        ["segments", path, "--state", "x1,x2", "--input", "u", "--n-changes", "1", "--json"], capsys
    )
    assert code == 0, err
    report = json.loads(out)
    api = ltvmodels.fit_segments(x, u, n_changes=1)
    assert report["n_missing"] == api.n_missing == 10
    assert report["changepoints"] == [int(c) for c in api.changepoints] == [100]

    # AR: a step enters only if y[t] and its 2 lags are observed: x1 missing at 10 and 150
    code, out, err = _run(["ar", path, "--column", "x1", "--na", "2", "--lam", "10"], capsys)
    assert code == 0, err
    assert "missing: 6 of 198 time steps left out (missing values: x1 2;" in out
    code, out, err = _run(
        ["ar", path, "--column", "x1", "--na", "2", "--constant", "--json"], capsys
    )
    ar = json.loads(out)
    assert code == 0 and ar["n_missing"] == 6 and ar["constant"] is True
    assert ar["lam"] == pytest.approx(ltvmodels.fit_ar(x[:, 0], 2, lam="auto", constant=True).lam)
    assert ar["lam"] != pytest.approx(ltvmodels.fit_ar(x[:, 0], 2, lam="auto").lam)
    # select-lambda leaves out the same AR rows: the same choice as ar --lam auto
    code, out, err = _run(
        ["select-lambda", path, "--column", "x1", "--na", "2", "--constant", "--json"], capsys
    )
    assert code == 0, err
    sel = json.loads(out)
    assert sel["n_missing"] == 6 and sel["lam"] == pytest.approx(ar["lam"])
    code, out, err = _run(
        ["select-lambda", path, "--state", "x1,x2", "--input", "u", "--json"], capsys
    )
    assert code == 0, err
    sel = json.loads(out)
    assert sel["n_missing"] == 10
    assert sel["lam"] == pytest.approx(ltvmodels.select_lambda(x, u).lam)


def test_predict_with_missing_values(missing_csv, workdir, tmp_path, capsys):
    path, x, u = missing_csv
    _, data = workdir
    model = ltvmodels.fit(data.x, data.u, lam=10.0)
    model = model.with_data(model.data.renamed({"state": ["x1", "x2"], "input": ["u"]}))
    model.save(tmp_path / "m.npz")
    code, out, err = _run(
        ["predict", tmp_path / "m.npz", path, "--out", tmp_path / "p.csv"], capsys
    )
    assert code == 0, err
    # x[t] or u[t] missing at t = 10, 30, 50, 120, 150, 170
    assert "6 not computed (they need a missing sample)" in out
    _, table = _read_csv(tmp_path / "p.csv")
    expected = model.predict(x, u)
    assert np.array_equal(np.isnan(table[:, 1:]), np.isnan(expected))
    assert set(np.flatnonzero(np.isnan(table[:, 1]))) == {10, 30, 50, 120, 150, 170}
    np.testing.assert_allclose(table[:, 1:], expected, rtol=1e-9, atol=1e-9, equal_nan=True)


def test_headerless_csv_with_a_missing_first_cell(tmp_path, monkeypatch, capsys):
    """With --no-header, a first row with an empty cell or NA is data."""
    data = systems.jump_linear(T=60, change_at=30, seed=1)
    values = np.hstack([data.x, data.u])
    rows = [",".join(f"{v:.10g}" for v in row) for row in values]
    rows[0] = "NA," + rows[0].split(",", 1)[1]
    rows[1] = "," + rows[1].split(",", 1)[1]
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n".join(rows) + "\n"))
    code, out, err = _run(
        ["fit", "-", "--no-header", "--state", "0,1", "--input", "2", "--lam", "10", "--json"],
        capsys,
    )
    assert code == 0, err
    report = json.loads(out)
    assert report["T"] == 60 and report["missing_values"] == {"0": 2, "1": 0, "2": 0}
    assert report["n_missing"] == 2  # transitions 0 → 1 and 1 → 2


def test_constant_on_fit_segments_select_lambda(workdir, tmp_path, capsys):
    root, data = workdir
    common = [root / "data.csv", "--state", "x1,x2", "--input", "u", "--constant"]
    code, out, err = _run(["fit", *common, "--lam", "10", "--out", tmp_path / "f.npz"], capsys)
    assert code == 0, err
    assert "with a constant term c_t" in out and "constant=True" in out
    saved = ltvmodels.load(tmp_path / "f.npz")
    api = ltvmodels.fit(data.x, data.u, lam=10.0, constant=True)
    assert saved.constant and saved.k.shape == (199, 2 * (2 + 1 + 1))
    assert np.allclose(saved.k, api.k) and np.allclose(saved.c, api.c)

    code, out, err = _run(
        ["segments", *common, "--n-changes", "1", "--out", tmp_path / "s.npz", "--json"], capsys
    )
    assert code == 0, err
    assert json.loads(out)["constant"] is True
    saved = ltvmodels.load(tmp_path / "s.npz")
    api = ltvmodels.fit_segments(data.x, data.u, n_changes=1, constant=True)
    assert saved.constant and np.allclose(saved.k, api.k)
    assert saved.info["min_size"] == 4  # n + m + 1

    code, out, err = _run(["select-lambda", *common, "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    with_c = ltvmodels.select_lambda(data.x, data.u, constant=True)
    without = ltvmodels.select_lambda(data.x, data.u)
    assert report["constant"] is True
    assert np.allclose(report["scores"], with_c.scores)
    assert (
        len(without.scores) != len(with_c.scores)  # the constant changes the criterion
        or not np.allclose(with_c.scores, without.scores)
    )


def test_predict_and_simulate_include_the_constant(workdir, tmp_path, capsys):
    root, data = workdir
    code, _, err = _run(
        [
            "fit",
            root / "data.csv",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--lam",
            "10",
            "--constant",
            "--out",
            tmp_path / "c.npz",
        ],
        capsys,
    )
    assert code == 0, err
    model = ltvmodels.load(tmp_path / "c.npz")
    assert np.any(model.c != 0)
    for command, expected in (
        ("predict", model.predict(data.x, data.u)),
        ("simulate", model.simulate(data.x[0], data.u)),
    ):
        code, out, err = _run(
            [command, tmp_path / "c.npz", root / "data.csv", "--out", tmp_path / f"{command}.csv"],
            capsys,
        )
        assert code == 0 and "constant=True" in out, err
        _, table = _read_csv(tmp_path / f"{command}.csv")
        np.testing.assert_allclose(table[:, 1:], expected, rtol=1e-9, atol=1e-9)


@pytest.fixture(scope="module")
def autonomous(workdir):
    """The states of workdir's data alone: an autonomous system (no --input)."""
    root, data = workdir
    np.savetxt(root / "auto.csv", data.x, delimiter=",", header="x1,x2", comments="")
    return root / "auto.csv", np.loadtxt(root / "auto.csv", delimiter=",", skiprows=1)


@pytest.mark.parametrize("command", ["fit", "segments", "select-lambda", "select-lambda l0"])
def test_commands_without_input(command, autonomous, tmp_path, capsys):
    path, x = autonomous
    name, *norm = command.split()
    extra = {
        "fit": ["--lam", "10", "--out", tmp_path / "m.npz"],
        "segments": ["--n-changes", "1", "--out", tmp_path / "m.npz"],
        "select-lambda": ["--norm", *norm] if norm else [],
    }[name]
    code, out, err = _run([name, path, "--state", "x1,x2", *extra, "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["input"] == [] and report["T"] == 200
    if name == "fit":
        api = ltvmodels.fit(x, None, lam=10.0)
    elif name == "segments":
        api = ltvmodels.fit_segments(x, None, n_changes=1)
    else:
        api = ltvmodels.select_lambda(x, None, norm=norm[0] if norm else "sq")
        assert report["n_changes" if norm else "lam"] == pytest.approx(api.lam)
        return
    model = ltvmodels.load(tmp_path / "m.npz")
    assert model.n_inputs == 0 and np.allclose(model.k, api.k)
    assert report["noise_var"] == pytest.approx(list(api.noise_var))
    assert report["rms"]["simulation"] is not None


@pytest.mark.parametrize("command", ["predict", "simulate"])
def test_predict_simulate_without_input(command, autonomous, tmp_path, capsys):
    path, x = autonomous
    model = ltvmodels.fit(x, None, lam=10.0, constant=True)
    model = model.with_data(model.data.renamed({"state": ["x1", "x2"], "input": []}))
    model.save(tmp_path / "m.npz")
    code, out, err = _run([command, tmp_path / "m.npz", path, "--out", tmp_path / "r.csv"], capsys)
    assert code == 0, err
    assert "inputs (none)" in out
    _, table = _read_csv(tmp_path / "r.csv")
    expected = model.predict(x) if command == "predict" else model.simulate(x[0])
    np.testing.assert_allclose(table[:, 1:], expected, rtol=1e-9, atol=1e-9)
    # an autonomous model refuses inputs
    code, _, err = _run([command, tmp_path / "m.npz", path, "--input", "x2"], capsys)
    assert code == 2 and "--input: the model has no inputs" in err


def test_noise_variance_per_state_in_reports(workdir, capsys):
    root, data = workdir
    code, out, err = _run(
        ["fit", root / "data.csv", "--state", "x1,x2", "--input", "u", "--lam", "10"], capsys
    )
    assert code == 0, err
    api = ltvmodels.fit(data.x, data.u, lam=10.0)
    assert api.noise_var.shape == (2,)
    v1, v2 = (f"{v:.4g}" for v in api.noise_var)
    assert f"noise variance: x1 {v1}, x2 {v2}" in out
    code, out, _ = _run(
        ["fit", root / "data.csv", "--state", "x1,x2", "--input", "u", "--lam", "10", "--json"],
        capsys,
    )
    assert json.loads(out)["noise_var"] == pytest.approx(list(api.noise_var))
    code, out, _ = _run(
        ["ar", root / "data.csv", "--column", "x1", "--na", "2", "--lam", "10", "--json"], capsys
    )
    report = json.loads(out)
    assert report["noise_var"] == pytest.approx(
        list(ltvmodels.fit_ar(data.x[:, 0], 2, lam=10.0).noise_var)
    )
    assert len(report["noise_var"]) == 1


def test_parquet_missing_values_and_inf(workdir, tmp_path, capsys):
    """Nulls in a Parquet file are missing values; inf is an error naming row and column."""
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    _, data = workdir
    x1 = data.x[:, 0].copy()
    x1[[7, 8]] = np.nan
    frames = {
        "ok": pd.DataFrame(
            {
                "x1": x1,
                "x2": data.x[:, 1],
                "u": pd.array([1] * 20 + [None] + [0] * 179, dtype="Int64"),
            }
        ),
        "inf": pd.DataFrame({"x1": np.where(np.arange(data.T) == 3, np.inf, x1)}),
    }
    for name, frame in frames.items():
        frame.to_parquet(tmp_path / f"{name}.parquet")
    code, out, err = _run(
        [
            "fit",
            tmp_path / "ok.parquet",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--lam",
            "30",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    report = json.loads(out)
    assert report["missing_values"] == {"x1": 2, "x2": 0, "u": 1}
    assert report["n_missing"] == 4  # transitions 6, 7, 8 (x1) and 20 (u)
    code, out, err = _run(["fit", tmp_path / "inf.parquet", "--state", "x1"], capsys)
    assert code == 2 and "row 3, column 'x1': value inf is not finite" in err


@pytest.mark.parametrize("command", ["fit", "segments"])
def test_model_out_must_be_an_npz_archive(command, tmp_path, capsys):
    """`--out coef.csv` used to write an NPZ archive named .csv: refused before any work."""
    data = ltvmodels.systems.jump_linear(T=60, change_at=30, seed=0)
    path = tmp_path / "data.csv"
    np.savetxt(path, np.c_[data.x, data.u], delimiter=",", header="x1,x2,u1", comments="")
    extra = ["--lam", "5"] if command == "fit" else ["--n-changes", "1"]
    code = main(
        [
            command,
            str(path),
            "--state",
            "x1,x2",
            "--input",
            "u1",
            *extra,
            "--out",
            str(tmp_path / "coef.csv"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and "out: a model file is an .npz archive" in err
    assert "'" + str(tmp_path / "coef.csv") + "'" in err
    assert not (tmp_path / "coef.csv").exists()


def test_forecast_command_matches_the_model_forecast(tmp_path, capsys):
    data = ltvmodels.systems.jump_linear(seed=0)
    path = tmp_path / "data.csv"
    np.savetxt(path, np.c_[data.x, data.u], delimiter=",", header="x1,x2,u1", comments="")
    future = np.random.default_rng(1).standard_normal((12, 1))
    np.savetxt(tmp_path / "future.csv", future, delimiter=",", header="u1", comments="")
    assert (
        main(
            [
                "fit",
                str(path),
                "--state",
                "x1,x2",
                "--input",
                "u1",
                "--lam",
                "10",
                "--out",
                str(tmp_path / "m.npz"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    code = main(
        [
            "forecast",
            str(tmp_path / "m.npz"),
            str(path),
            "--steps",
            "6",
            "--future-input",
            str(tmp_path / "future.csv"),
            "--level",
            "0.8",
            "--json",
            "--out",
            str(tmp_path / "fc.csv"),
            "--plot",
            str(tmp_path / "fc.png"),
        ]
    )
    report = __import__("json").loads(capsys.readouterr().out)
    assert code == 0 and report["steps"] == 6 and report["columns"] == ["x1", "x2"]
    model = ltvmodels.load(tmp_path / "m.npz")
    expected = model.forecast(data.x[-1], np.r_[data.u[-1:], future[:5]], level=0.8)
    np.testing.assert_allclose(report["mean"], expected.mean)
    np.testing.assert_allclose(report["lower"], expected.lower)
    table = np.loadtxt(tmp_path / "fc.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], np.arange(400, 406))
    np.testing.assert_allclose(table[:, [1, 4]], expected.mean)
    assert (tmp_path / "fc.png").stat().st_size > 0
    # an input model needs the future inputs
    assert main(["forecast", str(tmp_path / "m.npz"), str(path), "--steps", "6"]) == 2
    assert "--future-input: the model has inputs (u1)" in capsys.readouterr().err


def test_forecast_command_of_an_ar_model(tmp_path, capsys):
    rng = np.random.default_rng(2)
    y = np.zeros(300)
    for t in range(2, 300):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.1 * rng.standard_normal()
    path = tmp_path / "series.csv"
    np.savetxt(path, y[:, None], delimiter=",", header="y", comments="")
    assert (
        main(
            [
                "ar",
                str(path),
                "--column",
                "y",
                "--na",
                "2",
                "--lam",
                "30",
                "--out",
                str(tmp_path / "ar.npz"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert main(["forecast", str(tmp_path / "ar.npz"), str(path), "--steps", "4", "--json"]) == 0
    report = __import__("json").loads(capsys.readouterr().out)
    expected = ltvmodels.load(tmp_path / "ar.npz").forecast(y[-2:], steps=4)
    np.testing.assert_allclose(report["mean"], expected.mean)
    assert (
        main(["forecast", str(tmp_path / "ar.npz"), str(path), "--steps", "4", "--level", "1.5"])
        == 2
    )
    assert "--level" in capsys.readouterr().err


def _fitted_series(kind: str):
    """A model of ``kind`` fitted on named columns, its data (T, ·) and column names."""
    pd = pytest.importorskip("pandas")
    rng = np.random.default_rng(7)
    if kind == "ltv":
        sim = ltvmodels.systems.jump_linear(T=150, change_at=75, seed=0)
        frame = pd.DataFrame(np.c_[sim.x, sim.u], columns=["x1", "x2", "u1"])
        return ltvmodels.fit(frame[["x1", "x2"]], frame[["u1"]], lam=10.0), frame
    u = rng.standard_normal(200)
    y = np.zeros(200)
    for t in range(3, 200):
        y[t] = 0.6 * y[t - 1] - 0.2 * y[t - 2] + (kind == "arx") * (u[t - 2] + 0.5 * u[t - 3])
        y[t] += 0.05 * rng.standard_normal()
    frame = pd.DataFrame({"y": y, "u": u})
    if kind == "arx":  # y[t] reads u[t−2], u[t−3]: nk = 2
        return ltvmodels.fit_arx(frame["y"], frame["u"], 2, 2, 2, lam=30.0), frame
    return ltvmodels.fit_ar(frame["y"], 2, lam=30.0), frame[["y"]]


@pytest.mark.parametrize("kind", ["ltv", "arx", "ar"])
def test_forecast_command_is_the_python_forecast_from_the_end_of_the_data(kind, tmp_path, capsys):
    """The report: Python's forecast(x0, u) took the last recorded input as u[0], the
    command line's --future-input only the rows after DATA. Both now take only the
    inputs after the data and give the same forecast."""
    model, frame = _fitted_series(kind)
    model.save(tmp_path / "m.npz")
    frame.to_csv(tmp_path / "data.csv", index=False)
    H = 6
    future = np.random.default_rng(8).standard_normal((H, 1))  # u[T] … u[T+5]
    argv = ["forecast", str(tmp_path / "m.npz"), str(tmp_path / "data.csv"), "--steps", str(H)]
    argv += ["--level", "0.8", "--seed", "5", "--json"]
    inputs: dict = {}

    def write_future(rows):
        np.savetxt(
            tmp_path / "future.csv", rows, delimiter=",", header=frame.columns[-1], comments=""
        )

    if kind != "ar":
        write_future(future)
        argv += ["--future-input", str(tmp_path / "future.csv")]
        inputs = {"u": future}
    assert main(argv) == 0, capsys.readouterr().err
    report = json.loads(capsys.readouterr().out)
    expected = model.forecast(steps=H, **inputs, level=0.8, seed=5)
    for name in ("mean", "lower", "upper"):
        np.testing.assert_allclose(report[name], getattr(expected, name), rtol=1e-12, atol=1e-12)
    if kind != "ar":  # only the rows the forecast reads are needed: H − 1, H − nk
        needed = model.future_input_rows(H)
        assert needed == {"ltv": H - 1, "arx": H - 2}[kind]
        write_future(future[:needed])
        assert main(argv) == 0, capsys.readouterr().err
        assert json.loads(capsys.readouterr().out)["mean"] == report["mean"]
        write_future(future[: needed - 1])
        assert main(argv) == 2
        assert f"expected at least {needed} rows of future inputs" in capsys.readouterr().err


def test_forecast_command_continues_the_end_of_its_data_file(tmp_path, capsys):
    """DATA need not be the data of the fit: the forecast starts from DATA's end."""
    model, _ = _fitted_series("ltv")
    model.save(tmp_path / "m.npz")
    other = ltvmodels.systems.jump_linear(T=150, change_at=75, seed=1)
    path = tmp_path / "other.csv"
    np.savetxt(path, np.c_[other.x, other.u], delimiter=",", header="x1,x2,u1", comments="")
    future = np.full((3, 1), 0.5)
    np.savetxt(tmp_path / "future.csv", future, delimiter=",", header="u1", comments="")
    argv = ["forecast", str(tmp_path / "m.npz"), str(path), "--steps", "4", "--json"]
    assert main([*argv, "--future-input", str(tmp_path / "future.csv")]) == 0
    report = json.loads(capsys.readouterr().out)
    expected = model.forecast(other.x[-1], np.r_[other.u[-1:], future])
    np.testing.assert_allclose(report["mean"], expected.mean, rtol=1e-12, atol=1e-12)
    gap = other.x.copy()
    gap[-1, 1] = np.nan
    np.savetxt(path, np.c_[gap, other.u], delimiter=",", header="x1,x2,u1", comments="")
    assert main([*argv, "--future-input", str(tmp_path / "future.csv")]) == 2
    err = capsys.readouterr().err
    assert "other.csv: the forecast continues the end of DATA, which has missing values" in err
    assert "(the last row of its state columns and the last row of its input columns)" in err


def test_fit_options_match_the_python_api(tmp_path, capsys):
    """--weights COL, --noise-var and --coef-out on fit; --loss and --weights on
    select-lambda; each the same as the library call."""
    data = ltvmodels.systems.jump_linear(T=120, change_at=60, seed=3)
    w = np.random.default_rng(0).uniform(0.5, 2.0, 120)
    path = tmp_path / "data.csv"
    np.savetxt(path, np.c_[data.x, data.u, w], delimiter=",", header="x1,x2,u1,w", comments="")
    base = ["fit", str(path), "--state", "x1,x2", "--input", "u1", "--lam", "5"]
    assert (
        main(
            [
                *base,
                "--weights",
                "w",
                "--noise-var",
                "0.04,0.05",
                "--json",
                "--out",
                str(tmp_path / "m.npz"),
                "--coef-out",
                str(tmp_path / "coef.csv"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    expected = ltvmodels.fit(data.x, data.u, lam=5.0, weights=w[1:], noise_var=[0.04, 0.05])
    model = ltvmodels.load(tmp_path / "m.npz")
    np.testing.assert_allclose(model.k, expected.k, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(model.noise_var, [0.04, 0.05])
    frame = __import__("pandas").read_csv(tmp_path / "coef.csv", index_col="t")
    np.testing.assert_allclose(frame.iloc[:, :6].to_numpy(), expected.k, atol=1e-10)
    assert frame.columns[0] == "A[x1,x1]" and frame.columns[6] == "A[x1,x1] std"
    code = main(
        [
            "select-lambda",
            str(path),
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--norm",
            "group",
            "--loss",
            "huber",
            "--weights",
            "w",
            "--json",
        ]
    )
    report = __import__("json").loads(capsys.readouterr().out)
    selection = ltvmodels.select_lambda(data.x, data.u, norm="group", loss="huber", weights=w[1:])
    assert code == 0 and report["method"] == "cv"
    assert report["lam"] == pytest.approx(selection.lam)
    np.savetxt(
        path,
        np.c_[data.x, data.u, np.r_[w[:50], np.nan, w[51:]]],
        delimiter=",",
        header="x1,x2,u1,w",
        comments="",
    )
    assert main([*base, "--weights", "w"]) == 2
    assert "--weights: the weights must be observed" in capsys.readouterr().err
    assert main([*base, "--noise-var", "-1"]) == 2
    assert "--noise-var" in capsys.readouterr().err


def _dated_recording(path):
    """The jump-linear recording (change at step 200) with a "date" column, one day per
    sample from 2020-01-01, written to ``path``; returns the data and the days."""
    data = ltvmodels.systems.jump_linear(seed=0)
    days = np.arange("2020-01-01", "2021-02-04", dtype="datetime64[D]")[:400]
    path.write_text(
        "date,x1,x2,u1\n"
        + "".join(
            f"{days[t]},{data.x[t, 0]:.17g},{data.x[t, 1]:.17g},{data.u[t, 0]:.17g}\n"
            for t in range(400)
        )
    )
    return data, days


def test_time_column_dates_the_change_points(tmp_path, capsys):
    """--time parses ISO dates (or numbers); change points are reported at the date of
    x[c]; the model keeps the times and indexes its coefficients by them."""
    path = tmp_path / "dated.csv"
    data, days = _dated_recording(path)
    code = main(
        [
            "fit",
            str(path),
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--norm",
            "group",
            "--lam",
            "30",
            "--time",
            "date",
            "--json",
            "--out",
            str(tmp_path / "m.npz"),
        ]
    )
    report = __import__("json").loads(capsys.readouterr().out)
    assert code == 0 and report["changepoints"] == [200]
    assert report["changepoint_times"] == ["2020-07-20"]  # x[201], the first new state
    model = ltvmodels.load(tmp_path / "m.npz")
    np.testing.assert_array_equal(model.time, days.astype("datetime64[ns]"))
    assert model.state_names == ["x1", "x2"] and model.to_frame().index.name == "time"
    path.write_text("date,x1\n01/02/2020,1\n01/03/2020,2\n01/04/2020,3\n")
    assert main(["fit", str(path), "--state", "x1", "--lam", "1", "--time", "date"]) == 2
    assert "expected numbers or ISO 8601 dates" in capsys.readouterr().err


def _svg_texts(path):
    """The texts of an SVG figure written by matplotlib (each drawn text follows a comment
    that holds it)."""
    import re

    return re.findall(r"<!-- (.*?) -->", path.read_text())


def test_plots_of_a_dated_recording_show_its_dates(tmp_path, capsys):
    """--plot with --time: the figures of fit, segments and forecast are drawn against the
    dates, the x axis named by the time column."""
    path = tmp_path / "dated.csv"
    _dated_recording(path)
    columns = ["--state", "x1,x2", "--input", "u1", "--time", "date"]
    model_file = tmp_path / "m.npz"
    fit = ["fit", str(path), *columns, "--norm", "group", "--lam", "30"]
    assert main([*fit, "--out", str(model_file), "--plot", str(tmp_path / "fit.svg")]) == 0
    segments = ["segments", str(path), *columns, "--n-changes", "1"]
    assert main([*segments, "--plot", str(tmp_path / "segments.svg")]) == 0
    forecast = ["forecast", str(model_file), str(path), "--steps", "2"]
    future = tmp_path / "future.csv"
    future.write_text("u1\n0\n0\n")
    forecast += ["--future-input", str(future), "--plot", str(tmp_path / "forecast.svg")]
    assert main(forecast) == 0
    capsys.readouterr()
    for figure in ("fit", "segments", "forecast"):
        texts = _svg_texts(tmp_path / f"{figure}.svg")
        assert "date" in texts and "sample" not in texts and "t" not in texts, figure
        assert "2021" in texts or "Jan" in texts, (figure, texts)  # date ticks, not numbers
    # the change points' dates label the activation (x[201], the first new state)
    assert "detected: 2020-07-20" in _svg_texts(tmp_path / "fit.svg")


def _weighted_ar_series(path, T, seed, name):
    """An AR(2) series y and weights w, written to ``path`` as columns ``name`` and w."""
    rng = np.random.default_rng(seed)
    y = np.zeros(T)
    for t in range(2, T):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.1 * rng.standard_normal()
    w = rng.uniform(0.5, 2.0, T)
    np.savetxt(path, np.c_[y, w], delimiter=",", header=f"{name},w", comments="")
    return y, w


def test_ar_command_takes_weights_noise_var_and_coef_out(tmp_path, capsys):
    path = tmp_path / "series.csv"
    y, w = _weighted_ar_series(path, 200, 4, "level")
    assert (
        main(
            [
                "ar",
                str(path),
                "--column",
                "level",
                "--na",
                "2",
                "--lam",
                "30",
                "--weights",
                "w",
                "--noise-var",
                "0.01",
                "--out",
                str(tmp_path / "ar.npz"),
                "--coef-out",
                str(tmp_path / "coef.csv"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    expected = ltvmodels.fit_ar(y, 2, lam=30.0, weights=w[2:], noise_var=0.01)
    model = ltvmodels.load(tmp_path / "ar.npz")
    np.testing.assert_allclose(model.k, expected.k, rtol=1e-12, atol=1e-12)
    header = (tmp_path / "coef.csv").read_text().splitlines()[0]
    assert header.startswith("t,level:level[t-1],level:level[t-2]")


def test_select_lambda_of_an_ar_column_takes_weights(tmp_path, capsys):
    path = tmp_path / "series.csv"
    y, w = _weighted_ar_series(path, 150, 5, "y")
    assert (
        main(["select-lambda", str(path), "--column", "y", "--na", "2", "--weights", "w", "--json"])
        == 0
    )
    report = __import__("json").loads(capsys.readouterr().out)
    expected = ltvmodels.select_lambda_regression(*ltvmodels.ar_regressors(y, 2), weights=w[2:])
    assert report["lam"] == pytest.approx(expected.lam)


# -- --time: AR change points at their dates; the same rules for every command ----------


def _ar2_with_a_change(sample, T=300, seed=0):
    """An AR(2) series whose coefficients change at ``sample`` (the first sample they
    produce): (1.5, −0.9) before it, (0.4, 0.3) from it on."""
    rng = np.random.default_rng(seed)
    y = np.zeros(T)
    for t in range(2, T):
        a1, a2 = (1.5, -0.9) if t < sample else (0.4, 0.3)
        y[t] = a1 * y[t - 1] + a2 * y[t - 2] + rng.standard_normal()
    return y


def _dated_csv(path, y, days, rows=None):
    """A CSV of columns date, level; only ``rows`` (default all), in their order."""
    rows = range(len(y)) if rows is None else rows
    path.write_text("date,level\n" + "".join(f"{days[t]},{y[t]:.17g}\n" for t in rows))
    return path


DAYS = np.arange("2020-01-01", "2021-01-01", dtype="datetime64[D]")


def test_ar_time_column_dates_the_change_point(tmp_path, capsys):
    """The change at sample 150 (2020-05-30) of a daily AR(2) series: model step 148,
    sample 150 and its date in the text, the JSON and the model; the coefficients'
    CSV is indexed by date."""
    y = _ar2_with_a_change(150)
    path = _dated_csv(tmp_path / "dated.csv", y, DAYS)
    base = ["ar", path, "--column", "level", "--na", "2", "--norm", "group", "--lam", "100"]
    code, out, err = _run([*base, "--time", "date", "--json", "--out", tmp_path / "m.npz"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["changepoints"] == [148]  # model steps: the rows of the regression
    assert report["changepoint_samples"] == [150]  # y[150], the first new sample
    assert report["changepoint_times"] == ["2020-05-30"] == [str(DAYS[150])]
    assert report["fs"] == 1.0 and report["frequency_unit"] == "cycles per day"
    model = ltvmodels.load(tmp_path / "m.npz")
    np.testing.assert_array_equal(model.time, DAYS[:300].astype("datetime64[ns]"))
    np.testing.assert_array_equal(model.changepoint_times, model.time[[150]])
    code, out, err = _run(
        [*base, "--time", "date", "--coef-out", tmp_path / "c.csv", "--plot", tmp_path / "a.png"],
        capsys,
    )
    assert code == 0, err
    assert (
        "change points: [148] (peaks of the activation ||(Dk)_t|| (ltvmodels.find_changepoints))"
        "; first samples under the new coefficients: [150], at times 2020-05-30" in out
    )
    rows = (tmp_path / "c.csv").read_text().splitlines()
    assert rows[0].startswith("time,level:level[t-1]") and rows[1].startswith("2020-01-03,")
    assert len(rows) == 1 + 298 and _is_png(tmp_path / "a.png")
    # Without --time: the same steps and samples, no dates.
    code, out, err = _run([*base, "--json"], capsys)
    report = json.loads(out)
    assert report["changepoint_samples"] == [150] and "changepoint_times" not in report


def test_ar_time_column_with_fs_scales_the_frequencies_only(tmp_path, capsys):
    """--fs with --time: frequencies in the unit of --fs (cycles per year for 365.25
    samples per year) instead of the time column's (cycles per day)."""
    path = _dated_csv(tmp_path / "dated.csv", _ar2_with_a_change(150), DAYS)
    base = ["ar", path, "--column", "level", "--na", "2", "--lam", "10", "--time", "date"]
    per_day = json.loads(_run([*base, "--json"], capsys)[1])
    per_year = json.loads(_run([*base, "--fs", "365.25", "--json"], capsys)[1])
    assert per_year["fs"] == 365.25 and per_year["frequency_unit"] == "cycles per time unit of --fs"
    np.testing.assert_allclose(
        per_year["median_pole_frequencies"],
        365.25 * np.array(per_day["median_pole_frequencies"]),
        rtol=1e-12,
    )


def test_ar_time_column_gap_is_missing_samples(tmp_path, capsys):
    """Days missing from the daily grid become missing samples, with the warning of fit
    --time; the model is the library's fit of the same dated series."""
    pd = pytest.importorskip("pandas")
    y = _ar2_with_a_change(150)
    kept = [t for t in range(300) if t not in (40, 41, 200)]
    path = _dated_csv(tmp_path / "gaps.csv", y, DAYS, kept)
    argv = ["ar", path, "--column", "level", "--na", "2", "--norm", "group", "--lam", "100"]
    code, out, err = _run([*argv, "--time", "date", "--json", "--out", tmp_path / "m.npz"], capsys)
    assert code == 0, err
    report = json.loads(out)
    notice = "--time: 3 time stamps missing from the regular grid of its index"
    assert any(notice in text and "DataWarning" in text for text in report["warnings"])
    assert report["T"] == 300 and report["missing_values"] == {"level": 3}
    assert report["changepoint_times"] == ["2020-05-30"]  # the grid keeps the dates' places
    series = pd.Series(y[kept], index=pd.DatetimeIndex(DAYS[kept]))
    with pytest.warns(ltvmodels.DataWarning, match="3 time stamps missing"):
        expected = ltvmodels.fit_ar(series, 2, norm="group", lam=100.0)
    model = ltvmodels.load(tmp_path / "m.npz")
    assert model.n_missing == expected.n_missing == report["n_missing"] == 7
    np.testing.assert_allclose(model.k, expected.k, rtol=1e-9, atol=1e-9)
    code, out, err = _run([*argv, "--time", "date"], capsys)
    assert code == 0 and f"ltvmodels ar: warning: DataWarning: {notice}" in err


TIME_COMMANDS = {
    "fit": ["fit", "--state", "level", "--lam", "1"],
    "segments": ["segments", "--state", "level", "--n-changes", "1"],
    "ar": ["ar", "--column", "level", "--na", "2", "--lam", "1"],
    "select-lambda --state": ["select-lambda", "--state", "level"],
    "select-lambda --column": ["select-lambda", "--column", "level", "--na", "2"],
}


@pytest.mark.parametrize("command", TIME_COMMANDS, ids=list(TIME_COMMANDS))
def test_every_command_reading_a_series_checks_its_time_column(command, tmp_path, capsys):
    """--time has one meaning everywhere: unsorted times are an error naming the row;
    days missing from the grid are missing samples, with one warning."""
    name, *options = TIME_COMMANDS[command]
    y = _ar2_with_a_change(60, T=120)
    unsorted = _dated_csv(tmp_path / "unsorted.csv", y, DAYS, [0, 1, 3, 2, *range(4, 120)])
    code, out, err = _run([name, unsorted, *options, "--time", "date"], capsys)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert (
        f"ltvmodels {name}: error: --time: the time index is not sorted: row 3 (2020-01-03) "
        "comes after row 2 (2020-01-04); sort the rows by time (sort the file by that column)"
    ) in err
    gaps = _dated_csv(tmp_path / "gaps.csv", y, DAYS, [t for t in range(120) if t != 30])
    code, out, err = _run([name, gaps, *options, "--time", "date", "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["T"] == 120 and report["missing_values"] == {"level": 1}
    assert report["warnings"] == [
        "DataWarning: --time: 1 time stamp missing from the regular grid of its index "
        "(2020-01-01 to 2020-04-29) were inserted as missing samples (NaN rows); "
        "model.n_missing counts what they leave out"
    ]


@pytest.mark.parametrize("first_line", ["1,2,3", "NA,nan,null", "0,1,NA"])
def test_a_first_line_of_numbers_or_missing_values_must_be_declared(first_line, tmp_path, capsys):
    # It was read as a data row: a header 0,1,2 (pandas' integer column names) became
    # a sample, and NA,nan,null a sample with no values.
    data = systems.jump_linear(T=60, change_at=30, seed=1)
    rows = [",".join(f"{v:.10g}" for v in row) for row in np.hstack([data.x, data.u])]
    path = tmp_path / "data.csv"
    path.write_text("\n".join([first_line, *rows]) + "\n")
    names = first_line.split(",")
    argv = ["fit", path, "--state", f"{names[0]},{names[1]}", "--lam", "10", "--json"]
    code, out, err = _run(argv, capsys)
    assert code == 2 and out == ""
    assert err.strip() == (
        f"ltvmodels fit: error: {path}, line 1: the first line {first_line!r} holds only "
        "numbers and missing values, so it could be column names or data; pass --header "
        "if it names the columns, --no-header if it is the first data row"
    )
    code, out, err = _run([*argv, "--header"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["T"] == 60 and report["state"] == names[:2]
    if first_line == "1,2,3":  # the data row: its columns 1 and 2, selected by index
        code, out, err = _run([*argv, "--no-header"], capsys)
        assert code == 0, err
        assert json.loads(out)["T"] == 61


def test_a_text_header_is_a_header_and_no_header_reads_it_as_data(workdir, capsys):
    root, _ = workdir
    argv = ["fit", root / "data.csv", "--state", "2,3", "--input", "4", "--lam", "10"]
    code, out, err = _run([*argv, "--json"], capsys)
    assert code == 0 and json.loads(out)["state"] == ["x1", "x2"], err
    code, out, err = _run([*argv, "--no-header"], capsys)
    assert code == 2
    assert "line 1, column '2': 'x1' is not a number" in err


def test_header_options_are_for_csv_files(workdir, tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    _, data = workdir
    pd.DataFrame({"x1": data.x[:, 0], "x2": data.x[:, 1]}).to_parquet(tmp_path / "d.parquet")
    code, out, err = _run(
        ["fit", tmp_path / "d.parquet", "--state", "x1,x2", "--lam", "1", "--no-header"], capsys
    )
    assert code == 2
    assert "--no-header: " in err and "is a Parquet file, whose columns always have names" in err


def test_columns_of_the_same_name_cannot_be_selected_together(tmp_path, capsys):
    # Selected by index, they gave a model of two states both named 'p'.
    data = systems.jump_linear(T=60, change_at=30, seed=1)
    rows = [",".join(f"{v:.10g}" for v in row) for row in np.hstack([data.x, data.u])]
    path = tmp_path / "twice.csv"
    path.write_text("\n".join(["p,p,u", *rows]) + "\n")
    code, out, err = _run(["fit", path, "--state", "0,1", "--input", "u", "--lam", "10"], capsys)
    assert code == 2
    assert f"--state: columns 0 and 1 of {path} are both named 'p'" in err
    assert "rename one of them in the file" in err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["fit", "--state", "p,v", "--lam", "1"], "--state data: state 'v' has no observed"),
        (["segments", "--state", "p,v", "--n-changes", "1"], "--state data: state 'v' has no"),
        (["select-lambda", "--state", "p,v"], "--state data: state 'v' has no observed"),
        (["ar", "--column", "v", "--na", "1", "--lam", "1"], "--column data: output 'v' has no"),
        (["select-lambda", "--column", "v", "--na", "1"], "--column data: output 'v' has no"),
        (["fit", "--state", "p,big", "--lam", "1"], "--state data: column 'big' has values of"),
        (["ar", "--column", "big", "--na", "1", "--lam", "1"], "--column data: column 'big' has"),
        (
            ["fit", "--state", "p,w", "--weights", "gap", "--lam", "1"],
            "--weights: the weights must be observed, received a missing value in column "
            "'gap' at row 5",
        ),
        (
            ["ar", "--column", "p", "--na", "2", "--weights", "gap", "--lam", "1"],
            "--weights: the weights must be observed, received a missing value in column "
            "'gap' at row 5",
        ),
    ],
)
def test_rejected_columns_are_named_as_in_the_file(argv, message, tmp_path, capsys):
    # The library's messages named them by position in the selection ("state 1", "column 1").
    data = systems.jump_linear(T=60, change_at=30, seed=1)
    path = tmp_path / "data.csv"
    lines = ["p,v,big,w,gap"] + [
        f"{x0:.10g},NA,{x1 * 1e200:.10g},{x1:.10g},{'NA' if t == 5 else 1}"
        for t, (x0, x1) in enumerate(data.x)
    ]
    path.write_text("\n".join(lines) + "\n")
    code, out, err = _run([argv[0], path, *argv[1:]], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert message in err, err


def test_irregular_times_are_read_as_consecutive_rows_with_irregular(tmp_path, capsys):
    """--time stamps on no grid are an error whose remedies are the command line's; with
    --irregular the rows are fitted as consecutive samples (Python's regular=False)."""
    pd = pytest.importorskip("pandas")
    d = ltvmodels.systems.jump_linear(T=120, change_at=60, seed=0)
    stamps = np.cumsum(np.random.default_rng(0).uniform(0.5, 1.5, 120))
    path = tmp_path / "irregular.csv"
    path.write_text(
        "t,p,v,f\n"
        + "".join(
            f"{t:.17g},{p:.17g},{v:.17g},{f:.17g}\n" for t, (p, v), f in zip(stamps, d.x, d.u[:, 0])
        )
    )
    base = ["fit", path, "--state", "p,v", "--input", "f", "--lam", "10", "--time", "t"]
    code, _, err = _run(base, capsys)
    assert code == 2
    assert "no regular grid" in err and "--irregular" in err
    assert "regular=False" not in err and "df.resample" not in err
    code, _, err = _run([*base, "--irregular", "--out", tmp_path / "m.npz"], capsys)
    assert code == 0, err
    model = ltvmodels.load(tmp_path / "m.npz")
    frame = pd.DataFrame({"p": d.x[:, 0], "v": d.x[:, 1]}, index=stamps)
    reference = ltvmodels.fit(
        frame, pd.DataFrame({"f": d.u[:, 0]}, index=stamps), lam=10.0, regular=False
    )
    np.testing.assert_allclose(model.k, reference.k, rtol=0, atol=1e-12)
    np.testing.assert_allclose(model.time, stamps)
    code, _, err = _run(["fit", path, "--state", "p,v", "--lam", "10", "--irregular"], capsys)
    assert code == 2 and "--irregular" in err and "give --time" in err


def test_segments_trim_is_a_fraction_of_the_transitions(workdir, capsys):
    root, _ = workdir
    base = ["segments", root / "data.csv", "--state", "x1,x2", "--input", "u"]
    code, out, err = _run([*base, "--n-changes", "1", "--trim", "0.15", "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    samples = len((root / "data.csv").read_text().splitlines()) - 1  # after the header
    assert report["info"]["min_size"] == int(0.15 * (samples - 1))
    code, _, err = _run([*base, "--trim", "0.15", "--min-size", "5"], capsys)
    assert code == 2 and "trim, min_size: both give" in err
