"""The package's layers: imports point one way, no cycles, no private names across modules.

Every import of every module of ``src/ltvmodels`` is read from its source
(function-level imports included) and checked against ARCHITECTURE.md:

* a module may import from its own part of the package or from a lower layer;
* the one upward import allowed: a ``plot``/``plot_*`` method of a result
  (``results``) may import ``plotting`` inside the method;
* no import cycle between modules;
* no module imports a private name (``_name``) from another module, or uses
  one through an imported module.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "src" / "ltvmodels"
PACKAGE = "ltvmodels"

LAYERS = {
    "errors": 0,
    "progress": 0,
    "validation": 0,
    "core": 1,
    "results": 2,
    "estimators": 3,
    "systems": 3,
    "control": 3,
    "plotting": 4,
    "apps": 5,
    "cli": 6,
    "__main__": 7,
}
"""Layer of each part of the package (ARCHITECTURE.md).

The package root (``ltvmodels/__init__.py``) loads its public names lazily and
imports only the errors (:func:`test_the_package_root_imports_only_the_errors`).
"""


def module_name(path: Path) -> str:
    parts = path.relative_to(SOURCE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(path): path for path in SOURCE.rglob("*.py")}


def part(module: str) -> str | None:
    """The part of the package a module belongs to (None for the package root)."""
    pieces = module.split(".")
    return pieces[1] if len(pieces) > 1 else None


def layer(module: str) -> int:
    return 0 if part(module) is None else LAYERS[part(module)]


def resolve(importer: str, level: int, target: str | None) -> str:
    """The absolute name of a relative import in module ``importer``."""
    if level == 0:
        return target or ""
    is_package = MODULES[importer].name == "__init__.py"
    base = importer.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


class Import:
    """One import statement: the modules it reaches and the names it takes."""

    def __init__(self, importer: str, node: ast.AST, function: str | None):
        self.importer, self.line, self.function = importer, node.lineno, function
        self.targets: list[str] = []  # internal modules imported
        self.private: list[str] = []  # private names imported from internal modules
        self.bound: dict[str, str] = {}  # local name -> internal module bound to it
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == PACKAGE:
                    self.targets.append(alias.name)
                    if alias.asname:
                        self.bound[alias.asname] = alias.name
            return
        base = resolve(importer, node.level, node.module)
        if base.split(".")[0] != PACKAGE:
            return
        for alias in node.names:
            submodule = f"{base}.{alias.name}"
            if submodule in MODULES:  # "from . import module"
                self.targets.append(submodule)
                self.bound[alias.asname or alias.name] = submodule
                if alias.name.startswith("_") and alias.name != "__main__":
                    self.private.append(alias.name)
            else:
                if base not in self.targets:
                    self.targets.append(base)
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    self.private.append(alias.name)


def imports_of(module: str) -> tuple[list[Import], list[str]]:
    """The internal imports of a module, and its uses of private names through modules."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    found: list[Import] = []
    bound: dict[str, str] = {}

    def visit(node: ast.AST, function: str | None) -> None:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            function = node.name
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            imp = Import(module, node, function)
            if imp.targets:
                found.append(imp)
                bound.update(imp.bound)
        for child in ast.iter_child_nodes(node):
            visit(child, function)

    visit(tree, None)
    private_uses = [
        f"{module}:{node.lineno} uses {node.value.id}.{node.attr}"
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id in bound
        and node.attr.startswith("_")
        and not node.attr.startswith("__")
    ]
    return found, private_uses


ALL_IMPORTS = {module: imports_of(module) for module in MODULES}


def allowed_upward(imp: Import, target: str) -> bool:
    """A result's plot method importing the plotting layer (the one exception)."""
    return (
        part(imp.importer) == "results"
        and part(target) == "plotting"
        and imp.function is not None
        and (imp.function == "plot" or imp.function.startswith("plot_"))
    )


def test_every_part_has_a_layer():
    assert {part(m) for m in MODULES} - {None} == set(LAYERS)


def test_imports_point_down_the_layers():
    wrong = []
    for module, (found, _) in ALL_IMPORTS.items():
        if module == PACKAGE:
            continue
        for imp in found:
            for target in imp.targets:
                if part(target) == part(module) or allowed_upward(imp, target):
                    continue
                if layer(target) >= layer(module):
                    wrong.append(
                        f"{module}:{imp.line} imports {target} "
                        f"(layer {layer(module)} -> {layer(target)})"
                    )
    assert not wrong, "\n".join(wrong)


def type_checking_lines(module: str) -> set[int]:
    """The line numbers of a module's ``if TYPE_CHECKING:`` blocks (never run)."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    return {
        line
        for node in ast.walk(tree)
        if isinstance(node, ast.If)
        and isinstance(node.test, ast.Name)
        and node.test.id == "TYPE_CHECKING"
        for child in node.body
        for line in range(child.lineno, (child.end_lineno or child.lineno) + 1)
    }


def test_the_package_root_imports_only_the_errors():
    found, _ = ALL_IMPORTS[PACKAGE]
    skipped = type_checking_lines(PACKAGE)
    run = {t for imp in found if imp.line not in skipped for t in imp.targets}
    assert run == {f"{PACKAGE}.errors"}


def test_type_checkers_see_every_lazily_loaded_name_where_it_loads():
    """The root's TYPE_CHECKING imports are the names of _API from their modules."""
    tree = ast.parse(MODULES[PACKAGE].read_text(encoding="utf-8"))
    seen: dict[str, str] = {}
    declared: dict = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.lineno in type_checking_lines(PACKAGE):
            for alias in node.names:
                assert alias.asname == alias.name, "re-export explicitly: `name as name`"
                seen[alias.name] = node.module or ""
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
            if node.targets[0].id in ("_API", "_MODULES"):
                declared[node.targets[0].id] = ast.literal_eval(node.value)
    expected = dict(declared["_API"])
    expected.update({name: "" for name in declared["_MODULES"]})
    assert seen == expected


def test_no_import_cycles():
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for module, (found, _) in ALL_IMPORTS.items():
        for imp in found:
            for target in imp.targets:
                if target != module and not allowed_upward(imp, target):
                    graph[module].add(target)
    # Depth-first search for a back edge; report the cycle it closes.
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(module: str) -> list[str] | None:
        state[module] = 1
        path.append(module)
        for target in sorted(graph[module]):
            if state.get(target) == 1:
                return path[path.index(target) :] + [target]
            if target not in state:
                cycle = visit(target)
                if cycle:
                    return cycle
        state[module] = 2
        path.pop()
        return None

    for module in sorted(graph):
        if module not in state:
            cycle = visit(module)
            assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_no_private_names_across_modules():
    wrong = []
    for module, (found, private_uses) in ALL_IMPORTS.items():
        wrong += [
            f"{module}:{imp.line} imports {', '.join(imp.private)}" for imp in found if imp.private
        ]
        wrong += private_uses
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("folder", ["tests", "examples", "benchmarks"])
def test_no_private_names_outside_the_package(folder):
    """Tests, examples and benchmarks use the public or the documented internal API."""
    wrong = []
    for path in sorted((SOURCE.parents[1] / folder).rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bound = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)) and not getattr(node, "level", 0):
                names = (
                    [a.name for a in node.names]
                    if isinstance(node, ast.Import)
                    else [f"{node.module}.{a.name}" for a in node.names]
                )
                for alias, name in zip(node.names, names, strict=True):
                    if name.split(".")[0] != PACKAGE:
                        continue
                    if any(
                        piece.startswith("_") and not piece.startswith("__")
                        for piece in name.split(".")
                    ):
                        wrong.append(f"{path.name}:{node.lineno} imports {name}")
                    bound.add((alias.asname or alias.name).split(".")[0])
        wrong += [
            f"{path.name}:{node.lineno} uses {node.value.id}.{node.attr}"
            for node in ast.walk(tree)
            if isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in bound
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ]
    assert not wrong, "\n".join(wrong)


def test_the_checks_catch_violations():
    """The parser sees function-level, relative and private imports (a check that can fail)."""
    code = (
        "def f():\n    from ..estimators.fit import _refine\n    from .. import plotting\n"
        "    return plotting._private\n"
    )
    tree = ast.parse(code)
    node = tree.body[0].body[0]
    imp = Import("ltvmodels.core.sparse", node, "f")
    assert imp.targets == ["ltvmodels.estimators.fit"] and imp.private == ["_refine"]
    assert layer(imp.targets[0]) > layer("ltvmodels.core.sparse")
    plot_import = Import("ltvmodels.results.statespace", tree.body[0].body[1], "plot")
    assert allowed_upward(plot_import, "ltvmodels.plotting")
    assert not allowed_upward(
        Import("ltvmodels.results.statespace", tree.body[0].body[1], "f"), "ltvmodels.plotting"
    )


def test_import_loads_neither_solvers_nor_plotting_nor_extras():
    """``import ltvmodels`` stays light: numba, matplotlib, pandas, gymnasium load on use."""
    code = (
        "import sys, ltvmodels; heavy = [m for m in ('numba', 'matplotlib', 'pandas', "
        "'gymnasium', 'scipy.optimize', 'ltvmodels.core', 'ltvmodels.apps') "
        "if m in sys.modules]; print(heavy)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == "[]"


def test_help_does_not_load_the_solvers():
    code = (
        "import sys; from ltvmodels.cli import build_parser; build_parser(); "
        "print([m for m in ('numba', 'matplotlib', 'ltvmodels.core') if m in sys.modules])"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == "[]"
