"""The subcommands of ``ltvmodels``, one module each.

Each module's ``run`` takes the parsed arguments and returns the report: a
dict (printed as JSON with ``--json``) and the lines of the text summary.
``simulate`` and ``predict`` share :mod:`.replay`. The modules import the
library's estimators, models and figures inside ``run``, so that importing
them loads none of these.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from ..outputs import Report
from . import ar, demo, fit, fit_many, forecast, replay, segments, select_lambda

__all__ = ["COMMANDS"]

COMMANDS: dict[str, Callable[[argparse.Namespace], Report]] = {
    "fit": fit.run,
    "segments": segments.run,
    "ar": ar.run,
    "select-lambda": select_lambda.run,
    "simulate": replay.run,
    "predict": replay.run,
    "forecast": forecast.run,
    "demo": demo.run,
    "fit-many": fit_many.run,
}
"""The subcommands by name: each returns (report dict, text lines)."""
