"""The result of an exact segmentation of a regression (:func:`ltvmodels.segment_regression`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.breaks import break_interval, information_criteria
from ..errors import warn
from ..validation import options
from .model_summary import number_text, time_text
from .summary import Section, Summary, Table

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
        The cost of the optimal segmentation, in the units of ``cost_name``:
        the residual sum of squares Σ_t ‖y_t − Θ_t φ_t‖² ("rss"), or
        Σ_s Σ_i [n_s log σ̂²_si + RSS_si / σ̂²_si], −2 × the maximized Gaussian
        log-likelihood without the constant N · n · log 2π ("normal"; N the
        observed rows).
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
        "bic", "aic" (the rule of β, or with ``n_changes`` the criterion that
        chose the number of changes), "lwz" (such a criterion), or None (a
        number was given, or ``n_changes`` alone).
    noise_var : float or None
        The noise variance estimate σ̂² a penalty rule was scaled with.
    min_size : int
        Minimum segment length used.
    solver : str
        "dynamic programming" or "PELT"; with ``fixed`` regressors
        "dynamic programming (partial, exact)" (at most one change: an exact scan),
        "iterated dynamic programming (Bai–Perron)" or "iterated PELT (Bai–Perron)".
    work : int
        Rows rotated into a segment factor (about N²/2 for the dynamic program).
    model : RegressionModel or None
        The least-squares fit on the segments (:func:`ltvmodels.segment_regression`
        sets it when the segments leave a residual degree of freedom).
    time : ndarray, shape (N,), or None
        The time of each row of y (the index of a pandas y, on its regular
        grid); None without one.
    moments : dict or None
        Each segment's least-squares coefficients, regressor second moments,
        noise variance and rows, and the whole sample's
        (:func:`ltvmodels.core.breaks.segment_moments`), which :meth:`confint`
        uses; None where the segmentation did not keep them. With ``fixed``
        regressors: those of the changing regressors z on y − Γ̂x (Γ̂ the common
        coefficients of the joint fit), so the intervals use the change δ of
        the changing coefficients, the second moments of z on each segment and
        the joint residuals' variances (Bai and Perron 1998, partial change).
    fixed : tuple of int
        The regressor columns whose coefficients are common to all segments
        (``fixed=``, the partial structural-change model), sorted; () when
        every coefficient may change.
    iterations : int
        The alternations of Bai and Perron's iterated procedure behind the
        reported optimum (0 for an exact search).
    converged : bool
        Whether that procedure stopped on its tolerance (True for an exact
        search); False after its maximum number of iterations.
    tolerance : float or None
        Its tolerance on the relative decrease of the objective per iteration
        (None for an exact search).
    cost_name : {"rss", "normal"}
        The segment cost that was minimized.
    segment_variances : ndarray, shape (M + 1, n), or None
        With ``cost_name="normal"``: each segment's noise variance per output
        σ̂²_si = max(RSS_si / n_s, σ²_floor,i) (maximum likelihood, floored);
        None with "rss".
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
    moments: dict | None = field(default=None, repr=False, compare=False)
    fixed: tuple = ()
    iterations: int = 0
    converged: bool = True
    tolerance: float | None = None
    cost_name: str = "rss"
    segment_variances: np.ndarray | None = field(default=None, compare=False)

    @property
    def changepoint_times(self) -> np.ndarray | None:
        """The time of the first row of y under each new segment's coefficients, y[c]
        for change point c; None without a time index."""
        if self.time is None:
            return None
        return self.time[np.asarray(self.changepoints, dtype=int)]

    def confint(
        self, level: float = 0.95, *, het_reg: bool = True, het_err: bool = True
    ) -> np.ndarray:
        """Confidence intervals of the break dates (Bai 1997), as R's strucchange.

        For each change point c the interval of the date where the new
        segment's coefficients start (a change of the coefficients: with
        ``cost="normal"``, a change of the noise level alone has no interval
        here), from the limit distribution of the
        estimated date (:mod:`ltvmodels.core.breaks`), with strucchange's
        ``confint.breakpointsfull`` conventions: the same numbers on the same
        data (the row index c here is strucchange's break number).

        Parameters
        ----------
        level : float, default 0.95
            The coverage, in (0, 1).
        het_reg : bool, default True
            Each segment's own regressor second moments (False: the whole
            sample's), strucchange's ``het.reg``.
        het_err : bool, default True
            Each segment's own noise variance (False: one for all segments),
            strucchange's ``het.err``.

        Returns
        -------
        ndarray of float, shape (M, 3)
            Rows [lower, c, upper] in the row indices of y (the first row of
            the new segment at the lower end, the latest at the upper end). A
            bound that cannot be computed (P(argmax ≤ 0) outside the
            interval's tails, strucchange's "cannot be computed") is NaN, with
            a warning.

        Raises
        ------
        ValueError
            No change points, several outputs (the interval is that of one
            regression equation), a level outside (0, 1), or a segmentation
            without its moments (a model-free one: too few rows).
        """
        level = options.interval_level(level, "level")
        moments = self._interval_moments()
        intervals = np.full((self.n_changes, 3), np.nan)
        for i, c in enumerate(np.asarray(self.changepoints, dtype=int)):
            delta = moments["coefficients"][i + 1, :, 0] - moments["coefficients"][i, :, 0]
            pooled_q, pooled_var = moments["pooled_second_moment"], moments["pooled_variance"][0]
            offsets = break_interval(
                delta,
                moments["second_moments"][i] if het_reg else pooled_q,
                moments["second_moments"][i + 1] if het_reg else pooled_q,
                moments["variances"][i, 0] if het_err else pooled_var,
                moments["variances"][i + 1, 0] if het_err else pooled_var,
                level,
            )
            intervals[i, 1] = c
            if offsets is None:
                warn(
                    f"the confidence interval of change point {c} cannot be computed: the "
                    "limit distribution of its date puts less than the interval's tail on "
                    "one side of it (noise levels or regressor moments that differ greatly "
                    "across the break; het_err=False or het_reg=False pools them)",
                    RuntimeWarning,
                )
                continue
            lower, upper = offsets
            intervals[i, 0], intervals[i, 2] = c - math.ceil(upper), c - math.floor(lower)
        return intervals

    def confint_times(
        self, level: float = 0.95, *, het_reg: bool = True, het_err: bool = True
    ) -> np.ndarray | None:
        """:meth:`confint` as times of the rows of y (dates for a dated y), (M, 3); None
        without a time index. A bound outside the data is clipped to its first or last
        row; one that cannot be computed is NaT (dates) or NaN."""
        if self.time is None:
            return None
        intervals = self.confint(level, het_reg=het_reg, het_err=het_err)
        missing = np.isnan(intervals)
        rows = np.clip(np.nan_to_num(intervals), 0, self.time.size - 1).astype(int)
        times = self.time[rows]
        if missing.any():
            times = times.astype(times.dtype if times.dtype.kind == "M" else float)
            times[missing] = np.datetime64("NaT") if times.dtype.kind == "M" else np.nan
        return times

    def criteria(self) -> dict[str, Any]:
        """Information criteria of the optimal segmentations with 0 … M changes.

        With ``n_changes=M`` the search found the optimal cost C_m for every
        m ≤ M (:attr:`costs_by_n_changes`); this ranks them as Bai and Perron
        (2003) and R's strucchange do
        (:func:`ltvmodels.core.breaks.information_criteria`). For one output,
        r observed rows and p regressors, p_x of them ``fixed`` (0 by default)
        and p_z = p − p_x changing, with the residual sum of squares:

        * the Gaussian log-likelihood ℓ_m = −r/2 (log(C_m/r) + 1 + log 2π);
        * BIC_m = −2ℓ_m + (p_x + (p_z + 1)(m + 1)) log r, counting the
          coefficients, the break dates and the noise variance (strucchange's
          ``summary`` table when p_x = 0), and AIC_m with 2 for log r;
        * LWZ_m = log(C_m/(r − p*)) + p* · 0.299 (log r)^2.1 / r with
          p* = (m + 1)p_z + m + p_x (Liu, Wu and Zidek 1997, as Bai and Perron
          use it).

        With n outputs the n p coefficients of each segment count, and one noise
        variance over the r · n residuals. With fixed regressors C_m for m >= 2
        is the iterated procedure's (a local optimum at worst, see
        :func:`ltvmodels.segment_regression`).

        With ``cost_name="normal"`` the optimal cost C_m is already −2ℓ_m
        without its r · n · log 2π term, with a noise variance per segment and
        output (floored: see :func:`ltvmodels.fit_segments`), so
        ℓ_m = −(C_m + r n log 2π) / 2 and the variances count among the
        parameters: BIC_m = −2ℓ_m + ((p + 1)(m + 1) + m) log r for one output.
        LWZ, a criterion for one common noise variance, is not given.

        Returns
        -------
        dict
            ``n_changes`` (M + 1,) = 0 … M, ``cost`` (the optimal costs),
            ``loglik``, ``bic``, ``aic`` (M + 1,) each (inf / nan where no
            segmentation has m changes) and ``best_bic``, ``best_aic``, the m that
            minimizes each; with "rss" also ``rss`` (= ``cost``), ``lwz`` and
            ``best_lwz``.

        Raises
        ------
        ValueError
            A segmentation with a penalty (no costs for each m), or without its
            segments' moments (no residual degree of freedom).
        """
        if self.costs_by_n_changes is None:
            raise ValueError(
                "criteria: this segmentation was found with a penalty, so it has no "
                "optimal cost for each number of changes; segment with n_changes=M "
                "(the most changes to consider)"
            )
        moments = self._moments("criteria", single_output=False)
        rows = int(moments["rows"].sum())
        p, n = moments["coefficients"].shape[1:]  # the changing regressors' moments
        costs = np.asarray(self.costs_by_n_changes, dtype=float)
        table = information_criteria(costs, rows, n, p, len(self.fixed), self.cost_name)
        table["cost"] = costs
        if self.cost_name == "rss":
            table["rss"] = costs
        return table

    def summary(self, level: float = 0.95) -> Summary:
        """A report: the search, each break with its confidence interval (and dates),
        the criteria for 0 … M changes where known, and the model on the segments
        (its coefficients per segment with standard errors).

        Parameters
        ----------
        level : float, default 0.95
            The coverage of the break-date intervals (:meth:`confint`).

        Returns
        -------
        Summary
            The text report (a ``str``), with ``as_html()`` for notebooks.
        """
        how = f"{self.n_changes} change{'s' if self.n_changes != 1 else ''} " + self._how()
        search = Section(
            "Segmentation",
            (
                ("changes", how),
                ("solver", self.solver),
                self._cost_line(),
                ("minimum segment", f"{self.min_size} rows"),
            )
            + (
                (
                    ("fixed regressors", ", ".join(self._regressor_name(c) for c in self.fixed)),
                    ("iterations", f"{self.iterations} (converged: {self.converged})"),
                )
                if self.fixed
                else ()
            ),
        )
        sections = [search]
        if self.segment_variances is not None:
            sections.append(self._variances_section())
        elif self.n_changes and self._single_output:
            sections.append(self._breaks_section(level))
        if self.costs_by_n_changes is not None and self._single_output and self.cost_name == "rss":
            table = self.criteria()
            rows = tuple(
                (str(m), number_text(rss, 6), number_text(bic, 6), number_text(lwz, 6))
                for m, rss, bic, lwz in zip(
                    table["n_changes"], table["rss"], table["bic"], table["lwz"]
                )
            )
            sections.append(
                Section(
                    "Number of changes",
                    (("BIC picks", str(table["best_bic"])), ("LWZ picks", str(table["best_lwz"]))),
                    (Table("criteria", ("changes", "RSS", "BIC", "LWZ"), rows),),
                )
            )
        elif self.costs_by_n_changes is not None and self._single_output:
            table = self.criteria()
            lines = tuple(
                (str(m), number_text(cost, 6), number_text(bic, 6))
                for m, cost, bic in zip(table["n_changes"], table["cost"], table["bic"])
            )
            sections.append(
                Section(
                    "Number of changes",
                    (("BIC picks", str(table["best_bic"])),),
                    (Table("criteria", ("changes", "−2 log L − n log 2π", "BIC"), lines),),
                )
            )
        if self.model is not None:
            own = self._per_segment_coefficients
            for section in self.model.summary().sections:
                if section.title == "Coefficients" and own:
                    section = self._coefficients_section()
                sections.append(section)
        return Summary(f"Segmentation({how}, solver={self.solver!r})", sections)

    def _how(self) -> str:
        """How the number of changes was set: given, chosen by a criterion, or a penalty."""
        if self.penalty is not None:
            return f"(penalty {self.penalty:.4g})"
        if self.penalty_rule is not None and self.costs_by_n_changes is not None:
            most = len(self.costs_by_n_changes) - 1
            return f"({self.penalty_rule.upper()} picks among 0 … {most})"
        return "(n_changes given)"

    def _variances_section(self) -> Section:
        """Each segment's rows (and times) with its noise variances (``cost="normal"``):
        the break-date intervals of :meth:`confint` are those of a change of the
        coefficients, not of the noise level, so they are not reported here."""
        variances = np.asarray(self.segment_variances)
        header: tuple[str, ...] = ("segment", "rows")
        if self.time is not None:
            header += ("from (time)",)
        header += tuple(f"σ² output {i}" for i in range(variances.shape[1]))
        rows = []
        for j, (a, b) in enumerate(self.segments):
            row = [str(j + 1), f"{a}–{b - 1}"]
            if self.time is not None:
                row += time_text(self.time[[a]])
            rows.append((*row, *(number_text(v, 6) for v in variances[j])))
        return Section(
            "Segments",
            (("noise", "a variance per segment and output (maximum likelihood, floored)"),),
            (Table("noise variances", header, tuple(rows)),),
        )

    def _cost_line(self) -> tuple[str, str]:
        """The summary's line for the optimal cost, named after the cost."""
        if self.cost_name == "normal":
            return ("−2 log L − n log 2π", number_text(self.cost, 6))
        return ("RSS", number_text(self.cost, 6))

    def _repr_html_(self) -> str:
        return self.summary().as_html()

    def _regressor_name(self, column: int) -> str:
        """Regressor ``column`` by its name where the model knows it, else its index."""
        names = getattr(self.model, "regressor_names", None)
        return f"{names[column]} ({column})" if names else str(column)

    @property
    def _single_output(self) -> bool:
        """Whether the segments' moments are kept, for one output (what intervals and
        criteria need)."""
        return self.moments is not None and self.moments["coefficients"].shape[2] == 1

    def _breaks_section(self, level: float) -> Section:
        """The change points with their confidence intervals (rows, and times)."""
        intervals = self.confint(level)
        percent = f"{100 * level:g} %"
        header: tuple[str, ...] = ("break", f"{percent} from", "row", "to")
        cells = [[number_text(value, 12) for value in row] for row in intervals]
        times = self.confint_times(level)
        if times is not None:
            header += ("from (time)", "time", "to (time)")
            for row, stamps in zip(cells, times):
                row += time_text(stamps)
        rows = tuple((str(i + 1), *row) for i, row in enumerate(cells))
        return Section(
            "Breaks",
            (("intervals", f"Bai (1997), {percent}, per-segment moments (as strucchange)"),),
            (Table("break dates", header, rows),),
        )

    def _interval_moments(self) -> dict:
        if self.n_changes == 0:
            raise ValueError(
                "confint: the segmentation has no change points; there are no break "
                "dates to give intervals for"
            )
        return self._moments("confint")

    def _moments(self, name: str, *, single_output: bool = True) -> dict:
        """The segments' moments, for ``name`` (the method that needs them; of one output
        unless ``single_output`` is False)."""
        if self.moments is None:
            raise ValueError(
                f"{name}: this segmentation did not keep its segments' moments (its "
                "segments leave no residual degree of freedom); give more rows per "
                "segment (min_size)"
            )
        outputs = self.moments["coefficients"].shape[2]
        if single_output and outputs != 1:
            raise ValueError(
                f"{name}: it is defined for one regression equation; this segmentation "
                f"has {outputs} outputs: segment each output on its own"
            )
        return self.moments

    def vcov(self, *, het_err: bool = True) -> np.ndarray:
        """The covariance of each segment's least-squares coefficients, as strucchange's
        ``vcov.breakpointsfull``.

        For segment i with r_i rows, second moments Q_i = Φ_iᵀΦ_i / r_i and noise
        variance σ²_i = RSS_i / r_i (maximum likelihood), the covariance is
        σ²_i Q_i⁻¹ / r_i. With ``het_err=False`` one variance, RSS / r over all
        rows, serves every segment (with each segment's own Q_i: the covariance
        of the segmented least squares under one noise level; strucchange's
        ``het.err = FALSE`` also pools Q).

        Parameters
        ----------
        het_err : bool, default True
            Each segment's own noise variance (strucchange's default).

        Returns
        -------
        ndarray, shape (M + 1, p, p)
            One covariance per segment, for the p regressors of the one output.

        Raises
        ------
        ValueError
            Several outputs, fixed regressors (their joint covariance is
            ``model.cov``), or a segmentation without its moments.
        """
        moments = self._moments("vcov")
        if self.fixed:
            raise ValueError(
                "vcov: with fixed regressors the segments share coefficients, so their "
                "covariance is joint; use the model's: segmentation.model.cov or .std()"
            )
        second, rows = moments["second_moments"], moments["rows"]
        if het_err:
            variances = moments["variances"][:, 0]
        else:
            variances = np.full(rows.size, moments["pooled_variance"][0])
        identity = np.broadcast_to(np.eye(second.shape[1]), second.shape)
        return (variances / rows)[:, None, None] * np.linalg.solve(second, identity)

    def to_frame(self, *, het_err: bool = True) -> Any:
        """Each segment's coefficients with their standard errors, as a table.

        Parameters
        ----------
        het_err : bool, default True
            Standard errors from each segment's own noise variance (:meth:`vcov`).

        Returns
        -------
        pandas.DataFrame
            One row per segment and regressor: ``segment`` (1 …), ``start`` and
            ``stop`` (rows [start, stop)), ``first_time`` (the time of the first
            row, with a time index), ``regressor``, ``estimate``, ``std_err`` and
            ``z``.
        """
        import pandas as pd

        moments = self._moments("to_frame")
        std = np.sqrt(np.diagonal(self.vcov(het_err=het_err), axis1=1, axis2=2))
        names = self._regressor_names(std.shape[1])
        records = []
        for i, (start, stop) in enumerate(self.segments):
            for j, name in enumerate(names):
                estimate = float(moments["coefficients"][i, j, 0])
                record = {"segment": i + 1, "start": start, "stop": stop}
                if self.time is not None:
                    record["first_time"] = self.time[start]
                record.update(
                    regressor=name, estimate=estimate, std_err=std[i, j], z=estimate / std[i, j]
                )
                records.append(record)
        return pd.DataFrame.from_records(records)

    @property
    def _per_segment_coefficients(self) -> bool:
        """Whether the summary gives each segment's coefficients from its own moments
        (one output, every coefficient changing)."""
        return self._single_output and not self.fixed

    def _regressor_names(self, count: int) -> list[str]:
        names = getattr(self.model, "regressor_names", None)
        return list(names) if names else [f"phi{j}" for j in range(count)]

    def _coefficients_section(self) -> Section:
        """Each segment's coefficients with standard errors from its own noise variance
        (:meth:`vcov`, strucchange's default)."""
        moments = self._moments("summary")
        std = np.sqrt(np.diagonal(self.vcov(), axis1=1, axis2=2))
        names = self._regressor_names(std.shape[1])
        tables = []
        for i, (start, stop) in enumerate(self.segments):
            caption = f"segment {i + 1} of {len(self.segments)}: rows {start}–{stop - 1}"
            if self.time is not None:
                first, last = time_text(self.time[[start, stop - 1]])
                caption += f" ({first} – {last})"
            rows = []
            for j, name in enumerate(names):
                estimate, error = moments["coefficients"][i, j, 0], std[i, j]
                cells = (
                    number_text(estimate),
                    number_text(error),
                    number_text(estimate / error, 3),
                )
                rows.append(
                    (name, *cells) if error > 0 else (name, number_text(estimate), "—", "—")
                )
            tables.append(Table(caption, ("coefficient", "estimate", "std err", "z"), tuple(rows)))
        return Section(
            "Coefficients",
            (("standard errors", "each segment's own noise variance (strucchange's vcov)"),),
            tuple(tables),
        )

    def plot(self, fig: Any = None):
        """Plot the model on the segments (:meth:`RegressionModel.plot`); needs ``model``."""
        if self.model is None:
            raise ValueError(
                "the segmentation has no model (its segments leave no residual "
                "degree of freedom), so there are no coefficients to plot"
            )
        return self.model.plot(fig=fig)
