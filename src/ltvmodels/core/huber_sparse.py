"""The Huber loss with the group or l1 penalty: the exact minimizer.

Objective (rows scaled by √w as in :mod:`.huber`, thresholds δ̃ = δ√w):

    F(k) = L(k) + Σ_t R(Λ(Dk)_t),   L(k) = Σ h_δ̃(r),   R = ‖·‖₂ (group) or ‖·‖₁ (l1).

Independent parts are solved one at a time (:func:`sparse_parts`): with
norm="l1" every output row (both terms separate over outputs); with
norm="group" the whole problem, and when several outputs share the group
(whose rows then need different weights) in the "lifted" form of one output
with K regressors, y_tji = kᵀ(e_i ⊗ φ_tj).

Each part is solved by the interior-point method with residual cones
(:mod:`.robust_ipm`) when its weights are finite and positive (and, for
"group", it has at most GROUP_IPM_MAX_K coefficients per step, as for the
squared loss): one solve, certified by its duality gap. Otherwise
(coefficients held constant or unpenalized, or many per step) by proximal Newton
(Lee, Sun & Saunders, SIAM J. Optim. 2014): at the iterate k, L is replaced by
the quadratic model Q of :func:`.huber.newton_model` (L's gradient, curvature
1 inside δ̃ and τδ̃/|r| beyond); Q + R is a weighted sparse fit, solved exactly
by :func:`.sparse.solve_sparse`; a backtracking line search on F keeps it
decreasing. Its certificate: the sparse fit's minimizer k⁺ satisfies
−∇Q(k⁺) ∈ ∂R(k⁺) (to the inner solver's tolerance), so F's KKT residual at
k⁺ is ‖∇L(k⁺) − ∇Q(k⁺)‖, computed explicitly; it vanishes once the outliers
are identified, and the iteration stops when it is below ``tol`` relative to
the size of L's gradient, 2‖ψ‖‖Φ‖ with ψ = clip(r, ±δ̃).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceWarning
from .huber import LINE_SEARCH_STEPS, MIN_DAMPING, NEWTON_DAMPING, huber_loss, newton_model
from .penalties import named
from .problem import RegressionProblem, apply_difference
from .robust_ipm import fit_robust_ipm
from .sparse import GROUP_IPM_MAX_K, solve_sparse

__all__ = ["SparseHuberFit", "fit_huber_sparse", "ipm_applies", "sparse_parts"]

# The tightest tolerance asked of the inner solver.
INNER_TOL_FLOOR = 1e-14
IPM_SOLVER = "interior point with residual cones (block-banded Newton systems)"


@dataclass
class SparseHuberFit:
    """What :func:`fit_huber_sparse` computes."""

    theta: np.ndarray  # (N, n, p)
    objective: float  # F at theta
    iterations: int  # proximal Newton steps (sparse fits) taken, over all parts
    inner_iterations: int  # iterations of the sparse solver, over all steps
    converged: bool  # every part's KKT residual met tol
    kkt_residual: float  # the largest part's relative KKT residual
    outliers: np.ndarray  # (N, q, n) bool: observed entries with |r| > δ
    solver: str  # the methods used (parts may differ)
    stalled: bool = False  # stopped short of tol: no decrease along a step at working precision


def fit_huber_sparse(
    problem: RegressionProblem,
    weights: np.ndarray,
    norm: str,
    delta: np.ndarray,
    *,
    max_iter: int,
    tol: float,
    start: np.ndarray,
) -> SparseHuberFit:
    """Minimize F (module docstring), part by part, from ``start``.

    Parameters
    ----------
    problem : RegressionProblem
        Rows scaled by √w; ``problem.row_scale`` holds √w.
    weights : ndarray, shape (K,)
        λ_j > 0 per coefficient; inf holds coefficient j constant in time.
    norm : {"group", "l1"}
    delta : ndarray, shape (n,)
        Huber threshold δ_i > 0 of each output, in the units of y.
    max_iter : int
        Interior-point iterations, or proximal Newton steps, per part at most
        (also the inner sparse solver's limit).
    tol : float
        Relative tolerance of the certificates (duality gap and residuals, or
        the KKT residual).
    start : ndarray, shape (N, n, p)
        Starting coefficients (the squared-loss fit).
    """
    N, p = problem.N, problem.p
    thresholds = delta[None, None, :] * problem.row_scale[:, :, None]  # (N, q, n)
    theta = start.copy()
    objective, steps, inner, kkt_worst, all_converged, solvers = 0.0, 0, 0, 0.0, True, []
    stalled = False
    for part, part_weights, part_thresholds, index in sparse_parts(
        problem, weights, norm, thresholds
    ):
        k = theta[:, index, :].reshape(N, -1)
        if ipm_applies(part_weights, norm):
            with warnings.catch_warnings():  # judged by the caller from `converged`
                warnings.simplefilter("ignore", ConvergenceWarning)
                ip = fit_robust_ipm(
                    part,
                    part_weights,
                    norm,
                    "huber",
                    2.0 * part_thresholds,
                    tol=tol,
                    max_iter=max_iter,
                    start=k,
                )
            result = _PartResult(
                k=ip.k,
                objective=ip.objective,
                steps=ip.iterations,
                inner_iterations=0,
                converged=ip.converged,
                kkt=max(ip.dual_residual, ip.duality_gap),
                solver=IPM_SOLVER,
                stalled=ip.stalled,
            )
        else:
            result = _proximal_newton(
                part, part_weights, norm, part_thresholds, k, max_iter=max_iter, tol=tol
            )
        theta[:, index, :] = result.k.reshape(N, -1, p)
        objective += result.objective
        steps += result.steps
        inner += result.inner_iterations
        kkt_worst = max(kkt_worst, result.kkt)
        all_converged &= result.converged
        stalled |= result.stalled
        if result.solver not in solvers:
            solvers.append(result.solver)
    r = problem.residuals(theta)
    return SparseHuberFit(
        theta=theta,
        objective=objective,
        iterations=steps,
        inner_iterations=inner,
        converged=all_converged,
        kkt_residual=kkt_worst,
        outliers=(np.abs(r) > thresholds) & problem.observed[:, :, None],
        solver="; ".join(solvers),
        stalled=stalled and not all_converged,
    )


def ipm_applies(weights: np.ndarray, norm: str) -> bool:
    """Whether :func:`.robust_ipm.fit_robust_ipm` takes a part with these weights (K,)
    and ``norm``: all finite and positive, and for "group" (K × K Newton blocks) at most
    GROUP_IPM_MAX_K coefficients per step, the squared loss's limit (:func:`.sparse.ipm_suits`).

    Measured against the other routes (one-off runs, jump systems, order 1, λ = 0.1 and
    0.01 λ_max, tol 1e-6): for "group" at K = 24, 35 and 60 (T = 400) the interior point
    took 0.05-0.8 s, where Huber's proximal Newton took 0.2-3.7 s and Laplace's smoothing
    21-150 s (at K = 35, T = 2000: 1.4-2.0 s against 243-368 s); for "l1" at p = 24
    (16 outputs, T = 400) 2.7-5.5 s against 7-34 s. The objectives agree within the
    tolerance."""
    finite = bool(np.all(np.isfinite(weights)) and np.all(weights > 0))
    return finite and (norm != "group" or weights.size <= GROUP_IPM_MAX_K)


def sparse_parts(problem: RegressionProblem, weights: np.ndarray, norm: str, per_entry: np.ndarray):
    """The independent single-output parts of a sparse-norm problem with a robust loss.

    Yields (problem, its weights, its values of ``per_entry`` (N, q'), the output
    index) per part: each output with norm="l1" (both terms separate), the lifted
    problem of one output with regressors e_i ⊗ φ_tj (rows j·n + i) when a group
    couples several outputs. ``per_entry`` is (N, q, n).
    """
    n, p = problem.n, problem.p
    if norm == "l1" or n == 1:
        for i in range(n):
            part = RegressionProblem(
                y=problem.y[:, :, i : i + 1],
                phi=problem.phi,
                coeffs=problem.coeffs,
                observed=problem.observed,
                row_scale=problem.row_scale,
            )
            yield part, weights[i * p : (i + 1) * p], per_entry[:, :, i], slice(i, i + 1)
        return
    # group over several outputs: one output with regressors e_i ⊗ φ_tj (rows j·n + i)
    N, q, K = problem.N, problem.q, problem.K
    phi = np.zeros((N, q, n, n, p))
    for i in range(n):
        phi[:, :, i, i, :] = problem.phi
    lifted = RegressionProblem(
        y=problem.y.reshape(N, q * n, 1),
        phi=phi.reshape(N, q * n, K),
        coeffs=problem.coeffs,
        observed=np.repeat(problem.observed, n, axis=1),
        row_scale=np.repeat(problem.row_scale, n, axis=1),
    )
    yield lifted, weights, per_entry.reshape(N, q * n), slice(0, n)


@dataclass
class _PartResult:
    k: np.ndarray  # (N, K')
    objective: float
    steps: int
    inner_iterations: int
    converged: bool
    kkt: float
    solver: str
    stalled: bool


def _proximal_newton(part, weights, norm, thresholds, k, *, max_iter, tol) -> _PartResult:
    """Proximal Newton on one single-output part (module docstring)."""
    y = part.y[:, :, 0]
    finite_weights = np.where(np.isinf(weights), 0.0, weights)  # constants have Dk = 0
    phi_norm = float(np.linalg.norm(part.phi))
    value = _objective(part, k, thresholds, finite_weights, norm)
    damping, outliers = NEWTON_DAMPING, None
    kkt, steps, inner, converged, solver, stalled = np.inf, 0, 0, False, "", False
    while steps < max_iter:
        r = y - _fitted(part, k)
        sqrt_a, y_hat = newton_model(y, r, thresholds, damping)
        model = RegressionProblem(
            y=(y_hat * sqrt_a)[:, :, None],
            phi=part.phi * sqrt_a[:, :, None],
            coeffs=part.coeffs,
            observed=part.observed,
        )
        # The model's rows beyond δ̃ carry the large constant Σ δ̃|r|/τ: the inner
        # solver's relative tolerances are tightened by the inflation so that its
        # answer is accurate to tol on F's scale.
        scale = _gradient_scale(np.clip(r, -thresholds, thresholds), phi_norm)
        model_scale = 1.0 + 2.0 * float(np.linalg.norm(model.y)) * float(np.linalg.norm(model.phi))
        model_value = float(np.sum((sqrt_a * r) ** 2 * np.where(sqrt_a < 1, damping**-2, 1.0)))
        inner_tol = max(
            tol * min(1.0, scale / model_scale, value / max(model_value, 1e-300)), INNER_TOL_FLOOR
        )
        with warnings.catch_warnings():  # judged below by the certificate
            warnings.simplefilter("ignore", ConvergenceWarning)
            solution = solve_sparse(model, weights, named(norm), max_iter=max_iter, tol=inner_tol)
        steps += 1
        inner += solution.iterations
        solver = f"proximal Newton on {solution.solver}"
        k_new = solution.theta.reshape(k.shape)
        # F's KKT residual at the model's minimizer: ∇L(k⁺) − ∇Q(k⁺), plus the
        # inner solver's own stationarity residual and duality gap
        r_new = y - _fitted(part, k_new)
        psi = np.clip(r_new, -thresholds, thresholds)
        model_residual = sqrt_a * (y_hat * sqrt_a - _fitted(model, k_new))
        mismatch = -2.0 * _adjoint(part, psi - model_residual)
        scale = _gradient_scale(psi, phi_norm)
        new_value = _objective(part, k_new, thresholds, finite_weights, norm)
        inner_residual = np.inf
        if solution.converged:
            inner_residual = max(
                solution.details.get("dual_residual", 0.0) * model_scale / scale,
                solution.details.get("duality_gap", 0.0) / max(new_value, 1e-300),
            )
        kkt = max(float(np.linalg.norm(mismatch)) / scale, inner_residual)
        if kkt <= tol and new_value <= value * (1.0 + tol):
            # certified; F may differ from the iterate's by the inner solver's accuracy
            k, value, converged = k_new, new_value, True
            break
        limit = value + 8 * np.finfo(float).eps * abs(value)
        if new_value <= limit:  # the full step decreases F: the next iterate
            k, value = k_new, new_value
            # once the outliers are identified, less damping: superlinear convergence
            new_outliers = np.abs(r_new) > thresholds
            if outliers is not None and np.array_equal(new_outliers, outliers):
                damping = max(damping * 0.1, MIN_DAMPING)
            outliers = new_outliers
            continue
        kkt, damping, outliers = np.inf, NEWTON_DAMPING, None  # no certificate; damp again
        for alpha in 0.5 ** np.arange(1, LINE_SEARCH_STEPS):
            trial = k + alpha * (k_new - k)
            trial_value = _objective(part, trial, thresholds, finite_weights, norm)
            if trial_value <= limit:
                k, value = trial, trial_value
                break
        else:  # no decrease along the direction: k is optimal to working precision
            stalled = True
            break
    return _PartResult(
        k=k,
        objective=value,
        steps=steps,
        inner_iterations=inner,
        converged=converged,
        kkt=kkt,
        solver=solver,
        stalled=stalled,
    )


def _gradient_scale(psi: np.ndarray, phi_norm: float) -> float:
    """2‖ψ‖‖Φ‖, the size of L's gradient (ψ = clip(r, ±δ̃)), floored above 0."""
    return max(2.0 * float(np.linalg.norm(psi)) * phi_norm, np.finfo(float).tiny)


def _fitted(part: RegressionProblem, k: np.ndarray) -> np.ndarray:
    """φ_tjᵀ k_t of a single-output part, shape (N, q)."""
    return np.einsum("tjk,tk->tj", part.phi, k)


def _adjoint(part: RegressionProblem, v: np.ndarray) -> np.ndarray:
    """Σ_j v_tj φ_tj, shape (N, K') — the adjoint of :func:`_fitted`."""
    return np.einsum("tj,tjk->tk", v, part.phi)


def _objective(part, k, thresholds, weights, norm) -> float:
    """F of a single-output part at k (N, K')."""
    r = part.y[:, :, 0] - _fitted(part, k)
    scaled = apply_difference(k, part.coeffs) * weights
    penalty = np.linalg.norm(scaled, axis=1).sum() if norm == "group" else np.abs(scaled).sum()
    return float(huber_loss(r, thresholds).sum() + penalty)
