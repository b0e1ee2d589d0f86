"""Fuzz ``ltv.load`` with damaged, edited and foreign file contents.

A model file recipe (:class:`fuzz_strategies.ModelFile`) takes a genuine
saved model of one of ten kinds (state space with and without inputs or an
intercept, group lasso, LTI, segments, AR, VAR, ARX, regression) and edits
it: array members dropped or replaced (NaN/inf/huge coefficients, wrong
shapes and dtypes, bad covariance blocks, out-of-range change points), the
JSON ``meta`` member edited (unknown versions and types, wrong sizes, NaN
noise variances, a damaged status) or the whole file damaged (truncated, a
flipped byte, garbage appended, empty, random bytes, text, gzip, a zip of
something else). Paths that are not files (directory, missing file, non-path
objects) are fuzzed too.

The oracle accepts: a :class:`~ltvmodels.ModelFileError` (or TypeError for a
non-path, or the file errors ``load`` documents), or a loaded model that
passes the full model inspection of :func:`fuzz_oracle.inspect_model`
(finite coefficients, covariances, noise, likelihood or documented None,
usable predict/simulate/summary). A damaged file that loads but then breaks
on use, or loads with NaN in it, is a failure.
"""

from __future__ import annotations

import os
import pathlib

import numpy as np
from fuzz_oracle import DOCUMENTED_OS_ERRORS, check_call, expect, tmpdir
from fuzz_strategies import fitted, fuzz_test, model_files
from hypothesis import strategies as st

import ltvmodels as ltv


@fuzz_test(model_files(), examples=3.0)
def test_load_edited_files(recipe):
    """ltv.load on saved models with one or two edits."""
    content = recipe.content()
    with tmpdir() as d:
        path = os.path.join(d, "model.npz")
        with open(path, "wb") as fh:
            fh.write(content)
        model = check_call(
            ltv.load, path, label="load", allow=DOCUMENTED_OS_ERRORS, context={"loaded": True}
        )
        if (
            model is not None
            and recipe.member_edit == "none"
            and recipe.meta_edit == "none"
            and recipe.file_edit == "none"
        ):
            expect(
                np.array_equal(model.k, fitted(recipe.kind).k),
                "load",
                "round trip",
                f"the unedited {recipe.kind} model did not load back identical",
            )


@fuzz_test(
    st.sampled_from(
        [
            "directory",
            "missing",
            "int",
            "none",
            "bytes_path",
            "list",
            "pathlike_missing",
            "empty_string",
            "fifo_like_dir_npz",
            "symlink_loop",
            "no_permission",
        ]
    )
)
def test_load_paths(kind):
    """ltv.load on paths that are not model files."""
    with tmpdir() as d:
        path: object
        if kind == "directory":
            path = d
        elif kind == "missing":
            path = os.path.join(d, "nope.npz")
        elif kind == "int":
            path = 3
        elif kind == "none":
            path = None
        elif kind == "bytes_path":
            path = os.path.join(d, "m.npz").encode()
        elif kind == "list":
            path = [os.path.join(d, "m.npz")]
        elif kind == "pathlike_missing":
            path = pathlib.Path(d) / "missing.npz"
        elif kind == "empty_string":
            path = ""
        elif kind == "fifo_like_dir_npz":
            path = os.path.join(d, "dir.npz")
            os.mkdir(path)
        elif kind == "symlink_loop":
            path = os.path.join(d, "loop.npz")
            os.symlink(path, path)
        else:
            path = os.path.join(d, "locked.npz")
            fitted("sq").save(path)
            os.chmod(path, 0)
        check_call(ltv.load, path, label="load", allow=DOCUMENTED_OS_ERRORS)
