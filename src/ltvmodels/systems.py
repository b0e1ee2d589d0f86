"""Seeded example systems and test signals (the paper's examples).

The systems (:func:`jump_linear`, :func:`random_walk_system`) return a
:class:`SimulatedData`: the recorded states and inputs together with the true
coefficients, in the conventions of
:func:`ltvmodels.fit` — time on axis 0, N = T − 1 model steps, and model index
t maps (x[t], u[t]) to x[t+1]::

    x_true[t+1] = A[t] @ x_true[t] + B[t] @ u[t] + w[t],   w[t] ~ N(0, noise_std² I)
    x[t]        = x_true[t] + e[t],                        e[t] ~ N(0, measurement_std² I)

All randomness comes from one :func:`numpy.random.default_rng` generator
created from ``seed``, so equal arguments give identical data. :func:`chirp` is
the test signal of the root spectrogram (a time-varying AR model's poles).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from numbers import Integral
from typing import Any

import numpy as np

from .core.simulation import simulate_affine
from .results.base import LinearTimeVarying
from .validation import options

__all__ = ["SimulatedData", "jump_linear", "random_walk_system", "chirp"]

JUMP_LINEAR_A1 = np.array([[0.95, 0.1], [0.0, 0.95]])
"""State matrix of the jump-linear system before the change (paper Section VI)."""
JUMP_LINEAR_A2 = np.array([[0.5, 0.05], [0.0, 0.5]])
"""State matrix of the jump-linear system after the change (paper Section VI)."""
JUMP_LINEAR_B = np.array([[0.2], [1.0]])
"""Input matrix of the jump-linear system (constant, paper Section VI)."""


@dataclass(frozen=True)
class SimulatedData(LinearTimeVarying):
    """Data simulated from a known LTV system, with the true coefficients.

    Attributes
    ----------
    x : ndarray, shape (T, n)
        Recorded states (including measurement noise, if any). Pass to
        :func:`ltvmodels.fit`.
    u : ndarray, shape (T, m)
        Inputs (m may be 0: then pass ``u=None`` to :func:`ltvmodels.fit`).
    A : ndarray, shape (N, n, n)
        True state matrices; ``A[t]`` maps x[t] to x[t+1], N = T − 1.
    B : ndarray, shape (N, n, m)
        True input matrices.
    x_true : ndarray, shape (T, n)
        States before measurement noise (equal to ``x`` when there is none).
    noise_std : float
        Standard deviation of the process (state-transition) noise w[t].
    measurement_std : float
        Standard deviation of the measurement noise e[t] added to ``x``.
    changepoints : ndarray of int or None
        Indices c with k_c ≠ k_{c−1} (as :attr:`ltvmodels.LTVModel.changepoints`)
        for piecewise-constant systems; None when the coefficients change at
        every step.
    name : str
        Short description of the system.
    """

    x: np.ndarray
    u: np.ndarray
    A: np.ndarray
    B: np.ndarray
    x_true: np.ndarray
    noise_std: float
    measurement_std: float
    changepoints: np.ndarray | None = None
    name: str = field(default="")

    @property
    def T(self) -> int:
        """Number of samples."""
        return self.x.shape[0]

    @property
    def theta(self) -> np.ndarray:
        """(N, n, n + m) true coefficient matrices [A_t B_t] (a new array)."""
        return np.concatenate([self.A, self.B], axis=2)

    @property
    def k(self) -> np.ndarray:
        """(N, K) true parameter vectors k_t = ``np.hstack([A[t], B[t]]).ravel()`` (a new array)."""
        return self.theta.reshape(self.N, self.K)

    def __repr__(self) -> str:
        return (
            f"SimulatedData({self.name!r}, T={self.T}, n={self.n}, m={self.m}, "
            f"noise_std={self.noise_std:g}, measurement_std={self.measurement_std:g})"
        )


# -- argument checks ---------------------------------------------------------------
def _int_arg(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise TypeError(
            f"{name}: expected an integer >= {minimum}, received {value!r} ({type(value).__name__})"
        )
    if value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, received {value}")
    return int(value)


def _finish(
    rng: np.random.Generator,
    A: np.ndarray,
    B: np.ndarray,
    noise_std: float,
    measurement_std: float,
    changepoints: np.ndarray | None,
    name: str,
) -> SimulatedData:
    """Draw inputs and noise (in this order), simulate, and add measurement noise."""
    N, n, m = A.shape[0], A.shape[1], B.shape[2]
    T = N + 1
    u = rng.standard_normal((T, m))
    w = rng.standard_normal((N, n))
    w *= noise_std
    x_true = simulate_affine(np.ascontiguousarray(A), np.ascontiguousarray(B), w, np.zeros(n), u)
    if measurement_std > 0:
        e = rng.standard_normal((T, n))
        e *= measurement_std
        x = x_true + e
    else:
        x = x_true.copy()
    return SimulatedData(
        x=x,
        u=u,
        A=A,
        B=B,
        x_true=x_true,
        noise_std=noise_std,
        measurement_std=measurement_std,
        changepoints=changepoints,
        name=name,
    )


# -- the paper's examples ------------------------------------------------------------
def jump_linear(
    T: int = 400,
    change_at: int = 200,
    noise_std: float = 0.2,
    seed: int | np.random.Generator | None = 0,
    *,
    measurement_std: float | None = None,
) -> SimulatedData:
    """The jump-linear system of the paper (Section VI, "Example – Jump-linear system").

    Two states, one input. The state matrix switches from
    ``[[0.95, 0.1], [0, 0.95]]`` to ``[[0.5, 0.05], [0, 0.5]]`` at ``change_at``;
    ``B = [0.2, 1]ᵀ`` throughout::

        x_true[t+1] = A_t x_true[t] + B u[t] + w[t],   x_true[0] = 0,
        x[t]        = x_true[t] + e[t],

    with ``A_t`` the first matrix for ``t < change_at`` and the second for
    ``t >= change_at`` (model index t maps (x[t], u[t]) to x[t+1], so k_t
    changes first at t = ``change_at``). Inputs u[t] ~ N(0, 1); process noise
    w[t] ~ N(0, noise_std² I); measurement noise e[t] ~ N(0,
    measurement_std² I) is added to the *recorded* states ``x`` (so ``x``
    is noisy both as regressor and as target), as in the paper.

    Parameters
    ----------
    T : int, default 400
        Number of samples (T >= 2); the model has N = T − 1 steps.
    change_at : int, default 200
        First model index with the second dynamics, 0 <= change_at <= T − 1
        (0: second dynamics throughout; T − 1: first dynamics throughout).
    noise_std : float, default 0.2
        Standard deviation of the process noise (>= 0).
    seed : int, numpy.random.Generator or None, default 0
        Seed of the random generator; equal seeds give identical data.
    measurement_std : float, optional
        Standard deviation of the measurement noise (>= 0); defaults to
        ``noise_std`` (σ = 0.2 for both, as in the paper).

    Returns
    -------
    SimulatedData
        ``x`` (T, 2), ``u`` (T, 1), ``A`` (N, 2, 2), ``B`` (N, 2, 1),
        ``k`` (N, 6) and ``changepoints = [change_at]`` (empty if the switch
        falls outside 1 … N − 1).

    Examples
    --------
    >>> from ltvmodels import systems
    >>> data = systems.jump_linear()
    >>> data.x.shape, data.u.shape, data.A.shape
    ((400, 2), (400, 1), (399, 2, 2))
    >>> float(data.A[199, 0, 0]), float(data.A[200, 0, 0])
    (0.95, 0.5)
    """
    T = _int_arg(T, "T", 2)
    change_at = _int_arg(change_at, "change_at", 0)
    if change_at > T - 1:
        raise ValueError(
            f"change_at: expected an integer in [0, T - 1] = [0, {T - 1}], received {change_at}"
        )
    noise_std = options.nonnegative_scalar(noise_std, "noise_std")
    measurement_std = (
        noise_std
        if measurement_std is None
        else options.nonnegative_scalar(measurement_std, "measurement_std")
    )
    rng = options.random_generator(seed)
    N = T - 1
    A = np.empty((N, 2, 2))
    A[:change_at] = JUMP_LINEAR_A1
    A[change_at:] = JUMP_LINEAR_A2
    B = np.broadcast_to(JUMP_LINEAR_B, (N, 2, 1)).copy()
    changepoints = np.array([change_at]) if 0 < change_at < N else np.zeros(0, dtype=int)
    return _finish(
        rng,
        A,
        B,
        noise_std,
        measurement_std,
        changepoints,
        name=f"jump-linear (change at t={change_at})",
    )


def random_walk_system(
    T: int = 1000,
    n: int = 3,
    m: int = 2,
    drift_std: float = 1e-3,
    noise_std: float = 0.1,
    seed: int | np.random.Generator | None = 0,
    *,
    measurement_std: float = 0.0,
    max_norm: float = 0.95,
) -> SimulatedData:
    """An LTV system whose coefficients follow a Gaussian random walk, kept stable.

    This is the generative model behind ``norm="sq", order=1`` (paper eq.
    dynsys) and the system of the benchmarks. Construction:

    1. Start: ``A_0`` is a standard Gaussian n×n matrix scaled to Frobenius
       norm 0.6; ``B_0`` has standard Gaussian entries.
    2. Walk: k_{t+1} = k_t + s_t with s_t ~ N(0, drift_std² I) for all
       K = n(n + m) entries of [A_t B_t] (a vectorized cumulative sum).
    3. Stability: wherever ‖A_t‖_F exceeds ``max_norm`` (< 1), A_t is scaled
       down to Frobenius norm ``max_norm``. Since the spectral norm is at most
       the Frobenius norm, every A_t is then a contraction,
       ‖A_t x‖ <= max_norm ‖x‖, so the time-varying system is uniformly
       exponentially stable (a spectral radius < 1 of each A_t alone would not
       guarantee that). While the bound is inactive, A_t is exactly the random
       walk; B_t is never modified (it does not affect stability, and its
       entries wander with standard deviation drift_std·√t). For long
       series (drift_std·√T of order 0.3 or more, e.g. T >= 10⁵ with the
       default drift_std) A_t spends most of the time on the bound.

    Then ``x_true[0] = 0``, ``x_true[t+1] = A_t x_true[t] + B_t u[t] + w[t]``
    with u[t] ~ N(0, I_m), w[t] ~ N(0, noise_std² I_n), computed by a
    compiled loop (T = 10⁶ with n = 3, m = 2 takes well under a second), and
    ``x = x_true + e`` with e[t] ~ N(0, measurement_std² I_n).

    Parameters
    ----------
    T : int, default 1000
        Number of samples (T >= 2); N = T − 1 model steps.
    n : int, default 3
        Number of states (>= 1).
    m : int, default 2
        Number of inputs (>= 0; with m = 0, ``u`` has shape (T, 0)).
    drift_std : float, default 1e-3
        Standard deviation of the random-walk steps of each coefficient (>= 0;
        0 gives an LTI system). Over T steps the walk moves by about
        ``drift_std``·√T; choose e.g. 0.01 for visible variation at T ≈ 1000.
    noise_std : float, default 0.1
        Standard deviation of the process noise (>= 0).
    seed : int, numpy.random.Generator or None, default 0
        Seed of the random generator; equal seeds give identical data.
    measurement_std : float, default 0
        Standard deviation of measurement noise added to ``x`` (>= 0).
    max_norm : float, default 0.95
        Upper bound on ‖A_t‖_F, in (0, 1).

    Returns
    -------
    SimulatedData
        ``x`` (T, n), ``u`` (T, m), ``A`` (N, n, n), ``B`` (N, n, m),
        ``k`` (N, n(n + m)); ``changepoints`` is None.

    Examples
    --------
    >>> from ltvmodels import systems
    >>> data = systems.random_walk_system(T=500, seed=1)
    >>> data.x.shape, data.u.shape, data.k.shape
    ((500, 3), (500, 2), (499, 15))
    """
    T = _int_arg(T, "T", 2)
    n = _int_arg(n, "n", 1)
    m = _int_arg(m, "m", 0)
    drift_std = options.nonnegative_scalar(drift_std, "drift_std")
    noise_std = options.nonnegative_scalar(noise_std, "noise_std")
    measurement_std = options.nonnegative_scalar(measurement_std, "measurement_std")
    max_norm = options.positive_scalar(max_norm, "max_norm")
    if max_norm >= 1:
        raise ValueError(
            f"max_norm: expected a number in (0, 1) for a stable system, received {max_norm}"
        )
    rng = options.random_generator(seed)
    N = T - 1

    G = rng.standard_normal((n, n))
    A0 = G * (0.6 / max(float(np.linalg.norm(G)), 1e-300))
    B0 = rng.standard_normal((n, m))
    A = np.empty((N, n, n))
    B = np.empty((N, n, m))
    for walk, start in ((A, A0), (B, B0)):
        walk[0] = start
        if N > 1:
            steps = walk[1:]  # contiguous: draw the steps in place, then accumulate
            rng.standard_normal(out=steps)
            steps *= drift_std
            np.cumsum(steps, axis=0, out=steps)
            steps += start
    fro = np.sqrt(np.einsum("tij,tij->t", A, A))
    A *= np.minimum(1.0, max_norm / np.maximum(fro, 1e-300))[:, None, None]
    return _finish(
        rng,
        A,
        B,
        noise_std,
        measurement_std,
        None,
        name=f"random walk (n={n}, m={m}, drift_std={drift_std:g})",
    )


# -- test signals -------------------------------------------------------------------
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
    >>> y, inst = ltv.systems.chirp(2**12, seed=0)
    >>> y.shape, float(inst[0]), float(inst[-1])
    ((4096,), 2000.0, 3000.0)
    """
    T = options.integer(T, "T", minimum=2)
    fs = options.positive_scalar(fs, "fs")
    seed = options.integer(seed, "seed", minimum=0)
    rng = np.random.default_rng(seed)
    n = np.arange(T)
    t = n / fs
    f1 = np.linspace(2000.0, 2500.0, T)
    f2 = 5000.0 + 200.0 * np.sin(2 * np.pi * n / T)
    y = np.sin(2 * np.pi * f1 * t) + np.sin(2 * np.pi * f2 * t) + 0.01 * rng.standard_normal(T)
    return y, 2000.0 + 1000.0 * n / (T - 1)
