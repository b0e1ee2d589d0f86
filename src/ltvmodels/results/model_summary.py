"""What a model's ``summary()`` says: its data, penalty and λ, fit, noise, criteria,
change points and coefficients, read from the model and its fit record.

Everything shown is what the estimator recorded (``model.info``, ``model.status``,
``model.data``); nothing is inferred from the numbers. The sections, after
statsmodels' regression summaries:

* Data: samples, trajectories, the span of the time axis, the steps left out
  for missing values, the signals' names;
* Model: the kind of model, the penalty, the difference order, the loss (and
  Huber's threshold), λ and how it was chosen;
* Fit: the status, solver, iterations, objective and certificate;
* Noise: the variance of each output, estimated or given;
* Criteria: the log-likelihood, and AIC/BIC where the number of estimated
  parameters is known (least-squares fits between change points);
* Change points: indices and times;
* Coefficients: coefficients constant within segments (LTI and piecewise
  fits) get a table per segment with standard errors and z-values; varying
  ones their first, last, smallest and largest value.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any, Literal, Protocol

import numpy as np

from .description import DataDescription
from .record import FitStatus
from .summary import Section, Summary, Table

__all__ = ["SummarizedModel", "model_summary", "number_text", "order_text", "time_text"]

SAME_TOLERANCE = 1e-8
"""Coefficients within a segment are constant when they differ by at most this much
relative to the largest coefficient (the tolerance of ``RegressionModel.changepoints``)."""

TIME_UNITS: tuple[Literal["D", "m", "s", "ms", "us", "ns"], ...] = ("D", "m", "s", "ms", "us", "ns")
"""The units that times are shown to, coarsest first: the first that shows them exactly
(the last, nanoseconds, is the resolution of a time index)."""

MOST_CHANGEPOINTS_SHOWN = 20
"""Change points listed before the rest are only counted (a long list says little)."""

SELECTION_METHODS = {
    "ml": "marginal likelihood",
    "gcv": "GCV",
    "lcurve": "L-curve",
    "cv": "cross-validation",
}
"""How ``lam="auto"`` chose λ (``info["lam_selection"]["method"]``), in words."""

PENALTIES = {
    "sq": "squared differences (smoothly varying coefficients)",
    "group": "group lasso on the differences (piecewise)",
    "l1": "l1 norm of the differences (sparse changes per coefficient)",
    "lti": "none: constant coefficients (LTI)",
    "piecewise": "none: fitted between change points",
    "l0": "L0: exact segmentation (least squares between the changes found)",
}
"""Each value of ``model.norm``, in words."""

CERTIFICATES = {
    "duality_gap": "duality gap",
    "kkt_residual": "KKT residual",
    "primal_residual": "primal residual",
    "dual_residual": "dual residual",
}
"""The certificate's entries of ``FitStatus.details``, in the order shown."""


class SummarizedModel(Protocol):
    """What :func:`model_summary` reads from a model (every ``RegressionModel`` has it)."""

    @property
    def norm(self) -> str | None: ...

    @property
    def lam(self) -> Any: ...

    @property
    def coeffs(self) -> np.ndarray | None: ...

    @property
    def info(self) -> dict: ...

    @property
    def status(self) -> FitStatus | None: ...

    @property
    def data(self) -> DataDescription: ...

    @property
    def noise_var(self) -> np.ndarray | None: ...

    @property
    def loglik(self) -> float | None: ...

    @property
    def measurement_noise(self) -> np.ndarray | None: ...

    @property
    def N(self) -> int: ...

    @property
    def n_outputs(self) -> int: ...

    @property
    def n_regressors(self) -> int: ...

    @property
    def k(self) -> np.ndarray: ...

    @property
    def changepoints(self) -> np.ndarray: ...

    @property
    def changepoint_times(self) -> np.ndarray | None: ...

    @property
    def time(self) -> np.ndarray | None: ...

    @property
    def produced_offset(self) -> int: ...

    @property
    def output_names(self) -> list[str]: ...

    def std(self) -> np.ndarray | None: ...

    def coefficient_names(self) -> list[str]: ...

    def activation(self) -> np.ndarray: ...


def model_summary(
    model: SummarizedModel, *, kind: str, signals: Mapping[str, Sequence[str]]
) -> Summary:
    """The summary of a model: its repr as the title, then the sections of the module.

    Parameters
    ----------
    model : RegressionModel
        Any fitted model, or one with given coefficients.
    kind : str
        What kind of model it is, in words (e.g. the state-space equation).
    signals : mapping of str to sequence of str
        The signals' names by role, as the kind of model calls them (e.g.
        "states" and "inputs").

    Returns
    -------
    Summary
    """
    return Summary(
        repr(model),
        [
            _data_section(model, signals),
            _model_section(model, kind),
            _fit_section(model.status),
            _noise_section(model),
            _criteria_section(model),
            _changes_section(model),
            _coefficients_section(model),
        ],
    )


# -- text of values ------------------------------------------------------------------------
def number_text(value: Any, digits: int = 4) -> str:
    """A number in ``digits`` significant digits; "—" for None or NaN, "∞" for inf."""
    if value is None or np.isnan(value):
        return "—"
    if np.isinf(value):
        return "∞" if value > 0 else "-∞"
    return f"{float(value):.{digits}g}"


def time_text(values: np.ndarray) -> list[str]:
    """Times as people read them: dates without a time of day as YYYY-MM-DD, else with
    the time to the minute, second or finer as needed; numbers as numbers."""
    values = np.asarray(values)
    if not np.issubdtype(values.dtype, np.datetime64):
        return [number_text(value, 6) for value in values]
    unit = next(
        (unit for unit in TIME_UNITS if np.all(values.astype(f"datetime64[{unit}]") == values)),
        TIME_UNITS[-1],
    )
    texts = np.datetime_as_string(values, unit=unit)
    return [str(text).replace("T", " ") for text in texts]


def order_text(coeffs: np.ndarray) -> str:
    """The difference operator: its degree d for the standard d-th difference, else its
    coefficients c_0 … c_d."""
    d = len(coeffs) - 1
    standard = np.array([1.0])
    for _ in range(d):
        standard = np.convolve(standard, [-1.0, 1.0])
    return str(d) if np.array_equal(coeffs, standard) else str(np.asarray(coeffs).tolist())


def _per_name(names: Sequence[str], values: np.ndarray) -> str:
    return ", ".join(
        f"{name} {number_text(value)}" for name, value in zip(names, values, strict=True)
    )


def _span(times: np.ndarray) -> str:
    first, last = time_text(np.asarray([times[0], times[-1]]))
    return first if first == last else f"{first} – {last}"


# -- sections -------------------------------------------------------------------------------
def _data_section(model: SummarizedModel, signals: Mapping[str, Sequence[str]]) -> Section:
    names = [(role, ", ".join(values) or "none") for role, values in signals.items()]
    if model.status is None:  # coefficients given to the constructor: no data
        return Section("Data", (("samples", "— (coefficients given, no data)"), *names))
    data = model.data
    samples = model.N + model.produced_offset  # of one trajectory
    per = " per trajectory" if data.n_trajectories > 1 else ""
    time = model.time
    steps = model.N * data.n_trajectories
    return Section(
        "Data",
        (
            ("samples (T)", f"{samples}{per}"),
            ("trajectories", str(data.n_trajectories)),
            ("time", "none (sample indices)" if time is None else _span(time)),
            ("missing", f"{data.n_missing} of {steps} steps left out for missing values"),
            *names,
        ),
    )


def _model_section(model: SummarizedModel, kind: str) -> Section:
    info = model.info
    first = info.get("first_step")
    penalty = PENALTIES.get(model.norm, str(model.norm)) if model.norm else "— (coefficients given)"
    if isinstance(first, dict):
        penalty += f", found by a norm={first.get('norm')!r} fit (refined)"
    fields = [
        ("kind", kind),
        ("penalty", penalty),
        ("difference order", "—" if model.coeffs is None else order_text(model.coeffs)),
        ("loss", "—" if model.status is None else _loss_text(info)),
        ("λ", _lam_text(model)),
    ]
    prior = info.get("prior_mode")
    if prior not in (None, "none"):
        fields.append(("prior", str(prior)))
    return Section("Model", tuple(fields))


def _loss_text(info: dict) -> str:
    loss = str(info.get("loss", "squared"))
    delta = info.get("huber_delta")
    if loss != "huber" or delta is None:
        return loss
    values = ", ".join(number_text(value) for value in np.atleast_1d(delta))
    return f"huber, threshold δ = {values} ({info.get('huber_delta_rule', 'given')})"


def _lam_value(lam: Any) -> str:
    if lam is None:
        return "—"
    return number_text(float(lam)) if np.ndim(lam) == 0 else f"array of shape {np.shape(lam)}"


def _lam_text(model: SummarizedModel) -> str:
    """λ and how it was chosen, as the fit recorded it."""
    info = model.info
    selection = info.get("lam_selection")
    how = "given"
    if isinstance(selection, dict):
        method = str(selection.get("method"))
        how = SELECTION_METHODS.get(method, method)
    first = info.get("first_step")
    if isinstance(first, dict):  # the λ of the first step chose the change points
        return f"{_lam_value(first.get('lam'))} ({how}), then refined piecewise"
    if model.norm == "lti":
        return "∞ (constant coefficients)"
    if model.norm == "piecewise":
        return "∞ within the segments (change points given)"
    if model.norm == "l0":
        return _segmentation_text(info)
    if model.lam is None:
        return "— (coefficients given)"
    if how == "given" and "path_position" in info:
        how = "given, on a path of λ values"
    return f"{_lam_value(model.lam)} ({how})"


def _segmentation_text(info: dict) -> str:
    changes = int(info.get("n_changes", 0))
    found = f"none: {changes} change{'s' if changes != 1 else ''}"
    penalty = info.get("penalty")
    if penalty is None:
        return f"{found} (n_changes given)"
    rule = info.get("penalty_rule")
    return f"{found}, penalty β = {number_text(penalty)} per change ({rule or 'given'})"


def _fit_section(status: FitStatus | None) -> Section:
    if status is None:
        return Section("Fit", (("status", "— (coefficients given, not fitted)"),))
    return Section(
        "Fit",
        (
            ("status", f"{status.status} ({'success' if status.success else 'NOT optimal'})"),
            ("message", status.message),
            ("solver", status.solver),
            ("iterations", str(status.iterations)),
            ("objective", number_text(status.objective, 6)),
            ("certificate", _certificate_text(status)),
        ),
    )


def _certificate_text(status: FitStatus) -> str:
    details = status.details
    parts = [
        f"{label} {number_text(details[key], 3)}"
        for key, label in CERTIFICATES.items()
        if isinstance(details.get(key), (int, float))
    ]
    if details.get("polished"):
        parts.append("polished")
    if parts:
        return ", ".join(parts)
    return "none needed (closed form)" if status.status == "closed_form" else "none recorded"


def _sample_outlier_row(model: SummarizedModel, info: dict) -> tuple[str, str]:
    """The measurement loss and the samples judged corrupted (``model.sample_outliers``)."""
    flagged = getattr(model, "sample_outliers", None)
    loss = info.get("measurement_loss", "squared")
    if flagged is None:
        return ("measurement loss", str(loss))
    flagged = np.asarray(flagged)
    threshold = info.get("sample_outlier_threshold", 3.0)
    return (
        "sample outliers",
        f"{int(flagged.sum())} of {flagged.size} samples (|standardized residual| > "
        f"{threshold:g}); measurement loss {loss}",
    )


def _noise_section(model: SummarizedModel) -> Section:
    if model.noise_var is None:
        return Section("Noise", (("variance", "— (not estimated)"),))
    info = model.info
    if model.measurement_noise is not None:  # the measurement model, fitted by EM
        how = " (estimated)" if info.get("measurement_noise") == "estimate" else " (given)"
        done = "converged" if info.get("em_converged") else "stopped at em_max_iter"
        return Section(
            "Noise",
            (
                ("process variance", number_text(float(model.noise_var[0])) + " (every state)"),
                (
                    "measurement variance",
                    _per_name(model.output_names, model.measurement_noise) + how,
                ),
                ("EM", f"{info.get('em_iterations', '?')} iterations, {done}"),
                _sample_outlier_row(model, info),
            ),
        )
    if model.status is None:  # given with the coefficients
        how = " (given)"
    elif "noise_var_estimated" in info:  # the squared norm takes a given variance
        how = " (estimated)" if info["noise_var_estimated"] else " (given)"
    elif "loss" in info:  # a robust fit records no flag; it may have been given
        how = ""
    else:  # the least-squares and sparse fits always estimate it
        how = " (estimated from the residuals)"
    return Section("Noise", (("variance", _per_name(model.output_names, model.noise_var) + how),))


def _criteria_section(model: SummarizedModel) -> Section:
    if model.loglik is None:
        note = str(model.info.get("loglik_note", "no likelihood recorded"))
        return Section(
            "Criteria",
            (
                ("log-likelihood", f"not defined ({note.removesuffix('; loglik is None')})"),
                ("AIC, BIC", "not defined (no likelihood)"),
            ),
        )
    if model.measurement_noise is not None:
        return Section(
            "Criteria",
            (
                (
                    "log-likelihood",
                    number_text(model.loglik, 6) + " (of the recorded states, given the "
                    "coefficients and noise variances)",
                ),
                ("AIC, BIC", "not computed for the measurement model"),
            ),
        )
    marginal = " (log marginal likelihood)" if model.norm == "sq" else ""
    fields = [("log-likelihood", number_text(model.loglik, 6) + marginal)]
    count = _parameter_count(model)
    if count is None:
        fields.append(("AIC, BIC", "not defined (a penalized fit has no parameter count)"))
        return Section("Criteria", tuple(fields))
    parameters, observations, parts = count
    aic = -2.0 * model.loglik + 2.0 * parameters
    bic = -2.0 * model.loglik + np.log(observations) * parameters
    fields += [
        ("AIC", number_text(aic, 6)),
        ("BIC", f"{number_text(bic, 6)} ({observations} observations)"),
        ("parameters", f"{parameters}: {parts}"),
    ]
    return Section("Criteria", tuple(fields))


def _parameter_count(model: SummarizedModel) -> tuple[int, int, str] | None:
    """The parameters that the Gaussian log-likelihood of a least-squares fit between
    change points estimated, the observations it counts, and the parts in words.

    Known only for the fits without a penalty ("lti", "piecewise", "l0"), from the
    coefficients per equation and the residual degrees of freedom they recorded:
    n·P coefficients, n(n + 1)/2 entries of the noise covariance and, where the
    change points were found from the data (a segmentation, a refined fit), one
    parameter per change point (as strucchange's and ``select_lambda``'s BIC count
    break dates). None for penalized fits.
    """
    info = model.info
    per_equation: Any
    if model.norm == "lti":
        per_equation = model.n_regressors
    elif model.norm in ("piecewise", "l0"):
        per_equation = info.get("n_params_per_row")
    else:
        return None
    dof = info.get("dof")
    if not isinstance(per_equation, int) or not isinstance(dof, int):
        return None
    n = model.n_outputs
    coefficients, covariance = n * per_equation, n * (n + 1) // 2
    found = model.norm == "l0" or isinstance(info.get("first_step"), dict)
    changes = len(model.changepoints) if found else 0
    parts = f"{coefficients} coefficients, {covariance} noise covariance entries"
    if found:
        parts += f", {changes} change point{'s' if changes != 1 else ''} found"
    return coefficients + covariance + changes, dof + per_equation, parts


def _changes_section(model: SummarizedModel) -> Section:
    changepoints = np.asarray(model.changepoints, dtype=int)
    if changepoints.size > 1 and changepoints.size >= model.N - 1:  # every step changes
        fields = [("change points", "every step (smoothly varying coefficients)")]
        activation = model.activation()
        if activation.size:
            fields.append(
                (
                    "activation ‖Dk‖",
                    f"max {number_text(activation.max(), 3)} at t={int(activation.argmax())}, "
                    f"median {number_text(float(np.median(activation)), 3)}",
                )
            )
        return Section("Change points", tuple(fields))
    if not changepoints.size:
        return Section("Change points", (("change points", "none"),))
    shown = changepoints[:MOST_CHANGEPOINTS_SHOWN]
    more = changepoints.size - shown.size
    rest = f", … ({more} more)" if more else ""
    fields = [("steps", ", ".join(str(c) for c in shown) + rest)]
    times = model.changepoint_times
    if times is not None:
        fields.append(("times", ", ".join(time_text(times[: shown.size])) + rest))
    return Section("Change points", tuple(fields))


def _coefficients_section(model: SummarizedModel) -> Section:
    names = model.coefficient_names()
    k = np.asarray(model.k)
    segments = _constant_segments(k, np.asarray(model.changepoints, dtype=int))
    if segments is None:
        rows = tuple(
            (name, *(number_text(v) for v in (column[0], column[-1], column.min(), column.max())))
            for name, column in zip(names, k.T, strict=True)
        )
        caption = f"varying over the steps 0–{model.N - 1}"
        return Section(
            "Coefficients",
            tables=(Table(caption, ("coefficient", "first", "last", "min", "max"), rows),),
        )
    std = model.std()
    tables = []
    for index, (start, stop) in enumerate(segments):
        estimates = k[start]
        errors = None if std is None else std[start]
        rows = tuple(
            _coefficient_row(name, estimate, None if errors is None else errors[j])
            for j, (name, estimate) in enumerate(zip(names, estimates, strict=True))
        )
        caption = f"segment {index + 1} of {len(segments)}: steps {start}–{stop - 1}"
        if len(segments) == 1:
            caption = f"constant over the steps {start}–{stop - 1}"
        time = model.time
        if time is not None:  # the samples the segment's coefficients produce
            offset = model.produced_offset
            caption += f" ({_span(time[start + offset : stop + offset])})"
        tables.append(Table(caption, ("coefficient", "estimate", "std err", "z"), rows))
    return Section("Coefficients", tables=tuple(tables))


def _coefficient_row(name: str, estimate: float, error: float | None) -> tuple[str, ...]:
    if error is None or not error > 0:
        return (name, number_text(estimate), "—", "—")
    return (name, number_text(estimate), number_text(error), number_text(estimate / error, 3))


def _constant_segments(k: np.ndarray, changepoints: np.ndarray) -> list[tuple[int, int]] | None:
    """The segments [start, stop) between the change points when the coefficients are
    constant within each, else None (as when every step is a change: a smooth fit)."""
    N = k.shape[0]
    bounds = [0, *changepoints.tolist(), N]
    segments = list(itertools.pairwise(bounds))
    if len(segments) > 2 and len(segments) >= N:  # as _changes_section's "every step"
        return None
    tolerance = SAME_TOLERANCE * max(float(np.abs(k).max(initial=0.0)), 1e-300)
    for start, stop in segments:
        if np.abs(k[start:stop] - k[start]).max(initial=0.0) > tolerance:
            return None
    return segments
