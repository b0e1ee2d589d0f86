"""The number of changes chosen by a criterion among 0 … n_changes, and the criteria
themselves against the Gaussian likelihood evaluated directly."""

import itertools

import numpy as np
import pytest
from scipy import stats

import ltvmodels as ltv
from ltvmodels.core.breaks import information_criteria


def _two_output_series(seed=0, N=150):
    rng = np.random.default_rng(seed)
    phi = np.column_stack([np.ones(N), rng.standard_normal(N)])
    theta = np.where(
        np.arange(N)[:, None, None] < 70, [[1.0, 0.5], [0.0, 1.0]], [[2.0, -0.5], [0.5, 1.0]]
    )
    y = np.einsum("tij,tj->ti", theta, phi) + 0.4 * rng.standard_normal((N, 2))
    return y, phi


def _direct_loglik(y, phi, changepoints, per_segment_variance):
    """Σ log N(residual; 0, σ²) at the least-squares fit of each segment, σ² the ML
    variance: one over everything, or one per segment and output."""
    bounds = [0, *changepoints, y.shape[0]]
    residuals = []
    for a, b in itertools.pairwise(bounds):
        coef = np.linalg.lstsq(phi[a:b], y[a:b], rcond=None)[0]
        residuals.append(y[a:b] - phi[a:b] @ coef)
    if per_segment_variance:
        return sum(
            stats.norm.logpdf(r, scale=np.sqrt(np.mean(r**2, axis=0))).sum() for r in residuals
        )
    r = np.concatenate(residuals)
    return stats.norm.logpdf(r, scale=np.sqrt(np.mean(r**2))).sum()


def test_multi_output_criteria_equal_the_likelihood_evaluated_directly():
    y, phi = _two_output_series()
    seg = ltv.segment_regression(y, phi, n_changes=3, min_size=10)
    table = seg.criteria()
    for m in range(4):
        points = ltv.segment_regression(y, phi, n_changes=m, min_size=10).changepoints
        loglik = _direct_loglik(y, phi, points, per_segment_variance=False)
        assert table["loglik"][m] == pytest.approx(loglik, rel=1e-10)
        parameters = 2 * 2 * (m + 1) + m + 1  # n·p per segment, the dates, one variance
        assert table["bic"][m] == pytest.approx(-2 * loglik + parameters * np.log(150), rel=1e-10)
        assert table["aic"][m] == pytest.approx(-2 * loglik + 2 * parameters, rel=1e-10)
    normal = ltv.segment_regression(y, phi, n_changes=2, min_size=10, cost="normal")
    table = normal.criteria()
    for m in range(3):
        points = ltv.segment_regression(y, phi, n_changes=m, min_size=10, cost="normal")
        loglik = _direct_loglik(y, phi, points.changepoints, per_segment_variance=True)
        assert table["loglik"][m] == pytest.approx(loglik, rel=1e-10)
        parameters = (2 * 2 + 2) * (m + 1) + m  # coefficients and variances, the dates
        assert table["bic"][m] == pytest.approx(-2 * loglik + parameters * np.log(150), rel=1e-10)


@pytest.mark.parametrize("criterion", ["bic", "aic", "lwz"])
def test_a_criterion_with_n_changes_picks_its_best_number(criterion):
    y, phi = _two_output_series(seed=1)
    full = ltv.segment_regression(y[:, 0], phi, n_changes=5, min_size=10)
    best = full.criteria()[f"best_{criterion}"]
    chosen = ltv.segment_regression(y[:, 0], phi, n_changes=5, min_size=10, penalty=criterion)
    assert chosen.n_changes == best and chosen.penalty_rule == criterion
    exact = ltv.segment_regression(y[:, 0], phi, n_changes=best, min_size=10)
    np.testing.assert_array_equal(chosen.changepoints, exact.changepoints)
    assert chosen.cost == pytest.approx(exact.cost, rel=1e-12)
    np.testing.assert_allclose(chosen.costs_by_n_changes, full.costs_by_n_changes, rtol=1e-12)
    assert f"{criterion.upper()} picks among 0 … 5" in str(chosen.summary())


def test_nile_bic_picks_its_one_break():
    nile = ltv.datasets.nile()
    chosen = ltv.segment_regression(nile, np.ones(100), n_changes=5, trim=0.15, penalty="bic")
    assert chosen.changepoints.tolist() == [28]


def test_criteria_with_fixed_regressors_and_normal_cost_choose_their_own_best():
    y, phi = _two_output_series(seed=2)
    seg = ltv.segment_regression(y[:, 0], phi, n_changes=3, min_size=10, fixed=[1], penalty="bic")
    table = ltv.segment_regression(y[:, 0], phi, n_changes=3, min_size=10, fixed=[1]).criteria()
    assert seg.n_changes == table["best_bic"]
    normal = ltv.segment_regression(y, phi, n_changes=3, min_size=10, cost="normal", penalty="bic")
    table = ltv.segment_regression(y, phi, n_changes=3, min_size=10, cost="normal").criteria()
    assert normal.n_changes == table["best_bic"]
    model = ltv.fit_segments(np.cumsum(y, axis=0) * 0.01, n_changes=2, penalty="bic", min_size=10)
    assert model.info["penalty_rule"] == "bic" and model.info["penalty"] is None


@pytest.mark.parametrize(
    ("arguments", "error", "message"),
    [
        ({"penalty": "lwz"}, ValueError, "'lwz' ranks the optimal segmentations"),
        ({"n_changes": 2, "penalty": 3.0}, TypeError, "n_changes, penalty: expected one of"),
        ({"n_changes": 2, "penalty": "hq"}, ValueError, "expected a criterion that chooses"),
        ({"n_changes": 2, "penalty": "lwz", "cost": "normal"}, ValueError, "'lwz' assumes one"),
    ],
)
def test_criterion_errors(arguments, error, message):
    y, phi = _two_output_series()
    with pytest.raises(error, match=message):
        ltv.segment_regression(y[:, 0], phi, min_size=10, **arguments)


def test_information_criteria_skip_impossible_numbers_of_changes():
    table = information_criteria(np.array([10.0, 8.0, np.inf]), 50, 1, 2)
    assert table["best_bic"] in (0, 1) and not np.isfinite(table["bic"][2])
