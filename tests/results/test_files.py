"""Model files: the current format keeps the fit status and the data description; files
of ltvmodels 0.1 and 0.2 still load.

The files in ``data/`` were written by ltvmodels 0.1 (format version 1) from
``systems.jump_linear(T=100, change_at=50, seed=0)`` with the calls in
:data:`FITS`. Loading one must give the model that the same call gives now,
with the fit status reconstructed from its ``info``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import ltvmodels as ltv

DATA_DIR = Path(__file__).resolve().parent / "data"
D = ltv.systems.jump_linear(T=100, change_at=50, seed=0)
X, U = D.x, D.u
PHI = np.hstack([X[:-1], U[:-1]])

FITS = {
    "ltv_sq": lambda **kw: ltv.fit(X, U, lam=10.0, **kw),
    "ltv_group": lambda: ltv.fit(X, U, lam=5.0, norm="group"),
    "ltv_refined": lambda: ltv.fit(X, U, lam=5.0, norm="group", refine=True),
    "ltv_lti": lambda: ltv.fit_lti(X, U),
    "ltv_segments": lambda: ltv.fit_segments(X, U, n_changes=1),
    "regression": lambda **kw: ltv.fit_regression(X[1:], PHI, lam=10.0, **kw),
    "ar": lambda: ltv.fit_ar(X[:, 0], na=2, lam=10.0, constant=True),
    "arx": lambda: ltv.fit_arx(X[:, 0], U, na=2, nb=1, lam=10.0),
}

ITERATIVE = ("ltv_group",)
"""Fits whose result is an interior point's at its tolerance (1e-6 of the objective)."""
ITERATIVE_RTOL = 1e-3
"""How far such a fit's k and noise variance may move within that tolerance."""


def version_of(path: Path) -> int:
    with np.load(path, allow_pickle=False) as data:
        return json.loads(str(data["meta"]))["format_version"]


@pytest.mark.parametrize("name", list(FITS))
def test_files_of_version_0_1_load_as_the_same_model(name):
    path = DATA_DIR / f"v0.1_{name}.npz"
    assert version_of(path) == 1
    old, new = ltv.load(path), FITS[name]()
    if name in ("ltv_sq", "regression"):
        # 0.1 estimated one noise variance for all outputs, 0.2 one per output
        # (the same k): with the file's shared variance given, everything agrees.
        assert len(set(new.noise_var)) == 2 and len(set(old.noise_var)) == 1
        new = FITS[name](noise_var=old.noise_var[0])
    # An interior-point fit agrees with a refit by a later version (another start,
    # the same optimum) to the solver's tolerance, not to rounding.
    rtol = ITERATIVE_RTOL if name in ITERATIVE else 1e-10
    if name in ITERATIVE:
        assert old.info["objective"] == pytest.approx(new.info["objective"], rel=1e-6)
    # the other estimators' 0.1 noise_var was the mean of today's per-output variances
    assert old.noise_var == pytest.approx(np.mean(new.noise_var), rel=rtol)
    assert type(old) is type(new) and old.structure() == new.structure()
    np.testing.assert_allclose(old.k, new.k, rtol=rtol, atol=rtol * np.abs(new.k).max())
    assert old.norm == new.norm
    if new.loglik is None:  # version 0.1 wrote NaN where no likelihood exists
        assert old.loglik is None
    else:
        assert old.loglik == pytest.approx(new.loglik, rel=1e-10)
    if new.cov is not None:
        np.testing.assert_allclose(old.cov, new.cov, rtol=1e-8, atol=1e-14)
    np.testing.assert_array_equal(old.changepoints, new.changepoints)
    # new in 0.2, and model.outliers (every fit) later
    newer = {"loglik_note", "last_segment_unit_cov"}
    newer |= {"outliers", "outlier_scale", "outlier_threshold", "n_outliers"}
    assert set(old.info) == set(new.info) - newer
    assert old.outliers is None and new.outliers is not None
    # The status of a 0.1 file is reconstructed from its info: that of the same fit now.
    assert old.status.status == new.status.status
    assert old.status.solver == new.status.solver
    if name in ITERATIVE:  # the iterations of the file's fit, not of today's start
        assert old.status.iterations == old.info["iterations"]
    else:
        assert old.status.iterations == new.status.iterations
    assert old.status.objective == pytest.approx(
        new.status.objective, rel=1e-6 if name in ITERATIVE else 1e-10
    )
    assert set(old.status.details) == set(new.status.details)


def dated_frames(gap: bool = True):
    pd = pytest.importorskip("pandas")
    index = pd.date_range("2024-01-01", periods=len(X), freq="D")
    x = pd.DataFrame(X, index=index, columns=["pos", "vel"])
    if gap:
        x.iloc[40:43] = np.nan
    return x, pd.DataFrame(U, index=index, columns=["force"])


def test_current_files_are_version_3_and_keep_the_status_and_the_data(tmp_path):
    model = ltv.fit(*dated_frames(), lam=5.0, norm="group")
    path = tmp_path / "m.npz"
    model.save(path)
    assert version_of(path) == 3
    loaded = ltv.load(path)
    assert loaded.status == model.status
    assert dict(loaded.data.names) == {"state": ("pos", "vel"), "input": ("force",)}
    np.testing.assert_array_equal(loaded.time, model.time)
    assert loaded.n_missing == model.n_missing == 4 and loaded.data.n_trajectories == 1
    assert loaded.state_names == ["pos", "vel"] and loaded.input_names == ["force"]
    # a model without a status (given coefficients) round-trips too
    given = ltv.LTVModel(D.k, 2, 1)
    given.save(path)
    again = ltv.load(path)
    assert again.status is None and again.norm is None
    np.testing.assert_array_equal(again.k, D.k)


def test_version_2_files_keep_names_time_and_missing_in_info_and_load_them_as_data(tmp_path):
    # Version 2 wrote the data's names, time and missing count into info.
    model = ltv.fit(*dated_frames(), lam=10.0)
    path = tmp_path / "m.npz"
    model.save(path)
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    meta = json.loads(str(arrays.pop("meta")))
    meta["format_version"] = 2
    meta.pop("data")
    meta["info"]["signal_names"] = {"state": ["pos", "vel"], "input": ["force"]}
    meta["info"]["n_missing"] = 4
    arrays["info__time"] = arrays.pop("data_time")
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    loaded = ltv.load(path)
    assert {"signal_names", "time", "n_missing"}.isdisjoint(loaded.info)
    assert dict(loaded.data.names) == dict(model.data.names)
    np.testing.assert_array_equal(loaded.time, model.time)
    assert loaded.n_missing == 4


def test_unreadable_versions_are_rejected(tmp_path):
    path = tmp_path / "future.npz"
    ltv.fit_lti(X, U).save(path)
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    meta = json.loads(str(arrays["meta"]))
    meta["format_version"] = 99
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match="unsupported model file version 99"):
        ltv.load(path)


def test_files_keep_the_end_of_the_data_and_load_without_it_when_older(tmp_path):
    path = tmp_path / "m.npz"
    future = np.zeros((4, 1))
    cases = [  # each model, and its start for the same forecast (recorded inputs first)
        (ltv.fit(X, U, lam=10.0), X[-1], np.r_[U[-1:], future[:3]]),
        (FITS["arx"](), X[-2:, 0], np.r_[U[-2:], future]),
    ]
    for model, start, inputs in cases:
        model.save(path)
        loaded = ltv.load(path)
        np.testing.assert_array_equal(loaded.data.tail.outputs, model.data.tail.outputs)
        np.testing.assert_array_equal(loaded.data.tail.inputs, model.data.tail.inputs)
        np.testing.assert_array_equal(
            loaded.forecast(steps=4, u=future).mean, model.forecast(steps=4, u=future).mean
        )
        # a version-3 file written before models kept their end: the same model, no tail
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files if not key.startswith("data_tail")}
        np.savez(path, **arrays)
        older = ltv.load(path)
        assert older.data.tail is None
        with pytest.raises(TypeError, match="does not remember the end of its data"):
            older.forecast(steps=4, u=future)
        assert older.forecast(start, inputs).steps == 4
    assert ltv.load(DATA_DIR / "v0.1_ltv_sq.npz").data.tail is None


@pytest.mark.parametrize(
    "outputs, inputs",
    [
        (np.zeros((1, 3)), np.zeros((1, 1))),
        (np.zeros((1, 2)), np.zeros((2, 1))),
        (np.full((1, 2), np.nan), np.zeros((1, 1))),
    ],
)
def test_a_damaged_data_tail_is_a_model_file_error(tmp_path, outputs, inputs):
    path = tmp_path / "m.npz"
    ltv.fit(X, U, lam=10.0).save(path)
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    arrays["data_tail_outputs"], arrays["data_tail_inputs"] = outputs, inputs
    np.savez(path, **arrays)
    with pytest.raises(ltv.ModelFileError, match=r"m\.npz"):
        ltv.load(path)


def edited_file(tmp_path, model, **members):
    """``model`` saved, with ``members`` replaced (arrays) or, for "meta_<key>", the JSON
    entry <key> of its meta replaced: a file edited by hand."""
    path = tmp_path / "edited.npz"
    model.save(path)
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    meta = json.loads(str(arrays["meta"]))
    for key, value in members.items():
        if key.startswith("meta_"):
            meta[key[len("meta_") :]] = value
        else:
            arrays[key] = value
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize(
    "noise_cov, problem",
    [
        (-np.eye(2), r"positive semidefinite matrix, received one with eigenvalue -1"),
        (np.array([[1.0, 2.0], [2.0, 1.0]]), r"positive semidefinite .* eigenvalue -1"),
        (np.array([[1.0, 0.5], [0.0, 1.0]]), r"expected a symmetric matrix"),
        (np.array([[1.0, np.inf], [np.inf, 1.0]]), r"expected finite values"),
        (np.eye(3), r"expected a \(2, 2\) matrix, received shape \(3, 3\)"),
    ],
)
def test_a_noise_covariance_edited_to_be_invalid_is_rejected_on_loading(
    tmp_path, noise_cov, problem
):
    # Such a file used to load and forecast a negative covariance.
    model = ltv.LTVModel.from_arrays(0.5 * np.eye(2), steps=5, noise_cov=np.eye(2))
    path = edited_file(tmp_path, model, noise_cov=noise_cov)
    with pytest.raises(
        ltv.ModelFileError, match=rf"^path: .* holds an invalid 'noise_cov' .*{problem}"
    ):
        ltv.load(path)


@pytest.mark.parametrize("value, text", [(-1.0, "-1"), (None, "nan")])
def test_a_noise_variance_edited_to_be_invalid_is_rejected_naming_the_value(tmp_path, value, text):
    path = edited_file(tmp_path, ltv.fit(X, U, lam=10.0), meta_noise_var=[0.1, value])
    with pytest.raises(
        ltv.ModelFileError,
        match=rf"invalid 'noise_var' \(expected 2 finite variances >= 0, received {text} at "
        "position 1\\)",
    ):
        ltv.load(path)


def test_fitted_noise_covariances_load_as_they_were_saved(tmp_path):
    for model in (ltv.fit(X, U, lam=10.0), ltv.fit_arx(X[:, 0], U, na=2, nb=1, lam=10.0)):
        path = tmp_path / "m.npz"
        model.save(path)
        np.testing.assert_array_equal(ltv.load(path).noise_cov, model.noise_cov)


@pytest.mark.parametrize("key, value", [("na", 1.5), ("nk", -1)])
def test_ar_orders_edited_to_be_invalid_are_rejected_naming_them(tmp_path, key, value):
    # The sizes of an AR/ARX model were taken as int(value): 1.5 read as 1.
    model = ltv.fit_arx(X[:, 0], U, na=2, nb=1, lam=10.0)
    path = edited_file(tmp_path, model, **{f"meta_{key}": value})
    with pytest.raises(ltv.ModelFileError, match=rf"{key}: expected an integer >= 0"):
        ltv.load(path)


def test_a_time_axis_edited_to_decrease_is_rejected_on_loading(tmp_path):
    # It loaded, and to_statespace took its negative step for the sampling period.
    model = ltv.fit(X, U, lam=10.0).with_data(ltv.DataDescription.of(time=np.arange(100) * 0.5))
    path = edited_file(tmp_path, model, data_time=np.arange(100)[::-1] * 0.5)
    with pytest.raises(ltv.ModelFileError, match=r"invalid 'data_time' \(expected increasing"):
        ltv.load(path)
