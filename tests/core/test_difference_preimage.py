"""difference_preimage and null_space_basis against dense linear algebra on small problems."""

from __future__ import annotations

import numpy as np
import pytest

from ltvmodels.core.problem import null_space_basis
from ltvmodels.core.sparse_common import difference_preimage


def dense_difference(N: int, coeffs: np.ndarray) -> np.ndarray:
    """D (N − d, N): row t holds c_0 … c_d from column t."""
    d = len(coeffs) - 1
    D = np.zeros((N - d, N))
    for t in range(N - d):
        D[t, t : t + d + 1] = coeffs
    return D


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [2.0, -2.0], [1.0, -2.0, 1.0], [-1.0, 0.5]])
@pytest.mark.parametrize("N", [2, 3, 7, 60])
@pytest.mark.parametrize("shape", [(), (4,), (2, 3)])
def test_preimage_is_the_least_squares_solution(coeffs, N, shape):
    # v is not orthogonal to null(D): the result must be the least-squares solution
    # of Dᵀμ = v, (DDᵀ)⁻¹Dv, whatever route computes it
    c = np.array(coeffs)
    if N <= len(c) - 1:
        pytest.skip("D needs more columns than its order")
    if len(shape) > 1 and not (len(c) == 2 and c[0] == -c[1]):
        pytest.skip("the banded solve takes v of one or two axes (what its callers pass)")
    rng = np.random.default_rng(N)
    v = rng.standard_normal((N,) + shape) * 3.0
    D = dense_difference(N, c)
    expected, *_ = np.linalg.lstsq(D.T, v.reshape(N, -1), rcond=None)
    got = difference_preimage(v, c)
    assert got.shape == (N - len(c) + 1,) + shape
    np.testing.assert_allclose(got.reshape(expected.shape), expected, rtol=1e-10, atol=1e-10)


def test_preimage_does_not_change_its_input():
    rng = np.random.default_rng(0)
    v = rng.standard_normal((20, 3))[:, ::2]  # a strided view
    before = v.copy()
    difference_preimage(v, np.array([-1.0, 1.0]))
    np.testing.assert_array_equal(v, before)


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0], [2.0, -1.0, 1.0]])
def test_null_space_basis_spans_the_null_space(coeffs):
    N = 40
    c = np.array(coeffs)
    basis = null_space_basis(N, c)
    d = len(c) - 1
    assert basis.shape == (N, d)
    np.testing.assert_allclose(basis.T @ basis, np.eye(d), atol=1e-12)
    np.testing.assert_allclose(dense_difference(N, c) @ basis, 0.0, atol=1e-10)
