"""GMMPrior: a Gaussian mixture of the transitions, conditioned into a Prior for fit.

References: the least-squares LTI model (fit_lti) for one component; a
switching linear system for two; the moments built by hand (dense formulas,
scipy's multivariate normal density) from the mixture's means and covariances.
"""

import numpy as np
import pytest
from scipy import stats

import ltvmodels as ltv
from ltvmodels.errors import SingularProblemError

pytest.importorskip("sklearn")

A1 = np.array([[0.9, 0.2], [-0.1, 0.8]])
B1 = np.array([[0.5], [1.0]])
A2 = np.array([[0.6, -0.3], [0.2, 0.7]])
B2 = np.array([[-0.8], [0.3]])


def regime_offsets(A, center):
    """c such that the regime's equilibrium (u = 0) is ``center``."""
    return (np.eye(2) - A) @ center


C1 = regime_offsets(A1, np.array([6.0, 6.0]))
C2 = regime_offsets(A2, np.array([-6.0, -6.0]))


def simulate(regimes, T, rng, noise=0.05):
    """A trajectory of x_{t+1} = A_{s_t} x_t + B_{s_t} u_t + c_{s_t} + v_t; regimes (T − 1,)."""
    params = {0: (A1, B1, C1), 1: (A2, B2, C2)}
    u = rng.normal(size=(T, 1))
    x = np.zeros((T, 2))
    x[0] = [6.0, 6.0] if regimes[0] == 0 else [-6.0, -6.0]
    for t in range(T - 1):
        A, B, c = params[regimes[t]]
        x[t + 1] = A @ x[t] + B @ u[t] + c + noise * rng.normal(size=2)
    return x, u


def lti_data(seed=0, T=300):
    rng = np.random.default_rng(seed)
    return simulate(np.zeros(T - 1, int), T, rng, noise=0.3)


def switching_data(seed=0, T=1200, period=200):
    rng = np.random.default_rng(seed)
    regimes = (np.arange(T - 1) // period) % 2
    x, u = simulate(regimes, T, rng)
    return x, u, regimes


@pytest.mark.parametrize("layout", ["one", "trajectories", "missing"])
def test_one_component_is_the_least_squares_lti_model_with_its_covariance(layout):
    x, u = lti_data()
    if layout == "trajectories":
        x2, u2 = lti_data(seed=1)
        x, u = np.stack([x, x2]), np.stack([u, u2])
    elif layout == "missing":
        x, u = x.copy(), u.copy()
        x[[10, 11, 57], 0] = np.nan
        u[[100, 200], 0] = np.nan
    prior = ltv.GMMPrior(x, u, n_components=1, reg_covar=0.0)
    lti = ltv.fit_lti(x, u, constant=True)
    assert prior.n_transitions == lti.info["dof"] + 4  # M = dof + p, p = n + m + 1
    at = prior.at(x, u, constant=True)
    np.testing.assert_allclose(at.mean, lti.k, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(at.cov, lti.cov, rtol=1e-8, atol=1e-14 * np.abs(lti.cov).max())
    # Without the constant: the marginal on vec([A B]) of the same Gaussian.
    keep = [0, 1, 2, 4, 5, 6]
    at0 = prior.at(x, u)
    np.testing.assert_allclose(at0.mean, lti.k[:, keep], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(
        at0.cov, lti.cov[:, keep][:, :, keep], rtol=1e-8, atol=1e-14 * np.abs(lti.cov).max()
    )
    theta = lti.k[0].reshape(2, 4)  # rows of [A B c]
    np.testing.assert_allclose(prior.A[0], theta[:, :2], rtol=1e-9)
    np.testing.assert_allclose(prior.B[0], theta[:, 2:3], rtol=1e-9)
    np.testing.assert_allclose(prior.c[0], theta[:, 3], rtol=1e-9)


def test_two_components_recover_both_regimes_and_the_prior_follows_the_switch():
    x, u, _ = switching_data()
    prior = ltv.GMMPrior(x, u, n_components=2, seed=0)
    first = int(np.argmax(prior.means[:, 0]))  # the component around (+6, +6) is regime 1
    second = 1 - first
    for comp, (A, B, c) in [(first, (A1, B1, C1)), (second, (A2, B2, C2))]:
        np.testing.assert_allclose(prior.A[comp], A, atol=0.03)
        np.testing.assert_allclose(prior.B[comp], B, atol=0.03)
        np.testing.assert_allclose(prior.c[comp], c, atol=0.25)
        assert np.all(np.linalg.eigvalsh(prior.noise_cov[comp]) < 2 * 0.05**2)
    # A new trajectory that switches once at t = 150: the prior's mean switches with it.
    rng = np.random.default_rng(7)
    regimes = (np.arange(299) >= 150).astype(int)
    xn, un = simulate(regimes, 300, rng)
    resp = prior.responsibilities(xn, un)
    assert resp.shape == (299, 2)
    truth = np.where(regimes == 0, first, second)
    assert np.mean(np.argmax(resp, axis=1) == truth) > 0.98
    at = prior.at(xn, un, constant=True)
    theta1 = np.hstack([A1, B1, C1[:, None]]).ravel()
    theta2 = np.hstack([A2, B2, C2[:, None]]).ravel()
    steady1, steady2 = slice(10, 140), slice(170, 299)
    assert np.abs(at.mean[steady1] - theta1).max() < 0.3
    assert np.abs(at.mean[steady2] - theta2).max() < 0.3
    # Precise where one regime explains the data: the spread between the regimes is absent.
    assert np.trace(at.cov[20]) < 0.01 * np.sum((theta1 - theta2) ** 2)


def hand_moments(prior, x, u, constant, weights=None, max_samples=None):
    """The prior's mean and covariance from its means/covariances by dense formulas."""
    R = x.shape[0]
    n, m = prior.n_states, prior.n_inputs
    d = n + m
    z = np.concatenate([x[:, :-1], u[:, :-1], x[:, 1:]], axis=2)
    C = prior.n_components
    thetas, Vs = [], []
    for c in range(C):
        mu, S = prior.means[c], prior.covariances[c]
        W = S[d:, :d] @ np.linalg.inv(S[:d, :d])
        b = mu[d:] - W @ mu[:d]
        noise = S[d:, d:] - W @ S[:d, d:]
        count = prior.weights[c] * prior.n_transitions
        noise_u = noise * count / (count - (d + 1))
        second = np.block(
            [[S[:d, :d] + np.outer(mu[:d], mu[:d]), mu[:d, None]], [mu[None, :d], np.ones((1, 1))]]
        )
        strength = count if max_samples is None else min(count, max_samples)
        V = np.kron(noise_u, np.linalg.inv(strength * second))
        theta = np.hstack([W, b[:, None]]).ravel()
        if not constant:
            keep = [i * (d + 1) + j for i in range(n) for j in range(d)]
            theta, V = theta[keep], V[np.ix_(keep, keep)]
        thetas.append(theta)
        Vs.append(V)
    N = z.shape[1]
    w = np.ones((R, N)) if weights is None else np.broadcast_to(weights, (R, N))
    mean = np.zeros((N, thetas[0].size))
    cov = np.zeros((N, thetas[0].size, thetas[0].size))
    for t in range(N):
        rho = np.zeros(C)
        total = 0.0
        for r in range(R):
            seen = ~np.isnan(z[r, t])
            if not seen.any():
                continue
            dens = np.array(
                [
                    prior.weights[c]
                    * stats.multivariate_normal.pdf(
                        z[r, t, seen],
                        prior.means[c, seen],
                        prior.covariances[c][np.ix_(seen, seen)],
                    )
                    for c in range(C)
                ]
            )
            rho += w[r, t] * dens / dens.sum()
            total += w[r, t]
        rho = rho / total if total > 0 else prior.weights
        mean[t] = sum(rho[c] * thetas[c] for c in range(C))
        cov[t] = sum(
            rho[c] * (Vs[c] + np.outer(thetas[c] - mean[t], thetas[c] - mean[t])) for c in range(C)
        )
    return mean, cov


@pytest.mark.parametrize("constant", [True, False])
def test_prior_and_its_effect_on_fit_equal_the_moments_built_by_hand(constant):
    x, u, _ = switching_data(T=600)
    prior = ltv.GMMPrior(x, u, n_components=3, seed=1)
    rng = np.random.default_rng(3)
    xs, us = [], []
    for r in range(2):  # two trajectories with gaps, one step missing in both
        xr, ur = simulate((np.arange(99) >= 50 + 10 * r).astype(int), 100, rng)
        xs.append(xr)
        us.append(ur)
    xb, ub = np.stack(xs), np.stack(us)
    xb[0, 20, 1] = np.nan
    ub[1, 30, 0] = np.nan
    xb[:, 70] = np.nan
    weights = np.vstack([np.ones(99), np.linspace(0.2, 1.0, 99)])
    at = prior.at(xb, ub, constant=constant, weights=weights, max_samples=40.0)
    mean, cov = hand_moments(prior, xb, ub, constant, weights, max_samples=40.0)
    np.testing.assert_allclose(at.mean, mean, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(at.cov, cov, rtol=1e-6, atol=1e-10 * np.abs(cov).max())
    model = ltv.fit(xb, ub, lam=5.0, constant=constant, weights=weights, prior=at)
    by_hand = ltv.fit(
        xb, ub, lam=5.0, constant=constant, weights=weights, prior=ltv.Prior(mean, cov)
    )
    np.testing.assert_allclose(model.k, by_hand.k, rtol=1e-6, atol=1e-8)
    # The prior moves the fit: without it the estimate differs.
    plain = ltv.fit(xb, ub, lam=5.0, constant=constant, weights=weights)
    assert np.abs(plain.k - model.k).max() > 1e-3


def test_a_step_with_nothing_observed_gets_the_mixture_marginal():
    x, u, _ = switching_data(T=600)
    prior = ltv.GMMPrior(x, u, n_components=2, seed=0)
    xn, un = x[:50].copy(), u[:50].copy()
    xn[20:22] = np.nan
    un[20] = np.nan  # transitions 19, 20 and 21 lose entries; 20 loses all of them
    resp = prior.responsibilities(xn, un)
    np.testing.assert_allclose(resp[20], prior.weights)
    assert np.all(np.isfinite(resp)) and np.allclose(resp.sum(axis=1), 1.0)
    at = prior.at(xn, un, constant=True)
    mean, _ = hand_moments(prior, xn[None], un[None], True)
    np.testing.assert_allclose(at.mean, mean, rtol=1e-7, atol=1e-9)


def test_seeded_fits_are_reproducible_and_bic_chooses_the_count():
    x, u, _ = switching_data(T=800)
    a = ltv.GMMPrior(x, u, seed=3)
    b = ltv.GMMPrior(x, u, seed=3)
    assert a.n_components == b.n_components >= 2
    np.testing.assert_array_equal(a.means, b.means)
    np.testing.assert_array_equal(a.covariances, b.covariances)
    # BIC picked the smallest value among the counts it tried.
    for count in range(1, 5):
        other = ltv.GMMPrior(x, u, n_components=count, seed=3)
        assert a.bic <= other.bic + 1e-6
    gen = ltv.GMMPrior(x, u, seed=np.random.default_rng(3))
    assert gen.n_components >= 2
    assert "n_components=" in repr(a)


def test_update_continues_em_from_the_previous_mixture():
    x, u, _ = switching_data(T=1200)
    prior = ltv.GMMPrior(x[:400], u[:400], n_components=2, seed=0)
    before = prior.mixture
    prior_means = prior.means.copy()
    returned = prior.update(x[400:], u[400:])
    assert returned is prior
    assert prior.n_transitions == 399 + 799
    assert prior.mixture is not before  # the previous mixture is left as it was
    np.testing.assert_array_equal(before.means_ * prior._scale + prior._center, prior_means)
    # EM from a warm start never lowers the likelihood of the pooled data.
    pooled = (prior._points - prior._center) / prior._scale
    assert prior.mixture.score(pooled) >= before.score(pooled) - 1e-12
    # With the count chosen by BIC, one more component is tried and kept only if better.
    grown = ltv.GMMPrior(x[:300], u[:300], max_components=1, seed=0)
    assert grown.n_components == 1
    grown._max_components = 3  # let it grow: the switching data need two components
    grown.update(x[300:], u[300:])
    assert grown.n_components == 2


def test_invalid_arguments_name_the_argument():
    x, u = lti_data()
    with pytest.raises(ValueError, match="x: expected more than 5 complete transitions"):
        ltv.GMMPrior(x[:6], u[:6])  # z = (x_t, u_t, x_{t+1}) has 5 entries
    with pytest.raises(ValueError, match="n_components: expected at most 3"):
        ltv.GMMPrior(x[:20], u[:20], n_components=4)
    with pytest.raises(ValueError, match="n_components: expected an integer >= 1"):
        ltv.GMMPrior(x, u, n_components=0)
    with pytest.raises(ValueError, match="reg_covar: expected a finite real number >= 0"):
        ltv.GMMPrior(x, u, reg_covar=-1.0)
    with pytest.raises(TypeError, match="seed: expected"):
        ltv.GMMPrior(x, u, seed="a")
    prior = ltv.GMMPrior(x, u, n_components=1)
    with pytest.raises(ValueError, match="x: expected 2 states"):
        prior.at(x[:, :1], u)
    with pytest.raises(ValueError, match="u: expected 1 inputs"):
        prior.at(x, None)
    with pytest.raises(ValueError, match="max_samples: expected a finite real number > 0"):
        prior.at(x, u, max_samples=-1.0)
    with pytest.raises(ValueError, match=r"weights: expected shape \(299,\)"):
        prior.at(x, u, weights=np.ones(3))
    with pytest.raises(ValueError, match="x: expected at least one complete transition"):
        prior.update(np.where(np.arange(5)[:, None] % 2, np.nan, 1.0) * np.ones((5, 2)), u[:5])
    # A prior for the wrong structure is rejected by fit, naming the prior.
    with pytest.raises(ValueError, match="prior.mean"):
        ltv.fit(x, u, lam=1.0, prior=prior.at(x, u, constant=True))


def test_a_constant_input_needs_regularization():
    x, u = lti_data()
    u = np.ones_like(u)
    with pytest.raises(SingularProblemError, match="reg_covar > 0"):
        ltv.GMMPrior(x, u, n_components=1, reg_covar=0.0)
    # With the default regularization the input's coefficient gets a broad prior.
    prior = ltv.GMMPrior(x, u, n_components=1)
    at = prior.at(x, u)
    variances = np.diagonal(at.cov[0])
    assert variances[2] > 1e3 * variances[0]  # B's entries (column 2 of [A B]) are open
