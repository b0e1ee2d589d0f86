"""The short paths of small fits give what the general paths give.

A scalar λ without priors is solved with one factorization shared by the rows
and closed forms of the penalty's normalizer (core.squared); plain numeric
arrays and plain scalar λ are validated in fewer passes (validation). Each
test compares the short path with the general one on the same data, errors
included.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core.squared import fit_squared, shared_row_weight
from ltvmodels.errors import PrecisionWarning, SingularProblemError
from ltvmodels.estimators.recordings import state_space_data
from ltvmodels.validation import arrays, options


def _data(R=1, missing=False, weights=False, T=120, seed=3):
    d = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
    rng = np.random.default_rng(seed)
    x = np.stack([d.x + 0.05 * r * rng.standard_normal(d.x.shape) for r in range(R)])
    u = np.stack([d.u] * R)
    if missing:
        x[0, 17] = np.nan
    w = np.linspace(0.5, 1.5, T - 1) if weights else None
    return (x[0], u[0], w) if R == 1 else (x, u, w)


def _both(problem, lam, **kwargs):
    """The short path (W a (K,) vector) and the general one (the same W as a matrix)."""
    K = problem.K
    W = np.full(K, lam**2) if np.ndim(lam) == 0 else np.asarray(lam, float) ** 2
    assert shared_row_weight(W, problem.n, problem.p) is not None
    return fit_squared(problem, W, [], **kwargs), fit_squared(problem, np.diag(W), [], **kwargs)


@pytest.mark.parametrize("order", [1, 2, [1.0, -3.0, 3.0, -1.0]])
@pytest.mark.parametrize(
    "R, missing, weights", [(1, False, False), (1, True, True), (3, True, False)]
)
@pytest.mark.parametrize("noise_var", [None, 0.3, [0.2, 0.5]])
def test_shared_weight_equals_general(order, R, missing, weights, noise_var):
    x, u, w = _data(R, missing, weights)
    problem = state_space_data(x, u, order=order, weights=w).problem
    short, general = _both(problem, 3.0, noise_var=noise_var, compute_cov=True)
    np.testing.assert_allclose(short.theta, general.theta, rtol=1e-12, atol=1e-13)
    n, p = problem.n, problem.p
    np.testing.assert_allclose(short.cov.full(n, p), general.cov.full(n, p), rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(short.noise_var, general.noise_var, rtol=1e-12)
    assert short.loglik == pytest.approx(general.loglik, rel=1e-12)
    for name in (
        "rss",
        "penalty",
        "objective",
        "prior_cost",
        "n_eff",
        "n_factorizations",
        "noise_var_estimated",
    ):
        assert getattr(short, name) == pytest.approx(getattr(general, name), rel=1e-12), name
    assert short.info == general.info
    no_cov, _ = _both(problem, 3.0, noise_var=noise_var, compute_cov=False)
    assert no_cov.cov is None
    np.testing.assert_array_equal(no_cov.theta, short.theta)


def test_shared_vector_weight_and_zero_entries():
    x, u, _ = _data(R=3)  # three rows per step: a coefficient may be free (λ_j = 0)
    problem = state_space_data(x, u).problem
    lam = np.tile([2.0, 0.5, 0.0], problem.n)  # rows alike; a free coefficient
    short, general = _both(problem, lam, noise_var=None, compute_cov=True)
    np.testing.assert_allclose(short.theta, general.theta, rtol=1e-11, atol=1e-12)
    assert short.loglik == pytest.approx(general.loglik, rel=1e-12)
    assert short.n_eff == general.n_eff


def test_shared_weight_not_taken_for_other_weights():
    assert shared_row_weight(np.array([1.0, 2.0, 3.0, 1.0, 2.0, 4.0]), 2, 3) is None
    assert shared_row_weight(np.array([1.0, np.inf, 1.0, 1.0, np.inf, 1.0]), 2, 3) is None
    assert shared_row_weight(np.full(6, np.inf), 2, 3) is None
    assert shared_row_weight(np.eye(6), 2, 3) is None


def test_shared_weight_errors_and_warnings_as_general():
    x, u, _ = _data()
    problem = state_space_data(x, u).problem
    for lam in (0.0, 1e30):  # singular without a penalty; λ far too large
        messages = []
        for W in (np.full(problem.K, lam**2), np.diag(np.full(problem.K, lam**2))):
            with pytest.raises(SingularProblemError) as info:
                fit_squared(problem, W, [], noise_var=None, compute_cov=True)
            messages.append(str(info.value))
        assert messages[0] == messages[1]
    caught = []
    for W in (np.full(problem.K, 1e14), np.diag(np.full(problem.K, 1e14))):
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            result = fit_squared(problem, W, [], noise_var=None, compute_cov=False)
        caught.append([str(r.message) for r in record if r.category is PrecisionWarning])
        assert "digits_lost" in result.info
    assert caught[0] == caught[1] and len(caught[0]) == 1


def test_fit_warns_from_the_same_line_as_the_general_path():
    x, u, _ = _data()
    places = []
    for lam in (1e7, 1e14 * np.eye(6)):  # the short path; the matrix λ², the general one
        with pytest.warns(PrecisionWarning) as record:
            ltv.fit(x, u, lam=lam)
        places.append((record[0].filename, record[0].lineno))
    assert places[0] == places[1]


def _message(call, value):
    with pytest.raises((TypeError, ValueError)) as info:
        call(value)
    return type(info.value), str(info.value)


@pytest.mark.parametrize("case", ["inf", "huge", "tiny", "empty rows", "no columns", "3-d bad"])
def test_array_fast_path_errors_as_general(case):
    x = np.random.default_rng(0).standard_normal((30, 2))
    if case == "inf":
        x[4, 1] = np.inf
    elif case == "huge":
        x[:, 1] *= 1e120
    elif case == "tiny":
        x[:, 0] *= 1e-120
    elif case == "empty rows":
        x = x[:0]
    elif case == "no columns":
        x = x[:, :0]
    else:
        x = x[None, None]
    fast = _message(lambda v: arrays.trajectories(v, "x"), x)
    general = _message(lambda v: arrays.trajectories(v, "x"), x.view(_Subclass))
    assert fast == general


class _Subclass(np.ndarray):
    """An array that is not exactly np.ndarray: validated by the general path."""


def test_array_fast_path_values():
    x = np.arange(12, dtype=np.int32).reshape(6, 2)
    out = arrays.trajectories(x, "x")
    assert out.dtype == np.float64 and out.shape == (1, 6, 2)
    np.testing.assert_array_equal(out[0], x)
    out[0, 0, 0] = 99.0
    assert x[0, 0] == 0  # a copy
    nan = np.ones((5, 2))
    nan[1, 0] = np.nan
    np.testing.assert_array_equal(arrays.trajectories(nan, "x")[0], nan)  # NaN = missing
    with pytest.raises(ValueError, match="NaN or inf"):
        arrays.as_float_array(nan, "k")
    with pytest.raises(ValueError, match="inf"):
        arrays.as_float_array(np.array([1.0, -np.inf]), "k", missing=True)
    k = np.ones((3, 2))
    assert arrays.as_float_array(k, "k") is not k


@pytest.mark.parametrize("lam", [0, 3, 2.5, np.float64(2.5), np.inf])
def test_scalar_lam_weight(lam):
    expected = np.broadcast_to(np.asarray(float(lam)) ** 2, (6,))
    np.testing.assert_array_equal(options.penalty_weight(lam, 6), expected)


@pytest.mark.parametrize("lam", [-1.0, -2, np.nan, 1e200, True])
def test_scalar_lam_errors(lam):
    with pytest.raises((TypeError, ValueError), match="lam"):
        options.penalty_weight(lam, 6)


def test_difference_coefficients_are_fresh_arrays():
    first = options.difference_coefficients(2)
    first[0] = 42.0
    np.testing.assert_array_equal(options.difference_coefficients(2), [1.0, -2.0, 1.0])


@pytest.mark.parametrize("shape", [(1, 1), (5, 3), (4096, 2), (4097, 5), (9001, 3), (3, 4, 5)])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_representable_reads_the_largest_magnitude_of_either_sign(shape, sign):
    """The check reduces signed values (largest and smallest), not their magnitudes:
    a column whose extreme entry is negative, anywhere in a long array, is named."""
    rng = np.random.default_rng(0)
    values = rng.standard_normal(shape)
    flat = values.reshape(-1, shape[-1])
    flat[1::3, -1] = np.nan  # NaN (missing) is ignored
    flat[-1, -1] = sign * 1e101  # in the rest after the last full block, if any
    column = shape[-1] - 1
    with pytest.raises(ValueError, match=rf"column {column} has values of magnitude up to 1e\+101"):
        arrays.representable(values, "x")
    flat[:, -1] = sign * 1e-101  # every entry tiny
    with pytest.raises(ValueError, match=r"too small"):
        arrays.representable(values, "x")
    flat[:, -1] = np.nan  # a column of NaN only passes
    assert arrays.representable(values, "x") is values
