"""The sparse penalties: choose the solver for a problem and return a plain solution.

    minimize_k  Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ (Dk)_t),

with R a sparse :class:`~.penalties.Penalty`: ‖·‖₂ (group), ‖·‖₁ (l1), or one
registered by the user.

Three exact routes, tried in this order:

1. λ ≥ λ_max (:func:`.sparse_common.lambda_max`): Dk = 0 is optimal, and the
   null-space fit is the solution in closed form;
2. every weight positive, the interior-point method has the penalty's cones
   and suits the size (:func:`ipm_suits`): the primal-dual interior-point
   method (:mod:`.ipm`);
3. otherwise ADMM (:mod:`.admm`), which needs only the penalty's proximal
   operator and cones, and also takes a warm start along a path.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .admm import SparseResult, fit_sparse
from .ipm import InteriorPointResult, fit_sparse_ipm, interpolated_start
from .penalties import Penalty
from .problem import RegressionProblem
from .sparse_common import lambda_max, null_space_fit

__all__ = ["GROUP_IPM_MAX_K", "ipm_suits", "SparseSolution", "solve_sparse", "path_start"]

# The interior-point method's Newton blocks are K × K for "group" (cost ~ N·K³ per
# iteration) and p × p per output row for "l1" (~ N·n·p³). Measured on jump-linear
# systems (T = 1000 and 4000, jump systems of n = 4–16 states, m = 2–4 inputs): for
# "l1" at K = 24–320 the interior point was 12–57 times faster than ADMM (e.g. 0.47 s
# against 12 s at K = 24, T = 4000) and ADMM's objective was worse by up to 6.5e-6.
# For "group" the wide kernels (:mod:`.widekernels`, K >= 16) made the interior point
# the faster route at every K measured (``benchmarks/bench_wide_group.py``, order 1,
# tol 1e-6): at λ = 0.1 λ_max (one change) K = 35, T = 1000 took 0.55 s and 8
# iterations against ADMM's 616 s and 6335 iterations; at λ = 0.0015 λ_max (λ ≈ 5, many
# small changes) K = 35 and 60 at T = 1000 took 1.5 and 4.6 s against ADMM's 28 and
# 95 s (one loaded machine, one run each). Beyond K = 64 it is not measured (the
# interior point's factor holds N·(d + 1)·K² numbers, as ADMM's does).
GROUP_IPM_MAX_K = 64


def ipm_suits(penalty: Penalty, K: int) -> bool:
    """Whether the interior-point method has the penalty's cones and is the faster route
    for K parameters per step (its Newton blocks are p × p per output for a separable
    penalty, K × K otherwise)."""
    return penalty.interior_point and (penalty.separable or K <= GROUP_IPM_MAX_K)


@dataclass
class SparseSolution:
    """The solution of a sparse-norm problem and how it was obtained.

    Attributes
    ----------
    theta : ndarray, shape (N, n, p)
        The minimizer Θ_t.
    solver : str
        Which route solved it (a human-readable name).
    iterations : int
        Iterations of the solver (0 in closed form).
    converged : bool
        The solver met its tolerance (or the solution is exact).
    objective : float
        Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ (Dk)_t) at ``theta``.
    rss : float
        Σ_t ‖y_t − Θ_t φ_t‖².
    lambda_max : float
        The largest finite weight at which this weight pattern gives Dk = 0.
    details : dict
        Solver-specific numbers: duality gap and residuals (interior point),
        residuals, ρ and factorizations (ADMM).
    closed_form : bool
        λ ≥ λ_max: the null-space fit, exact without iterations.
    polished : bool
        The interior-point result was certified by the active-set polish.
    stalled : bool
        The interior-point method stopped short of its tolerance because it
        could not make progress at working precision.
    admm : SparseResult or None
        ADMM's state, for a warm start along a λ path.
    ipm : InteriorPointResult or None
        The interior-point method's result (with its duals), for a warm start
        along a λ path.
    pattern : ndarray, shape (K,), or None
        The weights divided by their largest finite one: ``lambda_max`` belongs
        to this pattern, and a warm start with the same pattern passes it on.
    residuals : ndarray, shape (N, q, n), or None
        y_tj − Θ_t φ_tj at ``theta`` (0 where unobserved), those ``rss`` was
        computed from: the model's noise variance and outlier check read them
        instead of recomputing them; None for a start that was not solved.
    """

    theta: np.ndarray
    solver: str
    iterations: int
    converged: bool
    objective: float
    rss: float
    lambda_max: float
    details: dict = field(default_factory=dict)
    closed_form: bool = False
    polished: bool = False
    stalled: bool = False
    admm: SparseResult | None = None
    ipm: InteriorPointResult | None = None
    pattern: np.ndarray | None = None
    residuals: np.ndarray | None = None


def solve_sparse(
    problem: RegressionProblem,
    weights: np.ndarray,
    penalty: Penalty,
    *,
    max_iter: int,
    tol: float,
    warm_start: SparseSolution | None = None,
) -> SparseSolution:
    """Minimize Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ (Dk)_t) on validated inputs.

    Parameters
    ----------
    problem : RegressionProblem
    weights : ndarray, shape (K,)
        λ_j >= 0 per coefficient of k_t; ``inf`` holds coefficient j constant.
    penalty : Penalty
        A sparse penalty (:mod:`.penalties`); the interior-point method serves the
        built-in cones, ADMM any penalty.
    max_iter : int
        Iteration limit of the solver.
    tol : float
        Relative tolerance (duality gap and residuals; ADMM: residuals).
    warm_start : SparseSolution, optional
        The solution of the same problem at other weights (a λ path): the
        interior-point method starts from its primal-dual pair, ADMM from its
        state, whichever solved both.

    Returns
    -------
    SparseSolution
    """
    K = problem.K
    # The largest finite weight at which this weight pattern gives the LTI fit
    # (weights of inf hold their coefficients constant at any λ). Along a λ path the
    # warm start's pattern is the same: its λ_max is reused (at T = 10⁴ the null-space
    # fit and λ_max took 3 % of the L-curve's twelve fits).
    finite = weights[np.isfinite(weights)]
    scale = finite.max() if finite.size else np.inf
    pattern = weights / scale if finite.size else None
    theta_bar = None
    if not finite.size:
        lam_max = 0.0
    elif (
        warm_start is not None
        and warm_start.pattern is not None
        and np.array_equal(warm_start.pattern, weights / scale)
    ):
        lam_max = warm_start.lambda_max
    else:
        theta_bar = null_space_fit(problem)
        lam_max = lambda_max(problem, penalty, weights / scale, theta_bar)
    if np.all(weights > 0) and scale >= lam_max:
        # Dk = 0 is optimal (λ_max's dual certificate): the null-space fit, exactly.
        theta_bar = null_space_fit(problem) if theta_bar is None else theta_bar
        resid = problem.residuals(theta_bar)
        rss = float(np.sum(resid**2))
        return SparseSolution(
            theta=theta_bar,
            solver="closed form (lam >= lambda_max)",
            iterations=0,
            converged=True,
            objective=rss,
            rss=rss,
            lambda_max=lam_max,
            details={"duality_gap": 0.0},
            closed_form=True,
            pattern=pattern,
            residuals=resid,
        )
    if ipm_suits(penalty, K) and np.all(weights > 0):
        ip = fit_sparse_ipm(
            problem,
            weights,
            penalty.name,
            tol=tol,
            max_iter=max_iter,
            warm_start=None if warm_start is None else warm_start.ipm,
        )
        resid = problem.residuals(ip.theta)
        return SparseSolution(
            theta=ip.theta,
            solver="interior point (block-banded Newton systems)",
            iterations=ip.iterations,
            converged=ip.converged,
            objective=ip.objective,
            rss=float(np.sum(resid**2)),
            lambda_max=lam_max,
            details={
                "duality_gap": ip.duality_gap,
                "primal_residual": ip.primal_residual,
                "dual_residual": ip.dual_residual,
                "polished": ip.polished,
            },
            polished=ip.polished,
            stalled=ip.stalled,
            ipm=ip,
            pattern=pattern,
            residuals=resid,
        )
    if np.isinf(weights).any():
        raise NotImplementedError(
            "lam: constant coefficients (lam = inf) with norm='group' or 'l1' need every "
            f"weight > 0 and, for 'group', at most {GROUP_IPM_MAX_K} parameters per time "
            f"step, received norm={penalty.name!r}, K = {K} and {int(np.sum(weights == 0))} zero "
            "weights"
        )
    result = fit_sparse(
        problem,
        weights,
        penalty,
        max_iter=max_iter,
        tol=tol,
        warm_start=None if warm_start is None else warm_start.admm,
    )
    resid = problem.residuals(result.theta)
    return SparseSolution(
        theta=result.theta,
        solver="ADMM (banded k-update)",
        iterations=result.iterations,
        converged=result.converged,
        objective=result.objective,
        rss=float(np.sum(resid**2)),
        lambda_max=lam_max,
        details={
            "duality_gap": result.duality_gap,
            "stationarity": result.stationarity,
            "primal_residual": result.primal_residual,
            "dual_residual": result.dual_residual,
            "rho": result.rho,
            "n_factorizations": result.n_factorizations,
        },
        admm=result,
        pattern=pattern,
        residuals=resid,
    )


def path_start(
    lower: SparseSolution, upper: SparseSolution, weights: np.ndarray
) -> SparseSolution | None:
    """A warm start for ``solve_sparse`` at weights between two solutions of a λ path.

    Interpolates the interior-point solutions' primal-dual pairs
    (:func:`.ipm.interpolated_start`): a feasible start nearer the optimum
    than either neighbour's. Weights Λ = λ·W between the neighbours' a·W and
    b·W (a < λ < b).

    Returns
    -------
    SparseSolution or None
        A start only (``converged`` False, objective and rss NaN); None where
        either neighbour was not solved by the interior-point method with duals
        (closed form, ADMM, polished) or the weights are not between theirs.
    """
    if lower.ipm is None or upper.ipm is None:
        return None
    start = interpolated_start(lower.ipm, upper.ipm, weights)
    if start is None:
        return None
    return SparseSolution(
        theta=start.theta,
        solver="interpolated start",
        iterations=0,
        converged=False,
        objective=np.nan,
        rss=np.nan,
        lambda_max=lower.lambda_max,
        ipm=start,
        pattern=lower.pattern,
    )
