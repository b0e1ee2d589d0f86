"""Robust fits at the edges of their problem, and checks that catch wrong robust answers.

Edges: λ at or beyond the loss's λ_max with a sparse norm (the robust fit with
Dk = 0), a Huber threshold far below the residual scale, data the model
reproduces exactly, a threshold that is not a number. Checks: the Laplace
certificate against Clarabel (cvxpy), the robust cross-validation score
against the held-out loss computed here, the default Huber threshold against
the rule computed here.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.errors import ConvergenceWarning

cp = pytest.importorskip("cvxpy")


def _spoiled(seed, T=None):
    """The jump-linear system with 5 % of the samples hit by +5σ in one state."""
    data = ltv.systems.jump_linear(seed=seed)
    rng = np.random.default_rng(seed)
    x = data.x.copy()
    hit = rng.choice(np.arange(1, x.shape[0]), size=x.shape[0] // 20, replace=False)
    x[hit, rng.integers(0, 2, size=hit.size)] += 5 * data.noise_std
    return (x, data.u) if T is None else (x[:T], data.u[:T])


def _clarabel(x, u, lam, *, norm, loss, delta=None, order=1):
    """Optimal value and (N, K) coefficients of Σ ρ(r) + penalty (λ²Σ‖Dk‖², λΣ‖Dk‖₂ or
    λΣ|Dk|; λ = inf: Dk = 0), built from the raw data (one trajectory, no gaps)."""
    T, n = x.shape
    p = n + u.shape[1]
    N = T - 1
    k = cp.Variable((N, n * p))
    phi = np.concatenate([x[:-1], u[:-1]], axis=1)
    terms = []
    for i in range(n):
        resid = x[1:, i] - cp.sum(cp.multiply(phi, k[:, i * p : (i + 1) * p]), axis=1)
        terms.append(cp.sum(cp.huber(resid, delta[i]) if loss == "huber" else cp.abs(resid)))
    coeffs = [-1.0, 1.0] if order == 1 else [1.0, -2.0, 1.0]
    Dk = sum(c * k[j : N - len(coeffs) + 1 + j] for j, c in enumerate(coeffs))
    constraints = []
    if np.isinf(lam):
        constraints = [Dk == 0]
    elif norm == "sq":
        terms.append(lam**2 * cp.sum_squares(Dk))
    elif norm == "group":
        terms.append(lam * cp.sum(cp.norm(Dk, 2, axis=1)))
    else:
        terms.append(lam * cp.sum(cp.abs(Dk)))
    problem = cp.Problem(cp.Minimize(sum(terms)), constraints)
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    return problem.value, k.value


# -- edges --------------------------------------------------------------------------------


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("loss", ["huber", "laplace"])
@pytest.mark.parametrize("order", [1, 2])
def test_a_huge_lambda_gives_the_robust_fit_with_no_change(norm, loss, order):
    """λ = 1e8 raised "the Newton system is singular" with both robust losses, while the
    squared loss returned the LTI fit: now the robust fit with Dk = 0, Clarabel's optimum."""
    x, u = _spoiled(2, T=150)
    model = ltv.fit(x, u, lam=1e8, norm=norm, order=order, loss=loss)
    delta = np.array(model.info["huber_delta"]) if loss == "huber" else None
    optimum, k = _clarabel(x, u, np.inf, norm=norm, loss=loss, delta=delta, order=order)
    assert model.status.success and model.info["null_space_fit"]
    # Huber: the static fit's KKT residual 1e-6; Laplace: its certified gap
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-8 if loss == "huber" else 1e-6)
    if loss == "laplace":
        assert model.info["objective"] * (1 - model.info["duality_gap"]) <= optimum * (1 + 1e-9)
    np.testing.assert_allclose(model.k, k, atol=1e-6)
    assert model.changepoints.size == 0
    # at 20 × the squared loss's λ_max: found by the estimate of the loss's own λ_max
    lam_max = ltv.lambda_max(x, u, norm=norm, order=order)
    above = ltv.fit(x, u, lam=20 * lam_max, norm=norm, order=order, loss=loss, huber_delta=delta)
    assert above.info.get("null_space_fit") and above.status.success
    optimum, _ = _clarabel(x, u, 20 * lam_max, norm=norm, loss=loss, delta=delta, order=order)
    assert above.info["objective"] == pytest.approx(optimum, rel=1e-6)


def test_a_huber_threshold_far_below_the_residual_scale_is_refused():
    """huber_delta=1e-12 was accepted and then ended in a singular (or stalled) system."""
    data = ltv.systems.jump_linear(seed=0)
    for norm in ("sq", "group"):
        with pytest.raises(ValueError, match=r"^huber_delta: expected a threshold of at least "):
            ltv.fit(data.x, data.u, lam=3.0, norm=norm, loss="huber", huber_delta=1e-12)
    with pytest.raises(ValueError, match=r"received 1e-12; .* pass loss='laplace'"):
        ltv.fit_lti(data.x, data.u, loss="huber", huber_delta=[0.1, 1e-12])
    # at the bound (1e-4 × the robust scale of about 0.25) it is accepted
    model = ltv.fit(data.x, data.u, lam=3.0, loss="huber", huber_delta=1e-3)
    assert model.status.success


@pytest.mark.parametrize("norm", ["group", "l1", "sq"])
@pytest.mark.parametrize("loss", ["huber", "laplace"])
def test_data_the_model_reproduces_give_an_optimal_fit(norm, loss):
    """Noise-free LTI data: Huber + group warned "the KKT residual 8.46e+16 did not reach
    its tolerance" (the default δ, 1.345 × the scale of near-zero residuals, made the
    residual cones degenerate). The fit with no residual and Dk = 0 has objective 0, the
    minimum for every loss and norm: reported optimal, without a warning."""
    rng = np.random.default_rng(0)
    A, B = np.array([[0.9, 0.1], [-0.2, 0.8]]), np.array([[1.0], [0.5]])
    u = rng.standard_normal((200, 1))
    x = np.zeros((200, 2))
    x[0] = [1.0, 0.0]
    for t in range(199):
        x[t + 1] = A @ x[t] + B @ u[t]
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        model = ltv.fit(x, u, lam=1.0, norm=norm, loss=loss)
    assert model.status.status == "optimal" and model.info["exact_fit"]
    assert model.info["objective"] <= 1e-9  # rounding
    np.testing.assert_allclose(model.A[0], A, atol=1e-12)
    assert not model.outliers.any()


def test_a_huber_threshold_that_is_not_a_number_gets_our_message():
    """huber_delta={} raised Python's own "float() argument must be ..." TypeError."""
    x = ltv.systems.jump_linear(seed=0).x
    for value in ({}, [[0.1], [0.2, 0.3]], object()):
        with pytest.raises(ValueError, match=r"^huber_delta: expected a threshold > 0 .* received"):
            ltv.fit(x, lam=3.0, loss="huber", huber_delta=value)


# -- checks that catch wrong robust answers ------------------------------------------------


@pytest.mark.parametrize("norm, lam", [("sq", 1.0), ("group", 0.5), ("l1", 0.5)])
def test_the_laplace_certificate_is_a_lower_bound_and_never_oversold(norm, lam):
    """The certified lower bound objective · (1 − gap) is at or below Clarabel's optimum,
    for the converged fit and for one stopped after 4 steps, which is never "optimal"
    unless it is at the optimum. (A dual bound computed as value + conjugate reported
    "optimal" with gap 0 at 6.85 against an optimum of 4.00.)"""
    x, u = _spoiled(3, T=120)
    optimum, _ = _clarabel(x, u, lam, norm=norm, loss="laplace")
    for max_iter in (4, 10000):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            model = ltv.fit(x, u, lam=lam, norm=norm, loss="laplace", max_iter=max_iter)
        objective, gap = model.info["objective"], model.info["duality_gap"]
        assert objective * (1.0 - gap) <= optimum * (1.0 + 1e-9), (max_iter, objective, gap)
        assert objective >= optimum * (1.0 - 1e-9)
        if model.status.status == "optimal":
            assert objective <= optimum * (1.0 + 1e-5), (max_iter, objective, optimum)
    assert model.status.status == "optimal"  # the converged one


@pytest.mark.parametrize("loss", ["huber", "laplace"])
def test_robust_cross_validation_scores_the_held_out_robust_loss(loss):
    """The score of a candidate λ is the mean robust loss of the held-out one-step
    residuals: fold f holds out the blocks f, f + 5, … of 25 contiguous blocks; its
    fit is the fit with those transitions at weight 0 (computed here with ltv.fit)."""
    x, u = _spoiled(4, T=200)
    lam = 4.0
    selection = ltv.select_lambda(x, u, norm="group", loss=loss, lams=[lam])
    delta = None if loss == "laplace" else np.array(selection.huber_delta)
    N, n = x.shape[0] - 1, x.shape[1]
    fold = (np.arange(N) * 25 // N) % 5
    phi = np.concatenate([x[:-1], u[:-1]], axis=1)
    total = 0.0
    for f in range(5):
        held = fold == f
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            theta = ltv.fit(
                x,
                u,
                lam=lam,
                norm="group",
                loss=loss,
                huber_delta=delta,
                weights=(~held).astype(float),
                tol=1e-10,
            ).theta
        r = x[1:][held] - np.einsum("tij,tj->ti", theta[held], phi[held])
        if loss == "huber":
            a = np.abs(r)
            total += float(np.sum(np.where(a <= delta, r**2, 2 * delta * a - delta**2)))
        else:
            total += float(np.sum(np.abs(r)))
    # the folds are fitted to a CV tolerance of 1e-4: the score to a few digits
    assert selection.scores[0] == pytest.approx(total / (N * n), rel=1e-3)


@pytest.mark.parametrize("norm", ["sq", "group"])
def test_the_default_huber_threshold_is_1_345_robust_scales(norm):
    """δ_i = 1.345 × 1.4826 × MAD (about the median) of output i's residuals of the
    squared-loss fit at the same λ."""
    x, u = _spoiled(5)
    lam = 30.0 if norm == "sq" else 8.0
    squared = ltv.fit(x, u, lam=lam, norm=norm, tol=1e-10)
    r = x[1:] - np.einsum("tij,tj->ti", squared.theta, np.concatenate([x[:-1], u[:-1]], 1))
    mad = np.median(np.abs(r - np.median(r, axis=0)), axis=0)
    model = ltv.fit(x, u, lam=lam, norm=norm, loss="huber")
    # the sparse start is solved to 1e-3 (a scale needs a few digits)
    rel = 1e-12 if norm == "sq" else 1e-2
    assert model.info["huber_delta"] == pytest.approx(1.345 * 1.4826 * mad, rel=rel)
    assert model.info["huber_delta_rule"].startswith("1.345")


@pytest.mark.parametrize("norm", ["sq", "group"])
def test_a_laplace_fit_short_of_its_tolerance_names_its_solver(norm):
    """The interior-point route reports its iterations, not "0 smoothing stages"."""
    data = ltv.systems.jump_linear(T=200, change_at=100, seed=0)
    with pytest.warns(ltv.ConvergenceWarning, match="interior-point iterations") as caught:
        ltv.fit(data.x, data.u, lam=5.0, norm=norm, loss="laplace", max_iter=1)
    assert not any("smoothing stages" in str(w.message) for w in caught)
