"""Tests for structural breaks in a regression: supF, aveF, expF and Bai–Perron's sequential test.

One break (Andrews 1993; Andrews and Ploberger 1994)
----------------------------------------------------
For a regression y_t = βᵀφ_t + e_t with n rows and p regressors, the F
statistic of a break at row c (the second segment starts at y[c]) compares the
residual sum of squares RSS₀ of one fit with RSS_c = C(0, c) + C(c, n) of two,

    F_c = (RSS₀ − RSS_c) / (RSS_c / (n − 2p)),

exactly as R's strucchange ``Fstats`` (its variance is the pooled one of the
two-segment fit, with n − 2p degrees of freedom, and F is not divided by p).
The candidates are c = from … to with from = ⌊trim · n⌋ (at least p + 1) and
to = n − from (at most n − p − 1); every RSS_c comes from one forward and one
backward sequential-QR pass (:func:`ltvmodels.core.segmentation.split_costs`),
O(n) in all. supF = max_c F_c, aveF = mean F_c, expF = log mean exp(F_c / 2).

p-values: B. E. Hansen (1997), "Approximate asymptotic p values for
structural-change tests", Journal of Business & Economic Statistics 15(1),
60–67: for each number of regressors k ≤ 40 and trimming τ = 0.01, 0.03, …,
0.49, the p-value is the chi-square tail P(χ²_ν > Σ_j b_j x^j) of a
polynomial in the statistic x; between the tabulated τ it is interpolated
linearly, with τ = λ for λ < 1 and τ = 1/(1 + √λ) otherwise, λ =
(n − from) · to / (from · (n − to)). This is strucchange's ``pvalue.Fstats``,
line for line, and its coefficient tables (``sc.beta.sup``, ``sc.beta.ave``,
``sc.beta.exp``) are the package data ``tables/hansen_1997_*.txt``, written by
``tests/reference/strucchange/hansen_tables.R``. With a single candidate
(λ = 1) the supF and aveF tests are Chow's test, referred to F(p, n − 2p), as
strucchange does.

Several breaks (Bai and Perron 1998, 2003)
------------------------------------------
supF(l + 1 | l): given the optimal segmentation with l breaks (minimum segment
length h), the largest over its segments of the one-break statistic within
the segment,

    F_i = (T_i − 2p) (C_i − min_c [C(a_i, c) + C(c, b_i)]) / min_c [C(a_i, c) + C(c, b_i)],

T_i the rows of segment i = [a_i, b_i), C_i its cost, and the split c with
both sides at least h rows long (segments shorter than 2h give 0). This is the
statistic of the R package mbreaks (``spflp1`` and ``pftest`` with
``prewhit = 0, robust = 0, hetdat = 1, hetvar = 0``: no serial correlation
correction and one noise variance per tested segment), Bai and Perron (1998),
"Estimating and testing linear models with multiple structural changes",
Econometrica 66, 47–78, Section 5. Its critical values are those of Bai and
Perron (2003), "Critical values for multiple structural change tests",
Econometrics Journal 6, 72–78, for trimming ε ∈ {0.05, 0.10, 0.15, 0.20,
0.25}, q = 1 … 10 regressors, l = 0 … 9 and levels 10 %, 5 %, 2.5 % and 1 %
(``tables/bai_perron_2003.txt``; see its header for where it was taken from).
"""

from __future__ import annotations

import functools
import math
from importlib import resources

import numpy as np
from scipy import stats
from scipy.optimize import brentq

from . import segmentation as search

__all__ = [
    "KINDS",
    "SEQUENTIAL_TRIMS",
    "SEQUENTIAL_LEVELS",
    "HANSEN_MAX_REGRESSORS",
    "candidate_range",
    "f_statistics",
    "aggregate",
    "hansen_table",
    "hansen_pvalue",
    "fstats_pvalue",
    "critical_value",
    "bai_perron_critical_values",
    "supf_next",
]

KINDS = ("supF", "aveF", "expF")
SEQUENTIAL_TRIMS = (0.05, 0.10, 0.15, 0.20, 0.25)
SEQUENTIAL_LEVELS = (0.10, 0.05, 0.025, 0.01)
SEQUENTIAL_MAX_REGRESSORS = 10
SEQUENTIAL_MAX_BREAKS = 10  # the tables stop at l = 9
HANSEN_MAX_REGRESSORS = 40
_HANSEN_ROWS = 25  # per number of regressors: τ = 0.49, 0.47, …, 0.01


@functools.cache
def hansen_table(kind: str) -> np.ndarray:
    """Hansen's coefficients for ``kind`` ("supF", "aveF" or "expF"), shape (1000, m + 1)."""
    name = f"hansen_1997_{kind[:3]}.txt"
    with resources.files("ltvmodels.core").joinpath("tables").joinpath(name).open() as file:
        return np.loadtxt(file, comments="#")


@functools.cache
def _hansen_peaks(kind: str) -> np.ndarray:
    """For each row of Hansen's table, where its polynomial stops increasing (inf if never).

    The fitted cubics of aveF and expF turn down for large statistics (and then
    below zero, where strucchange's p-value becomes 1); beyond its peak a
    polynomial is evaluated at the peak, so the p-value never increases with
    the statistic (it stays at the smallest value the fit reaches).
    """
    beta = hansen_table(kind)
    m = beta.shape[1] - 1
    peaks = np.full(beta.shape[0], np.inf)
    for i, row in enumerate(beta[:, :m]):
        slope = np.polynomial.Polynomial(row).deriv()
        roots = slope.roots() if slope.degree() > 0 else np.array([])
        turning = [r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0]
        turning = [r for r in turning if slope(r + 1e-6) < 0]  # where it turns down
        if turning:
            peaks[i] = min(turning)
        elif slope.degree() == 0 and slope.coef[0] <= 0:
            peaks[i] = 0.0
    return peaks


@functools.cache
def _bai_perron_table() -> np.ndarray:
    """Rows [trim, level, q, cv(l = 0) … cv(l = 9)], shape (200, 13)."""
    path = resources.files("ltvmodels.core").joinpath("tables").joinpath("bai_perron_2003.txt")
    with path.open() as file:
        return np.loadtxt(file, comments="#")


def candidate_range(n: int, trim: float, p: int) -> tuple[int, int, float]:
    """strucchange's candidate breaks for ``Fstats(from = trim)``.

    Returns
    -------
    start, stop : int
        The first and last candidate c (rows of the first segment), both
        inclusive: start = max(⌊trim · n⌋, p + 1), stop = min(n − ⌊trim · n⌋,
        n − p − 1); start > stop when there is none.
    lam : float
        λ = (n − start) · stop / (start · (n − stop)), the trimming parameter of
        the p-values.
    """
    start = int(math.floor(trim * n))
    stop = n - start
    start = max(start, p + 1)
    stop = min(stop, n - p - 1)
    if start > stop or start >= n:
        return start, stop, math.nan
    lam = ((n - start) * stop) / (start * (n - stop))
    return start, stop, lam


def f_statistics(
    data: np.ndarray, p: int, n: int, start: int, stop: int, a_max: np.ndarray
) -> np.ndarray:
    """F_c for c = start … stop (module docstring); NaN where a side is not feasible.

    Parameters
    ----------
    data : ndarray, shape (N, q, p + 1)
        Scaled rows [φ̃ ỹ] (:func:`ltvmodels.core.segmentation.scale_data`).
    p : int
        Number of regressors.
    n : int
        Observed rows (the degrees of freedom are n − 2p).
    start, stop : int
        The candidates, inclusive (:func:`candidate_range`).
    a_max : ndarray of int64, shape (N + 1,)
        :func:`ltvmodels.core.segmentation.feasible_starts`.

    Returns
    -------
    ndarray, shape (stop − start + 1,)
    """
    N = data.shape[0]
    head, tail = search.split_costs(data, p)
    rows = np.arange(start, stop + 1)
    rss = head[rows] + tail[rows]
    with np.errstate(divide="ignore", invalid="ignore"):
        F = (head[N] - rss) / (rss / (n - 2 * p))
    feasible = (a_max[rows] >= 0) & (a_max[N] >= rows)
    return np.where(feasible, F, np.nan)


def aggregate(F: np.ndarray, kind: str) -> float:
    """supF, aveF or expF of the finite F statistics (expF as log mean exp(F/2), stably)."""
    F = F[np.isfinite(F)]
    if kind == "supF":
        return float(F.max())
    if kind == "aveF":
        return float(F.mean())
    half = 0.5 * F
    top = half.max()
    return float(top + np.log(np.mean(np.exp(half - top))))


def hansen_pvalue(
    statistic: float, kind: str, k: int, lam: float, *, monotone: bool = True
) -> float:
    """Hansen's (1997) approximate asymptotic p-value, as strucchange's ``pvalue.Fstats``.

    Hansen's aveF and expF polynomials are cubics that turn down beyond the
    range they were fitted on, so that strucchange's p-value rises back to 1
    for very large statistics; with ``monotone`` (the default) each polynomial
    is held at its peak beyond it, so the p-value is non-increasing in the
    statistic and equals strucchange's wherever strucchange's is.

    Parameters
    ----------
    statistic : float
        The supF, aveF or expF statistic.
    kind : {"supF", "aveF", "expF"}
    k : int
        Number of regressors, 1 … 40 (more are not tabulated: use 40).
    lam : float
        strucchange's λ (:func:`candidate_range`), or a trimming τ < 1 itself.
    monotone : bool, default True
        Hold the polynomials at their peaks (False: strucchange's values exactly).

    Returns
    -------
    float
        The p-value.
    """
    beta = hansen_table(kind)
    m = beta.shape[1] - 1
    tau = lam if lam < 1 else 1.0 / (1.0 + math.sqrt(lam))
    rows = beta[(k - 1) * _HANSEN_ROWS : k * _HANSEN_ROWS]
    x = float(statistic)
    at = np.full(_HANSEN_ROWS, x)
    if monotone:
        at = np.minimum(at, _hansen_peaks(kind)[(k - 1) * _HANSEN_ROWS : k * _HANSEN_ROWS])
    value = np.sum(rows[:, :m] * at[:, None] ** np.arange(m), axis=1)
    pp = stats.chi2.sf(np.maximum(value, 0.0), rows[:, m])
    if tau == 0.5:
        p = stats.chi2.sf(x, k)
    elif tau <= 0.01:
        p = pp[_HANSEN_ROWS - 1]
    elif tau >= 0.49:
        p = ((0.5 - tau) * pp[0] + (tau - 0.49) * stats.chi2.sf(x, k)) * 100
    else:
        position = (0.51 - tau) * 50
        below = int(math.floor(position))
        p = (below + 1 - position) * pp[below - 1] + (position - below) * pp[below]
    return float(np.clip(p, 0.0, 1.0))  # the interpolation's roundoff can pass 1


def fstats_pvalue(statistic: float, kind: str, k: int, n: int, lam: float) -> float:
    """strucchange's ``sctest.Fstats`` p-value: Chow's F(k, n − 2k) test with one
    candidate (λ = 1, supF and aveF), Hansen's otherwise (k capped at 40)."""
    if lam == 1 and kind != "expF":
        return float(stats.f.sf(statistic, k, n - 2 * k))
    return hansen_pvalue(statistic, kind, min(k, HANSEN_MAX_REGRESSORS), lam)


def critical_value(kind: str, k: int, n: int, lam: float, level: float) -> float:
    """The statistic whose :func:`fstats_pvalue` is ``level`` (the test's critical value)."""
    if lam == 1 and kind != "expF":
        return float(stats.f.isf(level, k, n - 2 * k))
    upper = 10.0 * k + 50.0
    while fstats_pvalue(upper, kind, k, n, lam) > level:
        upper *= 2.0
    return float(brentq(lambda x: fstats_pvalue(x, kind, k, n, lam) - level, 0.0, upper))


def bai_perron_critical_values(trim: float, q: int, level: float) -> np.ndarray:
    """Bai and Perron's (2003) critical values of supF(l + 1 | l) for l = 0 … 9.

    ``trim`` in :data:`SEQUENTIAL_TRIMS`, ``level`` in :data:`SEQUENTIAL_LEVELS`,
    q = 1 … 10 (checked by the caller). Returns ndarray, shape (10,).
    """
    table = _bai_perron_table()
    match = (
        np.isclose(table[:, 0], trim, rtol=0, atol=1e-9)
        & np.isclose(table[:, 1], level, rtol=0, atol=1e-9)
        & (table[:, 2] == q)
    )
    (row,) = np.flatnonzero(match)
    return table[row, 3:].copy()


def supf_next(
    data: np.ndarray,
    p: int,
    observed_rows: np.ndarray,
    changepoints: np.ndarray,
    h: int,
    a_max: np.ndarray,
) -> tuple[float, int]:
    """supF(l + 1 | l) given the l breaks ``changepoints`` (module docstring).

    Parameters
    ----------
    data : ndarray, shape (N, q, p + 1)
        Scaled rows [φ̃ ỹ].
    p : int
    observed_rows : ndarray of int, shape (N + 1,)
        Cumulative count of observed rows before each time step (T_i of a segment).
    changepoints : ndarray of int, shape (l,)
    h : int
        Minimum segment length (rows), for the segments and both sides of a split.
    a_max : ndarray of int64, shape (N + 1,)
        Feasible starts (:func:`ltvmodels.core.segmentation.feasible_starts`).

    Returns
    -------
    statistic : float
        0 when no segment has room for one more break.
    new_break : int
        The row where the added segment starts (−1 when there is none).
    """
    N = data.shape[0]
    bounds = np.concatenate([[0], np.asarray(changepoints, dtype=np.int64), [N]])
    best, where = 0.0, -1
    for a, b in zip(bounds[:-1], bounds[1:]):
        a, b = int(a), int(b)
        if b - a < 2 * h:
            continue
        head, tail = search.split_costs(data[a:b], p)
        splits = np.arange(h, b - a - h + 1)
        rss = head[splits] + tail[splits]
        feasible = (a_max[a + splits] >= a) & (a_max[b] >= a + splits)
        if not feasible.any():
            continue
        rss = np.where(feasible, rss, np.inf)
        i = int(np.argmin(rss))
        rows = int(observed_rows[b] - observed_rows[a])
        with np.errstate(divide="ignore", invalid="ignore"):
            F = (rows - 2 * p) * (head[b - a] - rss[i]) / rss[i]
        if F > best:
            best, where = float(F), a + int(splits[i])
    return best, where
