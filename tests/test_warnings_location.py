"""Every warning of ltvmodels is reported at the user's line, not inside the package.

Each warning is a real one, triggered through a public function; the warning
must name this file (the first frame outside the package), however deep in the
package it arises. ``ltvmodels.errors.warn`` finds that frame; no module
hard-codes a ``stacklevel``.

The Kalman functions (``kalman_filter``, ``kalman_smoother``,
``OnlineParameterFilter``) issue no warnings (they raise), and ``fit_many``
issues none in the calling process: the warnings of its units go to the
summary (:func:`test_fit_many_records_the_warnings_of_its_units`).
"""

from __future__ import annotations

import ast
import warnings
from pathlib import Path

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels import systems
from ltvmodels.control import LinearDynamics, QuadraticCost, ilqg
from ltvmodels.errors import find_stack_level, warn

HERE = Path(__file__).resolve()
SOURCE = HERE.parents[1] / "src" / "ltvmodels"


def assert_reported_here(record, category) -> None:
    """At least one warning of ``category``, and every one of them names this file."""
    found = [w for w in record if issubclass(w.category, category)]
    assert found, f"no {category.__name__} among {[str(w.message) for w in record]}"
    for w in found:
        assert Path(w.filename).resolve() == HERE, (
            f"{category.__name__} reported at {w.filename}:{w.lineno}: {w.message}"
        )


@pytest.fixture(scope="module")
def jump():
    return systems.jump_linear(seed=0)


@pytest.fixture(scope="module")
def ill_conditioned():
    """x (T, 1) of a stable AR(1), and an input u ≈ x: the regressors [x_t, u_t] are
    nearly collinear (smallest scaled eigenvalue ~1e-8: ill-conditioned, not singular)."""
    rng = np.random.default_rng(0)
    T = 200
    x = np.zeros((T, 1))
    for t in range(T - 1):
        x[t + 1] = 0.5 * x[t] + rng.standard_normal()
    return x, x + 1e-4 * rng.standard_normal((T, 1))


# -- ltv.fit --------------------------------------------------------------------------------------
def test_fit_interior_point_convergence(jump):
    with pytest.warns(ltv.ConvergenceWarning, match="interior-point method") as record:
        ltv.fit(jump.x, jump.u, lam=2.0, norm="l1", max_iter=2)
    assert_reported_here(record, ltv.ConvergenceWarning)


def test_fit_admm_convergence():
    big = systems.random_walk_system(T=120, n=7, m=3, seed=1, drift_std=0.01)  # K = 70: ADMM
    with pytest.warns(ltv.ConvergenceWarning, match="ADMM did not converge") as record:
        ltv.fit(big.x, big.u, lam=5.0, norm="group", max_iter=3)
    assert_reported_here(record, ltv.ConvergenceWarning)


@pytest.mark.parametrize("loss", ["huber", "laplace"])
def test_fit_robust_loss_convergence(jump, loss):
    with pytest.warns(ltv.ConvergenceWarning, match=f"loss='{loss}'") as record:
        ltv.fit(jump.x, jump.u, lam=10.0, loss=loss, max_iter=1)
    assert_reported_here(record, ltv.ConvergenceWarning)


def test_fit_ill_conditioned_data(ill_conditioned):
    x, u = ill_conditioned
    with pytest.warns(ltv.IdentifiabilityWarning, match="ill-conditioned") as record:
        ltv.fit(x, u, lam=10.0)
    assert_reported_here(record, ltv.IdentifiabilityWarning)


def test_fit_unexcited_input_decided_by_the_prior(ill_conditioned):
    x, _ = ill_conditioned
    prior = ltv.Prior(np.array([0.3, 0.7]), np.diag([1.0, 0.5]))
    with pytest.warns(ltv.IdentifiabilityWarning, match="The prior determines") as record:
        ltv.fit(x, np.zeros_like(x), lam=1.0, prior=prior, noise_var=0.09)
    assert_reported_here(record, ltv.IdentifiabilityWarning)


def test_fit_very_large_lam_loses_precision(jump):
    with pytest.warns(ltv.PrecisionWarning, match="lam=np.inf") as record:
        ltv.fit(jump.x, jump.u, lam=1e6, order=1)  # one factorization shared by the rows
    assert_reported_here(record, ltv.PrecisionWarning)
    prior = ltv.Prior(np.zeros(6), 1.0)
    with pytest.warns(ltv.PrecisionWarning, match="lam=np.inf") as record:
        ltv.fit(jump.x, jump.u, lam=1e6, order=1, prior=prior)  # the general solver
    assert_reported_here(record, ltv.PrecisionWarning)


# -- the other estimators -------------------------------------------------------------------------
def test_fit_ar_without_intercept_on_a_level():
    y = 50.0 + np.random.default_rng(1).standard_normal(300)
    with pytest.warns(ltv.ModelStructureWarning, match="pass constant=True") as record:
        ltv.fit_ar(y, 2, lam=10.0)
    assert_reported_here(record, ltv.ModelStructureWarning)


def test_select_lambda_on_ill_conditioned_data(ill_conditioned):
    x, u = ill_conditioned
    with pytest.warns(ltv.IdentifiabilityWarning, match="ill-conditioned") as record:
        ltv.select_lambda(x, u)
    assert_reported_here(record, ltv.IdentifiabilityWarning)


def test_fit_piecewise_ill_conditioned_segment(ill_conditioned, jump):
    """Order 1: one segment (u ≈ x) is ill-conditioned, the other is not."""
    x, u = ill_conditioned
    x = np.vstack([x[:100], jump.x[:100, :1]])
    u = np.vstack([u[:100], jump.u[:100]])
    with pytest.warns(ltv.IdentifiabilityWarning, match="segment 0") as record:
        ltv.fit_piecewise(x, u, changepoints=[100])
    assert_reported_here(record, ltv.IdentifiabilityWarning)


def test_fit_piecewise_linear_ill_conditioned(ill_conditioned):
    x, u = ill_conditioned
    with pytest.warns(ltv.IdentifiabilityWarning, match="ill-conditioned") as record:
        ltv.fit_piecewise(x, u, changepoints=[100], order=2)
    assert_reported_here(record, ltv.IdentifiabilityWarning)


def test_gmm_prior_em_limit(jump):
    pytest.importorskip("sklearn")
    with pytest.warns(ltv.ConvergenceWarning, match="GMMPrior: EM stopped") as record:
        ltv.GMMPrior(jump.x, jump.u, n_components=3, max_iter=1, seed=0)
    assert_reported_here(record, ltv.ConvergenceWarning)


def test_fit_many_records_the_warnings_of_its_units(jump):
    """The units' warnings go to the summary; none reaches the calling process."""
    pytest.importorskip("pandas")
    units = {"a": (jump.x, jump.u), "b": (jump.x, jump.u)}
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        models = ltv.fit_many(units, lam=2.0, norm="l1", max_iter=2, n_jobs=1)
    assert not [w for w in record if issubclass(w.category, ltv.ConvergenceWarning)]
    assert models.summary["warnings"].str.startswith("ConvergenceWarning").all()


# -- models, control and the package ---------------------------------------------------------------
def test_a_diverging_simulation():
    model = ltv.LTVModel(np.tile([[1e100, 0.0]], (40, 1)), 1, 1)
    with pytest.warns(ltv.DivergenceWarning, match="diverged") as record:
        model.simulate([1.0], np.zeros(41))
    assert_reported_here(record, ltv.DivergenceWarning)


def test_ilqg_unreachable_trust_region():
    N, n = 30, 3
    dynamics = LinearDynamics(np.tile(0.9 * np.eye(n), (N, 1, 1)), np.ones((N, n, 1)))
    x0, u_ref = np.ones(n), np.full((N, 1), 3.0)  # u_ref lies outside the input bounds
    x_ref = dynamics.simulate(x0, u_ref)
    cost = QuadraticCost(np.eye(n), np.eye(1), N, Qf=np.eye(n))
    with pytest.warns(ltv.ConvergenceWarning, match="trust region") as record:
        ilqg(
            dynamics,
            cost,
            x0,
            u_ref,
            trust_region=0.1,
            reference=(x_ref, u_ref),
            u_bounds=(-1.0, 1.0),
        )
    assert_reported_here(record, ltv.ConvergenceWarning)


def test_moved_modules():
    with pytest.warns(DeprecationWarning, match="moved to ltvmodels.apps.rl") as record:
        ltv.rl  # noqa: B018
    assert_reported_here(record, DeprecationWarning)
    with pytest.warns(DeprecationWarning, match="moved to ltvmodels.apps.rl") as record:
        from ltvmodels import rl  # noqa: F401  (through importlib's frames)
    assert_reported_here(record, DeprecationWarning)


# -- the helper -----------------------------------------------------------------------------------
def test_warn_called_outside_the_package_points_at_its_caller():
    assert find_stack_level() == 1
    with pytest.warns(UserWarning, match="here") as record:
        warn("here", UserWarning)
    assert_reported_here(record, UserWarning)


def test_every_warning_of_the_package_goes_through_the_helper():
    """No module calls warnings.warn, or passes a stacklevel, except ltvmodels.errors."""
    wrong = []
    for path in sorted(SOURCE.rglob("*.py")):
        if path.name == "errors.py" and path.parent == SOURCE:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr == "warn":
                if isinstance(node.value, ast.Name) and node.value.id == "warnings":
                    wrong.append(f"{path.relative_to(SOURCE)}:{node.lineno} calls warnings.warn")
            if isinstance(node, ast.keyword) and node.arg == "stacklevel":
                wrong.append(f"{path.relative_to(SOURCE)}:{node.value.lineno} passes stacklevel")
            if isinstance(node, ast.ImportFrom) and node.module == "warnings":
                wrong.append(f"{path.relative_to(SOURCE)}:{node.lineno} imports from warnings")
    assert not wrong, "\n".join(wrong)
