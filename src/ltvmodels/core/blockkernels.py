"""Compiled kernels for symmetric positive definite block-banded matrices.

The matrix H has N × N blocks of size b × b and block bandwidth d:

    H_{t,s} = δ_{ts} G_t + β_{t−s}(s) W   for 0 <= t − s <= d,

where β_l(s) = (DᵀD)_{s+lag,s} are the diagonals of DᵀD, W is the penalty weight
and the Gram blocks are

    G_t = data_scale · (I_r ⊗ φ_t φ_tᵀ) + E_t,        b = r · p,

(φ_t ∈ R^p the shared regressor, r = 1 when output rows decouple, r = n for
the coupled form) plus optional extra blocks E_t (prior precision). The data
part is formed on the fly so that no N × b × b array is ever built.

The Cholesky factor L has the same block structure, stored as
``L[t, lag] = L_{t, t−lag}`` (shape (N, d+1, b, b), ``L[t, 0]`` lower triangular),
except that the diagonal of ``L[t, 0]`` holds the reciprocal pivots 1/L_aa:
every use divides by a pivot, and a multiplication is several times cheaper
than a division on the dependency chains of the sweeps.
Two sweeps do everything: forward (factor + forward substitution) and
backward (back substitution + selected inversion).

The block size b is an argument of every kernel, ``size``: an int, or a
tuple of length b. A tuple's length is part of its type, so a tuple compiles
one version per block size with b a compile-time constant, and the b × b
loops unroll. That is 1.2× (b = 8) to 3× (b = 2) faster and compiles in about
the same time, but once per block size (cached on disk); :mod:`.banded` uses
it for small blocks and for long series. (The ``*_fixed`` names are the same
kernels, for callers that pass the tuple.)
Small explicit loops over b × b blocks are several times faster than LAPACK's
banded routines here, whose per-column BLAS calls dominate at small
bandwidths.

Compilation time: the helpers below are inlined into the kernels (numba's
``inline="always"``) once, not through a second wrapper per variant: numba's
inlining of an inlined function's inlined helpers took about 1 s per kernel.
"""

from __future__ import annotations

import numba
import numpy as np
from numba.core import types
from numba.extending import intrinsic

from .precompiled import attach

__all__ = [
    "block_size",
    "offdiagonal_step",
    "diagonal_step",
    "factor_forward",
    "backward",
    "solve",
    "rowwise_matvec",
    "residual_and_difference_squares",
    "rows_factor_forward",
    "rows_backward",
    "first_difference_solve",
    "weighted_rows_factor_forward",
    "weighted_rows_solve",
    "weighted_rows_kalman",
    "KALMAN_SWITCH_RATIO",
    "solve_fixed",
    "PAIRED_RHS_MIN_B",
]

# first_difference_solve solves its right-hand sides two at a time for blocks
# larger than this (see there).
PAIRED_RHS_MIN_B = 8


@intrinsic
def block_size(typingctx, size):  # pragma: no cover - compiled
    """The block size b from a kernel's ``size`` argument (an int, or a tuple of length b).

    For a tuple b is a constant of the compiled code. (An intrinsic: numba's
    overloads cost about 0.3 s more compilation on first use.)
    """
    if isinstance(size, types.BaseTuple):
        b = len(size)

        def codegen(context, builder, signature, args):
            return context.get_constant(types.intp, b)

        return types.intp(size), codegen
    if isinstance(size, types.Integer):

        def codegen(context, builder, signature, args):
            return context.cast(builder, args[0], size, types.intp)

        return types.intp(size), codegen
    return None


@numba.njit(cache=True, inline="always")
def _gram_entry(phi, n_rep, data_scale, extra, t, i, j):  # pragma: no cover - compiled
    """Entry (i, j) of G_t; φ is (N, q, p): the q rows of step t add up."""
    p = phi.shape[2]
    value = extra[t if extra.shape[0] > 1 else 0, i, j] if extra.shape[0] > 0 else 0.0
    if data_scale != 0.0 and i // p == j // p:
        a, b = i % p, j % p
        if phi.shape[1] == 1:  # one trajectory: the common case, without the row loop
            value += data_scale * phi[t, 0, a] * phi[t, 0, b]
        else:
            acc = 0.0
            for r in range(phi.shape[1]):
                acc += phi[t, r, a] * phi[t, r, b]
            value += data_scale * acc
    return value


@numba.njit(cache=True, inline="always")
def _cholesky_block(A, ref, b):  # pragma: no cover - compiled
    """Lower Cholesky of A in place (reciprocal pivots on the diagonal); smallest pivot² / ref_a.

    Returns −1 if A is not positive definite.
    """
    # The smallest ratio pivot² / ref is kept as a fraction (num / den) and
    # divided out once: divisions are the slow operations of a small block.
    num = np.inf
    den = 1.0
    # Right-looking elimination without square roots first: each pivot waits
    # only for one division, not for a square root and a division.
    for j in range(b):
        s = A[j, j]
        if not ref[j] > 0 or s <= 0.0:
            return -1.0
        if s * den < num * ref[j]:
            num = s
            den = ref[j]
        inv_s = 1.0 / s
        for i in range(j + 1, b):
            f = A[i, j] * inv_s
            for k in range(j + 1, i + 1):
                A[i, k] -= f * A[k, j]
    # Then scale the columns: L_ij = A_ij / √A_jj, off the chain above.
    for j in range(b):
        inv = 1.0 / np.sqrt(A[j, j])
        A[j, j] = inv  # the reciprocal pivot (see the module docstring)
        for i in range(j + 1, b):
            A[i, j] *= inv
        for i in range(j):
            A[i, j] = 0.0
    return num / den


@numba.njit(cache=True, inline="always")
def _forward_step(L, X, t, d, b):  # pragma: no cover - compiled
    """z_t = L_tt⁻¹ (rhs_t − Σ_l L_{t,t−lag} z_{t−lag}), in place in X."""
    r = X.shape[2]
    for lag in range(1, min(d, t) + 1):
        Ll = L[t, lag]
        for i in range(b):
            for c in range(r):
                acc = 0.0
                for q in range(b):
                    acc += Ll[i, q] * X[t - lag, q, c]
                X[t, i, c] -= acc
    Ltt = L[t, 0]
    for c in range(r):
        for i in range(b):
            acc = X[t, i, c]
            for q in range(i):
                acc -= Ltt[i, q] * X[t, q, c]
            X[t, i, c] = acc * Ltt[i, i]


@numba.njit(cache=True, inline="always")
def _backward_step(L, X, t, d, b):  # pragma: no cover - compiled
    """x_t = L_tt⁻ᵀ (z_t − Σ_l L_{t+lag,t}ᵀ x_{t+lag}), in place in X."""
    N = L.shape[0]
    r = X.shape[2]
    for lag in range(1, min(d, N - 1 - t) + 1):
        Ll = L[t + lag, lag]
        for c in range(r):
            for i in range(b):
                acc = 0.0  # in a register: X[t] and X[t + lag] may alias for the compiler
                for q in range(b):
                    acc += Ll[q, i] * X[t + lag, q, c]
                X[t, i, c] -= acc
    Ltt = L[t, 0]
    for c in range(r):
        for i in range(b - 1, -1, -1):
            acc = X[t, i, c]
            for q in range(i + 1, b):
                acc -= Ltt[q, i] * X[t, q, c]
            X[t, i, c] = acc * Ltt[i, i]


@numba.njit(cache=True, inline="always")
def offdiagonal_step(L, M, t, lag, d, b):  # pragma: no cover - compiled
    """L_{t,s} = (M − Σ_j L_{t,j} L_{s,j}ᵀ) L_ss⁻ᵀ for s = t − lag; M holds H_{t,s}."""
    s = t - lag
    for jj in range(max(0, t - d), s):
        Lt = L[t, t - jj]
        Ls = L[s, s - jj]
        for i in range(b):
            for j in range(b):
                acc = 0.0
                for q in range(b):
                    acc += Lt[i, q] * Ls[j, q]
                M[i, j] -= acc
    # Forward substitution on each row of M against L_ssᵀ.
    Lss = L[s, 0]
    out = L[t, lag]
    for j in range(b):
        inv = Lss[j, j]
        for i in range(b):
            acc = M[i, j]
            for q in range(j):
                acc -= out[i, q] * Lss[j, q]
            out[i, j] = acc * inv


@numba.njit(cache=True, inline="always")
def diagonal_step(L, t, d, b, ref):  # pragma: no cover - compiled
    """Finish block row t: L[t, 0] holds H_tt (lower triangle), ref its diagonal.

    Subtracts Σ_l L_{t,t−l} L_{t,t−l}ᵀ and factors the block. Returns the
    smallest pivot² / ref ratio, −1 if not positive definite.
    """
    Ltt = L[t, 0]
    for lag in range(1, min(d, t) + 1):
        Ll = L[t, lag]
        for i in range(b):
            for j in range(i + 1):
                acc = 0.0
                for q in range(b):
                    acc += Ll[i, q] * Ll[j, q]
                Ltt[i, j] -= acc
    return _cholesky_block(Ltt, ref, b)


@numba.njit(cache=True, inline="always")
def _log_det_block(L, t, b):  # pragma: no cover - compiled
    """This block's contribution to log det H = 2 Σ log diag(L_tt) (L[t, 0] holds 1/L_aa).

    One logarithm of the pivots' product, not one per pivot (a logarithm costs
    as much as the rest of a small block's step); one per pivot where the
    product leaves the safe range of double precision.
    """
    product = 1.0
    for a in range(b):
        product *= L[t, 0, a, a]
    if 1e-250 < product < 1e250:
        return -2.0 * np.log(product)
    logdet = 0.0
    for a in range(b):
        logdet -= 2.0 * np.log(L[t, 0, a, a])
    return logdet


@numba.njit(cache=True, inline="always")
def _log_det_pivots(Ltt, b):  # pragma: no cover - compiled
    """:func:`_log_det_block` of one diagonal block ``Ltt`` (b, b), the same rounding."""
    product = 1.0
    for a in range(b):
        product *= Ltt[a, a]
    if 1e-250 < product < 1e250:
        return -2.0 * np.log(product)
    logdet = 0.0
    for a in range(b):
        logdet -= 2.0 * np.log(Ltt[a, a])
    return logdet


@numba.njit(cache=True, inline="always")
def _pack_lower(Ltt, packed, b):  # pragma: no cover - compiled
    """The lower triangle of ``Ltt`` (b, b) row by row into ``packed`` (b(b+1)/2,)."""
    position = 0
    for i in range(b):
        for j in range(i + 1):
            packed[position] = Ltt[i, j]
            position += 1


@numba.njit(cache=True, inline="always")
def _unpack_lower(packed, Ltt, b):  # pragma: no cover - compiled
    """:func:`_pack_lower` undone: the lower triangle of ``Ltt`` (its upper part is unused)."""
    position = 0
    for i in range(b):
        for j in range(i + 1):
            Ltt[i, j] = packed[position]
            position += 1


@numba.njit(cache=True)
def factor_forward(phi, n_rep, data_scale, extra, W, bands, Z, L, size):  # pragma: no cover
    """Factor H = L Lᵀ and forward-substitute the right-hand sides, in place.

    Output arrays are allocated by the caller with numpy, which requests
    transparent huge pages for large arrays: page faults on freshly allocated
    memory otherwise cost as much as the arithmetic at N ~ 1e6.

    Parameters
    ----------
    phi : (N, q, p);  n_rep : int;  data_scale : float
    extra : (0 | 1 | N, b, b) extra Gram blocks (prior precision)
    W : (b, b);  bands : (d+1, N), bands[lag, s] = (DᵀD)_{s+lag, s}
    Z : (N, b, r) right-hand sides (r may be 0), overwritten with L⁻¹ rhs
    L : (N, d+1, b, b) output, the factor
    size : int or tuple, the block size b = n_rep·p (see the module docstring)

    Returns
    -------
    worst_ratio : float
        Smallest pivot² relative to the diagonal of H it came from (−1: not
        positive definite).
    worst_t : int
        Time step where it occurred.
    logdet : float
        log det H = 2 Σ log diag(L).
    """
    b = block_size(size)
    N = phi.shape[0]
    d = bands.shape[0] - 1
    M = np.empty((b, b))
    ref = np.empty(b)
    worst = np.inf
    worst_t = 0
    logdet = 0.0
    for t in range(N):
        # Off-diagonal blocks L_{t,s}, s = t − lag, in increasing s.
        for lag in range(min(d, t), 0, -1):
            beta = bands[lag, t - lag]
            for i in range(b):
                for j in range(b):
                    M[i, j] = beta * W[i, j]
            offdiagonal_step(L, M, t, lag, d, b)
        # Diagonal block G_t + β_0 W (lower triangle).
        beta = bands[0, t]
        Ltt = L[t, 0]
        if n_rep == 1 and phi.shape[1] == 1 and extra.shape[0] == 0:
            # The common case (rows decoupled, one trajectory, no prior): b = p, so
            # G_t = data_scale φ_t φ_tᵀ without the index arithmetic of the general entry.
            for i in range(b):
                scaled = data_scale * phi[t, 0, i]
                for j in range(i + 1):
                    Ltt[i, j] = scaled * phi[t, 0, j] + beta * W[i, j]
                ref[i] = Ltt[i, i]
        else:
            for i in range(b):
                for j in range(i + 1):
                    Ltt[i, j] = _gram_entry(phi, n_rep, data_scale, extra, t, i, j) + beta * W[i, j]
                ref[i] = Ltt[i, i]
        ratio = diagonal_step(L, t, d, b, ref)
        if ratio < worst:
            worst = ratio
            worst_t = t
        if ratio < 0:
            return -1.0, t, 0.0
        _forward_step(L, Z, t, d, b)
        logdet += _log_det_block(L, t, b)
    return worst, worst_t, logdet


@numba.njit(cache=True, inline="always")
def _selected_inverse_step(L, window, rhs, cov, t, d, b):  # pragma: no cover - compiled
    """Step t of the selected inversion (see :func:`backward`): Σ_{t,i} for i = t … t + d
    into the rolling ``window`` (w = d + 1 slots per side), and Σ_tt into ``cov[t]``.

    ``rhs`` is a b × b scratch block. Needs the window's blocks of the steps after t.
    """
    N = L.shape[0]
    w = d + 1
    Ltt = L[t, 0]
    top = min(d, N - 1 - t)
    # Window slots by addition, not by t % w per access (an integer division
    # costs as much as a few multiply-adds of a small block).
    slot_t = t % w
    for m in range(top, -1, -1):
        slot_i = slot_t + m if slot_t + m < w else slot_t + m - w  # (t + m) % w
        # rhs = −Σ_k L_{k,t}ᵀ Σ_{k,i}
        for a in range(b):
            for c in range(b):
                rhs[a, c] = 0.0
        for q in range(1, top + 1):
            Lkt = L[t + q, q]  # L_{t+q, t}
            slot_k = slot_t + q if slot_t + q < w else slot_t + q - w
            S = window[slot_k, slot_i]  # indices > t, or this step's mirror
            for e in range(b):
                for a in range(b):
                    le = Lkt[e, a]
                    for c in range(b):
                        rhs[a, c] -= le * S[e, c]
        dest = window[slot_t, slot_i]
        if m > 0:
            # Back substitution L_ttᵀ Σ_{t,i} = rhs, all columns.
            for c in range(b):
                for a in range(b - 1, -1, -1):
                    acc = rhs[a, c]
                    for e in range(a + 1, b):
                        acc -= Ltt[e, a] * dest[e, c]
                    dest[a, c] = acc * Ltt[a, a]
            mirror = window[slot_i, slot_t]
            for a in range(b):
                for c in range(b):
                    mirror[c, a] = dest[a, c]
        else:
            # Upper triangle of Σ_tt (rows and columns descending), then
            # the lower one by symmetry.
            for a in range(b - 1, -1, -1):
                for c in range(b - 1, a - 1, -1):
                    acc = rhs[a, c] + (Ltt[a, a] if a == c else 0.0)
                    for e in range(a + 1, b):
                        acc -= Ltt[e, a] * (dest[e, c] if e <= c else dest[c, e])
                    dest[a, c] = acc * Ltt[a, a]
            for a in range(b):
                for c in range(a):
                    dest[a, c] = dest[c, a]
    # A loop, not cov[t] = ...: numba compiles an array assignment with a
    # shape-mismatch error message that formats strings, ~2 s on first use.
    Stt = window[slot_t, slot_t]
    for a in range(b):
        for c in range(b):
            cov[t, a, c] = Stt[a, c]


@numba.njit(cache=True)
def backward(L, X, cov, size):  # pragma: no cover - compiled
    """Back substitution X ← L⁻ᵀ X in place and the diagonal blocks of H⁻¹ into ``cov``.

    Selected inversion (block Takahashi recursion): from Lᵀ Σ = L⁻¹, for i >= t,

        L_ttᵀ Σ_{t,i} = δ_{ti} L_tt⁻¹ − Σ_{k=t+1}^{t+d} L_{k,t}ᵀ Σ_{k,i},

    solved by back substitution, for t from N − 1 down, keeping the blocks
    Σ_{i,j}, |i − j| <= d, of the last d + 1 time steps in a rolling window.
    L_tt⁻¹ is never formed: in the upper triangle (all the diagonal block
    needs, by symmetry) it is zero except for 1 / L_aa on the diagonal.

    Parameters
    ----------
    L : (N, d+1, b, b) factor;  X : (N, b, r), overwritten
    cov : (N, b, b) output, or (0, b, b) to skip the covariances
    size : int or tuple, the block size b
    """
    b = block_size(size)
    N, dp1, _, _ = L.shape
    d = dp1 - 1
    w = d + 1
    compute_cov = cov.shape[0] == N
    window = np.zeros((w, w, b, b))  # window[i % w, j % w] = Σ_{i,j}
    rhs = np.empty((b, b))
    for t in range(N - 1, -1, -1):
        _backward_step(L, X, t, d, b)
        if not compute_cov:
            continue
        _selected_inverse_step(L, window, rhs, cov, t, d, b)


@numba.njit(cache=True)
def solve(L, X, size):  # pragma: no cover - compiled
    """Solve L Lᵀ X = rhs in place; X (N, b, r) holds rhs on entry; size: int or tuple."""
    b = block_size(size)
    N, dp1, _, _ = L.shape
    d = dp1 - 1
    for t in range(N):
        _forward_step(L, X, t, d, b)
    for t in range(N - 1, -1, -1):
        _backward_step(L, X, t, d, b)


@numba.njit(cache=True)
def rowwise_matvec(theta, phi, out):  # pragma: no cover - compiled
    """out[t, r] = Θ_t φ_tr for Θ (N, n, p), φ (N, q, p), out (N, q, n)."""
    N, n, p = theta.shape
    for t in range(N):
        for r in range(phi.shape[1]):
            for i in range(n):
                acc = 0.0
                for j in range(p):
                    acc += theta[t, i, j] * phi[t, r, j]
                out[t, r, i] = acc


@numba.njit(cache=True)
def residual_and_difference_squares(
    theta, y, phi, coeffs, weights, rss, squares
):  # pragma: no cover - compiled
    """rss_i = Σ_tj (y_tji − Θ_t[i]·φ_tj)² and squares_i = Σ_t Σ_a w_a ((DΘ)_t[i, a])².

    One pass per output row over Θ (N, n, p) (any memory layout), y (N, q, n),
    φ (N, q, p), the difference coefficients (d + 1,) and the weights (p,);
    rss and squares (n,) are outputs. The fitted values are summed as
    :func:`rowwise_matvec` sums them.
    """
    N, n, p = theta.shape
    q = y.shape[1]
    d = coeffs.shape[0] - 1
    for i in range(n):
        rss[i] = 0.0
        squares[i] = 0.0
    # One pass over time (the arrays stream through the cache once); the n sums
    # are small enough to stay in L1.
    for t in range(N):
        for j in range(q):
            for i in range(n):
                fitted = 0.0
                for a in range(p):
                    fitted += theta[t, i, a] * phi[t, j, a]
                e = y[t, j, i] - fitted
                rss[i] += e * e
        if t + d < N:
            for i in range(n):
                total = 0.0
                for a in range(p):
                    difference = 0.0
                    for lag in range(d + 1):
                        difference += coeffs[lag] * theta[t + lag, i, a]
                    total += weights[a] * difference * difference
                squares[i] += total


# -- Rows sharing one system: the usual fit of a scalar λ ------------------------------
# When every output row has the same diagonal weight and no prior, the n rows
# are n right-hand sides of one p × p block system. The two kernels below solve
# it from the raw data: the Gram blocks, the right-hand sides Σ_j φ_tj y_tjᵀ,
# the diagonals of DᵀD, the residual and penalty sums are formed inside the two
# sweeps, and the solution is written in the (N, n, p) layout of Θ, so that no
# other pass over N-sized arrays is needed (at N ~ 1e5 each such pass costs
# about as much as a tenth of the factorization).


@numba.njit(cache=True, inline="always")
def _difference_band(coeffs, N, lag, s):  # pragma: no cover - compiled
    """(DᵀD)_{s+lag, s} = Σ_j c_j c_{j+lag} over the rows s − j of D (0 <= s − j < N − d)."""
    d = coeffs.shape[0] - 1
    acc = 0.0
    for j in range(d + 1 - lag):
        if 0 <= s - j < N - d:
            acc += coeffs[j] * coeffs[j + lag]
    return acc


@numba.njit(cache=True, inline="always")
def _first_difference_offdiagonal(Lss, out, beta, w, b):  # pragma: no cover - compiled
    """``out`` ← L_{t,t−1} = β diag(w) L_{t−1,t−1}⁻ᵀ for a first difference and a diagonal
    weight, from ``Lss`` = L_{t−1,t−1} (reciprocal pivots).

    The product of a diagonal and an upper triangular matrix is upper
    triangular: about half the work of :func:`offdiagonal_step`, whose
    general block is full. Row i solves x L_ssᵀ = β w_i e_iᵀ from column i on.
    The result depends on Lss, β and w alone, so a sweep that does not store it
    recomputes it bit for bit.
    """
    for i in range(b):
        for j in range(i):
            out[i, j] = 0.0
        out[i, i] = beta * w[i] * Lss[i, i]  # Lss[i, i] holds 1 / L_ii
        for j in range(i + 1, b):
            acc = 0.0
            for k in range(i, j):
                acc -= out[i, k] * Lss[j, k]
            out[i, j] = acc * Lss[j, j]


@numba.njit(cache=True, inline="always")
def _subtract_upper_gram(Ltt, off, b):  # pragma: no cover - compiled
    """``Ltt`` (lower triangle) ← Ltt − off offᵀ for an upper triangular ``off`` =
    L_{t,t−1} (:func:`_first_difference_offdiagonal`): Σ_k over k >= i only."""
    for i in range(b):
        for j in range(i + 1):
            acc = 0.0
            for k in range(i, b):
                acc += off[i, k] * off[j, k]
            Ltt[i, j] -= acc


@numba.njit(cache=True)
def rows_factor_forward(phi, y, w, coeffs, X, L, size):  # pragma: no cover - compiled
    """:func:`factor_forward` for output rows that share one system, from the raw data.

    H = blkdiag_t(Σ_j φ_tj φ_tjᵀ) + DᵀD ⊗ diag(w) (b = p) with right-hand side
    row c, Σ_j φ_tj y_tjc, for each of the n output rows.

    Parameters
    ----------
    phi : (N, q, p);  y : (N, q, n);  w : (p,) diagonal weight
    coeffs : (d + 1,) difference coefficients
    X : (N, n, p) output, L⁻¹ rhs of each row (the layout of Θ)
    L : (N, d+1, p, p) output, the factor; for a first difference (d = 1) also
        (N, 1, p, p): the diagonal blocks alone (the off-diagonal ones follow from
        them, see :func:`_first_difference_offdiagonal`; half the memory, for a
        solve without covariances), or (N, p(p+1)/2): their lower triangles
        packed row by row (:func:`_pack_lower`; 60 % of that again: the fit's
        largest array, whose first touch dominates a one-off call). The layout is
        told by ``L.ndim``, which numba knows when it compiles: each layout's
        kernel has no branch on it
    size : int or tuple, the block size p (see the module docstring)

    Returns
    -------
    worst_ratio, worst_t, logdet
        As :func:`factor_forward`.
    gram_trace : float
        Σ_t Σ_j ‖φ_tj‖² over the steps factored (all of them on success).
    """
    b = block_size(size)
    N, q, _ = phi.shape
    n = y.shape[2]
    d = coeffs.shape[0] - 1
    M = np.zeros((b, b))  # H_{t,s} = β diag(w): only the diagonal is ever written
    off = np.zeros((b, b))  # L_{t,t−1} when L holds the diagonal blocks alone
    stored = L.ndim == 4 and L.shape[1] > 1
    # packed diagonal blocks (L.ndim == 2): L_tt and L_{t−1,t−1} are formed in these
    current = np.zeros((b, b))
    previous = np.zeros((b, b))
    ref = np.empty(b)
    worst = np.inf
    worst_t = 0
    logdet = 0.0
    trace = 0.0
    for t in range(N):
        Ll = off
        if L.ndim == 4:
            if d == 1 and stored:
                Ll = L[t, 1]
        if d > 1:
            if L.ndim == 4:
                for lag in range(min(d, t), 0, -1):
                    beta = _difference_band(coeffs, N, lag, t - lag)
                    for i in range(b):
                        for j in range(b):
                            M[i, j] = 0.0
                        M[i, i] = beta * w[i]
                    offdiagonal_step(L, M, t, lag, d, b)
        elif t > 0:
            if L.ndim == 2:
                Lss = previous
            else:
                Lss = L[t - 1, 0]
            _first_difference_offdiagonal(Lss, Ll, _difference_band(coeffs, N, 1, t - 1), w, b)
        beta = _difference_band(coeffs, N, 0, t)
        if L.ndim == 2:
            Ltt = current
        else:
            Ltt = L[t, 0]
        for i in range(b):
            for j in range(i + 1):
                acc = 0.0
                for r in range(q):
                    acc += phi[t, r, i] * phi[t, r, j]
                Ltt[i, j] = acc
            trace += Ltt[i, i]
            Ltt[i, i] += beta * w[i]
            ref[i] = Ltt[i, i]
        ratio = -1.0
        if d > 1:
            if L.ndim == 4:
                ratio = diagonal_step(L, t, d, b, ref)
        else:
            if t > 0:
                _subtract_upper_gram(Ltt, Ll, b)
            ratio = _cholesky_block(Ltt, ref, b)
        if ratio < worst:
            worst = ratio
            worst_t = t
        if ratio < 0:
            return -1.0, t, 0.0, trace
        # z_tc = L_tt⁻¹ (Σ_j φ_tj y_tjc − Σ_lag L_{t,t−lag} z_{t−lag,c}) for each row c,
        # rounded as :func:`_forward_step` rounds it (a fit's value must not depend
        # on which of the two kernels computed it: noise-free data leave residuals
        # at the level of rounding)
        for c in range(n):
            for i in range(b):
                value = phi[t, 0, i] * y[t, 0, c]
                for r in range(1, q):
                    value += phi[t, r, i] * y[t, r, c]
                if d == 1:
                    if t > 0:
                        acc = 0.0
                        for k in range(b):
                            acc += Ll[i, k] * X[t - 1, c, k]
                        value -= acc
                elif L.ndim == 4:
                    for lag in range(1, min(d, t) + 1):
                        acc = 0.0
                        for k in range(b):
                            acc += L[t, lag, i, k] * X[t - lag, c, k]
                        value -= acc
                for k in range(i):
                    value -= Ltt[i, k] * X[t, c, k]
                X[t, c, i] = value * Ltt[i, i]
        logdet += _log_det_pivots(Ltt, b)
        if L.ndim == 2:
            _pack_lower(Ltt, L[t], b)
            current, previous = previous, current
    return worst, worst_t, logdet, trace


@numba.njit(cache=True)
def rows_backward(L, X, cov, phi, y, w, coeffs, rss, squares, size):  # pragma: no cover
    """:func:`backward` for the rows of :func:`rows_factor_forward`, with their sums.

    X (N, n, p) holds L⁻¹ rhs and is overwritten with Θ; ``cov`` (N, p, p), or
    (0, p, p) to skip the covariances, receives the diagonal blocks of H⁻¹ (which
    needs the off-diagonal blocks stored: L (N, d+1, p, p)); L may be any layout of
    :func:`rows_factor_forward`'s.
    As each Θ_t becomes final the same sweep adds, per output row c,
    rss_c = Σ_tj (y_tjc − Θ_t[c]·φ_tj)² and squares_c = Σ_t Σ_a w_a ((DΘ)_t[c, a])²
    (rss, squares (n,) outputs).
    """
    b = block_size(size)
    N = L.shape[0]
    d = coeffs.shape[0] - 1
    n = X.shape[1]
    q = phi.shape[1]
    compute_cov = cov.shape[0] == N
    stored = L.ndim == 4 and L.shape[1] > 1
    current = np.zeros((b, b))  # a packed L_tt (L.ndim == 2), unpacked
    window = np.zeros((d + 1, d + 1, b, b))  # as in backward
    off = np.zeros((b, b))  # L_{t+1,t}, recomputed when not stored
    Ll = off
    c0, c1 = coeffs[0], coeffs[1]
    rhs = np.empty((b, b))
    for c in range(n):
        rss[c] = 0.0
        squares[c] = 0.0
    for t in range(N - 1, -1, -1):
        if L.ndim == 2:
            _unpack_lower(L[t], current, b)
            Ltt = current
        else:
            Ltt = L[t, 0]
        if d == 1 and t + 1 < N:
            if stored:
                if L.ndim == 4:
                    Ll = L[t + 1, 1]
            else:
                Ll = off
                _first_difference_offdiagonal(Ltt, off, _difference_band(coeffs, N, 1, t), w, b)
        # x_tc = L_tt⁻ᵀ (z_tc − Σ_lag L_{t+lag,t}ᵀ x_{t+lag,c}) for each row c (row by
        # row: interleaving the rows' entries measured 1.8x slower)
        # (rounded as :func:`_backward_step` rounds it)
        for c in range(n):
            for i in range(b - 1, -1, -1):
                value = X[t, c, i]
                if d == 1:
                    if t + 1 < N:
                        acc = 0.0
                        for k in range(b):
                            acc += Ll[k, i] * X[t + 1, c, k]
                        value -= acc
                elif L.ndim == 4:
                    for lag in range(1, min(d, N - 1 - t) + 1):
                        acc = 0.0
                        for k in range(b):
                            acc += L[t + lag, lag, k, i] * X[t + lag, c, k]
                        value -= acc
                for k in range(i + 1, b):
                    value -= Ltt[k, i] * X[t, c, k]
                X[t, c, i] = value * Ltt[i, i]
        for c in range(n):
            # Θ_t is final, and so are Θ_{t+1} … Θ_{t+d}: this step's residuals
            # and the difference that starts here.
            # (One trajectory and a first difference spelled out: the general loops'
            # run-time bounds cost as much again as their arithmetic.)
            e2 = 0.0
            for r in range(q):
                fitted = 0.0
                for a in range(b):
                    fitted += X[t, c, a] * phi[t, r, a]
                e = y[t, r, c] - fitted
                e2 += e * e
            rss[c] += e2
            if d == 1 and t + 1 < N:
                total = 0.0
                for a in range(b):
                    difference = c0 * X[t, c, a] + c1 * X[t + 1, c, a]
                    total += w[a] * difference * difference
                squares[c] += total
            elif d != 1 and t + d < N:
                total = 0.0
                for a in range(b):
                    difference = 0.0
                    for lag in range(d + 1):
                        difference += coeffs[lag] * X[t + lag, c, a]
                    total += w[a] * difference * difference
                squares[c] += total
        if L.ndim == 4:
            if compute_cov:
                _selected_inverse_step(L, window, rhs, cov, t, d, b)


@numba.njit(cache=True)
def first_difference_solve(phi, data_scale, wsq, bands, X, L, size):  # pragma: no cover
    """Solve H x = rhs in place for a first difference with weights per difference.

    H = data_scale · blkdiag_t(Σ_j φ_tj φ_tjᵀ) + DᵀRD ⊗ diag(wsq) (b = p), D the
    first difference and R = diag(ρ) one weight per row of D, given by the
    bands of DᵀRD: the reweighted quadratic fits of group cones (see
    :class:`.ipm.RowFits`). One sweep factors and forward-substitutes, a second
    substitutes back: :func:`factor_forward` and :func:`solve` for this case,
    whose off-diagonal blocks L_{t,t−1} = β_t diag(wsq) L_{t−1,t−1}⁻ᵀ are upper
    triangular (:func:`_first_difference_offdiagonal`, half the work of the
    general block; the back substitution uses their upper triangles), without
    the log-determinant. (Applying L_{t+1,t}ᵀ through L_tt in the back
    substitution instead of storing it, as :func:`weighted_rows_solve` does, was
    slower here: 0.72 against 0.67 ms at N = 10⁴, p = 3, two right-hand sides.)

    Parameters
    ----------
    phi : (N, q, p);  data_scale : float;  wsq : (p,) diagonal weight
    bands : (2, N), bands[lag, s] = (DᵀRD)_{s+lag, s}
    X : (N, r, p) right-hand sides, one per row r (the layout of Θ), overwritten
        with the solutions
    L : (N, 2, p, p) output, the factor in :func:`factor_forward`'s layout
        (reciprocal pivots)
    size : int or tuple, the block size p (see the module docstring)

    Returns
    -------
    worst_ratio, worst_t
        As :func:`factor_forward` (−1: not positive definite; X is then
        partly substituted).
    """
    b = block_size(size)
    N, q, _ = phi.shape
    r = X.shape[1]
    # Right-hand sides solved in pairs, for blocks above PAIRED_RHS_MIN_B: at p = 10,
    # six rows, 1.2 against 1.5 ms a fit at N = 1000 and 5.0 against 6.3 ms at
    # 4000 (the same results); at p = 3, two rows, 11 % slower than one at a time.
    paired = 2 * (r // 2) if b > PAIRED_RHS_MIN_B else 0
    ref = np.empty(b)
    worst = np.inf
    worst_t = 0
    for t in range(N):
        Ltt = L[t, 0]
        off = L[t, 1]  # L_{t,t−1}
        for i in range(b):
            for j in range(i + 1):
                acc = 0.0
                for row in range(q):
                    acc += phi[t, row, i] * phi[t, row, j]
                Ltt[i, j] = data_scale * acc
            Ltt[i, i] += bands[0, t] * wsq[i]
            ref[i] = Ltt[i, i]
        if t > 0:
            _first_difference_offdiagonal(L[t - 1, 0], off, bands[1, t - 1], wsq, b)
            _subtract_upper_gram(Ltt, off, b)
        ratio = _cholesky_block(Ltt, ref, b)
        if ratio < worst:
            worst = ratio
            worst_t = t
        if ratio < 0:
            return -1.0, t
        # Two right-hand sides at a time: two independent chains of subtractions
        # (each in the order of one at a time), the rest one at a time.
        for c in range(0, paired, 2):
            for i in range(b):
                value, other = X[t, c, i], X[t, c + 1, i]
                if t > 0:
                    for k in range(i, b):
                        o = off[i, k]
                        value -= o * X[t - 1, c, k]
                        other -= o * X[t - 1, c + 1, k]
                for k in range(i):
                    o = Ltt[i, k]
                    value -= o * X[t, c, k]
                    other -= o * X[t, c + 1, k]
                X[t, c, i] = value * Ltt[i, i]
                X[t, c + 1, i] = other * Ltt[i, i]
        for c in range(paired, r):
            for i in range(b):
                value = X[t, c, i]
                if t > 0:
                    for k in range(i, b):
                        value -= off[i, k] * X[t - 1, c, k]
                for k in range(i):
                    value -= Ltt[i, k] * X[t, c, k]
                X[t, c, i] = value * Ltt[i, i]
    for t in range(N - 1, -1, -1):
        # x_t = L_tt⁻ᵀ (z_t − L_{t+1,t}ᵀ x_{t+1}), two right-hand sides at a time
        Ltt = L[t, 0]
        for c in range(0, paired, 2):
            for i in range(b - 1, -1, -1):
                acc, other = X[t, c, i], X[t, c + 1, i]
                if t + 1 < N:
                    for k in range(i + 1):  # L_{t+1,t}[k, i] = 0 for k > i
                        o = L[t + 1, 1, k, i]
                        acc -= o * X[t + 1, c, k]
                        other -= o * X[t + 1, c + 1, k]
                for k in range(i + 1, b):
                    o = Ltt[k, i]
                    acc -= o * X[t, c, k]
                    other -= o * X[t, c + 1, k]
                X[t, c, i] = acc * Ltt[i, i]
                X[t, c + 1, i] = other * Ltt[i, i]
        for c in range(paired, r):
            for i in range(b - 1, -1, -1):
                acc = X[t, c, i]
                if t + 1 < N:
                    for k in range(i + 1):
                        acc -= L[t + 1, 1, k, i] * X[t + 1, c, k]
                for k in range(i + 1, b):
                    acc -= Ltt[k, i] * X[t, c, k]
                X[t, c, i] = acc * Ltt[i, i]
    return worst, worst_t


# -- One weighted system per output row: the robust losses' Newton steps ------------
# A robust loss weighs each residual entry (row j of step t, output c) by its own
# a_tjc, so the output rows no longer share a system; but they share φ, the
# difference operator and the sweep over time, which factors every output's
# system (the outputs' Cholesky steps of a time step are independent dependency
# chains that the processor overlaps). The sweeps are bound by memory traffic,
# not arithmetic (a p = 5 factor is 400 bytes per step): for a first difference
# the off-diagonal block L_{t,t−1} = β diag(w) L_{t−1,t−1}⁻ᵀ is not stored but
# applied through L_{t−1,t−1} (a triangular solve, a few dozen flops), which
# halves the traffic of every sweep.


@numba.njit(cache=True, inline="always")
def _lower_solve(Ltt, v, b):  # pragma: no cover - compiled
    """v ← L_tt⁻¹ v in place (L[t, 0] with reciprocal pivots)."""
    for i in range(b):
        acc = v[i]
        for k in range(i):
            acc -= Ltt[i, k] * v[k]
        v[i] = acc * Ltt[i, i]


@numba.njit(cache=True, inline="always")
def _upper_solve(Ltt, v, b):  # pragma: no cover - compiled
    """v ← L_tt⁻ᵀ v in place."""
    for i in range(b - 1, -1, -1):
        acc = v[i]
        for k in range(i + 1, b):
            acc -= Ltt[k, i] * v[k]
        v[i] = acc * Ltt[i, i]


@numba.njit(cache=True, inline="always")
def _first_difference_forward(Lc, Xc, wc, beta, t, v, b):  # pragma: no cover - compiled
    """z_t = L_tt⁻¹ (rhs_t − L_{t,t−1} z_{t−1}) with L_{t,t−1} = β diag(w) L_{t−1,t−1}⁻ᵀ."""
    for col in range(Xc.shape[2]):
        if t > 0:
            for i in range(b):
                v[i] = Xc[t - 1, i, col]
            _upper_solve(Lc[t - 1, 0], v, b)
            for i in range(b):
                Xc[t, i, col] -= beta * wc[i] * v[i]
        for i in range(b):
            v[i] = Xc[t, i, col]
        _lower_solve(Lc[t, 0], v, b)
        for i in range(b):
            Xc[t, i, col] = v[i]


@numba.njit(cache=True)
def weighted_rows_factor_forward(
    phi, a, w, coeffs, active, X, L, worst, worst_t, size
):  # pragma: no cover - compiled
    """Factor H_c = blkdiag_t(Σ_j a_tjc φ_tj φ_tjᵀ) + DᵀD ⊗ diag(w_c) for each output c with
    ``active[c]``, and forward-substitute its right-hand sides, in one sweep over time.

    Parameters
    ----------
    phi : (N, q, p);  a : (N, q, n) row weights >= 0;  w : (n, p) diagonal weights
    coeffs : (d + 1,) difference coefficients;  active : (n,) bool
    X : (n, N, p, r) right-hand sides (r may be 0), overwritten with L_c⁻¹ rhs
    L : (n, N, d+1, p, p) output, the factors in :func:`factor_forward`'s layout per
        output; (n, N, 1, p, p) for a first difference (d = 1), whose off-diagonal
        blocks follow from the diagonal ones (see above)
    worst, worst_t : (n,) outputs, as :func:`factor_forward` returns them per output
        (worst −1: not positive definite; that output's sweep stops there)
    size : int or tuple, the block size p (see the module docstring)
    """
    b = block_size(size)
    N, q, _ = phi.shape
    n = a.shape[2]
    d = coeffs.shape[0] - 1
    M = np.zeros((b, b))
    off = np.zeros((b, b))
    v = np.empty(b)
    ref = np.empty(b)
    for c in range(n):
        worst[c] = np.inf
        worst_t[c] = 0
    for t in range(N):
        beta0 = _difference_band(coeffs, N, 0, t)
        beta1 = _difference_band(coeffs, N, 1, t - 1) if t > 0 else 0.0
        for c in range(n):
            if not active[c] or worst[c] < 0.0:
                continue
            Lc = L[c]
            wc = w[c]
            Ltt = Lc[t, 0]
            for i in range(b):
                for j in range(i + 1):
                    acc = 0.0
                    for r in range(q):
                        acc += a[t, r, c] * phi[t, r, i] * phi[t, r, j]
                    Ltt[i, j] = acc
                Ltt[i, i] += beta0 * wc[i]
                ref[i] = Ltt[i, i]
            if d == 1:
                if t > 0:
                    # L_{t,t−1} = β diag(w) L_{t−1,t−1}⁻ᵀ, upper triangular, in ``off``
                    Lss = Lc[t - 1, 0]
                    for i in range(b):
                        for j in range(i):
                            off[i, j] = 0.0
                        off[i, i] = beta1 * wc[i] * Lss[i, i]
                        for j in range(i + 1, b):
                            acc = 0.0
                            for k in range(i, j):
                                acc -= off[i, k] * Lss[j, k]
                            off[i, j] = acc * Lss[j, j]
                    for i in range(b):
                        for j in range(i + 1):
                            acc = 0.0
                            for k in range(i, b):
                                acc += off[i, k] * off[j, k]
                            Ltt[i, j] -= acc
                ratio = _cholesky_block(Ltt, ref, b)
            else:
                for lag in range(min(d, t), 0, -1):
                    beta = _difference_band(coeffs, N, lag, t - lag)
                    for i in range(b):
                        for j in range(b):
                            M[i, j] = 0.0
                        M[i, i] = beta * wc[i]
                    offdiagonal_step(Lc, M, t, lag, d, b)
                ratio = diagonal_step(Lc, t, d, b, ref)
            if ratio < worst[c]:
                worst[c] = ratio
                worst_t[c] = t
            if ratio < 0.0:
                worst[c] = -1.0
                continue
            if d == 1:
                _first_difference_forward(Lc, X[c], wc, beta1, t, v, b)
            else:
                _forward_step(Lc, X[c], t, d, b)


@numba.njit(cache=True)
def weighted_rows_solve(L, X, w, coeffs, active, forward, size):  # pragma: no cover - compiled
    """Solve H_c x = rhs (or, with ``forward`` False, finish it: X holds L_c⁻¹ rhs) in place
    for each output c with ``active[c]``; L, X, w and coeffs as in
    :func:`weighted_rows_factor_forward`."""
    b = block_size(size)
    n, N = L.shape[0], L.shape[1]
    d = coeffs.shape[0] - 1
    v = np.empty(b)
    for c in range(n):
        if not active[c]:
            continue
        Lc = L[c]
        Xc = X[c]
        wc = w[c]
        if forward:
            for t in range(N):
                if d == 1:
                    beta1 = _difference_band(coeffs, N, 1, t - 1) if t > 0 else 0.0
                    _first_difference_forward(Lc, Xc, wc, beta1, t, v, b)
                else:
                    _forward_step(Lc, Xc, t, d, b)
        for t in range(N - 1, -1, -1):
            if d != 1:
                _backward_step(Lc, Xc, t, d, b)
                continue
            # x_t = L_tt⁻ᵀ (z_t − L_{t+1,t}ᵀ x_{t+1}), L_{t+1,t}ᵀ = β L_tt⁻¹ diag(w)
            Ltt = Lc[t, 0]
            for col in range(Xc.shape[2]):
                if t + 1 < N:
                    beta = _difference_band(coeffs, N, 1, t)
                    for i in range(b):
                        v[i] = wc[i] * Xc[t + 1, i, col]
                    _lower_solve(Ltt, v, b)
                    for i in range(b):
                        Xc[t, i, col] -= beta * v[i]
                for i in range(b):
                    v[i] = Xc[t, i, col]
                _upper_solve(Ltt, v, b)
                for i in range(b):
                    Xc[t, i, col] = v[i]


# The same kernels under the names of their constant-size use (a tuple ``size``).
factor_forward_fixed = factor_forward
backward_fixed = backward
solve_fixed = solve


# -- The same systems for a first difference, in covariance form ----------------------
# For D a first difference the system of output c is a random walk's smoothing
# problem: minimize Σ_tj (a θ_tᵀφφᵀθ_t − 2 b φᵀθ_t) + Σ_t (θ_{t+1} − θ_t)ᵀ W (θ_{t+1} − θ_t)
# (rows with weight a and target b = a ŷ, W = diag(w)). A Kalman filter in covariance
# form (transition noise W⁻¹) takes each row as one rank-one update of P, whose
# dependency chain per step is a few dot products, where the block Cholesky's chain
# runs through a triangular solve and a b × b factorization; rows of weight 0 cost
# nothing. The series has no prior at its start (the first P is infinite), so the
# first steps run in information form (the block Cholesky recursion) until the
# information matrix is well conditioned; the filter then continues from its inverse.
# The backward pass is de Jong's smoother (no inverse per step): with r the adjoint,
# θ_t = x_t⁻ + P_t⁻ r, r ← r + φ_tj (e_tj − a_tj s_tjᵀ r) / F_tj through the rows.
# The filter keeps for the smoother P_t⁻ (its lower triangle, packed: P is held so
# throughout, which halves the stores of each rank-one update), x_t⁻ and per row
# e / F, a / F and s = P φ: the smoother then needs no product with P but θ_t's
# (where it recomputed s by replaying the rows' updates). The filter of one output
# and the smoother of the one before share a loop over time. Together, at p = 5 and
# T = 10⁵, about 0.7× the time of a solve with an unpacked P, a replaying smoother
# and the outputs' filter steps interleaved, for one output or three.

# The information form hands over once its matrix's smallest relative pivot²
# (pivot² / diagonal) reaches this: P = Λ⁻¹ then has a condition of a few hundred at
# most, and the rank-one updates lose no more than that many ulps.
KALMAN_SWITCH_RATIO = 1e-2


@numba.njit(cache=True, inline="always")
def _cholesky_inverse(M, P, v, b):  # pragma: no cover - compiled
    """P ← (L Lᵀ)⁻¹ from M's factor L (reciprocal pivots, see the module docstring)."""
    for col in range(b):
        for i in range(b):
            v[i] = 1.0 if i == col else 0.0
        _lower_solve(M, v, b)
        _upper_solve(M, v, b)
        for i in range(b):
            P[i, col] = v[i]


@numba.njit(cache=True, inline="always")
def _packed_index(i, k):  # pragma: no cover - compiled
    """The place of entry (i, k) of a symmetric matrix in its lower triangle packed row
    by row (a constant of the compiled code where the block size is)."""
    return i * (i + 1) // 2 + k if k <= i else k * (k + 1) // 2 + i


@numba.njit(cache=True, inline="always")
def _downdate(P, s, shrink, b):  # pragma: no cover - compiled
    """P ← P − shrink·s sᵀ on the packed lower triangle ``P`` of a symmetric P."""
    idx = 0
    for i in range(b):
        scaled = shrink * s[i]
        for k in range(i + 1):
            P[idx] = P[idx] - scaled * s[k]
            idx += 1


@numba.njit(cache=True, inline="always")
def _times_regressor(P, phi, t, j, s, b):  # pragma: no cover - compiled
    """s ← P φ_tj, P symmetric given by its packed lower triangle."""
    for i in range(b):
        acc = 0.0
        for k in range(b):
            acc += P[_packed_index(i, k)] * phi[t, j, k]
        s[i] = acc


@numba.njit(cache=True)
def weighted_rows_kalman(
    phi, a, targets, linear, w, active, replay, cov, mean, rows, X, status, size, max_reduction
):  # pragma: no cover - compiled
    """Solve H_c θ_c = Σ_j b_tjc φ_tj + g_tc,
    H_c = blkdiag_t(Σ_j a_tjc φ_tj φ_tjᵀ) + DᵀD ⊗ diag(w_c), for a first difference D
    (rows of DᵀD: θ_{t+1} − θ_t), each output c with ``active[c]``, by a Kalman filter
    and smoother (see above).

    A general term g_t enters as p rows of weight 0 along the unit vectors, taken
    before the step's rows: the mean moves by P_t⁻ g_t (the covariance not at all),
    and the smoother's backward vector r by g_t.

    Parameters
    ----------
    phi : (N, q, p);  a, targets : (N, q, n) row weights a >= 0 and targets b
    linear : (n, N, p) the terms g, or (n, 0, p): none
    w : (n, p) diagonal weights, > 0 (the difference's coefficient² folded in)
    active : (n,) bool
    cov : (n, N, p(p+1)/2), mean : (n, N, p), rows : (n, N, q, p + 2) work arrays: per
        step the factor of Λ_t + W and η_t (information steps) or P_t⁻ and x_t⁻
        (covariance steps; lower triangles packed row by row), per row e / F, a / F
        and s = P φ (P before the row's update)
    replay : bool, the covariance steps' P_t⁻ and each row's s = Pφ are those ``cov`` and
        ``rows`` hold from the last call, made with the same φ, a and w for every active
        output (another right-hand side: ``targets``, ``linear``): the filter only moves
        the mean with them, bit for bit as it would recompute them
    X : (n, N, p) output, the solutions of the active outputs whose status is >= 0
    status : (n,) int64 output: the step after which the covariance form took over,
        −1 if it never did (no solution: the caller factors that output), −2 if the
        information form met a matrix that is not positive definite (likewise), −3 if
        a row's update would have lost too many digits (``max_reduction``; likewise)
    size : int or tuple, the block size p
    max_reduction : float, the largest factor 1 + a φᵀPφ by which a row's update may
        divide the variance along φ (inf: any): P − a s sᵀ/(1 + a φᵀPφ) cancels about
        log10 of it in digits (a regressor orders of magnitude beyond the others'
        gives such a row); an output with a larger one stops, status −3. Not checked
        in a replay (the same rows as checked before).
    """
    b = block_size(size)
    N, q, _ = phi.shape
    n = a.shape[2]
    general = linear.shape[1] > 0
    Pc = np.empty((b, b))  # Λ of the information steps (lower triangle)
    Pp = np.empty(b * (b + 1) // 2)  # P of the covariance steps (packed lower triangle)
    xc = np.empty(b)  # η or the filtered mean
    noise = np.empty(b)  # the transition noise W⁻¹: no division per step
    M = np.empty((b, b))
    Z = np.empty((b, b))
    ref = np.empty(b)
    s = np.empty(b)
    v = np.empty(b)
    r = np.empty(b)
    for c in range(n):
        status[c] = -1
    # Output c's filter runs beside output c − 1's smoother, in one loop over time: the
    # filter's steps are a chain of dependent dot products, which leaves the processor
    # room for the smoother's independent work.
    for c in range(n + 1):
        filtering = c < n and active[c]
        back = c - 1  # the output smoothed
        smoothing = back >= 0 and active[back] and status[back] >= 0
        if filtering:
            for i in range(b):
                noise[i] = 1.0 / w[c, i]
                xc[i] = 0.0
                for k in range(b):
                    Pc[i, k] = 0.0
        if smoothing:
            for i in range(b):
                r[i] = 0.0
        if not filtering and not smoothing:
            continue
        for step in range(N):
            if filtering and status[c] >= 0:  # covariance form: predict, one update per row
                t = step
                packed = cov[c, t]
                if not replay:  # (a replay reads P⁻ and each row's s as stored)
                    for i in range(b):
                        Pp[i * (i + 3) // 2] += noise[i]  # (i, i)
                    for idx in range(Pp.shape[0]):
                        packed[idx] = Pp[idx]
                for i in range(b):
                    mean[c, t, i] = xc[i]
                if general:  # x += P⁻ g
                    for i in range(b):
                        acc = 0.0
                        for k in range(b):
                            acc += packed[_packed_index(i, k)] * linear[c, t, k]
                        s[i] = acc
                    for i in range(b):
                        xc[i] += s[i]
                for j in range(q):
                    weight = a[t, j, c]
                    if replay:
                        for i in range(b):
                            s[i] = rows[c, t, j, 2 + i]
                    else:
                        _times_regressor(Pp, phi, t, j, s, b)
                    along = 0.0
                    curvature = 0.0
                    for i in range(b):
                        along += phi[t, j, i] * xc[i]
                        curvature += phi[t, j, i] * s[i]
                    if not replay and 1.0 + weight * curvature > max_reduction:
                        status[c] = -3  # the filter of output c stops here
                        break
                    inv = 1.0 / (1.0 + weight * curvature)
                    gain = (targets[t, j, c] - weight * along) * inv
                    rows[c, t, j, 0] = gain
                    for i in range(b):
                        xc[i] += s[i] * gain
                    if not replay:
                        shrink = weight * inv
                        rows[c, t, j, 1] = shrink
                        for i in range(b):
                            rows[c, t, j, 2 + i] = s[i]
                        if shrink != 0.0:
                            _downdate(Pp, s, shrink, b)
            elif filtering and status[c] == -1:
                done = _information_step(
                    phi, a, targets, linear, w[c], Pc, Pp, xc, step, c, cov, mean, M, Z, ref, v
                )
                if done != 0:
                    status[c] = step if done > 0 else -2
            if smoothing:
                t = N - 1 - step
                if t > status[back]:  # de Jong's smoother (the rows' s as the filter stored them)
                    Pt = cov[back, t]  # P_t⁻, packed
                    for j in range(q - 1, -1, -1):
                        along = 0.0
                        for i in range(b):
                            along += rows[back, t, j, 2 + i] * r[i]
                        coef = rows[back, t, j, 0] - rows[back, t, j, 1] * along
                        for i in range(b):
                            r[i] += phi[t, j, i] * coef
                    if general:
                        for i in range(b):
                            r[i] += linear[back, t, i]
                    for i in range(b):
                        acc = mean[back, t, i]
                        for k in range(b):
                            acc += Pt[_packed_index(i, k)] * r[k]
                        X[back, t, i] = acc
                else:  # an information step: θ_t = (Λ_t + W)⁻¹ (η_t + W θ_{t+1})
                    idx = 0
                    for i in range(b):
                        for k in range(i + 1):
                            M[i, k] = cov[back, t, idx]
                            idx += 1
                    for i in range(b):
                        v[i] = mean[back, t, i] + w[back, i] * X[back, t + 1, i]
                    _lower_solve(M, v, b)
                    _upper_solve(M, v, b)
                    for i in range(b):
                        X[back, t, i] = v[i]


@numba.njit(cache=True)
def _information_step(
    phi, a, targets, linear, wc, Pc, Pp, xc, t, c, cov, mean, M, Z, ref, v
):  # pragma: no cover - compiled
    """One information step of output c in :func:`weighted_rows_kalman`: Λ (``Pc``, lower
    triangle) and η (``xc``) take step t's rows; returns 1 if the covariance form takes
    over after it (P = Λ⁻¹ into ``Pp``, packed, and x = P η into ``xc``), −1 if Λ + W
    is not positive definite, else 0 (Λ and η carried to step t + 1)."""
    N, q, b = phi.shape
    general = linear.shape[1] > 0
    packed = cov[c, t]
    # Λ += Σ a φφᵀ, η += Σ b φ (lower triangle of Λ)
    for j in range(q):
        weight = a[t, j, c]
        for i in range(b):
            xc[i] += targets[t, j, c] * phi[t, j, i]
            for k in range(i + 1):
                Pc[i, k] += weight * phi[t, j, i] * phi[t, j, k]
    if general:
        for i in range(b):
            xc[i] += linear[c, t, i]
    for i in range(b):
        mean[c, t, i] = xc[i]
    handover = False
    if b - 1 <= t < N - 1:  # Λ may be invertible: hand over if well conditioned
        for i in range(b):
            for k in range(i + 1):
                M[i, k] = Pc[i, k]
            ref[i] = Pc[i, i]
        handover = _cholesky_block(M, ref, b) >= KALMAN_SWITCH_RATIO
        if handover:
            _cholesky_inverse(M, Z, v, b)  # Λ⁻¹
    for i in range(b):
        for k in range(i + 1):
            M[i, k] = Pc[i, k]
        M[i, i] += wc[i]
        ref[i] = M[i, i]
    if _cholesky_block(M, ref, b) < 1e-12:  # RELATIVE_PIVOT_TOL of the block Cholesky
        return -1
    done = 0
    if handover:  # P = Λ⁻¹ (its lower triangle), x = P η
        idx = 0
        for i in range(b):
            for k in range(i + 1):
                Pp[idx] = Z[i, k]
                idx += 1
        for i in range(b):
            acc = 0.0
            for k in range(b):
                acc += Pp[_packed_index(i, k)] * xc[k]
            v[i] = acc
        for i in range(b):
            xc[i] = v[i]
        done = 1
    else:
        # Λ⁻ = W − W (Λ + W)⁻¹ W and η⁻ = W (Λ + W)⁻¹ η: with Z = L⁻¹ W, Λ⁻ = W − ZᵀZ
        for col in range(b):
            for i in range(b):
                v[i] = wc[i] if i == col else 0.0
            _lower_solve(M, v, b)
            for i in range(b):
                Z[i, col] = v[i]
        for i in range(b):
            for k in range(i + 1):
                acc = 0.0
                for m in range(b):
                    acc += Z[m, i] * Z[m, k]
                Pc[i, k] = (wc[i] if i == k else 0.0) - acc
        for i in range(b):
            v[i] = xc[i]
        _lower_solve(M, v, b)
        _upper_solve(M, v, b)
        for i in range(b):
            xc[i] = wc[i] * v[i]
    idx = 0
    for i in range(b):
        for k in range(i + 1):
            packed[idx] = M[i, k]
            idx += 1
    return done


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
