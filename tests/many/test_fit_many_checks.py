"""fit_many checks its options and columns before fitting.

Arguments that used to run (and fail every unit, or fit the wrong thing).
"""

from __future__ import annotations

import pytest

import ltvmodels as ltv

pd = pytest.importorskip("pandas")

from test_fit_many import STATE, panel  # noqa: E402


def keyword_needing(x, u=None, *, scale, **options):
    """``fit``, with ``scale`` (a required keyword-only option) recorded in ``info``."""
    model = ltv.fit(x, u, **options)
    model.info["scale"] = scale
    return model


# -- options ---------------------------------------------------------------------------------------
def test_a_required_option_that_is_missing_is_an_error_before_any_fit():
    frame = panel(2, T=30)
    with pytest.raises(
        TypeError, match=r"^lam: required by method='fit'; pass lam=\.\.\. \(a number or 'auto'\)$"
    ):
        ltv.fit_many(frame, by="unit", state=STATE, n_jobs=1)
    with pytest.raises(TypeError, match=r"^scale: required by method='keyword_needing'; pass"):
        ltv.fit_many(frame, by="unit", state=STATE, method=keyword_needing, lam=1.0, n_jobs=1)
    ms = ltv.fit_many(
        frame, by="unit", state=STATE, method=keyword_needing, scale=2.0, lam=1.0, n_jobs=1
    )
    assert ms.errors == {} and [ms[unit].info["scale"] for unit in ms] == [2.0, 2.0]
    # segments and lti require nothing; an option of fit is still not one of theirs
    assert len(ltv.fit_many(frame, by="unit", state=STATE, method="lti", n_jobs=1)) == 2
    with pytest.raises(TypeError, match=r"^lam: not an option of method='segments'"):
        ltv.fit_many(frame, by="unit", state=STATE, method="segments", lam=1.0)


# -- columns in two roles --------------------------------------------------------------------
@pytest.mark.parametrize(
    "columns, message",
    [
        (dict(time="x1"), r"^time: column 'x1' is also a state column \(state=\)"),
        (dict(inputs="u", time="u"), r"^time: column 'u' is also an input column \(inputs=\)"),
        (dict(time="w", weights="w"), r"^time: column 'w' is also the weights column"),
        (dict(by="id", time="id"), r"^time: column 'id' is also the unit column \(by=\)"),
        (dict(inputs=["u", "x2"]), r"^state, inputs: column 'x2' is named as both state and"),
        (dict(weights="x1"), r"^state, weights: column 'x1' is named as both"),
        (dict(state=["x1", "x2", "x1"]), r"^state: column 'x1' is named twice"),
    ],
)
def test_a_column_in_two_roles_is_an_error(columns, message):
    frame = panel(2, T=30, shuffle=False)
    frame["w"] = 1.0
    frame["id"] = frame["unit"].str[1:].astype(int)  # numeric units: a valid time dtype
    arguments = {"by": "unit", "state": STATE, **columns}
    with pytest.raises(ValueError, match=message):
        ltv.fit_many(frame, lam=1.0, n_jobs=1, **arguments)
