"""The structural-break test figure: the F statistics and the critical value."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..results.breaktest import BreakTest
from .figure import ESTIMATE_COLOR, new_axes

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = ["plot_break_test"]


def plot_break_test(test: BreakTest, ax: Axes | None = None) -> Axes:
    """Plot a break test: F_c against the candidate break c with the critical value.

    For supF the F statistics of every candidate row (against the time of the
    rows when y has a time index) with the supF critical value at the test's
    level as a dashed line and the largest F marked; for aveF and expF the
    test's statistic and critical value as lines over the same F statistics
    (they compare with those, not with single F values). For "sequential" the
    supF(l + 1 | l) statistics for l = 0, 1, … against Bai and Perron's
    critical values.

    Parameters
    ----------
    test : BreakTest
        From :func:`ltvmodels.break_test`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into. Default: the single axes of a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (``ax.figure`` is its figure).
    """
    if not isinstance(test, BreakTest):
        raise TypeError(
            f"test: expected a BreakTest (from break_test), received {type(test).__name__}"
        )
    ax = new_axes((6.0, 4.0)) if ax is None else ax
    percent = f"{100 * test.level:g} %"
    if test.kind == "sequential":
        assert test.statistics is not None and test.critical_values is not None
        nulls = np.arange(test.statistics.size)
        ax.plot(nulls, test.statistics, "o-", color=ESTIMATE_COLOR, label="supF(l+1|l)")
        ax.plot(nulls, test.critical_values, "s--", color="C3", label=f"critical value, {percent}")
        ax.set_xticks(nulls)
        ax.set_xlabel("breaks under the null, l")
        ax.set_ylabel("statistic")
        ax.set_title(f"Sequential test: {test.n_breaks} break(s)")
        ax.legend()
        return ax
    assert test.f_rows is not None and test.f_statistics is not None
    x = test.f_rows if test.time is None else test.time[test.f_rows]
    ax.plot(x, test.f_statistics, "-", color=ESTIMATE_COLOR, label="F statistics")
    if test.kind == "supF":
        ax.axhline(test.critical_value, color="C3", ls="--", label=f"critical value, {percent}")
        i = int(np.nanargmax(test.f_statistics))
        ax.plot(x[i], test.f_statistics[i], "o", color="C3", label="supF")
    else:
        ax.axhline(test.statistic, color=ESTIMATE_COLOR, ls=":", label=test.kind)
        ax.axhline(
            test.critical_value, color="C3", ls="--", label=f"{test.kind} critical value, {percent}"
        )
    ax.set_xlabel("first row of the new segment" if test.time is None else "time")
    ax.set_ylabel("F")
    ax.set_title(f"{test.kind} = {test.statistic:.4g}, p = {test.pvalue:.3g}")
    ax.legend()
    return ax
