"""The result of a λ selection (:func:`ltvmodels.select_lambda`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["LambdaSelection"]


@dataclass
class LambdaSelection:
    """The chosen λ and the data behind the choice.

    Attributes
    ----------
    lam : float
        The chosen λ (for norm="l0": the chosen number of changes).
    lams : ndarray, shape (G,)
        The candidates, increasing.
    scores : ndarray, shape (G,)
        The criterion per candidate; the choice maximizes it for "ml" and
        "lcurve" (log-likelihood, curvature) and minimizes it otherwise. The
        curvature is -inf where the L-curve does not bend (neighbouring
        candidates give the same fit, e.g. beyond λ_max), and the BIC/AIC of a
        number of changes whose segments fit exactly is +inf: never the choice.
    method, norm : str
    residual_norms, penalty_norms : ndarray, shape (G,)
        ‖y − Φk‖ and R(Dk) per candidate (the L-curve), where computed (NaN for
        a skipped candidate).
    dof : ndarray, shape (G,) or None
        Effective degrees of freedom per candidate ("gcv").
    loss : str
        The loss the candidates were fitted and scored with ("squared",
        "huber", "laplace").
    huber_delta : list of float or None
        The Huber thresholds used for every candidate (loss="huber").
    skipped : list of (float, str) or None
        Candidates left out because their problem is singular, with the reason
        (they score worst: -inf where the criterion is maximized, +inf where it
        is minimized; ``dof`` and the norms are NaN there).
    n_fits : int or None
        The fits the choice took: one per candidate (for "ml" one banded
        factorization each; "cv": ``n_folds`` per candidate; the sparse
        L-curve's far candidates solved again next to the corner count twice).
    """

    lam: float
    lams: np.ndarray
    scores: np.ndarray
    method: str
    norm: str
    residual_norms: np.ndarray | None = None
    penalty_norms: np.ndarray | None = None
    dof: np.ndarray | None = None
    loss: str = "squared"
    huber_delta: list | None = None
    skipped: list | None = None
    n_fits: int | None = None

    @property
    def maximize(self) -> bool:
        return self.method in ("ml", "lcurve")

    def plot(self, ax: Any = None, *, fig: Any = None):
        """Plot the criterion against λ (or the L-curve), the choice marked.

        See :func:`ltvmodels.plotting.plot_lambda_selection` (which returns the
        Axes). Returns the Figure, as every result's ``plot``: ``fig`` (cleared,
        one axes) when given, the figure of ``ax`` when given, else a new one.
        """
        from ..plotting import plot_lambda_selection
        from ..plotting.figure import axes_in

        return plot_lambda_selection(self, ax=axes_in(fig, ax)).figure
