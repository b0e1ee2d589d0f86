"""The package's layers: imports point one way, no cycles, no private names across modules.

Every import of every module of ``src/ltvmodels`` is read from its source
(function-level imports included) and checked against ARCHITECTURE.md:

* a module may import from its own part of the package or from a lower layer;
* the one upward import allowed: a ``plot``/``plot_*`` method of a result
  (``results``) may import ``plotting`` inside the method;
* no import cycle between modules;
* no module imports a private name (``_name``) from another module, or uses
  one through an imported module;
* every module outside ``cli`` has an ``__all__`` that names only what it binds
  and lists every public function and class it defines.
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
    "datasets": 3,
    "control": 3,
    "plotting": 4,
    "apps": 5,
    "sktime": 5,
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


# -- the public surface of each module ---------------------------------------------------------
def top_level_statements(tree: ast.Module) -> list[ast.stmt]:
    """The module's top-level statements, with those inside top-level ``if``/``try`` blocks."""
    found: list[ast.stmt] = []

    def add(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, ast.If):
                add(node.body)
                add(node.orelse)
            elif isinstance(node, ast.Try):
                add(node.body)
                add(node.orelse)
                add(node.finalbody)
                for handler in node.handlers:
                    add(handler.body)
            else:
                found.append(node)

    add(tree.body)
    return found


def literal_assignments(tree: ast.Module) -> dict[str, ast.expr]:
    """The values of the module's top-level assignments to one name."""
    values: dict[str, ast.expr] = {}
    for node in top_level_statements(tree):
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target, value = node.targets[0], node.value
        elif isinstance(node, ast.AnnAssign) and node.value is not None:
            target, value = node.target, node.value
        else:
            continue
        if isinstance(target, ast.Name):
            values[target.id] = value
    return values


def declared_all(tree: ast.Module) -> list[str] | None:
    """The module's ``__all__``, None without one.

    A literal list or tuple of strings, which may unpack (``*NAMES``) another
    literal of the module (the package root lists ``*_API``).
    """
    values = literal_assignments(tree)
    if "__all__" not in values:
        return None
    node = values["__all__"]
    assert isinstance(node, (ast.List, ast.Tuple)), "__all__ is a literal list or tuple"
    names: list[str] = []
    for element in node.elts:
        if isinstance(element, ast.Starred) and isinstance(element.value, ast.Name):
            names.extend(ast.literal_eval(values[element.value.id]))
        else:
            names.append(ast.literal_eval(element))
    return names


def bound_names(tree: ast.Module) -> set[str]:
    """The names a module binds at its top level (definitions, assignments, imports)."""
    names: set[str] = set()
    for node in top_level_statements(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
    return names


def public_definitions(tree: ast.Module) -> set[str]:
    """The public functions and classes a module defines (not those it imports)."""
    return {
        node.name
        for node in top_level_statements(tree)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
        and not node.name.startswith("_")
    }


LIBRARY_MODULES = sorted(m for m in MODULES if part(m) != "cli")


@pytest.mark.parametrize("module", LIBRARY_MODULES)
def test_every_module_lists_its_public_names_in_all(module):
    """``__all__`` exists, names what the module binds, and every public function and class.

    A function or class used only inside its module is private (``_name``); the
    command line (``cli``) is not checked.
    """
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    names = declared_all(tree)
    assert names is not None, f"{module} has no __all__"
    assert len(names) == len(set(names)), f"{module}: __all__ lists a name twice"
    missing = sorted(set(names) - bound_names(tree))
    assert not missing, f"{module}: __all__ names what the module does not define: {missing}"
    unlisted = sorted(public_definitions(tree) - set(names))
    assert not unlisted, (
        f"{module}: public functions or classes not in __all__ (list them, or make them "
        f"private with a leading underscore): {unlisted}"
    )


def test_the_public_names_check_can_fail():
    tree = ast.parse(
        "from x import y\n__all__ = ['f', 'y', 'z']\ndef f(): pass\nclass C: pass\n"
        "def _g(): pass\nif True:\n    def h(): pass\n"
    )
    assert declared_all(tree) == ["f", "y", "z"]
    assert set(declared_all(tree)) - bound_names(tree) == {"z"}
    assert public_definitions(tree) - set(declared_all(tree)) == {"C", "h"}
    assert declared_all(ast.parse("x = 1\n")) is None
    assert declared_all(ast.parse("A = {'a': 1}\n__all__ = [*A, 'b']\n")) == ["a", "b"]
