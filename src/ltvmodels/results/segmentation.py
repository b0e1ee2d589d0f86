"""The result of an exact segmentation of a regression (:func:`ltvmodels.segment_regression`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Segmentation"]


@dataclass(frozen=True)
class Segmentation:
    """Result of :func:`ltvmodels.segment_regression`.

    Attributes
    ----------
    changepoints : ndarray of int64, shape (M,)
        Indices c where a new segment starts (Θ_c ≠ Θ_{c−1}), increasing.
    segments : list of [start, stop]
        The M + 1 segments [start, stop) of row indices.
    cost : float
        Residual sum of squares Σ_t ‖y_t − Θ_t φ_t‖² of the optimal segmentation.
    objective : float
        ``cost`` for a given number of changes; ``cost + penalty · M`` with a penalty.
    n_changes : int
        M, the number of changes of the optimum.
    costs_by_n_changes : ndarray, shape (M_max + 1,), or None
        With ``n_changes=M_max``: the optimal cost with exactly m changes,
        m = 0 … M_max (inf where no feasible segmentation has m changes).
        None with a penalty.
    penalty : float or None
        β in the units of the cost (None with ``n_changes``).
    penalty_rule : str or None
        "bic", "aic", or None (a number was given, or ``n_changes``).
    noise_var : float or None
        The noise variance estimate σ̂² a penalty rule was scaled with.
    min_size : int
        Minimum segment length used.
    solver : str
        "dynamic programming" or "PELT".
    work : int
        Rows rotated into a segment factor (about N²/2 for the dynamic program).
    model : RegressionModel or None
        The least-squares fit on the segments (:func:`ltvmodels.segment_regression`
        sets it when the segments leave a residual degree of freedom).
    time : ndarray, shape (N,), or None
        The time of each row of y (the index of a pandas y, on its regular
        grid); None without one.
    """

    changepoints: np.ndarray
    segments: list
    cost: float
    objective: float
    n_changes: int
    costs_by_n_changes: np.ndarray | None
    penalty: float | None
    penalty_rule: str | None
    noise_var: float | None
    min_size: int
    solver: str
    work: int = field(default=0)
    model: Any = None
    time: np.ndarray | None = None

    @property
    def changepoint_times(self) -> np.ndarray | None:
        """The time of the first row of y under each new segment's coefficients, y[c]
        for change point c; None without a time index."""
        if self.time is None:
            return None
        return self.time[np.asarray(self.changepoints, dtype=int)]

    def plot(self, fig: Any = None):
        """Plot the model on the segments (:meth:`RegressionModel.plot`); needs ``model``."""
        if self.model is None:
            raise ValueError(
                "the segmentation has no model (its segments leave no residual "
                "degree of freedom), so there are no coefficients to plot"
            )
        return self.model.plot(fig=fig)
