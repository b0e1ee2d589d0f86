"""ScalarEvidence: log p(y | λ) by one forward sweep equals the full squared-norm fit's."""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core.evidence import ScalarEvidence
from ltvmodels.estimators.recordings import state_space_data
from ltvmodels.estimators.selection import criterion_fit


@pytest.mark.parametrize("order, R", [(1, 1), (2, 1), (1, 3), ([1.0, -3.0, 3.0, -1.0], 1)])
def test_matches_the_full_fit(order, R):
    T = 200
    d = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=1)
    rng = np.random.default_rng(0)
    x = np.stack([d.x + 0.05 * r * rng.standard_normal(d.x.shape) for r in range(R)])
    u = np.stack([d.u] * R)
    x[0, 20] = np.nan  # a missing sample and weights: the general problem
    data = state_space_data(x, u, order=order, weights=np.linspace(0.5, 1.5, T - 1))
    evidence = ScalarEvidence(data.problem)
    for lam in (0.3, 3.0, 30.0, 300.0):
        full = criterion_fit(data.problem, "sq", lam)["loglik"]
        assert evidence.loglik(lam) == pytest.approx(full, rel=1e-9)


def test_declines_where_it_cannot_answer():
    d = ltv.systems.jump_linear(T=60, change_at=30, seed=2)
    exact = d.x.copy()
    for t in range(len(exact) - 1):  # an exact LTI recursion, no noise
        exact[t + 1] = np.array([[0.9, 0.1], [-0.2, 0.8]]) @ exact[t]
    problem = state_space_data(exact, None).problem
    evidence = ScalarEvidence(problem)
    assert evidence.loglik(0.001) is None  # the subtraction would cancel: fit instead
    # a larger λ takes the minimum from the solution, without the subtraction
    assert evidence.loglik(10.0) == pytest.approx(
        criterion_fit(problem, "sq", 10.0)["loglik"], rel=1e-12
    )
    few = ScalarEvidence(state_space_data(d.x[:3], d.u[:3]).problem)
    assert few.loglik(1.0) is None  # no degrees of freedom left for the noise variance
    assert ScalarEvidence(state_space_data(d.x, d.u).problem).loglik(0.0) is None


@pytest.mark.parametrize("order", [1, 2])
def test_large_lam_matches_the_full_fit(order):
    """Where λ is large for the data (H ill-conditioned) the subtraction loses digits;
    the value then comes from the solution and still equals the full fit's."""
    import warnings

    d = ltv.systems.random_walk_system(T=200, seed=0)
    problem = state_space_data(d.x, d.u, order=order).problem
    evidence = ScalarEvidence(problem)
    for lam in (1e3, 1e4, 1e5, 3e5):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the fit's precision warning
            full = criterion_fit(problem, "sq", lam)["loglik"]
        assert evidence.loglik(lam) == pytest.approx(full, rel=1e-11, abs=1e-9)
