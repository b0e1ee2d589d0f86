"""fit_many: one model per unit, equal bit for bit to a loop of the estimator's calls.

The local engines run for real (this process and a forked process pool); the
Dask tests start a real ``LocalCluster`` with worker processes and shut it
down. The fault tests kill worker processes during a run.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import ltvmodels as ltv

pd = pytest.importorskip("pandas")

STATE, INPUT = ["x1", "x2"], ["u"]


def unit_frame(unit, T, seed, *, change_at=None, start="2021-01-01"):
    d = ltv.systems.jump_linear(
        T=T, change_at=T // 2 if change_at is None else change_at, seed=seed
    )
    return pd.DataFrame(
        {
            "unit": unit,
            "date": pd.date_range(start, periods=T, freq="D"),
            "x1": d.x[:, 0],
            "x2": d.x[:, 1],
            "u": d.u[:, 0],
        }
    )


def panel(n_units, T=80, *, shuffle=True):
    """A long table of jump-linear units with dates, rows shuffled across units."""
    frame = pd.concat([unit_frame(f"m{i}", T, seed=i) for i in range(n_units)], ignore_index=True)
    return frame.sample(frac=1.0, random_state=0) if shuffle else frame


def unit_rows(frame, unit):
    """What a user of ``fit`` passes for one unit: its rows by date, indexed by date."""
    rows = frame[frame["unit"] == unit].sort_values("date").set_index("date")
    return rows[STATE], rows[INPUT]


def assert_same_model(a, b):
    """Bit-for-bit equality of everything a model carries."""
    assert type(a) is type(b)
    np.testing.assert_array_equal(a.k, b.k)
    for name in ("cov", "noise_var", "time", "changepoints"):
        left, right = getattr(a, name), getattr(b, name)
        assert (left is None) == (right is None), name
        if left is not None:
            np.testing.assert_array_equal(left, right, err_msg=name)
    assert a.loglik == b.loglik or (a.loglik is None and b.loglik is None)
    assert a.state_names == b.state_names and a.input_names == b.input_names
    assert a.status == b.status
    assert a.info.keys() == b.info.keys()
    for key in a.info:
        if isinstance(a.info[key], np.ndarray):
            np.testing.assert_array_equal(a.info[key], b.info[key], err_msg=key)
        else:
            assert a.info[key] == b.info[key], key


# -- local engines -----------------------------------------------------------------------
@pytest.mark.parametrize("n_jobs", [1, 2])
def test_table_input_equals_a_loop_of_fit(n_jobs):
    frame = panel(6)
    ms = ltv.fit_many(
        frame, by="unit", state=STATE, inputs="u", time="date", lam=10.0, n_jobs=n_jobs
    )
    assert ms.units == [f"m{i}" for i in pd.unique(frame["unit"].str[1:].astype(int))]
    assert len(ms) == 6 and ms.errors == {}
    for unit in ms:
        x, u = unit_rows(frame, unit)
        assert_same_model(ms[unit], ltv.fit(x, u, lam=10.0))
    assert ms["m0"].time[0] == np.datetime64("2021-01-01")
    assert ms["m0"].state_names == STATE


@pytest.mark.parametrize(
    "options",
    [
        {"lam": "auto"},
        {"lam": 3.0, "norm": "group", "refine": True},
        {"lam": 10.0, "order": 2, "constant": True},
        {"lam": 10.0, "loss": "huber"},
    ],
)
def test_options_reach_fit(options):
    frame = panel(3, T=60)
    ms = ltv.fit_many(frame, by="unit", state=STATE, inputs=INPUT, time="date", n_jobs=1, **options)
    for unit in ms:
        assert_same_model(ms[unit], ltv.fit(*unit_rows(frame, unit), **options))
    if options.get("lam") == "auto":
        assert set(ms.summary["lam_method"]) == {"ml"}
        assert ms.summary["lam"].to_numpy() == pytest.approx([ms[unit].lam for unit in ms.units])


@pytest.mark.parametrize(
    "method, options, reference",
    [
        ("segments", {"n_changes": 1}, ltv.fit_segments),
        ("lti", {}, ltv.fit_lti),
    ],
)
def test_other_estimators(method, options, reference):
    data = {seed: ltv.systems.jump_linear(T=60, change_at=30, seed=seed) for seed in range(3)}
    ms = ltv.fit_many(
        {seed: (d.x, d.u) for seed, d in data.items()}, method=method, n_jobs=2, **options
    )
    for seed, d in data.items():
        assert_same_model(ms[seed], reference(d.x, d.u, **options))
    if method == "segments":
        assert list(ms.summary["n_changes"]) == [1, 1, 1]
        assert list(ms.summary["change_times"]) == [ms[seed].changepoints.tolist() for seed in data]


def test_mapping_input_equals_a_loop_of_fit():
    d = ltv.systems.jump_linear(T=50, change_at=25, seed=1)
    frame = pd.DataFrame(d.x, columns=["a", "b"], index=pd.RangeIndex(100, 150))
    data = {
        "plain": d.x,
        "pair": (d.x, d.u),
        "frame": (frame, d.u),
        "two runs": (np.stack([d.x, d.x[::-1]]), np.stack([d.u, d.u[::-1]])),
    }
    ms = ltv.fit_many(data, lam=5.0, n_jobs=2)
    assert ms.units == list(data) and ms.errors == {}
    for unit, value in data.items():
        x, u = value if isinstance(value, tuple) else (value, None)
        assert_same_model(ms[unit], ltv.fit(x, u, lam=5.0))
    assert ms["frame"].state_names == ["a", "b"]
    assert ms.summary.loc["two runs", "T"] == 50


def test_bad_units_are_recorded_and_the_others_fitted():
    frame = panel(3, T=60, shuffle=False)
    short = unit_frame("short", 2, seed=5)
    constant = unit_frame("constant input", 60, seed=6).assign(u=0.0)
    empty = unit_frame("no data", 60, seed=7).assign(x1=np.nan, x2=np.nan)
    dup = unit_frame("duplicated", 60, seed=8)
    dup.loc[5, "date"] = dup.loc[4, "date"]
    frame = pd.concat([frame, short, constant, empty, dup], ignore_index=True)
    ms = ltv.fit_many(frame, by="unit", state=STATE, inputs="u", time="date", lam=10.0, n_jobs=2)
    assert set(ms.errors) == {"short", "constant input", "no data", "duplicated"}
    assert "too few samples" in ms.errors["short"]
    assert (
        "SingularProblemError" in ms.errors["constant input"] and "u" in ms.errors["constant input"]
    )
    assert "no observed samples" in ms.errors["no data"]
    assert "duplicated time stamp 2021-01-05" in ms.errors["duplicated"]
    assert len(ms) == 3 and list(ms) == ["m0", "m1", "m2"]
    assert "m0" in ms and "short" not in ms and "elsewhere" not in ms
    summary = ms.summary
    assert list(summary.index) == ms.units
    assert list(summary["status"]) == ["closed_form"] * 3 + ["error"] * 4
    assert summary.loc["short", "T"] == 2 and summary.loc["short", "error"] == ms.errors["short"]
    with pytest.raises(KeyError, match="was not fitted: .*too few samples"):
        ms["short"]


def test_summary_columns():
    frame = panel(2, T=100)
    ms = ltv.fit_many(
        frame, by="unit", state=STATE, inputs="u", time="date", lam=2.0, norm="group", n_jobs=1
    )
    row = ms.summary.loc["m0"]
    model = ms["m0"]
    x, u = unit_rows(frame, "m0")
    error = x.to_numpy()[1:] - model.predict(x.to_numpy(), u.to_numpy())
    assert row["T"] == 100 and row["missing"] == 0
    assert row["lam"] == 2.0 and row["lam_method"] == "given"
    assert row["noise_var_x1"] == model.noise_var[0] and row["noise_var_x2"] == model.noise_var[1]
    assert row["rms"] == pytest.approx(np.sqrt(np.mean(error**2)), rel=1e-12)
    assert row["n_changes"] == len(model.changepoints) >= 1
    assert row["change_times"] == [
        str(t) for t in np.datetime_as_string(model.changepoint_times, unit="auto")
    ]
    assert row["status"] == "optimal" and row["seconds"] > 0
    assert ms.summary.index.name == "unit"


def test_weights_column_and_missing_samples():
    frame = panel(2, T=60, shuffle=False)
    frame["w"] = np.linspace(0.5, 2.0, len(frame))
    frame.loc[10, "x1"] = np.nan
    ms = ltv.fit_many(
        frame, by="unit", state=STATE, inputs="u", time="date", weights="w", lam=10.0, n_jobs=1
    )
    rows = frame[frame["unit"] == "m0"].set_index("date")
    reference = ltv.fit(rows[STATE], rows[INPUT], lam=10.0, weights=rows["w"].to_numpy()[:-1])
    assert_same_model(ms["m0"], reference)
    assert ms.summary.loc["m0", "missing"] == 2  # the NaN leaves out two transitions


def test_invalid_arguments_name_the_argument():
    frame = panel(2, T=30)
    with pytest.raises(ValueError, match=r"state: column 'x9' is not in data; its columns"):
        ltv.fit_many(frame, by="unit", state=["x1", "x9"], lam=1.0)
    with pytest.raises(TypeError, match="by: expected the name"):
        ltv.fit_many(frame, state=STATE, lam=1.0)
    with pytest.raises(TypeError, match="lamda: not an option of method='fit'"):
        ltv.fit_many(frame, by="unit", state=STATE, lamda=1.0)
    with pytest.raises(TypeError, match="engine: expected None"):
        ltv.fit_many(frame, by="unit", state=STATE, lam=1.0, engine="cluster")
    with pytest.raises(TypeError, match="data: expected a long pandas DataFrame"):
        ltv.fit_many(np.zeros((10, 2)), lam=1.0)
    with pytest.raises(TypeError, match="weights: a column name needs a table"):
        ltv.fit_many({"a": np.zeros((10, 2))}, lam=1.0, weights="w")
    with pytest.raises(ValueError, match="method: expected one of"):
        ltv.fit_many(frame, by="unit", state=STATE, method="kalman")
    with pytest.raises(TypeError, match="time: column 'unit' holds"):
        ltv.fit_many(frame, by="unit", state=STATE, time="unit", lam=1.0)
    with pytest.raises(ValueError, match="n_jobs"):
        ltv.fit_many(frame, by="unit", state=STATE, lam=1.0, n_jobs=0)


def test_save_and_load_many(tmp_path):
    frame = panel(3, T=40)
    frame.loc[frame.index[:3], "unit"] = "short"  # three rows of their own: too short
    ms = ltv.fit_many(frame, by="unit", state=STATE, inputs="u", time="date", lam=10.0, n_jobs=1)
    ms.save(tmp_path / "set")
    back = ltv.load_many(tmp_path / "set")
    assert back.units == ms.units and back.errors == ms.errors and list(back) == list(ms)
    for unit in ms:
        np.testing.assert_array_equal(back[unit].k, ms[unit].k)
    pd.testing.assert_frame_equal(back.summary, ms.summary)
    with pytest.raises(FileNotFoundError, match="manifest.json"):
        ltv.load_many(tmp_path)


def test_keep_models_false_writes_models_as_they_finish(tmp_path):
    frame = panel(4, T=40)
    ms = ltv.fit_many(
        frame,
        by="unit",
        state=STATE,
        inputs="u",
        time="date",
        lam=10.0,
        keep_models=False,
        models_dir=tmp_path / "models",
        n_jobs=2,
    )
    assert sorted(p.name for p in (tmp_path / "models").iterdir()) == ["manifest.json"] + [
        f"unit-{i:06d}.npz" for i in range(4)
    ]
    for unit in ms:  # read back from the directory
        assert_same_model(ms[unit], ltv.fit(*unit_rows(frame, unit), lam=10.0))
    bare = ltv.fit_many(frame, by="unit", state=STATE, lam=10.0, keep_models=False, n_jobs=1)
    with pytest.raises(KeyError, match="models_dir"):
        bare["m0"]
    assert len(bare.summary) == 4


def retained_and_peak_bytes(data, **options):
    """Memory held by the result and the peak during the run, in this process."""
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        ms = ltv.fit_many(data, lam=10.0, n_jobs=1, **options)
        current, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(ms) == len(data)
    return current - before, peak - before


def test_keep_models_false_memory_stays_flat():
    """Memory measured (not timed): without models, growing the units 4× adds only their
    summary records; with models, every unit keeps its model."""
    data = {
        unit: (d.x, d.u)
        for unit, d in enumerate(
            ltv.systems.jump_linear(T=200, change_at=100, seed=seed) for seed in range(400)
        )
    }
    small = dict(list(data.items())[:100])
    kept_small, _ = retained_and_peak_bytes(small)
    kept_large, _ = retained_and_peak_bytes(data)
    flat_small, peak_small = retained_and_peak_bytes(small, keep_models=False)
    flat_large, peak_large = retained_and_peak_bytes(data, keep_models=False)
    per_model = (kept_large - kept_small) / 300
    per_record = (flat_large - flat_small) / 300
    assert per_model > 20_000  # a model of T = 200 with its covariances
    assert per_record < 0.1 * per_model
    assert peak_large - peak_small < 300 * 0.1 * per_model


# -- faults in the process pool ----------------------------------------------------------
def marked_units(n, marked):
    data = {}
    for unit in range(n):
        d = ltv.systems.jump_linear(T=40, change_at=20, seed=unit)
        x = d.x.copy()
        if unit in marked:
            x[0, 0] = 1e6
        data[unit] = (x, d.u)
    return data


def test_a_killed_pool_worker_loses_nothing(tmp_path):
    from many_methods import die_once

    data = marked_units(40, {7})
    ms = ltv.fit_many(data, method=die_once, marker=str(tmp_path / "killed"), lam=10.0, n_jobs=2)
    assert (tmp_path / "killed").exists()  # a worker was killed during the run
    assert ms.errors == {} and len(ms) == 40
    for unit, (x, u) in data.items():
        assert_same_model(ms[unit], ltv.fit(x, u, lam=10.0))


def test_a_unit_that_kills_every_worker_is_an_error():
    from many_methods import die_on_marked

    data = marked_units(30, {3, 17})
    ms = ltv.fit_many(data, method=die_on_marked, lam=10.0, n_jobs=2)
    assert set(ms.errors) == {3, 17}
    assert "worker process fitting this unit died twice" in ms.errors[3]
    assert len(ms) == 28
    assert_same_model(ms[4], ltv.fit(*data[4], lam=10.0))


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_one_blas_and_numba_thread_per_worker_restored_after(n_jobs):
    import numba
    from many_methods import report_threads
    from threadpoolctl import threadpool_info

    def threads():
        return {pool["filepath"]: pool["num_threads"] for pool in threadpool_info()}

    ltv.fit(*marked_units(1, set())[0], lam=1.0)  # load the libraries a fit loads
    before, numba_before = threads(), numba.get_num_threads()
    ms = ltv.fit_many(marked_units(4, set()), method=report_threads, lam=10.0, n_jobs=n_jobs)
    assert {ms[unit].info["blas_threads"] for unit in ms} == {1}
    assert {ms[unit].info["numba_threads"] for unit in ms} == {1}
    after = threads()  # (numba's threading layer may have loaded a library of its own)
    assert {path: after[path] for path in before} == before
    assert numba.get_num_threads() == numba_before


class Terminal:
    """A text stream that says it is a terminal."""

    def __init__(self):
        self.text = ""

    def write(self, text):
        self.text += text

    def flush(self):
        pass

    def isatty(self):
        return True


def test_progress_line_has_rate_and_time_left():
    from ltvmodels.progress import Progress

    stream = Terminal()
    with Progress(
        "fit_many", total=10, unit="units", stream=stream, delay=0.0, interval=0.0, threaded=False
    ) as bar:
        bar._start -= 2.0  # two seconds have passed
        bar.advance(5)
        assert "5/10" in stream.text and "2.5 units/s, 2 s left" in stream.text
    assert stream.text.endswith("\r")  # erased at the end
