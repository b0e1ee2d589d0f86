"""Two classic structural-break data sets, for examples and for checking against R.

Both are the series of R's ``datasets`` package that strucchange's help pages
analyse, shipped as small CSV files with the package:

* :func:`nile`: the annual flow of the river Nile at Aswan, 1871–1970, in
  10⁸ m³ (Cobb 1978; Balke 1993), with its well-known drop around 1898 when
  the first Aswan dam was built;
* :func:`uk_driver_deaths`: monthly deaths and serious injuries of car drivers
  in Great Britain, January 1969 – December 1984 (Harvey and Durbin 1986),
  with the seat-belt law of 31 January 1983.

Each loader returns a pandas Series indexed by time (the ``pandas`` extra:
``pip install "ltvmodels[pandas]"``), which every estimator accepts and whose
time index it keeps.
"""

from __future__ import annotations

from importlib import resources
from typing import Any

import numpy as np

__all__ = ["nile", "uk_driver_deaths"]


def nile() -> Any:
    """Annual flow of the river Nile at Aswan, 1871–1970 (R's ``Nile``).

    Returns
    -------
    pandas.Series, shape (100,)
        The volume in 10⁸ m³, named "volume", indexed by the year (an integer
        index named "year").
    """
    years, volume = _columns("nile.csv", int)
    pd = _pandas()
    return pd.Series(volume, index=pd.Index(years, name="year"), name="volume")


def uk_driver_deaths() -> Any:
    """Monthly car drivers killed or seriously injured in Great Britain, 1969–1984
    (R's ``UKDriverDeaths``; the "Seatbelts" data of strucchange's examples).

    Returns
    -------
    pandas.Series, shape (192,)
        The counts, named "deaths", indexed by the first day of each month (a
        monthly ``DatetimeIndex`` named "month", January 1969 to December 1984).
    """
    months, deaths = _columns("uk_driver_deaths.csv", "datetime64[M]")
    pd = _pandas()
    index = pd.DatetimeIndex(months.astype("datetime64[ns]"), name="month", freq="MS")
    return pd.Series(deaths, index=index, name="deaths")


def _columns(filename: str, time_type: Any) -> tuple[np.ndarray, np.ndarray]:
    """The time column (as ``time_type``) and the value column (floats) of a data file."""
    text = resources.files(__package__).joinpath("data").joinpath(filename).read_text()
    rows = [line.split(",") for line in text.split()[1:]]
    times = np.array([row[0] for row in rows]).astype(time_type)
    return times, np.array([float(row[1]) for row in rows])


def _pandas() -> Any:
    try:
        import pandas as pd
    except ImportError as exc:  # pragma: no cover - the pandas extra is missing
        raise ImportError(
            'the data sets are returned as pandas Series: pip install "ltvmodels[pandas]"'
        ) from exc
    return pd
