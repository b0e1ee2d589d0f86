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
φ_t = [x_t; u_t (; 1)], as pseudo-data that every solver of the library
accepts (a :class:`RegressionProblem` with p rows per step whose Gram and cross
sums are those statistics).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .banded import kernel_size
from .blockkernels import block_size
from .problem import RegressionProblem

__all__ = [
    "StateMoments",
    "ExpectedStatistics",
    "smooth_states",
    "expected_statistics",
    "input_offsets",
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

    def measurement_squares(self, y: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
        """Σ_rt ω_rti E[(y_rti − x_rti)² | y] over the finite entries of ``y`` (R, T, n),
        per state i, (n,); ``weights`` ω (R, T, n), or None for 1."""
        out = np.zeros(y.shape[2])
        ones = np.ones((0, 0, 0))  # no weights: the kernel reads none
        w = ones if weights is None else np.ascontiguousarray(weights, dtype=float)
        _measurement_squares(np.ascontiguousarray(y, dtype=float), self.mean, self.cov, w, out)
        return out


@numba.njit(cache=True)
def _measurement_squares(y, mean, cov, w, out):  # pragma: no cover - compiled
    R, T, n = y.shape
    weighted = w.shape[0] > 0
    for r in range(R):
        for t in range(T):
            for i in range(n):
                v = y[r, t, i]
                if np.isfinite(v):
                    e = v - mean[r, t, i]
                    value = e * e + cov[r, t, i, i]
                    out[i] += w[r, t, i] * value if weighted else value


@dataclass(frozen=True)
class ExpectedStatistics:
    """The expected sufficient statistics of the transitions, as pseudo-data.

    With φ_t = [x_t; u_t (; 1)], the expected data term of step t is
    Σ_r w_rt E‖x_{r,t+1} − Θ_t φ_rt‖², a quadratic in Θ_t with the sums
    G_t = Σ_r w_rt E[φ_rt φ_rtᵀ] and C_t = Σ_r w_rt E[φ_rt x_{r,t+1}ᵀ]. Rows with
    these sums: one per trajectory, √w_rt [m_rt; u_rt (; 1)] with target
    √w_rt m_{r,t+1} (the smoothed means, m = E[x | y]), and n more for the
    smoothing uncertainty, [l_j; 0] with target row j of L_t⁻¹ S_t, where L_t is
    a Cholesky factor of Σ_r w_rt Cov(x_rt) (a pivot at or below a relative
    1e-12 of its diagonal drops its column: a zero row) and S_t =
    Σ_r w_rt Cov(x_rt, x_{r,t+1}) (in the range of that covariance, as the
    joint covariance of x_rt and x_{r,t+1} is semidefinite). Then Σ_j φ̃φ̃ᵀ = G_t
    and Σ_j φ̃ỹᵀ = C_t, so that the rows' residual sum is the expected data term
    less a constant, and every solver of the library minimizes it. A step or
    trajectory without a transition has rows of zeros: they add nothing to the
    squared-loss sums the M-step minimizes, so the problem has every row
    observed (marking them unobserved would copy y and φ, a tenth of an EM
    iteration at T = 10⁵, for the same fit).

    Attributes
    ----------
    problem : RegressionProblem
        The pseudo-data: φ (N, R + n, p), y (N, R + n, n); ``rows_are_samples``
        False.
    offset : ndarray, shape (n,)
        The constant: the expected residual sum of output i is the rows'
        residual sum plus ``offset[i]`` = Σ_t (Σ_r w_rt Var(x_{r,t+1,i}) −
        Σ_j ỹ_tji² over the n uncertainty rows).
    n_transitions : int
        Transitions in the chains (each with n noise entries).
    """

    problem: RegressionProblem
    offset: np.ndarray
    n_transitions: int

    def expected_rss(self, theta: np.ndarray) -> np.ndarray:
        """Σ_t Σ_r w_rt E[(x_{t+1,i} − θ_{t,i} φ_t)²] per output i, (n,), for Θ (N, n, p)."""
        problem = self.problem
        out = self.offset.copy()
        # compiled: the einsum form took as long as an E-step at T = 10⁵
        _add_rows_rss(_writable(theta), problem.phi, problem.y, out, _size(problem.p))
        return out


@numba.njit(cache=True)
def _add_rows_rss(theta, phi, y, out, size):  # pragma: no cover - compiled
    """out_i += Σ_tj (y_tji − θ_ti · φ_tj)²."""
    p = block_size(size)
    N, q, n = y.shape
    for t in range(N):
        for j in range(q):
            for i in range(n):
                e = y[t, j, i]
                for a in range(p):
                    e -= theta[t, i, a] * phi[t, j, a]
                out[i] += e * e


def input_offsets(theta: np.ndarray, u: np.ndarray, link: np.ndarray, constant: bool) -> np.ndarray:
    """b_rt = B_t u_rt (+ c_t), (R, N, n), from Θ_t = [A_t, B_t (, c_t)] (N, n, p) and
    the inputs ``u`` (R, T, m); 0 where ``link`` (R, N) is False (no transition)."""
    R, N = link.shape
    n = theta.shape[1]
    out = np.zeros((R, N, n))
    _input_offsets(
        _writable(theta),
        np.ascontiguousarray(u, dtype=float),
        np.ascontiguousarray(link, dtype=np.bool_),
        bool(constant),
        out,
    )
    return out


@numba.njit(cache=True)
def _input_offsets(theta, u, link, constant, out):  # pragma: no cover - compiled
    R, N, n = out.shape
    m = u.shape[2]
    for r in range(R):
        for t in range(N):
            if not link[r, t]:
                continue
            for i in range(n):
                acc = theta[t, i, n + m] if constant else 0.0
                for j in range(m):
                    acc += theta[t, i, n + j] * u[r, t, j]
                out[r, t, i] = acc


def prior_variance(y: np.ndarray) -> float:
    """κ of the initial prior N(0, κ I): wide against the recorded values y (NaN ignored)."""
    finite = y[np.isfinite(y)]
    scale = float(np.mean(finite**2)) if finite.size else 1.0
    return PRIOR_SCALE * max(1.0, scale)


def smooth_states(
    A: np.ndarray,
    offset: np.ndarray,
    link: np.ndarray,
    process_var: float | np.ndarray,
    y: np.ndarray,
    measurement_var: np.ndarray,
    prior_var: float,
) -> StateMoments:
    """Kalman filter and RTS smoother of the states (see the module docstring).

    Parameters
    ----------
    A : ndarray, shape (N, n, k), k >= n
        State matrices A_t = A[t, :, :n], N = T − 1 (the coefficients Θ_t
        = [A_t, B_t (, c_t)] may be passed as they are).
    offset : ndarray, shape (R, N, n)
        b_rt = B_t u_rt (+ c_t) of each transition (see :func:`input_offsets`).
    link : ndarray of bool, shape (R, N)
        Whether transition t of trajectory r is in the model (False: the chain
        restarts at t + 1 with the initial prior).
    process_var : float or ndarray, shape (R, N)
        q_rt > 0, the variance of each entry of w_rt (where ``link``).
    y : ndarray, shape (R, T, n)
        Recorded states, NaN where not observed.
    measurement_var : ndarray, shape (n,) or (R, T, n)
        r_rti > 0 of each entry, or one per state (a per-entry weight ω divides
        it: the hook of an iteratively reweighted robust measurement loss).
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
    # one per state, or one process variance: broadcast in the kernel, not copied
    qvar = np.asarray(process_var, dtype=float)
    rvar = np.asarray(measurement_var, dtype=float)
    loglik = _smooth(
        _writable(A),
        np.ascontiguousarray(offset, dtype=float),
        np.ascontiguousarray(link, dtype=np.bool_),
        np.ascontiguousarray(qvar.reshape((1, 1)) if qvar.ndim == 0 else qvar),
        np.ascontiguousarray(y, dtype=float),
        np.ascontiguousarray(rvar.reshape((1, 1, n)) if rvar.ndim == 1 else rvar),
        float(prior_var),
        mean,
        cov,
        cross,
        _size(n),
    )
    return StateMoments(mean, cov, cross, float(loglik))


def _size(b: int) -> int | tuple:
    """A kernel's size argument for b (see :func:`.banded.kernel_size`): the state
    and regressor counts of the usual models are small, and the kernels compiled
    for them as constants run about twice as fast (the smoother: 15 → 8 ms at
    n = 2, T = 10⁵)."""
    return kernel_size(0, b)


def _writable(arr: np.ndarray) -> np.ndarray:
    """``arr`` as a C-contiguous, writable float array (copied only if it is not one):
    numba compiles a kernel once more for a read-only argument (a result's Θ), 1–4 s."""
    return np.require(arr, float, ("C", "W"))


@numba.njit(cache=True)
def _smooth(A, offset, link, qvar, y, rvar, kappa, mean, cov, cross, size):  # pragma: no cover
    n = block_size(size)
    R, T, _ = y.shape
    # 1 where qvar (R, N) and rvar (R, T, n) vary along r and t, 0 where broadcast
    q_r, q_t = int(qvar.shape[0] > 1), int(qvar.shape[1] > 1)
    r_r, r_t = int(rvar.shape[0] > 1), int(rvar.shape[1] > 1)
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
                    P[i, i] += qvar[r * q_r, (t - 1) * q_t]
            for i in range(n):
                mp[t, i] = m[i]
                for j in range(n):
                    Pp[t, i, j] = P[i, j]
            for i in range(n):  # sequential scalar updates on the observed entries
                v = y[r, t, i]
                if not np.isfinite(v):
                    continue
                Pii = P[i, i]
                rv = rvar[r * r_r, t * r_t, i]
                s = Pii + rv
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
                P[i, i] = Pii * rv / s
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
    coeffs: np.ndarray,
) -> ExpectedStatistics:
    """The expected sufficient statistics of the transitions as pseudo-data (see
    :class:`ExpectedStatistics`), for the difference operator ``coeffs``.

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
    phi = np.zeros((N, R + n, p))
    y = np.zeros((N, R + n, n))
    offset = np.zeros(n)
    _pseudo_rows(
        mean, moments.cov, moments.cross, uu, np.ascontiguousarray(w), bool(constant),
        phi, y, offset, _size(n),
    )  # fmt: skip
    problem = RegressionProblem(y=y, phi=phi, coeffs=coeffs, rows_are_samples=False)
    return ExpectedStatistics(problem, offset, int(np.count_nonzero(link)))


@numba.njit(cache=True)
def _pseudo_rows(mean, cov, lag, u, w, constant, phi, y, offset, size):  # pragma: no cover
    n = block_size(size)
    R, T, _ = mean.shape
    m = u.shape[2]
    p = phi.shape[2]
    S = np.empty((n, n))  # Σ_r w Cov(x_t) (lower triangle) and Σ_r w Cov(x_t, x_{t+1})
    lagged = np.empty((n, n))
    L = np.zeros((n, n))
    inverse = np.zeros(n)  # 1 / L_jj, 0 for a dropped column
    for t in range(T - 1):
        for a in range(n):
            for b in range(n):
                S[a, b] = 0.0
                lagged[a, b] = 0.0
        seen = False
        for r in range(R):  # the rows of the smoothed means; the covariance sums
            wt = w[r, t]
            if wt == 0.0:
                continue
            seen = True
            root = np.sqrt(wt)
            for a in range(n):
                phi[t, r, a] = root * mean[r, t, a]
            for a in range(m):
                phi[t, r, n + a] = root * u[r, t, a]
            if constant:
                phi[t, r, p - 1] = root
            for i in range(n):
                y[t, r, i] = root * mean[r, t + 1, i]
                offset[i] += wt * cov[r, t + 1, i, i]
            for a in range(n):
                for b in range(a + 1):
                    S[a, b] += wt * cov[r, t, a, b]
                for i in range(n):  # Cov(x_t, x_{t+1})[a, i] = Cov(x_{t+1}, x_t)[i, a]
                    lagged[a, i] += wt * lag[r, t, i, a]
        if not seen:
            continue
        scale = 0.0
        for a in range(n):
            scale = max(scale, S[a, a])
        # semidefinite Cholesky (a vanishing pivot drops its column, left zero) and
        # the forward substitution L⁻¹ S_t, by reciprocal pivots (the loop is bound by
        # the latency of divisions)
        for j in range(n):
            acc = S[j, j]
            for k in range(j):
                acc -= L[j, k] * L[j, k]
            if acc > 1e-12 * scale:
                pivot = np.sqrt(acc)
                inverse[j] = 1.0 / pivot
            else:
                pivot = 0.0
                inverse[j] = 0.0
            L[j, j] = pivot
            for i in range(j + 1, n):
                acc = S[i, j]
                for k in range(j):
                    acc -= L[i, k] * L[j, k]
                L[i, j] = acc * inverse[j]
            row = R + j
            for i in range(n):
                acc = lagged[j, i]
                for k in range(j):
                    acc -= L[j, k] * y[t, R + k, i]
                value = acc * inverse[j]
                y[t, row, i] = value
                offset[i] -= value * value
            for a in range(j, n):  # row: column j of L (zero above the diagonal)
                phi[t, row, a] = L[a, j]
