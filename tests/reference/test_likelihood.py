"""``LTVModel.loglik`` against dense Gaussian references.

* Without priors (diffuse initialization): the limit κ → ∞ of the proper prior
  "diffuse unknowns ~ N(0, κ), increments Σ_j c_j k_{t+j} ~ N(0, σ² W⁻¹)" plus
  (z/2)·log(2πκ), z = number of diffuse unknowns. The reference evaluates the
  limit exactly (see dense_reference.DenseProblem.loglik_kappa) and is itself
  checked against scipy's multivariate normal at finite κ.
* With priors: log N(y; Φm, σ²I + Φ H_μ⁻¹ Φᵀ) via scipy.stats.multivariate_normal.
* noise_var=None is the maximum-likelihood estimate.
"""

from __future__ import annotations

import numpy as np
import pytest
from dense_reference import DenseProblem, random_data, random_spd, simulate_ltv
from scipy.optimize import minimize, minimize_scalar

import ltvmodels as ltv

ORDERS = [1, 2, [-1, 3, -3, 1], [0.5, -1.5, 1.0], [1.0, -3.0, 2.0]]
ORDER_IDS = ["order1", "order2", "poly3", "(z-1)(z-.5)", "(z-1)(2z-1)"]


def _lam(kind, K, seed=3):
    rng = np.random.default_rng(seed)
    if kind == "scalar":
        return 1.3
    if kind == "vector":
        return rng.uniform(0.5, 3.0, K)
    if kind == "vector-inf":
        lam = rng.uniform(0.5, 3.0, K)
        lam[[1, K - 1]] = np.inf
        return lam
    G = rng.standard_normal((K, K))
    return G @ G.T / K + 0.3 * np.eye(K)


@pytest.mark.parametrize("order", [1, 2, [-1, 3, -3, 1]], ids=ORDER_IDS[:3])
@pytest.mark.parametrize("kind", ["scalar", "matrix", "vector-inf"])
def test_reference_information_form_matches_scipy(order, kind):
    """The reference's κ-likelihood (information form, closed-form log det) equals
    scipy's multivariate normal at finite κ, so its κ → ∞ limit can be trusted."""
    x, u = random_data(51, 10, 2, 1)
    ref = DenseProblem(x, u, order, _lam(kind, 6, seed=4))
    for kappa in (0.3, 1.0, 5.0):
        a = ref.loglik_kappa(kappa, 0.7)
        b = ref.loglik_kappa_covariance_form(kappa, 0.7)
        assert a == pytest.approx(b, abs=1e-7)


@pytest.mark.parametrize("order", ORDERS, ids=ORDER_IDS)
@pytest.mark.parametrize("kind", ["scalar", "vector", "matrix", "vector-inf"])
@pytest.mark.parametrize("m", [0, 1])
def test_diffuse_loglik_equals_kappa_limit(order, kind, m):
    x, u = random_data(52 + m, 22, 2, m)
    K = 2 * (2 + m)
    lam = _lam(kind, K)
    model = ltv.fit(x, u, lam=lam, order=order, noise_var=0.6)
    ref = DenseProblem(x, u, order, lam)
    assert model.loglik == pytest.approx(ref.loglik_kappa(np.inf, 0.6), abs=1e-8)
    # ... and it is the limit of proper priors
    assert model.loglik == pytest.approx(ref.loglik_kappa(1e8, 0.6), abs=1e-4)


def test_diffuse_loglik_free_coefficient():
    """λ_j = 0: every time step of that coefficient is diffuse."""
    x, _ = random_data(54, 20, 1, 0)
    model = ltv.fit(x, lam=[0.0], noise_var=0.5)
    ref = DenseProblem(x, None, 1, [0.0])
    assert model.loglik == pytest.approx(ref.loglik_kappa(np.inf, 0.5), abs=1e-8)


def test_diffuse_loglik_compares_lambdas_like_the_reference():
    """Differences of loglik between λ (what model selection uses) match."""
    x, u, _ = simulate_ltv(55, T=30, n=2, m=1)
    vals, refs = [], []
    for lam in (0.3, 3.0, 30.0):
        vals.append(ltv.fit(x, u, lam=lam, noise_var=0.02).loglik)
        refs.append(DenseProblem(x, u, 1, lam).loglik_kappa(np.inf, 0.02))
    np.testing.assert_allclose(np.diff(vals), np.diff(refs), atol=1e-8)


@pytest.mark.parametrize("order", [1, 2, [-1, 3, -3, 1]], ids=ORDER_IDS[:3])
@pytest.mark.parametrize("kind", ["scalar", "vector", "matrix", "vector-inf"])
def test_noise_var_none_is_the_ml_estimate(order, kind):
    x, u, _ = simulate_ltv(56, T=30, n=2, m=1)
    lam = _lam(kind, 6)
    model = ltv.fit(x, u, lam=lam, order=order)
    s2 = model.noise_var
    assert model.info["noise_var_estimated"] is True
    # loglik at the estimate equals loglik with the estimate given, and beats 0.8×, 1.2×
    at = ltv.fit(x, u, lam=lam, order=order, noise_var=s2)
    assert at.loglik == pytest.approx(model.loglik, rel=1e-12)
    for f in (0.8, 0.95, 1.05, 1.2):
        assert ltv.fit(x, u, lam=lam, order=order, noise_var=f * s2).loglik < model.loglik
    # independent: maximize the dense diffuse likelihood over σ² — one per
    # output where the penalty does not couple the rows, else one shared
    ref = DenseProblem(x, u, order, lam)
    if kind == "matrix" and np.any(np.abs(np.asarray(lam)) * ~np.eye(len(lam), dtype=bool)):
        assert s2[0] == s2[1]
        res = minimize(
            lambda v: -ref.loglik_kappa(np.inf, np.exp(v[0])),
            np.log(s2[:1]) + 0.3,
            method="Nelder-Mead",
            options={"xatol": 1e-10, "fatol": 1e-13},
        )
    else:
        assert s2[0] != s2[1]
        res = minimize(
            lambda v: -ref.loglik_kappa(np.inf, np.exp(v)),
            np.log(s2) + 0.3,
            method="Nelder-Mead",
            options={"xatol": 1e-10, "fatol": 1e-13},
        )
    # The likelihood is flat at its maximum (a relative change δ in σ² costs
    # ~N·δ²/2), so the optimizer's argmax is only good to ~1e-5 relative:
    # compare the likelihood values, which are good to ~1e-11.
    np.testing.assert_allclose(np.exp(res.x), s2[: res.x.size], rtol=1e-4)
    assert ref.loglik_kappa(np.inf, s2) >= -res.fun - 1e-9
    assert model.loglik == pytest.approx(-res.fun, abs=1e-7)
    # The reference's closed form σ̂² (used by the closed-form covariance tests
    # instead of the model's noise_var) is this maximizer, and equals the model's.
    closed = ref.ml_noise_var()
    np.testing.assert_allclose(np.exp(res.x), closed[: res.x.size], rtol=1e-4)
    assert ref.loglik_kappa(np.inf, closed) >= -res.fun - 1e-9
    np.testing.assert_allclose(s2, closed, rtol=1e-10)


# -- with priors: a proper Gaussian ---------------------------------------------------------------


@pytest.fixture(scope="module")
def prior_system():
    x, u, k_true = simulate_ltv(57, T=30, n=2, m=1)
    rng = np.random.default_rng(58)
    N, K = k_true.shape
    return dict(
        x=x,
        u=u,
        N=N,
        K=K,
        mu=k_true + 0.05 * rng.standard_normal(k_true.shape),
        S=random_spd(rng, K, 0.2),
        ybar=x[1:] + 0.1 * rng.standard_normal((N, 2)),
        S_out=np.stack([random_spd(rng, 2, 0.05) for _ in range(N)]),
    )


@pytest.mark.parametrize("which", ["parameter", "output", "both", "scalar-cov"])
@pytest.mark.parametrize("order, lam", [(1, 2.0), (2, "vector")], ids=["order1", "order2-vec"])
def test_loglik_with_prior_equals_dense_gaussian(prior_system, which, order, lam):
    s = prior_system
    if lam == "vector":
        lam = np.random.default_rng(1).uniform(1.0, 3.0, s["K"])
    pp, op = [], []
    if which in ("parameter", "both"):
        pp.append((s["mu"], s["S"]))
    if which == "scalar-cov":
        pp.append((s["mu"][0], 0.3))
    if which in ("output", "both"):
        op.append((s["ybar"], s["S_out"]))
    priors = [ltv.Prior(*a) for a in pp] + [ltv.OutputPrior(*a) for a in op]
    model = ltv.fit(s["x"], s["u"], lam=lam, order=order, prior=priors, noise_var=0.04)
    ref = DenseProblem(s["x"], s["u"], order, lam, sigma2=0.04, param_priors=pp, output_priors=op)
    assert model.loglik == pytest.approx(ref.loglik_with_prior(), rel=1e-9, abs=1e-9)


def test_noise_var_none_with_prior_is_the_ml_estimate(prior_system):
    s = prior_system
    prior = ltv.Prior(s["mu"], s["S"])
    model = ltv.fit(s["x"], s["u"], lam=2.0, prior=prior)
    assert model.noise_var[0] == model.noise_var[1]  # with priors: one σ² for all outputs
    s2 = float(model.noise_var[0])
    for f in (0.8, 1.2):
        assert ltv.fit(s["x"], s["u"], lam=2.0, prior=prior, noise_var=f * s2).loglik < model.loglik

    def neg(v):
        return -DenseProblem(
            s["x"], s["u"], 1, 2.0, sigma2=np.exp(v), param_priors=[(s["mu"], s["S"])]
        ).loglik_with_prior()

    res = minimize_scalar(
        neg, bounds=(np.log(s2) - 3, np.log(s2) + 3), method="bounded", options={"xatol": 1e-9}
    )
    assert np.exp(res.x) == pytest.approx(s2, rel=1e-4)
    assert model.loglik == pytest.approx(-res.fun, abs=1e-6)


@pytest.mark.parametrize("kind", ["parameter", "output"])
def test_per_output_noise_with_priors_that_do_not_couple_rows(prior_system, kind):
    """Priors per output row: each row its own σ_i², the ML estimate of the dense Gaussian."""
    s = prior_system
    if kind == "parameter":
        prior, dense = ltv.Prior(s["mu"], 0.05), dict(param_priors=[(s["mu"], 0.05)])
    else:
        cov = np.diag([0.02, 0.05])
        prior, dense = ltv.OutputPrior(s["ybar"], cov), dict(output_priors=[(s["ybar"], cov)])
    model = ltv.fit(s["x"], s["u"], lam=2.0, prior=prior)
    s2 = model.noise_var
    assert s2[0] != s2[1]
    ref = DenseProblem(s["x"], s["u"], 1, 2.0, sigma2=s2, **dense)
    k, _ = ref.solve()
    np.testing.assert_allclose(model.k, k, rtol=1e-8, atol=1e-10)
    assert model.loglik == pytest.approx(ref.loglik_with_prior(), rel=1e-9)
    # a given vector gives the same fit; and the estimate maximizes the dense likelihood
    given = ltv.fit(s["x"], s["u"], lam=2.0, prior=prior, noise_var=s2)
    assert given.loglik == pytest.approx(model.loglik, rel=1e-12)

    def neg(v):
        return -DenseProblem(s["x"], s["u"], 1, 2.0, sigma2=np.exp(v), **dense).loglik_with_prior()

    res = minimize(
        neg, np.log(s2) + 0.2, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-12}
    )
    np.testing.assert_allclose(np.exp(res.x), s2, rtol=1e-3)
    assert model.loglik >= -res.fun - 1e-7
