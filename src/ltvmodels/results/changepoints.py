"""Change points that know where they lie on the data's axis.

A model's change point c is a model step: the model changes between steps
c − 1 and c, the index :func:`ltvmodels.fit_piecewise` and
:attr:`ltvmodels.RegressionModel.changepoints` use. The data's axis is another
one: step c produces x[c + 1] in a state-space model, y[c] in a regression and
y[lag + c] in an AR/ARX model (:attr:`~ltvmodels.RegressionModel.produced_offset`).
:class:`Changepoints` carries both, so that a change found in an AR(2) model at
step 148 is also reported at sample 150 of the series, and at its time.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Changepoints"]


class Changepoints(np.ndarray):
    """Change points c of a model: an int64 array (M,) of model steps that also knows
    their samples and times on the data's axis.

    The array itself holds the model steps c, as :func:`ltvmodels.find_changepoints`
    always returned them (pass it to :func:`ltvmodels.fit_piecewise`, index with it,
    compare it), so that code written for a plain array keeps working; arithmetic on
    it gives plain arrays (other numbers are not change points). The convention
    of the data's axis is that of :attr:`ltvmodels.RegressionModel.changepoint_times`:
    a change point lies at the first observation produced under the new
    coefficients.

    Attributes
    ----------
    changepoints : ndarray of int64, shape (M,)
        The model steps c (a plain array): the model changes between steps c − 1
        and c.
    sample_indices : ndarray of int64, shape (M,)
        The index on the data's axis (0-based sample of the series) of the first
        observation produced under the new coefficients: c + ``produced_offset``,
        i.e. x[c + 1] of a state-space model, y[c] of a regression, y[lag + c] of
        an AR/ARX model.
    times : ndarray, shape (M,), or None
        The times of those samples (the model's time axis: dates as
        datetime64[ns], or numbers); None when the model has no time axis.
    produced_offset : int
        The offset from a model step to the sample it produces.

    Parameters
    ----------
    steps : array_like of int, shape (M,)
        The model steps c.
    produced_offset : int, default 0
        The model's :attr:`~ltvmodels.RegressionModel.produced_offset`.
    time : ndarray, shape (T,), optional
        The model's time axis (one time per sample of the data).
    """

    _produced_offset: int
    _time: np.ndarray | None

    def __new__(
        cls, steps: ArrayLike, produced_offset: int = 0, time: np.ndarray | None = None
    ) -> Changepoints:
        values = np.asarray(steps)
        if values.ndim != 1 or not (values.size == 0 or np.issubdtype(values.dtype, np.integer)):
            raise ValueError(
                f"steps: expected a 1-d array of integer model steps, received shape "
                f"{values.shape} and dtype {values.dtype}"
            )
        changepoints = values.astype(np.int64).view(cls)
        changepoints._produced_offset = int(produced_offset)
        changepoints._time = None if time is None else np.asarray(time)
        return changepoints

    @classmethod
    def of_model(cls, steps: ArrayLike, model: Any) -> Changepoints:
        """The change points ``steps`` of ``model`` (a :class:`~ltvmodels.RegressionModel`
        or a subclass), placed on its data's axis."""
        return cls(steps, model.produced_offset, model.time)

    def __array_finalize__(self, obj: Any) -> None:
        # A view or a slice of change points lies on the same axis.
        self._produced_offset = getattr(obj, "_produced_offset", 0)
        self._time = getattr(obj, "_time", None)

    def __array_ufunc__(self, ufunc: Any, method: str, *inputs: Any, **kwargs: Any) -> Any:
        # c + 1 or c == 3 are numbers, not change points: computed on plain arrays.
        def plain(values: Any) -> Any:
            return values.view(np.ndarray) if isinstance(values, Changepoints) else values

        if "out" in kwargs:
            kwargs["out"] = tuple(plain(out) for out in kwargs["out"])
        return getattr(ufunc, method)(*(plain(value) for value in inputs), **kwargs)

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickled with the axis (an ndarray subclass otherwise loses its attributes).
        return (Changepoints, (self.changepoints, self._produced_offset, self._time))

    @property
    def changepoints(self) -> np.ndarray:
        """(M,) the model steps c, as a plain int64 array."""
        return np.array(self.view(np.ndarray))

    @property
    def produced_offset(self) -> int:
        """The offset from a model step to the sample it produces."""
        return self._produced_offset

    @property
    def sample_indices(self) -> np.ndarray:
        """(M,) the samples of the first observations under the new coefficients."""
        return self.changepoints + self._produced_offset

    @property
    def times(self) -> np.ndarray | None:
        """(M,) the times of :attr:`sample_indices`, or None without a time axis."""
        return None if self._time is None else self._time[self.sample_indices]

    def __repr__(self) -> str:
        text = f"Changepoints({self.changepoints.tolist()}, sample_indices="
        text += f"{self.sample_indices.tolist()}"
        times = self.times
        if times is not None:
            text += f", times={[str(value) for value in times]}"
        return text + ")"
