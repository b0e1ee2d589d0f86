"""One base for everything with A_t, B_t: models, Kalman results, simulated data, dynamics."""

from __future__ import annotations

import numpy as np

import ltvmodels as ltv
from ltvmodels.control import LinearDynamics
from ltvmodels.results.base import LinearTimeVarying

DATA = ltv.systems.random_walk_system(T=50, n=3, m=2, seed=5)


def holders():
    return {
        "model": ltv.fit(DATA.x, DATA.u, lam=10.0),
        "lti": ltv.fit_lti(DATA.x, DATA.u),
        "smoother": ltv.kalman_smoother(DATA.x, DATA.u, lam=10.0),
        "filter": ltv.kalman_filter(DATA.x, DATA.u, lam=10.0),
        "data": DATA,
        "dynamics": LinearDynamics(DATA.A, DATA.B),
    }


def test_sizes_and_names_come_from_a_and_b():
    for name, obj in holders().items():
        assert isinstance(obj, LinearTimeVarying), name
        assert (obj.N, obj.n, obj.m, obj.K) == (49, 3, 2, 15), name
        assert obj.A.shape == (49, 3, 3) and obj.B.shape == (49, 3, 2), name
        assert obj.state_names == ["x0", "x1", "x2"] and obj.input_names == ["u0", "u1"], name


def test_model_sizes_agree_with_its_own():
    model = holders()["model"]
    assert (model.n, model.m) == (model.n_states, model.n_inputs)
    np.testing.assert_array_equal(np.concatenate([model.A, model.B], axis=2), model.theta)
    np.testing.assert_array_equal(DATA.theta.reshape(49, 15), DATA.k)
