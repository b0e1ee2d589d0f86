"""Compiled factorizations of the interior-point Newton matrix for wide blocks.

The interior-point method's Newton matrix (:mod:`.ipm`)

    H = 2ΦᵀΦ + DᵀΛSΛD

has N × N blocks of size b × b and block bandwidth d (the order of D). For
``norm="group"`` the blocks are dense K × K (b = K = n·p); for ``"l1"`` each output
row has its own system of p × p blocks (b = p). The scalar loops of
:mod:`.blockkernels` and :mod:`.conekernels` are fastest for small blocks; from
a dozen or so coefficients on (``WIDE_MIN_SIZE`` in :mod:`.ipm`, with the
measured crossovers) the kernels here are faster:

- order 1 (:func:`factor_newton_wide_first`): the off-diagonal blocks are
  diagonal plus rank one, so a block elimination that keeps each Schur
  complement's explicit inverse needs one b × b inversion per step (b³/2
  multiply-adds, in compiled loops that vectorize) and b² work besides, against
  about 7b³/3 flops for the blocks of a block Cholesky;
- any order (:func:`factor_newton_wide`): the block Cholesky through LAPACK's
  ``dpotrf`` and BLAS's ``dtrsm``, ``dsyrk`` and ``dgemm`` (about
  (2d + 1/3)·b³ flops per step), on one thread (:func:`one_blas_thread`).

The BLAS and LAPACK routines are scipy's (``scipy.linalg.cython_lapack`` and
``cython_blas``), registered as external symbols of the compiled code
(:func:`_register`), so that the kernels compile once and are cached on disk
like the others, and no call goes back through Python.

Storage of :func:`factor_newton_wide`: ``L[t, lag] = L_{t, t−lag}`` as in
:mod:`.blockkernels` (shape (N, d+1, b, b), C order), but with the true pivots
on the diagonal of ``L[t, 0]`` (LAPACK's convention), so its factor is solved
with :func:`solve_wide`, not with :func:`.blockkernels.solve`. A C-ordered
(row-major) block is the transpose of the same memory read in Fortran order:
a lower triangular row-major factor is LAPACK's upper triangle (``uplo="U"``).
"""

from __future__ import annotations

from contextlib import AbstractContextManager

import llvmlite.binding as llvm  # type: ignore[import-untyped]  # (numba's own dependency)
import numba
import numpy as np
from numba import types
from numba.extending import get_cython_function_address
from threadpoolctl import ThreadpoolController

from . import conekernels as cones
from .precompiled import attach

__all__ = [
    "one_blas_thread",
    "factor_newton_wide",
    "solve_wide",
    "factor_newton_wide_first",
    "solve_wide_first",
]

_SYMBOLS = {
    "dpotrf": "scipy.linalg.cython_lapack",
    "dtrsm": "scipy.linalg.cython_blas",
    "dsyrk": "scipy.linalg.cython_blas",
    "dgemm": "scipy.linalg.cython_blas",
}


def _register() -> None:
    """Make scipy's routines known to the compiler as ``ltvmodels_<name>``.

    The compiled (and cached) code refers to the routines by these names; the
    addresses are resolved when the code is loaded, in each process.
    """
    for name, module in _SYMBOLS.items():
        llvm.add_symbol(f"ltvmodels_{name}", get_cython_function_address(module, name))


_register()

_controller: ThreadpoolController | None = None


def one_blas_thread() -> AbstractContextManager[object]:
    """A context in which BLAS and LAPACK run on one thread (restored on exit).

    The blocks are too small for threads to pay: with two threads each call's
    synchronization made the factorization of K = 35, N = 1000 sixteen times
    slower (2.5 s against 0.15 s) on a loaded machine.
    """
    global _controller
    if _controller is None:  # about 20 ms, once: it inspects the loaded libraries
        _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas")


_p = types.voidptr
# Fortran calling convention: every argument by reference. Character arguments
# are single bytes; the hidden string lengths are not read by these routines.
_dpotrf = types.ExternalFunction("ltvmodels_dpotrf", types.void(_p, _p, _p, _p, _p))
_dtrsm = types.ExternalFunction(
    "ltvmodels_dtrsm", types.void(_p, _p, _p, _p, _p, _p, _p, _p, _p, _p, _p)
)
_dsyrk = types.ExternalFunction(
    "ltvmodels_dsyrk", types.void(_p, _p, _p, _p, _p, _p, _p, _p, _p, _p)
)
_dgemm = types.ExternalFunction(
    "ltvmodels_dgemm", types.void(_p, _p, _p, _p, _p, _p, _p, _p, _p, _p, _p, _p, _p)
)

_CHAR_U, _CHAR_L, _CHAR_T, _CHAR_N = ord("U"), ord("L"), ord("T"), ord("N")


@numba.njit(cache=True, inline="always")
def _penalty_block(v, eta, s_coef, penalty, w, r, offset, out, b):  # pragma: no cover - compiled
    """out = (ΛSΛ)_r on the coefficients offset … offset + b − 1 (lower triangle).

    Group cones: η_r⁻²(Λ² − s_coef (Λv₁)(Λv₁)ᵀ); cones of width 2 (``penalty``
    non-empty, l1): the diagonal w_i² S_c, one cone per coefficient.
    """
    if penalty.shape[0] > 0:
        K = w.shape[0]
        for i in range(b):
            for j in range(i):
                out[i, j] = 0.0
            wi = w[offset + i]
            out[i, i] = wi * wi * penalty[r * K + offset + i]
        return
    inv_eta2 = 1.0 / (eta[r] * eta[r])
    scale = inv_eta2 * s_coef[r]
    for i in range(b):
        a_i = w[i] * v[r, 1 + i]
        c_i = scale * a_i
        for j in range(i):
            out[i, j] = -c_i * (w[j] * v[r, 1 + j])
        out[i, i] = inv_eta2 * w[i] * w[i] - c_i * a_i


@numba.njit(cache=True)
def factor_newton_wide(
    phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pinned, L
):  # pragma: no cover - compiled
    """Factor the Newton matrix 2ΦᵀΦ + DᵀΛSΛD into L (N, d+1, b, b) by BLAS and LAPACK.

    The same matrix as :func:`.conekernels.factor_newton_any` (arguments as
    there): S from the cone scaling (v, η, s_coef) of group cones, or from
    ``penalty`` for cones of width 2; coefficients with ``pinned[i] != 0`` get
    an identity row and column. Per time step t and lag = d … 1 (s = t − lag):

        L_{t,s} = (H_{t,s} − Σ_{j<s} L_{t,j}L_{s,j}ᵀ) L_ssᵀ⁻¹      (dgemm, dtrsm)
        L_tt L_ttᵀ = H_tt − Σ_{lag} L_{t,s}L_{t,s}ᵀ                  (dsyrk, dpotrf)

    Only the lower triangles of the diagonal blocks are formed and used; the
    strict upper triangle of ``L[t, 0]`` is zeroed for the solves.

    Returns (1.0, 0) on success, (−1.0, t) if the matrix is not positive
    definite at block t.
    """
    b = L.shape[2]
    N, n_rows, p = phi.shape
    d = coeffs.shape[0] - 1
    R = N - d
    ring = np.empty((d + 1, b, b))
    # Fortran scalars are passed by reference: one small array each.
    ints = np.empty(2, dtype=np.int32)
    ints[0] = b  # n = k = lda = ldb = ldc
    ints[1] = 0  # info
    reals = np.array([1.0, -1.0, 0.0])
    chars = np.array([_CHAR_U, _CHAR_L, _CHAR_T, _CHAR_N], dtype=np.uint8)
    n_ptr = ints[0:].ctypes
    info_ptr = ints[1:].ctypes
    one, minus_one = reals[0:].ctypes, reals[1:].ctypes
    up, left, trans, notrans = (
        chars[0:].ctypes,
        chars[1:].ctypes,
        chars[2:].ctypes,
        chars[3:].ctypes,
    )
    any_pinned = False
    for i in range(b):
        any_pinned = any_pinned or pinned[i] != 0.0
    for t in range(N):
        if t < R:
            _penalty_block(v, eta, s_coef, penalty, w, t, offset, ring[t % (d + 1)], b)
        for lag in range(min(d, t), 0, -1):
            s = t - lag
            M = L[t, lag]
            # Block (t, s) of DᵀΛSΛD = Σ_r c_{t−r} c_{s−r} (ΛSΛ)_r; ring holds lower triangles.
            for i in range(b):
                for j in range(b):
                    M[i, j] = 0.0
            for r in range(max(0, t - d), min(s, R - 1) + 1):
                weight = coeffs[t - r] * coeffs[s - r]
                P = ring[r % (d + 1)]
                for i in range(b):
                    for j in range(i):
                        M[i, j] += weight * P[i, j]
                        M[j, i] += weight * P[i, j]
                    M[i, i] += weight * P[i, i]
            for i in range(b if any_pinned else 0):
                if pinned[i] != 0.0:
                    for j in range(b):
                        M[i, j] = 0.0
                        M[j, i] = 0.0
            for jj in range(max(0, t - d), s):
                # Column-major view: Mᵀ −= L_{s,jj} L_{t,jj}ᵀ read as (C(L_sj))ᵀ C(L_tj).
                _dgemm(
                    trans, notrans, n_ptr, n_ptr, n_ptr, minus_one, L[s, s - jj].ctypes,
                    n_ptr, L[t, t - jj].ctypes, n_ptr, one, M.ctypes, n_ptr,
                )  # fmt: skip
            # Row-major X L_ssᵀ = M is, read in column-major order, U_ssᵀ Xᵀ = Mᵀ.
            _dtrsm(
                left, up, trans, notrans, n_ptr, n_ptr, one, L[s, 0].ctypes, n_ptr,
                M.ctypes, n_ptr,
            )  # fmt: skip
        Ltt = L[t, 0]
        cones.set_penalty_block(ring, coeffs, t, R, Ltt)
        cones.add_data_block(phi, t, n_rep, Ltt)  # the data part
        for lag in range(1, min(d, t) + 1):
            # Lower triangle of Ltt −= L_{t,s}L_{t,s}ᵀ: upper in column-major order.
            _dsyrk(
                up, trans, n_ptr, n_ptr, minus_one, L[t, lag].ctypes, n_ptr, one,
                Ltt.ctypes, n_ptr,
            )  # fmt: skip
        for i in range(b if any_pinned else 0):
            if pinned[i] != 0.0:
                for j in range(i):
                    Ltt[i, j] = 0.0
                for j in range(i + 1, b):
                    Ltt[j, i] = 0.0
                Ltt[i, i] = 1.0
        _dpotrf(up, n_ptr, Ltt.ctypes, n_ptr, info_ptr)
        if ints[1] != 0:
            return -1.0, t
        for i in range(b):
            for j in range(i + 1, b):
                Ltt[i, j] = 0.0
    return 1.0, 0


@numba.njit(cache=True, error_model="numpy")
def solve_wide(L, X):  # pragma: no cover - compiled
    """Solve H X = X in place with the factor of :func:`factor_newton_wide`; X is (N, b, r).

    Forward z_t = L_tt⁻¹(x_t − Σ_lag L_{t,t−lag} z_{t−lag}), then backward
    x_t = L_tt⁻ᵀ(z_t − Σ_lag L_{t+lag,t}ᵀ x_{t+lag}): b² work per step and
    column, which the compiled loops do at memory speed.
    """
    N, d1, b, _ = L.shape
    d = d1 - 1
    r = X.shape[2]
    acc = np.empty(b)
    for c in range(r):
        for t in range(N):
            for i in range(b):
                acc[i] = X[t, i, c]
            for lag in range(1, min(d, t) + 1):
                Ll = L[t, lag]
                for i in range(b):
                    total = 0.0
                    for q in range(b):
                        total += Ll[i, q] * X[t - lag, q, c]
                    acc[i] -= total
            Ltt = L[t, 0]
            for i in range(b):
                total = acc[i]
                for q in range(i):
                    total -= Ltt[i, q] * acc[q]
                acc[i] = total / Ltt[i, i]
            for i in range(b):
                X[t, i, c] = acc[i]
        for t in range(N - 1, -1, -1):
            for i in range(b):
                acc[i] = X[t, i, c]
            for lag in range(1, min(d, N - 1 - t) + 1):
                Ll = L[t + lag, lag]
                for q in range(b):
                    xq = X[t + lag, q, c]
                    for i in range(b):
                        acc[i] -= Ll[q, i] * xq
            Ltt = L[t, 0]
            for i in range(b - 1, -1, -1):
                total = acc[i]
                for q in range(i + 1, b):
                    total -= Ltt[q, i] * acc[q]
                acc[i] = total / Ltt[i, i]
            for i in range(b):
                X[t, i, c] = acc[i]


@numba.njit(cache=True, error_model="numpy", inline="always")
def _invert_spd(A, work):  # pragma: no cover - compiled
    """A ← A⁻¹ in place (both triangles) for a symmetric positive definite A given by
    its lower triangle.

    The symmetric sweep operator, two pivots at a time. Sweeping the pivots
    B = {k, k+1} with the columns X = A[:, B] (A_BB = B) maps

        A_ij −= (XB⁻¹Xᵀ)_ij,   A[:, B] ← XB⁻¹ (off B),   A_BB ← −B⁻¹,

    which is the single-pivot sweep (with r = A[k, :], d = 1/A_kk: A_ij −= r_i r_j d,
    A_ik = r_i d, A_kk = −d) applied to k and then k + 1; after every pivot A
    holds −A⁻¹. A pair's update is a rank-two update of the lower triangle
    along contiguous rows (b³/2 multiply-adds in all, as one pivot at a time,
    but half the passes over A: the loads and stores, not the multiply-adds,
    bound these loops). The pair's pivots a and e − c²/a (B = [[a, c], [c, e]])
    are those of A's LDLᵀ factorization, positive exactly when A is positive
    definite. CPU time per inversion at b = 35 and 60: 4.4 and 15 µs against
    5.4 and 20 µs one pivot at a time and 16 and 43 µs for LAPACK's dpotrf +
    dpotri (called from Python); four pivots at a time, a blocked update through
    BLAS (dgemm) and padded rows were not faster (one loaded machine, best of nine).
    ``work`` is (2, b). Returns False if a pivot is not positive.
    """
    b = A.shape[0]
    x0, x1 = work[0], work[1]
    k = 0
    while k + 2 <= b:
        k1 = k + 1
        for j in range(k):
            x0[j] = A[k, j]
            x1[j] = A[k1, j]
        x0[k] = A[k, k]
        x1[k] = A[k1, k]
        x0[k1] = A[k1, k]
        x1[k1] = A[k1, k1]
        for j in range(k + 2, b):
            x0[j] = A[j, k]
            x1[j] = A[j, k1]
        a, c, e = x0[k], x0[k1], x1[k1]
        if not a > 0.0:
            return False
        second = e - c * (c / a)  # the second pivot, as one pivot at a time
        if not second > 0.0:
            return False
        inv_det = 1.0 / (a * second)
        p00, p01, p11 = e * inv_det, -c * inv_det, a * inv_det  # B⁻¹
        # Every row, B's included (their entries are overwritten below), so that
        # the inner loops run over whole rows of the triangle.
        for i in range(b):
            u, v = x0[i], x1[i]
            w0 = u * p00 + v * p01
            w1 = u * p01 + v * p11
            Ai = A[i]
            for j in range(i + 1):
                Ai[j] -= w0 * x0[j] + w1 * x1[j]
        for j in range(k):
            u, v = x0[j], x1[j]
            A[k, j] = u * p00 + v * p01
            A[k1, j] = u * p01 + v * p11
        for i in range(k + 2, b):
            u, v = x0[i], x1[i]
            A[i, k] = u * p00 + v * p01
            A[i, k1] = u * p01 + v * p11
        A[k, k] = -p00
        A[k1, k] = -p01
        A[k1, k1] = -p11
        k += 2
    if k < b:  # an odd size: the last pivot alone
        row = x0
        pivot = A[k, k]
        if not pivot > 0.0:
            return False
        d = 1.0 / pivot
        for j in range(k):
            row[j] = A[k, j]
        row[k] = pivot
        for i in range(b):
            f = row[i] * d
            Ai = A[i]
            for j in range(i + 1):
                Ai[j] -= f * row[j]
        for j in range(k):
            A[k, j] = row[j] * d
        A[k, k] = -d
    for i in range(b):
        for j in range(i + 1):
            value = -A[i, j]
            A[i, j] = value
            A[j, i] = value
    return True


@numba.njit(cache=True, error_model="numpy")
def factor_newton_wide_first(
    phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pinned, L, P
):  # pragma: no cover - compiled
    """:func:`factor_newton_wide` for first differences (d = 1), in half the flops.

    The off-diagonal blocks are H_{t,t−1} = γ P_{t−1} with γ = c₀c₁ and
    P_r = (ΛSΛ)_r = diag(δ_r) − a_r a_rᵀ (δ_r = η_r⁻²Λ², a_r = √s_coef_r η_r⁻¹Λv₁,
    pinned entries zeroed): diagonal plus rank one. Block elimination with
    the Schur complements

        S_0 = H_00,   S_t = H_tt − γ² P_{t−1} S_{t−1}⁻¹ P_{t−1},

    needs S_{t−1}⁻¹ only through P S⁻¹ P, which is b² work from the explicit
    inverse: δ_iδ_j(S⁻¹)_ij − h_i a_j − a_i h_j + (aᵀS⁻¹a) a_i a_j with
    h = δ ∘ S⁻¹a. So each step costs one inversion of a b × b positive definite
    matrix (:func:`_invert_spd`), against a Cholesky factorization, a
    triangular solve and a rank-b update for the blocks L_{t,t−1}; and the
    solves are two matrix-vector products per step.

    Stores S_t⁻¹ (symmetric, both triangles) in ``L[t, 0]`` and δ_t, a_t in
    rows 0 and 1 of ``P[t]`` (P is (N, 2, b), L may be (N, 1, b, b): the off-diagonal
    blocks are not stored), for :func:`solve_wide_first`.

    Returns (1.0, 0), or (−1.0, t) if S_t is not positive definite.
    """
    b = L.shape[2]
    N, n_rows, p = phi.shape
    R = N - 1
    c0, c1 = coeffs[0], coeffs[1]
    gamma2 = (c0 * c1) * (c0 * c1)
    g = np.empty(b)
    work = np.empty((2, b))
    delta_prev = np.zeros(b)
    a_prev = np.zeros(b)
    for t in range(N):
        S = L[t, 0]
        # Lower triangle of H_tt: c₁²P_{t−1} + c₀²P_t + 2 I ⊗ Σφφᵀ, then −γ²P S⁻¹P.
        for i in range(b):
            for j in range(i + 1):
                S[i, j] = 0.0
        if t < R:
            if penalty.shape[0] > 0:
                K = w.shape[0]
                for i in range(b):
                    wi = w[offset + i]
                    P[t, 0, i] = wi * wi * penalty[t * K + offset + i]
                    P[t, 1, i] = 0.0
            else:
                inv_eta2 = 1.0 / (eta[t] * eta[t])
                root = np.sqrt(s_coef[t]) * (1.0 / eta[t])
                for i in range(b):
                    P[t, 0, i] = inv_eta2 * w[i] * w[i]
                    P[t, 1, i] = root * w[i] * v[t, 1 + i]
            for i in range(b):
                if pinned[i] != 0.0:
                    P[t, 0, i] = 0.0
                    P[t, 1, i] = 0.0
            delta, a = P[t, 0], P[t, 1]
            c00 = c0 * c0
            for i in range(b):
                ai = c00 * a[i]
                for j in range(i):
                    S[i, j] -= ai * a[j]
                S[i, i] += c00 * (delta[i] - a[i] * a[i])
        if t > 0:
            c11 = c1 * c1
            Sp = L[t - 1, 0]
            # g = S⁻¹a as a sum of columns (S⁻¹ is symmetric): contiguous updates
            # vectorize, a dot product per row would not without reassociation.
            for i in range(b):
                g[i] = 0.0
            for j in range(b):
                aj = a_prev[j]
                for i in range(b):
                    g[i] += Sp[j, i] * aj
            alpha = 0.0
            for i in range(b):
                alpha += a_prev[i] * g[i]
                g[i] *= delta_prev[i]
            # c₁²P − γ²PS⁻¹P, entry (i, j) = A_i a_j + C_i (S⁻¹)_ij δ_j + G_i g_j (+ c₁²δ_i
            # on the diagonal), with the row coefficients taken out of the inner loop.
            for i in range(b):
                di, ai, hi = delta_prev[i], a_prev[i], g[i]
                coef_a = gamma2 * (hi - alpha * ai) - c11 * ai
                coef_s = -gamma2 * di
                coef_g = gamma2 * ai
                Spi = Sp[i]
                Si = S[i]
                for j in range(i + 1):
                    Si[j] += coef_a * a_prev[j] + coef_s * (Spi[j] * delta_prev[j]) + coef_g * g[j]
                Si[i] += c11 * di
        cones.add_data_block(phi, t, n_rep, S)  # the data part
        for i in range(b):
            if pinned[i] != 0.0:
                for j in range(i):
                    S[i, j] = 0.0
                for j in range(i + 1, b):
                    S[j, i] = 0.0
                S[i, i] = 1.0
        if not _invert_spd(S, work):
            return -1.0, t
        if t < R:
            for i in range(b):
                delta_prev[i] = P[t, 0, i]
                a_prev[i] = P[t, 1, i]
    return 1.0, 0


@numba.njit(cache=True, error_model="numpy")
def solve_wide_first(L, P, X, coeffs):  # pragma: no cover - compiled
    """Solve H X = X in place with the factor of :func:`factor_newton_wide_first`.

    Block forward elimination y_t = x_t − γP_{t−1}S_{t−1}⁻¹y_{t−1}, then
    x_t = S_t⁻¹(y_t − γP_t x_{t+1}) backwards; X is (N, b, r).
    """
    N, _, b, _ = L.shape
    r = X.shape[2]
    gamma = coeffs[0] * coeffs[1]
    u = np.empty(b)
    x = np.empty(b)  # the previous block of column c, contiguous for the matrix-vector products
    for c in range(r):
        for i in range(b):
            x[i] = X[0, i, c]
        for t in range(1, N):
            _symmetric_matvec(L[t - 1, 0], x, u)
            dot = 0.0
            for i in range(b):
                dot += P[t - 1, 1, i] * u[i]
            for i in range(b):
                value = X[t, i, c] - gamma * (P[t - 1, 0, i] * u[i] - P[t - 1, 1, i] * dot)
                X[t, i, c] = value
                x[i] = value
        for t in range(N - 1, -1, -1):
            for i in range(b):
                u[i] = X[t, i, c]
            if t < N - 1:
                dot = 0.0
                for i in range(b):
                    dot += P[t, 1, i] * x[i]
                for i in range(b):
                    u[i] -= gamma * (P[t, 0, i] * x[i] - P[t, 1, i] * dot)
            _symmetric_matvec(L[t, 0], u, x)
            for i in range(b):
                X[t, i, c] = x[i]


@numba.njit(cache=True, inline="always")
def _symmetric_matvec(S, x, out):  # pragma: no cover - compiled
    """out = S x for a symmetric S, as a sum of S's rows (contiguous, vectorized updates)."""
    b = x.shape[0]
    for i in range(b):
        out[i] = 0.0
    for j in range(b):
        xj = x[j]
        for i in range(b):
            out[i] += S[j, i] * xj


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
