"""The kernels compiled ahead of time (ltvmodels.core.precompiled).

The manifest is checked everywhere; what needs the built extension skips where
the package was installed without it (``.ci/run`` requires it).
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from numba.core import types

from ltvmodels.core import precompiled

attached = pytest.mark.skipif(
    precompiled.status()[0] is None,
    reason=f"precompiled kernels: {precompiled.status()[1]}",
)

# The manifest's first calls in a fresh process with an empty numba cache: prints the
# ltvmodels kernels numba compiled and a digest of each fitted model.
FIRST_FITS = """
import hashlib, json, sys
from numba.core import event
from ltvmodels.core import precompiled

compiled = []

class Recorder(event.Listener):
    def on_start(self, ev):
        if ev.data["dispatcher"].py_func.__module__.startswith("ltvmodels"):
            compiled.append(ev.data["dispatcher"].py_func.__qualname__)

    def on_end(self, ev):
        pass

event.register("numba:compile", Recorder())
namespace = {}
exec(precompiled.workloads(), namespace)
digests = [hashlib.sha256(model.k.tobytes()).hexdigest() for model in namespace["models"]]
print(json.dumps({"compiled": compiled, "digests": digests}))
"""


def first_fits(*, switched_on: bool) -> dict:
    """Run FIRST_FITS in a fresh process, numba's cache empty."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        env[precompiled.SWITCH] = "1" if switched_on else "0"
        run = subprocess.run(
            [sys.executable, "-c", FIRST_FITS],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


def test_manifest_lists_existing_kernels_with_numba_types():
    listed = precompiled.manifest()
    assert sum(len(kernels) for kernels in listed.values()) == len(
        json.loads(precompiled.MANIFEST.read_text())["kernels"]
    )
    for module, kernels in listed.items():
        namespace = importlib.import_module(module).__dict__
        indices: dict[str, list[int]] = {}
        for function, index, arguments, result in kernels:
            assert hasattr(namespace[function], "py_func"), (module, function)
            assert len(arguments) == namespace[function].py_func.__code__.co_argcount
            assert all(isinstance(t, types.Type) for t in (*arguments, result))
            indices.setdefault(function, []).append(index)
        # each signature of a kernel has its own export
        assert all(found == list(range(len(found))) for found in indices.values())


def test_every_listed_module_attaches_its_kernels():
    for module in precompiled.manifest():
        source = Path(importlib.import_module(module).__file__)
        assert "\nattach(globals())\n" in source.read_text(), module


def test_manifest_types_must_round_trip():
    assert repr(precompiled.parse_type("UniTuple(int64, 3)")) == "UniTuple(int64, 3)"
    for text in ("float", "array(float64, 2d, C)", "UniTuple(int64 x 3)"):  # not reprs
        with pytest.raises(ValueError, match="not the repr of a numba type"):
            precompiled.parse_type(text)


def test_source_stamp_is_reproducible_and_changes_with_the_sources(monkeypatch, tmp_path):
    stamp = precompiled.source_stamp()
    assert stamp == precompiled.source_stamp() and 0 <= stamp < 2**63
    edited = tmp_path / precompiled.MANIFEST.name
    edited.write_text(precompiled.MANIFEST.read_text() + " ")  # one byte more
    monkeypatch.setattr(precompiled, "MANIFEST", edited)
    assert precompiled.source_stamp() != stamp  # a stale extension is not attached


@attached
def test_the_extension_carries_the_stamp_of_these_sources():
    path = precompiled.status()[0].__file__
    assert precompiled.built_stamp(path) == precompiled.source_stamp()


def test_switched_off_says_so_and_exits_with_1():
    env = dict(os.environ, **{precompiled.SWITCH: "0"})
    run = subprocess.run(
        [sys.executable, "-m", "ltvmodels.core.precompiled"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 1
    assert "switched off" in run.stdout


@attached
def test_first_fits_compile_no_kernel():
    """The manifest covers its first calls (every norm, n + m from 2 to 6): nothing of
    ltvmodels compiles (regenerate it with tools/update_precompiled.py where this fails)."""
    assert first_fits(switched_on=True)["compiled"] == []


@attached
def test_other_argument_types_compile_instead_of_reaching_the_compiled_kernel():
    """The dispatcher matches exact types: an array layout the manifest does not list
    compiles as before (the compiled function would read it wrongly), and agrees."""
    from ltvmodels.core.simulation import simulate_affine

    rng = np.random.default_rng(0)
    T, n, m = 30, 2, 1
    A = 0.5 * rng.standard_normal((T, n, n))
    B, w = rng.standard_normal((T, n, m)), rng.standard_normal((T, n))
    x0, u = rng.standard_normal(n), rng.standard_normal((T, m))
    compiled = set(simulate_affine.signatures)
    expected = simulate_affine(A, B, w, x0, u)  # the listed signature
    assert set(simulate_affine.signatures) == compiled  # served without compiling
    fortran = np.asfortranarray(A)
    np.testing.assert_array_equal(simulate_affine(fortran, B, w, x0, u), expected)
    assert len(simulate_affine.signatures) == len(compiled) + 1  # compiled for this layout


@attached
def test_a_served_signature_compiled_later_keeps_one_function_in_the_dispatch(monkeypatch):
    """Where numba compiles a served signature itself (as for a compiled caller), calls
    from Python still dispatch in C: two functions for one signature would send every
    call through the dispatcher's Python fallback (its ``_compile_for_args``)."""
    from ltvmodels.core.simulation import simulate_affine

    rng = np.random.default_rng(1)
    A, B = 0.5 * rng.standard_normal((20, 2, 2)), rng.standard_normal((20, 2, 1))
    w, x0, u = rng.standard_normal((20, 2)), rng.standard_normal(2), rng.standard_normal((20, 1))
    served = simulate_affine(A, B, w, x0, u)
    (_, _, arguments, result), *_ = precompiled.manifest()["ltvmodels.core.simulation"]
    simulate_affine.compile(result(*arguments))  # numba's own compilation of it
    fallback = []
    monkeypatch.setattr(simulate_affine, "_compile_for_args", lambda *a, **k: fallback.append(a))
    np.testing.assert_array_equal(simulate_affine(A, B, w, x0, u), served)
    assert fallback == []


@pytest.mark.slow
@attached
def test_first_fits_equal_those_of_the_jit_bit_for_bit():
    on, off = first_fits(switched_on=True), first_fits(switched_on=False)
    assert on["compiled"] == [] and off["compiled"] != []
    assert on["digests"] == off["digests"]
