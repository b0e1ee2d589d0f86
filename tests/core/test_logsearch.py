"""The coarse-to-fine maximization on log λ behind the choice of λ."""

import math

import numpy as np
import pytest

from ltvmodels.core.logsearch import maximize_on_log_scale

GRID = np.geomspace(1e-2, 1e4, 6)


def counted(function):
    """function, and a list that records the λ it was called with."""
    calls = []

    def wrapped(lam):
        calls.append(lam)
        return function(lam)

    return wrapped, calls


@pytest.mark.parametrize("peak", [0.05, 1.234, 5.0])
def test_a_smooth_maximum_is_found_to_the_tolerance_in_few_evaluations(peak):
    criterion, calls = counted(
        lambda lam: -((math.log(lam) - peak) ** 2) + 0.3 * math.sin(math.log(lam))
    )
    dense = np.geomspace(GRID[0], GRID[-1], 200_001)  # brute force
    expected = dense[np.argmax([criterion(v) for v in dense])]
    calls.clear()
    search = maximize_on_log_scale(criterion, GRID, xatol=1e-3)
    assert abs(math.log(search.best / expected)) < 2e-3
    assert search.n_evaluations == len(calls) <= GRID.size + 6
    assert np.all(np.diff(search.lams) > 0) and search.values.max() == criterion(search.best)


def test_every_local_maximum_of_the_grid_is_refined():
    """Two basins, the higher one off the grid's best point: both are refined and the
    higher wins."""

    def criterion(lam):
        v = math.log10(lam)
        return math.exp(-(((v - 0.3) / 0.8) ** 2)) + 1.05 * math.exp(-(((v - 3.1) / 0.6) ** 2))

    values = [criterion(v) for v in GRID]
    assert np.argmax(values) != np.argmin(np.abs(np.log10(GRID) - 3.1))  # the grid misleads
    search = maximize_on_log_scale(criterion, GRID, xatol=1e-4)
    assert math.log10(search.best) == pytest.approx(3.1, abs=2e-3)
    assert np.any(np.abs(np.log10(search.lams) - 0.3) < 0.01)  # the other basin, refined


def test_a_maximum_at_the_end_of_the_grid_stays_there_or_is_refined_inside():
    criterion, calls = counted(lambda lam: math.log(lam))
    search = maximize_on_log_scale(criterion, GRID, xatol=1e-3)
    assert search.best == GRID[-1] and len(calls) == GRID.size + 1  # the midpoint is lower
    peak = 0.6 * math.log(GRID[-1]) + 0.4 * math.log(GRID[-2])  # inside the last interval
    search = maximize_on_log_scale(lambda lam: -((math.log(lam) - peak) ** 2), GRID, xatol=1e-4)
    assert math.log(search.best) == pytest.approx(peak, abs=2e-4)


def test_unavailable_values_and_the_grid_values_as_given():
    def criterion(lam):
        if lam < 1.0:
            return -math.inf
        return math.nan if lam > 1e3 else -((math.log10(lam) - 2.0) ** 2)

    search = maximize_on_log_scale(criterion, GRID, xatol=1e-3)
    assert math.log10(search.best) == pytest.approx(2.0, abs=1e-3)
    np.testing.assert_array_equal(search.grid_values[:2], -np.inf)  # NaN counts as unavailable
    assert search.grid_values[-1] == -np.inf
    assert set(GRID) <= set(search.lams)  # the grid exactly as passed


def test_progress_reports_a_fraction_that_ends_at_one():
    reports = []
    search = maximize_on_log_scale(
        lambda lam: -((math.log(lam) - 1.0) ** 2),
        GRID,
        xatol=1e-3,
        progress=lambda done, total: reports.append((done, total)),
    )
    dones = [done for done, _ in reports]
    assert all(0 < done <= total for done, total in reports)
    assert dones[:-1] == list(range(1, search.n_evaluations + 1))
    assert reports[-1] == (search.n_evaluations, search.n_evaluations)


def test_a_level_criterion_ends_the_refinement():
    """Level values (e.g. cross-validation errors that do not depend on λ) tie the
    bracket's ends with its best point: the search stops, it does not fail."""
    search = maximize_on_log_scale(lambda lam: 1.0, GRID, xatol=1e-3)
    assert search.values.max() == 1.0 and GRID[0] <= search.best <= GRID[-1]
    step = maximize_on_log_scale(lambda lam: 1.0 if lam < 30.0 else 0.0, GRID, xatol=1e-3)
    assert step.values.max() == 1.0


def test_a_cubic_criterion_is_maximized_by_the_first_refining_step():
    """On a criterion that is a cubic in log λ, the first step after the grid (the
    maximum of the cubic through four grid points, in closed form) is the maximum."""
    low, top = -3.0, 0.37  # f'(s) = −(s − low)(s − top): a local maximum at s = top

    def criterion(lam: float) -> float:
        s = np.log(lam)
        return -(s**3) / 3.0 + (low + top) * s**2 / 2.0 - low * top * s

    grid = np.exp(np.linspace(-2.0, 3.0, 6))
    search = maximize_on_log_scale(criterion, grid, xatol=1e-3)
    assert np.log(search.best) == pytest.approx(top, abs=1e-10)
    assert search.n_evaluations <= grid.size + 2  # the step, and at most one check
