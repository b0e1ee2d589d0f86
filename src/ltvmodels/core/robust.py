"""A robust loss with any penalty: start from the squared-loss fit, then the loss's solver.

    minimize_k  Σ ρ(r) + P(k),   r = the residual entries of y − Θφ (rows scaled by √w),

with ρ a robust :class:`~.losses.Loss` ("huber", "laplace") and P the penalty
of the fit (:mod:`.penalties`): a squared-difference weight W (K,) or (K, K)
(norm "sq", and the LTI and piecewise fits, which hold every coefficient
constant with W = inf), or the weights (K,) of a sparse penalty. The
squared-loss fit starts the loss's solver and gives the default Huber
threshold: δ_i = 1.345 σ̂_i with σ̂_i the robust scale of the residuals of
output i, 1.4826 · MAD (95 % efficiency at Gaussian noise, Huber 1964);
residuals beyond δ count linearly, so a gross outlier moves the fit as little
as one δ away. The Laplacian loss counts every residual linearly.

The edges of the problem are solved directly: a squared-loss fit with no
residual is optimal for every loss (:func:`_exact_fit`); with a sparse
penalty and λ at or beyond the loss's own λ_max, the robust fit with Dk = 0
(the robust LTI fit for order 1) is the answer, computed as one static
problem and certified (:func:`_null_space_solution`), where the
interior-point method would face Newton systems scaled by λ. A given Huber
threshold must be at least DELTA_FLOOR × the robust scale of the squared-loss
residuals: below it Huber's loss is the Laplacian loss to working precision.

:func:`residual_outliers` marks the residual entries of any fit beyond
OUTLIER_THRESHOLD robust scales (``model.outliers``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numba
import numpy as np

from ..errors import ConvergenceWarning, SingularProblemError, warn
from .banded import solve_shared_rows
from .laplace import certified_gap
from .losses import Loss, LossFit
from .penalties import Penalty, named
from .precompiled import attach
from .priorterms import PriorTerm
from .problem import RegressionProblem, null_space_basis, output_spread
from .robust_scale import MAD_TO_STD, column_center_spread, median_in_place
from .sparse import solve_sparse
from .sparse_common import difference_preimage, null_space_fit
from .squared import SquaredSolver

__all__ = [
    "DELTA_FLOOR",
    "HUBER_EFFICIENCY",
    "MAD_TO_STD",
    "OUTLIER_THRESHOLD",
    "CLIP_SCALES",
    "RobustSolution",
    "default_delta",
    "residual_outliers",
    "solve_robust",
]

HUBER_EFFICIENCY = 1.345  # δ / σ of Huber's 95 %-efficient estimator
# Tolerance of the squared-loss sparse fit that starts a robust one: its residuals'
# MAD (the default δ) and a starting point need a few digits only.
START_TOL = 1e-3
# Residuals at most this fraction of the largest |y| are rounding: an exact fit.
EXACT_FIT = 1e-12
# The smallest Huber threshold, relative to the robust scale of the squared-loss
# residuals: measured on the jump-linear system, the sparse norms' solvers stall
# from about 5e-5 σ̂, where h_δ is |r| to within rounding of the residuals.
DELTA_FLOOR = 1e-4
# The robust fit with Dk = 0 is tried where the loss's λ_max, estimated at the
# least-squares fit with Dk = 0, is within this factor of λ (then certified).
NULL_SPACE_TRY = 10.0
# A residual entry beyond this many robust scales is an outlier: 2.576 is the
# two-sided 1 % point of the Gaussian; the margin covers the MAD's own
# estimation error (measured false-positive rates in tests/estimators/test_outliers.py).
OUTLIER_THRESHOLD = 3.0
# Outputs farther than this many robust scales (1.4826 · MAD of the column) from their
# column's median are drawn in to that distance before a robust fit (and the fit
# checked against the data as given, see solve_robust). The solvers' tolerances are
# relative to the objective, which one such entry dominates: on the jump-linear system
# (T = 200, λ = 5) a single output 1e5–1e8 times the data's scale already moved the
# sparse norms' Huber fits, and from 1e10 the interior-point method failed.
CLIP_SCALES = 1e3
# Residual entries within REPRODUCED × their output's residual RMS, or within
# ROUNDING × its largest |y|, are reproduced by the fit (a residual that a
# Laplace fit sets to zero, to its solver's tolerance, or rounding): they do not
# enter the scale (a Laplace fit with many degrees of freedom zeroes a third of
# them or more) and are never outliers. Gaussian noise falls below 1e-4 of its
# standard deviation with probability 8e-5.
REPRODUCED = 1e-4
ROUNDING = 1e-8


def default_delta(problem: RegressionProblem, theta: np.ndarray) -> np.ndarray:
    """1.345 × the robust scale (1.4826 · MAD) of each output's residuals of ``theta``
    (N, n, p), the squared-loss fit."""
    resid = problem.residuals(theta)
    scale = problem.row_scale[:, :, None]
    np.divide(resid, scale, out=resid, where=scale > 0)  # in the units of y
    n = problem.n
    median, mad, rms = np.empty(n), np.empty(n), np.empty(n)
    column_center_spread(resid, problem.observed, median, mad, rms)
    sigma = MAD_TO_STD * mad
    # More than half the residuals zero: the MAD is 0, fall back to the RMS; an exact
    # fit has nothing to be robust against (any δ gives the squared-loss fit).
    sigma = np.where(sigma > 0, sigma, np.where(rms > 0, rms, 1.0))
    return HUBER_EFFICIENCY * sigma


def residual_outliers(
    problem: RegressionProblem,
    theta: np.ndarray,
    threshold: float = OUTLIER_THRESHOLD,
    residuals: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The residual entries of ``theta`` (N, n, p) beyond ``threshold`` robust scales.

    The residuals are those of the weighted rows, √w (y − Θφ) (weights are
    inverse relative noise variances, so these have one variance per output).
    The robust scale of output i is σ̂_i = 1.4826 · median abs(r_ti) over its
    observed entries, about zero (the noise has mean zero under the model:
    an outlier is far from the model's prediction, not from the residuals'
    median), leaving out the entries the fit reproduces (within REPRODUCED ×
    the residuals' RMS or ROUNDING × the largest abs(y_i)). Returns the mask
    (N, q, n) of abs(r_ti) > threshold · σ̂_i (False where unobserved) and σ̂ (n,).
    ``residuals`` (N, q, n): ``problem.residuals(theta)`` where the caller has them.
    """
    r = problem.residuals(theta) if residuals is None else residuals
    mask = np.zeros(r.shape, dtype=np.bool_)
    sigma = np.zeros(r.shape[2])
    _outlier_mask(r, problem.y, problem.observed, threshold, mask, sigma)
    return mask, sigma


@numba.njit(cache=True)
def _outlier_mask(r, y, observed, threshold, mask, sigma):  # pragma: no cover - compiled
    """:func:`residual_outliers` on the residuals r (N, q, n): fills ``mask`` and ``sigma``.

    One compiled pass per output instead of a dozen array operations: a fit of a
    few hundred steps takes a fraction of a millisecond, and this runs after every
    fit.
    """
    N, q, n = r.shape
    values = np.empty(N * q)
    for i in range(n):
        # one strided pass: the sizes |r| of the observed entries, their RMS, the largest |y|
        total, largest, count = 0.0, 0.0, 0
        for t in range(N):
            for j in range(q):
                if observed[t, j]:
                    size = abs(r[t, j, i])
                    values[count] = size
                    total += size * size
                    largest = max(largest, abs(y[t, j, i]))
                    count += 1
        rms = np.sqrt(total / max(count, 1))
        floor = max(REPRODUCED * rms, ROUNDING * largest)
        kept = 0
        for index in range(count):  # the entries beyond the floor to the front, in place
            size = values[index]
            values[kept] = size
            kept += size > floor
        if kept == 0:
            continue
        sigma[i] = MAD_TO_STD * median_in_place(values[:kept])
        bound = max(threshold * sigma[i], floor)
        for t in range(N):
            for j in range(q):
                mask[t, j, i] = observed[t, j] and abs(r[t, j, i]) > bound


@dataclass
class RobustSolution(LossFit):
    """A robust-loss fit before it becomes a model (:func:`solve_robust`): the loss's
    solution and how its threshold δ was set."""

    delta_rule: str = "given"


def solve_robust(
    problem: RegressionProblem,
    weights: np.ndarray,
    *,
    loss: Loss,
    penalty: Penalty,
    delta: np.ndarray | None,
    max_iter: int,
    tol: float,
    priors: list[PriorTerm] | None = None,
    noise_var: np.ndarray | None = None,
) -> RobustSolution:
    """Minimize the robust ``loss`` plus ``penalty`` from the squared-loss fit.

    ``weights`` are the penalty's (W (K,) or (K, K) for the squared norm, whose
    inf entries hold coefficients constant; (K,) for a sparse penalty);
    ``delta`` the Huber thresholds (n,) (None: :func:`default_delta`). Warns
    (ConvergenceWarning) when the certificate does not reach ``tol``.

    ``priors`` (loss="huber", the squared norm) add σ_i² Σ_t (k_ti − m_ti)ᵀ P_t
    (k_ti − m_ti) per output, as in the squared loss's MAP estimate, with
    σ_i² = ``noise_var`` or, by default, the robust scale (δ_i / 1.345)².

    Outputs beyond CLIP_SCALES robust scales of their column are first drawn in
    to that distance (:func:`_clipped_outputs`): beyond δ the loss counts a
    residual linearly, so the minimizer depends only on its sign, and the
    solvers, whose tolerances are relative to the objective, keep the precision
    of the other samples. The clipped fit is the answer where every clipped
    entry's residual keeps its sign beyond δ (the optimality conditions are then
    those of the data as given; the objective is corrected for the clipped
    distance); otherwise the data are fitted as given.
    """

    def solve(data: RegressionProblem) -> tuple[RobustSolution, np.ndarray | None]:
        return _solve_robust(
            data,
            weights,
            loss=loss,
            penalty=penalty,
            delta=delta,
            max_iter=max_iter,
            tol=tol,
            priors=priors,
            noise_var=noise_var,
        )

    clipped = _clipped_outputs(problem)
    if clipped is not None:
        near, moved = clipped
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConvergenceWarning)
            solution, used = solve(near)
        threshold = used if loss.threshold else None
        scale = problem.row_scale[:, :, None]
        r_near, r_given = near.residuals(solution.theta), problem.residuals(solution.theta)
        same = loss.scaled_psi(r_near, scale, threshold) == loss.scaled_psi(
            r_given, scale, threshold
        )
        beyond = np.abs(r_near) > (threshold * scale if threshold is not None else 0.0)
        if np.all((same & beyond)[moved]):
            # Only the moved entries' losses differ, each by a constant.
            solution.objective += loss.value(
                np.where(moved, r_given, 0.0), scale, threshold
            ) - loss.value(np.where(moved, r_near, 0.0), scale, threshold)
            solution.details["clipped_outputs"] = int(np.count_nonzero(moved))
            for warning in caught:
                warn(str(warning.message), warning.category)
            return solution
    return solve(problem)[0]


def _clipped_outputs(problem: RegressionProblem) -> tuple[RegressionProblem, np.ndarray] | None:
    """The problem with every output entry beyond CLIP_SCALES robust scales of its column
    (:func:`~.problem.output_spread`) drawn in to that distance, and the mask (N, q, n)
    of those entries; None where there is none."""
    where = output_spread(problem)
    if where is None:
        return None
    moved = where.scales > CLIP_SCALES
    if not moved.any():
        return None
    reach = CLIP_SCALES * where.spread
    drawn = np.clip(where.given, where.center - reach, where.center + reach)
    clipped = RegressionProblem(
        y=np.where(moved, problem.row_scale[:, :, None] * drawn, problem.y),
        phi=problem.phi,
        coeffs=problem.coeffs,
        observed=problem.observed,
        row_scale=problem.row_scale,
        rows_are_samples=problem.rows_are_samples,
    )
    return clipped, moved


def _solve_robust(
    problem: RegressionProblem,
    weights: np.ndarray,
    *,
    loss: Loss,
    penalty: Penalty,
    delta: np.ndarray | None,
    max_iter: int,
    tol: float,
    priors: list[PriorTerm] | None = None,
    noise_var: np.ndarray | None = None,
) -> tuple[RobustSolution, np.ndarray | None]:
    """:func:`solve_robust` on the data as given.

    ``weights`` are the penalty's (W (K,) or (K, K) for the squared norm, whose
    inf entries hold coefficients constant; (K,) for a sparse penalty);
    ``delta`` the Huber thresholds (n,) (None: :func:`default_delta`). Warns
    (ConvergenceWarning) when the certificate does not reach ``tol``.

    ``priors`` (loss="huber", the squared norm) add σ_i² Σ_t (k_ti − m_ti)ᵀ P_t
    (k_ti − m_ti) per output, as in the squared loss's MAP estimate, with
    σ_i² = ``noise_var`` or, by default, the robust scale (δ_i / 1.345)².
    Returns the solution and the thresholds δ (n,) it used (None for a loss
    without one).
    """
    # the squared-loss fit starts the iteration (and gives the robust residual scale)
    if penalty.closed_form:
        start = _squared_fit(problem, weights)
    else:
        with warnings.catch_warnings():  # only a starting point and a residual scale
            warnings.simplefilter("ignore", ConvergenceWarning)
            start = solve_sparse(
                problem, weights, penalty, max_iter=max_iter, tol=max(tol, START_TOL)
            ).theta
    rule = "given"
    null_space = None  # the least-squares fit with Dk = 0 (sparse penalties)
    if not penalty.closed_form and (problem.degree == 1 or np.isfinite(weights).all()):
        null_space = null_space_fit(problem)
    exact = None
    if penalty.closed_form and not priors and _fits_exactly(problem, start):
        exact = start
    elif null_space is not None and _fits_exactly(problem, null_space):
        exact = null_space  # no residual and Dk = 0: the objective is 0, its minimum
    if delta is None:
        delta = default_delta(problem, exact if exact is not None else start)
        rule = "1.345 * 1.4826 * MAD of squared-loss residuals"
    elif exact is None:
        _check_delta(problem, start, delta)
    if exact is not None:
        return _exact_fit(problem, weights, penalty, exact, loss, delta, rule), delta
    if null_space is not None and np.all(weights > 0) and np.isfinite(weights).all():
        if _lambda_max_ratio(problem, null_space, loss, penalty, weights, delta) <= NULL_SPACE_TRY:
            solution = _null_space_solution(
                problem, weights, loss, penalty, delta, max_iter=max_iter, tol=tol
            )
            if solution is not None:
                return RobustSolution(**vars(solution), delta_rule=rule), delta
    prior_scale = None
    if priors:
        prior_scale = (
            (delta / HUBER_EFFICIENCY) ** 2 if noise_var is None else np.asarray(noise_var, float)
        )
    result = loss.fit(
        problem,
        weights,
        penalty,
        delta,
        max_iter=max_iter,
        tol=tol,
        start=start,
        priors=priors,
        prior_scale=prior_scale,
    )
    if not result.converged:
        remedy = (
            "it stopped at the limit of working precision; loosen tol"
            if result.stalled
            else "increase max_iter or loosen tol"
        )
        warn(
            f"loss={loss.name!r}: {result.failure}; the model is the last iterate: {remedy}",
            ConvergenceWarning,
        )
    return RobustSolution(**vars(result), delta_rule=rule), delta


def _squared_fit(problem: RegressionProblem, weights: np.ndarray) -> np.ndarray:
    """The squared-loss fit (N, n, p) for the squared norm's weight W (K,) or (K, K).

    Outputs that share one finite diagonal weight share one factorization, done
    on the raw arrays (:func:`~.banded.solve_shared_rows`, about half the time
    of the general solver at T = 1e5); other weights take :class:`SquaredSolver`.
    """
    n, p = problem.n, problem.p
    if weights.ndim == 1 and np.isfinite(weights).all():
        shared = weights[:p]
        if np.array_equal(weights.reshape(n, p), np.broadcast_to(shared, (n, p))):
            return solve_shared_rows(
                np.ascontiguousarray(problem.phi, dtype=float),
                np.ascontiguousarray(problem.y, dtype=float),
                shared,
                problem.coeffs,
                compute_cov=False,
            ).theta
    return SquaredSolver(problem, weights, []).solve(1.0)[0]


def _fits_exactly(problem: RegressionProblem, theta: np.ndarray) -> bool:
    """No residual beyond rounding (EXACT_FIT relative to the largest |y|)."""
    scale = max(float(np.abs(problem.y).max(initial=0.0)), np.finfo(float).tiny)
    return bool(np.abs(problem.residuals(theta)).max(initial=0.0) <= EXACT_FIT * scale)


def _check_delta(problem: RegressionProblem, start: np.ndarray, delta: np.ndarray) -> None:
    """A given Huber threshold is at least DELTA_FLOOR × the robust scale of the squared-loss
    residuals ``start`` (N, n, p) of its output."""
    sigma = default_delta(problem, start) / HUBER_EFFICIENCY
    low = delta < DELTA_FLOOR * sigma
    if np.any(low):
        i = int(np.flatnonzero(low)[0])
        raise ValueError(
            f"huber_delta: expected a threshold of at least {DELTA_FLOOR:g} × the robust scale "
            f"of the squared-loss residuals ({DELTA_FLOOR * sigma[i]:.3g} for output {i}), "
            f"received {delta[i]:.3g}; below it Huber's loss is the absolute value to working "
            "precision: pass loss='laplace', a larger huber_delta, or leave it out (1.345 × "
            "that scale)"
        )


def _lambda_max_ratio(problem, theta, loss: Loss, penalty: Penalty, weights, delta) -> float:
    """max_t R*((Dᵀ)⁺ Σ_j ψ(r_tj) φ_tj / weights) at Θ (N, n, p) with Dk = 0: at the loss's
    optimum with Dk = 0 this is λ_max / λ (Dk = 0 is optimal where it is <= 1); at
    another Θ, an estimate of it."""
    psi = loss.scaled_psi(problem.residuals(theta), problem.row_scale[:, :, None], delta)
    v = np.einsum("tji,tja->tia", psi, problem.phi).reshape(problem.N, problem.K)
    nu = difference_preimage(v, problem.coeffs)
    return float(penalty.dual_norms(nu / weights).max(initial=0.0))


def _null_space_solution(
    problem: RegressionProblem,
    weights: np.ndarray,
    loss: Loss,
    penalty: Penalty,
    delta: np.ndarray,
    *,
    max_iter: int,
    tol: float,
) -> LossFit | None:
    """The robust fit with Dk = 0 where it solves the problem with the sparse ``penalty``
    (λ at or beyond the loss's λ_max), certified; None where it does not.

    k_t = Σ_l U_tl γ_l over a basis U (N, d) of null(D) makes it one static
    problem with N·q rows and d·p regressors, every coefficient constant (as
    the robust piecewise fits). Its certificate for the sparse problem:
    Huber, :func:`_lambda_max_ratio` <= 1 at its solution (with its KKT
    residual); Laplace, the duality gap of its dual point for the sparse
    problem (:func:`~.laplace.certified_gap`) within ``tol``.
    """
    N, q, n, p = problem.N, problem.q, problem.n, problem.p
    U = null_space_basis(N, problem.coeffs)  # (N, d)
    d = U.shape[1]
    static = RegressionProblem(
        y=problem.y.reshape(1, N * q, n),
        phi=(U[:, None, :, None] * problem.phi[:, :, None, :]).reshape(1, N * q, d * p),
        coeffs=np.array([-1.0, 1.0]),
        observed=problem.observed.reshape(1, N * q),
        row_scale=problem.row_scale.reshape(1, N * q),
    )
    with warnings.catch_warnings():  # judged below by the certificate
        warnings.simplefilter("ignore", ConvergenceWarning)
        try:
            fit = solve_robust(
                static,
                np.full(n * d * p, np.inf),
                loss=loss,
                penalty=named("sq"),
                delta=delta,
                max_iter=max_iter,
                tol=tol,
            )
        except (SingularProblemError, ValueError):
            return None
    if not fit.converged:
        return None
    theta = np.ascontiguousarray(np.einsum("tl,ila->tia", U, fit.theta[0].reshape(n, d, p)))
    details = dict(fit.details)
    if loss.threshold:
        ratio = _lambda_max_ratio(problem, theta, loss, penalty, weights, delta)
        if ratio > 1.0:
            return None
        objective = loss.value(problem.residuals(theta), problem.row_scale[:, :, None], delta)
        details["lambda_max_ratio"] = ratio
    else:
        if fit.dual is None:
            return None
        psi = fit.dual.reshape(N, q, n)
        objective, gap, rigorous = certified_gap(problem, theta, psi, weights, penalty.name)
        if gap > tol:
            return None
        details.update(duality_gap=gap, duality_gap_rigorous=rigorous)
    details["null_space_fit"] = True
    return LossFit(
        theta=theta,
        objective=objective,  # the penalty of Dk = 0 is 0
        iterations=fit.iterations,
        converged=True,
        stalled=False,
        solver=f"the robust fit with Dk = 0 (lam >= the loss's lambda_max); {fit.solver}",
        details=details,
        failure="",
        beyond_delta=None if fit.beyond_delta is None else fit.beyond_delta.reshape(N, q, n),
    )


def _exact_fit(problem, W, penalty: Penalty, theta, loss: Loss, delta, rule) -> RobustSolution:
    """A squared-loss fit that leaves no residual: for the squared norm it minimizes the
    penalty with every residual zero (its stationarity is ∇P = 2Φᵀr = 0); for a sparse
    norm it is the fit with Dk = 0 (objective 0). Either minimizes any loss plus the
    penalty; the certificate is that zero gradient."""
    r = problem.residuals(theta)
    value = loss.value(r, problem.row_scale[:, :, None], delta)
    if loss.threshold:
        beyond = np.zeros(r.shape, dtype=bool)
        details = {"kkt_residual": 0.0, "huber_delta": delta.tolist(), "n_beyond_delta": 0}
    else:
        beyond = None
        details = {"duality_gap": 0.0, "duality_gap_rigorous": True, "kkt_residual": 0.0}
    details["exact_fit"] = True
    penalty_value = SquaredSolver(problem, W, []).penalty(theta) if penalty.closed_form else 0.0
    return RobustSolution(
        theta=theta,
        objective=value + penalty_value,
        iterations=0,
        converged=True,
        stalled=False,
        solver="the squared-loss fit (no residual: optimal for any loss)",
        details=details,
        failure="",
        beyond_delta=beyond,
        delta_rule=rule,
    )


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
