"""Property tests: random small problems against the dense references."""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import DenseProblem, diag_blocks, random_data, random_spd, relerr, row_scale

import ltvmodels as ltv

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

ORDERS = [1, 2, 3, [-1.0, 0.0, 1.0], [0.5, -1.5, 1.0], [2.0, -3.0, 1.0]]


@st.composite
def problems(draw):
    n = draw(st.integers(1, 2))
    m = draw(st.integers(0, 2))
    order = draw(st.sampled_from(ORDERS))
    d = order if isinstance(order, int) else len(order) - 1
    p = n + m
    N = draw(st.integers(p * d + 3, p * d + 14))
    kind = draw(st.sampled_from(["scalar", "vector", "matrix"]))
    seed = draw(st.integers(0, 2**31 - 1))
    K = n * p
    rng = np.random.default_rng(seed)
    if kind == "scalar":
        lam = float(np.exp(rng.uniform(np.log(0.1), np.log(10.0))))
    elif kind == "vector":
        lam = np.exp(rng.uniform(np.log(0.1), np.log(10.0), K))
    else:
        lam = random_spd(rng, K, float(np.exp(rng.uniform(np.log(0.1), np.log(10.0)))))
    x, u = random_data(seed, N + 1, n, m)
    return x, u, order, lam


@settings(max_examples=25, deadline=None, derandomize=True)
@given(problems())
def test_fit_equals_dense_reference(problem):
    x, u, order, lam = problem
    model = ltv.fit(x, u, lam=lam, order=order)
    ref = DenseProblem(x, u, order, lam)
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < 1e-7
    s2 = ref.ml_noise_var()  # the reference's own σ̂², not the model's
    np.testing.assert_allclose(model.noise_var, s2, rtol=1e-7)
    cov = row_scale(s2, ref.n, ref.K // ref.n) * diag_blocks(H_inv, ref.N, ref.K)
    assert relerr(model.cov_full(), cov) < 1e-7
    assert model.loglik == pytest.approx(ref.loglik_kappa(np.inf, s2), rel=1e-8, abs=1e-7)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(problems(), st.floats(0.01, 10.0), st.floats(0.05, 5.0))
def test_exact_prior_equals_dense_map(problem, sigma2, prior_var):
    x, u, order, lam = problem
    N = x.shape[0] - 1
    n = x.shape[1]
    K = n * (n + (0 if u is None else u.shape[1]))
    mean = np.random.default_rng(N).standard_normal(K)
    model = ltv.fit(x, u, lam=lam, order=order, prior=ltv.Prior(mean, prior_var), noise_var=sigma2)
    ref = DenseProblem(x, u, order, lam, sigma2=sigma2, param_priors=[(mean, prior_var)])
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < 1e-7
    assert relerr(model.cov_full(), sigma2 * diag_blocks(H_inv, N, K)) < 1e-7
    assert model.loglik == pytest.approx(ref.loglik_with_prior(), rel=1e-8, abs=1e-7)
