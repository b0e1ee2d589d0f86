"""Change points from the activation a_t = ‖(Dk)_t‖₂ (paper III-G, two-step refinement).

A fitted model's activation (:meth:`ltvmodels.LTVModel.activation`) measures
how much the coefficients change at each time step. For a sparse first step
(``norm="group"``) it is zero except where the model changes; for a
squared-norm fit (``norm="sq"``) every change is smeared into a bump on top of
a noisy background. :func:`find_changepoints` turns it into change points by
three rules, applied in this order:

1. **Level.** Only activations above

       level = max(threshold · max_t a_t,  median(a) + noise_factor · σ̂),
       σ̂ = 1.4826 · median(|a − median(a)|)    (the MAD, a robust noise scale)

   count. The relative threshold removes solver residue and changes that are
   tiny next to the largest one; the robust floor removes the background of
   a squared-norm fit and makes a model without any change give none.
2. **Peaks.** Only local maxima count (a_t > a_{t−1} and a_t ≥ a_{t+1}; the
   ends compare with their one neighbour; on a plateau the first index;
   differences below 1e-10 · max(a) are ties), so one bump gives one change,
   not one per sample above the level.
3. **Non-maximum suppression.** Peaks are taken from the largest down; a peak
   closer than ``min_distance`` to one already taken is dropped, and at most
   ``max_changes`` are taken.

Index convention
----------------
Activation index t refers to the stencil k_t … k_{t+d} of the difference
operator of degree d; it is mapped to the change point (model index)

    c = t + ⌈d/2⌉,

the centre of the stencil (rounded up), with "change point c" meaning that
the model changes between steps c − 1 and c. Hence

* d = 1: (Dk)_t = k_{t+1} − k_t, so a large a_t is a jump k_c ≠ k_{c−1} at
  c = t + 1 — the convention of :attr:`ltvmodels.LTVModel.changepoints` and of
  :func:`ltvmodels.fit_piecewise` (a new segment starts at c);
* d = 2: (Dk)_t = k_{t+2} − 2k_{t+1} + k_t is nonzero at a kink of a
  piecewise-linear k exactly when the kink is at the middle sample, c = t + 1
  — the knot of ``fit_piecewise(..., order=2)``;
* general d: a break in the (d−1)-th difference at c (k piecewise polynomial
  of degree d − 1) makes a_t nonzero for t = c − d + 1 … c − 1 (for d ≥ 2),
  symmetric about c − d/2; its peak (the first one for odd d, where two are
  equal) is at t = c − ⌈d/2⌉. For odd d ≥ 3 the location is therefore
  ambiguous by one step in noisy data.

An event of another kind is located less precisely: a jump seen through the
second difference gives two equal activations (t = c − 2 and c − 1) and is
reported at c − 1. Locate jumps with the first difference and kinks with the
second.

Model steps and the data's axis
-------------------------------
The change points are model steps c (above). Given a model,
:func:`find_changepoints` returns them as a
:class:`~ltvmodels.results.changepoints.Changepoints` array that also gives
where they lie on the data's axis: ``sample_indices``, the sample of the first
observation produced under the new coefficients (x[c + 1] of a state-space
model, y[c] of a regression, y[lag + c] of an AR/ARX model — a change in an
AR(2) model found at step 148 is at sample 150 of the series), and ``times``,
the time of that sample when the model has a time axis (the convention of
:attr:`ltvmodels.RegressionModel.changepoint_times`).
"""

from __future__ import annotations

from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike

from ..core.robust import MAD_TO_STD
from ..results.changepoints import Changepoints
from ..results.regression import RegressionModel
from ..validation import arrays, options

TIE_TOLERANCE = 1e-10
"""Activations closer than this fraction of max(a) are equal when finding peaks."""
RESIDUE = 1e-9
"""Activations below this fraction of the largest ‖k_t‖ are solver residue, not changes."""

__all__ = ["detection_level", "find_changepoints", "residue_level", "MAD_TO_STD"]


def residue_level(k: np.ndarray) -> float:
    """The activation level of rounding and solver residue for coefficients k (N, K)."""
    return RESIDUE * float(np.max(np.linalg.norm(k, axis=1), initial=0.0))


def _changepoint_offset(degree: int) -> int:
    """Offset ⌈d/2⌉ from activation index t to change point c = t + ⌈d/2⌉."""
    return (degree + 1) // 2


# A model gives change points on its data's axis; an activation array (no data axis)
# the plain array of steps.
@overload
def find_changepoints(
    model_or_activation: RegressionModel,
    *,
    threshold: float = ...,
    noise_factor: float | None = ...,
    min_distance: int = ...,
    max_changes: int | None = ...,
    degree: int | None = ...,
    min_level: float | None = ...,
) -> Changepoints: ...


@overload
def find_changepoints(
    model_or_activation: ArrayLike,
    *,
    threshold: float = ...,
    noise_factor: float | None = ...,
    min_distance: int = ...,
    max_changes: int | None = ...,
    degree: int | None = ...,
    min_level: float | None = ...,
) -> np.ndarray: ...


def find_changepoints(
    model_or_activation: RegressionModel | ArrayLike,
    *,
    threshold: float = 0.25,
    noise_factor: float | None = 8.0,
    min_distance: int = 10,
    max_changes: int | None = None,
    degree: int | None = None,
    min_level: float | None = None,
) -> np.ndarray:
    """Detect change points from the activation a_t = ‖(Dk)_t‖₂ of a model.

    The first step of the paper's two-step refinement (Section III-G): fit a
    model (ideally with a sparse penalty, ``norm="group"``), find where its
    activation is large, then refit with :func:`ltvmodels.fit_piecewise`.
    The rules (level, peaks, non-maximum suppression) and the index
    convention are described in :mod:`ltvmodels.estimators.changepoints`.

    Parameters
    ----------
    model_or_activation : LTVModel (any fitted model) or array_like, shape (N − d,)
        A fitted model (its :meth:`~ltvmodels.LTVModel.activation` and the
        degree d of its difference operator are used) or the activation
        itself: nonnegative values a_t for t = 0 … N − d − 1.
    threshold : float, default 0.25
        Relative level in [0, 1]: a change needs a_t > threshold · max(a).
        Measured on group-lasso fits (``norm="group"``, λ = 10 … 60) of the
        jump-linear system and of a system with three switches, the spurious
        or split steps reach up to about a quarter of the largest activation
        (at small λ; mostly right next to a true change, where
        ``min_distance`` merges them), while every true change stood at 0.3
        of the largest or more; solver residue is below 1e-3 of it. A single
        relative rule cannot tell "no change" from "one change": the largest
        activation always passes it (the floor below can reject it).
    noise_factor : float or None, default 8.0
        Robust floor: a change also needs a_t > median(a) + noise_factor · σ̂
        with σ̂ = 1.4826 · MAD(a). None switches the floor off. For a sparse
        activation (more than half of it zero) the floor is 0. The default is
        conservative: the background of a squared-norm fit is skewed and
        strongly correlated in time. On the jump-linear system without a
        change (``systems.jump_linear(change_at=399)``, ``norm="sq"``,
        λ = 10 and 30, 30 seeds) its maximum stood typically 5–6 σ̂ above the
        median, above 8 σ̂ in about one case in ten and at most 9.6 σ̂, while
        with the change at t = 200 the change stood typically 11 σ̂ above it
        (but below 8 σ̂ in about one case in five). Lower it (e.g. 6) to miss
        fewer changes at the price of false ones, or pass
        ``noise_factor=None`` with ``max_changes`` when the number of changes
        is known.
    min_distance : int, default 10
        Smallest distance (>= 1) between two change points; of two peaks
        closer than this only the larger is kept. It also merges the several
        local maxima that noise puts on one bump of a squared-norm fit (use
        about 20 for those) and the split steps of a group-lasso fit, and
        keeps the segments between change points at least 10 samples long,
        enough for :func:`ltvmodels.fit_piecewise` with up to 10 regressors
        (the first and last segment are not constrained).
    max_changes : int or None, default None
        Keep at most this many change points (the largest activations).
    degree : int or None
        Degree d of the difference operator that produced an activation array
        (default 1). With a model it is taken from the model; passing a
        different value is an error.
    min_level : float or None
        Activations at or below this absolute level are no change. Default:
        for a model 1e-9 · max_t ‖k_t‖ (rounding and solver residue, so a model
        that does not change gives no change point even when a_t is 1e-15
        somewhere); for an activation array 0.

    Returns
    -------
    Changepoints (for a model) or ndarray of int64 (for an activation), shape (M,)
        Sorted change points c in [⌈d/2⌉, N − d − 1 + ⌈d/2⌉] (for d = 1:
        [1, N − 1]): model steps (regression rows), the model changes between
        steps c − 1 and c — the index of :func:`ltvmodels.fit_piecewise` and of
        ``model.changepoints``. For a model they come as a
        :class:`~ltvmodels.results.changepoints.Changepoints` array (a subclass
        of ndarray holding the same steps) that also has ``sample_indices``, the
        sample of the data of the first observation produced under the new
        coefficients (x[c + 1] of a state-space model, y[c] of a regression,
        y[lag + c] of an AR/ARX model), and ``times``, their times (None
        without a time axis), as ``model.changepoint_times``.

    Raises
    ------
    ValueError, TypeError
        Invalid input; the message names the argument.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.zeros(100); a[49] = 1.0; a[79] = 0.5   # (Dk)_t = k_{t+1} − k_t
    >>> find_changepoints(a).tolist()
    [50, 80]
    >>> find_changepoints(a, max_changes=1).tolist()
    [50]

    The change of an AR(2) model at sample 150 is its step 148:

    >>> import ltvmodels as ltv
    >>> rng = np.random.default_rng(0)
    >>> y = np.zeros(300)
    >>> for t in range(2, 300):
    ...     a1, a2 = (1.5, -0.9) if t < 150 else (0.4, 0.3)
    ...     y[t] = a1 * y[t - 1] + a2 * y[t - 2] + rng.standard_normal()
    >>> found = find_changepoints(ltv.fit_ar(y, 2, lam=100.0, norm="group"))
    >>> found.tolist(), found.sample_indices.tolist()
    ([148], [150])
    """
    activation, degree = _activation_and_degree(model_or_activation, degree)
    if min_level is None:
        min_level = (
            residue_level(np.asarray(model_or_activation.k))
            if isinstance(model_or_activation, RegressionModel)
            else 0.0
        )
    else:
        min_level = options.nonnegative_scalar(min_level, "min_level")
    threshold = options.fraction(threshold, "threshold")
    noise_factor = options.optional_nonnegative(noise_factor, "noise_factor")
    min_distance = options.integer(min_distance, "min_distance", 1)
    max_changes = options.optional_integer(max_changes, "max_changes", 0)

    if activation.size == 0 or max_changes == 0:
        steps = np.zeros(0, dtype=np.int64)
    else:
        level = max(detection_level(activation, threshold, noise_factor), min_level)
        peaks = _local_maxima(activation)
        candidates = peaks[activation[peaks] > level]
        kept = _suppress_non_maxima(activation, candidates, min_distance, max_changes)
        steps = np.sort(kept) + _changepoint_offset(degree)
    if isinstance(model_or_activation, RegressionModel):
        return Changepoints.of_model(steps, model_or_activation)
    return steps


def detection_level(activation: np.ndarray, threshold: float, noise_factor: float | None) -> float:
    """The level max(threshold · max(a), median(a) + noise_factor · 1.4826 · MAD(a)).

    Parameters
    ----------
    activation : ndarray, shape (L,)
        Nonnegative activations, L >= 1.
    threshold : float
        Relative threshold in [0, 1].
    noise_factor : float or None
        Multiple of the robust noise scale above the median; None: no floor.

    Returns
    -------
    float
        Activations strictly above the level can be change points.
    """
    level = threshold * float(activation.max())
    if noise_factor is not None:
        median = float(np.median(activation))
        mad = float(np.median(np.abs(activation - median)))
        level = max(level, median + noise_factor * MAD_TO_STD * mad)
    return level


def _activation_and_degree(value: Any, degree: Any) -> tuple[np.ndarray, int]:
    """The activation array and the degree d of its difference operator."""
    if isinstance(value, RegressionModel):
        own = 1 if value.coeffs is None else len(value.coeffs) - 1
        if degree is not None and options.integer(degree, "degree", 1) != own:
            raise ValueError(
                f"degree: the model's difference operator has degree {own}; leave degree "
                f"unset (it is taken from the model), received {degree!r}"
            )
        return value.activation(), own
    degree = 1 if degree is None else options.integer(degree, "degree", 1)
    return arrays.activation_series(value, "model_or_activation"), degree


def _local_maxima(a: np.ndarray) -> np.ndarray:
    """Indices t with a_t > a_{t−1} and a_t >= a_{t+1} (missing neighbours: −inf).

    Differences below ``TIE_TOLERANCE`` · max(a) count as ties, so that
    rounding noise on a plateau does not make peaks: a plateau gives its first
    index only.
    """
    tol = TIE_TOLERANCE * float(a.max())
    left = np.concatenate([[-np.inf], a[:-1]])
    right = np.concatenate([a[1:], [-np.inf]])
    return np.flatnonzero((a - left > tol) & (a - right >= -tol))


def _suppress_non_maxima(
    a: np.ndarray, candidates: np.ndarray, min_distance: int, max_changes: int | None
) -> np.ndarray:
    """Greedy non-maximum suppression: largest first, none closer than min_distance.

    Ties are taken in time order (a stable sort), so the result does not
    depend on anything but the values.
    """
    order = candidates[np.argsort(-a[candidates], kind="stable")]
    blocked = np.zeros(a.size, dtype=bool)  # within min_distance of a kept peak
    kept: list[int] = []
    for t in order:
        if max_changes is not None and len(kept) == max_changes:
            break
        if not blocked[t]:
            kept.append(int(t))
            blocked[max(t - min_distance + 1, 0) : t + min_distance] = True
    return np.array(kept, dtype=np.int64)
