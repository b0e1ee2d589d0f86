"""Identifiability (paper Section V, Propositions 2 and 3).

* Linearly dependent regressors: not identifiable even as an LTI model
  (Proposition 2) → SingularProblemError without a prior.
* Second difference: the unpenalized trajectories are k_t = a + b·t. With the
  feedback u_t = −t·x_t (n = 1, m = 1) the trajectory A_t = α·t, B_t = α gives
  A_t x_t + B_t u_t ≡ 0, so it is invisible in the data although Σ φ_t φ_tᵀ is
  nonsingular: only the null-space condition of Proposition 3 fails. The same
  happens for a scalar system whose state is nonzero at a single time t₀: the
  trend through zero at t₀ is invisible.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from dense_reference import DenseProblem, random_data, relerr

import ltvmodels as ltv


def test_identical_inputs_raise_proposition_2():
    x, _ = random_data(81, 40, 2, 0)
    w = np.random.default_rng(82).standard_normal(40)
    u = np.column_stack([w, w])
    for call in (
        lambda: ltv.fit(x, u, lam=1.0),
        lambda: ltv.fit(x, u, lam=1.0, order=2),
        lambda: ltv.fit_lti(x, u),
    ):
        with pytest.raises(ltv.SingularProblemError, match="Proposition 2") as info:
            call()
        message = str(info.value)
        assert "u0" in message and "u1" in message  # names the dependent regressors


def test_proportional_state_and_input_raise_proposition_2():
    x, _ = random_data(83, 40, 1, 0)
    with pytest.raises(ltv.SingularProblemError, match="Proposition 2"):
        ltv.fit(x, -2.0 * x, lam=1.0)


def _trend_feedback(T=40, seed=84):
    x, _ = random_data(seed, T, 1, 0)
    t = np.arange(T, dtype=float)
    return x, (-t * x[:, 0])[:, None]


def test_trend_invisible_only_for_second_difference():
    x, u = _trend_feedback()
    phi = np.hstack([x[:-1], u[:-1]])
    assert np.linalg.cond(phi.T @ phi) < 1e8  # LTI-identifiable
    first = ltv.fit(x, u, lam=1.0, order=1)  # the first difference is fine
    assert relerr(first.k, DenseProblem(x, u, 1, 1.0).solve()[0]) < 1e-8
    with pytest.raises(ltv.SingularProblemError, match="Proposition 3"):
        ltv.fit(x, u, lam=1.0, order=2)
    with pytest.raises(ltv.SingularProblemError, match="Proposition 3"):
        ltv.fit(x, u, lam=1.0, order=[-1, 3, -3, 1])  # its null space contains the trend too


def test_trend_invisible_with_prior_warns_and_matches_dense_map():
    x, u = _trend_feedback()
    prior = ltv.Prior(np.array([0.5, 0.0]), 0.5)
    with pytest.warns(ltv.IdentifiabilityWarning, match="Proposition 3"):
        model = ltv.fit(x, u, lam=1.0, order=2, prior=prior, noise_var=0.5)
    ref = DenseProblem(x, u, 2, 1.0, sigma2=0.5, param_priors=[(np.array([0.5, 0.0]), 0.5)])
    k, _ = ref.solve()
    assert relerr(model.k, k) < 1e-8


def test_single_nonzero_state_second_difference():
    x = np.zeros((40, 1))
    x[10] = 1.3
    with pytest.raises(ltv.SingularProblemError, match="Proposition 3"):
        ltv.fit(x, lam=1.0, order=2)
    model = ltv.fit(x, lam=1.0, order=1)  # a constant is seen at t = 10
    assert np.all(np.isfinite(model.k))


def test_all_zero_state_raises():
    with pytest.raises(ltv.SingularProblemError):
        ltv.fit(np.zeros((20, 1)), lam=1.0)


def test_generic_data_do_not_warn():
    x, u = random_data(85, 40, 2, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for order in (1, 2, [-1, 3, -3, 1]):
            ltv.fit(x, u, lam=1.0, order=order)
        ltv.fit_lti(x, u)
