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
    evidence = ScalarEvidence(state_space_data(exact, None).problem)
    assert evidence.loglik(10.0) is None  # the subtraction would cancel: fit instead
    few = ScalarEvidence(state_space_data(d.x[:3], d.u[:3]).problem)
    assert few.loglik(1.0) is None  # no degrees of freedom left for the noise variance
    assert ScalarEvidence(state_space_data(d.x, d.u).problem).loglik(0.0) is None
