"""A saved model and the data it runs on: what ``simulate``, ``predict`` and ``forecast`` share.

The model file is read by :func:`load_model`; :func:`model_data` reads the
columns it needs from DATA (by default those it records, see
:func:`ltvmodels.cli.outputs.record_columns`) and checks their sizes.
"""

from __future__ import annotations

import argparse
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .data import read_columns
from .messages import DataError, one_line

__all__ = ["ModelData", "load_model", "model_data"]


@dataclass(frozen=True)
class ModelData:
    """The columns of DATA that a loaded model runs on.

    Attributes
    ----------
    kind : {"ltv", "ar", "arx"}
        The model's kind: a state-space model, or an AR/ARX model.
    label : str
        The data file as the reports name it.
    T : int
        The number of samples.
    y : ndarray
        (T, n) the states (AR/ARX: the outputs); NaN where missing.
    u : ndarray or None
        (T, m) the inputs, None for a model without.
    names, input_names : list of str
        The columns' names.
    lag : int
        The samples before the first step (1 for a state-space model, the
        largest lag for an AR/ARX model).
    """

    kind: Literal["ltv", "ar", "arx"]
    label: str
    T: int
    y: np.ndarray
    u: np.ndarray | None
    names: list[str]
    input_names: list[str]
    lag: int


def load_model(path: str) -> Any:
    """Load a model file, every failure a one-line :class:`DataError`.

    Parameters
    ----------
    path : str
        The model file (.npz) as given.

    Returns
    -------
    LTVModel, ARXModel or another result of :func:`ltvmodels.load`
    """
    from ..results.loading import load

    p = Path(path)
    if not p.exists():
        raise DataError(f"{path}: no such file")
    if p.is_dir():
        raise DataError(f"{path}: is a directory, expected a model file (.npz)")
    if not zipfile.is_zipfile(p):
        raise DataError(
            f"{path}: not an ltvmodels model file (expected an .npz archive written "
            "by 'ltvmodels fit --out' or model.save)"
        )
    try:
        return load(p)
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except Exception as exc:  # a damaged archive, or not one of ours
        text = one_line(exc)
        if text.startswith("path: "):  # ltvmodels.load's own messages
            text = text[len("path: ") :]
            text = text[len(str(p)) + 1 :] if text.startswith(f"{p} ") else text
            text = text.removeprefix("is ")
            raise DataError(f"{path}: {text}") from None
        raise DataError(
            f"{path}: not an ltvmodels model file ({type(exc).__name__}: {text})"
        ) from None


def model_data(args: argparse.Namespace, model: Any) -> ModelData:
    """Read the columns a loaded model needs from DATA and check their sizes.

    Parameters
    ----------
    args : argparse.Namespace
        ``model``, ``data``, ``command`` and the columns ``state`` and
        ``input`` (None: those the model records).
    model : LTVModel or ARXModel
        The loaded model.

    Returns
    -------
    ModelData

    Raises
    ------
    DataError
        A model without dynamics, columns that are not given nor recorded,
        or data whose sizes do not match the model's.
    """
    from ..results.arx import ARModel, ARXModel
    from ..results.statespace import LTVModel

    recorded = {role: list(names) for role, names in model.data.names.items()}
    kind: Literal["ltv", "ar", "arx"]
    if isinstance(model, LTVModel):
        kind, n, m, lag = "ltv", model.n_states, model.n_inputs, 1
        out_key = "state"
    elif isinstance(model, ARXModel):
        kind = "ar" if isinstance(model, ARModel) else "arx"
        n, m, lag = model.n_outputs, model.n_inputs, model.lag
        out_key = "output"
    else:
        raise DataError(
            f"{args.model}: a {type(model).__name__} has no dynamics to "
            f"{args.command} (expected a model from fit, segments or ar)"
        )
    state = args.state if args.state is not None else _spec(recorded.get(out_key))
    inputs = args.input if args.input is not None else _spec(recorded.get("input"))
    if state is None:
        raise DataError(
            f"--state: {args.model} does not record its data columns; give "
            f"--state (and --input) to choose them in the data"
        )
    if m and inputs is None:
        raise DataError(
            f"--input: the model has {m} inputs; give --input to choose their columns in the data"
        )
    if not m and args.input is not None:
        raise DataError(f"--input: the model has no inputs, received {args.input!r}")
    T, label, cols = read_columns(
        args.data, header=args.header, state=state, input=inputs if m else None
    )
    names, y = cols["state"]
    if y.shape[1] != n:
        what = "states" if kind == "ltv" else "outputs"
        raise DataError(
            f"--state: the model has {n} {what}, received {y.shape[1]} columns ({', '.join(names)})"
        )
    u = None
    input_names: list[str] = []
    if m:
        input_names, u = cols["input"]
        if u.shape[1] != m:
            raise DataError(
                f"--input: the model has {m} inputs, received {u.shape[1]} "
                f"columns ({', '.join(input_names)})"
            )
    expected = model.N + lag
    if T != expected:
        steps = (
            f"N = {model.N} transitions"
            if kind == "ltv"
            else f"N = {model.N} time steps after {lag} initial samples"
        )
        raise DataError(
            f"{label}: expected T = {expected} rows (the model has {steps}), received {T}"
        )
    return ModelData(kind, label, T, y, u, names, input_names, lag)


def _spec(names: Any) -> str | None:
    """Recorded column names as a ``--state``/``--input`` value (None: none recorded)."""
    if not names:
        return None
    return ",".join(str(name) for name in names)
