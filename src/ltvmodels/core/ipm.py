"""norm="group" and norm="l1" by a primal-dual interior-point method.

The problem Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ(Dk)_t) is written as a conic
quadratic program: with z = ΛDk split into cones c (group: one cone of size K
per row of D; l1: K cones of size 1 per row),

    minimize  ‖y − Φk‖² + Σ_c t_c   subject to  (t_c, z_c) ∈ Q  (‖z_c‖ <= t_c),

and solved by the primal-dual path-following method with Nesterov–Todd
scaling and Mehrotra's predictor–corrector steps (as in CVXOPT's ``coneqp``,
Vandenberghe 2010), which needs 10–30 iterations almost independently of N.

Structure makes each iteration O(N): the scaling W_c of cone c is a
hyperbolic Householder matrix η_c (2 w̄_c w̄_cᵀ − J), so after eliminating the
slacks and the epigraph variables t_c (one scalar per cone) the Newton system
in k is

    (2ΦᵀΦ + DᵀΛ S Λ D) Δk = r,   S_c = η_c⁻² (I − 8 w̄₀² w̄₁ w̄₁ᵀ / (1 + 8 w̄₀² ‖w̄₁‖²)),

block-banded with K × K blocks and block bandwidth d, like the squared-norm
normal equations. One block Cholesky factorization per iteration serves both
the predictor and the corrector. Problems of order 1 and 2 start primal and
dual feasible, from a quadratic fit (:func:`feasible_start`); group cones
then from a few reweighted quadratic fits closer to the optimum
(:func:`reweighted_start`).

Coefficients with weight inf are constant in time: they are pinned out of
the banded systems and solved for through a small border (see
:class:`_RowSystem`).

Notation: a cone vector v = (v₀, v₁) with v₀ scalar; J = diag(1, −I); the
Jordan product u ∘ v = (uᵀv, u₀v₁ + v₀u₁) with identity e = (1, 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..errors import ConvergenceWarning, SingularProblemError, warn
from . import blockkernels as kernels
from . import conekernels as cones
from . import widekernels as wide
from .banded import RELATIVE_PIVOT_TOL, difference_bands, kernel_size
from .polish import PolishResult, path_polish, polish, stationarity_scale
from .problem import RegressionProblem, output_spread

__all__ = [
    "STEP_FRACTION",
    "MIN_STEP",
    "SEPARATE_STEP_DEGREES",
    "START_DUAL_RANGE",
    "WARM_DEGREES",
    "REWEIGHT_STEPS",
    "WIDE_REWEIGHT_STEPS",
    "CENTRED_START",
    "EARLY_POLISH_GAP",
    "EARLY_POLISH_SPLITS",
    "EARLY_POLISH_ACTIVE",
    "EARLY_POLISH_MIN_ACTIVE",
    "WARM_REWEIGHT_STEPS",
    "REWEIGHT_FLOOR",
    "REWEIGHT_GAP_FRACTION",
    "FIXED_KERNEL_MIN_SIZE",
    "WIDE_MIN_SIZE",
    "WIDE_MIN_SIZE_FIRST",
    "DOMINANT_SCALES",
    "BOUNDARY",
    "InteriorPointResult",
    "ConicProblem",
    "NewtonSystem",
    "QuadraticScaling",
    "RowFits",
    "dominating_output",
    "feasible_start",
    "reweighted_start",
    "warm_dual",
    "interpolated_start",
    "fit_sparse_ipm",
]

# Fraction of the way to the cone boundary taken by a step (CVXOPT's STEP).
STEP_FRACTION = 0.99
# Fits of these orders (narrow blocks, no constant coefficients) step the primal
# (k, t, s) and the dual z each as far as its own cones allow. The reweighted start of
# group cones leaves many of them just off their vertex with their duals near the
# boundary: a common step stayed at 0.05-0.25 for the first two or three iterations
# (the primal's limit) while the dual could go 0.8 of its way. Separate steps leave a
# stationarity residual (α_p − α_d)·2ΦᵀΦΔk, which the next iterations close:
# convergence is still judged by the same gap and residuals. Jump-linear system,
# λ = 17, tol 1e-6: group T = 2000 7 → 5 iterations, T = 10⁴ 8 → 7. 288 fits of
# order 1 (jump-linear and random-walk, T = 300-2000, seeds 0-5, λ = 0.001-0.9
# λ_max): group 1727 → 1645 iterations, l1 2910 → 2613, objectives within 4.3e-7,
# none unconverged. The L-curves of benchmarks/bench_lcurve_choices.py: group 751 →
# 739, l1 1412 → 1261 (order 1), no choice moved. Order 2 is left out: near λ_max
# (the 128 fits of benchmarks/bench_stalls.py) 9 ended with a warning instead of 0.
# Wide blocks keep one step too (K = 60, T = 4000: their early polish then came
# later, 3 → 8 iterations).
SEPARATE_STEP_DEGREES = (1,)
# A step shorter than this makes no progress: the iterate is as good as it gets.
MIN_STEP = 1e-10
# The starting duality gap as a fraction of the starting objective (insensitive
# within 0.01–10; 0.1 needed the fewest iterations on the paper's example).
START_GAP_FRACTION = 0.1
# The feasible start (:func:`feasible_start`) aims at the largest dual cone
# norm START_DUAL_NORM and accepts anything within START_DUAL_RANGE (on the
# jump-linear benchmarks the iteration counts hardly depend on where in that
# range it lands, so the range is wide to save quadratic fits).
START_DUAL_NORM = 0.9
START_DUAL_RANGE = (0.2, 0.95)
START_TRIES = 6
# A warm start (:func:`warm_dual`) begins at a smaller gap than a cold one: its k is
# the previous λ's optimum. On the L-curve's grid of 29 jump-linear fits of order 1
# (T = 2000 and 10⁴, tol 1e-4, λ increasing) 0.01 and 0.1 needed about the same
# iterations (131–154 against 278–375 cold); a start's duals are kept this far
# inside their cones. For order 2 the feasible quadratic-fit start is as good
# (every third point of that grid, T = 2000, two seeds: group 196 warm against
# 194 cold, l1 277 against 238), so warm starts are taken for order 1 only.
WARM_GAP_FRACTION = 0.01
WARM_MAX_DUAL_NORM = 0.99
WARM_DEGREES = (1,)
# Group cones start from REWEIGHT_STEPS reweighted quadratic fits after the
# feasible start (:func:`reweighted_start`), each a fifth to a quarter of an
# iteration's work (p × p blocks), with the weights 1/‖(ΛDk)_c‖ floored at
# REWEIGHT_FLOOR times the largest and the gap REWEIGHT_GAP_FRACTION of the
# objective. On the jump-linear system (λ = 17, order 1, tol 1e-6, seeds 0-2)
# they took T = 2000 from 13-14 to 7 iterations and T = 10⁴ from 15-17 to 8
# (CPU time 1.4× less at both); 8 steps with floor 1e-4 and gap 0.003 left 7-8
# and 9-10 iterations, 16 steps cost more than they saved. Over λ = 0.5-400,
# orders 1 and 2, T = 300 and 2000, two seeds, at tol 1e-8: 336 iterations in
# all instead of 464, the same optima. (Along a λ path the warm start of
# order 1 needs about as many iterations without these fits: it takes
# WARM_REWEIGHT_STEPS from the previous k instead.)
REWEIGHT_STEPS = 12
REWEIGHT_FLOOR = 1e-5
REWEIGHT_GAP_FRACTION = 0.001
# Group cones whose Newton blocks take the wide kernels (WIDE_MIN_SIZE_FIRST,
# WIDE_MIN_SIZE) start from WIDE_REWEIGHT_STEPS reweighted fits instead: with
# p × p blocks against K × K ones (K = n·p) a fit costs 1/20 to 1/30 of an
# iteration there. Jump systems with K = 35 and 60 (order 1, T = 1000 and 4000,
# seeds 0-2, λ = 0.03, 0.1 and 0.3 λ_max, tol 1e-6, 36 fits, with the centred
# start of :func:`fit_sparse_ipm`): 8, 12, 16, 20, 30 and 40 fits took 253, 236,
# 223, 213, 197 and 190 iterations; beyond 20 the fits cost about what they save.
WIDE_REWEIGHT_STEPS = 20
# The reweighted start of wide fits puts each cone on its own central path (see
# fit_sparse_ipm).
CENTRED_START = True
# Wide group fits of order 1 try the active-set polish (:mod:`.polish`) once, when
# the relative duality gap first falls below this: the split of the cones into
# vertex and active ones is then settled enough for the polish to find the optimum
# and certify it (to the fit's tolerance, by the same test), and the iterations
# that would close the gap from there (2 to 4 at K = 35 and 60, T = 1000 and 4000,
# of 5 to 7) are left out. Where it fails, the iterations go on.
EARLY_POLISH_GAP = 1e-3
# The early attempt's bounds: at most this many corrections of the split, and only
# while at most this fraction of the cones (or this many) is active: with many
# changes the split settles late, and each correction costs a reduced solve the size
# of the changes (random-walk series of 10⁴ steps at 0.003-0.3 λ_max: 140 s of
# polish in all without the bounds, 0.2 s with them).
EARLY_POLISH_SPLITS = 10
EARLY_POLISH_ACTIVE = 0.01
EARLY_POLISH_MIN_ACTIVE = 32
# A warm start (order 1, a norm of WARM_POLISH_ACTIVE) first tries the active-set polish
# from the previous solution's split (:func:`.polish.path_polish`), where that solution
# has at most WARM_POLISH_ACTIVE[norm] active cones, with at most WARM_POLISH_SPLITS
# corrections of the split; where it certifies the answer to the fit's tolerance, no
# iteration is needed. On the L-curve of the jump-linear system (T = 10⁴, group) it
# certified 7 of the 12 candidates, in 3-10 ms each against 20-40 ms of warm
# iterations: the selection took 0.21 s instead of 0.30 s. On the 20 group series of
# order 1 of benchmarks/bench_lcurve_choices.py the same choices, 713 iterations
# instead of 739 (634 without the size bound below). Starts with at most 10 active
# cones were certified 59 times in 60; with 11-32, 7 times in 22, at a cost (1.1 s)
# beyond the iterations saved. Only from N·K² >= WARM_POLISH_MIN_WORK[norm] (the size
# of a Newton system's blocks) on: below it the polish's fixed costs exceed the few
# cheap iterations it saves (group: L-curves of three jump-linear series, K = 6, took
# 1.3-1.6x as long with it at T = 400, as long at T = 1000, 0.88x at 2000, 0.61x at
# 10⁴; random-walk series, K = 15, 1.02x at T = 400, 0.94x at 2000).
# l1 (scalar cones; reduced problems on each coefficient's own segments): on the 20 l1
# series of order 1 of that benchmark and four of T = 4000-10⁴ (at every size), starts
# with at most 10 active cones were certified 38 times in 38, with 11-20 34 times in
# 43, with 21-32 3 times in 11, with more 10 times in 151 (10.8 s of failed attempts).
# L-curves of two series with / without it (paired rounds, medians): jump-linear 1.04x
# at T = 1500, 0.87x at 2000, 0.73x at 10⁴; random-walk 1.09-1.17x at T = 400, 0.96x
# at 1000, 0.99-1.07x at 1500-2000 (within the rounds' spread; few of its starts are
# within the bound). Its size bound leaves out the random-walk series of T = 400 and the
# jump-linear ones up to T = 2777 (N·K² = 100,000), 2000 among them.
WARM_POLISH_SPLITS = 10
WARM_POLISH_ACTIVE = {"group": 10, "l1": 20}
WARM_POLISH_MIN_WORK = {"group": 50_000, "l1": 100_000}
# A warm start of group cones (order 1) takes WARM_REWEIGHT_STEPS reweighted fits from
# the previous solution's k (:func:`reweighted_start`) and then the reweighted
# start's gap: the previous duals, rescaled (:func:`warm_dual`), leave the new
# optimum's active cones off their boundary, and the steps stayed short (0.4-0.8).
# On the L-curve (``select_lambda``, tol 1e-4, 11 fits: 7 up the coarse grid, 4
# interpolated refinements) of the jump-linear system, T = 10⁴: 41 iterations
# instead of 64; T = 400 and 2000, two seeds each: 36-46 instead of 53-63 (3 fits:
# 40-46; 6 fits: 33-43 at 50 % more reweighting); the same corner on 20
# jump-linear and random-walk series of order 1 (T = 150-2000; 824 iterations in
# all instead of 1065). Down a path (a 7-point grid from the top) 59-74 instead of
# 65-75; blocked cross-validation 283 and 319 instead of 326 and 371 (T = 400,
# 2000). Each fit costs about a quarter of an iteration (T = 10⁴, K = 6).
WARM_REWEIGHT_STEPS = 4
# An output entry this many robust scales (1.4826 · MAD) from its column's median
# dominates a squared-loss objective beyond what the interior-point method resolves:
# a failure to start is then reported as caused by it (on the jump-linear system,
# T = 200, λ = 5, a single output 1e10 times the data's scale stopped every start).
DOMINANT_SCALES = 1e6
BOUNDARY = (
    "the interior-point iterate reached the boundary of a cone at working "
    "precision; a looser tol helps"
)
# Use the kernels compiled for a constant block size from this many unknowns on.
FIXED_KERNEL_MIN_SIZE = 2_000
# Newton blocks of at least this size are factored by :mod:`.widekernels` instead of
# the scalar loops: for order 1 by block elimination with explicit inverses, from
# WIDE_MIN_SIZE_FIRST on; otherwise by BLAS and LAPACK, from WIDE_MIN_SIZE on. CPU
# time of whole fits (norm="group", jump systems, T = 1000, λ = 0.1 λ_max, best of
# three, range of the ratios loops/wide): order 1, K = 8: 1.27–1.31, K = 12:
# 1.45–1.61, K = 15: 1.04–2.39, K = 24: 2.67–3.32; order 2, K = 8: 0.67–0.72,
# K = 12: 0.98–1.07, K = 15: 0.90–0.98, K = 24: 1.15–1.43. The same for norm="l1"'s
# p × p blocks (wall time, best of two, λ = 0.1 and 0.01 λ_max, T = 1000): order 1,
# p = 12: 1.24–1.28, p = 16: 1.58–1.61, p = 24: 2.6–3.0 (T = 4000: 2.2–3.3); order 2,
# p = 16: 1.19–1.23, p = 24: 1.65–1.68; the robust losses' l1 fits (T = 400, p = 24)
# 1.5–2.0.
WIDE_MIN_SIZE = 16
WIDE_MIN_SIZE_FIRST = 12


@dataclass
class InteriorPointResult:
    """Result of :func:`fit_sparse_ipm`."""

    theta: np.ndarray  # (N, n, p)
    objective: float  # Σ‖y_t − Θ_tφ_t‖² + Σ_t R(Λ(Dk)_t) at theta
    duality_gap: float  # sᵀz: primal minus dual objective of the conic program
    primal_residual: float  # relative ‖s − (t, ΛDk)‖
    dual_residual: float  # relative norm of the stationarity residual
    iterations: int
    converged: bool
    polished: bool = False  # the active-set polish (:mod:`.polish`) gave the result
    stalled: bool = False  # stopped before the tolerance: no progress at working precision
    # The cones' dual vectors z₁ (n_cones, g) and the weights solved for: a warm start
    # of the next λ (:func:`warm_dual`).
    dual: np.ndarray | None = None
    weights: np.ndarray | None = None


class _RowSystem:
    """One independent block-banded Newton system and its border of constant coefficients.

    Covers the coefficients ``rows`` (all K for group, one output row for l1).
    Coefficients held constant in time (λ = inf) are pinned to an identity in
    the banded matrix H_b and solved for through a border: with G the data
    coupling between the varying and the constant coefficients and C0 the
    constants' own Gram matrix, the Newton step is

        Δc = (C0 − GᵀH_b⁻¹G)⁻¹ (f_c − GᵀH_b⁻¹f),   Δk = H_b⁻¹(f − GΔc),

    with f_c the right-hand side summed over time (k_tj = c_j for all t).
    """

    def __init__(self, cp: ConicProblem, rows: slice, const: np.ndarray):
        self.rows, self.offset = rows, rows.start
        b = rows.stop - rows.start
        self.pinned = const[rows].astype(float)
        self.const = np.flatnonzero(const[rows])
        inverses = cp.degree == 1 and cp.block_inverses
        # The group cones' K × K blocks, or l1's p × p blocks of one output row
        self.wide = b >= (WIDE_MIN_SIZE_FIRST if inverses else WIDE_MIN_SIZE)
        self.coeffs = cp.coeffs
        # Wide blocks eliminated with explicit inverses: the factor keeps S_t⁻¹ per step
        # and P_t as (δ_t, a_t), no off-diagonal blocks (widekernels.factor_newton_wide_first).
        self.inverses = self.wide and inverses
        self.L = np.empty((cp.N, 1 if self.inverses else cp.degree + 1, b, b))
        self.P = np.empty((cp.N, 2, b)) if self.inverses else None
        small = cp.N * b >= FIXED_KERNEL_MIN_SIZE and b <= 16 and not self.wide
        self.fixed = (0,) * b if small else None
        if self.const.size:
            p = cp.p
            idx = self.offset + np.arange(b)
            cidx = self.offset + self.const
            same_row = (idx[:, None] // p == cidx[None, :] // p) & (self.pinned[:, None] == 0)
            gram = cp.problem.gram()
            self.G = 2.0 * gram[:, idx % p][:, :, cidx % p] * same_row
            cc_row = cidx[:, None] // p == cidx[None, :] // p
            self.C0 = 2.0 * gram[:, cidx % p][:, :, cidx % p].sum(axis=0) * cc_row

    def factor_and_solve(
        self, cp: ConicProblem, newton: NewtonSystem | QuadraticScaling, f: np.ndarray,
        pivot_tol: float = 0.0,
    ):  # fmt: skip
        """Factor at ``newton``'s scaling and return the Newton step for f (N, b).

        Raises SingularProblemError where a pivot² falls below ``pivot_tol`` times
        the diagonal entry it came from (0: only where the matrix is not positive
        definite).
        """
        f, f_c = self._split(f)
        Z = f[:, :, None] if not self.const.size else np.concatenate([f[:, :, None], self.G], 2)
        Z = np.ascontiguousarray(Z)
        self.factor(cp, newton, pivot_tol)
        self.solve_columns(Z)
        if self.const.size:
            self.HinvG = Z[:, :, 1:].copy()
            schur = self.C0 - np.einsum("tbj,tbk->jk", self.G, self.HinvG)
            self.schur = cho_factor(schur)
        return self._border(Z[:, :, 0], f_c)

    def factor(
        self, cp: ConicProblem, newton: NewtonSystem | QuadraticScaling, pivot_tol: float = 0.0
    ) -> None:
        """Factor the banded matrix H_b at ``newton``'s scaling (see :meth:`factor_and_solve`)."""
        args = (
            cp.phi,
            cp.n_rep,
            newton.v,
            newton.eta,
            newton.s_coef,
            newton.penalty,
            cp.w,
            cp.coeffs,
            self.offset,
            self.pinned,
            self.L,
        )
        if self.inverses:
            worst, worst_t = wide.factor_newton_wide_first(*args, self.P)
        elif self.wide:
            with wide.one_blas_thread():
                worst, worst_t = wide.factor_newton_wide(*args)
        elif self.fixed is not None:
            worst, worst_t = cones.factor_newton_fixed(*args, self.fixed)
        else:
            worst, worst_t = cones.factor_newton_any(*args)
        if worst < pivot_tol:
            raise self.singular(worst_t)

    def solve_columns(self, Z: np.ndarray) -> None:
        """H_b X = Z in place for Z (N, b, r), C-contiguous, with the current factor."""
        if self.inverses:
            wide.solve_wide_first(self.L, self.P, Z, self.coeffs)
        elif self.wide:
            wide.solve_wide(self.L, Z)
        elif self.fixed is not None:
            kernels.solve_fixed(self.L, Z, self.fixed)
        else:
            kernels.solve(self.L, Z, Z.shape[1])

    @staticmethod
    def singular(worst_t: int) -> SingularProblemError:
        """The error for a Newton matrix that is not positive definite near step worst_t."""
        return SingularProblemError(
            f"the Newton system is singular near time step {worst_t}: the data do "
            "not determine the model; more excitation or a larger lam helps"
        )

    def solve(self, f: np.ndarray) -> np.ndarray:
        """The Newton step for f (N, b) with the current factorization."""
        f, f_c = self._split(f)
        X = np.ascontiguousarray(f[:, :, None])
        self.solve_columns(X)
        return self._border(X[:, :, 0], f_c)

    def _split(self, f: np.ndarray):
        """f with the constants' entries removed (zeroed), and their sums over time."""
        if not self.const.size:
            return f, None
        f = np.array(f)
        f_c = f[:, self.const].sum(axis=0)
        f[:, self.const] = 0.0
        return f, f_c

    def _border(self, y: np.ndarray, f_c: np.ndarray) -> np.ndarray:
        if not self.const.size:
            return y
        dc = cho_solve(self.schur, f_c - np.einsum("tbj,tb->j", self.G, y))
        dk = y - self.HinvG @ dc
        dk[:, self.const] = dc
        return dk


class ConicProblem:
    """The data of the conic program and its independent Newton systems.

    Cone vectors are (n_cones, g + 1) arrays as in :mod:`.conekernels`.
    Coefficients with weight inf are constant in time: their cone entries get
    weight 0 and their steps come from the systems' borders. ``block_inverses``:
    whether the wide Newton blocks of a first difference may be eliminated with
    explicit inverses (:func:`.widekernels.factor_newton_wide_first`, faster),
    else they are factored by Cholesky (:func:`.widekernels.factor_newton_wide`
    from WIDE_MIN_SIZE on, the scalar loops below).
    """

    def __init__(
        self,
        problem: RegressionProblem,
        weights: np.ndarray,
        norm: str,
        block_inverses: bool = True,
    ):
        self.problem = problem
        self.N, self.n, self.p, self.K = problem.N, problem.n, problem.p, problem.K
        self.degree = problem.degree
        self.block_inverses = block_inverses
        self.y = np.ascontiguousarray(problem.y)
        self.phi = np.ascontiguousarray(problem.phi)
        self.coeffs = np.ascontiguousarray(problem.coeffs, dtype=float)
        self.const = np.isinf(weights)
        self.w = np.ascontiguousarray(np.where(self.const, 0.0, weights), dtype=float)
        rows = self.N - problem.degree
        g = self.K if norm == "group" else 1  # cone size without t
        self.n_cones = rows * (self.K // g)
        self.cone_shape = (self.n_cones, g + 1)
        # The data couple the coefficients of a time step only within an output
        # row (ΦᵀΦ = blkdiag_t(I_n ⊗ φ_tφ_tᵀ)); the l1 cones are single
        # coefficients, so then the Newton matrix splits into n systems with
        # p × p blocks, one per row. The group cones couple all K coefficients.
        if norm == "l1":
            slices = [slice(i * self.p, (i + 1) * self.p) for i in range(self.n)]
            self.n_rep = 1
        else:
            slices = [slice(0, self.K)]
            self.n_rep = self.n
        self.systems = [_RowSystem(self, rows, self.const) for rows in slices]
        self._row_fits: RowFits | None = None

    def factor_and_solve(
        self, newton: NewtonSystem | QuadraticScaling, rhs: np.ndarray, pivot_tol: float = 0.0
    ) -> np.ndarray:
        """Factor the Newton matrix at ``newton``'s scaling; the step for rhs (N, K)."""
        for system in self.systems:
            rows = system.rows
            rhs[:, rows] = system.factor_and_solve(self, newton, rhs[:, rows], pivot_tol)
        return rhs

    def quadratic_fit(self, rho: float) -> np.ndarray:
        """argmin_k ‖y − Φk‖² + (ρ/2)‖ΛDk‖², shape (N, K); no constant coefficients.

        Solved as 2(ΦᵀΦ + (ρ/2)DᵀΛ²D) k = 2Φᵀy. Group cones without constant
        coefficients take the row systems of :func:`reweighted_start` (ρ the
        same for every cone), which a group fit compiles anyway; the others the
        Newton systems' own factorization (:class:`QuadraticScaling`). Either
        way a fit compiles no other kernels for its start. Raises
        SingularProblemError where the matrix is singular to working precision
        (RELATIVE_PIVOT_TOL).
        """
        N, n, p = self.N, self.n, self.p
        if self.cone_shape[1] > 2 and not self.const.any():
            bands = rho * difference_bands(N, self.coeffs)  # of ρDᵀD: R = ρI
            k = self.row_fits().fit(bands, RELATIVE_PIVOT_TOL)
            if k is None:
                raise SingularProblemError(
                    "the quadratic start's system is singular to working precision"
                )
            return k.reshape(N, n * p)
        scaling = QuadraticScaling(self, rho)
        w_rows = self.w.reshape(n, p)
        if len(self.systems) > 1 and (w_rows == w_rows[0]).all():
            # l1 with the same weights in every output row: the row systems share
            # their matrix, factored once for the n right-hand sides.
            X = 2.0 * np.ascontiguousarray(self.problem.cross())  # (N, p, n)
            self.systems[0].factor(self, scaling, RELATIVE_PIVOT_TOL)
            self.systems[0].solve_columns(X)
            return X.transpose(0, 2, 1).reshape(N, n * p)
        rhs = 2.0 * self.problem.cross().transpose(0, 2, 1).reshape(N, n * p)
        return self.factor_and_solve(scaling, rhs, RELATIVE_PIVOT_TOL)

    def row_fits(self) -> RowFits:
        """The :class:`RowFits` of the group cones, made once: the quadratic start and
        the reweighted fits share their right-hand sides and storage."""
        if self._row_fits is None:
            self._row_fits = RowFits(self)
        return self._row_fits

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """The Newton step for rhs (N, K) with the current factorization, in place."""
        for system in self.systems:
            rhs[:, system.rows] = system.solve(rhs[:, system.rows])
        return rhs

    def newton_product(self, newton: NewtonSystem, x: np.ndarray) -> np.ndarray:
        """H x (N, K) for the Newton matrix H = 2ΦᵀΦ + DᵀΛSΛD at ``newton``'s scaling
        (the matrix :meth:`factor_and_solve` factors; no constant coefficients)."""
        fitted = np.einsum("tjp,tip->tji", self.phi, x.reshape(self.N, self.n, self.p))
        out = 2.0 * np.einsum("tjp,tji->tip", self.phi, fitted).reshape(self.N, self.K)
        cone = np.zeros(self.cone_shape)
        cones.weighted_difference(x, self.coeffs, self.w, cone)  # ΛDx per cone
        y = cone[:, 1:]
        if newton.pairs:  # S_c per cone of width 2
            y *= newton.penalty[:, None]
        else:  # S = η⁻²(I − s_coef v₁v₁ᵀ)
            v1 = newton.v[:, 1:]
            along = np.einsum("ci,ci->c", v1, y) * newton.s_coef
            y -= along[:, None] * v1
            y /= (newton.eta**2)[:, None]
        cones.add_weighted_difference_adjoint(cone, self.coeffs, self.w, 1.0, out)
        return out

    def dual_residual_norm(self, r_k: np.ndarray) -> float:
        """‖r_k‖ with the entries of constant coefficients summed over time."""
        if not self.const.any():
            return float(np.linalg.norm(r_k))
        varying = np.linalg.norm(r_k[:, ~self.const])
        return float(np.hypot(varying, np.linalg.norm(r_k[:, self.const].sum(axis=0))))


class RowFits:
    """Quadratic fits of group cones' coefficients, one p × p block system per output row.

    Solves 2(ΦᵀΦ ⊗ I + DᵀRD ⊗ Λ²) k = 2Φᵀy (rows of Θ independent: Λ² is
    diagonal) for the bands of DᵀRD given as :func:`.banded.difference_bands`
    holds those of DᵀD; output rows with equal weights share a factorization.
    A first difference takes one compiled call per fit,
    :func:`.blockkernels.first_difference_solve` (at T = 10⁴, p = 3, two rows:
    0.67 ms against 1.18 ms for the general factorization and solve); higher
    orders the squared norm's kernels (:func:`.blockkernels.factor_forward`,
    :func:`.blockkernels.solve`) with the argument types of its BlockFactor
    (:mod:`.banded`), so that a group fit compiles nothing more for them. Used
    for the quadratic start (R = ρI) and the reweighted fits
    (:func:`reweighted_start`).
    """

    def __init__(self, cp: ConicProblem):
        self.cp = cp
        N, n, p = cp.N, cp.n, cp.p
        # A first difference takes one fused kernel (see _fit_first).
        self.first = cp.degree == 1
        self.L = np.empty((N, cp.degree + 1, p, p))
        self.size = kernel_size(N, p)
        self.extra, self.no_rhs = np.zeros((0, p, p)), np.zeros((N, p, 0))
        self.data = 2.0 * cp.problem.cross().transpose(0, 2, 1)  # 2Φᵀy, (N, n, p)
        self.groups: list[list[int]] = []  # output rows with equal weights
        self.w_rows = cp.w.reshape(n, p)
        for i in range(n):
            for rows in self.groups:
                if np.array_equal(self.w_rows[rows[0]], self.w_rows[i]):
                    rows.append(i)
                    break
            else:
                self.groups.append([i])
        if self.first:  # each group's right-hand sides in the kernel's layout, once
            self.rhs = [np.ascontiguousarray(self.data[:, rows, :]) for rows in self.groups]
            self.wsq = [np.ascontiguousarray(self.w_rows[rows[0]] ** 2) for rows in self.groups]

    def fit(self, bands: np.ndarray, pivot_tol: float = 0.0) -> np.ndarray | None:
        """Θ (N, n, p) for the bands (d + 1, N) of DᵀRD; None where a system's
        smallest pivot² ratio is not above ``pivot_tol`` (not positive definite)."""
        cp, L = self.cp, self.L
        if self.first:
            return self._fit_first(bands, pivot_tol)
        fitted = np.empty((cp.N, cp.n, cp.p))
        for rows in self.groups:
            W = np.diag(self.w_rows[rows[0]] ** 2)
            worst, _, _ = kernels.factor_forward(
                cp.phi, 1, 2.0, self.extra, W, bands, self.no_rhs, L, self.size
            )
            if not worst > pivot_tol:
                return None
            Z = np.ascontiguousarray(self.data[:, rows, :].transpose(0, 2, 1))  # (N, p, rows)
            kernels.solve(L, Z, self.size)
            fitted[:, rows, :] = Z.transpose(0, 2, 1)
        return fitted

    def _fit_first(self, bands: np.ndarray, pivot_tol: float) -> np.ndarray | None:
        """:meth:`fit` for a first difference (:func:`.blockkernels.first_difference_solve`)."""
        cp = self.cp
        fitted = None if len(self.groups) == 1 else np.empty((cp.N, cp.n, cp.p))
        for rows, rhs, wsq in zip(self.groups, self.rhs, self.wsq):
            X = rhs.copy()
            worst, _ = kernels.first_difference_solve(cp.phi, 2.0, wsq, bands, X, self.L, self.size)
            if not worst > pivot_tol:
                return None
            if fitted is None:
                return X
            fitted[:, rows, :] = X
        return fitted


class QuadraticScaling:
    """The scaling whose Newton matrix 2ΦᵀΦ + DᵀΛSΛD is 2ΦᵀΦ + ρDᵀΛ²D (S = ρI).

    Given to :meth:`ConicProblem.factor_and_solve` in place of a
    :class:`NewtonSystem`: S as the diagonal term of cones of width 2
    (``penalty``, one entry per coefficient and row of D), which
    :func:`.conekernels._factor_newton` takes for any block size; the cone
    scaling arrays stay empty. The kernel's argument types are those of the
    interior-point iterations, so no other version of it is compiled.
    """

    def __init__(self, cp: ConicProblem, rho: float):
        m = cp.cone_shape[1]
        self.v, self.eta, self.s_coef = np.empty((0, m)), np.empty(0), np.empty(0)
        self.penalty = np.full((cp.N - cp.degree) * cp.K, float(rho))


class NewtonSystem:
    """The linearized KKT system at one iterate, factored once for several targets.

    Newton's equations for the residuals r_x = (1 − z₀, r_k) (stationarity in t
    and k) and r_z = s − (t, ΛDk) (the cone constraints), in scaled form, are

        P Δx + GᵀΔz = −r_x,   GΔx + Δs = −r_z,   λ ∘ (WΔz + W⁻¹Δs) = target,

    with G(t, k) = −(t, ΛDk). Eliminating Δs, then Δz = W⁻²(GΔx + r̂) with
    r̂ = r_z + W(λ ⋄ target), then Δt per cone, leaves the banded system in Δk
    (see :func:`.conekernels.direction_rhs` and :func:`.conekernels.direction_finish`).
    """

    def __init__(self, cp: ConicProblem, s, z, r_z, r_k):
        self.cp, self.s, self.z, self.r_z, self.r_k = cp, s, z, r_z, r_k
        n_cones, m = s.shape
        # Cones of width 2 (l1) take the closed forms of the *_pairs kernels; the
        # arrays of the other kind stay empty.
        self.pairs = m == 2
        general, pairs = (0, n_cones) if self.pairs else (n_cones, 0)
        self.v, self.eta = np.empty((general, m)), np.empty(general)
        self.lam, self.u_rz = np.empty((general, m)), np.empty((general, m))
        self.alpha, self.beta = np.empty(general), np.empty((general, m - 1))
        self.s_coef = np.empty(general)
        self.inv_s, self.base = np.empty((pairs, 2)), np.empty((pairs, 2))
        self.inv_alpha, self.ratio = np.empty(pairs), np.empty(pairs)
        self.penalty = np.empty(pairs)  # S_c, the diagonal Newton-matrix term
        self.lam_sq = np.empty_like(s)  # λ∘λ
        if self.pairs:
            interior = cones.prepare_newton_pairs(
                s, z, r_z, self.inv_s, self.base, self.inv_alpha, self.ratio,
                self.penalty, self.lam_sq,
            )  # fmt: skip
            if not interior:
                raise SingularProblemError(BOUNDARY)
            return
        args = (s, z, r_z, self.v, self.eta, self.lam, self.lam_sq, self.u_rz, self.alpha)
        try:
            cones.prepare_newton(*args, self.beta, self.s_coef)
        except ZeroDivisionError:  # a cone's s or z reached its boundary in rounding
            raise SingularProblemError(BOUNDARY) from None

    def predictor_corrector(self, gap: float):
        """(Δk, Δt, Δs, Δz, (step of s, step of z)) of Mehrotra's predictor–corrector
        iteration: the largest steps keeping s and keeping z in their cones.

        Factors the Newton matrix, solves for the predictor target −λ∘λ (step α_a,
        the smaller of the two), then for the corrector target
        σμe − λ∘λ − (W⁻¹Δs_a) ∘ (WΔz_a) with σ = (1 − min(1, α_a))³ and
        μ = gap / n_cones. Group cones without
        constant coefficients and with blocks below the wide kernels' sizes take it
        in two compiled calls (the factorization, then
        :func:`.conekernels.predictor_corrector` for both solves); the others
        through :meth:`affine_direction` and :meth:`direction`.
        """
        cp = self.cp
        if self.pairs or len(cp.systems) != 1 or cp.systems[0].const.size or cp.systems[0].wide:
            _, _, ds_a, dz_a, steps = self.affine_direction()
            sigma_mu = (1.0 - min(1.0, *steps)) ** 3 * gap / cp.n_cones
            return self.direction(self.corrector_target(ds_a, dz_a, sigma_mu))
        system = cp.systems[0]
        target, work = np.empty_like(self.lam_sq), np.empty_like(self.lam_sq)
        dk, dt = np.empty((cp.N, cp.K)), np.empty(cp.n_cones)
        ds, dz = np.empty_like(work), np.empty_like(work)
        size = system.fixed if system.fixed is not None else system.L.shape[2]
        try:
            system.factor(cp, self)
            step_s, step_z = cones.predictor_corrector(
                cp.coeffs, cp.w, self.s, self.z, self.r_z, self.r_k, gap, self.v, self.eta,
                self.lam, self.lam_sq, self.u_rz, self.alpha, self.beta, self.s_coef, system.L,
                target, work, dk, dt, ds, dz, size,
            )  # fmt: skip
        except ZeroDivisionError:  # a cone's scaling underflowed or overflowed
            raise SingularProblemError(BOUNDARY) from None
        return dk, dt, ds, dz, (step_s, step_z)

    def predictor_target(self) -> np.ndarray:
        """The affine (predictor) target −λ∘λ."""
        return -self.lam_sq

    def corrector_target(self, ds_a, dz_a, sigma_mu: float) -> np.ndarray:
        """Mehrotra's target σμe − λ∘λ − (W⁻¹Δs_a) ∘ (WΔz_a); ds_a, dz_a may be overwritten."""
        target = np.empty_like(self.lam_sq)
        if self.pairs:
            cones.corrector_target_pairs(self.lam_sq, ds_a, dz_a, sigma_mu, target)
        else:
            cones.corrector_target(self.lam, self.v, self.eta, ds_a, dz_a, sigma_mu, target)
        return target

    def affine_direction(self):
        """Factor the Newton matrix and solve for the predictor target −λ∘λ."""
        try:
            work, rhs = self.rhs_for(self.predictor_target())
            return self.finish(self.cp.factor_and_solve(self, rhs), work)
        except ZeroDivisionError:  # a cone's scaling underflowed or overflowed
            raise SingularProblemError(BOUNDARY) from None

    def direction(self, target: np.ndarray):
        """(Δk, Δt, Δs, Δz, (step of s, step of z)) for the target (after
        :meth:`affine_direction`)."""
        try:
            work, rhs = self.rhs_for(target)
            return self.finish(self.cp.solve(rhs), work)
        except ZeroDivisionError:
            raise SingularProblemError(BOUNDARY) from None

    def rhs_for(self, target: np.ndarray):
        """(work, rhs): the banded system's right-hand side (N, K) for a cone target."""
        cp = self.cp
        work = np.empty_like(target)
        rhs = np.empty((cp.N, cp.K))
        if self.pairs:
            cones.direction_rhs_pairs(
                target, self.inv_s, self.base, self.ratio, self.r_k, cp.coeffs, cp.w, work, rhs
            )
            return work, rhs
        cones.direction_rhs(
            target,
            self.lam,
            self.v,
            self.eta,
            self.u_rz,
            self.z,
            self.alpha,
            self.beta,
            self.r_k,
            cp.coeffs,
            cp.w,
            work,
            rhs,
        )
        return work, rhs

    def finish(self, dk: np.ndarray, work: np.ndarray):
        """(Δk, Δt, Δs, Δz) and the largest steps keeping s and keeping z in the cones."""
        cp = self.cp
        dt, ds, dz = np.empty(cp.n_cones), np.empty_like(work), np.empty_like(work)
        if self.pairs:
            steps = cones.direction_finish_pairs(
                dk, work, self.inv_s, self.r_z, self.z, self.inv_alpha, self.ratio,
                self.penalty, cp.coeffs, cp.w, dt, ds, dz,
            )  # fmt: skip
            return dk, dt, ds, dz, steps
        steps = cones.direction_finish(
            dk,
            work,
            self.s,
            self.r_z,
            self.z,
            self.alpha,
            self.beta,
            self.v,
            self.eta,
            self.s_coef,
            cp.coeffs,
            cp.w,
            dt,
            ds,
            dz,
        )
        return dk, dt, ds, dz, steps


def dominating_output(problem: RegressionProblem) -> SingularProblemError | None:
    """The error that names an output entry beyond DOMINANT_SCALES robust scales of its
    column (the farthest), or None where there is none."""
    where = output_spread(problem)
    if where is None or not np.any(where.scales > DOMINANT_SCALES):
        return None
    t, j, i = np.unravel_index(int(np.argmax(where.scales)), where.scales.shape)
    row = f"y[{t}, {i}] (x[{t + 1}, {i}] of a state-space fit)"
    if problem.q > 1:
        row = f"y[{j}, {t}, {i}] (x[{j}, {t + 1}, {i}] of a state-space fit)"
    return SingularProblemError(
        f"the output {row} is {where.given[t, j, i]:.3g}, {where.scales[t, j, i]:.1e} robust "
        f"scales (1.4826 · MAD = {where.spread[i]:.3g}) from its median "
        f"{where.center[i]:.3g}: with the squared loss this one sample dominates the "
        f"objective beyond what the interior-point method resolves in double precision "
        f"(expected within {DOMINANT_SCALES:.0e} scales); mark it missing (NaN) if it is a "
        "recording error, or pass loss='huber' or 'laplace' (which bound its influence) "
        "or norm='sq'"
    )


def feasible_start(problem: RegressionProblem, cp: ConicProblem):
    """A primal and dual feasible starting k and its ρ, or (zeros, None).

    The quadratic fit k(ρ) = argmin ‖y − Φk‖² + (ρ/2)‖ΛDk‖² satisfies
    2Φᵀ(Φk − y) + ρDᵀΛ²Dk = 0, so with z₁ = −ρΛDk every stationarity residual
    vanishes, and z = (1, z₁) is in the dual cones when ρ‖(ΛDk)_c‖ < 1 for
    every cone. That largest norm a(ρ) grows with ρ; a few secant steps on
    log a against log ρ bring it into START_DUAL_RANGE. Starting feasible saves
    the first iterations' work on the residuals: on 36 jump-linear fits
    (``benchmarks/bench_ipm_start.py``) 451 instead of 531 iterations for
    order 1 and 474 instead of 520 for order 2, at one or two quadratic fits
    each.
    """
    # ρ has the units of 1/y² (ρΛDk is dimensionless and λ‖Dk‖ ~ ‖y‖²).
    rho = 1.0 / max(float(np.mean(cp.y**2)), 1e-300)
    z = np.empty(cp.cone_shape)
    best = previous = None
    for _ in range(START_TRIES):
        try:
            k = cp.quadratic_fit(rho)
        except SingularProblemError:
            break
        cones.weighted_difference(k, cp.coeffs, cp.w, z)
        a = rho * float(np.sqrt(np.sum(z[:, 1:] ** 2, axis=1)).max())
        if not np.isfinite(a) or a == 0.0:
            break
        if a < START_DUAL_RANGE[1]:
            best = (k, rho)
            if a >= START_DUAL_RANGE[0]:
                break
        current = (np.log(rho), np.log(a))
        slope = 1.0  # of log a against log ρ: a secant once two points are known
        if previous is not None and current[0] != previous[0] and current[1] != previous[1]:
            slope = (current[1] - previous[1]) / (current[0] - previous[0])
            slope = min(max(slope, 0.1), 10.0)
        previous = current
        rho *= np.exp((np.log(START_DUAL_NORM) - current[1]) / slope)
    if best is None:
        return np.zeros((cp.N, cp.K)), None
    return best


def reweighted_start(
    problem: RegressionProblem, cp: ConicProblem, k: np.ndarray, steps: int | None = None
):
    """A start closer to the optimum than the quadratic fit k, for group cones.

    Returns (k, z₁ (n_cones, g)) after up to ``steps`` (default REWEIGHT_STEPS)
    reweighted quadratic fits from k: each minimizes ‖y − Φk‖² + Σ_c ‖(ΛDk)_c‖² / (2‖(ΛDk_prev)_c‖),
    the quadratic majorizer of the group penalty at the previous k, so that
    2Φᵀ(Φk − y) + DᵀΛRΛDk = 0 with R = diag(ρ_c), ρ_c = 1/‖(ΛDk_prev)_c‖, and
    z₁_c = −ρ_c(ΛDk)_c is stationary. With S_c = ρ_c I the normal equations
    split into one system per output row with p × p blocks (:class:`RowFits`)
    with the bands of DᵀRD (:func:`.conekernels.reweight_bands`) in place of
    those of DᵀD; rows with equal weights share a factorization. Duals outside
    their cones are pulled back to the norm WARM_MAX_DUAL_NORM (as in
    :func:`warm_dual`). None where no step was taken (no differences, or a
    system not positive definite).
    """
    N = cp.N
    e, bands = np.empty(cp.cone_shape), np.empty((cp.degree + 1, N))
    fits = cp.row_fits()
    theta, rho = np.array(k, dtype=float).reshape(N, cp.n, cp.p), None
    for _ in range(REWEIGHT_STEPS if steps is None else steps):
        if not cones.reweight_bands(
            theta.reshape(N, -1), cp.coeffs, cp.w, REWEIGHT_FLOOR, e, bands
        ):
            break
        fitted = fits.fit(bands)
        if fitted is None:
            break
        theta, rho = fitted, e[:, 0].copy()
    if rho is None:
        return None
    k = np.ascontiguousarray(theta.reshape(N, -1))
    cones.weighted_difference(k, cp.coeffs, cp.w, e)
    z1 = -rho[:, None] * e[:, 1:]
    norms = np.sqrt(np.sum(z1**2, axis=1, keepdims=True))
    z1 *= np.minimum(1.0, WARM_MAX_DUAL_NORM / np.maximum(norms, np.finfo(float).tiny))
    return k, z1


def warm_dual(previous: InteriorPointResult, cp: ConicProblem) -> np.ndarray:
    """The previous solution's cone duals z₁, rescaled to the new weights (n_cones, g).

    Stationarity 2Φᵀ(Φk − y) = DᵀΛz₁ holds at the previous optimum k with the
    previous weights; z₁·Λ_prev/Λ_new keeps it exact at the same k. With larger
    weights (a path of increasing λ) every cone's dual stays inside its cone, so
    the start is primal and dual feasible with only the gap to close; with
    smaller ones a dual that leaves its cone is pulled back to the norm
    WARM_MAX_DUAL_NORM (the step then also corrects the stationarity residual).
    """
    if previous.dual is None or previous.weights is None:
        raise ValueError("warm_dual: the previous solution holds no duals to start from")
    ratio = np.where(cp.w > 0, previous.weights / np.where(cp.w > 0, cp.w, 1.0), 0.0)
    rows = cp.N - cp.degree
    z1 = (previous.dual.reshape(rows, cp.K) * ratio).reshape(cp.n_cones, -1)
    norms = np.sqrt(np.sum(z1**2, axis=1, keepdims=True))
    return z1 * np.minimum(1.0, WARM_MAX_DUAL_NORM / np.maximum(norms, np.finfo(float).tiny))


def interpolated_start(
    lower: InteriorPointResult, upper: InteriorPointResult, weights: np.ndarray
) -> InteriorPointResult | None:
    """A warm start at weights between two solutions of a λ path: their convex combination.

    With Λ = (1 − θ)Λ_a + θΛ_b (weights proportional to one pattern, the
    solutions' at Λ_a and Λ_b), the pair k = (1 − θ)k_a + θk_b and
    Λz₁ = (1 − θ)Λ_a z₁ᵃ + θΛ_b z₁ᵇ satisfies the stationarity
    2Φᵀ(Φk − y) = DᵀΛz₁ exactly (it is affine in (k, Λz₁)), and every cone's
    ‖z₁‖ <= ((1 − θ)λ_a + θλ_b)/λ = 1: the start is primal and dual feasible,
    like the single neighbour's (:func:`warm_dual`), and its k is closer to the
    new optimum (on the L-curve's refinements of jump-linear fits, order 1,
    about one iteration fewer per candidate).

    Parameters
    ----------
    lower, upper : InteriorPointResult
        Solutions (with duals) at weights Λ_a = a·W and Λ_b = b·W, a < b.
    weights : ndarray, shape (K,)
        Λ = λ·W with a < λ < b.

    Returns
    -------
    InteriorPointResult or None
        A start only (objective and residuals NaN, not converged), for
        ``warm_start`` of :func:`fit_sparse_ipm`; None when either solution has
        no duals or the weights are not one pattern scaled.
    """
    if lower.dual is None or upper.dual is None or lower.weights is None:
        return None
    if upper.weights is None or np.any(np.isinf(weights)) or np.any(weights <= 0):
        return None
    a = lower.weights / weights
    b = upper.weights / weights
    # One pattern: the ratios are constant over the coefficients (to rounding).
    if np.ptp(a) > 1e-12 * a.max() or np.ptp(b) > 1e-12 * b.max() or not a[0] < 1.0 < b[0]:
        return None
    share = (1.0 - a[0]) / (b[0] - a[0])  # θ: λ = (1 − θ)a·λ + θb·λ
    return InteriorPointResult(
        theta=(1.0 - share) * lower.theta + share * upper.theta,
        objective=np.nan,
        duality_gap=np.nan,
        primal_residual=np.nan,
        dual_residual=np.nan,
        iterations=0,
        converged=False,
        dual=(1.0 - share) * a[0] * lower.dual + share * b[0] * upper.dual,
        weights=np.array(weights, dtype=float),
    )


def fit_sparse_ipm(
    problem: RegressionProblem,
    weights: np.ndarray,
    norm: str,
    *,
    tol: float = 1e-8,
    max_iter: int = 100,
    k0: np.ndarray | None = None,
    warm_start: InteriorPointResult | None = None,
) -> InteriorPointResult:
    """Minimize Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ(Dk)_t) by a primal-dual interior-point method.

    Parameters
    ----------
    problem : RegressionProblem
    weights : ndarray, shape (K,)
        λ_j > 0 per coefficient; inf holds coefficient j constant in time.
    norm : {"group", "l1"}
    tol : float
        Stop when the duality gap relative to the objective and both
        residuals relative to the data scale are below ``tol``.
    max_iter : int
        Limit on the number of iterations.
    k0 : ndarray, shape (N, K), optional
        Starting coefficients (default: zeros).
    warm_start : InteriorPointResult, optional
        The solution of the same problem at other weights (a regularization
        path): first the active-set polish of its split (see WARM_POLISH_ACTIVE),
        which ends the fit where it certifies the answer; otherwise a start from
        its k and its duals rescaled by :func:`warm_dual`, with a small gap; group
        cones from WARM_REWEIGHT_STEPS reweighted fits from its k
        (:func:`reweighted_start`). Taken for order 1 (see WARM_DEGREES) without
        constant coefficients, ignored otherwise.

    Returns
    -------
    InteriorPointResult
    """
    cp = ConicProblem(problem, weights, norm)
    N, K, n_cones = cp.N, cp.K, cp.n_cones
    separate = (
        problem.degree in SEPARATE_STEP_DEGREES and not cp.const.any() and not cp.systems[0].wide
    )
    t = np.zeros(n_cones)
    s, z = np.zeros(cp.cone_shape), np.zeros(cp.cone_shape)
    r_z, r_k = np.empty(cp.cone_shape), np.empty((N, K))
    rho = z1 = None
    warm_from = (  # the solution to start from, if its start is taken
        warm_start
        if warm_start is not None
        and warm_start.dual is not None
        and not cp.const.any()
        and problem.degree in WARM_DEGREES
        else None
    )
    warm = warm_from is not None
    if (
        warm_from is not None
        and warm_from.dual is not None  # (always: for the type checker)
        and norm in WARM_POLISH_ACTIVE
        and WARM_POLISH_SPLITS > 0
        and N * K * K >= WARM_POLISH_MIN_WORK[norm]
    ):
        polished_result = path_polish(
            problem,
            weights,
            norm,
            warm_from.theta.reshape(N, K),
            warm_from.dual,
            tol,
            WARM_POLISH_SPLITS,
            WARM_POLISH_ACTIVE[norm],
        )
        if polished_result is not None:
            return _polished(problem, polished_result, weights, n_cones, iterations=0)
    if warm_from is not None:
        k = np.array(warm_from.theta.reshape(N, K))
        reweighted = None
        if WARM_REWEIGHT_STEPS and norm == "group":
            reweighted = reweighted_start(problem, cp, k, WARM_REWEIGHT_STEPS)
        if reweighted is not None:  # then the reweighted start's gap
            (k, z1), warm = reweighted, False
        else:
            z1 = warm_dual(warm_from, cp)
    elif k0 is not None:
        k = np.array(k0, dtype=float)
    elif problem.degree in (1, 2) and not cp.const.any():
        k, rho = feasible_start(problem, cp)
        steps = WIDE_REWEIGHT_STEPS if cp.systems[0].wide else REWEIGHT_STEPS
        if steps and norm == "group" and rho is not None:
            reweighted = reweighted_start(problem, cp, k, steps)
            if reweighted is not None:
                k, z1 = reweighted
    else:  # measured for orders 1 and 2 only
        k = np.zeros((N, K))
    loss, reg, *_ = cones.kkt_residuals(k, t, s, z, cp.y, cp.phi, cp.coeffs, cp.w, r_z, r_k)
    # Start: s = (‖s₁‖ + δ, ΛDk) with t = s₀, so the cone constraints hold, and
    # z = (1, −ρΛDk), stationary for the quadratic fit k (see feasible_start),
    # the previous solution's duals (warm_dual), the reweighted fits' duals
    # (reweighted_start), or z = e, which makes the gap δ per cone, a fraction
    # of the objective. The reweighted duals z₁ = −ρ_c s₁ point against s₁, and
    # s ∘ z = (s₀ − ‖z₁‖‖s₁‖, (‖s₁‖ − ‖z₁‖s₀) s₁/‖s₁‖): a cone whose s₁ is large
    # against δ (a change) would start far from its central path, where the
    # first steps stay short. Its s₀ = ‖s₁‖/‖z₁‖ (when larger than ‖s₁‖ + δ)
    # puts it on that path, s ∘ z = μ_c e with μ_c = ‖s₁‖(1 − ‖z₁‖²)/‖z₁‖. On
    # 36 fits of jump systems with K = 35 and 60 (order 1, T = 1000 and 4000,
    # seeds 0-2, λ = 0.03-0.3 λ_max, tol 1e-6) 236 iterations instead of 268,
    # the same optima; order 2 (K = 20 and 35, T = 300 and 1000) about as many
    # (427 against 429). Wide blocks only: narrow ones gain too (narrow jump
    # systems, T = 300 and 2000: 230 iterations instead of 260), but their
    # iterates move within the tolerance, and with them the L-curve's corner on
    # 2 of the 80 series of benchmarks/bench_lcurve_choices.py.
    s[:, 1:] = -r_z[:, 1:]
    fraction = START_GAP_FRACTION
    if warm:
        fraction = WARM_GAP_FRACTION
    elif z1 is not None:
        fraction = REWEIGHT_GAP_FRACTION
    delta = max(fraction * (loss + reg) / n_cones, 1e-12)
    s_norms = np.sqrt(np.sum(s[:, 1:] ** 2, axis=1))
    s[:, 0] = s_norms + delta
    if CENTRED_START and cp.systems[0].wide and z1 is not None and not warm:
        z_norms = np.sqrt(np.sum(z1**2, axis=1))
        np.maximum(s[:, 0], s_norms / np.maximum(z_norms, np.finfo(float).tiny), out=s[:, 0])
    t[:] = s[:, 0]
    z[:, 0] = 1.0
    if z1 is not None:
        z[:, 1:] = z1
    elif rho is not None:
        z[:, 1:] = -rho * s[:, 1:]
    scale_k = stationarity_scale(problem)
    converged = stalled = False
    polished_result = None  # the active-set polish's, early or at the end
    early_polish = (
        EARLY_POLISH_GAP > 0
        and norm == "group"
        and problem.degree == 1
        and cp.systems[0].wide
        and not cp.const.any()
    )
    iterations = 0
    while True:
        loss, reg, gap, rz_norm, s_norm, rk_norm, rt_max = cones.kkt_residuals(
            k, t, s, z, cp.y, cp.phi, cp.coeffs, cp.w, r_z, r_k
        )
        if cp.const.any():
            rk_norm = cp.dual_residual_norm(r_k)
        objective = loss + reg
        primal_res = rz_norm / (1.0 + s_norm)
        dual_res = max(rk_norm / scale_k, rt_max)
        if gap <= tol * max(objective, 1e-300) and primal_res <= tol and dual_res <= tol:
            converged = True
            break
        if iterations == max_iter:
            break
        if early_polish and gap <= EARLY_POLISH_GAP * objective:
            early_polish = False  # once
            limit = max(int(EARLY_POLISH_ACTIVE * n_cones), EARLY_POLISH_MIN_ACTIVE)
            polished_result = polish(
                problem, weights, norm, k, s, z, tol, EARLY_POLISH_SPLITS, limit
            )
            if polished_result is not None:
                break
        # Predictor (affine) step, target −λ∘λ; then Mehrotra's corrector with the
        # target σμe − λ∘λ − (W⁻¹Δs_a) ∘ (WΔz_a), σ = (1 − α_a)³.
        try:
            newton = NewtonSystem(cp, s, z, r_z, r_k)
            dk, dt, ds, dz, (step, dual_step) = newton.predictor_corrector(gap)
        except SingularProblemError as exc:
            if iterations == 0:
                raise (dominating_output(problem) or exc) from None
            # Near the optimum the scaling of cones at their vertex grows without
            # bound; when it costs positive definiteness at working precision, or a
            # cone's s or z is at its boundary in rounding (separate steps can take s
            # there first at tight tolerances, e.g. 1e-11), the current iterate is as
            # accurate as this arithmetic allows (the polish below may certify it).
            stalled = True
            break
        iterations += 1
        if not separate:
            step = dual_step = min(step, dual_step)
        step, dual_step = min(1.0, STEP_FRACTION * step), min(1.0, STEP_FRACTION * dual_step)
        if min(step, dual_step) < MIN_STEP:
            stalled = True
            break
        cones.take_step(k, dk, t, dt, s, ds, z, dz, step, dual_step)
    unsolved = polished_result is None and not converged
    if unsolved and problem.degree in (1, 2) and not cp.const.any():
        # Near a degenerate optimum the Newton systems lose definiteness before
        # the gap closes; the active-set polish often still certifies an optimum.
        polished_result = polish(problem, weights, norm, k, s, z, tol)
    if polished_result is not None:
        return _polished(problem, polished_result, weights, n_cones, iterations)
    if not converged:
        reason = (
            "stalled at the limit of working precision"
            if stalled
            else f"did not converge in {max_iter} iterations"
        )
        warn(
            f"the interior-point method {reason} (relative gap "
            f"{gap / max(objective, 1e-300):.1e}, relative residuals {primal_res:.1e} and "
            f"{dual_res:.1e}; tolerance {tol:.0e}); increase max_iter or loosen tol",
            ConvergenceWarning,
        )
    return InteriorPointResult(
        theta=k.reshape(N, problem.n, problem.p),
        objective=objective,
        duality_gap=gap,
        primal_residual=primal_res,
        dual_residual=dual_res,
        iterations=iterations,
        converged=converged,
        stalled=stalled and not converged,
        dual=z[:, 1:].copy(),
        weights=weights,
    )


def _polished(
    problem: RegressionProblem,
    result: PolishResult,
    weights: np.ndarray,
    n_cones: int,
    iterations: int,
) -> InteriorPointResult:
    """The interior-point result of a fit that the active-set polish certified, with the
    certificate's duals (z₁ = −u: the iterate's would not match its k)."""
    return InteriorPointResult(
        theta=result.k.reshape(problem.N, problem.n, problem.p),
        objective=result.objective,
        duality_gap=result.duality_gap,
        primal_residual=0.0,
        dual_residual=result.dual_residual,
        iterations=iterations,
        converged=True,
        polished=True,
        stalled=False,
        dual=-result.dual.reshape(n_cones, -1),
        weights=weights,
    )
