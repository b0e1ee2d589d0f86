"""Segmentation.vcov, to_frame and the summary's per-segment coefficients, against the
least-squares formulas evaluated directly."""

import numpy as np
import pytest

import ltvmodels as ltv


@pytest.fixture(scope="module")
def two_segments():
    rng = np.random.default_rng(4)
    N = 120
    phi = np.column_stack([np.ones(N), rng.standard_normal(N)])
    noise = np.where(np.arange(N) < 50, 0.5, 2.0)
    y = np.where(
        np.arange(N) < 50, phi @ [1.0, 2.0], phi @ [-1.0, 0.5]
    ) + noise * rng.standard_normal(N)
    return y, phi, ltv.segment_regression(y, phi, n_changes=1, trim=0.15)


def test_vcov_is_each_segment_s_least_squares_covariance(two_segments):
    y, phi, seg = two_segments
    c = int(seg.changepoints[0])
    residuals = []
    for (a, b), own in zip(seg.segments, seg.vcov()):
        coef = np.linalg.lstsq(phi[a:b], y[a:b], rcond=None)[0]
        resid = y[a:b] - phi[a:b] @ coef
        residuals.append(resid)
        gram_inverse = np.linalg.inv(phi[a:b].T @ phi[a:b])
        np.testing.assert_allclose(own, np.mean(resid**2) * gram_inverse, rtol=1e-10)
    pooled = np.mean(np.concatenate(residuals) ** 2)
    for (a, b), one in zip(seg.segments, seg.vcov(het_err=False)):
        np.testing.assert_allclose(one, pooled * np.linalg.inv(phi[a:b].T @ phi[a:b]), rtol=1e-10)
    assert 0 < c < y.size


def test_to_frame_and_summary_show_the_same_standard_errors(two_segments):
    _, _, seg = two_segments
    frame = seg.to_frame()
    assert list(frame.columns) == [
        "segment",
        "start",
        "stop",
        "regressor",
        "estimate",
        "std_err",
        "z",
    ]
    std = np.sqrt(np.diagonal(seg.vcov(), axis1=1, axis2=2))
    np.testing.assert_allclose(frame["std_err"], std.ravel(), rtol=1e-12)
    text = str(seg.summary())
    assert "each segment's own noise variance" in text
    assert f"{std[1, 1]:.4g}" in text


def test_vcov_refuses_what_it_cannot_give(two_segments):
    y, phi, _ = two_segments
    partial = ltv.segment_regression(y, phi, n_changes=1, trim=0.15, fixed=[0])
    with pytest.raises(ValueError, match="vcov: with fixed regressors"):
        partial.vcov()
    assert "each segment's own noise variance" not in str(partial.summary())
    two = ltv.segment_regression(np.column_stack([y, y]), phi, n_changes=1, trim=0.15)
    with pytest.raises(ValueError, match="for one regression equation"):
        two.vcov()
