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
from typing import Any

import numba
import numpy as np

from .. import _validate
from ..errors import SingularProblemError
from ..problem import state_space_problem
from .squared import CovarianceBlocks

LOG_2PI = float(np.log(2.0 * np.pi))

#: Smallest eigenvalue of the information matrix, scaled to unit diagonal, at
#: which the diffuse filter regards the state as identified (the tolerance of
#: :mod:`ltvmodels.identifiability`).
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


def _realize(coeffs: np.ndarray, p: int, lam: float, noise_var: float) -> ParameterStateSpace:
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


def parameter_state_space(
    order: Any = 1, n_regressors: int = 1, *, lam: float, noise_var: float = 1.0
) -> ParameterStateSpace:
    """State-space realization of the penalty λ² Σ_t ‖(Dk)_t‖² (paper Proposition 1).

    Parameters
    ----------
    order : int or sequence of float
        Difference operator, as in :func:`ltvmodels.fit`.
    n_regressors : int
        p, the number of regressors (n + m for a state-space model).
    lam : float
        λ > 0.
    noise_var : float
        Measurement noise variance σ² > 0.

    Returns
    -------
    ParameterStateSpace
        Matrices for one output row; all rows share them.
    """
    coeffs = _validate.difference_coefficients(order)
    p = _validate.integer(n_regressors, "n_regressors", 1)
    lam = _validate.scalar_lam(lam)
    noise_var = _validate.positive_scalar(noise_var, "noise_var")
    return _realize(coeffs, p, lam, noise_var)


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
    """A⁻¹ B from the Cholesky factor L of A (D, D), B (D, r); returns a new C array.

    (Hand-written substitutions: small D, and much faster to compile than
    numba's np.linalg.solve.)
    """
    D, r = B.shape
    X = np.empty((D, r))
    for j in range(r):
        for a in range(D):  # L z = b
            acc = B[a, j]
            for b in range(a):
                acc -= L[a, b] * X[b, j]
            X[a, j] = acc / L[a, a]
        for a in range(D - 1, -1, -1):  # Lᵀ x = z
            acc = X[a, j]
            for b in range(a + 1, D):
                acc -= L[b, a] * X[b, j]
            X[a, j] = acc / L[a, a]
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
def _step(mat, vec, ell, info, predict, phi_t, y_t, F, FT, F_inv, F_invT, q, r,
          log_abs_det_F, tol):  # pragma: no cover - compiled
    """One time step: predict from t−1 (unless ``predict`` is False), then update with y_t.

    Returns the new (mat, vec, info); ``ell`` is updated in place.
    """
    p = phi_t.shape[0]
    if info:
        if predict:
            mat, vec = _info_predict(mat, vec, ell, F_inv, F_invT, p, q, log_abs_det_F)
        _info_update(mat, vec, ell, phi_t, y_t, r)
        if _info_identified(mat, tol):
            P, m = _info_to_moments(mat, vec, ell)
            return P, m, False
        return mat, vec, True
    if predict:
        mat, vec = _cov_predict(mat, vec, F, FT, p, q)
    _cov_update(mat, vec, ell, phi_t, y_t, r)
    return mat, vec, False


@numba.njit(cache=True)
def _filter_kernel(phi, y, F, F_inv, q, r, log_abs_det_F, diffuse, m0, P0,
                   tol):  # pragma: no cover - compiled
    """Run the filter over all time steps.

    Returns (vecs (N, D, n), mats (N, D, D), in_info (N,), ell (n,)): per step the
    filtered (m, P), or (η, Ω) while the state is not identified (in_info True).
    """
    N, p = phi.shape
    n = y.shape[1]
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
        mat, vec, info = _step(mat, vec, ell, info, t > 0, phi[t], y[t], F, FT, F_inv, F_invT,
                               q, r, log_abs_det_F, tol)
        vecs[t] = vec
        mats[t] = mat
        in_info[t] = info
    return vecs, mats, in_info, ell


@numba.njit(cache=True)
def _smoother_kernel(vecs, mats, in_info, F, F_inv, p, q):  # pragma: no cover - compiled
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
# Results
# ---------------------------------------------------------------------------------------


class _ParameterAccess:
    """A_t, B_t and the full covariance from ``k`` (N, K), ``cov`` (N, p, p), ``n_states``."""

    k: np.ndarray
    cov: np.ndarray
    n_states: int

    @property
    def A(self) -> np.ndarray:
        """(N, n, n) state matrices A_t."""
        n = self.n_states
        return self.k.reshape(self.k.shape[0], n, -1)[:, :, :n]

    @property
    def B(self) -> np.ndarray:
        """(N, n, m) input matrices B_t."""
        n = self.n_states
        return self.k.reshape(self.k.shape[0], n, -1)[:, :, n:]

    def cov_full(self) -> np.ndarray:
        """(N, K, K) covariance of k_t, I_n ⊗ cov[t]."""
        n = self.n_states
        shared = CovarianceBlocks(self.cov[None], np.zeros(n, dtype=int))
        return shared.full(n, self.cov.shape[1])


@dataclass(frozen=True)
class KalmanFilterResult(_ParameterAccess):
    """Filtered parameter estimates k_{t|t} = E[k_t | y_0 … y_t].

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Filtered means, k_t = Θ_t.ravel() (rows of [A_t B_t] concatenated).
        NaN at the time steps where the diffuse filter has not yet identified the
        state (k_t, …, k_{t−d+1}), i.e. before ``first_identified``.
    cov : ndarray, shape (N, p, p)
        Filtered covariance of one row θ_{t,i} of Θ_t (σ² included); all rows share
        it and are independent, so Cov(k_t | y_0 … y_t) = I_n ⊗ cov[t]. NaN where
        ``k`` is.
    loglik : float
        Log-likelihood of all N observations (prediction-error decomposition);
        NaN if the state is never identified.
    first_identified : int
        First time step with finite estimates (0 with a proper prior); N if none.
    noise_var : float
        σ² used.
    lam : float
        λ used.
    coeffs : ndarray, shape (d + 1,)
        Difference-operator coefficients c_0 … c_d.
    n_states : int
        n, the number of output rows.

    Properties ``A`` (N, n, n) and ``B`` (N, n, m) give [A_t B_t] from ``k``;
    ``cov_full()`` the (N, K, K) covariance.
    """

    k: np.ndarray
    cov: np.ndarray
    loglik: float
    first_identified: int
    noise_var: float
    lam: float
    coeffs: np.ndarray
    n_states: int


@dataclass(frozen=True)
class KalmanSmootherResult(_ParameterAccess):
    """Smoothed parameter estimates k_{t|N} = E[k_t | y_0 … y_{N−1}].

    With the default diffuse initialization these equal the minimizer of
    Σ_t ‖y_t − Θ_t φ_t‖² + λ² Σ_t ‖(Dk)_t‖² (:func:`ltvmodels.fit`).

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Smoothed means.
    cov : ndarray, shape (N, p, p)
        Smoothed covariance of one row θ_{t,i} (σ² included), shared by all rows:
        Cov(k_t | y) = I_n ⊗ cov[t].
    loglik : float
        Log-likelihood (see the module notes on the diffuse convention).
    filtered : KalmanFilterResult
        The forward pass.

    Properties ``A`` (N, n, n) and ``B`` (N, n, m) give [A_t B_t] from ``k``;
    ``cov_full()`` the (N, K, K) covariance.
    """

    k: np.ndarray
    cov: np.ndarray
    loglik: float
    filtered: KalmanFilterResult

    @property
    def n_states(self) -> int:
        """n, the number of output rows."""
        return self.filtered.n_states


# ---------------------------------------------------------------------------------------
# Batch functions
# ---------------------------------------------------------------------------------------


def _log_abs_det_F(coeffs: np.ndarray, p: int) -> float:
    """log |det F| = p · log |c_0 / c_d|."""
    return p * float(np.log(abs(coeffs[0] / coeffs[-1])))


def _loglik_offset(coeffs: np.ndarray, n: int, p: int, diffuse: bool) -> float:
    """From a flat prior on (k_0, k_{−1}, …, k_{−d+1}) to unit density on (k_0 … k_{d−1}).

    Integrating the d − 1 pre-sample lags out over a flat prior multiplies the
    likelihood by |c_d / c_0|^{(d−1)·K}; :func:`ltvmodels.fit` has no such lags.
    """
    if not diffuse:
        return 0.0
    d = len(coeffs) - 1
    return -(d - 1) * n * p * float(np.log(abs(coeffs[-1] / coeffs[0])))


@dataclass
class _Setup:
    phi: np.ndarray
    y: np.ndarray
    model: ParameterStateSpace
    lam: float
    prior: tuple[np.ndarray, np.ndarray] | None

    @property
    def n(self) -> int:
        return self.y.shape[1]

    @property
    def p(self) -> int:
        return self.phi.shape[1]


def _setup(x, u, lam, order, noise_var, init_mean, init_cov) -> _Setup:
    x, u = _validate.state_and_input(x, u)
    coeffs = _validate.difference_coefficients(order)
    lam = _validate.scalar_lam(lam)
    noise_var = _validate.positive_scalar(noise_var, "noise_var")
    problem = state_space_problem(x, u, coeffs)
    prior = _validate.initial_state_prior(init_mean, init_cov, problem.degree, problem.n, problem.p)
    return _Setup(
        phi=np.ascontiguousarray(problem.phi), y=np.ascontiguousarray(problem.y),
        model=_realize(coeffs, problem.p, lam, noise_var), lam=lam, prior=prior,
    )


def _run_filter(s: _Setup):
    model = s.model
    D = model.F.shape[0]
    diffuse = s.prior is None
    m0, P0 = (np.zeros((D, s.n)), np.eye(D)) if diffuse else s.prior
    return _filter_kernel(
        s.phi, s.y, model.F, model.F_inv, model.q, model.R, _log_abs_det_F(model.coeffs, s.p),
        diffuse, np.ascontiguousarray(m0), np.ascontiguousarray(P0), IDENTIFIED_TOL,
    )


def _filter_result(s: _Setup, vecs, mats, in_info, ell) -> KalmanFilterResult:
    N, p, n = s.y.shape[0], s.p, s.n
    k = vecs[:, :p, :].transpose(0, 2, 1).reshape(N, n * p).copy()
    cov = mats[:, :p, :p].copy()
    k[in_info] = np.nan
    cov[in_info] = np.nan
    identified = np.flatnonzero(~in_info)
    first = int(identified[0]) if identified.size else N
    offset = _loglik_offset(s.model.coeffs, n, p, s.prior is None)
    loglik = float("nan") if in_info[-1] else float(ell.sum()) + offset
    return KalmanFilterResult(
        k=k, cov=cov, loglik=loglik, first_identified=first, noise_var=float(s.model.R),
        lam=s.lam, coeffs=s.model.coeffs.copy(), n_states=n,
    )


def kalman_filter(
    x: Any,
    u: Any = None,
    *,
    lam: float,
    order: Any = 1,
    noise_var: float = 1.0,
    init_mean: Any = None,
    init_cov: Any = None,
) -> KalmanFilterResult:
    """Kalman filter for the parameters of x[t+1] = A_t x[t] + B_t u[t] + v_t.

    Computes k_{t|t} = E[k_t | x_0 … x_{t+1}, u_0 … u_t] and its covariance for
    the random-walk model of the module docstring (paper eqs. dynsys, dynsys2,
    Proposition 1): y_t = x[t+1], φ_t = [x[t]; u[t]], process noise σ²/(λ² c_d²),
    measurement noise σ². With the default exact diffuse initialization k_{t|t}
    is the last time step of the minimizer of Σ_{s≤t} ‖y_s − Θ_s φ_s‖² +
    λ² Σ ‖(Dk)_s‖² on the data up to t (:func:`ltvmodels.fit` on x[:t+2]).

    Parameters
    ----------
    x : array_like, shape (T, n)
        States, time on axis 0 (lists and pandas DataFrames are accepted).
    u : array_like, shape (T, m) or (T,), optional
        Inputs.
    lam : float
        λ > 0 (scalar only).
    order : int or sequence of float
        Difference operator: 1 (random walk), 2 (eq. dynsys2), an integer d, or
        polynomial coefficients c_0 … c_d summing to zero.
    noise_var : float
        Measurement noise variance σ² > 0. The means do not depend on it (without
        a prior); covariances scale with it.
    init_mean : array_like, shape (d, K) or (K,) for d = 1, optional
        Prior mean of the initial state (k_0, k_{−1}, …, k_{−d+1}) (row j: k_{−j}).
        Default zero when ``init_cov`` is given.
    init_cov : float or array_like, shape (d·p, d·p), optional
        Prior covariance of one output row's initial state
        (θ_{0,i}, θ_{−1,i}, …); rows are independent with this covariance. None
        (default, with ``init_mean`` None): exact diffuse initialization.

    Returns
    -------
    KalmanFilterResult
        ``k`` (N, K), ``cov`` (N, p, p), ``loglik``, ``first_identified``; N = T − 1.
        Entries before the state is identified are NaN.
    """
    s = _setup(x, u, lam, order, noise_var, init_mean, init_cov)
    return _filter_result(s, *_run_filter(s))


def kalman_smoother(
    x: Any,
    u: Any = None,
    *,
    lam: float,
    order: Any = 1,
    noise_var: float = 1.0,
    init_mean: Any = None,
    init_cov: Any = None,
) -> KalmanSmootherResult:
    """Rauch–Tung–Striebel smoother for the parameters of x[t+1] = A_t x[t] + B_t u[t] + v_t.

    Computes k_{t|N} = E[k_t | all data] and Cov(k_t | all data) for the model
    of :func:`kalman_filter`. With the default diffuse initialization the means
    are the exact minimizer of

        Σ_t ‖x_{t+1} − A_t x_t − B_t u_t‖² + λ² Σ_t ‖(Dk)_t‖²

    (paper eqs. slow, smooth, generalkalman) and the covariances σ² [H⁻¹]_tt,
    the same numbers as ``ltvmodels.fit(x, u, lam=lam, order=order,
    noise_var=noise_var)``, computed in O(N (d·p)³) with one D × D covariance
    recursion (D = d·p) shared by the n output rows.

    Parameters
    ----------
    x, u, lam, order, noise_var, init_mean, init_cov
        As in :func:`kalman_filter`.

    Returns
    -------
    KalmanSmootherResult
        ``k`` (N, K), ``cov`` (N, p, p), ``loglik``, ``filtered``.

    Raises
    ------
    SingularProblemError
        With the diffuse initialization, if the data never identify the state
        (too few or too poorly exciting samples).
    """
    s = _setup(x, u, lam, order, noise_var, init_mean, init_cov)
    if s.prior is None:
        _validate.enough_samples(s.y.shape[0], s.p, s.model.degree)
    vecs, mats, in_info, ell = _run_filter(s)
    filtered = _filter_result(s, vecs, mats, in_info, ell)
    if in_info[-1]:
        raise SingularProblemError(
            "the data do not identify the parameters: with a flat (diffuse) prior on the "
            f"initial state, the information matrix is still singular after all {s.y.shape[0]} "
            "time steps. Remedies: more excitation in the inputs, a larger lam, a proper "
            "prior (init_mean, init_cov), or fewer regressors."
        )
    means, covs = _smoother_kernel(vecs, mats, in_info, s.model.F, s.model.F_inv, s.p, s.model.q)
    N, p, n = s.y.shape[0], s.p, s.n
    k = means.transpose(0, 2, 1).reshape(N, n * p)
    return KalmanSmootherResult(k=k, cov=covs, loglik=filtered.loglik, filtered=filtered)


# ---------------------------------------------------------------------------------------
# Online use
# ---------------------------------------------------------------------------------------


class OnlineParameterFilter:
    """Recursive (online) estimation of A_t, B_t one transition at a time.

    Runs the same compiled step as :func:`kalman_filter`: after the t-th call of
    :meth:`update` the estimate equals ``kalman_filter(...)`` on the data seen so
    far, last time step.

    Parameters
    ----------
    n_states : int
        n, the dimension of x.
    n_inputs : int
        m, the dimension of u (0 for an autonomous system).
    lam : float
        λ > 0.
    order : int or sequence of float
        Difference operator, as in :func:`ltvmodels.fit`.
    noise_var : float
        Measurement noise variance σ² > 0.
    init_mean, init_cov : optional
        Proper prior on the initial state, as in :func:`kalman_filter`; by default
        the exact diffuse initialization (estimates are NaN until identified).

    Examples
    --------
    >>> f = OnlineParameterFilter(2, 1, lam=10.0)        # doctest: +SKIP
    >>> for t in range(T - 1):                            # doctest: +SKIP
    ...     k_t = f.update(x[t], u[t], x[t + 1])
    """

    def __init__(
        self,
        n_states: int,
        n_inputs: int = 0,
        *,
        lam: float,
        order: Any = 1,
        noise_var: float = 1.0,
        init_mean: Any = None,
        init_cov: Any = None,
    ) -> None:
        self.n_states = _validate.integer(n_states, "n_states", 1)
        self.n_inputs = _validate.integer(n_inputs, "n_inputs", 0)
        p = self.n_states + self.n_inputs
        coeffs = _validate.difference_coefficients(order)
        self.lam = _validate.scalar_lam(lam)
        noise_var = _validate.positive_scalar(noise_var, "noise_var")
        self.model = _realize(coeffs, p, self.lam, noise_var)
        d = self.model.degree
        prior = _validate.initial_state_prior(init_mean, init_cov, d, self.n_states, p)
        self._log_abs_det_F = _log_abs_det_F(coeffs, p)
        self._loglik_offset = _loglik_offset(coeffs, self.n_states, p, prior is None)
        D = d * p
        self._FT = np.ascontiguousarray(self.model.F.T)
        self._F_invT = np.ascontiguousarray(self.model.F_inv.T)
        self._info = prior is None
        if prior is None:
            self._mat, self._vec = np.zeros((D, D)), np.zeros((D, self.n_states))
        else:
            self._vec, self._mat = (np.ascontiguousarray(a) for a in prior)
        self._ell = np.zeros(self.n_states)
        self._t = 0

    @property
    def n_updates(self) -> int:
        """Number of transitions processed."""
        return self._t

    @property
    def identified(self) -> bool:
        """True once the data (or the prior) determine the current parameters."""
        return self._t > 0 and not self._info

    @property
    def k(self) -> np.ndarray:
        """(K,) current estimate k_{t|t}; NaN until identified."""
        p = self.model.G.shape[1]
        if not self.identified:
            return np.full(self.n_states * p, np.nan)
        return self._vec[:p].T.ravel().copy()

    @property
    def cov(self) -> np.ndarray:
        """(p, p) covariance of each row of [A_t B_t] (shared, σ² included).

        NaN until identified.
        """
        p = self.model.G.shape[1]
        if not self.identified:
            return np.full((p, p), np.nan)
        return self._mat[:p, :p].copy()

    @property
    def A(self) -> np.ndarray:
        """(n, n) current estimate of A_t."""
        return self.k.reshape(self.n_states, -1)[:, : self.n_states]

    @property
    def B(self) -> np.ndarray:
        """(n, m) current estimate of B_t."""
        return self.k.reshape(self.n_states, -1)[:, self.n_states :]

    @property
    def loglik(self) -> float:
        """Log-likelihood of the transitions seen so far (NaN until identified)."""
        if not self.identified:
            return float("nan")
        return float(self._ell.sum()) + self._loglik_offset

    def update(self, x_t: Any, u_t: Any, x_next: Any) -> np.ndarray:
        """Process one transition x_next = A_t x_t + B_t u_t + v_t.

        Parameters
        ----------
        x_t : array_like, shape (n,)
        u_t : array_like, shape (m,), or None when m = 0
        x_next : array_like, shape (n,)

        Returns
        -------
        ndarray, shape (K,)
            The filtered estimate k_{t|t} (NaN until identified).
        """
        n, m = self.n_states, self.n_inputs
        x_t = _validate.vector(x_t, "x_t", n)
        x_next = _validate.vector(x_next, "x_next", n)
        u_t = np.zeros(0) if u_t is None and m == 0 else _validate.vector(u_t, "u_t", m)
        phi = np.concatenate([x_t, u_t])
        model = self.model
        self._mat, self._vec, self._info = _step(
            self._mat, self._vec, self._ell, self._info, self._t > 0, phi, x_next,
            model.F, self._FT, model.F_inv, self._F_invT, model.q, model.R,
            self._log_abs_det_F, IDENTIFIED_TOL,
        )
        self._t += 1
        return self.k
