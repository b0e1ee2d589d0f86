"""The compiled medians of the robust losses' bookkeeping against numpy's."""

import numpy as np
import pytest

from ltvmodels.core.robust_scale import BRACKET_MIN, column_center_spread, median_in_place


def _samples(size: int, kind: str, rng: np.random.Generator) -> np.ndarray:
    if kind == "gaussian":
        return rng.standard_normal(size)
    if kind == "sorted":
        return np.sort(rng.standard_normal(size))
    if kind == "reversed":
        return np.sort(rng.standard_normal(size))[::-1].copy()
    if kind == "few values":
        return rng.integers(0, 3, size).astype(float)
    if kind == "constant":
        return np.full(size, 2.5)
    if kind == "heavy tails":  # |Cauchy|, every other entry a million times larger
        return np.abs(rng.standard_cauchy(size)) * np.tile([1.0, 1e6], size)[:size]
    # "periodic": the sample of every stride-th entry sees one phase only, so the
    # bracket misses and the plain selection must answer
    stride = max(size // 2048, 1)
    return np.where(np.arange(size) % stride == 0, 1e9, rng.standard_normal(size))


KINDS = ["gaussian", "sorted", "reversed", "few values", "constant", "heavy tails", "periodic"]
SIZES = [1, 2, 3, 10, BRACKET_MIN - 1, BRACKET_MIN, BRACKET_MIN + 1, 10_000, 100_001]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("size", SIZES)
def test_median_equals_numpy(size, kind):
    values = _samples(size, kind, np.random.default_rng(size))
    assert median_in_place(values.copy()) == np.median(values)


def test_median_of_an_even_count_is_the_mean_of_the_middle_two():
    values = np.arange(2 * BRACKET_MIN, dtype=float)[::-1].copy()  # 0 … 8191, reversed
    assert median_in_place(values) == (BRACKET_MIN - 1 + BRACKET_MIN) / 2


def test_column_center_spread_matches_numpy_over_the_observed_rows():
    rng = np.random.default_rng(3)
    values = rng.standard_normal((6000, 2, 3)) * np.array([1.0, 10.0, 1e-3])
    observed = rng.random((6000, 2)) > 0.2
    center, mad, rms = np.empty(3), np.empty(3), np.empty(3)
    column_center_spread(values, observed, center, mad, rms)
    kept = values[observed]  # (rows, n)
    np.testing.assert_array_equal(center, np.median(kept, axis=0))
    np.testing.assert_array_equal(mad, np.median(np.abs(kept - np.median(kept, axis=0)), axis=0))
    np.testing.assert_allclose(rms, np.sqrt(np.mean(kept**2, axis=0)), rtol=1e-13)


def test_column_center_spread_without_observed_rows_is_nan():
    center, mad, rms = np.zeros(2), np.zeros(2), np.zeros(2)
    column_center_spread(np.ones((5, 1, 2)), np.zeros((5, 1), dtype=bool), center, mad, rms)
    assert np.isnan(center).all() and np.isnan(mad).all() and np.isnan(rms).all()
