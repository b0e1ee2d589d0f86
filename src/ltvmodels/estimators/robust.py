"""loss="huber" and loss="laplace": the models of robust fits.

The fit itself is :func:`ltvmodels.core.robust.solve_robust`, which starts
from the squared-loss fit and runs the loss's solver (:mod:`ltvmodels.core.losses`);
this module turns its solution into a model.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from ..core.losses import named as named_loss
from ..core.penalties import Penalty
from ..core.priorterms import PriorTerm
from ..core.problem import RegressionProblem, activation
from ..core.robust import OUTLIER_THRESHOLD, RobustSolution, residual_outliers, solve_robust
from ..results.record import FitRecord, FitStatus, iterative_status
from ..results.regression import RegressionModel
from .changepoints import find_changepoints, residue_level

__all__ = ["outlier_info", "robust_model", "robust_record_parts"]

ModelT = TypeVar("ModelT", bound=RegressionModel)  # the model the caller's factory builds


def outlier_info(
    problem: RegressionProblem, theta: np.ndarray, residuals: np.ndarray | None = None
) -> dict[str, Any]:
    """The ``info`` entries of ``model.outliers`` for the fit ``theta`` (N, n, p) of
    ``problem`` (every fit): "outliers" (N, q, n), the residual entries beyond
    "outlier_threshold" × "outlier_scale" (σ̂ per output,
    :func:`~ltvmodels.core.robust.residual_outliers`), and "n_outliers"; none for
    pseudo-rows (EM's M-step), which are no samples. ``residuals`` (N, q, n):
    ``problem.residuals(theta)`` where the caller has them already."""
    if not problem.rows_are_samples:
        return {}
    mask, sigma = residual_outliers(problem, theta, residuals=residuals)
    return {
        "outliers": mask,
        "outlier_scale": sigma.tolist(),
        "outlier_threshold": OUTLIER_THRESHOLD,
        "n_outliers": int(mask.sum()),
    }


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
    if solution.beyond_delta is not None:
        info.update(huber_delta_rule=solution.delta_rule, beyond_delta=solution.beyond_delta)
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
    weights: np.ndarray,
    *,
    loss: str,
    penalty: Penalty,
    lam: Any,
    norm: str,
    delta: np.ndarray | None,
    factory: Callable[..., ModelT],
    max_iter: int,
    tol: float,
    priors: list[PriorTerm] | None = None,
    noise_var: np.ndarray | None = None,
) -> ModelT:
    """Fit with a robust ``loss`` and ``penalty`` with ``weights``
    (:func:`~ltvmodels.core.robust.solve_robust`) and build the model, recorded as
    ``norm`` (the penalty's name, or "lti" for a model held constant).

    ``model.info`` holds "loss", "objective", "iterations", "converged" and
    the certificate: "kkt_residual" (Huber), or "duality_gap" and
    "kkt_residual" (Laplace). Huber fits also hold "huber_delta" (n,),
    "n_beyond_delta" and "beyond_delta" (the (N, q, n) mask of the residuals in
    Huber's linear region, beyond δ); every fit holds :func:`outlier_info`.
    ``loglik`` is None (no Gaussian likelihood) and ``noise_var`` is the given
    one, else the residual mean square of each output. ``priors`` and
    ``noise_var`` as in :func:`solve_robust`.
    """
    solution = solve_robust(
        problem,
        weights,
        loss=named_loss(loss),
        penalty=penalty,
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
    if not penalty.closed_form:
        changepoints = find_changepoints(
            activation(k, problem.coeffs), degree=problem.degree, min_level=residue_level(k)
        )
    residuals = problem.residuals(solution.theta)  # for the noise and the outliers
    if noise_var is None:
        noise_var = problem.output_rss(solution.theta, residuals) / max(problem.n_observed, 1)
    return factory(
        k,  # the solver's own array, which nothing else holds: not copied again
        copy=False,
        fit=FitRecord(
            norm=norm,
            coeffs=problem.coeffs,
            lam=lam,
            noise_var=noise_var,
            noise_cov=np.diag(noise_var),
            info={**info, **outlier_info(problem, solution.theta, residuals)},
            changepoints=changepoints,
            status=status,
        ),
    )
