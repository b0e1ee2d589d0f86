"""fit_many on a real Dask cluster: a ``LocalCluster`` of worker processes started here.

The cluster lets a task fail once on a dead worker (``allowed-failures`` 0), so
that the kill tests need few worker restarts; fit_many's own retry is what
recovers the units.
"""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv

pd = pytest.importorskip("pandas")
dask = pytest.importorskip("dask")
distributed = pytest.importorskip("distributed")
dd = pytest.importorskip("dask.dataframe")

from test_fit_many import (  # noqa: E402
    INPUT,
    STATE,
    assert_same_model,
    marked_units,
    panel,
    unit_rows,
)


@pytest.fixture(scope="module")
def client():
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        )
    with cluster, distributed.Client(cluster) as dask_client:
        yield dask_client


def test_table_mapping_and_dask_frame_equal_a_loop_of_fit(client):
    frame = panel(8, T=60)
    options = dict(lam=10.0)
    on_table = ltv.fit_many(
        frame, by="unit", state=STATE, inputs="u", time="date", engine=client, **options
    )
    on_frame = ltv.fit_many(
        dd.from_pandas(frame, npartitions=3),
        by="unit",
        state=STATE,
        inputs="u",
        time="date",
        engine=client,
        **options,
    )
    units = {unit: unit_rows(frame, unit) for unit in pd.unique(frame["unit"])}
    on_mapping = ltv.fit_many(
        {unit: (x.to_numpy(), u.to_numpy()) for unit, (x, u) in units.items()},
        engine=client,
        **options,
    )
    assert on_table.units == list(units)
    assert sorted(on_frame.units) == sorted(units) and on_frame.errors == {}
    for unit, (x, u) in units.items():
        reference = ltv.fit(x, u, **options)
        assert_same_model(on_table[unit], reference)
        assert_same_model(on_frame[unit], reference)
        assert_same_model(on_mapping[unit], ltv.fit(x.to_numpy(), u.to_numpy(), **options))
    assert (
        on_frame.summary.loc[on_table.units, "loglik"].tolist()
        == on_table.summary["loglik"].tolist()
    )


def test_dask_frame_bad_units_and_auto_lambda(client):
    frame = pd.concat(
        [
            panel(4, T=60),
            pd.DataFrame(
                {
                    "unit": "short",
                    "date": pd.date_range("2021", periods=2),
                    "x1": [1.0, 2.0],
                    "x2": [0.0, 1.0],
                    "u": [1.0, 0.0],
                }
            ),
        ],
        ignore_index=True,
    )
    ms = ltv.fit_many(
        dd.from_pandas(frame, npartitions=2),
        by="unit",
        state=STATE,
        inputs=INPUT,
        time="date",
        engine=client,
        lam="auto",
    )
    assert set(ms.errors) == {"short"} and "too few samples" in ms.errors["short"]
    with pytest.raises(ValueError, match="state: column 'x9' is not in data"):
        ltv.fit_many(
            dd.from_pandas(frame, npartitions=2),
            by="unit",
            state=["x1", "x9"],
            engine=client,
            lam=1.0,
        )
    for unit in ms:
        assert_same_model(ms[unit], ltv.fit(*unit_rows(frame, unit), lam="auto"))


def test_a_killed_dask_worker_loses_nothing(client, tmp_path):
    from many_methods import die_once

    data = marked_units(24, {5})
    ms = ltv.fit_many(
        data, method=die_once, marker=str(tmp_path / "killed"), lam=10.0, engine=client
    )
    assert (tmp_path / "killed").exists()  # a worker process was killed during the run
    assert ms.errors == {} and len(ms) == 24
    for unit, (x, u) in data.items():
        assert_same_model(ms[unit], ltv.fit(x, u, lam=10.0))


def test_a_unit_that_kills_every_dask_worker_is_an_error(client):
    from many_methods import die_on_marked

    data = marked_units(16, {9})
    ms = ltv.fit_many(data, method=die_on_marked, lam=10.0, engine=client)
    assert set(ms.errors) == {9} and "died twice" in ms.errors[9]
    assert len(ms) == 15
    np.testing.assert_array_equal(ms[10].k, ltv.fit(*data[10], lam=10.0).k)


def test_cli_on_a_scheduler(client, tmp_path, capsys):
    from ltvmodels.cli import main

    frame = panel(3, T=50)
    frame.to_csv(tmp_path / "panel.csv", index=False)
    address = client.scheduler.address
    status = main(
        [
            "fit-many",
            str(tmp_path / "panel.csv"),
            "--by",
            "unit",
            "--time",
            "date",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--lam",
            "5",
            "--scheduler",
            address,
            "--out",
            str(tmp_path / "s.csv"),
        ]
    )
    assert status == 0 and f"on the cluster at {address}" in capsys.readouterr().out
    summary = pd.read_csv(tmp_path / "s.csv", index_col="unit")
    assert summary.loc["m1", "loglik"] == pytest.approx(
        ltv.fit(*unit_rows(frame, "m1"), lam=5.0).loglik, rel=1e-15
    )
