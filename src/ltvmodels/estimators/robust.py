"""loss="huber" and loss="laplace": models robust to outliers.

The solvers are :mod:`ltvmodels.core.huber` (norm="sq"),
:mod:`ltvmodels.core.huber_sparse` (norm="group"/"l1") and
:mod:`ltvmodels.core.laplace`. The default Huber threshold is
δ_i = 1.345 σ̂_i with σ̂_i the robust scale of the squared-loss fit's residuals
of output i, 1.4826 · MAD (95 % efficiency at Gaussian noise, Huber 1964);
residuals beyond δ count linearly, so a gross outlier moves the fit as little
as one δ away. The Laplacian loss Σ w|r| counts every residual linearly.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from ..core.huber import HuberFit, fit_huber, huber_loss
from ..core.huber_sparse import SparseHuberFit, fit_huber_sparse
from ..core.laplace import LaplaceFit, fit_laplace
from ..core.priorterms import PriorTerm
from ..core.problem import RegressionProblem, activation
from ..core.sparse import solve_sparse
from ..core.squared import SquaredSolver
from ..errors import ConvergenceWarning, warn
from ..results.record import FitRecord, FitStatus, iterative_status
from ..results.regression import RegressionModel
from .changepoints import MAD_TO_STD, find_changepoints, residue_level

__all__ = [
    "default_delta",
    "RobustSolution",
    "solve_robust",
    "loss_value",
    "robust_record_parts",
    "robust_model",
]

HUBER_EFFICIENCY = 1.345  # δ / σ of Huber's 95 %-efficient estimator
# Tolerance of the squared-loss sparse fit that starts a robust one: its residuals'
# MAD (the default δ) and a starting point need a few digits only.
START_TOL = 1e-3
# Residuals at most this fraction of the largest |y| are rounding: an exact fit.
EXACT_FIT = 1e-12

ModelT = TypeVar("ModelT", bound=RegressionModel)  # the model the caller's factory builds


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
class RobustSolution:
    """A robust-loss fit before it becomes a model (:func:`solve_robust`)."""

    theta: np.ndarray  # (N, n, p)
    objective: float
    iterations: int
    converged: bool
    stalled: bool
    solver: str
    details: dict  # the certificate and loss-specific numbers (FitStatus.details)
    outliers: np.ndarray | None  # (N, q, n) mask of residuals beyond δ (Huber)
    delta_rule: str


def solve_robust(
    problem: RegressionProblem,
    penalty: np.ndarray,
    *,
    loss: str,
    norm: str,
    delta: np.ndarray | None,
    max_iter: int,
    tol: float,
    priors: list[PriorTerm] | None = None,
    noise_var: np.ndarray | None = None,
) -> RobustSolution:
    """Minimize the robust loss plus the penalty of ``norm`` from the squared-loss fit.

    ``penalty`` is the weight W (K,) or (K, K) of a squared-difference penalty
    (norm "sq", or any other name: LTI and piecewise fits pass W = inf), or
    the sparse weights (K,) of "group"/"l1"; ``delta`` the Huber thresholds
    (n,) (None: :func:`default_delta`). Warns (ConvergenceWarning) when the
    certificate does not reach ``tol``.

    ``priors`` (loss="huber", a squared-difference penalty) add
    σ_i² Σ_t (k_ti − m_ti)ᵀ P_t (k_ti − m_ti) per output, as in the squared
    loss's MAP estimate, with σ_i² = ``noise_var`` or, by default, the robust
    scale (δ_i / 1.345)².
    """
    sparse = norm in ("group", "l1")
    # the squared-loss fit starts the iteration (and gives the robust residual scale)
    if not sparse:
        start = SquaredSolver(problem, penalty, []).solve(1.0)[0]
    else:
        with warnings.catch_warnings():  # only a starting point and a residual scale
            warnings.simplefilter("ignore", ConvergenceWarning)
            start = solve_sparse(
                problem, penalty, norm, max_iter=max_iter, tol=max(tol, START_TOL)
            ).theta
    rule = "given"
    if delta is None:
        delta = default_delta(problem, start)
        rule = "1.345 * 1.4826 * MAD of squared-loss residuals"
    if not sparse and not priors and _fits_exactly(problem, start):
        return _exact_fit(problem, penalty, start, loss, delta, rule)
    outliers = None
    result: LaplaceFit | HuberFit | SparseHuberFit
    if loss == "laplace":
        result = fit_laplace(
            problem,
            penalty,
            norm if sparse else "sq",
            delta,
            max_iter=max_iter,
            tol=tol,
            start=start,
        )
        solver = result.method + (", exact active-set polish" if result.polished else "")
        details: dict[str, Any] = {
            "duality_gap": result.duality_gap,
            "duality_gap_rigorous": result.rigorous,
            "kkt_residual": result.kkt_residual,
            "smoothing": result.smoothing,
            "stages": result.stages,
        }
        failure = (
            f"the duality gap {result.duality_gap:.3g} (relative) did not reach its "
            f"tolerance {tol:g} in {result.stages} smoothing stages"
        )
    else:
        if not sparse:
            prior_scale = None
            details = {}
            if priors:
                prior_scale = (
                    (delta / HUBER_EFFICIENCY) ** 2
                    if noise_var is None
                    else np.asarray(noise_var, dtype=float)
                )
                details["prior_scale"] = prior_scale.tolist()
            result = fit_huber(
                problem,
                penalty,
                delta,
                max_iter=max_iter,
                tol=tol,
                start=start,
                priors=priors,
                prior_scale=prior_scale,
            )
            solver = "damped Newton on reweighted fits (exact)"
        else:
            result = fit_huber_sparse(
                problem, penalty, norm, delta, max_iter=max_iter, tol=tol, start=start
            )
            solver = result.solver
            details = {"inner_iterations": result.inner_iterations}
        outliers = result.outliers
        details.update(
            kkt_residual=result.kkt_residual,
            huber_delta=delta.tolist(),
            n_outliers=int(outliers.sum()),
        )
        failure = (
            f"the KKT residual {result.kkt_residual:.3g} did not reach its tolerance "
            f"{tol:g} in {result.iterations} steps"
        )
    if not result.converged:
        remedy = (
            "it stopped at the limit of working precision; loosen tol"
            if result.stalled
            else "increase max_iter or loosen tol"
        )
        warn(
            f"loss={loss!r}: {failure}; the model is the last iterate: {remedy}",
            ConvergenceWarning,
        )
    return RobustSolution(
        theta=result.theta,
        objective=result.objective,
        iterations=result.iterations,
        converged=result.converged,
        stalled=result.stalled,
        solver=solver,
        details=details,
        outliers=outliers,
        delta_rule=rule,
    )


def _fits_exactly(problem: RegressionProblem, theta: np.ndarray) -> bool:
    """No residual beyond rounding (EXACT_FIT relative to the largest |y|)."""
    scale = max(float(np.abs(problem.y).max(initial=0.0)), np.finfo(float).tiny)
    return bool(np.abs(problem.residuals(theta)).max(initial=0.0) <= EXACT_FIT * scale)


def loss_value(loss: str, r: np.ndarray, scale: np.ndarray, delta: np.ndarray | None) -> float:
    """The robust loss of scaled residuals ``r`` (..., n) with row scales ``scale``
    (..., 1): Σ huber(r; δ·s) for "huber", Σ s·|r| for "laplace" (the residual in
    the units of y is r / s)."""
    if loss == "huber":
        return float(huber_loss(r, delta * scale).sum())
    return float(np.sum(scale * np.abs(r)))


def _exact_fit(problem, W, theta, loss, delta, rule) -> RobustSolution:
    """The squared-loss fit when it leaves no residual: it minimizes the penalty with every
    residual zero (its stationarity is ∇P = 2Φᵀr = 0), so it minimizes any loss plus the
    penalty; the certificate is that zero gradient."""
    r = problem.residuals(theta)
    s = problem.row_scale[:, :, None]
    value = loss_value(loss, r, s, delta)
    if loss == "huber":
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
        outliers=outliers,
        delta_rule=rule,
    )


def robust_record_parts(solution: RobustSolution, loss: str) -> tuple[dict, FitStatus]:
    """``info`` and ``status`` of a model fitted with a robust loss."""
    info = {
        "solver": solution.solver,
        "iterations": solution.iterations,
        "converged": solution.converged,
        "objective": solution.objective,
        "loss": loss,
        **solution.details,
        "loglik_note": f"loss={loss!r} has no Gaussian likelihood; loglik is None",
    }
    if solution.outliers is not None:
        info.update(huber_delta_rule=solution.delta_rule, outliers=solution.outliers)
    status = FitStatus(
        iterative_status(solution.converged, stalled=solution.stalled),
        solution.solver,
        solution.iterations,
        solution.objective,
        solution.details,
    )
    return info, status


def robust_model(
    problem: RegressionProblem,
    penalty: np.ndarray,
    *,
    loss: str,
    lam: Any,
    norm: str,
    delta: np.ndarray | None,
    factory: Callable[..., ModelT],
    max_iter: int,
    tol: float,
    priors: list[PriorTerm] | None = None,
    noise_var: np.ndarray | None = None,
) -> ModelT:
    """Fit with loss="huber" or "laplace" (:func:`solve_robust`) and build the model.

    ``model.info`` holds "loss", "objective", "iterations", "converged" and
    the certificate: "kkt_residual" (Huber), or "duality_gap" and
    "kkt_residual" (Laplace). Huber fits also hold "huber_delta" (n,),
    "n_outliers" and "outliers" (the (N, q, n) mask of residuals beyond δ).
    ``loglik`` is None (no Gaussian likelihood) and ``noise_var`` is the given
    one, else the residual mean square of each output. ``priors`` and
    ``noise_var`` as in :func:`solve_robust`.
    """
    solution = solve_robust(
        problem,
        penalty,
        loss=loss,
        norm=norm,
        delta=delta,
        max_iter=max_iter,
        tol=tol,
        priors=priors,
        noise_var=noise_var,
    )
    info, status = robust_record_parts(solution, loss)
    N, K = problem.N, problem.K
    k = solution.theta.reshape(N, K)
    changepoints = None
    if norm in ("group", "l1"):
        changepoints = find_changepoints(
            activation(k, problem.coeffs), degree=problem.degree, min_level=residue_level(k)
        )
    if noise_var is None:
        noise_var = problem.output_rss(solution.theta) / max(problem.n_observed, 1)
    return factory(
        k,
        fit=FitRecord(
            norm=norm,
            coeffs=problem.coeffs,
            lam=lam,
            noise_var=noise_var,
            noise_cov=np.diag(noise_var),
            info=info,
            changepoints=changepoints,
            status=status,
        ),
    )
