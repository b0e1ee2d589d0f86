"""The cart-pole simulator and the model-based RL experiment of paper Fig. 4 (ltvmodels.rl)."""

import numpy as np
import pytest

from ltvmodels.apps import rl


def test_jacobian_matches_finite_differences():
    s = rl.CartPole()
    rng = np.random.default_rng(0)
    for _ in range(5):
        x = rng.uniform([-1, -2, -np.pi, -5], [1, 2, np.pi, 5])
        u = rng.uniform(-3, 3, 1)
        A, B = s.jacobian(x, u)
        eps = 1e-6
        Afd = np.array(
            [(s.step(x + eps * e, u) - s.step(x - eps * e, u)) / (2 * eps) for e in np.eye(4)]
        ).T
        Bfd = (s.step(x, u + eps) - s.step(x, u - eps)) / (2 * eps)
        np.testing.assert_allclose(A, Afd, atol=1e-8)
        np.testing.assert_allclose(B[:, 0], Bfd, atol=1e-8)
        J, b = s.continuous_jacobian(x, u)
        Jfd = np.array(
            [
                (s.derivative(x + eps * e, u) - s.derivative(x - eps * e, u)) / (2 * eps)
                for e in np.eye(4)
            ]
        ).T
        np.testing.assert_allclose(J, Jfd, atol=1e-7)
    N = 6
    xs = rng.standard_normal((N + 1, 4))
    us = rng.standard_normal((N, 1))
    A, B = s.linearize(xs, us)
    np.testing.assert_allclose(A[3], s.jacobian(xs[3], us[3])[0])


def test_rk4_matches_scipy_and_energy_of_the_free_pendulum():
    s = rl.CartPole(pole_damping=0.0)
    u = np.random.default_rng(1).uniform(-3, 3, (40, 1))
    x0 = [0.0, 0.0, np.pi - 0.3, 0.0]
    np.testing.assert_allclose(s.simulate(x0, u), s.simulate(x0, u, method="scipy"), atol=1e-7)
    # Without force and friction the energy is conserved.
    x = s.simulate(x0, np.zeros((300, 1)))
    M, m, ell, g = s.cart_mass, s.pole_mass, s.length, s.gravity
    p, v, th, w = x.T
    energy = (
        0.5 * (M + m) * v**2
        + m * ell * v * w * np.cos(th)
        + 0.5 * m * ell**2 * w**2
        - m * g * ell * np.cos(th)
    )
    assert np.ptp(energy) < 1e-6 * np.abs(energy).max()


def test_linearizations_upright_and_hanging_on_opposite_sides():
    """The reason an LTI model fails (paper Section VIII)."""
    s = rl.CartPole()
    up = np.linalg.eigvals(s.continuous_jacobian([0, 0, np.pi, 0])[0])
    down = np.linalg.eigvals(s.continuous_jacobian([0, 0, 0, 0])[0])
    assert up.real.max() > 3.0
    assert down.real.max() <= 1e-12 and np.abs(down.imag).max() > 3.0


def test_rollout_bounds_seed_and_no_mutation():
    task = rl.cartpole_task(horizon=100)
    s = task.system
    x_nom = np.tile(task.x0, (101, 1))
    u_nom = np.full((100, 1), 2.5)
    K = np.random.default_rng(2).standard_normal((100, 1, 4)) * 20
    copies = [a.copy() for a in (x_nom, u_nom, K)]
    x1, u1 = s.rollout(task.x0, x_nom, u_nom, K, noise_std=1.0, seed=3)
    x2, u2 = s.rollout(task.x0, x_nom, u_nom, K, noise_std=1.0, seed=3)
    np.testing.assert_array_equal(x1, x2)
    assert np.all(np.abs(u1) <= s.force_limit) and np.any(np.abs(u1) == s.force_limit)
    for a, b in zip((x_nom, u_nom, K), copies, strict=True):
        np.testing.assert_array_equal(a, b)
    # The applied forces reproduce the states open loop.
    np.testing.assert_allclose(s.simulate(task.x0, u1), x1, atol=1e-12)


def test_learn_with_the_true_model_improves_and_respects_bounds():
    task = rl.cartpole_task()
    res = rl.learn(task, "true", iterations=4, seed=0)
    assert res.costs.shape == (4,) and res.predicted.shape == (3,)
    assert np.all(np.diff(res.costs) < 0)
    assert np.all(np.abs(res.u) <= task.system.force_limit)
    assert np.all(np.abs(res.controller.u) <= task.system.force_limit)


def test_quick_experiment_reproduces_the_paper_ordering():
    """Quick mode of Fig. 4: LTV beats LTI; the LTV model with prior reaches the optimum."""
    result = rl.run_experiment(quick=True, seed=0, models=rl.PAPER_MODELS)
    assert result.runs == rl.QUICK_RUNS and result.iterations == rl.QUICK_ITERATIONS
    med = result.median()
    first = med["ltv"][0]
    for m in rl.PAPER_MODELS:
        assert med[m][0] == pytest.approx(first)  # same initial controller and noise
    # LTV beats LTI after a few iterations (LTI stalls far above or diverges).
    assert np.all(med["ltv"][2:] < med["lti"][2:])
    assert med["lti"][-1] > 1.3 * result.optimum
    # Within 30 % of the true-model cost: LTV, and LTV with prior (closer).
    assert med["ltv"][-1] < 1.3 * result.optimum
    assert med["prior"][-1] < 1.15 * result.optimum
    assert med["prior"][-1] <= med["ltv"][-1]
    assert med["true"][-1] < 1.05 * result.optimum
    text = result.table()
    assert "LTV with prior" in text and "optimum" in text
    fig = rl.plot_experiment(result)
    assert len(fig.axes[0].lines) == len(rl.PAPER_MODELS) + 1


def test_learned_prior_arm_uses_the_earlier_rollouts_and_nothing_of_the_true_model(monkeypatch):
    pytest.importorskip("sklearn")
    task = rl.cartpole_task(horizon=200)
    plain = rl.learn(task, "ltv", iterations=5, seed=0)

    def no_true_model(*args, **kwargs):
        raise AssertionError("the learned-prior arm used the true Jacobians")

    monkeypatch.setattr(rl.CartPole, "linearize", no_true_model)
    learned = rl.learn(task, "learned", iterations=5, seed=0, learned_after=2)
    # Fits 1 and 2 are the LTV arm's (the mixture holds < 2 rollouts): rollouts 1-3 agree.
    np.testing.assert_array_equal(learned.costs[:3], plain.costs[:3])
    assert not np.array_equal(learned.costs[3:], plain.costs[3:])
    assert np.all(np.isfinite(learned.costs)) and learned.costs[-1] < learned.costs[0]


def test_experiment_input_validation():
    with pytest.raises(ValueError, match="model: expected one of"):
        rl.learn(rl.cartpole_task(horizon=10), "gmm")
    with pytest.raises(TypeError, match="task: expected a CartPoleTask"):
        rl.learn("cartpole")
    with pytest.raises(ValueError, match="runs: expected an integer >= 1"):
        rl.run_experiment(runs=0)
    with pytest.raises(TypeError, match="models: expected a non-empty sequence"):
        rl.run_experiment(models="ltv")
    with pytest.raises(ValueError, match="models: expected distinct names"):
        rl.run_experiment(models=["ltv", "ltv"])
    with pytest.raises(ValueError, match="trust_region: expected a real number > 0"):
        rl.learn(rl.cartpole_task(horizon=10), trust_region=0)
    with pytest.raises(ValueError, match="length: expected a finite real number > 0"):
        rl.CartPole(length=-1.0)
    with pytest.raises(ValueError, match=r"x_nom: expected shape \(3, 4\)"):
        rl.CartPole().rollout(np.zeros(4), np.zeros((2, 4)), np.zeros((2, 1)))
    with pytest.raises(TypeError, match="result: expected an RLExperiment"):
        rl.plot_experiment({"ltv": [1.0]})
