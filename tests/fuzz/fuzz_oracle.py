"""The oracle of the fuzzing suite: what an ltvmodels call may do with any input.

Every fuzzed call goes through :func:`check_call`, which runs it with all
warnings recorded and accepts exactly three kinds of outcome:

(a) **a valid finite result.** The call returns, and every float the result
    carries is finite: the arrays and scalars of a model (``k``, ``theta``,
    ``A``, ``B``, ``c``, ``cov``, ``std()``, ``cov_full()``, ``noise_var``,
    ``noise_cov``, ``loglik``, ``status.objective``, the numbers in ``info``),
    of a :class:`~ltvmodels.LambdaSelection`, a :class:`~ltvmodels.Segmentation`,
    a Kalman result, a prior, plain floats and arrays. Models are also *used*:
    ``repr``/``summary()``, ``activation()``, ``changepoints`` and
    ``predict``/``simulate`` on fresh finite data of the right shape must work
    and give finite numbers. Non-finite values are accepted only where the
    documentation promises them (:data:`DOCUMENTED_NONFINITE`): ``lam = inf``
    (LTI/piecewise/L0 models, coefficients held constant), ``inf`` in
    ``costs_by_n_changes`` (infeasible counts), NaN of a Kalman filter before
    ``first_identified``, NaN slots of ``root_spectrogram`` (real poles), NaN
    of ``predict`` where the data are NaN, and ``inf`` of ``simulate`` together
    with a :class:`~ltvmodels.DivergenceWarning`.
(b) **a documented library error.** ``ValueError``, ``TypeError`` or
    ``NotImplementedError`` (exactly those, or the library's own subclasses
    :class:`~ltvmodels.SingularProblemError`, :class:`~ltvmodels.ModelFileError`,
    :class:`~ltvmodels.OutputPathError`), raised from a frame inside
    ``ltvmodels``, with a non-empty message that is not a bare numpy/Python
    internal message (:data:`FOREIGN_MESSAGES`). A message of the form
    ``"name: ..."`` must name an argument of the called function that the
    caller actually passed: blaming a defaulted or non-existent argument
    (``fit_regression(y=[], ...)`` -> ``"order: ..."``) is a failure. Other
    ``ValueError`` subclasses (``LinAlgError``, ``JSONDecodeError``,
    ``UnicodeDecodeError``) and every other exception type (``IndexError``,
    ``ZeroDivisionError``, ``OverflowError``, ``KeyError``, ``AttributeError``,
    numba errors, ``zipfile.BadZipFile``, ...) are failures, except where a
    function documents them (``load``: ``FileNotFoundError``,
    ``IsADirectoryError``, ``PermissionError``; ``ilqg``: ``LinAlgError``).
(c) **documented warnings only.** :class:`~ltvmodels.IdentifiabilityWarning`,
    :class:`~ltvmodels.PrecisionWarning`, :class:`~ltvmodels.ConvergenceWarning`,
    :class:`~ltvmodels.DivergenceWarning`, :class:`~ltvmodels.ModelStructureWarning`
    may accompany (a) or (b). Any other
    warning (numpy/numba ``RuntimeWarning`` overflow/invalid-value, a
    ``UserWarning`` of another package, ...) is a failure.

``None`` in place of a value is accepted where documented
(:data:`DOCUMENTED_NONE`): ``cov``/``std()``/``cov_full()`` when not computed,
``loglik`` of the sparse norms ("group", "l1"), the optional fields of a
selection or segmentation.

Every accepted outcome is counted in :data:`OUTCOMES` and every example in
:data:`EXAMPLES` (printed at the end of the run by ``conftest.py``). With the
environment variable ``FUZZ_SURVEY=1`` a test keeps going after a failure,
collects the distinct failures (deduplicated by :attr:`FuzzFailure.signature`,
with the drawn arguments that produced them) in :data:`SURVEY_FAILURES` and
fails once at its end with the whole list. ``FUZZ_LOG=path`` appends one line
per accepted call (label, outcome, call) to a file, to tune the strategies.
"""

from __future__ import annotations

import collections
import inspect
import json
import os
import re
import tempfile
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import ltvmodels as ltv

# ---------------------------------------------------------------------------- configuration

LIBRARY_ERRORS = (ltv.SingularProblemError, ltv.ModelFileError, ltv.OutputPathError)
"""The library's own exception classes (all subclass ValueError)."""

PLAIN_ERRORS = (ValueError, TypeError, NotImplementedError)
"""Exception types accepted when raised exactly (not a foreign subclass)."""

LIBRARY_WARNINGS = (
    ltv.IdentifiabilityWarning,
    ltv.PrecisionWarning,
    ltv.ConvergenceWarning,
    ltv.DivergenceWarning,
    ltv.ModelStructureWarning,
)
"""The warning classes a call may issue."""

FOREIGN_MESSAGES = (
    "setting an array element with a sequence",
    "could not broadcast",
    "operands could not be",
    "index out of bounds",
    "out of bounds for axis",
    "eigenvalues did not converge",
    "svd did not converge",
    "unsupported operand",
    "object of type",
    "'nonetype'",
    "division by zero",
    "could not convert",
    "invalid literal for",
    "cannot reshape",
    "too many indices",
    "not enough values to unpack",
    "too many values to unpack",
    "is not subscriptable",
    "has no len()",
    "unhashable type",
    "not supported between",
    "only integer scalar arrays",
    "only length-1 arrays",
    "can't multiply sequence",
    "argument must be a string or a",
    "zero-size array to reduction",
    "ufunc",
    "matrix is not positive definite",
    "singular matrix",
    "nopython",
    "numba",
    "non-broadcastable",
    "inhomogeneous shape",
    "object arrays are not supported",
    "cannot cast",
    "must be real number",
    "is not iterable",
    "takes from",
    "positional argument",
    "keyword argument",
    "cannot be safely cast",
    "array must not contain infs or nans",
    "expected square matrix",
    "last 2 dimensions",
    "mismatch in its core dimension",
    "is not callable",
    "blockfactor",
    "unexpected array size",
    "leading minor",
)
"""Fragments of numpy/scipy/Python/numba messages that must not reach the user unexplained."""

DOCUMENTED_OS_ERRORS = (FileNotFoundError, IsADirectoryError, PermissionError, NotADirectoryError)
"""The file errors ``ltvmodels.load`` documents ("as for any file")."""

# Arguments an error message may name although the call does not take them under that name:
# the parts of an argument (a Prior's mean/cov, a list's items x[0]...).
ARGUMENT_PARTS = {
    "prior": ("mean", "cov", "prior"),
    "x": ("x",),
    "u": ("u",),
    "y": ("y",),
}

SURVEY = os.environ.get("FUZZ_SURVEY", "") not in ("", "0")
"""Survey mode: collect distinct failures instead of stopping at the first."""

OUTCOMES: collections.Counter = collections.Counter()
"""(label, outcome) -> count; outcome in {"finite", "finite+None", "library error"}."""

EXAMPLES: collections.Counter = collections.Counter()
"""test name -> number of hypothesis examples run (each makes one or more calls)."""

SURVEY_FAILURES: dict[str, dict[tuple, str]] = collections.defaultdict(dict)
"""test name -> {failure signature: first report} (survey mode)."""


class FuzzFailure(AssertionError):
    """An outcome the oracle does not accept; ``signature`` deduplicates by root cause."""

    def __init__(self, label: str, kind: str, detail: str, call: str = "") -> None:
        self.signature = (label, kind, _normalize(detail))
        text = f"[{label}] {kind}: {detail}"
        if call:
            text += f"\n    call: {call}"
        super().__init__(text)


def _normalize(text: str) -> str:
    """A message with numbers and reprs blurred, to group failures with one cause."""
    text = re.sub(r"\d+(\.\d+)?(e[-+]?\d+)?", "#", str(text).lower())
    text = re.sub(r"'[^']*'", "'?'", text)
    return text[:90]


# ---------------------------------------------------------------------------- the call


@dataclass
class Call:
    """One fuzzed call: what ran and what came back (filled in by :func:`check_call`)."""

    label: str
    fn: Callable
    args: tuple
    kwargs: dict
    passed: set = field(default_factory=set)
    warnings: list = field(default_factory=list)

    def describe(self) -> str:
        parts = [_short(a) for a in self.args] + [
            f"{k}={_short(v)}" for k, v in self.kwargs.items()
        ]
        return f"{self.label}({', '.join(parts)})"


def _short(value: Any) -> str:
    if isinstance(value, np.ndarray):
        if value.size <= 6:
            return f"np.array({value.tolist()!r}, dtype={value.dtype})"
        return f"<array {value.shape} {value.dtype}>"
    if isinstance(value, (list, tuple)) and len(repr(value)) > 80:
        return f"<{type(value).__name__} of {len(value)}>"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _label(fn: Callable) -> str:
    name = getattr(fn, "__qualname__", None) or getattr(fn, "__name__", None) or repr(fn)
    return name


def _passed_names(fn: Callable, args: tuple, kwargs: dict) -> set:
    """Names of the parameters the caller gave (positionally or by keyword)."""
    try:
        sig = inspect.signature(fn)
        bound = sig.bind_partial(*args, **kwargs)
        names = set(bound.arguments)
    except (TypeError, ValueError):
        names = set(kwargs)
    extra = set()
    for name in names:
        extra.update(ARGUMENT_PARTS.get(name, ()))
    return names | extra


def _parameters(fn: Callable) -> set:
    try:
        return set(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        return set()


def check_call(
    fn: Callable,
    *args: Any,
    label: str | None = None,
    allow: tuple = (),
    inspector: Callable | None = None,
    context: dict | None = None,
    **kwargs: Any,
) -> Any:
    """Run ``fn(*args, **kwargs)`` and check its outcome; returns the result or None on error.

    Parameters
    ----------
    fn : callable
        The public function or method under test.
    label : str, optional
        Name for reports and counts (default: the function's qualified name).
    allow : tuple of exception types
        Extra exception types the function documents (e.g. OS errors for ``load``).
    inspector : callable, optional
        ``inspector(result, call, context)`` replacing :func:`inspect_result`.
    context : dict, optional
        Facts for the inspection (e.g. ``{"norm": "group"}``).

    Raises
    ------
    FuzzFailure
        On an outcome that the module docstring does not accept.
    """
    call = Call(label or _label(fn), fn, args, kwargs)
    call.passed = _passed_names(fn, args, kwargs)
    context = dict(context or {})
    with (
        warnings.catch_warnings(record=True) as caught,
        np.errstate(over="warn", invalid="warn", divide="warn"),
    ):
        warnings.simplefilter("always")
        call.warnings = caught  # live: inspectors see the warnings of the call
        try:
            result = fn(*args, **kwargs)
        except BaseException as exc:  # noqa: BLE001 - the oracle judges every exception
            call.warnings = list(caught)
            _check_exception(call, exc, allow)  # the exception first: it is the outcome
            _check_warnings(call)
            OUTCOMES[(call.label, "library error")] += 1
            _log(call, f"{type(exc).__name__}: {str(exc)[:200]}")
            return None
        try:
            outcome = (inspector or inspect_result)(result, call, context)
        except FuzzFailure:
            raise
        except Exception as exc:  # noqa: BLE001 - a returned result must be usable
            raise FuzzFailure(
                call.label,
                f"using the result raised {type(exc).__name__}",
                str(exc)[:150] + _origin(exc),
                call.describe(),
            ) from exc
        finally:
            call.warnings = list(caught)
        _check_warnings(call)
    OUTCOMES[(call.label, outcome or "finite")] += 1
    _log(call, outcome or "finite")
    return result


_LOG = os.environ.get("FUZZ_LOG")
"""A file to append one line per accepted call to (label, call, outcome), for tuning."""


def _log(call: Call, outcome: str) -> None:
    if _LOG:
        with open(_LOG, "a", encoding="utf-8") as fh:
            fh.write(f"{call.label}\t{outcome}\t{call.describe()[:300]}\n")


def _check_warnings(call: Call) -> None:
    for record in call.warnings:
        category = record.category
        if issubclass(category, LIBRARY_WARNINGS):
            continue
        if issubclass(category, DeprecationWarning) and "ltvmodels" in str(record.message):
            continue
        raise FuzzFailure(
            call.label,
            f"foreign warning {category.__name__}",
            f"{record.message} (at {_where(record.filename, record.lineno)})",
            call.describe(),
        )


_SRC_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(ltv.__file__)))


def _where(filename: str, lineno: int) -> str:
    """A short file:line (relative to the package or to site-packages)."""
    if _in_library(filename):
        filename = os.path.relpath(filename, _SRC_ROOT)
    return f"{filename.split('site-packages/')[-1]}:{lineno}"


def _origin(exc: BaseException) -> str:
    """`` (raised at file:line)`` of the innermost frame of an exception."""
    last = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
    return f" (raised at {_where(last[0].filename, last[0].lineno)})" if last else ""


def _in_library(filename: str) -> bool:
    return os.path.abspath(filename).startswith(os.path.dirname(os.path.abspath(ltv.__file__)))


def _raising_frame(exc: BaseException) -> str:
    tb = exc.__traceback__
    last = None
    while tb is not None:
        last = tb
        tb = tb.tb_next
    return "" if last is None else last.tb_frame.f_code.co_filename


def _check_exception(call: Call, exc: BaseException, allow: tuple) -> None:
    message = str(exc)
    origin = _origin(exc)
    if allow and isinstance(exc, allow):
        return
    accepted = isinstance(exc, LIBRARY_ERRORS) or type(exc) in PLAIN_ERRORS
    if not accepted:
        raise FuzzFailure(
            call.label,
            f"foreign exception {type(exc).__name__}",
            message[:150] + origin,
            call.describe(),
        )
    if not message.strip():
        raise FuzzFailure(
            call.label, f"{type(exc).__name__} without a message", origin, call.describe()
        )
    lowered = message.lower()
    # load() wraps what it cannot diagnose in a ModelFileError naming the file (documented)
    foreign = () if isinstance(exc, ltv.ModelFileError) else FOREIGN_MESSAGES
    for fragment in foreign:
        if fragment in lowered:
            raise FuzzFailure(
                call.label,
                f"{type(exc).__name__} with an internal message",
                message[:150] + origin,
                call.describe(),
            )
    if not _in_library(_raising_frame(exc)) and not isinstance(exc, LIBRARY_ERRORS):
        raise FuzzFailure(
            call.label,
            f"{type(exc).__name__} raised outside ltvmodels",
            message[:150] + origin,
            call.describe(),
        )
    lam = call.kwargs.get("lam")
    if isinstance(lam, str) and lam.strip().lower() == "auto" and "lam is too large" in lowered:
        raise FuzzFailure(
            call.label,
            "the λ chosen by lam='auto' is rejected by the fit",
            message[:150],
            call.describe(),
        )
    blamed = re.match(r"^([A-Za-z_][A-Za-z_0-9]*)(\[\d+\])?: ", message)
    if blamed and _parameters(call.fn):
        name = blamed.group(1)
        if name not in _parameters(call.fn) and name not in call.passed:
            raise FuzzFailure(
                call.label,
                "error names an argument the function does not take",
                f"{name!r}: {message[:150]}",
                call.describe(),
            )
        if name not in call.passed and "received None" not in message:
            raise FuzzFailure(
                call.label,
                "error blames an argument the caller did not pass",
                f"{name!r}: {message[:150]}",
                call.describe(),
            )


# ---------------------------------------------------------------------------- inspection

DOCUMENTED_NONE = {
    "cov": "None if not computed (compute_cov=False, sparse norms, piecewise with N <= P)",
    "std()": "None when cov is None",
    "cov_full()": "None when cov is None",
    "loglik": "None where no likelihood exists (sparse norms, posthoc prior, exact fit, given "
    "coefficients), with the reason in info['loglik_note']",
    "noise_var/noise_cov/lam": "None for coefficients given to the constructor (and where an "
    "older model file holds NaN)",
}
"""Attributes that may be None, and when (checked in :func:`inspect_model`)."""

DOCUMENTED_NONFINITE = {
    "lam": "inf for LTI/piecewise/L0 models and entries of coefficients held constant",
    "info.costs_by_n_changes": "inf where no segmentation with that many changes is feasible",
    "KalmanFilterResult.k": "NaN before first_identified",
    "root_spectrogram()": "NaN slots for real poles",
    "simulate()": "inf/NaN after the step a DivergenceWarning names",
    "LambdaSelection.scores": "-inf (lcurve: no bend) or +inf (l0: exact fit), never chosen",
    "LambdaSelection (skipped)": "a candidate whose problem is singular scores worst (-inf "
    "maximized, +inf minimized), its norms and dof NaN",
}
"""Non-finite values the documentation promises."""


def _fail(call: Call, kind: str, detail: str) -> None:
    raise FuzzFailure(call.label, kind, detail, call.describe())


fail_result = _fail
"""Fail a call's outcome from a test-specific inspector."""


def diverged(call: Call) -> bool:
    """Whether the call issued a DivergenceWarning (which documents inf/NaN states)."""
    return any(issubclass(w.category, ltv.DivergenceWarning) for w in call.warnings)


def expect(condition: bool, label: str, kind: str, detail: str) -> None:
    """A property of a result beyond finiteness (a FuzzFailure when it does not hold)."""
    if not condition:
        raise FuzzFailure(label, kind, detail)


def require_finite(call: Call, name: str, value: Any, *, none_ok: bool = False) -> str | None:
    """Fail unless ``value`` is finite (a float, an array, or None when ``none_ok``)."""
    if value is None:
        if none_ok:
            return "None"
        _fail(call, "unexpected None", f"{name} is None")
    arr = np.asarray(value)
    if arr.dtype == object:
        try:
            arr = arr.astype(float)
        except (TypeError, ValueError):
            _fail(call, "non-numeric value", f"{name} = {_short(value)}")
    if arr.dtype.kind in "fc" and not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        first = np.argwhere(~np.isfinite(arr))
        at = "" if arr.ndim == 0 else f" (first at index {tuple(int(i) for i in first[0])})"
        flat = arr.ravel()
        shown = value if arr.ndim == 0 else flat[~np.isfinite(flat)][:3]
        _fail(call, "non-finite value", f"{name} has {bad} NaN/inf entries{at}: {_short(shown)}")
    return None


def _check_text(call: Call, name: str, text: Any) -> None:
    if not isinstance(text, str):
        _fail(call, "non-text", f"{name} returned {type(text).__name__}")
    if re.search(r"\bnan\b", text, flags=re.IGNORECASE):
        _fail(call, "NaN shown in text", f"{name}: {text.splitlines()[0][:160]}")


def _check_info(call: Call, info: Any, prefix: str = "info") -> None:
    if not isinstance(info, dict):
        _fail(call, "info is not a dict", f"{prefix} is {type(info).__name__}")
    for key, value in info.items():
        name = f"{prefix}.{key}"
        if isinstance(value, dict):
            _check_info(call, value, name)
            continue
        if name.endswith("costs_by_n_changes") and value is not None:
            arr = np.asarray(value, dtype=float)
            if np.isnan(arr).any() or (arr < 0).any() or np.isneginf(arr).any():
                _fail(call, "non-finite value", f"{name} = {_short(value)}")
            continue
        if key in ("lam",):
            continue  # λ (possibly inf) is checked with the model's lam
        if isinstance(value, (float, np.floating)) or (
            isinstance(value, np.ndarray) and value.dtype.kind in "fc"
        ):
            require_finite(call, name, value)
        elif (
            isinstance(value, (list, tuple))
            and value
            and all(isinstance(v, (int, float, np.number)) for v in value)
        ):
            require_finite(call, name, np.asarray(value, dtype=float))


def _check_lam(call: Call, lam: Any) -> None:
    """λ: None (given coefficients) or no NaN; a scalar or vector >= 0 (inf documented); a
    (K, K) matrix symmetric."""
    if lam is None:
        return
    arr = np.asarray(lam, dtype=float)
    if np.isnan(arr).any():
        _fail(call, "non-finite value", f"lam = {_short(lam)} holds NaN")
    if arr.ndim <= 1 and (arr < 0).any():
        _fail(call, "invalid value", f"lam = {_short(lam)} is negative")
    if arr.ndim == 2 and not (np.all(np.isfinite(arr)) and np.allclose(arr, arr.T)):
        _fail(call, "invalid value", f"the (K, K) lam = {_short(lam)} is not finite symmetric")


def _fresh(shape: tuple, seed: int = 12345) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal(shape)


def inspect_model(model: Any, call: Call, context: dict) -> str:
    """Check a fitted model's values and use it (module docstring, outcome (a))."""
    outcome = "finite"
    k = np.asarray(model.k)
    if k.ndim != 2:
        _fail(call, "wrong shape", f"k has shape {k.shape}")
    require_finite(call, "k", k)
    require_finite(call, "theta", model.theta)
    # coefficients given to the constructor: nothing estimated; a loaded file: NaN in older
    # files marks a value that was not estimated and reads as None (documented)
    given = model.status is None or bool(context.get("loaded"))
    if require_finite(call, "noise_var", model.noise_var, none_ok=given):
        outcome = "finite+None"
    else:
        nv = np.asarray(model.noise_var, dtype=float)
        if (nv < 0).any():
            _fail(call, "invalid value", f"noise_var = {nv.tolist()} is negative")
    if require_finite(call, "noise_cov", model.noise_cov, none_ok=given):
        outcome = "finite+None"
    sparse = model.norm in ("group", "l1")
    if model.loglik is None:
        # documented: no likelihood for the sparse norms, a posthoc prior, an exact fit, ...
        # with the reason in info["loglik_note"]
        if not (sparse or given or model.info.get("loglik_note")):
            _fail(
                call,
                "unexpected None",
                f"loglik is None for norm={model.norm!r} without info['loglik_note']",
            )
        outcome = "finite+None"
    else:
        require_finite(call, "loglik", model.loglik)
    if model.lam is None:  # documented for given coefficients (and NaN of older files)
        if not given:
            _fail(call, "unexpected None", f"lam is None for norm={model.norm!r}")
        outcome = "finite+None"
    else:
        _check_lam(call, model.lam)
    cov = model.cov
    if cov is None:
        outcome = "finite+None"
        if model.std() is not None or model.cov_full() is not None:
            _fail(call, "inconsistent None", "cov is None but std()/cov_full() is not")
    else:
        require_finite(call, "cov", cov)
        require_finite(call, "std()", model.std())
        require_finite(call, "cov_full()", model.cov_full())
        if (np.asarray(model.std()) < 0).any():
            _fail(call, "invalid value", "std() is negative")
    if model.status is not None:
        require_finite(call, "status.objective", model.status.objective)
        for key, value in model.status.details.items():
            if isinstance(value, (float, np.floating)):
                require_finite(call, f"status.details.{key}", value)
    if not context.get("loaded"):  # a file's info is free-form
        _check_info(call, model.info)
    act = model.activation()
    require_finite(call, "activation()", act)
    cps = np.asarray(model.changepoints)
    if cps.size and (cps.dtype.kind not in "iu" or cps.min() < 1 or cps.max() > model.N - 1):
        _fail(
            call, "invalid value", f"changepoints {cps.tolist()} outside [1, N - 1 = {model.N - 1}]"
        )
    _check_text(call, "repr(model)", repr(model))
    _check_text(call, "model.summary()", model.summary())
    if isinstance(model, ltv.ARXModel):
        _use_arx(model, call, context)
    elif isinstance(model, ltv.LTVModel):
        _use_ltv(model, call, context)
    else:
        pred = model.predict(_fresh((model.N, model.n_regressors)))
        require_finite(call, "predict(fresh phi)", pred)
    return outcome


def _use_ltv(model: Any, call: Call, context: dict) -> None:
    n, m, N = model.n_states, model.n_inputs, model.N
    require_finite(call, "A", model.A)
    require_finite(call, "B", model.B)
    require_finite(call, "c", model.c)
    x = _fresh((N + 1, n))
    u = _fresh((N + 1, m)) if m else None
    scale = float(np.abs(model.k).max(initial=0.0))
    pred = model.predict(x, u)
    if scale < 1e150:
        require_finite(call, "predict(fresh data)", pred)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim = model.simulate(x[0], u)
    diverged = any(issubclass(w.category, ltv.DivergenceWarning) for w in caught)
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if not diverged:
        require_finite(call, "simulate(fresh x0, u)", sim)
    elif np.all(np.isfinite(sim)):
        _fail(call, "spurious DivergenceWarning", "simulate warned but the state is finite")
    context["_diverged"] = diverged


def _use_arx(model: Any, call: Call, context: dict) -> None:
    n, m, L, N = model.n_outputs, model.n_inputs, model.lag, model.N
    y = _fresh((N + L, n))
    y_arg = y[:, 0] if n == 1 else y
    u = _fresh((N + L, m)) if m else None
    pred = model.predict(y_arg, u) if m else model.predict(y_arg)
    require_finite(call, "predict(fresh data)", pred)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if m:
            sim = model.simulate(y_arg[:L], u)
        else:
            sim = model.simulate(y_arg[:L])
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    diverged = any(issubclass(w.category, ltv.DivergenceWarning) for w in caught)
    if not diverged and float(np.abs(model.k).max(initial=0.0)) < 1e10:
        # an AR model of data with huge dynamic range can explode in N steps; then
        # inf without a DivergenceWarning is a silent non-finite result
        require_finite(call, "simulate(fresh y0)", sim)
    elif not diverged and not np.all(np.isfinite(sim)):
        _fail(call, "non-finite value", "ARX simulate() overflowed without a DivergenceWarning")
    context["_diverged"] = diverged
    poles = model.poles()
    require_finite(call, "poles()", poles)
    freq = model.root_spectrogram(1.0)
    if np.isinf(freq).any():
        _fail(call, "non-finite value", "root_spectrogram() holds inf")


def inspect_selection(sel: Any, call: Call, context: dict) -> str:
    require_finite(call, "selection.lam", sel.lam)
    require_finite(call, "selection.lams", sel.lams)
    scores = np.asarray(sel.scores, dtype=float)
    # documented: skipped (singular) candidates score worst and have NaN norms
    skipped = np.isin(
        np.asarray(sel.lams, dtype=float), [lam for lam, _ in (getattr(sel, "skipped", None) or [])]
    )
    worst = -np.inf if sel.maximize else np.inf
    if np.any(scores[skipped] != worst):
        _fail(call, "invalid value", f"skipped candidates score {_short(scores[skipped])}")
    scores = scores[~skipped]
    # documented: -inf where the L-curve does not bend, +inf for counts of changes whose
    # segments fit exactly; never NaN, never the choice
    allowed = {"lcurve": -np.inf, "bic": np.inf, "aic": np.inf}.get(sel.method)
    if allowed is not None:
        if np.isnan(scores).any() or np.any(np.isinf(scores) & (scores != allowed)):
            _fail(call, "non-finite value", f"selection.scores = {_short(scores)}")
        chosen = int(np.argmin(np.abs(np.asarray(sel.lams) - sel.lam)))
        require_finite(call, "selection.scores[choice]", np.asarray(sel.scores)[chosen])
    else:
        require_finite(call, "selection.scores", scores)
    outcome = "finite"
    for name in ("residual_norms", "penalty_norms", "dof"):
        value = getattr(sel, name)
        value = None if value is None else np.asarray(value)[~skipped]
        if require_finite(call, f"selection.{name}", value, none_ok=True):
            outcome = "finite+None"
    if sel.norm != "l0" and not sel.lam > 0:
        _fail(call, "invalid value", f"selection.lam = {sel.lam} is not > 0")
    return outcome


def inspect_segmentation(seg: Any, call: Call, context: dict) -> str:
    require_finite(call, "segmentation.cost", seg.cost)
    require_finite(call, "segmentation.objective", seg.objective)
    outcome = "finite"
    if seg.costs_by_n_changes is None:
        outcome = "finite+None"
    else:
        arr = np.asarray(seg.costs_by_n_changes, dtype=float)
        # a residual sum of squares is >= 0; the Gaussian cost (−2 log L) may be negative
        negative = (arr < 0).any() and getattr(seg, "cost_name", "rss") == "rss"
        if np.isnan(arr).any() or negative:
            _fail(call, "non-finite value", f"costs_by_n_changes = {arr.tolist()}")
    for name in ("penalty", "noise_var"):
        if require_finite(call, f"segmentation.{name}", getattr(seg, name), none_ok=True):
            outcome = "finite+None"
    return outcome


def inspect_kalman(res: Any, call: Call, context: dict) -> str:
    filt = getattr(res, "filtered", res)
    first = int(filt.first_identified)
    N = filt.k.shape[0]
    if res is filt:
        require_finite(call, "filter k[first_identified:]", res.k[first:])
        require_finite(call, "filter cov[first_identified:]", res.cov[first:])
        if first < N:
            require_finite(call, "filter loglik", res.loglik)
    else:
        require_finite(call, "smoother k", res.k)
        require_finite(call, "smoother cov", res.cov)
        require_finite(call, "smoother loglik", res.loglik)
        require_finite(call, "smoother A", res.A)
    return "finite"


def inspect_result(result: Any, call: Call, context: dict) -> str:
    """Dispatch on the type of a result (outcome (a) of the module docstring)."""
    if isinstance(result, ltv.RegressionModel):
        return inspect_model(result, call, context)
    if isinstance(result, ltv.LambdaSelection):
        return inspect_selection(result, call, context)
    if isinstance(result, ltv.Segmentation):
        return inspect_segmentation(result, call, context)
    if isinstance(result, (ltv.KalmanFilterResult, ltv.KalmanSmootherResult)):
        return inspect_kalman(result, call, context)
    if isinstance(result, (ltv.Prior, ltv.OutputPrior)):
        require_finite(call, "prior.mean", result.mean)
        require_finite(call, "prior.cov", result.cov)
        return "finite"
    if isinstance(result, list):
        outcomes = [inspect_result(item, call, context) for item in result]
        return "finite+None" if "finite+None" in outcomes else "finite"
    if isinstance(result, tuple):
        for i, item in enumerate(result):
            require_finite(call, f"result[{i}]", item)
        return "finite"
    if result is None:
        if context.get("none_ok"):
            return "finite+None"
        _fail(call, "unexpected None", "returned None")
    if isinstance(result, (int, float, np.number, np.ndarray)):
        require_finite(call, "result", result)
        return "finite"
    return "finite"


# ---------------------------------------------------------------------------- survey support


def run_example(test_name: str, body: Callable[[], None]) -> None:
    """Run one example body; in survey mode record a failure instead of raising it."""
    EXAMPLES[test_name] += 1
    if not SURVEY:
        body()
        return
    drawn = ", ".join(repr(a) for a in getattr(body, "args", ())) + "".join(
        f", {k}={v!r}" for k, v in getattr(body, "keywords", {}).items()
    )
    try:
        body()
    except FuzzFailure as failure:
        SURVEY_FAILURES[test_name].setdefault(
            failure.signature, f"{failure}\n    drawn: {drawn[:600]}"
        )
    except Exception as exc:  # noqa: BLE001 - e.g. a test's own assertion
        signature = (test_name, type(exc).__name__, _normalize(str(exc)))
        SURVEY_FAILURES[test_name].setdefault(
            signature,
            f"[{test_name}] {type(exc).__name__}: {str(exc)[:300]}{_origin(exc)}"
            f"\n    drawn: {drawn[:600]}",
        )


def survey_verdict(test_name: str) -> None:
    """In survey mode, fail the test once with every distinct failure it met."""
    found = SURVEY_FAILURES.get(test_name)
    if found:
        raise AssertionError(f"{len(found)} distinct failures:\n\n" + "\n\n".join(found.values()))


def strict_json(text: str) -> Any:
    """Parse JSON that must not contain NaN or Infinity."""

    def reject(token: str) -> None:
        raise ValueError(f"non-finite JSON constant {token}")

    return json.loads(text, parse_constant=reject)


def tmpdir() -> tempfile.TemporaryDirectory:
    return tempfile.TemporaryDirectory(prefix="ltvfuzz-")


__all__ = [
    "EXAMPLES",
    "OUTCOMES",
    "SURVEY",
    "SURVEY_FAILURES",
    "FuzzFailure",
    "check_call",
    "diverged",
    "expect",
    "fail_result",
    "inspect_kalman",
    "inspect_model",
    "inspect_result",
    "inspect_segmentation",
    "inspect_selection",
    "require_finite",
    "run_example",
    "strict_json",
    "survey_verdict",
    "tmpdir",
]
