"""Model-based RL on gymnasium's Pendulum-v1 (ltvmodels.gym_rl)."""

import subprocess
import sys

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from ltvmodels.apps import gym_rl  # noqa: E402
from ltvmodels.control import LinearDynamics, QuadraticCost, ilqg  # noqa: E402
from ltvmodels.apps.gym_rl import (  # noqa: E402
    PendulumCost,
    learn_pendulum,
    pendulum_rollout,
    plot_pendulum_experiment,
    run_pendulum_experiment,
    state_from_observations,
    swung_up,
)


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
    cost = PendulumCost(angle_weight=5.0, velocity_weight=0.1, torque_weight=0.001,
                        terminal_angle_weight=10.0, terminal_velocity_weight=0.5)
    c = cost.stage_costs(x, u)
    th, w = x[:, 0], x[:, 1]
    assert c.shape == (x.shape[0],)
    np.testing.assert_allclose(c[:-1], 5 * (1 - np.cos(th[:-1])) + 0.1 * w[:-1] ** 2
                               + 0.001 * u[:, 0] ** 2)
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

    np.testing.assert_allclose(e.lx, grad_fd(lambda xx: cost.stage_costs(xx, u), x),
                               rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(e.lu, grad_fd(lambda uu: cost.stage_costs(x, uu), u),
                               rtol=1e-6, atol=1e-8)
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
    assert res.final_return > res.initial_return + 300
    assert res.final_return > -400
    # The incumbent changes only when a rollout is accepted, and is one of the rollouts.
    changed = np.flatnonzero(np.diff(res.incumbent_returns) != 0) + 1
    assert np.all(res.accepted[changed])
    assert res.final_return in res.returns
    np.testing.assert_allclose(res.incumbent_returns[res.accepted],
                               res.returns[res.accepted])
    assert res.x.shape == (201, 2) and res.u.shape == (200, 1)
    assert np.all(np.abs(res.u) <= 2.0)
    assert np.isclose(res.rewards.sum(), res.final_return)
    assert np.all(res.horizons[:-1] <= res.horizons[1:])  # the planning horizon only grows


def test_learning_is_reproducible(env):
    a = learn_pendulum("lti", seed=3, iterations=4, env=env)
    b = learn_pendulum("lti", seed=3, iterations=4, env=env)
    np.testing.assert_array_equal(a.returns, b.returns)
    c = learn_pendulum("lti", seed=5, iterations=4, env=env)
    assert not np.array_equal(a.returns, c.returns)


def test_experiment_table_and_plot():
    import matplotlib

    matplotlib.use("Agg")
    result = run_pendulum_experiment(seeds=[7], iterations=3)
    assert result.returns["ltv"].shape == result.returns["lti"].shape == (1, 3)
    assert set(result.swung_up_count()) == {"ltv", "lti"}
    text = result.table()
    for piece in ("LTV model", "LTI model", "seeds swung up", "median iterations to swing-up",
                  "median final return", "-150"):
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
@pytest.mark.parametrize("kwargs, exc, name", [
    ({"model": "true"}, ValueError, "model"),
    ({"seed": -1}, ValueError, "seed"),
    ({"iterations": 0}, ValueError, "iterations"),
    ({"lam": 0.0}, ValueError, "lam"),
    ({"noise_std": -0.1}, ValueError, "noise_std"),
    ({"initial_torque_std": "1"}, TypeError, "initial_torque_std"),
    ({"trust_region": 5.0}, ValueError, "trust_region"),
    ({"horizon_start": 201}, ValueError, "horizon_start"),
    ({"horizon_step": -1}, ValueError, "horizon_step"),
    ({"reject_worse": 1}, TypeError, "reject_worse"),
    ({"feedback": "lqr"}, ValueError, "feedback"),
    ({"cost": "quadratic"}, TypeError, "cost"),
    ({"env": object()}, TypeError, "env"),
])
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
