"""One fit specification: every option is checked once, at the entry, by its declared constraint.

The invalid values come from the declarations themselves
(:data:`ltvmodels.estimators.spec.FIT_CONSTRAINTS`), so that a new option or
constraint is tested without a new list here.
"""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.estimators.spec import FIT_CONSTRAINTS, FitSpec

DATA = ltv.systems.jump_linear(T=60, change_at=30, seed=0)
SERIES = np.sin(np.arange(80) / 5.0) + 0.01 * np.random.default_rng(0).standard_normal(80)

FRONT_ENDS = {
    "fit": lambda **options: ltv.fit(DATA.x, DATA.u, **options),
    "fit_regression": lambda **options: ltv.fit_regression(
        DATA.x[1:, 0], np.column_stack([DATA.x[:-1], DATA.u[:-1]]), **options
    ),
    "fit_ar": lambda **options: ltv.fit_ar(SERIES, 2, **options),
    "fit_arx": lambda **options: ltv.fit_arx(SERIES, DATA.u[:80], 2, 1, **options),
}
TAKES = {  # options a front-end does not take (its signature has no such keyword)
    "fit_regression": {"progress"},
}
INVALID = [
    (front_end, name, value)
    for front_end in sorted(FRONT_ENDS)
    for name, constraint in FIT_CONSTRAINTS.items()
    if name not in TAKES.get(front_end, set())
    for value in constraint.invalid_examples()
]


def test_every_checked_option_declares_values_it_rejects():
    checked = {
        name for name, constraint in FIT_CONSTRAINTS.items() if constraint.invalid_examples()
    }
    assert checked == set(FIT_CONSTRAINTS) - {"order", "prior", "noise_var", "huber_delta"}


@pytest.mark.parametrize(
    ("front_end", "name", "value"), INVALID, ids=[f"{f}-{n}={v!r}" for f, n, v in INVALID]
)
def test_an_invalid_option_is_an_error_naming_it(front_end, name, value):
    options = {"lam": 10.0, name: value}
    with pytest.raises((ValueError, TypeError)) as raised:
        FRONT_ENDS[front_end](**options)
    assert str(raised.value).startswith(f"{name}: expected")


def test_the_options_are_checked_before_the_data():
    # An invalid option is reported even when the data are invalid too: the spec comes first.
    with pytest.raises(ValueError, match="^tol: expected"):
        ltv.fit(DATA.x, DATA.u[:-5], lam=1.0, tol=-1.0)


def test_the_spec_keeps_the_checked_values_and_defaults():
    spec = FitSpec.from_arguments({"lam": "auto", "max_iter": np.int64(50), "unrelated": 1})
    assert spec.lam_is_auto and spec.max_iter == 50 and type(spec.max_iter) is int
    assert (spec.norm, spec.loss, spec.tol, spec.refine) == ("sq", "squared", 1e-6, False)
    first = FitSpec.from_arguments({"lam": 2.0, "refine": True}).first_step()
    assert not first.refine and not first.compute_cov and first.lam == 2.0


def test_max_iter_and_tol_are_checked_with_every_norm():
    # They were checked only by the iterative solvers; now a wrong value is never ignored.
    with pytest.raises(ValueError, match="^max_iter: expected an integer >= 1"):
        ltv.fit(DATA.x, DATA.u, lam=10.0, norm="sq", max_iter=0)


def test_ar_models_take_the_two_step_refinement_as_every_front_end():
    rng = np.random.default_rng(0)
    y = np.r_[np.sin(np.arange(200) / 3), 2 * np.sin(np.arange(200) / 7)]
    y = y + 0.01 * rng.standard_normal(400)
    model = ltv.fit_ar(y, 2, lam=5.0, norm="group", refine=True)
    target, phi = ltv.ar_regressors(y, 2)
    reference = ltv.fit_regression(target, phi, lam=5.0, norm="group", refine=True)
    assert model.norm == "piecewise" and model.info["first_step"]["norm"] == "group"
    np.testing.assert_allclose(model.k, reference.k, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(model.changepoints, reference.changepoints)
