"""The interior-point method's building blocks against dense linear algebra."""

import dataclasses

import numpy as np
import pytest
from dense_reference import difference_matrix

import ltvmodels as ltv
from ltvmodels.core import conekernels as cones
from ltvmodels.core import ipm
from ltvmodels.core.problem import state_space_problem


def interior_points(rng, n_cones, g):
    """Random points strictly inside second-order cones of size g + 1."""
    x = rng.normal(size=(n_cones, g + 1))
    x[:, 0] = np.linalg.norm(x[:, 1:], axis=1) + rng.uniform(0.05, 2.0, n_cones)
    return x


def cone_matrices(v, eta, power):
    """W (power 1) or W⁻¹ (power −1) of every cone as dense matrices."""
    n_cones, m = v.shape
    cols = []
    for j in range(m):
        e = np.zeros((n_cones, m))
        e[:, j] = 1.0
        out = np.empty_like(e)
        cones.apply_scaling(v, eta, e, power, out)
        cols.append(out)
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("g", [1, 2, 3, 6])
@pytest.mark.parametrize("order", [1, 2, 3])
def test_difference_kernels_for_every_cone_size(g, order):
    """ΛDk into cone vectors and DᵀΛv₁ back, against a dense D, for any g dividing K."""
    rng = np.random.default_rng(10 * g + order)
    N, K = 9, 6
    coeffs = {1: [-1.0, 1.0], 2: [1.0, -2.0, 1.0], 3: [-1.0, 3.0, -3.0, 1.0]}[order]
    coeffs = np.array(coeffs)
    D = difference_matrix(N, coeffs)
    R, C = N - order, K // g
    k, w = rng.normal(size=(N, K)), rng.uniform(0.5, 2.0, K)
    out = np.zeros((R * C, g + 1))
    cones.weighted_difference(k, coeffs, w, out)
    np.testing.assert_allclose(out[:, 1:], ((D @ k) * w).reshape(R * C, g), atol=1e-13)
    v, adjoint = rng.normal(size=(R * C, g + 1)), np.zeros((N, K))
    cones.add_weighted_difference_adjoint(v, coeffs, w, 0.7, adjoint)
    np.testing.assert_allclose(adjoint, 0.7 * D.T @ (v[:, 1:].reshape(R, K) * w), atol=1e-13)


@pytest.mark.parametrize("g", [1, 4])
def test_corrector_target_against_dense_scaling(g):
    """σμe − λ∘λ − (W⁻¹Δs) ∘ (WΔz), with W and W⁻¹ as dense matrices and ∘ by its definition."""
    rng = np.random.default_rng(10 + g)
    s, z = interior_points(rng, 6, g), interior_points(rng, 6, g)
    v, eta, lam = np.empty_like(s), np.empty(6), np.empty_like(s)
    cones.nt_scaling(s, z, v, eta, lam)
    ds, dz = rng.normal(size=s.shape), rng.normal(size=s.shape)
    W, W_inv = cone_matrices(v, eta, 1.0), cone_matrices(v, eta, -1.0)
    a, b = np.einsum("cij,cj->ci", W_inv, ds), np.einsum("cij,cj->ci", W, dz)

    def jordan(x, y):
        return np.column_stack([np.sum(x * y, 1), x[:, :1] * y[:, 1:] + y[:, :1] * x[:, 1:]])

    expected = -jordan(lam, lam) - jordan(a, b)
    expected[:, 0] += 0.7
    out = np.empty_like(s)
    cones.corrector_target(lam, v, eta, ds.copy(), dz.copy(), 0.7, out)
    np.testing.assert_allclose(out, expected, rtol=1e-10, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("g", [1, 4])
def test_nesterov_todd_scaling(g):
    rng = np.random.default_rng(g)
    s, z = interior_points(rng, 5, g), interior_points(rng, 5, g)
    v, eta, lam = np.empty_like(s), np.empty(5), np.empty_like(s)
    cones.nt_scaling(s, z, v, eta, lam)
    W, W_inv = cone_matrices(v, eta, 1.0), cone_matrices(v, eta, -1.0)
    np.testing.assert_allclose(W @ W_inv, np.broadcast_to(np.eye(g + 1), W.shape), atol=1e-12)
    np.testing.assert_allclose(W, np.swapaxes(W, 1, 2), atol=1e-12)
    np.testing.assert_allclose(np.einsum("cij,cj->ci", W, z), lam, atol=1e-12)  # λ = Wz
    np.testing.assert_allclose(np.einsum("cij,cj->ci", W_inv, s), lam, atol=1e-12)  # = W⁻¹s
    # The elimination terms: W⁻² = [[α, βᵀ], [β, Γ]] and S = Γ − ββᵀ/α.
    alpha, beta, s_coef = np.empty(5), np.empty((5, g)), np.empty(5)
    cones.elimination_terms(v, eta, alpha, beta, s_coef)
    W2_inv = W_inv @ W_inv
    np.testing.assert_allclose(alpha, W2_inv[:, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(beta, W2_inv[:, 1:, 0], rtol=1e-10, atol=1e-12)
    schur = W2_inv[:, 1:, 1:] - W2_inv[:, 1:, :1] * W2_inv[:, :1, 1:] / W2_inv[:, :1, :1]
    rank_one = s_coef[:, None, None] * v[:, 1:, None] * v[:, None, 1:]
    S = (np.eye(g) - rank_one) / eta[:, None, None] ** 2
    np.testing.assert_allclose(S, schur, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
def test_pair_kernels_equal_the_general_kernels_on_2d_cones(coeffs):
    """The closed forms for cones of width 2 (l1) give what the general NT kernels give."""
    rng = np.random.default_rng(11)
    coeffs = np.array(coeffs)
    N, K = 40, 3
    n_cones = (N - len(coeffs) + 1) * K
    # cones near their boundary too: the largest and smallest scalings of an IPM
    s, z = interior_points(rng, n_cones, 1), interior_points(rng, n_cones, 1)
    s[::5, 0] = np.abs(s[::5, 1]) * (1.0 + 1e-6)
    z[1::5, 0] = np.abs(z[1::5, 1]) * (1.0 + 1e-5)
    r_z, target = rng.normal(size=(n_cones, 2)), rng.normal(size=(n_cones, 2))
    ds_a, dz_a = rng.normal(size=(n_cones, 2)), rng.normal(size=(n_cones, 2))
    r_k, dk = rng.normal(size=(N, K)), rng.normal(size=(N, K))
    w = rng.uniform(0.5, 2.0, K)

    v, lam, lam_sq, u_rz = (np.empty_like(s) for _ in range(4))
    eta = np.empty(n_cones)
    alpha, beta, s_coef = np.empty(n_cones), np.empty((n_cones, 1)), np.empty(n_cones)
    cones.prepare_newton(s, z, r_z, v, eta, lam, lam_sq, u_rz, alpha, beta, s_coef)
    inv_s, base, pair_lam_sq = np.empty_like(s), np.empty_like(s), np.empty_like(s)
    inv_alpha, ratio, penalty = np.empty(n_cones), np.empty(n_cones), np.empty(n_cones)
    assert cones.prepare_newton_pairs(
        s, z, r_z, inv_s, base, inv_alpha, ratio, penalty, pair_lam_sq
    )
    np.testing.assert_allclose(pair_lam_sq, lam_sq, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(inv_alpha, 1.0 / alpha, rtol=1e-9)
    np.testing.assert_allclose(ratio, beta[:, 0] / alpha, rtol=1e-9, atol=1e-14)
    S = (1.0 - s_coef * v[:, 1] ** 2) / eta**2
    np.testing.assert_allclose(penalty, S, rtol=1e-7)  # the general form cancels

    work, rhs = np.empty_like(s), np.empty((N, K))
    cones.direction_rhs(target, lam, v, eta, u_rz, z, alpha, beta, r_k, coeffs, w, work, rhs)
    pair_work, pair_rhs = np.empty_like(s), np.empty((N, K))
    cones.direction_rhs_pairs(target, inv_s, base, ratio, r_k, coeffs, w, pair_work, pair_rhs)
    scale = np.abs(work).max()
    np.testing.assert_allclose(pair_work, work, rtol=1e-8, atol=1e-12 * scale)
    np.testing.assert_allclose(pair_rhs, rhs, rtol=1e-8, atol=1e-12 * scale)

    general = [np.empty(n_cones), np.empty_like(s), np.empty_like(s)]
    steps = cones.direction_finish(
        dk, work, s, r_z, z, alpha, beta, v, eta, s_coef, coeffs, w, *general
    )
    pair = [np.empty(n_cones), np.empty_like(s), np.empty_like(s)]
    pair_steps = cones.direction_finish_pairs(
        dk, work, inv_s, r_z, z, inv_alpha, ratio, penalty, coeffs, w, *pair
    )
    for ours, theirs in zip(pair, general):
        np.testing.assert_allclose(ours, theirs, rtol=1e-7, atol=1e-9 * np.abs(theirs).max())
    np.testing.assert_allclose(pair_steps, steps, rtol=1e-6)
    assert pair_steps[0] == pytest.approx(cones.max_step(s, pair[1]), rel=1e-9)
    assert pair_steps[1] == pytest.approx(cones.max_step(z, pair[2]), rel=1e-9)

    out, pair_out = np.empty_like(s), np.empty_like(s)
    cones.corrector_target_pairs(lam_sq, ds_a, dz_a, 0.3, pair_out)
    cones.corrector_target(lam, v, eta, ds_a, dz_a, 0.3, out)
    np.testing.assert_allclose(pair_out, out, rtol=1e-9, atol=1e-9 * np.abs(out).max())

    s[3, 0] = s[3, 1]  # on the boundary
    assert not cones.prepare_newton_pairs(
        s, z, r_z, inv_s, base, inv_alpha, ratio, penalty, pair_lam_sq
    )


def test_max_step_reaches_the_boundary():
    rng = np.random.default_rng(3)
    x = interior_points(rng, 1, 3)
    for _ in range(20):
        dx = rng.normal(size=(1, 4)) * 3
        alpha = cones.max_step(x, dx)
        if np.isinf(alpha):  # the direction stays in the cone
            assert dx[0, 0] >= np.linalg.norm(dx[0, 1:])
            continue
        edge = x[0] + alpha * dx[0]
        assert edge[0] == pytest.approx(np.linalg.norm(edge[1:]), abs=1e-9)
        inside = x[0] + 0.999 * alpha * dx[0]
        assert inside[0] > np.linalg.norm(inside[1:])


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
def test_newton_direction_solves_the_linearized_kkt_system(norm, coeffs):
    """Δ from the banded elimination satisfies the three blocks of Newton's equations."""
    data = ltv.systems.jump_linear(T=30, change_at=15, seed=4)
    pb = state_space_problem(data.x, data.u, np.array(coeffs))
    rng = np.random.default_rng(5)
    weights = rng.uniform(0.5, 2.0, pb.K)
    cp = ipm.ConicProblem(pb, weights, norm)
    n_cones, m = cp.cone_shape
    N, K = cp.N, cp.K
    k, t = rng.normal(size=(N, K)), rng.uniform(1, 2, n_cones)
    s, z = interior_points(rng, n_cones, m - 1), interior_points(rng, n_cones, m - 1)
    r_z, r_k = np.empty_like(s), np.empty((N, K))
    cones.kkt_residuals(k, t, s, z, cp.y, cp.phi, cp.coeffs, cp.w, r_z, r_k)
    newton = ipm.NewtonSystem(cp, s, z, r_z, r_k)
    newton.affine_direction()  # factors
    target = rng.normal(size=s.shape)
    dk, dt, ds, dz, (step_s, step_z) = newton.direction(target)
    assert step_s == pytest.approx(cones.max_step(s, ds))  # each on its own cones
    assert step_z == pytest.approx(cones.max_step(z, dz))
    # G(Δt, Δk) = −(Δt, ΛDΔk);  Gᵀ(v₀, v₁) = (−v₀, −DᵀΛv₁).
    Dt = difference_matrix(N, np.array(coeffs))
    Dk = (Dt @ dk) * weights
    G_dx = -np.concatenate([dt[:, None], Dk.reshape(n_cones, m - 1)], axis=1)
    np.testing.assert_allclose(G_dx + ds, -r_z, atol=1e-8)  # GΔx + Δs = −r_z
    # PΔx + GᵀΔz = −r_x: t-part −Δz₀ = −(1 − z₀); k-part 2ΦᵀΦΔk − DᵀΛΔz₁ = −r_k.
    np.testing.assert_allclose(dz[:, 0], 1.0 - z[:, 0], atol=1e-10)
    adj = Dt.T @ (dz[:, 1:].reshape(-1, K) * weights)
    theta = dk.reshape(N, pb.n, pb.p)
    data_term = 2.0 * (
        np.einsum("tij,tj->ti", theta, pb.phi[:, 0])[:, :, None] * pb.phi[:, 0, None, :]
    ).reshape(N, K)
    np.testing.assert_allclose(data_term - adj, -r_k, atol=1e-7 * np.abs(r_k).max())
    # λ ∘ (WΔz + W⁻¹Δs) = target, with the general NT scaling (l1 takes closed forms).
    v, eta, lam = np.empty_like(s), np.empty(n_cones), np.empty_like(s)
    cones.nt_scaling(s, z, v, eta, lam)
    W, W_inv = cone_matrices(v, eta, 1.0), cone_matrices(v, eta, -1.0)
    scaled = np.einsum("cij,cj->ci", W, dz) + np.einsum("cij,cj->ci", W_inv, ds)
    out = np.empty_like(scaled)
    cones.jordan_product(lam, scaled, out)
    np.testing.assert_allclose(out, target, atol=1e-7)


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_compiled_block_size_kernels_agree(norm, monkeypatch):
    """The kernels specialized to a constant block size give the same iterates."""
    data = ltv.systems.jump_linear(T=60, change_at=30, seed=6)
    pb = state_space_problem(data.x, data.u, np.array([-1.0, 1.0]))
    weights = np.full(pb.K, 2.0)
    generic = ipm.fit_sparse_ipm(pb, weights, norm)
    monkeypatch.setattr(ipm, "FIXED_KERNEL_MIN_SIZE", 1)
    fixed = ipm.fit_sparse_ipm(pb, weights, norm)
    assert fixed.iterations == generic.iterations
    np.testing.assert_allclose(fixed.theta, generic.theta, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("scale", [1.0, 1e3])
@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
def test_feasible_start_is_primal_and_dual_feasible(norm, scale, coeffs):
    """The quadratic-fit start has zero stationarity residual and z strictly inside the cones."""
    data = ltv.systems.jump_linear(T=200, change_at=100, seed=7)
    pb = state_space_problem(scale * data.x, scale * data.u, np.array(coeffs))
    weights = np.random.default_rng(8).uniform(2.0, 20.0, pb.K) * scale
    cp = ipm.ConicProblem(pb, weights, norm)
    k, rho = ipm.feasible_start(pb, cp)
    assert rho is not None
    s = np.zeros(cp.cone_shape)
    cones.weighted_difference(k, cp.coeffs, cp.w, s)
    z = np.zeros(cp.cone_shape)
    z[:, 0] = 1.0
    z[:, 1:] = -rho * s[:, 1:]
    dual_norms = np.linalg.norm(z[:, 1:], axis=1)
    low, high = ipm.START_DUAL_RANGE
    assert low <= dual_norms.max() < high  # inside the dual cones, not far inside
    r_z, r_k = np.empty_like(s), np.empty_like(k)
    s[:, 0] = np.linalg.norm(s[:, 1:], axis=1) + 1.0
    cones.kkt_residuals(k, s[:, 0].copy(), s, z, cp.y, cp.phi, cp.coeffs, cp.w, r_z, r_k)
    gradient_scale = np.abs(2.0 * pb.phi[:, 0].T @ pb.y[:, 0]).max()
    assert np.abs(r_k).max() < 1e-9 * gradient_scale  # 2Φᵀ(Φk − y) − DᵀΛz₁ = 0
    start = ipm.fit_sparse_ipm(pb, weights, norm)
    zero = ipm.fit_sparse_ipm(pb, weights, norm, k0=np.zeros_like(k))
    assert start.converged and zero.converged
    assert start.objective == pytest.approx(zero.objective, rel=1e-6)


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
def test_warm_start_along_a_path_reaches_the_cold_optimum_in_fewer_iterations(
    norm, coeffs, monkeypatch
):
    """Up a λ path the previous optimum with its rescaled duals is a primal-dual feasible
    start (warm_dual): the same optimum as a cold start from the quadratic fit, in fewer
    iterations for order 1 (order 2 starts cold: see WARM_DEGREES). (The group cones'
    reweighted cold start needs about as many iterations as the warm start, after its
    reweighted fits: it is left out here.)"""
    monkeypatch.setattr(ipm, "REWEIGHT_STEPS", 0)
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=4)
    pb = state_space_problem(data.x, data.u, np.array(coeffs))
    lam_max = ltv.lambda_max(data.x, data.u, norm=norm, order=len(coeffs) - 1)
    previous, warm_iterations, cold_iterations = None, 0, 0
    for fraction in (0.02, 0.05, 0.1, 0.2, 0.4):
        weights = np.full(pb.K, fraction * lam_max)
        if previous is not None:
            cp = ipm.ConicProblem(pb, weights, norm)
            z1 = ipm.warm_dual(previous, cp)
            assert np.linalg.norm(z1, axis=1).max() < 1.0  # inside the dual cones
            r_z, r_k = np.empty(cp.cone_shape), np.empty((pb.N, pb.K))
            s = np.zeros(cp.cone_shape)
            z = np.zeros(cp.cone_shape)
            z[:, 1:] = z1
            k = previous.theta.reshape(pb.N, pb.K)
            cones.kkt_residuals(
                k, np.zeros(cp.n_cones), s, z, cp.y, cp.phi, cp.coeffs, cp.w, r_z, r_k
            )
            # stationary up to the previous solve's residual
            assert np.abs(r_k).max() < 1e-5 * np.abs(2.0 * pb.phi[:, 0].T @ pb.y[:, 0]).max()
        cold = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-8)
        warm = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-8, warm_start=previous)
        assert cold.converged and warm.converged
        assert warm.objective == pytest.approx(cold.objective, rel=1e-7)
        cold_iterations += cold.iterations
        warm_iterations += warm.iterations
        previous = warm if warm.dual is not None else cold
    if len(coeffs) - 1 in ipm.WARM_DEGREES:
        assert warm_iterations < cold_iterations
    else:
        assert warm_iterations == cold_iterations


@pytest.mark.parametrize("tol", [1e-4, 1e-8])
def test_group_warm_start_from_reweighted_fits_up_a_path(tol, monkeypatch):
    """A group warm start takes WARM_REWEIGHT_STEPS reweighted fits from the previous k:
    up a λ path (order 1) each fit reaches the cold optimum; at the L-curve's tolerance
    in fewer iterations than from the previous solution's rescaled duals (the warm
    start without the fits: 35 against 46 here; at 1e-8 66 against 74, but on other
    seeds about as many)."""
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=6)
    pb = state_space_problem(data.x, data.u, np.array([-1.0, 1.0]))
    lam_max = ltv.lambda_max(data.x, data.u, norm="group")
    previous, reweighted, plain = None, 0, 0
    for fraction in np.geomspace(1e-3, 0.5, 8):
        weights = np.full(pb.K, fraction * lam_max)
        cold = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-9)
        warm = ipm.fit_sparse_ipm(pb, weights, "group", tol=tol, warm_start=previous)
        monkeypatch.setattr(ipm, "WARM_REWEIGHT_STEPS", 0)
        without = ipm.fit_sparse_ipm(pb, weights, "group", tol=tol, warm_start=previous)
        monkeypatch.undo()
        assert cold.converged and warm.converged and without.converged
        assert warm.objective == pytest.approx(cold.objective, rel=3 * tol)
        if previous is not None:
            reweighted += warm.iterations
            plain += without.iterations
        previous = warm
    assert ipm.WARM_REWEIGHT_STEPS > 0
    if tol == 1e-4:
        assert reweighted < plain
    # The number of fits is the one asked for: one fit from k is the
    # REWEIGHT_STEPS = 1 start.
    cp = ipm.ConicProblem(pb, weights, "group")
    k = previous.theta.reshape(pb.N, pb.K)
    one = ipm.reweighted_start(pb, cp, k, 1)
    monkeypatch.setattr(ipm, "REWEIGHT_STEPS", 1)
    expected = ipm.reweighted_start(pb, cp, k)
    np.testing.assert_array_equal(one[0], expected[0])
    np.testing.assert_array_equal(one[1], expected[1])
    assert ipm.reweighted_start(pb, cp, k, 0) is None


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_interpolated_start_between_two_path_solutions_is_feasible(norm):
    """The convex combination of two solutions' primal-dual pairs (interpolated_start)
    is stationary and dual feasible at the λ between them, and a fit started there
    reaches the cold optimum."""
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=4)
    pb = state_space_problem(data.x, data.u, np.array([-1.0, 1.0]))
    lam_max = ltv.lambda_max(data.x, data.u, norm=norm, order=1)
    pattern = np.random.default_rng(3).uniform(0.5, 1.0, pb.K)
    lower = ipm.fit_sparse_ipm(pb, 0.05 * lam_max * pattern, norm, tol=1e-10)
    upper = ipm.fit_sparse_ipm(pb, 0.3 * lam_max * pattern, norm, tol=1e-10)
    weights = 0.1 * lam_max * pattern
    start = ipm.interpolated_start(lower, upper, weights)
    assert start is not None and not start.converged
    share = (0.1 - 0.05) / (0.3 - 0.05)
    np.testing.assert_allclose(start.theta, (1 - share) * lower.theta + share * upper.theta)
    assert np.linalg.norm(start.dual, axis=1).max() <= 1.0 + 1e-9  # inside the dual cones
    # 2Φᵀ(Φk − y) = DᵀΛz₁, with D from the dense reference.
    resid = pb.y[:, 0] - np.einsum("tia,ta->ti", start.theta, pb.phi[:, 0])
    gradient = -2.0 * np.einsum("ti,ta->tia", resid, pb.phi[:, 0]).reshape(pb.N, pb.K)
    D = difference_matrix(pb.N, [-1.0, 1.0])
    adjoint = D.T @ (start.dual.reshape(pb.N - 1, pb.K) * weights)
    scale = np.abs(2.0 * pb.phi[:, 0].T @ pb.y[:, 0]).max()
    assert np.abs(gradient - adjoint).max() < 1e-6 * scale
    cold = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-8)
    warm = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-8, warm_start=start)
    assert cold.converged and warm.converged
    assert warm.objective == pytest.approx(cold.objective, rel=1e-7)
    # Not between the two, or not one pattern scaled: no start.
    assert ipm.interpolated_start(lower, upper, 0.4 * lam_max * pattern) is None
    assert ipm.interpolated_start(lower, upper, 0.1 * lam_max * pattern[::-1]) is None


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
@pytest.mark.parametrize("fixed", [False, True])
def test_fused_predictor_corrector_equals_the_separate_calls(coeffs, fixed, monkeypatch):
    """The one-call predictor–corrector of group cones gives the directions of the
    separate factor, predictor, corrector target and corrector calls."""
    if fixed:
        monkeypatch.setattr(ipm, "FIXED_KERNEL_MIN_SIZE", 1)
    data = ltv.systems.jump_linear(T=40, change_at=20, seed=9)
    pb = state_space_problem(data.x, data.u, np.array(coeffs))
    rng = np.random.default_rng(10)
    cp = ipm.ConicProblem(pb, rng.uniform(0.5, 2.0, pb.K), "group")
    assert (cp.systems[0].fixed is not None) == fixed
    n_cones, m = cp.cone_shape
    k, t = rng.normal(size=(cp.N, cp.K)), rng.uniform(1, 2, n_cones)
    s, z = interior_points(rng, n_cones, m - 1), interior_points(rng, n_cones, m - 1)
    r_z, r_k = np.empty_like(s), np.empty((cp.N, cp.K))
    gap = cones.kkt_residuals(k, t, s, z, cp.y, cp.phi, cp.coeffs, cp.w, r_z, r_k)[2]
    fused = ipm.NewtonSystem(cp, s, z, r_z, r_k).predictor_corrector(gap)
    newton = ipm.NewtonSystem(cp, s, z, r_z, r_k)
    _, _, ds_a, dz_a, steps_a = newton.affine_direction()
    sigma_mu = (1.0 - min(1.0, *steps_a)) ** 3 * gap / n_cones
    separate = newton.direction(newton.corrector_target(ds_a, dz_a, sigma_mu))
    for got, expected in zip(fused, separate, strict=True):
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-11)
    # the steps are those of s and of z, each on its own cones
    dk, dt, ds, dz, (step_s, step_z) = fused
    assert step_s == pytest.approx(cones.max_step(s, ds), rel=1e-12)
    assert step_z == pytest.approx(cones.max_step(z, dz), rel=1e-12)


@pytest.mark.parametrize("norm,T,seed,lam", [("group", 2000, 0, 17.0), ("l1", 1000, 2, 5.0)])
def test_separate_primal_and_dual_steps_reach_the_optimum_in_fewer_iterations(
    norm, T, seed, lam, monkeypatch
):
    """Order-1 fits step the primal and the dual variables each as far as its cones
    allow: on the jump-linear group fit at T = 2000 the first steps are no longer held
    to the primal's 0.1-0.25 (5 iterations instead of 7; l1 here 10 instead of 12), to
    the same optimum (the same stopping test)."""
    data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
    pb = state_space_problem(data.x, data.u, np.array([-1.0, 1.0]))
    weights = np.full(pb.K, lam)
    separate = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6)
    monkeypatch.setattr(ipm, "SEPARATE_STEP_DEGREES", ())
    common = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6)
    assert separate.converged and common.converged
    assert separate.iterations < common.iterations
    assert separate.objective == pytest.approx(common.objective, rel=2e-6)


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_one_step_for_primal_and_dual_at_order_2(norm, monkeypatch):
    """Order 2 keeps one step (near λ_max it stalled with separate steps): the fit is the
    same bit for bit as with no order taking separate steps."""
    coeffs = [1.0, -2.0, 1.0]
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=1)
    pb = state_space_problem(data.x, data.u, np.array(coeffs))
    weights = np.full(pb.K, 5.0)
    default = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6)
    monkeypatch.setattr(ipm, "SEPARATE_STEP_DEGREES", ())
    common = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6)
    assert default.converged
    np.testing.assert_array_equal(default.theta, common.theta)


def _weighted_row_problem(coeffs, data_seed, rng_seed, shared, norm):
    """A jump-linear problem (T = 40) with random cone weights (equal across output rows
    where ``shared``), its ConicProblem, the generator for what follows, and the dense
    Φ (N n, N K) of its rows."""
    data = ltv.systems.jump_linear(T=40, change_at=20, seed=data_seed)
    pb = state_space_problem(data.x, data.u, np.array(coeffs))
    rng = np.random.default_rng(rng_seed)
    weights = rng.uniform(2.0, 20.0, pb.K)
    if shared:
        weights = np.tile(weights[: pb.p], pb.n)
    N, K, n, p = pb.N, pb.K, pb.n, pb.p
    Phi = np.zeros((N * n, N * K))
    for t in range(N):
        for i in range(n):
            Phi[t * n + i, t * K + i * p : t * K + (i + 1) * p] = pb.phi[t, 0]
    return pb, weights, ipm.ConicProblem(pb, weights, norm), rng, Phi


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
@pytest.mark.parametrize("shared", [False, True])
def test_reweighted_fit_solves_the_reweighted_normal_equations(coeffs, shared, monkeypatch):
    """One reweighted step is the dense solution of (2ΦᵀΦ + EᵀRE) k = 2Φᵀy with
    E = D ⊗ Λ and R the cones' weights 1/‖(ΛDk_prev)_c‖ (floored), and its duals are
    −R(Ek); output rows with equal weights share a factorization."""
    pb, weights, cp, rng, Phi = _weighted_row_problem(coeffs, 12, 13, shared, "group")
    N, K = pb.N, pb.K
    k0 = rng.normal(size=(N, K))
    E = np.kron(difference_matrix(N, np.array(coeffs)), np.diag(weights))
    norms = np.linalg.norm((E @ k0.ravel()).reshape(cp.n_cones, K), axis=1)
    floor = 0.3  # large enough that some cones are floored
    rho = 1.0 / np.maximum(norms, floor * norms.max())
    H = 2.0 * Phi.T @ Phi + E.T @ (np.repeat(rho, K)[:, None] * E)
    expected = np.linalg.solve(H, 2.0 * Phi.T @ pb.y[:, 0].ravel())
    monkeypatch.setattr(ipm, "REWEIGHT_STEPS", 1)
    monkeypatch.setattr(ipm, "REWEIGHT_FLOOR", floor)
    monkeypatch.setattr(ipm, "WARM_MAX_DUAL_NORM", np.inf)
    k, z1 = ipm.reweighted_start(pb, cp, k0)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(k.ravel(), expected, rtol=1e-8, atol=1e-10 * scale)
    dual = -rho[:, None] * (E @ expected).reshape(cp.n_cones, K)
    np.testing.assert_allclose(z1, dual, rtol=1e-7, atol=1e-9 * np.abs(dual).max())


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("shared", [False, True])
def test_quadratic_fit_solves_the_dense_normal_equations(coeffs, norm, shared):
    """The start's quadratic fit (group: the row systems of RowFits; l1: the Newton
    kernels) is the dense solution of (2ΦᵀΦ + ρEᵀE) k = 2Φᵀy with E = D ⊗ Λ."""
    pb, weights, cp, _, Phi = _weighted_row_problem(coeffs, 14, 15, shared, norm)
    N, K = pb.N, pb.K
    rho = 0.37
    E = np.kron(difference_matrix(N, np.array(coeffs)), np.diag(weights))
    H = 2.0 * Phi.T @ Phi + rho * E.T @ E
    expected = np.linalg.solve(H, 2.0 * Phi.T @ pb.y[:, 0].ravel())
    k = cp.quadratic_fit(rho)
    assert k.shape == (N, K)
    np.testing.assert_allclose(k.ravel(), expected, rtol=1e-8, atol=1e-10 * np.abs(expected).max())


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
def test_reweighted_start_reaches_the_same_optimum_in_fewer_iterations(coeffs, monkeypatch):
    """The reweighted start's duals are stationary (2Φᵀ(Φk − y) = DᵀΛz₁) and, pulled
    into the cones, the group fit from it reaches the feasible start's optimum."""
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=14)
    pb = state_space_problem(data.x, data.u, np.array(coeffs))
    gradient_scale = np.abs(2.0 * pb.phi[:, 0].T @ pb.y[:, 0]).max()
    with_start = without = 0
    for lam in (1.0, 10.0, 60.0):
        weights = np.full(pb.K, lam)
        cp = ipm.ConicProblem(pb, weights, "group")
        k_start = ipm.feasible_start(pb, cp)[0]
        monkeypatch.setattr(ipm, "WARM_MAX_DUAL_NORM", np.inf)  # duals as the fits give them
        k, z1 = ipm.reweighted_start(pb, cp, k_start)
        monkeypatch.undo()
        z = np.zeros(cp.cone_shape)
        z[:, 1:] = z1
        s, r_z, r_k = np.zeros(cp.cone_shape), np.empty(cp.cone_shape), np.empty_like(k)
        cones.kkt_residuals(k, np.zeros(cp.n_cones), s, z, cp.y, cp.phi, cp.coeffs, cp.w, r_z, r_k)
        assert np.abs(r_k).max() < 1e-8 * gradient_scale
        _, z1 = ipm.reweighted_start(pb, cp, k_start)
        assert np.linalg.norm(z1, axis=1).max() <= ipm.WARM_MAX_DUAL_NORM + 1e-12
        iterations = _iterations_with_and_without(monkeypatch, pb, weights, "REWEIGHT_STEPS", 0)
        with_start += iterations[0]
        without += iterations[1]
    assert with_start < without


def _iterations_with_and_without(monkeypatch, pb, weights, setting, off):
    """The iterations of a group fit (tol 1e-8) as it is and with ``ipm.<setting>`` set to
    ``off``: both converged to the same objective."""
    start = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8)
    monkeypatch.setattr(ipm, setting, off)
    plain = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8)
    monkeypatch.undo()
    assert start.converged and plain.converged
    assert start.objective == pytest.approx(plain.objective, rel=1e-7)
    return start.iterations, plain.iterations


def _wide_jump(T: int, seed: int, n: int = 4, m: int = 1):
    """x (T, n), u (T, m) of a system whose A switches at T/2 (K = n(n + m) = 20 at
    the defaults: the wide kernels' blocks for orders 1 and 2)."""
    rng = np.random.default_rng(seed)
    A = [rng.standard_normal((n, n)) for _ in range(2)]
    A = [0.9 * a / np.abs(np.linalg.eigvals(a)).max() for a in A]
    B, u = rng.standard_normal((n, m)), rng.standard_normal((T, m))
    x = np.zeros((T, n))
    for t in range(T - 1):
        x[t + 1] = A[t >= T // 2] @ x[t] + B @ u[t] + 0.2 * rng.standard_normal(n)
    return x, u


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
def test_centred_start_puts_each_cone_on_its_central_path(coeffs):
    """From the reweighted start (k, z₁) of a wide fit each cone's slack is
    s = (s₀, ΛDk_c) with s₀ = max(‖s₁‖ + δ, ‖s₁‖/‖z₁‖), δ the start's gap per cone:
    where the second bound holds, s ∘ z = μ_c e (the vector part ‖s₁‖ − ‖z₁‖s₀
    vanishes). The starting gap sᵀz is recomputed here from the dense ΛD; a narrow
    fit keeps s₀ = ‖s₁‖ + δ."""
    x, u = _wide_jump(200, seed=3)
    order = len(coeffs) - 1
    pb = state_space_problem(x, u, np.array(coeffs))
    lam_max = ltv.lambda_max(x, u, norm="group", order=order)
    weights = np.full(pb.K, 0.1 * lam_max)
    cp = ipm.ConicProblem(pb, weights, "group")
    assert cp.systems[0].wide
    steps = ipm.WIDE_REWEIGHT_STEPS
    k, z1 = ipm.reweighted_start(pb, cp, ipm.feasible_start(pb, cp)[0], steps)
    with pytest.warns(ltv.ConvergenceWarning):  # the start only
        start = ipm.fit_sparse_ipm(pb, weights, "group", max_iter=0)
    np.testing.assert_array_equal(start.theta.reshape(pb.N, pb.K), k)
    E = np.kron(difference_matrix(pb.N, np.array(coeffs)), np.diag(weights))
    s1 = (E @ k.ravel()).reshape(cp.n_cones, pb.K)
    s_norms, z_norms = np.linalg.norm(s1, axis=1), np.linalg.norm(z1, axis=1)
    fitted = np.einsum("tip,tp->ti", k.reshape(pb.N, pb.n, pb.p), pb.phi[:, 0])
    loss = np.sum((pb.y[:, 0] - fitted) ** 2)
    delta = ipm.REWEIGHT_GAP_FRACTION * (loss + s_norms.sum()) / cp.n_cones
    s0 = np.maximum(s_norms + delta, s_norms / z_norms)
    centred = s0 > s_norms + delta
    assert centred.any() and not centred.all()  # both kinds of cones occur here
    # z₁ points against s₁: then the vector part of s ∘ z is (‖s₁‖ − ‖z₁‖s₀) s₁/‖s₁‖
    np.testing.assert_allclose(np.einsum("ca,ca->c", s1, z1), -s_norms * z_norms, rtol=1e-9)
    vector_part = s_norms[centred] - z_norms[centred] * s0[centred]
    np.testing.assert_allclose(vector_part, 0.0, atol=1e-9 * s0.max())
    gap = np.sum(s0 - s_norms * z_norms)
    assert start.duality_gap == pytest.approx(gap, rel=1e-9)


def test_centred_start_reaches_the_same_optimum_in_fewer_iterations(monkeypatch):
    """The centred reweighted start (CENTRED_START) of wide fits against the slack
    ‖s₁‖ + δ of every cone: the same optima, fewer iterations over three seeds and
    λ = 0.03-0.3 λ_max (order 1; order 2 takes about as many either way)."""
    centred = plain = 0
    coeffs, order = [-1.0, 1.0], 1
    for seed in (0, 1, 2):
        x, u = _wide_jump(300, seed)
        pb = state_space_problem(x, u, np.array(coeffs))
        lam_max = ltv.lambda_max(x, u, norm="group", order=order)
        for fraction in (0.03, 0.1, 0.3):
            weights = np.full(pb.K, fraction * lam_max)
            iterations = _iterations_with_and_without(
                monkeypatch, pb, weights, "CENTRED_START", False
            )
            centred += iterations[0]
            plain += iterations[1]
    assert centred < plain, (centred, plain)


def test_wide_fits_are_polished_early_to_an_optimum_at_least_as_good(monkeypatch):
    """EARLY_POLISH_GAP: wide group fits of order 1 try the active-set polish once the
    relative gap is below 1e-3 (and at most EARLY_POLISH_ACTIVE of the cones are
    active). Over three seeds and λ = 0.03-0.3 λ_max most fits here are polished,
    each certified to the tolerance by the full problem's certificate, with an
    objective no larger than the interior point's own; fewer iterations in all."""
    early_iterations = plain_iterations = polished = 0
    for seed in (0, 1, 2):
        x, u = _wide_jump(600, seed)
        pb = state_space_problem(x, u, np.array([-1.0, 1.0]))
        lam_max = ltv.lambda_max(x, u, norm="group", order=1)
        for fraction in (0.03, 0.1, 0.3):
            weights = np.full(pb.K, fraction * lam_max)
            early = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8)
            monkeypatch.setattr(ipm, "EARLY_POLISH_GAP", 0.0)
            plain = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8)
            monkeypatch.undo()
            assert early.converged and plain.converged
            assert early.objective == pytest.approx(plain.objective, rel=1e-7)
            if early.polished:
                polished += 1
                assert early.duality_gap <= 1e-8 * early.objective
                assert early.dual_residual <= 1e-8
                assert early.objective <= plain.objective * (1.0 + 1e-12)
            early_iterations += early.iterations
            plain_iterations += plain.iterations
    assert polished >= 6, polished
    assert early_iterations < plain_iterations, (early_iterations, plain_iterations)


def test_early_polish_is_bounded_by_the_active_cones(monkeypatch):
    """With more active cones than EARLY_POLISH_ACTIVE of them (many changes: here none
    may be active) the early polish gives up at once and the iterations go on to the
    interior point's own optimum."""
    x, u = _wide_jump(300, 1)
    pb = state_space_problem(x, u, np.array([-1.0, 1.0]))
    weights = np.full(pb.K, 0.03 * ltv.lambda_max(x, u, norm="group", order=1))
    monkeypatch.setattr(ipm, "EARLY_POLISH_ACTIVE", 0.0)
    bounded = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8)
    monkeypatch.setattr(ipm, "EARLY_POLISH_GAP", 0.0)
    plain = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8)
    assert bounded.converged and not bounded.polished
    assert bounded.iterations == plain.iterations
    np.testing.assert_array_equal(bounded.theta, plain.theta)


def test_polished_fits_carry_their_certificates_duals_into_a_path():
    """A polished fit's duals are its certificate's (z₁ = −u, inside the dual cones and
    stationary at the polished k), so that the next λ of a path starts warm
    (warm_dual) instead of cold: up a path of wide fits (as the L-curve runs), each
    reaches the cold optimum, in fewer iterations in all than when polished fits carry
    no duals (the former rule; 3 against 8 here)."""
    x, u = _wide_jump(600, seed=1)
    pb = state_space_problem(x, u, np.array([-1.0, 1.0]))
    lam_max = ltv.lambda_max(x, u, norm="group", order=1)
    previous = without = None
    warm_iterations = without_iterations = polished = 0
    for fraction in (0.05, 0.1, 0.2, 0.3):
        weights = np.full(pb.K, fraction * lam_max)
        cold = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8)
        warm = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8, warm_start=previous)
        plain = ipm.fit_sparse_ipm(pb, weights, "group", tol=1e-8, warm_start=without)
        assert cold.converged and warm.converged and plain.converged
        assert warm.objective == pytest.approx(cold.objective, rel=1e-7)
        if warm.polished:
            polished += 1
            z1 = warm.dual
            assert z1.shape == (pb.N - 1, pb.K)
            assert np.linalg.norm(z1, axis=1).max() <= 1.0 + 1e-12
            # stationarity 2Φᵀ(Φk − y) = DᵀΛz₁ at the polished k (dense D)
            fitted = np.einsum("tp,tip->ti", pb.phi[:, 0], warm.theta)
            gradient = 2.0 * np.einsum("ti,tp->tip", fitted - pb.y[:, 0], pb.phi[:, 0])
            D = difference_matrix(pb.N, np.array([-1.0, 1.0]))  # applied to each coefficient
            dual_side = D.T @ (z1 * weights)  # (N, K)
            scale = np.abs(gradient).max()
            np.testing.assert_allclose(gradient.reshape(pb.N, pb.K), dual_side, atol=1e-6 * scale)
        if previous is not None:
            warm_iterations += warm.iterations
            without_iterations += plain.iterations
        previous = warm
        without = dataclasses.replace(plain, dual=None) if plain.polished else plain
    assert polished >= 3, polished
    assert warm_iterations < without_iterations, (warm_iterations, without_iterations)


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order", [1, 2])
def test_newton_product_is_the_matrix_the_solver_factors(norm, order):
    """ConicProblem.newton_product (H x, for the robust interior point's refinement of
    its steps) against the factorization of the same scaling: solving H x0 gives x0.
    Fails on a wrong cone scaling, data term or difference."""
    rng = np.random.default_rng(order)
    coeffs = np.array([-1.0, 1.0]) if order == 1 else np.array([1.0, -2.0, 1.0])
    x = rng.standard_normal((40, 3))
    u = rng.standard_normal((40, 2))
    pb = state_space_problem(x, u, coeffs)
    cp = ipm.ConicProblem(pb, rng.uniform(0.5, 2.0, pb.K), norm)
    cp.phi = np.ascontiguousarray(cp.phi * rng.uniform(0.1, 3.0, cp.phi.shape[:2])[:, :, None])
    s, z = np.zeros(cp.cone_shape), np.zeros(cp.cone_shape)
    for v in (s, z):
        v[:, 1:] = rng.standard_normal((cp.n_cones, cp.cone_shape[1] - 1))
        v[:, 0] = np.linalg.norm(v[:, 1:], axis=1) + rng.uniform(0.1, 1.0, cp.n_cones)
    newton = ipm.NewtonSystem(cp, s, z, np.zeros_like(s), np.zeros((cp.N, cp.K)))
    x0 = rng.standard_normal((cp.N, cp.K))
    solved = cp.factor_and_solve(newton, cp.newton_product(newton, x0))
    np.testing.assert_allclose(solved, x0, rtol=0, atol=1e-9)
