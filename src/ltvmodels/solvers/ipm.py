"""norm="group" and norm="l1" by a barrier (interior-point) Newton method.

The problem Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ(Dk)_t) in epigraph form: with
z = ΛDk split into cones (group: one cone of size K per time step; l1: K
cones of size 1),

    minimize  L(k) + Σ s_c   subject to  ‖z_c‖ <= s_c  for every cone c,

is solved by Newton's method on the log-barrier function

    f_μ(k, s) = L(k) + Σ s_c − μ Σ log(s_c² − ‖z_c‖²)

for a decreasing sequence of μ. Eliminating s (one scalar per cone) leaves the
Newton system in k

    (2ΦᵀΦ + DᵀΛ M Λ D) Δk = r,   M_c = (2μ/q_c) (I − 2 z_c z_cᵀ / (s_c² + ‖z_c‖²)),

q_c = s_c² − ‖z_c‖²: block-banded with K × K blocks (block bandwidth d), so
every Newton step is one block Cholesky factorization, O(N d² K³). With the
barrier parameter 2 per cone, a centred point at μ is at most 2·#cones·μ from
the optimal objective: that bound is the reported duality-gap certificate.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceWarning, SingularProblemError
from ..problem import RegressionProblem, apply_difference, apply_difference_adjoint
from . import _blockkernels as kernels


@dataclass
class BarrierResult:
    """Result of :func:`fit_sparse_barrier`."""

    theta: np.ndarray  # (N, n, p)
    objective: float
    gap_bound: float  # certified bound on objective − optimum
    newton_steps: int
    converged: bool


def _band_blocks(P: np.ndarray, coeffs: np.ndarray, N: int) -> list[np.ndarray]:
    """Blocks of Dᵀ blkdiag(P_r) D: entry l is (N − l, K, K) with [s] = block (s+l, s)."""
    d = len(coeffs) - 1
    rows = N - d
    K = P.shape[1]
    bands = []
    for lag in range(d + 1):
        B = np.zeros((N - lag, K, K))
        for j in range(d + 1 - lag):
            B[j : j + rows] += coeffs[j] * coeffs[j + lag] * P
        bands.append(B)
    return bands


class _Barrier:
    """Objective, gradient and Newton direction of f_μ for one problem."""

    def __init__(self, problem: RegressionProblem, weights: np.ndarray, norm: str):
        self.pb = problem
        self.w = weights
        N, n, p = problem.N, problem.n, problem.p
        self.K = n * p
        self.group = self.K if norm == "group" else 1  # cone size
        outer = problem.phi[:, :, None] * problem.phi[:, None, :]
        self.data_hessian = 2.0 * np.einsum("ij,tab->tiajb", np.eye(n), outer).reshape(
            N, self.K, self.K
        )

    def cones(self, k: np.ndarray) -> np.ndarray:
        """z = ΛDk as (rows of D, #cones per row, cone size)."""
        z = apply_difference(k, self.pb.coeffs) * self.w
        return z.reshape(z.shape[0], -1, self.group)

    def loss(self, k: np.ndarray) -> float:
        return float(np.sum(self.pb.residuals(k.reshape(self.pb.N, self.pb.n, self.pb.p)) ** 2))

    def value(self, k: np.ndarray, s: np.ndarray, mu: float) -> float:
        z = self.cones(k)
        q = s**2 - np.sum(z**2, axis=2)
        if np.any(s <= 0) or np.any(q <= 0):
            return np.inf
        return self.loss(k) + float(s.sum()) - mu * float(np.log(q).sum())

    def direction(self, k: np.ndarray, s: np.ndarray, mu: float):
        """Newton direction (Δk, Δs) and the directional derivative ∇fᵀ(Δk, Δs)."""
        pb = self.pb
        N, n, p, K = pb.N, pb.n, pb.p, self.K
        z = self.cones(k)  # (R, C, g)
        zz = np.sum(z**2, axis=2)
        q = s**2 - zz
        g_s = 1.0 - 2.0 * mu * s / q
        g_z = 2.0 * mu * z / q[:, :, None]
        h_ss = 2.0 * mu * (s**2 + zz) / q**2
        h_sz = -4.0 * mu * s[:, :, None] * z / q[:, :, None] ** 2
        resid = pb.residuals(k.reshape(N, n, p))  # y − Θφ
        g_data = (-2.0 * resid[:, :, None] * pb.phi[:, None, :]).reshape(N, K)
        g_k = g_data + apply_difference_adjoint(g_z.reshape(-1, K) * self.w, pb.coeffs, N)
        # Reduced cone curvature M_c, scaled by the weights on both sides.
        R, C, g = z.shape
        eye = np.eye(g)
        Mc = (2.0 * mu / q)[:, :, None, None] * (
            eye - 2.0 * z[:, :, :, None] * z[:, :, None, :] / (s**2 + zz)[:, :, None, None]
        )
        if C == 1:
            P = Mc[:, 0]
        else:  # l1: K cones of size 1, a diagonal block
            P = np.zeros((R, K, K))
            P[:, np.arange(K), np.arange(K)] = Mc[:, :, 0, 0]
        P = P * self.w[None, :, None] * self.w[None, None, :]
        bands = _band_blocks(P, pb.coeffs, N)
        diag = self.data_hessian + bands[0]
        off = np.zeros((len(bands) - 1, N, K, K))
        for lag in range(1, len(bands)):
            off[lag - 1, : N - lag] = bands[lag]
        pull = (h_sz * (g_s / h_ss)[:, :, None]).reshape(R, K) * self.w
        rhs = (-g_k + apply_difference_adjoint(pull, pb.coeffs, N))[:, :, None].copy()
        L = np.empty((N, len(bands), K, K))
        worst, worst_t, _ = kernels.factor_forward_blocks(diag, off, rhs, L)
        # Late barrier steps are badly scaled by design (cone curvature ~ 1/μ next
        # to data curvature ~ 1); only a matrix that is not positive definite is fatal.
        if worst < 0:
            raise SingularProblemError(
                f"the Newton system is singular near time step {worst_t}: the data do not "
                "determine the model; more excitation or a larger lam helps"
            )
        kernels.backward(L, rhs, np.empty((0, K, K)), K)
        dk = rhs[:, :, 0]
        dz = self.cones(dk)
        ds = -(g_s + np.sum(h_sz * dz, axis=2)) / h_ss
        slope = float(np.sum(g_k * dk) + np.sum(g_s * ds))
        return dk, ds, slope


def fit_sparse_barrier(
    problem: RegressionProblem,
    weights: np.ndarray,
    norm: str,
    *,
    tol: float = 1e-8,
    max_newton: int = 500,
    k0: np.ndarray | None = None,
) -> BarrierResult:
    """Minimize Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ(Dk)_t) by a barrier method.

    Parameters
    ----------
    problem : RegressionProblem
    weights : ndarray, shape (K,)
        λ_j > 0 per coefficient.
    norm : {"group", "l1"}
    tol : float
        Relative bound on the duality gap, 2·#cones·μ / objective.
    max_newton : int
        Limit on the total number of Newton steps.
    k0 : ndarray, shape (N, K), optional
        Starting coefficients (default: zeros).
    """
    N, K = problem.N, problem.n * problem.p
    barrier = _Barrier(problem, weights, norm)
    k = np.zeros((N, K)) if k0 is None else np.array(k0, dtype=float)
    z = barrier.cones(k)
    norms = np.sqrt(np.sum(z**2, axis=2))
    scale = max(float(norms.mean()), 1e-3 * float(np.mean(problem.y**2)) ** 0.5 * weights.mean())
    s = norms + scale  # strictly inside every cone
    n_cones = s.size
    objective = barrier.loss(k) + float(norms.sum())
    mu = max(objective, 1e-12) / (2.0 * n_cones)
    steps = 0
    converged = stalled = False
    while steps < max_newton and not stalled:
        # Centering: Newton's method on f_μ with a backtracking line search.
        for _ in range(50):
            try:
                dk, ds, slope = barrier.direction(k, s, mu)
            except SingularProblemError:
                if steps == 0:
                    raise
                # Late in the path cancellation can cost positive definiteness at
                # working precision: stop here and report the bound reached.
                stalled = True
                break
            steps += 1
            if -slope / 2.0 <= 1e-9 * max(objective, 1e-300):
                break
            f0 = barrier.value(k, s, mu)
            alpha = 1.0
            while alpha >= 1e-12:
                f1 = barrier.value(k + alpha * dk, s + alpha * ds, mu)
                if f1 <= f0 + 0.25 * alpha * slope:
                    break
                alpha *= 0.5
            if alpha < 1e-12:
                break  # no decrease at working precision: as centred as it gets
            k = k + alpha * dk
            s = s + alpha * ds
            if steps >= max_newton:
                break
        objective = barrier.loss(k) + float(np.sqrt(np.sum(barrier.cones(k) ** 2, axis=2)).sum())
        if 2.0 * n_cones * mu <= tol * objective:
            converged = True
            break
        if not stalled:
            mu /= 20.0
    if not converged:
        warnings.warn(
            f"the barrier method did not converge in {steps} Newton steps (relative duality "
            f"gap bound {2 * n_cones * mu / objective:.1e}, tolerance {tol:.0e}); increase "
            "max_iter or loosen tol",
            ConvergenceWarning,
            stacklevel=3,
        )
    return BarrierResult(
        theta=k.reshape(N, problem.n, problem.p), objective=objective,
        gap_bound=2.0 * n_cones * mu, newton_steps=steps, converged=converged,
    )
