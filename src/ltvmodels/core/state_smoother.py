"""The states of an LTV model observed with noise: Kalman filter, RTS smoother, moments.

The measurement model of :func:`ltvmodels.fit` with ``measurement_noise``:

    x_{t+1} = A_t x_t + b_t + w_t,   w_t ~ N(0, q_t I),   b_t = B_t u_t (+ c_t),
    y_t     = x_t + e_t,             e_{t,i} ~ N(0, r_{t,i}),

for each of R independent trajectories (sharing A_t, b_t only through the
caller), with y_t the recorded state: only its finite entries are observed.
The measurement update processes them one at a time (the measurement matrix
is a selection of the identity and the noise is diagonal, so the sequential
scalar updates are exact and need no matrix inverse); a sample with no finite
entry adds nothing. Where a transition is absent (an input is missing, or its
weight is 0) the chain restarts: the next state gets the initial prior again.

Initial state: a wide proper prior x_0 ~ N(0, κ I) at the start of each chain
(κ chosen by the caller, see :func:`prior_variance`), not an exact diffuse
one, so that the likelihood is the ordinary log p(y) of a proper model (it is
statsmodels' ``initialization="known"`` with that mean and covariance, or
``"approximate_diffuse"`` with ``initial_variance=κ``).

Outputs per trajectory r and time t: the smoothed means E[x_t | y], their
covariances Cov(x_t | y), the lag-one cross covariances
Cov(x_{t+1}, x_t | y) = P_{t+1|T} J_tᵀ (J_t the RTS gain), and the
log-likelihood Σ −½(log 2π s + v²/s) over the scalar innovations v with
variances s (the prediction-error decomposition). O(R T n³) time, O(R T n²)
memory.

:func:`expected_statistics` turns the moments into the expected sufficient
statistics of the transitions, Σ_r w_rt E[φ φᵀ] and Σ_r w_rt E[φ x_{t+1}ᵀ] with
φ_t = [x_t; u_t (; 1)], and :func:`expected_problem` into pseudo-data that
every solver of the library accepts (a :class:`RegressionProblem` with p rows
per step whose Gram and cross sums are those statistics).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .problem import RegressionProblem

__all__ = [
    "StateMoments",
    "ExpectedStatistics",
    "smooth_states",
    "expected_statistics",
    "expected_problem",
    "prior_variance",
]

PRIOR_SCALE = 1e6
"""κ = PRIOR_SCALE · max(1, the largest mean square of a recorded state)."""


@dataclass(frozen=True)
class StateMoments:
    """The smoothed states of R trajectories.

    Attributes
    ----------
    mean : ndarray, shape (R, T, n)
        E[x_t | y].
    cov : ndarray, shape (R, T, n, n)
        Cov(x_t | y).
    cross : ndarray, shape (R, T − 1, n, n)
        Cov(x_{t+1}, x_t | y) (zero where the chain restarts).
    loglik : float
        log p(y) by the prediction-error decomposition.
    """

    mean: np.ndarray
    cov: np.ndarray
    cross: np.ndarray
    loglik: float

    @property
    def std(self) -> np.ndarray:
        """Standard deviations of the smoothed states, (R, T, n)."""
        return np.sqrt(np.maximum(np.diagonal(self.cov, axis1=2, axis2=3), 0.0))


@dataclass(frozen=True)
class ExpectedStatistics:
    """Expected sufficient statistics of the transitions, summed over trajectories.

    Attributes
    ----------
    gram : ndarray, shape (N, p, p)
        Σ_r w_rt E[φ_rt φ_rtᵀ].
    cross : ndarray, shape (N, p, n)
        Σ_r w_rt E[φ_rt x_{r,t+1}ᵀ].
    target : ndarray, shape (N, n)
        Σ_r w_rt E[x_{r,t+1,i}²] (the diagonal of the targets' second moment).
    n_transitions : int
        Transitions in the chains (each with n noise entries).
    """

    gram: np.ndarray
    cross: np.ndarray
    target: np.ndarray
    n_transitions: int

    def expected_rss(self, theta: np.ndarray) -> np.ndarray:
        """Σ_t Σ_r w_rt E[(x_{t+1,i} − θ_{t,i} φ_t)²] per output i, (n,), for Θ (N, n, p)."""
        out = np.zeros(self.target.shape[1])
        # compiled: the einsum form took as long as an E-step at T = 10⁵
        _expected_rss(np.ascontiguousarray(theta, dtype=float), self.gram, self.cross, out)
        return self.target.sum(axis=0) + out


@numba.njit(cache=True)
def _expected_rss(theta, gram, cross, out):  # pragma: no cover - compiled
    """out_i += Σ_t θ_ti G_t θ_tiᵀ − 2 θ_ti C_t[:, i]."""
    N, n, p = theta.shape
    for t in range(N):
        G = gram[t]
        for i in range(n):
            th = theta[t, i]
            acc = 0.0
            for a in range(p):
                ga = 0.0
                for b in range(p):
                    ga += G[a, b] * th[b]
                acc += th[a] * (ga - 2.0 * cross[t, a, i])
            out[i] += acc


def prior_variance(y: np.ndarray) -> float:
    """κ of the initial prior N(0, κ I): wide against the recorded values y (NaN ignored)."""
    finite = y[np.isfinite(y)]
    scale = float(np.mean(finite**2)) if finite.size else 1.0
    return PRIOR_SCALE * max(1.0, scale)


def smooth_states(
    A: np.ndarray,
    offset: np.ndarray,
    link: np.ndarray,
    process_var: np.ndarray,
    y: np.ndarray,
    measurement_var: np.ndarray,
    prior_var: float,
) -> StateMoments:
    """Kalman filter and RTS smoother of the states (see the module docstring).

    Parameters
    ----------
    A : ndarray, shape (N, n, n)
        State matrices A_t, N = T − 1.
    offset : ndarray, shape (R, N, n)
        b_rt = B_t u_rt (+ c_t) of each transition.
    link : ndarray of bool, shape (R, N)
        Whether transition t of trajectory r is in the model (False: the chain
        restarts at t + 1 with the initial prior).
    process_var : ndarray, shape (R, N)
        q_rt > 0, the variance of each entry of w_rt (where ``link``).
    y : ndarray, shape (R, T, n)
        Recorded states, NaN where not observed.
    measurement_var : ndarray, shape (R, T, n)
        r_rti > 0 of each entry (a per-entry weight ω divides it: the hook of
        an iteratively reweighted robust measurement loss).
    prior_var : float
        κ of the initial prior N(0, κ I).

    Returns
    -------
    StateMoments
    """
    R, T, n = y.shape
    mean = np.empty((R, T, n))
    cov = np.empty((R, T, n, n))
    cross = np.zeros((R, max(T - 1, 0), n, n))
    loglik = _smooth(
        np.ascontiguousarray(A, dtype=float),
        np.ascontiguousarray(offset, dtype=float),
        np.ascontiguousarray(link, dtype=np.bool_),
        np.ascontiguousarray(process_var, dtype=float),
        np.ascontiguousarray(y, dtype=float),
        np.ascontiguousarray(measurement_var, dtype=float),
        float(prior_var),
        mean,
        cov,
        cross,
    )
    return StateMoments(mean, cov, cross, float(loglik))


@numba.njit(cache=True)
def _smooth(A, offset, link, qvar, y, rvar, kappa, mean, cov, cross):  # pragma: no cover - compiled
    R, T, n = y.shape
    log2pi = np.log(2.0 * np.pi)
    loglik = 0.0
    mp = np.empty((T, n))  # predicted means and covariances of one trajectory
    Pp = np.empty((T, n, n))
    AP = np.empty((n, n))
    gain = np.empty(n)
    row = np.empty(n)
    L = np.empty((n, n))
    Jt = np.empty((n, n))
    D = np.empty((n, n))
    JD = np.empty((n, n))
    dm = np.empty(n)
    for r in range(R):
        for t in range(T):
            P = cov[r, t]
            m = mean[r, t]
            if t == 0 or not link[r, t - 1]:
                for i in range(n):
                    m[i] = 0.0
                    for j in range(n):
                        P[i, j] = kappa if i == j else 0.0
            else:
                At = A[t - 1]
                mf = mean[r, t - 1]
                Pf = cov[r, t - 1]
                for i in range(n):
                    acc = offset[r, t - 1, i]
                    for j in range(n):
                        acc += At[i, j] * mf[j]
                    m[i] = acc
                    for j in range(n):
                        acc = 0.0
                        for k in range(n):
                            acc += At[i, k] * Pf[k, j]
                        AP[i, j] = acc
                for i in range(n):
                    for j in range(i + 1):
                        acc = 0.0
                        for k in range(n):
                            acc += AP[i, k] * At[j, k]
                        P[i, j] = acc
                        P[j, i] = acc
                    P[i, i] += qvar[r, t - 1]
            for i in range(n):
                mp[t, i] = m[i]
                for j in range(n):
                    Pp[t, i, j] = P[i, j]
            for i in range(n):  # sequential scalar updates on the observed entries
                v = y[r, t, i]
                if not np.isfinite(v):
                    continue
                Pii = P[i, i]
                s = Pii + rvar[r, t, i]
                innov = v - m[i]
                loglik += -0.5 * (log2pi + np.log(s) + innov * innov / s)
                for a in range(n):
                    gain[a] = P[a, i] / s
                    row[a] = P[i, a]
                for a in range(n):
                    m[a] += gain[a] * innov
                    for b in range(n):
                        P[a, b] -= gain[a] * row[b]
                # the updated variance without cancellation: P r / (P + r)
                P[i, i] = Pii * rvar[r, t, i] / s
            for a in range(n):
                for b in range(a + 1, n):
                    sym = 0.5 * (P[a, b] + P[b, a])
                    P[a, b] = sym
                    P[b, a] = sym
        # RTS smoother: the filtered moments in mean/cov become the smoothed ones
        for t in range(T - 2, -1, -1):
            if not link[r, t]:
                continue
            Pf = cov[r, t]
            At = A[t]
            # Jᵀ = Pp⁻¹ A Pf by the Cholesky factor of Pp (positive definite: q > 0)
            Pn = Pp[t + 1]
            for j in range(n):
                acc = Pn[j, j]
                for k in range(j):
                    acc -= L[j, k] * L[j, k]
                L[j, j] = np.sqrt(acc)
                for i in range(j + 1, n):
                    acc = Pn[i, j]
                    for k in range(j):
                        acc -= L[i, k] * L[j, k]
                    L[i, j] = acc / L[j, j]
            for c in range(n):
                for i in range(n):  # A Pf column c, then forward and back substitution
                    acc = 0.0
                    for k in range(n):
                        acc += At[i, k] * Pf[k, c]
                    row[i] = acc
                for i in range(n):
                    acc = row[i]
                    for k in range(i):
                        acc -= L[i, k] * gain[k]
                    gain[i] = acc / L[i, i]
                for i in range(n - 1, -1, -1):
                    acc = gain[i]
                    for k in range(i + 1, n):
                        acc -= L[k, i] * Jt[k, c]
                    Jt[i, c] = acc / L[i, i]
            for i in range(n):
                dm[i] = mean[r, t + 1, i] - mp[t + 1, i]
                for j in range(n):
                    D[i, j] = cov[r, t + 1, i, j] - Pn[i, j]
            for i in range(n):  # J = Jtᵀ: m += J dm; JD = J D
                acc = 0.0
                for k in range(n):
                    acc += Jt[k, i] * dm[k]
                mean[r, t, i] += acc
                for j in range(n):
                    acc = 0.0
                    for k in range(n):
                        acc += Jt[k, i] * D[k, j]
                    JD[i, j] = acc
            for i in range(n):
                for j in range(i + 1):
                    acc = 0.0
                    for k in range(n):
                        acc += JD[i, k] * Jt[k, j]
                    value = Pf[i, j] + acc
                    Pf[i, j] = value
                    Pf[j, i] = value
            Ps = cov[r, t + 1]
            for i in range(n):  # Cov(x_{t+1}, x_t) = P_{t+1|T} Jᵀ
                for j in range(n):
                    acc = 0.0
                    for k in range(n):
                        acc += Ps[i, k] * Jt[k, j]
                    cross[r, t, i, j] = acc
    return loglik


def expected_statistics(
    moments: StateMoments,
    u: np.ndarray,
    link: np.ndarray,
    weights: np.ndarray | None,
    constant: bool,
) -> ExpectedStatistics:
    """The expected sufficient statistics of the transitions (see :class:`ExpectedStatistics`).

    ``u`` (R, T, m) are exact inputs, ``link`` (R, N) the transitions in the
    model, ``weights`` (R, N) or None their weights.
    """
    mean = moments.mean
    R, T, n = mean.shape
    N = T - 1
    m = u.shape[2]
    p = n + m + int(constant)
    w = link.astype(float) if weights is None else np.where(link, weights, 0.0)
    uu = np.ascontiguousarray(np.where(link[:, :, None], u[:, :N], 0.0))  # NaN in no transition
    gram = np.zeros((N, p, p))
    cross = np.zeros((N, p, n))
    target = np.zeros((N, n))
    _statistics(
        mean, moments.cov, moments.cross, uu, np.ascontiguousarray(w), bool(constant),
        gram, cross, target,
    )  # fmt: skip
    return ExpectedStatistics(gram, cross, target, int(np.count_nonzero(link)))


@numba.njit(cache=True)
def _statistics(mean, cov, lag, u, w, constant, gram, cross, target):  # pragma: no cover - compiled
    R, T, n = mean.shape
    m = u.shape[2]
    p = gram.shape[1]
    phi = np.empty(p)
    for r in range(R):
        for t in range(T - 1):
            wt = w[r, t]
            if wt == 0.0:
                continue
            for a in range(n):
                phi[a] = mean[r, t, a]
            for a in range(m):
                phi[n + a] = u[r, t, a]
            if constant:
                phi[p - 1] = 1.0
            for a in range(p):
                for b in range(p):
                    gram[t, a, b] += wt * phi[a] * phi[b]
                for i in range(n):
                    cross[t, a, i] += wt * phi[a] * mean[r, t + 1, i]
            for a in range(n):
                for b in range(n):
                    gram[t, a, b] += wt * cov[r, t, a, b]
                for i in range(n):  # E[x_t x_{t+1}ᵀ] − m mᵀ = Cov(x_{t+1}, x_t)ᵀ
                    cross[t, a, i] += wt * lag[r, t, i, a]
            for i in range(n):
                x1 = mean[r, t + 1, i]
                target[t, i] += wt * (x1 * x1 + cov[r, t + 1, i, i])


def expected_problem(stats: ExpectedStatistics, coeffs: np.ndarray) -> RegressionProblem:
    """Pseudo-data with the Gram and cross sums of ``stats``: p rows per step.

    With G_t = L_t L_tᵀ (a Cholesky factor; where a pivot is at or below a
    relative 1e-12 of the diagonal — a direction without data, as for inputs
    that are zero over a step — its column is dropped), the rows φ̃_tj = column j
    of L_t and targets ỹ_t = L_t⁻¹ C_t (on the kept columns) give Σ_j φ̃ φ̃ᵀ = G_t
    and Σ_j φ̃ ỹᵀ = C_t (C_t lies in the range of G_t), so that
    Σ_j ‖ỹ_tj − Θ_t φ̃_tj‖² is the expected data term Σ_r w E‖x_{t+1} − Θ_t φ_t‖²
    up to a constant. A step without transitions, and a dropped column, give rows
    of zeros: they add nothing to the squared-loss sums the M-step minimizes, so
    the problem is built with every row observed (marking them unobserved would
    copy y and φ, a tenth of an EM iteration at T = 10⁵, for the same fit).
    """
    gram, cross = stats.gram, stats.cross
    N, p, n = cross.shape
    phi = np.zeros((N, p, p))
    y = np.zeros((N, p, n))
    keep = np.zeros((N, p), dtype=np.bool_)
    _pseudo_rows(gram, cross, phi, y, keep)
    return RegressionProblem(y=y, phi=phi, coeffs=coeffs, rows_are_samples=False)


@numba.njit(cache=True)
def _pseudo_rows(gram, cross, phi, y, keep):  # pragma: no cover - compiled
    N, p, n = cross.shape
    L = np.zeros((p, p))
    for t in range(N):
        G = gram[t]
        scale = 0.0
        for a in range(p):
            scale = max(scale, G[a, a])
        if scale <= 0.0:
            continue
        L[:, :] = 0.0
        for j in range(p):  # semidefinite Cholesky: a vanishing pivot drops its column
            acc = G[j, j]
            for k in range(j):
                acc -= L[j, k] * L[j, k]
            if acc <= 1e-12 * scale:
                continue
            L[j, j] = np.sqrt(acc)
            keep[t, j] = True
            for i in range(j + 1, p):
                acc = G[i, j]
                for k in range(j):
                    acc -= L[i, k] * L[j, k]
                L[i, j] = acc / L[j, j]
        for j in range(p):  # row j: column j of L; target: forward substitution
            if not keep[t, j]:
                continue
            for a in range(p):
                phi[t, j, a] = L[a, j]
            for i in range(n):
                acc = cross[t, j, i]
                for k in range(j):
                    acc -= L[j, k] * y[t, k, i]
                y[t, j, i] = acc / L[j, j]
