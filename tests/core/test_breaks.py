"""The limit distribution of a break date (``core.breaks``) and where its interval fails."""

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core.breaks import argmax_cdf, break_interval


@pytest.mark.parametrize("xi, phi1, phi2", [(1.0, 1.0, 1.0), (0.3, 1.0, 2.0), (4.0, 2.0, 0.5)])
def test_the_argmax_distribution_is_a_distribution(xi, phi1, phi2):
    points = np.linspace(-2000.0, 2000.0, 801)  # (the slower side drifts at ξ/2)
    values = np.array([argmax_cdf(x, xi, phi1, phi2) for x in points])
    assert np.all(np.diff(values) >= -1e-12)  # nondecreasing
    assert values[0] < 1e-6 and values[-1] > 1 - 1e-6  # from 0 to 1
    assert argmax_cdf(0.0, 1.0, 1.0, 1.0) == pytest.approx(0.5, abs=1e-12)  # symmetric case


def test_the_symmetric_interval_is_symmetric_and_widens_with_the_level():
    delta, q = np.array([1.0]), np.eye(1)
    lower, upper = break_interval(delta, q, q, 1.0, 1.0, 0.95)
    assert lower == pytest.approx(-upper, rel=1e-8)
    wider = break_interval(delta, q, q, 1.0, 1.0, 0.99)
    assert wider[1] > upper and wider[0] < lower


def test_an_interval_that_cannot_be_computed_is_nan_with_a_warning():
    # A clear mean shift into a segment 1000 times noisier (in standard deviation): the
    # limit puts P(argmax ≤ 0) far below the interval's tail, strucchange's "cannot be
    # computed"; pooling the noise levels gives an interval.
    rng = np.random.default_rng(0)
    y = np.r_[rng.normal(0.0, 0.01, 50), rng.normal(100.0, 10.0, 50)]
    segmentation = ltv.segment_regression(y, np.ones((100, 1)), n_changes=1, min_size=10)
    assert segmentation.changepoints.tolist() == [50]
    with pytest.warns(RuntimeWarning, match="change point 50 cannot be computed"):
        intervals = segmentation.confint()
    assert np.isnan(intervals[0, 0]) and np.isnan(intervals[0, 2]) and intervals[0, 1] == 50
    pooled = segmentation.confint(het_err=False)
    assert np.all(np.isfinite(pooled)) and pooled[0, 0] <= 50 <= pooled[0, 2]
