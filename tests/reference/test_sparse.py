"""norm="group" / "l1": agreement with cvxpy + Clarabel and the λ_max limit.

Every solver route is compared with Clarabel (run at 1e-12 tolerances) on the
objective Σ‖y − Φk‖² + Σ_t R(Λ(Dk)_t), which the tests evaluate themselves in
numpy (``dense_reference.sparse_objective``), and with a dual certificate:
``dense_reference.sparse_lower_bound`` turns any k into a feasible point of
the Lagrange dual, so objective(k) − bound bounds the suboptimality of k
without trusting either solver. Tolerances follow from the solvers' stopping
rules:

* interior point (K <= 20, all weights > 0): it stops at a duality gap
  <= tol · objective, which bounds the suboptimality, so the objective must be
  within tol of Clarabel's (and the certificate within 2·tol: it is rebuilt
  from k alone and carries its own dual slack);
* ADMM (K > 20 or a zero weight): it stops on relative residuals, which bound
  the suboptimality only up to a problem-dependent factor (measured 4–25 on
  these problems: relative suboptimality <= 2.3e-9 at tol = 1e-10); the
  objective must be within 1e-7 of Clarabel's, and so must the certificate.

Coefficients are compared where the data term alone is strongly convex
(several trajectories: Φ̃ᵀΦ̃ >= μI). Then P(k) − P* >= ‖Φ̃(k − k*)‖² >= μ‖k − k*‖²
(optimality of k*), so ‖k_a − k_b‖ <= (√gap_a + √gap_b)/√μ with each gap from
the certificate: a tolerance justified by the conditioning, not chosen.
"""

import warnings

import numpy as np
import pytest
from dense_reference import (
    sparse_lower_bound,
    sparse_objective,
    sparse_regression,
    state_space_regression,
)

import ltvmodels as ltv
import ltvmodels.core.sparse as sparse_dispatch
import ltvmodels.core.widekernels as widekernels
from ltvmodels.core.penalties import named
from ltvmodels.core.problem import state_space_problem
from ltvmodels.core.sparse_common import lambda_max

cp = pytest.importorskip("cvxpy")

IPM_TOL = 1e-9  # the tol passed to the interior-point fits below
ADMM_TOL = 1e-10  # the tol passed to the ADMM fits below
ADMM_AGREEMENT = 1e-7  # relative objective agreement required of ADMM at ADMM_TOL


def clarabel_regression(y, phi, weights, norm, coeffs, *, row_weights=None):
    """Optimal value and Θ (N, K) of Σ_r Σ_t w_rt ‖y_rt − Θ_t φ_rt‖² + Σ_t R(Λ(Dk)_t).

    y (R, N, n) or (N, n) and phi (R, N, p) or (N, p) with NaN = missing (a row
    enters only if y_rt and φ_rt are finite and w_rt > 0); row_weights (R, N)
    or None; weights (K,) the λ_j of Λ (0 = unpenalized).
    """
    y, phi = np.asarray(y, float), np.asarray(phi, float)
    if y.ndim == 2:
        y, phi = y[None], phi[None]
    R, N, n = y.shape
    p = phi.shape[2]
    w = np.ones((R, N)) if row_weights is None else np.asarray(row_weights, float)
    theta = cp.Variable((N, n * p))
    loss = 0
    for r in range(R):
        obs = np.all(np.isfinite(phi[r]), axis=1) & np.all(np.isfinite(y[r]), axis=1)
        obs &= w[r] > 0
        for i in range(n):
            fitted = cp.sum(cp.multiply(theta[obs, i * p : (i + 1) * p], phi[r][obs]), axis=1)
            loss = loss + cp.sum(cp.multiply(w[r][obs], cp.square(y[r][obs, i] - fitted)))
    d = len(coeffs) - 1
    Dk = sum(coeffs[j] * theta[j : N - d + j, :] for j in range(d + 1))
    Z = cp.multiply(Dk, np.tile(weights, (N - d, 1)))
    reg = cp.sum(cp.norm(Z, 2, axis=1)) if norm == "group" else cp.sum(cp.abs(Z))
    problem = cp.Problem(cp.Minimize(loss + reg))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "may be inaccurate" at these tight tolerances
        problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    return problem.value, theta.value


def clarabel_optimum(x, u, weights, norm, coeffs, *, row_weights=None, constant=False):
    """Optimal value of Σ_r Σ_t w_rt ‖y_rt − Θ_t φ_rt‖² + Σ_t R(Λ(Dk)_t) by cvxpy + Clarabel.

    Built from the raw data: x (T, n) or (R, T, n) with NaN = missing (a
    transition enters only if x[t], u[t], x[t+1] are all finite), u likewise or
    None, row_weights (R, T − 1) or None.
    """
    x = np.asarray(x, float)
    x = x[None] if x.ndim == 2 else x
    R, T, _ = x.shape
    u = np.zeros((R, T, 0)) if u is None else np.asarray(u, float).reshape(R, T, -1)
    cols = [x[:, :-1], u[:, :-1]] + ([np.ones((R, T - 1, 1))] if constant else [])
    return clarabel_regression(
        x[:, 1:], np.concatenate(cols, axis=2), weights, norm, coeffs, row_weights=row_weights
    )


def check_against_clarabel(
    Phi,
    Y,
    model,
    weights,
    norm,
    coeffs,
    optimum,
    theta,
    *,
    objective_rtol,
    certificate_rtol,
    mu=None,
):
    """The checks shared by the comparisons: objective, certificate and (given μ) coefficients.

    Returns the relative suboptimality certified for the model's k.
    """
    P = sparse_objective(Phi, Y, model.k, weights, norm, coeffs)
    P_ref = sparse_objective(Phi, Y, theta, weights, norm, coeffs)
    bound = sparse_lower_bound(Phi, Y, model.k, weights, norm, coeffs)
    bound_ref = sparse_lower_bound(Phi, Y, theta, weights, norm, coeffs)
    # the reference is at least as accurate as what is asked of the package
    # (certified, not assumed; Clarabel at 1e-12 reaches 1e-13 to 1e-9 here)
    gap_ref = P_ref - bound_ref
    assert gap_ref <= objective_rtol * P_ref, f"Clarabel's certified gap {gap_ref / P_ref:.1e}"
    assert P_ref == pytest.approx(optimum, rel=1e-10)
    assert model.info["objective"] == pytest.approx(P, rel=1e-12), "info['objective']"
    assert P - optimum <= objective_rtol * optimum, (
        f"objective {P!r} vs Clarabel {optimum!r}: relative {(P - optimum) / optimum:.1e} "
        f"> {objective_rtol:.0e}"
    )
    # below Clarabel's value by no more than Clarabel's own certified suboptimality
    assert optimum - P <= gap_ref + 1e-12 * optimum, "below the certified optimum"
    gap = P - bound
    assert gap <= certificate_rtol * P, (
        f"certified suboptimality {gap / P:.1e} > {certificate_rtol:.0e}"
    )
    # fitted values are unique: ‖Φ̃(k − k*)‖² <= P(k) − P* (no conditioning needed)
    fit_bound = np.sqrt(max(gap, 0.0)) + np.sqrt(max(gap_ref, 0.0))
    fit_error = np.linalg.norm(Phi @ (model.k - theta).ravel())
    assert fit_error <= 1.01 * fit_bound + 1e-12 * np.linalg.norm(Y), (fit_error, fit_bound)
    if mu is not None:  # strongly convex: coefficients are unique too
        k_error = np.linalg.norm(model.k - theta)
        assert k_error <= 1.01 * fit_bound / np.sqrt(mu), (k_error, fit_bound / np.sqrt(mu))
    return gap / P


def data(seed, with_input=True):
    d = ltv.systems.jump_linear(T=50, change_at=25, seed=seed)
    return d.x, (d.u if with_input else None)


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order,coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
@pytest.mark.parametrize("seed,frac", [(0, 0.05), (1, 0.3), (2, 0.8)])
def test_matches_clarabel(norm, order, coeffs, seed, frac):
    x, u = data(seed)
    pb = state_space_problem(x, u, np.array(coeffs))
    lam = frac * lambda_max(pb, named(norm))
    model = ltv.fit(x, u, lam=lam, norm=norm, order=order, tol=IPM_TOL, max_iter=100_000)
    weights = np.full(pb.K, lam)
    optimum, theta = clarabel_optimum(x, u, weights, norm, coeffs)
    assert model.info["converged"] and model.info["solver"].startswith("interior point")
    assert model.info["duality_gap"] <= IPM_TOL * model.info["objective"]
    Phi, Y = state_space_regression(x, u)
    check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        norm,
        coeffs,
        optimum,
        theta,
        objective_rtol=IPM_TOL,
        certificate_rtol=2 * IPM_TOL,
    )
    # One trajectory: k is not unique in every direction, but on these data
    # the solutions agree to ~1e-6 (measured <= 1.3e-6 at tol 1e-9).
    assert np.abs(model.k - theta).max() <= 1e-5 * np.abs(theta).max()


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_without_inputs_and_with_weight_vector(norm):
    x, _ = data(3, with_input=False)
    weights = np.array([1.0, 0.5, 2.0, 1.5])  # K = 4, one weight per coefficient
    pb = state_space_problem(x, np.zeros((len(x), 0)), np.array([-1.0, 1.0]))
    lam = 0.3 * lambda_max(pb, named(norm), weights)
    model = ltv.fit(x, None, lam=lam * weights, norm=norm, tol=IPM_TOL, max_iter=100_000)
    assert model.info["solver"].startswith("interior point")
    optimum, theta = clarabel_optimum(x, None, lam * weights, norm, [-1.0, 1.0])
    Phi, Y = state_space_regression(x)
    check_against_clarabel(
        Phi,
        Y,
        model,
        lam * weights,
        norm,
        [-1.0, 1.0],
        optimum,
        theta,
        objective_rtol=IPM_TOL,
        certificate_rtol=2 * IPM_TOL,
    )


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_lambda_max_separates_lti_from_ltv(norm):
    """λ >= λ_max gives the LTI solution exactly; just below it the model changes."""
    x, u = data(4)
    pb = state_space_problem(x, u, np.array([-1.0, 1.0]))
    lam_max = lambda_max(pb, named(norm))
    lti = ltv.fit_lti(x, u)
    above = ltv.fit(x, u, lam=1.001 * lam_max, norm=norm, tol=1e-10, max_iter=100_000)
    assert np.abs(above.k - lti.k).max() < 1e-7 * np.abs(lti.k).max()
    assert above.info["lambda_max"] == pytest.approx(lam_max, rel=1e-12)
    below = ltv.fit(x, u, lam=0.9 * lam_max, norm=norm, tol=1e-8)
    assert below.activation().max() > 1e-3 * np.abs(lti.k).max()


def test_lambda_max_order_two_gives_linear_trend():
    x, u = data(5)
    pb = state_space_problem(x, u, np.array([1.0, -2.0, 1.0]))
    lam_max = lambda_max(pb, named("group"))
    model = ltv.fit(x, u, lam=1.001 * lam_max, norm="group", order=2, tol=1e-9, max_iter=100_000)
    assert model.activation().max() < 1e-7 * np.abs(model.k).max()  # k_t linear in t


def test_not_converging_warns():
    x, u = data(6)
    # order 3: for orders 1 and 2 the active-set polish certifies the optimum from
    # the first iterate of this small problem
    with pytest.warns(ltv.ConvergenceWarning, match="did not converge"):
        model = ltv.fit(x, u, lam=1.0, norm="group", order=3, max_iter=1)
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
    weights = 0.3 * lambda_max(pb, named(norm), pattern) * pattern
    model = ltv.fit(x, u, lam=weights, norm=norm, order=order, tol=IPM_TOL)
    assert model.info["converged"] and model.info["solver"].startswith("interior point")
    np.testing.assert_allclose(model.k[:, const], model.k[:1, const].repeat(N, 0), atol=1e-12)

    theta = cp.Variable((N, n * p))
    phi = pb.phi[:, 0]  # one complete trajectory
    fitted = [cp.sum(cp.multiply(theta[:, i * p : (i + 1) * p], phi), axis=1) for i in range(n)]
    loss = sum(cp.sum_squares(pb.y[:, 0, i] - fitted[i]) for i in range(n))
    d = len(coeffs) - 1
    Dk = sum(coeffs[j] * theta[j : N - d + j, :] for j in range(d + 1))
    finite = np.where(np.isinf(weights), 0.0, weights)
    Z = cp.multiply(Dk, np.tile(finite, (N - d, 1)))
    reg = cp.sum(cp.norm(Z, 2, axis=1)) if norm == "group" else cp.sum(cp.abs(Z))
    constraints = [theta[1:, j] == theta[:-1, j] for j in const]
    problem = cp.Problem(cp.Minimize(loss + reg), constraints)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    # ("optimal_inaccurate" at these tolerances; the certificate below checks it)
    Phi, Y = state_space_regression(x, u)
    check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        norm,
        coeffs,
        problem.value,
        theta.value,
        objective_rtol=IPM_TOL,
        certificate_rtol=2 * IPM_TOL,
    )
    assert np.abs(model.k - theta.value).max() <= 1e-5 * np.abs(theta.value).max()


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
    model = ltv.fit(x, u, lam=lam, norm=norm, order=order, weights=w, constant=True, tol=IPM_TOL)
    assert model.info["solver"].startswith("interior point")
    weights = np.full(model.K, lam)
    optimum, theta = clarabel_optimum(x, u, weights, norm, coeffs, row_weights=w, constant=True)
    Phi, Y = state_space_regression(x, u, w, constant=True)
    check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        norm,
        coeffs,
        optimum,
        theta,
        objective_rtol=IPM_TOL,
        certificate_rtol=2 * IPM_TOL,
    )
    np.testing.assert_allclose(model.k, theta, atol=1e-5 * np.abs(theta).max())


# -- ADMM: more than 20 parameters per time step, or a zero weight ------------------------


def jump_batches(seed, R, T, n, m, noise=0.1):
    """R trajectories of one system whose A, B jump at T // 2: x (R, T, n), u (R, T, m)."""
    rng = np.random.default_rng(seed)

    def stable():
        A = rng.standard_normal((n, n))
        return 0.7 * A / np.abs(np.linalg.eigvals(A)).max()

    A1, A2 = stable(), stable()
    B1 = rng.standard_normal((n, m))
    B2 = B1 + 0.5 * rng.standard_normal((n, m))
    x = np.zeros((R, T, n))
    u = rng.standard_normal((R, T, m))
    x[:, 0] = rng.standard_normal((R, n))
    for t in range(T - 1):
        A, B = (A1, B1) if t < T // 2 else (A2, B2)
        x[:, t + 1] = x[:, t] @ A.T + u[:, t] @ B.T + noise * rng.standard_normal((R, n))
    return x, u


def strong_convexity(Phi, N, K):
    """μ = λ_min(Φ̃ᵀΦ̃): Φ̃ᵀΦ̃ is block diagonal with one K × K block per time step."""
    blocks = [Phi[:, t * K : (t + 1) * K] for t in range(N)]
    return min(float(np.linalg.eigvalsh(b.T @ b)[0]) for b in blocks)


def route(monkeypatch, solver):
    """Force ADMM (the route of "group" beyond 64 parameters per step and of zero weights)
    for a comparison on the same data; "interior point" is the default at K = 24."""
    if solver == "ADMM":
        monkeypatch.setattr(sparse_dispatch, "ipm_suits", lambda penalty, K: False)


@pytest.mark.parametrize("solver", ["interior point", "ADMM"])
@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order,coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_wide_state_space_matches_clarabel(norm, order, coeffs, solver, monkeypatch):
    """K = 24 parameters per step (4 states, 2 inputs), eight trajectories."""
    route(monkeypatch, solver)
    x, u = jump_batches(0, R=8, T=50, n=4, m=2)
    lam = 0.2 * ltv.lambda_max(x, u, norm=norm, order=order)
    model = ltv.fit(x, u, lam=lam, norm=norm, order=order, tol=ADMM_TOL, max_iter=100_000)
    assert model.K == 24 and model.info["solver"].startswith(solver)
    assert model.info["converged"]
    weights = np.full(model.K, lam)
    optimum, theta = clarabel_optimum(x, u, weights, norm, coeffs)
    Phi, Y = state_space_regression(x, u)
    mu = strong_convexity(Phi, model.N, model.K)
    assert mu > 1e-3
    check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        norm,
        coeffs,
        optimum,
        theta,
        objective_rtol=ADMM_AGREEMENT,
        certificate_rtol=ADMM_AGREEMENT,
        mu=mu,
    )


@pytest.mark.parametrize("const", [False, True])
@pytest.mark.parametrize("order,coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_group_interior_point_at_35_parameters_matches_clarabel(order, coeffs, const):
    """K = 35 (5 states, 2 inputs): the wide Newton kernels (:mod:`.widekernels`), with
    and without coefficients held constant (lam = inf: the border of the systems)."""
    x, u = jump_batches(2, R=3, T=30, n=5, m=2)
    pb = state_space_problem(x, u, np.array(coeffs))
    pattern = np.ones(pb.K)
    if const:
        pattern[[1, 20]] = np.inf  # A[0, 1] and A[2, 6]: in different output rows
    weights = 0.2 * lambda_max(pb, named("group"), pattern) * pattern
    model = ltv.fit(x, u, lam=weights, norm="group", order=order, tol=IPM_TOL)
    assert model.K == 35 and model.info["solver"].startswith("interior point")
    assert model.info["converged"]
    finite = np.where(np.isinf(weights), 0.0, weights)
    N, n, p = pb.N, pb.n, pb.p
    theta = cp.Variable((N, n * p))
    phi, y = pb.phi, pb.y  # (N, R, p) and (N, R, n)
    loss = sum(
        cp.sum_squares(
            y[:, r, i] - cp.sum(cp.multiply(theta[:, i * p : (i + 1) * p], phi[:, r]), 1)
        )
        for r in range(phi.shape[1])
        for i in range(n)
    )
    d = len(coeffs) - 1
    Dk = sum(coeffs[j] * theta[j : N - d + j, :] for j in range(d + 1))
    reg = cp.sum(cp.norm(cp.multiply(Dk, np.tile(finite, (N - d, 1))), 2, axis=1))
    constraints = [theta[1:, j] == theta[:-1, j] for j in np.flatnonzero(np.isinf(weights))]
    problem = cp.Problem(cp.Minimize(loss + reg), constraints)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    Phi, Y = state_space_regression(x, u)
    check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        "group",
        coeffs,
        problem.value,
        theta.value,
        objective_rtol=IPM_TOL,
        certificate_rtol=2 * IPM_TOL,
    )
    assert model.activation().max() > 0  # λ below λ_max: the coefficients do change


@pytest.mark.parametrize(
    "order, coeffs, kernel",
    [(1, [-1.0, 1.0], "factor_newton_wide_first"), (2, [1.0, -2.0, 1.0], "factor_newton_wide")],
)
def test_l1_with_16_regressors_takes_the_wide_kernels_and_matches_clarabel(
    order, coeffs, kernel, monkeypatch
):
    """norm="l1", p = 16 regressors (two outputs, four series with weights and a missing
    row): each output's 16 × 16 Newton blocks go to :mod:`.widekernels` (explicit
    inverses for order 1, BLAS and LAPACK for order 2; the scalar loops before, 1.2-3x
    slower), at Clarabel's optimum."""
    real = getattr(widekernels, kernel)
    calls = []

    def counted(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(widekernels, kernel, counted)
    rng = np.random.default_rng(5)
    R, N, n, p = 4, 40, 2, 16
    phi = rng.standard_normal((R, N, p))
    theta_true = np.where(np.arange(N)[:, None, None] < 25, 1.0, -0.5) * rng.standard_normal(
        (1, n, p)
    )
    y = np.einsum("tip,rtp->rti", theta_true, phi) + 0.1 * rng.standard_normal((R, N, n))
    w = rng.uniform(0.5, 2.0, (R, N))
    y[1, 12, 0] = np.nan
    lam = 0.05 * np.sqrt(float(np.nansum(y**2)))
    model = ltv.fit_regression(y, phi, lam=lam, norm="l1", order=order, weights=w, tol=IPM_TOL)
    assert calls, "the wide kernel was not called"
    assert model.info["solver"].startswith("interior point") and model.info["converged"]
    weights = np.full(n * p, lam)
    optimum, theta = clarabel_regression(y, phi, weights, "l1", coeffs, row_weights=w)
    Phi, Y = sparse_regression(y, phi, w)
    check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        "l1",
        coeffs,
        optimum,
        theta,
        objective_rtol=IPM_TOL,
        # the dense bound, a dual point made from the residuals alone, is looser here than
        # the solver's own for order 2 (2.2e-9; 5.4e-9 by the scalar loops)
        certificate_rtol=10 * IPM_TOL,
    )
    assert model.activation().max() > 0  # λ below λ_max: the coefficients do change


@pytest.mark.parametrize("solver", ["interior point", "ADMM"])
@pytest.mark.parametrize("norm", ["group", "l1"])
def test_wide_regression_with_dropped_rows_matches_clarabel(norm, solver, monkeypatch):
    """fit_regression, K = 3 × 8 = 24, ten series with weights (some 0) and missing rows."""
    route(monkeypatch, solver)
    rng = np.random.default_rng(11)
    R, N, n, p = 10, 45, 3, 8
    phi = rng.standard_normal((R, N, p))
    theta_true = np.where(np.arange(N)[:, None, None] < 20, 1.0, -0.5) * rng.standard_normal(
        (1, n, p)
    )
    y = np.einsum("tip,rtp->rti", theta_true, phi) + 0.1 * rng.standard_normal((R, N, n))
    w = rng.uniform(0.5, 2.0, (R, N))
    w[0, 3:9] = 0.0  # dropped transitions
    w[4, 30] = 0.0
    y[2, 17, 1] = np.nan  # a missing output drops its row
    phi[7, 40, 0] = np.nan
    lam = 0.1 * np.sqrt(float(np.nansum(y**2)))  # lambda_max is for the state-space form
    model = ltv.fit_regression(
        y, phi, lam=lam, norm=norm, weights=w, tol=ADMM_TOL, max_iter=100_000
    )
    assert model.info["solver"].startswith(solver) and model.info["converged"]
    weights = np.full(n * p, lam)
    optimum, theta = clarabel_regression(y, phi, weights, norm, [-1.0, 1.0], row_weights=w)
    Phi, Y = sparse_regression(y, phi, w)
    mu = strong_convexity(Phi, N, n * p)
    assert mu > 1e-3
    gap = check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        norm,
        [-1.0, 1.0],
        optimum,
        theta,
        objective_rtol=ADMM_AGREEMENT,
        certificate_rtol=ADMM_AGREEMENT,
        mu=mu,
    )
    assert gap >= 0.0
    assert model.activation().max() > 0  # λ below λ_max: the coefficients do change


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order,coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_zero_coefficient_weights_use_admm_and_match_clarabel(norm, order, coeffs):
    """λ_j = 0 leaves coefficient j free (K = 6, but the interior point needs λ > 0)."""
    x, u = jump_batches(1, R=6, T=50, n=2, m=1)
    pattern = np.array([1.0, 0.0, 2.0, 0.5, 1.0, 0.0])  # B[0] and B[1] free
    weights = 0.3 * ltv.lambda_max(x, u, norm=norm, order=order) * pattern
    model = ltv.fit(x, u, lam=weights, norm=norm, order=order, tol=ADMM_TOL, max_iter=100_000)
    assert model.info["solver"].startswith("ADMM") and model.info["converged"]
    optimum, theta = clarabel_optimum(x, u, weights, norm, coeffs)
    Phi, Y = state_space_regression(x, u)
    mu = strong_convexity(Phi, model.N, model.K)
    assert mu > 1e-3
    check_against_clarabel(
        Phi,
        Y,
        model,
        weights,
        norm,
        coeffs,
        optimum,
        theta,
        objective_rtol=ADMM_AGREEMENT,
        certificate_rtol=ADMM_AGREEMENT,
        mu=mu,
    )


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_admm_warns_when_its_certificate_misses_the_tolerance(norm):
    """ADMM stops on the duality-gap certificate; cut short, it says so."""
    x, u = jump_batches(1, R=2, T=60, n=2, m=1)
    weights = 0.3 * ltv.lambda_max(x, u, norm=norm) * np.array([1.0, 0.0, 2.0, 0.5, 1.0, 1.0])
    with pytest.warns(
        ltv.ConvergenceWarning, match=r"ADMM did not converge .*relative duality gap"
    ):
        model = ltv.fit(x, u, lam=weights, norm=norm, max_iter=5)
    assert not model.info["converged"] and model.info["duality_gap"] > 0
    full = ltv.fit(x, u, lam=weights, norm=norm, tol=1e-8, max_iter=100_000)
    assert full.info["converged"]
    assert full.info["duality_gap"] <= 1e-8 * full.info["objective"]
    assert full.info["stationarity"] <= 1e-8
