"""What the model-based learning loops share: affine model fits, the trust-region rule, figures.

Used by the cart-pole experiment (:mod:`.rl`, paper Section VIII) and the
gymnasium Pendulum-v1 experiment (:mod:`.gym_rl`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import IdentifiabilityWarning
from ..estimators.fit import fit, fit_lti
from ..estimators.priors import Prior

__all__ = [
    "padded_inputs",
    "fit_affine",
    "improvement_ratio",
    "adapt_radius",
    "median_by_model",
    "quartiles_by_model",
    "draw_learning_curves",
]

# Trust-region adaptation between learning iterations.
_SHRINK_BELOW = 0.1  # ρ below this: the model over-promised; halve the radius
_GROW_ABOVE = 0.5  # ρ above this (and the step as predicted): grow the radius
_GROWTH = 3.0
_DEVIATION_FACTOR = 1.5  # realized state deviation above this × radius: the model mispredicted


def _affine_inputs(u: np.ndarray) -> np.ndarray:
    """Inputs (N, m) with a constant column, padded to the data convention's N + 1 rows."""
    N, m = u.shape
    ua = np.zeros((N + 1, m + 1))
    ua[:N, :m] = u
    ua[:, m] = 1.0
    return ua


def padded_inputs(u: np.ndarray) -> np.ndarray:
    """Inputs (N, m) or (R, N, m) with a missing (NaN) last row: one per state sample, as
    recordings have (the last input is never used by a transition)."""
    pad = np.full(u.shape[:-2] + (1, u.shape[-1]), np.nan)
    return np.concatenate([u, pad], axis=-2)


def fit_affine(
    kind: str, x: np.ndarray, u: np.ndarray, lam: float, priors: Sequence[Prior] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians A (N, n, n), B (N, n, m) of an affine model fitted along one trajectory.

    ``kind`` "lti": :func:`ltvmodels.fit_lti`; otherwise :func:`ltvmodels.fit` with
    ``norm="sq"``, ``order=2``, ``lam`` and ``priors`` (on k_t = vec([A_t B_t c_t]),
    c_t the constant column). x has shape (N + 1, n) and u shape (N, m); the constant
    column is dropped from the returned B.
    """
    m = u.shape[1]
    ua = _affine_inputs(u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        if kind == "lti":
            model = fit_lti(x, ua)
        else:
            model = fit(
                x,
                ua,
                lam=lam,
                norm="sq",
                order=2,
                prior=list(priors or ()) or None,
                compute_cov=False,
            )
    return model.A, model.B[:, :, :m]


def improvement_ratio(previous_cost: float, cost: float, predicted: float) -> float:
    """ρ = (actual cost decrease) / (decrease the model predicted); 0 if none was predicted."""
    promised = previous_cost - predicted
    return (previous_cost - cost) / promised if promised > 0 else 0.0


def adapt_radius(
    radius: float,
    rho: float,
    *,
    max_radius: float,
    moved: float | None = None,
    min_radius: float = 0.0,
) -> float:
    """The trust-region rule of the learning loops: the next radius, at least ``min_radius``.

    ρ < 0.1 (the model over-promised) halves the radius; otherwise a realized
    change of the states ``moved`` above 1.5 × radius (the model mispredicted
    the size of its step) shrinks it to max(radius/4, radius²/moved); otherwise
    ρ > 0.5 triples it.

    Growth stops at ``max_radius``; ``moved`` (the realized change of the states)
    None skips the deviation test.
    """
    if rho < _SHRINK_BELOW:
        radius *= 0.5
    elif moved is not None and moved > _DEVIATION_FACTOR * radius:
        radius *= max(0.25, radius / moved)
    elif rho > _GROW_ABOVE:
        radius = min(_GROWTH * radius, max_radius)
    return max(radius, min_radius)


def median_by_model(values: dict) -> dict:
    """Median over the runs (axis 0) for each model: arrays of shape (iterations,)."""
    return {m: np.median(v, axis=0) for m, v in values.items()}


def quartiles_by_model(values: dict) -> dict:
    """(25 %, 75 %) quantiles over the runs for each model: arrays of shape (2, iterations)."""
    return {m: np.quantile(v, [0.25, 0.75], axis=0) for m, v in values.items()}


def draw_learning_curves(
    ax: Any, values: dict, models: Sequence[str], colors: dict, labels: dict
) -> None:
    """The median per learning iteration with its inter-quartile band, one curve per model.

    ``values[m]`` has shape (runs, iterations); iterations are numbered from 1.
    """
    it = np.arange(1, next(iter(values.values())).shape[1] + 1)
    med, quart = median_by_model(values), quartiles_by_model(values)
    for m in models:
        ax.fill_between(it, quart[m][0], quart[m][1], color=colors[m], alpha=0.2, lw=0)
        ax.plot(it, med[m], color=colors[m], lw=2, label=labels[m])
