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
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceWarning, warn
from .losses import Loss, LossFit
from .penalties import Penalty
from .priorterms import PriorTerm
from .problem import RegressionProblem
from .sparse import solve_sparse
from .squared import SquaredSolver

__all__ = ["HUBER_EFFICIENCY", "MAD_TO_STD", "RobustSolution", "default_delta", "solve_robust"]

HUBER_EFFICIENCY = 1.345  # δ / σ of Huber's 95 %-efficient estimator
MAD_TO_STD = 1.4826  # σ / MAD of Gaussian noise
# Tolerance of the squared-loss sparse fit that starts a robust one: its residuals'
# MAD (the default δ) and a starting point need a few digits only.
START_TOL = 1e-3
# Residuals at most this fraction of the largest |y| are rounding: an exact fit.
EXACT_FIT = 1e-12


def default_delta(problem: RegressionProblem, theta: np.ndarray) -> np.ndarray:
    """1.345 × the robust scale (1.4826 · MAD) of each output's residuals of ``theta``
    (N, n, p), the squared-loss fit."""
    scale = np.where(problem.row_scale > 0, problem.row_scale, 1.0)[:, :, None]
    resid = (problem.residuals(theta) / scale)[problem.observed]  # (rows, n), units of y
    median = np.median(resid, axis=0)
    sigma = MAD_TO_STD * np.median(np.abs(resid - median), axis=0)
    rms = np.sqrt(np.mean(resid**2, axis=0))
    # More than half the residuals zero: the MAD is 0, fall back to the RMS; an exact
    # fit has nothing to be robust against (any δ gives the squared-loss fit).
    sigma = np.where(sigma > 0, sigma, np.where(rms > 0, rms, 1.0))
    return HUBER_EFFICIENCY * sigma


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
    """
    # the squared-loss fit starts the iteration (and gives the robust residual scale)
    if penalty.closed_form:
        start = SquaredSolver(problem, weights, []).solve(1.0)[0]
    else:
        with warnings.catch_warnings():  # only a starting point and a residual scale
            warnings.simplefilter("ignore", ConvergenceWarning)
            start = solve_sparse(
                problem, weights, penalty, max_iter=max_iter, tol=max(tol, START_TOL)
            ).theta
    rule = "given"
    if delta is None:
        delta = default_delta(problem, start)
        rule = "1.345 * 1.4826 * MAD of squared-loss residuals"
    if penalty.closed_form and not priors and _fits_exactly(problem, start):
        return _exact_fit(problem, weights, start, loss, delta, rule)
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
    return RobustSolution(**vars(result), delta_rule=rule)


def _fits_exactly(problem: RegressionProblem, theta: np.ndarray) -> bool:
    """No residual beyond rounding (EXACT_FIT relative to the largest |y|)."""
    scale = max(float(np.abs(problem.y).max(initial=0.0)), np.finfo(float).tiny)
    return bool(np.abs(problem.residuals(theta)).max(initial=0.0) <= EXACT_FIT * scale)


def _exact_fit(problem, W, theta, loss: Loss, delta, rule) -> RobustSolution:
    """The squared-loss fit when it leaves no residual: it minimizes the penalty with every
    residual zero (its stationarity is ∇P = 2Φᵀr = 0), so it minimizes any loss plus the
    penalty; the certificate is that zero gradient."""
    r = problem.residuals(theta)
    value = loss.value(r, problem.row_scale[:, :, None], delta)
    if loss.threshold:
        outliers = np.zeros(r.shape, dtype=bool)
        details = {"kkt_residual": 0.0, "huber_delta": delta.tolist(), "n_outliers": 0}
    else:
        outliers = None
        details = {"duality_gap": 0.0, "duality_gap_rigorous": True, "kkt_residual": 0.0}
    details["exact_fit"] = True
    return RobustSolution(
        theta=theta,
        objective=value + SquaredSolver(problem, W, []).penalty(theta),
        iterations=0,
        converged=True,
        stalled=False,
        solver="the squared-loss fit (no residual: optimal for any loss)",
        details=details,
        failure="",
        outliers=outliers,
        delta_rule=rule,
    )
