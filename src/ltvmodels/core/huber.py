"""The Huber loss with the squared-difference penalty: the exact minimizer by majorize–minimize.

Objective, per output entry r_tji = y_tji − θ_tiᵀ φ_tj of the observed rows
(row j of step t, weight w_tj; stored scaled by √w_tj, see
:class:`~ltvmodels.core.problem.RegressionProblem`):

    F(k) = Σ w_tj h_δi(r_tji) + Σ_t (Dk)_tᵀ W (Dk)_t,
    h_δ(r) = r² for |r| <= δ,  2δ|r| − δ² beyond

(cvxpy's ``huber(r, δ)``: least squares for small residuals, so λ keeps its
meaning). Since w·h_δ(r) = h_{δ√w}(√w r), the scaled rows need only the
thresholds δ̃ = δ√w.

Method: damped (semismooth) Newton steps on each output row, each a weighted
squared-loss fit — one banded factorization — whose quadratic model has F's
gradient and F's curvature except τ δ̃/|r| instead of 0 beyond δ̃ (τ = 1e-2).
A backtracking line search keeps F decreasing; should it fail, the step with
τ = 1 is taken, the majorize–minimize (IRLS) step of h_δ(r) <= a r² + c,
a = min(1, δ/|r₀|), which never increases F. Newton identifies the outliers
in a few steps and then converges quadratically (IRLS alone took 60 steps
where Newton takes 10). F is convex and continuously differentiable, so the
iteration stops on a certificate: the KKT residual ‖∇F‖∞, relative to the
size of the gradient's terms, below ``tol``.

Without priors and with a finite diagonal weight (the usual fit) the same
iteration runs on compiled kernels (:func:`_fit_diagonal`), with τ = 0 (the
exact generalized Newton model) after a step of length >= ``EXACT_STEP``: the
outputs still needing steps are solved in one sweep over time (a Kalman
filter and smoother for a first difference, :class:`~.banded.WeightedRowsKalman`,
else :class:`~.banded.WeightedRowsFactor`); the KKT residuals and the Newton
models' rows share one pass over the arrays (on the residuals r, kept across
steps: a step of length α changes them by −α φᵀd), and the exact line search
(:func:`line_minimum`, which the Python path calls too) one pass for the
direction's residuals, after which it and both values of F need only those.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from ..errors import SingularProblemError
from .banded import WeightedRowsFactor, WeightedRowsKalman, long_series_size
from .blockkernels import block_size
from .precompiled import attach
from .priorterms import PriorTerm
from .problem import RegressionProblem, apply_difference, apply_difference_adjoint
from .squared import SquaredSolver, weight_diagonal

__all__ = [
    "NEWTON_DAMPING",
    "LINE_SEARCH_STEPS",
    "MIN_DAMPING",
    "EXACT_STEP",
    "HuberFit",
    "huber_loss",
    "fit_huber",
    "line_minimum",
    "newton_model",
]

# τ of the Newton steps (see _reweighted_fit) and the step halvings tried before falling
# back to the majorize-minimize step.
NEWTON_DAMPING = 1e-2
LINE_SEARCH_STEPS = 30
# The resolution of the line search's α (in [0, 1]).
LINE_SEARCH_TOL = 1e-12
# The Kalman form solves an output's Newton model only while no row's update divides
# the variance along its regressor by more than this (it then cancels about 8 digits):
# a state sample 10⁴ times the others' (a regressor of that size in the next step)
# gives 1e8 and more; the block factorization takes such outputs. Series without one
# stay far below: 31 at T = 10⁵ with 5 % outliers, 1.3e5 at λ = 0.1. (Above about
# 1e12 the Kalman form stalled where the factorization converged.)
KALMAN_MAX_REDUCTION = 1e8
# The smallest damping, reached once the outliers are identified (a smaller τ
# would inflate the model's rows beyond δ̃ by 1/√τ).
MIN_DAMPING = 1e-4
# The compiled iteration (rows given by weight a and target a ŷ = a·fitted + ψ, finite
# at τ = 0) takes τ = 0, the exact generalized Newton model, after a step of at least
# this length: the outliers are then nearly identified, and once they are, the next
# step is the minimizer (certificates near 1e-12). Across series of 2·10⁴–10⁵ steps
# with 2–15 % outliers this took 12–21 factorizations where lowering τ tenfold
# after each step that kept the outliers took 15–25, in as many steps or one fewer.
EXACT_STEP = 0.9


@dataclass
class HuberFit:
    """What :func:`fit_huber` computes."""

    theta: np.ndarray  # (N, n, p)
    objective: float  # F at theta
    iterations: int  # majorize–minimize steps taken
    converged: bool  # the KKT residual met tol
    kkt_residual: float  # relative ‖∇F‖∞ at theta
    outliers: np.ndarray  # (N, q, n) bool: observed entries with |r| > δ
    stalled: bool = False  # stopped short of tol: F flat to rounding


def huber_loss(r: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """h_δ(r) elementwise (δ broadcast against r)."""
    a = np.abs(r)
    return np.where(a <= delta, r * r, 2.0 * delta * a - delta * delta)


def fit_huber(
    problem: RegressionProblem,
    W: np.ndarray,
    delta: np.ndarray,
    *,
    max_iter: int = 200,
    tol: float = 1e-9,
    start: np.ndarray | None = None,
    priors: list[PriorTerm] | None = None,
    prior_scale: np.ndarray | None = None,
) -> HuberFit:
    """Minimize F (module docstring) for a penalty weight that does not couple output rows.

    Parameters
    ----------
    problem : RegressionProblem
        Rows scaled by √w (missing rows zero); ``problem.row_scale`` holds √w.
    W : ndarray, shape (K,) or (K, K)
        Penalty weight (no row coupling; inf holds a coefficient constant).
    delta : ndarray, shape (n,)
        Huber threshold δ_i > 0 of each output, in the units of y.
    max_iter : int
        Steps at most.
    tol : float
        Stop when ‖∇F‖∞ <= tol · (the largest gradient term).
    start : ndarray, shape (N, n, p), optional
        The squared-loss fit, if the caller has it (it starts the iteration).
    priors : list of PriorTerm, optional
        Parameter priors that do not couple output rows: F gains
        σ_i² Σ_t (k_ti − m_ti)ᵀ P_t (k_ti − m_ti) per output i (the squared
        loss's convention, with the noise variance σ_i² = ``prior_scale[i]``).
    prior_scale : ndarray, shape (n,), optional
        σ_i² of each output (required with ``priors``).
    """
    n = problem.n
    thresholds = delta[None, None, :] * problem.row_scale[:, :, None]  # δ̃ (N, q, n)
    penalty = SquaredSolver(problem, W, [])
    if not penalty.separable:
        raise NotImplementedError("loss='huber' needs a penalty that does not couple outputs")
    # the squared-loss fit starts the iteration (the caller's is not changed: the
    # compiled path reads it into its own layout, the general one updates a copy)
    theta = penalty.solve(1.0)[0] if start is None else start
    if not priors and penalty.diagonal and np.isfinite(weight_diagonal(W)).all():
        return _fit_diagonal(problem, penalty.W0_diagonal, thresholds, theta, max_iter, tol)
    if start is not None:
        theta = start.copy()
    outputs = [_output_problem(problem, i) for i in range(n)]
    quadratics = [
        _OutputQuadratic(
            problem,
            W,
            penalty.W0,
            i,
            priors or [],
            1.0 if prior_scale is None else float(prior_scale[i]),
        )
        for i in range(n)
    ]
    damping = np.full(n, NEWTON_DAMPING)
    kkt, iterations, stalled = np.full(n, np.inf), 0, False
    for iterations in range(max_iter + 1):
        r = problem.residuals(theta)
        kkt = _kkt_residuals(problem, theta, r, thresholds, quadratics)
        if kkt.max() <= tol or iterations == max_iter:
            break
        progress = False
        for i in np.flatnonzero(kkt > tol):  # the outputs are independent problems
            theta[:, i, :], damping[i], decreased = _newton_step(
                outputs[i],
                quadratics[i],
                theta[:, i, :],
                r[:, :, i],
                thresholds[:, :, i],
                damping[i],
            )
            progress |= decreased
        if not progress:  # F is flat to rounding: the tolerance is beyond working precision
            iterations += 1
            kkt = _kkt_residuals(problem, theta, problem.residuals(theta), thresholds, quadratics)
            stalled = bool(kkt.max() > tol)
            break
    r = problem.residuals(theta)
    objective = float(
        huber_loss(r, thresholds).sum()
        + sum(quad.value(theta[:, i, :]) for i, quad in enumerate(quadratics))
    )
    return HuberFit(
        theta=theta,
        objective=objective,
        iterations=iterations,
        converged=bool(kkt.max() <= tol),
        kkt_residual=float(kkt.max()),
        outliers=(np.abs(r) > thresholds) & problem.observed[:, :, None],
        stalled=stalled,
    )


class _OutputQuadratic:
    """Output i's quadratic terms of F: the difference penalty and the prior terms.

    value(Θ_i) = Σ_t (DΘ_i)_tᵀ W_i (DΘ_i)_t + σ_i² Σ_t (Θ_ti − m_ti)ᵀ P_t (Θ_ti − m_ti),
    with W_i, P_t and m_ti output i's blocks (constant coefficients: W's
    infinite entries contribute nothing, the coefficient is held by the solver).
    """

    def __init__(
        self,
        problem: RegressionProblem,
        W: np.ndarray,
        W0: np.ndarray,
        i: int,
        priors: list[PriorTerm],
        scale: float,
    ):
        p = problem.p
        rows = slice(i * p, (i + 1) * p)
        self.coeffs, self.N = problem.coeffs, problem.N
        self.W = W[rows] if W.ndim == 1 else W[rows, rows]
        self.W0 = W0[rows] if W0.ndim == 1 else W0[rows, rows]
        self.const = np.isinf(self.W if self.W.ndim == 1 else np.diag(self.W))
        self.scale = scale
        self.priors = [_output_prior(term, rows, problem.n, p) for term in priors]

    def value(self, theta: np.ndarray) -> float:
        Dk = apply_difference(theta, self.coeffs)
        weighted = Dk * self.W0 if self.W0.ndim == 1 else Dk @ self.W0
        total = float(np.sum(weighted * Dk))
        for term in self.priors:
            e = theta - term.mean
            total += self.scale * float(np.einsum("ta,tab,tb->", e, term.precision_at(self.N), e))
        return total

    def gradient(self, theta: np.ndarray) -> np.ndarray:
        """(N, p): 2DᵀW DΘ_i + 2σ² P (Θ_i − m_i)."""
        Dk = apply_difference(theta, self.coeffs)
        weighted = Dk * self.W0 if self.W0.ndim == 1 else Dk @ self.W0
        grad = 2.0 * apply_difference_adjoint(weighted, self.coeffs, self.N)
        for term in self.priors:
            grad += (
                2.0
                * self.scale
                * np.einsum("tab,tb->ta", term.precision_at(self.N), theta - term.mean)
            )
        return grad

    def line(self, current: np.ndarray, direction: np.ndarray) -> tuple[float, float]:
        """(a, b) with value(current + α·direction) = value(current) + 2αb + α²a."""
        Dd = apply_difference(direction, self.coeffs)
        Dc = apply_difference(current, self.coeffs)
        Wd = Dd * self.W0 if self.W0.ndim == 1 else Dd @ self.W0
        a, b = float(np.sum(Wd * Dd)), float(np.sum(Wd * Dc))
        for term in self.priors:
            Pd = np.einsum("tab,tb->ta", term.precision_at(self.N), direction)
            a += self.scale * float(np.sum(Pd * direction))
            b += self.scale * float(np.sum(Pd * (current - term.mean)))
        return a, b

    def solve(self, weighted: RegressionProblem) -> np.ndarray:
        """The minimizer (N, p) of the weighted squared loss of ``weighted`` plus these terms."""
        return SquaredSolver(weighted, self.W, self.priors).solve(self.scale)[0][:, 0, :]


def _output_prior(term: PriorTerm, rows: slice, n: int, p: int) -> PriorTerm:
    """Output i's block of a parameter prior (it must not couple the outputs)."""
    if term.on != "parameters":
        raise NotImplementedError(
            "prior: an OutputPrior is not available with loss='huber'; "
            "use a Prior on the coefficients"
        )
    precision = term.precision
    coupling = precision.copy()
    coupling[..., rows, rows] = 0.0
    if n > 1 and np.any(coupling[..., rows, :] != 0):
        raise NotImplementedError(
            "prior: with loss='huber' the prior must not couple the "
            "outputs (a block-diagonal precision)"
        )
    return PriorTerm(
        "parameters",
        np.ascontiguousarray(precision[..., rows, rows]),
        np.ascontiguousarray(term.mean[:, rows]),
    )


def _newton_step(output, quadratic, current, r, thresholds, damping):
    """One damped Newton step of output i: its new coefficients (N, p), damping, and
    whether F decreased.

    The step length minimizes F along the Newton direction exactly
    (:func:`_output_line_minimum`); a step that keeps the outliers (entries beyond δ̃)
    lowers the damping, towards the exact generalized Newton model.
    """
    direction = _reweighted_fit(output, quadratic, r, thresholds, damping) - current
    fitted_direction = np.einsum("tjk,tk->tj", output.phi, direction)
    alpha = _output_line_minimum(quadratic, current, direction, r, fitted_direction, thresholds)
    trial = current + alpha * direction
    value = _output_objective(output, quadratic, current, thresholds)
    trial_value = _output_objective(output, quadratic, trial, thresholds)
    # near the optimum F changes by rounding only: no increase beyond that is a decrease
    if alpha == 0.0 or trial_value > value + 8 * np.finfo(float).eps * abs(value):
        # no decrease along the Newton direction: the majorize-minimize step
        step = _reweighted_fit(output, quadratic, r, thresholds, 1.0)
        decreased = _output_objective(output, quadratic, step, thresholds) < value
        return step, NEWTON_DAMPING, decreased
    kept = alpha == 1.0 and np.array_equal(
        np.abs(r - fitted_direction) > thresholds, np.abs(r) > thresholds
    )
    damping = max(damping * 0.1, MIN_DAMPING) if kept else NEWTON_DAMPING
    return trial, damping, trial_value < value


def _output_line_minimum(quadratic, current, direction, r, fitted_direction, thresholds) -> float:
    """argmin over α in [0, 1] of F(current + α·direction), for one output.

    F along the line is convex and piecewise quadratic (:func:`line_minimum`,
    the compiled search both paths share), with g = φᵀdirection and the
    quadratic terms' a, b (:meth:`_OutputQuadratic.line`).
    """
    a, b = quadratic.line(current, direction)
    return float(
        line_minimum(
            np.ascontiguousarray(r, dtype=float),
            np.ascontiguousarray(fitted_direction, dtype=float),
            np.ascontiguousarray(thresholds, dtype=float),
            a,
            b,
        )
    )


def _reweighted_fit(output, quadratic, r, thresholds, damping) -> np.ndarray:
    """The minimizer (N, p) of the quadratic model of output i's F at residuals r.

    Residuals beyond δ̃ count with weight a = τ δ̃/|r| and the pseudo-response
    ŷ + r/τ: its gradient at ``theta`` is F's, its curvature there τ δ̃/|r|
    instead of 0. τ = 1 is the majorizer (a step that never increases F),
    small τ a damped Newton step (fast, checked by the line search).
    """
    sqrt_a, y_hat = newton_model(output.y[:, :, 0], r, thresholds, damping)
    scale = sqrt_a[:, :, None]
    weighted = RegressionProblem(
        y=y_hat[:, :, None] * scale,
        phi=output.phi * scale,
        coeffs=output.coeffs,
        observed=output.observed,
    )
    return quadratic.solve(weighted)


def newton_model(
    y: np.ndarray, r: np.ndarray, thresholds: np.ndarray, damping: float
) -> tuple[np.ndarray, np.ndarray]:
    """The rows of the quadratic model of Σ h_δ̃(r) at residuals r: (√a, ŷ), shapes of r.

    Σ a (ŷ − φᵀk)² has h's gradient at the current k and curvature a = 1 inside
    δ̃, τ δ̃/|r| beyond (τ = ``damping``), with the pseudo-response
    ŷ = y − r + r/τ beyond δ̃ (ŷ = y inside).
    """
    beyond = np.abs(r) > thresholds
    a = np.divide(damping * thresholds, np.abs(r), out=np.ones_like(r), where=beyond)
    return np.sqrt(a), np.where(beyond, y - r + r / damping, y)


def _output_objective(output, quadratic, theta, thresholds) -> float:
    """Output i's part of F at its coefficients ``theta`` (N, p)."""
    r = output.y[:, :, 0] - np.einsum("tjk,tk->tj", output.phi, theta)
    return float(huber_loss(r, thresholds).sum()) + quadratic.value(theta)


def _output_problem(problem: RegressionProblem, i: int) -> RegressionProblem:
    """The problem of output row i alone (its y column, the shared regressors)."""
    return RegressionProblem(
        y=problem.y[:, :, i : i + 1],
        phi=problem.phi,
        coeffs=problem.coeffs,
        observed=problem.observed,
    )


def _kkt_residuals(problem, theta, r, thresholds, quadratics) -> np.ndarray:
    """‖∇F‖∞ of each output, shape (n,), relative to its largest data or quadratic term.

    A coefficient held constant (inf weight) has one free value: its
    stationarity condition is the sum of its gradient over time, relative to
    the sum of its terms' sizes, row by row (a step's rows may cancel).
    """
    n = problem.n
    tiny = np.finfo(float).tiny
    psi = np.clip(r, -thresholds, thresholds)  # h'(r) / 2
    if problem.q == 1:  # an outer product per step (einsum's reduction is slower)
        data = -2.0 * psi[:, 0, :, None] * problem.phi[:, 0, None, :]  # (N, n, p)
    else:
        data = -2.0 * np.einsum("tji,tjk->tik", psi, problem.phi)
    residuals = np.zeros(n)
    for i, quad in enumerate(quadratics):
        grad = quad.gradient(theta[:, i, :])
        free, fixed = ~quad.const, quad.const
        if free.any():
            scale = max(
                float(np.abs(data[:, i, free]).max()), float(np.abs(grad[:, free]).max()), tiny
            )
            residuals[i] = float(np.abs(data[:, i, free] + grad[:, free]).max()) / scale
        if fixed.any():
            sums = np.abs((data[:, i, fixed] + grad[:, fixed]).sum(axis=0))
            sizes = 2.0 * np.einsum(
                "tj,tjk->k", np.abs(psi[:, :, i]), np.abs(problem.phi[:, :, fixed])
            ) + np.abs(grad[:, fixed]).sum(axis=0)
            residuals[i] = max(residuals[i], float((sums / np.maximum(sizes, tiny)).max()))
    return residuals


def _fit_diagonal(
    problem: RegressionProblem,
    weight: np.ndarray,
    thresholds: np.ndarray,
    theta: np.ndarray,
    max_iter: int,
    tol: float,
) -> HuberFit:
    """:func:`fit_huber` for a finite diagonal weight ``weight`` (K,) and no priors, on
    compiled kernels: the same steps (damped Newton, exact line search, the
    majorize–minimize fallback) and the same certificate, except that τ drops to 0
    (the exact generalized Newton step) after a step of length >= ``EXACT_STEP``.

    ``thresholds`` are δ̃ (N, q, n), ``theta`` (N, n, p) the start (read only).
    Per step: one pass for the KKT residuals and the Newton models' rows
    (:func:`_newton_state`, on the residuals kept from the previous step's line
    search), one sweep that solves the outputs still iterating
    (for a first difference a Kalman filter and smoother,
    :class:`~.banded.WeightedRowsKalman`, 3.5–5.5× faster than the block
    Cholesky sweep :class:`~.banded.WeightedRowsFactor`, which serves the other
    orders and the systems the filter leaves), and per output one pass for the
    direction's residuals, after which the exact line search and both values
    of F need only (r, g) (:func:`_line_search`).
    """
    N, q, n, p = problem.N, problem.q, problem.n, problem.p
    phi = np.ascontiguousarray(problem.phi, dtype=float)
    # each output's y and δ̃ contiguous: the per-output passes stream them
    y = np.ascontiguousarray(problem.y.transpose(2, 0, 1), dtype=float)  # (n, N, q)
    limits = np.ascontiguousarray(thresholds.transpose(2, 0, 1), dtype=float)  # (n, N, q)
    coeffs = np.ascontiguousarray(problem.coeffs, dtype=float)
    w = np.ascontiguousarray(weight.reshape(n, p), dtype=float)
    k = np.array(theta.transpose(1, 0, 2), dtype=float, order="C")  # (n, N, p), a copy
    a = np.empty((N, q, n))
    targets = np.empty((N, q, n))
    model = np.empty((n, N, p, 1))
    factors: np.ndarray | None = None  # the factors' storage, reused
    # a first difference: the Kalman form, which takes the rows (a, b) (no right-hand sides)
    kalman = WeightedRowsKalman(N, q, p, n) if WeightedRowsKalman.applies(coeffs, w) else None
    size = long_series_size(N, p)  # p, or a tuple: a constant of the state pass
    rhs = np.empty((n, 0, p, 1)) if kalman is not None else model
    damping = np.full(n, NEWTON_DAMPING)
    kkt = np.empty(n)
    # the residuals r = y − φk of each output, kept across steps: a step k ← k + αd
    # changes them by −αg, g = φd, which its line search computes anyway, so the state
    # pass reads them instead of forming φk again (``known``: r is that of k)
    resid = np.empty((n, N, q))
    known = np.zeros(n, dtype=np.bool_)
    along = np.empty((N, q))
    eps = np.finfo(float).eps
    # the outputs are independent problems: one that has converged keeps its k and its
    # KKT residual, and is no longer evaluated
    active = np.ones(n, dtype=np.bool_)
    none = np.zeros(n, dtype=np.bool_)
    iterations, stalled = 0, False
    for iterations in range(max_iter + 1):
        _newton_state(
            phi,
            y,
            limits,
            k,
            w,
            coeffs,
            damping,
            active,
            active,
            kkt,
            a,
            targets,
            rhs,
            resid,
            known,
            size,
        )
        if kkt.max() <= tol or iterations == max_iter:
            break
        active = kkt > tol
        try:
            factors = _solve_models(phi, a, targets, w, coeffs, active, kalman, model, factors)
        except SingularProblemError:
            # the exact model leaves out the outliers' rows: too few rows left (a δ far
            # below the residuals' scale) make it singular, the damped one is not
            exact = active & (damping == 0.0)
            if not exact.any():
                raise
            damping[exact] = NEWTON_DAMPING
            _newton_state(
                phi,
                y,
                limits,
                k,
                w,
                coeffs,
                damping,
                exact,
                exact,
                kkt,
                a,
                targets,
                rhs,
                resid,
                known,
                size,
            )
            factors = _solve_models(phi, a, targets, w, coeffs, active, kalman, model, factors)
        progress = False
        for c in np.flatnonzero(active):
            alpha, value, trial_value = _line_search(
                phi, limits[c], k[c], model[c, :, :, 0], w[c], coeffs, resid[c], along
            )
            # near the optimum F changes by rounding only: no increase beyond that is a decrease
            if alpha == 0.0 or trial_value > value + 8 * eps * abs(value):
                # no decrease along the Newton direction: the majorize-minimize step
                # (from k, whose residuals the line search has overwritten)
                known[c] = False
                factors = _majorizer_step(
                    phi, y, limits, k, w, coeffs, c, a, targets, model, factors, resid, known, size
                )
                step = model[c, :, :, 0]
                decreased = _output_value(phi, y[c], limits[c], step, w[c], coeffs) < value
                k[c] = step
                known[c] = False  # a new point: the next state pass forms its residuals
                damping[c] = NEWTON_DAMPING
            else:
                _take_step(k[c], model[c, :, :, 0], alpha)
                # a (nearly) full step: the outliers are (nearly) identified, and the
                # exact Newton model (τ = 0) ends the iteration once they are
                damping[c] = 0.0 if alpha >= EXACT_STEP else NEWTON_DAMPING
                decreased = trial_value < value
            progress |= decreased
        if not progress:  # F is flat to rounding: the tolerance is beyond working precision
            iterations += 1
            _newton_state(
                phi,
                y,
                limits,
                k,
                w,
                coeffs,
                damping,
                active,
                none,
                kkt,
                a,
                targets,
                rhs,
                resid,
                known,
                size,
            )
            stalled = bool(kkt.max() > tol)
            break
    theta = np.ascontiguousarray(k.transpose(1, 0, 2))
    if not known.all():  # (every output's residuals are known here: a safeguard)
        unknown = ~known
        _newton_state(
            phi,
            y,
            limits,
            k,
            w,
            coeffs,
            damping,
            unknown,
            none,
            np.empty(n),
            a,
            targets,
            rhs,
            resid,
            known,
            size,
        )
    # the residuals kept across the steps (y − φθ to rounding), not formed again
    r = resid.transpose(1, 2, 0)  # (N, q, n)
    objective = sum(
        _huber_value(resid[c], limits[c]) + _penalty_value(k[c], w[c], coeffs) for c in range(n)
    )
    return HuberFit(
        theta=theta,
        objective=objective,
        iterations=iterations,
        converged=bool(kkt.max() <= tol),
        kkt_residual=float(kkt.max()),
        outliers=(np.abs(r) > thresholds) & problem.observed[:, :, None],
        stalled=stalled,
    )


def _solve_models(phi, a, targets, w, coeffs, active, kalman, model, factors):
    """Solve the Newton models of the ``active`` outputs, rows (a, targets) (N, q, n), into
    ``model`` (n, N, p, 1): by the Kalman form where it applies (``kalman`` not None)
    and the block Cholesky factorization for the rest; returns the factors' storage.

    Raises SingularProblemError for a singular model.
    """
    unsolved = active
    if kalman is not None:
        unsolved = kalman.solve(
            phi,
            a,
            targets,
            w,
            coeffs,
            active,
            model[:, :, :, 0],
            max_reduction=KALMAN_MAX_REDUCTION,
        )
    if unsolved.any():  # no Kalman form, or the systems it leaves
        for c in np.flatnonzero(unsolved):
            model[c, :, :, 0] = np.einsum("tj,tjk->tk", targets[:, :, c], phi)
        factor = WeightedRowsFactor(phi, a, w, coeffs, model, unsolved, out=factors)
        factor.finish(model)
        factors = factor.L
    return factors


def _majorizer_step(
    phi, y, limits, k, w, coeffs, c, a, targets, model, factors, resid, known, size
):
    """The majorize–minimize step (τ = 1) of output c alone, into ``model[c]``; returns
    the factors' storage for the next call (``resid``, ``known``: see :func:`_newton_state`)."""
    n = k.shape[0]
    only = np.zeros(n, dtype=bool)
    only[c] = True
    full = np.ones(n)
    kkt = np.empty(n)
    # the other outputs' models are still to be used: only output c's rows change
    _newton_state(
        phi, y, limits, k, w, coeffs, full, only, only, kkt, a, targets, model, resid, known, size
    )
    factor = WeightedRowsFactor(phi, a, w, coeffs, model, only, out=factors)
    factor.finish(model)
    return factor.L


@numba.njit(cache=True)
def _newton_state(
    phi, y, limits, k, w, coeffs, damping, evaluate, rows, out, a, targets, rhs, resid, known, size
):  # pragma: no cover - compiled
    """At k (n, N, p), in one pass per output where ``evaluate`` (n,) is set: ‖∇F‖∞ of
    each output into ``out`` (n,),
    relative to its largest data or penalty term (:func:`_kkt_residuals`), and,
    where ``rows`` (n,) is set, the rows of its quadratic model (:func:`newton_model`):
    weights a (N, q, n), targets a ŷ (N, q, n) and, unless ``rhs`` has no steps
    (shape (n, 0, p, 1)), right-hand sides Σ_j a ŷ φ (n, N, p, 1).

    ``y`` and ``limits`` (the thresholds δ̃) are per output, shape (n, N, q). ``resid``
    (n, N, q) holds the residuals y − φk of the outputs with ``known`` (n,) set (read,
    not formed); the others' are formed here, stored, and ``known`` set. ``size``: p, or a
    tuple of length p (:func:`~.banded.long_series_size`), which makes p a constant of the
    compiled pass (a first difference's: a quarter faster at p = 5, T = 10⁵).
    """
    for c in range(k.shape[0]):
        if evaluate[c]:
            if coeffs.shape[0] == 2:
                # a first difference (the usual case): the same sums in the same order
                out[c] = _first_difference_state(
                    phi, y, limits, k, w, coeffs, damping, rows, a, targets, rhs, resid, known, c,
                    size,
                )  # fmt: skip
            else:
                out[c] = _difference_state(
                    phi, y, limits, k, w, coeffs, damping, rows, a, targets, rhs, resid, known, c,
                    size,
                )  # fmt: skip
            known[c] = True


@numba.njit(cache=True)
def _difference_state(
    phi, y, limits, k, w, coeffs, damping, rows, a, targets, rhs, resid, known, c, size
):  # pragma: no cover - compiled
    """:func:`_newton_state` of output c, any difference order d: its KKT residual."""
    N, q, _ = phi.shape
    p = block_size(size)
    d = coeffs.shape[0] - 1
    fill = rhs.shape[1] == N
    # W Dk over the last d + 1 differences: (W Dk)_s in row s % (d + 1)
    difference = np.empty((d + 1, p))
    data = np.empty(p)
    kc, wc, rc, yc, limit = k[c], w[c], resid[c], y[c], limits[c]
    given, tau, model = known[c], damping[c], rows[c]
    largest_data, largest_penalty, largest = 0.0, 0.0, 0.0
    for t in range(N):
        if t < N - d:
            for i in range(p):
                acc = 0.0
                for lag in range(d + 1):
                    acc += coeffs[lag] * kc[t + lag, i]
                difference[t % (d + 1), i] = wc[i] * acc
        for i in range(p):
            data[i] = 0.0
            if model and fill:
                rhs[c, t, i, 0] = 0.0
        for j in range(q):
            if given:
                r = rc[t, j]
                fitted = yc[t, j] - r
            else:
                fitted = 0.0
                for i in range(p):
                    fitted += phi[t, j, i] * kc[t, i]
                r = yc[t, j] - fitted
                rc[t, j] = r
            delta = limit[t, j]
            psi = min(max(r, -delta), delta)
            for i in range(p):
                data[i] += psi * phi[t, j, i]
            if model:
                if abs(r) > delta:
                    weight = tau * delta / abs(r)
                    target = weight * fitted + psi
                else:
                    weight = 1.0
                    target = yc[t, j]
                a[t, j, c] = weight
                targets[t, j, c] = target
                if fill:
                    for i in range(p):
                        rhs[c, t, i, 0] += target * phi[t, j, i]
        for i in range(p):
            # 2 (DᵀW Dk)_t: Σ_lag c_lag (W Dk)_{t − lag}
            penalty = 0.0
            for lag in range(d + 1):
                s = t - lag
                if 0 <= s < N - d:
                    penalty += coeffs[lag] * difference[s % (d + 1), i]
            penalty *= 2.0
            term = -2.0 * data[i]
            largest_data = max(largest_data, abs(term))
            largest_penalty = max(largest_penalty, abs(penalty))
            largest = max(largest, abs(term + penalty))
    return largest / max(largest_data, largest_penalty, np.finfo(np.float64).tiny)


@numba.njit(cache=True)
def _first_difference_state(
    phi, y, limits, k, w, coeffs, damping, rows, a, targets, rhs, resid, known, c, size
):  # pragma: no cover - compiled
    """:func:`_difference_state` for d = 1: (W Dk)_{t−1} and (W Dk)_t kept as they are
    (0 beyond the ends) instead of in a ring: twice as fast (the rows' loop is the
    same, written out: called as an inlined function it took twice the time too)."""
    N, q, _ = phi.shape
    p = block_size(size)
    first, second = coeffs[0], coeffs[1]
    fill = rhs.shape[1] == N
    previous = np.zeros(p)
    current = np.empty(p)
    data = np.empty(p)
    kc, wc, rc, yc, limit = k[c], w[c], resid[c], y[c], limits[c]
    given, tau, model = known[c], damping[c], rows[c]
    largest_data, largest_penalty, largest = 0.0, 0.0, 0.0
    for t in range(N):
        last = t == N - 1
        for i in range(p):
            current[i] = 0.0 if last else wc[i] * (first * kc[t, i] + second * kc[t + 1, i])
            data[i] = 0.0
            if model and fill:
                rhs[c, t, i, 0] = 0.0
        for j in range(q):
            if given:
                r = rc[t, j]
                fitted = yc[t, j] - r
            else:
                fitted = 0.0
                for i in range(p):
                    fitted += phi[t, j, i] * kc[t, i]
                r = yc[t, j] - fitted
                rc[t, j] = r
            delta = limit[t, j]
            psi = min(max(r, -delta), delta)
            for i in range(p):
                data[i] += psi * phi[t, j, i]
            if model:
                if abs(r) > delta:
                    # a ŷ = a (fitted + r/τ) = a·fitted + ψ: finite at τ = 0, where
                    # the model is the exact generalized Newton model
                    weight = tau * delta / abs(r)
                    target = weight * fitted + psi
                else:
                    weight = 1.0
                    target = yc[t, j]
                a[t, j, c] = weight
                targets[t, j, c] = target
                if fill:
                    for i in range(p):
                        rhs[c, t, i, 0] += target * phi[t, j, i]
        for i in range(p):
            penalty = 2.0 * (first * current[i] + second * previous[i])
            previous[i] = current[i]
            term = -2.0 * data[i]
            largest_data = max(largest_data, abs(term))
            largest_penalty = max(largest_penalty, abs(penalty))
            largest = max(largest, abs(term + penalty))
    return largest / max(largest_data, largest_penalty, np.finfo(np.float64).tiny)


@numba.njit(cache=True)
def _huber_value(r, limits):  # pragma: no cover - compiled
    """Σ h_δ̃(r) of one output's residuals r (N, q), thresholds ``limits`` (N, q)."""
    N, q = r.shape
    total = 0.0
    for t in range(N):
        for j in range(q):
            size, delta = abs(r[t, j]), limits[t, j]
            total += size * size if size <= delta else delta * (2.0 * size - delta)
    return total


@numba.njit(cache=True)
def _penalty_value(k, w, coeffs):  # pragma: no cover - compiled
    """Σ_t (Dk)_tᵀ diag(w) (Dk)_t of one output's k (N, p)."""
    N, p = k.shape
    d = coeffs.shape[0] - 1
    total = 0.0
    if d == 1:  # a first difference without the loop over lags (3x faster), same sums
        first, second = coeffs[0], coeffs[1]
        for t in range(N - 1):
            for i in range(p):
                difference = 0.0 + first * k[t, i]
                difference += second * k[t + 1, i]
                total += w[i] * difference * difference
        return total
    for t in range(N - d):
        for i in range(p):
            difference = 0.0
            for lag in range(d + 1):
                difference += coeffs[lag] * k[t + lag, i]
            total += w[i] * difference * difference
    return total


@numba.njit(cache=True)
def _output_value(phi, y, limits, k, w, coeffs):  # pragma: no cover - compiled
    """One output's part of F at its coefficients k (N, p); y and δ̃ (N, q) its own."""
    N, q, p = phi.shape
    total = 0.0
    for t in range(N):
        for j in range(q):
            fitted = 0.0
            for i in range(p):
                fitted += phi[t, j, i] * k[t, i]
            r = abs(y[t, j] - fitted)
            delta = limits[t, j]
            total += r * r if r <= delta else 2.0 * delta * r - delta * delta
    return total + _penalty_value(k, w, coeffs)


@numba.njit(cache=True)
def _take_step(k, model, alpha):  # pragma: no cover - compiled
    """k ← k + α (model − k) in place (one pass, no temporaries of the size of k)."""
    N, p = k.shape
    for t in range(N):
        for i in range(p):
            k[t, i] += alpha * (model[t, i] - k[t, i])


@numba.njit(cache=True)
def _line_search(phi, limits, k, model, w, coeffs, r, g):  # pragma: no cover
    """The exact line search of one output from k (N, p) towards its model's minimizer
    ``model`` (N, p): (α, F_c at k, F_c at k + α·direction), with direction = model − k
    (formed where it is used, not stored) and r (N, q) the residuals at k, which it
    overwrites with those at k + α·direction.

    One pass over the rows (:func:`_direction`) gives the fitted direction
    g = φᵀdirection (into ``g`` (N, q)) and, from the differences, the
    quadratic terms along the line, value(k + α·direction) = value + 2αb + α²a;
    the search (:func:`line_minimum`) and both values of F then need only (r, g).
    """
    N, q = r.shape
    if coeffs.shape[0] == 2:  # a first difference (the usual case): 1.7x faster
        quad_a, quad_b, quad_c = _first_difference_direction(phi, k, model, w, coeffs, g)
    else:
        quad_a, quad_b, quad_c = _direction(phi, k, model, w, coeffs, g)
    alpha = line_minimum(r, g, limits, quad_a, quad_b)
    value, trial_value = quad_c, quad_c + alpha * (2.0 * quad_b + alpha * quad_a)
    for t in range(N):
        for j in range(q):
            delta = limits[t, j]
            current = abs(r[t, j])
            moved = r[t, j] - alpha * g[t, j]
            r[t, j] = moved  # the residuals after the step (if taken; else formed again)
            shifted = abs(moved)
            value += current * current if current <= delta else delta * (2.0 * current - delta)
            trial_value += (
                shifted * shifted if shifted <= delta else delta * (2.0 * shifted - delta)
            )
    return alpha, value, trial_value


@numba.njit(cache=True)
def _direction(phi, k, model, w, coeffs, g):  # pragma: no cover - compiled
    """The pass of :func:`_line_search`: g = φᵀ(model − k) into ``g`` (N, q) and the
    quadratic terms (a, b, c) along the line: value(k + α·direction) = c + 2αb + α²a."""
    N, q, p = phi.shape
    d = coeffs.shape[0] - 1
    quad_a, quad_b, quad_c = 0.0, 0.0, 0.0
    for t in range(N):
        for j in range(q):
            along = 0.0
            for i in range(p):
                along += phi[t, j, i] * (model[t, i] - k[t, i])
            g[t, j] = along
        # the difference ending at t, while its rows are in cache
        s = t - d
        if s >= 0:
            for i in range(p):
                dd, dk = 0.0, 0.0
                for lag in range(d + 1):
                    dd += coeffs[lag] * (model[s + lag, i] - k[s + lag, i])
                    dk += coeffs[lag] * k[s + lag, i]
                quad_a += w[i] * dd * dd
                quad_b += w[i] * dd * dk
                quad_c += w[i] * dk * dk
    return quad_a, quad_b, quad_c


@numba.njit(cache=True)
def _first_difference_direction(phi, k, model, w, coeffs, g):  # pragma: no cover - compiled
    """:func:`_direction` for d = 1, without the loop over lags: the same sums in the
    same order."""
    N, q, p = phi.shape
    first, second = coeffs[0], coeffs[1]
    quad_a, quad_b, quad_c = 0.0, 0.0, 0.0
    for t in range(N):
        for j in range(q):
            along = 0.0
            for i in range(p):
                along += phi[t, j, i] * (model[t, i] - k[t, i])
            g[t, j] = along
        if t >= 1:  # the difference ending at t, while its rows are in cache
            s = t - 1
            for i in range(p):
                dd = 0.0 + first * (model[s, i] - k[s, i])
                dd += second * (model[t, i] - k[t, i])
                dk = 0.0 + first * k[s, i]
                dk += second * k[t, i]
                quad_a += w[i] * dd * dd
                quad_b += w[i] * dd * dk
                quad_c += w[i] * dk * dk
    return quad_a, quad_b, quad_c


@numba.njit(cache=True)
def line_minimum(r, g, limits, quad_a, quad_b):  # pragma: no cover - compiled
    """The exact line search of the Huber fits: argmin over α in [0, 1] of
    f(α) = Σ h_δ̃(r − αg) + 2αb + α²a (F along a line, up to a constant).

    f is convex and piecewise quadratic, f'(α) = −2Σ clip(r − αg, ±δ̃)g + 2αa + 2b;
    its root is found by Newton's method safeguarded by bisection (exact once
    the entries within δ̃ settle). Compiled; both Huber paths use it.

    Parameters
    ----------
    r : ndarray, shape (N, q)
        Residuals at the current point (C-contiguous float).
    g : ndarray, shape (N, q)
        The fitted direction φᵀd: the residuals change by −αg.
    limits : ndarray, shape (N, q)
        The thresholds δ̃.
    quad_a, quad_b : float
        The quadratic terms along the line: value + 2αb + α²a (a >= 0).

    Returns
    -------
    float
        α; 1 when f still decreases at 1, 0 when the direction does not
        descend (rounding at the optimum).
    """
    alpha = 1.0
    first, second = _slope(r, g, limits, 1.0, quad_a, quad_b)
    if first <= 0.0:
        return alpha
    if _slope(r, g, limits, 0.0, quad_a, quad_b)[0] >= 0.0:
        return 0.0
    low, high = 0.0, 1.0
    for _ in range(LINE_SEARCH_STEPS):
        if first > 0.0:
            high = alpha
        else:
            low = alpha
        if second > 0.0 and abs(first) <= LINE_SEARCH_TOL * second:
            # α is the root of its quadratic piece to within LINE_SEARCH_TOL: done. (At
            # such a root f' is rounding, whose sign keeps one end of the bracket far:
            # without this stop the bisection took 25-30 passes over the data to close
            # it, in the first Newton steps at T = 10⁵.)
            if low <= alpha - first / second <= high:
                alpha -= first / second
            break
        alpha = alpha - first / second if second > 0.0 else 0.5 * (low + high)
        if not low < alpha < high:
            alpha = 0.5 * (low + high)
        if high - low <= LINE_SEARCH_TOL:
            break
        first, second = _slope(r, g, limits, alpha, quad_a, quad_b)
        if first == 0.0:
            break
    return alpha


@numba.njit(cache=True, inline="always")
def _slope(r, g, limits, alpha, quad_a, quad_b):  # pragma: no cover - compiled
    """f'(α) and f''(α) of F along the line (see :func:`line_minimum`)."""
    N, q = r.shape
    first, curvature = 0.0, 0.0
    for t in range(N):
        for j in range(q):
            shifted = r[t, j] - alpha * g[t, j]
            delta = limits[t, j]
            # without branches (a few percent of the entries are outliers, at random):
            # the same sums, as clip(shifted, ±δ̃) is shifted or ±δ̃ and adding 0 keeps
            # the (nonnegative) curvature
            first += min(max(shifted, -delta), delta) * g[t, j]
            curvature += g[t, j] * g[t, j] if abs(shifted) <= delta else 0.0
    return -2.0 * first + 2.0 * (alpha * quad_a + quad_b), 2.0 * (curvature + quad_a)


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
