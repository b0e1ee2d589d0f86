"""The block-size-specialized kernels used for long series equal the generic ones."""

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.solvers import banded


@pytest.mark.parametrize("order", [1, 2])
def test_fixed_block_kernels_equal_generic(monkeypatch, order):
    rng = np.random.default_rng(7)
    x = rng.standard_normal((120, 2))
    u = rng.standard_normal((120, 1))
    generic = ltv.fit(x, u, lam=3.0, order=order)
    monkeypatch.setattr(banded, "FIXED_BLOCK_MIN_SIZE", 1)
    fixed = ltv.fit(x, u, lam=3.0, order=order)
    np.testing.assert_allclose(fixed.k, generic.k, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(fixed.cov, generic.cov, rtol=1e-12, atol=1e-14)
    assert fixed.loglik == pytest.approx(generic.loglik, rel=1e-13)
