"""The result of a test for structural breaks (:func:`ltvmodels.break_test`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .model_summary import number_text, time_text
from .summary import Section, Summary, Table

__all__ = ["BreakTest"]

_NAMES = {
    "supF": "supF test (Andrews 1993), Hansen (1997) p-value",
    "aveF": "aveF test (Andrews and Ploberger 1994), Hansen (1997) p-value",
    "expF": "expF test (Andrews and Ploberger 1994), Hansen (1997) p-value",
    "sequential": "sequential supF(l+1|l) tests (Bai and Perron 1998), "
    "Bai and Perron (2003) critical values",
}


@dataclass(frozen=True)
class BreakTest:
    """Result of :func:`ltvmodels.break_test`.

    Attributes
    ----------
    kind : str
        "supF", "aveF", "expF" or "sequential".
    statistic : float
        supF, aveF or expF; for "sequential" the supF(l + 1 | l) statistic of
        the test that ended the procedure (the first that did not reject, or
        the last one).
    pvalue : float
        Hansen's (1997) approximate asymptotic p-value (Chow's F test with a
        single candidate, as strucchange); NaN for "sequential" (compare
        ``statistics`` with ``critical_values``).
    level : float
        The significance level of ``reject`` and the critical values.
    reject : bool
        Whether the test rejects "no break" at ``level`` (for "sequential":
        at least one break selected).
    critical_value : float
        The statistic at which the test rejects at ``level``: p-value =
        ``level`` (for "sequential", the critical value of the test that ended
        the procedure).
    trim : float
        The trimming fraction.
    min_size : int
        The shortest segment: the first candidate row for supF/aveF/expF
        (strucchange's ``from``), h = ⌊trim · N⌋ (at least p + 1) for
        "sequential".
    n_regressors : int
        p.
    n_observations : int
        The observed rows n.
    break_index : int or None
        supF/aveF/expF: the row c with the largest F statistic, where the new
        segment starts (y[c] is its first row, as
        :attr:`Segmentation.changepoints`; strucchange's ``breakpoint``). None
        for "sequential" (see ``breaks``).
    f_statistics : ndarray, shape (K,), or None
        supF/aveF/expF: F_c for every candidate c in ``f_rows`` (NaN where a
        side's regressors are singular).
    f_rows : ndarray of int, shape (K,), or None
        The candidate rows c of ``f_statistics``.
    lam : float or None
        strucchange's λ = (n − from) · to / (from · (n − to)) of the p-values.
    n_breaks : int or None
        "sequential": the selected number of breaks.
    statistics : ndarray, shape (L,), or None
        "sequential": supF(l + 1 | l) for l = 0 … L − 1 (all of them, also
        past the first non-rejection).
    critical_values : ndarray, shape (L,), or None
        "sequential": Bai and Perron's critical values at ``level``.
    breaks : ndarray of int, shape (n_breaks,), or None
        "sequential": the change points of the optimal segmentation with
        ``n_breaks`` breaks (rows where a new segment starts).
    time : ndarray, shape (N,), or None
        The time of each row of y (a pandas y's index on its grid); None
        without one.
    """

    kind: str
    statistic: float
    pvalue: float
    level: float
    reject: bool
    critical_value: float
    trim: float
    min_size: int
    n_regressors: int
    n_observations: int
    break_index: int | None = None
    f_statistics: np.ndarray | None = field(default=None, repr=False)
    f_rows: np.ndarray | None = field(default=None, repr=False)
    lam: float | None = None
    n_breaks: int | None = None
    statistics: np.ndarray | None = None
    critical_values: np.ndarray | None = None
    breaks: np.ndarray | None = None
    time: np.ndarray | None = field(default=None, repr=False)

    @property
    def break_time(self) -> Any:
        """The time of y[``break_index``] (the first row of the new segment); None without
        a time index or for "sequential"."""
        if self.time is None or self.break_index is None:
            return None
        return self.time[self.break_index]

    @property
    def break_times(self) -> np.ndarray | None:
        """ "sequential": the times of y at ``breaks``; None without a time index."""
        if self.time is None or self.breaks is None:
            return None
        return self.time[np.asarray(self.breaks, dtype=int)]

    def summary(self) -> Summary:
        """A report: the test, its statistic, p-value or critical values, and the break(s).

        Returns
        -------
        Summary
            The text report (a ``str``), with ``as_html()`` for notebooks.
        """
        fields: list[tuple[str, str]] = [
            ("test", _NAMES[self.kind]),
            ("observations", str(self.n_observations)),
            ("regressors", str(self.n_regressors)),
            ("trimming", f"{self.trim:g} (segments of at least {self.min_size} rows)"),
        ]
        tables: tuple[Table, ...] = ()
        if self.kind == "sequential":
            assert self.statistics is not None and self.critical_values is not None
            fields.append(("breaks selected", f"{self.n_breaks} at level {self.level:g}"))
            if self.breaks is not None and self.breaks.size:
                fields.append(("break rows", ", ".join(str(int(b)) for b in self.breaks)))
                times = self.break_times
                if times is not None:
                    fields.append(("break times", ", ".join(time_text(times))))
            rows = tuple(
                (
                    f"supF({nulls + 1}|{nulls})",
                    number_text(stat, 6),
                    number_text(cv, 4),
                    "yes" if stat > cv else "no",
                )
                for nulls, (stat, cv) in enumerate(zip(self.statistics, self.critical_values))
            )
            header = ("test", "statistic", f"critical value ({100 * self.level:g} %)", "rejects")
            tables = (Table("sequential tests", header, rows),)
        else:
            fields += [
                (self.kind, number_text(self.statistic, 6)),
                ("p-value", number_text(self.pvalue, 4)),
                (f"critical value ({100 * self.level:g} %)", number_text(self.critical_value, 4)),
                ("rejects no break", "yes" if self.reject else "no"),
                ("largest F at row", str(self.break_index)),
            ]
            if self.break_time is not None:
                fields.append(("its time", time_text(np.asarray([self.break_time]))[0]))
        head = (
            f"BreakTest(sequential, n_breaks={self.n_breaks})"
            if self.kind == "sequential"
            else f"BreakTest({self.kind}={self.statistic:.4g}, p={self.pvalue:.3g})"
        )
        return Summary(head, [Section("Structural break test", tuple(fields), tables)])

    def _repr_html_(self) -> str:
        return self.summary().as_html()

    def plot(self, ax: Any = None, *, fig: Any = None):
        """Plot the F statistics with the critical value (or, for "sequential", the
        supF(l + 1 | l) statistics against their critical values).

        See :func:`ltvmodels.plotting.plot_break_test`. Returns the Figure: ``fig``
        (cleared, one axes) when given, the figure of ``ax`` when given, else a new one.
        """
        from ..plotting import plot_break_test
        from ..plotting.figure import axes_in

        return plot_break_test(self, ax=axes_in(fig, ax)).figure
