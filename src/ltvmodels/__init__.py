"""ltvmodels: identification of linear time-varying dynamical models.

Implements Bagge Carlson, Robertsson & Johansson (2018), "Identification of
LTV Dynamical Models with Smooth or Discontinuous Time Evolution by means of
Convex Optimization".

Quick use::

    import ltvmodels as ltv
    model = ltv.fit(x, u, lam=10.0, norm="sq", order=1)
    model.A, model.B, model.cov, model.loglik

The public names below load on first use (PEP 562): ``import ltvmodels`` is
about as fast as importing numpy, and the compiled solvers, matplotlib and
the optional extras load only when something needs them. ARCHITECTURE.md
describes the layers behind these names.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import (
    ConvergenceWarning,
    DataWarning,
    DivergenceWarning,
    IdentifiabilityWarning,
    ModelFileError,
    ModelStructureWarning,
    OutputPathError,
    PrecisionWarning,
    SingularProblemError,
)

__version__ = "0.2.0"

# Public name → the module (below this package) that defines it.
_API = {
    "fit": "estimators.fit",
    "fit_lti": "estimators.fit",
    "fit_path": "estimators.fit",
    "lambda_max": "estimators.fit",
    "fit_regression": "estimators.regression",
    "fit_ar": "estimators.ar",
    "fit_arx": "estimators.ar",
    "ar_regressors": "estimators.ar",
    "arx_regressors": "estimators.ar",
    "fit_piecewise": "estimators.piecewise",
    "fit_segments": "estimators.segments",
    "segment_regression": "estimators.segments",
    "noise_variance_estimate": "estimators.segments",
    "break_test": "estimators.breaktest",
    "find_changepoints": "estimators.changepoints",
    "select_lambda": "estimators.selection",
    "select_lambda_regression": "estimators.selection",
    "Prior": "estimators.priors",
    "OutputPrior": "estimators.priors",
    "GMMPrior": "estimators.mixture_prior",
    "kalman_filter": "estimators.kalman",
    "kalman_smoother": "estimators.kalman",
    "OnlineParameterFilter": "estimators.kalman",
    "LTVModel": "results.statespace",
    "RegressionModel": "results.regression",
    "ARModel": "results.arx",
    "ARXModel": "results.arx",
    "FitStatus": "results.record",
    "FitRecord": "results.record",
    "DataDescription": "results.description",
    "LambdaSelection": "results.selection",
    "Segmentation": "results.segmentation",
    "BreakTest": "results.breaktest",
    "KalmanFilterResult": "results.kalman",
    "KalmanSmootherResult": "results.kalman",
    "Forecast": "results.forecast",
    "load": "results.loading",
    "ilqg": "control",
    "fit_many": "estimators.many",
    "ModelSet": "results.model_set",
    "load_many": "results.model_set",
}
# Public modules, imported on first attribute access.
_MODULES = ("systems", "datasets", "plotting", "control")
# Former names of modules that moved, with their new place (a DeprecationWarning on use).
_MOVED = {"rl": "ltvmodels.apps.rl", "gym_rl": "ltvmodels.apps.gym_rl"}

if TYPE_CHECKING:
    # What a type checker sees of the names above, which load on first use at run
    # time (tests/test_architecture.py keeps this block equal to _API and _MODULES).
    from . import control as control
    from . import datasets as datasets
    from . import plotting as plotting
    from . import systems as systems
    from .control import ilqg as ilqg
    from .estimators.ar import (
        ar_regressors as ar_regressors,
    )
    from .estimators.ar import (
        arx_regressors as arx_regressors,
    )
    from .estimators.ar import (
        fit_ar as fit_ar,
    )
    from .estimators.ar import (
        fit_arx as fit_arx,
    )
    from .estimators.breaktest import break_test as break_test
    from .estimators.changepoints import find_changepoints as find_changepoints
    from .estimators.fit import (
        fit as fit,
    )
    from .estimators.fit import (
        fit_lti as fit_lti,
    )
    from .estimators.fit import (
        fit_path as fit_path,
    )
    from .estimators.fit import (
        lambda_max as lambda_max,
    )
    from .estimators.kalman import (
        OnlineParameterFilter as OnlineParameterFilter,
    )
    from .estimators.kalman import (
        kalman_filter as kalman_filter,
    )
    from .estimators.kalman import (
        kalman_smoother as kalman_smoother,
    )
    from .estimators.many import fit_many as fit_many
    from .estimators.mixture_prior import GMMPrior as GMMPrior
    from .estimators.piecewise import fit_piecewise as fit_piecewise
    from .estimators.priors import OutputPrior as OutputPrior
    from .estimators.priors import Prior as Prior
    from .estimators.regression import fit_regression as fit_regression
    from .estimators.segments import (
        fit_segments as fit_segments,
    )
    from .estimators.segments import (
        noise_variance_estimate as noise_variance_estimate,
    )
    from .estimators.segments import (
        segment_regression as segment_regression,
    )
    from .estimators.selection import (
        select_lambda as select_lambda,
    )
    from .estimators.selection import (
        select_lambda_regression as select_lambda_regression,
    )
    from .results.arx import ARModel as ARModel
    from .results.arx import ARXModel as ARXModel
    from .results.breaktest import BreakTest as BreakTest
    from .results.description import DataDescription as DataDescription
    from .results.forecast import Forecast as Forecast
    from .results.kalman import (
        KalmanFilterResult as KalmanFilterResult,
    )
    from .results.kalman import (
        KalmanSmootherResult as KalmanSmootherResult,
    )
    from .results.loading import load as load
    from .results.model_set import ModelSet as ModelSet
    from .results.model_set import load_many as load_many
    from .results.record import FitRecord as FitRecord
    from .results.record import FitStatus as FitStatus
    from .results.regression import RegressionModel as RegressionModel
    from .results.segmentation import Segmentation as Segmentation
    from .results.selection import LambdaSelection as LambdaSelection
    from .results.statespace import LTVModel as LTVModel

__all__ = [
    *_API,
    *_MODULES,
    "SingularProblemError",
    "IdentifiabilityWarning",
    "ConvergenceWarning",
    "PrecisionWarning",
    "DivergenceWarning",
    "ModelStructureWarning",
    "DataWarning",
    "ModelFileError",
    "OutputPathError",
    "__version__",
]


def __getattr__(name: str) -> Any:
    if name in _API:
        value = getattr(importlib.import_module(f".{_API[name]}", __name__), name)
    elif name in _MODULES:
        value = importlib.import_module(f".{name}", __name__)
    elif name in _MOVED:
        from .errors import warn

        warn(
            f"ltvmodels.{name} moved to {_MOVED[name]}; import it from there",
            DeprecationWarning,
        )
        return importlib.import_module(_MOVED[name])
    else:
        raise AttributeError(f"module 'ltvmodels' has no attribute {name!r}")
    globals()[name] = value  # later lookups find it directly
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
