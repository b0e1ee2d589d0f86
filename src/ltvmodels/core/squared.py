"""norm="sq": the exact minimizer of the squared-difference problem, with priors.

Objective (the paper's slowly varying, smooth, general Kalman-model and prior problems), with σ² the
noise variance:

    J(k) = Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t (Dk)_tᵀ W (Dk)_t
           + σ² Σ_t ‖μ_t − k_t‖²_{Σ_t⁻¹}  + σ² Σ_t ‖ȳ_t − Θ_t φ_t‖²_{S_t⁻¹}

W = λ² I for a scalar λ (stored as its diagonal, a (K,) vector, for a scalar
or vector λ: no K × K array is formed unless the user passed a matrix). It is
the negative log posterior (times σ²) of the Gaussian random walk
k_{t+1} = k_t + w_t (the paper's random-walk parameter model; for higher orders the polynomial model
of Proposition 1) with measurement noise R2 = σ² I and parameter drift
R1 = σ²/λ² I.

The data term sums over the rows of each time step (trajectories, each row
scaled by √weight; missing rows are zero, see
:class:`~ltvmodels.core.problem.RegressionProblem`), so only the Gram blocks
Σ_j φ_tj φ_tjᵀ enter H, and N below counts observed rows.

When the penalty weight and the priors do not mix output rows, every row of
Θ is a separate problem with the same regressor; rows whose systems coincide
(the usual case: scalar λ) share one banded factorization. Then each row i
has its own noise variance σ_i² (measurement noise σ_i², drift σ_i²/λ² and
prior terms weighted by σ_i²): the estimate without priors does not depend on
it, and the likelihood below is the sum of the rows' likelihoods, each with
its σ_i² (profiled out per row when estimated). Otherwise one σ² is shared.

Log marginal likelihood (``loglik``). Without priors the penalty is an improper
Gaussian prior on the trajectory whose unpenalized directions (the initial
state of the random walk) get a flat prior, i.e. diffuse initialization:

    log p(y) = −½ N_eff log(2πσ²) + ½ log Z − ½ log det H − ½ J(k̂)/σ²,

with H = ΦᵀΦ + DᵀD ⊗ W, N_eff = N·n − #unpenalized directions and Z the
normalizer of the penalty (see SquaredSolver.log_penalty_normalizer). This is
the limit of a proper prior k_0 ~ N(0, κI) as κ → ∞ without its κ terms. With priors
it is the proper log p(y | prior) = log N(y; Φ m, σ² I + Φ H_μ⁻¹ Φᵀ), where
H_μ (= H without the data) and m = argmin of J without the data come from a
second banded factorization:

    log p(y | prior) = −½ N n log(2πσ²) − ½ log det H + ½ log det H_μ
                       − ½ (J(k̂) − J_μ(m)) / σ².

Its maximum in σ² (``noise_var=None``) is found from its derivative, which the
same two factorizations give with the diagonal blocks of H⁻¹ and H_μ⁻¹ (see
:func:`_evidence_with_slope`): H = A + σ²P with P the priors' Gram, so
d log det H / dσ² = tr(H⁻¹P) = Σ_t tr((H⁻¹)_tt P_t), and the two minima J(k̂),
J_μ(m) change by their prior costs (envelope theorem). A safeguarded secant
search on the derivative then needs 3–7 σ² where a search on the value alone
needed 25–30, each with a refactorization of both systems.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import PrecisionWarning, SingularProblemError, warn
from .banded import BlockSolution, BlockSystem, solve_block_banded, solve_shared_rows
from .blockkernels import rowwise_matvec
from .covariance import CovarianceBlocks
from .priorterms import PriorTerm
from .problem import RegressionProblem, apply_difference

__all__ = ["SquaredResult", "weight_diagonal", "shared_row_weight", "SquaredSolver", "fit_squared"]

LOG_2PI = float(np.log(2.0 * np.pi))
EPS = float(np.finfo(float).eps)
# Warn when the penalty dominates the data by more than 1e10: results keep fewer
# than about 6 correct digits.
PRECISION_DIGITS_WARN = 10.0
# The noise variance with priors is searched within this distance in log σ² of its
# prior-free estimate, to steps in log σ² below NOISE_VAR_XTOL (a relative change of σ²
# of 1e-6, which moves the coefficients by about as much relative to the prior's pull),
# with at most this many evaluations (each two factorizations).
NOISE_VAR_RANGE = float(np.log(1e3))
NOISE_VAR_XTOL = 1e-6
NOISE_VAR_MAX_EVALUATIONS = 100


@dataclass
class SquaredResult:
    """Everything the squared-norm solver computes."""

    theta: np.ndarray  # (N, n, p)
    cov: CovarianceBlocks | None  # posterior covariance (σ² included)
    noise_var: np.ndarray  # (n,)
    noise_var_estimated: bool
    loglik: float | None  # None: not defined (see info["loglik_note"])
    objective: float
    rss: float
    penalty: float
    prior_cost: float
    n_eff: float
    n_factorizations: int
    info: dict = field(default_factory=dict)


def _is_row_separable(matrix: np.ndarray, n: int, p: int) -> bool:
    """True if a (…, n·p, n·p) matrix has no entries coupling different rows of Θ."""
    blocks = matrix.reshape(matrix.shape[:-2] + (n, p, n, p))
    blocks = np.moveaxis(blocks, -3, -2)  # (…, row i, row j, p, p)
    return not np.any(blocks[..., ~np.eye(n, dtype=bool), :, :])


def weight_diagonal(W: np.ndarray) -> np.ndarray:
    """The diagonal of a penalty weight given as a (K,) diagonal or a (K, K) matrix."""
    return W if W.ndim == 1 else np.diag(W)


def _finite(W: np.ndarray) -> np.ndarray:
    """W with the rows/columns of constant coefficients (inf) set to zero."""
    const = np.isinf(weight_diagonal(W))
    W0 = W.copy()
    if W.ndim == 1:
        W0[const] = 0.0
        return W0
    W0[const, :] = 0.0
    W0[:, const] = 0.0
    return W0


def _block(W: np.ndarray, rows: slice) -> np.ndarray:
    """The square block of W (diagonal (K,) or matrix (K, K)) on ``rows``, as a matrix."""
    return np.diag(W[rows]) if W.ndim == 1 else W[rows, rows]


def shared_row_weight(W: np.ndarray, n: int, p: int) -> np.ndarray | None:
    """The (p,) diagonal weight every output row shares (a scalar λ), or None.

    None for a matrix weight, rows with different weights, or constant (inf)
    coefficients: those take the general path of :class:`SquaredSolver`.
    """
    if W.ndim != 1:
        return None
    row = W[:p]
    if W[0] == W[-1] and (W == W[0]).all():  # a scalar λ: one comparison pass
        return row if np.isfinite(W[0]) else None
    if not np.isfinite(row).all() or (n > 1 and not (W.reshape(n, p) == row).all()):
        return None
    return row


def _row_penalty_diagonal(
    theta: np.ndarray, coeffs: np.ndarray, weights: np.ndarray, n: int, p: int
) -> np.ndarray:
    """Σ_j w_j ‖(Dk)_j‖² per output row, shape (n,), for a diagonal weight (K,)."""
    Dk = apply_difference(theta.reshape(theta.shape[0], -1), coeffs)
    return (np.einsum("tk,tk->k", Dk, Dk) * weights).reshape(n, p).sum(axis=1)


def _shared_normalizer(problem: RegressionProblem, row: np.ndarray) -> tuple[float, float, float]:
    """:meth:`SquaredSolver.log_penalty_normalizer` (per row) for a diagonal weight ``row``
    (p,) shared by every row, all finite, and the penalty's scale for :func:`_digits_lost`.

    Returns (log normalizer, diffuse directions, λ²_max (Σ_j |c_j|)²), the first
    two the same for every output row.
    """
    N, p, d = problem.N, problem.p, problem.degree
    weights = row.tolist()  # p numbers: Python's arithmetic beats numpy's call overhead
    coeffs = problem.coeffs.tolist()
    largest = max(weights)
    tol = 10 * p * EPS * max(largest, 1e-300)
    positive = [w for w in weights if w > tol]
    rank = len(positive)
    log_dd = 2.0 * (N - d) * math.log(abs(coeffs[-1]))
    log_pdet = rank * log_dd + (N - d) * sum(math.log(w) for w in positive)
    diffuse = float(N * p - (N - d) * rank)
    penalty = largest * sum(abs(c) for c in coeffs) ** 2
    return log_pdet, diffuse, penalty


def _digits_lost(penalty: float, gram_trace: float, problem: RegressionProblem) -> float:
    """:meth:`SquaredSolver.digits_lost` for a shared diagonal weight: the penalty's
    scale against the mean Gram diagonal Σ_t Σ_j ‖φ_tj‖² / (N p) (``gram_trace``)."""
    data = gram_trace / (problem.N * problem.p)
    return 0.0 if penalty == 0.0 or data == 0.0 else max(0.0, math.log10(penalty / data))


@dataclass
class _Group:
    """Output rows (None: all, coupled form) solved with one block system."""

    rows: np.ndarray | None
    system: BlockSystem
    rhs: np.ndarray  # (N, b, r)


class SquaredSolver:
    """Assemble and solve the normal equations of one regression problem.

    Parameters
    ----------
    problem : RegressionProblem
    W : ndarray, shape (K,) or (K, K)
        Penalty weight: its diagonal (scalar or vector λ) or the full matrix;
        inf on the diagonal holds a coefficient constant.
    priors : list of PriorTerm
    """

    def __init__(self, problem: RegressionProblem, W: np.ndarray, priors: list[PriorTerm]):
        self.problem = problem
        self.W = W
        self.priors = priors
        n, p = problem.n, problem.p
        # W without the constant coefficients' infinities, and whether it is
        # diagonal (scalar or vector λ), once: for a matrix both are K × K passes.
        self.W0 = _finite(W)
        self.W0_diagonal = weight_diagonal(self.W0).copy()
        self.diagonal = W.ndim == 1 or (
            np.count_nonzero(self.W0) == np.count_nonzero(self.W0_diagonal)
        )
        separable = self.diagonal or _is_row_separable(self.W0, n, p)
        for term in priors:
            if term.on == "parameters":
                separable &= _is_row_separable(term.precision, n, p)
            else:
                separable &= not np.any(term.precision * ~np.eye(n, dtype=bool))
        self.separable = separable

    # -- assembly -----------------------------------------------------------------
    def _prior_parts(self, scale: float | np.ndarray):
        """Prior contributions in k-space: Gram (1 | N, K, K) and rhs (N, K), or Nones.

        ``scale`` is σ², or σ_i² per output row (n,) when the rows decouple: row
        i's prior terms are weighted by its own noise variance.
        """
        pb = self.problem
        N, n, p = pb.N, pb.n, pb.p
        K = n * p
        if not self.priors:
            return None, None
        time_varying = any(t.precision.ndim == 3 or t.on == "output" for t in self.priors)
        gram = np.zeros((N if time_varying else 1, K, K))
        rhs = np.zeros((N, K))
        for term in self.priors:
            if term.on == "parameters":
                gram += term.precision
                rhs += np.einsum("tij,tj->ti", term.precision_at(N), term.mean)
            else:
                # M_t = I_n ⊗ φ_tᵀ:  M_tᵀ P M_t = P ⊗ φφᵀ,  M_tᵀ P ȳ = (P ȳ) ⊗ φ.
                P = term.precision_at(N)
                phi = pb.phi[:, 0]  # output priors need one complete trajectory
                gram += np.einsum("tij,ta,tb->tiajb", P, phi, phi).reshape(N, K, K)
                rhs += np.einsum("tij,tj,ta->tia", P, term.mean, phi).reshape(N, K)
        if np.ndim(scale):  # per row: the Gram is block diagonal by rows, scale its rows
            row_scale = np.repeat(scale, p)
            return gram * row_scale[:, None], rhs * row_scale
        return scale * gram, scale * rhs

    def _groups(self, prior_scale: float | np.ndarray, include_data: bool) -> list[_Group]:
        pb = self.problem
        N, n, p = pb.N, pb.n, pb.p
        K = n * p
        data_scale = 1.0 if include_data else 0.0
        prior_gram, prior_rhs = self._prior_parts(prior_scale)
        data_rhs = pb.cross()  # (N, p, n)
        if not include_data:
            data_rhs[:] = 0.0
        if not self.separable:
            rhs = np.swapaxes(data_rhs, 1, 2).reshape(N, K)
            if prior_rhs is not None:
                rhs = rhs + prior_rhs
            extra = np.zeros((0, K, K)) if prior_gram is None else prior_gram
            W = np.diag(self.W) if self.W.ndim == 1 else self.W  # b = K: H's blocks are K × K
            system = BlockSystem(pb.phi, n, data_scale, extra, W, pb.coeffs)
            return [_Group(None, system, rhs[:, :, None])]
        # Rows with the same weight and prior blocks share one factorization.
        row_sets: list[list[int]] = []
        keys: list[tuple[np.ndarray, np.ndarray]] = []
        if prior_gram is None and self.W.ndim == 1 and np.all(self.W.reshape(n, p) == self.W[:p]):
            row_sets, keys = [list(range(n))], [(np.diag(self.W[:p]), np.zeros((0, p, p)))]
        for i in range(n if not row_sets else 0):
            sl = slice(i * p, (i + 1) * p)
            extra = np.zeros((0, p, p)) if prior_gram is None else prior_gram[:, sl, sl]
            key = (_block(self.W, sl), extra)
            for rows, (W_g, extra_g) in zip(row_sets, keys, strict=True):
                if np.array_equal(W_g, key[0]) and np.array_equal(extra_g, key[1]):
                    rows.append(i)
                    break
            else:
                row_sets.append([i])
                keys.append(key)
        groups = []
        for rows, (W_g, extra_g) in zip(row_sets, keys, strict=True):
            rhs = data_rhs if len(rows) == n else data_rhs[:, :, rows]
            if prior_rhs is not None:
                rhs = rhs + prior_rhs.reshape(N, n, p)[:, rows, :].transpose(0, 2, 1)
            system = BlockSystem(pb.phi, 1, data_scale, extra_g, W_g, pb.coeffs)
            groups.append(_Group(np.array(rows), system, rhs))
        return groups

    # -- solving ------------------------------------------------------------------
    def solve(
        self,
        prior_scale: float | np.ndarray,
        *,
        include_data: bool = True,
        compute_cov: bool = False,
    ):
        """Minimize J with the prior terms weighted by ``prior_scale`` (σ², or σ_i² per row).

        Returns (theta (N, n, p), CovarianceBlocks | None, logdet H, #factorizations,
        row_logdet): ``row_logdet`` (n,) splits log det H by output row when the rows
        decouple, else it is None.
        """
        pb = self.problem
        N, n, p = pb.N, pb.n, pb.p
        what = "the normal equations" if include_data else "the prior alone"
        groups = self._groups(prior_scale, include_data)
        theta = np.empty((N, n, p))
        logdet = 0.0
        row_logdet = np.zeros(n)
        covs: list[np.ndarray] = []
        row_group = np.zeros(n, dtype=int)
        for g, group in enumerate(groups):
            sol: BlockSolution = solve_block_banded(
                group.system, group.rhs, compute_cov=compute_cov, what=what
            )
            if group.rows is None:
                theta[:] = sol.theta[:, :, 0].reshape(N, n, p)
                logdet += sol.logdet
            else:
                theta[:, group.rows, :] = np.swapaxes(sol.theta, 1, 2)
                logdet += sol.logdet * len(group.rows)
                row_logdet[group.rows] = sol.logdet
                row_group[group.rows] = g
            if sol.cov is not None:  # computed with compute_cov
                covs.append(sol.cov)
        cov = None
        if compute_cov:
            if groups[0].rows is None:
                cov = CovarianceBlocks(covs[0], None)
            else:
                blocks = covs[0][None] if len(covs) == 1 else np.stack(covs)
                cov = CovarianceBlocks(blocks, row_group)
        separable = groups[0].rows is not None
        return theta, cov, logdet, len(groups), row_logdet if separable else None

    def digits_lost(self) -> float:
        """Estimated decimal digits the normal equations lose to a large penalty.

        The penalty block of H has eigenvalues up to ‖W‖·(Σ_j |c_j|)² while the
        data contribute about mean ‖φ_t‖²/p per coefficient; the unpenalized
        directions are determined by the data alone, so Cholesky resolves them
        with relative accuracy about eps times that ratio.
        """
        if self.diagonal:  # scalar or vector λ: no eigvalsh of a K × K matrix
            largest = float(np.abs(self.W0_diagonal).max(initial=0.0))
        else:
            largest = float(np.abs(np.linalg.eigvalsh(self.W0)).max(initial=0.0))
        penalty = largest * np.abs(self.problem.coeffs).sum() ** 2
        data = float(np.mean(np.sum(self.problem.phi**2, axis=1)))  # mean Gram diagonal
        if penalty == 0.0 or data == 0.0:
            return 0.0
        return max(0.0, float(np.log10(penalty / data)))

    # -- objective pieces -----------------------------------------------------------
    def penalty(self, theta: np.ndarray) -> float:
        N = self.problem.N
        Dk = apply_difference(theta.reshape(N, -1), self.problem.coeffs)
        if self.diagonal:  # Σ_j w_j ‖(Dk)_j‖²
            return float(np.einsum("tk,tk->k", Dk, Dk) @ self.W0_diagonal)
        return float(np.sum((Dk @ self.W0) * Dk))

    def row_penalty(self, theta: np.ndarray) -> np.ndarray:
        """The penalty of each output row, shape (n,) (rows decoupled)."""
        pb = self.problem
        n, p = pb.n, pb.p
        if self.diagonal:  # Σ_j w_j ‖(Dk)_j‖² per row
            return _row_penalty_diagonal(theta, pb.coeffs, self.W0_diagonal, n, p)
        blocks = self.W0.reshape(n, p, n, p)[np.arange(n), :, np.arange(n), :]  # (n, p, p)
        Dk = apply_difference(theta.reshape(pb.N, -1), pb.coeffs).reshape(-1, n, p)
        return np.einsum("tia,iab,tib->i", Dk, blocks, Dk)

    def prior_cost(self, theta: np.ndarray) -> float:
        """Σ_t ‖μ_t − M_t k_t‖²_{P_t} over all prior terms (not scaled by σ²)."""
        return float(self.row_prior_cost(theta).sum())

    def row_prior_cost(self, theta: np.ndarray) -> np.ndarray:
        """:meth:`prior_cost` split by output row, shape (n,) (exact when the rows decouple)."""
        pb = self.problem
        N, n = pb.N, pb.n
        total = np.zeros(n)
        for term in self.priors:
            if term.on == "parameters":
                r = term.mean - theta.reshape(N, -1)
            else:
                fitted = np.empty((N, 1, n))
                rowwise_matvec(np.ascontiguousarray(theta), pb.phi[:, :1], fitted)
                r = term.mean - fitted[:, 0]
            per_entry = np.einsum("ti,tij,tj->i", r, term.precision_at(N), r)
            total += per_entry.reshape(n, -1).sum(axis=1)
        return total

    def log_penalty_normalizer(self) -> tuple[np.ndarray, np.ndarray]:
        """Log normalizer of the penalty as a prior, and the number of diffuse directions.

        The penalty is the improper Gaussian prior of the random walk
        Σ_j c_j k_{t+j} = w_t, w_t ~ N(0, W⁻¹), whose initial state k_0 … k_{d-1}
        gets a flat prior (the diffuse Kalman filter's convention: the limit of
        k_0 ~ N(0, κI) as κ → ∞ less its κ terms). The map from (initial state,
        w) to the trajectory is triangular with determinant c_d^-(N-d) per
        coefficient, so the normalizer is
        log Z = rank(W)·2(N − d)·log|c_d| + (N − d)·log pdet(W).
        Unpenalized directions (per row: d·|varying| + |constant| + the null
        space of W) are diffuse.

        Returns both per output row, shape (n,), when the rows decouple, else
        shape (1,).
        """
        pb = self.problem
        N, n, p = pb.N, pb.n, pb.p
        d = pb.degree
        log_dd = 2.0 * (N - d) * float(np.log(abs(pb.coeffs[-1])))
        if self.W.ndim == 1:  # diagonal weights (scalar or vector λ): all rows at once
            weights = self.W.reshape(n, p) if self.separable else self.W[None, :]
            varying = ~np.isinf(weights)
            finite = np.where(varying, weights, 0.0)
            tol = (
                10
                * varying.sum(axis=1)
                * np.finfo(float).eps
                * np.maximum(finite.max(axis=1, initial=0.0), 1e-300)
            )
            positive = varying & (finite > tol[:, None])
            rank = positive.sum(axis=1)
            log_weights = np.log(np.where(positive, finite, 1.0)).sum(axis=1)
            log_pdet = rank * log_dd + (N - d) * log_weights
            diffuse = N * varying.sum(axis=1) + (~varying).sum(axis=1) - (N - d) * rank
            return log_pdet, diffuse.astype(float)
        blocks = (
            [_block(self.W, slice(i * p, (i + 1) * p)) for i in range(n)]
            if self.separable
            else [_block(self.W, slice(None))]
        )
        log_pdet = np.zeros(len(blocks))
        diffuse = np.zeros(len(blocks))
        for row, Wb in enumerate(blocks):
            varying = ~np.isinf(np.diag(Wb))
            Wv = Wb[np.ix_(varying, varying)]
            if not np.any(Wv - np.diag(np.diag(Wv))):
                eig = np.diag(Wv)  # exact for the usual diagonal weights
            else:
                eig = np.linalg.eigvalsh(Wv)
            tol = 10 * Wv.shape[0] * np.finfo(float).eps * max(eig.max(initial=0.0), 1e-300)
            pos = eig[eig > tol]
            rank = pos.size
            log_pdet[row] = rank * log_dd + (N - d) * float(np.sum(np.log(pos)))
            diffuse[row] = N * varying.sum() + (~varying).sum() - (N - d) * rank
        return log_pdet, diffuse


def _loglik_with_prior(
    solver: SquaredSolver, variances: np.ndarray, theta: np.ndarray, logdets: np.ndarray
) -> np.ndarray:
    """log p(y | prior) = log N(y; M m, S + M H_μ⁻¹ Mᵀ), from two factorizations.

    When the rows decouple, per output row i (noise σ_i² = ``variances[i]``,
    ``logdets`` the rows' log det H): an array (n,) whose sum is the
    likelihood. Otherwise one shared σ² (``logdets`` = [log det H]): an array
    (1,). NaN when the prior alone does not determine every parameter
    (H_μ singular).
    """
    pb = solver.problem
    rows = solver.separable
    scale = variances if rows else variances[:1]
    prior_scale = variances if rows else float(variances[0])
    try:
        m, _, logdet_mu, _, row_logdet_mu = solver.solve(prior_scale, include_data=False)
    except SingularProblemError:
        return np.full(scale.shape, np.nan)
    if rows:
        j_y = (
            pb.output_rss(theta) + solver.row_penalty(theta) + scale * solver.row_prior_cost(theta)
        )
        j_mu = solver.row_penalty(m) + scale * solver.row_prior_cost(m)
        logdet_mu = row_logdet_mu
        size = pb.n_observed
    else:
        j_y = pb.output_rss(theta).sum() + solver.penalty(theta) + scale * solver.prior_cost(theta)
        j_mu = solver.penalty(m) + scale * solver.prior_cost(m)
        size = pb.n_observed * pb.n
    return (
        -0.5 * size * (LOG_2PI + np.log(scale))
        - 0.5 * logdets
        + 0.5 * logdet_mu
        - 0.5 * (j_y - j_mu) / scale
    )


def _noise_var_guess(problem: RegressionProblem, W: np.ndarray, n_eff: float) -> float:
    """A starting value for σ²: the prior-free ML estimate, else the LTI residual variance."""
    try:
        theta, *_ = SquaredSolver(problem, W, []).solve(0.0)
        if n_eff > 0:
            return (
                float(problem.output_rss(theta).sum())
                + SquaredSolver(problem, W, []).penalty(theta)
            ) / n_eff
    except SingularProblemError:
        pass
    # Minimum-norm least squares works for rank-deficient regressors too.
    phi, y = problem.stacked_rows()
    coef, _, rank, _ = np.linalg.lstsq(phi, y, rcond=None)
    resid = y - phi @ coef
    dof = max(y.shape[0] - rank, 1) * problem.n
    return max(float(np.sum(resid**2)) / dof, 1e-300)


def _prior_gram_diagonal(solver: SquaredSolver) -> np.ndarray:
    """The unscaled prior Gram blocks as the solver's groups see them: (1 | N, K, K) for
    coupled rows, or (n, 1 | N, p, p), row i's diagonal block, when the rows decouple."""
    gram, _ = solver._prior_parts(1.0)
    if not solver.separable:
        return gram
    n, p = solver.problem.n, solver.problem.p
    rows = np.arange(n)
    return gram.reshape(gram.shape[0], n, p, n, p)[:, rows, :, rows, :]


def _trace_with(cov: CovarianceBlocks, gram: np.ndarray) -> np.ndarray:
    """Σ_t tr((H⁻¹)_tt G_t) for the prior Gram G (see :func:`_prior_gram_diagonal`): per
    output row (n,) when the rows decouple, else (1,)."""
    if cov.row_group is None:
        blocks = cov.blocks  # (N, K, K)
        if gram.shape[0] == 1:
            return np.array([np.einsum("tab,ba->", blocks, gram[0])])
        return np.array([np.einsum("tab,tba->", blocks, gram)])
    rows = cov.blocks[cov.row_group]  # (n, N, p, p), the group of each row
    if gram.shape[1] == 1:
        return np.einsum("itab,iba->i", rows, gram[:, 0])
    return np.einsum("itab,itba->i", rows, gram)


@dataclass
class _Evidence:
    """log p(y | prior, σ²) at one σ² (σ_i² per row), with what :func:`fit_squared` reuses.

    ``value``, ``slope`` (the derivative in log σ²) and ``fixed`` (the fixed-point
    update of σ²) are per output row (n,) when the rows decouple, else (1,); NaN
    where the prior alone does not determine the parameters (H_μ singular).
    ``theta``, ``cov`` (blocks of H⁻¹), ``logdet``, ``row_logdet`` and
    ``n_factorizations`` are :meth:`SquaredSolver.solve`'s at ``variances``.
    """

    variances: np.ndarray
    value: np.ndarray
    slope: np.ndarray
    fixed: np.ndarray
    theta: np.ndarray
    cov: CovarianceBlocks | None
    logdet: float
    row_logdet: np.ndarray | None
    n_factorizations: int


def _evidence_with_slope(
    solver: SquaredSolver, variances: np.ndarray, gram: np.ndarray
) -> _Evidence:
    """log p(y | prior, σ²) (:func:`_loglik_with_prior`) and its derivative in log σ².

    With the prior terms weighted by s = σ² (H = A + sP, H_μ = A_μ + sP, P the prior's
    Gram ``gram``, see :func:`_prior_gram_diagonal`) the derivative of
    log p(y | prior, s) of the module docstring follows from the envelope theorem for
    the two minima (their derivatives in s are the prior costs) and
    d log det H / ds = tr(H⁻¹P) (from the diagonal blocks of H⁻¹, by the selected
    inversion):

        2 s d/ds log p = (RSS + pen(k̂) − pen(m)) / s − N_y + γ,
        γ = s tr(H_μ⁻¹P) − s tr(H⁻¹P),

    N_y the observed entries (per row when the rows decouple) and γ the number of
    parameters the data determine beyond the prior. Its zero is the fixed point
    s = (RSS + pen(k̂) − pen(m)) / (N_y − γ) (MacKay's update).
    """
    pb = solver.problem
    rows = solver.separable
    scale = variances if rows else variances[:1]
    prior_scale = variances if rows else float(variances[0])
    theta, cov, logdet, n_fact, row_logdet = solver.solve(prior_scale, compute_cov=True)
    nan = np.full(scale.shape, np.nan)
    try:
        m, cov_mu, logdet_mu, _, row_logdet_mu = solver.solve(
            prior_scale, include_data=False, compute_cov=True
        )
    except SingularProblemError:
        return _Evidence(variances, nan, nan, nan, theta, cov, logdet, row_logdet, n_fact)
    if rows:
        rss = pb.output_rss(theta)
        pen_k, pen_m = solver.row_penalty(theta), solver.row_penalty(m)
        cost_k, cost_m = solver.row_prior_cost(theta), solver.row_prior_cost(m)
        logdets, logdets_mu = row_logdet, row_logdet_mu
        size = float(pb.n_observed)
    else:
        rss = pb.output_rss(theta).sum(keepdims=True)
        pen_k, pen_m = np.array([solver.penalty(theta)]), np.array([solver.penalty(m)])
        cost_k, cost_m = np.array([solver.prior_cost(theta)]), np.array([solver.prior_cost(m)])
        logdets, logdets_mu = np.array([logdet]), np.array([logdet_mu])
        size = float(pb.n_observed * pb.n)
    residual = rss + pen_k - pen_m
    value = (
        -0.5 * size * (LOG_2PI + np.log(scale))
        - 0.5 * logdets
        + 0.5 * logdets_mu
        - 0.5 * residual / scale
        - 0.5 * (cost_k - cost_m)
    )
    if cov is None or cov_mu is None:  # pragma: no cover - computed with compute_cov
        raise RuntimeError("the selected inversion did not run")
    gamma = scale * (_trace_with(cov_mu, gram) - _trace_with(cov, gram))
    slope = 0.5 * (residual / scale - size + gamma)
    with np.errstate(divide="ignore", invalid="ignore"):
        fixed = np.where((residual > 0) & (size > gamma), residual / (size - gamma), np.nan)
    return _Evidence(variances, value, slope, fixed, theta, cov, logdet, row_logdet, n_fact)


def _ml_noise_var_with_prior(solver: SquaredSolver, guess: float) -> tuple[_Evidence | None, int]:
    """argmax of log p(y | prior, σ²) (empirical Bayes): σ_i² per output row when the rows
    decouple, else one σ².

    Searched within a factor 1e3 (``NOISE_VAR_RANGE``) of ``guess`` for a zero of the
    derivative in log σ² (:func:`_evidence_with_slope`), from ``guess``, by safeguarded
    secant steps: the first step is the fixed-point update, later ones the secant of
    the last two derivatives, kept inside the bracket of the maximum (bisection where
    a step leaves it or is not half the one before last; a step beyond a bound not yet
    visited, or one back against the rise toward it, goes to the bound, which is the
    result where the likelihood still rises there). A row stops when its next step is
    below ``NOISE_VAR_XTOL`` in log σ² (the point it stands on is the result). Each
    evaluation costs two factorizations with their selected inversions; all rows step
    at once when each row's likelihood depends on its own σ_i² only.

    Returns
    -------
    (_Evidence or None, int)
        The evaluation at the estimate (``variances`` (n,)), None if the likelihood
        is undefined; and the number of σ² evaluated.
    """
    n = solver.problem.n
    size = n if solver.separable else 1
    gram = _prior_gram_diagonal(solver)
    evaluations = 0

    def evaluate(log_var: np.ndarray) -> _Evidence:
        nonlocal evaluations
        evaluations += 1
        variances = np.broadcast_to(np.exp(log_var), (n,)).copy()
        return _evidence_with_slope(solver, variances, gram)

    x = np.full(size, np.log(guess))
    point = evaluate(x)
    if not np.all(np.isfinite(point.value)):
        return None, evaluations
    lo, hi = x - NOISE_VAR_RANGE, x + NOISE_VAR_RANGE
    a, b = lo.copy(), hi.copy()  # the bracket of the maximum
    a_seen = np.zeros(size, dtype=bool)  # whether the derivative's sign at a (b) is known
    b_seen = np.zeros(size, dtype=bool)
    active = np.ones(size, dtype=bool)
    prev_x, prev_slope = np.full(size, np.nan), np.full(size, np.nan)
    last_step, step_before = np.full(size, np.inf), np.full(size, np.inf)
    for _ in range(NOISE_VAR_MAX_EVALUATIONS - 1):
        slope = point.slope
        up, down = active & (slope > 0), active & (slope < 0)
        broken = active & ~np.isfinite(slope)  # H_μ singular here: stay on this side
        up |= broken & ~(x > prev_x)
        down |= broken & (x > prev_x)
        a, a_seen = np.where(up, x, a), a_seen | up
        b, b_seen = np.where(down, x, b), b_seen | down
        # the likelihood still rises at a bound (or is flat here): the maximum is here
        active &= ~(((slope > 0) & (x >= hi)) | ((slope < 0) & (x <= lo)) | (slope == 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            secant = x - slope * (x - prev_x) / (slope - prev_slope)
            proposal = np.where(np.isfinite(secant), secant, np.log(point.fixed))
        proposal = np.where(np.isfinite(proposal), proposal, x + np.sign(slope))
        # beyond a bound not yet visited: the bound; beyond a visited end, or slow: bisect
        proposal = np.where(proposal >= b, np.where(b_seen, np.nan, b), proposal)
        proposal = np.where(proposal <= a, np.where(a_seen, np.nan, a), proposal)
        slow = a_seen & b_seen & (np.abs(proposal - x) > 0.5 * step_before)
        # a bound not yet visited on the side where the likelihood rises, else the middle
        fallback = np.where(
            (slope > 0) & ~b_seen, b, np.where((slope < 0) & ~a_seen, a, 0.5 * (a + b))
        )
        proposal = np.where(np.isnan(proposal) | slow, fallback, proposal)
        step = np.abs(proposal - x)
        active &= (step >= NOISE_VAR_XTOL) & ~(a_seen & b_seen & (b - a < NOISE_VAR_XTOL))
        if not active.any():
            break
        prev_x, prev_slope = np.where(active, x, prev_x), np.where(active, slope, prev_slope)
        step_before, last_step = last_step, np.where(active, step, last_step)
        x = np.where(active, proposal, x)  # the rows that stopped stay where they are
        point = evaluate(x)
    if not solver.separable:
        point.variances = np.full(n, point.variances[0])
    return point, evaluations


def _raise_if_precision_lost(lost: float, exc: SingularProblemError) -> None:
    """A singular system because λ is too large for the data: say so."""
    if lost > PRECISION_DIGITS_WARN:
        raise SingularProblemError(
            f"lam is too large for the scale of the data (the penalty exceeds the data "
            f"term by about 1e{lost:.0f}), so the normal equations are singular to working "
            "precision. For coefficients constant in time use lam=np.inf (an exact LTI "
            "fit); otherwise use a smaller lam."
        ) from exc


def _warn_if_precision_lost(lost: float, info: dict) -> None:
    """Warn (and record in ``info``) when a large λ costs more than 10 digits."""
    if lost > PRECISION_DIGITS_WARN:
        info["digits_lost"] = lost
        warn(
            f"lam is very large for the scale of the data: the normal equations lose about "
            f"{lost:.0f} of 16 significant digits. For coefficients constant in time use "
            "lam=np.inf (an exact LTI fit); otherwise use a smaller lam.",
            PrecisionWarning,
        )


def _fit_shared(
    problem: RegressionProblem,
    W: np.ndarray,
    row: np.ndarray,
    *,
    noise_var: np.ndarray | float | None,
    compute_cov: bool,
) -> SquaredResult:
    """:func:`fit_squared` without priors for a diagonal weight ``row`` (p,) that every
    output row shares (``W`` (K,) its repetition; a scalar λ): the same results by
    one factorization for all rows and the closed forms of the shared normalizer.
    """
    n = problem.n
    n_obs = problem.n_observed
    log_pdet, diffuse, penalty_scale = _shared_normalizer(problem, row)
    variances = (
        None
        if noise_var is None
        else np.broadcast_to(np.asarray(noise_var, dtype=float), (n,)).copy()
    )
    try:
        # One factorization for the n rows, from the raw arrays; RSS_i and penalty_i
        # (the weighted squares of DΘ_i) come out of its back substitution.
        sol = solve_shared_rows(
            problem.phi, problem.y, row, problem.coeffs, compute_cov=compute_cov
        )
    except SingularProblemError as exc:
        gram_trace = float(np.vdot(problem.phi, problem.phi))
        _raise_if_precision_lost(_digits_lost(penalty_scale, gram_trace, problem), exc)
        raise
    theta, row_logdet, row_rss, row_pen = sol.theta, sol.logdet, sol.rss, sol.squares
    cov = None if sol.cov is None else CovarianceBlocks(sol.cov[None], np.zeros(n, dtype=int))
    info: dict = {"row_separable": True}
    _warn_if_precision_lost(_digits_lost(penalty_scale, sol.gram_trace, problem), info)
    rss, pen = float(row_rss.sum()), float(row_pen.sum())
    row_cost = row_rss + row_pen  # RSS_i + penalty_i
    variances, loglik = _rows_loglik(row_cost, n_obs, diffuse, log_pdet, row_logdet, variances)
    return SquaredResult(
        theta=theta,
        cov=None if cov is None else cov.scale_rows(variances),
        noise_var=variances,
        noise_var_estimated=noise_var is None,
        loglik=loglik,
        objective=rss + pen + 0.0,
        rss=rss,
        penalty=pen,
        prior_cost=0.0,
        n_eff=float(n_obs * n - diffuse * n),
        n_factorizations=1,
        info=info,
    )


def fit_squared(
    problem: RegressionProblem,
    W: np.ndarray,
    priors: list[PriorTerm],
    *,
    noise_var: np.ndarray | float | None,
    compute_cov: bool,
) -> SquaredResult:
    """Exact MAP estimate, posterior covariances and log marginal likelihood.

    Parameters
    ----------
    problem : RegressionProblem
    W : ndarray, shape (K,) or (K, K)
        Penalty weight: the diagonal of W, or W itself (see :class:`SquaredSolver`).
    priors : list of PriorTerm
    noise_var : float, ndarray of shape (n,), or None
        σ², shared or one per output. None estimates it by maximum likelihood
        given λ. Without priors in closed form: when the penalty and the data
        decouple the output rows, per output i (the model with noise σ_i² and
        parameter drift σ_i²/λ² in row i, whose estimate does not depend on
        σ_i), σ̂_i² = (RSS_i + penalty_i) / N_eff,i with N_eff,i = (observed
        rows) − #diffuse directions of row i; otherwise one σ² shared by all
        outputs. With priors (row i's prior terms weighted by σ_i²) by a
        search for the maximum of log p(y | prior, σ²) within a factor 1e3 of
        the prior-free estimate, from the zeros of its derivative (a few
        factorizations with their selected inversions; per row at once when
        the rows decouple), falling back to the prior-free estimate when the
        prior alone does not determine the parameters (``info`` records the
        σ² evaluated, ``noise_var_evaluations``).
    compute_cov : bool
    """
    # A scalar λ without priors (the common case): every row shares one diagonal
    # weight, and the normalizer, precision estimate and solve have short forms.
    shared = None if priors else shared_row_weight(W, problem.n, problem.p)
    if shared is not None:
        return _fit_shared(problem, W, shared, noise_var=noise_var, compute_cov=compute_cov)
    solver = SquaredSolver(problem, W, priors)
    n = problem.n
    n_obs = problem.n_observed
    row_log_pdet, row_diffuse = solver.log_penalty_normalizer()
    n_eff = n_obs * n - float(row_diffuse.sum())
    info: dict = {"row_separable": bool(solver.separable)}
    estimated = noise_var is None
    per_row = solver.separable  # each output row its own problem and σ_i²
    variances = (
        None
        if noise_var is None
        else np.broadcast_to(np.asarray(noise_var, dtype=float), (n,)).copy()
    )
    if variances is not None and not per_row and np.any(variances != variances[0]):
        raise ValueError(
            "noise_var: one variance per output needs a penalty and priors that do not "
            "couple the output rows; pass a scalar noise_var"
        )
    lost = solver.digits_lost()
    # the search's evaluation at its estimate: the solution and likelihood there
    estimate: _Evidence | None = None
    if priors and variances is None:
        guess = _noise_var_guess(problem, W, n_eff)
        try:
            estimate, info["noise_var_evaluations"] = _ml_noise_var_with_prior(solver, guess)
        except SingularProblemError as exc:
            _raise_if_precision_lost(lost, exc)
            raise
        if estimate is not None:
            variances = estimate.variances
        else:
            variances = np.full(n, guess)
            info["noise_var_note"] = (
                "log p(y | prior) is not defined, so noise_var is the prior-free estimate"
            )
    if variances is None:
        prior_scale: float | np.ndarray = 1.0  # no priors: the scale is unused
    else:
        prior_scale = variances if per_row else float(variances[0])

    if estimate is not None:
        theta, logdet, n_fact, row_logdet = (
            estimate.theta,
            estimate.logdet,
            estimate.n_factorizations,
            estimate.row_logdet,
        )
        cov = estimate.cov if compute_cov else None
    else:
        try:
            theta, cov, logdet, n_fact, row_logdet = solver.solve(
                prior_scale, compute_cov=compute_cov
            )
        except SingularProblemError as exc:
            _raise_if_precision_lost(lost, exc)
            raise
    _warn_if_precision_lost(lost, info)
    row_rss = problem.output_rss(theta)
    rss = float(row_rss.sum())
    # per row when the rows decouple (one differencing pass serves both)
    row_pen = solver.row_penalty(theta) if per_row else None
    pen = float(row_pen.sum()) if row_pen is not None else solver.penalty(theta)
    row_prior = solver.row_prior_cost(theta)
    prior_cost = float(row_prior.sum())

    loglik: float | None
    if priors and variances is not None:  # with priors, variances is given or estimated above
        if estimate is not None:
            loglik = float(estimate.value.sum())
        else:
            logdets = row_logdet if per_row and row_logdet is not None else np.array([logdet])
            loglik = float(_loglik_with_prior(solver, variances, theta, logdets).sum())
        if np.isnan(loglik):
            loglik = None
            info["loglik_note"] = (
                "the prior alone does not determine every parameter, so log p(y | prior) "
                "is not defined"
            )
        weighted_prior = (
            float(np.sum(variances * row_prior)) if per_row else float(variances[0]) * prior_cost
        )
    elif per_row:
        row_cost = row_rss + row_pen  # RSS_i + penalty_i
        variances, loglik = _rows_loglik(
            row_cost, n_obs, row_diffuse, row_log_pdet, row_logdet, variances
        )
        weighted_prior = 0.0
    else:
        if variances is None:
            if n_eff <= 0:
                raise SingularProblemError(
                    "too few samples to estimate the noise variance: the unpenalized "
                    "directions use up all observations; pass noise_var or use more data"
                )
            variances = np.full(n, (rss + pen) / n_eff)
        loglik = float(
            -0.5 * n_eff * (LOG_2PI + np.log(variances[0]))
            + 0.5 * float(row_log_pdet.sum())
            - 0.5 * logdet
            - 0.5 * (rss + pen) / variances[0]
        )
        weighted_prior = 0.0

    objective = rss + pen + weighted_prior
    return SquaredResult(
        theta=theta,
        cov=None if cov is None else cov.scale_rows(variances),
        noise_var=variances,
        noise_var_estimated=estimated,
        loglik=loglik if loglik is None else float(loglik),
        objective=float(objective),
        rss=rss,
        penalty=pen,
        prior_cost=prior_cost,
        n_eff=float(n_eff),
        n_factorizations=n_fact,
        info=info,
    )


def _rows_loglik(
    row_cost, n_obs: int, diffuse, log_pdet, row_logdet, variances: np.ndarray | None
) -> tuple[np.ndarray, float]:
    """Noise variances (their ML values when None) and the log-likelihood of decoupled rows.

    ``row_cost`` is RSS_i + penalty_i per row; ``diffuse``, ``log_pdet`` and
    ``row_logdet`` per row or shared (see :meth:`SquaredSolver.log_penalty_normalizer`).
    """
    row_n_eff = n_obs - np.asarray(diffuse, dtype=float)
    if variances is None:
        if np.any(row_n_eff <= 0):
            raise SingularProblemError(
                f"too few samples to estimate the noise variance: {n_obs} observed rows "
                f"and {int(np.max(diffuse))} unpenalized directions per output; pass "
                "noise_var or use more data"
            )
        variances = np.maximum(row_cost / row_n_eff, np.finfo(float).tiny)
    loglik = float(
        np.sum(
            -0.5 * row_n_eff * (LOG_2PI + np.log(variances))
            + 0.5 * log_pdet
            - 0.5 * row_logdet
            - 0.5 * row_cost / variances
        )
    )
    return variances, loglik
