"""Kalman filter and smoother of the parameters, and their online form (paper Section IV-C).

The squared-difference problem of :func:`ltvmodels.fit` with a scalar λ is the
negative log posterior of a linear Gaussian state-space model for the
parameters (:mod:`ltvmodels.core.kalman` has the model, its realization and the
recursions). These front-ends validate the data, run the recursions and wrap
the results: :func:`kalman_filter` (k_{t|t}), :func:`kalman_smoother` (k_{t|N},
equal to ``fit``'s estimate) and :class:`OnlineParameterFilter` (one transition
at a time).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..core.kalman import (
    IDENTIFIED_TOL,
    ParameterStateSpace,
    filter_kernel,
    log_abs_det_transition,
    loglik_offset,
    realize,
    smoother_kernel,
    step,
)
from ..core.problem import RegressionProblem
from ..errors import SingularProblemError
from ..results.kalman import KalmanFilterResult, KalmanSmootherResult
from ..validation import arrays, options
from .recordings import state_space_data

__all__ = ["parameter_state_space", "kalman_filter", "kalman_smoother", "OnlineParameterFilter"]


def parameter_state_space(
    order: Any = 1, n_regressors: int = 1, *, lam: float, noise_var: float = 1.0
) -> ParameterStateSpace:
    """State-space realization of the penalty λ² Σ_t ‖(Dk)_t‖² (paper Proposition 1).

    Parameters
    ----------
    order : int or sequence of float
        Difference operator, as in :func:`ltvmodels.fit`.
    n_regressors : int
        p, the number of regressors (n + m for a state-space model).
    lam : float
        λ > 0.
    noise_var : float
        Measurement noise variance σ² > 0.

    Returns
    -------
    ParameterStateSpace
        Matrices for one output row; all rows share them.
    """
    coeffs = options.difference_coefficients(order)
    p = options.integer(n_regressors, "n_regressors", 1)
    lam = options.scalar_lam(lam)
    noise_var = options.variance(noise_var, "noise_var")
    return realize(coeffs, p, lam, noise_var)


@dataclass
class _Setup:
    """Validated data and options of one filter or smoother run."""

    problem: RegressionProblem  # y_t = x[t+1], φ_t = [x_t; u_t] (C-contiguous)
    model: ParameterStateSpace
    lam: float
    prior: tuple[np.ndarray, np.ndarray] | None


def _setup(x, u, lam, order, noise_var, init_mean, init_cov, regular=True) -> _Setup:
    lam = options.scalar_lam(lam)
    noise_var = options.variance(noise_var, "noise_var")
    problem = state_space_data(x, u, order=order, regular=regular).problem
    prior = arrays.initial_state_prior(init_mean, init_cov, problem.degree, problem.n, problem.p)
    return _Setup(
        problem=problem,
        model=realize(problem.coeffs, problem.p, lam, noise_var),
        lam=lam,
        prior=prior,
    )


def _run_filter(s: _Setup):
    model = s.model
    D = model.F.shape[0]
    diffuse = s.prior is None
    pb = s.problem
    m0, P0 = (np.zeros((D, pb.n)), np.eye(D)) if s.prior is None else s.prior
    return filter_kernel(
        pb.phi,
        pb.y,
        pb.observed,
        model.F,
        model.F_inv,
        model.q,
        model.R,
        log_abs_det_transition(model.coeffs, pb.p),
        diffuse,
        np.ascontiguousarray(m0),
        np.ascontiguousarray(P0),
        IDENTIFIED_TOL,
    )


def _filter_result(s: _Setup, vecs, mats, in_info, ell) -> KalmanFilterResult:
    N, p, n = s.problem.N, s.problem.p, s.problem.n
    k = vecs[:, :p, :].transpose(0, 2, 1).reshape(N, n * p).copy()
    cov = mats[:, :p, :p].copy()
    k[in_info] = np.nan
    cov[in_info] = np.nan
    identified = np.flatnonzero(~in_info)
    first = int(identified[0]) if identified.size else N
    offset = loglik_offset(s.model.coeffs, n, p, s.prior is None)
    loglik = None if in_info[-1] else float(ell.sum()) + offset
    return KalmanFilterResult(
        k=k,
        cov=cov,
        loglik=loglik,
        first_identified=first,
        noise_var=float(s.model.R),
        lam=s.lam,
        coeffs=s.model.coeffs.copy(),
        n_states=n,
    )


def kalman_filter(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
    lam: float,
    order: int | ArrayLike = 1,
    noise_var: float = 1.0,
    init_mean: ArrayLike | None = None,
    init_cov: float | ArrayLike | None = None,
    regular: bool = True,
) -> KalmanFilterResult:
    """Kalman filter for the parameters of x[t+1] = A_t x[t] + B_t u[t] + v_t.

    Computes k_{t|t} = E[k_t | x_0 … x_{t+1}, u_0 … u_t] and its covariance for
    the random-walk model of the module docstring (the paper's random-walk parameter model,
    with momentum for order 2, Proposition 1): y_t = x[t+1], φ_t = [x[t]; u[t]], process noise
    σ²/(λ² c_d²), measurement noise σ². With the default exact diffuse initialization k_{t|t}
    is the last time step of the minimizer of Σ_{s≤t} ‖y_s − Θ_s φ_s‖² +
    λ² Σ ‖(Dk)_s‖² on the data up to t (:func:`ltvmodels.fit` on x[:t+2]).

    Parameters
    ----------
    x : array_like, shape (T, n)
        States, time on axis 0 (lists and pandas DataFrames are accepted).
    u : array_like, shape (T, m) or (T,), optional
        Inputs.
    lam : float
        λ > 0 (scalar only).
    order : int or sequence of float
        Difference operator: 1 (random walk), 2 (a random walk with momentum), an integer d, or
        polynomial coefficients c_0 … c_d summing to zero.
    noise_var : float
        Measurement noise variance σ² > 0. The means do not depend on it (without
        a prior); covariances scale with it.
    init_mean : array_like, shape (d, K) or (K,) for d = 1, optional
        Prior mean of the initial state (k_0, k_{−1}, …, k_{−d+1}) (row j: k_{−j}).
        Default zero when ``init_cov`` is given.
    init_cov : float or array_like, shape (d·p, d·p), optional
        Prior covariance of one output row's initial state
        (θ_{0,i}, θ_{−1,i}, …); rows are independent with this covariance. None
        (default, with ``init_mean`` None): exact diffuse initialization.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    KalmanFilterResult
        ``k`` (N, K), ``cov`` (N, p, p), ``loglik``, ``first_identified``; N = T − 1.
        Entries before the state is identified are NaN.
    """
    s = _setup(x, u, lam, order, noise_var, init_mean, init_cov, regular)
    return _filter_result(s, *_run_filter(s))


def kalman_smoother(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
    lam: float,
    order: int | ArrayLike = 1,
    noise_var: float = 1.0,
    init_mean: ArrayLike | None = None,
    init_cov: float | ArrayLike | None = None,
    regular: bool = True,
) -> KalmanSmootherResult:
    """Rauch–Tung–Striebel smoother for the parameters of x[t+1] = A_t x[t] + B_t u[t] + v_t.

    Computes k_{t|N} = E[k_t | all data] and Cov(k_t | all data) for the model
    of :func:`kalman_filter`. With the default diffuse initialization the means
    are the exact minimizer of

        Σ_t ‖x_{t+1} − A_t x_t − B_t u_t‖² + λ² Σ_t ‖(Dk)_t‖²

    (the paper's slowly varying, smooth and general Kalman-model problems) and the covariances
    σ² [H⁻¹]_tt, the same numbers as ``ltvmodels.fit(x, u, lam=lam, order=order,
    noise_var=noise_var)``, computed in O(N (d·p)³) with one D × D covariance
    recursion (D = d·p) shared by the n output rows.

    Parameters
    ----------
    x, u, lam, order, noise_var, init_mean, init_cov
        As in :func:`kalman_filter`.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    KalmanSmootherResult
        ``k`` (N, K), ``cov`` (N, p, p), ``loglik``, ``filtered``.

    Raises
    ------
    SingularProblemError
        With the diffuse initialization, if the data never identify the state
        (too few or too poorly exciting samples).
    """
    s = _setup(x, u, lam, order, noise_var, init_mean, init_cov, regular)
    if s.prior is None:
        options.enough_samples(s.problem.N, s.problem.p, s.model.degree)
    vecs, mats, in_info, ell = _run_filter(s)
    filtered = _filter_result(s, vecs, mats, in_info, ell)
    if in_info[-1]:
        raise SingularProblemError(
            "the data do not identify the parameters: with a flat (diffuse) prior on the "
            f"initial state, the information matrix is still singular after all {s.problem.N} "
            "time steps. Remedies: more excitation in the inputs, a larger lam, a proper "
            "prior (init_mean, init_cov), or fewer regressors."
        )
    means, covs = smoother_kernel(
        vecs, mats, in_info, s.model.F, s.model.F_inv, s.problem.p, s.model.q
    )
    N, p, n = s.problem.N, s.problem.p, s.problem.n
    k = means.transpose(0, 2, 1).reshape(N, n * p)
    return KalmanSmootherResult(k=k, cov=covs, loglik=filtered.loglik, filtered=filtered)


class OnlineParameterFilter:
    """Recursive (online) estimation of A_t, B_t one transition at a time.

    Runs the same compiled step as :func:`kalman_filter`: after the t-th call of
    :meth:`update` the estimate equals ``kalman_filter(...)`` on the data seen so
    far, last time step.

    Parameters
    ----------
    n_states : int
        n, the dimension of x.
    n_inputs : int
        m, the dimension of u (0 for an autonomous system).
    lam : float
        λ > 0.
    order : int or sequence of float
        Difference operator, as in :func:`ltvmodels.fit`.
    noise_var : float
        Measurement noise variance σ² > 0.
    init_mean, init_cov : optional
        Proper prior on the initial state, as in :func:`kalman_filter`; by default
        the exact diffuse initialization (estimates are NaN until identified).

    Examples
    --------
    >>> f = OnlineParameterFilter(2, 1, lam=10.0)        # doctest: +SKIP
    >>> for t in range(T - 1):                            # doctest: +SKIP
    ...     k_t = f.update(x[t], u[t], x[t + 1])
    """

    def __init__(
        self,
        n_states: int,
        n_inputs: int = 0,
        *,
        lam: float,
        order: int | ArrayLike = 1,
        noise_var: float = 1.0,
        init_mean: ArrayLike | None = None,
        init_cov: float | ArrayLike | None = None,
    ) -> None:
        self.n_states = options.integer(n_states, "n_states", 1)
        self.n_inputs = options.integer(n_inputs, "n_inputs", 0)
        p = self.n_states + self.n_inputs
        coeffs = options.difference_coefficients(order)
        self.lam = options.scalar_lam(lam)
        noise_var = options.variance(noise_var, "noise_var")
        self.model = realize(coeffs, p, self.lam, noise_var)
        d = self.model.degree
        prior = arrays.initial_state_prior(init_mean, init_cov, d, self.n_states, p)
        self._log_abs_det_F = log_abs_det_transition(coeffs, p)
        self._loglik_offset = loglik_offset(coeffs, self.n_states, p, prior is None)
        D = d * p
        self._F_invT = np.ascontiguousarray(self.model.F_inv.T)
        self._info = prior is None
        if prior is None:
            self._mat, self._vec = np.zeros((D, D)), np.zeros((D, self.n_states))
        else:
            self._vec, self._mat = (np.ascontiguousarray(a) for a in prior)
        self._ell = np.zeros(self.n_states)
        self._t = 0

    @property
    def n_updates(self) -> int:
        """Number of transitions processed."""
        return self._t

    @property
    def identified(self) -> bool:
        """True once the data (or the prior) determine the current parameters."""
        return self._t > 0 and not self._info

    @property
    def k(self) -> np.ndarray:
        """(K,) current estimate k_{t|t}; NaN until identified."""
        p = self.model.G.shape[1]
        if not self.identified:
            return np.full(self.n_states * p, np.nan)
        return self._vec[:p].T.ravel().copy()

    @property
    def cov(self) -> np.ndarray:
        """(p, p) covariance of each row of [A_t B_t] (shared, σ² included).

        NaN until identified.
        """
        p = self.model.G.shape[1]
        if not self.identified:
            return np.full((p, p), np.nan)
        return self._mat[:p, :p].copy()

    @property
    def A(self) -> np.ndarray:
        """(n, n) current estimate of A_t."""
        return self.k.reshape(self.n_states, -1)[:, : self.n_states]

    @property
    def B(self) -> np.ndarray:
        """(n, m) current estimate of B_t."""
        return self.k.reshape(self.n_states, -1)[:, self.n_states :]

    @property
    def loglik(self) -> float | None:
        """Log-likelihood of the transitions seen so far (None until identified)."""
        if not self.identified:
            return None
        return float(self._ell.sum()) + self._loglik_offset

    def update(self, x_t: ArrayLike, u_t: ArrayLike | None, x_next: ArrayLike) -> np.ndarray:
        """Process one transition x_next = A_t x_t + B_t u_t + v_t.

        Parameters
        ----------
        x_t : array_like, shape (n,)
        u_t : array_like, shape (m,), or None when m = 0
        x_next : array_like, shape (n,)
            A NaN anywhere marks the transition missing: the estimate is only
            predicted forward one step.

        Returns
        -------
        ndarray, shape (K,)
            The filtered estimate k_{t|t} (NaN until identified).
        """
        n, m = self.n_states, self.n_inputs
        x_t = arrays.vector(x_t, "x_t", n, missing=True)
        x_next = arrays.vector(x_next, "x_next", n, missing=True)
        u_t = np.zeros(0) if u_t is None and m == 0 else arrays.vector(u_t, "u_t", m, missing=True)
        for value, name in ((x_t, "x_t"), (u_t, "u_t"), (x_next, "x_next")):
            arrays.representable(value, name, small=False)  # one sample: tiny values are fine
        phi = np.concatenate([x_t, u_t])
        observed = np.array([np.all(np.isfinite(phi)) and np.all(np.isfinite(x_next))])
        if not observed[0]:  # a missing sample: predict only
            phi, x_next = np.zeros_like(phi), np.zeros_like(x_next)
        model = self.model
        self._mat, self._vec, self._info = step(
            self._mat,
            self._vec,
            self._ell,
            self._info,
            self._t > 0,
            phi[None],
            x_next[None],
            observed,
            model.F,
            model.F_inv,
            self._F_invT,
            model.q,
            model.R,
            self._log_abs_det_F,
            IDENTIFIED_TOL,
        )
        self._t += 1
        return self.k
