"""The fit status record (``model.status``) of every estimator, and the fit record."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.results.record import STATUSES, iterative_status

DATA = ltv.systems.jump_linear(T=200, change_at=100, seed=3)
X, U = DATA.x, DATA.u


def check(model, status, solver_part):
    s = model.status
    assert isinstance(s, ltv.FitStatus)
    assert s.status == status
    assert solver_part in s.solver and s.solver == model.info["solver"]
    assert s.message == STATUSES[status]
    assert s.success == (status in ("closed_form", "optimal", "optimal_polished"))
    return s


def test_squared_norm_is_closed_form():
    model = ltv.fit(X, U, lam=10.0)
    s = check(model, "closed_form", "Cholesky")
    assert s.iterations == 1 and s.objective == model.info["objective"]
    assert s.details == {"n_factorizations": model.info["n_factorizations"]}


def test_least_squares_and_piecewise_are_closed_form():
    lti = ltv.fit_lti(X, U)
    assert check(lti, "closed_form", "least-squares").objective == lti.info["rss"]
    pw = ltv.fit_piecewise(X, U, [100], order=2)
    assert check(pw, "closed_form", "piecewise").objective == pw.info["rss"]
    assert pw.status.iterations == 0


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_interior_point_is_optimal_with_its_numbers(norm):
    model = ltv.fit(X, U, lam=5.0, norm=norm)
    s = check(model, "optimal", "interior point")
    assert s.iterations == model.info["iterations"] > 0
    assert s.objective == model.info["objective"]
    for key in ("duality_gap", "primal_residual", "dual_residual", "lambda_max"):
        assert s.details[key] == model.info[key]
    assert s.details["duality_gap"] <= 1e-6 * s.objective


def test_at_lambda_max_the_solution_is_closed_form():
    lam_max = ltv.lambda_max(X, U, norm="group")
    model = ltv.fit(X, U, lam=lam_max, norm="group")
    assert check(model, "closed_form", "closed form").iterations == 0


def test_iteration_limit_is_max_iter_with_a_warning():
    with pytest.warns(ltv.ConvergenceWarning, match="did not converge"):
        model = ltv.fit(X, U, lam=5.0, norm="group", max_iter=1)
    s = check(model, "max_iter", "interior point")
    assert not s.success and model.info["converged"] is False


def test_polished_fit_is_optimal_polished():
    """A tolerance the interior-point iterations cannot reach is certified by the polish."""
    data = ltv.systems.jump_linear(T=1000, change_at=500, seed=1)
    lam = 0.5 * ltv.lambda_max(data.x, data.u, norm="group", order=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ltv.ConvergenceWarning)
        model = ltv.fit(data.x, data.u, lam=lam, norm="group", order=2, tol=1e-9)
    if not model.info.get("polished"):
        pytest.skip("the interior-point method met the tolerance on this machine")
    check(model, "optimal_polished", "interior point")


def test_admm_status():
    # K = 70 parameters per step: beyond the interior point's GROUP_IPM_MAX_K (64)
    big = ltv.systems.random_walk_system(T=120, n=7, m=3, seed=1, drift_std=0.01)
    model = ltv.fit(big.x, big.u, lam=5.0, norm="group")
    s = check(model, "optimal", "ADMM")
    assert {"rho", "n_factorizations", "lambda_max", "duality_gap", "stationarity"} <= set(
        s.details
    )
    with pytest.warns(ltv.ConvergenceWarning):
        short = ltv.fit(big.x, big.u, lam=5.0, norm="group", max_iter=3)
    check(short, "max_iter", "ADMM")


def test_segmentation_is_optimal():
    model = ltv.fit_segments(X, U, n_changes=1)
    s = check(model, "optimal", "dynamic programming")
    assert s.objective == model.info["objective"]
    check(ltv.fit_segments(X, U), "optimal", "PELT")


def test_regression_ar_and_refined_fits_have_a_status():
    check(ltv.fit_ar(X[:, 0], na=2, lam=10.0), "closed_form", "Cholesky")
    check(
        ltv.fit_regression(X[1:], np.hstack([X[:-1], U[:-1]]), lam=5.0, norm="l1"),
        "optimal",
        "interior point",
    )
    refined = ltv.fit(X, U, lam=5.0, norm="group", refine=True)
    check(refined, "closed_form", "piecewise")
    assert refined.info["first_step"]["converged"] is True


def test_iterative_status_table():
    assert iterative_status(True) == "optimal"
    assert iterative_status(True, polished=True) == "optimal_polished"
    assert iterative_status(False, stalled=True) == "stalled"
    assert iterative_status(False) == "max_iter"


def test_status_record_validates_and_round_trips():
    with pytest.raises(ValueError, match="status: expected one of"):
        ltv.FitStatus("converged", "x")
    s = ltv.FitStatus("stalled", "interior point", 7, 1.5, {"duality_gap": np.float64(2e-5)})
    assert not s.success and "working precision" in s.message
    back = ltv.FitStatus.from_dict(s.to_dict())
    assert back == s and type(back.details["duality_gap"]) is float
    assert "stalled" in repr(s)


def test_model_from_given_coefficients_needs_no_record():
    """``LTVModel(k, n, m)``: the record's defaults describe given coefficients."""
    model = ltv.LTVModel(DATA.k, 2, 1)
    assert model.status is None and model.norm is None and model.cov is None
    x = np.empty((DATA.T, 2))
    x[0] = DATA.x[0]
    for t in range(DATA.N):
        x[t + 1] = DATA.A[t] @ x[t] + DATA.B[t] @ DATA.u[t]
    np.testing.assert_allclose(model.simulate(DATA.x[0], DATA.u), x, rtol=1e-12)
    record = ltv.fit(X, U, lam=10.0).record
    copy = ltv.LTVModel(DATA.k, 2, 1, record)
    assert copy.status == record.status and copy.info == record.info
    assert copy.info is not record.info  # the model keeps its own dict
