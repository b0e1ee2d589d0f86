"""The log marginal likelihood of the squared norm at a scalar λ, by one forward sweep.

For ``norm="sq"`` with a scalar λ and no prior, every output row i solves the
same banded system H = blkdiag(Σ_j φ_tj φ_tjᵀ) + λ²(DᵀD ⊗ I_p) with its own
right-hand side b_i = Φᵀy_i, and the minimum of row i's objective is

    RSS_i + penalty_i = ‖y_i‖² − b_iᵀ H⁻¹ b_i = ‖y_i‖² − ‖L⁻¹ b_i‖²,

with H = L Lᵀ. So the log marginal likelihood that :func:`.squared.fit_squared`
computes (noise variance at its maximum-likelihood value per row) needs only
the factorization and the forward substitution: no back substitution, no
residuals, no differencing — the work of one factorization per λ, which is
what a search over λ repeats, by the fit's own kernels (which form the right-hand
sides as they sweep); ‖y_i‖² is computed once per problem. The same factorization with
the back substitution (and, for the degrees of freedom, the selected inversion)
gives the residual and penalty norms that GCV and the L-curve score
(:meth:`ScalarEvidence.solution`), again without a fit.

The subtraction loses digits when a row's fit is nearly exact (RSS_i + penalty_i
≪ ‖y_i‖²); there :meth:`ScalarEvidence.loglik` says so (returns None) and the
caller evaluates the full fit instead. It also loses digits when λ is large
for the data (H ill-conditioned: ‖L⁻¹b_i‖² is then accurate to eps·κ(H) only,
which moved the maximum of the criterion on some series); there the minimum is
RSS_i + penalty_i of the solution (one back substitution more), as in the fit.
"""

from __future__ import annotations

import math

import numpy as np

from . import blockkernels as kernels
from .banded import RELATIVE_PIVOT_TOL, kernel_size
from .problem import RegressionProblem

__all__ = ["ScalarEvidence"]

LOG_2PI = float(np.log(2.0 * np.pi))
TINY = float(np.finfo(float).tiny)
EPS = float(np.finfo(float).eps)

# Below this ratio of a row's minimum to ‖y_i‖², the subtraction would keep
# fewer than about 8 significant digits of the minimum.
CANCELLATION_LIMIT = 1e-8
# ‖L⁻¹ b_i‖² carries a relative error of about eps·κ(H), and κ(H) grows like the
# penalty's scale over the data's (λ²(Σ|c_j|)² / mean diag Σφφᵀ, the ratio of
# SquaredSolver.digits_lost): measured, the log-likelihood's error is about 1e3
# times eps times that ratio. Beyond this value of eps·ratio (errors above
# ~1e-9) the minimum is computed from the solution instead, as the fit does.
SUBTRACTION_LIMIT = 1e-12


class ScalarEvidence:
    """log p(y | λ), and the fit's norms, of the squared norm for many scalar λ on one
    problem (see the module).

    Parameters
    ----------
    problem : RegressionProblem
        Without constant (infinite-weight) coefficients and without priors.
    """

    def __init__(self, problem: RegressionProblem) -> None:
        N, n, p = problem.N, problem.n, problem.p
        d = problem.degree
        self.N, self.n, self.p, self.d = N, n, p, d
        # the arrays as the fit's kernels take them (banded.solve_shared_rows)
        self.phi = np.ascontiguousarray(problem.phi)  # (N, q, p)
        self.y = np.ascontiguousarray(problem.y)  # (N, q, n)
        self.coeffs = np.ascontiguousarray(problem.coeffs, dtype=float)
        self.yy = np.einsum("tji,tji->i", problem.y, problem.y)  # ‖y_i‖² (n,)
        self.size = kernel_size(N, p)
        self.n_eff = problem.n_observed - d * p  # observed rows less the diffuse directions
        self.log_cd = float(np.log(abs(problem.coeffs[-1])))
        self._L = np.empty((N, d + 1, p, p))
        self._Z = np.empty((N, n, p))  # L⁻¹ b_i, then Θ (the layout of Θ)
        self._no_cov = np.zeros((0, p, p))
        self.problem = problem
        # The ratio of SquaredSolver.digits_lost, less λ²: penalty scale over data scale.
        # (einsum, not vdot: a BLAS call wakes its thread pool, which costs more than
        # this sum where the other cores are busy)
        data = float(np.einsum("tja,tja->", problem.phi, problem.phi)) / (N * p)
        self.conditioning = float(np.abs(problem.coeffs).sum()) ** 2 / data if data > 0 else np.inf
        self._weights = np.empty(p)  # λ² per regressor (a scalar λ)
        self._logdet = 0.0
        self.yy_list = self.yy.tolist()

    def loglik(self, lam: float) -> float | None:
        """log p(y | λ) as :func:`.squared.fit_squared` defines it with ``noise_var=None``.

        Returns None where the value is not available this way: H singular to
        working precision, too few observations for the noise variances, or a
        nearly exact fit (see the module docstring).
        """
        N, p, d = self.N, self.p, self.d
        n_eff = self.n_eff
        if n_eff <= 0 or not lam > 0:
            return None
        weight = lam * lam
        if self._factor(weight) < RELATIVE_PIVOT_TOL:
            return None
        logdet = self._logdet
        if weight * self.conditioning * EPS > SUBTRACTION_LIMIT:
            costs = self._solution_costs(weight)
        else:
            squares = np.einsum("tia,tia->i", self._Z, self._Z).tolist()  # ‖L⁻¹ b_i‖² per row
            costs = [yy - square for yy, square in zip(self.yy_list, squares, strict=True)]
            if any(
                cost < CANCELLATION_LIMIT * yy for cost, yy in zip(costs, self.yy_list, strict=True)
            ):
                return None
        # log pdet of the penalty as a prior (SquaredSolver.log_penalty_normalizer):
        # p directions per row, each with (N − d) differences of weight λ² / c_d².
        log_pdet = p * (N - d) * (2.0 * self.log_cd + math.log(weight))
        # The n rows' terms on Python numbers: a candidate λ is a few small vectors,
        # for which numpy's per-call overhead would cost a third of the factorization.
        total = 0.0
        for cost in costs:  # RSS_i + penalty_i
            variance = max(cost / n_eff, TINY)
            total += (
                -0.5 * n_eff * (LOG_2PI + math.log(variance))
                + 0.5 * log_pdet
                - 0.5 * logdet
                - 0.5 * cost / variance
            )
        return total

    def solution(self, lam: float, *, dof: bool = False) -> dict | None:
        """The numbers of the fit at λ that the criteria other than the likelihood need.

        One factorization, forward and back substitution (with ``dof`` also the
        diagonal blocks of H⁻¹ by selected inversion), without building a fit.

        Returns
        -------
        dict or None
            "rss" (Σ_i RSS_i), "penalty_norm" (‖Dk‖₂ over all coefficients)
            and with ``dof`` the effective degrees of freedom
            tr(Φ H⁻¹ Φᵀ) = n Σ_t Σ_j φ_tjᵀ (H⁻¹)_tt φ_tj (every output row has
            the same H); None where H is singular to working precision.
        """
        weight = lam * lam
        if not lam > 0 or self._factor(weight) < RELATIVE_PIVOT_TOL:
            return None
        cov = np.empty((self.N, self.p, self.p)) if dof else self._no_cov
        rss, penalty = self._back_substitution(cov)
        out = {"rss": float(rss.sum()), "penalty_norm": float(np.sqrt(penalty.sum() / weight))}
        if dof:
            out["dof"] = self.n * float(np.einsum("tja,tab,tjb->", self.phi, cov, self.phi))
        return out

    def _factor(self, weight: float) -> float:
        """Factor H at λ² = ``weight`` and forward-substitute; the worst relative pivot."""
        self._weights.fill(weight)
        worst, _, self._logdet, _ = kernels.rows_factor_forward(
            self.phi, self.y, self._weights, self.coeffs, self._Z, self._L, self.size
        )
        return worst

    def _back_substitution(self, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Θ into ``_Z`` (and the diagonal blocks of H⁻¹ into ``cov`` unless it is empty),
        after :meth:`_factor`; RSS_i and penalty_i = λ²‖Dθ_i‖² (n,) of that solution."""
        rss, penalty = np.empty(self.n), np.empty(self.n)
        kernels.rows_backward(
            self._L, self._Z, cov, self.phi, self.y, self._weights, self.coeffs, rss, penalty,
            self.size,
        )  # fmt: skip
        return rss, penalty

    def _solution_costs(self, weight: float) -> list[float]:
        """RSS_i + penalty_i of the solution, after :meth:`loglik`'s forward sweep."""
        rss, penalty = self._back_substitution(self._no_cov)
        return (rss + penalty).tolist()
