"""Kalman filter and Rauch–Tung–Striebel smoother for the parameter random walk.

Paper Section IV-C (eqs. dynsys, dynsys2, Proposition 1). The squared-difference
problem solved by :func:`ltvmodels.fit` with ``norm="sq"`` and a scalar λ,

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
k_{t+1} = k_t + w_t (eq. dynsys with H = I); for d = 2 it is
k_{t+1} = 2k_t − k_{t−1} + w_t, the augmented model eq. dynsys2 in the
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

from .dense import cholesky_solve

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
        F=np.kron(C, eye), F_inv=np.kron(C_inv, eye), G=G, Q=q * eye, R=float(noise_var),
        coeffs=coeffs.copy(),
    )


# ---------------------------------------------------------------------------------------
# Compiled steps. State of the recursion, for all rows at once:
#   information phase (info=True):  mat = Ω (D, D), vec = η (D, n), ell = log normalizer (n,)
#   covariance phase  (info=False): mat = P (D, D), vec = m (D, n), ell = log-likelihood (n,)
# ---------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _symmetrize(A: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    return 0.5 * (A + A.T)


@numba.njit(cache=True)
def _chol_solve(L: np.ndarray, B: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """A⁻¹ B from the Cholesky factor L of A (D, D), B (D, r); returns a new C array."""
    X = B.copy()
    cholesky_solve(L, B.shape[0], X)
    return X


@numba.njit(cache=True)
def _spd_solve(A: np.ndarray, B: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """A⁻¹ B for symmetric positive definite A."""
    return _chol_solve(np.linalg.cholesky(A), B)


@numba.njit(cache=True)
def _info_predict(Omega, eta, ell, F_inv, F_invT, p, q, log_abs_det_F):  # pragma: no cover
    """Flat-prior-exact prediction in information form (Woodbury, Ω may be singular)."""
    M = _symmetrize(F_invT @ Omega @ F_inv)
    eta_p = F_invT @ eta
    S = M[:p, :p].copy()
    for a in range(p):
        S[a, a] += 1.0 / q
    Mp = np.ascontiguousarray(M[:, :p])
    L = np.linalg.cholesky(S)
    X = _chol_solve(L, M[:p, :])  # S⁻¹ Gᵀ M, (p, D)
    Z = _chol_solve(L, eta_p[:p])  # S⁻¹ Gᵀ η', (p, n)
    Omega_new = _symmetrize(M - Mp @ X)
    eta_new = eta_p - Mp @ Z
    logdet_qS = p * np.log(q)  # log det(q S) = log det(I + q Gᵀ M G)
    for a in range(p):
        logdet_qS += 2.0 * np.log(L[a, a])
    for i in range(ell.shape[0]):
        quad = 0.0
        for a in range(p):
            quad += eta_p[a, i] * Z[a, i]
        ell[i] += -log_abs_det_F - 0.5 * logdet_qS + 0.5 * quad
    return Omega_new, eta_new


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _info_identified(Omega, tol):  # pragma: no cover - compiled
    """True if Ω scaled to unit diagonal has smallest eigenvalue > tol."""
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
    return np.linalg.eigvalsh(scaled)[0] > tol


@numba.njit(cache=True)
def _info_to_moments(Omega, eta, ell):  # pragma: no cover - compiled
    """Switch to moments: P = Ω⁻¹, m = Ω⁻¹η; ell becomes log ∫ (likelihood so far) ds."""
    D = Omega.shape[0]
    L = np.linalg.cholesky(Omega)
    P = _symmetrize(_chol_solve(L, np.eye(D)))
    m = _chol_solve(L, eta)
    logdet = 0.0
    for a in range(D):
        logdet += 2.0 * np.log(L[a, a])
    for i in range(ell.shape[0]):
        quad = 0.0
        for a in range(D):
            quad += eta[a, i] * m[a, i]
        ell[i] += 0.5 * D * LOG_2PI - 0.5 * logdet + 0.5 * quad
    return P, m


@numba.njit(cache=True)
def _cov_predict(P, m, F, FT, p, q):  # pragma: no cover - compiled
    """m⁺ = F m, P⁺ = F P Fᵀ + G q Gᵀ."""
    P_new = F @ P @ FT
    for a in range(p):
        P_new[a, a] += q
    return _symmetrize(P_new), F @ m


@numba.njit(cache=True)
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
def step(mat, vec, ell, info, predict, phi_t, y_t, obs_t, F, FT, F_inv, F_invT, q, r,
          log_abs_det_F, tol):  # pragma: no cover - compiled
    """One time step: predict from t−1 (unless ``predict`` is False), then update.

    The measurements of step t are the rows j of φ_t (q, p), y_t (q, n) with
    ``obs_t[j]`` True (one per trajectory; none for a missing sample).
    Returns the new (mat, vec, info); ``ell`` is updated in place.
    """
    p = phi_t.shape[1]
    if info:
        if predict:
            mat, vec = _info_predict(mat, vec, ell, F_inv, F_invT, p, q, log_abs_det_F)
        for j in range(phi_t.shape[0]):
            if obs_t[j]:
                _info_update(mat, vec, ell, phi_t[j], y_t[j], r)
        if _info_identified(mat, tol):
            P, m = _info_to_moments(mat, vec, ell)
            return P, m, False
        return mat, vec, True
    if predict:
        mat, vec = _cov_predict(mat, vec, F, FT, p, q)
    for j in range(phi_t.shape[0]):
        if obs_t[j]:
            _cov_update(mat, vec, ell, phi_t[j], y_t[j], r)
    return mat, vec, False


@numba.njit(cache=True)
def filter_kernel(phi, y, observed, F, F_inv, q, r, log_abs_det_F, diffuse, m0, P0,
                   tol):  # pragma: no cover - compiled
    """Run the filter over all time steps: φ (N, q, p), y (N, q, n), observed (N, q).

    Returns (vecs (N, D, n), mats (N, D, D), in_info (N,), ell (n,)): per step the
    filtered (m, P), or (η, Ω) while the state is not identified (in_info True).
    """
    N = phi.shape[0]
    n = y.shape[2]
    D = F.shape[0]
    FT = np.ascontiguousarray(F.T)
    F_invT = np.ascontiguousarray(F_inv.T)
    vecs = np.empty((N, D, n))
    mats = np.empty((N, D, D))
    in_info = np.zeros(N, dtype=np.bool_)
    ell = np.zeros(n)
    if diffuse:
        mat = np.zeros((D, D))
        vec = np.zeros((D, n))
    else:
        mat = P0.copy()
        vec = m0.copy()
    info = diffuse
    for t in range(N):
        mat, vec, info = step(mat, vec, ell, info, t > 0, phi[t], y[t], observed[t], F, FT,
                              F_inv, F_invT, q, r, log_abs_det_F, tol)
        vecs[t] = vec
        mats[t] = mat
        in_info[t] = info
    return vecs, mats, in_info, ell


@numba.njit(cache=True)
def smoother_kernel(vecs, mats, in_info, F, F_inv, p, q):  # pragma: no cover - compiled
    """RTS backward pass; returns the k-blocks: means (N, p, n), covariances (N, p, p)."""
    N, D, n = vecs.shape
    FT = np.ascontiguousarray(F.T)
    F_invT = np.ascontiguousarray(F_inv.T)
    Fp = np.ascontiguousarray(F_inv[:, :p])  # F⁻¹ G
    FpT = np.ascontiguousarray(Fp.T)
    out_m = np.empty((N, p, n))
    out_P = np.empty((N, p, p))
    ms = vecs[N - 1].copy()
    Ps = mats[N - 1].copy()
    out_m[N - 1] = ms[:p]
    out_P[N - 1] = Ps[:p, :p]
    for t in range(N - 2, -1, -1):
        if in_info[t]:
            M = _symmetrize(F_invT @ mats[t] @ F_inv)
            eta_p = F_invT @ vecs[t]
            S = M[:p, :p].copy()
            for a in range(p):
                S[a, a] += 1.0 / q
            L_S = np.linalg.cholesky(S)
            X = _chol_solve(L_S, M[:p, :])  # S⁻¹ Gᵀ M
            IGX = np.eye(D)
            IGX[:p, :] -= X
            J = F_inv @ IGX
            b = Fp @ _chol_solve(L_S, eta_p[:p])
            L = Fp @ _chol_solve(L_S, FpT)
            ms = J @ ms + b
            Ps = _symmetrize(J @ Ps @ np.ascontiguousarray(J.T) + L)
        else:
            P = mats[t]
            m = vecs[t]
            FP = F @ P
            P_pred = FP @ FT
            for a in range(p):
                P_pred[a, a] += q
            P_pred = _symmetrize(P_pred)
            JT = _spd_solve(P_pred, FP)  # P⁻¹_{t+1|t} F P_{t|t} = Jᵀ
            J = np.ascontiguousarray(JT.T)
            ms = m + J @ (ms - F @ m)
            Ps = _symmetrize(P + J @ (Ps - P_pred) @ JT)
        out_m[t] = ms[:p]
        out_P[t] = Ps[:p, :p]
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
