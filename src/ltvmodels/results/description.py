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
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["ROLES", "DataDescription"]

ROLES = ("state", "input", "output", "regressor")
"""The roles a signal can have: states and inputs of a state-space model, outputs
and regressors of a regression (AR/ARX models: outputs and inputs)."""


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
    n_trajectories : int
        R, the number of time-aligned trajectories (series) the fit shared.
    n_missing : int
        Rows of the data term left out: transitions (state-space models) or
        regression rows (regressions, AR/ARX) with a missing value, summed over
        the trajectories.
    """

    names: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    time: np.ndarray | None = None
    n_trajectories: int = 1
    n_missing: int = 0

    @classmethod
    def of(
        cls,
        names: Mapping[str, Any] | None = None,
        time: np.ndarray | None = None,
        *,
        n_trajectories: int = 1,
        n_missing: int = 0,
    ) -> DataDescription:
        """A description from names by role (lists, or None for a role without names)."""
        kept = {
            role: tuple(str(name) for name in values)
            for role, values in (names or {}).items()
            if values is not None and role in ROLES
        }
        return cls(
            kept, None if time is None else np.array(time), int(n_trajectories), int(n_missing)
        )

    def renamed(self, names: Mapping[str, Any], time: np.ndarray | None = None) -> DataDescription:
        """This description with other names by role (and, if given, another time axis)."""
        return DataDescription.of(
            names,
            self.time if time is None else time,
            n_trajectories=self.n_trajectories,
            n_missing=self.n_missing,
        )

    def names_of(self, role: str, count: int) -> list[str] | None:
        """The recorded names of ``role`` when they name ``count`` signals, else None."""
        names = self.names.get(role)
        return list(names) if names is not None and len(names) == count else None

    # -- model files ---------------------------------------------------------------
    def to_json(self) -> dict:
        """Everything but the time axis, as JSON values (the file keeps ``time`` as an array)."""
        return {
            "names": {role: list(values) for role, values in self.names.items()},
            "n_trajectories": self.n_trajectories,
            "n_missing": self.n_missing,
        }

    @classmethod
    def from_json(cls, value: Mapping[str, Any], time: np.ndarray | None) -> DataDescription:
        """The description written by :meth:`to_json` (and its time axis)."""
        return cls.of(
            value.get("names"),
            time,
            n_trajectories=value.get("n_trajectories", 1),
            n_missing=value.get("n_missing", 0),
        )

    def __repr__(self) -> str:
        names = ", ".join(f"{role}={list(values)}" for role, values in self.names.items())
        time = "None" if self.time is None else f"array({self.time.dtype}, {self.time.size})"
        return (
            f"DataDescription({names + ', ' if names else ''}time={time}, "
            f"n_trajectories={self.n_trajectories}, n_missing={self.n_missing})"
        )
