"""Result objects: a time-varying regression y_t = Θ_t φ_t + e_t and the LTV model.

:class:`RegressionModel` is the general result (:func:`ltvmodels.fit_regression`);
:class:`LTVModel` is the state-space case x[t+1] = A_t x[t] + B_t u[t] + v_t
(:func:`ltvmodels.fit`). The AR/ARX models are in :mod:`ltvmodels.ar`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numba
import numpy as np

from . import _validate
from .problem import apply_difference
from .solvers.squared import CovarianceBlocks

FORMAT_VERSION = 1


@numba.njit(cache=True)
def _simulate(A, B, x0, u):  # pragma: no cover - compiled
    """x[t+1] = A_t x[t] + B_t u[t] from x[0] = x0; returns (N + 1, n)."""
    N, n, _ = A.shape
    m = B.shape[2]
    x = np.empty((N + 1, n))
    x[0] = x0
    for t in range(N):
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += A[t, i, j] * x[t, j]
            for j in range(m):
                acc += B[t, i, j] * u[t, j]
            x[t + 1, i] = acc
    return x


class RegressionModel:
    """An identified time-varying regression y_t = Θ_t φ_t + e_t.

    The general result of :func:`ltvmodels.fit_regression`, and the base class
    of :class:`LTVModel` (φ_t = [x_t; u_t]) and the AR/ARX models of
    :mod:`ltvmodels.ar`. Model index t = 0 … N − 1 is row t of the regression.
    The parameter vector is ``k[t] = theta[t].ravel()`` (rows of Θ_t
    concatenated).

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Parameter vectors, K = n·p.
    theta : ndarray, shape (N, n, p)
        Coefficient matrices Θ_t.
    cov : ndarray or None
        Posterior covariance of k_t: shape (N, p, p) when the output rows are
        independent with a shared covariance (then Cov(k_t) = I_n ⊗ cov[t]),
        otherwise (N, K, K). None if not computed. :meth:`cov_full` always
        returns (N, K, K); :meth:`std` (N, K).
    noise_var : float
        Noise variance σ² of the isotropic model (estimated or given).
    noise_cov : ndarray, shape (n, n)
        Noise covariance estimate.
    loglik : float
        Log (marginal) likelihood of the data under the model's probabilistic
        interpretation (see :func:`ltvmodels.fit`).
    info : dict
        Solver details: objective, solver name, factorizations, and so on.
    """

    _types: dict[str, type] = {}  # class name → class, for :func:`load`

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        RegressionModel._types[cls.__name__] = cls

    def __init__(
        self,
        k: np.ndarray,
        n_outputs: int,
        n_regressors: int,
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
        self._k = np.array(k, dtype=float)
        self._n_outputs = int(n_outputs)
        self._n_regressors = int(n_regressors)
        if self._k.ndim != 2 or self._k.shape[1] != self._n_outputs * self._n_regressors:
            raise ValueError(
                f"k: expected shape (N, {self._n_outputs * self._n_regressors}) for "
                f"{self._n_outputs} outputs and {self._n_regressors} regressors, received "
                f"{self._k.shape}"
            )
        self.norm = norm
        self.coeffs = None if coeffs is None else np.asarray(coeffs, dtype=float)
        self.lam = lam
        self._cov = cov
        self.noise_var = float(noise_var)
        n = self._n_outputs
        self.noise_cov = np.full((n, n), np.nan) if noise_cov is None else noise_cov
        self.loglik = float(loglik)
        self.info = {} if info is None else dict(info)
        self._changepoints = changepoints

    # -- shapes -------------------------------------------------------------------
    @property
    def N(self) -> int:
        """Number of model time steps (regression rows)."""
        return self._k.shape[0]

    @property
    def K(self) -> int:
        return self._k.shape[1]

    @property
    def n_outputs(self) -> int:
        """n, the number of outputs (rows of Θ_t)."""
        return self._n_outputs

    @property
    def n_regressors(self) -> int:
        """p, the number of regressors (columns of Θ_t)."""
        return self._n_regressors

    @property
    def k(self) -> np.ndarray:
        """(N, K) parameter vectors (read-only view)."""
        view = self._k.view()
        view.flags.writeable = False
        return view

    @property
    def theta(self) -> np.ndarray:
        """(N, n, p) coefficient matrices Θ_t (read-only view)."""
        return self.k.reshape(self.N, self.n_outputs, self.n_regressors)

    @property
    def order(self) -> np.ndarray | None:
        """Difference-operator coefficients c_0 … c_d of the penalty."""
        return self.coeffs

    # -- uncertainty --------------------------------------------------------------
    @property
    def cov(self) -> np.ndarray | None:
        """Posterior covariance of k_t: (N, p, p) if shared by rows, else (N, K, K)."""
        if self._cov is None:
            return None
        c = self._cov
        if c.row_group is not None and c.blocks.shape[0] == 1:
            return c.blocks[0]
        return self.cov_full()

    @property
    def cov_shared_by_rows(self) -> bool:
        """True when :attr:`cov` is the compact (N, p, p) form."""
        c = self._cov
        return c is not None and c.row_group is not None and c.blocks.shape[0] == 1

    def cov_full(self) -> np.ndarray | None:
        """Posterior covariance of k_t as an (N, K, K) array (O(N K²) memory)."""
        if self._cov is None:
            return None
        return self._cov.full(self.n_outputs, self.n_regressors)

    def std(self) -> np.ndarray | None:
        """(N, K) posterior standard deviations of the entries of k_t."""
        c = self._cov
        if c is None:
            return None
        if c.row_group is None:
            var = np.diagonal(c.blocks, axis1=1, axis2=2)
        else:
            per_group = np.diagonal(c.blocks, axis1=2, axis2=3)  # (G, N, p)
            var = np.concatenate([per_group[g] for g in c.row_group], axis=1)
        return np.sqrt(np.maximum(var, 0.0))

    # -- use ----------------------------------------------------------------------
    def predict(self, phi: Any) -> np.ndarray:
        """Predictions ŷ_t = Θ_t φ_t of the regression.

        Parameters
        ----------
        phi : array_like, shape (N, p), or (N,) when p = 1
            Regressors, one row per model time step.

        Returns
        -------
        ndarray, shape (N, n)
        """
        phi = _validate.regressor_rows(phi, self.N, self.n_regressors)
        return np.einsum("tij,tj->ti", self.theta, phi)

    def activation(self) -> np.ndarray:
        """‖(Dk)_t‖₂ for t = 0 … N − d − 1: how much the model changes (paper III-G).

        Uses the model's difference operator (first difference for LTI models).
        """
        coeffs = self.coeffs if self.coeffs is not None else np.array([-1.0, 1.0])
        return model_activation(self._k, coeffs)

    @property
    def changepoints(self) -> np.ndarray:
        """Indices c with k_c ≠ k_{c−1} (relative change above 1e-8 of the scale of k)."""
        if self._changepoints is not None:
            return self._changepoints
        step = np.linalg.norm(np.diff(self._k, axis=0), axis=1)
        scale = max(float(np.abs(self._k).max(initial=0.0)), 1e-300)
        return np.flatnonzero(step > 1e-8 * scale) + 1

    # -- persistence --------------------------------------------------------------
    def _structure(self) -> dict:
        """JSON-serializable sizes that, with k, rebuild the model (see :func:`load`)."""
        return {"n_outputs": self.n_outputs, "n_regressors": self.n_regressors}

    @classmethod
    def _from_structure(cls, k: np.ndarray, structure: dict, **common: Any) -> RegressionModel:
        return cls(k, structure["n_outputs"], structure["n_regressors"], **common)

    def save(self, path: str | Path) -> None:
        """Save to a NumPy ``.npz`` archive (lossless; :func:`ltvmodels.load` reads it)."""
        arrays: dict[str, np.ndarray] = {"k": self._k, "noise_cov": self.noise_cov}
        if self.coeffs is not None:
            arrays["coeffs"] = self.coeffs
        arrays["lam"] = np.asarray(self.lam, dtype=float)
        if self._cov is not None:
            arrays["cov_blocks"] = self._cov.blocks
            if self._cov.row_group is not None:
                arrays["cov_row_group"] = self._cov.row_group
        if self._changepoints is not None:
            arrays["changepoints"] = self._changepoints
        info_json, info_arrays = _split_info(self.info)
        arrays.update({f"info__{key}": value for key, value in info_arrays.items()})
        meta = {
            "format_version": FORMAT_VERSION,
            "model_type": type(self).__name__,
            **self._structure(),
            "norm": self.norm,
            "noise_var": self.noise_var,
            "loglik": self.loglik,
            "info": info_json,
        }
        arrays["meta"] = np.array(json.dumps(meta))
        with open(path, "wb") as fh:
            np.savez(fh, **arrays)

    # -- display ------------------------------------------------------------------
    def _repr_sizes(self) -> str:
        return f"n_outputs={self.n_outputs}, n_regressors={self.n_regressors}"

    def __repr__(self) -> str:
        lam = self.lam
        lam_text = f"{float(lam):g}" if np.ndim(lam) == 0 else f"array{np.shape(lam)}"
        order = "-" if self.coeffs is None else _order_text(self.coeffs)
        return (
            f"{type(self).__name__}(N={self.N}, {self._repr_sizes()}, "
            f"norm={self.norm!r}, order={order}, lam={lam_text}, "
            f"noise_var={self.noise_var:.4g}, loglik={self.loglik:.6g})"
        )

    def summary(self) -> str:
        """Human-readable multi-line summary."""
        lines = [repr(self)]
        keys = ("solver", "objective", "n_factorizations", "noise_var_estimated", "prior_mode")
        for key in keys:
            if key in self.info:
                lines.append(f"  {key}: {self.info[key]}")
        act = self.activation()
        if act.size:
            lines.append(f"  activation ‖Dk‖: max {act.max():.3g} at t={int(act.argmax())}, "
                         f"median {np.median(act):.3g}")
        return "\n".join(lines)


RegressionModel._types["RegressionModel"] = RegressionModel


class LTVModel(RegressionModel):
    """An identified linear time-varying model.

    Model index t maps (x[t], u[t]) to x[t+1], t = 0 … N-1 (N = T − 1 for T
    samples of data). The parameter vector is ``k[t] = np.hstack([A[t], B[t]]).ravel()``.
    It is the :class:`RegressionModel` with y_t = x_{t+1} and φ_t = [x_t; u_t].

    Attributes
    ----------
    k : ndarray, shape (N, K)
        Parameter vectors, K = n·(n + m).
    A : ndarray, shape (N, n, n)
    B : ndarray, shape (N, n, m)
    cov : ndarray or None
        Posterior covariance of k_t: shape (N, p, p) with p = n + m when the
        output rows are independent with a shared covariance (then
        Cov(k_t) = I_n ⊗ cov[t]), otherwise (N, K, K). None if not computed.
        :meth:`cov_full` always returns (N, K, K); :meth:`std` (N, K).
    noise_var : float
        Noise variance σ² of the isotropic model (estimated or given).
    noise_cov : ndarray, shape (n, n)
        Noise covariance estimate.
    loglik : float
        Log (marginal) likelihood of the data under the model's probabilistic
        interpretation (see :func:`ltvmodels.fit`).
    info : dict
        Solver details: objective, solver name, factorizations, and so on.
    """

    def __init__(
        self,
        k: np.ndarray,
        n_states: int,
        n_inputs: int,
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
            k, n_states, int(n_states) + int(n_inputs), norm=norm, coeffs=coeffs, lam=lam,
            cov=cov, noise_var=noise_var, noise_cov=noise_cov, loglik=loglik, info=info,
            changepoints=changepoints,
        )
        self.n_states = int(n_states)
        self.n_inputs = int(n_inputs)

    # -- shapes -------------------------------------------------------------------
    @property
    def A(self) -> np.ndarray:
        """(N, n, n) state matrices."""
        return self.theta[:, :, : self.n_states]

    @property
    def B(self) -> np.ndarray:
        """(N, n, m) input matrices."""
        return self.theta[:, :, self.n_states :]

    # -- use ----------------------------------------------------------------------
    def _check_length(self, T: int, name: str) -> None:
        if T != self.N + 1:
            raise ValueError(
                f"{name}: expected T = {self.N + 1} time steps (the model has N = {self.N} "
                f"transitions), received {T}"
            )

    def predict(self, x: Any, u: Any = None) -> np.ndarray:
        """One-step predictions x̂[t+1] = A_t x[t] + B_t u[t].

        Parameters
        ----------
        x : array_like, shape (T, n), T = N + 1
        u : array_like, shape (T, m) or (T,), or None when m = 0

        Returns
        -------
        ndarray, shape (T − 1, n)
            Predictions of x[1:].
        """
        x, u = self._data(x, u)
        self._check_length(x.shape[0], "x")
        phi = np.hstack([x[:-1], u[:-1]])
        return np.einsum("tij,tj->ti", self.theta, phi)

    def simulate(self, x0: Any, u: Any = None) -> np.ndarray:
        """Open-loop simulation from x0.

        Parameters
        ----------
        x0 : array_like, shape (n,)
        u : array_like, shape (T, m), (T,) or (N, m) — T = N + 1 (the last
            input is unused) — or None when the model has no inputs.

        Returns
        -------
        ndarray, shape (T, n)
        """
        x0 = _validate.as_float_array(x0, "x0").ravel()
        if x0.shape != (self.n_states,):
            raise ValueError(f"x0: expected shape ({self.n_states},), received {x0.shape}")
        if u is None:
            if self.n_inputs:
                raise ValueError(f"u: the model has {self.n_inputs} inputs, received None")
            u = np.zeros((self.N, 0))
        else:
            u = _validate.as_time_series(u, "u")
            if u.shape[1] != self.n_inputs:
                raise ValueError(f"u: expected {self.n_inputs} columns, received {u.shape[1]}")
            if u.shape[0] not in (self.N, self.N + 1):
                raise ValueError(
                    f"u: expected {self.N + 1} (or {self.N}) rows, received {u.shape[0]}"
                )
        return _simulate(
            np.ascontiguousarray(self.A), np.ascontiguousarray(self.B), x0,
            np.ascontiguousarray(u[: self.N]),
        )

    def _data(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        x, u = _validate.state_and_input(x, u)
        if x.shape[1] != self.n_states:
            raise ValueError(f"x: expected {self.n_states} columns, received {x.shape[1]}")
        if u.shape[1] != self.n_inputs:
            raise ValueError(f"u: expected {self.n_inputs} columns, received {u.shape[1]}")
        return x, u

    # -- persistence --------------------------------------------------------------
    def _structure(self) -> dict:
        return {"n_states": self.n_states, "n_inputs": self.n_inputs}

    @classmethod
    def _from_structure(cls, k: np.ndarray, structure: dict, **common: Any) -> LTVModel:
        return cls(k, structure["n_states"], structure["n_inputs"], **common)

    # -- display ------------------------------------------------------------------
    def _repr_sizes(self) -> str:
        return f"n_states={self.n_states}, n_inputs={self.n_inputs}"

    def plot(self, truth: Any = None, *, bands: bool = True, fig: Any = None):
        """Plot the coefficients of [A_t B_t] over time.

        See :func:`ltvmodels.plotting.plot_coefficients`; returns the Figure.
        """
        from .plotting import plot_coefficients

        return plot_coefficients(self, truth=truth, bands=bands, fig=fig)


def model_activation(k: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    """a_t = ‖(Dk)_t‖₂ for t = 0 … N − d − 1 (paper Section III-G)."""
    return np.linalg.norm(apply_difference(k, coeffs), axis=1)


def _order_text(coeffs: np.ndarray) -> str:
    d = len(coeffs) - 1
    standard = np.array([1.0])
    for _ in range(d):
        standard = np.convolve(standard, [-1.0, 1.0])
    return str(d) if np.array_equal(coeffs, standard) else str(coeffs.tolist())


def _split_info(info: dict) -> tuple[dict, dict]:
    """Separate arrays (saved as npz members) from JSON-serializable values."""
    plain, arrays = {}, {}
    for key, value in info.items():
        if isinstance(value, np.ndarray):
            arrays[key] = value
        elif isinstance(value, np.generic):
            plain[key] = value.item()
        else:
            plain[key] = value
    json.dumps(plain)  # fail early (TypeError) on values that cannot be stored
    return plain, arrays


def load(path: str | Path) -> RegressionModel:
    """Load a model written by :meth:`RegressionModel.save` (any model of this package).

    Returns an instance of the class that was saved (:class:`LTVModel`,
    :class:`RegressionModel`, :class:`ltvmodels.ARModel`, ...).
    """
    with np.load(path, allow_pickle=False) as data:
        files = set(data.files)
        if "meta" not in files or "k" not in files:
            raise ValueError(f"path: {path} is not an ltvmodels model file (no 'meta'/'k' entries)")
        meta = json.loads(str(data["meta"]))
        if meta.get("format_version") != FORMAT_VERSION:
            raise ValueError(
                f"path: unsupported model file version {meta.get('format_version')} "
                f"(this ltvmodels reads version {FORMAT_VERSION})"
            )
        model_type = meta.get("model_type", "LTVModel")  # files written before model types
        cls = RegressionModel._types.get(model_type)
        if cls is None:
            raise ValueError(
                f"path: {path} holds a model of unknown type {model_type!r} (known: "
                f"{sorted(RegressionModel._types)})"
            )
        cov = None
        if "cov_blocks" in files:
            row_group = data["cov_row_group"] if "cov_row_group" in files else None
            cov = CovarianceBlocks(data["cov_blocks"], row_group)
        info = dict(meta["info"])
        info.update({key[len("info__"):]: data[key] for key in files if key.startswith("info__")})
        lam = data["lam"]
        return cls._from_structure(
            data["k"],
            meta,
            norm=meta["norm"],
            coeffs=data["coeffs"] if "coeffs" in files else None,
            lam=float(lam) if lam.ndim == 0 else lam,
            cov=cov,
            noise_var=meta["noise_var"],
            noise_cov=data["noise_cov"],
            loglik=meta["loglik"],
            info=info,
            changepoints=data["changepoints"] if "changepoints" in files else None,
        )
