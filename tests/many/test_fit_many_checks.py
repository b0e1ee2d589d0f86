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
