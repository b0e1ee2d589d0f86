"""Fuzz fit_many: over a mapping of drawn units it must equal a loop of ``fit`` calls.

Each example fits three units — the drawn data, the same recipe with another
seed, and a two-sample cut that no model identifies — in this process, with
drawn options of ``fit``. The inspector refits every unit with ``fit``: a unit
that ``fit`` rejects must be in ``errors`` with the same message, any other
unit's model must be bit for bit ``fit``'s and pass the model inspection.
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial

import numpy as np
import pytest
from fuzz_oracle import FuzzFailure, check_call, inspect_model
from fuzz_strategies import datasets, fuzz_test
from test_fuzz_fit import fit_options, resolved

import ltvmodels as ltv

pytest.importorskip("pandas")


def agrees_with_loop(units: dict, kwargs: dict, result, call, context) -> str:
    for name, (x, u) in units.items():
        try:
            reference = ltv.fit(x, u, **kwargs)
        except Exception as exc:  # noqa: BLE001 - the same error must be recorded
            expected = f"{type(exc).__name__}: {exc}"
            if result.errors.get(name) != expected:
                raise FuzzFailure(
                    call.label,
                    f"unit {name!r}: fit raised {expected[:120]}",
                    f"fit_many recorded {result.errors.get(name)!r}"[:200],
                    call.describe(),
                ) from exc
            continue
        if name in result.errors:
            raise FuzzFailure(
                call.label,
                f"unit {name!r} failed in fit_many only",
                result.errors[name][:200],
                call.describe(),
            )
        model = result[name]
        if not np.array_equal(model.k, reference.k):
            raise FuzzFailure(
                call.label, f"unit {name!r}: k differs from fit's", "", call.describe()
            )
        inspect_model(model, call, context)
    summary = result.summary
    if list(summary.index) != list(units):
        raise FuzzFailure(
            call.label, "summary rows are not the units", str(summary.index), call.describe()
        )
    return "finite"


@fuzz_test(
    datasets(max_T=40),
    fit_options(),
    examples=0.5,
    valid=(datasets(forms=False, max_T=40), fit_options(0)),
)
def test_fit_many(data, kwargs):
    """ltv.fit_many over a mapping of units equals the loop of ltv.fit, errors included."""
    kwargs = resolved(data, kwargs)
    recipes = {
        "drawn": data,
        "other seed": replace(data, seed=data.seed + 1),
        "two samples": replace(data, T=min(data.T, 2)),
    }
    units = {name: recipe.xu() for name, recipe in recipes.items()}
    check_call(
        ltv.fit_many,
        units,
        n_jobs=1,
        progress=False,
        inspector=partial(agrees_with_loop, units, kwargs),
        **kwargs,
    )
