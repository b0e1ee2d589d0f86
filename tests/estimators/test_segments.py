"""ltvmodels.fit_segments / segment_regression: exact L0 segmentation (paper eq:l0).

References built here from scratch:

* brute force over every change-point placement with one ``np.linalg.lstsq``
  per segment;
* ruptures' ``Dynp`` and ``Pelt`` with ``model="linear"`` and ``jump=1``
  (exact) on single-output regressions.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.errors import SingularProblemError
from ltvmodels.estimators.segments import noise_variance_estimate, segment_regression

# -- references ---------------------------------------------------------------------------


def lstsq_cost(y, phi, changepoints):
    """Σ over segments of the least-squares residual sum of squares (lstsq per segment)."""
    if y.ndim == 1:
        y = y[:, None]
    bounds = [0, *changepoints, len(y)]
    total = 0.0
    for a, b in itertools.pairwise(bounds):
        theta, *_ = np.linalg.lstsq(phi[a:b], y[a:b], rcond=None)
        total += float(np.sum((y[a:b] - phi[a:b] @ theta) ** 2))
    return total


def brute_force(y, phi, M, min_size, feasible=None):
    """Smallest cost over all placements of exactly M changes with segments >= min_size."""
    N = len(y)
    best, best_cps = np.inf, None
    for cps in itertools.combinations(range(min_size, N - min_size + 1), M):
        bounds = [0, *cps, N]
        if min(np.diff(bounds)) < min_size:
            continue
        if feasible is not None and not all(feasible(a, b) for a, b in itertools.pairwise(bounds)):
            continue
        cost = lstsq_cost(y, phi, cps)
        if cost < best:
            best, best_cps = cost, cps
    return best, best_cps


def random_regression(seed, N, n, p, changes=(), noise=0.3):
    """y_t = Θ_s φ_t + e_t with Θ_s switching at ``changes``; returns y (N, n), φ (N, p)."""
    rng = np.random.default_rng(seed)
    phi = rng.standard_normal((N, p))
    bounds = [0, *changes, N]
    y = np.empty((N, n))
    for a, b in itertools.pairwise(bounds):
        theta = rng.standard_normal((n, p))
        y[a:b] = phi[a:b] @ theta.T
    return y + noise * rng.standard_normal((N, n)), phi


def switching_system(seed, T, n, m, changes, noise=0.1):
    """x[t+1] = A_s x[t] + B_s u[t] + v[t], random stable (A_s, B_s) switching at ``changes``."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((T, m))
    x = np.zeros((T, n))
    bounds = [0, *changes, T - 1]
    for a, b in itertools.pairwise(bounds):
        A = rng.standard_normal((n, n))
        A *= 0.8 / np.abs(np.linalg.eigvals(A)).max()
        B = rng.standard_normal((n, m))
        for t in range(a, b):
            x[t + 1] = A @ x[t] + B @ u[t] + noise * rng.standard_normal(n)
    return x, u


# -- exactness ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "seed,N,n,p,min_size",
    [(0, 18, 1, 1, 1), (1, 22, 1, 2, 2), (2, 20, 2, 2, 3), (3, 24, 1, 3, 3), (4, 21, 3, 2, 4)],
)
@pytest.mark.parametrize("M", [1, 2, 3])
def test_dynamic_program_equals_brute_force(seed, N, n, p, min_size, M):
    y, phi = random_regression(seed, N, n, p, changes=(N // 3, 2 * N // 3))
    if (M + 1) * min_size > N:
        pytest.skip("infeasible")
    exact = [brute_force(y, phi, m, min_size)[0] for m in range(M + 1)]
    result = segment_regression(y, phi, n_changes=M, min_size=min_size)
    # every count up to M is optimal, and the result is the best of them (at most M changes)
    np.testing.assert_allclose(result.costs_by_n_changes, exact, rtol=1e-10)
    assert result.cost == pytest.approx(min(exact), rel=1e-10)
    assert lstsq_cost(y, phi, result.changepoints) == pytest.approx(min(exact), rel=1e-10)
    if exact[M] <= min(exact) * (1 + 1e-12):
        assert result.n_changes == M
    else:  # min_size can make M changes worse than fewer (short data)
        assert result.n_changes < M
    assert all(b - a >= min_size for a, b in result.segments)


def test_one_change_shortcut_equals_full_dynamic_program():
    """M = 1 takes two O(N) passes; the general O(N²) program gives the same."""
    from ltvmodels.core import segmentation as seg

    x, u = switching_system(17, 80, 2, 1, changes=(33,), noise=0.3)
    u[50:58] = 0.0  # an infeasible stretch
    phi = np.hstack([x[:-1], u[:-1]])
    data = seg.scale_data(x[1:], phi).data
    for min_size in (3, 7):
        a_max = seg.feasible_starts(data, 3, min_size, seg.FEASIBILITY_TOL * 79)
        fast, fast_starts = seg.one_change(data, 3, a_max)
        full, full_starts = seg.dynamic_program(data, 3, 1, min_size, a_max)
        np.testing.assert_allclose(fast, full, rtol=1e-12)
        assert fast_starts[1, -1] == full_starts[1, -1]


def test_costs_guarded_against_cancellation():
    """A nearly exact fit with a large regressor offset: the costs still match lstsq.

    Σyᵀy − tr(SφyᵀSφφ⁻¹Sφy) from prefix sums would lose every digit here
    (RSS / Σyᵀy ≈ 1e-22).
    """
    rng = np.random.default_rng(11)
    N = 40
    phi = np.column_stack([1e3 + rng.standard_normal(N), rng.standard_normal(N)])
    theta = np.where(np.arange(N)[:, None] < 17, [[2.0, -1.0]], [[1.5, 0.5]])
    y = np.sum(phi * theta, axis=1) + 1e-8 * rng.standard_normal(N)
    result = segment_regression(y, phi, n_changes=2, min_size=4)
    for m in range(3):
        best, _ = brute_force(y[:, None], phi, m, 4)
        assert result.costs_by_n_changes[m] == pytest.approx(best, rel=1e-6)
    assert 17 in result.changepoints.tolist()
    assert result.cost < 1e-12


def test_penalized_equals_dynamic_program_optimum():
    y, phi = random_regression(5, 150, 2, 3, changes=(40, 90, 100), noise=0.5)
    M_max = 8
    dp = segment_regression(y, phi, n_changes=M_max, min_size=5)
    for beta in [0.0, 0.5, 2.0, 5.0, 20.0, 100.0, 1e4]:
        pelt = segment_regression(y, phi, penalty=beta, min_size=5)
        objective = dp.costs_by_n_changes + beta * np.arange(M_max + 1)
        if pelt.n_changes <= M_max:
            assert pelt.cost == pytest.approx(dp.costs_by_n_changes[pelt.n_changes], rel=1e-9)
            assert pelt.objective == pytest.approx(objective.min(), rel=1e-9)
        else:  # β small: more than M_max changes, and better than any of them
            assert pelt.objective <= objective.min() * (1 + 1e-12)
        assert pelt.objective == pytest.approx(pelt.cost + beta * pelt.n_changes, rel=1e-12)
        assert pelt.solver == "PELT" and pelt.penalty == beta
    assert segment_regression(y, phi, penalty=1e6, min_size=5).n_changes == 0


def test_penalized_equals_brute_force_small():
    y, phi = random_regression(6, 20, 1, 2, changes=(8,), noise=0.4)
    for beta in [0.05, 0.5, 3.0]:
        pelt = segment_regression(y, phi, penalty=beta, min_size=3)
        best = min(brute_force(y, phi, m, 3)[0] + beta * m for m in range(20 // 3))
        assert pelt.objective == pytest.approx(best, rel=1e-10)


def test_infeasible_segments_are_never_used_and_pelt_stays_exact():
    """Zero input on a stretch: segments inside it cannot identify B and are excluded."""
    x, u = switching_system(7, 60, 1, 1, changes=(35,), noise=0.2)
    u[20:32] = 0.0
    y, phi = x[1:], np.hstack([x[:-1], u[:-1]])

    def feasible(a, b):
        return np.linalg.matrix_rank(phi[a:b]) == 2

    for M in (1, 2):
        best, _ = brute_force(y, phi, M, 2, feasible)
        result = segment_regression(y, phi, n_changes=M)
        assert result.cost == pytest.approx(best, rel=1e-10)
        assert all(feasible(a, b) for a, b in result.segments)
    dp = segment_regression(y, phi, n_changes=10, min_size=2)
    for beta in [0.01, 0.1, 1.0]:
        pelt = segment_regression(y, phi, penalty=beta, min_size=2)
        assert all(feasible(a, b) for a, b in pelt.segments)
        objective = dp.costs_by_n_changes + beta * np.arange(11)
        if pelt.n_changes <= 10:
            assert pelt.objective == pytest.approx(objective.min(), rel=1e-9)


def test_pelt_exact_with_min_size():
    """PELT with min_size > p against the dynamic program over every number of changes.

    With a minimum size a start pruned at end b may still be the best one for
    ends b' < b + min_size; pruning it at once loses the optimum in several of
    these cases.
    """
    for seed in range(60):
        rng = np.random.default_rng(seed)
        N, min_size = int(rng.integers(40, 90)), int(rng.integers(2, 10))
        changes = tuple(sorted(rng.choice(np.arange(5, N - 5), 3, replace=False)))
        y, phi = random_regression(seed, N, 1, 2, changes=changes, noise=0.3)
        M_max = N // min_size - 1  # every feasible number of changes
        dp = segment_regression(y, phi, n_changes=M_max, min_size=min_size)
        for beta in [0.05, 0.3, 1.0]:
            pelt = segment_regression(y, phi, penalty=beta, min_size=min_size)
            objective = dp.costs_by_n_changes + beta * np.arange(M_max + 1)
            assert pelt.objective == pytest.approx(objective.min(), rel=1e-9), (seed, beta)
            assert all(b - a >= min_size for a, b in pelt.segments)


def test_pelt_exact_with_infeasible_stretches():
    """Zero-input stretches: a pruned start stays a candidate until [b, b') can be feasible."""
    for seed in range(250, 300):
        rng = np.random.default_rng(seed)
        N, min_size = int(rng.integers(40, 80)), int(rng.integers(2, 6))
        x, u = switching_system(seed, N + 1, 1, 1, changes=(N // 2,), noise=0.3)
        start = int(rng.integers(0, N - 10))
        u[start : start + int(rng.integers(3, 15))] = 0.0
        y, phi = x[1:], np.hstack([x[:-1], u[:-1]])
        M_max = N // min_size - 1
        dp = segment_regression(y, phi, n_changes=M_max, min_size=min_size)
        for beta in [0.01, 0.1, 0.5]:
            pelt = segment_regression(y, phi, penalty=beta, min_size=min_size)
            objective = dp.costs_by_n_changes + beta * np.arange(M_max + 1)
            finite = objective[np.isfinite(objective)]
            assert pelt.objective == pytest.approx(finite.min(), rel=1e-9), (seed, beta)


# -- ruptures -------------------------------------------------------------------------------


def test_agrees_with_ruptures_dynp_and_pelt():
    rpt = pytest.importorskip("ruptures")
    x, u = switching_system(3, 91, 1, 2, changes=(30, 62), noise=0.3)
    y, phi = x[1:, 0], np.hstack([x[:-1], u[:-1]])
    signal = np.column_stack([y, phi])  # ruptures' "linear": column 0 on the others
    cost = rpt.costs.CostLinear().fit(signal)

    def ruptures_cost(bkps):
        return sum(cost.error(a, b) for a, b in itertools.pairwise([0, *bkps]))

    for M in (1, 2, 3):
        bkps = rpt.Dynp(model="linear", min_size=3, jump=1).fit(signal).predict(n_bkps=M)
        ours = ltv.fit_segments(x, u, n_changes=M)
        assert ours.info["cost"] == pytest.approx(ruptures_cost(bkps), rel=1e-10)
        assert ours.changepoints.tolist() == bkps[:-1]
    for beta in (0.5, 3.0):
        bkps = rpt.Pelt(model="linear", min_size=3, jump=1).fit(signal).predict(pen=beta)
        ours = ltv.fit_segments(x, u, penalty=beta)
        assert ours.info["objective"] == pytest.approx(
            ruptures_cost(bkps) + beta * (len(bkps) - 1), rel=1e-10
        )


# -- the state-space front-end --------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jump_linear_switch_found(seed):
    """Paper Section VI: the switch at t = 200 is found within ±2 (known M and BIC)."""
    data = ltv.systems.jump_linear(seed=seed)
    model = ltv.fit_segments(data.x, data.u, n_changes=1)
    assert abs(int(model.changepoints[0]) - 200) <= 2
    assert model.info["solver"] == "dynamic programming" and model.info["n_changes"] == 1
    penalized = ltv.fit_segments(data.x, data.u)  # penalty="bic" by default
    assert penalized.changepoints.size == 1 and abs(int(penalized.changepoints[0]) - 200) <= 2
    assert penalized.info["penalty_rule"] == "bic"
    # the true A before and after the switch, roughly
    np.testing.assert_allclose(model.A[0], [[0.95, 0.1], [0.0, 0.95]], atol=0.15)
    np.testing.assert_allclose(model.A[-1], [[0.5, 0.05], [0.0, 0.5]], atol=0.2)


def test_model_is_the_piecewise_refit():
    x, u = switching_system(4, 120, 2, 1, changes=(50,), noise=0.1)
    model = ltv.fit_segments(x, u, n_changes=2, min_size=6)
    refit = ltv.fit_piecewise(x, u, model.changepoints)
    np.testing.assert_allclose(model.k, refit.k, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(model.std(), refit.std(), rtol=1e-12)
    assert model.norm == "l0"
    assert model.info["cost"] == pytest.approx(model.info["rss"], rel=1e-10)
    assert model.info["min_size"] == 6
    assert model.info["costs_by_n_changes"].shape == (3,)
    assert model.info["penalty"] is None
    np.testing.assert_array_equal(model.activation().nonzero()[0] + 1, model.changepoints)
    assert 50 in model.changepoints.tolist()


def test_multi_output(tmp_path):
    """n = 3 states, m = 2 inputs: brute force on a short record, the switches on a long one."""
    x, u = switching_system(8, 26, 3, 2, changes=(12,), noise=0.05)
    y, phi = x[1:], np.hstack([x[:-1], u[:-1]])
    best, cps = brute_force(y, phi, 1, 5)
    model = ltv.fit_segments(x, u, n_changes=1)
    assert model.info["cost"] == pytest.approx(best, rel=1e-10)
    assert model.changepoints.tolist() == list(cps)

    x, u = switching_system(9, 600, 3, 2, changes=(150, 420), noise=0.1)
    model = ltv.fit_segments(x, u, n_changes=2)
    assert model.changepoints.tolist() == [150, 420]
    penalized = ltv.fit_segments(x, u, penalty="bic")
    assert penalized.changepoints.tolist() == [150, 420]
    assert penalized.A.shape == (599, 3, 3) and penalized.B.shape == (599, 3, 2)
    path = tmp_path / "segments.npz"
    penalized.save(path)
    loaded = ltv.load(path)
    np.testing.assert_array_equal(loaded.changepoints, penalized.changepoints)
    assert loaded.info["solver"] == "PELT"


def test_min_size_default_and_effect():
    x, u = switching_system(10, 80, 2, 1, changes=(40,), noise=0.3)
    model = ltv.fit_segments(x, u, n_changes=3)
    assert model.info["min_size"] == 3  # p = n + m
    assert all(b - a >= 3 for a, b in model.info["segments"])
    wide = ltv.fit_segments(x, u, n_changes=3, min_size=15)
    assert all(b - a >= 15 for a, b in wide.info["segments"])
    assert wide.info["cost"] >= model.info["cost"]
    y, phi = x[1:], np.hstack([x[:-1], u[:-1]])
    assert wide.info["cost"] == pytest.approx(brute_force(y, phi, 3, 15)[0], rel=1e-10)
    # no changes: the LTI least-squares model
    lti = ltv.fit_segments(x, u, n_changes=0)
    np.testing.assert_allclose(lti.k, ltv.fit_lti(x, u).k, atol=1e-12)
    assert lti.changepoints.size == 0


def test_regression_entry_ar_model():
    """segment_regression on an AR(2) regression built by hand (the (y, φ) entry)."""
    rng = np.random.default_rng(12)
    N = 500
    s = np.zeros(N + 2)
    for t in range(2, N + 2):
        a = (1.5, -0.9) if t < 260 else (0.4, 0.3)
        s[t] = a[0] * s[t - 1] + a[1] * s[t - 2] + rng.standard_normal()
    y = s[2:]
    phi = np.column_stack([s[1:-1], s[:-2]])
    result = segment_regression(y, phi, n_changes=1)
    assert abs(int(result.changepoints[0]) - 258) <= 3
    assert result.segments == [[0, int(result.changepoints[0])], [int(result.changepoints[0]), N]]
    assert result.cost == pytest.approx(lstsq_cost(y, phi, result.changepoints), rel=1e-10)
    bic = segment_regression(y, phi)
    assert bic.penalty_rule == "bic" and bic.n_changes == 1
    assert bic.penalty == pytest.approx(2 * np.log(N) * bic.noise_var)
    aic = segment_regression(y, phi, penalty="aic")
    assert aic.penalty == pytest.approx(4 * aic.noise_var)


def test_noise_variance_estimate_ignores_changes():
    y, phi = random_regression(13, 2000, 2, 3, changes=(500, 1000, 1500), noise=0.5)
    sigma2 = noise_variance_estimate(y, phi)
    assert sigma2 == pytest.approx(0.25, rel=0.1)
    lti = lstsq_cost(y, phi, []) / (2 * (2000 - 3))
    assert lti > 2 * sigma2  # the LTI residual variance is inflated by the changes


def test_inputs_not_mutated_and_lists_accepted():
    x, u = switching_system(14, 50, 2, 1, changes=(25,))
    x0, u0 = x.copy(), u.copy()
    model = ltv.fit_segments(x.tolist(), u[:, 0].tolist(), n_changes=1)
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(u, u0)
    assert model.N == 49


# -- bad input ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs,exc,match",
    [
        ({"n_changes": -1}, ValueError, "n_changes: expected an integer >= 0, received -1"),
        ({"n_changes": 10}, ValueError, r"n_changes: 10 changes .* N = 29"),
        ({"n_changes": 1.5}, TypeError, "n_changes: expected an integer"),
        ({"n_changes": True}, TypeError, "n_changes: expected an integer"),
        ({"penalty": -1.0}, ValueError, "penalty: expected a finite real number >= 0"),
        ({"penalty": float("nan")}, ValueError, "penalty: expected a finite"),
        ({"penalty": float("inf")}, ValueError, "penalty: expected a finite"),
        ({"penalty": "mdl"}, ValueError, r"penalty: expected a number >= 0 or one of \('bic'"),
        ({"penalty": [1.0]}, TypeError, "penalty: expected a number"),
        ({"n_changes": 1, "penalty": 2.0}, TypeError, "n_changes, penalty: expected one"),
        ({"n_changes": 1, "min_size": 2}, ValueError, r"min_size: expected an integer >= p = 3"),
        ({"n_changes": 1, "min_size": 4.0}, TypeError, "min_size: expected None or an integer"),
        ({"n_changes": 0, "min_size": 40}, ValueError, "x: too few samples"),
    ],
)
def test_bad_input(kwargs, exc, match):
    x, u = switching_system(15, 30, 2, 1, changes=(15,))
    with pytest.raises(exc, match=match):
        ltv.fit_segments(x, u, **kwargs)


def test_bad_input_data():
    x, u = switching_system(16, 30, 2, 1, changes=(15,))
    with pytest.raises(ValueError, match="u: expected 30 rows"):
        ltv.fit_segments(x, u[:-1], n_changes=1)
    bad = x.copy()
    bad[3, 0] = -np.inf
    with pytest.raises(ValueError, match="x: expected finite values or NaN"):
        ltv.fit_segments(bad, u, n_changes=1)
    with pytest.raises(SingularProblemError, match="x: the regressors are linearly dependent"):
        ltv.fit_segments(x, np.zeros(30), n_changes=1)
    with pytest.raises(ValueError, match="phi: expected 29 rows"):
        segment_regression(x[1:], x[:-2], n_changes=1)
    with pytest.raises(TypeError, match="compute_cov"):
        ltv.fit_segments(x, u, n_changes=1, compute_cov=1)


def test_segment_regression_returns_the_unshrunk_segment_model():
    """statsmodels' Nile flow (1871–1970): one change, at 1899 (index 28); the segment
    levels are the segment means, 1097.75 and 849.97, computed here independently."""
    sm = pytest.importorskip("statsmodels.api")
    nile = sm.datasets.nile.load_pandas().data["volume"].to_numpy()
    seg = ltv.segment_regression(nile, np.ones(nile.size), n_changes=1)
    assert seg.changepoints.tolist() == [28]
    model = seg.model
    assert model.norm == "l0" and model.changepoints.tolist() == [28]
    np.testing.assert_allclose(model.theta[:28, 0, 0], nile[:28].mean(), rtol=1e-12)
    np.testing.assert_allclose(model.theta[28:, 0, 0], nile[28:].mean(), rtol=1e-12)
    assert model.std() is not None and model.info["cost"] == seg.cost
    # a segmentation that leaves no residual degree of freedom has no model
    assert ltv.segment_regression(nile[:2], np.ones(2), n_changes=1, min_size=1).model is None
