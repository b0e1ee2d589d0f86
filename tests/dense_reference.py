"""Dense numpy references for the tests, independent of the package's code.

Everything here is built from scratch with numpy/scipy: the stacked regressor
Φ̃ (block diagonal with blocks I_n ⊗ φ_tᵀ), the stacked difference operator
D̃ = D ⊗ I_K, the penalty W̃ = I ⊗ W, and the dense normal equations of

    J(k) = ‖Ỹ − Φ̃ k‖² + (D̃k)ᵀ W̃ (D̃k)
           + σ² Σ_t ‖μ_t − k_t‖²_{Σ_t⁻¹} + σ² Σ_t ‖ȳ_t − Θ_t φ_t‖²_{S_t⁻¹},

(paper eq:closedform, eq:prioropt), with k_t = np.hstack([A_t, B_t]).ravel().
Coefficients with an infinite weight (λ_j = inf) are a single unknown shared by
all time steps: k = T θ with a 0/1 map T.

Sizes are small (N·K of a few hundred at most), so dense inverses are fine.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

LOG_2PI = np.log(2.0 * np.pi)


# -- data ---------------------------------------------------------------------------------


def random_data(seed: int, T: int, n: int, m: int):
    """White-noise states and inputs: a well-excited regression problem."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((T, n))
    u = rng.standard_normal((T, m)) if m else None
    return x, u


def simulate_ltv(seed: int, T: int = 60, n: int = 2, m: int = 1, noise: float = 0.1):
    """A stable, slowly varying LTV system x[t+1] = A_t x[t] + B_t u[t] + v_t.

    Returns x (T, n), u (T, m) or None, and the true k (T−1, K).
    """
    rng = np.random.default_rng(seed)
    A0 = rng.standard_normal((n, n))
    A0 *= 0.6 / max(np.abs(np.linalg.eigvals(A0)).max(), 1e-12)
    A1 = 0.25 * rng.standard_normal((n, n))
    B0 = rng.standard_normal((n, m))
    x = np.zeros((T, n))
    x[0] = rng.standard_normal(n)
    u = rng.standard_normal((T, m))
    ks = []
    for t in range(T - 1):
        s = np.sin(2 * np.pi * t / T)
        A = A0 + A1 * s
        A *= 0.9 / max(np.abs(np.linalg.eigvals(A)).max(), 0.9)  # keep it stable
        B = B0 * (1.0 + 0.3 * np.cos(2 * np.pi * t / T))
        ks.append(np.hstack([A, B]).ravel())
        x[t + 1] = A @ x[t] + B @ u[t] + noise * rng.standard_normal(n)
    return x, (u if m else None), np.array(ks)


# -- operators ----------------------------------------------------------------------------


def coefficients(order) -> np.ndarray:
    """Difference coefficients c_0 … c_d, computed here with binomials."""
    if np.ndim(order) == 0:
        from math import comb

        d = int(order)
        return np.array([(-1.0) ** (d - j) * comb(d, j) for j in range(d + 1)])
    return np.asarray(order, dtype=float)


def difference_matrix(N: int, coeffs: np.ndarray) -> np.ndarray:
    """Dense (N − d) × N matrix with (Dv)_t = Σ_j c_j v_{t+j}."""
    d = len(coeffs) - 1
    D = np.zeros((N - d, N))
    for t in range(N - d):
        D[t, t : t + d + 1] = coeffs
    return D


def weight_matrix(lam, K: int) -> np.ndarray:
    """W of Σ_t (Dk)_tᵀ W (Dk)_t: λ²I, diag(λ²) (inf kept) or the matrix itself."""
    lam = np.asarray(lam, dtype=float)
    if lam.ndim == 0:
        return np.diag(np.full(K, float(lam) ** 2))
    if lam.ndim == 1:
        return np.diag(lam**2)
    return lam.copy()


def stacked_regressor(x: np.ndarray, u: np.ndarray | None):
    """Φ̃ (N n × N K), Ỹ (N n,), φ (N, p)."""
    x = np.asarray(x, dtype=float)
    T, n = x.shape
    N = T - 1
    U = np.zeros((T, 0)) if u is None else np.asarray(u, dtype=float).reshape(T, -1)
    phi = np.hstack([x[:-1], U[:-1]])
    p = phi.shape[1]
    K = n * p
    Phi = np.zeros((N * n, N * K))
    for t in range(N):
        Phi[t * n : (t + 1) * n, t * K : (t + 1) * K] = np.kron(np.eye(n), phi[t])
    return Phi, x[1:].ravel(), phi


def block_diag_stack(blocks: np.ndarray) -> np.ndarray:
    """Dense block-diagonal matrix from an (N, d, d) array."""
    N, d, _ = blocks.shape
    out = np.zeros((N * d, N * d))
    for t in range(N):
        out[t * d : (t + 1) * d, t * d : (t + 1) * d] = blocks[t]
    return out


def diag_blocks(M: np.ndarray, N: int, K: int) -> np.ndarray:
    """The N diagonal K × K blocks of an (N K × N K) matrix."""
    return np.stack([M[t * K : (t + 1) * K, t * K : (t + 1) * K] for t in range(N)])


def as_blocks(cov, N: int, d: int) -> np.ndarray:
    cov = np.asarray(cov, dtype=float)
    if cov.ndim == 0:
        return np.broadcast_to(float(cov) * np.eye(d), (N, d, d)).copy()
    if cov.ndim == 2:
        return np.broadcast_to(cov, (N, d, d)).copy()
    return cov.copy()


def as_means(mean, N: int, d: int) -> np.ndarray:
    mean = np.asarray(mean, dtype=float)
    return np.broadcast_to(mean, (N, d)).copy() if mean.ndim == 1 else mean.copy()


# -- the dense problem ----------------------------------------------------------------------


@dataclass
class DenseProblem:
    """The dense normal equations, optionally with priors.

    ``param_priors``: list of (mean (N, K) | (K,), cov scalar | (K, K) | (N, K, K));
    ``output_priors``: list of (mean (N, n) | (n,), cov scalar | (n, n) | (N, n, n)).
    ``sigma2`` weighs the priors (the noise variance): a scalar, or one σ_i²
    per output (n,), which weighs the prior terms of row i (the priors and W
    must not couple the rows then).
    """

    x: np.ndarray
    u: np.ndarray | None
    order: object
    lam: object
    sigma2: object = 1.0
    param_priors: list = field(default_factory=list)
    output_priors: list = field(default_factory=list)

    def __post_init__(self):
        self.Phi, self.y, self.phi = stacked_regressor(self.x, self.u)
        self.N, self.p = self.phi.shape
        self.n = self.y.size // self.N
        self.K = self.n * self.p
        N, K = self.N, self.K
        self.coeffs = coefficients(self.order)
        self.d = len(self.coeffs) - 1
        W = weight_matrix(self.lam, K)
        const = np.isinf(np.diag(W))
        self.const = const
        W_fin = W.copy()
        W_fin[const, :] = 0.0
        W_fin[:, const] = 0.0
        self.W = W_fin
        Dt = np.kron(difference_matrix(N, self.coeffs), np.eye(K))
        self.Dt = Dt
        self.Q = Dt.T @ np.kron(np.eye(N - self.d), W_fin) @ Dt  # penalty Hessian
        # Map from the free unknowns θ to k: constant coefficients shared over time.
        cols = []
        for j in range(K):
            if const[j]:
                c = np.zeros(N * K)
                c[j::K] = 1.0
                cols.append(c)
            else:
                for t in range(N):
                    c = np.zeros(N * K)
                    c[t * K + j] = 1.0
                    cols.append(c)
        self.T = np.column_stack(cols)
        # Prior Hessian and right-hand side (in k, scaled by σ²).
        Hp = np.zeros((N * K, N * K))
        bp = np.zeros(N * K)
        s_y, s_k = self._noise_scales(self.sigma2)
        for mean, cov in self.param_priors:
            P = block_diag_stack(np.linalg.inv(as_blocks(cov, N, K)))
            Hp += s_k[:, None] * P
            bp += s_k * (P @ as_means(mean, N, K).ravel())
        for mean, cov in self.output_priors:
            P = block_diag_stack(np.linalg.inv(as_blocks(cov, N, self.n)))
            Hp += self.Phi.T @ (s_y[:, None] * P) @ self.Phi
            bp += self.Phi.T @ (s_y * (P @ as_means(mean, N, self.n).ravel()))
        self.Hp, self.bp = Hp, bp

    # -- estimates --------------------------------------------------------------------
    def hessian(self) -> np.ndarray:
        """H = Tᵀ(Φ̃ᵀΦ̃ + D̃ᵀW̃D̃ + σ² priors)T in the free unknowns."""
        return self.T.T @ (self.Phi.T @ self.Phi + self.Q + self.Hp) @ self.T

    def solve(self):
        """MAP k (N, K) and the dense k-covariance H⁻¹ (in units of σ², N K × N K)."""
        H = self.hessian()
        b = self.T.T @ (self.Phi.T @ self.y + self.bp)
        theta = np.linalg.solve(H, b)
        k = self.T @ theta
        cov = self.T @ np.linalg.inv(H) @ self.T.T
        return k.reshape(self.N, self.K), cov

    def cov_blocks(self, noise_var: float) -> np.ndarray:
        """σ² × diagonal blocks of H⁻¹: the marginal posterior covariances (N, K, K)."""
        _, cov = self.solve()
        return noise_var * diag_blocks(cov, self.N, self.K)

    def objective(self, k: np.ndarray) -> float:
        k = np.asarray(k).ravel()
        r = self.y - self.Phi @ k
        Dk = self.Dt @ k
        val = r @ r + Dk @ np.kron(np.eye(self.N - self.d), self.W) @ Dk
        return float(val + k @ self.Hp @ k - 2 * self.bp @ k + self._prior_const())

    def _prior_const(self) -> float:
        c = 0.0
        N, K, n = self.N, self.K, self.n
        s_y, s_k = self._noise_scales(self.sigma2)
        for mean, cov in self.param_priors:
            mu = as_means(mean, N, K).ravel()
            c += mu @ (s_k * (block_diag_stack(np.linalg.inv(as_blocks(cov, N, K))) @ mu))
        for mean, cov in self.output_priors:
            yb = as_means(mean, N, n).ravel()
            c += yb @ (s_y * (block_diag_stack(np.linalg.inv(as_blocks(cov, N, n))) @ yb))
        return c

    # -- likelihoods -----------------------------------------------------------------
    def loglik_with_prior(self) -> float:
        """log N(y; Φ̃ m, S + Φ̃ H_μ⁻¹ Φ̃ᵀ) with H_μ = (D̃ᵀW̃D̃ + σ² priors)/σ² (per row σ_i²)."""
        from scipy.stats import multivariate_normal

        s_y, s_k = self._noise_scales(self.sigma2)
        PhiT = self.Phi @ self.T
        H_mu = self.T.T @ ((self.Q + self.Hp) / s_k[:, None]) @ self.T
        m = np.linalg.solve(H_mu, self.T.T @ (self.bp / s_k))
        C = np.diag(s_y) + PhiT @ np.linalg.solve(H_mu, PhiT.T)
        return float(multivariate_normal(PhiT @ m, C).logpdf(self.y))

    def diffuse_mask(self) -> np.ndarray:
        """Free unknowns that get the κ prior: the first d time steps of every
        varying coefficient, every time step of a coefficient with weight 0, and
        the single unknown of a constant coefficient (diagonal W assumed for the
        weight-0 case)."""
        N, K, d = self.N, self.K, self.d
        mask = []
        diag = np.diag(self.W)
        for j in range(K):
            if self.const[j]:
                mask.append(True)
            else:
                free = diag[j] == 0 and not np.any(self.W[j])
                mask.extend([free or t < d for t in range(N)])
        return np.array(mask)

    def ml_noise_var(self) -> np.ndarray:
        """σ̂² maximizing :meth:`loglik_kappa` (κ = ∞) given λ, per output (n,).

        In the diffuse likelihood σ² scales the noise and the drift alike, so
        with J_i = RSS_i + penalty_i of output row i at the estimate it is
        −½ (N − z_i) log σ_i² − ½ J_i / σ_i² + const, z_i the diffuse unknowns
        of the row: σ̂_i² = J_i / (N − z_i). When W couples the rows one σ² is
        shared: σ̂² = Σ_i J_i / (N n − z). (No priors.)
        """
        assert not self.param_priors and not self.output_priors
        N, n, K = self.N, self.n, self.K
        p = K // n
        k, _ = self.solve()
        r = (self.y - self.Phi @ k.ravel()).reshape(N, n)
        Dk = (self.Dt @ k.ravel()).reshape(-1, K)
        penalty = np.einsum("tj,jl,tl->j", Dk, self.W, Dk)  # per coefficient (W's rows)
        J = (r**2).sum(axis=0) + penalty.reshape(n, p).sum(axis=1)
        diffuse_per_unknown = self.diffuse_mask()
        # free unknowns in order: coefficient j's unknowns (1 if constant, else N)
        owner = np.concatenate([[j] if self.const[j] else [j] * N for j in range(K)])
        z = np.bincount(owner[diffuse_per_unknown] // p, minlength=n)
        blocks = self.W.reshape(n, p, n, p).transpose(0, 2, 1, 3)  # (row, row, p, p)
        if np.any(blocks[~np.eye(n, dtype=bool)]):  # W couples the rows: one σ²
            return np.full(n, J.sum() / (N * n - z.sum()))
        return J / (N - z)

    def _penalized_set(self) -> tuple[np.ndarray, np.ndarray]:
        """Penalized (varying, nonzero weight) and free (varying, zero weight) coefficients."""
        W = self.W
        free = ~self.const & ~np.any(W != 0, axis=1)
        pen = ~self.const & ~free
        return pen, free

    def logdet_prior_precision(self, kappa: float, noise_var: float) -> float:
        """log det Q_κ + z·log κ, Q_κ = TᵀD̃ᵀW̃D̃T/σ² + diag(mask)/κ, in closed form.

        Per penalized coefficient block the map k ↦ (k_0 … k_{d−1}, Dk) is lower
        triangular with diagonal (1, …, 1, c_d, …, c_d), so
        Q_κ = Mᵀ diag(I/κ, I ⊗ W_P/σ²) M and
        log det Q_κ = −z log κ + 2(N−d)|P| log|c_d| + (N−d) log det(W_P/σ²);
        free and constant unknowns contribute −log κ each. Independent of κ after
        adding z·log κ, which is what makes the κ → ∞ limit exact.
        """
        pen, _ = self._penalized_set()
        scale = np.sqrt(self._noise_scales(noise_var)[1][: self.K][pen])
        W_P = self.W[np.ix_(pen, pen)] / scale[:, None] / scale[None, :]
        sign, ld_W = np.linalg.slogdet(W_P) if pen.any() else (1.0, 0.0)
        assert sign > 0, "the reference needs W positive definite on the penalized set"
        N, d = self.N, self.d
        return float(2 * (N - d) * pen.sum() * np.log(abs(self.coeffs[-1])) + (N - d) * ld_W)

    def loglik_kappa(self, kappa: float, noise_var) -> float:
        """log p(y) for the proper prior: the penalty as a Gaussian random walk with
        drift precision W/σ² and the diffuse unknowns ~ N(0, κ), plus the flat-prior
        normalization (z/2)·log(2πκ), z = number of diffuse unknowns. ``kappa=np.inf``
        gives the exact limit (the diffuse likelihood).

        ``noise_var`` is σ², or one σ_i² per output (n,): output i then has noise
        σ_i² and its row of the coefficients drift precision W_ii/σ_i² (W must
        not couple the rows).

        Computed in information form (no κ-sized covariances):
        log N(y; 0, S + Φ Q⁻¹ Φᵀ) = −½[log det 2πS + log det(Q + ΦᵀS⁻¹Φ) − log det Q
                                      + yᵀS⁻¹y − bᵀ(Q + ΦᵀS⁻¹Φ)⁻¹ b],  b = ΦᵀS⁻¹y,
        with log det Q from :meth:`logdet_prior_precision`.
        """
        s_y, s_k = self._noise_scales(noise_var)
        mask = self.diffuse_mask()
        PhiT = self.Phi @ self.T
        inv_kappa = 0.0 if np.isinf(kappa) else 1.0 / kappa
        Q_s = self.Q / np.sqrt(s_k)[:, None] / np.sqrt(s_k)[None, :]
        Hr = self.T.T @ Q_s @ self.T + np.diag(mask * inv_kappa) + PhiT.T @ (PhiT / s_y[:, None])
        b = PhiT.T @ (self.y / s_y)
        sign, ld_H = np.linalg.slogdet(Hr)
        assert sign > 0
        z = int(mask.sum())
        ld_Q_plus = self.logdet_prior_precision(kappa, noise_var)  # log det Q_κ + z log κ
        return float(
            -0.5
            * (
                np.sum(np.log(2 * np.pi * s_y))
                + ld_H
                + self.y @ (self.y / s_y)
                - b @ np.linalg.solve(Hr, b)
            )
            + 0.5 * ld_Q_plus
            + 0.5 * z * np.log(2 * np.pi)
        )

    def _noise_scales(self, noise_var):
        """Per entry of y (t-major) and per entry of k (t-major): the noise variance."""
        var = np.broadcast_to(np.asarray(noise_var, dtype=float), (self.n,))
        return np.tile(var, self.N), np.tile(np.repeat(var, self.p), self.N)

    def loglik_kappa_covariance_form(self, kappa: float, noise_var: float) -> float:
        """The same proper-prior likelihood via scipy's multivariate normal (for
        moderate κ only: it forms the κ-sized covariance)."""
        from scipy.stats import multivariate_normal

        s2 = noise_var
        mask = self.diffuse_mask()
        PhiT = self.Phi @ self.T
        Qr = self.T.T @ self.Q @ self.T / s2 + np.diag(mask / kappa)
        C = s2 * np.eye(self.y.size) + PhiT @ np.linalg.solve(Qr, PhiT.T)
        z = int(mask.sum())
        return float(
            multivariate_normal(np.zeros(self.y.size), C).logpdf(self.y)
            + 0.5 * z * np.log(2 * np.pi * kappa)
        )


def cvxpy_state_space(cp, x, u, order):
    """For a cvxpy objective of a state-space fit: the coefficient variable k (N, K),
    the one-step prediction of x[1:] (N, n) in k, the data y = x[1:] and D @ k."""
    phi = np.hstack([x[:-1], u[:-1]])
    y = x[1:]
    N, p = phi.shape
    n = y.shape[1]
    k = cp.Variable((N, n * p))
    rows = [cp.sum(cp.multiply(k[:, i * p : (i + 1) * p], phi), axis=1) for i in range(n)]
    prediction = cp.hstack([cp.reshape(row, (N, 1), order="C") for row in rows])
    return k, prediction, y, difference_matrix(N, coefficients(order)) @ k


def relerr(a, b) -> float:
    """max |a − b| / max |b|."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def random_spd(rng, d: int, scale: float = 1.0, jitter: float = 0.1) -> np.ndarray:
    G = rng.standard_normal((d, d))
    return scale * (G @ G.T / d + jitter * np.eye(d))


def row_scale(noise_var, n: int, p: int) -> np.ndarray:
    """Row scaling of a covariance: σ_i² for the p parameters of output row i, a (K, 1) column.

    Covariances are σ_i² times the rows' blocks of H⁻¹ (one noise variance per
    output); multiplying H⁻¹ (unit noise) entrywise by this column gives them
    where H⁻¹ does not couple the rows. Pass the σ² given to the fit, or the
    reference's own estimate :meth:`DenseProblem.ml_noise_var` — never the
    model's ``noise_var``, which would make a wrong estimate invisible.
    """
    return np.repeat(np.broadcast_to(np.asarray(noise_var, dtype=float), (n,)), p)[:, None]


def cov_scale(model) -> np.ndarray:
    """:func:`row_scale` of a model's own ``noise_var`` (only where the test gave it)."""
    return row_scale(model.noise_var, len(model.noise_var), model.n_regressors)


# -- sparse norms: objective and a dual lower bound --------------------------------------


def sparse_regression(y, phi, row_weights=None):
    """Φ̃ (M × N K) and Ỹ (M,) of Σ_r Σ_t w_rt ‖y_rt − Θ_t φ_rt‖², observed rows only.

    y (R, N, n) or (N, n), phi (R, N, p) or (N, p), NaN = missing (a row enters
    only if y_rt and φ_rt are finite and w_rt > 0); row_weights (R, N) or None.
    Each observed (r, t) contributes n rows √w_rt (I_n ⊗ φ_rtᵀ) in the columns of
    step t, so that Φ̃ k stacks the fitted outputs for k_t = Θ_t.ravel().
    """
    y = np.asarray(y, dtype=float)
    phi = np.asarray(phi, dtype=float)
    if y.ndim == 2:
        y, phi = y[None], phi[None]
    R, N, n = y.shape
    p = phi.shape[2]
    K = n * p
    w = np.ones((R, N)) if row_weights is None else np.asarray(row_weights, dtype=float)
    rows, targets = [], []
    for r in range(R):
        for t in range(N):
            if not (
                np.all(np.isfinite(y[r, t])) and np.all(np.isfinite(phi[r, t])) and w[r, t] > 0
            ):
                continue
            block = np.zeros((n, N * K))
            block[:, t * K : (t + 1) * K] = np.sqrt(w[r, t]) * np.kron(np.eye(n), phi[r, t])
            rows.append(block)
            targets.append(np.sqrt(w[r, t]) * y[r, t])
    return np.vstack(rows), np.concatenate(targets)


def state_space_regression(x, u=None, row_weights=None, constant=False):
    """:func:`sparse_regression` of x[t+1] = A_t x[t] + B_t u[t] (+ c_t).

    y = x[1:] and φ = [x, u, 1][:-1], per trajectory; arguments as in
    :func:`sparse_regression` (x (T, n) or (R, T, n), row_weights (R, T − 1)).
    """
    x = np.asarray(x, dtype=float)
    x = x[None] if x.ndim == 2 else x
    R, T, _ = x.shape
    u = np.zeros((R, T, 0)) if u is None else np.asarray(u, dtype=float).reshape(R, T, -1)
    cols = [x[:, :-1], u[:, :-1]] + ([np.ones((R, T - 1, 1))] if constant else [])
    return sparse_regression(x[:, 1:], np.concatenate(cols, axis=2), row_weights)


def sparse_penalty(k, weights, norm, coeffs) -> float:
    """Σ_t R(Λ (Dk)_t): R = ‖·‖₂ ("group") or ‖·‖₁ ("l1"), Λ = diag(weights).

    A weight inf holds its coefficient constant (a constraint, not a cost): it
    adds nothing here, and the caller checks that the coefficient is constant.
    """
    k = np.asarray(k, dtype=float)
    weights = np.asarray(weights, dtype=float)
    weights = np.where(np.isinf(weights), 0.0, weights)
    Z = difference_matrix(k.shape[0], coefficients(coeffs)) @ k * weights
    return float(np.linalg.norm(Z, axis=1).sum() if norm == "group" else np.abs(Z).sum())


def sparse_objective(Phi, Y, k, weights, norm, coeffs) -> float:
    """‖Ỹ − Φ̃k‖² + Σ_t R(Λ (Dk)_t), k of shape (N, K) (see :func:`sparse_penalty` for inf)."""
    r = Y - Phi @ np.asarray(k, dtype=float).ravel()
    return float(r @ r) + sparse_penalty(k, weights, norm, coeffs)


def sparse_lower_bound(Phi, Y, k, weights, norm, coeffs) -> float:
    """A lower bound on min_k ‖Ỹ − Φ̃k‖² + Σ_t R(Λ(Dk)_t) from a dual certificate built at k.

    The Lagrange dual (e = Ỹ − Φ̃k with multiplier u; ν for the penalty) is

        max_{u, ν}  uᵀỸ − ‖u‖²/4   s.t.  Φ̃ᵀu + D̃ᵀν = 0,  ν_t in the dual ball,

    the dual ball being ‖ν_t / λ‖₂ <= 1 (group) or |ν_tj| <= λ_j (l1) over the
    penalized coefficients, with ν_tj = 0 for a weight λ_j = 0. A weight inf
    (coefficient constant in time, a constraint) only needs (Φ̃ᵀu)_j to be
    orthogonal to the constant sequence. At the optimum u = 2r (r the
    residual). From any k: refit by least squares the directions that keep k
    feasible and leave the penalty unchanged (null(D) per penalized
    coefficient, every time step of a zero-weight one, the constant of a
    constant one), so that g = −2Φ̃ᵀr is orthogonal to them; solve D̃ᵀν = g;
    scale (u, ν) into the dual ball. Any dual-feasible point bounds the optimum
    from below (weak duality) and the bound is tight at the optimum, so
    objective(k) − bound bounds the suboptimality of k.
    """
    k = np.asarray(k, dtype=float)
    N, K = k.shape
    weights = np.broadcast_to(np.asarray(weights, dtype=float), (K,))
    coeffs = coefficients(coeffs)
    D = difference_matrix(N, coeffs)
    free, const = weights == 0, np.isinf(weights)
    pen = ~free & ~const
    null = np.linalg.svd(D)[2][D.shape[0] :].T  # (N, d): orthonormal basis of null(D)
    blocks = []
    for j in range(K):
        basis = np.eye(N) if free[j] else (np.ones((N, 1)) if const[j] else null)
        cols = np.zeros((N * K, basis.shape[1]))
        cols[np.arange(N) * K + j] = basis
        blocks.append(cols)
    E = np.hstack(blocks)
    c, *_ = np.linalg.lstsq(Phi @ E, Y - Phi @ k.ravel(), rcond=None)
    r = Y - Phi @ (k.ravel() + E @ c)
    g = (-2.0 * Phi.T @ r).reshape(N, K)
    nu, *_ = np.linalg.lstsq(D.T, g[:, pen], rcond=None)  # D̃ᵀν = g, one column per coefficient
    violation = np.abs(D.T @ nu - g[:, pen]).max(initial=0.0)
    assert violation <= 1e-9 * max(np.abs(g).max(), 1e-300), "g not in range(Dᵀ)"
    scaled = nu / weights[pen]
    size = np.linalg.norm(scaled, axis=1).max() if norm == "group" else np.abs(scaled).max()
    s = max(1.0, float(size))
    u = 2.0 * r / s
    return float(u @ Y - u @ u / 4.0)


# -- choosing λ (norm="sq"): the criteria and their optimum -------------------------------


def lam_criterion(x, u, order, lam: float, method: str) -> float:
    """The criterion select_lambda minimizes, from the dense problem at a scalar λ.

    "ml": minus the diffuse log marginal likelihood at the ML noise variances
    (:meth:`DenseProblem.ml_noise_var`, one per output). "gcv": M·RSS / (M − dof)²
    with M = N·n observations and dof = tr(Φ̃ H⁻¹ Φ̃ᵀ), the trace of the hat matrix.
    """
    ref = DenseProblem(x, u, order, lam)
    if method == "ml":
        return -ref.loglik_kappa(np.inf, ref.ml_noise_var())
    k, H_inv = ref.solve()
    r = ref.y - ref.Phi @ k.ravel()
    dof = float(np.einsum("ij,jk,ik->", ref.Phi, H_inv, ref.Phi))
    M = ref.y.size
    return M * float(r @ r) / (M - dof) ** 2


def best_lam(x, u, order, method: str, lo: float = 1e-2, hi: float = 1e5) -> float:
    """argmin over λ of :func:`lam_criterion`: a coarse log grid on [lo, hi] (15 points,
    half a decade apart), then Brent's bounded search on log λ between the
    neighbours of the best point, to 1e-7 in log λ. Fails if the best grid
    point is at an end (no interior optimum to compare with)."""
    from scipy.optimize import minimize_scalar

    grid = np.logspace(np.log10(lo), np.log10(hi), 15)
    values = [lam_criterion(x, u, order, lam, method) for lam in grid]
    best = int(np.argmin(values))
    assert 0 < best < len(grid) - 1, f"{method}: the optimum is not inside [{lo}, {hi}]"
    res = minimize_scalar(
        lambda v: lam_criterion(x, u, order, float(np.exp(v)), method),
        bounds=(np.log(grid[best - 1]), np.log(grid[best + 1])),
        method="bounded",
        options={"xatol": 1e-7},
    )
    assert res.fun <= values[best]
    return float(np.exp(res.x))
