"""Seeded example systems: ltvmodels.systems."""

from __future__ import annotations

import numpy as np
import pytest

from ltvmodels import systems

A1 = np.array([[0.95, 0.1], [0.0, 0.95]])
A2 = np.array([[0.5, 0.05], [0.0, 0.5]])


# -- jump_linear ----------------------------------------------------------------------
def test_jump_linear_shapes():
    data = systems.jump_linear()
    assert data.x.shape == (400, 2) and data.x_true.shape == (400, 2)
    assert data.u.shape == (400, 1)
    assert data.A.shape == (399, 2, 2) and data.B.shape == (399, 2, 1)
    assert data.k.shape == (399, 6) and data.theta.shape == (399, 2, 3)
    assert (data.T, data.N, data.n, data.m, data.K) == (400, 399, 2, 1, 6)
    assert "jump-linear" in repr(data)


def test_jump_linear_switch_matches_paper():
    data = systems.jump_linear()
    np.testing.assert_array_equal(data.A[:200], np.broadcast_to(A1, (200, 2, 2)))
    np.testing.assert_array_equal(data.A[200:], np.broadcast_to(A2, (199, 2, 2)))
    np.testing.assert_array_equal(data.B, np.broadcast_to([[0.2], [1.0]], (399, 2, 1)))
    np.testing.assert_array_equal(data.changepoints, [200])
    # k_t is the rows of [A_t B_t] concatenated
    np.testing.assert_array_equal(data.k[199], np.hstack([A1, [[0.2], [1.0]]]).ravel())
    np.testing.assert_array_equal(data.k[200], np.hstack([A2, [[0.2], [1.0]]]).ravel())


def test_jump_linear_custom_change_and_edges():
    data = systems.jump_linear(T=100, change_at=30)
    assert data.A.shape == (99, 2, 2)
    np.testing.assert_array_equal(data.A[29], A1)
    np.testing.assert_array_equal(data.A[30], A2)
    assert systems.jump_linear(T=50, change_at=0).changepoints.size == 0
    assert np.all(systems.jump_linear(T=50, change_at=49).A == A1)


def test_jump_linear_deterministic_and_seeded():
    a, b = systems.jump_linear(seed=3), systems.jump_linear(seed=3)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.u, b.u)
    assert not np.array_equal(a.x, systems.jump_linear(seed=4).x)
    c = systems.jump_linear(seed=np.random.default_rng(3))
    np.testing.assert_array_equal(a.x, c.x)


def test_jump_linear_noise_levels_and_recursion():
    data = systems.jump_linear(T=4000, change_at=2000, seed=1)
    # measurement noise σ = 0.2 on the recorded states
    assert 0.18 < np.std(data.x - data.x_true) < 0.22
    # process noise σ = 0.2 in the state recursion
    w = data.x_true[1:] - np.einsum(
        "tij,tj->ti", data.theta, np.hstack([data.x_true[:-1], data.u[:-1]])
    )
    assert 0.18 < np.std(w) < 0.22
    assert 0.95 < np.std(data.u) < 1.05
    assert data.x_true[0].tolist() == [0.0, 0.0]


def test_jump_linear_noise_free():
    data = systems.jump_linear(T=60, noise_std=0.0, measurement_std=0.0, change_at=20)
    np.testing.assert_array_equal(data.x, data.x_true)
    pred = np.einsum("tij,tj->ti", data.theta, np.hstack([data.x[:-1], data.u[:-1]]))
    np.testing.assert_allclose(pred, data.x[1:], atol=1e-12)
    assert data.measurement_std == 0.0
    assert systems.jump_linear(noise_std=0.1).measurement_std == 0.1


def test_returned_arrays_are_fresh():
    data = systems.jump_linear(T=20, change_at=10)
    k = data.k
    k[:] = 0.0
    assert data.A[0, 0, 0] == 0.95


@pytest.mark.parametrize(
    "kwargs, exc, word",
    [
        ({"T": 1}, ValueError, "T"),
        ({"T": 10.5}, TypeError, "T"),
        ({"T": True}, TypeError, "T"),
        ({"change_at": 400}, ValueError, "change_at"),
        ({"change_at": -1}, ValueError, "change_at"),
        ({"noise_std": -0.1}, ValueError, "noise_std"),
        ({"noise_std": float("nan")}, ValueError, "noise_std"),
        ({"measurement_std": -1.0}, ValueError, "measurement_std"),
        ({"seed": "a"}, TypeError, "seed"),
        ({"seed": -1}, TypeError, "seed"),
    ],
)
def test_jump_linear_rejects_bad_arguments(kwargs, exc, word):
    with pytest.raises(exc, match=rf"^{word}:"):
        systems.jump_linear(**kwargs)


# -- random_walk_system ----------------------------------------------------------------
def test_random_walk_shapes():
    data = systems.random_walk_system(T=500, seed=1)
    assert data.x.shape == (500, 3) and data.u.shape == (500, 2)
    assert data.A.shape == (499, 3, 3) and data.B.shape == (499, 3, 2)
    assert data.k.shape == (499, 15)
    assert data.changepoints is None
    small = systems.random_walk_system(T=50, n=2, m=0)
    assert small.u.shape == (50, 0) and small.B.shape == (49, 2, 0) and small.k.shape == (49, 4)


def test_random_walk_deterministic():
    a = systems.random_walk_system(T=300, seed=5)
    b = systems.random_walk_system(T=300, seed=5)
    for name in ("x", "u", "A", "B"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.k, systems.random_walk_system(T=300, seed=6).k)


def test_random_walk_is_a_random_walk_while_unclipped():
    data = systems.random_walk_system(T=3000, drift_std=0.01, seed=2)
    steps = np.diff(data.B, axis=0)  # B is never rescaled
    assert 0.009 < steps.std() < 0.011
    assert abs(steps.mean()) < 1e-3
    lti = systems.random_walk_system(T=100, drift_std=0.0)
    assert np.all(lti.k == lti.k[0])


def test_random_walk_stays_stable():
    # large drift over a long series: the walk leaves the unit ball, the bound holds
    data = systems.random_walk_system(T=20_000, drift_std=0.02, seed=3, max_norm=0.9)
    fro = np.linalg.norm(data.A, axis=(1, 2))
    assert fro.max() <= 0.9 + 1e-12
    assert np.isclose(fro.max(), 0.9)  # the bound was active
    assert np.abs(np.linalg.eigvals(data.A)).max() < 1.0
    assert np.all(np.isfinite(data.x))
    # contraction: |x| is bounded by input and noise, not growing with time
    assert np.abs(data.x).max() < 50 * (1 + np.abs(data.B).max())


def test_random_walk_measurement_noise():
    data = systems.random_walk_system(T=2000, measurement_std=0.3, seed=0)
    assert 0.28 < np.std(data.x - data.x_true) < 0.32
    clean = systems.random_walk_system(T=200)
    np.testing.assert_array_equal(clean.x, clean.x_true)


@pytest.mark.parametrize(
    "kwargs, exc, word",
    [
        ({"n": 0}, ValueError, "n"),
        ({"m": -1}, ValueError, "m"),
        ({"drift_std": -1.0}, ValueError, "drift_std"),
        ({"max_norm": 1.0}, ValueError, "max_norm"),
        ({"max_norm": 0.0}, ValueError, "max_norm"),
        ({"T": "10"}, TypeError, "T"),
    ],
)
def test_random_walk_rejects_bad_arguments(kwargs, exc, word):
    with pytest.raises(exc, match=rf"^{word}:"):
        systems.random_walk_system(**kwargs)
