"""A new penalty, defined here and registered, is fitted exactly: the solvers need no change.

The toy is the sum of the ∞-norms of the differences,

    Σ_t ‖y_t − Θ_t φ_t‖² + λ Σ_t max_j abs((Dk)_tj),

which none of the built-in norms expresses (its dual norm is the 1-norm, its
proximal operator a projection onto an l1 ball). It defines only the pieces of
:class:`ltvmodels.core.penalties.Penalty`; λ_max, ADMM and the duality-gap
certificate come from the library, and cvxpy with Clarabel is the reference.
"""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import cvxpy_state_space, relerr, simulate_ltv

import ltvmodels as ltv
from ltvmodels.core import penalties

cp = pytest.importorskip("cvxpy")
if "CLARABEL" not in cp.installed_solvers():  # pragma: no cover
    pytest.skip("cvxpy without the Clarabel solver", allow_module_level=True)


def project_rows_on_l1_ball(v: np.ndarray, radius: float) -> np.ndarray:
    """Each row of v projected onto {w : ‖w‖₁ <= radius} (Duchi et al. 2008)."""
    size = np.abs(v)
    inside = size.sum(axis=1) <= radius
    ordered = -np.sort(-size, axis=1)
    cumulative = np.cumsum(ordered, axis=1) - radius
    index = np.arange(1, v.shape[1] + 1)
    count = np.sum(ordered - cumulative / index > 0, axis=1)
    shift = cumulative[np.arange(v.shape[0]), count - 1] / count
    projected = np.sign(v) * np.maximum(size - shift[:, None], 0.0)
    return np.where(inside[:, None], v, projected)


class MaxNorm(penalties.Penalty):
    """R(z) = Σ_t ‖z_t‖_∞: at most the largest change of a step counts."""

    name = "max"

    def cone_norms(self, z):
        return np.abs(z).max(axis=1)

    def dual_norms(self, u):
        return np.abs(u).sum(axis=1)

    def prox(self, v, threshold):
        # Moreau: prox of τ‖·‖_∞ is v minus the projection onto the τ-ball of the dual norm.
        return v - project_rows_on_l1_ball(v, threshold)


@pytest.fixture
def max_norm():
    penalty = penalties.register(MaxNorm())
    yield penalty
    del penalties.PENALTIES[penalty.name]


def cvxpy_solution(x, u, order, lam):
    k, pred, y, dk = cvxpy_state_space(cp, x, u, order)
    objective = cp.sum_squares(y - pred) + lam * cp.sum(cp.max(cp.abs(dk), axis=1))
    problem = cp.Problem(cp.Minimize(objective))
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    assert problem.status == "optimal"
    return k.value, problem.value


def test_the_projection_is_onto_the_l1_ball():
    v = np.random.default_rng(0).standard_normal((50, 6))
    w = project_rows_on_l1_ball(v, 1.5)
    assert np.all(np.abs(w).sum(axis=1) <= 1.5 + 1e-12)
    for row, projected in zip(v, w):  # no point of the ball is nearer (random directions)
        trials = np.random.default_rng(1).standard_normal((200, 6))
        trials *= 1.5 / np.abs(trials).sum(axis=1, keepdims=True)
        assert np.linalg.norm(row - projected) <= np.linalg.norm(row - trials, axis=1).min()


@pytest.mark.parametrize(("order", "lam"), [(1, 1.0), (2, 3.0)])
def test_a_registered_penalty_matches_cvxpy(max_norm, order, lam):
    x, u, _ = simulate_ltv(31, T=40, n=2, m=1)
    k_ref, value = cvxpy_solution(x, u, order, lam)
    model = ltv.fit(x, u, lam=lam, norm="max", order=order, tol=1e-9, max_iter=50000)
    assert model.norm == "max" and model.status.status == "optimal"
    assert model.info["objective"] == pytest.approx(value, rel=1e-8)
    assert relerr(model.k, k_ref) < 1e-7


def test_a_registered_penalty_has_its_lambda_max(max_norm):
    x, u, _ = simulate_ltv(32, T=40, n=2, m=1)
    lmax = ltv.fit(x, u, lam=1.0, norm="max").info["lambda_max"]
    at_max = ltv.fit(x, u, lam=lmax * 1.0001, norm="max")
    below = ltv.fit(x, u, lam=lmax * 0.9, norm="max", tol=1e-9, max_iter=50000)
    assert at_max.status.status == "closed_form"
    assert np.ptp(at_max.k, axis=0).max() < 1e-12  # the LTI fit
    assert np.ptp(below.k, axis=0).max() > 1e-6


def test_an_unregistered_norm_is_an_error_listing_the_registered_ones(max_norm):
    with pytest.raises(ValueError, match=r"norm: expected one of \('sq', 'group', 'l1', 'max'\)"):
        ltv.fit(*simulate_ltv(33, T=20, n=1, m=1)[:2], lam=1.0, norm="min")


def test_a_robust_loss_needs_a_built_in_norm(max_norm):
    x, u, _ = simulate_ltv(34, T=30, n=2, m=1)
    with pytest.raises(NotImplementedError, match="loss: 'huber' is available"):
        ltv.fit(x, u, lam=1.0, norm="max", loss="huber")
