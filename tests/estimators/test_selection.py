"""Choosing λ: marginal likelihood, GCV, L-curve, cross-validation, and M for L0."""

import numpy as np
import pytest
from dense_reference import best_lam, difference_matrix, lam_criterion, simulate_ltv

import ltvmodels as ltv
from ltvmodels.core.problem import state_space_problem
from ltvmodels.estimators import selection
from ltvmodels.estimators.selection import criterion_fit, select_lambda


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("method", ["ml", "gcv", "cv"])
def test_recovers_the_random_walk_ratio(seed, method):
    """λ = σ_noise / σ_drift is the generative value of the squared-norm model."""
    data = ltv.systems.random_walk_system(
        T=2000, n=2, m=1, drift_std=1e-2, noise_std=0.1, seed=seed
    )
    chosen = select_lambda(data.x, data.u, norm="sq", method=method).lam
    assert 10.0 / 2 <= chosen <= 10.0 * 2


def test_gcv_degrees_of_freedom_equal_the_dense_hat_trace():
    data = ltv.systems.jump_linear(T=25, change_at=12, seed=3)
    pb = state_space_problem(data.x, data.u, np.array([1.0, -2.0, 1.0]))
    N, n, K = pb.N, pb.n, pb.K
    lam = 2.5
    Phi = np.zeros((N * n, N * K))
    for t in range(N):
        Phi[t * n : (t + 1) * n, t * K : (t + 1) * K] = np.kron(np.eye(n), pb.phi[t, 0])
    D = np.kron(difference_matrix(N, pb.coeffs), np.eye(K))
    hat = Phi @ np.linalg.solve(Phi.T @ Phi + lam**2 * D.T @ D, Phi.T)
    assert criterion_fit(pb, "sq", lam, compute_cov=True)["dof"] == pytest.approx(
        np.trace(hat), rel=1e-9
    )


@pytest.mark.parametrize("norm,power", [("sq", 1), ("group", 2), ("l1", 2)])
def test_lcurve_corner_is_equivariant_to_rescaling(norm, power):
    """Scaling x and u by c scales the data term by c², so λ by c (sq) or c² (sparse)."""
    data = ltv.systems.jump_linear(T=200, change_at=100, seed=4)
    base = select_lambda(data.x, data.u, norm=norm, method="lcurve")
    scaled = select_lambda(10.0 * data.x, 10.0 * data.u, norm=norm, method="lcurve")
    assert scaled.lam == pytest.approx(base.lam * 10.0**power, rel=1e-6)
    assert np.argmax(scaled.scores) == np.argmax(base.scores)


def test_lcurve_and_cv_on_the_jump_linear_system_find_the_switch():
    data = ltv.systems.jump_linear(seed=0)
    for method in ("lcurve", "cv"):
        choice = select_lambda(data.x, data.u, norm="group", method=method)
        model = ltv.fit(data.x, data.u, lam=choice.lam, norm="group", refine=True)
        assert len(model.changepoints) == 1
        assert abs(int(model.changepoints[0]) - 200) <= 3


def test_l0_bic_chooses_the_true_number_of_changes():
    data = ltv.systems.jump_linear(seed=1)
    choice = select_lambda(data.x, data.u, norm="l0", max_changes=4)
    assert choice.lam == 1.0
    np.testing.assert_array_equal(choice.lams, np.arange(5.0))
    assert np.argmin(choice.scores) == 1


def test_result_object_and_plot():
    import matplotlib

    matplotlib.use("Agg")
    data = ltv.systems.jump_linear(T=150, change_at=75, seed=5)
    grid = [1.0, 3.0, 10.0, 30.0, 100.0]
    for method in ("ml", "gcv", "lcurve", "cv"):
        choice = select_lambda(data.x, data.u, method=method, lams=grid[::-1])
        np.testing.assert_array_equal(choice.lams, grid)  # sorted
        assert choice.scores.shape == (5,) and np.all(np.isfinite(choice.scores[1:-1]))
        assert grid[0] <= choice.lam <= grid[-1]
        assert choice.plot() is not None


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"norm": "sq", "method": "bic"}, r"^method:"),
        ({"norm": "group", "method": "gcv"}, r"^method:"),
        ({"norm": "huber"}, r"^norm:"),
        ({"lams": [1.0, -2.0]}, r"^lams:"),
        ({"lams": []}, r"^lams:"),
        ({"method": "cv", "n_folds": 1}, r"^n_folds:"),
        ({"norm": "l0", "lams": [0, 1.5]}, r"^lams:"),
    ],
)
def test_bad_input_is_rejected(kwargs, match):
    data = ltv.systems.jump_linear(T=60, change_at=30, seed=6)
    with pytest.raises(ValueError, match=match):
        select_lambda(data.x, data.u, **kwargs)


def test_fit_lam_auto_records_the_choice():
    data = ltv.systems.jump_linear(seed=0)
    model = ltv.fit(data.x, data.u, lam="auto")
    chosen = select_lambda(data.x, data.u, norm="sq", method="ml").lam
    assert model.lam == pytest.approx(chosen)
    record = model.info["lam_selection"]
    assert record["method"] == "ml"
    assert len(record["scores"]) == len(record["lams"]) == record["n_fits"]


def test_fit_lam_auto_is_the_independent_marginal_likelihood_optimum():
    """lam="auto" maximizes the marginal likelihood: checked against a dense search
    (dense_reference.best_lam: the dense diffuse likelihood, Brent on log λ to 1e-7),
    not against select_lambda, which runs the same code. The package refines its
    coarse grid's choice to about 1e-3 in log λ (see tests/reference)."""
    x, u, _ = simulate_ltv(4, T=61, n=1, m=1)
    model = ltv.fit(x, u, lam="auto")
    expected = best_lam(x, u, 1, "ml")
    assert model.lam == pytest.approx(expected, rel=1e-3), (model.lam, expected)
    assert model.info["lam_selection"]["lam"] == model.lam
    # the model is the fit at that λ, with its likelihood
    assert model.loglik == pytest.approx(-lam_criterion(x, u, 1, model.lam, "ml"), rel=1e-9)


def test_fit_lam_auto_group_with_refinement_finds_the_switch():
    data = ltv.systems.jump_linear(seed=0)
    model = ltv.fit(data.x, data.u, lam="auto", norm="group", refine=True)
    assert model.info["lam_selection"]["method"] == "lcurve"
    assert len(model.changepoints) == 1 and abs(int(model.changepoints[0]) - 200) <= 3


def test_lam_auto_for_the_regression_front_ends():
    data = ltv.systems.jump_linear(seed=2)
    ar = ltv.fit_ar(data.x[:, 0], na=2, lam="auto")
    assert ar.info["lam_selection"]["method"] == "ml" and ar.lam > 0


def test_lam_strings_other_than_auto_and_auto_with_a_prior_are_rejected():
    data = ltv.systems.jump_linear(T=60, change_at=30, seed=6)
    with pytest.raises(TypeError, match=r"^lam: expected a number, an array or 'auto'"):
        ltv.fit(data.x, data.u, lam="best")
    prior = ltv.Prior(np.zeros(6), 1.0)
    with pytest.raises(ValueError, match=r"^lam: 'auto'"):
        ltv.fit(data.x, data.u, lam="auto", prior=prior)


def test_regression_front_end_matches_fit_ar_auto():
    data = ltv.systems.jump_linear(seed=2)
    y, phi = ltv.ar_regressors(data.x[:, 0], na=2)
    choice = ltv.select_lambda_regression(y, phi, method="ml")
    assert ltv.fit_ar(data.x[:, 0], na=2, lam="auto").lam == pytest.approx(choice.lam)
    with pytest.raises(ValueError, match=r"^phi:"):
        ltv.select_lambda_regression(y, phi[:-1])


def test_progress_is_reported_per_candidate():
    data = ltv.systems.jump_linear(T=120, change_at=60, seed=7)
    calls = []
    select_lambda(
        data.x,
        data.u,
        lams=[1.0, 10.0, 100.0],
        method="lcurve",
        progress=lambda done, total: calls.append((done, total)),
    )
    assert calls == [(1, 3), (2, 3), (3, 3)]


def test_lam_auto_skips_a_singular_grid_point_and_records_it():
    """statsmodels' co2 (weekly, 2284 samples), AR(3) with an intercept: the largest grid λ
    gives normal equations singular to working precision; it is skipped, not fatal."""
    sm = pytest.importorskip("statsmodels.api")
    co2 = sm.datasets.co2.load_pandas().data["co2"].interpolate().to_numpy()
    model = ltv.fit_ar(co2, 3, constant=True, lam="auto")
    selection = model.info["lam_selection"]
    assert selection["skipped"] and np.isfinite(model.lam)
    skipped = [lam for lam, _ in selection["skipped"]]
    assert model.lam not in skipped
    assert all("singular" in why for _, why in selection["skipped"])
    # the skipped candidates have no score in the model's record (None)
    assert all(
        score is None
        for lam, score in zip(selection["lams"], selection["scores"])
        if lam in skipped
    )


def test_select_lambda_fails_only_when_every_candidate_is_singular(monkeypatch):
    """The error path: every candidate's fit raises (forced here, as no small data set makes
    every λ singular while passing the identifiability check)."""
    import ltvmodels.estimators.selection as selection_module

    def singular(*args, **kwargs):
        raise ltv.SingularProblemError("the normal equations are singular (forced)")

    data = ltv.systems.jump_linear(T=60, change_at=30, seed=0)
    monkeypatch.setattr(selection_module, "criterion_fit", singular)
    # the factorization-only route declines (as where H is singular): the fit decides
    monkeypatch.setattr(selection_module.ScalarEvidence, "solution", lambda *a, **k: None)
    with pytest.raises(
        ltv.SingularProblemError,
        match=r"^x: every candidate λ .* gives a singular problem; at λ = ",
    ):
        ltv.select_lambda(data.x, data.u, lams=[1.0, 2.0], method="gcv")


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("seed", [0, 1])
def test_the_default_search_reaches_the_maximum_of_a_fine_grid(order, seed):
    """The coarse grid refined (ml, gcv) scores as well as the best of 200 candidates over
    the same range, in a handful of evaluations. (To 1e-2 in log-likelihood: where λ is
    large for the data the criterion is a plateau with rounding noise of a few 1e-3, whose
    highest point on a fine grid is noise.)"""
    from ltvmodels.core.evidence import ScalarEvidence
    from ltvmodels.estimators.recordings import state_space_data

    data = ltv.systems.random_walk_system(T=300, seed=seed)
    problem = state_space_data(data.x, data.u, order=order).problem
    evidence = ScalarEvidence(problem)
    # the default range (select_lambda's docstring): s·[0.1, 2·N^d], s the rms ‖φ_t‖
    scale = np.sqrt(np.sum(problem.phi**2) / problem.n_observed)
    fine = scale * np.geomspace(0.1, 2.0 * problem.N**order, 200)
    ml = select_lambda(data.x, data.u, order=order, method="ml")
    best_fine = max(evidence.loglik(lam) for lam in fine)
    assert evidence.loglik(ml.lam) >= best_fine - 1e-2
    assert ml.n_fits == len(ml.lams) <= 18  # the most measured on 72 series

    def gcv(lam):  # N·n·RSS / (N·n − dof)²
        numbers = evidence.solution(lam, dof=True)
        size = problem.n_observed * problem.n
        return size * numbers["rss"] / (size - numbers["dof"]) ** 2

    chosen = select_lambda(data.x, data.u, order=order, method="gcv")
    assert gcv(chosen.lam) <= min(gcv(lam) for lam in fine) * (1 + 1e-4)  # the same plateau
    assert chosen.scores[np.argmin(np.abs(chosen.lams - chosen.lam))] == pytest.approx(
        gcv(chosen.lam), rel=1e-12
    )


def test_fit_lam_auto_reports_progress_and_the_number_of_fits():
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=3)
    for norm in ("sq", "group"):
        reports = []
        model = ltv.fit(
            data.x,
            data.u,
            lam="auto",
            norm=norm,
            progress=lambda done, total, reports=reports: reports.append((done, total)),
        )
        record = model.info["lam_selection"]
        n_fits = record["n_fits"]
        assert n_fits == len(record["lams"])
        assert [done for done, _ in reports[:n_fits]] == list(range(1, n_fits + 1))
        assert len(reports) <= n_fits + 1 and all(done <= total for done, total in reports)
        assert reports[-1] == (n_fits, n_fits)  # the bar ends full
    with pytest.raises(TypeError, match=r"^progress: expected a function"):
        ltv.fit(data.x, data.u, lam="auto", progress="bar")


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_the_lcurve_leaves_out_candidates_without_a_resolved_penalty(norm):
    """At λ ≥ λ_max the penalty is 0 (log = −inf): such a candidate has no place on the
    logarithmic L-curve and used to put a spurious corner next to it. The choice is the same
    with or without it."""
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=1)
    lam_max = ltv.lambda_max(data.x, data.u, norm=norm)
    below = lam_max * np.logspace(-3, -0.05, 20)
    with_max = select_lambda(
        data.x, data.u, norm=norm, method="lcurve", lams=np.append(below, [lam_max, 2 * lam_max])
    )
    without = select_lambda(data.x, data.u, norm=norm, method="lcurve", lams=below)
    assert with_max.lam == without.lam
    assert np.all(with_max.scores[-2:] == -np.inf)  # never the choice


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_the_sparse_lcurve_search_finds_the_single_change_like_a_fine_grid(norm):
    """Order 1 on the jump-linear system: the default search (8 points, the corner refined,
    warm-started fits) and a grid of 61 candidates choose models with the same change."""
    data = ltv.systems.jump_linear(T=400, change_at=200, seed=2)
    lam_max = ltv.lambda_max(data.x, data.u, norm=norm)
    search = select_lambda(data.x, data.u, norm=norm)
    fine = select_lambda(data.x, data.u, norm=norm, lams=lam_max * np.logspace(-3, 0, 61))
    assert search.n_fits == 12 and abs(np.log10(search.lam / fine.lam)) < 0.2
    for choice in (search, fine):
        model = ltv.fit(data.x, data.u, lam=choice.lam, norm=norm, refine=True)
        np.testing.assert_array_equal(model.changepoints, [200])


def test_lam_auto_on_data_that_leave_nothing_to_choose_blames_lam():
    """A VAR(1) of 6 series with as many complete transitions as coefficients per output:
    the LTI fit is exact, λ_max is at rounding level and every default candidate gives the
    same fit. The error blames lam (found by fuzzing: it blamed lams, which fit_ar lacks)."""
    y = np.random.default_rng(3).standard_normal((12, 6))
    y[1:4, 4] = np.nan  # four transitions dropped, and the last: 6 left
    y[-1] = np.nan
    with pytest.raises(ValueError, match=r"^lam: the L-curve has no corner"):
        ltv.fit_ar(y, na=1, lam="auto", norm="l1")


def test_ar_and_arx_lam_auto_report_progress():
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=3)
    y = data.x[:, 0]
    for fit, args in ((ltv.fit_ar, (y, 2)), (ltv.fit_arx, (y, data.u, 2, 1))):
        reports = []
        model = fit(
            *args,
            lam="auto",
            progress=lambda done, total, reports=reports: reports.append((done, total)),
        )
        n_fits = model.info["lam_selection"]["n_fits"]
        assert [done for done, _ in reports[:n_fits]] == list(range(1, n_fits + 1))
        assert reports[-1] == (n_fits, n_fits)
        with pytest.raises(TypeError, match=r"^progress: expected a function"):
            fit(*args, lam="auto", progress=1)


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_lcurve_path_starts_give_the_cold_fits(norm):
    """The L-curve's sparse fits start from their neighbours' solutions (the refinements
    from the interpolation of both): each candidate's residual and penalty norms are
    those of a cold fit at a tight tolerance, to the L-curve's solver tolerance (the far
    candidates' for the two smallest, which lie far from this series' corner)."""
    data = ltv.systems.jump_linear(T=300, change_at=150, seed=5)
    choice = select_lambda(data.x, data.u, norm=norm, method="lcurve")
    pb = state_space_problem(data.x, data.u, np.array([-1.0, 1.0]))
    assert choice.n_fits > 8  # the refinements ran
    assert np.argmax(choice.scores) > selection.LCURVE_FAR_COUNT + 1
    for index, (lam, residual, penalty) in enumerate(
        zip(choice.lams, choice.residual_norms, choice.penalty_norms, strict=True)
    ):
        far = index < selection.LCURVE_FAR_COUNT
        within = 10 * (selection.LCURVE_FAR_TOL if far else selection.LCURVE_TOL)
        cold = criterion_fit(pb, norm, float(lam), tol=1e-9)
        assert residual == pytest.approx(np.sqrt(cold["rss"]), rel=within)
        objective = cold["rss"] + lam * cold["penalty_norm"]
        assert lam * penalty == pytest.approx(lam * cold["penalty_norm"], abs=within * objective)


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_far_lcurve_candidates_next_to_the_corner_are_solved_again(monkeypatch, norm):
    """The default grid's two smallest candidates are solved to LCURVE_FAR_TOL only. On this
    random-walk series a corner comes next to them during the search (group: the final
    one), so they are solved again to LCURVE_TOL (more fits), and the choice and the numbers
    around it are those of the search that solves every candidate to LCURVE_TOL."""
    data = ltv.systems.random_walk_system(T=150, seed=0)
    far = select_lambda(data.x, data.u, norm=norm, method="lcurve")
    monkeypatch.setattr(selection, "LCURVE_FAR_COUNT", 0)
    tight = select_lambda(data.x, data.u, norm=norm, method="lcurve")
    assert far.lam == tight.lam and far.n_fits > tight.n_fits
    np.testing.assert_array_equal(far.lams, tight.lams)
    best = int(np.argmax(tight.scores))
    near = slice(max(best - 1, 0), best + 2)
    np.testing.assert_allclose(far.residual_norms[near], tight.residual_norms[near], rtol=1e-4)
    np.testing.assert_allclose(far.penalty_norms[near], tight.penalty_norms[near], rtol=1e-3)
    if norm == "group":
        assert best <= selection.LCURVE_FAR_COUNT  # the corner at a far candidate


def test_fit_lam_auto_starts_from_the_selections_solution():
    """fit(lam="auto") with a sparse norm fits the chosen λ from the L-curve's solution
    there: the polish of its split certifies the fit's tolerance without an iteration,
    at the optimum of a cold fit solved to 1e-10."""
    data = ltv.systems.jump_linear(T=2000, change_at=1000, seed=0)
    model = ltv.fit(data.x, data.u, lam="auto", norm="group", compute_cov=False)
    assert model.info["iterations"] == 0 and model.status.status == "optimal_polished"
    assert model.info["duality_gap"] <= 1e-6 * model.info["objective"]
    cold = ltv.fit(data.x, data.u, lam=model.lam, norm="group", compute_cov=False, tol=1e-10)
    assert cold.info["iterations"] > 0
    assert model.info["objective"] <= cold.info["objective"] * (1 + 1e-9)
    assert model.info["objective"] == pytest.approx(cold.info["objective"], rel=1e-8)
