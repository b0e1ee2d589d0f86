"""Figures of an exact segmentation: the series with its breaks and their confidence
intervals, and the criteria against the number of changes (as R's strucchange draws them)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..results.segmentation import Segmentation
from .figure import new_axes
from .timeaxis import SAMPLE_LABEL, TIME_LABEL, TimeAxis

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = ["plot_breaks", "plot_criteria"]


def plot_breaks(
    segmentation: Segmentation,
    y: ArrayLike,
    phi: ArrayLike | None = None,
    *,
    level: float | None = 0.95,
    ax: Axes | None = None,
) -> Axes:
    """Plot a series with its breaks, their confidence intervals and the fitted segments.

    Each break c is a dashed line between rows c − 1 and c, over a shaded span
    from the lower to the upper end of its interval
    (:meth:`Segmentation.confint`); with ``phi``, the fitted values of the
    model on the segments, ŷ_t = θ_{j(t)}ᵀ φ_t, are drawn over the data.

    Parameters
    ----------
    segmentation : Segmentation
        From :func:`ltvmodels.segment_regression` (one output).
    y : array_like, shape (N,) or (N, 1)
        The response it segmented (NaN where missing).
    phi : array_like, shape (N, p), optional
        Its regressors: then the fitted segments are drawn too.
    level : float or None, default 0.95
        The coverage of the intervals; None draws the breaks only.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes, against the segmentation's time axis (row indices without one).

    Raises
    ------
    TypeError, ValueError
        Not a Segmentation; y of another length or with several outputs; fitted
        values asked of a segmentation without a model.
    """
    if not isinstance(segmentation, Segmentation):
        raise TypeError(
            f"segmentation: expected a Segmentation (from segment_regression), received "
            f"{type(segmentation).__name__}"
        )
    values = np.asarray(y.to_numpy() if hasattr(y, "to_numpy") else y, dtype=float)
    N = segmentation.segments[-1][1]
    if values.ndim == 2 and values.shape[1] == 1:
        values = values[:, 0]
    if values.shape != (N,):
        raise ValueError(
            f"y: expected the {N} rows of one output that were segmented, received shape "
            f"{values.shape}"
        )
    axis = _row_axis(segmentation, N)
    ax = new_axes((7.0, 3.5)) if ax is None else ax
    ax.plot(axis.values, values, color="0.45", lw=1.0, label="data")
    if phi is not None:
        if segmentation.model is None:
            raise ValueError(
                "phi: the segmentation has no model on its segments (they leave no residual "
                "degree of freedom), so there are no fitted values to draw; leave phi out"
            )
        fitted = segmentation.model.predict(phi)[:, 0]
        ax.plot(axis.values, fitted, color="C0", lw=1.8, label="fitted segments")
    intervals, interval_label = None, ""
    if level is not None and segmentation.n_changes:
        intervals, interval_label = segmentation.confint(level), f"{100 * level:g} % intervals"
    for i, c in enumerate(np.asarray(segmentation.changepoints, dtype=int)):
        first = i == 0
        ax.axvline(
            axis.at(np.array([c - 0.5]))[0],
            color="C3",
            ls="--",
            lw=1.2,
            label="breaks" if first else None,
        )
        if intervals is not None and np.all(np.isfinite(intervals[i])):
            lower, _, upper = np.clip(intervals[i], 0, N - 1)
            span = axis.at(np.array([lower - 0.5, upper + 0.5]).clip(0, N - 1))
            ax.axvspan(
                span[0],
                span[1],
                color="C3",
                alpha=0.12,
                lw=0,
                label=interval_label if first else None,
            )
    axis.draw_on(ax)
    ax.set_ylabel(_response_name(segmentation))
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_criteria(segmentation: Segmentation, ax: Axes | None = None) -> Axes:
    """Plot the BIC and the residual sum of squares against the number of changes, the
    BIC's choice marked (strucchange's ``plot`` of a ``breakpointsfull``).

    Parameters
    ----------
    segmentation : Segmentation
        Found with ``n_changes=M`` (:meth:`Segmentation.criteria`).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The BIC's axes; the RSS is on a twin axis on the right.
    """
    if not isinstance(segmentation, Segmentation):
        raise TypeError(
            f"segmentation: expected a Segmentation (from segment_regression), received "
            f"{type(segmentation).__name__}"
        )
    table = segmentation.criteria()
    ax = new_axes((6.0, 3.5)) if ax is None else ax
    m = table["n_changes"]
    ax.plot(m, table["bic"], "o-", color="C0", label="BIC")
    best = table["best_bic"]
    ax.plot(
        m[best], table["bic"][best], "o", ms=10, mfc="none", color="C3", label=f"BIC picks {best}"
    )
    ax.set_xlabel("number of changes")
    ax.set_ylabel("BIC")
    ax.set_xticks(m)
    rss_ax = ax.twinx()
    rss_ax.plot(m, table["rss"], "s--", color="0.45", ms=4, label="RSS")
    rss_ax.set_ylabel("residual sum of squares")
    lines = ax.get_legend_handles_labels()
    more = rss_ax.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], loc="upper center", fontsize="small")
    return ax


def _row_axis(segmentation: Segmentation, N: int) -> TimeAxis:
    """The rows' times (the segmentation's time axis) or their indices."""
    time = segmentation.time
    if time is None:
        return TimeAxis(np.arange(N), SAMPLE_LABEL)
    model = segmentation.model
    name = getattr(getattr(model, "data", None), "time_name", None)
    return TimeAxis(np.asarray(time), name or TIME_LABEL)


def _response_name(segmentation: Segmentation) -> str:
    model = segmentation.model
    names: Any = getattr(model, "output_names", None)
    return str(names[0]) if names else "y"
