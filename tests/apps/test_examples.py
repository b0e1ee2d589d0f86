"""Every example script in examples/ runs headless (in a quick mode) and writes its figures."""

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(path.stem for path in EXAMPLES.glob("*.py"))

# Options that keep a slow example fast; an example with a --quick flag that is not
# listed here runs with --quick.
QUICK_ARGS = {
    "rl_cartpole": ["--quick", "--runs", "1"],
}
# Text each example must print.
EXPECTED_OUTPUT = {
    "jump_linear": "detected change points [200], true [200]",
    "robot_contact": "detected change points",
    "chirp_spectrogram": "order 2: mean error",
    "rl_cartpole": "Median cost over 1 runs",
    "gym_pendulum": "gymnasium's usual good return",
    "structural_breaks": "ours:        0 breaks (-602.86)",
}
# Examples that need an optional dependency (skipped without it).
REQUIRES = {
    "gym_pendulum": ("gymnasium", "sklearn"),
    "rl_cartpole": ("sklearn",),
    "structural_breaks": ("pandas",),
}
# Figures beside --out for examples that write several.
EXTRA_FIGURES = {
    "robot_contact": ["robot_contact_train.png", "robot_contact_validation.png"],
}


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def quick_args(name):
    if name in QUICK_ARGS:
        return QUICK_ARGS[name]
    return ["--quick"] if "--quick" in (EXAMPLES / f"{name}.py").read_text() else []


def test_the_examples_are_found():
    assert {"jump_linear", "robot_contact", "rl_cartpole", "chirp_spectrogram"} <= set(SCRIPTS)


# The slowest examples (about 50 s, 45 s and 20 s) run in the default suite's place in
# the documentation build, which executes every example and fails on an error (.ci/run).
SLOW = {"gym_pendulum", "sktime_backtest", "rl_cartpole"}


@pytest.mark.parametrize(
    "name",
    [pytest.param(name, marks=pytest.mark.slow) if name in SLOW else name for name in SCRIPTS],
)
def test_example_runs_headless(name, tmp_path, capsys):
    for module in REQUIRES.get(name, ()):
        pytest.importorskip(module)
    out = tmp_path / f"{name}.png"
    assert load(name).main(["--out", str(out), *quick_args(name)]) == 0
    figures = EXTRA_FIGURES.get(name, [out.name])
    for figure in figures:
        assert (tmp_path / figure).stat().st_size > 10_000, figure
    text = capsys.readouterr().out
    if name in EXPECTED_OUTPUT:
        assert EXPECTED_OUTPUT[name] in text
