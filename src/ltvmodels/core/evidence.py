"""The log marginal likelihood of the squared norm at a scalar λ, by one forward sweep.

For ``norm="sq"`` with a scalar λ and no prior, every output row i solves the
same banded system H = blkdiag(Σ_j φ_tj φ_tjᵀ) + λ²(DᵀD ⊗ I_p) with its own
right-hand side b_i = Φᵀy_i, and the minimum of row i's objective is

    RSS_i + penalty_i = ‖y_i‖² − b_iᵀ H⁻¹ b_i = ‖y_i‖² − ‖L⁻¹ b_i‖²,

with H = L Lᵀ. So the log marginal likelihood that :func:`.squared.fit_squared`
computes (noise variance at its maximum-likelihood value per row) needs only
the factorization and the forward substitution: no back substitution, no
residuals, no differencing — the work of one factorization per λ, which is
what a search over λ repeats. The λ-independent parts (right-hand sides, ‖y_i‖²,
the bands of DᵀD) are computed once per problem.

The subtraction loses digits when a row's fit is nearly exact (RSS_i + penalty_i
≪ ‖y_i‖²); there :meth:`ScalarEvidence.loglik` says so (returns None) and the
caller evaluates the full fit instead.
"""

from __future__ import annotations

import numpy as np

from . import blockkernels as kernels
from .banded import RELATIVE_PIVOT_TOL, difference_bands, kernel_size
from .problem import RegressionProblem

LOG_2PI = float(np.log(2.0 * np.pi))

# Below this ratio of a row's minimum to ‖y_i‖², the subtraction would keep
# fewer than about 8 significant digits of the minimum.
CANCELLATION_LIMIT = 1e-8


class ScalarEvidence:
    """log p(y | λ) of the squared norm for many scalar λ on one problem (see the module).

    Parameters
    ----------
    problem : RegressionProblem
        Without constant (infinite-weight) coefficients and without priors.
    """

    def __init__(self, problem: RegressionProblem) -> None:
        N, n, p = problem.N, problem.n, problem.p
        d = problem.degree
        self.N, self.n, self.p, self.d = N, n, p, d
        self.phi = np.ascontiguousarray(problem.phi)
        self.rhs = np.ascontiguousarray(problem.cross())  # (N, p, n)
        self.yy = np.einsum("tji,tji->i", problem.y, problem.y)  # ‖y_i‖² (n,)
        self.bands = difference_bands(N, problem.coeffs)
        self.size = kernel_size(N, p)
        self.n_eff = problem.n_observed - d * p  # observed rows less the diffuse directions
        self.log_cd = float(np.log(abs(problem.coeffs[-1])))
        self._L = np.empty((N, d + 1, p, p))
        self._Z = np.empty_like(self.rhs)
        self._extra = np.zeros((0, p, p))

    def loglik(self, lam: float) -> float | None:
        """log p(y | λ) as :func:`.squared.fit_squared` defines it with ``noise_var=None``.

        Returns None where the value is not available this way: H singular to
        working precision, too few observations for the noise variances, or a
        nearly exact fit (see the module docstring).
        """
        N, p, d = self.N, self.p, self.d
        if self.n_eff <= 0 or not lam > 0:
            return None
        weight = lam * lam
        self._Z[...] = self.rhs
        worst, _, logdet = kernels.factor_forward(
            self.phi, 1, 1.0, self._extra, weight * np.eye(p), self.bands, self._Z,
            self._L, self.size)
        if worst < RELATIVE_PIVOT_TOL:
            return None
        cost = self.yy - np.einsum("tai,tai->i", self._Z, self._Z)  # RSS_i + penalty_i
        if np.any(cost < CANCELLATION_LIMIT * self.yy):
            return None
        variances = np.maximum(cost / self.n_eff, np.finfo(float).tiny)
        # log pdet of the penalty as a prior (SquaredSolver.log_penalty_normalizer):
        # p directions per row, each with (N − d) differences of weight λ² / c_d².
        log_pdet = p * (N - d) * (2.0 * self.log_cd + np.log(weight))
        return float(np.sum(
            -0.5 * self.n_eff * (LOG_2PI + np.log(variances))
            + 0.5 * log_pdet - 0.5 * logdet - 0.5 * cost / variances))
