"""``loss="huber"`` and ``loss="laplace"`` against cvxpy + Clarabel (``cp.huber``,
``cp.abs``), and their limits.

The objectives Σ w h_δ(r) or Σ w|r| plus the penalty of each norm are built in
cvxpy from the raw data (trajectories, NaN rows dropped, weights),
independently of the package.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ltvmodels as ltv

cp = pytest.importorskip("cvxpy")


def _data(seed, R=2, T=40, n=2, m=1):
    rng = np.random.default_rng(seed)
    x = np.zeros((R, T, n))
    x[:, 0] = rng.standard_normal((R, n))
    u = rng.standard_normal((R, T, m))
    A = np.array([[0.6, 0.2], [-0.1, 0.5]])[:n, :n]
    B = rng.standard_normal((n, m))
    for t in range(T - 1):
        x[:, t + 1] = x[:, t] @ A.T + u[:, t] @ B.T + 0.1 * rng.standard_normal((R, n))
    x[0, 12, 0] += 3.0  # gross outliers
    x[1, 25, 1] -= 4.0
    x[0, 30] = np.nan  # a missing sample
    weights = rng.uniform(0.5, 2.0, (R, T - 1))
    weights[1, 5] = 0.0
    return x, u, weights


def _cvxpy_huber(x, u, weights, lam, coeffs, delta):
    """Optimal value and (N, K) coefficients of the Huber problem with λ²‖Dk‖², from scratch."""
    return _cvxpy_reference(x, u, weights, lam, coeffs, norm="sq", loss="huber", delta=delta)


def _cvxpy_reference(x, u, weights, lam, coeffs, *, norm, loss, delta=None):
    """Optimal value and (N, K) coefficients of a robust-loss problem, built from the raw data.

    Loss Σ w h_δ(r) (``cp.huber``) or Σ w|r| (``cp.abs``) over the observed
    entries; penalty λ² Σ‖Dk‖² ("sq", λ = inf: LTI), λ Σ_t‖(Dk)_t‖₂ ("group")
    or λ Σ|Dk| ("l1").
    """
    R, T, n = x.shape
    p = n + u.shape[2]
    N, K = T - 1, n * p
    k = cp.Variable((N, K))
    rows, targets, phis, row_weights = [], [], [], []
    for r in range(R):
        for t in range(N):
            phi = np.concatenate([x[r, t], u[r, t]])
            if (
                weights[r, t] == 0
                or not np.all(np.isfinite(phi))
                or not np.all(np.isfinite(x[r, t + 1]))
            ):
                continue
            rows.append(t)
            targets.append(x[r, t + 1])
            phis.append(phi)
            row_weights.append(weights[r, t])
    rows, targets, phis = np.array(rows), np.array(targets), np.array(phis)
    row_weights = np.array(row_weights)
    terms = []
    for i in range(n):
        fitted = cp.sum(cp.multiply(phis, k[rows, i * p : (i + 1) * p]), axis=1)
        resid = targets[:, i] - fitted
        entry = cp.huber(resid, delta[i]) if loss == "huber" else cp.abs(resid)
        terms.append(row_weights @ entry)
    d = len(coeffs) - 1
    Dk = sum(c * k[j : N - d + j] for j, c in enumerate(coeffs))
    constraints = []
    if norm == "sq" and not np.all(np.isfinite(lam)):
        constraints = [k[1:] == k[:-1]]  # LTI
    elif norm == "sq":
        terms.append(lam**2 * cp.sum_squares(Dk))
    else:
        weights = np.broadcast_to(np.asarray(lam, dtype=float), (K,))
        held = ~np.isfinite(weights)  # coefficients constant in time
        constraints = [k[1:, j] == k[:-1, j] for j in np.flatnonzero(held)]
        scaled = cp.multiply(Dk[:, ~held], np.tile(weights[~held], (N - d, 1)))
        terms.append(
            cp.sum(cp.norm(scaled, 2, axis=1)) if norm == "group" else cp.sum(cp.abs(scaled))
        )
    problem = cp.Problem(cp.Minimize(sum(terms)), constraints)
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-9, tol_gap_rel=1e-9, tol_feas=1e-9)
    return problem.value, k.value


@pytest.mark.parametrize("order, coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_huber_matches_clarabel_with_missing_samples_and_weights(order, coeffs):
    x, u, w = _data(order)
    delta = np.array([0.15, 0.25])
    model = ltv.fit(
        x, u, lam=3.0, order=order, weights=w, loss="huber", huber_delta=delta, tol=1e-11
    )
    optimum, k = _cvxpy_huber(x, u, w, 3.0, np.array(coeffs), delta)
    assert model.status.success and model.info["kkt_residual"] <= 1e-11
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-8)
    np.testing.assert_allclose(model.k, k, atol=1e-6)
    # Huber's linear region: the residuals beyond δ, in the units of x
    resid = x[:, 1:] - np.einsum(
        "tij,rtj->rti", model.theta, np.concatenate([x[:, :-1], u[:, :-1]], axis=2)
    )
    observed = np.isfinite(resid) & (w > 0)[:, :, None]
    expected = observed & (np.abs(np.nan_to_num(resid)) > delta)
    np.testing.assert_array_equal(model.beyond_delta, expected)
    assert model.beyond_delta[0, 11, 0] and model.beyond_delta[1, 24, 1]  # the planted ones
    assert model.outliers[0, 11, 0] and model.outliers[1, 24, 1]  # outliers too
    assert model.info["n_beyond_delta"] == expected.sum() and model.loglik is None


def test_huber_lti_matches_clarabel():
    x, u, w = _data(3)
    delta = np.array([0.2, 0.2])
    model = ltv.fit_lti(x, u, weights=w, loss="huber", huber_delta=0.2)
    optimum, k = _cvxpy_huber(x, u, w, np.inf, np.array([-1.0, 1.0]), delta)
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-8)
    np.testing.assert_allclose(model.k, k, atol=1e-6)
    assert np.ptp(model.k, axis=0).max() == 0.0  # constant in time


def test_delta_beyond_every_residual_is_the_squared_loss_fit():
    x, u, w = _data(4)
    squared = ltv.fit(x, u, lam=2.0, weights=w)
    huber = ltv.fit(x, u, lam=2.0, weights=w, loss="huber", huber_delta=1e6)
    np.testing.assert_allclose(huber.k, squared.k, rtol=0, atol=1e-12)
    assert huber.info["n_beyond_delta"] == 0 and huber.status.iterations == 0


def test_regression_and_ar_front_ends_use_per_output_thresholds():
    rng = np.random.default_rng(5)
    phi = rng.standard_normal((80, 2))
    y = phi @ np.array([[1.0, -0.5], [0.3, 0.8]]).T + 0.05 * rng.standard_normal((80, 2))
    y[10] += [2.0, -3.0]
    model = ltv.fit_regression(y, phi, lam=10.0, loss="huber", huber_delta=[0.1, 0.2], tol=1e-11)
    assert model.beyond_delta.shape == (80, 2) and model.beyond_delta[10].all()
    assert model.outliers[10].all() and model.outliers.sum() <= 4  # 160 entries
    assert model.info["huber_delta"] == [0.1, 0.2]
    ar = ltv.fit_ar(y[:, 0], 2, lam=10.0, loss="huber")
    assert ar.info["huber_delta_rule"].startswith("1.345") and ar.beyond_delta.shape == (78, 1)


def test_huber_resists_gross_outliers_on_the_jump_linear_system():
    """5 % of the samples hit by +5σ outliers in one state (σ: that state's std).

    An outlier in x[t] is also a regressor of the next transition (a leverage
    point, which no loss of the residual can discount), so the gain is
    smaller than for outliers in y alone (next test): measured RMS coefficient
    error 0.152 (Huber) against 0.249 (squared) relative to the clean fit.
    """
    data = ltv.systems.jump_linear(seed=0)
    rng = np.random.default_rng(0)
    clean = ltv.fit(data.x, data.u, lam=30.0).theta
    x = data.x.copy()
    hit = rng.choice(x.shape[0], size=x.shape[0] // 20, replace=False)
    state = rng.integers(0, 2, size=hit.size)
    x[hit, state] += 5 * np.std(data.x, axis=0)[state]
    errors = {
        loss: np.sqrt(np.mean((ltv.fit(x, data.u, lam=30.0, loss=loss).theta - clean) ** 2))
        for loss in ("squared", "huber")
    }
    assert errors["huber"] < 0.7 * errors["squared"], errors


def test_huber_discounts_output_outliers_of_a_regression():
    rng = np.random.default_rng(8)
    phi = rng.standard_normal((400, 2))
    slope = np.where(np.arange(400) < 200, 1.0, -1.0)
    y = slope * phi[:, 0] + 0.5 * phi[:, 1] + 0.1 * rng.standard_normal(400)
    clean = ltv.fit_regression(y, phi, lam=30.0).theta
    spoiled = y.copy()
    hit = rng.choice(400, size=20, replace=False)
    spoiled[hit] += 5.0 * np.std(y)
    errors = {
        loss: np.sqrt(
            np.mean((ltv.fit_regression(spoiled, phi, lam=30.0, loss=loss).theta - clean) ** 2)
        )
        for loss in ("squared", "huber")
    }
    assert errors["huber"] < 0.5 * errors["squared"], errors  # measured 0.055 vs 0.144


def test_robust_options_are_validated():
    x, u, _ = _data(6)
    x = x[0]
    with pytest.raises(ValueError, match=r"^loss: expected one of"):
        ltv.fit(x, u[0], lam=1.0, loss="cauchy")
    with pytest.raises(ValueError, match=r"^huber_delta: applies to loss='huber' only"):
        ltv.fit(x, u[0], lam=1.0, huber_delta=1.0)
    with pytest.raises(ValueError, match=r"^huber_delta: applies to loss='huber' only"):
        ltv.fit(x, u[0], lam=1.0, loss="laplace", huber_delta=1.0)
    with pytest.raises(ValueError, match=r"^huber_delta: expected a threshold > 0"):
        ltv.fit(x, u[0], lam=1.0, loss="huber", huber_delta=[1.0, -1.0])
    with pytest.raises(NotImplementedError, match=r"^noise_var: not available with loss='laplace'"):
        ltv.fit(x, u[0], lam=1.0, norm="group", loss="laplace", noise_var=1.0)


def test_outliers_survive_save_and_load(tmp_path):
    x, u, w = _data(7)
    model = ltv.fit(x, u, lam=3.0, weights=w, loss="huber")
    model.save(tmp_path / "huber.npz")
    loaded = ltv.load(tmp_path / "huber.npz")
    np.testing.assert_array_equal(loaded.outliers, model.outliers)
    np.testing.assert_array_equal(loaded.beyond_delta, model.beyond_delta)
    assert loaded.info["huber_delta"] == model.info["huber_delta"]


def test_segments_keep_the_squared_loss_and_the_cli_takes_huber(tmp_path, capsys):
    x, u, _ = _data(9)
    with pytest.raises(ValueError, match=r"^loss: fit_segments uses the squared loss only"):
        ltv.fit_segments(x[0], u[0], n_changes=1, loss="huber")
    from ltvmodels.cli import main

    path = tmp_path / "data.csv"
    np.savetxt(path, np.c_[x[1], u[1]], delimiter=",", header="x1,x2,u1", comments="")
    code = main(
        [
            "fit",
            str(path),
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--lam",
            "3",
            "--loss",
            "huber",
            "--huber-delta",
            "0.2",
            "--json",
        ]
    )
    report = __import__("json").loads(capsys.readouterr().out)
    assert code == 0 and report["loss"] == "huber" and report["huber_delta"] == [0.2, 0.2]
    assert report["n_beyond_delta"] >= 1 and report["n_outliers"] >= 1  # the planted -4 in x2


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order, coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_sparse_huber_matches_clarabel(norm, order, coeffs):
    x, u, w = _data(10 + order)
    delta = np.array([0.15, 0.25])
    model = ltv.fit(
        x, u, lam=0.5, norm=norm, order=order, weights=w, loss="huber", huber_delta=delta, tol=1e-10
    )
    optimum, k = _cvxpy_reference(
        x, u, w, 0.5, np.array(coeffs), norm=norm, loss="huber", delta=delta
    )
    assert model.status.success and model.info["kkt_residual"] <= 1e-10
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-7)
    np.testing.assert_allclose(model.k, k, atol=1e-4)
    assert model.beyond_delta[1, 24, 1]
    assert model.beyond_delta.sum() == model.info["n_beyond_delta"]
    assert model.changepoints is not None and model.loglik is None


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_sparse_huber_with_delta_beyond_every_residual_is_the_squared_loss_fit(norm):
    x, u, w = _data(12)
    squared = ltv.fit(x, u, lam=0.5, norm=norm, weights=w, tol=1e-10)
    huber = ltv.fit(x, u, lam=0.5, norm=norm, weights=w, loss="huber", huber_delta=1e6, tol=1e-10)
    # both solved to the tolerance: the same optimum
    assert huber.info["objective"] == pytest.approx(squared.info["objective"], rel=1e-9)
    np.testing.assert_allclose(huber.k, squared.k, rtol=0, atol=1e-5)
    assert huber.info["n_beyond_delta"] == 0


@pytest.mark.parametrize("norm, lam", [("sq", 1.0), ("group", 0.5), ("l1", 0.5)])
@pytest.mark.parametrize("order, coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_laplace_matches_clarabel_and_its_certificate_holds(norm, lam, order, coeffs):
    x, u, w = _data(20 + order)
    tol = 1e-9
    model = ltv.fit(x, u, lam=lam, norm=norm, order=order, weights=w, loss="laplace", tol=tol)
    optimum, _ = _cvxpy_reference(x, u, w, lam, np.array(coeffs), norm=norm, loss="laplace")
    assert model.status.success and model.info["loss"] == "laplace"
    gap = model.info["duality_gap"]
    assert gap <= tol
    # the certificate is honest: the true suboptimality is within the reported gap (up to
    # the reference's own accuracy, 1e-9)
    excess = (model.info["objective"] - optimum) / optimum
    assert -1e-8 <= excess <= gap + 1e-8, (excess, gap)
    assert model.beyond_delta is None and model.loglik is None


def _wide_data(seed, T=40, n=4, m=2):
    """One trajectory of a random stable system with n(n + m) = 24 coefficients per step,
    a gross outlier, a missing sample and sample weights."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 0.8 / np.abs(np.linalg.eigvals(A)).max()
    B = rng.standard_normal((n, m))
    x = np.zeros((1, T, n))
    u = rng.standard_normal((1, T, m))
    for t in range(T - 1):
        x[0, t + 1] = A @ x[0, t] + B @ u[0, t] + 0.1 * rng.standard_normal(n)
    x[0, 12, 0] += 3.0
    x[0, 30] = np.nan
    return x, u, rng.uniform(0.5, 2.0, (1, T - 1))


@pytest.mark.parametrize("loss", ["huber", "laplace"])
@pytest.mark.parametrize("order, coeffs", [(1, [-1.0, 1.0]), (2, [1.0, -2.0, 1.0])])
def test_group_robust_fits_of_wide_steps_take_the_interior_point(loss, order, coeffs):
    """24 coefficients per step in one group (wide Newton blocks): the interior point with
    residual cones, certified at 1e-9, at Clarabel's optimum. (Laplace took Huber
    smoothing beyond 20 coefficients before, 21-150 s at T = 400; and the blocks'
    explicit inverses of order 1 stalled here short of 1e-9.)"""
    x, u, w = _wide_data(30 + order)
    delta = np.full(4, 0.2)
    options = {"huber_delta": delta} if loss == "huber" else {}
    model = ltv.fit(
        x, u, lam=0.5, norm="group", order=order, weights=w, loss=loss, tol=1e-9, **options
    )
    optimum, _ = _cvxpy_reference(
        x, u, w, 0.5, np.array(coeffs), norm="group", loss=loss, delta=delta
    )
    assert model.status.success
    assert model.info["solver"].startswith("interior point with residual cones")
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-7)


def test_laplace_fit_short_of_its_certificate_at_working_precision_says_so():
    """Short series at tol = 1e-9 where the interior point meets its own test but the
    certificate (its dual point made exactly feasible) stays above tol, also after the
    retry to a 100x tighter own test (1.4e-9 and 2.2e-9 when measured). The status is
    "stalled" with the remedy "loosen tol"; it was "max_iter" with "increase
    max_iter", which does not help there."""
    for n, seed in [(3, 5), (4, 3)]:
        x, u, w = _wide_data(seed, n=n, m=2)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model = ltv.fit(x, u, lam=0.3, norm="group", weights=w, loss="laplace", tol=1e-9)
        assert model.status.success or model.status.status == "stalled"
        assert not any("increase max_iter" in str(item.message) for item in caught)
        if model.status.status == "stalled":
            assert model.info["duality_gap"] > 1e-9
            assert any("loosen tol" in str(item.message) for item in caught)


def _jump_system(n, m, T, seed):
    """x (T, n), u (T, m) of a system whose A switches between two random stable
    matrices at T/2 (the benchmarks' wide jump systems), noise σ = 0.2."""
    rng = np.random.default_rng(seed)

    def stable():
        A = rng.standard_normal((n, n))
        return 0.9 * A / np.abs(np.linalg.eigvals(A)).max()

    A1, A2, B = stable(), stable(), rng.standard_normal((n, m))
    u = rng.standard_normal((T, m))
    x = np.zeros((T, n))
    for t in range(T - 1):
        x[t + 1] = (A1 if t < T // 2 else A2) @ x[t] + B @ u[t] + 0.2 * rng.standard_normal(n)
    return x, u


@pytest.mark.parametrize("norm, n", [("l1", 3), ("group", 4)])
def test_laplace_fits_of_order_2_refine_their_newton_steps(norm, n):
    """Order 2, default tol: near the optimum the residual cones' weights make the
    Newton steps inaccurate, and these fits stalled short of tol (gaps 1.5e-6 and
    2.3e-5, the stationarity residual growing under full steps). One refinement of each step
    certifies them (on wide jump systems at T = 400, 5 of 54 order-2 fits still stall,
    13 did); the optimum is Clarabel's."""
    x, u = _jump_system(n, 2, 400, seed=1)
    lam = 0.3 * ltv.lambda_max(x, u, norm=norm, order=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ltv.ConvergenceWarning)
        model = ltv.fit(x, u, lam=lam, norm=norm, order=2, loss="laplace", compute_cov=False)
    assert model.status.success
    optimum, _ = _cvxpy_reference(
        x[None], u[None], np.ones((1, 399)), lam, np.array([1.0, -2.0, 1.0]), norm=norm,
        loss="laplace",
    )  # fmt: skip
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-6)


def test_laplace_fit_whose_certificate_misses_tol_is_solved_again_tighter():
    """l1, 16 regressors, order 2, default tol: every output's interior point met its
    own test (gaps <= 2.3e-7) but the certificate of their dual point made feasible
    was 1.01e-6 > 1e-6, and the fit ended with a warning. The parts run once more to
    tol/100, and the fit is certified."""
    x, u = _jump_system(10, 6, 400, seed=0)
    lam = 0.1 * ltv.lambda_max(x, u, norm="l1")
    with warnings.catch_warnings():
        warnings.simplefilter("error", ltv.ConvergenceWarning)
        model = ltv.fit(x, u, lam=lam, norm="l1", order=2, loss="laplace", compute_cov=False)
    assert model.status.success
    assert model.info["duality_gap"] <= 1e-6 and model.info["duality_gap_rigorous"]


@pytest.mark.parametrize("loss", ["huber", "laplace"])
def test_l1_robust_fits_of_many_regressors_take_the_interior_point(loss):
    """24 regressors (l1: one part, 24 coefficients per step): the interior point with
    residual cones, at Clarabel's optimum (before: proximal Newton or Huber smoothing)."""
    rng = np.random.default_rng(3)
    T, p = 50, 24
    phi = rng.standard_normal((T, p))
    k = np.where(np.arange(T)[:, None] < T // 2, 1.0, -1.0) * rng.standard_normal(p) / p
    y = np.sum(phi * k, axis=1) + 0.05 * rng.standard_normal(T)
    y[[7, 31]] += 3.0
    options = {"huber_delta": 0.1} if loss == "huber" else {}
    model = ltv.fit_regression(y, phi, lam=0.5, norm="l1", loss=loss, tol=1e-9, **options)
    kv = cp.Variable((T, p))
    resid = y - cp.sum(cp.multiply(phi, kv), axis=1)
    data = cp.sum(cp.huber(resid, 0.1)) if loss == "huber" else cp.sum(cp.abs(resid))
    problem = cp.Problem(cp.Minimize(data + 0.5 * cp.sum(cp.abs(kv[1:] - kv[:-1]))))
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-8, tol_gap_rel=1e-8, tol_feas=1e-8)
    assert model.status.success
    assert model.info["solver"].startswith("interior point with residual cones")
    assert model.info["objective"] == pytest.approx(problem.value, rel=1e-7)


def test_laplace_lti_matches_clarabel():
    x, u, w = _data(23)
    model = ltv.fit_lti(x, u, weights=w, loss="laplace")
    optimum, k = _cvxpy_reference(x, u, w, np.inf, np.array([-1.0, 1.0]), norm="sq", loss="laplace")
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-8)
    assert np.ptp(model.k, axis=0).max() == 0.0


def _spoiled_jump_linear(seed):
    """The jump-linear system with 5 % of the samples hit by +5σ in one state (σ = 0.2)."""
    data = ltv.systems.jump_linear(seed=seed)
    rng = np.random.default_rng(seed)
    x = data.x.copy()
    hit = rng.choice(np.arange(1, x.shape[0]), size=x.shape[0] // 20, replace=False)
    x[hit, rng.integers(0, 2, size=hit.size)] += 5 * data.noise_std
    return data, x


def test_huber_group_finds_the_change_despite_gross_outliers():
    """Over 8 seeds at λ = 8 (measured): the Huber group fit finds the one change at
    t = 200 and nothing else in every seed, the squared loss 1 to 6 changes; RMS
    coefficient errors 0.028–0.071 (Huber) against 0.033–0.111 (squared), mean
    0.047 against 0.061."""
    errors = {"squared": [], "huber": []}
    for seed in range(8):
        data, x = _spoiled_jump_linear(seed)
        for loss in errors:
            model = ltv.fit(x, data.u, lam=8.0, norm="group", loss=loss)
            errors[loss].append(np.sqrt(np.mean((model.theta - data.theta) ** 2)))
            if loss == "huber":
                assert np.abs(model.changepoints - 200).min() <= 3, model.changepoints
                assert model.changepoints.size == 1, model.changepoints
    assert np.mean(errors["huber"]) < 0.85 * np.mean(errors["squared"]), errors


def _cvxpy_piecewise(x, u, changepoints, order, loss, delta=None):
    """Optimal value of the piecewise model (constant or continuous linear between the
    change points) with a robust loss, from scratch: k_t = Σ_l B_tl Γ_l."""
    T, n = x.shape
    p = n + u.shape[1]
    N = T - 1
    t = np.arange(N)
    if order == 1:
        bounds = np.concatenate([[0], changepoints, [N]])
        basis = np.stack([(t >= a) & (t < b) for a, b in zip(bounds[:-1], bounds[1:])], 1)
    else:
        knots = np.concatenate([[0], changepoints, [N - 1]])
        basis = np.stack([np.interp(t, knots, np.eye(len(knots))[j]) for j in range(len(knots))], 1)
    gamma = cp.Variable((basis.shape[1], n * p))
    k = basis.astype(float) @ gamma
    phi = np.concatenate([x[:-1], u[:-1]], axis=1)
    terms = []
    for i in range(n):
        resid = x[1:, i] - cp.sum(cp.multiply(phi, k[:, i * p : (i + 1) * p]), axis=1)
        terms.append(cp.sum(cp.huber(resid, delta[i]) if loss == "huber" else cp.abs(resid)))
    problem = cp.Problem(cp.Minimize(sum(terms)))
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    return problem.value


@pytest.mark.parametrize("loss", ["huber", "laplace"])
@pytest.mark.parametrize("order", [1, 2])
def test_robust_piecewise_matches_clarabel(loss, order):
    data, x = _spoiled_jump_linear(3)
    x, u = x[:120], data.u[:120]
    delta = np.array([0.3, 0.3]) if loss == "huber" else None
    model = ltv.fit_piecewise(x, u, [40, 80], order=order, loss=loss, huber_delta=delta)
    optimum = _cvxpy_piecewise(x, u, np.array([40, 80]), order, loss, delta)
    assert model.status.success and model.info["loss"] == loss
    assert model.info["objective"] == pytest.approx(optimum, rel=1e-7)
    assert model.cov is None and model.loglik is None
    assert model.changepoints.tolist() == [40, 80]


def test_refine_keeps_the_robust_loss():
    """One gross outlier at t = 50 makes the squared loss report a change there."""
    data = ltv.systems.jump_linear(seed=0)
    x = data.x.copy()
    x[50, 0] += 5.0
    squared = ltv.fit(x, data.u, lam=8.0, norm="group", refine=True)
    huber = ltv.fit(x, data.u, lam=8.0, norm="group", refine=True, loss="huber")
    assert 50 in squared.changepoints.tolist()  # measured: [50, 200]
    assert huber.changepoints.tolist() == [200]
    assert huber.info["loss"] == "huber" and huber.norm == "piecewise"
    assert huber.info["first_step"]["changepoints"] == [200]


def test_lam_auto_with_a_robust_loss_is_robust_cross_validation():
    data, x = _spoiled_jump_linear(1)
    selection = ltv.select_lambda(x, data.u, norm="group", loss="huber")
    assert selection.method == "cv" and selection.loss == "huber"
    assert len(selection.lams) == 15 and len(selection.huber_delta) == 2
    model = ltv.fit(x, data.u, lam="auto", norm="group", loss="huber")
    assert model.lam == selection.lam
    assert model.info["huber_delta"] == selection.huber_delta  # the loss λ was chosen for
    assert model.info["lam_selection"]["loss"] == "huber"
    assert model.changepoints.tolist() == [200]  # measured at λ = 7.9
    with pytest.raises(ValueError, match=r"^method: expected one of \('cv',\)"):
        ltv.select_lambda(x, data.u, norm="sq", method="ml", loss="huber")
    with pytest.raises(ValueError, match=r"^loss: norm='l0'"):
        ltv.select_lambda(x, data.u, norm="l0", loss="laplace")


def test_cli_fits_the_laplacian_loss(tmp_path, capsys):
    from ltvmodels.cli import main

    x, u, _ = _data(24)
    path = tmp_path / "data.csv"
    np.savetxt(path, np.c_[x[0], u[0]], delimiter=",", header="x1,x2,u1", comments="")
    code = main(
        [
            "fit",
            str(path),
            "--state",
            "x1,x2",
            "--input",
            "u1",
            "--lam",
            "1",
            "--loss",
            "laplace",
            "--json",
        ]
    )
    report = __import__("json").loads(capsys.readouterr().out)
    assert code == 0 and report["loss"] == "laplace" and report["duality_gap"] <= 1e-6
    code = main(
        ["fit", str(path), "--state", "x1,x2", "--input", "u1", "--lam", "1", "--loss", "laplace"]
    )
    assert code == 0 and "loss: laplace (absolute residuals)" in capsys.readouterr().out


@pytest.mark.parametrize("loss", ["huber", "laplace"])
@pytest.mark.parametrize("norm", ["group", "l1"])
def test_sparse_robust_losses_with_a_coefficient_held_constant(loss, norm):
    """λ = inf on one coefficient: proximal Newton (Huber) or certified smoothing (Laplace),
    not the interior-point method with residual cones."""
    x, u, w = _data(30)
    lam = np.array([0.5, 0.5, np.inf, 0.5, 0.5, 0.5])
    delta = np.array([0.15, 0.25]) if loss == "huber" else None
    tol = 1e-9 if loss == "huber" else 1e-5  # smoothing: certified to about 1e-6
    model = ltv.fit(x, u, lam=lam, norm=norm, weights=w, loss=loss, huber_delta=delta, tol=tol)
    optimum, _ = _cvxpy_reference(
        x, u, w, lam, np.array([-1.0, 1.0]), norm=norm, loss=loss, delta=delta
    )
    assert "residual cones" not in model.status.solver.split("; ")[0]
    assert np.ptp(model.k[:, 2]) == pytest.approx(0.0, abs=1e-12)
    assert model.info["objective"] == pytest.approx(optimum, rel=10 * tol)
    if loss == "laplace":  # the certificate bounds the true excess
        excess = (model.info["objective"] - optimum) / optimum
        assert excess <= model.info["duality_gap"] + 1e-9


def test_huber_with_a_parameter_prior_matches_clarabel():
    """Σ w h_δ(r) + λ²Σ‖Dk‖² + σ²Σ_t (k_t − m)ᵀP(k_t − m), σ² = noise_var (the
    squared loss's MAP convention), against cvxpy."""
    x, u, w = _data(31)
    delta = np.array([0.15, 0.25])
    mean = np.array([0.5, 0.1, 0.3, -0.1, 0.4, 0.2])
    cov = np.diag([0.5, 0.5, 1.0, 0.2, 0.2, 1.0])
    sigma2 = np.array([0.01, 0.02])
    model = ltv.fit(
        x,
        u,
        lam=3.0,
        weights=w,
        loss="huber",
        huber_delta=delta,
        prior=ltv.Prior(mean, cov),
        noise_var=sigma2,
        tol=1e-11,
    )
    R, T, n = x.shape
    p, N = n + u.shape[2], T - 1
    k = cp.Variable((N, n * p))
    value, _ = _cvxpy_reference(
        x, u, w, 3.0, np.array([-1.0, 1.0]), norm="sq", loss="huber", delta=delta
    )
    # the same problem plus the prior, built directly
    terms = []
    precision = np.linalg.inv(cov)
    for r in range(R):
        for t in range(N):
            phi = np.concatenate([x[r, t], u[r, t]])
            if w[r, t] == 0 or not np.all(np.isfinite(phi)) or not np.all(np.isfinite(x[r, t + 1])):
                continue
            for i in range(n):
                terms.append(
                    w[r, t] * cp.huber(x[r, t + 1, i] - phi @ k[t, i * p : (i + 1) * p], delta[i])
                )
    terms.append(9.0 * cp.sum_squares(k[1:] - k[:-1]))
    scale = np.repeat(sigma2, p)  # output i's rows weighted by σ_i²
    root = np.linalg.cholesky(precision).T * np.sqrt(scale)[None, :]
    terms.append(cp.sum_squares((k - mean[None, :]) @ root.T))
    problem = cp.Problem(cp.Minimize(sum(terms)))
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-9, tol_gap_rel=1e-9, tol_feas=1e-9)
    assert model.status.success and model.info["prior_scale"] == sigma2.tolist()
    assert model.info["objective"] == pytest.approx(problem.value, rel=1e-7)
    assert model.info["objective"] > value  # the prior pulls away from the prior-free optimum
    np.testing.assert_array_equal(model.noise_var, sigma2)
    default = ltv.fit(
        x, u, lam=3.0, weights=w, loss="huber", huber_delta=delta, prior=ltv.Prior(mean, cov)
    )
    assert default.info["prior_scale"] == pytest.approx((delta / 1.345) ** 2)
    with pytest.raises(NotImplementedError, match=r"^prior: not available with loss='laplace'"):
        ltv.fit(x, u, lam=3.0, loss="laplace", prior=ltv.Prior(mean, cov))
    with pytest.raises(NotImplementedError, match=r"^prior_mode: 'posthoc' is not available"):
        ltv.fit(x, u, lam=3.0, loss="huber", prior=ltv.Prior(mean, cov), prior_mode="posthoc")


def test_huber_group_error_with_outliers_of_the_state_scale():
    """+5 standard deviations of the state (not of the noise) in 5 % of the samples, λ = 16,
    8 seeds (measured): RMS coefficient error 0.155 (Huber) against 0.415 (squared), at most
    0.45 of it in every seed."""
    errors = {"squared": [], "huber": []}
    for seed in range(8):
        data = ltv.systems.jump_linear(seed=seed)
        rng = np.random.default_rng(seed)
        x = data.x.copy()
        hit = rng.choice(np.arange(1, x.shape[0]), size=x.shape[0] // 20, replace=False)
        state = rng.integers(0, 2, size=hit.size)
        x[hit, state] += 5 * np.std(data.x, axis=0)[state]
        for loss in errors:
            model = ltv.fit(x, data.u, lam=16.0, norm="group", loss=loss)
            errors[loss].append(np.sqrt(np.mean((model.theta - data.theta) ** 2)))
    assert np.mean(errors["huber"]) < 0.5 * np.mean(errors["squared"]), errors


@pytest.mark.parametrize("loss", ["huber", "laplace"])
def test_an_exact_fit_is_optimal_for_every_loss(loss):
    """Noise-free data that the squared-loss fit reproduces: that fit has ∇P = 0 and no
    residual, so it is the robust optimum too (reported with a zero certificate)."""
    rng = np.random.default_rng(11)
    phi = rng.standard_normal((60, 2))
    y = phi @ np.array([1.5, -0.5])
    squared = ltv.fit_regression(y, phi, lam=5.0)
    robust = ltv.fit_regression(y, phi, lam=5.0, loss=loss)
    assert robust.status.success and robust.info["exact_fit"]
    np.testing.assert_array_equal(robust.k, squared.k)
