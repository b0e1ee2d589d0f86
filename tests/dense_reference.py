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
            -0.5 * (np.sum(np.log(2 * np.pi * s_y)) + ld_H + self.y @ (self.y / s_y)
                    - b @ np.linalg.solve(Hr, b))
            + 0.5 * ld_Q_plus + 0.5 * z * np.log(2 * np.pi)
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


def relerr(a, b) -> float:
    """max |a − b| / max |b|."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def random_spd(rng, d: int, scale: float = 1.0, jitter: float = 0.1) -> np.ndarray:
    G = rng.standard_normal((d, d))
    return scale * (G @ G.T / d + jitter * np.eye(d))


def cov_scale(model) -> np.ndarray:
    """Row scaling of a model's covariance: σ_i² for the parameters of output row i.

    A fitted model's covariance is σ_i² times the rows' blocks of H⁻¹ (one
    noise variance per output); multiplying H⁻¹ (unit noise) entrywise by this
    (K, 1) column gives it where H⁻¹ does not couple the rows.
    """
    return np.repeat(np.asarray(model.noise_var), model.n_regressors)[:, None]
