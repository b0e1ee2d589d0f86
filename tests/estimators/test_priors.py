"""Priors (paper Section IV).

* ``prior_mode="exact"`` equals the dense MAP estimate of eq:prioropt, with the
  prior weighted by the noise variance σ²: H = Φ̃ᵀΦ̃ + D̃ᵀW̃D̃ + σ² blkdiag(Σ_t⁻¹);
* ``prior_mode="posthoc"`` equals the paper's correction eq:postk–eq:postcov
  applied by hand to the prior-free model's k and cov_full();
* ``OutputPrior`` equals its dense reference (the prior as a measurement of Θ_t φ_t);
* a tight prior at the truth reduces the error at every time step;
* a prior makes a poorly excited problem solvable, with a warning.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from dense_reference import DenseProblem, diag_blocks, random_spd, relerr, simulate_ltv

import ltvmodels as ltv

TOL = 1e-8
SIGMA2 = 0.05


@pytest.fixture(scope="module")
def system():
    x, u, k_true = simulate_ltv(41, T=40, n=2, m=1)
    rng = np.random.default_rng(42)
    N, K = k_true.shape
    return dict(
        x=x,
        u=u,
        k_true=k_true,
        N=N,
        K=K,
        mu=k_true + 0.05 * rng.standard_normal(k_true.shape),
        cov_t=np.stack([random_spd(rng, K, 0.1) for _ in range(N)]),
        cov_m=random_spd(rng, K, 0.3),
        ybar=x[1:] + 0.1 * rng.standard_normal((N, 2)),
        S_t=np.stack([random_spd(rng, 2, 0.05) for _ in range(N)]),
        S_m=random_spd(rng, 2, 0.1),
    )


def _prior(system, mean_kind, cov_kind):
    mean = system["mu"] if mean_kind == "N,K" else system["mu"][3]
    cov = {"scalar": 0.2, "K,K": system["cov_m"], "N,K,K": system["cov_t"]}[cov_kind]
    return mean, cov


@pytest.mark.parametrize(
    "cov_kind",
    ["scalar", "K,K", "N,K,K"],
)
@pytest.mark.parametrize("mean_kind", ["K", "N,K"])
@pytest.mark.parametrize("order, lam", [(1, 2.0), (2, "vector")], ids=["order1", "order2-vec"])
def test_exact_prior_equals_dense_map(system, cov_kind, mean_kind, order, lam):
    if lam == "vector":
        lam = np.random.default_rng(0).uniform(1.0, 3.0, system["K"])
    mean, cov = _prior(system, mean_kind, cov_kind)
    model = ltv.fit(
        system["x"], system["u"], lam=lam, order=order, prior=ltv.Prior(mean, cov), noise_var=SIGMA2
    )
    ref = DenseProblem(
        system["x"], system["u"], order, lam, sigma2=SIGMA2, param_priors=[(mean, cov)]
    )
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < TOL
    assert relerr(model.cov_full(), SIGMA2 * diag_blocks(H_inv, system["N"], system["K"])) < TOL
    assert np.all(model.noise_var == SIGMA2)
    assert model.info["objective"] == pytest.approx(ref.objective(k), rel=1e-9)


def test_exact_prior_time_varying_cov_with_model_mean(system):
    """Prior mean given as an LTVModel and (N, K, K) covariances."""
    x, u = system["x"], system["u"]
    mean_model = ltv.fit(x, u, lam=5.0)
    model = ltv.fit(x, u, lam=2.0, prior=ltv.Prior(mean_model, system["cov_t"]), noise_var=SIGMA2)
    ref = DenseProblem(
        x, u, 1, 2.0, sigma2=SIGMA2, param_priors=[(np.array(mean_model.k), system["cov_t"])]
    )
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < TOL
    assert relerr(model.cov_full(), SIGMA2 * diag_blocks(H_inv, system["N"], system["K"])) < TOL


def test_prior_mean_as_model_equals_its_k(system):
    x, u = system["x"], system["u"]
    mean_model = ltv.fit(x, u, lam=5.0, order=2)
    a = ltv.fit(x, u, lam=2.0, prior=ltv.Prior(mean_model, system["cov_m"]), noise_var=SIGMA2)
    b = ltv.fit(
        x, u, lam=2.0, prior=ltv.Prior(np.array(mean_model.k), system["cov_m"]), noise_var=SIGMA2
    )
    np.testing.assert_array_equal(a.k, b.k)
    ref = DenseProblem(
        x, u, 1, 2.0, sigma2=SIGMA2, param_priors=[(np.array(mean_model.k), system["cov_m"])]
    )
    assert relerr(a.k, ref.solve()[0]) < TOL


@pytest.mark.parametrize("mean_kind", ["n", "N,n"])
@pytest.mark.parametrize("cov_kind", ["scalar", "n,n", "N,n,n"])
def test_output_prior_equals_dense_map(system, mean_kind, cov_kind):
    mean = system["ybar"] if mean_kind == "N,n" else system["ybar"][0]
    cov = {"scalar": 0.05, "n,n": system["S_m"], "N,n,n": system["S_t"]}[cov_kind]
    x, u = system["x"], system["u"]
    model = ltv.fit(x, u, lam=2.0, prior=ltv.OutputPrior(mean, cov), noise_var=SIGMA2)
    ref = DenseProblem(x, u, 1, 2.0, sigma2=SIGMA2, output_priors=[(mean, cov)])
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < TOL
    assert relerr(model.cov_full(), SIGMA2 * diag_blocks(H_inv, system["N"], system["K"])) < TOL


def test_parameter_and_output_priors_together(system):
    x, u = system["x"], system["u"]
    priors = [
        ltv.Prior(system["mu"], system["cov_m"]),
        ltv.OutputPrior(system["ybar"], system["S_t"]),
    ]
    model = ltv.fit(x, u, lam=2.0, order=2, prior=priors, noise_var=SIGMA2)
    ref = DenseProblem(
        x,
        u,
        2,
        2.0,
        sigma2=SIGMA2,
        param_priors=[(system["mu"], system["cov_m"])],
        output_priors=[(system["ybar"], system["S_t"])],
    )
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < TOL
    assert relerr(model.cov_full(), SIGMA2 * diag_blocks(H_inv, system["N"], system["K"])) < TOL
    # a tuple of priors is the same as a list
    model2 = ltv.fit(x, u, lam=2.0, order=2, prior=tuple(priors), noise_var=SIGMA2)
    np.testing.assert_array_equal(model2.k, model.k)


def test_tight_prior_at_truth_reduces_error_at_every_step(ltv_data):
    x, u, k_true = ltv_data
    free = ltv.fit(x, u, lam=3.0, noise_var=0.01)
    tight = ltv.fit(x, u, lam=3.0, noise_var=0.01, prior=ltv.Prior(k_true, 1e-6))
    err_free = np.linalg.norm(free.k - k_true, axis=1)
    err_tight = np.linalg.norm(tight.k - k_true, axis=1)
    assert np.all(err_tight < err_free)
    assert err_tight.max() < 0.05 * err_free.min() + 1e-3
    # the posterior is tighter too
    assert np.all(tight.std() < free.std())


# -- posthoc mode: eq:postk–eq:postcov by hand ------------------------------------------------


def _posthoc_by_hand(k, P, mean, cov, M=None):
    """k̄ = k + K̄(z − Mk), P̄ = P − K̄MP, K̄ = PMᵀ(MPMᵀ + R)⁻¹, per time step."""
    N, K = k.shape
    k_new, P_new = np.empty_like(k), np.empty_like(P)
    for t in range(N):
        Mt = np.eye(K) if M is None else M[t]
        Rt = cov[t] if cov.ndim == 3 else cov
        gain = P[t] @ Mt.T @ np.linalg.inv(Mt @ P[t] @ Mt.T + Rt)
        zt = mean[t] if mean.ndim == 2 else mean
        k_new[t] = k[t] + gain @ (zt - Mt @ k[t])
        P_new[t] = P[t] - gain @ Mt @ P[t]
    return k_new, P_new


@pytest.mark.parametrize("cov_kind", ["K,K", "N,K,K"])
@pytest.mark.parametrize("order", [1, 2])
def test_posthoc_equals_paper_correction(system, cov_kind, order):
    x, u = system["x"], system["u"]
    cov = system["cov_m"] if cov_kind == "K,K" else system["cov_t"]
    base = ltv.fit(x, u, lam=2.0, order=order, noise_var=SIGMA2)
    k_ref, P_ref = _posthoc_by_hand(np.array(base.k), base.cov_full(), system["mu"], cov)
    model = ltv.fit(
        x,
        u,
        lam=2.0,
        order=order,
        prior=ltv.Prior(system["mu"], cov),
        prior_mode="posthoc",
        noise_var=SIGMA2,
    )
    assert relerr(model.k, k_ref) < TOL
    assert relerr(model.cov_full(), P_ref) < TOL
    assert model.loglik is None and "posthoc" in model.info["loglik_note"]
    # posthoc is a different estimator than the exact MAP
    exact = ltv.fit(
        x, u, lam=2.0, order=order, prior=ltv.Prior(system["mu"], system["cov_m"]), noise_var=SIGMA2
    )
    if cov_kind == "K,K":
        assert relerr(model.k, exact.k) > 1e-4


def test_posthoc_two_priors_applied_in_sequence(system):
    x, u = system["x"], system["u"]
    N = system["N"]
    base = ltv.fit(x, u, lam=2.0, noise_var=SIGMA2)
    phi = np.hstack([x[:-1], u[:-1]])
    M_out = np.stack([np.kron(np.eye(2), phi[t]) for t in range(N)])  # I_n ⊗ φ_tᵀ
    k1, P1 = _posthoc_by_hand(np.array(base.k), base.cov_full(), system["mu"], system["cov_m"])
    k2, P2 = _posthoc_by_hand(k1, P1, system["ybar"], system["S_t"], M=M_out)
    model = ltv.fit(
        x,
        u,
        lam=2.0,
        noise_var=SIGMA2,
        prior_mode="posthoc",
        prior=[
            ltv.Prior(system["mu"], system["cov_m"]),
            ltv.OutputPrior(system["ybar"], system["S_t"]),
        ],
    )
    assert relerr(model.k, k2) < TOL
    assert relerr(model.cov_full(), P2) < TOL


def test_posthoc_noise_var_is_the_prior_free_estimate(system):
    x, u = system["x"], system["u"]
    base = ltv.fit(x, u, lam=2.0)
    model = ltv.fit(
        x, u, lam=2.0, prior=ltv.Prior(system["mu"], system["cov_m"]), prior_mode="posthoc"
    )
    assert model.noise_var == pytest.approx(base.noise_var, rel=1e-12)
    k_ref, P_ref = _posthoc_by_hand(
        np.array(base.k), base.cov_full(), system["mu"], system["cov_m"]
    )
    assert relerr(model.k, k_ref) < TOL


# -- poorly excited systems -------------------------------------------------------------------


def _unexcited(T=40):
    rng = np.random.default_rng(43)
    x = np.zeros((T, 1))
    x[0] = 1.0
    for t in range(T - 1):
        x[t + 1] = 0.8 * x[t] + 0.3 * rng.standard_normal()
    return x, np.zeros((T, 1))


def test_unexcited_input_raises_without_prior():
    x, u = _unexcited()
    with pytest.raises(ltv.SingularProblemError, match="Proposition 2") as info:
        ltv.fit(x, u, lam=1.0)
    assert "u0" in str(info.value)
    assert isinstance(info.value, ValueError)  # SingularProblemError is a LinAlgError/ValueError


def test_unexcited_input_with_prior_warns_and_uses_prior():
    x, u = _unexcited()
    mean, cov = np.array([0.3, 0.7]), np.diag([1.0, 0.5])
    with pytest.warns(ltv.IdentifiabilityWarning, match="Proposition 2"):
        model = ltv.fit(x, u, lam=1.0, prior=ltv.Prior(mean, cov), noise_var=0.09)
    # The data say nothing about B: its MAP is the prior mean (diagonal prior cov).
    np.testing.assert_allclose(model.B[:, 0, 0], 0.7, rtol=1e-10)
    ref = DenseProblem(x, u, 1, 1.0, sigma2=0.09, param_priors=[(mean, cov)])
    k, H_inv = ref.solve()
    assert relerr(model.k, k) < TOL
    assert relerr(model.cov_full(), 0.09 * diag_blocks(H_inv, 39, 2)) < TOL
    assert model.loglik == pytest.approx(ref.loglik_with_prior(), rel=1e-9)
    # and with the noise variance estimated
    with pytest.warns(ltv.IdentifiabilityWarning):
        est = ltv.fit(x, u, lam=1.0, prior=ltv.Prior(mean, cov))
    assert np.isfinite(est.noise_var) and est.noise_var > 0 and np.isfinite(est.loglik)
    np.testing.assert_allclose(est.B[:, 0, 0], 0.7, rtol=1e-10)


def test_well_excited_data_with_prior_do_not_warn(system):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ltv.fit(
            system["x"], system["u"], lam=2.0, prior=ltv.Prior(system["mu"], 0.1), noise_var=SIGMA2
        )


@pytest.mark.parametrize("order", [1, 2])
def test_priors_with_constant_coefficients(system, order):
    """λ_j = inf (shared unknowns) together with parameter and output priors."""
    x, u, K = system["x"], system["u"], system["K"]
    lam = np.random.default_rng(5).uniform(0.5, 2.0, K)
    lam[[1, 4]] = np.inf
    pp = [(system["mu"], system["cov_m"])]
    op = [(system["ybar"], system["S_m"])]
    for pp_, op_ in ((pp, []), ([], op), (pp, op)):
        priors = [ltv.Prior(*a) for a in pp_] + [ltv.OutputPrior(*a) for a in op_]
        model = ltv.fit(x, u, lam=lam, order=order, prior=priors, noise_var=SIGMA2)
        ref = DenseProblem(x, u, order, lam, sigma2=SIGMA2, param_priors=pp_, output_priors=op_)
        k, H_inv = ref.solve()
        assert relerr(model.k, k) < TOL
        assert relerr(model.cov_full(), SIGMA2 * diag_blocks(H_inv, system["N"], K)) < TOL
        assert model.loglik == pytest.approx(ref.loglik_with_prior(), rel=1e-9)
        assert np.ptp(model.k[:, [1, 4]], axis=0).max() == 0.0


def test_posthoc_without_covariances_gives_same_estimate(system):
    x, u = system["x"], system["u"]
    prior = ltv.Prior(system["mu"], system["cov_m"])
    a = ltv.fit(x, u, lam=2.0, prior=prior, prior_mode="posthoc", compute_cov=False)
    b = ltv.fit(x, u, lam=2.0, prior=prior, prior_mode="posthoc")
    assert a.cov is None
    np.testing.assert_array_equal(a.k, b.k)


def test_output_prior_noise_var_is_the_ml_estimate(system):
    x, u = system["x"], system["u"]
    prior = ltv.OutputPrior(system["ybar"], system["S_m"])
    model = ltv.fit(x, u, lam=2.0, prior=prior)
    assert model.noise_var[0] == model.noise_var[1]  # with priors: one σ² for all outputs
    s2 = float(model.noise_var[0])
    assert np.isfinite(model.loglik)
    for f in (0.8, 1.2):
        assert ltv.fit(x, u, lam=2.0, prior=prior, noise_var=f * s2).loglik < model.loglik
    ref = DenseProblem(x, u, 1, 2.0, sigma2=s2, output_priors=[(system["ybar"], system["S_m"])])
    assert model.loglik == pytest.approx(ref.loglik_with_prior(), rel=1e-9)
