"""The example scripts run headless and write their figures."""

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", ["jump_linear", "jump_linear_sq"])
def test_example_runs(name, tmp_path, capsys):
    out = tmp_path / f"{name}.png"
    assert load(name).main(["--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
    if name == "jump_linear":
        assert "detected change points [200], true [200]" in capsys.readouterr().out


def test_robot_example_writes_both_figures(tmp_path, capsys):
    assert load("robot_contact").main(["--out", str(tmp_path / "robot.png")]) == 0
    for which in ("train", "validation"):
        assert (tmp_path / f"robot_{which}.png").stat().st_size > 10_000
    assert "detected change points" in capsys.readouterr().out
