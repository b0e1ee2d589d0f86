"""Kernels compiled ahead of time: the first fit in a fresh process without numba's compilation.

numba compiles a kernel on its first call in every new environment (its cache
is empty after an install): 10–17 s for a first ``fit(norm="group")``. The
signatures those first calls compile are listed in :data:`MANIFEST`
(``precompiled.json``, written by ``tools/update_precompiled.py``); the package's
build (``setup.py``, :func:`build`) compiles them with ``numba.pycc`` into the
extension module ``ltvmodels.core.precompiled_kernels``.

Each kernel module ends with ``attach(globals())``: every listed signature of
its kernels is then served by the compiled function, through the kernel's own
numba dispatcher (its type dispatch picks the compiled function for exactly
that signature; any other argument types compile as before). Calls from other
compiled code are unchanged (numba compiles the kernel into them where a
caller is not precompiled). Nothing is attached (and every kernel compiles at
first use, as without this module) where

* the extension was not built (no C compiler at install, or ``numba.pycc``
  missing),
* it is stale: its :func:`source_stamp` (this package's ``core`` sources, the
  manifest and the numba and numpy versions it was built with) differs from
  the running one's, e.g. after editing a kernel in a development install (``pip install
  -e .`` again rebuilds it),
* the environment variable ``LTVMODELS_PRECOMPILED`` is ``0``,
* the numba dispatcher lacks the methods this relies on (``_insert`` and
  ``_clear``, numba's own way to add compiled overloads) in a future numba.

``python -m ltvmodels.core.precompiled`` says which, and exits with 1 unless
the kernels are attached.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import json
import os
import sys
from functools import cache
from pathlib import Path
from typing import Any

import numba
import numpy as np
from numba.core import types
from numba.core.registry import CPUDispatcher

__all__ = [
    "EXTENSION",
    "MANIFEST",
    "STAMP_FUNCTION",
    "SWITCH",
    "attach",
    "build",
    "built_stamp",
    "export_name",
    "manifest",
    "parse_type",
    "source_stamp",
    "status",
    "workloads",
]

MANIFEST = Path(__file__).with_name("precompiled.json")
EXTENSION = "ltvmodels.core.precompiled_kernels"
SWITCH = "LTVMODELS_PRECOMPILED"
# Exported next to the kernels: the stamp of the sources they were compiled from.
STAMP_FUNCTION = "source_stamp"


def source_stamp() -> int:
    """A 63-bit hash of numba's and numpy's versions, :data:`MANIFEST` and every ``core``
    source file.

    The compiled kernels inline their callees from any of these modules, so a
    change in any of them makes the extension stale.
    """
    digest = hashlib.sha256(f"numba {numba.__version__}, numpy {np.__version__}".encode())
    for path in [MANIFEST, *sorted(Path(__file__).parent.glob("*.py"))]:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return int.from_bytes(digest.digest()[:8], "little") >> 1


def export_name(function: str, index: int) -> str:
    """The extension's name of the ``index``-th signature of kernel ``function``."""
    return f"{function}__{index}"


@cache
def _type_names() -> dict[str, Any]:
    names = {name: getattr(types, name) for name in dir(types) if not name.startswith("_")}
    names["bool"] = types.boolean
    return names


def parse_type(text: str) -> types.Type:
    """The numba type whose ``repr`` is ``text`` (the manifest's spelling)."""
    try:  # the manifest is this package's own file: its texts are numba's reprs
        parsed = eval(text, {"__builtins__": {}}, _type_names())
    except (NameError, SyntaxError, TypeError):
        parsed = None
    if not isinstance(parsed, types.Type) or repr(parsed) != text:
        raise ValueError(f"{MANIFEST.name}: {text!r} is not the repr of a numba type")
    return parsed


@cache
def manifest() -> dict[str, list[tuple[str, int, tuple[types.Type, ...], types.Type]]]:
    """The listed signatures by module: (kernel, export index, argument types, return type)."""
    entries: dict[str, list[tuple[str, int, tuple[types.Type, ...], types.Type]]] = {}
    counts: dict[tuple[str, str], int] = {}
    for entry in json.loads(MANIFEST.read_text())["kernels"]:
        key = (entry["module"], entry["function"])
        index = counts[key] = counts.get(key, -1) + 1
        arguments = tuple(parse_type(text) for text in entry["args"])
        entries.setdefault(entry["module"], []).append(
            (entry["function"], index, arguments, parse_type(entry["return"]))
        )
    return entries


def workloads() -> str:
    """The code of the first calls whose signatures :data:`MANIFEST` lists (it fits
    ``models``, a list of fitted models)."""
    return "\n".join(json.loads(MANIFEST.read_text())["workloads"])


def built_stamp(path: str) -> int:
    """The :func:`source_stamp` that the extension module in the file ``path`` was built with."""
    spec = importlib.util.spec_from_file_location(EXTENSION, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{path} is not an extension module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return int(getattr(module, STAMP_FUNCTION)())


@cache
def status() -> tuple[Any, str]:
    """(the extension module or None, why not / "attached")."""
    if os.environ.get(SWITCH, "1") == "0":
        return None, f"switched off ({SWITCH}=0)"
    if not all(hasattr(CPUDispatcher, name) for name in ("_insert", "_clear", "add_overload")):
        return None, f"numba {numba.__version__}'s dispatchers cannot take compiled functions"
    try:
        extension = importlib.import_module(EXTENSION)
    except ImportError as error:
        return None, f"not built ({error}): the kernels compile at first use"
    if getattr(extension, STAMP_FUNCTION)() != source_stamp():
        return None, "stale: built from other sources, numba or numpy; reinstall to rebuild it"
    return extension, "attached"


def attach(namespace: dict[str, Any]) -> None:
    """Serve the listed signatures of the kernels in a module's ``namespace`` by the extension."""
    extension = status()[0]
    if extension is None:
        return
    served: dict[str, dict[tuple[types.Type, ...], Any]] = {}
    for function, index, arguments, _ in manifest().get(namespace["__name__"], []):
        served.setdefault(function, {})[arguments] = getattr(
            extension, export_name(function, index)
        )
    for function, functions in served.items():
        _serve(namespace[function], functions)


def _serve(dispatcher: Any, served: dict[tuple[types.Type, ...], Any]) -> None:
    """Add the compiled ``served`` functions (by argument types) to a numba dispatcher.

    numba's own step that adds a compiled overload (``_insert``: its type dispatch by
    type codes). Where numba later compiles one of these signatures itself (a
    compiled caller needs the kernel's code), its type dispatch would hold two
    functions for one signature and resolve every call from Python slowly (~30 µs):
    the served one is then dropped and the table rebuilt from numba's own overloads.
    """

    def insert(arguments: tuple[types.Type, ...], function: Any, objectmode: bool) -> None:
        codes = [argument._code for argument in arguments]  # type: ignore[attr-defined]
        dispatcher._insert(codes, function, objectmode)

    def insert_served() -> None:
        for arguments, function in served.items():
            insert(arguments, function, False)

    add_compiled = dispatcher.add_overload

    def add_overload(result: Any) -> None:
        add_compiled(result)
        if served.pop(tuple(result.signature.args), None) is not None:
            dispatcher._clear()
            for arguments, compiled in dispatcher.overloads.items():
                insert(arguments, compiled.entry_point, compiled.objectmode)
            insert_served()

    dispatcher.add_overload = add_overload
    insert_served()


def build(output_dir: str, output_file: str) -> None:
    """Compile the listed signatures into ``output_dir/output_file`` (numba.pycc).

    Used by ``setup.py``; every module in the manifest is imported. Raises
    whatever numba.pycc raises (no C compiler, an unsupported numba).
    """
    import warnings

    with warnings.catch_warnings():  # numba.pycc is pending deprecation; it still works
        warnings.simplefilter("ignore")
        from numba.pycc import CC

    compiler = CC(EXTENSION.rsplit(".", 1)[1])
    # under another name first: a process importing the file never sees it half written
    compiler.output_dir, compiler.output_file = output_dir, f".{output_file}.partial"
    for module, kernels in manifest().items():
        namespace = importlib.import_module(module).__dict__
        for function, index, arguments, result in kernels:
            signature = result(*arguments)
            compiler.export(export_name(function, index), signature)(namespace[function].py_func)
    value = source_stamp()

    def stamp() -> int:  # numba compiles the closure's value in as a constant
        return value

    compiler.export(STAMP_FUNCTION, types.int64())(stamp)
    compiler.compile()
    os.replace(Path(output_dir) / compiler.output_file, Path(output_dir) / output_file)


if __name__ == "__main__":
    extension, why = status()
    print(f"{EXTENSION}: {why}")
    sys.exit(0 if extension is not None else 1)
