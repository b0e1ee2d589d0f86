"""Huber and Laplacian losses with the group or l1 penalty, in one interior-point method.

The interior-point method of :mod:`.ipm` with two more cones per residual
entry e (row j of step t of a single-output problem, rows scaled by √w):

* Huber, Σ h_δ̃(r) with h_δ(r) = min_w (r − w)² + 2δ|w|:

      minimize Σ (r_e − w_e)² + Σ c_e b_e + Σ_c t_c,   c_e = 2δ̃_e,
      subject to σ±_e = b_e ∓ w_e >= 0;

* Laplace, Σ s|r̃|:

      minimize Σ c_e b_e + Σ_c t_c,   c_e = s_e,
      subject to σ±_e = b_e ∓ r_e >= 0,

with r = y − φᵀk and the group/l1 cones (t_c, (ΛDk)_c) of :mod:`.ipm`
(:func:`fit_robust_ipm`), or the squared-difference penalty
(:func:`fit_robust_ipm_squared`).

Each entry's variables (w, b, their duals ζ±) are eliminated from the Newton
equations in closed form (a 2 × 2 orthant per entry: g± = ζ±/σ±), which
leaves the block-banded system of :mod:`.ipm` with the data block
Σ_e d_e φ_eφ_eᵀ instead of 2ΦᵀΦ: d_e = 2κ/(2 + κ) (Huber) or κ (Laplace),
κ = 4g⁺g⁻/(g⁺ + g⁻). The same banded factorization serves the predictor and
Mehrotra's corrector; steps keep σ, ζ and the cones interior. Derivation in
the comments of :func:`_Entries.eliminate`.

Stops when the duality gap (cones and orthants) relative to the objective and
the residuals of stationarity (in k, w, b and t) and of the cone constraints
are below ``tol``: an optimality certificate of the convex problem.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from ..errors import ConvergenceWarning, SingularProblemError, warn
from . import conekernels as cones
from .banded import (
    BlockFactor,
    BlockSystem,
    WeightedRowsFactor,
    WeightedRowsKalman,
    long_series_size,
)
from .blockkernels import block_size
from .ipm import MIN_STEP, STEP_FRACTION, ConicProblem, NewtonSystem, feasible_start
from .precompiled import attach
from .problem import RegressionProblem, apply_difference, apply_difference_adjoint
from .sparse_common import difference_preimage

__all__ = [
    "RobustIPMResult",
    "fit_laplace_ipm_diagonal",
    "fit_robust_ipm",
    "fit_robust_ipm_squared",
]

# The starting slack of each entry's orthant, relative to the median |r| (Huber's;
# Laplace's: LAPLACE_START_SLACK); and how far inside [0, c] the starting duals ζ± sit.
START_SLACK = 0.1
START_DUAL_SHRINK = 0.9
# Iterative refinement of the Newton steps of order 2 and higher (_solved): at most
# this many, until the residual is within REFINE_TOL of the right-hand side. On wide
# jump systems (l1 and group, T = 400, 54 fits of order 2 at the default tol) 13 stalled
# short of tol without, 5 with one refinement, 4 with two; their time 28.7 s, 28.6 s and
# 32.1 s (fewer stalled iterations pay for the extra solves). Huber: 11 and 6 (one
# refinement), 16.0 s and 17.7 s. Order 1 never stalled there.
REFINEMENTS = 1
REFINE_TOL = 1e-12
# From a given start, the cone duals' norms are capped here (0.5 took 12
# iterations on the jump-linear benchmark, 0.9 took 14, 0.99 took 17).
WARM_DUAL_NORM = 0.5
# fit_laplace_ipm_diagonal's starting slack, relative to the median |r| (benchmark
# "sq", T = 1e5, with the pairing 2r clipped: 0.1 took 52 iterations over its
# three outputs, 1 took 38, 3 took 35; the sign pairing and 0.1 took 61).
LAPLACE_START_SLACK = 1.0
# Each starting slack is at least this fraction of its |r| (where the typical |r| is far
# smaller, e.g. 0 when most rows are fitted exactly, a smaller slack is lost in b = |r| +
# slack, which leaves σ = 0).
LAPLACE_SLACK_FLOOR = 1e-8
# For a first difference, fit_laplace_ipm_diagonal starts instead from this many
# reweighted least-squares steps (weights c/(|r| + h)) from the squared-loss fit, h this
# fraction of its median |r|, with the slacks 2h and the pairing c·r/(|r| + h): a point
# near the central path (σ±ζ± within [ch, 2ch]) where k is nearly stationary. On the
# benchmark "sq" (T = 1e5) the outputs' iterations went from 14/11/13 to 10/9/8 (a step
# costs about a third of an iteration); h = 0.1 took 13 iterations, 0.3 and 0.5 took
# 10, and more steps (6, 8) 10 or 9.
LAPLACE_IRLS_STEPS = 4
LAPLACE_IRLS_SMOOTHING = 0.3
# fit_laplace_ipm_diagonal keeps a Kalman solution of a Newton system whose relative
# residual is at most this (the block Cholesky's are about 1e-14; the covariance
# form's grow with the largest row weight, to 1e-9 at 4e6 on the benchmark "sq").
# A direction that far from exact only perturbs the iterate at the level of
# the stopping test's residuals' rounding (tol 1e-6): the last directions of the
# benchmark "sq" (residuals 1.4e-9 and 3.7e-10) gave the same objective to 1e-16
# relative unrefined as refined (also at T = 2e3 to 3e4, 5 % and 20 % outliers),
# with the same iterations, and their 4 replayed solves and 6 residual passes
# (about 7 % of the fit at T = 1e5) are saved; 1e-10 refined them.
KALMAN_RESIDUAL = 1e-8
# A Kalman solution over that residual is first refined this many times (each a
# replayed solve with the residual as right-hand side); only if it is still over
# is the output factored. On the benchmark "sq" (T = 1e5) one refinement brought
# the last iterations' residuals (3.7e-10 and 1.2e-9) to 1e-13; each had cost a
# factorization (about two iterations' time) before.
KALMAN_REFINEMENTS = 2


@dataclass
class RobustIPMResult:
    """What :func:`fit_robust_ipm` computes for one single-output part."""

    k: np.ndarray  # (N, K)
    objective: float  # the loss plus Σ_t R(Λ(Dk)_t)
    duality_gap: float  # relative to the objective
    dual_residual: float  # relative stationarity residual
    iterations: int
    converged: bool
    stalled: bool
    psi: np.ndarray  # (N, q): ζ⁺ − ζ⁻, the loss's gradient pairing (Laplace dual · s)


def fit_robust_ipm(
    part: RegressionProblem,
    weights: np.ndarray,
    norm: str,
    loss: str,
    costs: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    start: np.ndarray | None = None,
) -> RobustIPMResult:
    """Minimize the loss plus the sparse penalty of a single-output problem (module docstring).

    Parameters
    ----------
    part : RegressionProblem
        One output (n = 1): rows scaled by √w, unobserved rows zero.
    weights : ndarray, shape (K,)
        λ_j > 0, all finite.
    norm : {"group", "l1"}
    loss : {"huber", "laplace"}
    costs : ndarray, shape (N, q)
        c_e per row: 2δ̃ (Huber thresholds δ̃ = δ√w) or s = √w (Laplace).
    tol, max_iter
        Relative tolerance of the certificate; iterations at most.
    start : ndarray, shape (N, K), optional
        Starting coefficients (e.g. the squared-loss fit). The cone duals then
        start from the loss's gradient there, u = Λ⁻¹(DDᵀ)⁻¹D∇L (the duals that
        make k stationary), shrunk into the cones' interior. Default: the
        quadratic fit of :func:`.ipm.feasible_start`. On the jump-linear
        benchmark (T = 1e4, Huber, group) the squared-loss start took 12
        iterations instead of 16.
    """
    # Wide group blocks by Cholesky, not by explicit inverses: the residual cones' weights
    # grow without bound near the optimum. Laplace fits of K = 15 and 24 (T = 40, order 1,
    # three seeds, three λ, tol 1e-6 and 1e-9) ended short of their tolerance in 23 of 36
    # cases with the inverses (5 of 18 at 1e-6), at gaps up to 3e-4; by Cholesky none did.
    # Its price on jump systems (the same iterations): K = 12-15 1.0-1.3x at T = 400 and
    # 1.4-1.7x at T = 2000-10^4; K = 24-60 1.3-2.5x.
    cp = ConicProblem(part, weights, norm, block_inverses=False)
    entries = _Entries(part, loss, costs)
    data_phi = cp.phi
    n_cones = cp.n_cones
    if start is not None:
        k, rho = np.array(start, dtype=float), None
    elif part.degree in (1, 2):
        k, rho = feasible_start(part, cp)
    else:
        k, rho = np.zeros((cp.N, cp.K)), None
    entries.start(k)
    t = np.zeros(n_cones)
    s, z = np.zeros(cp.cone_shape), np.zeros(cp.cone_shape)
    r_z, r_k = np.empty(cp.cone_shape), np.empty((cp.N, cp.K))
    cones.weighted_difference(k, cp.coeffs, cp.w, r_z)
    size = np.sqrt(np.sum(r_z[:, 1:] ** 2, axis=1))
    objective = entries.loss(k) + float(size.sum())
    s[:, 1:] = r_z[:, 1:]
    s[:, 0] = size + max(0.1 * objective / n_cones, 1e-12)
    t[:] = s[:, 0]
    z[:, 0] = 1.0
    if rho is not None:
        z[:, 1:] = -rho * s[:, 1:]
    elif start is not None:  # the duals that make k stationary (DᵀΛu = ∇L), inside the cones
        entries.refresh(k)
        u = (difference_preimage(entries.gradient(k), cp.coeffs) / cp.w).reshape(n_cones, -1)
        norms = np.linalg.norm(u, axis=1)
        z[:, 1:] = u * (WARM_DUAL_NORM / np.maximum(norms, WARM_DUAL_NORM))[:, None]
    degree = n_cones + 2 * entries.count
    converged = stalled = False
    iterations = 0
    gap = dual_res = np.inf
    while True:
        entries.refresh(k)
        # residuals of the cone constraints and of stationarity in k (data + cones)
        cones.weighted_difference(k, cp.coeffs, cp.w, r_z)
        r_z[:, 0] = s[:, 0] - t
        r_z[:, 1:] = s[:, 1:] - r_z[:, 1:]
        r_k[:] = entries.gradient(k)
        cones.add_weighted_difference_adjoint(z, cp.coeffs, cp.w, -1.0, r_k)
        reg = float(np.sqrt(np.sum((s[:, 1:] - r_z[:, 1:]) ** 2, axis=1)).sum())
        objective = entries.loss(k) + reg
        gap = float(np.sum(s * z)) + entries.gap()
        primal_res = float(np.linalg.norm(r_z)) / (1.0 + float(np.linalg.norm(s)))
        dual_res = max(
            float(np.linalg.norm(r_k)) / entries.scale,
            float(np.abs(1.0 - z[:, 0]).max(initial=0.0)),
            entries.residual(),
        )
        if gap <= tol * max(objective, 1e-300) and primal_res <= tol and dual_res <= tol:
            converged = True
            break
        if not entries.interior():  # a slack or dual underflowed to the boundary
            stalled = True
            break
        if iterations == max_iter:
            break
        cp.phi = entries.scaled_regressors(data_phi)  # the data block Σ d_e φφᵀ
        try:
            newton = NewtonSystem(cp, s, z, r_z, r_k)
            work, rhs = newton.rhs_for(newton.predictor_target())
            affine = entries.eliminate(-entries.complementarity())
            rhs += affine.rhs
            dk, _, ds_a, dz_a, cone_steps = newton.finish(_solved(cp, newton, rhs, True), work)
        except SingularProblemError:
            if iterations == 0:
                raise
            stalled = True  # the scaling lost definiteness at working precision
            break
        iterations += 1
        step = min(1.0, *cone_steps, affine.step(dk))
        mu = gap / degree
        sigma_mu = (1.0 - step) ** 3 * mu
        # Mehrotra's corrector, for the cones (conekernels) and the orthants
        target = newton.corrector_target(ds_a, dz_a, sigma_mu)
        orthant_target = sigma_mu - entries.complementarity() - affine.second_order(dk)
        work, rhs = newton.rhs_for(target)
        direction = entries.eliminate(orthant_target)
        rhs += direction.rhs
        dk, dt, ds, dz, cone_steps = newton.finish(_solved(cp, newton, rhs, False), work)
        step = min(1.0, STEP_FRACTION * min(*cone_steps, direction.step(dk)))
        if step < MIN_STEP:
            stalled = True
            break
        cones.take_step(k, dk, t, dt, s, ds, z, dz, step, step)
        entries.take_step(direction, dk, step)
    cp.phi = data_phi
    if not converged:
        reason = (
            "stalled at the limit of working precision"
            if stalled
            else f"did not converge in {max_iter} iterations"
        )
        warn(
            f"the interior-point method {reason} (relative gap "
            f"{gap / max(objective, 1e-300):.1e}, dual residual {dual_res:.1e})",
            ConvergenceWarning,
        )
    return RobustIPMResult(
        k=k,
        objective=objective,
        duality_gap=gap / max(objective, 1e-300),
        dual_residual=dual_res,
        iterations=iterations,
        converged=converged,
        stalled=stalled and not converged,
        psi=entries.pairing(),
    )


def _solved(cp: ConicProblem, newton: NewtonSystem, rhs: np.ndarray, factor: bool):
    """The Newton step H⁻¹ rhs (N, K), factoring H first if ``factor``; for differences
    of order 2 and higher refined.

    Near the optimum the residual cones' weights grow without bound and H's
    conditioning with them (the more so for a second difference): a step solved
    once carries errors that undo its progress in stationarity. Each refinement
    solves for the residual rhs − H·step with the same factor (at most REFINEMENTS,
    until the residual is within REFINE_TOL of rhs). The residual is itself
    computed in working precision, so that refinement cannot remove all of it:
    a few fits still stall.
    """
    refine = cp.degree >= 2 and not cp.const.any()  # (the constants' border: not refined)
    target = rhs.copy() if refine else rhs  # (the solves overwrite rhs)
    step = cp.factor_and_solve(newton, rhs) if factor else cp.solve(rhs)
    for _ in range(REFINEMENTS if refine else 0):
        residual = target - cp.newton_product(newton, step)
        if not np.linalg.norm(residual) > REFINE_TOL * np.linalg.norm(target):
            break
        step += cp.solve(residual)
    return step


def fit_robust_ipm_squared(
    part: RegressionProblem,
    W: np.ndarray,
    loss: str,
    costs: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    start: np.ndarray,
) -> RobustIPMResult:
    """The same with the squared-difference penalty Σ_t (Dk)_tᵀ W (Dk)_t instead of cones.

    The Newton system is then (Σ_e d_e φ_eφ_eᵀ + 2DᵀWD)Δk = rhs, one block-banded
    factorization per iteration (a weighted squared-loss fit's matrix), used by
    the predictor and the corrector.

    Parameters
    ----------
    part : RegressionProblem
        One output (n = 1).
    W : ndarray, shape (p,) or (p, p)
        Its penalty weight, finite.
    loss, costs, tol, max_iter
        As in :func:`fit_robust_ipm`.
    start : ndarray, shape (N, p)
        Starting coefficients (the squared-loss fit).
    """
    entries = _Entries(part, loss, costs)
    N, coeffs = part.N, part.coeffs
    Wm = np.diag(W) if W.ndim == 1 else W
    k = np.array(start, dtype=float)
    entries.start(k)
    degree = 2 * entries.count
    converged = stalled = False
    iterations, gap, dual_res, objective = 0, np.inf, np.inf, np.inf
    while True:
        entries.refresh(k)
        WDk = apply_difference(k, coeffs) @ Wm
        r_k = entries.gradient(k) + 2.0 * apply_difference_adjoint(WDk, coeffs, N)
        objective = entries.loss(k) + float(np.sum(WDk * apply_difference(k, coeffs)))
        gap = entries.gap()
        dual_res = max(float(np.linalg.norm(r_k)) / entries.scale, entries.residual())
        if gap <= tol * max(objective, 1e-300) and dual_res <= tol:
            converged = True
            break
        if not entries.interior() or iterations == max_iter:  # interior: see fit_robust_ipm
            stalled = not entries.interior()
            break
        phi = entries.scaled_regressors(part.phi) * np.sqrt(2.0)  # Σ d φφᵀ
        try:
            factor = BlockFactor(
                BlockSystem(phi, 1, 1.0, np.zeros((0,) + Wm.shape), 2.0 * Wm, coeffs),
                "the interior-point Newton system",
            )
        except SingularProblemError:
            if iterations == 0:
                raise
            stalled = True
            break
        iterations += 1
        affine = entries.eliminate(-entries.complementarity())
        dk = factor.solve(np.ascontiguousarray((affine.rhs - r_k)[:, :, None]))[:, :, 0]
        step = min(1.0, affine.step(dk))
        sigma_mu = (1.0 - step) ** 3 * gap / degree
        direction = entries.eliminate(
            sigma_mu - entries.complementarity() - affine.second_order(dk)
        )
        dk = factor.solve(np.ascontiguousarray((direction.rhs - r_k)[:, :, None]))[:, :, 0]
        step = min(1.0, STEP_FRACTION * direction.step(dk))
        if step < MIN_STEP:
            stalled = True
            break
        k += step * dk
        entries.take_step(direction, dk, step)
    return RobustIPMResult(
        k=k,
        objective=objective,
        duality_gap=gap / max(objective, 1e-300),
        dual_residual=dual_res,
        iterations=iterations,
        converged=converged,
        stalled=stalled and not converged,
        psi=entries.pairing(),
    )


@dataclass
class _Direction:
    """One Newton direction's per-entry parts, before Δk is known."""

    rhs: np.ndarray  # (N, K) added to the banded system's right-hand side
    entries: _Entries
    target: np.ndarray  # (2, N, q) the orthant targets η±
    cached: tuple | None = None  # (Δk, its deltas)

    def deltas(self, dk: np.ndarray):
        """(Δw or None, Δb, Δσ (2, N, q), Δζ (2, N, q)) for the solution Δk (kept for reuse)."""
        if self.cached is None or self.cached[0] is not dk:
            self.cached = (dk, self.entries.deltas(self, dk))
        return self.cached[1]

    def step(self, dk: np.ndarray) -> float:
        """The largest step keeping every entry's σ± and ζ± positive."""
        _, _, d_sigma, d_zeta = self.deltas(dk)
        e = self.entries
        return min(_ratio(e.sigma, d_sigma, e.mask), _ratio(e.zeta, d_zeta, e.mask))

    def second_order(self, dk: np.ndarray) -> np.ndarray:
        """Δσ ∘ Δζ of this (affine) direction, for Mehrotra's corrector."""
        _, _, d_sigma, d_zeta = self.deltas(dk)
        return d_sigma * d_zeta


class _Entries:
    """The residual entries' variables: b, w (Huber), slacks σ± and duals ζ± (2, N, q)."""

    w: np.ndarray | None  # the residual beyond the threshold (Huber); None for Laplace

    def __init__(self, part: RegressionProblem, loss: str, costs: np.ndarray):
        self.loss_name = loss
        self.y = part.y[:, :, 0]
        self.phi = part.phi
        self.mask = part.observed & (costs > 0)  # entries that enter the loss
        self.c = np.where(self.mask, costs, 0.0)
        self.count = int(self.mask.sum())
        row_norms = np.sqrt(np.einsum("tjk,tjk->tj", self.phi, self.phi))
        # stationarity scale: the largest possible data gradient, ‖c·|φ|‖ (floored)
        self.scale = max(float(np.linalg.norm(self.c * row_norms)), np.finfo(float).tiny)

    # -- state ----------------------------------------------------------------------------
    def start(self, k: np.ndarray) -> None:
        r = self.residuals(k)
        c = self.c
        if self.loss_name == "huber":
            spread = float(np.median(np.abs(r[self.mask]))) if self.count else 1.0
            slack = START_SLACK * np.maximum(np.where(self.mask, spread, 1.0), 1e-300)
            delta = c / 2.0
            self.w = np.where(self.mask, r - np.clip(r, -delta, delta), 0.0)
            self.b = np.abs(self.w) + slack
            pairing = 2.0 * START_DUAL_SHRINK * np.clip(r, -delta, delta)
        else:
            # As fit_laplace_ipm_diagonal's start: the squared-loss start's own pairing 2r
            # clipped into the box, which leaves k stationary except through its outliers
            # (with the cone duals that make it so), and a slack of LAPLACE_START_SLACK
            # typical |r|. On wide jump systems (l1 and group, orders 1 and 2, T = 400) and
            # the jump-linear system (T = 10⁴): 583 iterations in all instead of 781 with
            # the pairing sign(r)·0.9c and a slack of 0.1 median |r|; slacks of 0.3 and 3
            # typical |r| took 635 and 529.
            self.w = None
            typical = np.where(self.mask, _typical_size(r[self.mask]), 1.0)
            slack = np.maximum(LAPLACE_START_SLACK * typical, LAPLACE_SLACK_FLOOR * np.abs(r))
            self.b = np.abs(r) + slack
            pairing = np.clip(2.0 * r, -START_DUAL_SHRINK * c, START_DUAL_SHRINK * c)
        # ζ⁺ + ζ⁻ = c (stationarity in b), ζ⁺ − ζ⁻ a shrunk pairing: both >= 0.05c > 0;
        # entries outside the loss are frozen at σ = ζ = 1 and never move
        self.zeta = np.stack(
            [
                np.where(self.mask, (c + pairing) / 2.0, 1.0),
                np.where(self.mask, (c - pairing) / 2.0, 1.0),
            ]
        )
        self.refresh(k)

    def _slacks(self, r: np.ndarray) -> np.ndarray:
        inner = self.w if self.w is not None else r
        sigma = np.stack([self.b - inner, self.b + inner])
        return np.where(self.mask, sigma, 1.0)

    def take_step(self, direction: _Direction, dk: np.ndarray, step: float) -> None:
        dw, db, d_sigma, d_zeta = direction.deltas(dk)
        mask = self.mask
        if dw is not None and self.w is not None:  # both set for Huber only
            self.w = self.w + step * np.where(mask, dw, 0.0)
        self.b = self.b + step * np.where(mask, db, 0.0)
        self.zeta = np.where(mask, self.zeta + step * d_zeta, 1.0)  # σ: refresh()

    # -- values ---------------------------------------------------------------------------
    def residuals(self, k: np.ndarray) -> np.ndarray:
        return self.y - np.einsum("tjk,tk->tj", self.phi, k)

    def loss(self, k: np.ndarray) -> float:
        """Σ h_δ̃(r) or Σ s|r̃| at k (the exact loss, not the lifted objective)."""
        r = np.where(self.mask, self.residuals(k), 0.0)
        if self.loss_name == "huber":
            delta = self.c / 2.0
            a = np.abs(r)
            return float(np.sum(np.where(a <= delta, r * r, 2.0 * delta * a - delta * delta)))
        return float(np.sum(self.c * np.abs(r)))

    def gradient(self, k: np.ndarray) -> np.ndarray:
        """The data part of the stationarity residual in k, (N, K)."""
        if self.loss_name == "huber":
            factor = -2.0 * (self.residuals(k) - self.w)
        else:
            factor = self.zeta[1] - self.zeta[0]
        return np.einsum("tj,tjk->tk", np.where(self.mask, factor, 0.0), self.phi)

    def residual(self) -> float:
        """Stationarity in b (and w), relative to the costs."""
        c_norm = max(float(np.linalg.norm(self.c)), np.finfo(float).tiny)
        r_b = np.where(self.mask, self.c - self.zeta[0] - self.zeta[1], 0.0)
        value = float(np.linalg.norm(r_b))
        if self.loss_name == "huber":
            value = max(value, float(np.linalg.norm(self._r_w())))
        return value / c_norm

    def _r_w(self) -> np.ndarray:
        r = self._last_r
        return np.where(self.mask, -2.0 * (r - self.w) + self.zeta[0] - self.zeta[1], 0.0)

    def interior(self) -> bool:
        """Every slack σ± and dual ζ± of the loss's entries is positive."""
        return bool(np.all(self.sigma[:, self.mask] > 0) and np.all(self.zeta[:, self.mask] > 0))

    def complementarity(self) -> np.ndarray:
        return np.where(self.mask, self.sigma * self.zeta, 0.0)

    def gap(self) -> float:
        return float(np.sum(self.complementarity()))

    def pairing(self) -> np.ndarray:
        """ζ⁺ − ζ⁻: at the optimum 2·clip(r, ±δ̃) (Huber) or s·ψ, ψ ∈ sign(r) (Laplace)."""
        return np.where(self.mask, self.zeta[0] - self.zeta[1], 0.0)

    def scaled_regressors(self, phi: np.ndarray) -> np.ndarray:
        """φ·√(d/2), so that the kernel's 2Φ̃ᵀΦ̃ is the data block Σ d_e φφᵀ."""
        d = self._curvature()
        return np.ascontiguousarray(phi * np.sqrt(d / 2.0)[:, :, None])

    def _terms(self):
        g = self.zeta / self.sigma
        G, H = g[0] + g[1], g[0] - g[1]
        kappa = 4.0 * g[0] * g[1] / G
        return G, H, kappa

    def _curvature(self) -> np.ndarray:
        _, _, kappa = self._terms()
        d = 2.0 * kappa / (2.0 + kappa) if self.loss_name == "huber" else kappa
        return np.where(self.mask, d, 0.0)

    # -- Newton directions ------------------------------------------------------------------
    def eliminate(self, target: np.ndarray) -> _Direction:
        """The per-entry elimination for the orthant targets η± (2, N, q).

        Linearizing σ±ζ± = η± gives Δζ± = η±/σ± − g±Δσ±. Huber (Δσ± = Δb ∓ Δw):
        stationarity in b, Δζ⁺ + Δζ⁻ = r_b, gives Δb = (E + HΔw)/G with
        E = η⁺/σ⁺ + η⁻/σ⁻ − r_b; then Δζ⁺ − Δζ⁻ = A + κΔw, A = F − HE/G,
        F = η⁺/σ⁺ − η⁻/σ⁻; stationarity in w, 2φᵀΔk + 2Δw + Δζ⁺ − Δζ⁻ = −r_w,
        gives Δw = −(r_w + A + 2φᵀΔk)/(2 + κ), and the k equation gains
        Σ d φφᵀ with d = 2κ/(2 + κ) and 2Σ φ(r_w + A)/(2 + κ) on the right.
        Laplace (Δσ± = Δb ± φᵀΔk): Δb = (E − HφᵀΔk)/G, Δζ⁻ − Δζ⁺ = −A + κφᵀΔk,
        so d = κ and the right-hand side gains Σ φA.
        """
        G, H, kappa = self._terms()
        r_b = self.c - self.zeta[0] - self.zeta[1]
        ratio = target / self.sigma
        E = ratio[0] + ratio[1] - r_b
        F = ratio[0] - ratio[1]
        A = F - H * E / G
        if self.loss_name == "huber":
            q = 2.0 * (self._r_w() + A) / (2.0 + kappa)
        else:
            q = A
        q = np.where(self.mask, q, 0.0)
        return _Direction(rhs=np.einsum("tj,tjk->tk", q, self.phi), entries=self, target=target)

    def deltas(self, direction: _Direction, dk: np.ndarray):
        G, H, kappa = self._terms()
        ratio = direction.target / self.sigma
        r_b = self.c - self.zeta[0] - self.zeta[1]
        E = ratio[0] + ratio[1] - r_b
        A = ratio[0] - ratio[1] - H * E / G
        g = self.zeta / self.sigma
        fitted = np.einsum("tjk,tk->tj", self.phi, dk)  # φᵀΔk
        if self.loss_name == "huber":
            dw = -(self._r_w() + A + 2.0 * fitted) / (2.0 + kappa)
            db = (E + H * dw) / G
            d_sigma = np.stack([db - dw, db + dw])
        else:
            dw = None
            db = (E - H * fitted) / G
            d_sigma = np.stack([db + fitted, db - fitted])
        d_zeta = ratio - g * d_sigma
        return dw, db, d_sigma, d_zeta

    def refresh(self, k: np.ndarray) -> None:
        """The residuals and slacks at k (Laplace's σ depends on k; Huber's on b, w)."""
        self._last_r = self.residuals(k)
        self.sigma = self._slacks(self._last_r)


def _ratio(x: np.ndarray, dx: np.ndarray, mask: np.ndarray) -> float:
    """The largest α with x + α·dx > 0 where ``mask`` (inf if none decreases)."""
    shrinking = mask & (dx < 0)
    if not shrinking.any():
        return np.inf
    return float(np.min(-x[shrinking] / dx[shrinking]))


def fit_laplace_ipm_diagonal(
    problem: RegressionProblem,
    weight: np.ndarray,
    costs: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    start: np.ndarray,
) -> list[RobustIPMResult]:
    """:func:`fit_robust_ipm_squared` (Laplace) for every output of ``problem`` at once,
    for a finite diagonal penalty weight, on compiled kernels.

    Each output c solves its own problem, minimize Σ s|r̃_c| + Σ_t (Dk_c)_tᵀ
    diag(w_c) (Dk_c)_t, by the iterations of :func:`fit_robust_ipm_squared`
    (Mehrotra predictor and corrector, step lengths, stopping rule) from a
    better centred start: the pairing ζ⁺ − ζ⁻ = 2r clipped to ±0.9c (which
    leaves the squared-loss start stationary except through its outliers) and
    a slack of LAPLACE_START_SLACK median |r| (for a first difference: from
    LAPLACE_IRLS_STEPS reweighted least-squares steps of the Laplace loss first,
    by the Kalman form, and their centred pairing; :func:`_reweighted_start`);
    the outputs still iterating are run in lockstep so that one sweep over
    time factors all their Newton systems (Σ_e κ_e φ_eφ_eᵀ + 2DᵀD ⊗ diag(w_c),
    :class:`~.banded.WeightedRowsFactor`), and the per-entry work (residuals,
    elimination, ratio tests, updates) is a few compiled passes per iteration.
    For a first difference both systems of an iteration are solved by the Kalman
    form instead (:class:`~.banded.WeightedRowsKalman`, the right-hand side as its
    general term; the corrector's solve replays the predictor's covariances and
    gains) as long as its solutions' relative residuals stay within
    KALMAN_RESIDUAL: the covariance form loses digits once the weights κ of the
    residuals tending to 0 grow large. A solution over it is refined (up to
    KALMAN_REFINEMENTS replayed solves of its residual, :func:`_refine`), and
    only where that fails does the factorization take over.

    Parameters
    ----------
    problem : RegressionProblem
        Rows scaled by √w, unobserved rows zero.
    weight : ndarray, shape (n, p)
        The penalty weight's diagonal of each output, finite.
    costs : ndarray, shape (N, q, n)
        c_e per entry (s = √w).
    tol, max_iter
        As in :func:`fit_robust_ipm`.
    start : ndarray, shape (N, n, p)
        Starting coefficients (the squared-loss fit).

    Returns
    -------
    list of RobustIPMResult
        One per output (its ``k`` of shape (N, p)).
    """
    N, q, n, p = problem.N, problem.q, problem.n, problem.p
    phi = np.ascontiguousarray(problem.phi, dtype=float)
    coeffs = np.ascontiguousarray(problem.coeffs, dtype=float)
    w2 = np.ascontiguousarray(2.0 * np.asarray(weight, dtype=float).reshape(n, p))
    mask_all = problem.observed[:, :, None] & (costs > 0)  # (N, q, n)
    mask = np.ascontiguousarray(mask_all.transpose(2, 0, 1))  # (n, N, q)
    c = np.ascontiguousarray(np.where(mask_all, costs, 0.0).transpose(2, 0, 1))
    y = np.ascontiguousarray(problem.y.transpose(2, 0, 1), dtype=float)
    k = np.ascontiguousarray(np.array(start, dtype=float).transpose(1, 0, 2))  # (n, N, p)
    # a first difference: both solves of an iteration by the Kalman form (the filter
    # runs twice, the second time replaying its covariances: cheaper than one
    # factorization and its substitutions), the right-hand side as its general term;
    # the outputs it leaves are factored
    kalman = WeightedRowsKalman(N, q, p, n) if WeightedRowsKalman.applies(coeffs, w2) else None
    size = long_series_size(N, p)  # p, or a tuple: a constant of the per-entry passes
    # the start: b = |r| + a slack, ζ± = (c ± pairing)/2 inside [0, c]
    r, objectives = np.empty((n, N, q)), np.empty(n)
    _laplace_residuals(phi, y, c, k, w2, coeffs, np.ones(n, dtype=np.bool_), r, objectives, size)
    smoothing, factors = None, None
    if LAPLACE_IRLS_STEPS > 0:
        smoothing = np.array(
            [LAPLACE_IRLS_SMOOTHING * _typical_size(r[i][mask[i]]) for i in range(n)]
        )
        factors = _reweighted_start(
            kalman, phi, y, c, mask, w2, coeffs, smoothing, k, r, objectives, size
        )
    b, zp, zm = np.empty((n, N, q)), np.empty((n, N, q)), np.empty((n, N, q))
    row_norms = np.sqrt(np.einsum("tjk,tjk->tj", phi, phi))
    tiny = np.finfo(float).tiny
    scale, c_norm, degree = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        m, ci = mask[i], c[i]
        count = int(m.sum())
        bound = START_DUAL_SHRINK * ci
        if smoothing is None:
            slack = LAPLACE_START_SLACK * np.where(m, _typical_size(r[i][m]), 1.0)
            # the start's own stationarity pairing (2r: the squared-loss fit's), clipped
            # into the box: k is then stationary except through the outliers
            pairing = np.clip(2.0 * r[i], -bound, bound)
        else:  # that of the reweighted steps (LAPLACE_IRLS_STEPS), centred
            slack = np.where(m, 2.0 * smoothing[i], 1.0)
            pairing = np.clip(ci * r[i] / (np.abs(r[i]) + smoothing[i]), -bound, bound)
        # a slack below |r|'s rounding would vanish in b (σ = b ∓ r = 0): keep it above
        b[i] = np.abs(r[i]) + np.maximum(slack, LAPLACE_SLACK_FLOOR * np.abs(r[i]))
        zp[i] = np.where(m, (ci + pairing) / 2.0, 1.0)
        zm[i] = np.where(m, (ci - pairing) / 2.0, 1.0)
        # (sums of squares: np.linalg.norm's BLAS dot waits on its threads on a busy machine)
        scale[i] = max(float(np.sqrt(np.sum((ci * row_norms) ** 2))), tiny)
        c_norm[i] = max(float(np.sqrt(np.sum(ci**2))), tiny)
        degree[i] = 2 * count
    del r
    sp, sm = np.empty((n, N, q)), np.empty((n, N, q))
    tp, tm = np.empty((n, N, q)), np.empty((n, N, q))
    a = np.zeros((N, q, n))
    rhs = np.empty((n, N, p, 1))
    r_k = np.empty((n, N, p))
    stats = np.zeros((n, 6))
    steps = np.empty(n)
    sigma_mu = np.zeros(n)
    active = np.ones(n, dtype=np.bool_)
    iterations = np.zeros(n, dtype=np.int64)
    converged = np.zeros(n, dtype=bool)
    stalled = np.zeros(n, dtype=bool)
    objective, gap, dual_res = np.full(n, np.inf), np.full(n, np.inf), np.full(n, np.inf)
    what = "the interior-point Newton system"
    # the Newton directions: solved in place in ``rhs`` by the factorization alone;
    # with the Kalman form into their own array (``rhs`` kept for its residual check)
    dk = rhs if kalman is None else np.empty((n, N, p, 1))
    work = np.empty((2, n, N, p) if kalman is not None else (2, n, 0, p))
    no_targets = np.zeros((N, q, n) if kalman is not None else (0, q, n))
    no_vector = np.empty((n, 0, p))
    residual = np.zeros(n)
    accurate = np.full(n, kalman is not None)  # the outputs the Kalman form still solves
    while active.any():
        _laplace_state(
            phi, y, c, mask, k, b, zp, zm, w2, coeffs, active, sp, sm, a, rhs, r_k, stats, size
        )
        for i in np.flatnonzero(active).tolist():
            objective[i] = stats[i, 0] + stats[i, 1]
            gap[i] = stats[i, 2]
            dual_res[i] = max(np.sqrt(stats[i, 3]) / scale[i], np.sqrt(stats[i, 4]) / c_norm[i])
            if gap[i] <= tol * max(objective[i], 1e-300) and dual_res[i] <= tol:
                converged[i], active[i] = True, False
            elif stats[i, 5] == 0.0 or iterations[i] == max_iter:
                stalled[i], active[i] = stats[i, 5] == 0.0, False
        if not active.any():
            break
        filtered = np.zeros(n, dtype=np.bool_)  # the outputs the Kalman form solved
        refined = np.zeros(n, dtype=np.bool_)  # those of them that needed refinement
        if kalman is not None and (active & accurate).any():
            which = active & accurate
            filtered = which & ~kalman.solve(
                phi, a, no_targets, w2, coeffs, which, dk[:, :, :, 0], linear=rhs[:, :, :, 0]
            )
            # the norms only: the residuals themselves are wanted for a refinement
            _newton_residual(phi, a, w2, coeffs, dk, rhs, filtered, no_vector, residual)
            off = filtered & ~(residual <= KALMAN_RESIDUAL)
            if off.any():
                _newton_residual(phi, a, w2, coeffs, dk, rhs, off, work[0], residual)
                refined = _refine(
                    kalman, phi, a, no_targets, w2, coeffs, off, rhs, dk, work, residual
                )
                filtered &= ~off | refined
            accurate &= ~which | filtered  # κ only grows: an output left is left for good
        need = active & ~filtered  # the outputs to factor
        factor = None
        if need.any():
            try:
                factor = WeightedRowsFactor(
                    phi, a, w2, coeffs, _copied(rhs, dk, need), need, out=factors, what=what
                )
            except SingularProblemError:
                # which outputs lost definiteness: those stop (before their first step: raise)
                before = int(active.sum())
                for i in np.flatnonzero(need).tolist():
                    only = np.zeros(n, dtype=np.bool_)
                    only[i] = True
                    try:
                        WeightedRowsFactor(phi, a, w2, coeffs, rhs.copy(), only, what=what)
                    except SingularProblemError:
                        if iterations[i] == 0:
                            raise
                        stalled[i], active[i] = True, False
                if int(active.sum()) == before:  # none alone: rounding in the joint sweep
                    stalled[active], active[:] = True, False
                continue
            factors = factor.L
            factor.finish(dk)  # the affine (predictor) direction
        iterations[active] += 1
        _laplace_affine(phi, c, mask, sp, sm, zp, zm, dk, active, tp, tm, steps, size)
        for i in np.flatnonzero(active).tolist():
            step = min(1.0, steps[i])
            sigma_mu[i] = (1.0 - step) ** 3 * gap[i] / max(degree[i], 1.0)
        _laplace_corrector(phi, c, mask, sp, sm, zp, zm, sigma_mu, r_k, active, tp, tm, rhs, size)
        if factor is not None:
            factor.solve(_copied(rhs, dk, need))
        if kalman is not None and filtered.any():
            # the predictor's matrices: the filter solves the same outputs again
            solved = filtered & ~kalman.solve(
                phi, a, no_targets, w2, coeffs, filtered, dk[:, :, :, 0],
                linear=rhs[:, :, :, 0], replay=True,
            )  # fmt: skip
            again = solved & refined  # as inaccurate as their predictors: refined too
            if again.any():
                _newton_residual(phi, a, w2, coeffs, dk, rhs, again, work[0], residual)
                off = again & ~_refine(
                    kalman, phi, a, no_targets, w2, coeffs, again, rhs, dk, work, residual
                )
                accurate &= ~off  # factored from the next iteration on
                if off.any():  # factored now if possible, else the best refined directions
                    trial = rhs.copy()
                    try:
                        WeightedRowsFactor(phi, a, w2, coeffs, trial, off, what=what).finish(trial)
                    except SingularProblemError:
                        pass
                    else:
                        dk[off] = trial[off]
            left = filtered & ~solved  # the filter left them (not expected: a replay)
            if left.any():
                rows = _copied(rhs, dk, left)
                WeightedRowsFactor(phi, a, w2, coeffs, rows, left, what=what).finish(rows)
        _laplace_step(
            phi, c, mask, sp, sm, zp, zm, dk, active, tp, tm, STEP_FRACTION, MIN_STEP, k, b, steps,
            size,
        )  # fmt: skip
        for i in np.flatnonzero(active).tolist():
            if steps[i] < MIN_STEP:
                stalled[i], active[i] = True, False
    psi = np.where(mask, zp - zm, 0.0)
    return [
        RobustIPMResult(
            k=np.ascontiguousarray(k[i]),
            objective=float(objective[i]),
            duality_gap=float(gap[i] / max(objective[i], 1e-300)),
            dual_residual=float(dual_res[i]),
            iterations=int(iterations[i]),
            converged=bool(converged[i]),
            stalled=bool(stalled[i] and not converged[i]),
            psi=psi[i],
        )
        for i in range(n)
    ]


def _typical_size(r: np.ndarray) -> float:
    """The median |r|, or where that is 0 (most entries exactly 0) their mean |r|, or 1.0
    where every entry is 0 (or there is none): a positive scale of the residuals."""
    size = float(np.median(np.abs(r))) if r.size else 0.0
    if not size > 0.0:
        size = float(np.mean(np.abs(r))) if r.size else 0.0
    return size if size > 0.0 and np.isfinite(size) else 1.0


def _reweighted_start(
    kalman: WeightedRowsKalman | None,
    phi: np.ndarray,
    y: np.ndarray,
    c: np.ndarray,
    mask: np.ndarray,
    w2: np.ndarray,
    coeffs: np.ndarray,
    smoothing: np.ndarray,
    k: np.ndarray,
    r: np.ndarray,
    objectives: np.ndarray,
    size: int | tuple,
) -> np.ndarray | None:
    """LAPLACE_IRLS_STEPS reweighted least-squares steps of Σ c|r| + Σ_t (Dk)ᵀ diag(w2/2) Dk
    from k (n, N, p), its residuals r = y − φᵀk (n, N, q) and these objectives (n,), all
    three updated in place; returns the factorization's storage, if one was used (for
    reuse).

    Each step minimizes the majorizer Σ c r²/(2m) + the penalty with m = |r| + h (the
    last residuals, h = ``smoothing`` (n,) per output): H = Σ (c/m) φφᵀ + DᵀD ⊗ diag(w2)
    with the right-hand side Σ (c/m) y φ, by the Kalman form (``kalman``, the
    targets (c/m)·y) or else the factorization; its optimum is stationary with the
    pairing c·r/m. An output the Kalman form leaves is factored. The steps decrease the
    objective; an output whose step does not (rounding: a regressor far beyond the
    others'), or whose system is singular, keeps its last k and stops (``size``: p or
    a tuple of length p, :func:`~.banded.long_series_size`). The rows, the
    residuals and the objectives are compiled passes (:func:`_reweighted_rows`,
    :func:`_laplace_residuals`): as numpy expressions their temporaries were half the
    time of the steps at T = 1e5.
    """
    n, N, q = r.shape
    active = np.ones(n, dtype=np.bool_)
    factors = None
    a, targets = np.empty((N, q, n)), np.empty((N, q, n))
    current, last = np.empty(n), np.empty_like(k)
    for _ in range(LAPLACE_IRLS_STEPS):
        if not active.any():
            break
        np.copyto(last, k)
        _reweighted_rows(c, r, mask, smoothing, y, a, targets)
        left = active
        if kalman is not None:
            left = kalman.solve(phi, a, targets, w2, coeffs, active, k)
        if left.any():
            rhs = np.ascontiguousarray(np.einsum("tjc,tjk->ctk", targets, phi)[:, :, :, None])
            try:
                factor = WeightedRowsFactor(phi, a, w2, coeffs, rhs, left, out=factors)
            except SingularProblemError:
                active = active & ~left
            else:
                factors = factor.L
                factor.finish(rhs)
                k[left] = rhs[left, :, :, 0]
        # the outputs that took the step (the others' k, r and objective stand)
        _laplace_residuals(phi, y, c, k, w2, coeffs, active, r, current, size)
        worse = active & ~(current <= objectives)
        objectives[:] = np.where(active & ~worse, current, objectives)
        if worse.any():
            active &= ~worse
            k[worse] = last[worse]
            _laplace_residuals(phi, y, c, k, w2, coeffs, worse, r, current, size)
    return factors


@numba.njit(cache=True)
def _reweighted_rows(c, r, mask, smoothing, y, a, targets):  # pragma: no cover - compiled
    """The rows of a reweighted least-squares step (:func:`_reweighted_start`): weights
    a = c/(|r| + h) where ``mask`` (0 elsewhere) and targets a·y, (N, q, n), from c, r,
    y (n, N, q) and h = ``smoothing`` (n,)."""
    n, N, q = r.shape
    for t in range(N):
        for j in range(q):
            for i in range(n):
                weight = c[i, t, j] / (abs(r[i, t, j]) + smoothing[i]) if mask[i, t, j] else 0.0
                a[t, j, i] = weight
                targets[t, j, i] = weight * y[i, t, j]


@numba.njit(cache=True)
def _laplace_residuals(phi, y, c, k, w2, coeffs, which, r, objectives, size):  # pragma: no cover
    """For the outputs ``which`` (n,): the residuals r = y − φᵀk (n, N, q) and the
    objectives Σ c|r| + Σ_t (Dk)ᵀ diag(w2/2) Dk into ``objectives`` (n,), one pass each
    (k (n, N, p), c and y (n, N, q); ``size`` as in :func:`_laplace_state`)."""
    N, q, _ = phi.shape
    p = block_size(size)
    d = coeffs.shape[0] - 1
    for i in range(k.shape[0]):
        if not which[i]:
            continue
        ki = k[i]
        data, penalty = 0.0, 0.0
        for t in range(N):
            for j in range(q):
                fitted = 0.0
                for m in range(p):
                    fitted += phi[t, j, m] * ki[t, m]
                value = y[i, t, j] - fitted
                r[i, t, j] = value
                data += c[i, t, j] * abs(value)
            if t < N - d:
                for m in range(p):
                    difference = 0.0
                    for lag in range(d + 1):
                        difference += coeffs[lag] * ki[t + lag, m]
                    penalty += w2[i, m] * difference * difference
        objectives[i] = data + 0.5 * penalty


def _refine(
    kalman: WeightedRowsKalman,
    phi: np.ndarray,
    a: np.ndarray,
    no_targets: np.ndarray,
    w2: np.ndarray,
    coeffs: np.ndarray,
    which: np.ndarray,
    rhs: np.ndarray,
    dk: np.ndarray,
    work: np.ndarray,
    norms: np.ndarray,
) -> np.ndarray:
    """Iterative refinement of the Kalman form's solutions ``dk`` (n, N, p, 1) of the
    Newton systems H Δk = ``rhs`` (n, N, p, 1) of the outputs ``which``, in place;
    returns those whose relative residual ‖H Δk − rhs‖∞/‖rhs‖∞ ends within
    KALMAN_RESIDUAL (the others: factor them).

    The covariance form loses digits as the row weights κ grow without bound
    (entries whose residual tends to 0: the rank-one downdates of P cancel), but
    its solution stays a good approximate inverse: up to KALMAN_REFINEMENTS times,
    the residual rhs − H Δk (computed from H itself) is solved for a correction by
    replaying the last solve's covariances and gains (no downdates: cheaper than a
    solve, far cheaper than a factorization). A correction that does not reduce the
    residual is undone (each output keeps its best solution). ``work`` (2, n, N, p)
    holds the residuals (on entry those of ``dk``, :func:`_newton_residual`, with
    their relative norms ``norms`` (n,), updated) and the corrections."""
    n = len(which)
    vector, correction = work[0], work[1]
    fresh = np.zeros(n)
    todo = np.array(which, dtype=np.bool_)
    ok = np.zeros(n, dtype=np.bool_)
    for _ in range(KALMAN_REFINEMENTS):
        todo &= ~kalman.solve(
            phi, a, no_targets, w2, coeffs, todo, correction, linear=vector, replay=True
        )
        last = {i: dk[i, :, :, 0].copy() for i in np.flatnonzero(todo).tolist()}
        for i in last:
            dk[i, :, :, 0] += correction[i]
        _newton_residual(phi, a, w2, coeffs, dk, rhs, todo, vector, fresh)
        worse = todo & ~(fresh < norms)  # NaN too
        for i in np.flatnonzero(worse).tolist():
            dk[i, :, :, 0] = last[i]
        norms[:] = np.where(todo & ~worse, fresh, norms)
        ok |= todo & (norms <= KALMAN_RESIDUAL)
        todo &= ~ok & ~worse
        if not todo.any():
            break
    return ok


def _copied(rhs: np.ndarray, dk: np.ndarray, which: np.ndarray) -> np.ndarray:
    """``dk`` with the right-hand sides ``rhs`` of the outputs ``which`` copied in (for
    the factorization, which solves in place): nothing to copy where they are one array."""
    if dk is not rhs:
        dk[which] = rhs[which]
    return dk


@numba.njit(cache=True)
def _newton_residual(phi, a, w2, coeffs, x, rhs, which, vector, out):  # pragma: no cover
    """The residual rhs − H x (into ``vector`` (n, N, p), unless it is (n, 0, p): only the
    norms) and ‖H x − rhs‖∞ / ‖rhs‖∞ (into ``out`` (n,); NaN if an entry of the
    residual is NaN) per output in ``which``, H = blkdiag_t(Σ_j κ φφᵀ) + DᵀD ⊗ diag(w2)
    for a first difference D; x and rhs (n, N, p, 1)."""
    N, q, p = phi.shape
    store = vector.shape[1] > 0
    c0, c1 = coeffs[0], coeffs[1]
    weighted = np.empty(q)
    carried = np.empty(p)  # (Dx)_{t−1}
    for o in range(x.shape[0]):
        if not which[o]:
            continue
        worst, size = 0.0, 0.0
        for t in range(N):
            for j in range(q):
                fitted = 0.0
                for m in range(p):
                    fitted += phi[t, j, m] * x[o, t, m, 0]
                weighted[j] = a[t, j, o] * fitted
            for i in range(p):
                acc = 0.0
                if t > 0:
                    acc += c1 * w2[o, i] * carried[i]
                if t < N - 1:
                    diff = c0 * x[o, t, i, 0] + c1 * x[o, t + 1, i, 0]
                    acc += c0 * w2[o, i] * diff
                    carried[i] = diff
                for j in range(q):
                    acc += weighted[j] * phi[t, j, i]
                value = rhs[o, t, i, 0]
                if store:
                    vector[o, t, i] = value - acc
                miss = abs(acc - value)
                if not miss <= worst:  # NaN too: a solution that is not finite fails
                    worst = miss
                size = max(size, abs(value))
        out[o] = worst / size if size > 0.0 else (0.0 if worst == 0.0 else np.inf)


@numba.njit(cache=True)
def _laplace_state(
    phi, y, c, mask, k, b, zp, zm, w2, coeffs, active, sp, sm, a, rhs, r_k, stats, size
):  # pragma: no cover - compiled
    """At k (n, N, p) of each active output: the slacks σ± = b ∓ r, the Newton
    matrix's row weights κ (into ``a`` (N, q, n)), the stationarity residual
    r_k = Σ(ζ⁻ − ζ⁺)φ + 2DᵀWDk (n, N, p), the predictor's right-hand side
    Σ Aφ − r_k (``rhs`` (n, N, p, 1); target η± = −σ±ζ±, :meth:`_Entries.eliminate`),
    and ``stats`` (n, 6): the loss, the penalty, the gap Σσζ, ‖r_k‖², ‖r_b‖² and
    whether every slack and dual is positive (1.0 or 0.0).

    One sweep over time: step t's part of 2DᵀWDk gathers the differences (Dk)_s,
    s = t − d … t, that contain k_t, in the order a scatter over s would add them
    (for a first difference the last one carried over from step t − 1, else
    recomputed). An entry that is not interior (a slack or dual <= 0, or NaN) gets
    κ = 0 and no part in ``rhs``: the output stops there (``stats``), before any
    division by its slack.

    ``size``: p, or a tuple of length p (:func:`~.banded.long_series_size`), which makes p a
    constant of the compiled pass (here and in the other per-entry passes: 10-30 %
    faster at p = 5, T = 10⁵, the same sums)."""
    N, q, _ = phi.shape
    p = block_size(size)
    n = k.shape[0]
    d = coeffs.shape[0] - 1
    c0, c1 = coeffs[0], coeffs[-1]
    carried = np.empty(p)  # a first difference's w(Dk)_{t−1}
    # step t's rows of r_k and of the right-hand side, summed here and stored once
    # (sums into the output arrays are reloaded and stored at every entry)
    rk_t = np.empty(p)
    rhs_t = np.empty(p)
    for o in range(n):
        if not active[o]:
            continue
        ko = k[o]
        rko = r_k[o]
        rhso = rhs[o]
        penalty, loss, gap, rk2, rb2, interior = 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
        for t in range(N):
            if d == 1:
                for i in range(p):
                    acc = 0.0
                    if t > 0:
                        acc += c1 * carried[i]
                    if t < N - 1:
                        diff = c0 * ko[t, i] + c1 * ko[t + 1, i]
                        penalty += 0.5 * w2[o, i] * diff * diff
                        diff *= w2[o, i]
                        acc += c0 * diff
                        carried[i] = diff
                    rk_t[i] = acc
                    rhs_t[i] = 0.0
            else:
                for i in range(p):
                    acc = 0.0
                    for lag in range(d, -1, -1):
                        s = t - lag
                        if s < 0 or s >= N - d:
                            continue
                        diff = 0.0
                        for m in range(d + 1):
                            diff += coeffs[m] * ko[s + m, i]
                        if lag == 0:
                            penalty += 0.5 * w2[o, i] * diff * diff
                        acc += coeffs[lag] * (diff * w2[o, i])
                    rk_t[i] = acc
                    rhs_t[i] = 0.0
            for j in range(q):
                if not mask[o, t, j]:
                    sp[o, t, j] = 1.0
                    sm[o, t, j] = 1.0
                    a[t, j, o] = 0.0
                    continue
                fitted = 0.0
                for i in range(p):
                    fitted += phi[t, j, i] * ko[t, i]
                r = y[o, t, j] - fitted
                cost = c[o, t, j]
                s_p = b[o, t, j] - r
                s_m = b[o, t, j] + r
                z_p = zp[o, t, j]
                z_m = zm[o, t, j]
                sp[o, t, j] = s_p
                sm[o, t, j] = s_m
                loss += cost * abs(r)
                gap += s_p * z_p + s_m * z_m
                r_b = cost - z_p - z_m
                rb2 += r_b * r_b
                data = z_m - z_p  # the data part of r_k
                for i in range(p):
                    rk_t[i] += data * phi[t, j, i]
                if not (s_p > 0.0 and s_m > 0.0 and z_p > 0.0 and z_m > 0.0):
                    interior = 0.0
                    a[t, j, o] = 0.0
                    continue
                g_p = z_p / s_p
                g_m = z_m / s_m
                G = g_p + g_m
                H = g_p - g_m
                a[t, j, o] = 4.0 * g_p * g_m / G
                # target η± = −σ±ζ±: η/σ = −ζ
                E = -z_p - z_m - r_b
                A = (z_m - z_p) - H * E / G
                for i in range(p):
                    rhs_t[i] += A * phi[t, j, i]
            for i in range(p):
                rko[t, i] = rk_t[i]
                rk2 += rk_t[i] * rk_t[i]
                rhso[t, i, 0] = rhs_t[i] - rk_t[i]
        stats[o, 0] = loss
        stats[o, 1] = penalty
        stats[o, 2] = gap
        stats[o, 3] = rk2
        stats[o, 4] = rb2
        stats[o, 5] = interior


@numba.njit(cache=True, inline="always")
def _laplace_deltas(
    phi, dk, o, t, j, cost, s_p, s_m, z_p, z_m, eta_p, eta_m, p
):  # pragma: no cover - compiled
    """(Δb, Δσ⁺, Δσ⁻, Δζ⁺, Δζ⁻) of one entry for the solution Δk and targets η±
    (:meth:`_Entries.deltas`, Laplace)."""
    fitted = 0.0
    for i in range(p):
        fitted += phi[t, j, i] * dk[o, t, i, 0]
    g_p = z_p / s_p
    g_m = z_m / s_m
    G = g_p + g_m
    H = g_p - g_m
    ratio_p = eta_p / s_p
    ratio_m = eta_m / s_m
    E = ratio_p + ratio_m - (cost - z_p - z_m)
    db = (E - H * fitted) / G
    ds_p = db + fitted
    ds_m = db - fitted
    return db, ds_p, ds_m, ratio_p - g_p * ds_p, ratio_m - g_m * ds_m


@numba.njit(cache=True, inline="always")
def _shrink(step, x, dx):  # pragma: no cover - compiled
    """The ratio test of one variable: min(step, −x/dx) where dx < 0."""
    if dx < 0.0:
        return min(step, -x / dx)
    return step


@numba.njit(cache=True)
def _laplace_affine(
    phi, c, mask, sp, sm, zp, zm, dk, active, tp, tm, steps, size
):  # pragma: no cover - compiled
    """The predictor's largest step (``steps`` (n,), inf if none is bounded) for its
    solution Δk (n, N, p, 1), and its second-order terms Δσ±Δζ± (into ``tp``, ``tm``);
    ``size`` as in :func:`_laplace_state`."""
    n, N, q = c.shape
    p = block_size(size)
    for o in range(n):
        if not active[o]:
            continue
        step = np.inf
        for t in range(N):
            for j in range(q):
                if not mask[o, t, j]:
                    continue
                s_p, s_m, z_p, z_m = sp[o, t, j], sm[o, t, j], zp[o, t, j], zm[o, t, j]
                _, ds_p, ds_m, dz_p, dz_m = _laplace_deltas(
                    phi, dk, o, t, j, c[o, t, j], s_p, s_m, z_p, z_m, -s_p * z_p, -s_m * z_m, p
                )
                step = _shrink(step, s_p, ds_p)
                step = _shrink(step, s_m, ds_m)
                step = _shrink(step, z_p, dz_p)
                step = _shrink(step, z_m, dz_m)
                tp[o, t, j] = ds_p * dz_p
                tm[o, t, j] = ds_m * dz_m
        steps[o] = step


@numba.njit(cache=True)
def _laplace_corrector(
    phi, c, mask, sp, sm, zp, zm, sigma_mu, r_k, active, tp, tm, rhs, size
):  # pragma: no cover - compiled
    """Mehrotra's corrector: the targets η± = σμ − σ±ζ± − Δσ±Δζ± (``tp``, ``tm`` hold
    the second-order terms on entry, the targets on return) and the right-hand
    side Σ Aφ − r_k (into ``rhs``); ``size`` as in :func:`_laplace_state`."""
    n, N, q = c.shape
    p = block_size(size)
    row = np.empty(p)  # step t's right-hand side, summed here and stored once
    for o in range(n):
        if not active[o]:
            continue
        for t in range(N):
            for i in range(p):
                row[i] = -r_k[o, t, i]
            for j in range(q):
                if not mask[o, t, j]:
                    continue
                s_p, s_m, z_p, z_m = sp[o, t, j], sm[o, t, j], zp[o, t, j], zm[o, t, j]
                eta_p = sigma_mu[o] - s_p * z_p - tp[o, t, j]
                eta_m = sigma_mu[o] - s_m * z_m - tm[o, t, j]
                tp[o, t, j] = eta_p
                tm[o, t, j] = eta_m
                g_p = z_p / s_p
                g_m = z_m / s_m
                G = g_p + g_m
                H = g_p - g_m
                ratio_p = eta_p / s_p
                ratio_m = eta_m / s_m
                E = ratio_p + ratio_m - (c[o, t, j] - z_p - z_m)
                A = ratio_p - ratio_m - H * E / G
                for i in range(p):
                    row[i] += A * phi[t, j, i]
            for i in range(p):
                rhs[o, t, i, 0] = row[i]


@numba.njit(cache=True)
def _laplace_step(
    phi, c, mask, sp, sm, zp, zm, dk, active, tp, tm, fraction, min_step, k, b, steps, size
):  # pragma: no cover - compiled
    """The corrector's step min(1, fraction · the largest step keeping σ±, ζ± positive)
    per active output (into ``steps``) and, where it is at least ``min_step``, the
    step itself: k += αΔk, b += αΔb, ζ± += αΔζ± (σ follows from k and b).

    The ratio test keeps Δb, Δζ± in ``sp``, ``tp``, ``tm`` (the slacks and targets are
    not needed after it: the next state recomputes them), so that the step is a plain
    update without a second pass over φ. ``size`` as in :func:`_laplace_state`."""
    n, N, q = c.shape
    p = block_size(size)
    for o in range(n):
        if not active[o]:
            continue
        largest = np.inf
        for t in range(N):
            for j in range(q):
                if not mask[o, t, j]:
                    continue
                s_p, s_m, z_p, z_m = sp[o, t, j], sm[o, t, j], zp[o, t, j], zm[o, t, j]
                db, ds_p, ds_m, dz_p, dz_m = _laplace_deltas(
                    phi, dk, o, t, j, c[o, t, j], s_p, s_m, z_p, z_m, tp[o, t, j], tm[o, t, j], p
                )
                largest = _shrink(largest, s_p, ds_p)
                largest = _shrink(largest, s_m, ds_m)
                largest = _shrink(largest, z_p, dz_p)
                largest = _shrink(largest, z_m, dz_m)
                sp[o, t, j] = db
                tp[o, t, j] = dz_p
                tm[o, t, j] = dz_m
        step = min(1.0, fraction * largest)
        steps[o] = step
        if step < min_step:
            continue
        for t in range(N):
            for i in range(p):
                k[o, t, i] += step * dk[o, t, i, 0]
            for j in range(q):
                if not mask[o, t, j]:
                    continue
                b[o, t, j] += step * sp[o, t, j]
                zp[o, t, j] += step * tp[o, t, j]
                zm[o, t, j] += step * tm[o, t, j]


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
