"""norm="group" / "l1": agreement with cvxpy + Clarabel and the λ_max limit."""

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core.problem import state_space_problem
from ltvmodels.core.sparse_common import lambda_max

cp = pytest.importorskip("cvxpy")


def clarabel_optimum(x, u, weights, norm, coeffs, *, row_weights=None, constant=False):
    """Optimal value of Σ_r Σ_t w_rt ‖y_rt − Θ_t φ_rt‖² + Σ_t R(Λ(Dk)_t) by cvxpy + Clarabel.

    Built from the raw data: x (T, n) or (R, T, n) with NaN = missing (a
    transition enters only if x[t], u[t], x[t+1] are all finite), u likewise or
    None, row_weights (R, T − 1) or None.
    """
    x = np.asarray(x, float)
    x = x[None] if x.ndim == 2 else x
    R, T, n = x.shape
    u = np.zeros((R, T, 0)) if u is None else np.asarray(u, float).reshape(R, T, -1)
    cols = [x[:, :-1], u[:, :-1]] + ([np.ones((R, T - 1, 1))] if constant else [])
    phi, y = np.concatenate(cols, axis=2), x[:, 1:]
    w = np.ones((R, T - 1)) if row_weights is None else np.asarray(row_weights, float)
    N, p = T - 1, phi.shape[2]
    theta = cp.Variable((N, n * p))
    loss = 0
    for r in range(R):
        obs = np.all(np.isfinite(phi[r]), axis=1) & np.all(np.isfinite(y[r]), axis=1)
        obs &= w[r] > 0
        for i in range(n):
            fitted = cp.sum(cp.multiply(theta[obs, i * p:(i + 1) * p], phi[r][obs]), axis=1)
            loss = loss + cp.sum(cp.multiply(w[r][obs], cp.square(y[r][obs, i] - fitted)))
    d = len(coeffs) - 1
    Dk = sum(coeffs[j] * theta[j:N - d + j, :] for j in range(d + 1))
    Z = cp.multiply(Dk, np.tile(weights, (N - d, 1)))
    reg = cp.sum(cp.norm(Z, 2, axis=1)) if norm == "group" else cp.sum(cp.abs(Z))
    problem = cp.Problem(cp.Minimize(loss + reg))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "may be inaccurate" at these tight tolerances
        problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    return problem.value, theta.value


def data(seed, with_input=True):
    d = ltv.systems.jump_linear(T=50, change_at=25, seed=seed)
    return d.x, (d.u if with_input else None)


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order,coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
@pytest.mark.parametrize("seed,frac", [(0, 0.05), (1, 0.3), (2, 0.8)])
def test_matches_clarabel(norm, order, coeffs, seed, frac):
    x, u = data(seed)
    pb = state_space_problem(x, u, np.array(coeffs))
    lam = frac * lambda_max(pb, norm)
    model = ltv.fit(x, u, lam=lam, norm=norm, order=order, tol=1e-9, max_iter=100_000)
    optimum, theta = clarabel_optimum(x, u, np.full(pb.K, lam), norm, coeffs)
    assert model.info["converged"]
    assert abs(model.info["objective"] - optimum) <= 1e-6 * optimum
    assert np.abs(model.k - theta).max() <= 1e-3 * np.abs(theta).max()


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_without_inputs_and_with_weight_vector(norm):
    x, _ = data(3, with_input=False)
    weights = np.array([1.0, 0.5, 2.0, 1.5])  # K = 4, one weight per coefficient
    pb = state_space_problem(x, np.zeros((len(x), 0)), np.array([-1.0, 1.0]))
    lam = 0.3 * lambda_max(pb, norm, weights)
    model = ltv.fit(x, None, lam=lam * weights, norm=norm, tol=1e-9, max_iter=100_000)
    optimum, _ = clarabel_optimum(x, None, lam * weights, norm, [-1.0, 1.0])
    assert abs(model.info["objective"] - optimum) <= 1e-6 * optimum


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_lambda_max_separates_lti_from_ltv(norm):
    """λ >= λ_max gives the LTI solution exactly; just below it the model changes."""
    x, u = data(4)
    pb = state_space_problem(x, u, np.array([-1.0, 1.0]))
    lam_max = lambda_max(pb, norm)
    lti = ltv.fit_lti(x, u)
    above = ltv.fit(x, u, lam=1.001 * lam_max, norm=norm, tol=1e-10, max_iter=100_000)
    assert np.abs(above.k - lti.k).max() < 1e-7 * np.abs(lti.k).max()
    assert above.info["lambda_max"] == pytest.approx(lam_max, rel=1e-12)
    below = ltv.fit(x, u, lam=0.9 * lam_max, norm=norm, tol=1e-8)
    assert below.activation().max() > 1e-3 * np.abs(lti.k).max()


def test_lambda_max_order_two_gives_linear_trend():
    x, u = data(5)
    pb = state_space_problem(x, u, np.array([1.0, -2.0, 1.0]))
    lam_max = lambda_max(pb, "group")
    model = ltv.fit(x, u, lam=1.001 * lam_max, norm="group", order=2, tol=1e-9, max_iter=100_000)
    assert model.activation().max() < 1e-7 * np.abs(model.k).max()  # k_t linear in t


def test_not_converging_warns():
    x, u = data(6)
    with pytest.warns(ltv.ConvergenceWarning, match="did not converge"):
        model = ltv.fit(x, u, lam=1.0, norm="group", max_iter=1)
    assert model.info["converged"] is False


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_path_equals_independent_fits(norm):
    x, u = data(7)
    lam_max = ltv.lambda_max(x, u, norm=norm)
    lams = lam_max * np.array([0.05, 0.5, 0.2])  # unsorted on purpose
    path = ltv.fit_path(x, u, lams=lams, norm=norm, tol=1e-9, max_iter=100_000)
    assert [m.lam for m in path] == list(lams)
    assert [m.info["path_position"] for m in path] == [2, 0, 1]  # solved from the largest
    for model, lam in zip(path, lams, strict=True):
        alone = ltv.fit(x, u, lam=lam, norm=norm, tol=1e-9, max_iter=100_000)
        assert model.info["objective"] == pytest.approx(alone.info["objective"], rel=1e-7)


def test_path_sq_equals_fit():
    x, u = data(8)
    path = ltv.fit_path(x, u, lams=[1.0, 10.0], norm="sq", order=2)
    for model, lam in zip(path, [1.0, 10.0], strict=True):
        np.testing.assert_allclose(model.k, ltv.fit(x, u, lam=lam, order=2).k, rtol=1e-12)
    with pytest.raises(ValueError, match=r"^lams:"):
        ltv.fit_path(x, u, lams=[], norm="group")


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order,coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_constant_coefficients_match_clarabel(norm, order, coeffs):
    """lam = inf holds a coefficient constant in time: a border in the Newton systems."""
    x, u = data(9)
    pb = state_space_problem(x, u, np.array(coeffs))
    N, n, p = pb.N, pb.n, pb.p
    const = np.array([1, 4])  # A[0, 1] and A[1, 1]: one in each row
    pattern = np.ones(pb.K)
    pattern[const] = np.inf
    weights = 0.3 * lambda_max(pb, norm, pattern) * pattern
    model = ltv.fit(x, u, lam=weights, norm=norm, order=order, tol=1e-9)
    assert model.info["converged"] and model.info["solver"].startswith("interior point")
    np.testing.assert_allclose(model.k[:, const], model.k[:1, const].repeat(N, 0), atol=1e-12)

    theta = cp.Variable((N, n * p))
    phi = pb.phi[:, 0]  # one complete trajectory
    fitted = [cp.sum(cp.multiply(theta[:, i * p:(i + 1) * p], phi), axis=1) for i in range(n)]
    loss = sum(cp.sum_squares(pb.y[:, 0, i] - fitted[i]) for i in range(n))
    d = len(coeffs) - 1
    Dk = sum(coeffs[j] * theta[j:N - d + j, :] for j in range(d + 1))
    finite = np.where(np.isinf(weights), 0.0, weights)
    Z = cp.multiply(Dk, np.tile(finite, (N - d, 1)))
    reg = cp.sum(cp.norm(Z, 2, axis=1)) if norm == "group" else cp.sum(cp.abs(Z))
    constraints = [theta[1:, j] == theta[:-1, j] for j in const]
    problem = cp.Problem(cp.Minimize(loss + reg), constraints)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    assert abs(model.info["objective"] - problem.value) <= 1e-6 * problem.value
    assert np.abs(model.k - theta.value).max() <= 1e-3 * np.abs(theta.value).max()


def test_all_coefficients_constant_is_the_lti_fit():
    x, u = data(10)
    lti = ltv.fit_lti(x, u)
    model = ltv.fit(x, u, lam=np.full(6, np.inf), norm="group")
    np.testing.assert_allclose(model.k, lti.k, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order,coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_missing_samples_batches_and_weights_match_clarabel(norm, order, coeffs):
    """Three trajectories with gaps and weights, an intercept: the same optimum as Clarabel."""
    rng = np.random.default_rng(order)
    x = np.stack([ltv.systems.jump_linear(T=40, change_at=20, seed=s).x for s in range(3)])
    u = np.stack([ltv.systems.jump_linear(T=40, change_at=20, seed=s).u for s in range(3)])
    x[0, 5] = np.nan
    x[1, 30:33] = np.nan
    u[2, 12] = np.nan
    w = rng.uniform(0.5, 2.0, (3, 39))
    lam = 0.2 * ltv.lambda_max(x, u, norm=norm, order=order, weights=w, constant=True)
    model = ltv.fit(x, u, lam=lam, norm=norm, order=order, weights=w, constant=True, tol=1e-9)
    optimum, theta = clarabel_optimum(x, u, np.full(model.K, lam), norm, coeffs,
                                      row_weights=w, constant=True)
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-6)
    np.testing.assert_allclose(model.k, theta, atol=2e-3 * np.abs(theta).max())
