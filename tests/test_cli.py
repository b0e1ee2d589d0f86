"""The ``ltvmodels`` command: ltvmodels.cli and ``python -m ltvmodels``."""

from __future__ import annotations

import subprocess
import sys

import pytest

import ltvmodels
from ltvmodels.cli import JUMP_LINEAR_LAM, OutputPathError, main, run_jump_linear_demo

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
