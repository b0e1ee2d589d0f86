"""Block-banded symmetric positive definite systems: the linear algebra of norm="sq".

The normal equations of the squared-difference problem for one group of
unknowns θ_t ∈ R^b, t = 0 … N-1, are

    H = blkdiag(G_0, …, G_{N-1}) + (DᵀD) ⊗ W,

where G_t is the per-time Gram matrix (data, plus prior precision) and W the
b × b penalty weight. H is block-banded with block bandwidth d (the degree of the
difference operator), so its block Cholesky factor costs O(N d² b³) and every
right-hand side O(N d b²). Marginal covariances (diagonal blocks of H⁻¹) come
from the same factor by block selected inversion (Takahashi's recursion). The
kernels are sequential loops over time and live, compiled, in
:mod:`._blockkernels`.

Coefficients held constant in time (weight ``inf``) enter as a small dense
border: the varying part is solved banded and the constants via a Schur
complement.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..errors import SingularProblemError
from ..problem import gram_bands
from ._blockkernels import block_cholesky, block_selected_inverse, block_solve

# A pivot whose square is below this fraction of the matrix diagonal it came
# from means the system is singular to working precision.
RELATIVE_PIVOT_TOL = 1e-12

SINGULAR_ADVICE = (
    "Remedies: more excitation in the inputs, a larger lam, a prior "
    "(ltvmodels.Prior), or fewer regressors."
)


@dataclass
class BlockCholesky:
    """Cholesky factor of H = blkdiag(G_t) + (DᵀD) ⊗ W, N blocks of size b."""

    L: np.ndarray  # (N, d+1, b, b), L[t, l] = L_{t, t−l}

    @classmethod
    def factor(
        cls, gram: np.ndarray, W: np.ndarray, coeffs: np.ndarray, what: str = "the normal equations"
    ) -> BlockCholesky:
        """Factor H; raise SingularProblemError if it is singular to working precision."""
        N, b, _ = gram.shape
        d = len(coeffs) - 1
        bands = np.zeros((d + 1, N))
        for lag, band in enumerate(gram_bands(N, coeffs)):
            bands[lag, : band.size] = band
        L, worst, worst_t = block_cholesky(
            np.ascontiguousarray(gram), np.ascontiguousarray(W), bands
        )
        if worst < 0:
            raise SingularProblemError(
                f"{what} are singular (not positive definite at time step {worst_t}): the "
                f"data do not determine a unique solution. {SINGULAR_ADVICE}"
            )
        if worst < RELATIVE_PIVOT_TOL:
            raise SingularProblemError(
                f"{what} are singular to working precision near time step {worst_t} "
                f"(relative pivot {worst:.1e}). {SINGULAR_ADVICE}"
            )
        return cls(L=L)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve H X = rhs for rhs of shape (N, b, r); returns (N, b, r)."""
        return block_solve(self.L, np.ascontiguousarray(rhs, dtype=float))

    def logdet(self) -> float:
        """log det H."""
        return 2.0 * float(np.sum(np.log(np.diagonal(self.L[:, 0], axis1=1, axis2=2))))

    def marginal_cov(self) -> np.ndarray:
        """Diagonal blocks (N, b, b) of H⁻¹ by selected inversion, O(N d² b³)."""
        return block_selected_inverse(self.L)


@dataclass
class BlockSolution:
    """Solution of the bordered system for one group of rows.

    Attributes
    ----------
    theta : ndarray, shape (N, b, r)
        Solution for r right-hand sides.
    cov : ndarray, shape (N, b, b) or None
        Diagonal blocks of H⁻¹.
    logdet : float
        log det H.
    """

    theta: np.ndarray
    cov: np.ndarray | None
    logdet: float


def solve_block_banded(
    gram: np.ndarray,
    rhs: np.ndarray,
    W: np.ndarray,
    coeffs: np.ndarray,
    *,
    compute_cov: bool,
    what: str = "the normal equations",
) -> BlockSolution:
    """Solve (blkdiag(gram) + DᵀD ⊗ W) θ = rhs, with constants where diag(W) = inf.

    Parameters
    ----------
    gram : ndarray, shape (N, b, b)
        Per-time Gram matrices (symmetric positive semidefinite).
    rhs : ndarray, shape (N, b, r)
    W : ndarray, shape (b, b)
        Penalty weight; an infinite diagonal entry holds that coefficient
        constant over time (its row/column is otherwise ignored).
    coeffs : ndarray
        Difference operator coefficients.
    compute_cov : bool
        Also return the diagonal blocks of H⁻¹ (selected inversion).
    """
    N, b, r = rhs.shape
    const = np.isinf(np.diag(W))
    if not const.any():
        factor = BlockCholesky.factor(gram, W, coeffs, what)
        theta = factor.solve(rhs)
        cov = factor.marginal_cov() if compute_cov else None
        return BlockSolution(theta=theta, cov=cov, logdet=factor.logdet())
    return _solve_bordered(gram, rhs, W, coeffs, const, compute_cov=compute_cov, what=what)


def _solve_bordered(gram, rhs, W, coeffs, const, *, compute_cov, what) -> BlockSolution:
    """Constant coefficients c shared by all t: the system [[A, E], [Eᵀ, G]].

    A is the banded system of the varying coefficients, E_t = gram_t[V, C] and
    G = Σ_t gram_t[C, C]. Eliminating the varying part leaves the Schur
    complement S = G − Eᵀ A⁻¹ E of size |C|.
    """
    N, b, r = rhs.shape
    V = np.flatnonzero(~const)
    C = np.flatnonzero(const)
    E = gram[:, V][:, :, C]  # (N, |V|, |C|)
    G = gram[:, C][:, :, C].sum(axis=0)
    rhs_C = rhs[:, C, :].sum(axis=0)  # (|C|, r)
    if V.size:
        factor = BlockCholesky.factor(gram[:, V][:, :, V], W[np.ix_(V, V)], coeffs, what)
        X = factor.solve(np.concatenate([rhs[:, V, :], E], axis=2))
        X_rhs, X_E = X[:, :, :r], X[:, :, r:]
        schur = G - np.einsum("tvc,tvd->cd", E, X_E)
        schur_rhs = rhs_C - np.einsum("tvc,tvr->cr", E, X_rhs)
        logdet_A = factor.logdet()
    else:  # every coefficient constant: plain least squares
        factor = None
        X_rhs, X_E = np.zeros((N, 0, r)), np.zeros((N, 0, C.size))
        schur, schur_rhs, logdet_A = G, rhs_C, 0.0
    try:
        schur_factor = cho_factor(0.5 * (schur + schur.T), lower=True, check_finite=False)
    except np.linalg.LinAlgError as exc:
        raise SingularProblemError(
            f"{what}: the coefficients held constant (lam = inf) are not identified by the "
            f"data. {SINGULAR_ADVICE}"
        ) from exc
    diag_s = np.diag(schur_factor[0]) ** 2 / np.maximum(np.diag(G), 1e-300)
    if diag_s.min() < RELATIVE_PIVOT_TOL:
        raise SingularProblemError(
            f"{what}: the coefficients held constant (lam = inf) are not identified by the "
            f"data (singular to working precision). {SINGULAR_ADVICE}"
        )
    c = cho_solve(schur_factor, schur_rhs, check_finite=False)  # (|C|, r)
    theta = np.empty((N, b, r))
    theta[:, C, :] = c
    theta[:, V, :] = X_rhs - np.einsum("tvc,cr->tvr", X_E, c)
    logdet = logdet_A + 2.0 * float(np.sum(np.log(np.diag(schur_factor[0]))))
    cov = None
    if compute_cov:
        S_inv = cho_solve(schur_factor, np.eye(C.size), check_finite=False)
        cov = np.empty((N, b, b))
        XS = np.einsum("tvc,cd->tvd", X_E, S_inv)
        cov[:, C[:, None], C] = S_inv
        cov[:, V[:, None], C] = -XS
        cov[:, C[:, None], V] = -np.swapaxes(XS, 1, 2)
        if factor is not None:
            cov[:, V[:, None], V] = factor.marginal_cov() + np.einsum("tvc,twc->tvw", XS, X_E)
    return BlockSolution(theta=theta, cov=cov, logdet=logdet)
