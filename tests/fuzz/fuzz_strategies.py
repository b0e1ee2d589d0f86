"""Hypothesis strategies of the fuzzing suite, and the decorator that runs them per profile.

What is fuzzed
--------------
* **Data** (:class:`Data`, drawn by :func:`datasets`): a compact recipe — number
  of samples T (0, 1, 2, 3 … 60), states n (1 … 4, sometimes 6 for more
  parameters than samples), inputs m (0 … 2), R time-aligned trajectories, a
  seed, the scales of x and u (1, 1e±150, 1e±300, 0) — plus *defects* (NaN
  blocks, ±inf entries, constant or duplicated columns, all-zero or all-NaN
  data, a huge single entry, inputs of the wrong length) and a *form* in which
  the arrays reach the library (float64, float32, int, bool, complex, object,
  strings, lists, ragged lists, masked arrays with masked entries, 1-d,
  transposed, pandas, None, scalars, empty arrays). ``Data.x()`` and
  ``Data.u()`` build the arrays, so a failing example prints a short recipe
  that rebuilds its data exactly.
* **Options**: values of ``lam`` (negative, 0, inf, NaN, 1e300, strings,
  "auto", lists, ragged lists, vectors and matrices of the right and wrong
  size, masked, complex), ``order`` (0, 1, 2, 3, -1, 1.5, "1", True,
  polynomial coefficients that do or do not sum to zero), ``norm`` (valid and
  invalid spellings), ``weights`` (negative, zero, NaN, inf, wrong shape),
  ``constant`` (bools and non-bools), ``noise_var``, ``compute_cov``,
  ``max_iter``, ``tol``, priors, ``penalty``, ``min_size``, ``n_changes``,
  ``max_changes`` and so on. Values that depend on the data (a λ vector of
  length K) are drawn as tokens starting with ``@`` and resolved by
  :func:`resolve` once the sizes are known.

Profiles
--------
:func:`fuzz_test` turns a body ``f(*drawn)`` into a pytest test parametrized
by profile: ``fast`` (the default run, a few examples per test, derandomized
so CI is reproducible) and ``long`` (marked ``slow``; the same strategies,
many more examples). The profiles are registered in ``conftest.py``.
"""

from __future__ import annotations

import functools
import inspect
import warnings
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from fuzz_oracle import run_example, survey_verdict
from hypothesis import example as hypothesis_example
from hypothesis import given, seed, settings
from hypothesis import strategies as st

import ltvmodels as ltv

PROFILES = pytest.mark.parametrize(
    "profile", ["fast", pytest.param("long", marks=pytest.mark.slow)]
)


def fuzz_test(
    *strategies: st.SearchStrategy,
    examples: float = 1.0,
    valid: tuple | None = None,
    explicit: tuple = (),
) -> Callable:
    """Make ``body(*drawn)`` a hypothesis test run under the fast and the long profile.

    ``examples`` scales the profile's ``max_examples`` (for expensive bodies).
    With ``valid`` (strategies of inputs the function should accept: clean
    forms, valid options, still with extreme values and missing data) the test
    has two variants, ``any`` (the ``strategies``) and ``valid``, so that the
    results are inspected often, not only the errors. Each variant's seed
    derives from its name, so it draws its own reproducible examples.
    ``explicit`` lists argument tuples that every run tries first (known edge
    cases, e.g. data scaled by 1e300), in both profiles and variants.
    """

    def decorate(body: Callable) -> Callable:
        name = body.__name__

        def test(profile: str, inputs: str) -> None:
            base = settings.get_profile(profile)
            count = max(2, round(base.max_examples * examples))
            drawn_from = valid if inputs == "valid" else strategies

            def example(*args: Any, **kwargs: Any) -> None:
                run_example(name, functools.partial(body, *args, **kwargs))

            example.__signature__ = inspect.signature(body)  # hypothesis names the values
            example.__name__ = name
            for args in reversed(explicit):
                example = hypothesis_example(*args)(example)
            run = seed(zlib.crc32(f"{name}:{inputs}".encode()))(
                settings(base, max_examples=count)(given(*drawn_from)(example))
            )
            run()
            survey_verdict(name)

        test.__name__ = test.__qualname__ = name
        test.__doc__ = body.__doc__
        test.__module__ = body.__module__
        variants = ["any", "valid"] if valid is not None else ["any"]
        return PROFILES(pytest.mark.parametrize("inputs", variants)(test))

    return decorate


# ---------------------------------------------------------------------------- data recipes

FORMS = ["float64"] * 10 + [
    "list",
    "float32",
    "int",
    "bool",
    "complex",
    "object",
    "str",
    "masked",
    "masked",
    "1d",
    "transposed",
    "pandas",
    "none",
    "scalar",
    "empty",
    "nested_ragged",
    "float16",
    "complex_real",
    "bytes",
    "dict",
]
"""How the x array reaches the library (``float64`` is a plain (T, n) array)."""

BATCH_FORMS = ["array3d"] * 3 + [
    "list_of_arrays",
    "list_of_arrays",
    "ragged_list",
    "list_of_lists",
    "masked3d",
    "list_with_none",
]

DEFECTS = [
    "nan_block",
    "nan_block",
    "nan_row",
    "all_nan",
    "inf",
    "neg_inf",
    "const_col",
    "dup_col",
    "zero",
    "huge_entry",
    "tiny_col",
    "u_nan",
    "u_inf",
    "u_zero",
    "u_const",
    "u_len",
    "u_huge",
    "nan_first",
    "nan_last",
    "step_change",
]
"""Modifications of the float64 data before the form is applied."""

SCALES = [1e150, 1e300, 1e-150, 1e-300, 1e100, 1e-100, 1e8, 1e-8, 0.0, -1.0, 1e307, 1.0]
"""Scales of x or u (one of the two, or both, for the "scale" aspect)."""


@dataclass(frozen=True)
class Data:
    """Recipe of a data set (x, u); ``x()``/``u()`` build the arrays it describes.

    ``R = 0`` means one trajectory of shape (T, n); ``R >= 1`` a batch (R, T, n)
    in ``form`` (one of :data:`BATCH_FORMS`).
    """

    T: int
    n: int
    m: int
    seed: int = 0
    R: int = 0
    scale: float = 1.0
    u_scale: float = 1.0
    defects: tuple = ()
    form: str = "float64"
    u_form: str = "float64"

    # sizes the library should see when it accepts the data
    @property
    def N(self) -> int:
        return max(self.T - 1, 0)

    def K(self, constant: Any = False) -> int:
        return self.n * (self.n + self.m + int(_truthy(constant)))

    # -- building ----------------------------------------------------------------------
    def arrays(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The float64 arrays (R or 1, T, n), (R or 1, T, m) before defects and forms."""
        rng = np.random.default_rng(self.seed)
        R = max(self.R, 1)
        n, m, T = self.n, self.m, self.T
        u = rng.standard_normal((R, T, m)) if m else None
        x = np.zeros((R, T, n))
        if T:
            x[:, 0] = rng.standard_normal((R, n))
        base = 0.5 * np.eye(n) + 0.3 * rng.standard_normal((n, n)) / np.sqrt(n)
        drift = 0.2 * rng.standard_normal((n, n)) / np.sqrt(n)
        B = rng.standard_normal((n, m)) if m else np.zeros((n, 0))
        for t in range(T - 1):
            A = base + drift * np.sin(2 * np.pi * t / max(T, 2))
            if "step_change" in self.defects and t >= T // 2:
                A = -A
            x[:, t + 1] = x[:, t] @ A.T + 0.1 * rng.standard_normal((R, n))
            if m:
                x[:, t + 1] += u[:, t] @ B.T
        return x, u

    def _defective(self) -> tuple[np.ndarray, np.ndarray | None]:
        x, u = self.arrays()
        _, T, n = x.shape
        with np.errstate(over="ignore", invalid="ignore"):
            x = x * self.scale
            if u is not None:
                u = u * self.u_scale
        rng = np.random.default_rng(self.seed + 1)
        t0 = int(rng.integers(0, max(T, 1)))
        j = int(rng.integers(0, n))
        for defect in self.defects:
            if not T:
                break
            if defect == "nan_block":
                x[:, t0 : t0 + 1 + T // 5, j] = np.nan
            elif defect == "nan_row":
                x[:, t0] = np.nan
            elif defect == "all_nan":
                x[:] = np.nan
            elif defect == "nan_first":
                x[:, 0] = np.nan
            elif defect == "nan_last":
                x[:, -1] = np.nan
            elif defect == "inf":
                x[0, t0, j] = np.inf
            elif defect == "neg_inf":
                x[0, t0, j] = -np.inf
            elif defect == "const_col":
                x[:, :, j] = 1.0
            elif defect == "dup_col" and n > 1:
                x[:, :, j] = x[:, :, (j + 1) % n]
            elif defect == "zero":
                x[:] = 0.0
            elif defect == "huge_entry":
                x[0, t0, j] = 1e300
            elif defect == "tiny_col":
                x[:, :, j] *= 1e-300
            elif u is not None and defect == "u_nan":
                u[:, t0] = np.nan
            elif u is not None and defect == "u_inf":
                u[0, t0, 0] = np.inf
            elif u is not None and defect == "u_zero":
                u[:] = 0.0
            elif u is not None and defect == "u_const":
                u[:] = 1.0
            elif u is not None and defect == "u_huge":
                u[0, t0, 0] = 1e300
        if u is not None and "u_len" in self.defects:
            u = u[:, :-1] if T else u
        return x, u

    def x(self) -> Any:
        x, _ = self._defective()
        return _apply_form(x, self.form, batch=bool(self.R))

    def u(self) -> Any:
        _, u = self._defective()
        if u is None:
            return None
        return _apply_form(u, self.u_form, batch=bool(self.R))

    def xu(self) -> tuple[Any, Any]:
        return self.x(), self.u()

    def regression(self) -> tuple[Any, Any]:
        """(y, phi) of the regression behind the data: y_t = x[t+1], φ_t = [x[t]; u[t]]."""
        x, u = self._defective()
        y = x[:, 1:]
        T = x.shape[1]
        parts = [x[:, :-1]] + ([u[:, : T - 1]] if u is not None else [])
        phi = np.concatenate(parts, axis=2) if T else np.zeros((x.shape[0], 0, 1))
        if phi.shape[1] and "u_len" in self.defects:  # one row short
            phi = phi[:, 1:]
        return (
            _apply_form(y, self.form, batch=bool(self.R)),
            _apply_form(phi, self.u_form, batch=bool(self.R)),
        )

    def clean(self) -> tuple[np.ndarray, np.ndarray | None]:
        """float64 (T, n)/(R, T, n) arrays of the recipe (defects applied, no form)."""
        x, u = self._defective()
        if not self.R:
            return x[0], None if u is None else u[0]
        return x, u


def _truthy(value: Any) -> bool:
    try:
        return bool(value) if isinstance(value, (bool, int, float, np.bool_, np.integer)) else False
    except (TypeError, ValueError):
        return False


def _apply_form(a: np.ndarray, form: str, *, batch: bool) -> Any:
    """a: (R, T, d) float64. Returns what the library receives."""
    if batch:
        parts = [a[r] for r in range(a.shape[0])]
        if form == "array3d":
            return a
        if form == "list_of_arrays":
            return parts
        if form == "ragged_list":
            return [p[: max(len(p) - r, 0)] for r, p in enumerate(parts)]
        if form == "list_of_lists":
            return [p.tolist() for p in parts]
        if form == "masked3d":
            masked = np.ma.masked_array(a, mask=np.zeros(a.shape, dtype=bool))
            if a.size:
                masked.mask.flat[:: max(a.size // 4, 1)] = True
            return masked
        if form == "list_with_none":
            return parts[:-1] + [None]
        return a
    a = a[0]
    with np.errstate(all="ignore"):
        if form == "float64":
            return a
        if form == "list":
            return a.tolist()
        if form == "float32":
            return a.astype(np.float32)
        if form == "float16":
            return a.astype(np.float16)
        if form == "int":
            return np.nan_to_num(a, nan=0, posinf=0, neginf=0).round().astype(np.int64)
        if form == "bool":
            return a > 0
        if form == "complex":
            return a + 1j * np.ones_like(a)
        if form == "complex_real":
            return a.astype(complex)
        if form == "object":
            return a.astype(object)
        if form == "str":
            return a.astype(str)
        if form == "bytes":
            return a.tobytes()
        if form == "dict":
            return {"x": a}
        if form == "masked":
            masked = np.ma.masked_array(a, mask=np.zeros(a.shape, dtype=bool))
            if a.size:
                masked.mask.flat[:: max(a.size // 3, 1)] = True
                masked.data.flat[:: max(a.size // 3, 1)] = 1e300  # must not be used
            return masked
        if form == "1d":
            return a[:, 0] if a.ndim == 2 and a.shape[1] == 1 else a.ravel()
        if form == "transposed":
            return a.T
        if form == "pandas":
            import pandas as pd

            return pd.DataFrame(a, columns=[f"c{j}" for j in range(a.shape[1])])
        if form == "none":
            return None
        if form == "scalar":
            return 3.0
        if form == "empty":
            return np.empty((0, a.shape[1]))
        if form == "nested_ragged":
            rows = a.tolist()
            if rows:
                rows[0] = rows[0] + [1.0]
            return rows
    return a


ASPECTS = ["clean", "clean", "clean", "scale", "defect", "defect", "form", "form", "mixed"]
"""What a drawn data set is unusual in (one thing at a time, mostly)."""


@st.composite
def datasets(
    draw: Callable,
    *,
    inputs: bool = True,
    batch: bool = True,
    edge: bool = True,
    min_T: int = 0,
    max_T: int = 60,
    max_n: int = 4,
    forms: bool = True,
) -> Data:
    """A :class:`Data` recipe; ``edge=False`` keeps the data clean (no defects, float64)."""
    if edge:
        usual = st.integers(max(min_T, 12), max_T)
        T = draw(
            st.one_of(
                usual,
                usual,
                usual,
                usual,
                st.sampled_from([v for v in (0, 1, 2, 3, 4, 5, 6, max_T) if v >= min_T]),
            )
        )
        n = draw(
            st.one_of(
                st.integers(1, max_n),
                st.integers(1, max_n),
                st.integers(1, 2),
                st.integers(1, 2),
                st.just(6),
            )
        )
    else:
        T = draw(st.integers(max(min_T, 15), max_T))
        n = draw(st.integers(1, min(max_n, 3)))
    m = draw(st.integers(0, 2)) if inputs else 0
    R = draw(st.sampled_from([0] * 7 + [1, 2, 3])) if batch and edge else 0
    data_seed = draw(st.integers(0, 2**16))
    if not edge:
        return Data(T, n, m, data_seed)
    aspect = draw(st.sampled_from(ASPECTS if forms else [a for a in ASPECTS if a != "form"]))
    scale = u_scale = 1.0
    defects: tuple = ()
    form = u_form = "array3d" if R else "float64"
    if aspect in ("scale", "mixed"):
        which = draw(st.sampled_from(["x", "x", "both", "u"])) if m else "x"
        scale = draw(st.sampled_from(SCALES)) if which != "u" else 1.0
        u_scale = draw(st.sampled_from(SCALES)) if which != "x" else 1.0
    if aspect in ("defect", "mixed"):
        defects = tuple(
            draw(st.lists(st.sampled_from(DEFECTS), min_size=1, max_size=2, unique=True))
        )
    if aspect in ("form", "mixed") and forms:
        form = draw(st.sampled_from(BATCH_FORMS if R else FORMS))
        u_form = draw(st.sampled_from(["float64"] * 6 + (BATCH_FORMS if R else FORMS)))
        if R and u_form == "float64":
            u_form = "array3d"
    return Data(T, n, m, data_seed, R, scale, u_scale, defects, form, u_form)


# ---------------------------------------------------------------------------- option values

OMIT = "<default>"
"""An option left out of the call (the library's default applies)."""


@dataclass(frozen=True)
class Opt:
    """The values of one option: ``valid`` ones and ``invalid`` ones (strategies)."""

    valid: st.SearchStrategy
    invalid: st.SearchStrategy


def choice_of(*items: Any) -> st.SearchStrategy:
    return st.sampled_from(list(items))


@st.composite
def options(draw: Callable, required: tuple = (), max_bad: int = 2, **spec: Opt) -> dict:
    """Keyword arguments: mostly valid or omitted, with up to ``max_bad`` drawn invalid.

    ``required`` names are never omitted. Tokens ``@...`` in the values are
    resolved by :func:`resolve` in the test.
    """
    names = sorted(spec)
    n_bad = draw(st.sampled_from([b for b in (0, 0, 0, 1, 1, 2) if b <= max_bad]))
    bad = set(draw(st.permutations(names))[:n_bad]) if names else set()
    out = {}
    for name in names:
        if name in bad:
            out[name] = draw(spec[name].invalid)
        else:
            valid = spec[name].valid
            value = draw(valid if name in required else st.one_of(st.just(OMIT), valid))
            if not (isinstance(value, str) and value == OMIT):
                out[name] = value
    return out


def special_floats() -> st.SearchStrategy:
    return choice_of(
        0.0,
        -1.0,
        np.inf,
        -np.inf,
        np.nan,
        1e300,
        1e150,
        1e-300,
        -0.0,
        np.float32(2.0),
        np.int64(3),
        True,
        "1.0",
        "abc",
        None,
        1j,
    )


LAM = Opt(
    st.one_of(
        st.floats(0.05, 300.0),
        st.floats(0.05, 300.0),
        choice_of(
            "auto",
            "@vecK",
            "@vecK_inf",
            "@vecK_zero",
            "@matK",
            0.0,
            np.inf,
            np.float32(2.0),
            np.int64(3),
            1e-300,
            1e150,
            [3.0],
        ),
    ),
    choice_of(
        -1.0,
        -np.inf,
        np.nan,
        1e300,
        "abc",
        None,
        True,
        1j,
        "@vecK_neg",
        "@vecK_nan",
        "@vecK-1",
        "@vecK+1",
        "@matK_nonpsd",
        "@matK_nonsym",
        "@matK_nan",
        "@matK_wrong",
        "@masked",
        "@ragged",
        "@empty",
        "@column",
        "@vecK_huge",
        "1.0",
        "AUTO",
        "",
        "ml",
    ),
)
SPARSE_LAM = Opt(
    st.one_of(
        st.floats(0.05, 30.0),
        st.floats(0.05, 30.0),
        choice_of("auto", "@vecK", "@vecK_inf", np.inf, 1e-300, 1e200),
    ),
    LAM.invalid,
)
ORDER = Opt(
    choice_of(
        1,
        1,
        2,
        2,
        3,
        [-1, 1],
        [1, -2, 1],
        np.int64(2),
        [-1, 3, -3, 1],
        [0.5, -1.5, 1.0],
        np.array([-1.0, 1.0]),
    ),
    choice_of(
        0,
        -1,
        1.5,
        "1",
        True,
        False,
        None,
        [1, 1],
        [],
        [[1, -1]],
        10,
        [np.nan, 1.0],
        "2",
        [-1e300, 1e300],
        [1e-300, -1e-300],
        2.0,
    ),
)
NORM = Opt(
    choice_of("sq", "sq", "group", "l1"),
    choice_of("SQ", "l2", "", None, 1, "l0", "piecewise", " group", ["sq"]),
)
WEIGHTS = Opt(
    choice_of(None, "@ones", "@some_zero", "@huge", "@tiny", "@RN", "@ones"),
    choice_of("@zeros", "@neg", "@nan", "@inf", "@len+1", "@2d", "@str", "@scalar", "@w_masked"),
)
CONSTANT = Opt(choice_of(False, True, np.bool_(True)), choice_of(1, 0, "yes", None, 2, 1.0))
NOISE_VAR = Opt(
    choice_of(None, 1.0, 0.5, 1e-300, "@vec_n"),
    choice_of(0.0, -1.0, np.nan, np.inf, 1e300, "@vec_wrong", "abc", [1.0]),
)
BOOL = Opt(choice_of(True, False), choice_of(None, "no", 1, 0, np.bool_(False), 2.0))
PRIOR = Opt(
    choice_of(
        None,
        "@prior_ok",
        "@prior_NK",
        "@prior_NKK",
        "@output_prior",
        "@prior_list",
        "@prior_tiny_cov",
        "@prior_huge",
    ),
    choice_of("@prior_wrong_K", "@output_prior_bad", "@not_prior", "prior", 3.0),
)
PRIOR_MODE = Opt(choice_of("exact", "posthoc"), choice_of("bogus", None, "EXACT", 1))
MAX_ITER = Opt(st.integers(1, 50), choice_of(0, -1, 1.5, "10", None, np.nan, 10**12))
TOL = Opt(choice_of(1e-6, 1e-3, 0.5, 1e-12), choice_of(0.0, -1.0, np.nan, np.inf, "x", 1e-300, 2.0))
LOSS = Opt(choice_of("squared", "huber", "laplace"), choice_of("cauchy", None, 1, "HUBER"))
HUBER_DELTA = Opt(
    choice_of(None, 0.5, 1e-3, 10.0, "@vec_n"),
    choice_of(0.0, -1.0, np.nan, np.inf, "x", 1e300, "@vec_wrong"),
)


def counts(low: int, high: int) -> Opt:
    """A nonnegative count option (n_changes, min_size, na, ...)."""
    return Opt(
        st.integers(low, high),
        choice_of(-1, 1.5, "2", None, 10**9, True, np.float64(3.0), np.nan, low - 1),
    )


def resolve(value: Any, *, K: int, n: int, N: int, R: int = 0, p: int | None = None) -> Any:
    """The concrete value of an option token (see :func:`lams`, :data:`WEIGHTS`, ...)."""
    if not (isinstance(value, str) and value.startswith("@")):
        return value
    rng = np.random.default_rng(7)
    K = max(K, 1)
    token = value[1:]
    if token == "vecK":
        return np.full(K, 3.0)
    if token == "vecK_inf":
        v = np.full(K, 3.0)
        v[::2] = np.inf
        return v
    if token == "vecK_neg":
        v = np.full(K, 3.0)
        v[0] = -1.0
        return v
    if token == "vecK_nan":
        v = np.full(K, 3.0)
        v[-1] = np.nan
        return v
    if token == "vecK_zero":
        v = np.full(K, 3.0)
        v[0] = 0.0
        return v
    if token == "vecK_huge":
        v = np.full(K, 3.0)
        v[0] = 1e200
        return v
    if token == "vecK-1":
        return np.full(max(K - 1, 0), 3.0)
    if token == "vecK+1":
        return np.full(K + 1, 3.0)
    if token == "column":
        return np.full((K, 1), 3.0)
    if token == "matK":
        G = rng.standard_normal((K, K))
        return G @ G.T + K * np.eye(K)
    if token == "matK_nonpsd":
        return -np.eye(K)
    if token == "matK_nonsym":
        M = np.eye(K) * 4.0
        if K > 1:
            M[0, 1] = 3.0
        return M
    if token == "matK_nan":
        M = np.eye(K)
        M[0, 0] = np.nan
        return M
    if token == "matK_wrong":
        return np.eye(K + 1)
    if token == "masked":
        return np.ma.masked_array(np.full(K, 3.0), mask=[True] + [False] * (K - 1))
    if token == "ragged":
        return [[1.0, 2.0], [3.0]]
    if token == "list1":
        return [3.0]
    if token == "empty":
        return []
    # weights
    Nw = max(N, 0)
    if token == "ones":
        return np.ones(Nw)
    if token == "zeros":
        return np.zeros(Nw)
    if token == "neg":
        w = np.ones(Nw)
        w[:1] = -1.0
        return w
    if token == "nan":
        w = np.ones(Nw)
        w[:1] = np.nan
        return w
    if token == "inf":
        w = np.ones(Nw)
        w[:1] = np.inf
        return w
    if token == "len+1":
        return np.ones(Nw + 1)
    if token == "2d":
        return np.ones((Nw, 2))
    if token == "str":
        return ["1"] * Nw
    if token == "some_zero":
        w = np.ones(Nw)
        w[::2] = 0.0
        return w
    if token == "huge":
        return np.full(Nw, 1e300)
    if token == "tiny":
        return np.full(Nw, 1e-300)
    if token == "RN":
        return np.ones((max(R, 1), Nw))
    if token == "scalar":
        return 2.0
    if token == "w_masked":
        return np.ma.masked_array(np.ones(Nw), mask=np.arange(Nw) % 2 == 0)
    # noise variances
    if token == "vec_n":
        return np.full(n, 0.5)
    if token == "vec_wrong":
        return np.full(n + 1, 0.5)
    # priors (a prior whose construction fails is fuzzed by the prior test; here: None)
    makers = {
        "prior_ok": lambda: ltv.Prior(np.zeros(K), 1.0),
        "prior_nan_mean": lambda: ltv.Prior(np.full(K, np.nan), 1.0),
        "prior_cov0": lambda: ltv.Prior(np.zeros(K), 0.0),
        "prior_neg": lambda: ltv.Prior(np.zeros(K), -np.eye(K)),
        "prior_wrong_K": lambda: ltv.Prior(np.zeros(K + 1), 1.0),
        "prior_NK": lambda: ltv.Prior(np.zeros((max(N, 1), K)), 0.5),
        "prior_NKK": lambda: ltv.Prior(
            np.zeros((max(N, 1), K)), np.broadcast_to(np.eye(K), (max(N, 1), K, K)).copy()
        ),
        "prior_huge": lambda: ltv.Prior(np.full(K, 1e300), 1.0),
        "prior_tiny_cov": lambda: ltv.Prior(np.zeros(K), 1e-300),
        "output_prior": lambda: ltv.OutputPrior(np.zeros(n), 1.0),
        "output_prior_bad": lambda: ltv.OutputPrior(np.zeros(n + 1), np.eye(n + 1)),
        "prior_list": lambda: [ltv.Prior(np.zeros(K), 1.0), ltv.OutputPrior(np.zeros(n), 2.0)],
        "not_prior": lambda: {"mean": np.zeros(K), "cov": 1.0},
    }
    if token in makers:
        try:
            return makers[token]()
        except (ValueError, TypeError):
            return None
    raise AssertionError(f"unknown token {value!r}")


# ---------------------------------------------------------------------------- fitted models


@functools.cache
def fitted(kind: str):
    """One model of each kind, fitted on clean data (cached for the session)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = ltv.systems.jump_linear(T=60, change_at=30, seed=1)
        x, u = data.x, data.u
        if kind == "sq":
            return ltv.fit(x, u, lam=10.0)
        if kind == "sq_constant":
            return ltv.fit(x, u, lam=10.0, constant=True)
        if kind == "group":
            return ltv.fit(x, u, lam=5.0, norm="group")
        if kind == "autonomous":
            return ltv.fit(x, None, lam=10.0)
        if kind == "lti":
            return ltv.fit_lti(x, u)
        if kind == "segments":
            return ltv.fit_segments(x, u, n_changes=1)
        if kind == "ar":
            return ltv.fit_ar(x[:, 0], 2, lam=10.0)
        if kind == "var":
            return ltv.fit_ar(x, 2, lam=10.0, constant=True)
        if kind == "arx":
            return ltv.fit_arx(x[:, 0], u[:, 0], 2, 1, lam=10.0)
        if kind == "regression":
            return ltv.fit_regression(x[1:], np.column_stack([x[:-1], u[:-1]]), lam=10.0)
    raise AssertionError(kind)


# ---------------------------------------------------------------------------- file contents

MODEL_KINDS = [
    "sq",
    "sq_constant",
    "group",
    "autonomous",
    "lti",
    "segments",
    "ar",
    "var",
    "arx",
    "regression",
]

MEMBER_EDITS = [
    "none",
    "none",
    "drop:k",
    "drop:meta",
    "drop:noise_cov",
    "drop:lam",
    "drop:coeffs",
    "drop:cov_blocks",
    "drop:cov_row_group",
    "drop:changepoints",
    "k_nan",
    "k_inf",
    "k_1d",
    "k_wrong_K",
    "k_str",
    "k_empty",
    "k_int",
    "k_complex",
    "k_3d",
    "k_huge",
    "noise_cov_nan",
    "noise_cov_shape",
    "noise_cov_str",
    "lam_nan",
    "lam_str",
    "lam_neg",
    "lam_shape",
    "cov_blocks_nan",
    "cov_blocks_shape",
    "cov_blocks_neg",
    "cov_row_group_bad",
    "cov_row_group_float",
    "cov_row_scale_nan",
    "coeffs_nan",
    "coeffs_empty",
    "coeffs_2d",
    "changepoints_out",
    "changepoints_float",
    "changepoints_2d",
    "info_nan",
    "extra_member",
    "meta_bytes",
    "meta_2d",
]
"""Edits of the arrays inside a saved model archive."""

META_EDITS = [
    "none",
    "none",
    "none",
    "not_json",
    "list",
    "version_3",
    "version_str",
    "version_none",
    "no_version",
    "type_unknown",
    "type_int",
    "type_regression_for_ltv",
    "n_states_str",
    "n_states_neg",
    "n_states_huge",
    "n_states_float",
    "n_inputs_wrong",
    "constant_str",
    "noise_var_nan",
    "noise_var_len",
    "noise_var_str",
    "noise_var_null",
    "loglik_str",
    "loglik_nan",
    "loglik_inf",
    "info_list",
    "info_missing",
    "status_bad",
    "status_keys",
    "status_objective_str",
    "status_list",
    "norm_int",
    "na_neg",
    "na_huge",
    "drop_structure",
    "empty_object",
    "status_iterations_float",
    "nested_info_nan",
]
"""Edits of the JSON ``meta`` member."""

FILE_EDITS = [
    "none",
    "none",
    "none",
    "truncate",
    "flip_byte",
    "append_garbage",
    "empty",
    "random_bytes",
    "text",
    "gzip",
    "zip_of_text",
    "npy_not_npz",
]


@dataclass(frozen=True)
class ModelFile:
    """Recipe of the bytes of a model file: a saved model of ``kind`` with edits."""

    kind: str
    member_edit: str = "none"
    meta_edit: str = "none"
    file_edit: str = "none"
    fraction: float = 0.5
    seed: int = 0

    def content(self) -> bytes:
        import io
        import json
        import os
        import tempfile
        import zipfile

        model = fitted(self.kind)
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "m.npz")
            model.save(path)
            with np.load(path, allow_pickle=False) as data:
                members = {key: data[key] for key in data.files}
        members = _edit_members(members, self.member_edit)
        if "meta" in members and members["meta"].dtype.kind == "U" and members["meta"].ndim == 0:
            meta = json.loads(str(members["meta"]))
            edited = _edit_meta(meta, self.meta_edit)
            members["meta"] = np.array(edited if isinstance(edited, str) else json.dumps(edited))
        buffer = io.BytesIO()
        np.savez(buffer, **members)
        raw = buffer.getvalue()
        rng = np.random.default_rng(self.seed)
        if self.file_edit == "truncate":
            return raw[: int(len(raw) * self.fraction)]
        if self.file_edit == "flip_byte":
            b = bytearray(raw)
            i = int(len(b) * self.fraction) % max(len(b), 1)
            b[i] ^= 0xFF
            return bytes(b)
        if self.file_edit == "append_garbage":
            return raw + rng.bytes(64)
        if self.file_edit == "empty":
            return b""
        if self.file_edit == "random_bytes":
            return rng.bytes(int(1 + 2000 * self.fraction))
        if self.file_edit == "text":
            return b"t,x1,x2\n0,1,2\n"
        if self.file_edit == "gzip":
            import gzip

            return gzip.compress(raw)
        if self.file_edit == "zip_of_text":
            out = io.BytesIO()
            with zipfile.ZipFile(out, "w") as z:
                z.writestr("k.npy", b"not an array")
                z.writestr("meta.npy", b"{}")
            return out.getvalue()
        if self.file_edit == "npy_not_npz":
            out = io.BytesIO()
            np.save(out, np.zeros(3))
            return out.getvalue()
        return raw


def _edit_members(members: dict, edit: str) -> dict:
    m = dict(members)
    k = m.get("k")
    if edit.startswith("drop:"):
        m.pop(edit[5:], None)
        return m
    if edit == "none" or k is None:
        return m
    table = {
        "k_nan": lambda: {"k": k * np.nan},
        "k_inf": lambda: {"k": k + np.inf},
        "k_1d": lambda: {"k": k.ravel()},
        "k_wrong_K": lambda: {"k": k[:, :-1]},
        "k_str": lambda: {"k": k.astype(str)},
        "k_empty": lambda: {"k": k[:0]},
        "k_int": lambda: {"k": np.ones(k.shape, dtype=np.int64)},
        "k_complex": lambda: {"k": k + 1j},
        "k_3d": lambda: {"k": k[None]},
        "k_huge": lambda: {"k": k * 1e308},
        "noise_cov_nan": lambda: {"noise_cov": np.full_like(m["noise_cov"], np.nan)},
        "noise_cov_shape": lambda: {"noise_cov": np.ones((7, 3))},
        "noise_cov_str": lambda: {"noise_cov": np.array("abc")},
        "lam_nan": lambda: {"lam": np.array(np.nan)},
        "lam_str": lambda: {"lam": np.array("x")},
        "lam_neg": lambda: {"lam": np.array(-1.0)},
        "lam_shape": lambda: {"lam": np.ones((2, 3, 4))},
        "cov_blocks_nan": lambda: (
            {"cov_blocks": m["cov_blocks"] * np.nan} if "cov_blocks" in m else {}
        ),
        "cov_blocks_shape": lambda: {"cov_blocks": np.ones((2, 3))},
        "cov_blocks_neg": lambda: (
            {"cov_blocks": -np.abs(m["cov_blocks"])} if "cov_blocks" in m else {}
        ),
        "cov_row_group_bad": lambda: {"cov_row_group": np.array([5, 9, 11])},
        "cov_row_group_float": lambda: {"cov_row_group": np.array([0.5])},
        "cov_row_scale_nan": lambda: {"cov_row_scale": np.array([np.nan, np.nan])},
        "coeffs_nan": lambda: {"coeffs": np.array([np.nan, 1.0])},
        "coeffs_empty": lambda: {"coeffs": np.zeros(0)},
        "coeffs_2d": lambda: {"coeffs": np.ones((2, 2))},
        "changepoints_out": lambda: {"changepoints": np.array([-3, 10**6])},
        "changepoints_float": lambda: {"changepoints": np.array([2.5])},
        "changepoints_2d": lambda: {"changepoints": np.ones((2, 2), dtype=int)},
        "info_nan": lambda: {"info__bogus": np.array([np.nan])},
        "extra_member": lambda: {"zzz": np.arange(3)},
        "meta_bytes": lambda: {"meta": np.array(b"\x00\xff")},
        "meta_2d": lambda: {"meta": np.array([["a"]])},
    }
    m.update(table[edit]())
    return m


def _edit_meta(meta: dict, edit: str) -> Any:
    import copy

    meta = copy.deepcopy(meta)
    if edit == "none":
        return meta
    if edit == "not_json":
        return "{not json"
    if edit == "list":
        return [1, 2, 3]
    if edit == "empty_object":
        return {}
    structure_keys = (
        "n_states",
        "n_inputs",
        "constant",
        "n_outputs",
        "n_regressors",
        "na",
        "nb",
        "nk",
    )
    setters = {
        "version_3": ("format_version", 3),
        "version_str": ("format_version", "2"),
        "version_none": ("format_version", None),
        "type_unknown": ("model_type", "Foo"),
        "type_int": ("model_type", 3),
        "type_regression_for_ltv": ("model_type", "ARModel"),
        "n_states_str": ("n_states", "2"),
        "n_states_neg": ("n_states", -1),
        "n_states_huge": ("n_states", 10**9),
        "n_states_float": ("n_states", 1.5),
        "n_inputs_wrong": ("n_inputs", 5),
        "constant_str": ("constant", "yes"),
        "noise_var_nan": ("noise_var", [float("nan")] * 2),
        "noise_var_len": ("noise_var", [1.0] * 7),
        "noise_var_str": ("noise_var", "abc"),
        "noise_var_null": ("noise_var", None),
        "loglik_str": ("loglik", "high"),
        "loglik_nan": ("loglik", float("nan")),
        "loglik_inf": ("loglik", float("inf")),
        "info_list": ("info", [1]),
        "status_bad": ("status", {"status": "great"}),
        "status_list": ("status", [1, 2]),
        "norm_int": ("norm", 5),
        "na_neg": ("na", -2),
        "na_huge": ("na", 10**6),
    }
    if edit in setters:
        key, value = setters[edit]
        meta[key] = value
    elif edit == "no_version":
        meta.pop("format_version", None)
    elif edit == "info_missing":
        meta.pop("info", None)
    elif edit == "drop_structure":
        for key in structure_keys:
            meta.pop(key, None)
    elif edit == "status_keys" and isinstance(meta.get("status"), dict):
        meta["status"].pop("solver", None)
    elif edit == "status_objective_str" and isinstance(meta.get("status"), dict):
        meta["status"]["objective"] = "x"
    elif edit == "status_iterations_float" and isinstance(meta.get("status"), dict):
        meta["status"]["iterations"] = 2.5
    elif edit == "nested_info_nan":
        meta.setdefault("info", {})["objective"] = float("nan")
    return meta


@st.composite
def model_files(draw: Callable, *, max_edits: int = 1) -> ModelFile:
    """A model file recipe: mostly one edit (member, meta or whole-file) at a time."""
    kind = draw(st.sampled_from(MODEL_KINDS))
    where = draw(st.sampled_from(["none", "member", "meta", "meta", "file", "mixed"]))
    member = draw(st.sampled_from(MEMBER_EDITS)) if where in ("member", "mixed") else "none"
    meta = draw(st.sampled_from(META_EDITS)) if where in ("meta", "mixed") else "none"
    file_edit = draw(st.sampled_from(FILE_EDITS)) if where in ("file", "mixed") else "none"
    return ModelFile(
        kind, member, meta, file_edit, draw(st.floats(0.0, 1.0)), draw(st.integers(0, 1000))
    )


__all__ = [
    "Data",
    "datasets",
    "options",
    "Opt",
    "OMIT",
    "resolve",
    "fuzz_test",
    "special_floats",
    "PROFILES",
    "choice_of",
    "LAM",
    "SPARSE_LAM",
    "ORDER",
    "NORM",
    "WEIGHTS",
    "CONSTANT",
    "NOISE_VAR",
    "BOOL",
    "PRIOR",
    "PRIOR_MODE",
    "MAX_ITER",
    "TOL",
    "counts",
    "fitted",
    "ModelFile",
    "model_files",
]
