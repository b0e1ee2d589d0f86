"""``DataDescription``: what the data said about a fit, kept by the model as ``model.data``.

The front-end that turns the user's data into the regression problem (see
:mod:`ltvmodels.estimators.recordings`) describes the data once: the names of
its signals by role, its time axis, how many trajectories it held and how many
of the data term's rows were missing. The model keeps that description as its
field ``data`` (statsmodels' ``model.data`` is the same idea); ``model.info``
keeps the solver's diagnostics. Model files keep it (format version 3).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

__all__ = ["ROLES", "DataTail", "DataDescription"]

ROLES = ("state", "input", "output", "regressor")
"""The roles a signal can have: states and inputs of a state-space model, outputs
and regressors of a regression (AR/ARX models: outputs and inputs)."""


@dataclass(frozen=True, eq=False)
class DataTail:
    """The end of a series: the last samples a model needs to continue it.

    A model's forecast from the end of its data (``model.forecast(steps=H,
    u=future)``) starts here. How many samples that takes is the model's
    ``tail_lengths`` (a, b): a state-space model needs the last state x[T−1]
    and the last input u[T−1] (it drives x[T]); an AR/ARX model the last na
    outputs and the last nk + nb − 1 inputs (those its regressors reach at the
    samples after the data).

    Attributes
    ----------
    outputs : ndarray, shape (a, n)
        The last a samples of the modelled signal (the states; an AR/ARX
        model's outputs), oldest first, finite.
    inputs : ndarray, shape (b, m)
        The last b inputs, oldest first, finite.
    """

    outputs: np.ndarray
    inputs: np.ndarray

    def __post_init__(self) -> None:
        for name in ("outputs", "inputs"):
            value = np.array(getattr(self, name), dtype=float)  # a copy: the caller's stays theirs
            if value.ndim != 2 or not np.all(np.isfinite(value)):
                raise ValueError(
                    f"{name}: expected the last samples of the data as a finite 2-d array "
                    f"(samples, signals), received {value.ndim}-d values"
                    + ("" if value.ndim != 2 else " with missing or infinite entries")
                )
            value.flags.writeable = False
            object.__setattr__(self, name, value)

    @classmethod
    def of(
        cls, outputs: np.ndarray, inputs: np.ndarray | None, lengths: tuple[int, int]
    ) -> DataTail | None:
        """The end of validated data: the last ``lengths`` = (a, b) samples of each.

        Parameters
        ----------
        outputs : ndarray, shape (R, T, n)
            The modelled signal of R trajectories (NaN = missing).
        inputs : ndarray, shape (R, T, m), or None without inputs
        lengths : (int, int)
            a and b, the model's ``tail_lengths``.

        Returns
        -------
        DataTail or None
            None when there is no one end to continue: several trajectories
            (R > 1), fewer than a or b samples, or a missing value among the
            samples kept.
        """
        a, b = lengths
        if inputs is None:
            inputs = np.zeros(outputs.shape[:2] + (0,))
        if outputs.shape[0] != 1 or outputs.shape[1] < max(a, b):
            return None
        last_outputs = outputs[0, outputs.shape[1] - a :]
        last_inputs = inputs[0, inputs.shape[1] - b :]
        if not (np.all(np.isfinite(last_outputs)) and np.all(np.isfinite(last_inputs))):
            return None
        return cls(last_outputs, last_inputs)

    def fits(self, lengths: tuple[int, int], n: int, m: int) -> bool:
        """Whether this is the end a model of ``tail_lengths`` (a, b), n outputs and m
        inputs continues: outputs (a, n) and inputs (b, m)."""
        a, b = lengths
        return self.outputs.shape == (a, n) and self.inputs.shape == (b, m)

    def __repr__(self) -> str:
        return f"DataTail(outputs={self.outputs.tolist()}, inputs={self.inputs.tolist()})"


@dataclass(frozen=True)
class DataDescription:
    """What the data said about a fit.

    Attributes
    ----------
    names : mapping of str to tuple of str
        The data's column names by role (:data:`ROLES`), for the roles whose data
        had names (pandas columns, the command line's columns); a role without an
        entry has the default names (x0, u0, y0, phi0, …).
    time : ndarray, shape (T,), or None
        The time of each sample of one series (a pandas index: dates as
        datetime64[ns], numbers, or time spans as seconds); None without a time
        index or for several trajectories.
    time_name : str or None
        The name of the time axis: the pandas index's name, or the time column's
        (``fit_many``'s ``time=``, the command line's ``--time``); None when it
        had none. Figures label their time axis with it.
    n_trajectories : int
        R, the number of time-aligned trajectories (series) the fit shared.
    n_missing : int
        Rows of the data term left out: transitions (state-space models) or
        regression rows (regressions, AR/ARX) with a missing value, summed over
        the trajectories.
    tail : DataTail or None
        The last samples of the data, where ``model.forecast(steps=H, u=future)``
        starts; None where there is no one end to continue (several
        trajectories, a missing value among those samples, a regression
        without dynamics, coefficients given rather than fitted, a model file
        written before models kept it).
    """

    names: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    time: np.ndarray | None = None
    n_trajectories: int = 1
    n_missing: int = 0
    time_name: str | None = None
    tail: DataTail | None = None

    @classmethod
    def of(
        cls,
        names: Mapping[str, Any] | None = None,
        time: np.ndarray | None = None,
        *,
        n_trajectories: int = 1,
        n_missing: int = 0,
        time_name: Any = None,
        tail: DataTail | None = None,
    ) -> DataDescription:
        """A description from names by role (lists, or None for a role without names)."""
        kept = {
            role: tuple(str(name) for name in values)
            for role, values in (names or {}).items()
            if values is not None and role in ROLES
        }
        return cls(
            kept,
            None if time is None else np.array(time),
            int(n_trajectories),
            int(n_missing),
            None if time is None or time_name is None else str(time_name),
            tail,
        )

    def renamed(
        self,
        names: Mapping[str, Any],
        time: np.ndarray | None = None,
        time_name: str | None = None,
    ) -> DataDescription:
        """This description with other names by role (and, if given, another time axis and
        its name)."""
        return DataDescription.of(
            names,
            self.time if time is None else time,
            n_trajectories=self.n_trajectories,
            n_missing=self.n_missing,
            time_name=self.time_name if time is None else time_name,
            tail=self.tail,
        )

    def with_tail(self, tail: DataTail | None) -> DataDescription:
        """This description with another end of the data (:attr:`tail`), e.g. the end
        of other data of the same length that a forecast should continue."""
        if tail is not None and not isinstance(tail, DataTail):
            raise TypeError(f"tail: expected a DataTail or None, received {type(tail).__name__}")
        return replace(self, tail=tail)

    def names_of(self, role: str, count: int) -> list[str] | None:
        """The recorded names of ``role`` when they name ``count`` signals, else None."""
        names = self.names.get(role)
        return list(names) if names is not None and len(names) == count else None

    # -- model files ---------------------------------------------------------------
    def to_json(self) -> dict:
        """Everything but the time axis and the tail, as JSON values (the file keeps those
        as arrays; ``time_name`` only where there is one, so that older readers see no new
        key)."""
        value: dict[str, Any] = {
            "names": {role: list(values) for role, values in self.names.items()},
            "n_trajectories": self.n_trajectories,
            "n_missing": self.n_missing,
        }
        if self.time_name is not None:
            value["time_name"] = self.time_name
        return value

    @classmethod
    def from_json(
        cls, value: Mapping[str, Any], time: np.ndarray | None, tail: DataTail | None = None
    ) -> DataDescription:
        """The description written by :meth:`to_json` (and its time axis and tail)."""
        return cls.of(
            value.get("names"),
            time,
            n_trajectories=value.get("n_trajectories", 1),
            n_missing=value.get("n_missing", 0),
            time_name=value.get("time_name"),
            tail=tail,
        )

    def __repr__(self) -> str:
        names = ", ".join(f"{role}={list(values)}" for role, values in self.names.items())
        time = "None" if self.time is None else f"array({self.time.dtype}, {self.time.size})"
        if self.time_name is not None:
            time += f", time_name={self.time_name!r}"
        tail = "" if self.tail is None else f", tail={self.tail!r}"
        return (
            f"DataDescription({names + ', ' if names else ''}time={time}, "
            f"n_trajectories={self.n_trajectories}, n_missing={self.n_missing}{tail})"
        )
