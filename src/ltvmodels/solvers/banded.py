"""Block-banded symmetric positive definite systems: the linear algebra of norm="sq".

The normal equations of the squared-difference problem for one group of
unknowns θ_t ∈ R^b, t = 0 … N-1, are

    H = blkdiag(G_0, …, G_{N-1}) + (DᵀD) ⊗ W,

where G_t is the per-time Gram matrix (data, plus prior precision) and W the
b × b penalty weight. H is banded with half-bandwidth u = (d + 1)·b − 1 for a
difference operator of degree d, so one LAPACK banded Cholesky (pbtrf) costs
O(N b u²) and every right-hand side O(N b u). Marginal covariances (diagonal
blocks of H⁻¹) come from the same factor by selected inversion (Takahashi's
recursion), compiled with numba because it is a sequential loop over N·b.

Coefficients held constant in time (weight ``inf``) enter as a small dense
border: the varying part is solved banded and the constants via a Schur
complement.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.linalg import cho_factor, cho_solve, cho_solve_banded, cholesky_banded

from ..errors import SingularProblemError
from ..problem import gram_bands

# A pivot whose square is below this fraction of the matrix diagonal it came
# from means the system is singular to working precision.
RELATIVE_PIVOT_TOL = 1e-12

SINGULAR_ADVICE = (
    "Remedies: more excitation in the inputs, a larger lam, a prior "
    "(ltvmodels.Prior), or fewer regressors."
)


def build_banded(gram: np.ndarray, W: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    """Lower band storage of H = blkdiag(gram) + (DᵀD) ⊗ W.

    Parameters
    ----------
    gram : ndarray, shape (N, b, b)
    W : ndarray, shape (b, b)
    coeffs : ndarray, shape (d + 1,)

    Returns
    -------
    ab : ndarray, shape ((d + 1)·b, N·b)
        ``ab[i - j, j] = H[i, j]`` for i >= j (LAPACK lower band storage).
    """
    N, b, _ = gram.shape
    d = len(coeffs) - 1
    bands = gram_bands(N, coeffs)
    ab = np.zeros(((d + 1) * b, N, b))
    for lag in range(min(d, N - 1) + 1):
        # Block H_{s+lag, s} for s = 0 … N-1-lag.
        block = bands[lag][:, None, None] * W
        if lag == 0:
            block = block + gram
        for col in range(b):
            # Entry (row a, column col) of the block lies on band lag·b + a − col;
            # only a >= col is stored for the diagonal block.
            first = col if lag == 0 else 0
            lo = lag * b + first - col
            ab[lo : lo + b - first, : N - lag, col] = block[:, first:, col].T
    return ab.reshape((d + 1) * b, N * b)


@numba.njit(cache=True)
def _selected_inverse_blocks(chol: np.ndarray, b: int) -> np.ndarray:  # pragma: no cover - compiled
    """Diagonal b×b blocks of H⁻¹ from the lower band Cholesky factor of H.

    Takahashi's recursion on LᵀΣ = L⁻¹: for i >= j,
        Σ_ij = (δ_ij / L_jj − Σ_{k=j+1}^{j+u} L_kj Σ_ki) / L_jj,
    run for j from the last column down. Only entries of Σ inside the band are
    needed and kept, in a rolling window of u + 1 columns.
    """
    u = chol.shape[0] - 1
    n = chol.shape[1]
    N = n // b
    # window[j % w, m] = Σ_{j+m, j} for the last w = u + 1 columns processed.
    w = u + 1
    window = np.zeros((w, w))
    out = np.zeros((N, b, b))
    col = np.zeros(w)
    for j in range(n - 1, -1, -1):
        ljj = chol[0, j]
        top = min(u, n - 1 - j)
        for m in range(top, -1, -1):
            i = j + m
            acc = 0.0
            for q in range(1, top + 1):
                k = j + q
                # Σ_ki from the window: column min(k, i), offset |k − i|.
                if k >= i:
                    s = window[i % w, k - i] if i != j else col[q]
                else:
                    s = window[k % w, i - k]
                acc += chol[q, j] * s
            value = ((1.0 / ljj if m == 0 else 0.0) - acc) / ljj
            col[m] = value
        for m in range(top + 1):
            window[j % w, m] = col[m]
        for m in range(top + 1, w):
            window[j % w, m] = 0.0
        t = j // b
        a = j % b
        # Column j of Σ restricted to block t: rows t·b + a … t·b + b − 1.
        for m in range(min(b - a, top + 1)):
            out[t, a + m, a] = col[m]
            out[t, a, a + m] = col[m]
    return out


@dataclass
class BandedCholesky:
    """Cholesky factor of a block-banded SPD matrix of N blocks of size b."""

    chol: np.ndarray  # lower band storage of L
    N: int
    b: int

    @classmethod
    def factor(cls, ab: np.ndarray, N: int, b: int, what: str = "the normal equations") -> BandedCholesky:
        """Factor H given in lower band storage; raise SingularProblemError if singular."""
        diag = ab[0].copy()
        try:
            chol = cholesky_banded(ab, lower=True, overwrite_ab=True, check_finite=False)
        except np.linalg.LinAlgError as exc:
            raise SingularProblemError(
                f"{what} are singular (not positive definite): the data do not determine "
                f"a unique solution. {SINGULAR_ADVICE}"
            ) from exc
        ratio = chol[0] ** 2 / np.where(diag > 0, diag, 1.0)
        worst = int(np.argmin(ratio))
        if ratio[worst] < RELATIVE_PIVOT_TOL:
            raise SingularProblemError(
                f"{what} are singular to working precision near time step {worst // b} "
                f"(relative pivot {ratio[worst]:.1e}). {SINGULAR_ADVICE}"
            )
        return cls(chol=chol, N=N, b=b)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve H X = rhs for rhs of shape (N, b, r); returns (N, b, r)."""
        r = rhs.shape[2]
        flat = np.ascontiguousarray(rhs.reshape(self.N * self.b, r))
        sol = cho_solve_banded((self.chol, True), flat, overwrite_b=True, check_finite=False)
        return sol.reshape(self.N, self.b, r)

    def logdet(self) -> float:
        """log det H."""
        return 2.0 * float(np.sum(np.log(self.chol[0])))

    def marginal_cov(self) -> np.ndarray:
        """Diagonal blocks (N, b, b) of H⁻¹ by selected inversion, O(N b u²)."""
        return _selected_inverse_blocks(self.chol, self.b)


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
        factor = BandedCholesky.factor(build_banded(gram, W, coeffs), N, b, what)
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
        factor = BandedCholesky.factor(
            build_banded(gram[:, V][:, :, V], W[np.ix_(V, V)], coeffs), N, V.size, what
        )
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
