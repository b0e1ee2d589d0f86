"""The Laplacian loss Σ w|r| (paper Section IV-A): the exact minimizer, certified.

Objective (rows scaled by s = √w as in :mod:`.huber`, so w|r| = s|r̃|):

    F(k) = Σ s|r̃| + P(k),   P = Σ_t (Dk)_tᵀ W (Dk)_t  or  Σ_t R(Λ(Dk)_t).

Methods:

* Finite positive weights (and, for "group", at most GROUP_IPM_MAX_K
  coefficients per step): the interior-point method with residual cones
  (:mod:`.robust_ipm`), part by part (each output for "sq" and "l1").
* Otherwise (coefficients held constant, or many per step): |r| is
  smoothed by the Huber function, h_δ(r)/(2δ), which lies within
  [|r| − δ/2, |r|]; its minimizer, that of Σ w h_δ(r) + 2δ P(k), is computed
  by the Huber solvers (:mod:`.huber`, :mod:`.huber_sparse`) from the
  previous one, for δ decreasing tenfold per stage until a duality gap
  certifies the answer. For norm="sq" each stage also tries the exact
  solution with the zero residuals and signs it has found
  (:func:`_polish_squared`, the method of multipliers on an
  equality-constrained QP), which ends the iteration as soon as they are
  right; smoothing alone reaches gaps of about 1e-7 to 1e-6 before the
  smoothed problems become too badly scaled for working precision.

Certificate: Laplace's dual is max_{|ψ|<=1} Σ sψỹ − P*(Σ sψφ̃). The method's
dual point ψ (the interior-point duals, the smoothed optimum's
clip(r/δ, ±1), or the polish's multipliers) is made exactly feasible
(:func:`_dual_bound`), so its dual value is a rigorous lower bound on min F,
and the relative gap (F(k) − bound)/F(k) bounds the suboptimality of the
answer.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceWarning, SingularProblemError
from .huber import HuberFit, fit_huber
from .huber_sparse import SparseHuberFit, fit_huber_sparse, ipm_applies, sparse_parts
from .problem import (
    RegressionProblem,
    apply_difference,
    apply_difference_adjoint,
    null_space_basis,
)
from .robust_ipm import fit_laplace_ipm_diagonal, fit_robust_ipm, fit_robust_ipm_squared
from .sparse_common import difference_preimage
from .squared import SquaredSolver, weight_diagonal

__all__ = ["LaplaceFit", "certified_gap", "fit_laplace"]

SMOOTHING = "Huber smoothing with a duality-gap certificate"
IPM = "interior point with residual cones (block-banded Newton systems)"
# δ shrinks by this factor per stage (a larger step changes which residuals are
# within δ too much at once: the next stage then needs many more Newton steps).
REDUCTION = 0.1
MAX_STAGES = 40
# A stage that fails (too little smoothing for working precision) is retried
# this often, each time halfway (geometrically) to the last stage's δ.
MAX_RETRIES = 4
# Smoothing stops when the gap has grown this much over the best one: rounding wins.
GAP_GROWTH = 100.0
# The smoothed problems are solved to this fraction of tol (at least the floor),
# in at most STAGE_STEPS Newton steps each.
STAGE_TOL_FACTOR = 1e-3
STAGE_TOL_FLOOR = 1e-10
STAGE_STEPS = 200
# Where every interior point met its own test but the certificate (their dual point
# made exactly feasible) missed tol, they run once more to this fraction of tol.
CERTIFICATE_RETRY = 1e-2


@dataclass
class LaplaceFit:
    """What :func:`fit_laplace` computes."""

    theta: np.ndarray  # (N, n, p)
    objective: float  # F at theta
    duality_gap: float  # relative to F
    rigorous: bool  # the gap is that of a feasible dual point (else: assuming stationarity)
    kkt_residual: float  # of the last smoothed problem
    iterations: int  # Newton steps over all stages
    stages: int  # smoothed problems solved
    smoothing: float  # the last δ
    converged: bool
    psi: np.ndarray  # (N, q, n) the dual point of the certificate
    polished: bool = False  # the exact active-set solution (norm="sq") gave the result
    stalled: bool = False  # ended short of tol at working precision
    method: str = SMOOTHING  # how it was solved (parts may differ)
    own_tests_met: bool = False  # every part by the interior point, each to its own test


def fit_laplace(
    problem: RegressionProblem,
    penalty: np.ndarray,
    norm: str,
    delta: np.ndarray,
    *,
    max_iter: int,
    tol: float,
    start: np.ndarray,
) -> LaplaceFit:
    """Minimize F (module docstring) from ``start``.

    Parameters
    ----------
    problem : RegressionProblem
        Rows scaled by √w; ``problem.row_scale`` holds √w.
    penalty : ndarray
        W (K,) or (K, K) for norm="sq" (no row coupling), the weights Λ (K,)
        for "group" and "l1"; inf holds a coefficient constant.
    norm : {"sq", "group", "l1"}
    delta : ndarray, shape (n,)
        A robust residual scale per output: the first smoothing δ is the smallest.
    max_iter, tol
        Newton steps per stage at most; the relative duality gap (and each
        stage's KKT residual) to reach.
    start : ndarray, shape (N, n, p)
        Starting coefficients (the squared-loss fit).
    """
    fit = _fit_laplace(problem, penalty, norm, delta, max_iter=max_iter, tol=tol, start=start)
    if fit.converged or not fit.own_tests_met:
        return fit
    # Each interior point met its own test (its iterates' gap and dual residual), but the
    # certificate lost more than the margin left to making their dual point feasible
    # (l1, 16 regressors, order 2: parts at gaps <= 2.3e-7 and dual residuals up to
    # 2.8e-8 certified 1.01e-6 > 1e-6). Once more to a tighter own test; what is still
    # short then is short at working precision (at tol 1e-9 on short series the retry
    # never helped).
    again = _fit_laplace(
        problem,
        penalty,
        norm,
        delta,
        max_iter=max_iter,
        tol=tol,
        start=start,
        ipm_tol=tol * CERTIFICATE_RETRY,
    )
    best = again if again.duality_gap <= fit.duality_gap else fit
    best.iterations = fit.iterations + again.iterations
    best.stalled = not best.converged
    return best


def _fit_laplace(
    problem: RegressionProblem,
    penalty: np.ndarray,
    norm: str,
    delta: np.ndarray,
    *,
    max_iter: int,
    tol: float,
    start: np.ndarray,
    ipm_tol: float | None = None,
) -> LaplaceFit:
    """One attempt of :func:`fit_laplace`, its interior points run to ``ipm_tol``
    (``tol`` unless given)."""
    ipm_tol = tol if ipm_tol is None else ipm_tol
    N, p = problem.N, problem.p
    costs = np.repeat(problem.row_scale[:, :, None], problem.n, 2)
    if norm == "sq":
        # each output alone, by the interior-point method where the weights are finite
        if (
            not SquaredSolver(problem, penalty, []).separable
            or np.isinf(weight_diagonal(penalty)).any()
        ):
            return _smoothed(problem, penalty, norm, delta, max_iter=max_iter, tol=tol, start=start)
        solver = SquaredSolver(problem, penalty, [])
        if solver.diagonal:  # all outputs at once, on compiled kernels
            return _fit_diagonal(
                problem,
                penalty,
                solver.W0_diagonal,
                costs,
                max_iter=max_iter,
                tol=tol,
                start=start,
                ipm_tol=ipm_tol,
            )
        parts = sparse_parts(problem, weight_diagonal(penalty), "l1", costs)
    else:  # the sparse norms part by part: the interior-point method where it applies
        parts = sparse_parts(problem, penalty, norm, costs)
    theta = start.copy()
    psi = np.zeros_like(problem.y)
    iterations, stages, smoothing, kkt, stalled, methods = 0, 0, 0.0, 0.0, False, []
    own_tests_met = True  # every part by the interior point, each to its own test
    for part, weights, part_costs, index in parts:
        method = IPM if norm == "sq" or ipm_applies(weights, norm) else SMOOTHING
        if method not in methods:
            methods.append(method)
        if method == IPM:
            k0 = theta[:, index, :].reshape(N, -1)
            with warnings.catch_warnings():  # judged below by the certificate
                warnings.simplefilter("ignore", ConvergenceWarning)
                if norm == "sq":
                    rows = slice(index.start * p, index.stop * p)
                    block = penalty[rows] if penalty.ndim == 1 else penalty[rows, rows]
                    ip = fit_robust_ipm_squared(
                        part, block, "laplace", part_costs, tol=ipm_tol, max_iter=max_iter, start=k0
                    )
                else:
                    ip = fit_robust_ipm(
                        part,
                        weights,
                        norm,
                        "laplace",
                        part_costs,
                        tol=ipm_tol,
                        max_iter=max_iter,
                        start=k0,
                    )
            k, pairing = ip.k, ip.psi / np.where(part_costs > 0, part_costs, 1.0)
            iterations, kkt = iterations + ip.iterations, max(kkt, ip.dual_residual)
            stalled |= ip.stalled
            own_tests_met &= ip.converged
        else:
            own_tests_met = False
            smoothed = _smoothed(
                part,
                weights,
                norm,
                delta,
                max_iter=max_iter,
                tol=tol,
                start=theta[:, index, :].reshape(N, 1, -1),
            )
            k, pairing = smoothed.theta.reshape(N, -1), smoothed.psi[:, :, 0]
            iterations, kkt = iterations + smoothed.iterations, max(kkt, smoothed.kkt_residual)
            stages, smoothing = max(stages, smoothed.stages), smoothed.smoothing
            stalled |= smoothed.stalled
        theta[:, index, :] = k.reshape(N, -1, p)
        psi[:, :, index] = pairing.reshape(N, problem.q, -1)
    objective = _objective(problem, theta, penalty, norm)
    gap, rigorous = _relative_gap(problem, theta, objective, psi, penalty, norm)
    return LaplaceFit(
        theta=theta,
        objective=objective,
        duality_gap=gap,
        rigorous=rigorous,
        kkt_residual=kkt,
        iterations=iterations,
        stages=stages,
        smoothing=smoothing,
        converged=gap <= tol,
        stalled=stalled and gap > tol,
        psi=psi,
        method="; ".join(methods),
        own_tests_met=own_tests_met,
    )


def _fit_diagonal(problem, penalty, weight, costs, *, max_iter, tol, start, ipm_tol) -> LaplaceFit:
    """:func:`fit_laplace` for norm="sq" with a finite diagonal ``penalty`` (its diagonal
    ``weight`` (K,)): the interior-point method on every output at once
    (:func:`.robust_ipm.fit_laplace_ipm_diagonal`, the iterations of
    :func:`.robust_ipm.fit_robust_ipm_squared` output by output, to ``ipm_tol``), then
    the same certificate."""
    N, n, p = problem.N, problem.n, problem.p
    results = fit_laplace_ipm_diagonal(
        problem, weight.reshape(n, p), costs, tol=ipm_tol, max_iter=max_iter, start=start
    )
    theta = np.stack([ip.k for ip in results], axis=1)
    psi = np.stack(
        [
            ip.psi / np.where(costs[:, :, i] > 0, costs[:, :, i], 1.0)
            for i, ip in enumerate(results)
        ],
        axis=2,
    )
    objective = _objective(problem, theta, penalty, "sq")
    gap, rigorous = _relative_gap(problem, theta, objective, psi, penalty, "sq")
    return LaplaceFit(
        theta=theta.reshape(N, n, p),
        objective=objective,
        duality_gap=gap,
        rigorous=rigorous,
        kkt_residual=max(ip.dual_residual for ip in results),
        iterations=sum(ip.iterations for ip in results),
        stages=0,
        smoothing=0.0,
        converged=gap <= tol,
        stalled=any(ip.stalled for ip in results) and gap > tol,
        psi=psi,
        method=IPM,
        own_tests_met=all(ip.converged for ip in results),
    )


def _smoothed(problem, penalty, norm, delta, *, max_iter, tol, start) -> LaplaceFit:
    """Certified Huber smoothing (module docstring) of the whole ``problem``."""
    tiny = np.finfo(float).tiny
    theta = start.copy()
    smoothing = float(np.min(delta))  # one δ: the penalty is scaled by 2δ
    # the best certified point so far: (gap, Θ, objective, KKT residual, rigorous, polished, ψ)
    best = (
        np.inf,
        theta,
        _objective(problem, theta, penalty, norm),
        np.inf,
        True,
        False,
        np.zeros_like(problem.y),
    )
    steps, stage, reduction, retries, stalled = 0, 0, 1.0, 0, False
    # the dual point inherits the stages' stationarity error, amplified by the
    # difference operator's inverse: the stages are solved more tightly
    stage_tol = max(STAGE_TOL_FACTOR * tol, STAGE_TOL_FLOOR)
    stage_steps = min(max_iter, STAGE_STEPS)
    for stage in range(1, MAX_STAGES + 1):
        thresholds = np.full(problem.n, smoothing)
        scaled = 2.0 * smoothing * penalty
        fit: HuberFit | SparseHuberFit
        try:
            if norm == "sq":
                fit = fit_huber(
                    problem, scaled, thresholds, max_iter=stage_steps, tol=stage_tol, start=theta
                )
            else:
                fit = fit_huber_sparse(
                    problem,
                    scaled,
                    norm,
                    thresholds,
                    max_iter=stage_steps,
                    tol=stage_tol,
                    start=theta,
                )
        except SingularProblemError:
            # too little smoothing for working precision: retry nearer the last stage
            if stage == 1:
                raise
            if retries == MAX_RETRIES:
                stalled = True
                break
            retries += 1
            smoothing /= reduction
            reduction = np.sqrt(reduction)
            smoothing *= reduction
            continue
        theta, steps = fit.theta, steps + fit.iterations
        objective = _objective(problem, theta, penalty, norm)
        r = problem.residuals(theta)
        psi = np.clip(r / np.maximum(problem.row_scale[:, :, None] * smoothing, tiny), -1, 1)
        gap, rigorous = _relative_gap(problem, theta, objective, psi, penalty, norm)
        candidates = [(gap, theta, objective, fit.kkt_residual, rigorous, False, psi)]
        if norm == "sq" and gap > tol:  # the exact solution with the zeros found so far
            exact = _polish_squared(problem, penalty, theta, smoothing)
            if exact is not None:
                polished_objective = _objective(problem, exact[0], penalty, norm)
                polished_gap, polished_rigorous = _relative_gap(
                    problem, exact[0], polished_objective, exact[1], penalty, norm
                )
                candidates.append(
                    (
                        polished_gap,
                        exact[0],
                        polished_objective,
                        exact[2],
                        polished_rigorous,
                        True,
                        exact[1],
                    )
                )
        for candidate in candidates:
            if candidate[0] < best[0] and (candidate[4] or fit.converged or candidate[5]):
                best = candidate
        if best[0] <= tol:
            break
        if gap > GAP_GROWTH * best[0]:  # less smoothing only loses digits now
            stalled = True
            break
        reduction = REDUCTION
        smoothing *= reduction
    gap, theta, objective, kkt, rigorous, polished, psi = best
    converged = gap <= tol
    return LaplaceFit(
        theta=theta,
        objective=objective,
        duality_gap=gap,
        rigorous=rigorous,
        kkt_residual=kkt,
        iterations=steps,
        stages=stage,
        smoothing=smoothing,
        converged=converged,
        polished=polished,
        stalled=stalled and not converged,
        psi=psi,
    )


def _polish_squared(
    problem: RegressionProblem,
    W: np.ndarray,
    theta: np.ndarray,
    smoothing: float,
) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The exact optimum from the zero residuals Z (|r| <= δ) and the signs of the others:
    (Θ, its dual point ψ (N, q, n), relative KKT residual), or None.

    With Z and the signs c = s·sign(r̃) fixed, F is the equality-constrained QP

        minimize  P(k) − Σ_{e∉Z} c_e φ̃_eᵀk   subject to  φ̃_eᵀk = ỹ_e (e ∈ Z),

    solved by the method of multipliers (each step a weighted squared-loss fit
    with the same matrix: Z rows weighted ρ, the others ε with the
    pseudo-response c/2ε that carries the linear term). Its multipliers ν are
    Laplace's dual on Z, ψ = ν/s, sign(r) elsewhere. The split is optimal when
    |ψ| <= 1 on Z and no residual outside Z changed sign; otherwise the
    entries of Z with |ψ| > 1 leave it (with the sign of ψ) and those that
    changed sign join it, up to POLISH_SPLITS times. None if no residual may be
    zero, a QP is singular, or the multipliers or the split do not settle.
    """
    s = problem.row_scale[:, :, None] * np.ones((1, 1, problem.n))  # (N, q, n)
    r = problem.residuals(theta)
    observed = s > 0
    zero = observed & (np.abs(r) <= smoothing * s)
    signs = np.where(observed & ~zero, np.sign(r), 0.0)
    for _ in range(POLISH_SPLITS):
        solved = _equality_qp(problem, W, zero, signs * s)
        if solved is None:
            return None
        theta, nu = solved
        psi = np.where(zero, nu / np.where(zero, s, 1.0), signs)
        r = problem.residuals(theta)
        leave = zero & (np.abs(psi) > 1.0)
        join = observed & ~zero & (signs * r < 0.0)
        if not (leave.any() or join.any()):
            return theta, psi, _laplace_kkt(problem, theta, W, psi * s)
        signs = np.where(leave, np.sign(psi), np.where(join, 0.0, signs))
        zero = (zero & ~leave) | join
    return None


def _equality_qp(problem, W, zero, linear) -> tuple[np.ndarray, np.ndarray] | None:
    """(Θ, ν) of the polish's QP for the zero set ``zero`` and linear terms c = ``linear``
    (N, q, n), by the method of multipliers; None if singular or not settled."""
    observed = problem.row_scale[:, :, None] * np.ones((1, 1, problem.n)) > 0
    if not zero.any():
        return None
    phi_sq = np.einsum("tjk,tjk->tj", problem.phi, problem.phi)[:, :, None] * np.ones(zero.shape)
    W_scale = float(np.max(np.where(np.isinf(W), 0.0, W), initial=0.0))
    rho = POLISH_RHO * max(W_scale, 1.0) / max(float(np.mean(phi_sq[zero])), 1e-300)
    eps = POLISH_EPSILON * rho
    nu = np.zeros(zero.shape)
    row_weight = np.where(zero, rho, np.where(observed, eps, 0.0))
    y_scale = float(np.abs(problem.y).max(initial=0.0)) + 1e-300
    for _ in range(POLISH_STEPS):
        pseudo = np.where(zero, problem.y + nu / (2.0 * rho), linear / (2.0 * eps))
        theta = _weighted_fit(problem, row_weight, pseudo, W)
        if theta is None:
            return None
        violation = np.where(zero, problem.residuals(theta), 0.0)
        nu += 2.0 * rho * violation
        if np.abs(violation).max() <= POLISH_FEASIBILITY * y_scale:
            return theta, nu
    return None


def certified_gap(
    problem: RegressionProblem, theta: np.ndarray, psi: np.ndarray, penalty: np.ndarray, norm: str
) -> tuple[float, float, bool]:
    """(F(k), the relative duality gap, rigorous) of Θ (N, n, p) for the problem with
    ``penalty`` and ``norm`` (as :func:`fit_laplace`), from a dual point ψ (N, q, n),
    e.g. that of another fit: the certificate of a candidate answer."""
    objective = _objective(problem, theta, penalty, norm)
    gap, rigorous = _relative_gap(problem, theta, objective, psi, penalty, norm)
    return objective, gap, rigorous


def _relative_gap(
    problem: RegressionProblem,
    theta: np.ndarray,
    objective: float,
    psi: np.ndarray,
    penalty: np.ndarray,
    norm: str,
) -> tuple[float, bool]:
    """((F(k) − dual)/F(k), rigorous) at Θ (N, n, p) and the dual point ψ (N, q, n).

    Rigorous: the dual point made feasible (:func:`_dual_bound`). Where no such
    point is available (an unpenalized coefficient), Σ s(|r̃| − ψr̃)/F, the gap
    if the stationarity of Θ with ψ were exact.
    """
    tiny = np.finfo(float).tiny
    bound = _dual_bound(problem, psi, penalty, norm)
    if bound is not None:
        return max(objective - bound, 0.0) / max(objective, tiny), True
    r = problem.residuals(theta)
    gap = float(np.sum(problem.row_scale[:, :, None] * (np.abs(r) - psi * r)))
    return max(gap, 0.0) / max(objective, tiny), False


def _dual_bound(
    problem: RegressionProblem, psi: np.ndarray, penalty: np.ndarray, norm: str
) -> float | None:
    """A lower bound on min F: Laplace's dual at a feasible point made from ψ (N, q, n).

    The dual is max_{|ψ|<=1} Σ sψỹ − P*(v), v = Σ_j s ψ φ̃ (N, K). P* is finite
    only for v ⊥ null(D) (and, for a coefficient held constant, Σ_t v_t = 0):
    ψ is projected onto that subspace (a least-squares correction per
    output). Then v = Dᵀμ with μ = (DDᵀ)⁻¹Dv, and P*(v) = ¼ Σ_t μ_tᵀW⁻¹μ_t
    (norm="sq"), or 0 when every ‖(Λ⁻¹μ)_t‖ of the dual norm is <= 1
    (group: ℓ2, l1: ℓ∞). Dividing ψ by the largest violation of |ψ| <= 1 (and
    of that cone condition) keeps both linear conditions and makes the point
    feasible, so the value is a rigorous lower bound. None when a coefficient
    is unpenalized (weight 0), where P* needs v = 0 at every step.
    """
    N, n, p = problem.N, problem.n, problem.p
    weights = weight_diagonal(penalty) if norm == "sq" else penalty
    if np.any(weights == 0):
        return None
    const = np.isinf(weights).reshape(n, p)
    s = problem.row_scale  # (N, q)
    basis = null_space_basis(N, problem.coeffs)  # (N, d)
    ones = np.full((N, 1), 1.0 / np.sqrt(N))
    psi = psi.copy()
    scaled = s[:, :, None] * problem.phi  # s φ̃ (N, q, p)
    # the outputs with the same constant coefficients share their columns: one
    # least-squares problem with a right-hand side each
    patterns: dict[tuple[bool, ...], list[int]] = {}
    for i in range(n):
        patterns.setdefault(tuple(const[i].tolist()), []).append(i)
    for pattern, outputs in patterns.items():
        # columns Σ_t U_tl s_tj φ̃_tja: ψ_i ⊥ them ⇔ v_i ⊥ null(D) (constants: ⊥ 1)
        columns = [
            (ones if pattern[a] else basis)[:, None, :] * scaled[:, :, a, None] for a in range(p)
        ]
        Z = np.concatenate(columns, axis=2).reshape(-1, sum(c.shape[2] for c in columns))
        target = psi[:, :, outputs].reshape(-1, len(outputs))
        coef, *_ = np.linalg.lstsq(Z, target, rcond=None)
        psi[:, :, outputs] = (target - Z @ coef).reshape(psi.shape[:2] + (len(outputs),))
    weighted = s[:, :, None] * psi  # s ψ (N, q, n)
    v = np.einsum("tji,tja->tia", weighted, problem.phi).reshape(N, n * p)
    mu = difference_preimage(v, problem.coeffs)  # (N − d, K)
    finite = ~np.isinf(weights)
    worst = max(1.0, float(np.abs(psi).max(initial=0.0)))
    if norm != "sq":
        u = mu[:, finite] / weights[finite]
        cone = np.linalg.norm(u, axis=1) if norm == "group" else np.abs(u)
        worst = max(worst, float(cone.max(initial=0.0)))
        conjugate = 0.0
    else:
        mu = mu / worst
        if penalty.ndim == 1:
            conjugate = 0.25 * float(np.sum(mu[:, finite] ** 2 / weights[finite]))
        else:
            block = penalty[np.ix_(finite, finite)]
            conjugate = 0.25 * float(
                np.sum(mu[:, finite] * np.linalg.solve(block, mu[:, finite].T).T)
            )
    value = float(np.einsum("tji,tji->", weighted, problem.y)) / worst
    return value - conjugate


# Polish: ρ relative to the penalty weight over the mean squared regressor of Z,
# ε relative to ρ, the multiplier steps at most, the constraint violation
# (relative to the largest |y|) accepted as zero, and the corrections of the split.
POLISH_RHO = 1e6
POLISH_EPSILON = 1e-30
POLISH_STEPS = 50
POLISH_FEASIBILITY = 1e-13
POLISH_SPLITS = 10


def _weighted_fit(problem, row_weight, pseudo, W) -> np.ndarray | None:
    """argmin Σ a(ŷ − φ̃ᵀk)² + P(k) per output (a = ``row_weight``), or None if singular."""
    n = problem.n
    theta = np.empty((problem.N, n, problem.p))
    for i in range(n):
        scale = np.sqrt(row_weight[:, :, i])
        part = RegressionProblem(
            y=(pseudo[:, :, i] * scale)[:, :, None],
            phi=problem.phi * scale[:, :, None],
            coeffs=problem.coeffs,
        )
        rows = slice(i * problem.p, (i + 1) * problem.p)
        block = W[rows] if W.ndim == 1 else W[rows, rows]
        try:
            theta[:, i, :] = SquaredSolver(part, block, []).solve(1.0)[0][:, 0, :]
        except SingularProblemError:
            return None
    return theta


def _laplace_kkt(problem, theta, W, weighted_psi) -> float:
    """‖∇P(k) − Σ sψφ̃‖ relative to the size of its terms (constants: summed over time).

    The size counts each row's term |sψφ̃| separately (a step's rows may cancel).
    """
    N, K = problem.N, problem.K
    data = np.einsum("tji,tjk->tik", weighted_psi, problem.phi).reshape(N, K)
    terms = np.einsum("tji,tjk->tik", np.abs(weighted_psi), np.abs(problem.phi)).reshape(N, K)
    W0 = SquaredSolver(problem, W, []).W0
    Dk = apply_difference(theta.reshape(N, K), problem.coeffs)
    pen = 2.0 * apply_difference_adjoint(Dk * W0 if W0.ndim == 1 else Dk @ W0, problem.coeffs, N)
    const = np.isinf(np.diag(W) if W.ndim == 2 else W)
    total = pen - data
    residual = np.concatenate([total[:, ~const].ravel(), total[:, const].sum(axis=0)])
    size = np.concatenate([(np.abs(pen) + terms)[:, ~const].ravel(), terms[:, const].sum(axis=0)])
    return float(np.linalg.norm(residual)) / max(float(np.linalg.norm(size)), np.finfo(float).tiny)


def _laplace_loss(problem: RegressionProblem, theta: np.ndarray) -> float:
    """Σ w|r| = Σ s|r̃| at Θ (N, n, p)."""
    return float(np.sum(problem.row_scale[:, :, None] * np.abs(problem.residuals(theta))))


def _objective(problem, theta, penalty, norm) -> float:
    """F at Θ: the Laplacian loss plus the penalty (constant coefficients add 0)."""
    if norm == "sq":
        return _laplace_loss(problem, theta) + SquaredSolver(problem, penalty, []).penalty(theta)
    weights = np.where(np.isinf(penalty), 0.0, penalty)
    scaled = apply_difference(theta.reshape(problem.N, -1), problem.coeffs) * weights
    size = np.linalg.norm(scaled, axis=1).sum() if norm == "group" else np.abs(scaled).sum()
    return _laplace_loss(problem, theta) + float(size)
