"""The documentation's code runs as written, and its API reference is complete.

Every ``python`` block of README.md and of each page under ``docs/`` runs, the
blocks of one page in order in one namespace (a page is self-contained). The
API reference (``docs/api.rst``) lists every public function and class. The
site itself is built by ``python -m sphinx -W --keep-going -b html docs
docs/_build/html`` (in ``.ci/run``).
"""

import importlib
import importlib.util
import inspect
import re
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
PAGES = [page for page in PAGES if "_build" not in page.parts]
# Modules whose public names (their __all__) have API pages besides the top level.
DOCUMENTED_MODULES = [
    "ltvmodels.systems",
    "ltvmodels.datasets",
    "ltvmodels.plotting",
    "ltvmodels.control",
    "ltvmodels.apps.robot",
    "ltvmodels.apps.rl",
    "ltvmodels.apps.gym_rl",
    "ltvmodels.apps.demos",
    "ltvmodels.sktime",
]


def python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.S)


def test_the_pages_with_code_are_found():
    with_code = {page.name for page in PAGES if python_blocks(page)}
    assert {"README.md", "getting_started.md", "methods.md", "many_series.md"} <= with_code


@pytest.mark.parametrize(
    "page", [p for p in PAGES if python_blocks(p)], ids=lambda p: str(p.relative_to(ROOT))
)
def test_python_blocks_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the examples write model files and figures
    namespace: dict = {}
    exec(compile("\n".join(python_blocks(page)), str(page), "exec"), namespace)
    if page.name == "getting_started.md":
        assert (tmp_path / "model.npz").stat().st_size > 0
        assert namespace["same"].k.shape == namespace["model"].k.shape


def public_callables(module_name: str) -> set[str]:
    module = importlib.import_module(module_name)
    names = set()
    for name in module.__all__:
        value = getattr(module, name)
        if inspect.isclass(value) or inspect.isfunction(value):
            names.add(name)
    return names


def test_every_public_function_and_class_has_an_api_page():
    listed = set(re.findall(r"^   (\w+)$", (ROOT / "docs" / "api.rst").read_text(), re.M))
    wanted = public_callables("ltvmodels")
    for module_name in DOCUMENTED_MODULES:
        wanted |= public_callables(module_name)
    assert wanted - listed == set(), "add these to docs/api.rst"
    assert listed - wanted == set(), "docs/api.rst lists names that are not public"


def test_public_functions_document_their_parameters_and_return_value():
    """numpydoc's checks: every parameter documented and described, a Returns section."""
    validate = pytest.importorskip("numpydoc.validate").validate
    problems = []
    for module_name in ["ltvmodels", *DOCUMENTED_MODULES]:
        module = importlib.import_module(module_name)
        for name in sorted(public_callables(module_name)):
            value = getattr(module, name)
            if not inspect.isfunction(value):
                continue  # classes document their fields as Attributes
            path = f"{value.__module__}.{value.__qualname__}"
            for code, message in validate(path)["errors"]:
                if code in {"PR01", "PR02", "PR07", "RT01"}:
                    problems.append(f"{module_name}.{name}: {code} {message}")
    assert problems == []


def _docs_conf():
    spec = importlib.util.spec_from_file_location("docs_conf", ROOT / "docs" / "conf.py")
    conf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conf)
    return conf


def test_plain_text_formulas_of_docstrings_are_typeset_on_the_site():
    """The site's docstring hook wraps TeX-like tokens in :math: and leaves code alone."""
    conf = _docs_conf()
    lines = [
        "Minimizes Σ_t ‖x^r_{t+1} − A_t x^r_t‖² with σ_{e,i}² and ℓ_{N−1}, ū_{N−1}.",
        "Literal ``k_{t+1}`` and :func:`f` stay; so does a role :math:`k_{t}`.",
        ">>> a[1] = 1  # (Dk)_t = k_{t+1} − k_t",
        "Example::",
        "",
        "    y_{t} = 1",
        ".. math::",
        "",
        "    \\sum_{t} k_{t+1}",
        "After the block: Θ_{c−1}.",
    ]
    conf.typeset_docstring_math(None, "function", "f", None, {}, lines)
    assert lines[0] == (
        "Minimizes Σ_t ‖:math:`x^r_{t+1}` − A_t x^r_t‖² with :math:`σ_{e,i}²` and "
        ":math:`ℓ_{N−1}`, :math:`ū_{N−1}`."
    )
    assert lines[1] == "Literal ``k_{t+1}`` and :func:`f` stay; so does a role :math:`k_{t}`."
    assert lines[2:9] == [
        ">>> a[1] = 1  # (Dk)_t = k_{t+1} − k_t",
        "Example::",
        "",
        "    y_{t} = 1",
        ".. math::",
        "",
        "    \\sum_{t} k_{t+1}",
    ]
    assert lines[9] == "After the block: :math:`Θ_{c−1}`."
