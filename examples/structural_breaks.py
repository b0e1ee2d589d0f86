"""
Structural breaks with inference: the Nile and the UK seat-belt law
===================================================================

The two classic analyses of R's strucchange, redone with ltvmodels and
printed next to strucchange's own figures (strucchange 1.5-3; the test suite
compares them to all printed digits):

* the Nile's annual flow, y ~ 1: one break, its 95 % confidence interval, the
  supF test and Bai and Perron's sequential test;
* the UK car-driver deaths (log10), y[t] ~ y[t−1] + y[t−12] + 1 with
  h = 0.1: two breaks with their intervals, the RSS and BIC of 0 … 8 breaks,
  and the supF test;
* the same deaths with the monthly pattern held fixed across segments
  (partial structural change, ``fixed=``): the level's breaks alone.

Writes a figure of the series with their breaks and intervals, the criteria
and the F statistics. Row c is the first observation of a new segment;
strucchange numbers a break by the last observation of the old one, so its
*dates* are one step earlier than ours for the same break.

Usage::

    python examples/structural_breaks.py [--out structural_breaks.png]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import ltvmodels as ltv
from ltvmodels.errors import OutputPathError
from ltvmodels.plotting import plot_break_test, plot_breaks, plot_criteria
from ltvmodels.plotting.figure import image_file, new_figure, save_figure

# strucchange 1.5-3 on the same data (R: breakpoints, confint, summary, Fstats, sctest)
STRUCCHANGE = {
    "nile break": "28 (1898), [25, 32]",
    "seatbelt breaks": "46 (1973(10)), 157 (1983(1)); [33, 56], [144, 171]",
    "seatbelt rss": "0.3297082, 0.2967377, 0.2675731, 0.2438039, 0.2395281, 0.2317149, "
    "0.2258093, 0.224386, 0.2231045",
    "seatbelt bic": "0 breaks (-602.86)",
    "seatbelt supF": "19.333, p = 0.0067, at 46",
    "seatbelt segment 1": "y[t-1] 0.117 (0.111), y[t-12] 0.694 (0.108), const 0.633 (0.327)",
}


def month(stamp: np.datetime64) -> str:
    return str(np.datetime64(stamp, "M"))


def row(label: str, ours: str, theirs: str) -> None:
    print(f"  {label:<18} ours:        {ours}")
    print(f"  {'':<18} strucchange: {theirs}")


def nile_analysis() -> tuple:
    nile = ltv.datasets.nile()
    level = np.ones((nile.size, 1))
    seg = ltv.segment_regression(nile, level, n_changes=1, trim=0.15)
    ((lower, c, upper),) = seg.confint(0.95).astype(int)
    supf = ltv.break_test(nile, level, kind="supF", trim=0.15)
    sequential = ltv.break_test(nile, level, kind="sequential", trim=0.15)
    print("Nile, annual flow 1871-1970, y ~ 1, h = 0.15")
    row(
        "break, 95 %",
        f"{c} (first year of the new level {nile.index[c]}), [{lower}, {upper}]",
        STRUCCHANGE["nile break"],
    )
    print(
        f"  supF               {supf.statistic:.3f}, p = {supf.pvalue:.2g}, at {supf.break_index}"
    )
    print(
        f"  sequential tests   {sequential.n_breaks} break "
        f"(supF(2|1) = {sequential.statistics[1]:.2f} < {sequential.critical_values[1]:.2f})"
    )
    return nile, level, seg, supf


def seatbelt_analysis() -> tuple:
    deaths = np.log10(ltv.datasets.uk_driver_deaths())
    values = deaths.to_numpy()
    # y_t on y_{t-1}, y_{t-12} and a level, from January 1970 on (the first 12 are only lags)
    phi = np.column_stack([values[11:-1], values[:-12], np.ones(values.size - 12)])
    y = deaths.iloc[12:]
    seg = ltv.segment_regression(y, phi, n_changes=2, trim=0.1)
    table = ltv.segment_regression(y, phi, n_changes=8, trim=0.1).criteria()
    supf = ltv.break_test(y, phi, kind="supF", trim=0.1)
    intervals = seg.confint(0.95).astype(int)
    print("\nUK car-driver deaths (log10) 1970-1984, y ~ y[t-1] + y[t-12] + 1, h = 0.1")
    dates = ", ".join(f"{c} ({month(t)})" for c, t in zip(seg.changepoints, seg.changepoint_times))
    spans = ", ".join(f"[{lo}, {hi}]" for lo, _, hi in intervals)
    row("2 breaks, 95 %", f"{dates}; {spans}", STRUCCHANGE["seatbelt breaks"])
    row("RSS, 0-8 breaks", ", ".join(f"{v:.7g}" for v in table["rss"]), STRUCCHANGE["seatbelt rss"])
    best = table["best_bic"]
    row("BIC picks", f"{best} breaks ({table['bic'][best]:.2f})", STRUCCHANGE["seatbelt bic"])
    row(
        "supF",
        f"{supf.statistic:.3f}, p = {supf.pvalue:.2g}, at {supf.break_index}",
        STRUCCHANGE["seatbelt supF"],
    )
    print("  per-segment coefficients (estimate, std err from each segment's own variance):")
    table = seg.to_frame()
    for number, (a, b) in enumerate(seg.segments, start=1):
        rows = table[table.segment == number]
        text = ", ".join(
            f"{name} {v:.3f} ({s:.3f})"
            for name, v, s in zip(("y[t-1]", "y[t-12]", "const"), rows.estimate, rows.std_err)
        )
        print(f"    rows {a}-{b - 1}: {text}")
    print(f"    strucchange, rows 0-45: {STRUCCHANGE['seatbelt segment 1']}")
    return y, phi, seg, ltv.segment_regression(y, phi, n_changes=8, trim=0.1)


def seasonal_analysis() -> None:
    deaths = np.log10(ltv.datasets.uk_driver_deaths())
    months = deaths.index.month.to_numpy()
    # a level that may break, and eleven month effects (February … December) held fixed
    phi = np.column_stack([np.ones(deaths.size)] + [months == k for k in range(2, 13)])
    fixed = list(range(1, 12))
    seg = ltv.segment_regression(deaths, phi.astype(float), n_changes=2, trim=0.1, fixed=fixed)
    free = ltv.segment_regression(deaths, np.ones(deaths.size), penalty="bic", min_size=6)
    print("\nUK car-driver deaths (log10) 1969-1984, level breaks, month effects fixed")
    for t_lo, t, t_hi in seg.confint_times(0.95):
        print(f"  break at {month(t)}, 95 % interval {month(t_lo)} to {month(t_hi)}")
    print(
        f"  without the month effects the BIC finds {free.n_changes} changes of level "
        "(the seasonal pattern taken for breaks)"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out", default="structural_breaks.png", help="image file (default: structural_breaks.png)"
    )
    args = parser.parse_args(argv)
    try:
        path, fmt = image_file(args.out)
    except OutputPathError as exc:
        print(f"error: --{exc}", file=sys.stderr)
        return 2
    nile, level, nile_seg, nile_supf = nile_analysis()
    y, phi, seat_seg, seat_all = seatbelt_analysis()
    seasonal_analysis()

    fig = new_figure((11.0, 7.0))
    axes = fig.subplots(2, 2)
    plot_breaks(nile_seg, nile, level, ax=axes[0, 0]).set_title("Nile: one break, 95 % interval")
    plot_breaks(seat_seg, y, phi, ax=axes[0, 1]).set_title("Driver deaths: two breaks")
    plot_break_test(nile_supf, ax=axes[1, 0]).set_title("Nile: F statistics, supF test")
    plot_criteria(seat_all, ax=axes[1, 1]).set_title("Driver deaths: BIC and RSS")
    save_figure(fig, path, fmt)
    print(f"\nwrote {path.name}")
    return 0


if __name__ == "__main__":
    # Exit only on failure: the documentation's gallery runs this file in-process.
    if status := main():
        raise SystemExit(status)
