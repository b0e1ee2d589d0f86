"""Checks of options: scalars, choices, counts, λ, the difference operator, seeds.

Each check raises :class:`ValueError` or :class:`TypeError` with a message that
names the argument, what was expected and what was received. Array inputs are
checked in :mod:`ltvmodels.validation.arrays`.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from numbers import Integral, Real
from typing import Any, Literal, TypeVar, cast, get_args

import numpy as np

from .arrays import as_float_array, describe

__all__ = [
    "Norm",
    "SparseNorm",
    "SelectionNorm",
    "SelectionMethod",
    "Loss",
    "PriorMode",
    "PenaltyRule",
    "SegmentCriterion",
    "SegmentCost",
    "ManyMethod",
    "NORMS",
    "SPARSE_NORMS",
    "PRIOR_MODES",
    "choice",
    "interval_level",
    "trimmed_min_size",
    "trim_fraction",
    "break_test_kind",
    "BREAK_TEST_KINDS",
    "significance_level",
    "flag",
    "callback",
    "is_auto",
    "integer",
    "optional_integer",
    "nonnegative_scalar",
    "positive_scalar",
    "noise_variance",
    "measurement_noise",
    "MEASUREMENT_LOSSES",
    "MeasurementLoss",
    "measurement_loss_needs_noise",
    "variance",
    "optional_nonnegative",
    "fraction",
    "norm_name",
    "LOSSES",
    "loss_options",
    "huber_delta",
    "threshold_of",
    "penalty_weight",
    "sparse_weights",
    "scalar_lam",
    "difference_coefficients",
    "piecewise_order",
    "lag_orders",
    "enough_samples",
    "enough_rows",
    "segment_cost",
    "smallest_segment",
    "segment_min_size",
    "segmentable_length",
    "n_changes_count",
    "segment_penalty",
    "segment_mode",
    "segment_criterion",
    "SEGMENT_CRITERIA",
    "fixed_columns",
    "random_generator",
]

# The option strings of the public functions, as types for their signatures. The
# checks accept exactly these values (the tuples NORMS, SPARSE_NORMS, LOSSES, … are
# derived from them).
Norm = Literal["sq", "group", "l1"]
"""The penalty norm of a fit: squared 2-norm, group (2-)norm or l1 norm."""
SparseNorm = Literal["group", "l1"]
"""The norms with a λ_max (:func:`ltvmodels.lambda_max`)."""
SelectionNorm = Literal["sq", "group", "l1", "l0"]
"""The norms :func:`ltvmodels.select_lambda` chooses for ("l0": the number of changes)."""
SelectionMethod = Literal["ml", "gcv", "lcurve", "cv", "bic", "aic"]
"""The criteria of :func:`ltvmodels.select_lambda` (which apply depends on the norm)."""
Loss = Literal["squared", "huber", "laplace"]
"""The loss on the residuals."""
PriorMode = Literal["exact", "posthoc"]
"""How a prior enters a fit with the squared norm."""
PenaltyRule = Literal["bic", "aic"]
"""The rules for the penalty per change of a segmentation."""
SegmentCriterion = Literal["bic", "aic", "lwz"]
"""The criteria that choose a segmentation's number of changes among 0 … n_changes."""
SegmentCost = Literal["rss", "normal"]
"""The cost of a segment: its residual sum of squares, or its Gaussian −2 log-likelihood
with its own noise variance."""
ManyMethod = Literal["fit", "segments", "lti"]
"""The estimators :func:`ltvmodels.fit_many` runs by name."""

NORMS: tuple[Norm, ...] = get_args(Norm)
SPARSE_NORMS: tuple[SparseNorm, ...] = get_args(SparseNorm)
PENALTY_RULES: tuple[PenaltyRule, ...] = get_args(PenaltyRule)
SEGMENT_CRITERIA: tuple[SegmentCriterion, ...] = get_args(SegmentCriterion)
SEGMENT_COSTS: tuple[SegmentCost, ...] = get_args(SegmentCost)
PRIOR_MODES: tuple[PriorMode, ...] = get_args(PriorMode)


_Option = TypeVar("_Option", bound=str)


def choice(value: Any, name: str, options: Sequence[_Option]) -> _Option:
    """Validate that ``value`` is one of the string ``options`` (and type it as one)."""
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name}: expected one of {tuple(options)}, received {describe(value)}")
    return cast(_Option, value)  # one of the options


def flag(value: Any, name: str) -> bool:
    """Validate True or False (no other truthy values)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, received {describe(value)}")
    return bool(value)


def callback(value: Any, name: str) -> Any:
    """Validate a function or None (e.g. ``progress(done, total)``)."""
    if value is not None and not callable(value):
        raise TypeError(
            f"{name}: expected a function {name}(done, total) or None, received {describe(value)}"
        )
    return value


def is_auto(value: Any, name: str) -> bool:
    """True for the string "auto"; any other string is a TypeError naming the argument."""
    if isinstance(value, str):
        if value != "auto":
            raise TypeError(f"{name}: expected a number, an array or 'auto', received {value!r}")
        return True
    return False


def integer(value: Any, name: str, minimum: int) -> int:
    """Validate an integer >= ``minimum`` (bools are rejected)."""
    if type(value) is int and value >= minimum:  # the common case, without the ABC checks
        return value
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, received {describe(value)}")
    return int(value)


def optional_integer(value: Any, name: str, minimum: int) -> int | None:
    """Validate None or an integer >= ``minimum``."""
    return None if value is None else integer(value, name, minimum)


def nonnegative_scalar(value: Any, name: str, *, allow_inf: bool = False) -> float:
    """Validate a real scalar >= 0 (0-d numpy arrays are accepted)."""
    if type(value) is float and 0.0 <= value < np.inf:  # the common case, without ABC checks
        return value
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
        raise TypeError(f"{name}: expected a real number >= 0, received {describe(value)}")
    v = float(value)
    if np.isnan(v) or v < 0 or (np.isinf(v) and not allow_inf):
        raise ValueError(f"{name}: expected a finite real number >= 0, received {v}")
    return v


def positive_scalar(value: Any, name: str) -> float:
    """Validate a finite real scalar > 0."""
    try:
        v = nonnegative_scalar(value, name)
    except ValueError:  # NaN, negative or infinite: say "> 0", not ">= 0"
        raise ValueError(
            f"{name}: expected a finite real number > 0, received {float(value)}"
        ) from None
    if v == 0:
        raise ValueError(f"{name}: expected a real number > 0, received 0")
    return v


def noise_variance(value: Any, n: int) -> float | np.ndarray | None:
    """Validate None, a variance > 0 shared by n outputs, or an (n,) vector of them."""
    if value is None:
        return None
    if np.ndim(value) == 0 or (n != 1 and np.size(value) == 1):
        return variance(value if np.ndim(value) == 0 else np.ravel(value)[0], "noise_var")
    arr = np.asarray(value, dtype=float) if not isinstance(value, str) else None
    if arr is None or arr.shape != (n,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(
            f"noise_var: expected a variance > 0 or one per output (shape ({n},)), received "
            f"{value!r}"
        )
    for v in arr:
        variance(v, "noise_var")
    return arr.copy()


MeasurementLoss = Literal["squared", "huber", "student"]
MEASUREMENT_LOSSES: tuple[MeasurementLoss, ...] = ("squared", "huber", "student")
"""The losses of the measurement model (``measurement_loss``, see
:mod:`ltvmodels.core.measurement_weights`)."""


def measurement_loss_needs_noise(loss: str, noise: Any) -> None:
    """A robust ``measurement_loss`` (validated) needs the measurement model."""
    if loss != "squared" and noise is None:
        raise ValueError(
            f"measurement_loss: {loss!r} is a loss of the measurement model, which "
            "measurement_noise=None (exact recorded states) does not have; received "
            f"measurement_loss={loss!r} with measurement_noise=None; pass "
            "measurement_noise='estimate' (or a variance), or use loss='huber' for "
            "outliers in the state equation's residuals"
        )


def measurement_noise(value: Any, n: int) -> np.ndarray | str | None:
    """Validate ``measurement_noise``: None (exact states), "estimate", or a variance > 0
    of the measurement noise shared by the n states or one per state (returned as (n,))."""
    if value is None:
        return None
    if isinstance(value, str):
        if value == "estimate":
            return value
        raise ValueError(
            f"measurement_noise: expected None, 'estimate' or a variance > 0 (one number or "
            f"one per state, shape ({n},)), received {value!r}; pass 'estimate' to estimate it"
        )
    if isinstance(value, bool):
        raise TypeError(
            f"measurement_noise: expected None, 'estimate' or a variance > 0, received {value!r}"
        )
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            "measurement_noise: expected None, 'estimate' or a variance > 0 (one number or one "
            f"per state, shape ({n},)), received {value!r}"
        ) from None
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(
            f"measurement_noise: expected one variance or one per state (shape ({n},)), "
            f"received shape {arr.shape}; pass a number or {n} numbers"
        )
    for v in arr:
        variance(v, "measurement_noise")
    return arr.copy()


def variance(value: Any, name: str) -> float:
    """Validate a variance: a number between 1e-100 and 1e100 (products of two are formed)."""
    v = positive_scalar(value, name)
    if not 1e-100 <= v <= 1e100:
        raise ValueError(
            f"{name}: expected a variance between 1e-100 and 1e100, received {v:g}; rescale "
            "the data so that the noise is of a representable size"
        )
    return v


def optional_nonnegative(value: Any, name: str) -> float | None:
    """Validate None or a finite real number >= 0."""
    return None if value is None else nonnegative_scalar(value, name)


def interval_level(value: Any, name: str) -> float:
    """The probability of a central interval: a real number in (0, 1) with both tails
    representable."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}: expected a probability in (0, 1), received {describe(value)}")
    value = float(value)
    if not 0.0 < value < 1.0:
        raise ValueError(f"{name}: expected a probability in (0, 1) (e.g. 0.95), received {value}")
    if (1.0 + value) / 2.0 >= 1.0:  # no tail left in floating point: no interval bound
        raise ValueError(
            f"{name}: expected a probability in (0, 1) whose tails are representable (at most "
            f"1 - 1e-15), received {value!r}"
        )
    return value


def fraction(value: Any, name: str) -> float:
    """Validate a real number in [0, 1]."""
    v = nonnegative_scalar(value, name)
    if v > 1:
        raise ValueError(f"{name}: expected a number in [0, 1], received {v}")
    return v


def norm_name(norm: Any) -> Norm:
    """Validate the regularization norm name."""
    if not isinstance(norm, str) or norm not in NORMS:
        raise ValueError(f"norm: expected one of {NORMS}, received {describe(norm)}")
    return norm


LOSSES: tuple[Loss, ...] = get_args(Loss)


def loss_options(loss: Any, delta: Any, n: int) -> tuple[Loss, np.ndarray | None]:
    """Validate ``loss`` ("squared", "huber" or "laplace") and ``huber_delta`` together:
    (loss, δ (n,) or None)."""
    loss = choice(loss, "loss", LOSSES)
    return loss, threshold_of(loss, loss == "huber", delta, n)


def threshold_of(loss: str, takes_threshold: bool, delta: Any, n: int) -> np.ndarray | None:
    """Validate ``huber_delta`` for ``loss``, which takes a threshold or not."""
    delta = huber_delta(delta, n)
    if not takes_threshold and delta is not None:
        raise ValueError(
            f"huber_delta: applies to loss='huber' only, received loss={loss!r}; "
            "pass loss='huber' or leave huber_delta out"
        )
    return delta


def huber_delta(value: Any, n: int) -> np.ndarray | None:
    """Validate None (the default rule), a threshold δ > 0, or one per output (n,)."""
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=float) if not isinstance(value, (str, bytes, bool)) else None
    except (TypeError, ValueError):  # not numbers: a dict, a ragged list, …
        arr = None
    if (
        arr is None
        or arr.shape not in ((), (n,))
        or not np.all(np.isfinite(arr))
        or np.any(arr <= 0)
    ):
        raise ValueError(
            f"huber_delta: expected a threshold > 0 or one per output (shape ({n},)), in the "
            f"units of the outputs, received {describe(value)}; pass numbers, or leave it out "
            "for the default (1.345 × the robust scale of the residuals)"
        )
    if np.any(arr > 1e100) or np.any(arr < 1e-100):
        raise ValueError(
            f"huber_delta: expected thresholds between 1e-100 and 1e100, received {describe(value)}"
        )
    return np.broadcast_to(arr, (n,)).copy()


# The largest finite λ whose square (the weight of the squared norm) is finite.
LARGEST_SQUARED_LAM = float(np.sqrt(np.finfo(float).max))


def _square_fits(values: np.ndarray) -> None:
    """Reject finite λ whose square overflows: it would silently act like inf."""
    big = np.isfinite(values) & (values > LARGEST_SQUARED_LAM)
    if big.any():
        raise ValueError(
            f"lam: expected a finite λ below {LARGEST_SQUARED_LAM:.3g} (its square weighs the "
            f"penalty), received {values[big][0]:g}; for coefficients constant in time pass "
            "lam=np.inf (an exact LTI fit)"
        )


def penalty_weight(lam: Any, K: int) -> np.ndarray:
    """Turn ``lam`` into the penalty weight W of sum_t (Dk)_t' W (Dk)_t.

    * scalar λ >= 0:   W = λ² I, returned as its diagonal, shape (K,);
    * vector (K,):     W = diag(λ_j²), returned as its diagonal, shape (K,);
      ``inf`` marks a coefficient constant in time, 0 a coefficient free to
      change arbitrarily;
    * matrix (K, K):   W = Λ, symmetric positive semidefinite (used as is, so
      λ² I is equivalent to the scalar λ), shape (K, K).

    A diagonal W stays a vector so that wide models (K = n·p in the tens of
    thousands) never form a K x K array. Infinite diagonal entries mark
    constant coefficients.
    """
    if type(lam) in (float, int, np.float64) and 0 <= lam <= LARGEST_SQUARED_LAM:
        return np.full(K, float(lam) * float(lam))  # a plain scalar λ: λ² I, at once
    arr = _lam_array(lam, K)
    if arr.ndim < 2:
        _square_fits(arr)
        return np.broadcast_to(arr**2, (K,)).copy()
    if not np.all(np.isfinite(arr)):
        raise ValueError(
            "lam: a weight matrix must be finite (use a vector with inf "
            "entries to hold coefficients constant)"
        )
    if not np.allclose(arr, arr.T, rtol=1e-10, atol=1e-12 * np.abs(arr).max()):
        raise ValueError("lam: expected a symmetric weight matrix, received a non-symmetric one")
    eig_min = np.linalg.eigvalsh(arr).min()
    if eig_min < -1e-10 * max(np.abs(arr).max(), 1e-300):
        raise ValueError(
            f"lam: expected a positive semidefinite weight matrix, received one with "
            f"eigenvalue {eig_min:g}"
        )
    return 0.5 * (arr + arr.T)


def _lam_array(lam: Any, K: int) -> np.ndarray:
    """``lam`` as a float array: a scalar (shape ()), a (K,) vector >= 0, or a (K, K) matrix.

    Checks type, NaN, shape and signs; what each norm allows beyond that is
    checked by :func:`penalty_weight` and :func:`sparse_weights`.
    """
    expected = (
        f"lam: expected a number >= 0, a (K,) vector or a (K, K) matrix of real "
        f"numbers (K={K}), received {describe(lam)}"
    )
    if lam is None or isinstance(lam, (str, bytes, bool)):
        raise TypeError(expected)
    if isinstance(lam, np.ma.MaskedArray) and np.ma.getmaskarray(lam).any():
        raise ValueError(
            "lam: received a masked array with masked entries; pass the weights to use "
            "(a plain array, inf for a coefficient constant in time)"
        )
    try:
        arr = np.array(lam.to_numpy() if hasattr(lam, "to_numpy") else lam, dtype=float)
    except (TypeError, ValueError) as exc:  # text, objects, ragged nested lists
        raise TypeError(expected) from exc
    if arr.ndim == 0:
        return np.asarray(nonnegative_scalar(float(arr), "lam", allow_inf=True))
    if np.isnan(arr).any():
        raise ValueError("lam: expected numbers, received NaN")
    if arr.ndim == 1:
        if arr.shape != (K,):
            raise ValueError(
                f"lam: expected a vector of length K={K} (one weight per parameter), "
                f"received shape {arr.shape}"
            )
        if (arr < 0).any():
            raise ValueError(f"lam: expected entries >= 0, received min {arr.min()}")
        return arr
    if arr.ndim == 2:
        if arr.shape != (K, K):
            raise ValueError(f"lam: expected a ({K}, {K}) matrix, received shape {arr.shape}")
        return arr
    raise ValueError(
        f"lam: expected a scalar, a (K,) vector or a (K, K) matrix (K={K}), "
        f"received shape {arr.shape}"
    )


def sparse_weights(lam: Any, K: int) -> np.ndarray:
    """λ for norm="group"/"l1": a scalar > 0 or a (K,) vector of weights >= 0 (inf: constant).

    Returns the (K,) weight vector Λ of the penalty Σ_t R(Λ (Dk)_t). λ is not
    squared here, so any finite scalar is allowed; a vector's finite entries
    must stay below 1.34e154 (inf holds a coefficient constant).
    """
    arr = _lam_array(lam, K)
    if arr.ndim == 2:
        raise ValueError(
            "lam: a (K, K) weight matrix applies to norm='sq' only; use a scalar or a "
            f"(K,) vector with norm='group' or 'l1', received shape {arr.shape}"
        )
    if arr.ndim == 1:  # a scalar is scale-free (λ >= λ_max is the constant fit); a vector is not
        _square_fits(arr)
    weights = np.broadcast_to(arr, (K,)).copy()
    if not np.any(weights > 0):
        raise ValueError(
            "lam: expected lam > 0 with norm='group' or 'l1': with lam = 0 every time step "
            "has its own unregularized model and the problem is ill-posed (paper Section V)"
        )
    return weights


def scalar_lam(lam: Any) -> float:
    """Validate a scalar regularization weight 0 < λ < inf for the Kalman form.

    The Kalman filter realizes the isotropic penalty λ² Σ_t ‖(Dk)_t‖² only;
    vector and matrix weights are handled by :func:`ltvmodels.fit`.
    """
    if np.ndim(lam) != 0 or isinstance(lam, (str, bytes)):
        raise TypeError(
            "lam: the Kalman filter/smoother supports a scalar λ > 0 only (use "
            f"ltvmodels.fit for vector or matrix weights), received {describe(lam)}"
        )
    return positive_scalar(lam.item() if hasattr(lam, "item") else lam, "lam")


@lru_cache(maxsize=16)
def _difference_of_degree(d: int) -> np.ndarray:
    """(c_0, …, c_d) of the d-th difference, kept: small fits ask for it every time."""
    coeffs = np.array([1.0])
    for _ in range(d):
        coeffs = np.convolve(coeffs, [-1.0, 1.0])
    return coeffs


def difference_coefficients(order: Any, max_degree: int | None = None) -> np.ndarray:
    """Return the coefficients (c_0, ..., c_d) of the difference operator.

    ``order`` is an integer d >= 1, giving the d-th difference
    (Dk)_t = sum_j (-1)^(d-j) binom(d, j) k_{t+j}, or a sequence of polynomial
    coefficients c_0..c_d with (Dk)_t = sum_j c_j k_{t+j}; the coefficients must
    sum to zero (paper Proposition 1) and c_d must be nonzero. ``max_degree``
    (the largest degree the data can support, if given) rejects a huge integer
    order before its coefficients are built.
    """
    if isinstance(order, bool):
        raise TypeError(
            f"order: expected an integer >= 1 or a sequence of coefficients, "
            f"received {describe(order)}"
        )
    if isinstance(order, Integral):
        d = int(order)
        if d < 1:
            raise ValueError(f"order: expected an integer >= 1, received {d}")
        if max_degree is not None and d > max_degree:
            raise ValueError(
                f"order: expected a degree of at most {max_degree} (a difference of degree "
                f"d needs more than d + 1 samples), received {d}"
            )
        return _difference_of_degree(d).copy()  # a copy: the caller may modify it
    if isinstance(order, Real):
        raise TypeError(
            f"order: expected an integer >= 1 or a sequence of coefficients, "
            f"received {describe(order)}"
        )
    coeffs = as_float_array(order, "order")
    if coeffs.ndim != 1 or coeffs.size < 2:
        raise ValueError(
            "order: expected an integer >= 1 or a 1-d sequence of at least 2 polynomial "
            f"coefficients, received shape {coeffs.shape}"
        )
    if coeffs[-1] == 0 or coeffs[0] == 0:
        raise ValueError(
            "order: the first and last polynomial coefficients must be nonzero "
            f"(trim them to lower the degree), received {coeffs.tolist()}"
        )
    scale = np.abs(coeffs).sum()
    if not 1e-50 <= np.abs(coeffs).max() <= 1e50:
        raise ValueError(
            "order: expected polynomial coefficients of magnitude between 1e-50 and 1e50 "
            f"(their squares weigh the penalty), received {coeffs.tolist()}; divide them by a "
            "common factor (only their ratios and λ matter)"
        )
    if abs(coeffs.sum()) > 1e-10 * scale:
        raise ValueError(
            "order: polynomial coefficients must sum to zero so that constant "
            f"coefficients are not penalized (P(1) = 0), received {coeffs.tolist()} "
            f"with sum {coeffs.sum():g}"
        )
    return coeffs


def piecewise_order(order: Any) -> int:
    """Validate the order of a piecewise refit: 1 (constant) or 2 (linear, continuous)."""
    expected = "1 (piecewise constant) or 2 (piecewise linear, continuous)"
    if isinstance(order, bool) or not isinstance(order, Integral):
        raise TypeError(f"order: expected {expected}, received {describe(order)}")
    degree = int(order)
    if degree < 1:
        raise ValueError(f"order: expected {expected}, received {degree}")
    if degree > 2:
        raise NotImplementedError(
            f"order={degree}: piecewise polynomials of degree >= 2 are not implemented; "
            f"use order=1 or order=2"
        )
    return degree


def lag_orders(na: Any, nb: Any, nk: Any, *, min_na: int, min_nb: int) -> tuple[int, int, int]:
    """Validate the AR/ARX orders: integers na >= ``min_na``, nb >= ``min_nb``, nk >= 0."""
    na = integer(na, "na", minimum=min_na)
    nb = integer(nb, "nb", minimum=min_nb)
    nk = integer(nk, "nk", minimum=0)
    return na, nb, nk


def enough_samples(
    N: int,
    n_params_per_row: int,
    n_diff: int,
    observed: int | None = None,
    n_rows: int | None = None,
) -> None:
    """Require enough time steps and observed transitions to identify the parameters.

    With a difference operator of degree d the penalty leaves a d-dimensional
    family of trajectories per parameter unpenalized, so at least d·p observed
    regression equations per output row are needed, and N > d time steps.
    ``observed`` of ``n_rows`` transitions (all trajectories) are complete
    (default: all N).
    """
    _enough(
        N,
        n_params_per_row,
        n_diff,
        observed,
        n_rows,
        "x",
        "transitions",
        f" (T={N + 1})",
        "T >= {}",
        1,
    )


def enough_rows(
    N: int,
    n_params_per_row: int,
    n_diff: int,
    name: str,
    note: str = "",
    observed: int | None = None,
    n_rows: int | None = None,
) -> None:
    """Require enough regression rows to identify p regressors per output row.

    As :func:`enough_samples` for a regression with N rows (``name`` is the
    data argument; ``note`` says how the rows relate to the series, e.g. for AR).
    """
    _enough(N, n_params_per_row, n_diff, observed, n_rows, name, "regression rows", note, "", 0)


def _enough(N, p, d, observed, n_rows, name, rows, note, total_hint, offset) -> None:
    needed = max(p * d, d + 1)
    observed = N if observed is None else observed
    n_rows = N if n_rows is None else n_rows
    hint = f" ({total_hint.format(needed + offset)})" if total_hint else ""
    if N < d + 1 or (observed == n_rows and observed < needed):
        raise ValueError(
            f"{name}: too few samples: {N} {rows}{note} cannot identify {p} regressors per "
            f"output with a difference operator of degree {d}; need at least {needed} "
            f"{rows}{hint}"
        )
    if observed < needed:
        raise ValueError(
            f"{name}: too few observed samples: {observed} of {n_rows} {rows} are complete "
            f"(the others have a missing value), and {p} regressors per output with a "
            f"difference operator of degree {d} need at least {needed}; supply more data "
            "or fill the gaps"
        )


def trimmed_min_size(trim: Any, min_size: Any, N: int, p: int) -> Any:
    """``min_size`` as given, or ⌊trim · N⌋ (at least ``p``, the smallest segment
    allowed: :func:`smallest_segment`) for a trimming fraction ``trim`` in (0, 0.5)
    (strucchange's ``h``); both given is an error."""
    if trim is None:
        return min_size
    if min_size is not None:
        raise ValueError(
            "trim, min_size: both give the minimum segment length (trim as a fraction of "
            f"the rows, min_size as a count); give one, received trim={trim!r} and "
            f"min_size={min_size!r}"
        )
    return max(p, int(np.floor(trim_fraction(trim) * N)))


def segment_cost(value: Any) -> SegmentCost:
    """The cost of a segment: "rss" or "normal"."""
    if not isinstance(value, str) or value not in SEGMENT_COSTS:
        raise ValueError(
            f"cost: expected one of {SEGMENT_COSTS} ('rss': the residual sum of squares; "
            "'normal': the Gaussian likelihood with a noise variance per segment, which also "
            f"sees changes of the noise level), received {describe(value)}; use one of them"
        )
    return value  # one of the options


def smallest_segment(p: int, cost: SegmentCost) -> int:
    """The smallest ``min_size`` a cost allows: p for "rss" (least squares is well
    posed), p + 1 for "normal" (a segment of p rows fits exactly: its noise variance is
    zero)."""
    return p if cost == "rss" else p + 1


def segment_min_size(value: Any, p: int, cost: SegmentCost = "rss") -> int:
    """Minimum segment length: None (→ the default of the cost) or an integer >= the
    smallest the cost allows (:func:`smallest_segment`).

    A segment with fewer samples than the p regressors of each output row has
    no unique least-squares fit; one of exactly p rows has a zero residual, so no
    noise variance. The default is p for "rss" and max(2p, p + 5) for "normal":
    each segment's variance then rests on at least max(p, 5) residual degrees of
    freedom, so that a short segment's chance small residual (log σ̂² has a long
    lower tail with few degrees of freedom) does not pass for a change of the noise
    level.
    """
    bound = f"p = {p}" if cost == "rss" else f"p + 1 = {p + 1}"
    if value is None:
        return p if cost == "rss" else max(2 * p, p + 5)
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise TypeError(
            f"min_size: expected None or an integer >= {bound}, received {describe(value)}"
        )
    if value < smallest_segment(p, cost):
        if cost == "rss":
            raise ValueError(
                f"min_size: expected an integer >= p = {p} (a segment needs at least as many "
                f"samples as regressors for its least squares to be well posed), received "
                f"{int(value)}"
            )
        raise ValueError(
            f"min_size: expected an integer >= p + 1 = {p + 1} with cost='normal' (a segment "
            f"of p samples fits exactly, so it has no noise variance), received {int(value)}; "
            "give a larger min_size, or leave it out for the default max(2p, p + 5)"
        )
    return int(value)


def segmentable_length(N: int, min_size: int, data_name: str) -> None:
    """Require at least one segment of ``min_size`` samples."""
    if N < min_size:
        extra = " (T = N + 1)" if data_name == "x" else ""
        raise ValueError(
            f"{data_name}: too few samples: {N} regression rows{extra} cannot hold a single "
            f"segment of min_size = {min_size} samples"
        )


def n_changes_count(value: Any, N: int, min_size: int) -> int:
    """Number of changes M: an integer >= 0 with (M + 1) · min_size <= N."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise TypeError(f"n_changes: expected an integer >= 0, received {describe(value)}")
    if value < 0:
        raise ValueError(f"n_changes: expected an integer >= 0, received {int(value)}")
    M = int(value)
    if (M + 1) * min_size > N:
        raise ValueError(
            f"n_changes: {M} changes make {M + 1} segments of at least min_size = {min_size} "
            f"samples, i.e. at least {(M + 1) * min_size} regression rows, but the data have "
            f"N = {N}; use n_changes <= {N // min_size - 1} or a smaller min_size"
        )
    return M


def segment_penalty(value: Any) -> float | PenaltyRule:
    """Penalty per change: a finite real number >= 0, or one of the rules 'bic', 'aic'."""
    if isinstance(value, str):
        if value not in PENALTY_RULES:
            raise ValueError(
                f"penalty: expected a number >= 0 or one of {PENALTY_RULES}, received "
                f"{describe(value)}"
            )
        return value
    if isinstance(value, bool) or np.ndim(value) != 0:
        raise TypeError(
            f"penalty: expected a number >= 0 or one of {PENALTY_RULES}, received {describe(value)}"
        )
    return nonnegative_scalar(value.item() if hasattr(value, "item") else value, "penalty")


def segment_criterion(n_changes: Any, penalty: Any, cost: str) -> str | None:
    """The criterion that chooses the number of changes among 0 … ``n_changes``: a
    rule name given as ``penalty`` together with ``n_changes`` (None otherwise).

    "lwz" ranks the optimal segmentations of each number of changes, so it needs
    ``n_changes``; it assumes one noise variance, so not with ``cost="normal"``.
    """
    if not isinstance(penalty, str):
        return None
    if penalty == "lwz" and n_changes is None:
        raise ValueError(
            "penalty: 'lwz' ranks the optimal segmentations with 0 … M changes, so it needs "
            "n_changes=M (the most changes to consider); received n_changes=None"
        )
    if n_changes is None:
        return None  # a PELT rule, checked by segment_penalty
    if penalty not in SEGMENT_CRITERIA:
        raise ValueError(
            f"penalty: with n_changes, expected a criterion that chooses the number of "
            f"changes, one of {SEGMENT_CRITERIA}, received {penalty!r}"
        )
    if penalty == "lwz" and cost == "normal":
        raise ValueError(
            "penalty: 'lwz' assumes one noise variance for all segments, and cost='normal' "
            "gives each its own; use penalty='bic' or 'aic' with cost='normal'"
        )
    return penalty


def segment_mode(n_changes: Any, penalty: Any) -> None:
    """n_changes and a penalty β are alternatives: at most one may be given (a criterion
    with n_changes is :func:`segment_criterion`'s)."""
    if n_changes is not None and penalty is not None:
        raise TypeError(
            "n_changes, penalty: expected one of them (n_changes=M for exactly M changes, "
            f"penalty=β for a cost of β per change, or n_changes=M with a criterion "
            f"{SEGMENT_CRITERIA} that chooses among 0 … M), received both "
            f"(n_changes={n_changes!r}, penalty={penalty!r})"
        )


def random_generator(seed: Any) -> np.random.Generator:
    """A numpy Generator from a seed: an integer >= 0, a Generator (used as is) or None."""
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None:
        return np.random.default_rng()
    if isinstance(seed, Integral) and not isinstance(seed, bool) and int(seed) >= 0:
        return np.random.default_rng(int(seed))
    raise TypeError(
        f"seed: expected a non-negative integer, a numpy Generator or None, received {seed!r}"
    )


def fixed_columns(value: Any, names: Sequence[str], remedy_names: str) -> tuple[int, ...]:
    """The regressor columns whose coefficients are common to all segments (``fixed=``).

    ``value`` is None, one column or a sequence of columns, each an integer index
    (negative counts from the end, as in numpy) or a regressor name from ``names``
    (the p regressor names; ``remedy_names`` says where they come from). Returns the
    sorted nonnegative indices, empty for None or an empty sequence. Duplicates,
    indices out of range, unknown names and all p columns fixed are errors.
    """
    if value is None:
        return ()
    p = len(names)
    items = [value] if isinstance(value, (str, Integral)) else value
    expected = (
        f"None, or regressor columns as integer indices in [-{p}, {p - 1}] or names "
        f"({remedy_names}: {list(names)})"
    )
    if isinstance(items, (bytes, dict, set)) or not hasattr(items, "__iter__"):
        raise TypeError(f"fixed: expected {expected}, received {describe(value)}")
    columns: list[int] = []
    for item in list(items):
        if isinstance(item, str):
            if item not in names:
                raise ValueError(
                    f"fixed: expected {expected}, received the unknown name {item!r}; use one "
                    "of the names listed"
                )
            column = list(names).index(item)
        elif isinstance(item, Integral) and not isinstance(item, bool):
            if not -p <= int(item) < p:
                raise ValueError(
                    f"fixed: expected {expected}, received the index {int(item)}, out of range "
                    f"for p = {p} regressors"
                )
            column = int(item) % p
        else:
            raise TypeError(f"fixed: expected {expected}, received {describe(item)} in {value!r}")
        if column in columns:
            raise ValueError(
                f"fixed: expected each column once, received column {column} "
                f"({names[column]!r}) twice in {value!r}; list it once"
            )
        columns.append(column)
    if len(columns) == p:
        raise ValueError(
            f"fixed: all {p} regressors are fixed ({value!r}), so no coefficient can change "
            "and there is nothing to segment; leave at least one regressor out of fixed, or "
            "fit one model without segments (ltvmodels.fit_lti / a least-squares regression)"
        )
    return tuple(sorted(columns))


BREAK_TEST_KINDS = ("supF", "aveF", "expF", "sequential")


def break_test_kind(value: Any) -> str:
    """The kind of a structural-break test: one of :data:`BREAK_TEST_KINDS`."""
    if not isinstance(value, str):
        raise TypeError(f"kind: expected one of {BREAK_TEST_KINDS}, received {describe(value)}")
    if value not in BREAK_TEST_KINDS:
        raise ValueError(
            f"kind: expected one of {BREAK_TEST_KINDS}, received {value!r}; supF, aveF and "
            "expF test for one break, 'sequential' selects the number of breaks"
        )
    return value


def trim_fraction(value: Any) -> float:
    """A trimming fraction: a real number in (0, 0.5)."""
    fraction = positive_scalar(value, "trim")
    if fraction >= 0.5:
        raise ValueError(
            f"trim: expected a fraction of the rows in (0, 0.5) (e.g. 0.15), received "
            f"{value!r}; two segments of at least half the rows each leave no room for a change"
        )
    return fraction


def significance_level(value: Any) -> float:
    """A test's significance level: a real number in (0, 1)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(
            f"level: expected a significance level in (0, 1), received {describe(value)}"
        )
    level = float(value)
    if not 0.0 < level < 1.0:
        raise ValueError(
            f"level: expected a significance level in (0, 1) (e.g. 0.05), received {level}"
        )
    return level
