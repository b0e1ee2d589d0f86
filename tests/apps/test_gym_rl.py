"""Model-based RL on gymnasium's Pendulum-v1 (ltvmodels.gym_rl)."""

import subprocess
import sys

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from ltvmodels.apps import gym_rl  # noqa: E402
from ltvmodels.apps.gym_rl import (  # noqa: E402
    PendulumCost,
    fit_rollouts,
    learn_pendulum,
    locality_weights,
    pendulum_rollout,
    pendulum_rollouts,
    plot_pendulum_experiment,
    run_pendulum_experiment,
    state_from_observations,
    swung_up,
)
from ltvmodels.control import LinearDynamics, QuadraticCost, ilqg  # noqa: E402


@pytest.fixture(scope="module")
def env():
    e = gym.make("Pendulum-v1")
    yield e
    e.close()


# -- the surrogate cost ---------------------------------------------------------------------
def _trajectory(N=12, seed=0):
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-7, 7, N + 1), rng.normal(0, 3, N + 1)])
    u = rng.uniform(-2, 2, (N, 1))
    return x, u


def test_cost_values_match_the_formula():
    x, u = _trajectory()
    cost = PendulumCost(
        angle_weight=5.0,
        velocity_weight=0.1,
        torque_weight=0.001,
        terminal_angle_weight=10.0,
        terminal_velocity_weight=0.5,
    )
    c = cost.stage_costs(x, u)
    th, w = x[:, 0], x[:, 1]
    assert c.shape == (x.shape[0],)
    np.testing.assert_allclose(
        c[:-1], 5 * (1 - np.cos(th[:-1])) + 0.1 * w[:-1] ** 2 + 0.001 * u[:, 0] ** 2
    )
    np.testing.assert_allclose(c[-1], 10 * (1 - np.cos(th[-1])) + 0.5 * w[-1] ** 2)
    # periodic in the angle, and zero only upright at rest
    shifted = x.copy()
    shifted[:, 0] += 2 * np.pi * 3
    np.testing.assert_allclose(cost.stage_costs(shifted, u), c, atol=1e-12)
    assert cost.total(np.zeros((4, 2)), np.zeros((3, 1))) == 0.0


@pytest.mark.parametrize("hessian", ["clipped", "gauss-newton"])
def test_cost_gradient_and_hessian_against_finite_differences(hessian):
    x, u = _trajectory(seed=1)
    cost = PendulumCost(hessian=hessian)
    e = cost.quadratize(x, u)
    h = 1e-6

    def grad_fd(fun, arr):
        g = np.zeros_like(arr)
        for idx in np.ndindex(arr.shape):
            d = np.zeros_like(arr)
            d[idx] = h
            g[idx] = (fun(arr + d) - fun(arr - d))[idx[0]] / (2 * h)
        return g

    np.testing.assert_allclose(
        e.lx, grad_fd(lambda xx: cost.stage_costs(xx, u), x), rtol=1e-6, atol=1e-6
    )
    np.testing.assert_allclose(
        e.lu, grad_fd(lambda uu: cost.stage_costs(x, uu), u), rtol=1e-6, atol=1e-8
    )
    # The exact second derivatives by finite differences of the gradient.
    exact = np.zeros_like(e.lxx)
    for i in range(2):
        d = np.zeros_like(x)
        d[:, i] = h
        exact[:, :, i] = (cost.quadratize(x + d, u).lx - cost.quadratize(x - d, u).lx) / (2 * h)
    np.testing.assert_allclose(e.luu[:, 0, 0], 2 * cost.torque_weight)
    np.testing.assert_array_equal(e.lux, 0.0)
    np.testing.assert_allclose(e.lxx[:, 1, 1], exact[:, 1, 1], rtol=1e-6)
    np.testing.assert_allclose(e.lxx[:, 0, 1], 0.0)
    cos = np.cos(x[:, 0])
    weights = np.full(x.shape[0], cost.angle_weight)
    weights[-1] = cost.terminal_angle_weight
    np.testing.assert_allclose(exact[:, 0, 0], weights * cos, rtol=1e-5, atol=1e-6)
    if hessian == "clipped":  # exact above the horizontal, zero (not negative) below
        up = cos > 0
        np.testing.assert_allclose(e.lxx[up, 0, 0], exact[up, 0, 0], rtol=1e-5)
        np.testing.assert_array_equal(e.lxx[~up, 0, 0], 0.0)
    else:  # Gauss–Newton of the residuals sin θ, 1 − cos θ: the constant weight
        np.testing.assert_allclose(e.lxx[:, 0, 0], weights)
    assert np.all(np.linalg.eigvalsh(e.lxx) >= -1e-12)  # positive semidefinite


def test_riccati_gains_are_the_lqr_gains_of_ilqg():
    rng = np.random.default_rng(3)
    N = 30
    A = np.eye(2) + 0.1 * rng.standard_normal((N, 2, 2))
    B = 0.2 * rng.standard_normal((N, 2, 1))
    dyn = LinearDynamics(A, B)
    cost = QuadraticCost(np.diag([1.0, 0.3]), np.array([[0.1]]), N)
    plan = ilqg(dyn, cost, np.array([1.0, -0.5]), np.zeros((N, 1)))
    K = gym_rl.riccati_gains(A, B, cost.quadratize(plan.x, plan.u))
    np.testing.assert_allclose(K, plan.K, rtol=1e-8, atol=1e-10)


# -- states from observations -----------------------------------------------------------------
def test_states_match_the_internal_state_on_a_spinning_rollout(env):
    # Torque along the velocity spins the pendulum over the top several times.
    obs, _ = env.reset(seed=1)
    observations, internal, torques = [obs], [env.unwrapped.state.copy()], []
    for _ in range(200):
        torque = 2.0 if obs[2] >= 0 else -2.0
        obs, *_ = env.step(np.array([torque]))
        observations.append(obs)
        internal.append(env.unwrapped.state.copy())
        torques.append(torque)
    internal = np.array(internal)
    assert np.ptp(internal[:, 0]) > 4 * np.pi  # unwrapping matters
    x = state_from_observations(np.array(observations))
    np.testing.assert_allclose(x, internal, atol=2e-5)
    # The online unwrapping of a rollout gives the same states, and the env's rewards.
    xr, ur, rewards = pendulum_rollout(env, 1, np.array(torques))
    np.testing.assert_allclose(xr, internal, atol=2e-5)
    np.testing.assert_allclose(ur[:, 0], torques)
    th = (internal[:-1, 0] + np.pi) % (2 * np.pi) - np.pi
    expected = -(th**2 + 0.1 * internal[:-1, 1] ** 2 + 0.001 * np.array(torques) ** 2)
    np.testing.assert_allclose(rewards, expected, rtol=1e-5, atol=1e-4)


def test_rollout_feedback_uses_the_wrapped_angle_error(env):
    N = 200
    x0, *_ = pendulum_rollout(env, 4, np.zeros(N))
    K = np.zeros((N, 1, 2))
    K[:, 0, 0] = -1.0
    # A nominal trajectory a full turn away is the same physical trajectory: no feedback.
    shifted = x0 + np.array([2 * np.pi, 0.0])
    x1, u1, _ = pendulum_rollout(env, 4, np.zeros(N), shifted, K)
    np.testing.assert_allclose(u1, 0.0, atol=1e-9)
    np.testing.assert_allclose(x1, x0)


def test_rollout_batch_shares_the_initial_state_and_reflects_the_noise(env):
    N, R = 200, 4
    rng = np.random.default_rng(0)
    noise = np.zeros((R, N))
    noise[1:] = 0.3 * rng.standard_normal((R - 1, N))
    u_nom = np.full(N, 2.0)  # saturated throughout: clipped noise would vanish
    x, u, rewards = pendulum_rollouts(env, 5, u_nom, noise=noise)
    assert x.shape == (R, N + 1, 2) and u.shape == (R, N, 1) and rewards.shape == (R, N)
    np.testing.assert_array_equal(x[:, 0], np.broadcast_to(x[0, 0], (R, 2)))  # one reset seed
    # Row 0 (no noise) is the plain rollout; a saturated torque moves inward by |e|.
    x0, u0, r0 = pendulum_rollout(env, 5, u_nom)
    np.testing.assert_array_equal(x[0], x0)
    np.testing.assert_array_equal(u[0], u0)
    np.testing.assert_array_equal(rewards[0], r0)
    np.testing.assert_allclose(u[:, :, 0], 2.0 - np.abs(noise), atol=1e-12)
    assert np.all(np.abs(u) <= 2.0)
    assert np.ptp(x[:, -1, 0]) > 0.01  # the noise changed the trajectories
    with pytest.raises(ValueError, match="noise"):
        pendulum_rollouts(env, 5, u_nom, noise=np.zeros(N))


def _true_jacobians(x):
    """Jacobians of gymnasium's Pendulum-v1 step (g = 10, m = l = 1, dt = 0.05), unclipped.

    The library never uses them; they check what it identifies from rollouts.
    """
    dt = 0.05
    a = 15.0 * np.cos(x[:, 0]) * dt  # ∂θ̇'/∂θ, with θ = 0 upright
    A = np.zeros((x.shape[0], 2, 2))
    A[:, 0, 0], A[:, 0, 1], A[:, 1, 0], A[:, 1, 1] = 1 + a * dt, dt, a, 1.0
    B = np.broadcast_to(np.array([[3 * dt * dt], [3 * dt]]), (x.shape[0], 2, 1))
    return A, B


def test_ltv_fit_on_a_batch_recovers_the_pendulum_jacobians(env):
    # Swings about hanging (|θ̇| < 8: the env's velocity clip never acts) under a small
    # torque, perturbed by the reflected exploration noise of the learning loop.
    N, R = 200, 8
    rng = np.random.default_rng(1)
    noise = np.zeros((R, N))
    noise[1:] = 0.03 * rng.standard_normal((R - 1, N))
    x, u, _ = pendulum_rollouts(env, 2, 0.5 * np.sin(0.3 * np.arange(N)), noise=noise)
    assert np.max(np.abs(x[..., 1])) < 7.5
    A_true, B_true = _true_jacobians(x[0, :-1])
    A, B = fit_rollouts("ltv", x, u, 0.01, locality_weights(x, 0.3))
    assert A.shape == (N, 2, 2) and B.shape == (N, 2, 1)
    # A_0 is not identified (all rollouts start at the same state): skip the first steps.
    err = np.abs(A[5:, 1, 0] - A_true[5:, 1, 0])  # A21 = 0.75 cos θ ranges over ±0.75
    assert np.median(err) < 0.04 and np.quantile(err, 0.9) < 0.12
    assert np.median(np.abs(B[5:, 1, 0] - B_true[5:, 1, 0])) < 0.005  # B21 = 0.15
    # One rollout leaves the Jacobians to the smoothness penalty, and a large λ
    # over-smooths them: both far off.
    A1, _ = fit_rollouts("ltv", x[:1], u[:1], 0.01)
    assert np.median(np.abs(A1[5:, 1, 0] - A_true[5:, 1, 0])) > 5 * np.median(err)
    A100, _ = fit_rollouts("ltv", x, u, 100.0, locality_weights(x, 0.3))
    assert np.median(np.abs(A100[5:, 1, 0] - A_true[5:, 1, 0])) > 4 * np.median(err)
    # The LTI model fitted on the same batch: one A for the whole swing.
    A_lti, _ = fit_rollouts("lti", x, u, 0.01, locality_weights(x, 0.3))
    np.testing.assert_array_equal(A_lti, np.broadcast_to(A_lti[0], A_lti.shape))
    assert np.median(np.abs(A_lti[5:, 1, 0] - A_true[5:, 1, 0])) > 0.15


def test_locality_weights():
    x = np.zeros((3, 11, 2))
    x[1, :, 0] = 0.3  # 0.3 rad from rollout 0 throughout
    x[2, 5:, 0] = 2 * np.pi  # over the top the other way from step 5: far
    w = locality_weights(x, 0.3)
    assert w.shape == (3, 10)
    np.testing.assert_array_equal(w[0], 1.0)
    np.testing.assert_allclose(w[1], np.exp(-0.5))
    np.testing.assert_array_equal(w[2, :5], 1.0)
    assert np.all(w[2, 5:] < 1e-50)
    assert locality_weights(x, None) is None


def test_swung_up_criterion():
    x = np.zeros((200, 2))
    x[:, 0] = 2 * np.pi  # upright, one turn later
    assert swung_up(x)
    x[-1, 0] = 2 * np.pi + 0.31
    assert not swung_up(x)
    assert swung_up(x[:-1])
    x[:-41, 0] = np.pi  # hanging before the last 40 steps (of x[:-1]) does not matter
    assert swung_up(x[:-1])
    assert not swung_up(x[:-1], steps=41)
    assert swung_up(x[:-1], angle=np.pi + 0.1, steps=199)


# -- learning -------------------------------------------------------------------------------------
def test_ltv_loop_swings_up_an_easy_initial_state(env):
    res = learn_pendulum("ltv", seed=7, iterations=20, env=env)
    assert res.returns.shape == res.incumbent_returns.shape == (20,)
    assert res.swing_up_iteration is not None and res.swing_up_iteration <= 20
    assert swung_up(res.x)
    # swing_up_iteration: from there on the incumbent stays swung up, and not before.
    it = res.swing_up_iteration
    assert np.all(res.swung_up[it - 1 :])
    assert it == 1 or not res.swung_up[it - 2]
    assert res.final_return > res.initial_return + 300
    assert res.final_return > -400
    # The incumbent changes only when a rollout is accepted, and is one of the rollouts.
    changed = np.flatnonzero(np.diff(res.incumbent_returns) != 0) + 1
    assert np.all(res.accepted[changed])
    assert res.final_return in res.returns
    np.testing.assert_allclose(res.incumbent_returns[res.accepted], res.returns[res.accepted])
    assert res.x.shape == (201, 2) and res.u.shape == (200, 1)
    assert np.all(np.abs(res.u) <= 2.0)
    assert np.isclose(res.rewards.sum(), res.final_return)
    assert np.all(res.horizons[:-1] <= res.horizons[1:])  # the planning horizon only grows


def test_learned_prior_arm_pools_the_earlier_iterations(env, monkeypatch):
    pytest.importorskip("sklearn")
    plain = learn_pendulum("ltv", seed=7, iterations=4, env=env)
    mixtures = []
    fit = gym_rl.fit_rollouts

    def spy(model, x, u, lam, weights=None, learned=None, learned_samples=None, noise=None):
        mixtures.append(None if learned is None else learned.n_transitions)
        return fit(model, x, u, lam, weights, learned, learned_samples, noise)

    monkeypatch.setattr(gym_rl, "fit_rollouts", spy)
    res = learn_pendulum("learned", seed=7, iterations=4, env=env, learned_after=1)
    # The first fit has no mixture yet: the first two iterations are the LTV loop's.
    np.testing.assert_array_equal(res.batch_returns[:2], plain.batch_returns[:2])
    # Then the mixture holds every earlier iteration's 8 rollouts of 200 transitions.
    assert mixtures == [None, 8 * 200, 2 * 8 * 200]
    assert not np.array_equal(res.batch_returns[2:], plain.batch_returns[2:])


def test_learning_is_reproducible(env):
    a = learn_pendulum("lti", seed=3, iterations=4, env=env)
    b = learn_pendulum("lti", seed=3, iterations=4, env=env)
    np.testing.assert_array_equal(a.batch_returns, b.batch_returns)
    np.testing.assert_array_equal(a.x, b.x)
    c = learn_pendulum("lti", seed=5, iterations=4, env=env)
    assert not np.array_equal(a.returns, c.returns)


def test_each_iteration_fits_both_models_on_the_same_batch_of_rollouts(env, monkeypatch):
    calls = []
    fit = gym_rl.fit_rollouts

    def spy(model, x, u, lam, weights=None, *learned):
        calls.append(
            (model, np.array(x), np.array(u), None if weights is None else np.array(weights))
        )
        return fit(model, x, u, lam, weights, *learned)

    monkeypatch.setattr(gym_rl, "fit_rollouts", spy)
    through = []
    original_through = gym_rl.LinearDynamics.through.__func__

    def through_spy(cls, A, B, x, u):
        through.append((np.array(x), np.array(u)))
        return original_through(cls, A, B, x, u)

    monkeypatch.setattr(gym_rl.LinearDynamics, "through", classmethod(through_spy))
    R, iterations = 5, 3
    res = {
        m: learn_pendulum(m, seed=7, iterations=iterations, rollouts_per_iteration=R, env=env)
        for m in ("ltv", "lti")
    }
    assert [c[0] for c in calls] == ["ltv"] * (iterations - 1) + ["lti"] * (iterations - 1)
    for _model, x, u, w in calls:
        assert x.shape == (R, 201, 2) and u.shape == (R, 200, 1) and w.shape == (R, 200)
        np.testing.assert_array_equal(x[:, 0], np.broadcast_to(x[0, 0], (R, 2)))
        assert np.all(np.ptp(x[:, -1], axis=0) > 0)  # R different rollouts
        np.testing.assert_array_equal(w[0], 1.0)  # the nominal rollout weighs fully
        assert np.all((w > 0) & (w <= 1))
    # Iteration 1 (the random-torque controller and its noise) is the same for both models.
    np.testing.assert_array_equal(calls[0][1], calls[iterations - 1][1])
    np.testing.assert_array_equal(calls[0][2], calls[iterations - 1][2])
    for r in res.values():
        assert r.batch_returns.shape == (iterations, R) and r.rollouts_per_iteration == R
        np.testing.assert_array_equal(r.batch_returns[:, 0], r.returns)  # rollout 0: no noise
        # The incumbent (the data of the fits) is a noise-free rollout of the controller.
        assert r.final_return in r.returns
    # Each linearization is through the incumbent: rollout 0 (noise-free) of the batch fitted.
    assert len(through) == len(calls)
    for (_, x, u, _), (xl, ul) in zip(calls, through):
        H = ul.shape[0]
        np.testing.assert_array_equal(xl, x[0, : H + 1])
        np.testing.assert_array_equal(ul, u[0, :H])


@pytest.mark.parametrize("tail", ["hold", "zero", "incumbent"])
def test_controller_after_the_planning_horizon(env, monkeypatch, tail):
    controllers = []
    rollouts = gym_rl.pendulum_rollouts

    def spy(env_, seed, u_nom, x_nom=None, K=None, *, noise):
        controllers.append(
            (
                np.array(u_nom),
                None if x_nom is None else np.array(x_nom),
                None if K is None else np.array(K),
            )
        )
        return rollouts(env_, seed, u_nom, x_nom, K, noise=noise)

    monkeypatch.setattr(gym_rl, "pendulum_rollouts", spy)
    H = 10
    res = learn_pendulum("ltv", seed=7, iterations=2, horizon_start=H, tail=tail, env=env)
    assert res.horizons[0] == H
    u_nom, x_nom, K = controllers[1]  # the first planned controller
    assert np.any(K[:H] != 0)
    if tail == "hold":  # the plan's last gains towards its last state
        np.testing.assert_array_equal(K[H:], np.broadcast_to(K[H - 1], K[H:].shape))
        np.testing.assert_array_equal(
            x_nom[H + 1 :], np.broadcast_to(x_nom[H], x_nom[H + 1 :].shape)
        )
        np.testing.assert_array_equal(u_nom[H:], 0.0)
    elif tail == "zero":
        np.testing.assert_array_equal(K[H:], 0.0)
        np.testing.assert_array_equal(u_nom[H:], 0.0)
    else:  # the incumbent (the first rollout) replayed open loop
        np.testing.assert_array_equal(K[H:], 0.0)
        first_u = controllers[0][0]  # the random initial torques: the first rollout's
        np.testing.assert_array_equal(u_nom[H:], first_u[H:])


def test_one_rollout_per_iteration_is_the_loop_without_exploration(env):
    res = learn_pendulum("ltv", seed=7, iterations=3, rollouts_per_iteration=1, env=env)
    assert res.batch_returns.shape == (3, 1)
    np.testing.assert_array_equal(res.batch_returns[:, 0], res.returns)


def test_experiment_table_and_plot():
    import matplotlib

    matplotlib.use("Agg")
    result = run_pendulum_experiment(seeds=[7], iterations=3, models=("ltv", "lti"))
    assert result.returns["ltv"].shape == result.returns["lti"].shape == (1, 3)
    assert set(result.swung_up_count()) == {"ltv", "lti"}
    text = result.table()
    for piece in (
        "LTV model",
        "LTI model",
        "seeds swung up",
        "median iterations to swing-up",
        "median final return",
        "-150",
    ):
        assert piece in text
    fig = plot_pendulum_experiment(result)
    assert len(fig.axes) == 2


def test_importing_ltvmodels_does_not_import_gymnasium():
    code = "import sys, ltvmodels, ltvmodels.apps.gym_rl; assert 'gymnasium' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_missing_gymnasium_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "gymnasium", None)
    with pytest.raises(ImportError, match=r"install ltvmodels\[rl\]"):
        gym_rl.make_env()


# -- invalid arguments --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, exc, name",
    [
        ({"model": "true"}, ValueError, "model"),
        ({"seed": -1}, ValueError, "seed"),
        ({"iterations": 0}, ValueError, "iterations"),
        ({"lam": 0.0}, ValueError, "lam"),
        ({"noise_std": -0.1}, ValueError, "noise_std"),
        ({"rollouts_per_iteration": 0}, ValueError, "rollouts_per_iteration"),
        ({"locality": 0.0}, ValueError, "locality"),
        ({"tail": "brake"}, ValueError, "tail"),
        ({"initial_torque_std": "1"}, TypeError, "initial_torque_std"),
        ({"trust_region": 5.0}, ValueError, "trust_region"),
        ({"horizon_start": 201}, ValueError, "horizon_start"),
        ({"horizon_step": -1}, ValueError, "horizon_step"),
        ({"reject_worse": 1}, TypeError, "reject_worse"),
        ({"feedback": "lqr"}, ValueError, "feedback"),
        ({"cost": "quadratic"}, TypeError, "cost"),
        ({"env": object()}, TypeError, "env"),
    ],
)
def test_learn_pendulum_rejects_invalid_arguments(kwargs, exc, name):
    with pytest.raises(exc, match=name):
        learn_pendulum(**kwargs)


def test_other_functions_reject_invalid_arguments(env):
    with pytest.raises(ValueError, match="hessian"):
        PendulumCost(hessian="exact")
    with pytest.raises(ValueError, match="angle_weight"):
        PendulumCost(angle_weight=-1.0)
    with pytest.raises(ValueError, match="obs"):
        state_from_observations(np.zeros((5, 2)))
    with pytest.raises(ValueError, match="steps"):
        swung_up(np.zeros((10, 2)), steps=11)
    with pytest.raises(ValueError, match="x_nom"):
        pendulum_rollout(env, 0, np.zeros(200), np.zeros((200, 2)), np.zeros((200, 1, 2)))
    with pytest.raises(ValueError, match="noise"):
        pendulum_rollout(env, 0, np.zeros(200), noise=np.zeros(3))
    with pytest.raises(ValueError, match="u_nom"):
        pendulum_rollout(env, 0, np.zeros(250))
    with pytest.raises(TypeError, match="models"):
        run_pendulum_experiment(models="ltv")
    with pytest.raises(ValueError, match="model"):
        run_pendulum_experiment(models=("ltv", "true"))
    with pytest.raises(TypeError, match="seeds"):
        run_pendulum_experiment(seeds="0")
    with pytest.raises(TypeError, match="seed"):
        run_pendulum_experiment(seeds=[0], seed=1)
    with pytest.raises(TypeError, match="result"):
        plot_pendulum_experiment(None)


# -- the command line -----------------------------------------------------------------------------
def test_cli_pendulum_demo_writes_png(tmp_path, capsys):
    from ltvmodels.cli import main

    out = tmp_path / "p.png"
    assert main(["demo", "pendulum", "--quick", "--seed", "7", "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
    text = capsys.readouterr().out
    assert "Pendulum-v1" in text and "seeds swung up" in text


def test_cli_pendulum_demo_without_gymnasium_is_a_user_error(monkeypatch, tmp_path, capsys):
    from ltvmodels.cli import main

    monkeypatch.setitem(sys.modules, "gymnasium", None)
    assert main(["demo", "pendulum", "--out", str(tmp_path / "p.png")]) == 2
    err = capsys.readouterr().err
    assert "install ltvmodels[rl]" in err and "Traceback" not in err


def test_sensor_noise_reaches_the_fits_not_the_controller(env, monkeypatch):
    seen = []
    fit = gym_rl.fit_rollouts

    def spy(model, x, u, lam, weights=None, learned=None, learned_samples=None, noise=None):
        seen.append((np.array(x), noise))
        return fit(model, x, u, lam, weights, learned, learned_samples, noise)

    monkeypatch.setattr(gym_rl, "fit_rollouts", spy)
    clean = learn_pendulum("ltv", seed=7, iterations=2, env=env)
    noisy = learn_pendulum(
        "ltv", seed=7, iterations=2, env=env, state_noise_std=0.01, measurement_noise=1e-4
    )
    # the first batch runs the same controller on the true states: the same returns
    np.testing.assert_array_equal(noisy.batch_returns[0], clean.batch_returns[0])
    (x_clean, none), (x_noisy, variance) = seen
    assert none is None and variance == 1e-4
    assert 0.008 < float(np.std(x_noisy - x_clean)) < 0.012  # the sensor's noise, in the fit
    with pytest.raises(ValueError, match="state_noise_std"):
        learn_pendulum("ltv", seed=7, iterations=1, env=env, state_noise_std=-1.0)
