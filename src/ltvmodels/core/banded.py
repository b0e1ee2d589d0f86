"""Block-banded symmetric positive definite systems: the linear algebra of norm="sq".

The normal equations of the squared-difference problem for one group of
unknowns θ_t ∈ R^b, t = 0 … N-1, are

    H = blkdiag(G_0, …, G_{N-1}) + (DᵀD) ⊗ W,

where G_t is the per-time Gram matrix (data, plus prior precision) and W the
b × b penalty weight. H is block-banded with block bandwidth d (the degree of
the difference operator), so its block Cholesky factor costs O(N d² b³) and
every right-hand side O(N d b²). Marginal covariances (diagonal blocks of H⁻¹)
come from the same factor by block selected inversion (Takahashi's
recursion). The kernels are sequential loops over time and live, compiled, in
:mod:`.blockkernels`.

Coefficients held constant in time (weight ``inf``) enter as a small dense
border: the varying part is solved banded and the constants via a Schur
complement.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..errors import SingularProblemError
from . import blockkernels as kernels
from .problem import gram_bands

__all__ = [
    "RELATIVE_PIVOT_TOL",
    "FIXED_BLOCK_SMALL_B",
    "FIXED_BLOCK_MIN_SIZE",
    "BlockSystem",
    "difference_bands",
    "BlockSolution",
    "kernel_size",
    "long_series_size",
    "BlockFactor",
    "solve_block_banded",
    "RowsSolution",
    "solve_shared_rows",
    "WeightedRowsFactor",
    "WeightedRowsKalman",
]

# A pivot whose square is below this fraction of the matrix diagonal it came
# from means the system is singular to working precision.
RELATIVE_PIVOT_TOL = 1e-12

# Kernels compiled for the block size as a constant are faster (factor 1.2 at
# b = 8 to 3 at b = 2 for the selected inversion) and compile in the same time
# as the general version (about 3 s, then cached on disk), but once per block
# size. Small blocks (the usual state-space models) always use them: a loop of
# many small fits repeats one size; larger ones from this many unknowns (N·b)
# on, which long series repay.
FIXED_BLOCK_SMALL_B = 8
FIXED_BLOCK_MIN_SIZE = 250_000
# Beyond this block size unrolling bloats the compiled code more than it helps.
FIXED_BLOCK_MAX_B = 16
# The bands of DᵀD are kept for series up to this length (small fits repeat them).
CACHED_BANDS_MAX_N = 20_000

SINGULAR_ADVICE = (
    "Remedies: more excitation in the inputs, a larger lam, a prior "
    "(ltvmodels.Prior), or fewer regressors."
)


@dataclass
class BlockSystem:
    """H = blkdiag(G_t) + (DᵀD) ⊗ W with G_t = data_scale·(I_r ⊗ φ_tφ_tᵀ) + E_t.

    Attributes
    ----------
    phi : ndarray, shape (N, q, p)
        Regressors shared by the r = n_rep output rows in this system (q rows
        per time step, whose Gram matrices add up).
    n_rep : int
        1 when rows decouple (b = p), n for the coupled form (b = n·p).
    data_scale : float
        1 to include the data, 0 for the prior alone.
    extra : ndarray, shape (0 | 1 | N, b, b)
        Extra Gram blocks (prior precision); leading size 1 broadcasts.
    W : ndarray, shape (b, b)
        Penalty weight; an infinite diagonal entry holds that coefficient
        constant in time.
    coeffs : ndarray
        Difference operator coefficients c_0 … c_d.
    """

    phi: np.ndarray
    n_rep: int
    data_scale: float
    extra: np.ndarray
    W: np.ndarray
    coeffs: np.ndarray

    @property
    def N(self) -> int:
        return self.phi.shape[0]

    @property
    def b(self) -> int:
        return self.W.shape[0]

    def bands(self) -> np.ndarray:
        """(d+1, N) diagonals of DᵀD, zero-padded (see :func:`difference_bands`)."""
        return difference_bands(self.N, self.coeffs)

    def gram(self) -> np.ndarray:
        """The Gram blocks G_t as an (N, b, b) array."""
        phi_gram = self.data_scale * _phi_outer(self.phi)
        G = np.zeros((self.N, self.b, self.b))
        p = self.phi.shape[2]
        for i in range(self.n_rep):
            G[:, i * p : (i + 1) * p, i * p : (i + 1) * p] = phi_gram
        if self.extra.shape[0]:
            G += self.extra
        return G


def difference_bands(N: int, coeffs: np.ndarray) -> np.ndarray:
    """(d+1, N) diagonals of DᵀD, zero-padded: row lag holds (DᵀD)_{s+lag, s}.

    For N <= ``CACHED_BANDS_MAX_N`` the array is shared between calls with the
    same operator and length: read it, never write it. (It stays writeable: a
    read-only array would compile the kernels once more.)
    """
    if N <= CACHED_BANDS_MAX_N:
        return _cached_bands(N, tuple(np.asarray(coeffs, dtype=float).tolist()))
    return _make_bands(N, coeffs)


@lru_cache(maxsize=16)  # at most 16 · 3 · 20 000 numbers (order 2)
def _cached_bands(N: int, coeffs: tuple) -> np.ndarray:
    return _make_bands(N, np.array(coeffs))


def _make_bands(N: int, coeffs: np.ndarray) -> np.ndarray:
    d = len(coeffs) - 1
    out = np.zeros((d + 1, N))
    for lag, band in enumerate(gram_bands(N, coeffs)):
        out[lag, : band.size] = band
    return out


def _phi_outer(phi: np.ndarray) -> np.ndarray:
    """(N, p, p) array of Σ_j φ_tj φ_tjᵀ for φ of shape (N, q, p)."""
    return np.einsum("tja,tjb->tab", phi, phi)


@dataclass
class BlockSolution:
    """Solution of one block system.

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


def _check_pivots(worst: float, worst_t: int, what: str) -> None:
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


def kernel_size(N: int, b: int) -> int | tuple:
    """The block size as the kernels take it: an int, or a tuple of that length.

    A tuple selects the kernels compiled for that block size as a constant
    (small blocks, or long series; see ``FIXED_BLOCK_SMALL_B``).
    """
    if b <= FIXED_BLOCK_SMALL_B or (N * b >= FIXED_BLOCK_MIN_SIZE and b <= FIXED_BLOCK_MAX_B):
        return (0,) * b
    return b


def long_series_size(N: int, b: int) -> int | tuple:
    """:func:`kernel_size` for long series only (from FIXED_BLOCK_MIN_SIZE unknowns on),
    else the int b: for the per-entry passes of the robust losses' iterations, which a
    constant size makes 10-30 % faster at T = 10⁵ (p = 5) but whose compilation costs
    2-4 s for every new size, which the short series of tests and loops of small fits
    would pay for each of their sizes."""
    if N * b >= FIXED_BLOCK_MIN_SIZE and b <= FIXED_BLOCK_MAX_B:
        return (0,) * b
    return b


def _factor_forward(system: BlockSystem, rhs: np.ndarray, what: str):
    """Factor H and forward-substitute ``rhs`` in place; returns (L, logdet, size)."""
    N, b = system.N, system.b
    d = len(system.coeffs) - 1
    L = np.empty((N, d + 1, b, b))
    size = kernel_size(N, b)  # a tuple selects the version compiled for this b
    worst, worst_t, logdet = kernels.factor_forward(
        np.ascontiguousarray(system.phi),
        system.n_rep,
        float(system.data_scale),
        np.ascontiguousarray(system.extra),
        np.ascontiguousarray(system.W),
        system.bands(),
        rhs,
        L,
        size,
    )
    _check_pivots(worst, worst_t, what)
    return L, logdet, size


def _factor_solve(system: BlockSystem, rhs: np.ndarray, compute_cov: bool, what: str):
    """Factor, solve and (optionally) selected-invert; returns (X, cov, logdet).

    ``rhs`` (N, b, r) is overwritten with the solution X if it is C-contiguous
    float, otherwise a C-contiguous copy is: the kernels specialize on the
    layout, and another one (a concatenation of F-ordered parts, as the bordered
    solve's can be) compiled the factorization and solve again, ~5 s.
    """
    rhs = np.ascontiguousarray(rhs, dtype=float)
    L, logdet, size = _factor_forward(system, rhs, what)
    cov = np.empty((system.N if compute_cov else 0, system.b, system.b))
    kernels.backward(L, rhs, cov, size)
    return rhs, (cov if compute_cov else None), logdet


class BlockFactor:
    """A factorization of H kept for many right-hand sides (e.g. ADMM iterations).

    Constant coefficients (inf weights) are not supported here.
    """

    def __init__(self, system: BlockSystem, what: str = "the normal equations") -> None:
        if np.isinf(np.diag(system.W)).any():
            raise ValueError("BlockFactor does not handle constant (inf-weight) coefficients")
        self.N, self.b = system.N, system.b
        self.L, self.logdet, self._size = _factor_forward(
            system, np.zeros((system.N, system.b, 0)), what
        )

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve H X = rhs; ``rhs`` (N, b, r), C-contiguous float, is overwritten and returned."""
        kernels.solve(self.L, rhs, self._size)
        return rhs


def solve_block_banded(
    system: BlockSystem, rhs: np.ndarray, *, compute_cov: bool, what: str = "the normal equations"
) -> BlockSolution:
    """Solve H θ = rhs for rhs of shape (N, b, r), with constants where diag(W) = inf.

    ``rhs`` is an array owned by the caller: if C-contiguous float, it is
    overwritten (with the solution when no coefficient is constant), otherwise
    a C-contiguous copy is.

    Raises
    ------
    SingularProblemError
        If H is singular to working precision.
    """
    # A layout of its own (e.g. a sum with a transposed array) would compile the
    # kernels once more (numba specializes on it), ~2.5 s on first use.
    rhs = np.ascontiguousarray(rhs, dtype=float)
    const = np.isinf(np.diag(system.W))
    if not const.any():
        theta, cov, logdet = _factor_solve(system, rhs, compute_cov, what)
        return BlockSolution(theta=theta, cov=cov, logdet=logdet)
    return _solve_bordered(system, rhs, const, compute_cov=compute_cov, what=what)


@dataclass
class RowsSolution:
    """Solution of :func:`solve_shared_rows`.

    Attributes
    ----------
    theta : ndarray, shape (N, n, p)
        One solution per output row, in the layout of Θ.
    cov : ndarray, shape (N, p, p) or None
        Diagonal blocks of H⁻¹ (the same for every row).
    logdet : float
        log det H (of one row's system).
    rss, squares : ndarray, shape (n,)
        Σ_tj (y_tjc − Θ_t[c]·φ_tj)² and Σ_t Σ_a w_a ((DΘ)_t[c, a])² per row c.
    gram_trace : float
        Σ_t Σ_j ‖φ_tj‖², the trace of the data's part of H.
    """

    theta: np.ndarray
    cov: np.ndarray | None
    logdet: float
    rss: np.ndarray
    squares: np.ndarray
    gram_trace: float


def solve_shared_rows(
    phi: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    coeffs: np.ndarray,
    *,
    compute_cov: bool,
    what: str = "the normal equations",
) -> RowsSolution:
    """Solve H θ_c = Σ_j φ_tj y_tjc for every output row c with one factorization of
    H = blkdiag_t(Σ_j φ_tj φ_tjᵀ) + DᵀD ⊗ diag(w) (rows sharing a finite diagonal weight).

    Two compiled sweeps over the raw arrays (φ (N, q, p) and y (N, q, n),
    C-contiguous float): no Gram blocks, right-hand sides, bands of DᵀD or
    transposed copies are built, and the residual and penalty sums come out of
    the back substitution.

    Raises
    ------
    SingularProblemError
        If H is singular to working precision.
    """
    N, _, p = phi.shape
    n = y.shape[2]
    coeffs = np.ascontiguousarray(coeffs, dtype=float)
    w = np.ascontiguousarray(w, dtype=float)
    theta = np.empty((N, n, p))
    # Without covariances a first difference stores the lower triangles of the
    # diagonal blocks alone, packed (the off-diagonal blocks are recomputed, bit for
    # bit, in the backward sweep): p(p+1)/2 numbers a step instead of 2p², the
    # largest array of the fit, whose first touch dominates a one-off call. (Its huge
    # pages stay: 4 KiB pages, by madvise, made calls that reuse freed memory slower.)
    if len(coeffs) == 2 and not compute_cov:
        L = np.empty((N, p * (p + 1) // 2))
    else:
        L = np.empty((N, len(coeffs), p, p))
    size = kernel_size(N, p)
    worst, worst_t, logdet, trace = kernels.rows_factor_forward(phi, y, w, coeffs, theta, L, size)
    _check_pivots(worst, worst_t, what)
    cov = np.empty((N if compute_cov else 0, p, p))
    rss, squares = np.empty(n), np.empty(n)
    kernels.rows_backward(L, theta, cov, phi, y, w, coeffs, rss, squares, size)
    return RowsSolution(theta, cov if compute_cov else None, logdet, rss, squares, trace)


class WeightedRowsFactor:
    """A factorization per output row c of H_c = blkdiag_t(Σ_j a_tjc φ_tjφ_tjᵀ) + DᵀD ⊗ diag(w_c),
    all in one sweep over time: the Newton systems of the robust losses, whose
    residual weights a differ by output while φ, D and the sweep are shared.

    Parameters
    ----------
    phi : ndarray, shape (N, q, p)
        The regressors (C-contiguous float).
    a : ndarray, shape (N, q, n)
        Row weights a_tjc >= 0 of each output.
    w : ndarray, shape (n, p)
        Diagonal penalty weight of each output, finite.
    coeffs : ndarray
        Difference operator coefficients c_0 … c_d.
    rhs : ndarray, shape (n, N, p, r)
        Right-hand sides (r may be 0), C-contiguous float: forward-substituted in
        place, :meth:`finish` completes their solution.
    active : ndarray, shape (n,), bool
        The outputs to factor (the others' parts of ``rhs`` and ``out`` are left alone).
    out : ndarray, optional
        Storage for the factors, reused between calls (an array of this size,
        freshly allocated, costs page faults comparable to the sweep): shape
        (n, N, d+1, p, p), or (n, N, 1, p, p) for a first difference (d = 1).
    what : str
        What is factored, for the error message.

    Raises
    ------
    SingularProblemError
        If an active H_c is singular to working precision.
    """

    def __init__(
        self,
        phi: np.ndarray,
        a: np.ndarray,
        w: np.ndarray,
        coeffs: np.ndarray,
        rhs: np.ndarray,
        active: np.ndarray,
        *,
        out: np.ndarray | None = None,
        what: str = "the normal equations",
    ) -> None:
        N, _, p = phi.shape
        n = a.shape[2]
        coeffs = np.ascontiguousarray(coeffs, dtype=float)
        shape = (n, N, 1 if len(coeffs) == 2 else len(coeffs), p, p)
        self.w, self.coeffs = np.ascontiguousarray(w, dtype=float), coeffs
        self.L = out if out is not None and out.shape == shape else np.empty(shape)
        self.active = np.ascontiguousarray(active, dtype=np.bool_)
        self._size = kernel_size(N, p)
        worst, worst_t = np.empty(n), np.zeros(n, dtype=np.int64)
        kernels.weighted_rows_factor_forward(
            phi, a, self.w, coeffs, self.active, rhs, self.L, worst, worst_t, self._size
        )
        for c in np.flatnonzero(self.active):
            _check_pivots(float(worst[c]), int(worst_t[c]), what)

    def finish(self, rhs: np.ndarray) -> np.ndarray:
        """Complete the solution of the right-hand sides forward-substituted by the
        factorization (in place; returned)."""
        kernels.weighted_rows_solve(
            self.L, rhs, self.w, self.coeffs, self.active, False, self._size
        )
        return rhs

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve H_c x = rhs_c for the active outputs; ``rhs`` (n, N, p, r), C-contiguous
        float, is overwritten and returned."""
        kernels.weighted_rows_solve(self.L, rhs, self.w, self.coeffs, self.active, True, self._size)
        return rhs


class WeightedRowsKalman:
    """The systems of :class:`WeightedRowsFactor` for a first difference, solved by a
    Kalman filter and smoother in covariance form (one rank-one update per row),
    with the rows given by weight and target instead of a right-hand side.

    Solves, for each active output c,

        H_c θ_c = Σ_j b_tjc φ_tj,   H_c = blkdiag_t(Σ_j a_tjc φ_tjφ_tjᵀ) + DᵀD ⊗ diag(w_c),

    that is, minimizes Σ_tj (a_tjc (φ_tjᵀθ_t)² − 2 b_tjc φ_tjᵀθ_t) + Σ_t ‖Dθ‖²_diag(w_c).
    The filter's steps depend on each other through a few dot products only, where
    the block Cholesky sweep's go through a b × b factorization: 3.5–4× (three
    outputs) to 4.5–5.5× (one) faster at p = 5, T = 10⁵ (the factorization's
    storage reused), and rows of weight 0 cost nothing.
    The first steps, before the data determine every coefficient, run in
    information form (see :func:`.blockkernels.weighted_rows_kalman`).

    Parameters
    ----------
    N, q, p, n : int
        Steps, rows per step, regressors and outputs: the work arrays' sizes
        (p(p + 3)/2 + (p + 2)q numbers per step and output), kept between solves.
    """

    def __init__(self, N: int, q: int, p: int, n: int) -> None:
        self.cov = np.empty((n, N, p * (p + 1) // 2))
        self.mean = np.empty((n, N, p))
        self.rows = np.empty((n, N, q, p + 2))
        self._size = kernel_size(N, p)

    @staticmethod
    def applies(coeffs: np.ndarray, w: np.ndarray) -> bool:
        """Whether the difference is a first difference (c_0 = −c_1 ≠ 0) and every
        weight w (n, p) positive and finite."""
        coeffs = np.asarray(coeffs, dtype=float)
        return bool(
            coeffs.size == 2
            and coeffs[1] != 0.0
            and coeffs[0] == -coeffs[1]
            and np.all(np.isfinite(w))
            and np.all(w > 0)
        )

    def solve(
        self,
        phi: np.ndarray,
        a: np.ndarray,
        targets: np.ndarray,
        w: np.ndarray,
        coeffs: np.ndarray,
        active: np.ndarray,
        out: np.ndarray,
        linear: np.ndarray | None = None,
        replay: bool = False,
        max_reduction: float = np.inf,
    ) -> np.ndarray:
        """Solve the active outputs' systems into ``out`` (n, N, p).

        ``phi`` (N, q, p), ``a`` and ``targets`` (N, q, n) and ``w`` (n, p), C-contiguous
        float, with :meth:`applies` true for ``coeffs`` and ``w``. ``linear`` (n, N, p),
        C-contiguous float, adds a general term g_tc to each right-hand side (H_c θ_c =
        Σ_j b_tjc φ_tj + g_tc): a right-hand side the rows do not carry, e.g. a Newton
        step's, with ``targets`` zero (it costs about one more product with P_t a step,
        and no rounding of a large target against a large weight). Returns the active
        outputs (n,) bool left unsolved: those whose information matrix never
        became well conditioned, or met a matrix that is not positive definite
        (singular systems): factor them with :class:`WeightedRowsFactor`, which
        also reports the singular ones.

        ``replay``: the last solve had the same ``phi``, ``a``, ``w`` and ``coeffs``
        and every output of ``active`` among its active ones (only the right-hand side
        differs, e.g. Mehrotra's corrector after the predictor): the filter reuses its
        covariances and gains, which leaves about a third of its work per step, with
        the same result bit for bit.

        ``max_reduction``: an output with a row whose update divides the variance along
        its regressor by more than this (1 + a φᵀPφ; the covariance form loses about
        log10 of it in digits) is left unsolved too (default: none is).
        """
        n = a.shape[2]
        status = np.empty(n, dtype=np.int64)
        scale = float(coeffs[1]) ** 2  # ‖c_1 (θ_{t+1} − θ_t)‖²: the weight times c_1²
        if linear is None:
            linear = np.empty((n, 0, phi.shape[2]))
        kernels.weighted_rows_kalman(
            phi,
            a,
            targets,
            linear,
            np.ascontiguousarray(w * scale, dtype=float),
            np.ascontiguousarray(active, dtype=np.bool_),
            bool(replay),
            self.cov,
            self.mean,
            self.rows,
            out,
            status,
            self._size,
            float(max_reduction),
        )
        return np.asarray(active, dtype=bool) & (status < 0)


def _solve_bordered(system: BlockSystem, rhs, const, *, compute_cov, what) -> BlockSolution:
    """Constant coefficients c shared by all t: the system [[A, E], [Eᵀ, G]].

    A is the banded system of the varying coefficients, E_t = G_t[V, C] and
    G = Σ_t G_t[C, C]. Eliminating the varying part leaves the Schur
    complement S = G − Eᵀ A⁻¹ E of size |C|.
    """
    N, b, r = rhs.shape
    V = np.flatnonzero(~const)
    C = np.flatnonzero(const)
    gram = system.gram()
    E = gram[:, V][:, :, C]  # (N, |V|, |C|)
    G = gram[:, C][:, :, C].sum(axis=0)
    rhs_C = rhs[:, C, :].sum(axis=0)  # (|C|, r)
    if V.size:
        varying = BlockSystem(
            phi=system.phi,
            n_rep=1,
            data_scale=0.0,
            extra=gram[:, V][:, :, V],
            W=system.W[np.ix_(V, V)],
            coeffs=system.coeffs,
        )
        X, cov_A, logdet_A = _factor_solve(
            varying, np.concatenate([rhs[:, V, :], E], axis=2), compute_cov, what
        )
        X_rhs, X_E = X[:, :, :r], X[:, :, r:]
        schur = G - np.einsum("tvc,tvd->cd", E, X_E)
        schur_rhs = rhs_C - np.einsum("tvc,tvr->cr", E, X_rhs)
    else:  # every coefficient constant: plain least squares
        cov_A, logdet_A = None, 0.0
        X_rhs, X_E = np.zeros((N, 0, r)), np.zeros((N, 0, C.size))
        schur, schur_rhs = G, rhs_C
    try:
        schur_factor = cho_factor(0.5 * (schur + schur.T), lower=True, check_finite=False)
    except np.linalg.LinAlgError as exc:
        raise SingularProblemError(
            f"{what}: the coefficients held constant (lam = inf) are not identified by the "
            f"data. {SINGULAR_ADVICE}"
        ) from exc
    ratio = np.diag(schur_factor[0]) ** 2 / np.maximum(np.diag(G), 1e-300)
    if ratio.min() < RELATIVE_PIVOT_TOL:
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
        if V.size:
            cov[:, V[:, None], V] = cov_A + np.einsum("tvc,twc->tvw", XS, X_E)
    return BlockSolution(theta=theta, cov=cov, logdet=logdet)
