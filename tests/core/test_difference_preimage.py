"""difference_preimage and null_space_basis against dense linear algebra on small problems."""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import difference_matrix

from ltvmodels.core.problem import null_space_basis
from ltvmodels.core.sparse_common import difference_preimage


def _preimage_cases() -> list[tuple[list[float], int, tuple[int, ...]]]:
    """(coeffs, N, shape of v's trailing axes): D with more columns than its order;
    v of more than two axes only where the first difference's pass takes it (the
    banded route takes one or two axes, what its callers pass)."""
    cases = []
    for coeffs in ([-1.0, 1.0], [2.0, -2.0], [1.0, -2.0, 1.0], [-1.0, 0.5]):
        first_difference = len(coeffs) == 2 and coeffs[0] == -coeffs[1]
        for N in (2, 3, 7, 60):
            for shape in ((), (4,), (2, 3)):
                if N > len(coeffs) - 1 and (len(shape) <= 1 or first_difference):
                    cases.append((coeffs, N, shape))
    return cases


@pytest.mark.parametrize(("coeffs", "N", "shape"), _preimage_cases())
def test_preimage_is_the_least_squares_solution(coeffs, N, shape):
    # v is not orthogonal to null(D): the result must be the least-squares solution
    # of Dᵀμ = v, (DDᵀ)⁻¹Dv, whatever route computes it
    c = np.array(coeffs)
    rng = np.random.default_rng(N)
    v = rng.standard_normal((N,) + shape) * 3.0
    D = difference_matrix(N, c)
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
    np.testing.assert_allclose(difference_matrix(N, c) @ basis, 0.0, atol=1e-10)
