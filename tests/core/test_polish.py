"""Active-set polish of sparse-change fits: exact zeros, a certificate, stalled solves."""

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core import conekernels as cones
from ltvmodels.core import ipm, polish
from ltvmodels.core.penalties import named
from ltvmodels.core.problem import apply_difference, state_space_problem
from ltvmodels.core.sparse_common import lambda_max, null_space_fit

COEFFS = {1: np.array([-1.0, 1.0]), 2: np.array([1.0, -2.0, 1.0])}


def problem_and_weights(seed, order, lam, T=120):
    d = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
    pb = state_space_problem(d.x, d.u, COEFFS[order])
    return pb, np.full(pb.K, lam)


def last_iterate(monkeypatch, pb, weights, norm, tol):
    """The interior-point solution with the (k, s, z) of its last step."""
    saved = {}
    take_step = cones.take_step

    def recording(k, dk, t, dt, s, ds, z, dz, step):
        take_step(k, dk, t, dt, s, ds, z, dz, step)
        saved["iterate"] = (k.copy(), s.copy(), z.copy())

    monkeypatch.setattr(cones, "take_step", recording)
    result = ipm.fit_sparse_ipm(pb, weights, norm, tol=tol)
    monkeypatch.undo()
    return result, saved["iterate"]


def cone_norms(k, pb, weights, norm):
    e = apply_difference(k, pb.coeffs) * weights
    return np.linalg.norm(e, axis=1) if norm == "group" else np.abs(e).ravel()


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order", [1, 2])
def test_polish_certifies_the_interior_point_optimum_with_exact_zeros(monkeypatch, norm, order):
    pb, weights = problem_and_weights(3, order, 4.0)
    result, (k, s, z) = last_iterate(monkeypatch, pb, weights, norm, tol=1e-8)
    polished = polish.polish(pb, weights, norm, k, s, z, tol=1e-9)
    assert polished is not None
    assert polished.duality_gap <= 1e-9 * polished.objective
    assert polished.objective <= result.objective + 1e-8 * result.objective
    assert polished.objective == pytest.approx(result.objective, rel=1e-7)
    norms = cone_norms(polished.k, pb, weights, norm)
    vertex = norms <= 1e-12 * norms.max()
    # Most differences vanish exactly; the interior-point iterate has none at 0.
    assert vertex.mean() > 0.5
    assert np.all(cone_norms(k, pb, weights, norm) > 0)


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_certificate_agrees_with_lambda_max(norm):
    # The LTI (null-space) fit is optimal exactly when λ >= λ_max.
    pb, _ = problem_and_weights(5, 1, 1.0)
    k = null_space_fit(pb).reshape(pb.N, pb.K)
    lam_max = lambda_max(pb, named(norm), np.ones(pb.K), null_space_fit(pb))
    _, gap, residual, u_norm = polish.certificate(pb, np.full(pb.K, 1.01 * lam_max), k, named(norm))
    assert gap == pytest.approx(0.0, abs=1e-9) and residual < 1e-12 and u_norm.max() <= 1.0
    _, _, residual, u_norm = polish.certificate(pb, np.full(pb.K, 0.5 * lam_max), k, named(norm))
    assert u_norm.max() > 1.5 and residual > 1e-3


def test_vertex_cones_from_a_central_iterate():
    s = np.array([[1e-6, 5e-7, 0.0], [2.0, 1.9999, 0.0]])  # near vertex / on the boundary
    z = np.array([[1.0, 0.3, 0.0], [1.0, 0.99999, 0.0]])  # inside / on the boundary
    np.testing.assert_array_equal(polish.vertex_cones(s, z), [True, False])


def test_stalled_order2_fit_is_certified_by_the_polish():
    # Order 2 near λ_max: the Newton systems lose definiteness at a relative
    # gap of about 1e-6, long before a tolerance of 1e-9 is met; "polished"
    # says that the interior-point method did not converge by itself.
    cp = pytest.importorskip("cvxpy")
    d = ltv.systems.jump_linear(T=2000, change_at=1000, seed=1)
    lam = 0.5 * ltv.lambda_max(d.x, d.u, norm="group", order=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ltv.ConvergenceWarning)
        model = ltv.fit(d.x, d.u, lam=lam, norm="group", order=2, tol=1e-9)
    assert model.info["converged"] and model.info["polished"]
    assert model.info["duality_gap"] <= 1e-9 * model.info["objective"]
    pb = state_space_problem(d.x, d.u, COEFFS[2])
    theta = cp.Variable((pb.N, pb.K))
    fitted = [
        cp.sum(cp.multiply(theta[:, i * pb.p : (i + 1) * pb.p], pb.phi[:, 0]), axis=1)
        for i in range(pb.n)
    ]
    loss = sum(cp.sum_squares(pb.y[:, 0, i] - fitted[i]) for i in range(pb.n))
    reg = cp.sum(cp.norm(theta[:-2] - 2 * theta[1:-1] + theta[2:], 2, axis=1))
    reference = cp.Problem(cp.Minimize(loss + lam * reg))
    reference.solve(solver=cp.CLARABEL)
    assert model.info["objective"] <= reference.value * (1 + 1e-7)
    assert model.info["objective"] == pytest.approx(reference.value, rel=1e-6)
