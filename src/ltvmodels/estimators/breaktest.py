"""Tests for structural breaks in a regression: supF, aveF, expF and the sequential test.

The numerics, with their sources (Andrews 1993; Andrews and Ploberger 1994;
Hansen 1997; Bai and Perron 1998, 2003), are in
:mod:`ltvmodels.core.breaktests`; the optimal segmentations of the sequential
test come from the exact dynamic program of :mod:`ltvmodels.core.segmentation`.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..core import breaktests
from ..core import segmentation as search
from ..core.problem import RegressionProblem
from ..errors import SingularProblemError, warn
from ..results.breaktest import BreakTest
from ..validation import options
from .recordings import regression_data

__all__ = ["break_test"]

DEFAULT_MAX_BREAKS = 5  # as the mbreaks package's m


def break_test(
    y: ArrayLike,
    phi: ArrayLike,
    *,
    kind: Literal["supF", "aveF", "expF", "sequential"] = "supF",
    trim: float = 0.15,
    max_breaks: int | None = None,
    weights: ArrayLike | None = None,
    regular: bool = True,
    level: float = 0.05,
) -> BreakTest:
    """Test a regression y_t = βᵀφ_t + e_t for structural breaks, as R's strucchange
    and Bai and Perron do.

    * ``kind="supF"``, ``"aveF"``, ``"expF"``: one break against none
      (Andrews 1993; Andrews and Ploberger 1994), as strucchange's
      ``sctest(Fstats(y ~ phi, from = trim), type = kind)``. For every
      candidate row c from ⌊trim · n⌋ (at least p + 1) to n − ⌊trim · n⌋ (at
      most n − p − 1) the statistic

          F_c = (RSS₀ − RSS_c) / (RSS_c / (n − 2p))

      compares the least-squares fit on all rows (RSS₀) with separate fits on
      rows [0, c) and [c, n) (RSS_c); supF = max F_c, aveF = mean F_c,
      expF = log mean exp(F_c / 2), with Hansen's (1997) approximate
      asymptotic p-values. All F_c cost O(n) together.
    * ``kind="sequential"``: Bai and Perron's (1998) sequential selection of
      the number of breaks. For l = 0, 1, …, given the optimal segmentation
      with l breaks and segments of at least h = ⌊trim · N⌋ rows (at least
      p + 1; the exact dynamic program of :func:`segment_regression`),
      supF(l + 1 | l) is the
      largest over its segments of (T_i − 2p)(C_i − C_i')/C_i', C_i the
      residual sum of squares of segment i (T_i rows) and C_i' that of its
      best split into two parts of at least h rows (the statistic of the
      mbreaks package without serial-correlation correction). The procedure
      stops at the first l whose statistic does not exceed Bai and Perron's
      (2003) critical value at ``level``; the number of breaks is that l.

    Parameters
    ----------
    y : array_like, shape (N,) or (N, 1)
        One output (a pandas Series keeps its time index; NaN marks a missing row).
    phi : array_like, shape (N, p) or (N,)
        Regressors (include a column of ones for a level).
    kind : {"supF", "aveF", "expF", "sequential"}, default "supF"
        The test.
    trim : float, default 0.15
        The trimming fraction in (0, 0.5) (strucchange's ``from``; Bai and
        Perron's ε). "sequential" has critical values for 0.05, 0.10, 0.15,
        0.20 and 0.25 only.
    max_breaks : int, optional
        "sequential" only: the most breaks to select, 1 … 10 (the tests are
        supF(l + 1 | l) for l < max_breaks). Default min(5, ⌊N / h⌋ − 1).
    weights : array_like, shape (N,), optional
        Weights >= 0 of the rows (weighted least squares).
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).
    level : float, default 0.05
        The significance level of ``reject`` and the critical values; for
        "sequential" one of 0.10, 0.05, 0.025, 0.01 (the tabulated ones).

    Returns
    -------
    BreakTest
        ``statistic``, ``pvalue`` (NaN for "sequential"), ``reject``,
        ``critical_value``; ``break_index`` / ``break_time`` and the F sequence
        ``f_statistics`` over ``f_rows`` (supF, aveF, expF); ``n_breaks``,
        ``statistics``, ``critical_values`` and ``breaks`` ("sequential").

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument): several outputs, an
        unknown kind, trim outside (0, 0.5), too few rows for one candidate
        break; for "sequential" a trim, level or number of regressors (p > 10)
        without critical values, or max_breaks beyond what the data hold.
    SingularProblemError
        The regressors are linearly dependent over the whole data set.

    Notes
    -----
    Missing rows (NaN) are left out of every fit and count neither in n nor
    in T_i, but the trimming counts rows of y (as :func:`segment_regression`).
    A candidate split whose segment has linearly dependent regressors has
    F = NaN and is left out of the statistics (strucchange would fit it with
    a rank-deficient least squares). p > 40 regressors use Hansen's p-values
    for 40, with a warning (as strucchange).

    Examples
    --------
    >>> import numpy as np
    >>> import ltvmodels as ltv
    >>> rng = np.random.default_rng(0)
    >>> y = np.r_[np.zeros(60), np.ones(60)] + 0.5 * rng.standard_normal(120)
    >>> r = ltv.break_test(y, np.ones(120))
    >>> r.break_index, r.pvalue < 0.01
    (60, True)
    """
    kind_name = options.break_test_kind(kind)
    trim = options.trim_fraction(trim)
    level = options.significance_level(level)
    problem, description = regression_data(y, phi, weights=weights, regular=regular)
    if problem.n != 1:
        raise ValueError(
            f"y: expected one output (one regression equation), received {problem.n} "
            "columns; test each output on its own"
        )
    scaled = search.scale_data(problem.y, problem.phi, problem.n_observed)
    N, p = problem.N, problem.p
    a_max = search.feasible_starts(scaled.data, p, 1, search.FEASIBILITY_TOL * N)
    if a_max[N] < 0:
        raise SingularProblemError(
            "phi: the regressors are linearly dependent over the whole data set (or "
            "numerically so), so no fit is unique; more excitation or fewer regressors is needed"
        )
    if kind_name == "sequential":
        return _sequential(problem, scaled, a_max, trim, max_breaks, level, description.time)
    if max_breaks is not None:
        raise TypeError(
            f"max_breaks: only the 'sequential' test selects a number of breaks; "
            f"kind={kind_name!r} tests one break against none, received "
            f"max_breaks={max_breaks!r}; leave it out or use kind='sequential'"
        )
    return _one_break(problem, scaled, a_max, kind_name, trim, level, description.time)


def _one_break(
    problem: RegressionProblem,
    scaled: search.ScaledData,
    a_max: np.ndarray,
    kind: str,
    trim: float,
    level: float,
    time: np.ndarray | None,
) -> BreakTest:
    """supF, aveF or expF (strucchange's ``Fstats`` and ``sctest``)."""
    N, p, n = problem.N, problem.p, problem.n_observed
    start, stop, lam = breaktests.candidate_range(N, trim, p)
    if start > stop or n <= 2 * p:
        raise ValueError(
            f"y: too few rows for a break test: {N} rows ({n} observed) with p = {p} "
            f"regressors leave no candidate break with at least {max(start, p + 1)} rows on "
            "each side and a residual degree of freedom; supply more rows or a smaller trim"
        )
    F = breaktests.f_statistics(scaled.data, p, n, start, stop, a_max)
    finite = np.isfinite(F)
    if not finite.any():
        raise ValueError(
            "phi: every candidate break leaves a segment with linearly dependent regressors; "
            "more excitation, fewer regressors or a larger trim is needed"
        )
    if not finite.all():
        warn(
            f"{int((~finite).sum())} of {F.size} candidate breaks leave a segment with "
            "linearly dependent regressors; their F statistics are NaN and left out",
            RuntimeWarning,
        )
    if p > breaktests.HANSEN_MAX_REGRESSORS:
        warn(
            f"no p-values are tabulated for p = {p} > {breaktests.HANSEN_MAX_REGRESSORS} "
            f"regressors; those for {breaktests.HANSEN_MAX_REGRESSORS} are used",
            RuntimeWarning,
        )
    statistic = breaktests.aggregate(F, kind)
    pvalue = breaktests.fstats_pvalue(statistic, kind, p, n, lam)
    rows = np.arange(start, stop + 1)
    return BreakTest(
        kind=kind,
        statistic=statistic,
        pvalue=pvalue,
        level=level,
        reject=bool(pvalue < level),
        critical_value=breaktests.critical_value(kind, p, n, lam, level),
        trim=trim,
        min_size=start,
        n_regressors=p,
        n_observations=n,
        break_index=int(rows[np.nanargmax(F)]),
        f_statistics=F,
        f_rows=rows,
        lam=float(lam),
        time=time,
    )


def _sequential(
    problem: RegressionProblem,
    scaled: search.ScaledData,
    a_max: np.ndarray,
    trim: float,
    max_breaks: Any,
    level: float,
    time: np.ndarray | None,
) -> BreakTest:
    """Bai and Perron's sequential supF(l + 1 | l) procedure."""
    N, p = problem.N, problem.p
    tabulated = [t for t in breaktests.SEQUENTIAL_TRIMS if abs(t - trim) < 1e-9]
    if not tabulated:
        raise ValueError(
            f"trim: the sequential test's critical values (Bai and Perron 2003) are tabulated "
            f"for trim in {breaktests.SEQUENTIAL_TRIMS}, received {trim!r}; use one of them "
            "(or kind='supF' for one break with any trim)"
        )
    levels = [a for a in breaktests.SEQUENTIAL_LEVELS if abs(a - level) < 1e-12]
    if not levels:
        raise ValueError(
            f"level: the sequential test's critical values are tabulated for levels "
            f"{breaktests.SEQUENTIAL_LEVELS}, received {level!r}; use one of them"
        )
    if p > breaktests.SEQUENTIAL_MAX_REGRESSORS:
        raise ValueError(
            f"phi: the sequential test's critical values are tabulated for at most "
            f"{breaktests.SEQUENTIAL_MAX_REGRESSORS} regressors, received p = {p}; use fewer "
            "regressors, or kind='supF' (p-values for up to 40)"
        )
    # as strucchange's from: at least p + 1 rows, so that every fit has a residual
    h = max(p + 1, int(np.floor(trim * N)))
    most = min(breaktests.SEQUENTIAL_MAX_BREAKS, N // h - 1)
    if most < 1 or problem.n_observed <= 2 * p:
        raise ValueError(
            f"y: too few rows for a break test: {N} rows ({problem.n_observed} observed) "
            f"cannot hold two segments of at least h = {h} rows (trim = {trim:g}) with a "
            "residual degree of freedom; supply more rows or a smaller trim"
        )
    if max_breaks is None:
        L = min(DEFAULT_MAX_BREAKS, most)
    else:
        L = options.integer(max_breaks, "max_breaks", 1)
        if L > most:
            raise ValueError(
                f"max_breaks: at most {most} breaks fit {N} rows in segments of at least "
                f"h = {h} rows (and the critical values stop at 10), received {L}; use "
                f"max_breaks <= {most} or a smaller trim"
            )
    best, starts = search.dynamic_program(scaled.data, p, L, h, a_max)
    observed_rows = np.concatenate([[0], np.cumsum(problem.observed.sum(axis=1))])
    table = breaktests.bai_perron_critical_values(tabulated[0], p, levels[0])
    statistics = np.full(L, np.nan)
    for breaks in range(L):
        if not np.isfinite(best[breaks]):
            break  # no feasible segmentation with l breaks: nothing to test from here on
        changepoints = search.backtrack_layers(starts, breaks)
        statistics[breaks], _ = breaktests.supf_next(
            scaled.data, p, observed_rows, changepoints, h, a_max
        )
    critical_values = table[:L]
    rejects = statistics > critical_values
    n_breaks = int(np.argmin(rejects)) if not rejects.all() else L
    decisive = min(n_breaks, L - 1)
    return BreakTest(
        kind="sequential",
        statistic=float(statistics[decisive]),
        pvalue=float("nan"),
        level=level,
        reject=n_breaks > 0,
        critical_value=float(critical_values[decisive]),
        trim=trim,
        min_size=h,
        n_regressors=p,
        n_observations=problem.n_observed,
        n_breaks=n_breaks,
        statistics=statistics,
        critical_values=critical_values,
        breaks=search.backtrack_layers(starts, n_breaks),
        time=time,
    )
