"""The data description: what every front-end records of the data in ``model.data``."""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.results.description import DataDescription, DataTail

D = ltv.systems.jump_linear(T=80, change_at=40, seed=0)


def test_info_keeps_the_solver_diagnostics_only():
    pd = pytest.importorskip("pandas")
    index = pd.date_range("2024", periods=80, freq="h")
    x = pd.DataFrame(D.x, index=index, columns=["a", "b"])
    x.iloc[10] = np.nan
    u = pd.DataFrame(D.u, index=index, columns=["f"])
    for model in (
        ltv.fit(x, u, lam=10.0),
        ltv.fit(x, u, lam=2.0, norm="l1", refine=True),
        ltv.fit_lti(x, u),
        ltv.fit_piecewise(x, u, [40]),
        ltv.fit_segments(x, u, n_changes=1),
    ):
        assert {"signal_names", "time", "n_missing"}.isdisjoint(model.info)
        assert dict(model.data.names) == {"state": ("a", "b"), "input": ("f",)}
        np.testing.assert_array_equal(model.time, index.values)
        assert model.n_missing == 2  # the transitions into and out of sample 10


def test_regressions_and_ar_models_are_described():
    pd = pytest.importorskip("pandas")
    index = pd.RangeIndex(100, 179)
    y = pd.Series(D.x[1:, 0], index=index, name="next")
    phi = pd.DataFrame(np.column_stack([D.x[:-1], D.u[:-1]]), index=index, columns=["p", "q", "r"])
    y.iloc[5] = np.nan
    model = ltv.fit_regression(y, phi, lam=10.0)
    assert dict(model.data.names) == {"output": ("next",), "regressor": ("p", "q", "r")}
    assert model.n_missing == 1 and model.regressor_names == ["p", "q", "r"]
    np.testing.assert_array_equal(model.time, index.values)
    seg = ltv.segment_regression(y, phi, n_changes=1)
    assert seg.model.n_missing == 1 and seg.model.output_names == ["next"]
    series = pd.Series(D.x[:, 0], index=pd.RangeIndex(1, 81), name="pos")
    ar = ltv.fit_ar(series, 2, lam=10.0)
    assert ar.output_names == ["pos"] and ar.n_missing == 0
    np.testing.assert_array_equal(ar.time, np.arange(1, 81))
    assert ltv.fit_ar(series.reset_index(drop=True), 2, lam=10.0).time is None


def test_trajectories_are_counted():
    x = np.stack([D.x, D.x + 0.01])
    u = np.stack([D.u, D.u])
    model = ltv.fit(x, u, lam=10.0)
    assert model.data.n_trajectories == 2 and model.time is None and not model.data.names


def test_with_data_returns_a_new_model_and_leaves_the_fitted_one_alone():
    model = ltv.fit(D.x, D.u, lam=10.0)
    named = model.with_data(model.data.renamed({"state": ["p", "v"], "input": ["f"]}))
    assert named.state_names == ["p", "v"] and model.state_names == ["x0", "x1"]
    assert named.k is not None and np.shares_memory(named.k, model.k)
    named.info["note"] = 1
    assert "note" not in model.info
    with pytest.raises(TypeError, match="data: expected a DataDescription"):
        model.with_data({"state": ["p", "v"]})


def test_names_of_a_role_are_used_only_when_they_fit_the_count():
    description = DataDescription.of({"state": ["a", "b"], "nonsense": ["z"], "input": None})
    assert dict(description.names) == {"state": ("a", "b")}
    assert description.names_of("state", 2) == ["a", "b"]
    assert description.names_of("state", 3) is None
    assert "state=['a', 'b']" in repr(description)


def test_the_tail_is_kept_by_renaming_and_replaced_by_with_tail():
    model = ltv.fit(D.x, D.u, lam=10.0)
    renamed = model.data.renamed({"state": ["p", "v"], "input": ["f"]})
    assert renamed.tail is model.data.tail and "tail=DataTail(" in repr(renamed)
    other = DataTail.of(D.x[None, :40], D.u[None, :40], model.tail_lengths)
    np.testing.assert_array_equal(model.data.with_tail(other).tail.outputs, D.x[39:40])
    assert model.data.with_tail(None).tail is None
    with pytest.raises(TypeError, match="tail: expected a DataTail or None, received ndarray"):
        model.data.with_tail(D.x[-1:])
    with pytest.raises(ValueError, match="outputs: expected the last samples .* missing"):
        DataTail(np.full((1, 2), np.nan), np.zeros((1, 1)))
