"""``ltvmodels fit-many`` on a CSV panel: the summary, the model files, the errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.cli import main

pd = pytest.importorskip("pandas")

from test_fit_many import STATE, panel, unit_frame  # noqa: E402


@pytest.fixture
def panel_csv(tmp_path):
    frame = pd.concat([panel(4, T=60), unit_frame("short", 3, seed=9)], ignore_index=True)
    frame["date"] = frame["date"].dt.strftime("%Y-%m-%d")  # dates as text, as in a CSV
    path = tmp_path / "panel.csv"
    frame.to_csv(path, index=False)
    return path, frame


def test_fit_many_writes_summary_and_models(panel_csv, tmp_path, capsys):
    path, frame = panel_csv
    status = main(
        [
            "fit-many",
            str(path),
            "--by",
            "unit",
            "--time",
            "date",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--lam",
            "7",
            "--out",
            str(tmp_path / "s.csv"),
            "--models-dir",
            str(tmp_path / "models"),
            "--jobs",
            "2",
        ]
    )
    out = capsys.readouterr().out
    assert status == 0
    assert "5 units" in out and "4 fitted, 1 failed" in out and "unit 'short'" in out
    summary = pd.read_csv(tmp_path / "s.csv", index_col="unit")
    assert list(summary.index) == list(pd.unique(frame["unit"]))
    assert summary.loc["short", "status"] == "error"
    assert "too few samples" in summary.loc["short", "error"]
    models = ltv.load_many(tmp_path / "models")
    rows = frame[frame["unit"] == "m2"].assign(date=lambda f: pd.to_datetime(f["date"]))
    rows = rows.sort_values("date").set_index("date")
    reference = ltv.fit(rows[STATE], rows[["u"]], lam=7.0)
    # Not bit for bit: the worker process fits with one BLAS thread, this process with
    # several, and a BLAS's threaded and single-threaded kernels may round differently
    # (differences of 2e-15 were seen); the same data and options give k to rounding.
    np.testing.assert_allclose(models["m2"].k, reference.k, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(models["m2"].time, reference.time)
    assert summary.loc["m2", "loglik"] == pytest.approx(reference.loglik, rel=1e-12)


def test_fit_many_json_parquet_and_segments(panel_csv, tmp_path, capsys):
    pytest.importorskip("pyarrow")
    path, _ = panel_csv
    status = main(
        [
            "fit-many",
            str(path),
            "--by",
            "unit",
            "--state",
            "x1,x2",
            "--input",
            "u",
            "--method",
            "segments",
            "--n-changes",
            "1",
            "--jobs",
            "1",
            "--out",
            str(tmp_path / "s.parquet"),
            "--json",
        ]
    )
    report = json.loads(capsys.readouterr().out)
    assert status == 0 and report["n_fitted"] == 4 and list(report["errors"]) == ["short"]
    summary = pd.read_parquet(tmp_path / "s.parquet")
    assert (summary["n_changes"].dropna() == 1).all()


def test_fit_many_user_errors(panel_csv, capsys):
    path, _ = panel_csv
    assert main(["fit-many", str(path), "--by", "unit", "--state", "x1,x7"]) == 2
    assert "state: column 'x7' is not in data" in capsys.readouterr().err
    assert main(["fit-many", str(path) + ".missing", "--by", "unit", "--state", "x1"]) == 2
    assert "no such file" in capsys.readouterr().err


def fit_many_args(path, *options):
    return ["fit-many", str(path), "--by", "unit", "--state", "x1,x2", "--input", "u", *options]


@pytest.mark.parametrize(
    "options, message",
    [
        (["--method", "segments", "--lam", "3"], "--lam: not an option of --method segments"),
        (["--method", "lti", "--norm", "group"], "--norm: not an option of --method lti"),
        (["--method", "lti", "--refine"], "--refine: not an option of --method lti"),
        (["--method", "segments", "--loss", "huber"], "--loss: not an option of --method segm"),
        (["--order", "2", "--method", "lti"], "--order: not an option of --method lti"),
        (["--n-changes", "1"], "--n-changes: not an option of --method fit; it applies to "),
        (["--time", "x1"], "time: column 'x1' is also a state column"),
    ],
)
def test_fit_many_options_the_method_would_ignore(panel_csv, tmp_path, capsys, options, message):
    path, _ = panel_csv
    status = main([*fit_many_args(path, *options), "--out", str(tmp_path / "s.csv")])
    err = capsys.readouterr().err
    assert status == 2
    assert err.startswith("ltvmodels fit-many: error: ") and message in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "s.csv").exists()  # nothing was fitted


def test_fit_many_options_reach_the_method_that_takes_them(panel_csv, tmp_path, capsys):
    """--loss reaches --method lti; without --lam etc. --method fit has lam="auto"."""
    path, frame = panel_csv
    rows = frame[frame["unit"] == "m1"].assign(date=lambda f: pd.to_datetime(f["date"]))
    rows = rows.sort_values("date").set_index("date")
    args = fit_many_args(path, "--time", "date", "--jobs", "1")
    lti = [*args, "--method", "lti", "--loss", "huber", "--models-dir", str(tmp_path / "lti")]
    assert main(lti) == 0
    huber = ltv.fit_lti(rows[STATE], rows[["u"]], loss="huber")
    np.testing.assert_array_equal(ltv.load_many(tmp_path / "lti")["m1"].k, huber.k)
    squared = ltv.fit_lti(rows[STATE], rows[["u"]])
    assert np.abs(huber.k - squared.k).max() > 1e-6  # (so the loss did reach the fit)

    assert main([*args, "--out", str(tmp_path / "s.csv")]) == 0
    summary = pd.read_csv(tmp_path / "s.csv", index_col="unit")
    reference = ltv.fit(rows[STATE], rows[["u"]], lam="auto")
    assert summary.loc["m1", "lam_method"] == "ml"
    assert summary.loc["m1", "lam"] == pytest.approx(reference.lam, rel=1e-12)


def test_fit_many_models_dir_that_is_a_file(panel_csv, tmp_path, capsys):
    path, _ = panel_csv
    existing = tmp_path / "ok.csv"
    existing.write_text("keep me\n")
    status = main([*fit_many_args(path, "--jobs", "1"), "--models-dir", str(existing)])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert err.startswith("ltvmodels fit-many: error: --models-dir: ")
    assert "is an existing file, not a directory" in err
    assert existing.read_text() == "keep me\n"
    missing = tmp_path / "no such dir" / "s.csv"
    args = [*fit_many_args(path, "--jobs", "1"), "--out", str(missing)]
    assert main([*args, "--models-dir", str(tmp_path / "models")]) == 2
    assert "--out: cannot write" in capsys.readouterr().err
    assert not (tmp_path / "models").exists()  # checked before anything was fitted


def test_fit_many_reads_times_by_the_rule_of_every_command(panel_csv, tmp_path, capsys):
    """--time takes numbers or ISO 8601 dates, as fit --time does: dates in another
    format are an error naming the column (pandas would guess their format)."""
    _, frame = panel_csv
    path = tmp_path / "us-dates.csv"
    frame.assign(date=pd.to_datetime(frame["date"]).dt.strftime("%m/%d/%Y")).to_csv(
        path, index=False
    )
    status = main([*fit_many_args(path, "--time", "date", "--jobs", "1")])
    err = capsys.readouterr().err
    assert status == 2 and len(err.strip().splitlines()) == 1
    assert f"ltvmodels fit-many: error: {path}, column 'date': " in err
    assert "expected numbers or ISO 8601 dates and times" in err
    assert main(["fit", str(path), "--state", "x1", "--lam", "1", "--time", "date"]) == 2
    assert "expected numbers or ISO 8601 dates and times" in capsys.readouterr().err
