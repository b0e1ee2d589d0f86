"""The live comparisons with R: run a committed script that writes reference values."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest


def run_r_script(script: Path, timeout: float = 120) -> dict:
    """Run ``Rscript script`` and return the JSON it prints; skip the test where R or the
    package the script loads is not installed (``.ci/run`` installs both)."""
    if shutil.which("Rscript") is None:
        pytest.skip("R is not installed (Debian: r-base-core, r-cran-strucchange)")
    run = subprocess.run(["Rscript", str(script)], capture_output=True, text=True, timeout=timeout)
    if "there is no package called" in run.stderr:
        pytest.skip(f"an R package {script.name} loads is not installed: {run.stderr.strip()}")
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)
