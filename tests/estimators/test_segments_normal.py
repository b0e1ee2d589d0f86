"""segment_regression / fit_segments with cost="normal": a noise variance per segment.

References built here from scratch:

* brute force over every change-point placement, the Gaussian cost of each segment
  from one ``np.linalg.lstsq`` (the floor recomputed from its definition); with a
  penalty, a plain Bellman recursion over that table of segment costs (every
  number of changes);
* the maximized Gaussian log-likelihood summed with ``scipy.stats.norm.logpdf``;
* ruptures' ``Dynp`` with its ``CostNormal`` (mean and variance changes).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import stats

import ltvmodels as ltv
from ltvmodels.estimators.segments import VARIANCE_FLOOR

# -- references ---------------------------------------------------------------------------


def reference_floor(y, phi, observed):
    """VARIANCE_FLOOR × each output's least-squares residual variance over the whole data
    (the windows of the floor are one window when N < 2 · max(4p, 20, min_size))."""
    p = phi.shape[1]
    theta, *_ = np.linalg.lstsq(phi[observed], y[observed], rcond=None)
    resid = y[observed] - phi[observed] @ theta
    return VARIANCE_FLOOR * np.sum(resid**2, axis=0) / (observed.sum() - p)


def segment_cost(y, phi, observed, a, b, floor):
    """Σ_i n_s log σ̂²_i + RSS_i / σ̂²_i of rows [a, b); None if the segment is not
    identifiable (fewer observed rows than regressors, or rank deficient)."""
    kept = observed[a:b]
    ys, phis = y[a:b][kept], phi[a:b][kept]
    if ys.shape[0] < phi.shape[1] or np.linalg.matrix_rank(phis) < phi.shape[1]:
        return None
    theta, *_ = np.linalg.lstsq(phis, ys, rcond=None)
    rss = np.sum((ys - phis @ theta) ** 2, axis=0)
    n_s = ys.shape[0]
    var = np.maximum(rss / n_s, floor)
    return float(np.sum(n_s * np.log(var) + rss / var))


def cost_table(y, phi, observed, floor, min_size):
    """{(a, b): segment_cost} for every segment of at least min_size rows."""
    N = len(y)
    return {
        (a, b): segment_cost(y, phi, observed, a, b, floor)
        for a in range(N)
        for b in range(a + min_size, N + 1)
    }


def brute_force(table, N, M, min_size):
    """The smallest Gaussian cost and its change points over all placements of exactly M
    changes with segments of at least min_size rows (inf, None if there is none)."""
    best, best_cps = np.inf, None
    for cps in itertools.combinations(range(min_size, N - min_size + 1), M):
        bounds = [0, *cps, N]
        if min(np.diff(bounds)) < min_size:
            continue
        costs = [table[a, b] for a, b in itertools.pairwise(bounds)]
        if any(c is None for c in costs):
            continue
        if sum(costs) < best:
            best, best_cps = sum(costs), list(cps)
    return best, best_cps


def penalized_reference(table, N, beta):
    """min over all segmentations of Σ C + β · #changes (Bellman over ``table``) and the
    change points of the minimizer."""
    F, last = {0: -beta}, {}
    for b in range(1, N + 1):
        options = [
            (F[a] + beta + table[a, b], a)
            for a in range(b)
            if (a, b) in table and table[a, b] is not None and a in F
        ]
        if options:
            F[b], last[b] = min(options)
    cps, b = [], N
    while last[b] > 0:
        b = last[b]
        cps.append(b)
    return F[N], cps[::-1]


def noisy_regression(seed, N, n, p, missing=False, weighted=False):
    """y (N, n), φ (N, p) with a change of coefficients at N/3 and of the noise at 2N/3;
    NaN rows and weights optional. Returns y, φ, weights, and the data the references see
    (rows scaled by √w, the observed mask)."""
    rng = np.random.default_rng(seed)
    phi = rng.standard_normal((N, p))
    phi[:, 0] += 1.0
    theta = rng.standard_normal((2, n, p))
    y = np.where(np.arange(N)[:, None] < N // 3, phi @ theta[0].T, phi @ theta[1].T)
    sigma = np.where(np.arange(N) < 2 * N // 3, 0.3, 1.2)[:, None]
    y = y + sigma * rng.standard_normal((N, n))
    w = rng.uniform(0.5, 2.0, N) if weighted else np.ones(N)
    observed = np.ones(N, dtype=bool)
    if missing:
        gone = rng.choice(N, size=3, replace=False)
        y[gone[:2], 0] = np.nan
        w[gone[2]] = 0.0
        observed[gone] = False
    root = np.sqrt(w)[:, None]
    y_ref = np.where(observed[:, None], y * root, 0.0)
    phi_ref = np.where(observed[:, None], phi * root, 0.0)
    return y, phi, (w if weighted or missing else None), y_ref, phi_ref, observed


# -- exactness ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "seed, N, n, p, missing, weighted",
    [
        (0, 34, 1, 1, False, False),
        (1, 36, 1, 2, False, False),
        (2, 32, 2, 1, True, False),
        (3, 36, 2, 2, False, True),
        (4, 38, 1, 2, True, True),
    ],
)
def test_dynamic_program_equals_brute_force(seed, N, n, p, missing, weighted):
    y, phi, w, y_ref, phi_ref, observed = noisy_regression(seed, N, n, p, missing, weighted)
    floor = reference_floor(y_ref, phi_ref, observed)
    min_size = p + 3
    table = cost_table(y_ref, phi_ref, observed, floor, min_size)
    full = ltv.segment_regression(y, phi, n_changes=3, min_size=min_size, weights=w, cost="normal")
    assert full.cost_name == "normal"
    for m in range(4):
        best, cps = brute_force(table, N, m, min_size)
        ours = ltv.segment_regression(
            y, phi, n_changes=m, min_size=min_size, weights=w, cost="normal"
        )
        assert ours.cost == pytest.approx(best, rel=1e-9, abs=1e-9 * N)
        assert full.costs_by_n_changes[m] == pytest.approx(best, rel=1e-9, abs=1e-9 * N)
        assert ours.changepoints.tolist() == cps
        # the per-segment variances are those of the optimal segments
        bounds = [0, *cps, N]
        for s, (a, b) in enumerate(itertools.pairwise(bounds)):
            kept = observed[a:b]
            theta, *_ = np.linalg.lstsq(phi_ref[a:b][kept], y_ref[a:b][kept], rcond=None)
            rss = np.sum((y_ref[a:b][kept] - phi_ref[a:b][kept] @ theta) ** 2, axis=0)
            np.testing.assert_allclose(
                ours.segment_variances[s], np.maximum(rss / kept.sum(), floor), rtol=1e-9
            )


@pytest.mark.parametrize(
    "seed, N, n, p, missing, weighted",
    [(5, 34, 1, 1, False, False), (6, 36, 2, 2, True, True), (7, 36, 1, 2, False, True)],
)
def test_pelt_equals_brute_force(seed, N, n, p, missing, weighted):
    y, phi, w, y_ref, phi_ref, observed = noisy_regression(seed, N, n, p, missing, weighted)
    floor = reference_floor(y_ref, phi_ref, observed)
    min_size = p + 3
    table = cost_table(y_ref, phi_ref, observed, floor, min_size)
    changes = set()
    for beta in (2.0, 8.0, 30.0):
        objective, cps = penalized_reference(table, N, beta)
        ours = ltv.segment_regression(
            y, phi, penalty=beta, min_size=min_size, weights=w, cost="normal"
        )
        assert ours.solver == "PELT" and ours.penalty == beta
        assert ours.objective == pytest.approx(objective, rel=1e-9, abs=1e-9 * N)
        assert ours.changepoints.tolist() == cps
        if len(cps) <= 3:  # the brute force over placements agrees
            best, _ = brute_force(table, N, len(cps), min_size)
            assert objective == pytest.approx(best + beta * len(cps), rel=1e-12, abs=1e-12 * N)
        changes.add(len(cps))
    assert len(changes) > 1  # the penalties make a difference


def test_floor_keeps_an_exact_fit_finite():
    """A stretch the model fits exactly (a stuck sensor) costs n_s log σ²_floor, and the
    floor is VARIANCE_FLOOR × the median windowed residual variance (windows of 20 rows,
    the exact stretch taking one window out of the median's majority)."""
    rng = np.random.default_rng(11)
    y = rng.standard_normal(200)
    y[80:100] = 0.5  # exactly constant: a zero residual
    seg = ltv.segment_regression(y, np.ones(200), n_changes=2, cost="normal")
    assert seg.changepoints.tolist() == [80, 100]
    windows = y.reshape(10, 20)
    scale = np.median(np.sum((windows - windows.mean(1, keepdims=True)) ** 2, axis=1) / 19)
    assert seg.segment_variances[1, 0] == pytest.approx(VARIANCE_FLOOR * scale, rel=1e-12)
    assert np.isfinite(seg.cost)


# -- detection --------------------------------------------------------------------------------


def test_variance_change_found_where_the_squared_loss_is_blind():
    """σ 1 → 3 at T/2 with a constant mean: "normal" finds it within 2 % of T with
    n_changes=1 and with the BIC rule; "rss" puts its change somewhere else."""
    T, rss_misses = 1000, 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        y = rng.standard_normal(T) * np.where(np.arange(T) < T // 2, 1.0, 3.0)
        ones = np.ones(T)
        normal = ltv.segment_regression(y, ones, n_changes=1, cost="normal")
        assert abs(normal.changepoints[0] - T // 2) <= 0.02 * T
        by_bic = ltv.segment_regression(y, ones, cost="normal")
        assert by_bic.n_changes == 1 and abs(by_bic.changepoints[0] - T // 2) <= 0.02 * T
        rss = ltv.segment_regression(y, ones, n_changes=1)
        rss_misses += abs(rss.changepoints[0] - T // 2) > 0.02 * T
    assert rss_misses >= 4


def test_mean_and_variance_change_and_regression_change():
    rng = np.random.default_rng(21)
    T = 600
    y = np.concatenate([rng.normal(0.0, 1.0, 250), rng.normal(1.0, 2.5, 350)])
    seg = ltv.segment_regression(y, np.ones(T), cost="normal", penalty="bic")
    assert seg.n_changes == 1 and abs(seg.changepoints[0] - 250) <= 12
    assert seg.penalty == pytest.approx((1 + 1 + 1) * np.log(T))  # K = n·p + n + 1
    assert seg.noise_var is None and seg.penalty_rule == "bic"
    np.testing.assert_allclose(np.sqrt(seg.segment_variances[:, 0]), [1.0, 2.5], rtol=0.15)
    # p = 2: coefficients and the noise level change together at 400
    phi = np.column_stack([np.ones(T), rng.standard_normal(T)])
    theta = np.where(np.arange(T)[:, None] < 400, [1.0, 2.0], [1.5, 1.0])
    sigma = np.where(np.arange(T) < 400, 0.5, 1.5)
    y = np.sum(phi * theta, axis=1) + sigma * rng.standard_normal(T)
    seg = ltv.segment_regression(y, phi, n_changes=1, cost="normal")
    assert abs(seg.changepoints[0] - 400) <= 12 and seg.min_size == 7  # max(2p, p + 5)
    assert seg.model is not None and seg.model.changepoints.tolist() == seg.changepoints.tolist()
    intervals = seg.confint()  # Bai's intervals use each segment's own variance already
    assert intervals[0, 0] <= 400 <= intervals[0, 2]


def test_fit_segments_records_the_cost():
    rng = np.random.default_rng(5)
    T, a = 500, 0.7
    noise = np.where(np.arange(T) < 300, 0.2, 1.0)
    x = np.zeros((T, 1))
    for t in range(T - 1):
        x[t + 1] = a * x[t] + noise[t] * rng.standard_normal()
    model = ltv.fit_segments(x, n_changes=1, cost="normal")
    assert abs(model.changepoints[0] - 300) <= 10
    assert model.info["cost_name"] == "normal"
    assert model.info["segment_variances"].shape == (2, 1)
    assert "cost_name" not in ltv.fit_segments(x, n_changes=1).info  # the default's as it was


def test_criteria_are_the_gaussian_likelihood():
    """loglik and BIC from the optimal cost equal the log-likelihood summed directly at the
    maximum-likelihood estimates of the optimal segmentation with m changes."""
    rng = np.random.default_rng(8)
    T = 300
    y = np.concatenate([rng.normal(0, 1, 100), rng.normal(0, 3, 100), rng.normal(2, 1, 100)])
    phi = np.ones(T)
    table = ltv.segment_regression(y, phi, n_changes=3, cost="normal").criteria()
    assert "lwz" not in table
    for m in range(4):
        seg = ltv.segment_regression(y, phi, n_changes=m, cost="normal")
        loglik = 0.0
        for a, b in seg.segments:
            part = y[a:b]
            loglik += stats.norm.logpdf(part, part.mean(), part.std()).sum()
        assert table["loglik"][m] == pytest.approx(loglik, rel=1e-10)
        k = 2 * (m + 1) + m  # a mean and a variance per segment, m dates
        assert table["bic"][m] == pytest.approx(-2 * loglik + k * np.log(T), rel=1e-10)
    assert table["best_bic"] == 2
    assert "−2 log L" in str(ltv.segment_regression(y, phi, n_changes=2, cost="normal").summary())


# -- ruptures -------------------------------------------------------------------------------


def test_agrees_with_ruptures_normal_cost():
    """ruptures' CostNormal is n_s log(var) per segment (var: the ML variance) plus 1e-6 on
    var unless add_small_diag=False; ours adds RSS / σ̂² = n_s per segment: the two differ by
    the constant N whenever no floor is active."""
    rpt = pytest.importorskip("ruptures")
    rng = np.random.default_rng(2)
    y = np.concatenate([rng.normal(0, 1, 60), rng.normal(1.5, 0.4, 50), rng.normal(0, 2, 70)])
    N, min_size = y.size, 6
    cost = rpt.costs.CostNormal(add_small_diag=False).fit(y)
    for M in (1, 2, 3):
        bkps = rpt.Dynp(custom_cost=cost, min_size=min_size, jump=1).fit(y).predict(n_bkps=M)
        ours = ltv.segment_regression(y, np.ones(N), n_changes=M, cost="normal")
        assert ours.changepoints.tolist() == bkps[:-1]
        theirs = sum(cost.error(a, b) for a, b in itertools.pairwise([0, *bkps]))
        assert ours.cost - theirs == pytest.approx(N, rel=1e-9)


# -- options ----------------------------------------------------------------------------------


def test_options():
    rng = np.random.default_rng(0)
    y, phi = rng.standard_normal(60), np.ones(60)
    with pytest.raises(ValueError, match=r"cost: expected one of \('rss', 'normal'\).*'gauss'"):
        ltv.segment_regression(y, phi, n_changes=1, cost="gauss")
    with pytest.raises(ValueError, match="cost: expected one of"):
        ltv.fit_segments(np.c_[y], n_changes=1, cost=None)
    with pytest.raises(ValueError, match=r"min_size: expected an integer >= p \+ 1 = 2"):
        ltv.segment_regression(y, phi, n_changes=1, min_size=1, cost="normal")
    assert ltv.segment_regression(y, phi, n_changes=1, min_size=2, cost="normal").min_size == 2
    assert ltv.segment_regression(y, phi, n_changes=1, cost="normal").min_size == 6
    # trim can give no less than p + 1 rows either; an explicit min_size wins over the default
    assert ltv.segment_regression(y, phi, n_changes=1, trim=0.01, cost="normal").min_size == 2
    assert ltv.segment_regression(y, phi, n_changes=1, min_size=20, cost="normal").min_size == 20
    # the default cost is the residual sum of squares, with no variances
    rss = ltv.segment_regression(y, phi, n_changes=1)
    assert rss.cost_name == "rss" and rss.segment_variances is None and rss.min_size == 1


def test_summary_reports_each_segment_s_noise_variance():
    rng = np.random.default_rng(5)
    y = np.r_[rng.normal(0, 1, 200), rng.normal(0, 3, 200)]
    seg = ltv.segment_regression(y, np.ones(400), n_changes=1, cost="normal")
    text = str(seg.summary())
    assert "noise variances" in text and "Breaks" not in text
    for variance in seg.segment_variances[:, 0]:
        assert f"{variance:.6g}" in text


def test_fixed_columns_take_the_residual_sum_of_squares_only():
    y = np.random.default_rng(0).standard_normal(100)
    phi = np.column_stack([np.ones(100), np.arange(100.0)])
    with pytest.raises(ValueError, match="fixed, cost: the partial structural-change search"):
        ltv.segment_regression(y, phi, n_changes=1, fixed=[1], cost="normal")
