"""One base for everything that has time-varying [A_t B_t]: sizes and names.

Identified models (:class:`~ltvmodels.LTVModel`), the Kalman results, simulated
systems (:class:`~ltvmodels.systems.SimulatedData`) and the dynamics of
:mod:`ltvmodels.control` all describe

    x[t+1] = A_t x[t] + B_t u[t] (+ …),   t = 0 … N − 1,

and derive their sizes from ``A`` (N, n, n) and ``B`` (N, n, m). (The stacked
coefficients [A_t B_t] are stored by some and derived by others, so each class
provides them in its own way.)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

__all__ = ["LinearTimeVarying", "signal_names"]


class LinearTimeVarying:
    """Sizes and signal names of x[t+1] = A_t x[t] + B_t u[t].

    A mixin: a subclass provides ``A`` of shape (N, n, n) and ``B`` of shape
    (N, n, m), as attributes or properties; everything here is derived from
    them.
    """

    if TYPE_CHECKING:  # read-only here: a subclass may provide them as properties

        @property
        def A(self) -> np.ndarray: ...

        @property
        def B(self) -> np.ndarray: ...

    @property
    def N(self) -> int:
        """Number of time steps (transitions)."""
        return self.A.shape[0]

    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[1]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.B.shape[2]

    @property
    def K(self) -> int:
        """Number of parameters per time step, n·(n + m)."""
        return self.n * (self.n + self.m)

    @property
    def produced_offset(self) -> int:
        """Step t maps x[t] to x[t + 1]: it produces the sample t + 1 (figures draw step t
        there, as change points are timed)."""
        return 1

    @property
    def state_names(self) -> list[str]:
        """Names of the states: the data's column names where it had them (a pandas
        DataFrame, recorded in ``data.names``), else ``["x0", "x1", …]``."""
        return _recorded_names(self, "state", self.n) or signal_names("x", self.n)

    @property
    def input_names(self) -> list[str]:
        """Names of the inputs: the data's column names, else ``["u0", "u1", …]``."""
        return _recorded_names(self, "input", self.m) or signal_names("u", self.m)


def _recorded_names(obj: object, key: str, count: int) -> list[str] | None:
    """The names of ``key`` in ``obj.data`` (a fitted model's :class:`DataDescription`)
    when they name ``count`` signals, else None."""
    data = getattr(obj, "data", None)
    return data.names_of(key, count) if data is not None else None


def signal_names(prefix: str, count: int) -> list[str]:
    """Default names of ``count`` signals: ``prefix`` followed by 0, 1, …"""
    return [f"{prefix}{i}" for i in range(count)]
