"""The λ-selection figure: the criterion against λ, or the L-curve, with the choice marked."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..results.selection import LambdaSelection
from .figure import new_axes

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = ["plot_lambda_selection"]


def plot_lambda_selection(selection: LambdaSelection, ax: Axes | None = None) -> Axes:
    """Plot a λ-selection curve: the criterion against λ, or the L-curve, the choice marked.

    For the L-curve (``method="lcurve"``) the points (‖y − Φk‖, R(Dk)) of the
    candidates on log axes with the corner marked; otherwise the criterion
    against λ (or against the number of changes for ``norm="l0"``) with the
    choice as a dashed line.

    Parameters
    ----------
    selection : LambdaSelection
        From :func:`ltvmodels.select_lambda` or
        :func:`ltvmodels.select_lambda_regression`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure).
    """
    if not isinstance(selection, LambdaSelection):
        raise TypeError(
            f"selection: expected a LambdaSelection (from select_lambda), received "
            f"{type(selection).__name__}"
        )
    s = selection
    ax = new_axes((6.0, 4.0)) if ax is None else ax
    if s.method == "lcurve" and s.residual_norms is not None and s.penalty_norms is not None:
        ax.loglog(s.residual_norms, s.penalty_norms, ".-", color="C0")
        i = int(np.argmin(np.abs(s.lams - s.lam)))
        ax.loglog(
            s.residual_norms[i],
            s.penalty_norms[i],
            "o",
            color="C3",
            label=f"corner, lam = {s.lam:.3g}",
        )
        ax.set_xlabel("residual norm ‖y − Φk‖")
        ax.set_ylabel("penalty R(Dk)")
    else:
        xlabel = "number of changes" if s.norm == "l0" else "lam"
        (ax.plot if s.norm == "l0" else ax.semilogx)(s.lams, s.scores, ".-")
        ax.axvline(s.lam, color="C3", ls="--", label=f"choice: {s.lam:.3g}")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(s.method)
    ax.set_title(f"choosing lam: norm={s.norm!r}, method={s.method!r}")
    ax.legend()
    return ax
