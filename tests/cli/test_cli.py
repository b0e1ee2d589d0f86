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
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert "LTVModel(" in proc.stdout and "coefficient RMS error" in proc.stdout
    assert _is_png(tmp_path / "ltvmodels-jump-linear.png")


def test_bad_option_via_python_m(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "ltvmodels", "demo", "jump-linear", "--bogus"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
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
from ltvmodels.cli.progress import Progress
from ltvmodels.cli.report import jsonable  # noqa: E402


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
            writer.writerow([t, "before" if t < 100 else "after",
                             *(f"{v:.10g}" for v in data.x[t]), f"{data.u[t, 0]:.10g}"])
    return root, data


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_fit_model_file_then_simulate_and_predict(workdir, capsys):
    root, data = workdir
    model_path, fig, sim_csv, pred_csv = (root / n for n in ("m.npz", "fit.png", "sim.csv",
                                                             "pred.csv"))
    code, out, err = _run(["fit", root / "data.csv", "--state", "x1,x2", "--input", "u",
                           "--norm", "group", "--lam", "auto", "--refine",
                           "--out", model_path, "--plot", fig], capsys)
    assert code == 0, err
    assert "fit: norm='group', order=1, lambda = " in out and "criterion 'lcurve'" in out
    assert "two-step refinement" in out
    assert "change points: [100]" in out
    assert "one-step prediction RMS" in out and "open-loop simulation RMS" in out
    assert f"wrote {model_path}" in out and _is_png(fig)
    model = ltvmodels.load(model_path)
    assert model.info["data_columns"] == {"state": ["x1", "x2"], "input": ["u"]}

    # the model file records its columns: no --state/--input needed
    code, out, err = _run(["simulate", model_path, root / "data.csv", "--out", sim_csv,
                           "--plot", root / "sim.png"], capsys)
    assert code == 0, err
    assert "open-loop simulation of samples 0 to 199" in out and "RMS error" in out
    header, table = _read_csv(sim_csv)
    assert header == ["t", "x1", "x2"] and table.shape == (200, 3)
    np.testing.assert_allclose(table[:, 1:], model.simulate(data.x[0], data.u), rtol=1e-9,
                               atol=1e-9)
    assert _is_png(root / "sim.png")

    code, out, err = _run(["predict", model_path, root / "data.csv", "--out", pred_csv,
                           "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["start"] == 1 and report["rows"] == 199 and report["columns"] == ["x1", "x2"]
    header, table = _read_csv(pred_csv)
    np.testing.assert_array_equal(table[:, 0], np.arange(1, 200))
    np.testing.assert_allclose(table[:, 1:], model.predict(data.x, data.u), rtol=1e-9,
                               atol=1e-9)
    assert report["rms"] == pytest.approx(np.sqrt(np.mean((table[:, 1:] - data.x[1:]) ** 2)))


def test_fit_json_is_strict_json(workdir, capsys):
    root, _ = workdir
    code, out, err = _run(["fit", root / "data.csv", "--state", "2,3", "--input", "u",
                           "--norm", "sq", "--lam", "30", "--json"], capsys)
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
    code, out, _ = _run(["fit", root / "data.csv", "--state", "x1,x2", "--input", "u",
                         "--norm", "l1", "--json"], capsys)
    report = json.loads(out)
    assert code == 0 and report["loglik"] is None and report["lam_method"] == "lcurve"


def test_segments_ar_select_lambda(workdir, capsys):
    root, _ = workdir
    code, out, err = _run(["segments", root / "data.csv", "--state", "x1,x2", "--input", "u",
                           "--n-changes", "1", "--plot", root / "seg.png", "--out",
                           root / "seg.npz"], capsys)
    assert code == 0, err
    assert "change points: [100]" in out and "dynamic programming" in out
    assert _is_png(root / "seg.png") and ltvmodels.load(root / "seg.npz").norm == "l0"
    code, out, _ = _run(["segments", root / "data.csv", "--state", "x1,x2", "--input", "u",
                         "--penalty", "bic", "--json"], capsys)
    report = json.loads(out)
    assert code == 0 and report["changepoints"] == [100] and report["penalty_rule"] == "bic"

    code, out, err = _run(["select-lambda", root / "data.csv", "--state", "x1,x2", "--input",
                           "u", "--plot", root / "sel.png", "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["method"] == "ml" and report["lam"] > 0
    assert len(report["candidates"]) == len(report["scores"]) == 30
    assert _is_png(root / "sel.png")
    code, out, _ = _run(["select-lambda", root / "data.csv", "--state", "x1,x2", "--input",
                         "u", "--norm", "l0"], capsys)
    assert code == 0 and "chosen: number of changes 1" in out


def test_ar_root_spectrogram_and_model_file(tmp_path, capsys):
    y, _ = ltvmodels.systems.chirp(2**11, seed=0)
    np.savetxt(tmp_path / "chirp.csv", y[:, None], header="y", comments="")
    code, out, err = _run(["ar", tmp_path / "chirp.csv", "--column", "y", "--na", "4",
                           "--fs", "16000", "--lam", "300", "--plot", tmp_path / "ar.png",
                           "--out", tmp_path / "ar.npz", "--json"], capsys)
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
    code, out, err = _run(["fit", "-", "--state", "0,1", "--input", "2", "--lam", "10",
                           "--json"], capsys)
    assert code == 0, err
    report = json.loads(out)
    assert report["data"] == "standard input" and report["T"] == 60
    assert report["state"] == ["0", "1"]


def test_parquet_through_pandas(workdir, tmp_path, monkeypatch, capsys):
    pd = pytest.importorskip("pandas")
    _, data = workdir
    frame = pd.DataFrame({"x1": data.x[:, 0], "x2": data.x[:, 1], "u": data.u[:, 0],
                          "note": ["a"] * data.T})
    try:
        import pyarrow  # noqa: F401
    except ImportError:  # no Parquet engine here: serve the frame directly
        monkeypatch.setattr(pd, "read_parquet", lambda path: frame)
    else:
        frame.to_parquet(tmp_path / "d.parquet")
    (tmp_path / "d.parquet").touch()
    code, out, err = _run(["fit", tmp_path / "d.parquet", "--state", "x1,x2", "--input", "u",
                           "--lam", "30", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["T"] == data.T
    code, out, err = _run(["fit", tmp_path / "d.parquet", "--state", "note"], capsys)
    assert code == 2 and "column 'note' is not numeric" in err


def test_warnings_are_one_line_each(workdir, capsys):
    root, _ = workdir
    code, out, err = _run(["fit", root / "data.csv", "--state", "x1,x2", "--input", "u",
                           "--norm", "group", "--lam", "3", "--max-iter", "1"], capsys)
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
        (["fit", "{bad}", "--state", "a,b"], "bad.csv, line 3, column 'b': empty value"),
        (["fit", "{ragged}", "--state", "a"], "ragged.csv, line 3: expected 2 fields"),
        (["fit", "{data}", "--state", "time,x1", "--lam", "0", "--order", "3"], "singular"),
        (["fit", "{tmp}/d.parquet", "--state", "a"], "d.parquet"),
        (["segments", "{data}", "--state", "x1", "--n-changes", "1", "--penalty", "2"],
         "not allowed with"),
        (["segments", "{data}", "--state", "x1", "--n-changes", "500"], "--n-changes: 500"),
        (["ar", "{data}", "--column", "x1", "--na", "500"], "--column data: the series is"),
        (["select-lambda", "{data}", "--state", "x1", "--norm", "group", "--method", "ml"],
         "--method: expected one of"),
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
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n3,\n5,6\n")
    (tmp_path / "ragged.csv").write_text("a,b\n1,2\n3\n")
    (tmp_path / "d.parquet").write_bytes(b"not parquet")
    (tmp_path / "short.csv").write_text("x1,x2,u\n" + "1,2,3\n" * 50)
    model = tmp_path / "model.npz"
    if "{model}" in argv:
        fitted = ltvmodels.fit(data.x, data.u, lam=10.0)
        fitted.info["data_columns"] = {"state": ["x1", "x2"], "input": ["u"]}
        fitted.save(model)
    subs = {"{tmp}": str(tmp_path), "{data}": str(root / "data.csv"), "{model}": str(model),
            "{bad}": str(tmp_path / "bad.csv"), "{ragged}": str(tmp_path / "ragged.csv"),
            "{short}": str(tmp_path / "short.csv")}
    for key, value in subs.items():
        argv = [a.replace(key, value) for a in argv]
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
        capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.strip() == (f"ltvmodels fit: error: --state: no column 'nope' in "
                                   f"{root / 'data.csv'} (columns: time, label, x1, x2, u)")


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
    value = {"a": np.float64(np.nan), "b": np.array([1.0, np.inf]), "c": np.int64(3),
             "d": (np.bool_(True), None), 4: float("-inf")}
    assert jsonable(value) == {"a": None, "b": [1.0, None], "c": 3, "d": [True, None],
                                "4": None}
    json.dumps(jsonable(value), allow_nan=False)


def test_help_lists_every_subcommand(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in ("fit", "segments", "ar", "select-lambda", "simulate", "predict", "demo"):
        assert command in out
    assert main(["demo", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(s in out for s in ("jump-linear", "robot", "chirp", "rl"))
