"""fit_many checks its options and columns before fitting, and gets two subtle cases right.

The first tests are arguments that used to run (and fail every unit, or fit
the wrong thing); the last two compare against a recomputation the existing
tests did not make: the row order of an interleaved table without ``time``,
and the one-step RMS of a unit with missing samples.
"""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv

pd = pytest.importorskip("pandas")

from test_fit_many import INPUT, STATE, panel  # noqa: E402


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


# -- wrong answers the other tests would not see ------------------------------------------------
def interleaved_table(T):
    """Two units whose rows alternate (a row of a, a row of b, ...), without time stamps."""
    frames = []
    for seed, unit in enumerate(["a", "b"]):
        d = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
        frames.append(
            pd.DataFrame({"unit": unit, "x1": d.x[:, 0], "x2": d.x[:, 1], "u": d.u[:, 0]})
        )
    rows = np.column_stack([np.arange(T), np.arange(T) + T]).ravel()  # a0, b0, a1, b1, ...
    return pd.concat(frames, ignore_index=True).iloc[rows].reset_index(drop=True)


def test_interleaved_units_without_time_keep_their_row_order():
    """Each unit's rows in table order: enough rows that an unstable sort would mix them."""
    frame = interleaved_table(T=300)
    ms = ltv.fit_many(frame, by="unit", state=STATE, inputs=INPUT, lam=10.0, n_jobs=1)
    assert ms.units == ["a", "b"] and ms.errors == {}
    for unit in ms:
        rows = frame[frame["unit"] == unit]
        reference = ltv.fit(rows[STATE].to_numpy(), rows[INPUT].to_numpy(), lam=10.0)
        np.testing.assert_array_equal(ms[unit].k, reference.k)
        assert ms[unit].loglik == reference.loglik
        assert ms[unit].time is None  # no time column: the rows' order is the time


def test_rms_of_a_unit_with_missing_samples_counts_only_observed_transitions():
    frame = panel(2, T=120, shuffle=False)
    gap = frame.index[(frame["unit"] == "m1")][40:60]  # 20 missing rows: 21 transitions
    frame.loc[gap, "x1"] = np.nan
    ms = ltv.fit_many(frame, by="unit", state=STATE, inputs=INPUT, time="date", lam=5.0, n_jobs=1)
    assert ms.summary.loc["m1", "missing"] == 21
    for unit in ms:
        rows = frame[frame["unit"] == unit]
        x, u = rows[STATE].to_numpy(), rows[INPUT].to_numpy()
        error = x[1:] - ms[unit].predict(x, u)  # one-step predictions; NaN where missing
        observed = error[np.isfinite(error).all(axis=1)]
        assert len(observed) == (119 - 21 if unit == "m1" else 119)
        expected = np.sqrt(np.mean(observed**2))
        assert ms.summary.loc[unit, "rms"] == pytest.approx(expected, rel=1e-10)
