"""Kalman filter and Rauch–Tung–Striebel smoother for the parameter random walk.

Paper Section IV-C (the random-walk parameter model, its momentum variant, Proposition 1). The
squared-difference problem solved by :func:`ltvmodels.fit` with ``norm="sq"`` and a scalar λ,

    minimize_k  Σ_t ‖y_t − Θ_t φ_t‖² + λ² Σ_t ‖(Dk)_t‖²,   (Dk)_t = Σ_{j=0..d} c_j k_{t+j},

is the negative log posterior (times σ²) of the linear Gaussian state-space model

    k_{t+1} = a_0 k_t + a_1 k_{t−1} + … + a_{d−1} k_{t−d+1} + w_t,
              a_l = −c_{d−1−l} / c_d,   w_t ~ N(0, q I),  q = σ² / (λ² c_d²),
    y_{t,i} = φ_tᵀ θ_{t,i} + e_{t,i},   e_{t,i} ~ N(0, σ²),

(rows θ_{t,i} of Θ_t, k_t = Θ_t.ravel()). In companion form the state of output
row i is s_t = (θ_{t,i}, θ_{t−1,i}, …, θ_{t−d+1,i}) ∈ R^D, D = d·p:

    s_{t+1} = F s_t + G w_t,   F = C ⊗ I_p,   G = (I_p, 0, …, 0)ᵀ,
    y_{t,i} = hₜᵀ s_t + e,     h_t = (φ_t, 0, …, 0),

with C the d × d companion matrix of the a_l. For d = 1 this is the random walk
k_{t+1} = k_t + w_t (the random-walk model with H = I); for d = 2 it is
k_{t+1} = 2k_t − k_{t−1} + w_t, the paper's augmented model with momentum in the
coordinates (k_t, k_{t−1}) instead of (k_t, k_t − k_{t−1}). Every output row is
a separate scalar-measurement problem with the same h_t, so the covariance
recursion (D × D) is shared by all rows and only the means differ (D × n).

Initialization
--------------
*Exact diffuse* (default): a flat prior on the initial state. The filter runs in
information form (Ω, η) — measurement updates add h hᵀ/σ², predictions use
Ω⁺ = M − M G S⁻¹ Gᵀ M with M = F⁻ᵀ Ω F⁻¹ and S = I/q + Gᵀ M G (Woodbury, valid
for singular Ω) — until Ω is nonsingular (smallest eigenvalue of Ω scaled to
unit diagonal above :data:`IDENTIFIED_TOL`); from then on it is a standard
covariance-form filter. The state at time 0 holds the pre-sample lags
k_{−1} … k_{−d+1}; with a flat prior they integrate out exactly (c_0 ≠ 0), so
the estimates are those of the penalty on the observed k_0 … k_{N−1} only, i.e.
exactly :func:`ltvmodels.fit`. Filtered estimates at times where the state
(k_t, …, k_{t−d+1}) is not yet determined by y_0 … y_t are NaN (typically
t < d·p − 1).

*Proper prior*: ``init_mean``, ``init_cov`` give s_0 ~ N(μ, Σ) — a prior on
(k_0, k_{−1}, …, k_{−d+1}), rows of Θ independent with the shared covariance Σ.

Smoother
--------
Backward recursion on the conditional p(s_t | s_{t+1}, y_0 … y_t) = N(J_t s_{t+1} + b_t, L_t):
the RTS gain J_t = P_{t|t} Fᵀ P_{t+1|t}⁻¹ in the covariance phase and, where the
filtered state is still diffuse, J_t = F⁻¹(I − G S⁻¹ Gᵀ M), b_t = F⁻¹ G S⁻¹ Gᵀ F⁻ᵀ η,
L_t = F⁻¹ G S⁻¹ Gᵀ F⁻ᵀ, which is proper because the process noise is. Then
m_{t|N} = J_t m_{t+1|N} + b_t and P_{t|N} = J_t P_{t+1|N} J_tᵀ + L_t.

Log-likelihood
--------------
Prediction-error decomposition, Σ_{t,i} −½(log 2π F_t + v_{t,i}²/F_t) with
v = y − hᵀ m_{t|t−1}, F_t = hᵀ P_{t|t−1} h + σ², after the state is identified;
the diffuse start contributes the exact integral of the likelihood of the
first observations over the flat prior. The convention (flat prior with unit
density on k_0 … k_{d−1}) is that of :func:`ltvmodels.fit`, so with the same
σ² both give the same number. With a proper prior it is log p(y).
statsmodels' exact diffuse log-likelihood (the limit of log p(y) + (q/2) log κ
under N(0, κI) on the q = d·K diffuse states) is this value − (d·K/2) log 2π.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .dense import cholesky, cholesky_solve

__all__ = [
    "IDENTIFIED_TOL",
    "ParameterStateSpace",
    "realize",
    "step",
    "filter_kernel",
    "smoother_kernel",
    "log_abs_det_transition",
    "loglik_offset",
]

LOG_2PI = float(np.log(2.0 * np.pi))

#: Smallest eigenvalue of the information matrix, scaled to unit diagonal, at
#: which the diffuse filter regards the state as identified (the tolerance of
#: :mod:`ltvmodels.core.identifiability`).
IDENTIFIED_TOL = 1e-10


# ---------------------------------------------------------------------------------------
# Realization
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ParameterStateSpace:
    """Companion-form realization of the parameter random walk for one output row.

    s_{t+1} = F s_t + G w_t, w_t ~ N(0, Q);  y_t = h_tᵀ s_t + e_t, e_t ~ N(0, R),
    with s_t = (θ_t, θ_{t−1}, …, θ_{t−d+1}) ∈ R^D, D = d·p and h_t = (φ_t, 0, …, 0).

    Attributes
    ----------
    F : ndarray, shape (D, D)
        Transition matrix C ⊗ I_p (C: companion matrix of a_l = −c_{d−1−l}/c_d).
    F_inv : ndarray, shape (D, D)
        Its inverse (exists since c_0 ≠ 0).
    G : ndarray, shape (D, p)
        Noise input (I_p, 0, …, 0)ᵀ.
    Q : ndarray, shape (p, p)
        Process noise covariance σ²/(λ² c_d²) I_p.
    R : float
        Measurement noise variance σ².
    coeffs : ndarray, shape (d + 1,)
        Difference-operator coefficients c_0 … c_d.
    """

    F: np.ndarray
    F_inv: np.ndarray
    G: np.ndarray
    Q: np.ndarray
    R: float
    coeffs: np.ndarray

    @property
    def degree(self) -> int:
        return len(self.coeffs) - 1

    @property
    def q(self) -> float:
        """Process noise variance per coefficient."""
        return float(self.Q[0, 0])


def realize(coeffs: np.ndarray, p: int, lam: float, noise_var: float) -> ParameterStateSpace:
    d = len(coeffs) - 1
    a = -coeffs[d - 1 :: -1] / coeffs[d]  # a_l = −c_{d−1−l}/c_d, l = 0 … d−1
    C = np.zeros((d, d))
    C[0] = a
    C[np.arange(1, d), np.arange(d - 1)] = 1.0
    # C⁻¹: s_l = s'_{l+1} (l < d−1) and s_{d−1} = (s'_0 − Σ_{l<d−1} a_l s'_{l+1}) / a_{d−1}.
    C_inv = np.zeros((d, d))
    C_inv[np.arange(d - 1), np.arange(1, d)] = 1.0
    C_inv[d - 1, 0] = 1.0 / a[d - 1]
    C_inv[d - 1, 1:] = -a[: d - 1] / a[d - 1]
    eye = np.eye(p)
    G = np.zeros((d * p, p))
    G[:p] = eye
    q = noise_var / (lam**2 * coeffs[d] ** 2)
    return ParameterStateSpace(
        F=np.kron(C, eye),
        F_inv=np.kron(C_inv, eye),
        G=G,
        Q=q * eye,
        R=float(noise_var),
        coeffs=coeffs.copy(),
    )


# ---------------------------------------------------------------------------------------
# Compiled steps. State of the recursion, for all rows at once:
#   information phase (info=True):  mat = Ω (D, D), vec = η (D, n), ell = log normalizer (n,)
#   covariance phase  (info=False): mat = P (D, D), vec = m (D, n), ell = log-likelihood (n,)
#
# The matrices are small (D = d·p), so everything is written as explicit loops over
# C-contiguous arrays with the small Cholesky of :mod:`.dense`: numba compiles this
# in a fraction of the time that ``@``, ``np.linalg`` and array expressions take
# (the first kalman_smoother call in a fresh process compiled for 16 s before), and
# the loops are as fast as BLAS/LAPACK calls at these sizes. For the same reason the
# steps used at one place are inlined (``inline="always"``: a compiled callee is
# optimized again inside every caller), while the small helpers used at many
# places are compiled once.
# ---------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _matmul(A, B, out):  # pragma: no cover - compiled
    """out = A B (out must not alias A or B)."""
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc


@numba.njit(cache=True)
def _matmul_bt(A, B, out):  # pragma: no cover - compiled
    """out = A Bᵀ (out must not alias A or B)."""
    for i in range(A.shape[0]):
        for j in range(B.shape[0]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[j, k]
            out[i, j] = acc


@numba.njit(cache=True)
def _symmetrize(A):  # pragma: no cover - compiled
    """A ← (A + Aᵀ)/2 in place."""
    for a in range(A.shape[0]):
        for b in range(a):
            value = 0.5 * (A[a, b] + A[b, a])
            A[a, b] = value
            A[b, a] = value


@numba.njit(cache=True)
def _leading_cholesky(A, p, shift):  # pragma: no cover - compiled
    """Cholesky factor (p, p) of A[:p, :p] + shift·I (np.linalg.cholesky's error if not PD)."""
    L = np.zeros((p, p))
    if not cholesky(A, np.arange(p), -shift, L):
        raise np.linalg.LinAlgError("Matrix is not positive definite.")
    return L


@numba.njit(cache=True)
def _solve_rows(L, B):  # pragma: no cover - compiled
    """(L Lᵀ)⁻¹ B[:d] for the (d, d) factor L, as a new (d, r) array."""
    d = L.shape[0]
    X = np.empty((d, B.shape[1]))
    for a in range(d):
        for c in range(B.shape[1]):
            X[a, c] = B[a, c]
    cholesky_solve(L, d, X)
    return X


@numba.njit(cache=True, inline="always")
def _info_gain(Omega, eta, F_inv, F_invT, p, q):  # pragma: no cover - compiled
    """The Woodbury terms of an information-form prediction (shared with the smoother).

    Returns M = F⁻ᵀ Ω F⁻¹, η' = F⁻ᵀ η, the Cholesky factor L of S = Gᵀ M G + I/q,
    X = S⁻¹ Gᵀ M (p, D) and Z = S⁻¹ Gᵀ η' (p, n).
    """
    D = Omega.shape[0]
    work = np.empty((D, D))
    _matmul(F_invT, Omega, work)
    M = np.empty((D, D))
    _matmul(work, F_inv, M)
    _symmetrize(M)
    eta_p = np.empty((D, eta.shape[1]))
    _matmul(F_invT, eta, eta_p)
    L = _leading_cholesky(M, p, 1.0 / q)
    return M, eta_p, L, _solve_rows(L, M), _solve_rows(L, eta_p)


@numba.njit(cache=True, inline="always")
def _info_predict(Omega, eta, ell, F_inv, F_invT, p, q, log_abs_det_F):  # pragma: no cover
    """Flat-prior-exact prediction in information form (Woodbury, Ω may be singular)."""
    D = Omega.shape[0]
    n = eta.shape[1]
    M, eta_p, L, X, Z = _info_gain(Omega, eta, F_inv, F_invT, p, q)
    Omega_new = np.empty((D, D))  # M − M G X
    eta_new = np.empty((D, n))  # η' − M G Z
    for a in range(D):
        for b in range(D):
            acc = 0.0
            for c in range(p):
                acc += M[a, c] * X[c, b]
            Omega_new[a, b] = M[a, b] - acc
        for i in range(n):
            acc = 0.0
            for c in range(p):
                acc += M[a, c] * Z[c, i]
            eta_new[a, i] = eta_p[a, i] - acc
    _symmetrize(Omega_new)
    logdet_qS = p * np.log(q)  # log det(q S) = log det(I + q Gᵀ M G)
    for a in range(p):
        logdet_qS += 2.0 * np.log(L[a, a])
    for i in range(n):
        quad = 0.0
        for a in range(p):
            quad += eta_p[a, i] * Z[a, i]
        ell[i] += -log_abs_det_F - 0.5 * logdet_qS + 0.5 * quad
    return Omega_new, eta_new


@numba.njit(cache=True, inline="always")
def _info_update(Omega, eta, ell, phi_t, y_t, r):  # pragma: no cover - compiled
    """Add the measurement y_t = φ_tᵀ θ_t + e to (Ω, η) and the log normalizer, in place."""
    p = phi_t.shape[0]
    for a in range(p):
        for b in range(p):
            Omega[a, b] += phi_t[a] * phi_t[b] / r
        for i in range(y_t.shape[0]):
            eta[a, i] += phi_t[a] * y_t[i] / r
    for i in range(y_t.shape[0]):
        ell[i] += -0.5 * (LOG_2PI + np.log(r)) - 0.5 * y_t[i] ** 2 / r


@numba.njit(cache=True, inline="always")
def _info_identified(Omega, tol):  # pragma: no cover - compiled
    """True if Ω scaled to unit diagonal has smallest eigenvalue > tol.

    That is, if the scaled Ω minus tol·I is positive definite: its Cholesky
    factorization succeeds (as the feasibility test of :mod:`.segmentation`).
    """
    D = Omega.shape[0]
    s = np.empty(D)
    for a in range(D):
        if not Omega[a, a] > 0.0:
            return False
        s[a] = 1.0 / np.sqrt(Omega[a, a])
    scaled = np.empty((D, D))
    for a in range(D):
        for b in range(D):
            scaled[a, b] = 0.5 * (Omega[a, b] + Omega[b, a]) * s[a] * s[b]
    return cholesky(scaled, np.arange(D), tol, np.empty((D, D)))


@numba.njit(cache=True, inline="always")
def _info_to_moments(Omega, eta, ell):  # pragma: no cover - compiled
    """Switch to moments: P = Ω⁻¹, m = Ω⁻¹η; ell becomes log ∫ (likelihood so far) ds."""
    D = Omega.shape[0]
    L = _leading_cholesky(Omega, D, 0.0)
    P = np.zeros((D, D))
    for a in range(D):
        P[a, a] = 1.0
    P = _solve_rows(L, P)
    _symmetrize(P)
    m = _solve_rows(L, eta)
    logdet = 0.0
    for a in range(D):
        logdet += 2.0 * np.log(L[a, a])
    for i in range(ell.shape[0]):
        quad = 0.0
        for a in range(D):
            quad += eta[a, i] * m[a, i]
        ell[i] += 0.5 * D * LOG_2PI - 0.5 * logdet + 0.5 * quad
    return P, m


@numba.njit(cache=True, inline="always")
def _cov_predict(P, m, F, p, q):  # pragma: no cover - compiled
    """m⁺ = F m, P⁺ = F P Fᵀ + G q Gᵀ; returns (P⁺, m⁺, F P)."""
    D = P.shape[0]
    FP = np.empty((D, D))
    _matmul(F, P, FP)
    P_new = np.empty((D, D))
    _matmul_bt(FP, F, P_new)
    for a in range(p):
        P_new[a, a] += q
    _symmetrize(P_new)
    m_new = np.empty((D, m.shape[1]))
    _matmul(F, m, m_new)
    return P_new, m_new, FP


@numba.njit(cache=True, inline="always")
def _cov_update(P, m, ell, phi_t, y_t, r):  # pragma: no cover - compiled
    """Scalar measurement update shared by all rows, in place; adds to the log-likelihood."""
    D, n = m.shape
    p = phi_t.shape[0]
    Pphi = np.zeros(D)  # P h
    for a in range(D):
        acc = 0.0
        for b in range(p):
            acc += P[a, b] * phi_t[b]
        Pphi[a] = acc
    Fv = r
    for b in range(p):
        Fv += phi_t[b] * Pphi[b]
    for i in range(n):
        pred = 0.0
        for b in range(p):
            pred += phi_t[b] * m[b, i]
        v = y_t[i] - pred
        for a in range(D):
            m[a, i] += Pphi[a] * v / Fv
        ell[i] += -0.5 * (LOG_2PI + np.log(Fv) + v * v / Fv)
    for a in range(D):
        for b in range(a, D):
            val = 0.5 * (P[a, b] + P[b, a]) - Pphi[a] * Pphi[b] / Fv
            P[a, b] = val
            P[b, a] = val


@numba.njit(cache=True)
def _filter_steps(
    mat,
    vec,
    ell,
    info,
    predict_first,
    phi,
    y,
    observed,
    F,
    F_inv,
    F_invT,
    q,
    r,
    log_abs_det_F,
    tol,
    vecs,
    mats,
    in_info,
):  # pragma: no cover - compiled
    """The filter over the time steps of φ (N, q, p), y (N, q, n), observed (N, q).

    Starts from the state (mat, vec, info) (see above), predicts before every
    step but the first (and before the first too if ``predict_first``), and
    stores each step's state in vecs (N, D, n), mats (N, D, D), in_info (N,);
    ``ell`` is updated in place. Returns the final (mat, vec, info).

    This one kernel serves :func:`filter_kernel` and :func:`step` (the online
    filter): a compiled function calling another compiled function makes numba
    optimize the callee's code once more inside the caller, so the whole filter
    as a callee of a loop kernel cost ~1.5 s more compilation.
    """
    p = phi.shape[2]
    D, n = vec.shape
    for t in range(phi.shape[0]):
        predict = t > 0 or predict_first
        if info:
            if predict:
                mat, vec = _info_predict(mat, vec, ell, F_inv, F_invT, p, q, log_abs_det_F)
            for j in range(phi.shape[1]):
                if observed[t, j]:
                    _info_update(mat, vec, ell, phi[t, j], y[t, j], r)
            if _info_identified(mat, tol):
                mat, vec = _info_to_moments(mat, vec, ell)
                info = False
        else:
            if predict:
                mat, vec, _ = _cov_predict(mat, vec, F, p, q)
            for j in range(phi.shape[1]):
                if observed[t, j]:
                    _cov_update(mat, vec, ell, phi[t, j], y[t, j], r)
        # Element by element: an array assignment (vecs[t] = vec) makes numba
        # compile its shape-mismatch error message, ~2 s on first use.
        for a in range(D):
            for i in range(n):
                vecs[t, a, i] = vec[a, i]
            for b in range(D):
                mats[t, a, b] = mat[a, b]
        in_info[t] = info
    return mat, vec, info


def step(
    mat, vec, ell, info, predict, phi_t, y_t, obs_t, F, F_inv, F_invT, q, r, log_abs_det_F, tol
):
    """One time step: predict from t−1 (unless ``predict`` is False), then update.

    The measurements of step t are the rows j of φ_t (q, p), y_t (q, n) with
    ``obs_t[j]`` True (one per trajectory; none for a missing sample).
    Returns the new (mat, vec, info); ``ell`` is updated in place.
    """
    D, n = vec.shape
    mat, vec, info = _filter_steps(
        mat,
        vec,
        ell,
        bool(info),
        bool(predict),
        np.ascontiguousarray(phi_t[None], float),
        np.ascontiguousarray(y_t[None], float),
        np.ascontiguousarray(obs_t[None], bool),
        F,
        F_inv,
        F_invT,
        float(q),
        float(r),
        float(log_abs_det_F),
        float(tol),
        np.empty((1, D, n)),
        np.empty((1, D, D)),
        np.empty(1, bool),
    )
    return mat, vec, info


def filter_kernel(phi, y, observed, F, F_inv, q, r, log_abs_det_F, diffuse, m0, P0, tol):
    """Run the filter over all time steps: φ (N, q, p), y (N, q, n), observed (N, q).

    Returns (vecs (N, D, n), mats (N, D, D), in_info (N,), ell (n,)): per step the
    filtered (m, P), or (η, Ω) while the state is not identified (in_info True).
    """
    N, n, D = phi.shape[0], y.shape[2], F.shape[0]
    vecs, mats, in_info = np.empty((N, D, n)), np.empty((N, D, D)), np.empty(N, bool)
    ell = np.zeros(n)
    if diffuse:
        mat, vec = np.zeros((D, D)), np.zeros((D, n))
    else:
        mat, vec = np.array(P0, float), np.array(m0, float)
    _filter_steps(
        mat,
        vec,
        ell,
        bool(diffuse),
        False,
        np.ascontiguousarray(phi, float),
        np.ascontiguousarray(y, float),
        np.ascontiguousarray(observed, bool),
        np.ascontiguousarray(F, float),
        np.ascontiguousarray(F_inv, float),
        np.ascontiguousarray(F_inv.T, float),
        float(q),
        float(r),
        float(log_abs_det_F),
        float(tol),
        vecs,
        mats,
        in_info,
    )
    return vecs, mats, in_info, ell


@numba.njit(cache=True)
def smoother_kernel(vecs, mats, in_info, F, F_inv, p, q):  # pragma: no cover - compiled
    """RTS backward pass; returns the k-blocks: means (N, p, n), covariances (N, p, p).

    The conditional mean of s_t given s_{t+1} is J s_{t+1} + b, its covariance L:
    in the information phase J = F⁻¹(I − G X), b = F⁻¹ G Z, L = F⁻¹ G S⁻¹ Gᵀ F⁻ᵀ
    (the terms of :func:`_info_gain`); in the covariance phase
    J = P_t Fᵀ P_pred⁻¹, b = m_t − J F m_t, L = P_t − J P_pred Jᵀ.
    """
    N, D, n = vecs.shape
    F_invT = np.empty((D, D))
    for a in range(D):
        for b in range(D):
            F_invT[a, b] = F_inv[b, a]
    FpT = np.empty((p, D))  # (F⁻¹ G)ᵀ
    for c in range(p):
        for a in range(D):
            FpT[c, a] = F_inv[a, c]
    out_m = np.empty((N, p, n))
    out_P = np.empty((N, p, p))
    ms = vecs[N - 1].copy()
    Ps = mats[N - 1].copy()
    J = np.empty((D, D))
    JP = np.empty((D, D))
    work = np.empty((D, D))
    ms_new = np.empty((D, n))
    for t in range(N - 1, -1, -1):
        if t < N - 1 and in_info[t]:
            _, _, L_S, X, Z = _info_gain(mats[t], vecs[t], F_inv, F_invT, p, q)
            for a in range(D):  # J = F⁻¹ (I − G X)
                for b in range(D):
                    acc = F_inv[a, b]
                    for c in range(p):
                        acc -= F_inv[a, c] * X[c, b]
                    J[a, b] = acc
            _matmul(J, ms, ms_new)  # m = J m⁺ + F⁻¹ G Z
            for a in range(D):
                for i in range(n):
                    acc = 0.0
                    for c in range(p):
                        acc += F_inv[a, c] * Z[c, i]
                    ms[a, i] = ms_new[a, i] + acc
            Lt = _solve_rows(L_S, FpT)  # P = J P⁺ Jᵀ + F⁻¹ G S⁻¹ Gᵀ F⁻ᵀ
            _matmul(J, Ps, JP)
            _matmul_bt(JP, J, work)
            for a in range(D):
                for b in range(D):
                    acc = 0.0
                    for c in range(p):
                        acc += F_inv[a, c] * Lt[c, b]
                    Ps[a, b] = work[a, b] + acc
            _symmetrize(Ps)
        elif t < N - 1:
            P = mats[t]
            m = vecs[t]
            P_pred, m_pred, FP = _cov_predict(P, m, F, p, q)
            JT = _solve_rows(_leading_cholesky(P_pred, D, 0.0), FP)  # P_pred⁻¹ F P_t = Jᵀ
            for a in range(D):
                for b in range(D):
                    J[a, b] = JT[b, a]
            for a in range(D):  # m = m_t + J (m⁺ − F m_t)
                for i in range(n):
                    m_pred[a, i] = ms[a, i] - m_pred[a, i]
            _matmul(J, m_pred, ms_new)
            for a in range(D):
                for i in range(n):
                    ms[a, i] = m[a, i] + ms_new[a, i]
            for a in range(D):  # P = P_t + J (P⁺ − P_pred) Jᵀ
                for b in range(D):
                    work[a, b] = Ps[a, b] - P_pred[a, b]
            _matmul(J, work, JP)
            _matmul(JP, JT, work)
            for a in range(D):
                for b in range(D):
                    Ps[a, b] = P[a, b] + work[a, b]
            _symmetrize(Ps)
        for a in range(p):
            for i in range(n):
                out_m[t, a, i] = ms[a, i]
            for b in range(p):
                out_P[t, a, b] = Ps[a, b]
    return out_m, out_P


# ---------------------------------------------------------------------------------------
# Likelihood conventions
# ---------------------------------------------------------------------------------------


def log_abs_det_transition(coeffs: np.ndarray, p: int) -> float:
    """log |det F| = p · log |c_0 / c_d|."""
    return p * float(np.log(abs(coeffs[0] / coeffs[-1])))


def loglik_offset(coeffs: np.ndarray, n: int, p: int, diffuse: bool) -> float:
    """From a flat prior on (k_0, k_{−1}, …, k_{−d+1}) to unit density on (k_0 … k_{d−1}).

    Integrating the d − 1 pre-sample lags out over a flat prior multiplies the
    likelihood by |c_d / c_0|^{(d−1)·K}; :func:`ltvmodels.fit` has no such lags.
    """
    if not diffuse:
        return 0.0
    d = len(coeffs) - 1
    return -(d - 1) * n * p * float(np.log(abs(coeffs[-1] / coeffs[0])))
