"""iLQG / box-DDP with a trust region (ltvmodels.control) against independent references."""

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.control import CostExpansion, ILQGResult, LinearDynamics, QuadraticCost, ilqg


def random_system(seed, N=40, n=4, m=2):
    rng = np.random.default_rng(seed)
    A = np.eye(n) + 0.15 * rng.standard_normal((N, n, n))
    B = rng.standard_normal((N, n, m))
    Q = np.diag(rng.uniform(0.5, 2.0, n))
    R = np.diag(rng.uniform(0.5, 2.0, m))
    Qf = 3.0 * Q
    x0 = 2.0 * rng.standard_normal(n)
    return A, B, Q, R, Qf, x0


def riccati(A, B, Q, R, Qf):
    """Finite-horizon LQR for J = Σ xᵀQx + uᵀRu + x_Nᵀ Qf x_N: gains u_t = K_t x_t and P_0."""
    N = A.shape[0]
    P = Qf.copy()
    K = np.zeros((N, B.shape[2], A.shape[1]))
    for t in range(N - 1, -1, -1):
        At, Bt = A[t], B[t]
        K[t] = -np.linalg.solve(R + Bt.T @ P @ Bt, Bt.T @ P @ At)
        P = Q + At.T @ P @ (At + Bt @ K[t])
        P = 0.5 * (P + P.T)
    return K, P


def closed_loop(A, B, K, x0):
    N = A.shape[0]
    x = np.zeros((N + 1, A.shape[1]))
    u = np.zeros((N, B.shape[2]))
    x[0] = x0
    for t in range(N):
        u[t] = K[t] @ x[t]
        x[t + 1] = A[t] @ x[t] + B[t] @ u[t]
    return x, u


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_unbounded_linear_quadratic_is_riccati_lqr(seed):
    A, B, Q, R, Qf, x0 = random_system(seed)
    N = A.shape[0]
    res = ilqg(LinearDynamics(A, B), QuadraticCost(Q, R, N, Qf=Qf), x0, np.zeros((N, 2)))
    K, P0 = riccati(A, B, Q, R, Qf)
    x, u = closed_loop(A, B, K, x0)
    scale = np.max(np.abs(K))
    assert np.max(np.abs(res.K - K)) <= 1e-8 * scale
    assert np.max(np.abs(res.u - u)) <= 1e-8 * max(1.0, np.max(np.abs(u)))
    assert np.max(np.abs(res.x - x)) <= 1e-8 * max(1.0, np.max(np.abs(x)))
    assert res.cost == pytest.approx(x0 @ P0 @ x0, rel=1e-10)
    assert res.converged and res.eta == 0.0
    # One Newton step reaches the optimum: the trace is [initial, optimum].
    assert len(res.cost_trace) == 2


def test_ltvmodel_input_matches_riccati_on_its_coefficients():
    rng = np.random.default_rng(3)
    T, n, m = 60, 2, 1
    x = np.zeros((T, n))
    u = rng.standard_normal((T, m))
    for t in range(T - 1):
        x[t + 1] = np.array([[0.9, 0.2], [0.0, 0.8]]) @ x[t] + np.array([0.0, 1.0]) * u[t, 0]
        x[t + 1] += 0.01 * rng.standard_normal(n)
    model = ltv.fit(x, u, lam=10.0, norm="sq", order=1)
    Q, R = np.eye(n), np.eye(m)
    x0 = np.array([1.0, -1.0])
    res = ilqg(model, QuadraticCost(Q, R, model.N), x0, np.zeros((model.N, m)))
    K, _ = riccati(model.A, model.B, Q, R, Q)
    assert np.max(np.abs(res.K - K)) <= 1e-8 * np.max(np.abs(K))
    np.testing.assert_allclose(res.x, model.simulate(x0, np.vstack([res.u, [[0.0]]])), atol=1e-10)


def test_tracking_cost_and_offsets_match_lifted_riccati():
    """x_goal ≠ 0 and offsets c_t: Riccati on the system lifted with a constant state."""
    A, B, Q, R, Qf, x0 = random_system(4, N=30, n=3, m=1)
    N, n, m = A.shape[0], 3, 1
    rng = np.random.default_rng(5)
    c = 0.3 * rng.standard_normal((N, n))
    g = rng.standard_normal(n)
    res = ilqg(
        LinearDynamics(A, B, c), QuadraticCost(Q, R, N, Qf=Qf, x_goal=g), x0, np.zeros((N, m))
    )
    # Lifted state z = [x; 1]: z' = [[A, c], [0, 1]] z + [B; 0] u, cost (Ez)ᵀQ(Ez), E = [I, −g].
    Az = np.zeros((N, n + 1, n + 1))
    Az[:, :n, :n], Az[:, :n, n], Az[:, n, n] = A, c, 1.0
    Bz = np.concatenate([B, np.zeros((N, 1, m))], axis=1)
    E = np.hstack([np.eye(n), -g[:, None]])
    Kz, _ = riccati(Az, Bz, E.T @ Q @ E, R, E.T @ Qf @ E)
    z, u = closed_loop(Az, Bz, Kz, np.append(x0, 1.0))
    np.testing.assert_allclose(res.u, u, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(res.x, z[:, :n], rtol=1e-8, atol=1e-10)


def dense_box_qp(A, B, c, Q, R, Qf, x0, lo, hi):
    """The same problem as one dense QP in u, solved by cvxpy (independent reference)."""
    cp = pytest.importorskip("cvxpy")
    N, n, m = B.shape
    # x = Fx x0 + Gu u + h, stacked over t = 0..N.
    Fx = np.zeros(((N + 1) * n, n))
    Gu = np.zeros(((N + 1) * n, N * m))
    h = np.zeros((N + 1) * n)
    Phi, hc = np.eye(n), np.zeros(n)
    Fx[:n] = Phi
    for t in range(N):
        rows = slice((t + 1) * n, (t + 2) * n)
        Fx[rows] = A[t] @ Fx[t * n : (t + 1) * n]
        Gu[rows] = A[t] @ Gu[t * n : (t + 1) * n]
        Gu[rows, t * m : (t + 1) * m] = B[t]
        hc = A[t] @ h[t * n : (t + 1) * n] + c[t]
        h[rows] = hc
    Qbig = np.kron(np.eye(N + 1), Q)
    Qbig[-n:, -n:] = Qf
    Rbig = np.kron(np.eye(N), R)
    H = Gu.T @ Qbig @ Gu + Rbig
    f = Gu.T @ Qbig @ (Fx @ x0 + h)
    const = (Fx @ x0 + h) @ Qbig @ (Fx @ x0 + h)
    uvar = cp.Variable(N * m)
    prob = cp.Problem(
        cp.Minimize(cp.quad_form(uvar, cp.psd_wrap(H)) + 2 * f @ uvar),
        [uvar >= lo.ravel(), uvar <= hi.ravel()],
    )
    prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    return uvar.value.reshape(N, m), prob.value + const


def test_box_bounds_respected_and_match_a_qp_solver():
    A, B, Q, R, Qf, x0 = random_system(6, N=25, n=3, m=2)
    N = A.shape[0]
    x0 = 5.0 * x0
    lo, hi = np.array([-0.5, -0.2]), np.array([0.5, 0.3])
    res = ilqg(
        LinearDynamics(A, B), QuadraticCost(Q, R, N, Qf=Qf), x0, np.zeros((N, 2)), u_bounds=(lo, hi)
    )
    assert np.all(res.u >= lo) and np.all(res.u <= hi)
    active = np.isclose(res.u, lo) | np.isclose(res.u, hi)
    assert active.any()
    # Clamped controls get zero feedback gain.
    assert np.all(res.K[active] == 0.0)
    u_ref, J_ref = dense_box_qp(
        A, B, np.zeros((N, 3)), Q, R, Qf, x0, np.tile(lo, (N, 1)), np.tile(hi, (N, 1))
    )
    np.testing.assert_allclose(res.u, u_ref, atol=1e-5)
    assert res.cost == pytest.approx(J_ref, rel=1e-7)
    # The feedback law never leaves the box either.
    for t in (0, N // 2, N - 1):
        ut = res.control(t, res.x[t] + 10.0)
        assert np.all(ut >= lo) and np.all(ut <= hi)


@pytest.mark.parametrize("radius", [0.5, 2.0])
def test_trust_region_respected_and_active(radius):
    A, B, Q, R, Qf, x0 = random_system(7, N=30, n=3, m=1)
    N = A.shape[0]
    rng = np.random.default_rng(8)
    u_ref = rng.uniform(-0.8, 0.8, (N, 1))  # a feasible reference
    dyn = LinearDynamics(A, B)
    x_ref = dyn.simulate(x0, u_ref)
    weights = (np.array([1.0, 2.0, 0.5]), np.array([4.0]))
    free = ilqg(dyn, QuadraticCost(Q, R, N, Qf=Qf), x0, u_ref)
    res = ilqg(
        dyn,
        QuadraticCost(Q, R, N, Qf=Qf),
        x0,
        u_ref,
        trust_region=radius,
        reference=(x_ref, u_ref),
        trust_weights=weights,
        u_bounds=(-1.0, 1.0),
    )
    d2 = np.sum((res.x - x_ref) ** 2 * weights[0], axis=1)
    d2[:-1] += np.sum((res.u - u_ref) ** 2 * weights[1], axis=1)
    assert np.sqrt(d2.max()) <= radius * (1 + 1e-12)
    assert res.deviation == pytest.approx(np.sqrt(d2.max()))
    assert res.deviation >= 0.9 * radius  # the bound is active, not over-tightened
    assert res.eta > 0
    assert free.cost < res.cost < QuadraticCost(Q, R, N, Qf=Qf).stage_costs(x_ref, u_ref).sum()
    assert np.all(np.abs(res.u) <= 1.0)


def test_unreachable_trust_region_warns():
    A, B, Q, R, Qf, x0 = random_system(7, N=30, n=3, m=1)
    N = A.shape[0]
    u_ref = np.full((N, 1), 3.0)  # outside the bounds: the reference cannot be reached
    x_ref = LinearDynamics(A, B).simulate(x0, u_ref)
    with pytest.warns(ltv.ConvergenceWarning, match="trust region of radius 0.1 could not"):
        res = ilqg(
            LinearDynamics(A, B),
            QuadraticCost(Q, R, N, Qf=Qf),
            x0,
            u_ref,
            trust_region=0.1,
            reference=(x_ref, u_ref),
            u_bounds=(-1.0, 1.0),
        )
    assert np.all(np.abs(res.u) <= 1.0)


def test_trust_region_inactive_when_optimum_inside():
    A, B, Q, R, Qf, x0 = random_system(9, N=20, n=2, m=1)
    N = A.shape[0]
    free = ilqg(LinearDynamics(A, B), QuadraticCost(Q, R, N, Qf=Qf), x0, np.zeros((N, 1)))
    res = ilqg(
        LinearDynamics(A, B),
        QuadraticCost(Q, R, N, Qf=Qf),
        x0,
        np.zeros((N, 1)),
        trust_region=10 * free.deviation,
    )
    assert res.eta == 0.0
    np.testing.assert_allclose(res.u, free.u)


def pendulum(h=0.05):
    def f(x, u, t):
        return np.array([x[0] + h * x[1], x[1] + h * (-9.81 * np.sin(x[0]) + u[0])])

    def jac(x, u, t):
        return (np.array([[1.0, h], [-h * 9.81 * np.cos(x[0]), 1.0]]), np.array([[0.0], [h]]))

    return f, jac


def test_nonlinear_cost_decreases_monotonically_and_bounds_hold():
    """Swing-up of a torque-limited pendulum: the line search only accepts decreases."""
    f, jac = pendulum()
    N = 80
    cost = QuadraticCost(
        np.diag([1.0, 0.1]), [[0.01]], N, Qf=np.diag([100.0, 10.0]), x_goal=[np.pi, 0.0]
    )
    res = ilqg(f, cost, [0.0, 0.0], np.full((N, 1), 0.1), jacobian=jac, u_bounds=(-4.0, 4.0))
    assert res.iterations > 3
    assert np.all(np.diff(res.cost_trace) < 0)
    assert np.all(np.abs(res.u) <= 4.0)
    assert np.any(np.isclose(np.abs(res.u), 4.0))  # the bound matters
    assert abs(res.x[-1, 0] - np.pi) < 0.1  # swung up
    # The reported trajectory is a rollout of the true dynamics.
    x = np.zeros((N + 1, 2))
    for t in range(N):
        x[t + 1] = f(x[t], res.u[t], t)
    np.testing.assert_allclose(res.x, x, atol=1e-12)


class QuarticCost:
    """A non-quadratic cost: Σ (x_tᵀx_t + ρ (x_t[0])⁴ + u_tᵀu_t) + terminal x_Nᵀx_N."""

    def __init__(self, N, n, m, rho):
        self.N, self.n, self.m, self.rho = N, n, m, rho

    def stage_costs(self, x, u):
        c = np.sum(x * x, axis=1) + self.rho * x[:, 0] ** 4
        c[:-1] += np.sum(u * u, axis=1)
        return c

    def quadratize(self, x, u):
        N, n, m = self.N, self.n, self.m
        lx = 2 * x.copy()
        lx[:, 0] += 4 * self.rho * x[:, 0] ** 3
        lxx = np.tile(2 * np.eye(n), (N + 1, 1, 1))
        lxx[:, 0, 0] += 12 * self.rho * x[:, 0] ** 2
        return CostExpansion(
            lx=lx, lu=2 * u, lxx=lxx, luu=np.tile(2 * np.eye(m), (N, 1, 1)), lux=np.zeros((N, m, n))
        )


def test_general_cost_protocol_reaches_a_stationary_point():
    A, B, _, _, _, x0 = random_system(10, N=30, n=3, m=1)
    N = A.shape[0]
    quad = ilqg(LinearDynamics(A, B), QuadraticCost(np.eye(3), np.eye(1), N), x0, np.zeros((N, 1)))
    same = ilqg(LinearDynamics(A, B), QuarticCost(N, 3, 1, 0.0), x0, np.zeros((N, 1)))
    np.testing.assert_allclose(same.u, quad.u, atol=1e-10)
    res = ilqg(LinearDynamics(A, B), QuarticCost(N, 3, 1, 5.0), x0, np.zeros((N, 1)), tol=1e-12)
    assert res.converged
    # Stationarity: the gradient of J(u) by finite differences vanishes.
    cost = QuarticCost(N, 3, 1, 5.0)
    dyn = LinearDynamics(A, B)

    def J(u):
        return cost.stage_costs(dyn.simulate(x0, u), u).sum()

    eps = 1e-6
    grad = [
        (J(res.u + eps * e) - J(res.u - eps * e)) / (2 * eps)
        for e in np.eye(N)[:, :, None][[0, N // 2, N - 1]]
    ]
    assert np.max(np.abs(grad)) < 1e-5 * max(1.0, res.cost)


def test_linear_dynamics_through_reproduces_the_trajectory():
    rng = np.random.default_rng(11)
    N, n, m = 15, 3, 2
    x = rng.standard_normal((N + 1, n))
    u = rng.standard_normal((N + 1, m))  # data convention: a last row is ignored
    A, B = rng.standard_normal((N, n, n)), rng.standard_normal((N, n, m))
    x_copy, u_copy = x.copy(), u.copy()
    dyn = LinearDynamics.through(A, B, x, u)
    np.testing.assert_allclose(dyn.simulate(x[0], u[:N]), x, atol=1e-12)
    np.testing.assert_array_equal(x, x_copy)
    np.testing.assert_array_equal(u, u_copy)


def test_inputs_not_mutated_and_result_fields():
    A, B, Q, R, Qf, x0 = random_system(12, N=10, n=2, m=1)
    u0 = np.ones((10, 1))
    copies = [a.copy() for a in (A, B, Q, R, x0, u0)]
    res = ilqg(
        LinearDynamics(A, B),
        QuadraticCost(Q, R, 10),
        x0,
        u0,
        u_bounds=(-0.5, 0.5),
        trust_region=1.0,
    )
    for a, b in zip((A, B, Q, R, x0, u0), copies, strict=True):
        np.testing.assert_array_equal(a, b)
    assert isinstance(res, ILQGResult)
    assert res.x.shape == (11, 2) and res.u.shape == (10, 1) and res.K.shape == (10, 1, 2)
    assert "ILQGResult(N=10" in repr(res)


@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        ({"x0": [[1.0, 2.0]]}, ValueError, "x0: expected a 1-d state vector"),
        ({"x0": [1.0, 2.0, 3.0]}, ValueError, "x0: expected length 2"),
        ({"u_init": np.zeros((9, 1))}, ValueError, r"u_init: expected shape \(10, 1\)"),
        ({"u_init": np.full((10, 1), np.nan)}, ValueError, "u_init: expected finite values"),
        ({"u_bounds": (1.0, -1.0)}, ValueError, "u_bounds: expected lower <= upper"),
        ({"u_bounds": 1.0}, TypeError, "u_bounds: expected a pair"),
        ({"u_bounds": ([0, 0], 1.0)}, ValueError, "u_bounds lower: expected a scalar or shape"),
        ({"trust_region": -1.0}, ValueError, "trust_region: expected a finite real number > 0"),
        (
            {"trust_region": 1.0, "trust_weights": ([1, 1], [-1])},
            ValueError,
            "trust_weights.1.: expected nonnegative",
        ),
        ({"reference": np.zeros(3)}, TypeError, "reference: expected a pair"),
        (
            {"reference": (np.zeros((10, 2)), np.zeros((10, 1)))},
            ValueError,
            r"reference\[0\]: expected shape \(11, 2\)",
        ),
        ({"max_iter": 0}, ValueError, "max_iter: expected an integer >= 1"),
        ({"tol": 0.0}, ValueError, "tol: expected a real number > 0"),
        ({"cost": "quadratic"}, TypeError, "cost: expected a QuadraticCost"),
        ({"dynamics": 3.0}, TypeError, "dynamics: expected an LTVModel"),
        ({"dynamics": lambda x, u, t: x}, TypeError, "jacobian: expected a function"),
    ],
)
def test_invalid_input_names_the_argument(kwargs, exc, match):
    A, B, Q, R, _, _ = random_system(13, N=10, n=2, m=1)
    args = {
        "dynamics": LinearDynamics(A, B),
        "cost": QuadraticCost(Q, R, 10),
        "x0": np.zeros(2),
        "u_init": np.zeros((10, 1)),
    }
    extra = {k: v for k, v in kwargs.items() if k not in args}
    args.update({k: v for k, v in kwargs.items() if k in args})
    with pytest.raises(exc, match=match):
        ilqg(args["dynamics"], args["cost"], args["x0"], args["u_init"], **extra)


def test_cost_and_dynamics_validation():
    with pytest.raises(ValueError, match="Q: expected a symmetric matrix"):
        QuadraticCost([[1.0, 1.0], [0.0, 1.0]], [[1.0]], 5)
    with pytest.raises(ValueError, match="R: expected a positive semidefinite"):
        QuadraticCost(np.eye(2), [[-1.0]], 5)
    with pytest.raises(ValueError, match=r"x_goal: expected shape \(2,\) or \(6, 2\)"):
        QuadraticCost(np.eye(2), [[1.0]], 5, x_goal=np.zeros(3))
    with pytest.raises(ValueError, match="horizon: expected an integer >= 1"):
        QuadraticCost(np.eye(2), [[1.0]], 0)
    with pytest.raises(ValueError, match=r"B: expected shape \(4, 2, m\)"):
        LinearDynamics(np.zeros((4, 2, 2)), np.zeros((3, 2, 1)))
    A, B, Q, R, _, _ = random_system(14, N=10, n=2, m=1)
    with pytest.raises(ValueError, match="cost: expected horizon N=10"):
        ilqg(LinearDynamics(A, B), QuadraticCost(Q, R, 9), np.zeros(2), np.zeros((10, 1)))
    f, jac = pendulum()
    with pytest.raises(ValueError, match="jacobian: expected"):
        ilqg(
            f,
            QuadraticCost(np.eye(2), [[1.0]], 5),
            np.zeros(2),
            np.zeros((5, 1)),
            jacobian=lambda x, u, t: (np.eye(3), np.zeros((3, 1))),
        )
