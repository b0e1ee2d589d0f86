"""norm="group" and norm="l1" by a primal-dual interior-point method.

The problem Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ(Dk)_t) is written as a conic
quadratic program: with z = ΛDk split into cones c (group: one cone of size K
per row of D; l1: K cones of size 1 per row),

    minimize  ‖y − Φk‖² + Σ_c t_c   subject to  (t_c, z_c) ∈ Q  (‖z_c‖ <= t_c),

and solved by the primal-dual path-following method with Nesterov–Todd
scaling and Mehrotra's predictor–corrector steps (as in CVXOPT's ``coneqp``,
Vandenberghe 2010), which needs 15–30 iterations almost independently of N.

Structure makes each iteration O(N): the scaling W_c of cone c is a
hyperbolic Householder matrix η_c (2 w̄_c w̄_cᵀ − J), so after eliminating the
slacks and the epigraph variables t_c (one scalar per cone) the Newton system
in k is

    (2ΦᵀΦ + DᵀΛ S Λ D) Δk = r,   S_c = η_c⁻² (I − 8 w̄₀² w̄₁ w̄₁ᵀ / (1 + 8 w̄₀² ‖w̄₁‖²)),

block-banded with K × K blocks and block bandwidth d, like the squared-norm
normal equations. One block Cholesky factorization per iteration serves both
the predictor and the corrector.

Notation: a cone vector v = (v₀, v₁) with v₀ scalar; J = diag(1, −I); the
Jordan product u ∘ v = (uᵀv, u₀v₁ + v₀u₁) with identity e = (1, 0).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceWarning, SingularProblemError
from ..problem import RegressionProblem
from . import _blockkernels as kernels
from . import _conekernels as cones

# Fraction of the way to the cone boundary taken by a step (CVXOPT's STEP).
STEP_FRACTION = 0.99
# A step shorter than this makes no progress: the iterate is as good as it gets.
MIN_STEP = 1e-10
# Use the kernels compiled for a constant block size from this many unknowns on.
FIXED_KERNEL_MIN_SIZE = 20_000


@dataclass
class InteriorPointResult:
    """Result of :func:`fit_sparse_ipm`."""

    theta: np.ndarray  # (N, n, p)
    objective: float  # Σ‖y_t − Θ_tφ_t‖² + Σ_t R(Λ(Dk)_t) at theta
    duality_gap: float  # sᵀz: primal minus dual objective of the conic program
    primal_residual: float  # relative ‖s − (t, ΛDk)‖
    dual_residual: float  # relative norm of the stationarity residual
    iterations: int
    converged: bool


class _ConicProblem:
    """The data of the conic program, its workspace and the operators it needs.

    Cone vectors are (n_cones, g + 1) arrays as in :mod:`._conekernels`.
    """

    def __init__(self, problem: RegressionProblem, weights: np.ndarray, norm: str):
        self.pb = problem
        self.N, self.n, self.p, self.K = problem.N, problem.n, problem.p, problem.K
        self.coeffs = np.ascontiguousarray(problem.coeffs, dtype=float)
        self.rows = self.N - problem.degree
        self.w = np.ascontiguousarray(weights, dtype=float)
        g = self.K if norm == "group" else 1  # cone size without t
        self.n_cones = self.rows * (self.K // g)
        self.cone_shape = (self.n_cones, g + 1)
        self.phi = np.ascontiguousarray(problem.phi)
        self.phity = (problem.y[:, :, None] * self.phi[:, None, :]).reshape(self.N, self.K)
        size = self.N * self.K
        self.fixed = (0,) * self.K if size >= FIXED_KERNEL_MIN_SIZE and self.K <= 16 else None
        self.S = np.empty((self.rows, self.K, self.K))
        self.L = np.empty((self.N, problem.degree + 1, self.K, self.K))

    def cones(self, k: np.ndarray, t: np.ndarray | float = 0.0) -> np.ndarray:
        """The cone vectors (t_c, (ΛDk)_c)."""
        out = np.empty(self.cone_shape)
        out[:, 0] = t
        cones.weighted_difference(k, self.coeffs, self.w, out)
        return out

    def residuals(self, k: np.ndarray) -> np.ndarray:
        return self.pb.residuals(k.reshape(self.N, self.n, self.p))

    def half_gradient(self, k: np.ndarray) -> np.ndarray:
        """ΦᵀΦk − Φᵀy = −Φᵀ(y − Φk), (N, K)."""
        return (-self.residuals(k)[:, :, None] * self.phi[:, None, :]).reshape(self.N, self.K)

    def objective(self, k: np.ndarray) -> float:
        reg = np.sqrt(np.sum(self.cones(k)[:, 1:] ** 2, axis=-1)).sum()
        return float(np.sum(self.residuals(k) ** 2) + reg)

    def factor(self) -> None:
        """Factor 2ΦᵀΦ + DᵀΛSΛD (the penalty blocks in ``self.S``) into ``self.L``."""
        rhs = np.empty((self.N, self.K, 0))
        if self.fixed is not None:
            worst, worst_t, _ = kernels.factor_forward_penalty_fixed(
                self.phi, self.n, 2.0, self.S, self.coeffs, rhs, self.L, self.fixed
            )
        else:
            worst, worst_t, _ = kernels.factor_forward_penalty(
                self.phi, self.n, 2.0, self.S, self.coeffs, rhs, self.L, self.K
            )
        if worst < 0:
            raise SingularProblemError(
                f"the Newton system is singular near time step {worst_t}: the data do not "
                "determine the model; more excitation or a larger lam helps"
            )

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve the factored Newton system for rhs (N, K), in place."""
        X = rhs[:, :, None]
        if self.fixed is not None:
            kernels.solve_fixed(self.L, X, self.fixed)
        else:
            kernels.solve(self.L, X, self.K)
        return rhs


class _NewtonSystem:
    """The linearized KKT system at one iterate, factored once for several targets.

    Newton's equations for the residuals r_x = (r_t, r_k) (stationarity in t
    and k) and r_z = s − (t, ΛDk) (the cone constraints), in scaled form, are

        P Δx + GᵀΔz = −r_x,   GΔx + Δs = −r_z,   λ ∘ (WΔz + W⁻¹Δs) = target,

    with G(t, k) = −(t, ΛDk). Eliminating Δs, then Δz = W⁻²(GΔx + r̂) with
    r̂ = r_z + W(λ ⋄ target), then Δt per cone, leaves the banded system in Δk.
    """

    def __init__(self, cp: _ConicProblem, s, z, r_z, r_t, r_k):
        self.cp, self.r_z, self.r_t, self.r_k = cp, r_z, r_t, r_k
        n_cones, m = s.shape
        self.v, self.eta, self.lam = np.empty_like(s), np.empty(n_cones), np.empty_like(s)
        self.alpha, self.beta = np.empty(n_cones), np.empty((n_cones, m - 1))
        self.s_coef = np.empty(n_cones)
        cones.nt_scaling(s, z, self.v, self.eta, self.lam)
        cones.newton_blocks(self.v, self.eta, cp.w, cp.S, self.alpha, self.beta, self.s_coef)
        cp.factor()

    def scale(self, x: np.ndarray, power: float) -> np.ndarray:
        """W x (power 1) or W⁻¹ x (power −1), as a new array."""
        out = np.empty_like(x)
        cones.apply_scaling(self.v, self.eta, x, power, out)
        return out

    def direction(self, target: np.ndarray):
        """(Δk, Δt, Δs, Δz) for the complementarity target."""
        cp = self.cp
        work = np.empty_like(target)
        cones.jordan_divide(self.lam, target, work)
        r_hat = self.scale(work, 1.0) + self.r_z
        u = self.scale(self.scale(r_hat, -1.0), -1.0)  # W⁻² r̂
        f_t = u[:, 0] - self.r_t
        work[:, 1:] = u[:, 1:] - self.beta * (f_t / self.alpha)[:, None]
        rhs = -self.r_k
        cones.add_weighted_difference_adjoint(work, cp.coeffs, cp.w, 1.0, rhs)
        dk = cp.solve(rhs)
        dv = cp.cones(dk)  # (Δt, ΛDΔk), Δt from its elimination
        dv[:, 0] = (f_t - np.sum(self.beta * dv[:, 1:], axis=1)) / self.alpha
        # Δz = u − W⁻²(Δt, e) with e = ΛDΔk. By the elimination, (W⁻²(Δt, e))₀ = f_t
        # and (W⁻²(Δt, e))₁ = S e + β f_t/α: no cancellation between large terms.
        dz = work
        dz[:, 0] = self.r_t
        cones.apply_schur(self.v, self.eta, self.s_coef, dv, dz)
        return dk, dv[:, 0].copy(), dv - self.r_z, dz


def fit_sparse_ipm(
    problem: RegressionProblem,
    weights: np.ndarray,
    norm: str,
    *,
    tol: float = 1e-8,
    max_iter: int = 100,
    k0: np.ndarray | None = None,
) -> InteriorPointResult:
    """Minimize Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ(Dk)_t) by a primal-dual interior-point method.

    Parameters
    ----------
    problem : RegressionProblem
    weights : ndarray, shape (K,)
        λ_j > 0 per coefficient.
    norm : {"group", "l1"}
    tol : float
        Stop when the duality gap relative to the objective and both
        residuals relative to the data scale are below ``tol``.
    max_iter : int
        Limit on the number of iterations.
    k0 : ndarray, shape (N, K), optional
        Starting coefficients (default: zeros).

    Returns
    -------
    InteriorPointResult
    """
    cp = _ConicProblem(problem, weights, norm)
    N, K, n_cones = cp.N, cp.K, cp.n_cones
    k = np.zeros((N, K)) if k0 is None else np.array(k0, dtype=float)
    # Start: s = (‖z_c‖ + δ, z_c) with t = s₀, so the cone constraints hold;
    # dual z = e. Then the gap is δ per cone; δ matches the objective's scale.
    s = cp.cones(k)
    delta = max(cp.objective(k) / n_cones, 1e-12)
    s[:, 0] = np.sqrt(np.sum(s[:, 1:] ** 2, axis=1)) + delta
    t = s[:, 0].copy()
    z = np.zeros_like(s)
    z[:, 0] = 1.0
    scale_k = 1.0 + 2.0 * float(np.linalg.norm(cp.phity))
    converged = stalled = False
    iterations = 0
    while True:
        r_z = s - cp.cones(k, t)
        r_t = 1.0 - z[:, 0]
        r_k = 2.0 * cp.half_gradient(k)
        cones.add_weighted_difference_adjoint(z, cp.coeffs, cp.w, -1.0, r_k)
        gap = float(np.sum(s * z))
        objective = cp.objective(k)
        primal_res = float(np.linalg.norm(r_z)) / (1.0 + float(np.linalg.norm(s)))
        dual_res = max(float(np.linalg.norm(r_k)) / scale_k, float(np.abs(r_t).max()))
        if gap <= tol * max(objective, 1e-300) and primal_res <= tol and dual_res <= tol:
            converged = True
            break
        if iterations == max_iter:
            break
        try:
            newton = _NewtonSystem(cp, s, z, r_z, r_t, r_k)
        except SingularProblemError:
            if iterations == 0:
                raise
            # Near the optimum the scaling of cones at their vertex grows without
            # bound; when it costs positive definiteness at working precision,
            # the current iterate is as accurate as this arithmetic allows.
            stalled = True
            break
        iterations += 1
        lam_sq = np.empty_like(s)
        cones.jordan_product(newton.lam, newton.lam, lam_sq)
        # Predictor (affine) step, then Mehrotra's corrector with the target
        # σμe − λ∘λ − (W⁻¹Δs_a) ∘ (WΔz_a), σ = (1 − α_a)³.
        _, _, ds_a, dz_a = newton.direction(-lam_sq)
        step = min(1.0, cones.max_step(s, ds_a), cones.max_step(z, dz_a))
        target = np.empty_like(s)
        cones.jordan_product(newton.scale(ds_a, -1.0), newton.scale(dz_a, 1.0), target)
        target += lam_sq
        target *= -1.0
        target[:, 0] += (1.0 - step) ** 3 * gap / n_cones
        dk, dt, ds, dz = newton.direction(target)
        step = min(1.0, STEP_FRACTION * min(cones.max_step(s, ds), cones.max_step(z, dz)))
        if step < MIN_STEP:
            stalled = True
            break
        k += step * dk
        t += step * dt
        s += step * ds
        z += step * dz
    if not converged:
        reason = ("stalled at the limit of working precision" if stalled
                  else f"did not converge in {max_iter} iterations")
        warnings.warn(
            f"the interior-point method {reason} (relative gap "
            f"{gap / max(objective, 1e-300):.1e}, relative residuals {primal_res:.1e} and "
            f"{dual_res:.1e}; tolerance {tol:.0e}); increase max_iter or loosen tol",
            ConvergenceWarning,
            stacklevel=3,
        )
    return InteriorPointResult(
        theta=k.reshape(N, problem.n, problem.p), objective=objective, duality_gap=gap,
        primal_residual=primal_res, dual_residual=dual_res, iterations=iterations,
        converged=converged,
    )
