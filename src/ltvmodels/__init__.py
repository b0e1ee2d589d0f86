"""ltvmodels: identification of linear time-varying dynamical models.

Implements Bagge Carlson, Robertsson & Johansson (2018), "Identification of
LTV Dynamical Models with Smooth or Discontinuous Time Evolution by means of
Convex Optimization".

Quick use::

    import ltvmodels as ltv
    model = ltv.fit(x, u, lam=10.0, norm="sq", order=1)
    model.A, model.B, model.cov, model.loglik
"""

from . import control, gym_rl, plotting, rl, systems
from .ar import ARModel, ARXModel, ar_regressors, arx_regressors, fit_ar, fit_arx
from .changepoints import find_changepoints
from .control import ilqg
from .errors import (
    ConvergenceWarning,
    IdentifiabilityWarning,
    PrecisionWarning,
    SingularProblemError,
)
from .fit import fit, fit_lti, fit_path, fit_regression
from .models import LTVModel, RegressionModel, load
from .piecewise import fit_piecewise
from .priors import OutputPrior, Prior
from .selection import LambdaSelection, select_lambda, select_lambda_regression
from .segments import fit_segments
from .solvers.kalman import (
    KalmanFilterResult,
    KalmanSmootherResult,
    OnlineParameterFilter,
    kalman_filter,
    kalman_smoother,
)

__version__ = "0.1.0"

__all__ = [
    "fit",
    "fit_lti",
    "fit_path",
    "fit_piecewise",
    "fit_segments",
    "fit_regression",
    "fit_ar",
    "fit_arx",
    "ar_regressors",
    "arx_regressors",
    "find_changepoints",
    "LTVModel",
    "RegressionModel",
    "ARModel",
    "ARXModel",
    "load",
    "Prior",
    "OutputPrior",
    "select_lambda",
    "select_lambda_regression",
    "LambdaSelection",
    "kalman_filter",
    "kalman_smoother",
    "OnlineParameterFilter",
    "KalmanFilterResult",
    "KalmanSmootherResult",
    "SingularProblemError",
    "IdentifiabilityWarning",
    "ConvergenceWarning",
    "PrecisionWarning",
    "systems",
    "plotting",
    "control",
    "rl",
    "gym_rl",
    "ilqg",
    "__version__",
]
