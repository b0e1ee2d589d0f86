"""Noisy and partly missing recorded states: the measurement model, fitted by EM.

The model of :func:`ltvmodels.fit` (and :func:`ltvmodels.fit_lti`,
:func:`ltvmodels.fit_piecewise`) with ``measurement_noise``:

    x^r_{t+1} = A_t x^r_t + B_t u^r_t (+ c_t) + w^r_t,   w^r_t ~ N(0, (σ_w² / w_rt) I),
    y^r_t     = x^r_t + e^r_t,                            e^r_{t,i} ~ N(0, σ_{e,i}²),

with y the recorded states (NaN entries unobserved), u exact, w_rt the
transition weights (1 by default), one process variance σ_w² shared by the
states and one measurement variance per state. The process noise is isotropic
so that the M-step for the coefficients is exactly the library's penalized
problem (every norm, order, prior and solver): with Q = σ_w² I the expected
data term Σ E‖x_{t+1} − Θ_t φ_t‖²/σ_w² has the same minimizer for every σ_w²,
and one σ_w² scales the penalty as it scales the data term.

Expectation–maximization increases the penalized log-likelihood

    F(Θ, σ_w², σ_e²) = log p(y | Θ, σ_w², σ_e²) − P(Θ) / (2σ_w²) − ½ Σ_t ‖k_t − μ_t‖²_{Σ_t⁻¹},

where log p(y) is the likelihood of the recorded states (innovations form,
with each chain's first state x_0 ~ N(0, κ I), κ = 10⁶·max(1, largest mean
square of a recorded state)), P(Θ) the penalty of the fit's objective
(λ² Σ‖Dk‖² for "sq", λ Σ‖Dk‖ for "group"/"l1", 0 for the LTI and piecewise
fits, whose constraints are exact) and the last term that of a ``Prior``
(absent without one). Each iteration:

* E-step: the Kalman filter and RTS smoother of the states under the current
  parameters (:mod:`ltvmodels.core.state_smoother`), giving E[x_t], Cov(x_t),
  Cov(x_{t+1}, x_t) and log p(y);
* M-step for Θ: the fit's own problem on pseudo-data with the expected
  statistics Σ w E[φφᵀ] and Σ w E[φ x_{t+1}ᵀ] (φ = [x_t; u_t (; 1)], p rows per
  step), at the current σ_w² (which weighs a prior);
* M-step for the noises, in closed form: σ_w² = (Σ w E‖x_{t+1} − Θ_t φ_t‖² + P(Θ))
  / (n · transitions), and, for ``measurement_noise="estimate"``,
  σ_{e,i}² = mean over the observed entries of state i of E[(y_ti − x_ti)²].

It stops when |F_k − F_{k−1}| <= em_tol · |F_k| or after em_max_iter
iterations. It starts from the fit on the recorded states as if exact (the
fit without measurement noise, which also chooses λ for ``lam="auto"``; EM
then runs at that λ), with σ_w² half and σ_{e,i}² a quarter of the residual
variance of that fit. With ``refine=True`` EM first runs with the penalty,
then again with the coefficients constant (or linear) between the change
points of that fit, whose constraints replace the penalty (P = 0).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core import measurement_weights as robust_measurement
from ..core.problem import RegressionProblem, state_space_problem
from ..core.state_smoother import (
    ExpectedStatistics,
    StateMoments,
    expected_statistics,
    input_offsets,
    prior_variance,
    smooth_states,
)
from ..errors import IdentifiabilityWarning, warn
from ..results.record import FitStatus, iterative_status
from ..validation import options
from .recordings import StateSpaceData
from .robust import outlier_info

__all__ = ["MeasurementEM", "measurement_fit", "penalty_terms", "process_variance"]

MStep = Callable[[RegressionProblem, float], Any]
"""The M-step for Θ: (pseudo-data, current σ_w²) → model."""


@dataclass
class MeasurementEM:
    """The state of EM on one recording (see the module docstring).

    Attributes
    ----------
    data : StateSpaceData
        The validated recording (x as y, with NaN; u exact).
    estimate_noise : bool
        Whether σ_e² is estimated (``"estimate"``) or given.
    fixed_process : bool
        Whether σ_w² is given (``noise_var``) rather than estimated.
    measurement_var : ndarray, shape (n,)
        σ_e² (current).
    process_var : float
        σ_w² (current).
    loss : str
        The measurement loss: "squared", "huber" or "student" (the weights ω of
        :mod:`ltvmodels.core.measurement_weights`, (R, T, n), divide σ_e² in the
        E-step).
    """

    data: StateSpaceData
    estimate_noise: bool
    fixed_process: bool
    measurement_var: np.ndarray
    process_var: float
    loss: str = "squared"

    def __post_init__(self) -> None:
        x, u = self.data.x, self.data.u
        N = x.shape[1] - 1
        link = np.all(np.isfinite(u[:, :N]), axis=2)
        w = self.data.weights
        if w is not None:
            link &= w > 0
        self.link = link
        self.kappa = prior_variance(x)
        self.observed = np.isfinite(x)
        self.observed_counts = self.observed.sum(axis=(0, 1))
        self.objectives: list[float] = []
        # IRLS weights of a robust measurement loss and the s that made them
        self.weights = np.ones(x.shape)
        self.standardized: np.ndarray | None = None

    @property
    def robust(self) -> bool:
        """Whether the measurement loss reweights the entries."""
        return self.loss != "squared"

    def reweight(self, moments: StateMoments) -> None:
        """The weights ω that maximize the bound given the smoothed states (IRLS step)."""
        var = np.diagonal(moments.cov, axis1=2, axis2=3)
        s = robust_measurement.standardized_square(
            self.data.x, moments.mean, var, self.measurement_var
        )
        self.standardized = s
        self.weights = robust_measurement.measurement_weights(self.loss, s, self.observed)

    def e_step(self, model: Any) -> StateMoments:
        """The smoothed states under ``model``'s coefficients and the current variances."""
        x, u = self.data.x, self.data.u
        theta = model.theta  # (N, n, p): A_t in its first n columns
        offset = input_offsets(theta, u, self.link, self.data.constant)
        w = self.data.weights
        qvar: float | np.ndarray = self.process_var
        if w is not None:
            qvar = self.process_var / np.where(self.link, w, 1.0)
        rvar = self.measurement_var
        if self.robust:
            rvar = rvar / self.weights
        return smooth_states(theta, offset, self.link, qvar, x, rvar, self.kappa)

    def statistics(self, moments: StateMoments) -> ExpectedStatistics:
        data = self.data
        return expected_statistics(
            moments, data.u, self.link, data.weights, data.constant, data.problem.coeffs
        )

    def objective(self, moments: StateMoments, model: Any) -> float:
        """F at ``model``'s coefficients and the current variances (E-step done)."""
        penalty, prior = penalty_terms(model)
        value = moments.loglik - (penalty + prior) / (2.0 * self.process_var)
        if self.robust:  # the bound of the robust loss (core.measurement_weights)
            value += robust_measurement.bound_correction(
                self.loss, self.weights, self.standardized, self.observed
            )
        return value

    def update_noise(self, moments: StateMoments, stats: ExpectedStatistics, model: Any) -> None:
        """The closed-form M-steps of σ_w² (with Θ of ``model``) and σ_e² (given the moments)."""
        n = self.data.n
        if not self.fixed_process:
            penalty, _ = penalty_terms(model)
            rows_rss = model.info.get("rss") if model.norm == "sq" else None
            if rows_rss is not None:  # the solver's own sum over the pseudo-rows at Θ
                expected = float(rows_rss) + float(stats.offset.sum())
            else:
                expected = float(stats.expected_rss(model.theta).sum())
            count = max(n * stats.n_transitions, 1)
            self.process_var = max((expected + penalty) / count, 1e-300)
        if self.estimate_noise:
            # with a robust loss the weighted update, which maximizes the bound
            total = moments.measurement_squares(self.data.x, self.weights if self.robust else None)
            counts = self.observed_counts
            fresh = np.where(counts > 0, total / np.maximum(counts, 1), self.measurement_var)
            self.measurement_var = np.maximum(fresh, 1e-300)

    def step(self, moments: StateMoments, mstep: MStep) -> Any:
        """One EM map from the E-step ``moments``: the M-step for Θ, then the noise updates
        (which leave the variances in ``self``); with a robust loss first the weights of
        these states."""
        if self.robust:
            self.reweight(moments)
        stats = self.statistics(moments)
        model = mstep(stats.problem, self.process_var)
        self.update_noise(moments, stats, model)
        return model

    def _vector(self, theta: np.ndarray) -> np.ndarray:
        """The parameter vector of the extrapolation: (Θ, log σ_w², log σ_e²)."""
        return np.concatenate(
            [theta.ravel(), np.log([self.process_var]), np.log(self.measurement_var)]
        )

    def _variances(self) -> tuple[float, np.ndarray, np.ndarray]:
        """The variances and the robust loss's weights (restored when an extrapolation
        is rejected)."""
        return self.process_var, self.measurement_var.copy(), self.weights.copy()

    def _set_variances(self, variances: tuple[float, np.ndarray, np.ndarray]) -> None:
        self.process_var, self.measurement_var = variances[0], variances[1].copy()
        self.weights = variances[2].copy()

    def run(
        self,
        model: Any,
        mstep: MStep,
        tol: float,
        max_iter: int,
        accelerate: bool = True,
    ) -> tuple[Any, StateMoments, int, bool, dict[str, int]]:
        """EM from ``model`` (its coefficients the start): the last model, its E-step,
        the M-steps taken, whether the objective met ``tol``, and the extrapolations
        tried and accepted.

        With ``accelerate`` each cycle is SQUAREM (Varadhan & Roland 2008, scheme
        S3) on the vector (Θ, log σ_w², log σ_e²): from θ₀, two EM maps give θ₁
        and θ₂; with r = θ₁ − θ₀, v = θ₂ − 2θ₁ + θ₀ and α = −‖r‖/‖v‖ (at most −1)
        the point θ₀ − 2αr + α²v is mapped once more by EM. That point is accepted
        only where F there is at least F(θ₁) (so the accepted path is monotone in
        F); otherwise the cycle ends at θ₂, the plain EM iterate. α = −1 is θ₂
        itself. Every accepted point is the output of an M-step, whose penalty
        P(Θ) its solver reports."""
        moments = self.e_step(model)
        if self.robust:  # the objective needs the weights of these states
            self.reweight(moments)
            moments = self.e_step(model)
        self.objectives.append(self.objective(moments, model))
        counts = {"tried": 0, "accepted": 0}
        msteps = 0

        def accept(new: Any, new_moments: StateMoments) -> bool:
            """Append F at the accepted point; whether the relative change met ``tol``."""
            value = self.objective(new_moments, new)
            previous = self.objectives[-1]
            self.objectives.append(value)
            return abs(value - previous) <= tol * max(abs(value), 1e-300)

        converged = False
        while msteps < max_iter and not converged:
            start = self._vector(model.theta) if accelerate else None
            one = self.step(moments, mstep)
            msteps += 1
            moments_one = self.e_step(one)
            converged = accept(one, moments_one)
            model, moments = one, moments_one
            if converged or msteps >= max_iter or start is None:
                continue
            first = self._vector(one.theta)
            two = self.step(moments_one, mstep)
            msteps += 1
            at_two = self._variances()
            r = first - start
            v = self._vector(two.theta) - first - r
            norm_v = float(np.linalg.norm(v))
            alpha = -float(np.linalg.norm(r)) / norm_v if norm_v > 0 else -1.0
            if msteps < max_iter and np.isfinite(alpha) and alpha < -1.0:
                counts["tried"] += 1
                jump = start - 2.0 * alpha * r + alpha * alpha * v
                size = model.theta.size
                self.process_var = float(np.exp(jump[size]))
                self.measurement_var = np.exp(jump[size + 1 :])
                if self.fixed_process:
                    self.process_var = at_two[0]
                if not self.estimate_noise:
                    self.measurement_var = at_two[1].copy()
                proxy = _Coefficients(jump[:size].reshape(model.theta.shape))
                moments_jump = self.e_step(proxy)
                if np.isfinite(moments_jump.loglik):
                    three = self.step(moments_jump, mstep)
                    msteps += 1
                    moments_three = self.e_step(three)
                    value = self.objective(moments_three, three)
                    if np.isfinite(value) and value >= self.objectives[-1]:
                        counts["accepted"] += 1
                        converged = accept(three, moments_three)
                        model, moments = three, moments_three
                        continue
                self._set_variances(at_two)
            moments_two = self.e_step(two)
            converged = accept(two, moments_two)
            model, moments = two, moments_two
        return model, moments, msteps, converged, counts


@dataclass(frozen=True)
class _Coefficients:
    """Coefficients Θ (N, n, p) at an extrapolated point: only an E-step reads them."""

    theta: np.ndarray


def penalty_terms(model: Any) -> tuple[float, float]:
    """P(Θ) of an M-step's model (its objective less its data term) and its prior cost
    (σ_w² times the prior's quadratic form); both 0 for unpenalized fits."""
    info = model.info
    if model.norm == "sq":
        return float(info.get("penalty", 0.0)), float(info.get("prior_cost", 0.0))
    if model.norm in ("group", "l1") and "objective" in info and "rss" in info:
        return max(float(info["objective"]) - float(info["rss"]), 0.0), 0.0
    return 0.0, 0.0


def _start(
    data: StateSpaceData,
    first: Any,
    measurement_noise: Any,
    noise_var: Any,
    loss: str = "squared",
) -> MeasurementEM:
    """The EM state at the fit on the recorded states: σ_w² half, σ_e² a quarter of its
    residual variance (or as given). With a robust measurement loss the residual
    variance is the square of the robust residual scale of that fit (its
    ``outlier_scale``): corrupted samples would inflate the plain one."""
    n = data.n
    residual = np.broadcast_to(np.asarray(first.noise_var, float), (n,))
    scale_rule = first.info.get("outlier_scale")
    if loss != "squared" and scale_rule is not None:
        robust = np.asarray(scale_rule, float) ** 2
        residual = np.where(robust > 0, np.minimum(robust, residual), residual)
    scale = max(float(np.mean(residual)), 1e-300)
    estimate = isinstance(measurement_noise, str)
    measurement = 0.25 * np.maximum(residual, 1e-6 * scale) if estimate else measurement_noise
    process = 0.5 * scale if noise_var is None else float(noise_var)
    return MeasurementEM(
        data, estimate, noise_var is not None, np.array(measurement, float).copy(), process, loss
    )


def process_variance(noise_var: Any, n: int) -> float | None:
    """σ_w² given as ``noise_var`` (one variance shared by the states), or None."""
    value = options.noise_variance(noise_var, n)
    if value is None:
        return None
    values = np.atleast_1d(np.asarray(value, dtype=float))
    if np.ptp(values) > 0:
        raise ValueError(
            "noise_var: with measurement_noise the process noise has one variance shared by "
            f"the states; received {values.tolist()}; pass one number or leave "
            "noise_var out to estimate it"
        )
    return float(values[0])


def _finish(
    em: MeasurementEM,
    model: Any,
    moments: StateMoments,
    converged: bool,
    stages: list[dict],
) -> Any:
    """The EM model: the last M-step's coefficients with the states, the variances, the
    likelihood and the EM record."""
    n = em.data.n
    states, std = moments.mean, moments.std
    if states.shape[0] == 1:
        states, std = states[0], std[0]
    model.states = states
    model.states_std = std
    var = np.diagonal(moments.cov, axis1=2, axis2=3)
    flagged = robust_measurement.sample_outliers(em.data.x, moments.mean, var, em.measurement_var)
    model.sample_outliers = flagged[0] if flagged.shape[0] == 1 else flagged
    model.measurement_noise = em.measurement_var.copy()
    model.noise_var = np.full(n, em.process_var)
    model.noise_cov = em.process_var * np.eye(n)
    model.loglik = moments.loglik
    _warn_if_unseparated(em)
    # model.outliers: the state equation's residuals at the smoothed states (the
    # last M-step's were those of its pseudo-rows, which are no samples)
    data = em.data
    smoothed = state_space_problem(
        moments.mean, data.u, data.problem.coeffs, weights=data.weights, constant=data.constant
    )
    model.info.update(outlier_info(smoothed, model.theta))
    objective = em.objectives[-1]
    total = sum(stage["iterations"] for stage in stages)
    model.info.update(
        {
            "measurement_noise": "estimate" if em.estimate_noise else "given",
            "measurement_loss": em.loss,
            "sample_outlier_threshold": robust_measurement.OUTLIER_THRESHOLD,
            "n_sample_outliers": int(flagged.sum()),
            "em_iterations": int(total),  # M-steps, the cost (with SQUAREM: > accepted points)
            "em_extrapolations": {
                key: int(sum(stage[key] for stage in stages)) for key in ("tried", "accepted")
            },
            "em_converged": bool(converged),
            "em_objective": float(objective),
            "em_objectives": np.array(em.objectives),
            "em_stages": stages,
            "process_noise_var": float(em.process_var),
            "initial_state_var": float(em.kappa),
            "loglik_note": "log p(recorded x | coefficients, noise variances): the "
            "measurement model's likelihood (innovations form, initial state N(0, κI))",
            "cov_note": "no coefficient covariance is computed with measurement noise",
        }
    )
    solver = f"EM (Kalman smoother; M-step: {model.status.solver if model.status else '?'})"
    model.info["solver"] = solver
    model.status = FitStatus(
        iterative_status(converged),
        solver,
        int(total),
        float(objective),
        {"em_converged": bool(converged)},
    )
    return model


# An estimated measurement variance below this fraction of the process variance is
# not told apart from 0 by the fit.
UNSEPARATED = 1e-2


def _warn_if_unseparated(em: MeasurementEM) -> None:
    """Warn when an estimated measurement variance is a small fraction of the process
    variance: the recorded states are nearly exact, or the process noise of a flexible
    model (small λ, short data) absorbs the measurement noise, which the likelihood
    then cannot tell apart from it (measured on the robot arm: σ_e² → 1e-5 with
    σ_w² ≈ 1e-2 whatever the sensor noise added)."""
    if not em.estimate_noise:
        return
    small = em.measurement_var < UNSEPARATED * em.process_var
    if small.any():
        given = em.data.state_names or [f"x{i}" for i in range(small.size)]
        names = [given[i] for i in np.flatnonzero(small)]
        warn(
            f"measurement_noise: the estimated measurement variance of {', '.join(names)} is "
            f"{em.measurement_var[small].max():.3g}, under 1 % of the process noise "
            f"variance {em.process_var:.3g}: either the recorded states are nearly exact "
            "(measurement_noise=None gives the same fit) or this model's process noise "
            "absorbs the measurement noise (small λ, few samples); give the sensor's "
            "variance (measurement_noise=value) or a larger λ",
            IdentifiabilityWarning,
        )


def measurement_fit(
    data: StateSpaceData,
    first: Any,
    mstep: MStep,
    *,
    measurement_noise: Any,
    noise_var: float | None,
    tol: float,
    max_iter: int,
    label: str,
    second: Callable[[Any], MStep] | None = None,
    measurement_loss: str = "squared",
    accelerate: bool = True,
) -> Any:
    """EM from ``first`` (the fit on the recorded states) with the M-step ``mstep``;
    ``second`` (for the two-step refinement) makes from the converged model the M-step of
    a second EM run, which continues from the first (see the module docstring).
    ``measurement_noise`` is validated here (against n); ``noise_var`` is a given σ_w²
    (see :func:`process_variance`) or None; ``measurement_loss`` (validated) is
    "squared", "huber" or "student" (:mod:`ltvmodels.core.measurement_weights`); ``accelerate``:
    SQUAREM cycles (see :meth:`MeasurementEM.run`) rather than plain EM iterations."""
    measurement_noise = options.measurement_noise(measurement_noise, data.n)
    em = _start(data, first, measurement_noise, noise_var, measurement_loss)
    model, moments, iterations, converged, counts = em.run(first, mstep, tol, max_iter, accelerate)
    stages = [{"model": label, "iterations": iterations, "converged": converged, **counts}]
    if second is not None:
        refit = second(model)
        start = len(em.objectives)
        begin = refit(em.statistics(moments).problem, em.process_var)
        model, moments, iterations, converged, counts = em.run(
            begin, refit, tol, max_iter, accelerate
        )
        stages.append(
            {
                "model": "piecewise",
                "iterations": iterations,
                "converged": converged,
                "first_objective_index": start,
                **counts,
            }
        )
    return _finish(em, model, moments, converged, stages)
