"""Active-set polish of sparse-change fits: exact zeros, a certificate, stalled solves."""

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core import conekernels as cones
from ltvmodels.core import ipm, polish
from ltvmodels.core.penalties import named
from ltvmodels.core.problem import RegressionProblem, apply_difference, state_space_problem
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

    def recording(k, dk, t, dt, s, ds, z, dz, step, dual_step):
        take_step(k, dk, t, dt, s, ds, z, dz, step, dual_step)
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
@pytest.mark.parametrize("order", [1, 2])
def test_dense_and_sparse_reduced_solves_agree(monkeypatch, norm, order):
    """Reduced problems up to DENSE_SIZE unknowns are solved with dense matrices, larger
    ones with sparse LU: both reach the same certified optimum."""
    pb, weights = problem_and_weights(3, order, 4.0)
    _, (k, s, z) = last_iterate(monkeypatch, pb, weights, norm, tol=1e-8)
    dense_solves = []
    solve = np.linalg.solve

    def counted(a, b):
        dense_solves.append(a.shape[0])
        return solve(a, b)

    monkeypatch.setattr(polish.np.linalg, "solve", counted)
    dense = polish.polish(pb, weights, norm, k, s, z, tol=1e-9)
    assert dense_solves and max(dense_solves) <= polish.DENSE_SIZE
    monkeypatch.setattr(polish, "DENSE_SIZE", 0)
    del dense_solves[:]
    sparse = polish.polish(pb, weights, norm, k, s, z, tol=1e-9)
    assert not dense_solves
    assert dense is not None and sparse is not None
    np.testing.assert_allclose(dense.k, sparse.k, rtol=0, atol=1e-9 * np.abs(sparse.k).max())
    assert dense.objective == pytest.approx(sparse.objective, rel=1e-12)


def test_l1_polish_with_several_rows_outputs_and_weights(monkeypatch):
    """The l1 polish of order 1 works on each coefficient's own segments, coupled where
    an output's coefficients overlap in time: with q = 3 rows per step (one missing),
    n = 2 outputs and a different λ per coefficient it reaches the optimum of a cold
    fit solved to 1e-10, with most differences exactly zero."""
    rng = np.random.default_rng(7)
    N, q, n, p = 200, 3, 2, 2
    phi = rng.standard_normal((N, q, p))
    jumps = rng.standard_normal((N, n, p)) * (rng.random((N, n, p)) < 0.02)
    theta = np.cumsum(jumps, axis=0)
    y = np.einsum("tja,tia->tji", phi, theta) + 0.1 * rng.standard_normal((N, q, n))
    observed = np.ones((N, q), dtype=bool)
    observed[17, 1] = False
    phi[~observed], y[~observed] = 0.0, 0.0
    pb = RegressionProblem(y=y, phi=phi, coeffs=COEFFS[1], observed=observed)
    lam_max = lambda_max(pb, named("l1"), np.ones(pb.K), null_space_fit(pb))
    weights = 0.05 * lam_max * (0.5 + rng.random(pb.K))
    _, (k, s, z) = last_iterate(monkeypatch, pb, weights, "l1", tol=1e-8)
    polished = polish.polish(pb, weights, "l1", k, s, z, tol=1e-9)
    reference = ipm.fit_sparse_ipm(pb, weights, "l1", tol=1e-10)
    assert polished is not None
    assert polished.duality_gap <= 1e-9 * polished.objective
    assert polished.objective <= reference.objective * (1 + 1e-10)
    assert polished.objective == pytest.approx(reference.objective, rel=1e-9)
    scale = np.abs(polished.k).max()
    np.testing.assert_allclose(polished.k, reference.theta.reshape(N, pb.K), atol=1e-5 * scale)
    norms = cone_norms(polished.k, pb, weights, "l1")
    assert 0 < np.count_nonzero(norms) < 0.1 * norms.size


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_certificate_agrees_with_lambda_max(norm):
    # The LTI (null-space) fit is optimal exactly when λ >= λ_max.
    pb, _ = problem_and_weights(5, 1, 1.0)
    k = null_space_fit(pb).reshape(pb.N, pb.K)
    lam_max = lambda_max(pb, named(norm), np.ones(pb.K), null_space_fit(pb))
    _, gap, residual, u_norm, _ = polish.certificate(
        pb, np.full(pb.K, 1.01 * lam_max), k, named(norm)
    )
    assert gap == pytest.approx(0.0, abs=1e-9) and residual < 1e-12 and u_norm.max() <= 1.0
    _, _, residual, u_norm, _ = polish.certificate(pb, np.full(pb.K, 0.5 * lam_max), k, named(norm))
    assert u_norm.max() > 1.5 and residual > 1e-3


def test_vertex_cones_from_a_central_iterate():
    s = np.array([[1e-6, 5e-7, 0.0], [2.0, 1.9999, 0.0]])  # near vertex / on the boundary
    z = np.array([[1.0, 0.3, 0.0], [1.0, 0.99999, 0.0]])  # inside / on the boundary
    np.testing.assert_array_equal(polish.vertex_cones(s, z), [True, False])


def clarabel_objective(pb, lam, norm):
    """The optimum of the same problem by cvxpy + Clarabel (an independent solver)."""
    cp = pytest.importorskip("cvxpy")
    theta = cp.Variable((pb.N, pb.K))
    fitted = [
        cp.sum(cp.multiply(theta[:, i * pb.p : (i + 1) * pb.p], pb.phi[:, 0]), axis=1)
        for i in range(pb.n)
    ]
    loss = sum(cp.sum_squares(pb.y[:, 0, i] - fitted[i]) for i in range(pb.n))
    second = theta[:-2] - 2 * theta[1:-1] + theta[2:]
    reg = cp.sum(cp.norm(second, 2, axis=1)) if norm == "group" else cp.sum(cp.abs(second))
    reference = cp.Problem(cp.Minimize(loss + lam * reg))
    reference.solve(solver=cp.CLARABEL)
    return reference.value


def certified_order2_fit(seed, fraction, norm, tol):
    """An order-2 fit near λ_max (T = 2000) that must end certified, without a warning."""
    d = ltv.systems.jump_linear(T=2000, change_at=1000, seed=seed)
    lam = fraction * ltv.lambda_max(d.x, d.u, norm=norm, order=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ltv.ConvergenceWarning)
        model = ltv.fit(d.x, d.u, lam=lam, norm=norm, order=2, tol=tol, compute_cov=False)
    # The certificate of whichever route ended the fit (the interior point by itself
    # or its polish: which one can change with the rounding of a Newton system).
    assert model.info["converged"]
    assert model.info["duality_gap"] <= tol * model.info["objective"]
    assert model.info["dual_residual"] <= tol
    return model, state_space_problem(d.x, d.u, COEFFS[2]), lam


def test_stalled_order2_fit_is_certified():
    # Order 2 near λ_max: the Newton systems lose definiteness at a relative
    # gap of about 1e-6, long before a tolerance of 1e-9 is met; the fit must
    # still end certified and at the optimum of an independent solver.
    model, pb, lam = certified_order2_fit(1, 0.5, "group", 1e-9)
    reference = clarabel_objective(pb, lam, "group")
    assert model.info["objective"] <= reference * (1 + 1e-7)
    assert model.info["objective"] == pytest.approx(reference, rel=1e-6)


def test_order2_l1_fit_with_an_undetermined_reduced_problem_is_certified():
    # T = 2000, seed 3, 0.5 λ_max, l1: the interior point stalls at a relative gap
    # of 1.5e-5 (its Newton matrix loses definiteness), and its iterate marks
    # active the rows 873–876 of two coefficients of one output row. Spikes of both
    # at one time step fit one equation: the polish's reduced Hessian is singular
    # (its steps were 1e25 and no split passed the certificate). It must certify.
    model, pb, lam = certified_order2_fit(3, 0.5, "l1", 1e-6)
    reference = clarabel_objective(pb, lam, "l1")
    assert model.info["objective"] <= reference * (1 + 1e-7)
    assert model.info["objective"] == pytest.approx(reference, rel=1e-6)


def test_polish_certifies_from_the_iterate_with_a_singular_reduced_hessian(monkeypatch):
    # The same fit's last interior-point iterate, polished directly: the active-set
    # loop collapses the cones that the steps along the undetermined directions
    # reach first, one at a time, until the split passes the certificate.
    d = ltv.systems.jump_linear(T=2000, change_at=1000, seed=3)
    lam = 0.5 * ltv.lambda_max(d.x, d.u, norm="l1", order=2)
    pb = state_space_problem(d.x, d.u, COEFFS[2])
    weights = np.full(pb.K, lam)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ltv.ConvergenceWarning)
        result, (k, s, z) = last_iterate(monkeypatch, pb, weights, "l1", tol=1e-6)
    polished = polish.polish(pb, weights, "l1", k, s, z, tol=1e-6)
    assert polished is not None
    assert polished.duality_gap <= 1e-6 * polished.objective
    assert polished.dual_residual <= 1e-6
    # At least as good as the interior-point iterate (its gap bounds its distance).
    assert polished.objective <= result.objective + result.duality_gap
    # A handful of changes; the other differences vanish to the rounding of λ·Dk.
    norms = cone_norms(polished.k, pb, weights, "l1")
    assert np.mean(norms <= 1e-9 * norms.max()) > 0.99


def test_polish_gives_up_within_its_bounds(monkeypatch):
    """max_splits and max_active bound the work: none allowed, no result."""
    pb, weights = problem_and_weights(3, 1, 4.0)
    _, (k, s, z) = last_iterate(monkeypatch, pb, weights, "group", tol=1e-8)
    assert polish.polish(pb, weights, "group", k, s, z, tol=1e-9) is not None
    assert polish.polish(pb, weights, "group", k, s, z, tol=1e-9, max_splits=0) is None
    assert polish.polish(pb, weights, "group", k, s, z, tol=1e-9, max_active=0) is None


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order", [1, 2])
def test_certificate_against_a_dense_reference(order, norm):
    """certificate (one compiled pass) against the same terms from dense matrices: the
    dual u solves DᵀΛu = −∇f on the rows t < R (D's first R columns), scaled into the
    dual cones; a coefficient of weight 0 has u = 0 and no cone term."""
    pb, weights = problem_and_weights(5, order, 3.0, T=60)
    weights[1] = 0.0
    k = np.random.default_rng(order).standard_normal((pb.N, pb.K))
    objective, gap, residual, u_norm, u = polish.certificate(pb, weights, k, named(norm))
    theta = k.reshape(pb.N, pb.n, pb.p)
    resid = pb.residuals(theta)
    grad = -2.0 * np.einsum("tji,tja->tia", resid, pb.phi).reshape(pb.N, pb.K)
    R = pb.N - order
    D = np.zeros((R, pb.N))
    for lag, c in enumerate(COEFFS[order]):
        D[np.arange(R), np.arange(R) + lag] = c
    lam_u = np.linalg.solve(D[:, :R].T, -grad[:R])
    u_dense = np.divide(lam_u, weights, out=np.zeros_like(lam_u), where=weights > 0)
    e = (D @ k) * weights
    if norm == "group":
        u_norms, e_norms = np.linalg.norm(u_dense, axis=1), np.linalg.norm(e, axis=1)
    else:
        u_norms, e_norms = np.abs(u_dense).ravel(), np.abs(e).ravel()
    np.testing.assert_allclose(u_norm, u_norms, rtol=1e-9)
    scaled = u_dense / max(1.0, u_norms.max())
    np.testing.assert_allclose(u, scaled, rtol=1e-9, atol=1e-12 * np.abs(scaled).max())
    assert objective == pytest.approx(np.sum(resid**2) + e_norms.sum(), rel=1e-12)
    assert gap == pytest.approx(max(e_norms.sum() - np.sum(scaled * e), 0.0), rel=1e-9)
    stationarity = D.T @ (scaled * weights) + grad
    assert residual == pytest.approx(
        np.linalg.norm(stationarity) / polish.stationarity_scale(pb), rel=1e-9
    )


def jump_problem(norm, T=400, seed=2):
    """The jump-linear problem of order 1 and its λ_max."""
    d = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
    pb = state_space_problem(d.x, d.u, COEFFS[1])
    return pb, lambda_max(pb, named(norm), np.ones(pb.K), null_space_fit(pb))


def changes(result, pb, norm):
    """The number of nonzero differences (cones off their vertex) of a result."""
    norms = cone_norms(result.theta.reshape(pb.N, pb.K), pb, np.ones(pb.K), norm)
    return np.count_nonzero(norms)


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_a_warm_start_is_polished_from_the_last_split(monkeypatch, norm):
    """Along a λ path the warm fit is the active-set polish of the previous solution's
    split, certified without an interior-point iteration, at the optimum of a cold
    fit solved to 1e-10: up the path cones reach their vertex; down it, from a polished
    solution's exact zeros, cones must leave it (opened along their duals). (Here with
    room for l1's dozen active entries.)"""
    monkeypatch.setattr(ipm, "WARM_POLISH_ACTIVE", {"group": 32, "l1": 32})
    # a small problem: polished too
    monkeypatch.setattr(ipm, "WARM_POLISH_MIN_WORK", {"group": 0, "l1": 0})
    pb, lam_max = jump_problem(norm)
    previous = ipm.fit_sparse_ipm(pb, np.full(pb.K, 0.15 * lam_max), norm, tol=1e-6)
    counts = []
    for fraction in (0.3, 0.1):
        weights = np.full(pb.K, fraction * lam_max)
        warm = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6, warm_start=previous)
        cold = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-10)
        assert warm.polished and warm.iterations == 0 and warm.converged
        assert warm.duality_gap <= 1e-6 * warm.objective
        assert warm.objective <= cold.objective * (1 + 1e-9)
        assert warm.objective == pytest.approx(cold.objective, rel=1e-8)
        # its duals are the certificate's (in the dual cones): the next warm start
        assert warm.dual.shape == previous.dual.shape
        assert np.abs(warm.dual).max() <= 1.0 + 1e-12
        counts.append(changes(warm, pb, norm))
        previous = warm
    # exact zeros: a handful of changes, more at the smaller λ
    assert 0 < counts[0] < counts[1] < 0.05 * pb.N


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_the_warm_polish_is_bounded(monkeypatch, norm):
    """Without the polish (WARM_POLISH_SPLITS = 0), for a norm not listed, from a split
    with more active cones than WARM_POLISH_ACTIVE, or on a problem below
    WARM_POLISH_MIN_WORK (N·K² = 14,400 here), the warm fit iterates to the same
    optimum."""
    pb, lam_max = jump_problem(norm)
    previous = ipm.fit_sparse_ipm(pb, np.full(pb.K, 0.1 * lam_max), norm, tol=1e-6)
    weights = np.full(pb.K, 0.2 * lam_max)
    monkeypatch.setattr(ipm, "WARM_POLISH_MIN_WORK", {norm: 0})
    polished = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6, warm_start=previous)
    assert polished.polished
    active = ipm.WARM_POLISH_ACTIVE[norm]
    limits = (
        (0, {norm: active}, 0),
        (10, {}, 0),
        (10, {norm: 0}, 0),
        (10, {norm: active}, pb.N * pb.K**2 + 1),
    )
    for splits, most_active, work in limits:
        monkeypatch.setattr(ipm, "WARM_POLISH_SPLITS", splits)
        monkeypatch.setattr(ipm, "WARM_POLISH_ACTIVE", most_active)
        monkeypatch.setattr(ipm, "WARM_POLISH_MIN_WORK", {norm: work})
        iterated = ipm.fit_sparse_ipm(pb, weights, norm, tol=1e-6, warm_start=previous)
        assert not iterated.polished and iterated.iterations > 0 and iterated.converged
        assert iterated.objective == pytest.approx(polished.objective, rel=1e-6)


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_a_polished_path_of_trajectories_with_gaps_and_weights(monkeypatch, norm):
    """fit_path with the warm polish taken at any size, on two trajectories with a
    missing sample and sample weights: each λ's fit has the objective of a fit of its
    own solved to 1e-9, and some of them are certified by the polish alone."""
    monkeypatch.setattr(ipm, "WARM_POLISH_MIN_WORK", {"group": 0, "l1": 0})
    rng = np.random.default_rng(11)
    runs = [ltv.systems.jump_linear(T=400, change_at=200, seed=seed) for seed in (4, 5)]
    x, u = np.stack([d.x for d in runs]), np.stack([d.u for d in runs])
    x[1, 123, 0] = np.nan
    weights = 0.5 + rng.random(399)
    lams = ltv.lambda_max(x, u, norm=norm) * np.array([0.5, 0.2, 0.05])
    path = ltv.fit_path(x, u, lams=lams, norm=norm, weights=weights, compute_cov=False)
    for model, lam in zip(path, lams, strict=True):
        alone = ltv.fit(x, u, lam=lam, norm=norm, weights=weights, tol=1e-9, compute_cov=False)
        assert model.status.objective == pytest.approx(alone.status.objective, rel=1e-6)
        assert model.status.objective >= alone.status.objective * (1 - 1e-9)
    # the warm fits polished without an iteration
    assert any(model.info["iterations"] == 0 for model in path[1:])
