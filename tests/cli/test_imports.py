"""The command line loads the solvers, the figures and the applications only when a command runs."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numba", "ltvmodels.apps", "matplotlib")

# Every subcommand but the demo, whose options name the demos (ltvmodels.apps.defaults).
COMMANDS = ["fit", "segments", "ar", "select-lambda", "simulate", "predict", "forecast", "fit-many"]


def loaded_after(code: str) -> list[str]:
    """The modules of HEAVY that a new interpreter has loaded after running ``code``."""
    check = (
        f"import json, sys\n{code}\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    )
    result = subprocess.run(
        [sys.executable, "-c", check], capture_output=True, text=True, check=True
    )
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_importing_the_command_line_loads_nothing_heavy():
    assert loaded_after("import ltvmodels.cli") == []


@pytest.mark.parametrize(
    "argv", [["--help"], *([name, "--help"] for name in COMMANDS)], ids=" ".join
)
def test_help_loads_nothing_heavy(argv):
    code = f"import ltvmodels.cli\nltvmodels.cli.main({argv!r})"
    assert loaded_after(code) == []


def test_the_demo_help_loads_the_applications_not_the_solvers():
    code = "import ltvmodels.cli\nltvmodels.cli.main(['demo', '--help'])"
    assert loaded_after(code) == ["ltvmodels.apps"]
