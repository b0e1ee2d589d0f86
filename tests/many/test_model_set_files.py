"""Model sets on disk: units of every type, files only inside the set, damaged manifests.

``ModelSet.save`` / ``fit_many(models_dir=...)`` write a directory that
``load_many`` reads back; these tests write real directories under pytest's
``tmp_path`` and edit their ``manifest.json`` by hand.
"""

from __future__ import annotations

import datetime
import json
import uuid
from pathlib import Path

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.errors import ModelFileError, OutputPathError
from ltvmodels.estimators.many import check_unit_dtype

pd = pytest.importorskip("pandas")

from test_fit_many import INPUT, STATE, panel  # noqa: E402


def small_units(units):
    """A mapping {unit: (x, u)} of short jump-linear series, one per unit."""
    data = {}
    for seed, unit in enumerate(units):
        d = ltv.systems.jump_linear(T=40, change_at=20, seed=seed)
        data[unit] = (d.x, d.u)
    return data


def saved_set(tmp_path, units=("a", "b")):
    """A model set of ``units`` written by fit_many(models_dir=...), and its directory."""
    directory = tmp_path / "set"
    ms = ltv.fit_many(small_units(units), lam=5.0, n_jobs=1, models_dir=directory)
    return ms, directory


def edit_manifest(directory, change):
    """Apply ``change`` to the manifest's JSON object and write it back."""
    path = directory / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest = change(manifest) or manifest
    path.write_text(json.dumps(manifest))


# -- a model set reads only its own files -------------------------------------------------------
@pytest.mark.parametrize(
    "name",
    [
        "ABSOLUTE",  # replaced by the absolute path of a model file outside the set
        "../outside.npz",
        "../../outside.npz",
        "sub/inner.npz",
        "sub\\inner.npz",
        "",
        ".",
        "..",
    ],
)
def test_manifest_file_names_stay_inside_the_directory(tmp_path, name):
    ms, directory = saved_set(tmp_path)
    outside = tmp_path / "outside.npz"  # a valid model file that the set must not read
    ltv.fit(*small_units(["other"])["other"], lam=1.0).save(outside)
    (directory / "sub").mkdir()
    ltv.fit(*small_units(["other"])["other"], lam=1.0).save(directory / "sub" / "inner.npz")
    name = str(outside) if name == "ABSOLUTE" else name

    def point_outside(manifest):
        manifest["units"][1]["file"] = name

    edit_manifest(directory, point_outside)
    with pytest.raises(ModelFileError, match=r"entry 1 \(unit 'b'\): 'file' must be null or the"):
        ltv.load_many(directory)


def test_a_model_set_built_with_a_path_as_file_name_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"files: the model file of unit 'a' must be a file name"):
        ltv.ModelSet(["a"], [{"unit": "a"}], {}, directory=tmp_path, files={"a": "../x.npz"})


# -- units of any supported type round-trip -----------------------------------------------------
ROUND_TRIP_UNITS = [
    pd.Timestamp("2024-03-01 08:00", tz="Europe/Paris"),
    pd.Timestamp("2024-03-02 01:02:03.000000004"),
    datetime.date(2024, 3, 3),
    datetime.datetime(2024, 3, 4, 5, 6, 7, 8),
    datetime.datetime(2024, 3, 4, 5, tzinfo=datetime.timezone(datetime.timedelta(hours=-3))),
    7,
    np.int64(8),
    2.5,
    "m9",
    np.datetime64("2024-03-05T06:07", "m"),
    pd.Timedelta("1 day 2 ns"),
    datetime.timedelta(days=2, microseconds=3),
    np.timedelta64(5, "s"),
    uuid.UUID(int=12345),
    ("site", 3),
    True,
    None,
]


def test_units_of_any_supported_type_round_trip(tmp_path):
    data = small_units(ROUND_TRIP_UNITS)
    ms = ltv.fit_many(data, lam=5.0, n_jobs=1, models_dir=tmp_path / "written")
    ms.save(tmp_path / "saved")
    for directory in ("written", "saved"):
        back = ltv.load_many(tmp_path / directory)
        assert back.units == ms.units
        # Each unit comes back as a value of its type (numpy integers as Python ints).
        expected = [int if type(u) is np.int64 else type(u) for u in ROUND_TRIP_UNITS]
        assert [type(unit) for unit in back.units] == expected
        assert back.units[0].tz is not None and str(back.units[0].tz) == "Europe/Paris"
        for unit in ms:  # a lookup by the original unit finds its model file
            np.testing.assert_array_equal(back[unit].k, ms[unit].k)
        pd.testing.assert_frame_equal(back.summary, ms.summary)


def test_date_units_of_a_table_round_trip_with_every_method(tmp_path):
    """Units from a datetime column are pandas Timestamps; the summary of each method is JSON."""
    frame = panel(3, T=60, shuffle=False)
    starts = {
        unit: pd.Timestamp("2020-01-01") + pd.Timedelta(days=7 * i)
        for i, unit in enumerate(pd.unique(frame["unit"]))
    }
    frame["unit"] = frame["unit"].map(starts)
    runs = {
        "l1": dict(lam=3.0, norm="l1"),
        "auto": dict(lam="auto"),
        "segments": dict(method="segments", n_changes=1),
        "lti": dict(method="lti"),
    }
    for label, options in runs.items():
        directory = tmp_path / label
        ms = ltv.fit_many(
            frame,
            by="unit",
            state=STATE,
            inputs=INPUT,
            time="date",
            n_jobs=1,
            models_dir=directory,
            **options,
        )
        assert ms.errors == {} and all(isinstance(u, pd.Timestamp) for u in ms.units)
        for record in ms.records:  # what the manifest stores besides the unit: plain JSON
            json.dumps({key: value for key, value in record.items() if key != "unit"})
        back = ltv.load_many(directory)
        assert back.units == ms.units
        pd.testing.assert_frame_equal(back.summary, ms.summary)
        if label in ("l1", "segments"):  # change points as dates, as in the summary
            assert back.summary["change_times"].iloc[0][0].startswith("20")
        np.testing.assert_array_equal(back[ms.units[1]].k, ms[ms.units[1]].k)


def test_an_unsupported_unit_fails_before_any_model_is_written(tmp_path):
    data = small_units(["a", 1 + 2j])
    with pytest.raises(
        TypeError, match=r"data: unit \(1\+2j\) is of type complex, which .* supported unit types"
    ):
        ltv.fit_many(data, lam=5.0, n_jobs=1, models_dir=tmp_path / "set")
    assert list((tmp_path / "set").iterdir()) == []  # no model file without a manifest
    ms = ltv.fit_many(data, lam=5.0, n_jobs=1)  # in memory: fine
    with pytest.raises(TypeError, match=r"units: unit \(1\+2j\) is of type complex"):
        ms.save(tmp_path / "saved")
    assert not (tmp_path / "saved").exists()


def test_unit_column_dtypes_of_a_dask_frame_are_checked():
    """A dask DataFrame's units are known only on the cluster: its unit column's dtype is."""
    for values in (["a", "b"], [1, 2], [1.5, 2.5], pd.to_datetime(["2024-01-01"] * 2)):
        check_unit_dtype(pd.Series(values).dtype, "unit")
    check_unit_dtype(pd.Series(["a", "b"], dtype="category").dtype, "unit")
    check_unit_dtype(pd.Series(pd.date_range("2024", periods=2, tz="UTC")).dtype, "unit")
    with pytest.raises(TypeError, match=r"by: column 'unit' holds period\[M\] units"):
        check_unit_dtype(pd.Series(pd.period_range("2024-01", periods=2, freq="M")).dtype, "unit")
    with pytest.raises(TypeError, match="holds complex128 units"):
        check_unit_dtype(pd.Series([1 + 1j]).dtype, "unit")


# -- the manifest on disk --------------------------------------------------------------------------
def test_manifest_format_2_is_written_and_format_1_still_read(tmp_path):
    ms, directory = saved_set(tmp_path, units=[pd.Timestamp("2024-01-01"), "b"])
    manifest = json.loads((directory / "manifest.json").read_text())
    assert manifest["format"] == 2
    assert manifest["units"][0]["unit"] == {
        "type": "pandas.Timestamp",
        "value": "2024-01-01T00:00:00",
    }
    assert "unit" not in manifest["units"][0]["summary"]  # stored once, with its type
    assert [p.name for p in directory.iterdir() if p.name.endswith(".tmp")] == []

    # A manifest of format 1 (units that are not text or numbers as their text).
    old = tmp_path / "old"
    old.mkdir()
    for position, unit in enumerate(ms.units):
        ms[unit].save(old / f"unit-{position:06d}.npz")
    entries = [
        {
            "unit": str(unit) if not isinstance(unit, str) else unit,
            "file": f"unit-{position:06d}.npz",
            "error": None,
            "summary": {**record, "unit": str(unit)},
        }
        for position, (unit, record) in enumerate(zip(ms.units, ms.records))
    ]
    (old / "manifest.json").write_text(json.dumps({"format": 1, "by": "unit", "units": entries}))
    back = ltv.load_many(old)
    assert back.units == ["2024-01-01 00:00:00", "b"]
    np.testing.assert_array_equal(back["b"].k, ms["b"].k)
    assert back.summary.loc["b", "loglik"] == ms.summary.loc["b", "loglik"]


def test_summary_values_json_cannot_hold_are_written(tmp_path):
    """Records of another estimator may hold numpy values or dates: they are written."""
    records = [
        {
            "unit": "a",
            "T": np.int64(40),
            "peak": np.float32(1.5),
            "flags": np.array([1, 2]),
            "seen": datetime.date(2024, 1, 2),
        }
    ]
    ltv.ModelSet(["a"], records, {"a": "failed"}).save(tmp_path / "set")
    back = ltv.load_many(tmp_path / "set")
    assert back.records == [
        {"unit": "a", "T": 40, "peak": 1.5, "flags": [1, 2], "seen": "2024-01-02"}
    ]


def test_a_manifest_that_cannot_be_written_leaves_no_temporary_file(tmp_path):
    ms, directory = saved_set(tmp_path)
    target = tmp_path / "blocked"
    (target / "manifest.json").mkdir(parents=True)  # a directory where the file goes
    with pytest.raises(OutputPathError, match=r"directory: cannot write .*manifest.json"):
        ms.save(target)
    assert sorted(p.name for p in target.iterdir() if not p.name.endswith(".npz")) == [
        "manifest.json"
    ]


# -- models_dir and save(directory) that cannot be a directory ---------------------------------
def test_models_dir_that_cannot_be_created_fails_before_the_data_are_split(tmp_path):
    existing = tmp_path / "summary.csv"
    existing.write_text("unit\n")
    frame = panel(2, T=30)
    bad_places = [existing, existing / "models"]
    if Path("/proc").is_dir():  # (Linux) a directory where nothing can be created
        bad_places.append(Path("/proc") / "nope")
    for place in bad_places:
        with pytest.raises(OutputPathError, match=r"models_dir: .*; pass an existing directory"):
            # state names a missing column: the directory is checked before the split
            ltv.fit_many(frame, by="unit", state=["x9"], lam=1.0, models_dir=place)
    with pytest.raises(OutputPathError, match=r"models_dir: '.*summary.csv' is an existing file"):
        ltv.fit_many(small_units(["a"]), lam=1.0, models_dir=existing)
    ms = ltv.fit_many(small_units(["a"]), lam=1.0, n_jobs=1)
    with pytest.raises(OutputPathError, match=r"directory: '.*summary.csv' is an existing file"):
        ms.save(existing)
    assert existing.read_text() == "unit\n"


# -- damaged manifests --------------------------------------------------------------------------
def set_entry(index, key, value):
    def change(manifest):
        manifest["units"][index][key] = value

    return change


def drop_key(index, key):
    def change(manifest):
        del manifest["units"][index][key]

    return change


def in_format_1(change):
    def changed(manifest):
        change(manifest)
        manifest["format"] = 1

    return changed


def whole(value):
    return lambda manifest: value


DAMAGES = [
    (set_entry(1, "unit", [1]), r"entry 1: invalid unit: expected a text, .* received \[1\]"),
    (in_format_1(set_entry(1, "unit", [1])), r"entry 1: unit \[1\] is not a valid unit \(a list"),
    (set_entry(1, "unit", {"type": "pandas.Timestamp", "value": "soon"}), r"entry 1: invalid unit"),
    (set_entry(1, "unit", {"type": "set", "value": [1]}), r"entry 1: .*unknown unit type 'set'"),
    (set_entry(1, "unit", "a"), r"entry 1 \(unit 'a'\): the unit is also entry 0"),
    (set_entry(1, "file", 5), r"entry 1 \(unit 'b'\): 'file' must be null or the name of a file"),
    (set_entry(1, "error", 3), r"entry 1 \(unit 'b'\): 'error' must be null or a text"),
    (set_entry(1, "error", "boom"), r"entry 1 \(unit 'b'\): has both a model file and an error"),
    (set_entry(1, "summary", "x"), r"entry 1 \(unit 'b'\): 'summary' must be an object"),
    (drop_key(1, "file"), r"entry 1 \(unit 'b'\): no 'file'"),
    (drop_key(1, "unit"), r"entry 1: no 'unit'"),
    (lambda m: m.update(units={"a": 1}), r"'units' must be a list of entries"),
    (lambda m: m.update(units=["a", "b"]), r"entry 0: expected an object with unit, file"),
    (
        lambda m: m.update(format=9),
        r"unknown model-set format 9 \(this version reads formats 1, 2\)",
    ),
    (lambda m: m.update(by=["unit"]), r"'by' must be a text"),
    (whole([1, 2]), r"not a model-set manifest \(a JSON list"),
]


@pytest.mark.parametrize("change, message", DAMAGES)
def test_a_damaged_manifest_names_the_entry_and_the_problem(tmp_path, change, message):
    _, directory = saved_set(tmp_path)
    edit_manifest(directory, change)
    with pytest.raises(ModelFileError, match=message):
        ltv.load_many(directory)


def test_a_manifest_that_is_not_json(tmp_path):
    _, directory = saved_set(tmp_path)
    (directory / "manifest.json").write_text('{"format": 2, "units": [')
    with pytest.raises(ModelFileError, match=r"manifest.json: not a model-set manifest .*write"):
        ltv.load_many(directory)


def test_saving_into_its_own_directory_keeps_the_model_files(tmp_path):
    """fit_many(models_dir=...) with the models in memory too writes each model file once."""
    directory = tmp_path / "set"
    ms = ltv.fit_many(small_units(["a", "b", "c"]), lam=5.0, n_jobs=1, models_dir=directory)
    before = {p.name: p.stat().st_mtime_ns for p in directory.glob("*.npz")}
    ms.save(directory)
    after = {p.name: p.stat().st_mtime_ns for p in directory.glob("*.npz")}
    assert after == before and len(after) == 3
    assert ltv.load_many(directory).units == ["a", "b", "c"]
