"""Losses on the residuals, as objects the robust solver dispatches on.

A fit minimizes Σ ρ(r) + penalty over the residual entries r of y − Θφ (rows
scaled by √w). A :class:`Loss` is ρ with what the solvers need of it:

* the squared loss (``closed_form``) is the default of every solver: exact
  banded solves, with a likelihood and covariances;
* a robust loss gives its value (:meth:`Loss.value`, also the score of
  cross-validation), whether it takes a threshold δ in the units of y (Huber:
  ``threshold``; the default is the robust scale of the squared-loss fit's
  residuals, :func:`ltvmodels.core.robust.default_delta`), and its exact
  solver with its certificate (:meth:`Loss.fit`): what it measured, how
  close to optimal it got, and what to say when it did not get there.
  Huber and Laplace have solvers of their own. A smooth convex loss needs
  only ρ and its derivative ψ with ρ'' <= 2 (:meth:`Loss.rho`,
  :meth:`Loss.psi`): the general solver majorizes it by a squared loss and
  solves one squared-loss fit with the fit's penalty per step (below).

The general solver (majorization–minimization): with ρ'' <= 2, ρ(r) <= ρ(r₀)
+ ψ(r₀)(r − r₀) + (r − r₀)², so each step minimizes Σ (ŷ − Φk)² + P(k) with
ŷ = Φk₀ + ψ(r₀)/2, and the objective never increases. That step's optimality
gives a (sub)gradient of P at the new k, so the stationarity residual of the
loss's problem is Φᵀ(2r − 2r₀ + ψ(r₀) − ψ(r)) without differentiating P; the
iteration stops when it is below ``tol`` relative to 1 + 2‖y‖‖Φ‖.

The losses are registered by name (:data:`LOSSES`, ``fit(loss=name)``).
ARCHITECTURE.md ("Adding a loss") lists what else a new loss touches.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .huber import fit_huber, huber_loss
from .huber_sparse import fit_huber_sparse
from .laplace import fit_laplace
from .penalties import Penalty
from .polish import stationarity_scale
from .priorterms import PriorTerm
from .problem import RegressionProblem, apply_difference
from .sparse import solve_sparse
from .squared import SquaredSolver

__all__ = [
    "LOSSES",
    "HuberLoss",
    "LaplaceLoss",
    "Loss",
    "LossFit",
    "SquaredLoss",
    "named",
    "register",
]


@dataclass
class LossFit:
    """What a robust loss's solver found (:meth:`Loss.fit`).

    ``details`` holds its certificate and loss-specific numbers (they become the
    fit status's details); ``failure`` says which tolerance was missed (used
    when ``converged`` is False); ``beyond_delta`` marks the residuals beyond δ
    (N, q, n), Huber's linear region, for a loss with a threshold; ``dual`` is the
    loss's dual point ψ (N, q, n), |ψ| <= 1, where the solver has one (Laplace).
    """

    theta: np.ndarray  # (N, n, p)
    objective: float
    iterations: int
    converged: bool
    stalled: bool
    solver: str
    details: dict
    failure: str
    beyond_delta: np.ndarray | None = None
    dual: np.ndarray | None = None


class Loss:
    """A loss ρ on the residual entries (see the module docstring).

    Attributes
    ----------
    name : str
        The ``loss`` a fit takes.
    closed_form : bool
        The squared loss, solved by the penalties' own solvers.
    threshold : bool
        It takes a threshold δ per output (``huber_delta``).
    priors : bool
        Its solver for the squared norm takes priors on the coefficients and a
        given noise variance.
    """

    name: str = ""
    closed_form: bool = False
    threshold: bool = False
    priors: bool = False

    def rho(self, e: np.ndarray, delta: np.ndarray | None) -> np.ndarray:
        """ρ of residuals ``e`` in the units of y (..., n), entry by entry (ρ'' <= 2)."""
        raise NotImplementedError

    def psi(self, e: np.ndarray, delta: np.ndarray | None) -> np.ndarray:
        """ρ'(e), entry by entry."""
        raise NotImplementedError

    def value(self, r: np.ndarray, scale: np.ndarray, delta: np.ndarray | None) -> float:
        """Σ w ρ(r / √w) of the scaled residuals ``r`` (..., n) with row scales ``scale``
        = √w (..., 1) (the residual in the units of y is r / scale)."""
        return float(np.sum(np.square(scale) * self.rho(self._unscaled(r, scale), delta)))

    def scaled_psi(self, r: np.ndarray, scale: np.ndarray, delta: np.ndarray | None):
        """The derivative of :meth:`value` in each scaled residual: √w ψ(r / √w)."""
        return scale * self.psi(self._unscaled(r, scale), delta)

    @staticmethod
    def _unscaled(r: np.ndarray, scale: np.ndarray) -> np.ndarray:
        return np.divide(
            r, scale, out=np.zeros(np.broadcast_shapes(r.shape, scale.shape)), where=scale > 0
        )

    def fit(
        self,
        problem: RegressionProblem,
        weights: np.ndarray,
        penalty: Penalty,
        delta: np.ndarray,
        *,
        max_iter: int,
        tol: float,
        start: np.ndarray,
        priors: list[PriorTerm] | None,
        prior_scale: np.ndarray | None,
    ) -> LossFit:
        """Minimize Σ ρ(r) plus ``penalty`` with ``weights`` from ``start`` (N, n, p).

        The general solver of a smooth loss (see the module docstring).
        """
        scale = problem.row_scale[:, :, None]
        theta = start
        r = problem.residuals(theta)
        residual, warm, steps = np.inf, None, 0
        while steps < max_iter and residual > tol:
            steps += 1
            psi = self.scaled_psi(r, scale, delta)
            model = RegressionProblem(
                y=problem.y - r + 0.5 * psi,
                phi=problem.phi,
                coeffs=problem.coeffs,
                observed=problem.observed,
                row_scale=problem.row_scale,
            )
            if penalty.closed_form:
                theta = SquaredSolver(model, weights, []).solve(1.0)[0]
            else:
                warm = solve_sparse(
                    model, weights, penalty, max_iter=max_iter, tol=tol * 1e-2, warm_start=warm
                )
                theta = warm.theta
            r_new = problem.residuals(theta)
            mismatch = 2.0 * (r_new - r) + psi - self.scaled_psi(r_new, scale, delta)
            residual = float(np.linalg.norm(np.einsum("tji,tja->tia", mismatch, problem.phi)))
            residual /= stationarity_scale(problem)
            r = r_new
        value = self.value(r, scale, delta) + _penalty_value(problem, weights, penalty, theta)
        return LossFit(
            theta=theta,
            objective=value,
            iterations=steps,
            converged=residual <= tol,
            stalled=False,
            solver="majorization by squared-loss fits",
            details={"kkt_residual": residual},
            failure=(
                f"the KKT residual {residual:.3g} did not reach its tolerance {tol:g} in "
                f"{steps} steps"
            ),
        )

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class SquaredLoss(Loss):
    """ρ(r) = r² (the paper's Gaussian noise)."""

    name = "squared"
    closed_form = True
    priors = True

    def value(self, r: np.ndarray, scale: np.ndarray, delta: np.ndarray | None) -> float:
        return float(np.sum(np.square(r)))


class HuberLoss(Loss):
    """ρ(r) = r² for abs(r) <= δ, 2δ·abs(r) − δ² beyond (cvxpy's ``huber``)."""

    name = "huber"
    threshold = True
    priors = True

    def rho(self, e: np.ndarray, delta: np.ndarray | None) -> np.ndarray:
        if delta is None:
            raise ValueError("huber_delta: the Huber loss needs its threshold δ")
        return huber_loss(e, delta)

    def psi(self, e: np.ndarray, delta: np.ndarray | None) -> np.ndarray:
        if delta is None:
            raise ValueError("huber_delta: the Huber loss needs its threshold δ")
        return 2.0 * np.clip(e, -delta, delta)

    def value(self, r: np.ndarray, scale: np.ndarray, delta: np.ndarray | None) -> float:
        return float(huber_loss(r, delta * scale).sum())

    def fit(
        self,
        problem: RegressionProblem,
        weights: np.ndarray,
        penalty: Penalty,
        delta: np.ndarray,
        *,
        max_iter: int,
        tol: float,
        start: np.ndarray,
        priors: list[PriorTerm] | None,
        prior_scale: np.ndarray | None,
    ) -> LossFit:
        details: dict[str, Any] = {}
        if penalty.closed_form:
            if prior_scale is not None:
                details["prior_scale"] = prior_scale.tolist()
            result: Any = fit_huber(
                problem,
                weights,
                delta,
                max_iter=max_iter,
                tol=tol,
                start=start,
                priors=priors,
                prior_scale=prior_scale,
            )
            solver = "damped Newton on reweighted fits (exact)"
        else:
            result = fit_huber_sparse(
                problem, weights, penalty.name, delta, max_iter=max_iter, tol=tol, start=start
            )
            solver = result.solver
            details["inner_iterations"] = result.inner_iterations
        details.update(
            kkt_residual=result.kkt_residual,
            huber_delta=delta.tolist(),
            n_beyond_delta=int(result.outliers.sum()),
        )
        return LossFit(
            theta=result.theta,
            objective=result.objective,
            iterations=result.iterations,
            converged=result.converged,
            stalled=result.stalled,
            solver=solver,
            details=details,
            failure=(
                f"the KKT residual {result.kkt_residual:.3g} did not reach its tolerance "
                f"{tol:g} in {result.iterations} steps"
            ),
            beyond_delta=result.outliers,
        )


class LaplaceLoss(Loss):
    """ρ(r) = abs(r) (the paper's Laplacian noise, Section IV-A)."""

    name = "laplace"

    def rho(self, e: np.ndarray, delta: np.ndarray | None) -> np.ndarray:
        return np.abs(e)

    def psi(self, e: np.ndarray, delta: np.ndarray | None) -> np.ndarray:
        """sign(e), a subgradient (0 at e = 0; the solver has its own exact dual)."""
        return np.sign(e)

    def value(self, r: np.ndarray, scale: np.ndarray, delta: np.ndarray | None) -> float:
        return float(np.sum(scale * np.abs(r)))

    def fit(
        self,
        problem: RegressionProblem,
        weights: np.ndarray,
        penalty: Penalty,
        delta: np.ndarray,
        *,
        max_iter: int,
        tol: float,
        start: np.ndarray,
        priors: list[PriorTerm] | None,
        prior_scale: np.ndarray | None,
    ) -> LossFit:
        result = fit_laplace(
            problem, weights, penalty.name, delta, max_iter=max_iter, tol=tol, start=start
        )
        return LossFit(
            theta=result.theta,
            objective=result.objective,
            iterations=result.iterations,
            converged=result.converged,
            stalled=result.stalled,
            solver=result.method + (", exact active-set polish" if result.polished else ""),
            details={
                "duality_gap": result.duality_gap,
                "duality_gap_rigorous": result.rigorous,
                "kkt_residual": result.kkt_residual,
                "smoothing": result.smoothing,
                "stages": result.stages,
            },
            dual=result.psi,
            failure=(
                f"the duality gap {result.duality_gap:.3g} (relative) did not reach its "
                f"tolerance {tol:g} "
                + (
                    f"in {result.stages} smoothing stages"
                    if result.stages
                    else f"after {result.iterations} interior-point iterations (of all outputs)"
                )
            ),
        )


def _penalty_value(problem: RegressionProblem, weights: np.ndarray, penalty: Penalty, theta):
    """P(k) of the fit's penalty at Θ (N, n, p)."""
    if penalty.closed_form:
        return SquaredSolver(problem, weights, []).penalty(theta)
    z = apply_difference(theta.reshape(problem.N, -1), problem.coeffs) * weights
    return penalty.value(z)


LOSSES: dict[str, Loss] = {}
"""The losses by name, in the order of the ``loss`` choices."""


def register(loss: Loss) -> Loss:
    """Make ``loss`` available as ``fit(..., loss=loss.name)``; returns it."""
    if not isinstance(loss, Loss) or not isinstance(loss.name, str) or not loss.name:
        raise TypeError(f"loss: expected a Loss with a name, received {loss!r}")
    LOSSES[loss.name] = loss
    return loss


def named(loss: str) -> Loss:
    """The registered loss ``loss`` (a name the fit's options check has accepted)."""
    return LOSSES[loss]


register(SquaredLoss())
register(HuberLoss())
register(LaplaceLoss())
