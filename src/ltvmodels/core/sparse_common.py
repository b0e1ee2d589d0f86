"""What the sparse-norm solvers share: the penalized quadratic fit, the null-space fit and λ_max.

For the problem Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ(Dk)_t) with R a group or l1
norm (:mod:`.ipm`, :mod:`.admm`):

* :class:`QuadraticUpdate` — argmin ‖y − Φk‖² + (ρ/2)‖ΛDk − v‖², ADMM's k-update
  and (with v = 0) the interior-point method's feasible start;
* :func:`null_space_fit` — the least-squares fit with Dk = 0, the solution at
  λ ≥ λ_max;
* :func:`lambda_max` — the smallest λ at which that fit is optimal.
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.linalg import solveh_banded

from .banded import BlockFactor, BlockSystem
from .penalties import Penalty
from .precompiled import attach
from .problem import (
    RegressionProblem,
    apply_difference,
    apply_difference_adjoint,
    null_space_basis,
)
from .widekernels import one_blas_thread

__all__ = [
    "QuadraticUpdate",
    "null_space_fit",
    "lambda_max",
    "difference_preimage",
]


class QuadraticUpdate:
    """argmin_k ‖y − Φk‖² + (ρ/2)‖ΛDk − v‖² for many v, factored once per group of equal rows.

    ADMM's k-update (with v = z − w) and the interior-point method's start
    (with v = 0). The matrix is the squared-norm solver's with ρ/2·Λ² in place
    of W, so output rows with equal weights share one block-banded factor.
    """

    def __init__(self, problem: RegressionProblem, weights: np.ndarray, rho: float):
        n, p = problem.n, problem.p
        self.problem, self.weights, self.rho = problem, weights, rho
        W_rows = (weights.reshape(n, p) ** 2) * (rho / 2.0)
        self.groups: list[tuple[list[int], BlockFactor]] = []
        for i in range(n):
            for rows, _ in self.groups:
                if np.array_equal(W_rows[rows[0]], W_rows[i]):
                    rows.append(i)
                    break
            else:
                system = BlockSystem(
                    problem.phi, 1, 1.0, np.zeros((0, p, p)), np.diag(W_rows[i]), problem.coeffs
                )
                self.groups.append(([i], BlockFactor(system)))
        self.data_rhs = problem.cross()  # (N, p, n)

    def __call__(self, z_minus_w: np.ndarray | None) -> np.ndarray:
        """Θ (N, n, p) minimizing ‖y − Φk‖² + (ρ/2)‖ΛDk − (z − w)‖² (z − w = 0 if None)."""
        pb = self.problem
        N, n, p = pb.N, pb.n, pb.p
        pull = None
        if z_minus_w is not None:
            pull = apply_difference_adjoint(z_minus_w * self.weights, pb.coeffs, N)
            pull = (self.rho / 2.0) * pull.reshape(N, n, p).transpose(0, 2, 1)  # (N, p, n)
        theta = np.empty((N, n, p))
        for rows, factor in self.groups:
            rhs = self.data_rhs[:, :, rows]
            if pull is not None:
                rhs = rhs + pull[:, :, rows]
            theta[:, rows, :] = factor.solve(np.ascontiguousarray(rhs)).transpose(0, 2, 1)
        return theta


def null_space_fit(problem: RegressionProblem) -> np.ndarray:
    """Least squares with Dk = 0 (the LTI fit for order 1); returns Θ̄ (N, n, p).

    Every coefficient trajectory lies in null(D); the rows share the regressor.
    """
    N, p = problem.N, problem.p
    U = null_space_basis(N, problem.coeffs)  # (N, d)
    Z = (U[:, None, :, None] * problem.phi[:, :, None, :]).reshape(N * problem.q, -1)
    # A tall, narrow least-squares problem: threads do not pay, and on a loaded
    # machine they stalled it (N = 4000, d·p = 10: 115 ms against 0.7 ms on one).
    with one_blas_thread():
        coef, *_ = np.linalg.lstsq(Z, problem.y.reshape(-1, problem.n), rcond=None)  # (d·p, n)
    theta = np.einsum("tl,lan->tna", U, coef.reshape(U.shape[1], p, problem.n))
    return np.ascontiguousarray(theta)


def lambda_max(
    problem: RegressionProblem,
    penalty: Penalty,
    weights: np.ndarray | None = None,
    theta_bar: np.ndarray | None = None,
) -> float:
    """Smallest λ (scaling ``weights``) for which the solution has Dk = 0.

    At λ ≥ λ_max the minimizer is the least-squares fit within the null space
    of D (the LTI model for order 1). Optimality of that k̄ requires a dual
    vector ν with Dᵀν = −∇‖y − Φk̄‖² = −g and R*(ν/λ) finite, i.e.
    ‖ν_t / w‖₂ ≤ λ (group) or |ν_tj / w_j| ≤ λ (l1): the dual norms of the
    penalty's cones. D has full row rank and g
    is orthogonal to null(D) at k̄, so ν = −(DDᵀ)⁻¹ D g is the unique solution.

    Parameters
    ----------
    problem : RegressionProblem
    penalty : Penalty
        A sparse penalty (:mod:`.penalties`).
    weights : ndarray, shape (K,), optional
        Relative weights (default ones); coefficients with weight 0 are free.
    theta_bar : ndarray, shape (N, n, p), optional
        :func:`null_space_fit` of the problem, if already computed.
    """
    K = problem.K
    weights = np.ones(K) if weights is None else weights
    theta = null_space_fit(problem) if theta_bar is None else theta_bar
    g = problem.gradient(theta)
    free = weights == 0  # unpenalized coefficients: their dual part is unconstrained
    nu = -difference_preimage(g, problem.coeffs)
    scaled = nu[:, ~free] / weights[~free]
    return float(penalty.dual_norms(scaled).max(initial=0.0))


def difference_preimage(v: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    """μ = (DDᵀ)⁻¹ D v, shape (N − d, ...): the solution of Dᵀμ = v when v ⊥ null(D).

    One banded solve (D has full row rank); v is (N, ...).
    """
    d = len(coeffs) - 1
    c = np.asarray(coeffs, dtype=float)
    if d == 1 and c[0] == -c[1] and c[0] != 0 and v.shape[0] > 1:
        # First differences: null(D) is the constants and Dᵀμ = v − mean(v) is solved
        # by a running sum, μ_s = Σ_{r<=s} (v_r − v̄) / c_0 — the same least-squares
        # solution as the banded Cholesky solve below (and more accurate: no
        # factor of a matrix of condition ~N²), in two passes over v.
        flat = np.ascontiguousarray(v, dtype=float).reshape(v.shape[0], -1)
        return _first_difference_preimage(flat, float(c[0])).reshape((-1,) + v.shape[1:])
    acf = np.array([np.dot(c[: d + 1 - lag], c[lag:]) for lag in range(d + 1)])
    rows = v.shape[0] - d
    ab = np.zeros((d + 1, rows))
    for lag in range(d + 1):
        ab[d - lag, lag:] = acf[lag]  # upper band storage of D Dᵀ
    Dv = apply_difference(v, c)
    # LAPACK's banded solver needs two rows or more
    return Dv / acf[0] if rows == 1 else solveh_banded(ab, Dv, check_finite=False)


@numba.njit(cache=True)
def _first_difference_preimage(v, c0):  # pragma: no cover - compiled
    """μ (N − 1, K) with μ_s = Σ_{r<=s} (v_r − v̄) / c_0 for v (N, K): Dᵀμ = v − v̄ for
    D = c_0·(first differences), one pass for the means and one for the sums."""
    N, K = v.shape
    mean = np.zeros(K)
    for t in range(N):
        for j in range(K):
            mean[j] += v[t, j]
    for j in range(K):
        mean[j] /= N
    out = np.empty((N - 1, K))
    running = np.zeros(K)
    for t in range(N - 1):
        for j in range(K):
            running[j] += v[t, j] - mean[j]
            out[t, j] = running[j] / c0
    return out


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
