"""ltv.break_test: the sequential test against a brute force, its selection, the
Bai–Perron tables, the time index, the report, the figure and the input checks
(the supF/aveF/expF values against strucchange are in tests/reference)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core import breaktests


def rss(y: np.ndarray, phi: np.ndarray) -> float:
    coef, *_ = np.linalg.lstsq(phi, y, rcond=None)
    return float(np.sum((y - phi @ coef) ** 2))


def brute_force_supf_next(y: np.ndarray, phi: np.ndarray, breaks: int, h: int) -> float:
    """supF(l+1|l): the optimal l-break segmentation by enumeration, then each segment's
    best split (both sides >= h rows) and (T_i − 2p)(C_i − C_i')/C_i' (mbreaks' pftest)."""
    N, p = phi.shape
    best, bounds = np.inf, None
    for cps in itertools.combinations(range(h, N - h + 1), breaks):
        b = (0, *cps, N)
        if any(b1 - b0 < h for b0, b1 in itertools.pairwise(b)):
            continue
        cost = sum(rss(y[b0:b1], phi[b0:b1]) for b0, b1 in itertools.pairwise(b))
        if cost < best:
            best, bounds = cost, b
    statistic = 0.0
    for a, b in itertools.pairwise(bounds):
        if b - a < 2 * h:
            continue
        whole = rss(y[a:b], phi[a:b])
        split = min(rss(y[a:c], phi[a:c]) + rss(y[c:b], phi[c:b]) for c in range(a + h, b - h + 1))
        statistic = max(statistic, (b - a - 2 * p) * (whole - split) / split)
    return statistic


def two_break_series(N: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(N)
    regime = np.searchsorted([N // 3, 2 * N // 3], np.arange(N), side="right")
    level, slope = np.array([0.0, 2.0, -1.0])[regime], np.array([1.0, -0.5, 1.5])[regime]
    y = level + slope * x + 0.5 * rng.standard_normal(N)
    return y, np.column_stack([np.ones(N), x])


def test_the_sequential_statistics_equal_a_brute_force():
    y, phi = two_break_series(40, seed=3)
    y = y + np.random.default_rng(4).standard_normal(40)  # weaker breaks: several l matter
    test = ltv.break_test(y, phi, kind="sequential", trim=0.2, max_breaks=3)
    assert test.min_size == 8
    for breaks in range(3):
        assert test.statistics[breaks] == pytest.approx(
            brute_force_supf_next(y, phi, breaks, 8), rel=1e-9
        )


def test_two_clear_breaks_are_selected_and_white_noise_has_none():
    y, phi = two_break_series(300, seed=0)
    test = ltv.break_test(y, phi, kind="sequential")
    assert test.n_breaks == 2 and test.reject
    np.testing.assert_allclose(test.breaks, [100, 200], atol=3)
    assert test.statistics[0] > test.critical_values[0]
    assert test.statistics[2] <= test.critical_values[2]
    assert test.statistic == test.statistics[2] and np.isnan(test.pvalue)
    segmentation = ltv.segment_regression(y, phi, n_changes=2, trim=0.15)
    np.testing.assert_array_equal(test.breaks, segmentation.changepoints)
    noise = np.random.default_rng(1).standard_normal(300)
    none = ltv.break_test(noise, np.ones(300), kind="sequential", level=0.01)
    assert none.n_breaks == 0 and not none.reject and none.breaks.size == 0
    assert none.statistic == none.statistics[0] < none.critical_values[0]


def test_the_bai_perron_tables_are_the_published_ones():
    five = breaktests.bai_perron_critical_values(0.15, 1, 0.05)
    np.testing.assert_array_equal(five[:3], [8.58, 10.13, 11.14])  # Bai and Perron (2003)
    one = breaktests.bai_perron_critical_values(0.15, 1, 0.01)
    assert one[0] == 12.29
    for trim, level in itertools.product(breaktests.SEQUENTIAL_TRIMS, breaktests.SEQUENTIAL_LEVELS):
        for q in range(1, 11):
            values = breaktests.bai_perron_critical_values(trim, q, level)
            assert np.all(np.diff(values) >= 0)  # more breaks under the null: not smaller
    by_level = [
        breaktests.bai_perron_critical_values(0.1, 3, a) for a in breaktests.SEQUENTIAL_LEVELS
    ]
    assert np.all(np.diff(by_level, axis=0) > 0)  # smaller level: larger critical value


def test_a_dated_series_gives_break_times_and_missing_rows_are_left_out():
    import pandas as pd

    y, phi = two_break_series(300, seed=0)
    index = pd.date_range("2000-01-01", periods=300, freq="D")
    test = ltv.break_test(pd.Series(y, index=index), phi)
    assert test.break_time == index[test.break_index]
    sequential = ltv.break_test(pd.Series(y, index=index), phi, kind="sequential")
    np.testing.assert_array_equal(sequential.break_times, index[sequential.breaks])
    gappy = y.copy()
    gappy[[5, 150, 290]] = np.nan
    kept = np.isfinite(gappy)
    with_gaps = ltv.break_test(gappy, phi)
    assert with_gaps.n_observations == 297
    c = with_gaps.break_index
    F = rss(y[kept], phi[kept]) - (
        rss(gappy[:c][kept[:c]], phi[:c][kept[:c]]) + rss(gappy[c:][kept[c:]], phi[c:][kept[c:]])
    )
    F /= (
        rss(gappy[:c][kept[:c]], phi[:c][kept[:c]]) + rss(gappy[c:][kept[c:]], phi[c:][kept[c:]])
    ) / (297 - 4)
    assert with_gaps.statistic == pytest.approx(F, rel=1e-9)


def test_the_f_statistics_equal_least_squares_and_weights_are_weighted_least_squares():
    y, phi = two_break_series(80, seed=5)
    w = np.random.default_rng(6).uniform(0.5, 2.0, 80)
    test = ltv.break_test(y, phi, kind="aveF", weights=w, trim=0.25)
    sw = np.sqrt(w)
    ys, ps = y * sw, phi * sw[:, None]
    expected = [
        (rss(ys, ps) - rss(ys[:c], ps[:c]) - rss(ys[c:], ps[c:]))
        / ((rss(ys[:c], ps[:c]) + rss(ys[c:], ps[c:])) / (80 - 4))
        for c in test.f_rows
    ]
    np.testing.assert_allclose(test.f_statistics, expected, rtol=1e-9)
    assert test.f_rows[0] == 20 and test.f_rows[-1] == 60
    assert test.statistic == pytest.approx(np.mean(expected), rel=1e-12)


def test_the_report_and_the_figure():
    y, phi = two_break_series(200, seed=2)
    for kind in ("supF", "expF", "sequential"):
        test = ltv.break_test(y, phi, kind=kind)
        report = test.summary()
        assert "Structural break test" in report and "<table" in test._repr_html_()
        fig = test.plot()
        assert fig.axes and fig.axes[0].get_title()
    assert "supF(3|2)" in ltv.break_test(y, phi, kind="sequential").summary()


def test_invalid_input_is_refused_with_what_to_do():
    y, phi = two_break_series(100, seed=0)
    with pytest.raises(ValueError, match="y: expected one output"):
        ltv.break_test(np.column_stack([y, y]), phi)
    for trim in (0.0, 0.5, 0.7, -0.1):
        with pytest.raises(ValueError, match="trim: expected"):
            ltv.break_test(y, phi, trim=trim)
    with pytest.raises(ValueError, match="kind: expected one of"):
        ltv.break_test(y, phi, kind="supW")
    with pytest.raises(TypeError, match="kind: expected one of"):
        ltv.break_test(y, phi, kind=1)
    with pytest.raises(ValueError, match="y: too few rows"):
        ltv.break_test(y[:5], phi[:5])
    with pytest.raises(ValueError, match="y: too few rows"):
        ltv.break_test(y[:5], phi[:5], kind="sequential")
    with pytest.raises(ValueError, match="level: expected a significance level"):
        ltv.break_test(y, phi, level=1.5)
    with pytest.raises(ValueError, match=r"trim: the sequential test's critical values .* 0\.15"):
        ltv.break_test(y, phi, kind="sequential", trim=0.12)
    with pytest.raises(ValueError, match="level: the sequential test's critical values"):
        ltv.break_test(y, phi, kind="sequential", level=0.07)
    with pytest.raises(ValueError, match="phi: the sequential test's critical values .* p = 11"):
        ltv.break_test(y, np.random.default_rng(0).standard_normal((100, 11)), kind="sequential")
    with pytest.raises(ValueError, match="max_breaks: at most 5 breaks"):
        ltv.break_test(y, phi, kind="sequential", max_breaks=7)
    with pytest.raises(TypeError, match="max_breaks: only the 'sequential' test"):
        ltv.break_test(y, phi, max_breaks=2)
    with pytest.raises(
        ltv.SingularProblemError, match="phi: the regressors are linearly dependent"
    ):
        ltv.break_test(y, np.column_stack([phi[:, 0], phi[:, 0]]))
    original = y.copy()
    ltv.break_test(y, phi, kind="sequential")
    np.testing.assert_array_equal(y, original)
