"""``fit_many``: one model per unit of a panel — thousands to millions of series.

A unit is one machine of a fleet, one loop of a plant, one patient or region.
:func:`fit_many` splits the data by unit (a long table, a mapping of arrays,
or a dask DataFrame), fits each unit with the estimator and options given,
and collects the models, a summary row per unit and the errors of the units
that fail — one bad unit never stops the others. Where the units are fitted
is up to :mod:`.engines`: this process, a pool of local processes (the
default), or a Dask cluster.

The unit's model is what the estimator returns for its data alone, bit for
bit: ``fit_many(frame, by="unit", state=["x1", "x2"], time="date", lam=10)[u]``
equals ``fit(g.set_index("date")[["x1", "x2"]], lam=10)`` for the rows ``g`` of
unit ``u``; the table is split once, and each unit reaches the estimator as a
:class:`~ltvmodels.validation.arrays.LabelledSeries` (its column names and time
stamps, without a DataFrame per unit).
"""

from __future__ import annotations

import inspect
import os
import time as clock
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ..progress import Progress
from ..results.manifest import check_units, model_file_name, output_directory
from ..results.model_set import ModelSet
from ..validation import arrays
from ..validation import options as checks
from ..validation.options import ManyMethod
from . import engines
from .fit import fit, fit_lti
from .segments import fit_segments

__all__ = ["fit_many", "check_unit_dtype"]

METHODS: dict[ManyMethod, Callable] = {"fit": fit, "segments": fit_segments, "lti": fit_lti}
"""The estimators ``method=`` names."""

# Dask tasks per worker thread: the cluster's workers take tasks as they free up.
DASK_TASKS_PER_WORKER = 8

DASK_STALL_SECONDS = 600.0
"""The default ``stall_timeout`` on a Dask cluster (no fit here measures a unit's cost)."""


@dataclass(frozen=True)
class _UnitData:
    """One unit's data, as its estimator receives it."""

    unit: Any
    position: int
    x: Any
    u: Any = None
    weights: Any = None
    T: int | None = None
    error: str | None = None  # found while splitting the table (e.g. duplicated times)


@dataclass(frozen=True)
class _UnitResult:
    """What a worker sends back for one unit."""

    position: int
    unit: Any
    record: dict
    model: Any = None
    error: str | None = None


@dataclass(frozen=True)
class _FitSpec:
    """How every unit is fitted (sent to the workers once per task)."""

    estimator: Callable
    options: dict
    keep_models: bool
    models_dir: str | None


# -- the work of one task ---------------------------------------------------------------
def _fit_units(units: list[_UnitData], spec: _FitSpec) -> list[_UnitResult]:
    """Fit each unit; a unit that fails becomes a result with its error (never raises)."""
    return [_fit_unit(data, spec) for data in units]


def _fit_unit(data: _UnitData, spec: _FitSpec) -> _UnitResult:
    """Fit one unit and summarize it (see :attr:`ltvmodels.ModelSet.summary`)."""
    record: dict[str, Any] = {"unit": data.unit, "T": data.T}
    start = clock.perf_counter()
    if data.error is not None:
        return _failed(data, record, data.error)
    extra = {} if data.weights is None else {"weights": data.weights}
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model = spec.estimator(data.x, data.u, **spec.options, **extra)
    except Exception as exc:  # one bad unit never stops the others
        return _failed(data, record, f"{type(exc).__name__}: {exc}")
    seconds = clock.perf_counter() - start
    record.update(_model_record(model, data, spec.options))
    record["seconds"] = seconds
    record["warnings"] = (
        "; ".join(sorted({f"{w.category.__name__}: {w.message}" for w in caught})) or None
    )
    if spec.models_dir is not None:
        try:
            model.save(Path(spec.models_dir) / model_file_name(data.position))
        except OSError as exc:  # a full disk fails this unit, not the task
            return _failed(
                data, record, f"cannot write its model file ({type(exc).__name__}: {exc})"
            )
    return _UnitResult(data.position, data.unit, record, model=model if spec.keep_models else None)


def _failed(data: _UnitData, record: dict, message: str) -> _UnitResult:
    record.update(status="error", error=message)
    return _UnitResult(data.position, data.unit, record, error=message)


def _model_record(model: Any, data: _UnitData, options: dict) -> dict:
    """The summary entries of a fitted model (JSON-compatible values)."""
    record: dict[str, Any] = {}
    info = getattr(model, "info", {})
    lam = getattr(model, "lam", None)
    record["lam"] = float(lam) if lam is not None and np.ndim(lam) == 0 else None
    selection = info.get("lam_selection")
    record["lam_method"] = (
        selection["method"] if selection else ("given" if lam is not None else None)
    )
    record["missing"] = getattr(model, "n_missing", None)
    names = getattr(model, "state_names", None) or []
    noise = getattr(model, "noise_var", None)
    if noise is not None and len(names) == len(noise):
        record.update({f"noise_var_{name}": float(value) for name, value in zip(names, noise)})
    loglik = getattr(model, "loglik", None)
    record["loglik"] = None if loglik is None else float(loglik)
    record["rms"] = _one_step_rms(model, data, options)
    if getattr(model, "norm", "sq") != "sq" and hasattr(model, "changepoints"):
        times = model.changepoint_times
        points = model.changepoints if times is None else times
        record["n_changes"] = int(len(points))
        record["change_times"] = _json_times(points)
    else:
        record["n_changes"], record["change_times"] = None, None
    status = getattr(model, "status", None)
    record["status"] = getattr(status, "status", None)
    return record


def _one_step_rms(model: Any, data: _UnitData, options: dict) -> float | None:
    """Root mean square of x[t+1] − x̂[t+1] over the transitions with data."""
    info = getattr(model, "info", {})
    unweighted = (
        data.weights is None
        and options.get("weights") is None
        and options.get("loss", "squared") == "squared"
    )
    missing = getattr(model, "n_missing", None)
    if unweighted and "rss" in info and missing is not None and np.ndim(_plain(data.x)) in (1, 2):
        # The fit's residual sum of squares over its observed transitions: no recomputation.
        rows = model.N - missing
        return float(np.sqrt(info["rss"] / (rows * model.n_outputs))) if rows > 0 else None
    try:  # the estimator has validated the data: no need to check them again
        x = np.asarray(_plain(data.x), dtype=np.float64)
        u = None if data.u is None else np.asarray(_plain(data.u), dtype=np.float64)
        theta = model.theta
    except (AttributeError, TypeError, ValueError):
        return None
    if x.ndim == 1:
        x = x[:, None]
    if u is not None and u.ndim == 1:
        u = u[:, None]
    if x.ndim != 2 or x.shape[0] != theta.shape[0] + 1:  # several trajectories: predict
        try:
            error = arrays.trajectories(data.x, "x")[:, 1:] - model.predict(data.x, data.u)
        except (TypeError, ValueError):
            return None
    else:
        parts = [x[:-1]] + ([] if u is None else [u[:-1]])
        if theta.shape[2] > sum(part.shape[1] for part in parts):  # the intercept
            parts.append(np.ones((x.shape[0] - 1, 1)))
        error = x[1:] - np.einsum("tij,tj->ti", theta, np.concatenate(parts, axis=1))
    error = error[np.isfinite(error).all(axis=-1)]
    return float(np.sqrt(np.mean(error**2))) if error.size else None


def _plain(value: Any) -> Any:
    """The values of a DataFrame or LabelledSeries; anything else as it is."""
    return value.to_numpy() if hasattr(value, "to_numpy") else value


def _json_times(points: np.ndarray) -> list:
    """Change-point times as JSON keeps them: ISO text for dates, numbers otherwise."""
    points = np.asarray(points)
    if np.issubdtype(points.dtype, np.datetime64):
        return [str(text) for text in np.datetime_as_string(points, unit="auto")]
    return points.tolist()


# -- splitting the data into units ----------------------------------------------------------
def _column_list(value: Any, name: str, columns: Any, *, required: bool) -> list:
    """Column names given as one name or a list; checked present and named once.

    Parameters
    ----------
    value : str, list, tuple or None
        The names.
    name : str
        The argument they come from (the start of the messages).
    columns : sequence
        The columns of the table.
    required : bool
        Whether at least one name is needed.

    Returns
    -------
    list
        The names.

    Raises
    ------
    TypeError
        None where a name is required.
    ValueError
        No name where one is required, a name that is not a column, a name
        given twice, or a name that two columns of the table have.
    """
    if value is None:
        if required:
            raise TypeError(f"{name}: expected the name(s) of the column(s) to use, received None")
        return []
    names = list(value) if isinstance(value, (list, tuple)) else [value]
    if len(names) == 0 and required:
        raise ValueError(f"{name}: expected at least one column name, received an empty list")
    repeated = [column for position, column in enumerate(names) if column in names[:position]]
    if repeated:
        raise ValueError(
            f"{name}: column {repeated[0]!r} is named twice in {names!r}; name each column once"
        )
    missing = [column for column in names if column not in columns]
    if missing:
        shown = ", ".join(repr(column) for column in list(columns)[:12])
        raise ValueError(
            f"{name}: column {missing[0]!r} is not in data; its columns are "
            f"{shown}{', ...' if len(columns) > 12 else ''}"
        )
    arrays.distinct_columns(columns, name, used=names)
    return names


def _check_roles(by: Any, state: list, inputs: list, time: list, weights: list) -> None:
    """Each column plays one role: the unit, a state, an input, the time or the weights.

    Parameters
    ----------
    by : column name
        The unit column.
    state, inputs, time, weights : list
        The columns of each role (``time`` and ``weights``: none or one).

    Raises
    ------
    ValueError
        A column named in two roles; the message names the column and both roles.
    """
    roles = [("by", [by]), ("state", state), ("inputs", inputs), ("time", time)]
    roles.append(("weights", weights))
    for index, (first, names) in enumerate(roles):
        for second, others in roles[index + 1 :]:
            shared = [column for column in names if column in others]
            if not shared:
                continue
            column = shared[0]
            if "time" in (first, second):
                other = second if first == "time" else first
                raise ValueError(
                    f"time: column {column!r} is also {ROLE_PHRASES[other]} ({other}=); each "
                    "unit's rows would be sorted by its values: pass the column of time "
                    "stamps as time= (or time=None to keep the table's row order)"
                )
            raise ValueError(
                f"{first}, {second}: column {column!r} is named as both {first} and "
                f"{second}; a column plays one role: name it in one of them"
            )


ROLE_PHRASES = {
    "by": "the unit column",
    "state": "a state column",
    "inputs": "an input column",
    "weights": "the weights column",
}


def _numeric_columns(frame: Any, names: list, name: str) -> np.ndarray:
    """The columns as a float64 (rows, len(names)) array; TypeError naming a text column."""
    for column in names:
        kind = getattr(frame[column].dtype, "kind", "O")
        if kind not in "biuf":
            raise TypeError(
                f"{name}: column {column!r} holds {frame[column].dtype} values; "
                "expected numbers (convert it, e.g. with pandas.to_numeric)"
            )
    return frame[names].to_numpy(dtype=np.float64)


def _table_units(
    frame: Any, by: Any, state: Any, inputs: Any, time: Any, weights: Any
) -> list[_UnitData]:
    """Split a long pandas DataFrame (one row per unit and time step) into units.

    Units in order of first appearance; rows of a unit sorted by ``time`` (stably),
    or in their order in the table when ``time`` is None.

    Parameters
    ----------
    frame : pandas.DataFrame
        The long table.
    by, state, inputs, time, weights : column names
        As :func:`fit_many` takes them (``weights``: a column name or None).

    Returns
    -------
    list of _UnitData
        One per unit, its position its order of first appearance.

    Raises
    ------
    TypeError, ValueError
        A column that is missing, named twice or in two roles (e.g. ``time``
        also a state), not numeric (state, inputs, weights) or not dates or
        numbers (time), missing units or time stamps.
    """
    import pandas as pd

    columns = frame.columns
    if isinstance(by, (list, tuple)):
        raise TypeError(f"by: expected the name of one column (the unit), received {by!r}")
    (by,) = _column_list(by, "by", columns, required=True)
    state = _column_list(state, "state", columns, required=True)
    inputs = _column_list(inputs, "inputs", columns, required=False)
    time_column = _column_list(time, "time", columns, required=False)
    weight_column = (
        _column_list(weights, "weights", columns, required=False)
        if isinstance(weights, str)
        else []
    )
    if weights is not None and not weight_column:
        raise TypeError(
            f"weights: expected the name of a column of weights, received "
            f"{arrays.describe(weights)}"
        )
    keys = frame[by]
    if keys.isna().any():
        raise ValueError(
            f"by: column {by!r} has {int(keys.isna().sum())} rows without a unit "
            "(missing values); drop them or label them"
        )
    codes, uniques = pd.factorize(keys, sort=False)
    if time_column:
        stamps = frame[time_column[0]]
        if stamps.isna().any():
            raise ValueError(
                f"time: column {time_column[0]!r} has {int(stamps.isna().sum())} "
                "missing time stamps; drop those rows or fill them"
            )
        stamps = arrays.index_values(pd.Index(stamps))
        if not (
            np.issubdtype(stamps.dtype, np.datetime64) or np.issubdtype(stamps.dtype, np.number)
        ):
            raise TypeError(
                f"time: column {time_column[0]!r} holds {stamps.dtype} values; "
                "expected dates or numbers (convert it, e.g. with "
                "pandas.to_datetime)"
            )
    _check_roles(by, state, inputs, time_column, weight_column)
    if time_column:
        order = np.lexsort((stamps, codes))
        stamps = stamps[order]
    else:
        order = np.argsort(codes, kind="stable")
    x_all = _numeric_columns(frame, state, "state")[order]
    u_all = _numeric_columns(frame, inputs, "inputs")[order] if inputs else None
    w_all = _numeric_columns(frame, weight_column, "weights")[order, 0] if weight_column else None
    bounds = np.searchsorted(codes[order], np.arange(len(uniques) + 1))
    state_names = [str(name) for name in state]
    input_names = [str(name) for name in inputs]
    time_name = str(time_column[0]) if time_column else None
    units = []
    for position, unit in enumerate(uniques.tolist()):
        a, b = int(bounds[position]), int(bounds[position + 1])
        unit_time = stamps[a:b] if time_column else None
        error = None
        if unit_time is not None and b - a > 1 and np.any(unit_time[1:] == unit_time[:-1]):
            first = unit_time[1:][unit_time[1:] == unit_time[:-1]][0]
            error = (
                f"ValueError: time: duplicated time stamp {first} in column "
                f"{time_column[0]!r}; each unit needs one row per time step (aggregate "
                "or drop the duplicates)"
            )
        units.append(
            _UnitData(
                unit,
                position,
                arrays.LabelledSeries(x_all[a:b], state_names, unit_time, time_name),
                None
                if u_all is None
                else arrays.LabelledSeries(u_all[a:b], input_names, unit_time, time_name),
                None if w_all is None else w_all[a : b - 1],
                T=b - a,
                error=error,
            )
        )
    return units


def _mapping_units(data: Mapping, weights: Any) -> list[_UnitData]:
    """Units of a mapping ``{unit: x}`` or ``{unit: (x, u)}`` (arrays or DataFrames)."""
    if isinstance(weights, str):
        raise TypeError(
            "weights: a column name needs a table; with a mapping of arrays, "
            "pass (x, u) pairs and the weights as an array shared by every unit, "
            "or fit the units with different weights separately"
        )
    units = []
    for position, (unit, value) in enumerate(data.items()):
        if isinstance(value, tuple):
            if len(value) not in (1, 2):
                raise ValueError(
                    f"data[{unit!r}]: expected x or a pair (x, u), received a "
                    f"tuple of {len(value)} items"
                )
            x, u = value if len(value) == 2 else (value[0], None)
        else:
            x, u = value, None
        shape = np.shape(x) if not isinstance(x, list) else (None,)
        T = shape[-2] if len(shape) == 3 else (shape[0] if shape else None)
        units.append(_UnitData(unit, position, x, u, T=T))
    return units


# -- fit_many -------------------------------------------------------------------------------
def fit_many(
    data: Any,
    *,
    by: Any = None,
    state: Any = None,
    inputs: Any = None,
    time: Any = None,
    engine: Any = None,
    n_jobs: int | None = None,
    keep_models: bool = True,
    models_dir: str | os.PathLike | None = None,
    method: ManyMethod | Callable = "fit",
    progress: bool | None = None,
    stall_timeout: float | None = None,
    **options: Any,
) -> ModelSet:
    """Fit one model per unit of a panel, on all local cores or on a Dask cluster.

    Each unit's model is what ``method`` returns for that unit's data alone
    (``fit`` by default), bit for bit; a unit whose fit fails is recorded in
    ``errors`` and never stops the others.

    Parameters
    ----------
    data : pandas.DataFrame, mapping or dask.dataframe.DataFrame
        * a long DataFrame: one row per unit and time step; ``by`` names the
          unit column, ``state`` and ``inputs`` the columns of x and u, ``time``
          the column to sort each unit's rows by (dates or numbers; the
          model's ``time``). Rows are consecutive samples: insert NaN rows for
          missing time steps.
        * a mapping ``{unit: x}`` or ``{unit: (x, u)}`` of arrays, lists or
          DataFrames, each as :func:`ltvmodels.fit` takes them (including
          several trajectories per unit).
        * a dask DataFrame, laid out as the long DataFrame: it is shuffled by
          unit on the cluster and each partition is fitted where it lives (the
          raw data never reach this process). Units come in the order of the
          partitions; a partition whose worker dies is computed once more,
          and if that fails too it is one entry ``"<partition i>"`` in
          ``errors``.
    by : str
        The unit column (tables only).
    state : str or list of str
        The state columns (tables only).
    inputs : str or list of str, optional
        The input columns (tables only).
    time : str, optional
        The time column (tables only); None keeps the table's row order. A
        column plays one role: ``time`` cannot be ``by``, a state, an input
        or the weights column, nor a column both a state and an input.
    engine : None or dask.distributed.Client
        None: a pool of ``n_jobs`` processes on this machine. A Client: tasks
        on its cluster (a ``LocalCluster``, ``dask scheduler``/``dask worker``,
        dask-jobqueue, Kubernetes), best with one thread per worker process.
    n_jobs : int, optional
        Processes of the local pool; 1 fits in this process. Default: every
        core this process may use, for a job large enough to gain from them:
        the first units are fitted in this process, which measures what a
        unit costs, and a job that would not finish sooner on the pool
        (worker start-up included) is finished here. Ignored with a Client.
    keep_models : bool
        False keeps only the summary (and the model files, with
        ``models_dir``), so that 10⁵ units fit in bounded memory here.
    models_dir : str or path-like, optional
        Write each unit's model file there as it finishes (workers write it:
        on a cluster the directory must be shared), with the manifest of
        :func:`ltvmodels.load_many` at the end (written atomically). Created
        (with its parents) before the data are split; the units must be of a
        type the manifest stores (text, numbers, bools, dates, times,
        durations, UUIDs or tuples of these: see
        :mod:`ltvmodels.results.manifest`), checked before any unit is fitted.
    method : {"fit", "segments", "lti"} or callable
        The estimator: :func:`ltvmodels.fit`, :func:`ltvmodels.fit_segments`,
        :func:`ltvmodels.fit_lti`, or any function ``f(x, u, **options)``
        returning a model (module-level, so that workers can import it).
    progress : bool, optional
        A progress line on stderr (units done, rate, time left); default: only
        when stderr is a terminal.
    stall_timeout : float, optional
        Seconds to wait for the next finished task before giving up: the
        workers are stopped and every unit without a result is recorded in
        ``errors`` with a message that says so (a worker that hangs or was
        stopped never hangs ``fit_many``). Default (local processes): 600 s
        until a task has finished, then 60 s or 20 times the longest task so
        far, whichever is longer; 600 s on Dask.
    **options
        Keyword arguments of the estimator, the same for every unit, e.g.
        ``lam`` (``"auto"`` selects λ per unit), ``norm``, ``order``, ``refine``,
        ``constant``, ``loss``; for a table ``weights`` may name a column
        (the weight of row t applies to the transition from t to t + 1).
        Checked against the estimator's signature before anything runs: an
        option it does not take, or a parameter it requires (``lam`` for
        ``fit``) that is missing, is an error.

    Returns
    -------
    ModelSet
        ``ms[unit]`` the model, ``ms.summary`` one row per unit (pandas),
        ``ms.errors`` ``{unit: message}``, ``ms.save(directory)``.

    Raises
    ------
    TypeError, ValueError
        Invalid arguments or options (a unit's bad data only fail that unit),
        including a missing required option and a column named in two roles.
    OutputPathError
        ``models_dir`` is an existing file, or cannot be created or written.
    ImportError
        A table without pandas, or a Client or dask DataFrame without
        ``dask.distributed``.

    Notes
    -----
    Every task runs with one BLAS and one numba thread (restored after). A
    worker process that dies (killed, out of memory) loses only its running
    tasks: their units are retried once, and those whose worker dies again
    are recorded in ``errors``; a pool that stops answering is stopped after
    ``stall_timeout`` (see :mod:`ltvmodels.estimators.engines`). The local
    workers are loky's reusable processes: they stay for the next call (five
    minutes idle), so only a session's first parallel call waits for them
    to start. With the default ``n_jobs``, the units fitted in this process
    (the first few, or all of a small job) are as exposed as in a loop of
    ``fit``: a unit that crashes the interpreter takes this process along.
    Pass ``n_jobs`` to fit every unit in worker processes.

    Examples
    --------
    >>> import numpy as np, pandas as pd, ltvmodels as ltv
    >>> frames = []
    >>> for unit in range(3):
    ...     d = ltv.systems.jump_linear(T=100, change_at=50, seed=unit)
    ...     frames.append(pd.DataFrame({"unit": unit, "t": np.arange(100), "x1": d.x[:, 0],
    ...                                 "x2": d.x[:, 1], "u": d.u[:, 0]}))
    >>> panel = pd.concat(frames)
    >>> ms = ltv.fit_many(panel, by="unit", state=["x1", "x2"], inputs="u", time="t",
    ...                   lam=10.0, n_jobs=1)
    >>> len(ms), list(ms.summary["status"])
    (3, ['closed_form', 'closed_form', 'closed_form'])
    """
    estimator = _estimator_of(method)
    _check_options(estimator, method, options)
    keep_models = checks.flag(keep_models, "keep_models")
    if progress is not None:
        progress = checks.flag(progress, "progress")
    adaptive = n_jobs is None
    n_jobs = (
        engines.default_jobs() if n_jobs is None else checks.integer(n_jobs, "n_jobs", minimum=1)
    )
    if stall_timeout is not None:
        stall_timeout = checks.positive_scalar(stall_timeout, "stall_timeout")
    # Created now, before the data are split: a directory that cannot be one fails at once.
    directory = None if models_dir is None else output_directory(models_dir, "models_dir")
    client = _dask_client(engine)
    weights = options.pop("weights", None)
    if _is_dask_frame(data):
        return _fit_dask_frame(
            data,
            client,
            by=by,
            state=state,
            inputs=inputs,
            time=time,
            weights=weights,
            estimator=estimator,
            options=options,
            keep_models=keep_models,
            directory=directory,
            progress=progress,
            stall_timeout=DASK_STALL_SECONDS if stall_timeout is None else stall_timeout,
        )
    if isinstance(data, Mapping):
        if by is not None or state is not None or inputs is not None or time is not None:
            raise TypeError(
                "by, state, inputs, time: name columns of a table; a mapping "
                "{unit: (x, u)} needs none of them"
            )
        units = _mapping_units(data, weights)
        if weights is not None:
            options["weights"] = weights
        by_name = "unit"
    elif hasattr(data, "columns") and hasattr(data, "groupby"):
        units = _table_units(data, by, state, inputs, time, weights)
        by_name = str(by)
    else:
        raise TypeError(
            f"data: expected a long pandas DataFrame (with by=, state=), a mapping "
            f"{{unit: (x, u)}} or a dask DataFrame, received {arrays.describe(data)}"
        )
    if directory is not None:  # the manifest stores every unit: checked before any fit
        check_units((data.unit for data in units), "data" if isinstance(data, Mapping) else "by")
    spec = _FitSpec(estimator, options, keep_models, None if directory is None else str(directory))
    collected = _Collector(len(units), by_name, keep_models, directory, progress)
    task = partial(_fit_units, spec=spec)
    with collected.progress:
        if client is not None:
            engines.run_dask(
                client,
                task,
                engines.even_chunks(units, _client_workers(client), DASK_TASKS_PER_WORKER),
                collected.add,
                collected.lose,
                stall_timeout=DASK_STALL_SECONDS if stall_timeout is None else stall_timeout,
            )
        else:
            engines.run_local(
                task,
                units,
                n_jobs,
                collected.add,
                collected.lose,
                adaptive=adaptive,
                stall_timeout=stall_timeout,
            )
    return collected.model_set(units)


def _estimator_of(method: Any) -> Callable:
    if callable(method):
        return method
    return METHODS[checks.choice(method, "method", tuple(METHODS))]


# How to pass a required option, in the message that asks for it.
REQUIRED_HINTS = {"lam": "a number or 'auto'"}


def _check_options(estimator: Callable, method: Any, options: dict) -> None:
    """Check the options against the estimator's signature, before any unit runs.

    Parameters
    ----------
    estimator : callable
        The estimator, called as ``estimator(x, u, **options)``.
    method : str or callable
        What the caller passed as ``method`` (named in the messages).
    options : dict
        The options for every unit (a table's ``weights`` column included).

    Raises
    ------
    TypeError
        An option the estimator does not take (unless it takes ``**kwargs``),
        or a parameter it requires (no default, beyond x and u) that is not
        given: every unit would fail with it.
    """
    try:
        signature = inspect.signature(estimator)
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return
    parameters = signature.parameters
    name_of = method if isinstance(method, str) else getattr(method, "__name__", "")
    positional = [
        p.name
        for p in parameters.values()
        if p.kind in (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    ][:2]  # x and u: every unit's data
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        for name in options:
            if name not in parameters or name in ("x", "u"):
                accepted = [p for p in parameters if p not in ("x", "u")]
                raise TypeError(
                    f"{name}: not an option of method={name_of!r}; it takes {', '.join(accepted)}"
                )
    missing = [
        p.name
        for p in parameters.values()
        if p.default is inspect.Parameter.empty
        and p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
        and p.name not in positional
        and p.name not in options
    ]
    if missing:
        name = missing[0]
        raise TypeError(
            f"{name}: required by method={name_of!r}; pass {name}=... "
            f"({REQUIRED_HINTS.get(name, 'the same value for every unit')})"
            + (f" (also required: {', '.join(missing[1:])})" if len(missing) > 1 else "")
        )


def _dask_client(engine: Any) -> Any:
    if engine is None:
        return None
    if type(engine).__name__ == "Client" and hasattr(engine, "submit"):
        return engine
    raise TypeError(
        f"engine: expected None (local processes) or a dask.distributed.Client, "
        f"received {arrays.describe(engine)}"
    )


def _client_workers(client: Any) -> int:
    """Worker threads of a cluster (at least 1)."""
    return max(1, sum(client.nthreads().values()))


def _is_dask_frame(data: Any) -> bool:
    return type(data).__module__.startswith("dask") and hasattr(data, "npartitions")


class _Collector:
    """Gathers the workers' results into a :class:`~ltvmodels.ModelSet`."""

    def __init__(
        self,
        total: int | None,
        by: str,
        keep_models: bool,
        directory: Path | None,
        progress: bool | None,
        unit: str = "units",
    ) -> None:
        self.results: dict[int, _UnitResult] = {}
        self.by = by
        self.keep_models = keep_models
        self.directory = directory
        self.progress = Progress("fit_many", total, unit=unit, threaded=False)
        if progress is not None:
            self.progress.enabled = progress

    def add(self, results: list[_UnitResult]) -> None:
        for result in results:
            self.results[result.position] = result
        self.progress.advance(len(results))

    def lose(self, data: _UnitData, message: str) -> None:
        self.add([_failed(data, {"unit": data.unit, "T": data.T}, message)])

    def model_set(self, units: list[_UnitData]) -> ModelSet:
        ordered = [self.results[data.position] for data in units]
        errors = {result.unit: result.error for result in ordered if result.error}
        models = {
            result.unit: result.model
            for result in ordered
            if self.keep_models and result.error is None
        }
        files = (
            {}
            if self.directory is None
            else {
                data.unit: model_file_name(data.position)
                for data in units
                if data.unit not in errors
            }
        )
        model_set = ModelSet(
            [result.unit for result in ordered],
            [result.record for result in ordered],
            errors,
            by=self.by,
            models=models,
            directory=self.directory,
            files=files,
        )
        if self.directory is not None:
            model_set.save(self.directory)
        return model_set


def _fit_dask_frame(
    frame: Any,
    client: Any,
    *,
    by: Any,
    state: Any,
    inputs: Any,
    time: Any,
    weights: Any,
    estimator: Callable,
    options: dict,
    keep_models: bool,
    directory: Path | None,
    progress: bool | None,
    stall_timeout: float,
) -> ModelSet:
    """Fit the units of a dask DataFrame where its partitions live (see :func:`fit_many`)."""
    import dask

    if client is None:
        from distributed import get_client

        try:
            client = get_client()
        except ValueError:
            raise TypeError(
                "engine: a dask DataFrame needs a dask.distributed.Client: pass "
                "engine=Client(...) (or start one, e.g. Client(LocalCluster()))"
            ) from None
    if not isinstance(by, str):
        raise TypeError(f"by: expected the name of the unit column, received {arrays.describe(by)}")
    # The column names are known here: check them before any partition runs, so
    # that a typo is an error naming the argument, not a failed partition.
    _column_list(by, "by", frame.columns, required=True)
    if weights is not None and not isinstance(weights, str):
        raise TypeError(
            f"weights: expected the name of a column of weights, received "
            f"{arrays.describe(weights)}"
        )
    _check_roles(
        by,
        _column_list(state, "state", frame.columns, required=True),
        _column_list(inputs, "inputs", frame.columns, required=False),
        _column_list(time, "time", frame.columns, required=False),
        _column_list(weights, "weights", frame.columns, required=False),
    )
    if directory is not None:  # the units are known only on the cluster: check their type
        check_unit_dtype(frame[by].dtype, by)
        directory = output_directory(directory, "models_dir")
    shuffled = frame.shuffle(on=by)
    spec = _FitSpec(estimator, options, keep_models, None if directory is None else str(directory))
    parts = shuffled.to_delayed()
    tasks = [
        dask.delayed(_fit_partition)(part, index, by, state, inputs, time, weights, spec)
        for index, part in enumerate(parts)
    ]
    collected = _Collector(len(tasks), by, keep_models, directory, progress, unit="partitions")
    from distributed import as_completed as dask_as_completed

    def partition_failed(index: int, message: str) -> _UnitResult:
        unit = f"<partition {index}>"  # its units are unknown here
        data = _UnitData(unit, index * PARTITION_STRIDE, None)
        return _failed(data, {"unit": unit, "T": None}, message)

    results: list[_UnitResult] = []
    with collected.progress:
        futures = dict(zip(client.compute(tasks), enumerate(tasks)))
        queue = dask_as_completed(list(futures))
        retried = set()
        try:
            for future in engines.dask_completed(queue, stall_timeout):
                index, part_task = futures.pop(future)
                try:
                    results.extend(future.result())
                except Exception as exc:  # its worker died, after the scheduler's own retries
                    if index not in retried:  # once more, from the partition's source
                        retried.add(index)
                        again = client.compute(part_task)
                        futures[again] = (index, part_task)
                        queue.add(again)
                        continue
                    message = f"{engines.WORKER_DIED} ({type(exc).__name__}: {exc})"
                    results.append(partition_failed(index, message))
                collected.progress.advance(1)
        except TimeoutError:
            client.cancel(list(futures))
            message = engines.STALLED.format(where="Dask workers", seconds=stall_timeout)
            results.extend(partition_failed(index, message) for index, _ in futures.values())
    results.sort(key=lambda result: result.position)
    units = [_UnitData(result.unit, result.position, None) for result in results]
    collected.results = {result.position: result for result in results}
    return collected.model_set(units)


def check_unit_dtype(dtype: Any, by: str) -> None:
    """Raise if a unit column of this dtype holds units a manifest cannot store.

    For a dask DataFrame, whose units are known only once its partitions are
    fitted. Python objects (object dtype) cannot be checked here.

    Parameters
    ----------
    dtype : numpy or pandas dtype
        The dtype of the unit column.
    by : str
        Its name.

    Raises
    ------
    TypeError
        Complex numbers, periods, intervals and other types that are neither
        text, numbers, bools, dates nor durations.
    """
    import pandas as pd

    if isinstance(dtype, pd.CategoricalDtype):
        dtype = dtype.categories.dtype
    kind = getattr(dtype, "kind", "O")
    if kind in "biufmMUS" or dtype == np.dtype(object) or pd.api.types.is_string_dtype(dtype):
        return
    raise TypeError(
        f"by: column {by!r} holds {dtype} units, which a model set's manifest cannot store "
        f"(models_dir); expected text, numbers, bools, dates or durations; relabel the units "
        "(e.g. as text)"
    )


PARTITION_STRIDE = 10**9
"""Positions of a dask DataFrame's units: partition × stride + position in the partition."""


def _fit_partition(
    frame: Any,
    index: int,
    by: str,
    state: Any,
    inputs: Any,
    time: Any,
    weights: Any,
    spec: _FitSpec,
) -> list[_UnitResult]:
    """Fit the units of one partition (all rows of a unit are in one partition)."""
    units = _table_units(frame, by, state, inputs, time, weights)
    units = [
        _UnitData(
            data.unit,
            index * PARTITION_STRIDE + data.position,
            data.x,
            data.u,
            data.weights,
            data.T,
            data.error,
        )
        for data in units
    ]
    return engines.run_task(partial(_fit_units, spec=spec), units)
