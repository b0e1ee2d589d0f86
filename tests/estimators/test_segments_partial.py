"""Partial structural change: ``fixed=`` on segment_regression / fit_segments.

y_t = Θ_j z_t + Γ x_t + e_t on segment j, Γ common to all segments. References
built here from scratch (``numpy.linalg.lstsq`` on the joint design
[z·1{segment 1}, …, z·1{segment M+1}, x], for every break date or every pair of
break dates), and R's ``lm`` on the same design (``reference/strucchange/partial.R``).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from r_reference import run_r_script

import ltvmodels as ltv
from ltvmodels.core import partial_change
from ltvmodels.core import segmentation as search
from ltvmodels.estimators.recordings import regression_problem

REFERENCE = Path(__file__).parents[1] / "reference" / "strucchange"


# -- references ---------------------------------------------------------------------------


def joint_rss(y, phi, fixed, changepoints, weights=None):
    """min over Θ_j, Γ of the weighted RSS, by lstsq on the joint design (NaN rows left out)."""
    y = y.reshape(len(y), -1)
    N, p = phi.shape
    changing = [c for c in range(p) if c not in fixed]
    segment = np.searchsorted(np.asarray(changepoints), np.arange(N), side="right")
    blocks = [phi[:, changing] * (segment == j)[:, None] for j in range(len(changepoints) + 1)]
    design = np.column_stack([*blocks, phi[:, list(fixed)]])
    kept = ~(np.isnan(y).any(axis=1) | np.isnan(phi).any(axis=1))
    root = np.ones(N) if weights is None else np.sqrt(weights)
    design, target = design[kept] * root[kept, None], y[kept] * root[kept, None]
    coef = np.linalg.lstsq(design, target, rcond=None)[0]
    return float(np.sum((target - design @ coef) ** 2))


def profile(y, phi, fixed, min_size, weights=None):
    """Our RSS(k) for one break at every k (inf where a segment is infeasible)."""
    problem = regression_problem(y, phi, weights=weights)
    scaled = search.scale_data(problem.y, problem.phi, problem.n_observed)
    p, n = problem.p, problem.n
    changing = [c for c in range(p) if c not in fixed]
    pz, px = len(changing), len(fixed)
    data = np.ascontiguousarray(scaled.data[..., [*changing, *fixed, *range(p, p + n)]])
    zy = partial_change.adjusted_data(data, pz, px, np.zeros((n, px)))
    a_max = search.feasible_starts(zy, pz, min_size, search.FEASIBILITY_TOL * problem.N)
    rss, _ = partial_change.one_change_partial(data, pz, px, a_max)
    return rss * scaled.y_scale**2


def partial_series(seed, N, n=1, breaks=(), noise=0.3):
    """z = [1, w], x = two regressors with fixed effects; Θ switching at ``breaks``."""
    rng = np.random.default_rng(seed)
    phi = np.column_stack([np.ones(N), rng.standard_normal((N, 3))])
    segment = np.searchsorted(np.asarray(breaks, dtype=int), np.arange(N), side="right")
    theta = rng.standard_normal((len(breaks) + 1, n, 2)) * 2
    gamma = rng.standard_normal((n, 2))
    y = np.einsum("tij,tj->ti", theta[segment], phi[:, :2]) + phi[:, 2:] @ gamma.T
    return y + noise * rng.standard_normal((N, n)), phi


# -- one break: exact ---------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2])
@pytest.mark.parametrize("gaps", [False, True])
def test_one_break_scan_equals_lstsq_at_every_date(n, gaps):
    y, phi = partial_series(n, 70, n=n, breaks=(30,))
    weights = None
    if gaps:
        y[[5, 40], 0] = np.nan
        phi[12, 1] = np.nan
        weights = np.random.default_rng(3).uniform(0.2, 2.0, 70)
    fixed, min_size = (2, 3), 5
    ours = profile(y, phi, fixed, min_size, weights)
    finite = np.flatnonzero(np.isfinite(ours))
    assert finite.min() >= min_size and finite.max() <= 70 - min_size
    assert finite.size >= 70 - 2 * min_size - 3  # only the too-short segments are out
    reference = np.array([joint_rss(y, phi, fixed, [k], weights) for k in finite])
    np.testing.assert_allclose(ours[finite], reference, rtol=1e-9)
    segmentation = ltv.segment_regression(
        y, phi, n_changes=1, fixed=list(fixed), min_size=min_size, weights=weights
    )
    assert segmentation.changepoints.tolist() == [finite[np.argmin(reference)]]
    assert segmentation.cost == pytest.approx(reference.min(), rel=1e-9)
    assert segmentation.solver == "dynamic programming (partial, exact)"
    assert segmentation.fixed == fixed


def test_one_break_scan_keeps_its_digits_on_a_near_perfect_fit():
    y, phi = partial_series(7, 80, breaks=(33,), noise=0.0)
    y = y + 1e-8 * np.abs(y).mean() * np.random.default_rng(8).standard_normal(y.shape)
    ours = profile(y, phi, (2, 3), 6)
    finite = np.flatnonzero(np.isfinite(ours))
    reference = np.array([joint_rss(y, phi, (2, 3), [k]) for k in finite])
    np.testing.assert_allclose(ours[finite], reference, rtol=1e-6)
    assert finite[np.argmin(ours[finite])] == 33


# -- several breaks: Bai and Perron's iterated procedure ----------------------------------


def exhaustive_two(y, phi, fixed, min_size):
    N = len(y)
    best, best_pair = np.inf, None
    for a, b in itertools.combinations(range(min_size, N - min_size + 1), 2):
        if b - a < min_size:
            continue
        value = joint_rss(y, phi, fixed, [a, b])
        if value < best:
            best, best_pair = value, (a, b)
    return best, best_pair


# Measured: the global optimum in 96 of the 100 seeds (the first 30: 27); the bounds sit a
# little below.
GLOBAL_FRACTION_BOUND = {30: 0.85, 100: 0.9}


@pytest.mark.parametrize(
    "count", [30, pytest.param(100, marks=pytest.mark.slow)], ids=["30 seeds", "100 seeds"]
)
def test_iterated_search_reaches_the_global_optimum_mostly(count):
    hits, seeds = 0, range(count)
    for seed in seeds:
        rng = np.random.default_rng(1000 + seed)
        N = int(rng.integers(40, 61))
        a = int(rng.integers(8, N // 2 - 4))
        b = int(rng.integers(a + 8, N - 8))
        y, phi = partial_series(seed, N, breaks=(a, b), noise=float(rng.uniform(0.3, 1.5)))
        fixed, min_size = (2, 3), 5
        segmentation = ltv.segment_regression(y, phi, n_changes=2, fixed=fixed, min_size=min_size)
        best, _ = exhaustive_two(y, phi, fixed, min_size)
        ours = joint_rss(y, phi, fixed, segmentation.changepoints)
        assert ours == pytest.approx(segmentation.cost, rel=1e-9)
        assert ours >= best * (1 - 1e-9)  # never below the global optimum
        hits += ours <= best * (1 + 1e-9)
        assert segmentation.converged
    fraction = hits / len(seeds)
    print(f"iterated partial-change search: global optimum in {hits} of {len(seeds)}")
    assert fraction >= GLOBAL_FRACTION_BOUND[count]


def test_each_alternation_does_not_increase_the_rss():
    for seed in range(20):
        y, phi = partial_series(seed, 90, breaks=(25, 60), noise=1.5)
        problem = regression_problem(y, phi)
        scaled = search.scale_data(problem.y, problem.phi)
        data = np.ascontiguousarray(scaled.data[..., [0, 1, 2, 3, 4]])
        zy = partial_change.adjusted_data(data, 2, 2, np.zeros((1, 2)))
        a_max = search.feasible_starts(zy, 2, 5, search.FEASIBILITY_TOL * 90)
        start = np.random.default_rng(seed).standard_normal((1, 2))  # any Γ̃
        for beta in (None, 0.5):
            run = partial_change.alternate(
                data, 2, 2, start, None, np.inf, n_changes=3, beta=beta, min_size=5, a_max=a_max
            )
            history = np.array(run.history[1:])
            assert np.all(np.diff(history) <= 1e-12 * history[:-1])
            assert run.objective == history.min()


# -- R's lm on the joint design -----------------------------------------------------------


def check_r_reference(reference):
    one = reference["one_break"]
    y, phi = np.array(one["y"]), np.column_stack([one["Z"], one["X"]])
    fixed = tuple(range(2, phi.shape[1]))
    ours = profile(y, phi, fixed, one["h"])
    dates = np.array(one["dates"], dtype=int)
    np.testing.assert_allclose(ours[dates], one["rss"], rtol=1e-6)
    assert np.isinf(np.delete(ours, dates)).all()
    segmentation = ltv.segment_regression(y, phi, n_changes=1, fixed=fixed, trim=0.15)
    assert segmentation.changepoints.tolist() == [one["break"]]
    assert segmentation.cost == pytest.approx(one["min_rss"][0], rel=1e-6)
    two = reference["two_breaks"]
    y, phi = np.array(two["y"]), np.column_stack([two["Z"], two["X"]])
    segmentation = ltv.segment_regression(y, phi, n_changes=2, fixed=fixed, trim=0.15)
    assert segmentation.min_size == two["h"]
    assert segmentation.changepoints.tolist() == two["breaks"]
    assert segmentation.cost == pytest.approx(two["min_rss"][0], rel=1e-6)


def test_partial_change_equals_r_lm():
    check_r_reference(json.loads((REFERENCE / "partial.json").read_text()))


def test_partial_change_equals_a_live_r_lm():
    check_r_reference(run_r_script(REFERENCE / "partial.R"))


# -- a seasonal series --------------------------------------------------------------------


def test_seasonal_dummies_held_fixed_leave_one_mean_break():
    rng = np.random.default_rng(5)
    T, shift = 240, 130
    month = np.arange(T) % 12
    pattern = 2.0 * np.sin(2 * np.pi * np.arange(12) / 12)
    y = pattern[month] + 1.5 * (np.arange(T) >= shift) + 0.5 * rng.standard_normal(T)
    dummies = (month[:, None] == np.arange(1, 12)).astype(float)  # the intercept carries month 0
    phi = np.column_stack([np.ones(T), dummies])
    held = ltv.segment_regression(y, phi, fixed=list(range(1, 12)), min_size=12)
    assert held.n_changes == 1 and abs(int(held.changepoints[0]) - shift) <= 3
    lower, _, upper = held.confint()[0]
    assert lower <= shift <= upper
    # the criteria over 0 … 3 changes agree: one change
    assert (
        ltv.segment_regression(
            y, phi, n_changes=3, fixed=list(range(1, 12)), min_size=12
        ).criteria()["best_bic"]
        == 1
    )
    # without the dummies the level must follow the seasonal pattern: changes wasted on it
    level_only = ltv.segment_regression(y, np.ones(T), min_size=3)
    assert level_only.n_changes >= 4


# -- fit_segments, results ----------------------------------------------------------------


def test_fit_segments_holds_an_input_effect_fixed_by_name():
    import pandas as pd

    rng = np.random.default_rng(2)
    T = 200
    u = rng.standard_normal(T)
    x = np.zeros(T)
    for t in range(T - 1):
        a = 0.8 if t < 120 else 0.2
        x[t + 1] = a * x[t] + 1.0 * u[t] + 0.1 * rng.standard_normal()
    frame = pd.DataFrame({"level": x})
    model = ltv.fit_segments(frame, pd.DataFrame({"drive": u}), n_changes=1, fixed="drive")
    assert abs(int(model.changepoints[0]) - 120) <= 2
    assert model.info["fixed"] == [1]
    B = model.B[:, 0, 0]
    assert np.ptp(B) == 0 and B[0] == pytest.approx(1.0, abs=0.05)
    assert model.A[0, 0, 0] == pytest.approx(0.8, abs=0.05)
    assert model.A[-1, 0, 0] == pytest.approx(0.2, abs=0.05)


def test_criteria_count_the_fixed_coefficients_once():
    y, phi = partial_series(4, 150, breaks=(50, 100))
    segmentation = ltv.segment_regression(y, phi, n_changes=3, fixed=[2, 3], min_size=10)
    table = segmentation.criteria()
    rows, m = 150, np.arange(4)
    parameters = 2 + (m + 1) * 2 + m + 1
    loglik = -0.5 * rows * (np.log(table["rss"] / rows) + 1 + np.log(2 * np.pi))
    np.testing.assert_allclose(table["bic"], -2 * loglik + parameters * np.log(rows))
    assert table["best_bic"] == 2
    np.testing.assert_allclose(
        table["rss"][:3],
        [joint_rss(y, phi, [2, 3], cps) for cps in ([], [50], segmentation_breaks(y, phi, 2))],
        rtol=1e-9,
    )
    assert segmentation.model.loglik == pytest.approx(loglik[3])


def segmentation_breaks(y, phi, m):
    return ltv.segment_regression(y, phi, n_changes=m, fixed=[2, 3], min_size=10).changepoints


# -- validation ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fixed", "error", "words"),
    [
        ([2, 2], ValueError, "twice"),
        ([2, -2], ValueError, "twice"),
        ([4], ValueError, "out of range"),
        (["nope"], ValueError, "unknown name"),
        ([0, 1, 2, 3], ValueError, "nothing to segment"),
        ([1.5], TypeError, "received"),
        ([True], TypeError, "received"),
        ({"a": 1}, TypeError, "received"),
    ],
)
def test_fixed_is_validated(fixed, error, words):
    y, phi = partial_series(0, 60)
    with pytest.raises(error, match="fixed") as caught:
        ltv.segment_regression(y, phi, n_changes=1, fixed=fixed)
    assert words in str(caught.value)


def test_fixed_names_of_a_pandas_phi_and_min_size_of_the_changing_ones():
    import pandas as pd

    y, phi = partial_series(1, 80, breaks=(40,))
    frame = pd.DataFrame(phi, columns=["one", "w", "a", "b"])
    by_name = ltv.segment_regression(y, frame, n_changes=1, fixed=["a", "b"], min_size=4)
    by_index = ltv.segment_regression(y, phi, n_changes=1, fixed=[-2, -1], min_size=4)
    assert by_name.changepoints.tolist() == by_index.changepoints.tolist() == [40]
    assert by_name.cost == by_index.cost
    with pytest.raises(ValueError, match="min_size: expected an integer >= p = 2"):
        ltv.segment_regression(y, phi, n_changes=1, fixed=[2, 3], min_size=1)
