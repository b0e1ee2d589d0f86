"""Coercion and validation of every public input, in one place.

Each check raises :class:`ValueError` or :class:`TypeError` with a message that
names the argument, what was expected and what was received. Arrays are always
copied into fresh float64 arrays, so user data are never mutated and never
aliased by a returned model.
"""

from __future__ import annotations

from numbers import Integral, Real
from typing import Any, Sequence

import numpy as np

NORMS = ("sq", "group", "l1")


def _describe(value: Any) -> str:
    """Short description of a received value for error messages."""
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape} and dtype {value.dtype}"
    if hasattr(value, "shape") and hasattr(value, "dtype"):
        return f"{type(value).__name__} of shape {tuple(value.shape)}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def as_float_array(value: Any, name: str) -> np.ndarray:
    """Convert lists, numpy arrays and pandas objects to a new float64 array.

    Raises TypeError for values that are not numeric and ValueError for
    NaN or infinite entries.
    """
    if value is None:
        raise TypeError(f"{name}: expected an array of numbers, received None")
    if hasattr(value, "to_numpy"):  # pandas DataFrame / Series
        value = value.to_numpy()
    expected = f"{name}: expected an array of real numbers, received {_describe(value)}"
    if isinstance(value, (str, bytes)):
        raise TypeError(expected)
    try:
        raw = np.asarray(value)
    except ValueError as exc:  # ragged nested sequences
        raise TypeError(expected) from exc
    if np.iscomplexobj(raw):  # checked before the cast, which would only warn
        raise TypeError(f"{name}: expected real numbers, received complex values")
    if raw.dtype.kind in "USV":  # text (even "1.5") or raw bytes are not numbers
        raise TypeError(expected)
    try:
        arr = np.array(raw, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as exc:  # objects that are not numbers
        raise TypeError(expected) from exc
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(
            f"{name}: expected finite values, received NaN or inf "
            f"(first at index {tuple(int(i) for i in bad)})"
        )
    return arr


def as_time_series(value: Any, name: str, *, allow_1d: bool = True) -> np.ndarray:
    """Return a (T, d) float64 copy of a time series with time on axis 0.

    A 1-d input of length T becomes (T, 1) when ``allow_1d``.
    """
    arr = as_float_array(value, name)
    if arr.ndim == 1 and allow_1d:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(
            f"{name}: expected a 2-d array of shape (T, d) with time on axis 0, "
            f"received {arr.ndim}-d array of shape {arr.shape}"
        )
    if arr.shape[1] == 0:
        raise ValueError(f"{name}: expected at least one column, received shape {arr.shape}")
    return arr


def state_and_input(x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validate states ``x`` (T, n) and inputs ``u`` (T, m) | (T,) | None.

    Returns float64 copies; ``u`` is (T, 0) when None.
    """
    x = as_time_series(x, "x", allow_1d=True)
    T = x.shape[0]
    if T < 2:
        raise ValueError(f"x: expected at least 2 time steps, received T={T}")
    if u is None:
        u = np.zeros((T, 0))
    else:
        u = as_time_series(u, "u", allow_1d=True)
        if u.shape[0] != T:
            raise ValueError(
                f"u: expected {T} rows (one per time step, as x), received {u.shape[0]}"
            )
    return x, u


def norm_name(norm: Any) -> str:
    """Validate the regularization norm name."""
    if not isinstance(norm, str) or norm not in NORMS:
        raise ValueError(f"norm: expected one of {NORMS}, received {_describe(norm)}")
    return norm


def sparse_weights(lam: Any, K: int) -> np.ndarray:
    """λ for norm="group"/"l1": a scalar > 0 or a (K,) vector of weights >= 0 (inf: constant).

    Returns the (K,) weight vector Λ of the penalty Σ_t R(Λ (Dk)_t).
    """
    W = penalty_weight(lam, K)  # shape and sign checks shared with norm="sq"
    if np.ndim(lam) == 2:
        raise ValueError(
            "lam: a (K, K) weight matrix applies to norm='sq' only; use a scalar or a "
            f"(K,) vector with norm='group' or 'l1', received shape {np.shape(lam)}"
        )
    weights = np.sqrt(np.diag(W))
    if not np.any(weights > 0):
        raise ValueError(
            "lam: expected lam > 0 with norm='group' or 'l1': with lam = 0 every time step "
            "has its own unregularized model and the problem is ill-posed (paper Section V)"
        )
    return weights


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
        raise TypeError(f"order: expected an integer >= 1 or a sequence of coefficients, "
                        f"received {_describe(order)}")
    if isinstance(order, Integral):
        d = int(order)
        if d < 1:
            raise ValueError(f"order: expected an integer >= 1, received {d}")
        if max_degree is not None and d > max_degree:
            raise ValueError(
                f"order: expected a degree of at most {max_degree} (a difference of degree "
                f"d needs more than d + 1 samples), received {d}"
            )
        coeffs = np.array([1.0])
        for _ in range(d):
            coeffs = np.convolve(coeffs, [-1.0, 1.0])
        return coeffs
    if isinstance(order, Real):
        raise TypeError(f"order: expected an integer >= 1 or a sequence of coefficients, "
                        f"received {_describe(order)}")
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
    if abs(coeffs.sum()) > 1e-10 * scale:
        raise ValueError(
            "order: polynomial coefficients must sum to zero so that constant "
            f"coefficients are not penalized (P(1) = 0), received {coeffs.tolist()} "
            f"with sum {coeffs.sum():g}"
        )
    return coeffs


def nonnegative_scalar(value: Any, name: str, *, allow_inf: bool = False) -> float:
    """Validate a real scalar >= 0 (0-d numpy arrays are accepted)."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
        raise TypeError(f"{name}: expected a real number >= 0, received {_describe(value)}")
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


def penalty_weight(lam: Any, K: int) -> np.ndarray:
    """Turn ``lam`` into the K x K penalty weight matrix W of sum_t (Dk)_t' W (Dk)_t.

    * scalar λ >= 0:   W = λ² I;
    * vector (K,):     W = diag(λ_j²); ``inf`` marks a coefficient constant in
      time, 0 a coefficient free to change arbitrarily;
    * matrix (K, K):   W = Λ, symmetric positive semidefinite (used as is, so
      λ² I is equivalent to the scalar λ).

    Infinite diagonal entries of the returned matrix mark constant coefficients.
    """
    if lam is None or isinstance(lam, (str, bool)):
        raise TypeError(
            "lam: expected a number >= 0, a (K,) vector or a (K, K) matrix "
            f"(K={K}), received {_describe(lam)}"
        )
    if np.ndim(lam) == 0:
        value = nonnegative_scalar(lam, "lam", allow_inf=True)
        return np.diag(np.full(K, value**2))  # no 0·inf off the diagonal
    try:
        arr = np.array(lam.to_numpy() if hasattr(lam, "to_numpy") else lam, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            "lam: expected a number >= 0, a (K,) vector or a (K, K) matrix of real numbers "
            f"(K={K}), received {_describe(lam)}"
        ) from exc
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
        return np.diag(arr**2)
    if arr.ndim == 2:
        if arr.shape != (K, K):
            raise ValueError(f"lam: expected a ({K}, {K}) matrix, received shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("lam: a weight matrix must be finite (use a vector with inf "
                             "entries to hold coefficients constant)")
        if not np.allclose(arr, arr.T, rtol=1e-10, atol=1e-12 * np.abs(arr).max()):
            raise ValueError(
                "lam: expected a symmetric weight matrix, received a non-symmetric one"
            )
        eig_min = np.linalg.eigvalsh(arr).min()
        if eig_min < -1e-10 * max(np.abs(arr).max(), 1e-300):
            raise ValueError(
                f"lam: expected a positive semidefinite weight matrix, received one with "
                f"eigenvalue {eig_min:g}"
            )
        return 0.5 * (arr + arr.T)
    raise ValueError(
        f"lam: expected a scalar, a (K,) vector or a (K, K) matrix (K={K}), "
        f"received shape {arr.shape}"
    )


def covariance(value: Any, name: str, N: int, d: int) -> np.ndarray:
    """Validate a covariance given as scalar, (d, d) or (N, d, d).

    Returns an array of shape (), (d, d) or (N, d, d). Matrices must be
    symmetric positive definite (checked by a Cholesky factorization).
    """
    arr = as_float_array(value, name)
    if arr.ndim == 0:
        if arr <= 0:
            raise ValueError(f"{name}: expected a variance > 0, received {float(arr)}")
        return arr
    if arr.shape not in ((d, d), (N, d, d)):
        raise ValueError(
            f"{name}: expected a scalar, a ({d}, {d}) matrix or an ({N}, {d}, {d}) array, "
            f"received shape {arr.shape}"
        )
    if not np.allclose(arr, np.swapaxes(arr, -1, -2), rtol=1e-8, atol=1e-12 * np.abs(arr).max()):
        raise ValueError(f"{name}: expected symmetric covariance matrices")
    try:
        np.linalg.cholesky(arr)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name}: expected positive definite covariance matrices") from None
    return arr


def mean_sequence(value: Any, name: str, N: int, d: int) -> np.ndarray:
    """Validate a mean given as (d,) or (N, d); returns (N, d)."""
    arr = as_float_array(value, name)
    if arr.shape == (d,):
        return np.broadcast_to(arr, (N, d)).copy()
    if arr.shape != (N, d):
        raise ValueError(f"{name}: expected shape ({d},) or ({N}, {d}), received {arr.shape}")
    return arr


def choice(value: Any, name: str, options: Sequence[str]) -> str:
    """Validate that ``value`` is one of the string ``options``."""
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name}: expected one of {tuple(options)}, received {_describe(value)}")
    return value


def enough_samples(N: int, n_params_per_row: int, n_diff: int) -> None:
    """Require enough time steps to identify the parameters at all.

    With a difference operator of degree d the penalty leaves a d-dimensional
    family of trajectories per parameter unpenalized, so at least
    d * p regression equations per output row are needed.
    """
    needed = max(n_params_per_row * n_diff, n_diff + 1)
    if N < needed:
        raise ValueError(
            f"x: too few samples: {N} transitions (T={N + 1}) cannot identify "
            f"{n_params_per_row} regressors per output with a difference operator of "
            f"degree {n_diff}; need at least {needed} transitions (T >= {needed + 1})"
        )


# -- Kalman form (ltvmodels.solvers.kalman) ---------------------------------------------


def scalar_lam(lam: Any) -> float:
    """Validate a scalar regularization weight 0 < λ < inf for the Kalman form.

    The Kalman filter realizes the isotropic penalty λ² Σ_t ‖(Dk)_t‖² only;
    vector and matrix weights are handled by :func:`ltvmodels.fit`.
    """
    if np.ndim(lam) != 0 or isinstance(lam, (str, bytes)):
        raise TypeError(
            "lam: the Kalman filter/smoother supports a scalar λ > 0 only (use "
            f"ltvmodels.fit for vector or matrix weights), received {_describe(lam)}"
        )
    return positive_scalar(lam.item() if hasattr(lam, "item") else lam, "lam")


def integer(value: Any, name: str, minimum: int) -> int:
    """Validate an integer >= ``minimum`` (bools are rejected)."""
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, received {_describe(value)}")
    return int(value)


def vector(value: Any, name: str, size: int) -> np.ndarray:
    """Validate a finite 1-d vector of the given length; returns a float64 copy."""
    arr = as_float_array(value, name)
    if arr.ndim == 0 and size == 1:
        arr = arr.reshape(1)
    if arr.shape != (size,):
        raise ValueError(f"{name}: expected a vector of length {size}, received shape {arr.shape}")
    return arr


def initial_state_prior(
    init_mean: Any, init_cov: Any, degree: int, n: int, p: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """Validate a Gaussian prior on the initial state of the parameter random walk.

    The state of the realization of a degree-d difference operator is
    s_0 = (k_0, k_{-1}, …, k_{-d+1}); per output row i it is
    (θ_{0,i}, θ_{-1,i}, …) of size D = d·p, rows independent a priori with a
    shared covariance.

    Parameters
    ----------
    init_mean : array_like, shape (d, K), (K,) when d = 1, or None
        Row j is the mean of k_{-j}. None means zero (only with ``init_cov``).
    init_cov : float or array_like, shape (D, D), or None
        Covariance of one row's state; a scalar v means v·I. None (with
        ``init_mean`` None) selects the exact diffuse initialization.

    Returns
    -------
    None for the diffuse initialization, else (mean (D, n), cov (D, D)) with
    column i the mean of row i's state.
    """
    D, K = degree * p, n * p
    if init_cov is None:
        if init_mean is not None:
            raise ValueError(
                "init_cov: expected a covariance to go with init_mean (a scalar or a "
                f"({D}, {D}) matrix), received None"
            )
        return None
    cov = as_float_array(init_cov, "init_cov")
    if cov.ndim == 0:
        if cov <= 0:
            raise ValueError(f"init_cov: expected a variance > 0, received {float(cov)}")
        cov = float(cov) * np.eye(D)
    elif cov.shape != (D, D):
        raise ValueError(
            f"init_cov: expected a scalar or a ({D}, {D}) matrix (the covariance of one "
            f"output row's state: {degree} block(s) of {p} regressors), received shape "
            f"{cov.shape}"
        )
    if not np.allclose(cov, cov.T, rtol=1e-8, atol=1e-12 * np.abs(cov).max()):
        raise ValueError("init_cov: expected a symmetric covariance matrix")
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        raise ValueError("init_cov: expected a positive definite covariance matrix") from None
    cov = 0.5 * (cov + cov.T)
    if init_mean is None:
        return np.zeros((D, n)), cov
    mean = as_float_array(init_mean, "init_mean")
    if degree == 1 and mean.shape == (K,):
        mean = mean[None, :]
    if mean.shape != (degree, K):
        expected = f"({K},) or (1, {K})" if degree == 1 else f"({degree}, {K})"
        raise ValueError(
            f"init_mean: expected shape {expected} (row j: mean of k_(-j)), received "
            f"shape {mean.shape}"
        )
    # (d, n, p) → (d, p, n) → (D, n): column i stacks θ_{0,i}, θ_{-1,i}, …
    return np.ascontiguousarray(mean.reshape(degree, n, p).transpose(0, 2, 1).reshape(D, n)), cov


# -- change points and piecewise refits (ltvmodels.changepoints, ltvmodels.piecewise) ---


def fraction(value: Any, name: str) -> float:
    """Validate a real number in [0, 1]."""
    v = nonnegative_scalar(value, name)
    if v > 1:
        raise ValueError(f"{name}: expected a number in [0, 1], received {v}")
    return v


def optional_nonnegative(value: Any, name: str) -> float | None:
    """Validate None or a finite real number >= 0."""
    return None if value is None else nonnegative_scalar(value, name)


def optional_integer(value: Any, name: str, minimum: int) -> int | None:
    """Validate None or an integer >= ``minimum``."""
    return None if value is None else integer(value, name, minimum)


def dynamics_matrices(model: Any) -> np.ndarray:
    """``model.A`` as a float array of shape (N, n, n), for any object that has one."""
    if not hasattr(model, "A"):
        raise TypeError(f"model: expected an object with attribute A (N, n, n) such as an "
                        f"LTVModel, received {type(model).__name__}")
    A = np.asarray(model.A, dtype=float)
    if A.ndim != 3 or A.shape[1] != A.shape[2]:
        raise ValueError(f"model.A: expected shape (N, n, n), received {A.shape}")
    return A


def activation_series(value: Any, name: str) -> np.ndarray:
    """Validate an activation a_t = ‖(Dk)_t‖: a 1-d array of finite numbers >= 0."""
    arr = as_float_array(value, name)
    if arr.ndim != 1:
        raise ValueError(
            f"{name}: expected an LTVModel or a 1-d activation array a_t = ‖(Dk)_t‖ "
            f"(for (Dk)_t of shape (L, K) use np.linalg.norm(Dk, axis=1)), received "
            f"{arr.ndim}-d array of shape {arr.shape}"
        )
    if arr.size and arr.min() < 0:
        raise ValueError(
            f"{name}: expected nonnegative activations (norms), received min {arr.min():g} "
            f"at index {int(arr.argmin())}"
        )
    return arr


def piecewise_order(order: Any) -> int:
    """Validate the order of a piecewise refit: 1 (constant) or 2 (linear, continuous)."""
    expected = "1 (piecewise constant) or 2 (piecewise linear, continuous)"
    if isinstance(order, bool) or not isinstance(order, Integral):
        raise TypeError(f"order: expected {expected}, received {_describe(order)}")
    if order < 1:
        raise ValueError(f"order: expected {expected}, received {int(order)}")
    if order > 2:
        raise NotImplementedError(
            f"order={int(order)}: piecewise polynomials of degree >= 2 are not implemented; "
            f"use order=1 or order=2"
        )
    return int(order)


def changepoint_indices(
    value: Any, N: int, *, last: int, note: str = "", name: str = "changepoints"
) -> np.ndarray:
    """Validate change points: integers in [1, ``last``], strictly increasing.

    A scalar is one change point; an empty sequence none. Unsorted or
    repeated values are an error (never silently sorted or deduplicated).
    Integral floats (200.0) are accepted; booleans are not. ``note`` is added
    to the range message (e.g. why ``last`` is N − 2).

    Returns
    -------
    ndarray of int64, shape (M,)
        A new array.
    """
    if value is None:
        raise TypeError(
            f"{name}: expected a sequence of integer change points (e.g. from "
            "ltvmodels.find_changepoints; [] for none), received None"
        )
    arr = as_float_array(value, name)
    if np.asarray(value.to_numpy() if hasattr(value, "to_numpy") else value).dtype == bool:
        raise TypeError(f"{name}: expected integers, received booleans ({_describe(value)})")
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-d sequence of integers, received shape {arr.shape}")
    if np.any(arr != np.round(arr)):
        bad = arr[arr != np.round(arr)][0]
        raise ValueError(f"{name}: expected integers, received {bad:g}")
    outside = (arr < 1) | (arr > last)
    if outside.any():
        raise ValueError(
            f"{name}: expected model indices in [1, {last}] (a change point c starts a new "
            f"segment at model index c; N = {N} model steps{note}), received "
            f"{_integer_text(arr[outside][0])}"
        )
    out = arr.astype(np.int64)
    steps = np.diff(out)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise ValueError(
            f"{name}: expected strictly increasing indices without repeats, received "
            f"{int(out[i])} after {int(out[i - 1])} (position {i}); sort and deduplicate them"
        )
    return out


def _integer_text(value: float) -> str:
    """An integral float as an integer, or in exponent notation when huge."""
    return str(int(value)) if abs(value) < 1e15 else f"{value:g}"


# -- L0 segmentation (ltvmodels.segments) ---------------------------------------------------

PENALTY_RULES = ("bic", "aic")


def regression_data(y: Any, phi: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validate a regression y_t = Θ φ_t: y (N, n) or (N,), φ (N, p) or (N,).

    Returns float64 copies of shapes (N, n) and (N, p).
    """
    y = as_time_series(y, "y", allow_1d=True)
    phi = as_time_series(phi, "phi", allow_1d=True)
    if phi.shape[0] != y.shape[0]:
        raise ValueError(
            f"phi: expected {y.shape[0]} rows (one regressor vector per row of y), "
            f"received {phi.shape[0]}"
        )
    return y, phi


def segment_min_size(value: Any, p: int) -> int:
    """Minimum segment length: None (→ p) or an integer >= p.

    A segment with fewer samples than the p regressors of each output row has
    no unique least-squares fit.
    """
    if value is None:
        return p
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise TypeError(
            f"min_size: expected None or an integer >= p = {p}, received {_describe(value)}"
        )
    if value < p:
        raise ValueError(
            f"min_size: expected an integer >= p = {p} (a segment needs at least as many "
            f"samples as regressors for its least squares to be well posed), received "
            f"{int(value)}"
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
        raise TypeError(
            f"n_changes: expected an integer >= 0, received {_describe(value)}"
        )
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


def segment_penalty(value: Any) -> float | str:
    """Penalty per change: a finite real number >= 0, or one of the rules 'bic', 'aic'."""
    if isinstance(value, str):
        if value not in PENALTY_RULES:
            raise ValueError(
                f"penalty: expected a number >= 0 or one of {PENALTY_RULES}, received "
                f"{_describe(value)}"
            )
        return value
    if isinstance(value, bool) or np.ndim(value) != 0:
        raise TypeError(
            f"penalty: expected a number >= 0 or one of {PENALTY_RULES}, received "
            f"{_describe(value)}"
        )
    return nonnegative_scalar(value.item() if hasattr(value, "item") else value, "penalty")


def segment_mode(n_changes: Any, penalty: Any) -> None:
    """n_changes and penalty are alternatives: at most one may be given."""
    if n_changes is not None and penalty is not None:
        raise TypeError(
            "n_changes, penalty: expected one of them (n_changes=M for exactly M changes, "
            f"penalty=β for a cost of β per change), received both (n_changes={n_changes!r}, "
            f"penalty={penalty!r})"
        )


def positive_grid(value: Any, name: str) -> np.ndarray:
    """A non-empty 1-d array of finite values > 0, sorted increasing (a λ grid)."""
    arr = as_float_array(value, name)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-d sequence, received shape {arr.shape}")
    if np.any(arr <= 0):
        raise ValueError(f"{name}: expected values > 0, received a minimum of {arr.min():g}")
    return np.unique(arr)


def count_grid(value: Any, name: str) -> np.ndarray:
    """A non-empty 1-d array of whole numbers >= 0, sorted increasing (numbers of changes)."""
    arr = as_float_array(value, name)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-d sequence, received shape {arr.shape}")
    if np.any(arr < 0) or np.any(arr != np.round(arr)):
        bad = arr[(arr < 0) | (arr != np.round(arr))][0]
        raise ValueError(f"{name}: expected whole numbers >= 0, received {bad:g}")
    return np.unique(arr.astype(np.int64))


# -- general regressions and AR/ARX models (ltvmodels.fit_regression, ltvmodels.ar) -------


def flag(value: Any, name: str) -> bool:
    """Validate True or False (no other truthy values)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, received {_describe(value)}")
    return bool(value)


def enough_rows(N: int, n_params_per_row: int, n_diff: int, name: str, note: str = "") -> None:
    """Require enough regression rows to identify p regressors per output row.

    As :func:`enough_samples` for a regression with N rows (``name`` is the
    data argument; ``note`` says how the rows relate to the series, e.g. for AR).
    """
    needed = max(n_params_per_row * n_diff, n_diff + 1)
    if N < needed:
        raise ValueError(
            f"{name}: too few samples: {N} regression rows{note} cannot identify "
            f"{n_params_per_row} regressors per output with a difference operator of "
            f"degree {n_diff}; need at least {needed} rows"
        )


def regressor_rows(value: Any, N: int, p: int, name: str = "phi") -> np.ndarray:
    """Regressors for a fitted regression: (N, p), or (N,) when p = 1; returns a copy."""
    arr = as_time_series(value, name, allow_1d=(p == 1))
    if arr.shape != (N, p):
        raise ValueError(
            f"{name}: expected shape ({N}, {p}) (one row of {p} regressors per model time "
            f"step), received shape {arr.shape}"
        )
    return arr


def lag_orders(na: Any, nb: Any, nk: Any, *, min_na: int, min_nb: int) -> tuple[int, int, int]:
    """Validate the AR/ARX orders: integers na >= ``min_na``, nb >= ``min_nb``, nk >= 0."""
    na = integer(na, "na", minimum=min_na)
    nb = integer(nb, "nb", minimum=min_nb)
    nk = integer(nk, "nk", minimum=0)
    return na, nb, nk


def lagged_series(
    y: Any, u: Any, lag: int, structure: str, *, n_inputs: int | None = None,
    require_inputs: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Validate AR/ARX data: y (T, n) or (T,), u (T, m) or (T,) or None; T > lag.

    ``u`` may be None unless ``require_inputs``; ``n_inputs`` (if given) is the
    required number of columns of ``u``. ``structure`` names the orders (e.g.
    "na = 2, nb = 1, nk = 1") in the too-short message. Returns float64
    copies, u of shape (T, 0) when None.
    """
    y = as_time_series(y, "y", allow_1d=True)
    T = y.shape[0]
    if u is None:
        if require_inputs:
            expected = f"({T}, {n_inputs})" if n_inputs else f"({T}, m) or ({T},)"
            raise TypeError(f"u: expected inputs of shape {expected}, received None")
        u = np.zeros((T, 0))
    else:
        u = as_time_series(u, "u", allow_1d=True)
        if u.shape[0] != T:
            raise ValueError(
                f"u: expected {T} rows (one per sample of y), received {u.shape[0]}"
            )
        if n_inputs is not None and u.shape[1] != n_inputs:
            raise ValueError(f"u: expected {n_inputs} columns, received {u.shape[1]}")
    if T <= lag:
        raise ValueError(
            f"y: the series is shorter than the lag structure: {structure} reaches back "
            f"{lag} samples, so y needs more than {lag} samples, received T = {T}"
        )
    return y, u


def model_series(
    y: Any, u: Any, *, N: int, n: int, m: int, lag: int
) -> tuple[np.ndarray, np.ndarray]:
    """Data for a fitted AR/ARX model: y (N + lag, n), u (N + lag, m) (None if m = 0)."""
    y, u = lagged_series(y, u, lag, f"the model's lags ({lag})", n_inputs=m,
                         require_inputs=m > 0)
    if y.shape[1] != n:
        raise ValueError(f"y: expected {n} columns (outputs), received {y.shape[1]}")
    if y.shape[0] != N + lag:
        raise ValueError(
            f"y: expected T = {N + lag} samples (the model has N = {N} time steps after "
            f"{lag} initial samples), received T = {y.shape[0]}"
        )
    return y, u


def simulation_inputs(
    y0: Any, u: Any, noise: Any, *, N: int, n: int, m: int, lag: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate an AR/ARX simulation: initial samples, inputs and noise.

    Returns y0 (lag, n), u (N + lag, m) and noise (N, n) (zeros when None).
    ``y0`` may be 1-d when n = 1 and None when lag = 0; ``noise`` 1-d when n = 1.
    """
    T = N + lag
    if y0 is None and lag == 0:
        y0 = np.zeros((0, n))
    else:
        y0 = as_float_array(y0, "y0")
        if y0.ndim == 1 and n == 1:
            y0 = y0[:, None]
        if y0.shape != (lag, n):
            expected = f"({lag}, {n})" + (f" or ({lag},)" if n == 1 else "")
            raise ValueError(
                f"y0: expected the {lag} initial samples y[0:{lag}], shape {expected}, "
                f"received shape {y0.shape}"
            )
    if u is None:
        if m:
            raise TypeError(f"u: expected inputs of shape ({T}, {m}), received None")
        u = np.zeros((T, 0))
    else:
        u = as_time_series(u, "u", allow_1d=True)
        if u.shape != (T, m):
            raise ValueError(
                f"u: expected shape ({T}, {m}) (T = {lag} initial + {N} simulated samples), "
                f"received shape {u.shape}"
            )
    if noise is None:
        noise = np.zeros((N, n))
    else:
        noise = as_float_array(noise, "noise")
        if noise.ndim == 1 and n == 1:
            noise = noise[:, None]
        if noise.shape != (N, n):
            expected = f"({N}, {n})" + (f" or ({N},)" if n == 1 else "")
            raise ValueError(
                f"noise: expected shape {expected} (one e[t] per simulated sample), received "
                f"shape {noise.shape}"
            )
    return y0, u, noise


def is_auto(value: Any, name: str) -> bool:
    """True for the string "auto"; any other string is a TypeError naming the argument."""
    if isinstance(value, str):
        if value != "auto":
            raise TypeError(f"{name}: expected a number, an array or 'auto', received {value!r}")
        return True
    return False
