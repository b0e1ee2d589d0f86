"""``ltvmodels.lambda_max``: the smallest λ with Dk = 0, without running a fit."""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv

DATA = ltv.systems.jump_linear(T=300, change_at=150, seed=4)


@pytest.mark.parametrize("norm", ["group", "l1"])
@pytest.mark.parametrize("order", [1, 2])
def test_equals_the_value_a_fit_reports(norm, order):
    lam_max = ltv.lambda_max(DATA.x, DATA.u, norm=norm, order=order)
    fitted = ltv.fit(DATA.x, DATA.u, lam=1.0, norm=norm, order=order)
    assert lam_max == fitted.info["lambda_max"] == fitted.status.details["lambda_max"]


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_separates_the_lti_fit_from_a_varying_one(norm):
    """At λ_max the fit is the LTI model; just below it the coefficients change."""
    lam_max = ltv.lambda_max(DATA.x, DATA.u, norm=norm)
    at = ltv.fit(DATA.x, DATA.u, lam=lam_max, norm=norm)
    np.testing.assert_allclose(at.k, ltv.fit_lti(DATA.x, DATA.u).k, rtol=1e-10, atol=1e-12)
    below = ltv.fit(DATA.x, DATA.u, lam=0.7 * lam_max, norm=norm, tol=1e-9)
    assert np.abs(np.diff(below.k, axis=0)).max() > 1e-6 * np.abs(below.k).max()


def test_scales_with_the_data():
    """λ weighs ‖(Dk)_t‖ against squared residuals: λ_max scales with the square of y."""
    base = ltv.lambda_max(DATA.x, DATA.u, norm="group")
    assert ltv.lambda_max(3.0 * DATA.x, 3.0 * DATA.u, norm="group") == pytest.approx(9.0 * base)


def test_autonomous_system_and_lists():
    value = ltv.lambda_max(DATA.x.tolist(), norm="l1")
    assert value == ltv.fit(DATA.x, None, lam=1.0, norm="l1").info["lambda_max"]


@pytest.mark.parametrize(
    "kwargs, error, pattern",
    [
        ({"norm": "sq"}, ValueError, "norm: expected one of \\('group', 'l1'\\)"),
        ({"norm": "group", "order": 0}, ValueError, "order"),
        ({"norm": "group", "order": 400}, ValueError, "order"),
    ],
)
def test_invalid_options(kwargs, error, pattern):
    with pytest.raises(error, match=pattern):
        ltv.lambda_max(DATA.x, DATA.u, **kwargs)


def test_requires_the_norm_and_valid_data():
    with pytest.raises(TypeError):
        ltv.lambda_max(DATA.x, DATA.u)  # norm is keyword-only and required
    with pytest.raises(ValueError, match="u: expected 300 rows"):
        ltv.lambda_max(DATA.x, DATA.u[:10], norm="group")
    with pytest.raises(ltv.SingularProblemError):
        ltv.lambda_max(DATA.x, np.zeros((300, 1)), norm="group")
