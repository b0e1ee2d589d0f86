"""The block-size-specialized kernels (small blocks, long series) equal the generic ones."""

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core import banded


@pytest.mark.parametrize("order", [1, 2])
def test_fixed_block_kernels_equal_generic(monkeypatch, order):
    rng = np.random.default_rng(7)
    x = rng.standard_normal((120, 2))
    u = rng.standard_normal((120, 1))
    assert isinstance(banded.kernel_size(119, 3), tuple)  # small blocks: specialized
    fixed = ltv.fit(x, u, lam=3.0, order=order)
    monkeypatch.setattr(banded, "FIXED_BLOCK_SMALL_B", 0)
    assert banded.kernel_size(119, 3) == 3
    generic = ltv.fit(x, u, lam=3.0, order=order)
    np.testing.assert_allclose(fixed.k, generic.k, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(fixed.cov, generic.cov, rtol=1e-12, atol=1e-14)
    assert fixed.loglik == pytest.approx(generic.loglik, rel=1e-13)


@pytest.mark.slow
def test_long_series_agrees_with_kalman_smoother():
    """Above the size threshold (specialized kernels, as used for long series) the
    banded solver still equals the independent Kalman smoother."""
    from ltvmodels.systems import random_walk_system

    data = random_walk_system(T=60_000, n=3, m=2, seed=3)
    assert (data.N * (data.n + data.m)) >= banded.FIXED_BLOCK_MIN_SIZE
    for order in (1, 2):
        model = ltv.fit(data.x, data.u, lam=30.0, order=order, noise_var=0.01)
        smoothed = ltv.kalman_smoother(data.x, data.u, lam=30.0, order=order, noise_var=0.01)
        scale = np.abs(model.k).max()
        assert np.abs(model.k - smoothed.k).max() < 1e-8 * scale
        np.testing.assert_allclose(model.cov, smoothed.cov, rtol=1e-6, atol=1e-12)
        assert model.loglik == pytest.approx(smoothed.loglik, rel=1e-9)
