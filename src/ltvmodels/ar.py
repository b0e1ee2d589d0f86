"""Time-varying AR and ARX models and the root spectrogram.

An ARX model with time-varying coefficients (VARX for vector y)

    y[t] = Σ_{i=1}^{na} A_{t,i} y[t−i] + Σ_{j=1}^{nb} B_{t,j} u[t−nk−j+1] + c_t + e[t],

y[t] ∈ R^n, u[t] ∈ R^m, is the regression y_t = Θ_t φ_t + e_t (DESIGN §1) with

    φ_t = [y[t−1]; …; y[t−na]; u[t−nk]; …; u[t−nk−nb+1]; 1],
    Θ_t = [A_{t,1} … A_{t,na}  B_{t,1} … B_{t,nb}  c_t]      (n × p),

p = n·na + m·nb (+ 1 with the constant term c_t). The rows of Θ_t share φ_t,
so every norm ("sq", "group", "l1") is solved by the same solvers as
:func:`ltvmodels.fit`; the regression starts at the first sample whose lags
all exist, t = L = max(na, nk + nb − 1), and has N = T − L rows: model index
j describes y[L + j] (``model.sample_index``).

* :func:`fit_ar`, :func:`fit_arx` — identify the model (:class:`ARModel`,
  :class:`ARXModel`);
* :func:`ar_regressors`, :func:`arx_regressors` — the (y, φ) pair, e.g. for
  :func:`ltvmodels.segments.segment_regression` (exact L0 segmentation) or
  :func:`ltvmodels.fit_regression`;
* :meth:`ARXModel.root_spectrogram` — frequencies of the poles of 1/A_t(z),
  A_t(z) = I − Σ_i A_{t,i} z^{−i}, over time: a parametric time–frequency
  picture;
* :func:`chirp` — the two-component test chirp of the reference implementation.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import numba
import numpy as np

from . import _validate
from .fit import _fit_problem
from .models import RegressionModel
from .problem import RegressionProblem
from .solvers.squared import CovarianceBlocks

__all__ = [
    "ARModel",
    "ARXModel",
    "ar_regressors",
    "arx_regressors",
    "fit_ar",
    "fit_arx",
    "chirp",
]


def _lag(na: int, nb: int, nk: int) -> int:
    """L: how far the regressors reach back (the first regression row is y[L])."""
    return max(na, nk + nb - 1 if nb else 0)


def _structure_text(na: int, nb: int, nk: int) -> str:
    return f"na = {na}" if nb == 0 else f"na = {na}, nb = {nb}, nk = {nk}"


def _build(
    y: np.ndarray, u: np.ndarray, na: int, nb: int, nk: int, constant: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(y[L:], φ) for validated y (T, n), u (T, m); φ has the column order of the module."""
    T = y.shape[0]
    L = _lag(na, nb, nk)
    N = T - L
    cols = [y[L - i : T - i] for i in range(1, na + 1)]
    cols += [u[L - nk - j : T - nk - j] for j in range(nb)]
    if constant:
        cols.append(np.ones((N, 1)))
    phi = np.hstack(cols) if cols else np.zeros((N, 0))
    return y[L:].copy(), np.ascontiguousarray(phi)


def _names(n: int, m: int, na: int, nb: int, nk: int, constant: bool) -> list[str]:
    """Regressor names for messages: y[t-1], y0[t-1], u[t-1], …, 1."""
    ys = [""] if n == 1 else [str(i) for i in range(n)]
    us = [""] if m == 1 else [str(i) for i in range(m)]
    names = [f"y{i}[t-{lag}]" for lag in range(1, na + 1) for i in ys]
    names += [f"u{i}[t-{nk + j}]" if nk + j else f"u{i}[t]" for j in range(nb) for i in us]
    return names + (["1"] if constant else [])


def arx_regressors(
    y: Any, u: Any, na: int, nb: int, nk: int = 1, *, constant: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The regression (y_t, φ_t) of a (V)ARX model.

    Parameters
    ----------
    y : array_like, shape (T, n) or (T,)
        Outputs, time on axis 0.
    u : array_like, shape (T, m) or (T,)
        Inputs.
    na : int >= 0
        Number of output lags.
    nb : int >= 1
        Number of input lags.
    nk : int >= 0
        Input delay: the newest input in φ_t is u[t − nk].
    constant : bool
        Append a constant regressor 1 (a time-varying offset c_t).

    Returns
    -------
    y_out : ndarray, shape (N, n)
        y[L:], N = T − L, L = max(na, nk + nb − 1).
    phi : ndarray, shape (N, p)
        Rows φ_t = [y[t−1]; …; y[t−na]; u[t−nk]; …; u[t−nk−nb+1]; 1],
        p = n·na + m·nb (+ 1).

    Examples
    --------
    Exact L0 segmentation of an ARX model (paper eq:l0):

    >>> import numpy as np, ltvmodels as ltv
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(300); y = np.zeros(300)
    >>> for t in range(1, 300):
    ...     a = 0.9 if t < 150 else 0.3
    ...     y[t] = a * y[t - 1] + u[t - 1] + 0.01 * rng.standard_normal()
    >>> y_out, phi = ltv.arx_regressors(y, u, na=1, nb=1)
    >>> ltv.segments.segment_regression(y_out, phi, n_changes=1).changepoints.tolist()
    [149]
    """
    na, nb, nk = _validate.lag_orders(na, nb, nk, min_na=0, min_nb=1)
    constant = _validate.flag(constant, "constant")
    y, u = _validate.lagged_series(
        y, u, _lag(na, nb, nk), _structure_text(na, nb, nk), require_inputs=True
    )
    return _build(y, u, na, nb, nk, constant)


def ar_regressors(y: Any, na: int, *, constant: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The regression (y_t, φ_t) of a (V)AR(na) model: y[na:] and [y[t−1]; …; y[t−na] (; 1)].

    Parameters
    ----------
    y : array_like, shape (T, n) or (T,)
        The series, time on axis 0.
    na : int >= 1
        Model order.
    constant : bool
        Append a constant regressor 1.

    Returns
    -------
    y_out : ndarray, shape (T − na, n)
    phi : ndarray, shape (T − na, n·na (+ 1))
    """
    na, _, _ = _validate.lag_orders(na, 0, 1, min_na=1, min_nb=0)
    constant = _validate.flag(constant, "constant")
    y, u = _validate.lagged_series(y, None, na, _structure_text(na, 0, 1))
    return _build(y, u, na, 0, 1, constant)


# -- fitting ---------------------------------------------------------------------------


def fit_arx(
    y: Any,
    u: Any,
    na: int,
    nb: int,
    nk: int = 1,
    *,
    lam: Any,
    norm: str = "sq",
    order: Any = 1,
    constant: bool = False,
    prior: Any = None,
    prior_mode: str = "exact",
    noise_var: float | None = None,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
) -> ARXModel:
    """Identify a time-varying (V)ARX model.

    y[t] = Σ_{i=1}^{na} A_{t,i} y[t−i] + Σ_{j=1}^{nb} B_{t,j} u[t−nk−j+1] (+ c_t) + e[t]:
    the regression of :func:`arx_regressors` solved by
    :func:`ltvmodels.fit_regression`. With ``norm="sq"`` the exact minimizer of

        Σ_{t=L}^{T−1} ‖y[t] − Θ_t φ_t‖² + λ² Σ_t ‖(Dk)_t‖²,   k_t = Θ_t.ravel(),

    and with ``norm="group"`` / ``"l1"`` the penalty λ Σ_t ‖(Dk)_t‖₂ / ‖(Dk)_t‖₁
    (piecewise constant or linear coefficients), as in :func:`ltvmodels.fit`.

    Parameters
    ----------
    y : array_like, shape (T, n) or (T,)
        Outputs, time on axis 0 (lists and pandas objects are accepted).
    u : array_like, shape (T, m) or (T,)
        Inputs.
    na : int >= 0
        Number of output lags (0: a time-varying FIR model).
    nb : int >= 1
        Number of input lags.
    nk : int >= 0, default 1
        Input delay (0: direct feedthrough of u[t]).
    lam, norm, order, prior, prior_mode, noise_var, compute_cov, max_iter, tol
        As in :func:`ltvmodels.fit`, with K = n·p parameters per time step,
        p = n·na + m·nb (+ 1).
    constant : bool, default False
        Include a time-varying constant term c_t.

    Returns
    -------
    ARXModel
        N = T − L time steps, L = max(na, nk + nb − 1); ``a``, ``b``, ``c``,
        ``predict``, ``simulate``, ``root_spectrogram``, and everything of a
        :class:`~ltvmodels.RegressionModel` (``theta``, ``cov``, ``loglik``, ...).

    Raises
    ------
    ValueError, TypeError
        Invalid input: na < 0, nb < 1, nk < 0, a series not longer than the
        lag structure, inputs of the wrong length, too few samples for the
        number of parameters, and the errors of :func:`ltvmodels.fit`.
    SingularProblemError
        The data do not identify the model (e.g. an input that is not exciting).
    """
    na, nb, nk = _validate.lag_orders(na, nb, nk, min_na=0, min_nb=1)
    constant = _validate.flag(constant, "constant")
    L = _lag(na, nb, nk)
    y, u = _validate.lagged_series(y, u, L, _structure_text(na, nb, nk), require_inputs=True)
    n, m = y.shape[1], u.shape[1]
    factory = partial(ARXModel, n_outputs=n, n_inputs=m, na=na, nb=nb, nk=nk, constant=constant)
    return _fit_lagged(y, u, na, nb, nk, constant, factory, lam=lam, norm=norm, order=order,
                       prior=prior, prior_mode=prior_mode, noise_var=noise_var,
                       compute_cov=compute_cov, max_iter=max_iter, tol=tol)


def fit_ar(
    y: Any,
    na: int,
    *,
    lam: Any,
    norm: str = "sq",
    order: Any = 1,
    constant: bool = False,
    prior: Any = None,
    prior_mode: str = "exact",
    noise_var: float | None = None,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
) -> ARModel:
    """Identify a time-varying (V)AR(na) model y[t] = Σ_{i=1}^{na} A_{t,i} y[t−i] (+ c_t) + e[t].

    The regression of :func:`ar_regressors`, solved as in :func:`fit_arx`
    (objective Σ_{t=na}^{T−1} ‖y[t] − Θ_t φ_t‖² + R(DΘ) with the penalty R of
    ``norm``). For a scalar series :meth:`ARModel.root_spectrogram` gives the
    resonance frequencies over time.

    Parameters
    ----------
    y : array_like, shape (T, n) or (T,)
        The series, time on axis 0.
    na : int >= 1
        Model order.
    lam, norm, order, prior, prior_mode, noise_var, compute_cov, max_iter, tol
        As in :func:`ltvmodels.fit`, with K = n·p, p = n·na (+ 1).
    constant : bool, default False
        Include a time-varying constant term c_t.

    Returns
    -------
    ARModel
        N = T − na time steps (model index j describes y[na + j]).

    Raises
    ------
    ValueError, TypeError
        na < 1, T <= na, too few samples for the number of parameters, and the
        errors of :func:`ltvmodels.fit`.

    Examples
    --------
    >>> import numpy as np, ltvmodels as ltv
    >>> fs, T = 1000.0, 2000
    >>> t = np.arange(T) / fs
    >>> rng = np.random.default_rng(0)
    >>> y = np.sin(2 * np.pi * 100 * t) + 0.01 * rng.standard_normal(T)
    >>> model = ltv.fit_ar(y, na=2, lam=100.0)
    >>> model.root_spectrogram(fs).shape
    (1998, 1)
    >>> bool(abs(np.median(model.root_spectrogram(fs)) - 100.0) < 1.0)
    True
    """
    na, _, _ = _validate.lag_orders(na, 0, 1, min_na=1, min_nb=0)
    constant = _validate.flag(constant, "constant")
    y, u = _validate.lagged_series(y, None, na, _structure_text(na, 0, 1))
    factory = partial(ARModel, n_outputs=y.shape[1], na=na, constant=constant)
    return _fit_lagged(y, u, na, 0, 1, constant, factory, lam=lam, norm=norm, order=order,
                       prior=prior, prior_mode=prior_mode, noise_var=noise_var,
                       compute_cov=compute_cov, max_iter=max_iter, tol=tol)


def _fit_lagged(
    y: np.ndarray,
    u: np.ndarray,
    na: int,
    nb: int,
    nk: int,
    constant: bool,
    factory: Any,
    *,
    lam: Any,
    norm: Any,
    order: Any,
    prior: Any,
    prior_mode: Any,
    noise_var: Any,
    compute_cov: Any,
    max_iter: Any,
    tol: Any,
) -> ARXModel:
    """Build the regression of validated AR/ARX data and run the shared core."""
    norm = _validate.norm_name(norm)
    y_out, phi = _build(y, u, na, nb, nk, constant)
    coeffs = _validate.difference_coefficients(order, max_degree=y_out.shape[0])
    L = _lag(na, nb, nk)
    return _fit_problem(
        RegressionProblem(y=y_out, phi=phi, coeffs=coeffs),
        factory=factory,
        regressor_names=_names(y.shape[1], u.shape[1], na, nb, nk, constant),
        data_name="y",
        rows_note=f" (T = {y.shape[0]} samples, the first {L} only as lags)",
        lam=lam, norm=norm, prior=prior, prior_mode=prior_mode, noise_var=noise_var,
        compute_cov=compute_cov, max_iter=max_iter, tol=tol,
    )


# -- models ----------------------------------------------------------------------------


@numba.njit(cache=True)
def _simulate_arx(theta, y, u, noise, na, nb, nk, lag, constant):  # pragma: no cover
    """y[lag + t] = Θ_t φ_t + noise[t] for t = 0 … N − 1, in place on y (T, n)."""
    N, n, _ = theta.shape
    m = u.shape[1]
    for t in range(N):
        s = lag + t
        for i in range(n):
            acc = noise[t, i]
            col = 0
            for i_lag in range(1, na + 1):
                for j in range(n):
                    acc += theta[t, i, col] * y[s - i_lag, j]
                    col += 1
            for j_lag in range(nb):
                for j in range(m):
                    acc += theta[t, i, col] * u[s - nk - j_lag, j]
                    col += 1
            if constant:
                acc += theta[t, i, col]
            y[s, i] = acc
    return y


class ARXModel(RegressionModel):
    """An identified time-varying (V)ARX model (see :mod:`ltvmodels.ar`).

    Model index j = 0 … N − 1 describes y[L + j] (``sample_index``),
    L = max(na, nk + nb − 1). For a scalar output (n = 1) the coefficient
    arrays and predictions drop the output axis.

    Attributes
    ----------
    na, nb, nk : int
        Orders and input delay.
    constant : bool
        Whether the model has a constant term c_t.
    n_inputs : int
        m, the number of inputs.
    theta : ndarray, shape (N, n, p)
        [A_{t,1} … A_{t,na}  B_{t,1} … B_{t,nb}  c_t].

    All attributes of :class:`~ltvmodels.RegressionModel` (``k``, ``cov``,
    ``noise_var``, ``loglik``, ``info``, ``save``, ...) are available.
    """

    def __init__(
        self,
        k: np.ndarray,
        n_outputs: int,
        n_inputs: int,
        na: int,
        nb: int,
        nk: int,
        constant: bool,
        *,
        norm: str,
        coeffs: np.ndarray | None,
        lam: Any,
        cov: CovarianceBlocks | None = None,
        noise_var: float = float("nan"),
        noise_cov: np.ndarray | None = None,
        loglik: float = float("nan"),
        info: dict | None = None,
        changepoints: np.ndarray | None = None,
    ) -> None:
        self.n_inputs = int(n_inputs)
        self.na, self.nb, self.nk = int(na), int(nb), int(nk)
        self.constant = bool(constant)
        p = int(n_outputs) * self.na + self.n_inputs * self.nb + int(self.constant)
        super().__init__(
            k, n_outputs, p, norm=norm, coeffs=coeffs, lam=lam, cov=cov, noise_var=noise_var,
            noise_cov=noise_cov, loglik=loglik, info=info, changepoints=changepoints,
        )

    # -- structure --------------------------------------------------------------------
    @property
    def lag(self) -> int:
        """L = max(na, nk + nb − 1): the number of initial samples used only as lags."""
        return _lag(self.na, self.nb, self.nk)

    @property
    def sample_index(self) -> np.ndarray:
        """(N,) the sample t of y[t] that model index j describes: t = L + j."""
        return np.arange(self.lag, self.lag + self.N)

    def _squeeze(self, arr: np.ndarray) -> np.ndarray:
        return arr[:, 0] if self.n_outputs == 1 else arr

    @property
    def a(self) -> np.ndarray:
        """Output-lag coefficients [A_{t,1} … A_{t,na}]: (N, n, n·na), or (N, na) for n = 1.

        ``a[t, i, (l − 1)·n + j]`` multiplies y_j[t − l] in output i.
        """
        return self._squeeze(self.theta[:, :, : self.n_outputs * self.na])

    @property
    def b(self) -> np.ndarray:
        """Input-lag coefficients [B_{t,1} … B_{t,nb}]: (N, n, m·nb), or (N, m·nb) for n = 1.

        ``b[t, i, l·m + j]`` multiplies u_j[t − nk − l] in output i, l = 0 … nb − 1.
        """
        start = self.n_outputs * self.na
        return self._squeeze(self.theta[:, :, start : start + self.n_inputs * self.nb])

    @property
    def c(self) -> np.ndarray | None:
        """Constant term c_t: (N, n), or (N,) for n = 1; None without a constant."""
        if not self.constant:
            return None
        return self._squeeze(self.theta[:, :, -1])

    # -- poles ------------------------------------------------------------------------
    def poles(self) -> np.ndarray:
        """Poles of 1/A_t(z), A_t(z) = I − Σ_i A_{t,i} z^{−i}, over time.

        The eigenvalues of the (n·na × n·na) companion matrix of each A_t
        (the roots of z^na − Σ_i a_{t,i} z^{na−i} for scalar y), computed for
        all t in one batched eigenvalue call.

        Returns
        -------
        ndarray of complex, shape (N, n·na)
            Sorted by angle in (−π, π] at each t.
        """
        n, na, N = self.n_outputs, self.na, self.N
        D = n * na
        if D == 0:
            return np.zeros((N, 0), dtype=complex)
        companion = np.zeros((N, D, D))
        companion[:, :n, :] = self.theta[:, :, :D]
        companion[:, n:, : D - n] = np.eye(D - n)
        poles = np.linalg.eigvals(companion)
        return np.take_along_axis(poles, np.argsort(np.angle(poles), axis=1), axis=1)

    def root_spectrogram(self, fs: float) -> np.ndarray:
        """Frequencies of the poles of 1/A_t(z) over time (a parametric spectrogram).

        One frequency per complex-conjugate pair of poles, f = angle(z)·fs/(2π)
        for the pole z with Im z > 0, sorted increasing at each t. Real poles
        (at 0 or fs/2) are not resonances and give no frequency: slots left
        over when poles are real are NaN (at the end of the row). Poles close
        to the unit circle are sharp spectral peaks; see :meth:`poles` for the
        radii.

        Parameters
        ----------
        fs : float
            Sampling frequency; the result is in its units (Hz for fs in Hz).

        Returns
        -------
        ndarray, shape (N, (n·na) // 2)
            Row j belongs to sample ``sample_index[j]`` (time sample_index[j] / fs).
        """
        fs = _validate.positive_scalar(fs, "fs")
        poles = self.poles()
        freq = np.where(poles.imag > 0, np.angle(poles) * (fs / (2 * np.pi)), np.nan)
        return np.sort(freq, axis=1)[:, : poles.shape[1] // 2]  # NaNs sort last

    # -- use --------------------------------------------------------------------------
    def predict(self, y: Any, u: Any = None) -> np.ndarray:
        """One-step predictions ŷ[t] = Θ_t φ_t from measured data, t = L … T − 1.

        Parameters
        ----------
        y : array_like, shape (T, n) or (T,), T = N + L
            Measured outputs (as fitted, or new data of the same length).
        u : array_like, shape (T, m) or (T,); None for an AR model.

        Returns
        -------
        ndarray, shape (N, n), or (N,) for n = 1
            Predictions of y[L:].
        """
        y, u = _validate.model_series(y, u, N=self.N, n=self.n_outputs, m=self.n_inputs,
                                      lag=self.lag)
        _, phi = _build(y, u, self.na, self.nb, self.nk, self.constant)
        return self._squeeze(np.einsum("tij,tj->ti", self.theta, phi))

    def simulate(self, y0: Any, u: Any = None, noise: Any = None) -> np.ndarray:
        """Simulate the model from initial samples: y[t] = Θ_t φ_t + noise[t − L].

        Parameters
        ----------
        y0 : array_like, shape (L, n) or (L,) for n = 1
            The initial samples y[0:L] (None when L = 0).
        u : array_like, shape (T, m) or (T,), T = N + L; None for an AR model.
        noise : array_like, shape (N, n) or (N,) for n = 1, optional
            e[t] added at t = L … T − 1 (e.g. seeded white noise to simulate the
            stochastic process); default zero (the noise-free response).

        Returns
        -------
        ndarray, shape (T, n), or (T,) for n = 1
            y[0:L] = y0, then the simulated samples.
        """
        y0, u, noise = _validate.simulation_inputs(
            y0, u, noise, N=self.N, n=self.n_outputs, m=self.n_inputs, lag=self.lag
        )
        y = np.zeros((self.N + self.lag, self.n_outputs))
        y[: self.lag] = y0
        _simulate_arx(np.ascontiguousarray(self.theta), y, u, noise, self.na, self.nb, self.nk,
                      self.lag, self.constant)
        return y[:, 0] if self.n_outputs == 1 else y

    def plot(self, fs: float, ax: Any = None):
        """Plot the root spectrogram; see :func:`ltvmodels.plotting.plot_root_spectrogram`."""
        from .plotting import plot_root_spectrogram

        return plot_root_spectrogram(self, fs, ax=ax)

    # -- persistence and display ------------------------------------------------------
    def _structure(self) -> dict:
        return {"n_outputs": self.n_outputs, "n_inputs": self.n_inputs, "na": self.na,
                "nb": self.nb, "nk": self.nk, "constant": self.constant}

    @classmethod
    def _from_structure(cls, k: np.ndarray, structure: dict, **common: Any) -> ARXModel:
        s = structure
        return cls(k, s["n_outputs"], s["n_inputs"], s["na"], s["nb"], s["nk"], s["constant"],
                   **common)

    def _repr_sizes(self) -> str:
        return (f"n_outputs={self.n_outputs}, n_inputs={self.n_inputs}, na={self.na}, "
                f"nb={self.nb}, nk={self.nk}, constant={self.constant}")


class ARModel(ARXModel):
    """An identified time-varying (V)AR model: an :class:`ARXModel` without inputs.

    ``predict(y)``, ``simulate(y0, noise=None)`` and ``root_spectrogram(fs)``
    → (N, (n·na) // 2) are those of :class:`ARXModel`; ``b`` is empty.
    """

    def __init__(
        self,
        k: np.ndarray,
        n_outputs: int,
        na: int,
        constant: bool,
        *,
        norm: str,
        coeffs: np.ndarray | None,
        lam: Any,
        cov: CovarianceBlocks | None = None,
        noise_var: float = float("nan"),
        noise_cov: np.ndarray | None = None,
        loglik: float = float("nan"),
        info: dict | None = None,
        changepoints: np.ndarray | None = None,
    ) -> None:
        super().__init__(
            k, n_outputs, 0, na, 0, 1, constant, norm=norm, coeffs=coeffs, lam=lam, cov=cov,
            noise_var=noise_var, noise_cov=noise_cov, loglik=loglik, info=info,
            changepoints=changepoints,
        )

    def predict(self, y: Any) -> np.ndarray:
        """One-step predictions ŷ[t] = Σ_i A_{t,i} y[t−i] (+ c_t), t = na … T − 1.

        Parameters
        ----------
        y : array_like, shape (T, n) or (T,), T = N + na

        Returns
        -------
        ndarray, shape (N, n), or (N,) for n = 1
        """
        return super().predict(y, None)

    def simulate(self, y0: Any, noise: Any = None) -> np.ndarray:
        """Simulate y[t] = Σ_i A_{t,i} y[t−i] (+ c_t) + noise[t − na] from y[0:na] = y0.

        Parameters
        ----------
        y0 : array_like, shape (na, n) or (na,) for n = 1
        noise : array_like, shape (N, n) or (N,) for n = 1, optional
            Default zero (the free response).

        Returns
        -------
        ndarray, shape (N + na, n), or (N + na,) for n = 1
        """
        return super().simulate(y0, None, noise)

    def _structure(self) -> dict:
        return {"n_outputs": self.n_outputs, "na": self.na, "constant": self.constant}

    @classmethod
    def _from_structure(cls, k: np.ndarray, structure: dict, **common: Any) -> ARModel:
        s = structure
        return cls(k, s["n_outputs"], s["na"], s["constant"], **common)

    def _repr_sizes(self) -> str:
        return f"n_outputs={self.n_outputs}, na={self.na}, constant={self.constant}"


# -- test signal -----------------------------------------------------------------------


def chirp(T: int = 2**14, fs: float = 16000.0, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The two-component chirp of the reference implementation's root-spectrogram example.

        y[j] = sin(2π f₁[j] t_j) + sin(2π f₂[j] t_j) + e[j],   t_j = j / fs,  e[j] ~ N(0, 0.01²),

    with f₁ rising linearly from 2000 to 2500 Hz over the record (so the
    instantaneous frequency d/dt (f₁(t) t) of the first component rises from
    2000 to 3000 Hz) and f₂[j] = 5000 + 200 sin(2π j / T) Hz. With the
    defaults (fs = 16 kHz, T = 2¹⁴) both components lie below fs/2.

    Parameters
    ----------
    T : int, default 2**14
        Number of samples, >= 2.
    fs : float, default 16000.0
        Sampling frequency (Hz).
    seed : int, default 0
        Seed of the measurement noise e (>= 0).

    Returns
    -------
    y : ndarray, shape (T,)
        The signal.
    inst_freq : ndarray, shape (T,)
        Instantaneous frequency of the first component (Hz),
        2000 + 1000 j / (T − 1).

    Examples
    --------
    >>> import ltvmodels as ltv
    >>> y, inst = ltv.ar.chirp(2**12, seed=0)
    >>> y.shape, float(inst[0]), float(inst[-1])
    ((4096,), 2000.0, 3000.0)
    """
    T = _validate.integer(T, "T", minimum=2)
    fs = _validate.positive_scalar(fs, "fs")
    seed = _validate.integer(seed, "seed", minimum=0)
    rng = np.random.default_rng(seed)
    n = np.arange(T)
    t = n / fs
    f1 = np.linspace(2000.0, 2500.0, T)
    f2 = 5000.0 + 200.0 * np.sin(2 * np.pi * n / T)
    y = np.sin(2 * np.pi * f1 * t) + np.sin(2 * np.pi * f2 * t) + 0.01 * rng.standard_normal(T)
    return y, 2000.0 + 1000.0 * n / (T - 1)
