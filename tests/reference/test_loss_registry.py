"""A new loss, defined here and registered, is fitted exactly: the solvers need no change.

The toy is the pseudo-Huber loss ρ_δ(e) = 2δ²(√(1 + (e/δ)²) − 1), smooth and
convex with ρ'' <= 2 (≈ e² near 0, ≈ 2δ·abs(e) far out), which none of the
built-in losses is. It defines only ρ and ψ = ρ'; the library's general
solver (majorization by squared-loss fits, with the fit's penalty) and its
certificate do the rest, and cvxpy with Clarabel is the reference.
"""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import cvxpy_state_space, relerr, simulate_ltv

import ltvmodels as ltv
from ltvmodels.core import losses

cp = pytest.importorskip("cvxpy")
if "CLARABEL" not in cp.installed_solvers():  # pragma: no cover
    pytest.skip("cvxpy without the Clarabel solver", allow_module_level=True)


class PseudoHuber(losses.Loss):
    name = "pseudo_huber"
    threshold = True  # takes huber_delta (δ), by default the robust scale rule

    def rho(self, e, delta):
        return 2.0 * delta**2 * (np.sqrt(1.0 + (e / delta) ** 2) - 1.0)

    def psi(self, e, delta):
        return 2.0 * e / np.sqrt(1.0 + (e / delta) ** 2)


@pytest.fixture
def pseudo_huber():
    loss = losses.register(PseudoHuber())
    yield loss
    del losses.LOSSES[loss.name]


def outlying_data(seed):
    x, u, _ = simulate_ltv(seed, T=40, n=2, m=1)
    x = x.copy()
    x[[7, 21, 30], 0] += [2.0, -1.5, 3.0]  # gross outliers
    return x, u


def cvxpy_solution(x, u, order, delta, lam, norm):
    k, pred, y, dk = cvxpy_state_space(cp, x, u, order)
    N = y.shape[0]
    loss = 0
    for i in range(y.shape[1]):
        e = (y[:, i] - pred[:, i]) / delta[i]
        size = cp.norm(cp.vstack([np.ones((1, N)), cp.reshape(e, (1, N), order="C")]), 2, axis=0)
        loss += 2.0 * delta[i] ** 2 * cp.sum(size - 1.0)
    penalty = lam**2 * cp.sum_squares(dk) if norm == "sq" else lam * cp.sum(cp.abs(dk))
    problem = cp.Problem(cp.Minimize(loss + penalty))
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    assert problem.status == "optimal"
    return k.value, problem.value


@pytest.mark.parametrize(("norm", "lam"), [("sq", 3.0), ("l1", 0.5)])
def test_a_registered_loss_matches_cvxpy(pseudo_huber, norm, lam):
    x, u = outlying_data(41)
    delta = np.array([0.05, 0.08])
    k_ref, value = cvxpy_solution(x, u, 1, delta, lam, norm)
    model = ltv.fit(
        x, u, lam=lam, norm=norm, loss="pseudo_huber", huber_delta=delta, tol=1e-9, max_iter=5000
    )
    assert model.status.status == "optimal" and model.info["loss"] == "pseudo_huber"
    assert model.info["objective"] == pytest.approx(value, rel=1e-7)
    assert relerr(model.k, k_ref) < 1e-5
    assert model.loglik is None and model.cov is None


def test_a_registered_loss_resists_outliers_and_chooses_lambda(pseudo_huber):
    x, u = outlying_data(42)
    clean = np.delete(np.arange(x.shape[0] - 1), [6, 7, 20, 21, 29, 30])
    plain = ltv.fit(x, u, lam=3.0)
    robust = ltv.fit(x, u, lam=3.0, loss="pseudo_huber")  # δ by the robust scale rule
    truth = ltv.fit(x[:, :], u, lam=3.0, weights=np.isin(np.arange(39), clean).astype(float))
    assert relerr(robust.k, truth.k) < 0.5 * relerr(plain.k, truth.k)
    auto = ltv.fit(x, u, lam="auto", loss="pseudo_huber")  # blocked CV scored by ρ
    assert auto.info["lam_selection"]["loss"] == "pseudo_huber" and auto.lam > 0


def test_a_loss_without_a_threshold_rejects_huber_delta(pseudo_huber):
    class Cosh(losses.Loss):
        name = "logcosh"

        def rho(self, e, delta):
            return 2.0 * np.log(np.cosh(e))

        def psi(self, e, delta):
            return 2.0 * np.tanh(e)

    losses.register(Cosh())
    try:
        x, u = outlying_data(43)
        with pytest.raises(ValueError, match="huber_delta: applies to loss='huber' only"):
            ltv.fit(x, u, lam=3.0, loss="logcosh", huber_delta=0.1)
        model = ltv.fit(x, u, lam=3.0, loss="logcosh", tol=1e-9, max_iter=5000)
        assert model.status.status == "optimal"
    finally:
        del losses.LOSSES["logcosh"]
