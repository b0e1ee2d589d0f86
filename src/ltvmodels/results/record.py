"""What a fit records besides its coefficients: the fit status and the estimation record.

:class:`FitStatus` is one typed record of how every estimator's solution was
obtained (after scipy's ``OptimizeResult`` and Clarabel's solution status):
``status`` is one of the small set :data:`STATUSES`, ``message`` is set from
it, and solver-specific numbers go in ``details``. :class:`FitRecord` bundles
what a model holds besides its coefficients (penalty, λ, covariances, noise,
likelihood, status, free-form ``info``), so that every model class takes it as
one argument.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.covariance import CovarianceBlocks
from .description import DataDescription

__all__ = ["STATUSES", "iterative_status", "FitStatus", "FitRecord"]

STATUSES = {
    "closed_form": "solved exactly by direct linear algebra, without iterations",
    "optimal": "optimal: the optimality conditions hold to the requested tolerance "
    "(for a segmentation: the exact optimum of the search)",
    "optimal_polished": "optimal: the active-set polish fixed the vanishing differences and "
    "certified the optimum to the requested tolerance",
    "stalled": "not optimal to the requested tolerance: the solver made no progress at the "
    "limit of working precision; the last iterate is returned",
    "max_iter": "not optimal to the requested tolerance: the solver stopped at its iteration "
    "limit; the last iterate is returned",
}
"""Every value of :attr:`FitStatus.status`, with its message."""

SUCCESS = ("closed_form", "optimal", "optimal_polished")
"""The statuses of a solution that meets its tolerance."""


def iterative_status(converged: bool, *, polished: bool = False, stalled: bool = False) -> str:
    """The status of an iterative solver from its outcome flags."""
    if converged:
        return "optimal_polished" if polished else "optimal"
    return "stalled" if stalled else "max_iter"


@dataclass(frozen=True)
class FitStatus:
    """How a model's coefficients were computed, and whether that met its tolerance.

    Attributes
    ----------
    status : str
        One of :data:`STATUSES`: ``"closed_form"`` (direct linear algebra:
        the squared norm, least squares, λ >= λ_max), ``"optimal"`` (an
        iterative solver met its tolerance, or a segmentation search found
        its exact optimum), ``"optimal_polished"`` (certified by the
        interior-point method's active-set polish), ``"stalled"`` (no progress
        at working precision before the tolerance) or ``"max_iter"`` (the
        iteration limit).
    solver : str
        The solver that produced the coefficients.
    iterations : int
        Its iterations (0 for a direct solution; 1 for the squared norm's one
        factorization).
    objective : float
        The objective value at the solution (the residual sum of squares for
        least squares and segmentations, plus the penalty where there is one).
    details : dict
        Solver-specific numbers, e.g. ``duality_gap``, ``primal_residual``,
        ``dual_residual``, ``lambda_max`` (interior point), ``rho``,
        ``n_factorizations`` (ADMM).
    """

    status: str
    solver: str
    iterations: int = 0
    objective: float = float("nan")
    details: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status: expected one of {tuple(STATUSES)}, received {self.status!r}")

    @property
    def message(self) -> str:
        """What ``status`` means, in words."""
        return STATUSES[self.status]

    @property
    def success(self) -> bool:
        """True when the solution meets its tolerance (or is exact)."""
        return self.status in SUCCESS

    def to_dict(self) -> dict:
        """The record as JSON-serializable values (for saving a model)."""
        return {
            "status": self.status,
            "solver": self.solver,
            "iterations": int(self.iterations),
            "objective": float(self.objective),
            "details": {key: _plain(value) for key, value in self.details.items()},
        }

    @classmethod
    def from_dict(cls, values: dict) -> FitStatus:
        """The inverse of :meth:`to_dict`."""
        return cls(
            values["status"],
            values["solver"],
            int(values["iterations"]),
            float(values["objective"]),
            dict(values["details"]),
        )

    def __repr__(self) -> str:
        return (
            f"FitStatus(status={self.status!r}, solver={self.solver!r}, "
            f"iterations={self.iterations}, objective={self.objective:.6g})"
        )


def _plain(value: Any) -> Any:
    """numpy scalars as Python numbers (JSON cannot store them)."""
    return value.item() if isinstance(value, np.generic) else value


@dataclass
class FitRecord:
    """Everything a fit computes besides the coefficients k, as one argument of a model.

    Every field is optional, so that a model can also be built from known
    coefficients: ``ltvmodels.LTVModel(k, n, m)``.

    Attributes
    ----------
    norm : str or None
        The penalty: ``"sq"``, ``"group"``, ``"l1"``, or the estimator of an
        unpenalized model (``"lti"``, ``"piecewise"``, ``"l0"``); None for
        given coefficients.
    coeffs : array_like of float, shape (d + 1,), or None
        Difference-operator coefficients c_0 … c_d of the penalty
        (``model.activation()`` uses them; None: the first difference).
    lam : float, ndarray or None
        λ (a scalar, a (K,) vector or a (K, K) matrix); None for given
        coefficients.
    cov : CovarianceBlocks or None
        Posterior covariance of k_t in compact form.
    noise_var : float, ndarray of shape (n,), or None
        Noise variance σ², shared or one per output (None: not estimated, as
        for given coefficients).
    noise_cov : ndarray, shape (n, n), or None
        Noise covariance (None: not estimated).
    loglik : float or None
        Log (marginal) likelihood; None where the estimator defines none (see
        :attr:`RegressionModel.loglik`).
    info : dict
        Estimator-specific facts (see each estimator).
    changepoints : ndarray of int or None
        Change points found by the estimator (None: derived from k).
    status : FitStatus or None
        How the coefficients were computed (None for given coefficients).
    data : DataDescription or None
        What the data said: names, time axis, trajectories, missing rows (None:
        nothing known, as for given coefficients).
    states, states_std : ndarray or None
        The smoothed states E[x_t | recorded x] and their standard deviations,
        the shape of the recorded x, of a fit with measurement noise (None: the
        states were taken as exact).
    measurement_noise : ndarray, shape (n,), or None
        The measurement-noise variance of each state (None: exact states).
    sample_outliers : ndarray of bool, shape (T,) or (R, T), or None
        The recorded samples judged corrupted by a fit with measurement noise
        (None: exact states).
    """

    norm: str | None = None
    coeffs: Any = None
    lam: Any = None
    cov: CovarianceBlocks | None = None
    noise_var: Any = None
    noise_cov: np.ndarray | None = None
    loglik: float | None = None
    info: dict = field(default_factory=dict)
    changepoints: np.ndarray | None = None
    status: FitStatus | None = None
    data: DataDescription | None = None
    states: np.ndarray | None = None
    states_std: np.ndarray | None = None
    measurement_noise: np.ndarray | None = None
    sample_outliers: np.ndarray | None = None
