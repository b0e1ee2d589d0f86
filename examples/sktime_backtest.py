"""
Back-testing in sktime: our time-varying AR forecaster against sktime's own
===========================================================================

:class:`ltvmodels.sktime.LTVForecaster` (a time-varying AR model, λ chosen by
the marginal likelihood) is back-tested with sktime's ``evaluate`` on an
expanding window, next to sktime's ``AutoARIMA`` (pmdarima),
``ExponentialSmoothing`` and ``NaiveForecaster``, on sktime's bundled airline
passengers (monthly, 144 samples, horizon 12) and lynx trappings (yearly, 114
samples, horizon 10). The table gives, per forecaster and data set, the mean
over the folds of the symmetric MAPE of the point forecasts and the empirical
coverage of their 90 % prediction intervals ("-" where a forecaster has none).

Then :class:`ltvmodels.sktime.LTVChangePointDetector` (exact segmentation,
and the group lasso) and sktime's PELT and binary segmentation look for the
changes of a generated series with known changes of its mean; the figure
shows the series and what each found.

Usage::

    python examples/sktime_backtest.py [--out sktime_backtest.png] [--quick]

``--quick`` uses two folds per data set and a non-seasonal AutoARIMA of orders
p, q <= 2 (the seasonal search takes minutes per fold).
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from ltvmodels.errors import OutputPathError
from ltvmodels.plotting.figure import image_file, new_figure, save_figure


def forecasters(period: int, quick: bool) -> dict:
    from sktime.forecasting.arima import AutoARIMA
    from sktime.forecasting.exp_smoothing import ExponentialSmoothing
    from sktime.forecasting.naive import NaiveForecaster

    from ltvmodels.sktime import LTVForecaster

    return {
        "LTVForecaster": LTVForecaster(na=period + 1, lam="auto", n_samples=1000),
        "AutoARIMA": (
            AutoARIMA(sp=1, max_p=2, max_q=2, maxiter=20, suppress_warnings=True)
            if quick
            else AutoARIMA(sp=period, suppress_warnings=True)
        ),
        "ExponentialSmoothing": ExponentialSmoothing(trend="add", seasonal="add", sp=period),
        "NaiveForecaster": NaiveForecaster(strategy="last", sp=period),
    }


def backtest(y, period: int, horizon: int, folds: int, quick: bool) -> dict:
    """Mean sMAPE and 90 % interval coverage of each forecaster over the last ``folds`` folds."""
    from sktime.forecasting.model_evaluation import evaluate
    from sktime.performance_metrics.forecasting import MeanAbsolutePercentageError
    from sktime.performance_metrics.forecasting.probabilistic import EmpiricalCoverage
    from sktime.split import ExpandingWindowSplitter

    initial = len(y) - folds * horizon
    cv = ExpandingWindowSplitter(
        initial_window=initial, step_length=horizon, fh=list(range(1, horizon + 1))
    )
    smape = MeanAbsolutePercentageError(symmetric=True)
    rows = {}
    for name, forecaster in forecasters(period, quick).items():
        scoring = [smape]
        if forecaster.get_tag("capability:pred_int"):
            scoring.append(EmpiricalCoverage(coverage=0.9))
        result = evaluate(forecaster, cv, y, scoring=scoring)
        coverage = [c for c in result.columns if "Coverage" in c]
        rows[name] = (
            float(result[f"test_{type(smape).__name__}"].mean()),
            float(result[coverage[0]].mean()) if coverage else None,
        )
    return rows


def changes(seed: int = 0):
    """A series with changes of the mean at samples 120 and 200 and of the noise at 300."""
    import pandas as pd

    rng = np.random.default_rng(seed)
    level = np.r_[np.zeros(120), 2.0 * np.ones(80), 0.5 * np.ones(180)]
    scale = np.r_[np.ones(300), 2.5 * np.ones(80)]
    index = pd.date_range("2024-01-01", periods=level.size, freq="h")
    return pd.Series(level + scale * rng.standard_normal(level.size), index=index), [120, 200, 300]


def detectors() -> dict:
    from sktime.detection.bs import BinarySegmentation
    from sktime.detection.pelt import PELT

    from ltvmodels.sktime import LTVChangePointDetector

    return {
        "LTV exact, BIC, normal cost": LTVChangePointDetector(penalty="bic", cost="normal"),
        "LTV exact, 3 changes": LTVChangePointDetector(n_changes=3),
        "LTV group lasso": LTVChangePointDetector(method="group", lam=40.0),
        "sktime PELT": PELT(min_segment_length=5),
        "sktime BinarySegmentation": BinarySegmentation(threshold=20.0, min_cp_distance=5),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out", default="sktime_backtest.png", help="image file (default: sktime_backtest.png)"
    )
    parser.add_argument("--quick", action="store_true", help="two folds, small ARIMA")
    args = parser.parse_args(argv)
    try:
        path, fmt = image_file(args.out, "out")
    except OutputPathError as exc:
        print(f"error: --{exc}", file=sys.stderr)
        return 2
    try:
        from sktime.datasets import load_airline, load_lynx
    except ImportError:
        print("error: this example needs sktime: pip install 'ltvmodels[sktime]'", file=sys.stderr)
        return 2
    folds = 2 if args.quick else 6
    table = {}
    with warnings.catch_warnings():
        # sktime's notice of a future default, and the ARIMA search's convergence chatter
        warnings.simplefilter("ignore")
        table["airline"] = backtest(load_airline(), 12, 12, folds, args.quick)
        table["lynx"] = backtest(load_lynx(), 10, 10, folds, args.quick)
    print(f"Back-test, expanding window, {folds} folds (sMAPE of the point forecasts, ")
    print("empirical coverage of the 90 % intervals)")
    print(f"  {'data':<8} {'forecaster':<22} {'sMAPE':>7} {'coverage':>9}")
    for data, rows in table.items():
        for name, (smape, coverage) in rows.items():
            shown = "-" if coverage is None else f"{coverage:.2f}"
            print(f"  {data:<8} {name:<22} {smape:7.3f} {shown:>9}")

    series, truth = changes()
    print(f"\nChange points of a generated series (true: {truth})")
    found = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, detector in detectors().items():
            found[name] = detector.fit(series).predict(series)["ilocs"].tolist()
            print(f"  {name:<28} {found[name]}")

    fig = new_figure(figsize=(9, 4.5))
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(np.arange(series.size), series.to_numpy(), color="0.6", lw=0.8)
    for c in truth:
        ax.axvline(c, color="k", lw=2, alpha=0.3)
    for row, (name, points) in enumerate(found.items()):
        ax.plot(points, [series.max() + 0.6 * (row + 1)] * len(points), "v", label=name)
    ax.set_xlabel("sample")
    ax.set_title("Detected change points (grey bars: the true ones)")
    ax.legend(loc="lower left", fontsize=8)
    save_figure(fig, path, fmt)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    # Exit only on failure: the documentation's gallery runs this file in-process.
    if status := main():
        sys.exit(status)
