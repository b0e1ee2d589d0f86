"""The shipped data sets equal their published copies (statsmodels' Nile, R's UKDriverDeaths
as recorded in the strucchange reference file)."""

import json
from pathlib import Path

import numpy as np
import pytest

pd = pytest.importorskip("pandas")

from ltvmodels import datasets  # noqa: E402

REFERENCE = Path(__file__).parent / "reference" / "strucchange" / "confint.json"


def test_nile_equals_statsmodels_copy():
    sm = pytest.importorskip("statsmodels.api")
    flow = sm.datasets.nile.load_pandas().data
    nile = datasets.nile()
    assert nile.index.name == "year" and nile.name == "volume"
    np.testing.assert_array_equal(nile.index.to_numpy(), flow["year"].to_numpy().astype(int))
    np.testing.assert_array_equal(nile.to_numpy(), flow["volume"].to_numpy())


def test_uk_driver_deaths_equals_the_seatbelt_regression_data():
    deaths = datasets.uk_driver_deaths()
    assert deaths.size == 192 and deaths.index.freqstr == "MS"
    assert deaths.index[0] == pd.Timestamp("1969-01-01")
    assert deaths.index[-1] == pd.Timestamp("1984-12-01")
    cases = json.loads(REFERENCE.read_text())["cases"]
    seatbelt = next(case for case in cases if case["name"] == "seatbelt")
    # strucchange's example: log10 deaths from 1970 on, regressed on lags 1 and 12
    np.testing.assert_allclose(np.log10(deaths.to_numpy()[12:]), seatbelt["y"], rtol=1e-15)
    lags = np.reshape(seatbelt["X"]["values"], (-1, 2))
    np.testing.assert_allclose(np.log10(deaths.to_numpy()[11:-1]), lags[:, 0], rtol=1e-15)
    np.testing.assert_allclose(np.log10(deaths.to_numpy()[:-12]), lags[:, 1], rtol=1e-15)


def test_loaders_return_fresh_series():
    first = datasets.nile()
    first.iloc[0] = -1.0
    assert datasets.nile().iloc[0] == 1120.0
