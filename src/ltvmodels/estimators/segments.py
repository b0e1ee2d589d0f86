"""Exact piecewise-constant segmentation with a known number of changes or a penalty.

Paper Section III-D (the problem with a known number of changes): with at most M time indices
where the model changes,

    minimize_Θ  Σ_t ‖y_t − Θ_t φ_t‖²   subject to   Σ_t 1{Θ_{t+1} ≠ Θ_t} <= M,

and the penalized form Σ_t ‖y_t − Θ_t φ_t‖² + β · #{t : Θ_{t+1} ≠ Θ_t}. Each
segment between two changes is one LTI model fitted by least squares, so both
problems are searches over change-point placements, solved exactly by
dynamic programming (fixed M) and PELT (penalty). The searches are in
:mod:`ltvmodels.core.segmentation`.

The squared loss cannot see a change of the noise level alone. With
``cost="normal"`` each segment s has its own noise variance per output and
the cost minimized is −2 × the maximized Gaussian log-likelihood (without the
constant N · n · log 2π),

    Σ_s Σ_{i=1}^{n} [ n_s log σ̂²_si + RSS_si / σ̂²_si ],  σ̂²_si = max(RSS_si / n_s, σ²_floor,i),

with n_s the observed rows of segment s and RSS_si the least-squares residual
sum of squares of its output i. The floor σ²_floor,i is 10⁻⁶ times a robust
noise variance of output i (:data:`VARIANCE_FLOOR`), so that a segment the
regression fits exactly costs a finite amount. Both costs are superadditive,
so both searches stay exact.

* :func:`fit_segments` — state-space front-end, returns an :class:`LTVModel`;
* :func:`segment_regression` — the same on any regression (y, φ) (AR, ARX or
  user-built regressors), returns a :class:`~ltvmodels.Segmentation`.
"""

from __future__ import annotations

import itertools
from dataclasses import replace
from functools import partial
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..core import partial_change
from ..core import segmentation as search
from ..core.breaks import information_criteria, segment_moments
from ..core.problem import RegressionProblem
from ..errors import SingularProblemError
from ..results.base import signal_names
from ..results.record import FitStatus
from ..results.regression import RegressionModel
from ..results.segmentation import Segmentation
from ..results.statespace import LTVModel
from ..validation import options
from ..validation.options import PenaltyRule, SegmentCost, SegmentCriterion
from .piecewise import fit_piecewise, piecewise_fit
from .recordings import regression_data, regression_problem, state_space_data

__all__ = ["fit_segments", "segment_regression", "noise_variance_estimate", "VARIANCE_FLOOR"]

VARIANCE_FLOOR = 1e-6
"""σ²_floor,i of ``cost="normal"`` as a fraction of output i's robust noise variance (the
median over windows of the least-squares residual variance, as in
:func:`noise_variance_estimate`): a segment whose noise standard deviation is below
10⁻³ times the typical one is costed as if it were that."""


def segment_regression(
    y: ArrayLike,
    phi: ArrayLike,
    *,
    n_changes: int | None = None,
    penalty: float | PenaltyRule | SegmentCriterion | None = None,
    min_size: int | None = None,
    weights: ArrayLike | None = None,
    regular: bool = True,
    trim: float | None = None,
    fixed: Any = None,
    cost: SegmentCost = "rss",
) -> Segmentation:
    """Optimal piecewise-constant segmentation of a regression y_t = Θ_t φ_t + e_t.

    The lower-level entry of :func:`fit_segments` for any regression (AR/ARX
    or user-built regressors). With ``n_changes=M`` it solves

        minimize  Σ_{t=0}^{N−1} ‖y_t − Θ_t φ_t‖²  subject to at most M indices c with Θ_c ≠ Θ_{c−1}

    by dynamic programming; with ``penalty=β`` it minimizes
    Σ_t ‖y_t − Θ_t φ_t‖² + β · (number of changes) by PELT. Both are exact
    (global optima); see :func:`fit_segments` for the details. With
    ``cost="normal"`` the residual sum of squares is replaced by the Gaussian
    −2 log-likelihood with a noise variance per segment and output, which also
    finds changes of the noise level (see ``cost``).

    With ``fixed`` columns (Bai and Perron's partial structural change) the
    model is y_t = Θ_j z_t + Γ x_t + e_t on segment j, z the changing and x the
    fixed regressors, Γ common to all segments, and the objective the total
    residual sum of squares over the break dates, Θ_1 … Θ_{M+1} and Γ. One
    change is found exactly (every admissible date, each with the joint least
    squares, O(N (p_z + p_x)²); :mod:`ltvmodels.core.partial_change`). More
    changes, and ``penalty``, use Bai and Perron's (2003) iterated procedure:
    alternate the exact search for the breaks of y − Γx on z (dynamic
    programming, or PELT) and the joint least squares of (Θ_j, Γ) given the
    breaks, until the objective decreases by less than 1e-10 of itself (at
    most 100 alternations). No step increases the objective, but the fixed
    point can be a local optimum: two starts are run and the better one kept,
    Γ of the joint fit at the full-change optimum with as many changes (as
    Bai and Perron) and Γ of the fit without changes. ``costs_by_n_changes[m]``
    is then exact for m <= 1 and the iterated optimum for m >= 2.

    Parameters
    ----------
    y : array_like, shape (N, n) or (N,)
        Outputs.
    phi : array_like, shape (N, p) or (N,)
        Regressors, shared by all output rows.
    n_changes : int, optional
        M >= 0, the largest number of changes.
    penalty : float or {"bic", "aic", "lwz"}, optional
        β >= 0 per change, or a rule (see :func:`fit_segments`). Default "bic"
        when neither ``n_changes`` nor ``penalty`` is given. With
        ``n_changes=M`` a criterion "bic", "aic" or "lwz" chooses the number of
        changes among 0 … M, as strucchange's ``breakpoints`` does with its BIC
        (:meth:`Segmentation.criteria`: the coefficients, the break dates and the
        noise variance counted).
    min_size : int, optional
        Minimum number of rows per segment, >= p (>= p + 1 with
        ``cost="normal"``). Default p (max(2p, p + 5) with ``cost="normal"``).
    trim : float, optional
        The minimum segment length as a fraction of the rows, in (0, 0.5):
        ⌊trim · N⌋ rows (at least p, or p + 1 with ``cost="normal"``),
        strucchange's ``h`` (Bai and Perron use 0.15). Give ``min_size`` or
        ``trim``, not both.
    weights : array_like, shape (N,) or (R, N), optional
        Weights >= 0 of the rows (y and phi may hold R series, (R, N, ·), and
        NaN for missing rows, as in :func:`ltvmodels.fit_regression`).
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).
    fixed : int, str or sequence of them, optional
        Regressor columns whose coefficients are common to all segments: indices
        into the columns of phi (negative ones count from the end, as in numpy)
        or column names of a pandas phi (default names "phi0", "phi1", …). At
        least one column must be left to change. ``min_size`` then defaults to,
        and must be at least, the number p_z of changing regressors, and
        segments are feasible when the changing regressors identify their
        coefficients.
    cost : {"rss", "normal"}, default "rss"
        The cost of a segment, as in :func:`fit_segments`: "rss" its residual
        sum of squares; "normal" Σ_i [n_s log σ̂²_i + RSS_i / σ̂²_i] with
        σ̂²_i = max(RSS_i / n_s, σ²_floor,i) over its n_s observed rows (a weight
        is a precision multiplier, each row counts once), −2 × the maximized
        Gaussian log-likelihood of the segment without the n_s · n · log 2π
        constant. ``Segmentation.cost``, ``costs_by_n_changes`` and ``penalty``
        are in the units of the cost; ``segment_variances`` holds the σ̂².

    Returns
    -------
    Segmentation
        With ``model``, the least-squares :class:`~ltvmodels.RegressionModel`
        on the segments (unshrunk segment levels, their covariances and the
        noise estimate; ``norm="l0"``), or None when the segments leave no
        residual degree of freedom.

    Raises
    ------
    ValueError, TypeError
        Invalid input, n_changes < 0 or too large for N and min_size, β < 0,
        both n_changes and penalty given, a ``fixed`` column repeated, out of
        range, unknown, or every column fixed.
    SingularProblemError
        The regressors are linearly dependent over the whole data set, so no
        segment is identifiable.
    """
    cost = options.segment_cost(cost)
    problem, description = regression_data(y, phi, weights=weights, regular=regular)
    names = description.names_of("regressor", problem.p) or signal_names("phi", problem.p)
    fixed_columns = options.fixed_columns(fixed, names, "the columns of phi")
    n_changing = problem.p - len(fixed_columns)
    smallest = options.smallest_segment(n_changing, cost)
    min_size = options.trimmed_min_size(trim, min_size, problem.N, smallest)
    result = _segment(
        problem, n_changes, penalty, min_size, cost=cost, data_name="y", fixed=fixed_columns
    )
    result = replace(result, time=description.time)
    if problem.n_observed <= (result.n_changes + 1) * n_changing + len(fixed_columns):
        return result  # no residual degree of freedom: no noise estimate, no model
    model = piecewise_fit(
        problem,
        result.changepoints,
        order=1,
        compute_cov=True,
        names=signal_names("phi", problem.p),
        loss="squared",
        delta=None,
        factory=partial(RegressionModel, n_outputs=problem.n, n_regressors=problem.p),
        fixed=fixed_columns,
    )
    model.data = description  # the model of this call
    moments = _moments(problem, result.changepoints, fixed_columns, model.k)
    result = replace(result, moments=moments)
    return replace(result, model=_segmentation_model(model, result))


def fit_segments(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
    n_changes: int | None = None,
    penalty: float | PenaltyRule | SegmentCriterion | None = None,
    min_size: int | None = None,
    compute_cov: bool = True,
    weights: ArrayLike | None = None,
    constant: bool = False,
    loss: Literal["squared"] = "squared",
    regular: bool = True,
    trim: float | None = None,
    fixed: Any = None,
    cost: SegmentCost = "rss",
) -> LTVModel:
    r"""Piecewise-constant LTV model with exactly optimal change points.

    With ``n_changes=M`` it finds the global optimum of the paper's problem
    with a known number of changes,

    .. math::

        \min_{k} \sum_{t=0}^{N-1} \lVert x_{t+1} - A_t x_t - B_t u_t \rVert_2^2
        \quad \text{subject to} \quad \sum_{t} \mathbf{1}\{k_t \neq k_{t-1}\} \le M,

    by Bellman's dynamic programming over segmentations (segment
    neighbourhood); with ``penalty=β`` the global optimum of the penalized
    problem

    .. math::

        \min_{k} \sum_{t=0}^{N-1} \lVert x_{t+1} - A_t x_t - B_t u_t \rVert_2^2
        + \beta \sum_{t} \mathbf{1}\{k_t \neq k_{t-1}\}

    by PELT
    (pruned dynamic programming, also exact). Each segment between two
    changes is one LTI model [A B] fitted by least squares (the n output rows
    share the regressor φ_t = [x_t; u_t], p = n + m).

    Cost of the search: the residual sum of squares of every candidate
    segment [a, b) is computed by a sequential QR update (one Givens row
    update per start, O(p (p + n)), shared by the n output rows; no normal
    equations and no differences of large prefix sums, so no cancellation).
    The dynamic program evaluates all N(N+1)/2 segments once, whatever M
    (for M = 1 one forward and one backward pass suffice: O(N)), and gives
    the optimal cost for every number of changes 0 … M; PELT
    evaluates only unpruned starts, near-linear when changes are frequent and
    up to quadratic when they are rare.

    Noise-level changes (``cost="normal"``): each segment gets its own noise
    variance per output and the search minimizes, exactly as well,

        Σ_s Σ_{i=1}^{n} [ n_s log σ̂²_si + RSS_si / σ̂²_si ]  (+ β · #changes),
        σ̂²_si = max(RSS_si / n_s, σ²_floor,i),

    −2 × the maximized Gaussian log-likelihood with a diagonal noise
    covariance per segment, without the constant N · n · log 2π (n_s: the
    observed transitions of segment s; RSS_si: the residual sum of squares of
    its output i, from the same QR updates). The floor σ²_floor,i =
    :data:`VARIANCE_FLOOR` · (output i's median windowed residual variance,
    as :func:`noise_variance_estimate` computes it) keeps a segment that fits
    exactly from a cost of −∞. The cost is a minimum over Θ and σ² >= floor of
    a sum of per-sample terms, hence superadditive, so PELT's pruning (K = 0,
    with the minimum size and feasibility rule of
    :mod:`ltvmodels.core.segmentation`) stays exact. The per-segment models
    are least squares as with "rss" (the maximum-likelihood Θ under either
    cost).

    Parameters
    ----------
    x : array_like, shape (T, n)
        States, time on axis 0 (lists and pandas DataFrames are accepted).
    u : array_like, shape (T, m) or (T,), optional
        Inputs.
    n_changes : int, optional
        M >= 0: at most M changes (the optimum uses exactly M unless fewer are
        strictly better, which only min_size or infeasible segments can
        cause). Needs (M + 1) · min_size <= N = T − 1.
    penalty : float or {"bic", "aic"}, optional
        β >= 0, the cost of one change in the units of the cost (the residual
        sum of squares, or with ``cost="normal"`` the −2 log-likelihood). With
        "rss" the rules scale with a noise variance estimate σ̂² per output
        (:func:`noise_variance_estimate`: median over short windows of the
        least-squares residual variance, so that the changes do not inflate
        it):

        * "bic" (the default when neither n_changes nor penalty is given):
          β = K · log(N) · σ̂², K = n·p the parameters of one more segment —
          the Bayesian information criterion RSS/σ² + (#parameters) · log N
          multiplied by σ² to be in the units of the cost;
        * "aic": β = 2 · K · σ̂².

        With ``n_changes=M`` instead a criterion, "bic", "aic" or "lwz" (Liu,
        Wu and Zidek's, as Bai and Perron), that chooses the number of changes
        among 0 … M from the optimal cost of each (the dynamic program's
        ``costs_by_n_changes``), with the noise variance estimated for each
        number and counted among the parameters, with the break dates, as R's
        strucchange does (:meth:`ltvmodels.Segmentation.criteria`).

        With ``cost="normal"`` the cost is a likelihood, so no σ̂²: "bic" is
        β = K · log N and "aic" β = 2K with K = n·p + n + 1, the coefficients,
        the noise variances and the date of one more segment.
    min_size : int, optional
        Minimum number of transitions per segment. Default p = n + m, the
        smallest size for which a segment's least squares is well posed;
        a segment of exactly p samples fits perfectly (zero cost), so with
        noisy data a larger min_size (say 2p to 5p) avoids short segments
        that only absorb outliers. With ``cost="normal"`` at least p + 1 (a
        segment of p samples has no noise variance), default max(2p, p + 5):
        at least max(p, 5) residual degrees of freedom per segment variance,
        whose log otherwise has a long lower tail that makes a short segment
        look like a quiet stretch. Segments whose regressors are numerically
        linearly dependent (smallest eigenvalue of their Gram matrix, with
        each regressor scaled to unit RMS over the whole data, at most
        1e-10 · N) are excluded as well.
    trim : float, optional
        The minimum segment length as a fraction of the N = T − 1 transitions,
        in (0, 0.5): ⌊trim · N⌋ (at least p, or p + 1 with ``cost="normal"``),
        as strucchange's ``h``. Give ``min_size`` or ``trim``, not both.
    compute_cov : bool, default True
        Compute the covariances of the per-segment estimates.
    loss : {"squared"}
        Only the squared loss: the exact dynamic program relies on segment
        costs that update in O(1) (QR row updates); for outliers refit the
        change points found with ``ltvmodels.fit(..., loss="huber")`` (or
        "laplace") by ``ltvmodels.fit_piecewise(..., loss=...)``.
    weights, constant
        As in :func:`ltvmodels.fit`; x and u may also hold R trajectories
        (each segment's cost sums over them) and NaN for missing samples.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).
    fixed : int, str or sequence of them, optional
        Columns of φ_t = [x_t; u_t (; 1)] whose coefficients are common to all
        segments (Bai and Perron's partial structural change; see
        :func:`segment_regression`): indices (negative from the end) or names,
        the state and input names (the columns of pandas x and u, else "x0", …,
        "u0", …) and "1" for the intercept of ``constant=True``. The fixed
        coefficient of column i is the same in every state equation's segments;
        ``min_size`` defaults to the number of changing regressors.
    cost : {"rss", "normal"}, default "rss"
        The cost of a segment: its residual sum of squares, or the Gaussian
        −2 log-likelihood with a noise variance per segment and output (see
        above), which also finds changes of the noise level alone.

    Returns
    -------
    LTVModel
        The least-squares model of each segment (built by
        :func:`ltvmodels.fit_piecewise` at the optimal change points, so
        ``cov``, ``noise_cov`` and ``loglik`` are as documented there),
        ``norm="l0"``, ``changepoints`` the optimal change points (index c
        means k_c ≠ k_{c−1}). ``info`` has, in addition to the keys of
        :func:`fit_piecewise`:

        * "cost": the optimal cost (the residual sum of squares, or the
          −2 log-likelihood without the 2π constant);
        * with ``cost="normal"`` only: "cost_name": "normal" (absent: the
          residual sum of squares) and "segment_variances": ndarray (M + 1, n),
          the σ̂² of each segment and output (the model's ``noise_var`` is one
          pooled variance per output);
        * "objective": cost, plus β · n_changes with a penalty;
        * "n_changes": the number of changes of the optimum;
        * "costs_by_n_changes" (with n_changes=M): ndarray (M + 1,), the
          optimal cost with exactly m changes, m = 0 … M (inf if infeasible);
        * "penalty": β (None with n_changes), "penalty_rule": "bic", "aic" or
          None, "noise_var_estimate": σ̂² of the rule (None otherwise);
        * "solver": "dynamic programming" or "PELT" (with ``fixed``: see
          :class:`~ltvmodels.Segmentation`); "min_size";
        * with ``fixed``: "fixed" (the column indices), "iterations",
          "converged" and "tolerance" of the iterated procedure.

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument): n_changes < 0 or
        more than the data can hold with min_size, β < 0, an unknown penalty
        rule or cost, min_size < p (<= p with "normal"), both n_changes and
        penalty given, too few samples.
    SingularProblemError
        The regressors are linearly dependent over the whole data set.

    Examples
    --------
    >>> import ltvmodels as ltv
    >>> data = ltv.systems.jump_linear(seed=0)
    >>> model = ltv.fit_segments(data.x, data.u, n_changes=1)
    >>> model.changepoints.tolist()
    [200]
    >>> model.info["costs_by_n_changes"].shape
    (2,)
    """
    if loss != "squared":
        raise ValueError(
            f"loss: fit_segments uses the squared loss only (its exact dynamic program relies "
            f"on it), received {loss!r}; for outliers use ltvmodels.fit(..., loss='huber')"
        )
    cost = options.segment_cost(cost)
    data = state_space_data(x, u, weights=weights, constant=constant, regular=regular)
    if not isinstance(compute_cov, bool):
        raise TypeError(f"compute_cov: expected True or False, received {compute_cov!r}")
    fixed_columns = options.fixed_columns(
        fixed, data.regressor_names, "the state, input and intercept names"
    )
    n_changing = data.problem.p - len(fixed_columns)
    smallest = options.smallest_segment(n_changing, cost)
    min_size = options.trimmed_min_size(trim, min_size, data.problem.N, smallest)
    result = _segment(
        data.problem, n_changes, penalty, min_size, cost=cost, data_name="x", fixed=fixed_columns
    )
    n_params = (result.n_changes + 1) * n_changing + len(fixed_columns)
    if data.problem.n_observed <= n_params:
        raise ValueError(
            f"penalty: the {result.n_changes + 1} segments found use "
            f"{n_params} coefficients per equation for {data.problem.n_observed} observed "
            "transitions, leaving no residual degree of freedom to estimate the noise; use a "
            f"larger penalty, fewer n_changes or min_size > {n_changing}"
        )
    if fixed_columns:
        model = piecewise_fit(
            data.problem,
            result.changepoints,
            order=1,
            compute_cov=compute_cov,
            names=data.regressor_names,
            loss="squared",
            delta=None,
            factory=partial(LTVModel, n_states=data.n, n_inputs=data.m, constant=data.constant),
            fixed=fixed_columns,
        )
        return _segmentation_model(data.describe(model), result)
    model = fit_piecewise(
        data.x,
        data.inputs,
        result.changepoints,
        order=1,
        compute_cov=compute_cov,
        weights=data.weights,
        constant=data.constant,
    )
    return _segmentation_model(data.describe(model), result)


def _segmentation_model(model: Any, result: Segmentation) -> Any:
    """The piecewise least-squares refit on ``result``'s segments, marked as the l0 optimum."""
    model.norm = "l0"
    model.status = FitStatus("optimal", result.solver, 0, result.objective)
    model.info.update(
        {
            "solver": result.solver,
            "cost": result.cost,
            "objective": result.objective,
            "n_changes": result.n_changes,
            "penalty": result.penalty,
            "penalty_rule": result.penalty_rule,
            "noise_var_estimate": result.noise_var,
            "min_size": result.min_size,
        }
    )
    if result.costs_by_n_changes is not None:
        model.info["costs_by_n_changes"] = result.costs_by_n_changes
    if result.fixed:
        model.info.update(
            {
                "fixed": list(result.fixed),
                "iterations": result.iterations,
                "converged": result.converged,
                "tolerance": result.tolerance,
            }
        )
    if result.cost_name != "rss":  # the default's info (and its files) stay as they were
        model.info["cost_name"] = result.cost_name
        model.info["segment_variances"] = result.segment_variances
    return model


def _moments(
    problem: RegressionProblem, changepoints: np.ndarray, fixed: tuple[int, ...], k: np.ndarray
) -> dict:
    """The segments' moments for the break-date intervals and the criteria.

    Without fixed regressors those of each segment's own least squares. With them
    (partial change, Bai and Perron 1998) those of the changing regressors z on
    y − Γ̂x, Γ̂ the common coefficients of the joint fit (the rows of ``k``, (N, n·p)):
    each segment's least squares there is the joint fit's Θ̂_j, its residuals the
    joint residuals, and the second moments are those of z, so that the intervals
    use the change of the changing coefficients only.
    """
    if not fixed:
        return segment_moments(problem.y, problem.phi, problem.observed, changepoints)
    index = np.array(fixed)
    changing = np.setdiff1d(np.arange(problem.p), index)
    gamma = np.asarray(k)[0].reshape(problem.n, problem.p)[:, index]  # (n, p_x)
    adjusted = problem.y - problem.phi[..., index] @ gamma.T
    return segment_moments(adjusted, problem.phi[..., changing], problem.observed, changepoints)


def noise_variance_estimate(y: ArrayLike, phi: ArrayLike, min_size: int | None = None) -> float:
    """Robust estimate of the noise variance σ² per output for the penalty rules.

    The rows are cut into consecutive windows of w = max(4p, 20, min_size)
    rows (the last window takes the remainder; one window if N < 2w); each
    window is fitted by least squares and gives s² = RSS / (n (w − p)). The
    estimate is the median of s² over the windows whose regressors have full
    rank, divided by the median of χ²_ν / ν (ν = n (w − p), Wilson–Hilferty
    (1 − 2/(9ν))³) so that it is unbiased for Gaussian noise. Windows that
    straddle a change are few and do not move the median, unlike the LTI
    residual variance, which the changes inflate. Floored at 1e-12 times the
    mean square of y.

    Parameters
    ----------
    y : array_like, shape (N, n) or (N,)
        Outputs.
    phi : array_like, shape (N, p) or (N,)
        Regressors.
    min_size : int, optional
        Minimum segment size; windows are at least this long.

    Returns
    -------
    float
        σ̂², in the units of y².
    """
    problem = regression_problem(y, phi)
    min_size = options.optional_integer(min_size, "min_size", 1)
    return _noise_variance(problem, min_size, remedy="y: more samples")


def _noise_variance(problem: RegressionProblem, min_size: int | None, remedy: str) -> float:
    """:func:`noise_variance_estimate` on a validated problem (windows of time steps).

    ``remedy`` ("argument: what to do") ends the error when no window can be fitted.
    """
    n, p, y = problem.n, problem.p, problem.y
    ratios, dofs = [], []
    for resid, rows in _window_fits(problem, min_size):
        dof = n * (rows - p)
        ratios.append(float(np.sum(resid**2)) / dof)
        dofs.append(dof)
    if not ratios:
        argument, _, advice = remedy.partition(": ")
        raise ValueError(
            f"{argument}: the noise variance cannot be estimated: no window of the data has "
            f"more samples than the p = {p} regressors and full rank; {advice}"
        )
    nu = float(np.median(dofs))
    sigma2 = float(np.median(ratios)) / (1.0 - 2.0 / (9.0 * nu)) ** 3
    return max(sigma2, 1e-12 * float(np.sum(y**2)) / max(problem.n_observed * n, 1))


def _window_fits(problem: RegressionProblem, min_size: int | None):
    """The least-squares residuals (rows·q, n) and observed rows of each window of
    :func:`noise_variance_estimate` with more rows than regressors and full rank."""
    N, n, p = problem.N, problem.n, problem.p
    y, phi, observed = problem.y, problem.phi, problem.observed
    w = max(4 * p, 20, min_size or 0)
    if N < 2 * w:
        bounds = [0, N]
    else:  # windows of w rows, the last one takes the remainder (w <= length < 2w)
        bounds = [i * w for i in range(N // w)] + [N]
    for a, b in itertools.pairwise(bounds):
        rows = int(observed[a:b].sum())
        if rows <= p:
            continue
        phi_w, y_w = phi[a:b].reshape(-1, p), y[a:b].reshape(-1, n)
        coef, _, rank, _ = np.linalg.lstsq(phi_w, y_w, rcond=None)
        if rank < p:
            continue
        yield y_w - phi_w @ coef, rows


def _variance_floor(problem: RegressionProblem, min_size: int) -> np.ndarray:
    """σ²_floor (n,) of ``cost="normal"``: :data:`VARIANCE_FLOOR` times each output's
    median windowed residual variance (the windows of :func:`noise_variance_estimate`,
    which the changes do not inflate, unlike the whole data's residual or variance).

    Where that median is zero (most windows fit exactly) the mean over the windows is
    used, then the mean square of the output, then 1: the floor must be positive.
    """
    n, p = problem.n, problem.p
    ratios = [
        np.sum(resid**2, axis=0) / (rows - p) for resid, rows in _window_fits(problem, min_size)
    ]
    scale = np.zeros(n)
    if ratios:
        stacked = np.array(ratios)
        scale = np.median(stacked, axis=0)
        scale = np.where(scale > 0, scale, stacked.mean(axis=0))
    mean_square = np.sum(problem.y**2, axis=(0, 1)) / max(problem.n_observed, 1)
    scale = np.where(scale > 0, scale, mean_square)
    return VARIANCE_FLOOR * np.where(scale > 0, scale, 1.0)


# -- shared driver -----------------------------------------------------------------------


def _segment(
    problem: RegressionProblem,
    n_changes: Any,
    penalty: Any,
    min_size: Any,
    *,
    cost: SegmentCost,
    data_name: str,
    fixed: tuple[int, ...] = (),
) -> Segmentation:
    """Validate the options and run the dynamic program or PELT on a validated problem
    (with ``fixed`` columns, validated: the partial-change searches; ``cost`` validated by
    the caller)."""
    N, n, p = problem.N, problem.n, problem.p
    y, phi = problem.y, problem.phi
    if fixed and cost != "rss":
        raise ValueError(
            f"fixed, cost: the partial structural-change search minimizes the residual sum "
            f"of squares only, received fixed columns {list(fixed)} with cost={cost!r}; use "
            "cost='rss' with fixed, or segment with cost='normal' without fixed"
        )
    criterion = options.segment_criterion(n_changes, penalty, cost)
    options.segment_mode(n_changes, None if criterion else penalty)
    min_size = options.segment_min_size(min_size, p - len(fixed), cost)
    options.segmentable_length(N, min_size, data_name)
    if n_changes is not None:
        M = options.n_changes_count(n_changes, N, min_size)
        beta_spec: float | str | None = None
    else:
        M = -1
        beta_spec = options.segment_penalty("bic" if penalty is None else penalty)

    if problem.n_observed < p:
        raise ValueError(
            f"{data_name}: too few observed samples: {problem.n_observed} complete rows "
            f"cannot determine the p = {p} regressors of one segment"
        )
    scaled = search.scale_data(y, phi, problem.n_observed)
    a_max = search.feasible_starts(scaled.data, p, min_size, search.FEASIBILITY_TOL * N)
    if a_max[N] < 0:
        raise SingularProblemError(
            f"{data_name}: the regressors are linearly dependent over the whole data set (or "
            "numerically so), so no segment has a unique least-squares model; more excitation "
            "or fewer regressors is needed"
        )
    unit = scaled.y_scale**2
    if fixed:
        penalty_value = (
            None
            if beta_spec is None
            else _penalty_value(problem, beta_spec, min_size, data_name, p - len(fixed))
        )
        partial_result = _segment_partial(
            problem, scaled, fixed, M, penalty_value, min_size, a_max, criterion
        )
        return replace(partial_result, fixed=fixed)
    normal = cost == "normal"
    # n_s of a segment [a, b) is counts[b] − counts[a]: the observed rows, not weight sums
    counts = np.zeros(N + 1, dtype=np.int64)
    np.cumsum(np.count_nonzero(problem.observed, axis=1), out=counts[1:])
    floor = _variance_floor(problem, min_size) if normal else np.ones(n)
    kernel_cost = (search.NORMAL, counts, floor / unit) if normal else (search.RSS, counts, floor)
    # the Gaussian cost of the scaled data is shifted by n_s · n · log y_scale² per segment
    shift = problem.n_observed * n * np.log(unit) if normal else 0.0

    if beta_spec is None:  # n_changes given: M >= 0 changes
        if M == 1:  # O(N): one forward and one backward pass
            best, starts = search.one_change(scaled.data, p, a_max, *kernel_cost)
        else:
            best, starts = search.dynamic_program(scaled.data, p, M, min_size, a_max, *kernel_cost)
        costs = best + shift if normal else best * unit
        m_opt = _number_of_changes(costs, problem, criterion, n_changing=p, cost=cost)
        changepoints = search.backtrack_layers(starts, m_opt)
        total = float(costs[m_opt])
        result: dict[str, Any] = dict(
            cost=total,
            objective=total,
            costs_by_n_changes=costs,
            penalty=None,
            penalty_rule=criterion,
            noise_var=None,
            solver="dynamic programming",
            work=2 * N if M == 1 else N * (N + 1) // 2,
        )
    else:
        rule: str | None
        if isinstance(beta_spec, str) and normal:  # a likelihood: no noise variance scaling
            K = n * p + n + 1  # coefficients, noise variances and date of one more segment
            beta = K * np.log(N) if beta_spec == "bic" else 2.0 * K
            sigma2, rule = None, beta_spec
        else:
            beta, sigma2, rule = _penalty_value(problem, beta_spec, min_size, data_name, p)
        if normal:  # roundoff of a sum of n_s · n terms of size about 1 + |log σ²|
            size = 1.0 + abs(float(np.log(floor.min() / unit))) + np.log(problem.n_observed * n)
            margin = search.PRUNE_MARGIN * problem.n_observed * n * size
            beta_scaled = beta
        else:
            margin = search.PRUNE_MARGIN * float(np.sum(scaled.data[..., p:] ** 2))
            beta_scaled = beta / unit
        last, _, work = search.pelt(
            scaled.data, p, beta_scaled, min_size, a_max, margin, *kernel_cost
        )
        changepoints = search.backtrack_last(last)
        # the cost itself, not objective − β·M (which cancels when β dominates)
        if normal:
            total = _normal_cost(problem, changepoints, floor)
        else:
            total = float(_segment_residuals(problem, changepoints)[0].sum())
        objective = total + beta * len(changepoints)
        result = dict(
            cost=total,
            objective=objective,
            costs_by_n_changes=None,
            penalty=float(beta),
            penalty_rule=rule,
            noise_var=sigma2,
            solver="PELT",
            work=int(work),
        )
    bounds = np.concatenate([[0], changepoints, [N]])
    return Segmentation(
        changepoints=changepoints,
        segments=[[int(a), int(b)] for a, b in itertools.pairwise(bounds)],
        n_changes=len(changepoints),
        min_size=min_size,
        cost_name=cost,
        segment_variances=_segment_variances(problem, changepoints, floor) if normal else None,
        **result,
    )


def _number_of_changes(
    costs: np.ndarray,
    problem: RegressionProblem,
    criterion: str | None,
    *,
    n_changing: int,
    n_fixed: int = 0,
    cost: str = "rss",
) -> int:
    """The number of changes of the optimum among 0 … M (``costs`` the optimal cost of
    each): the one ``criterion`` picks (:func:`ltvmodels.core.breaks.information_criteria`),
    or, without one, the largest within roundoff of the lowest cost (exactly M in the
    usual case)."""
    if criterion is not None:
        table = information_criteria(
            costs, problem.n_observed, problem.n, n_changing, n_fixed, cost
        )
        return int(table[f"best_{criterion}"])
    finite = np.isfinite(costs)
    lowest = costs[finite].min()
    if cost == "normal":  # a log-likelihood: its roundoff scales with the number of terms
        tol = 1e-12 * (abs(lowest) + problem.n_observed * problem.n)
    else:
        tol = 1e-12 * lowest + 1e-14 * float(np.sum(problem.y**2))
    return int(np.flatnonzero(finite & (costs <= lowest + tol)).max())


def _penalty_value(
    problem: RegressionProblem,
    beta_spec: float | str,
    min_size: int,
    data_name: str,
    n_changing: int,
) -> tuple[float, float | None, str | None]:
    """β in the units of the cost, the noise variance of its rule and the rule's name.

    A rule counts the K = n · ``n_changing`` coefficients one more segment adds.
    """
    if not isinstance(beta_spec, str):
        return float(beta_spec), None, None
    sigma2 = _noise_variance(
        problem,
        min_size,
        remedy=f"{data_name}: more samples, or a number for "
        f"penalty (the rule {beta_spec!r} needs the noise variance)",
    )
    K = problem.n * n_changing
    N = problem.N
    beta = K * np.log(N) * sigma2 if beta_spec == "bic" else 2.0 * K * sigma2
    return float(beta), sigma2, beta_spec


# -- partial structural change (fixed regressors) -------------------------------------------


def _segment_partial(
    problem: RegressionProblem,
    scaled: search.ScaledData,
    fixed: tuple[int, ...],
    M: int,
    penalty_value: tuple[float, float | None, str | None] | None,
    min_size: int,
    a_max_full: np.ndarray,
    criterion: str | None,
) -> Segmentation:
    """The partial structural-change searches (see :func:`segment_regression`).

    ``M`` changes (exact for M <= 1, iterated beyond; the number chosen among
    0 … M by ``criterion`` when given) or, with ``penalty_value`` (β, σ̂², rule),
    the iterated PELT. ``a_max_full`` is the feasibility of the whole regressor
    set, for the full-change start.
    """
    N, n, p = problem.N, problem.n, problem.p
    index = np.array(fixed)
    changing = np.setdiff1d(np.arange(p), index)
    pz, px = changing.size, index.size
    order = np.concatenate([changing, index, p + np.arange(n)])
    data = np.ascontiguousarray(scaled.data[..., order])  # rows [z̃ x̃ ỹ]
    tau = search.FEASIBILITY_TOL * N
    no_gamma = np.zeros((n, px))
    a_max = search.feasible_starts(
        partial_change.adjusted_data(data, pz, px, no_gamma), pz, min_size, tau
    )
    unit = scaled.y_scale**2
    rss0, factor0 = partial_change.joint_fit(data, pz, px, np.array([0, N]))
    gamma_lti = partial_change.fixed_solution(factor0, px)
    work = 0

    def alternate(start_gamma, start_changepoints, start_objective, m, beta):
        nonlocal work
        run = partial_change.alternate(
            data,
            pz,
            px,
            start_gamma,
            start_changepoints,
            start_objective,
            n_changes=m,
            beta=beta,
            min_size=min_size,
            a_max=a_max,
        )
        work += run.work
        return run

    def joint(changepoints):
        bounds = np.concatenate([[0], changepoints, [N]])
        rss, factor = partial_change.joint_fit(data, pz, px, bounds)
        return rss, partial_change.fixed_solution(factor, px)

    no_breaks = np.zeros(0, dtype=np.int64)
    if penalty_value is None:
        costs = np.full(M + 1, np.inf)
        runs: list[partial_change.Alternation | None] = [None] * (M + 1)
        costs[0] = rss0
        runs[0] = partial_change.Alternation(no_breaks, rss0, 0, True, [rss0])
        if M >= 1:  # exact: every break date with the joint least squares
            profile, _ = partial_change.one_change_partial(data, pz, px, a_max)
            work += 2 * N
            k = int(np.argmin(profile))
            if np.isfinite(profile[k]):
                costs[1] = profile[k]
                runs[1] = partial_change.Alternation(
                    np.array([k], dtype=np.int64), profile[k], 0, True, []
                )
        if M >= 2:
            full, full_starts = search.dynamic_program(scaled.data, p, M, min_size, a_max_full)
            work += N * (N + 1) // 2
            for m in range(2, M + 1):
                candidates = [alternate(gamma_lti, None, np.inf, m, None)]
                if np.isfinite(full[m]):  # Bai and Perron's start: the full-change optimum
                    start = search.backtrack_layers(full_starts, m)
                    rss, gamma = joint(start)
                    candidates.append(alternate(gamma, start, rss, m, None))
                run = min(candidates, key=lambda candidate: candidate.objective)
                if np.isfinite(run.objective):
                    costs[m], runs[m] = run.objective, run
        costs = costs * unit
        m_opt = _number_of_changes(costs, problem, criterion, n_changing=pz, n_fixed=px, cost="rss")
        chosen = runs[m_opt]
        assert chosen is not None  # a finite cost has its run
        cost = float(costs[m_opt])
        result: dict[str, Any] = dict(
            cost=cost,
            objective=cost,
            costs_by_n_changes=costs,
            penalty=None,
            penalty_rule=criterion,
            noise_var=None,
        )
        exact = m_opt <= 1
    else:
        beta, sigma2, rule = penalty_value
        margin = search.PRUNE_MARGIN * float(np.sum(scaled.data[..., p:] ** 2))
        last, _, rows = search.pelt(scaled.data, p, beta / unit, min_size, a_max_full, margin)
        work += int(rows)
        start = search.backtrack_last(last)
        rss, gamma = joint(start)
        candidates = [
            alternate(gamma_lti, None, np.inf, 0, beta / unit),
            alternate(gamma, start, rss + beta / unit * len(start), 0, beta / unit),
        ]
        chosen = min(candidates, key=lambda candidate: candidate.objective)
        cost = float(joint(chosen.changepoints)[0] * unit)
        result = dict(
            cost=cost,
            objective=cost + beta * len(chosen.changepoints),
            costs_by_n_changes=None,
            penalty=float(beta),
            penalty_rule=rule,
            noise_var=sigma2,
        )
        exact = False
    changepoints = np.asarray(chosen.changepoints, dtype=np.int64)
    bounds = np.concatenate([[0], changepoints, [N]])
    if exact:
        solver = "dynamic programming (partial, exact)"
    elif penalty_value is None:
        solver = "iterated dynamic programming (Bai–Perron)"
    else:
        solver = "iterated PELT (Bai–Perron)"
    return Segmentation(
        changepoints=changepoints,
        segments=[[int(a), int(b)] for a, b in itertools.pairwise(bounds)],
        n_changes=len(changepoints),
        min_size=min_size,
        solver=solver,
        work=work,
        iterations=chosen.iterations,
        converged=chosen.converged,
        tolerance=None if exact else partial_change.TOLERANCE,
        **result,
    )


def _segment_residuals(
    problem: RegressionProblem, changepoints: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each segment's least-squares residual sum of squares per output (M + 1, n), by QR,
    and its observed rows (M + 1,)."""
    y, phi, observed = problem.y, problem.phi, problem.observed
    bounds = np.concatenate([[0], changepoints, [y.shape[0]]])
    rss, rows = [], []
    for a, b in itertools.pairwise(bounds):
        phi_s, y_s = phi[a:b].reshape(-1, phi.shape[2]), y[a:b].reshape(-1, y.shape[2])
        q, _ = np.linalg.qr(phi_s)
        rss.append(np.sum((y_s - q @ (q.T @ y_s)) ** 2, axis=0))
        rows.append(np.count_nonzero(observed[a:b]))
    return np.array(rss), np.array(rows)


def _segment_variances(
    problem: RegressionProblem, changepoints: np.ndarray, floor: np.ndarray
) -> np.ndarray:
    """σ̂² = max(RSS / n_s, σ²_floor) of each segment and output, (M + 1, n)."""
    rss, rows = _segment_residuals(problem, changepoints)
    return np.maximum(rss / rows[:, None], floor)


def _normal_cost(problem: RegressionProblem, changepoints: np.ndarray, floor: np.ndarray) -> float:
    """Σ_s Σ_i n_s log σ̂²_si + RSS_si / σ̂²_si, the Gaussian cost of a segmentation."""
    rss, rows = _segment_residuals(problem, changepoints)
    variances = np.maximum(rss / rows[:, None], floor)
    return float(np.sum(rows[:, None] * np.log(variances) + rss / variances))
