"""plot_breaks and plot_criteria draw what the segmentation says: the breaks between rows,
the intervals' spans, the fitted segments and the criteria table."""

import matplotlib
import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.plotting import plot_breaks, plot_criteria

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def shifted_mean():
    rng = np.random.default_rng(3)
    y = np.r_[np.zeros(60), 2 * np.ones(40)] + 0.5 * rng.standard_normal(100)
    phi = np.ones((100, 1))
    return y, phi, ltv.segment_regression(y, phi, n_changes=2, trim=0.15)


def test_breaks_spans_and_fitted_values_are_the_segmentation_s(shifted_mean):
    y, phi, seg = shifted_mean
    ax = plot_breaks(seg, y, phi, level=0.9)
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_array_equal(lines["data"].get_ydata(), y)
    np.testing.assert_allclose(lines["fitted segments"].get_ydata(), seg.model.predict(phi)[:, 0])
    breaks = [line for line in ax.get_lines() if line.get_linestyle() == "--"]
    assert [line.get_xdata()[0] for line in breaks] == [c - 0.5 for c in seg.changepoints]
    spans = list(ax.patches)
    intervals = seg.confint(0.9)
    assert len(spans) == seg.n_changes
    for span, (lower, _, upper) in zip(spans, intervals):
        x = span.get_patch_transform().transform(span.get_path().vertices)[:, 0]
        assert x.min() == pytest.approx(max(lower - 0.5, 0))
        assert x.max() == pytest.approx(min(upper + 0.5, 99))


def test_breaks_on_a_dated_series_use_its_dates():
    pd = pytest.importorskip("pandas")
    nile = ltv.datasets.nile()
    seg = ltv.segment_regression(nile, np.ones((100, 1)), n_changes=1, trim=0.15)
    ax = plot_breaks(seg, nile, level=None)
    assert ax.get_xlabel() == "year" and not ax.patches
    assert ax.get_lines()[0].get_xdata()[0] == 1871
    assert isinstance(nile, pd.Series)


def test_criteria_plot_marks_the_bic_choice(shifted_mean):
    _, _, seg = shifted_mean
    ax = plot_criteria(seg)
    table = seg.criteria()
    bic = ax.get_lines()[0]
    np.testing.assert_allclose(bic.get_ydata(), table["bic"])
    assert f"BIC picks {table['best_bic']}" in [line.get_label() for line in ax.get_lines()]


def test_plot_errors(shifted_mean):
    y, phi, seg = shifted_mean
    with pytest.raises(TypeError, match="segmentation: expected a Segmentation"):
        plot_breaks(seg.model, y)
    with pytest.raises(ValueError, match="y: expected the 100 rows"):
        plot_breaks(seg, y[:-1])
    penalized = ltv.segment_regression(y, phi, penalty=5.0)
    with pytest.raises(ValueError, match="criteria: this segmentation was found with a penalty"):
        plot_criteria(penalized)
