"""What the reports compute from the data and a model.

Missing values and what they leave out, one-step predictions that skip the
samples they cannot use, the λ a fit used, a model's change points on the
data's axis (:func:`changepoint_report`), and the report that ``fit`` and
``segments`` share (:func:`state_space_report`). The library's models and
estimators are imported inside the functions: importing the command line
does not load the solvers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .messages import user_errors
from .report import (
    fmt,
    info_subset,
    missing_text,
    noise_text,
    per_name,
    rms,
    rms_columns,
    time_text,
)

if TYPE_CHECKING:  # pragma: no cover
    from .recordings import StateSpaceData

__all__ = [
    "missing_values",
    "missing_transitions",
    "transition_terms",
    "first_missing",
    "predict",
    "lam_facts",
    "lam_how",
    "changepoint_report",
    "state_space_report",
]


def missing_values(names: list[str], *columns: np.ndarray | None) -> dict[str, int]:
    """The number of missing values (NaN) of each selected data column, by name."""
    arrays = [c for c in columns if c is not None and c.size]
    counts = (
        np.concatenate([np.sum(np.isnan(c), axis=0) for c in arrays]) if arrays else np.zeros(0)
    )
    return {name: int(c) for name, c in zip(names, counts, strict=True)}


def _observed_rows(x: np.ndarray, u: np.ndarray | None) -> np.ndarray:
    """(T,) whether x[t] and u[t] are observed (no NaN)."""
    ok = np.all(np.isfinite(x), axis=1)
    return ok if u is None else ok & np.all(np.isfinite(u), axis=1)


def missing_transitions(x: np.ndarray, u: np.ndarray | None) -> int:
    """Transitions t → t+1 left out of a fit: x[t], u[t] or x[t+1] not observed."""
    ok = _observed_rows(x, u)[:-1] & np.all(np.isfinite(x[1:]), axis=1)
    return int(ok.size - np.count_nonzero(ok))


def transition_terms(u: np.ndarray | None) -> str:
    """What a transition needs observed: ``x[t], u[t] and x[t+1]`` (without inputs, no u)."""
    return "x[t], u[t] and x[t+1]" if u is not None else "x[t] and x[t+1]"


def first_missing(values: np.ndarray | None, names: list[str]) -> tuple[int, str] | None:
    """(sample, column name) of the first missing value, or None."""
    if values is None:
        return None
    bad = np.argwhere(np.isnan(values))
    return None if not bad.size else (int(bad[0, 0]), names[int(bad[0, 1])])


def _lags_observed(model: Any, y: np.ndarray, u: np.ndarray | None) -> np.ndarray:
    """(N,) whether the lags of step j of an AR/ARX model (sample lag + j) are observed."""
    from ..results.arx import ARModel

    t = model.lag + np.arange(model.N)

    def observed(series: np.ndarray | None, first: int, stop: int) -> np.ndarray:
        """Whether rows t + first, ..., t + stop - 1 of ``series`` are all observed."""
        if series is None or stop <= first:
            return np.ones(t.size, dtype=bool)
        count = np.concatenate([[0], np.cumsum(~np.all(np.isfinite(series), axis=1))])
        return count[t + stop] - count[t + first] == 0

    ok = observed(y, -model.na, 0)
    if not isinstance(model, ARModel):
        ok &= observed(u, 1 - model.nk - model.nb, 1 - model.nk)
    return ok


def predict(model: Any, y: np.ndarray, u: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """One-step predictions (N, n) and (N,) whether each one could be computed.

    A prediction needs its regressors observed (LTV: x[t] and u[t]; AR/ARX:
    the lags); the others are NaN. An AR/ARX model's predict takes finite data
    only: missing samples are filled with 0 for it, and the predictions that
    use them are set to NaN.
    """
    from ..results.arx import ARModel
    from ..results.statespace import LTVModel

    if isinstance(model, LTVModel):
        ok = _observed_rows(y, u)[:-1]
        with user_errors():
            prediction = np.array(model.predict(y, u), dtype=float).reshape(model.N, -1)
    else:
        ok = _lags_observed(model, y, u)
        filled = np.where(np.isfinite(y), y, 0.0)
        series = filled[:, 0] if filled.shape[1] == 1 else filled
        with user_errors():
            if isinstance(model, ARModel) or u is None:  # u is None for an AR model only
                prediction = model.predict(series)
            else:
                prediction = model.predict(series, np.where(np.isfinite(u), u, 0.0))
        prediction = np.array(prediction, dtype=float).reshape(model.N, -1)
    prediction[~ok] = np.nan
    return prediction, ok


def lam_facts(model: Any, requested: Any) -> dict[str, Any]:
    """λ used (of the first step for a refined model) and how it was chosen.

    Parameters
    ----------
    model : LTVModel or ARXModel
        The fitted model.
    requested : float or "auto"
        The ``--lam`` given.

    Returns
    -------
    dict
        ``lam``, and with ``--lam auto`` the criterion ``lam_method``.
    """
    from ..estimators.selection import DEFAULT_METHOD

    first = model.info.get("first_step")
    lam = first["lam"] if isinstance(first, dict) and "lam" in first else model.lam
    facts: dict[str, Any] = {"lam": lam if np.ndim(lam) == 0 else np.asarray(lam)}
    if requested == "auto":
        selection = model.info.get("lam_selection") or {}
        norm = first["norm"] if isinstance(first, dict) else model.norm
        facts["lam_method"] = selection.get("method", DEFAULT_METHOD.get(norm))
    return facts


def lam_how(facts: dict[str, Any]) -> str:
    """How λ was chosen, in words, from :func:`lam_facts`."""
    if "lam_method" in facts:
        return f"chosen by lam=auto, criterion {facts['lam_method']!r}"
    return "given"


def changepoint_report(model: Any) -> tuple[dict[str, Any], str, np.ndarray]:
    """A fitted model's change points as the reports give them.

    The segment boundaries of a piecewise, L0 or LTI model, else the peaks of
    its activation (:func:`ltvmodels.find_changepoints`); each as the model
    step c, the sample of the data it lies at (the first observation
    produced under the new coefficients: x[c + 1] of a state-space model,
    y[lag + c] of an AR model) and, with ``--time``, that sample's time.

    Parameters
    ----------
    model : LTVModel or ARXModel
        The fitted model.

    Returns
    -------
    facts : dict
        ``changepoints`` (model steps), ``changepoint_samples``,
        ``changepoint_rule`` and, with a time axis and change points,
        ``changepoint_times`` (text: dates or numbers).
    line : str
        The text summary's line.
    changepoints : ndarray of int, shape (M,)
        The model steps (for the figure).
    """
    from ..estimators.changepoints import find_changepoints
    from ..results.changepoints import Changepoints

    if model.norm in ("piecewise", "l0", "lti"):
        found = Changepoints.of_model(model.changepoints, model)
        rule = "segment boundaries of the model"
    else:
        with user_errors("change points: "):
            found = find_changepoints(model)
        rule = "peaks of the activation ||(Dk)_t|| (ltvmodels.find_changepoints)"
    steps, samples = found.changepoints, found.sample_indices
    facts: dict[str, Any] = {
        "changepoints": steps,
        "changepoint_samples": samples,
        "changepoint_rule": rule,
    }
    line = f"change points: {steps.tolist()} ({rule})"
    if steps.size:
        line += f"; first samples under the new coefficients: {samples.tolist()}"
    if found.times is not None and steps.size:
        facts["changepoint_times"] = time_text(found.times)
        line += f", at times {', '.join(facts['changepoint_times'])}"
    return facts, line, steps


def state_space_report(
    command: str, data: StateSpaceData, model: Any
) -> tuple[dict[str, Any], list[str], np.ndarray]:
    """The facts common to ``fit`` and ``segments``: RMS, missing data, change points, solver.

    Parameters
    ----------
    command : str
        The subcommand, as the report names it.
    data : StateSpaceData
        The recording the model was fitted on.
    model : LTVModel
        The fitted model.

    Returns
    -------
    report : dict
        What ``--json`` prints (the command adds its own facts).
    lines : list of str
        The text summary.
    changepoints : ndarray
        The change points detected (for the figure).
    """
    label, x, u = data.label, data.x, data.u
    state_names, input_names = data.state_names, data.input_names
    counts = missing_values(state_names + input_names, x, u)
    any_missing = any(counts.values())
    prediction, ok = predict(model, x, u)
    valid = ok[:, None] & np.isfinite(x[1:])
    pred_rms = rms_columns(prediction - x[1:], valid)
    u_sim = None if u is None else u[: model.N]  # u[T-1] drives no transition
    blocked_u = first_missing(u_sim, input_names)
    blocked_x = first_missing(x[:1], state_names)
    if blocked_u is not None:
        skipped = (
            f"input {blocked_u[1]} is missing at sample {blocked_u[0]}; a simulation "
            "needs every input"
        )
    elif blocked_x is not None:
        skipped = f"the initial state is missing ({blocked_x[1]} at sample 0)"
    else:
        skipped = None
    if skipped is None:
        with user_errors():
            simulation = model.simulate(x[0], u_sim)
        sim_valid = np.isfinite(x)
        sim_rms: list[float] | None = rms_columns(simulation - x, sim_valid)
        sim_total: float | None = rms(simulation - x, sim_valid)
    else:
        sim_rms = sim_total = None
    changepoint_facts, changepoint_line, changepoints = changepoint_report(model)
    info = model.info
    n_missing = model.n_missing
    report: dict[str, Any] = {
        "command": command,
        "data": label,
        "T": x.shape[0],
        "state": state_names,
        "input": input_names,
        "model": type(model).__name__,
        "N": model.N,
        "norm": model.norm,
        "order": None if model.coeffs is None else len(model.coeffs) - 1,
        "constant": bool(model.constant),
        "n_missing": n_missing,
        "missing_values": counts,
        "rms": {
            "prediction": rms(prediction - x[1:], valid),
            "simulation": sim_total,
            "prediction_per_state": pred_rms,
            "simulation_per_state": sim_rms,
        },
        **changepoint_facts,
        "noise_var": np.atleast_1d(model.noise_var),
        "loglik": model.loglik,
        "solver": info.get("solver"),
        "converged": info.get("converged"),
        "iterations": info.get("iterations"),
        "info": info_subset(info),
    }
    if skipped is not None:
        report["rms"]["simulation_skipped"] = skipped
    status = ""
    if info.get("converged") is not None:
        status = ", converged" if info["converged"] else ", NOT converged (see the warnings)"
    if info.get("iterations") is not None:
        status += f", {info['iterations']} iterations"
    observed_only = "; observed samples only" if any_missing else ""
    lines = [
        f"ltvmodels {command}: {label}, T = {x.shape[0]} samples; states "
        f"{', '.join(state_names)}; inputs {', '.join(input_names) or '(none)'}",
        model.summary(),
        f"solver: {info.get('solver', '?')}{status}",
    ]
    if any_missing:
        lines.append(
            missing_text(
                n_missing,
                model.N,
                counts,
                "transitions",
                f"a transition enters the fit only if {transition_terms(u)} are observed",
            )
        )
    lines += [
        noise_text(model, state_names),
        f"one-step prediction RMS: {fmt(report['rms']['prediction'])} "
        f"({per_name(state_names, pred_rms)}{observed_only})",
        (
            f"open-loop simulation RMS: {fmt(sim_total)} ({per_name(state_names, sim_rms)}; "
            "from the first state"
            + (" with the recorded inputs" if u is not None else "")
            + f"{observed_only})"
        )
        if sim_total is not None
        else f"open-loop simulation: not computed ({skipped})",
        changepoint_line,
    ]
    return report, lines, changepoints
