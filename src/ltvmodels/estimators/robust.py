"""loss="huber": models robust to outliers (the solver is :mod:`ltvmodels.core.huber`).

The default threshold is δ_i = 1.345 σ̂_i with σ̂_i the robust scale of the
squared-loss fit's residuals of output i, 1.4826 · MAD (95 % efficiency at
Gaussian noise, Huber 1964); residuals beyond δ count linearly, so a gross
outlier moves the fit as little as one δ away.
"""

from __future__ import annotations

import warnings
from typing import Any, Callable

import numpy as np

from ..core.huber import fit_huber
from ..core.problem import RegressionProblem
from ..core.squared import SquaredSolver
from ..errors import ConvergenceWarning
from ..results.record import FitRecord, FitStatus, iterative_status
from ..results.regression import RegressionModel
from .changepoints import MAD_TO_STD

HUBER_EFFICIENCY = 1.345  # δ / σ of Huber's 95 %-efficient estimator
SOLVER = "IRLS (majorize-minimize, exact)"


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


def huber_model(
    problem: RegressionProblem, W: np.ndarray, *, lam: Any, norm: str, delta: np.ndarray | None,
    factory: Callable[..., RegressionModel], max_iter: int, tol: float,
) -> RegressionModel:
    """Fit with loss="huber" and build the model (``delta`` None: :func:`default_delta`).

    ``model.info`` holds "huber_delta" (n,), "n_outliers", "outliers" (the
    (N, q, n) mask of residuals beyond δ), "kkt_residual" and "iterations";
    ``loglik`` is None (no Gaussian likelihood) and ``noise_var`` is the
    residual mean square of each output.
    """
    rule = "given" if delta is not None else "1.345 * 1.4826 * MAD of squared-loss residuals"
    start = None
    if delta is None:  # the squared-loss fit gives δ and starts the iteration
        start = SquaredSolver(problem, W, []).solve(1.0)[0]
        delta = default_delta(problem, start)
    result = fit_huber(problem, W, delta, max_iter=max_iter, tol=tol, start=start)
    if not result.converged:
        warnings.warn(
            f"loss='huber': the reweighting did not reach its tolerance {tol:g} in "
            f"{max_iter} steps (KKT residual {result.kkt_residual:.3g}); the model is the last "
            "iterate. Increase max_iter or tol.",
            ConvergenceWarning, stacklevel=4,
        )
    N, K = problem.N, problem.K
    n_outliers = int(result.outliers.sum())
    details = {"kkt_residual": result.kkt_residual, "huber_delta": delta.tolist(),
               "n_outliers": n_outliers}
    info = {
        "solver": SOLVER, "iterations": result.iterations, "converged": result.converged,
        "objective": result.objective, "loss": "huber", "huber_delta": delta.tolist(),
        "huber_delta_rule": rule, "n_outliers": n_outliers, "outliers": result.outliers,
        "kkt_residual": result.kkt_residual,
        "loglik_note": "loss='huber' has no Gaussian likelihood; loglik is None",
    }
    status = FitStatus(iterative_status(result.converged), SOLVER, result.iterations,
                       result.objective, details)
    noise_var = problem.output_rss(result.theta) / max(problem.n_observed, 1)
    return factory(result.theta.reshape(N, K), fit=FitRecord(
        norm=norm, coeffs=problem.coeffs, lam=lam, noise_var=noise_var,
        noise_cov=np.diag(noise_var), info=info, status=status,
    ))
