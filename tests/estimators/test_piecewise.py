"""ltvmodels.fit_piecewise: the equality-constrained second step of the two-step refinement.

References built here from scratch with numpy/scipy:

* order 1: one ``np.linalg.lstsq`` per segment;
* orders 1 and 2: the dense equality-constrained least-squares problem
  min ‖Ỹ − Φ̃k‖² s.t. (D ⊗ I_K) k = 0 on every row of D except those that
  straddle a change point (t = c − 1), solved in a null-space basis of the
  constraints, with the covariance by the sandwich formula.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
import scipy.linalg
from dense_reference import difference_matrix, random_data, stacked_regressor

import ltvmodels as ltv
from ltvmodels.errors import SingularProblemError


def constrained_reference(x, u, changepoints, order):
    """Dense constrained LS: k (N, K), residual covariance and Cov(k_t) (N, K, K)."""
    Phi, Y, phi = stacked_regressor(x, u)
    N, p = phi.shape
    n = x.shape[1]
    K = n * p
    D = difference_matrix(N, np.array([[-1.0, 1.0], [1.0, -2.0, 1.0]][order - 1]))
    free_rows = [c - 1 for c in changepoints]  # (Dk)_{c−1} spans the change at c
    D = np.delete(D, free_rows, axis=0)
    Q = scipy.linalg.null_space(np.kron(D, np.eye(K)))  # (N K, r)
    PQ = Phi @ Q
    g, *_ = np.linalg.lstsq(PQ, Y, rcond=None)
    k = (Q @ g).reshape(N, K)
    resid = (Y - Phi @ Q @ g).reshape(N, n)
    n_params = Q.shape[1] // n
    noise_cov = resid.T @ resid / (N - n_params)
    # Sandwich: Cov(k) = Q M⁻¹ QᵀΦ̃ᵀ (I_N ⊗ Σ_v) Φ̃ Q M⁻¹ Qᵀ, M = QᵀΦ̃ᵀΦ̃Q.
    M_inv = np.linalg.inv(PQ.T @ PQ)
    G = Q @ M_inv @ PQ.T
    cov = G @ np.kron(np.eye(N), noise_cov) @ G.T
    blocks = np.stack([cov[t * K : (t + 1) * K, t * K : (t + 1) * K] for t in range(N)])
    return k, noise_cov, blocks


def assert_row_covariances(model, reference):
    """The stored per-row blocks and std() equal the reference; cross-row blocks are 0."""
    n, p = model.n_states, model.n_regressors
    full = model.cov_full().reshape(-1, n, p, n, p)
    ref = reference.reshape(-1, n, p, n, p)
    for i in range(n):
        np.testing.assert_allclose(full[:, i, :, i, :], ref[:, i, :, i, :], rtol=1e-8, atol=1e-14)
        for j in range(n):
            if j != i:
                assert not full[:, i, :, j, :].any()
    ref_std = np.sqrt(np.diagonal(reference, axis1=1, axis2=2))
    np.testing.assert_allclose(model.std(), ref_std, rtol=1e-8)


# -- order 1 ------------------------------------------------------------------------------


@pytest.mark.parametrize("n,m,changepoints", [(2, 1, [20, 45]), (3, 0, [30]), (1, 2, [10, 21])])
def test_order1_equals_per_segment_lstsq(n, m, changepoints):
    x, u = random_data(3, 70, n, m)
    model = ltv.fit_piecewise(x, u, changepoints)
    phi = np.hstack([x[:-1], np.zeros((69, 0)) if u is None else u[:-1]])
    y = x[1:]
    bounds = [0, *changepoints, 69]
    for start, stop in itertools.pairwise(bounds):
        theta, *_ = np.linalg.lstsq(phi[start:stop], y[start:stop], rcond=None)  # (p, n)
        expected = theta.T  # [A B]
        for t in range(start, stop):
            np.testing.assert_allclose(model.A[t], expected[:, :n], atol=1e-12)
            np.testing.assert_allclose(model.B[t], expected[:, n:], atol=1e-12)
    np.testing.assert_array_equal(model.changepoints, changepoints)
    assert model.info["segments"] == [list(pair) for pair in itertools.pairwise(bounds)]


def test_order1_noise_covariance_and_posterior_covariance():
    x, u = random_data(5, 60, 2, 1)
    model = ltv.fit_piecewise(x, u, [25])
    k, noise_cov, cov = constrained_reference(x, u, [25], order=1)
    np.testing.assert_allclose(model.k, k, atol=1e-10)
    np.testing.assert_allclose(model.noise_cov, noise_cov, rtol=1e-10)
    np.testing.assert_allclose(model.noise_var, np.diag(noise_cov), rtol=1e-12)
    assert_row_covariances(model, cov)
    # Per segment, row i: Σ_v[i, i] (Φ_sᵀΦ_s)⁻¹.
    phi = np.hstack([x[:-1], u[:-1]])
    expected = model.noise_cov[1, 1] * np.linalg.inv(phi[25:].T @ phi[25:])
    np.testing.assert_allclose(model.cov_full()[40, 3:, 3:], expected, rtol=1e-10)
    assert model.info["dof"] == 59 - 2 * 3 and model.info["n_params_per_row"] == 6


def test_order1_without_changepoints_is_fit_lti():
    x, u = random_data(7, 50, 2, 1)
    model = ltv.fit_piecewise(x, u, [])
    lti = ltv.fit_lti(x, u)
    np.testing.assert_allclose(model.k, lti.k, atol=1e-12)
    np.testing.assert_allclose(model.noise_cov, lti.noise_cov, rtol=1e-10)
    np.testing.assert_allclose(model.std(), lti.std(), rtol=1e-9)
    assert model.loglik == pytest.approx(lti.loglik, rel=1e-12)
    assert model.changepoints.size == 0


def simulate_exact(theta, seed):
    """x[t+1] = Θ_t [x_t; u_t] without noise (Θ: (N, n, n + m)); returns x, u."""
    N, n, p = theta.shape
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((N + 1, p - n))
    x = np.zeros((N + 1, n))
    x[0] = rng.standard_normal(n)
    for t in range(N):
        x[t + 1] = theta[t] @ np.concatenate([x[t], u[t]])
    return x, u


def test_order1_recovers_noise_free_piecewise_constant_data_exactly():
    rng = np.random.default_rng(11)
    N, cps = 89, [30, 61]
    bounds = [0, *cps, N]
    theta = np.empty((N, 2, 3))
    for a, b in itertools.pairwise(bounds):
        theta[a:b] = 0.3 * rng.standard_normal((2, 3))  # ‖A‖ <= ‖A‖_F < 1: stable
    x, u = simulate_exact(theta, 12)
    model = ltv.fit_piecewise(x, u, cps)
    np.testing.assert_allclose(model.theta, theta, atol=1e-10)
    assert np.all(model.noise_var < 1e-20)


# -- order 2 ------------------------------------------------------------------------------


@pytest.mark.parametrize("n,m,changepoints", [(2, 1, [20, 41]), (2, 0, [30]), (1, 1, [])])
def test_order2_equals_dense_constrained_least_squares(n, m, changepoints):
    x, u = random_data(13, 60, n, m)
    model = ltv.fit_piecewise(x, u, changepoints, order=2)
    k, noise_cov, cov = constrained_reference(x, u, changepoints, order=2)
    np.testing.assert_allclose(model.k, k, atol=1e-10)
    np.testing.assert_allclose(model.noise_cov, noise_cov, rtol=1e-9)
    assert_row_covariances(model, cov)
    assert model.info["n_params_per_row"] == (len(changepoints) + 2) * (n + m)
    assert model.info["knots"] == [0, *changepoints, 58]


def test_order2_is_linear_on_segments_and_continuous_at_knots():
    x, u = random_data(17, 80, 2, 1)
    cps = [25, 50]
    model = ltv.fit_piecewise(x, u, cps, order=2)
    k = model.k
    second = k[2:] - 2 * k[1:-1] + k[:-2]  # nonzero only at t = c − 1 (a kink at c)
    kinks = np.flatnonzero(np.linalg.norm(second, axis=1) > 1e-10 * np.abs(k).max())
    np.testing.assert_array_equal(kinks, np.array(cps) - 1)
    # Each closed interval [τ_j, τ_{j+1}] is one straight line: the pieces meet at the knots.
    knots = [0, *cps, 78]
    for a, b in itertools.pairwise(knots):
        t = np.arange(a, b + 1)
        slope, intercept = np.polyfit(t, k[a : b + 1], 1)
        np.testing.assert_allclose(slope * t[:, None] + intercept, k[a : b + 1], atol=1e-10)
    np.testing.assert_array_equal(ltv.find_changepoints(model), cps)


def test_order2_recovers_noise_free_piecewise_linear_data_exactly():
    rng = np.random.default_rng(19)
    N, cps = 99, [40, 70]
    knots = np.array([0, *cps, N - 1])
    values = 0.3 * rng.standard_normal((len(knots), 6))  # k at the knots
    k_true = np.stack([np.interp(np.arange(N), knots, values[:, j]) for j in range(6)], axis=1)
    x, u = simulate_exact(k_true.reshape(N, 2, 3), 20)
    model = ltv.fit_piecewise(x, u, cps, order=2)
    np.testing.assert_allclose(model.k, k_true, atol=1e-10)
    # The piecewise-constant refit cannot represent the ramps.
    assert np.abs(ltv.fit_piecewise(x, u, cps).k - k_true).max() > 0.05


# -- the paper's jump-linear system ---------------------------------------------------------


def test_jump_linear_recovers_A_with_the_true_changepoint():
    data = ltv.systems.jump_linear(seed=0)
    model = ltv.fit_piecewise(data.x, data.u, data.changepoints)
    assert model.changepoints.tolist() == [200]
    # Measurement noise (σ = 0.2 on the regressors) biases least squares slightly
    # (errors-in-variables): the errors stay below 0.11 everywhere. The penalized
    # first step smears the jump: around the switch its errors are 3x larger.
    err = np.abs(model.A - data.A)
    assert err.max() < 0.11
    first_err = np.abs(ltv.fit(data.x, data.u, lam=30.0).A - data.A)
    assert err.mean() < first_err.mean()
    assert err[190:210].mean() < first_err[190:210].mean() / 3
    # Without measurement noise the truth lies within 4 posterior standard deviations.
    clean = ltv.systems.jump_linear(seed=0, measurement_std=0.0)
    m_clean = ltv.fit_piecewise(clean.x, clean.u, [200])
    z = np.abs(m_clean.k - clean.k) / m_clean.std()
    assert z.max() < 4.0


# -- model object ---------------------------------------------------------------------------


def test_model_fields_and_save_load_roundtrip(tmp_path):
    x, u = random_data(23, 60, 2, 1)
    model = ltv.fit_piecewise(x, u, [30], order=2)
    assert model.norm == "piecewise" and np.isinf(model.lam)
    np.testing.assert_array_equal(model.coeffs, [1.0, -2.0, 1.0])
    assert model.info["solver"] == "piecewise least squares"
    assert model.cov_full().shape == (59, 6, 6)
    assert "norm='piecewise', order=2" in repr(model)
    path = tmp_path / "pw.npz"
    model.save(path)
    same = ltv.load(path)
    np.testing.assert_array_equal(same.k, model.k)
    np.testing.assert_array_equal(same.changepoints, [30])
    assert same.info["segments"] == [[0, 30], [30, 59]]
    assert ltv.fit_piecewise(x, u, [30], compute_cov=False).cov is None


def test_inputs_are_not_mutated_or_aliased():
    x, u = random_data(29, 50, 2, 1)
    cps = np.array([20])
    x0, u0 = x.copy(), u.copy()
    model = ltv.fit_piecewise(x.tolist(), u, cps)
    cps[0] = 5
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(u, u0)
    assert model.changepoints.tolist() == [20]
    same = ltv.fit_piecewise(x, u[:, 0], (20.0,))  # (T,) input, tuple of integral floats
    np.testing.assert_allclose(same.k, model.k, atol=1e-12)


# -- bad input ------------------------------------------------------------------------------


CP = r"^changepoints: "
BAD = [
    ("none", None, 1, TypeError, CP + r".*received None"),
    ("text", "abc", 1, TypeError, CP),
    ("bool", [True], 1, TypeError, CP + r"expected integers, received booleans"),
    ("float", [20.5], 1, ValueError, CP + r"expected integers, received 20.5"),
    ("nan", [np.nan], 1, ValueError, CP + r"expected finite"),
    ("2d", [[10, 20]], 1, ValueError, CP + r"expected a 1-d sequence"),
    ("zero", [0], 1, ValueError, CP + r"expected model indices in \[1, 48\]"),
    ("too-large", [49], 1, ValueError, CP + r"expected model indices in \[1, 48\].*received 49"),
    ("order2-last", [48], 2, ValueError, CP + r"expected model indices in \[1, 47\].*order=2"),
    ("unsorted", [30, 20], 1, ValueError, CP + r"expected strictly increasing.*20 after 30"),
    ("repeated", [20, 20], 1, ValueError, CP + r"expected strictly increasing.*20 after 20"),
    ("short-segment", [20, 21], 1, ValueError, CP + r"segment 1 = \[20, 21\) has 1 transition"),
    ("short-first", [2], 1, ValueError, CP + r"segment 0 = \[0, 2\) has 2 transition"),
    ("knot-unidentified", [2], 2, SingularProblemError, CP + r"the coefficients at the knot t = 0"),
    (
        "too-many-knots",
        list(range(2, 48, 3)),
        2,
        ValueError,
        CP + r"49 transitions \(with data\) cannot",
    ),
]


@pytest.mark.parametrize("case,changepoints,order,exc,match", BAD, ids=[b[0] for b in BAD])
def test_bad_changepoints_raise_naming_the_argument(case, changepoints, order, exc, match):
    x, u = random_data(31, 50, 2, 1)
    with pytest.raises(exc, match=match):
        ltv.fit_piecewise(x, u, changepoints, order=order)


@pytest.mark.parametrize(
    "order,exc,match",
    [
        (0, ValueError, r"^order: expected 1 \(piecewise constant\) or 2"),
        (-1, ValueError, r"^order:"),
        (1.0, TypeError, r"^order:"),
        (True, TypeError, r"^order:"),
        ("1", TypeError, r"^order:"),
        ([-1, 1], TypeError, r"^order:"),
        (3, NotImplementedError, r"^order=3: piecewise polynomials"),
    ],
)
def test_bad_order(order, exc, match):
    x, u = random_data(37, 40, 2, 1)
    with pytest.raises(exc, match=match):
        ltv.fit_piecewise(x, u, [20], order=order)


def test_bad_data_and_flags():
    x, u = random_data(41, 40, 2, 1)
    with pytest.raises(ValueError, match=r"^u: expected 40 rows"):
        ltv.fit_piecewise(x, u[:-1], [20])
    with pytest.raises(ValueError, match=r"^x: expected finite values or NaN"):
        ltv.fit_piecewise(np.where(np.arange(40)[:, None] == 3, np.inf, x), u, [20])
    with pytest.raises(TypeError, match=r"^compute_cov:"):
        ltv.fit_piecewise(x, u, [20], compute_cov=1)
    with pytest.raises(ValueError, match=r"^x: the data .* has 2 transition"):
        ltv.fit_piecewise(x[:3], u[:3], [])


def test_rank_deficient_segment_names_the_segment_and_the_regressor():
    x, u = random_data(43, 80, 2, 1)
    u[:40] = 0.0  # the input is silent on the first segment: its B is not identifiable
    with pytest.raises(SingularProblemError, match=r"^changepoints: segment 0 = \[0, 39\).*u0"):
        ltv.fit_piecewise(x, u, [39])
    model = ltv.fit_piecewise(x, u, [])  # over the whole record the input is excited
    assert np.isfinite(model.k).all()
    x[:, 1] = 2.0 * x[:, 0]  # collinear states everywhere
    with pytest.raises(SingularProblemError, match=r"^x: .*linearly dependent.*x0.*x1"):
        ltv.fit_piecewise(x, u, [])
    with pytest.raises(SingularProblemError, match=r"^x: the coefficients at the knot"):
        ltv.fit_piecewise(x, u, [], order=2)


def test_ill_conditioned_segment_warns():
    x, u = random_data(47, 80, 2, 1)
    # u ≈ 1e-3·x0 on the first segment: identifiable, but barely (scaled eigenvalue ~3e-9)
    u[:40] = 1e-7 * np.random.default_rng(0).standard_normal((40, 1)) + 1e-3 * x[:40, :1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ltv.IdentifiabilityWarning, match=r"^changepoints: segment 0"):
            ltv.fit_piecewise(x, u, [39])
