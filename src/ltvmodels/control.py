"""Trajectory optimization on LTV models: iLQG / DDP with control bounds and a trust region.

The problem, over a horizon of N steps (states x_0 … x_N, controls u_0 … u_{N−1}),

    minimize_u   Σ_{t<N} ℓ_t(x_t, u_t) + ℓ_N(x_N)
    subject to   x_{t+1} = f_t(x_t, u_t),   x_0 given,
                 lo_t <= u_t <= hi_t                       (box bounds, optional)
                 max_t ‖[x_t − x̄_t; u_t − ū_t]‖_W <= ε      (trust region, optional)

is solved by iterative LQG (differential dynamic programming with a
Gauss–Newton expansion of the dynamics; Tassa, Erez & Todorov 2012). Each
iteration expands the cost to second order and the dynamics to first order
along the current trajectory, computes the value function exactly for that
expansion in a backward pass, and updates the trajectory in a forward pass with
a backtracking line search that only accepts a lower cost, so the cost decreases
monotonically. Control bounds are handled as in box-DDP (Tassa, Mansard &
Todorov 2014): every step of the backward pass solves a box-constrained QP in
the control by a projected Newton method, and the feedback gains of the clamped
controls are zero.

The trust region keeps the new trajectory where a model fitted along a previous
trajectory (x̄, ū) is valid, the role of the KL-divergence bound of guided
policy search (Levine & Koltun 2013) and of the paper's Section VIII. It is
enforced by the penalty η Σ_t ‖[x_t − x̄_t; u_t − ū_t]‖²_W added to the cost,
with the multiplier η >= 0 chosen by bisection: the smallest η found whose
solution satisfies the bound is used (η = 0 when the unpenalized optimum already
lies inside the trust region).

Dynamics are given as

* an :class:`~ltvmodels.LTVModel` — x_{t+1} = A_t x_t + B_t u_t;
* :class:`LinearDynamics` — x_{t+1} = A_t x_t + B_t u_t + c_t;
  :meth:`LinearDynamics.through` sets c_t so that a measured trajectory
  satisfies the model exactly (a linearization along that trajectory);
* a function ``f(x_t, u_t, t) -> x_{t+1}`` with ``jacobian(x_t, u_t, t) ->
  (A_t, B_t)``.

Costs are :class:`QuadraticCost` or any object with the two methods of the
:class:`Cost` protocol. The numerical kernels (backward pass, box QP, forward
pass of linear dynamics) are compiled with numba.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numba
import numpy as np
from numpy.typing import ArrayLike

from .core.dense import cholesky, cholesky_solve
from .core.simulation import simulate_affine
from .errors import ConvergenceWarning, warn
from .results.base import LinearTimeVarying
from .validation import arrays, options

__all__ = [
    "ilqg",
    "ILQGResult",
    "LinearDynamics",
    "QuadraticCost",
    "Cost",
    "CostExpansion",
]


# -- cost ----------------------------------------------------------------------------
@dataclass
class CostExpansion:
    """Second-order expansion of a trajectory cost at a trajectory (x, u).

    Attributes
    ----------
    lx : ndarray, shape (N + 1, n)
        ∂ℓ_t/∂x; row N belongs to the terminal cost.
    lu : ndarray, shape (N, m)
        ∂ℓ_t/∂u.
    lxx : ndarray, shape (N + 1, n, n)
        ∂²ℓ_t/∂x²; block N belongs to the terminal cost.
    luu : ndarray, shape (N, m, m)
        ∂²ℓ_t/∂u².
    lux : ndarray, shape (N, m, n)
        ∂²ℓ_t/∂u∂x.
    """

    lx: np.ndarray
    lu: np.ndarray
    lxx: np.ndarray
    luu: np.ndarray
    lux: np.ndarray


@runtime_checkable
class Cost(Protocol):
    """A twice-differentiable trajectory cost Σ_{t<N} ℓ_t(x_t, u_t) + ℓ_N(x_N).

    Any object with these two methods can be passed to :func:`ilqg`.
    """

    def stage_costs(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Costs ℓ_0 … ℓ_{N−1}, ℓ_N of x (N + 1, n), u (N, m); shape (N + 1,)."""
        ...  # pragma: no cover

    def quadratize(self, x: np.ndarray, u: np.ndarray) -> CostExpansion:
        """Derivatives of the stage costs at (x, u), see :class:`CostExpansion`."""
        ...  # pragma: no cover


def _square_sequence(value: Any, name: str, N: int, d: int) -> np.ndarray:
    """A symmetric PSD weight, (d, d) or (N, d, d), as a (N, d, d) float64 array."""
    arr = arrays.as_float_array(value, name)
    if arr.ndim == 0 and d == 1:
        arr = arr.reshape(1, 1)
    if arr.shape == (d, d):
        arr = np.broadcast_to(arr, (N, d, d))
    elif arr.shape != (N, d, d):
        raise ValueError(
            f"{name}: expected shape ({d}, {d}) or ({N}, {d}, {d}), received shape {arr.shape}"
        )
    if not np.allclose(arr, np.swapaxes(arr, 1, 2), rtol=1e-10, atol=1e-12):
        raise ValueError(f"{name}: expected a symmetric matrix, received a non-symmetric one")
    if np.min(np.linalg.eigvalsh(arr[:1] if arr.strides[0] == 0 else arr)) < -1e-10 * max(
        1.0, float(np.max(np.abs(arr)))
    ):
        raise ValueError(
            f"{name}: expected a positive semidefinite matrix, received an indefinite one"
        )
    return np.ascontiguousarray(arr)


def _target_sequence(value: Any, name: str, rows: int, d: int) -> np.ndarray:
    """A target, (d,) or (rows, d), as a (rows, d) float64 array (zeros when None)."""
    if value is None:
        return np.zeros((rows, d))
    arr = arrays.as_float_array(value, name)
    if arr.ndim == 0 and d == 1:
        arr = arr.reshape(1)
    if arr.shape == (d,):
        return np.ascontiguousarray(np.broadcast_to(arr, (rows, d)))
    if arr.shape != (rows, d):
        raise ValueError(
            f"{name}: expected shape ({d},) or ({rows}, {d}), received shape {arr.shape}"
        )
    return arr


class QuadraticCost:
    """Quadratic tracking cost.

    The objective of a trajectory x (N + 1, n), u (N, m) is

        J = Σ_{t<N} [(x_t − g_t)ᵀ Q_t (x_t − g_t) + (u_t − r_t)ᵀ R_t (u_t − r_t)]
            + (x_N − g_N)ᵀ Q_f (x_N − g_N).

    Parameters
    ----------
    Q : array_like, shape (n, n) or (N, n, n)
        State weight, symmetric positive semidefinite.
    R : array_like, shape (m, m) or (N, m, m)
        Control weight, symmetric positive semidefinite (positive definite
        unless the controls are bounded).
    horizon : int
        N, the number of control steps.
    Qf : array_like, shape (n, n), optional
        Terminal weight; default: ``Q`` (its last block when time-varying).
    x_goal : array_like, shape (n,) or (N + 1, n), optional
        State target g_t; default 0.
    u_goal : array_like, shape (m,) or (N, m), optional
        Control target r_t; default 0.
    """

    def __init__(
        self,
        Q: ArrayLike,
        R: ArrayLike,
        horizon: int,
        *,
        Qf: ArrayLike | None = None,
        x_goal: ArrayLike | None = None,
        u_goal: ArrayLike | None = None,
    ) -> None:
        N = options.integer(horizon, "horizon", 1)
        Qa = arrays.as_float_array(Q, "Q")
        Ra = arrays.as_float_array(R, "R")
        if Qa.ndim < 2 or Qa.shape[-1] != Qa.shape[-2]:
            raise ValueError(f"Q: expected shape (n, n) or (N, n, n), received shape {Qa.shape}")
        n = Qa.shape[-1]
        m = 1 if Ra.ndim == 0 else Ra.shape[-1]
        self.N, self.n, self.m = N, n, m
        self.Q = _square_sequence(Qa, "Q", N, n)
        self.R = _square_sequence(Ra, "R", N, m)
        self.Qf = self.Q[-1].copy() if Qf is None else _square_sequence(Qf, "Qf", 1, n)[0].copy()
        self.x_goal = _target_sequence(x_goal, "x_goal", N + 1, n)
        self.u_goal = _target_sequence(u_goal, "u_goal", N, m)

    def __repr__(self) -> str:
        return f"QuadraticCost(N={self.N}, n={self.n}, m={self.m})"

    def stage_costs(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Stage costs ℓ_0 … ℓ_{N−1} and the terminal cost ℓ_N, shape (N + 1,)."""
        dx = x - self.x_goal
        du = u - self.u_goal
        c = np.empty(self.N + 1)
        c[:-1] = np.einsum("ti,tij,tj->t", dx[:-1], self.Q, dx[:-1]) + np.einsum(
            "ti,tij,tj->t", du, self.R, du
        )
        c[-1] = dx[-1] @ self.Qf @ dx[-1]
        return c

    def quadratize(self, x: np.ndarray, u: np.ndarray) -> CostExpansion:
        """Exact derivatives (the cost is quadratic)."""
        dx = x - self.x_goal
        du = u - self.u_goal
        lx = np.empty_like(dx)
        lx[:-1] = 2.0 * np.einsum("tij,tj->ti", self.Q, dx[:-1])
        lx[-1] = 2.0 * self.Qf @ dx[-1]
        lxx = np.empty((self.N + 1, self.n, self.n))
        lxx[:-1] = 2.0 * self.Q
        lxx[-1] = 2.0 * self.Qf
        return CostExpansion(
            lx=lx,
            lu=2.0 * np.einsum("tij,tj->ti", self.R, du),
            lxx=lxx,
            luu=2.0 * self.R,
            lux=np.zeros((self.N, self.m, self.n)),
        )


# -- dynamics -------------------------------------------------------------------------
class LinearDynamics(LinearTimeVarying):
    """Affine time-varying dynamics x_{t+1} = A_t x_t + B_t u_t + c_t.

    Parameters
    ----------
    A : array_like, shape (N, n, n)
        State matrices A_t of x[t+1] = A_t x[t] + B_t u[t] + c_t.
    B : array_like, shape (N, n, m)
        Input matrices B_t.
    c : array_like, shape (N, n) or (n,), optional
        Offsets; default 0.
    """

    A: np.ndarray
    B: np.ndarray

    def __init__(self, A: ArrayLike, B: ArrayLike, c: ArrayLike | None = None) -> None:
        A = arrays.as_float_array(A, "A")
        B = arrays.as_float_array(B, "B")
        if A.ndim != 3 or A.shape[1] != A.shape[2]:
            raise ValueError(f"A: expected shape (N, n, n), received shape {A.shape}")
        N, n = A.shape[:2]
        if B.ndim != 3 or B.shape[:2] != (N, n):
            raise ValueError(f"B: expected shape ({N}, {n}, m), received shape {B.shape}")
        self.A = np.ascontiguousarray(A)
        self.B = np.ascontiguousarray(B)
        self.c = _target_sequence(c, "c", N, n)

    @classmethod
    def through(cls, A: ArrayLike, B: ArrayLike, x: ArrayLike, u: ArrayLike) -> LinearDynamics:
        """Jacobians A_t, B_t with offsets that make a trajectory satisfy the model.

        c_t = x_{t+1} − A_t x_t − B_t u_t, so the model is the linearization
        x_{t+1} ≈ x̄_{t+1} + A_t (x_t − x̄_t) + B_t (u_t − ū_t) along (x̄, ū).

        Parameters
        ----------
        A : array_like, shape (N, n, n)
        B : array_like, shape (N, n, m)
        x : array_like, shape (N + 1, n)
            The trajectory's states.
        u : array_like, shape (N, m) or (N + 1, m)
            Its controls (a last row, as in the data convention of
            :func:`ltvmodels.fit`, is ignored).
        """
        dyn = cls(A, B)
        N, n, m = dyn.N, dyn.n, dyn.m
        xs, us = _trajectory(x, u, N, n, m, "x", "u")
        dyn.c = (
            xs[1:] - np.einsum("tij,tj->ti", dyn.A, xs[:-1]) - np.einsum("tij,tj->ti", dyn.B, us)
        )
        return dyn

    def simulate(self, x0: ArrayLike, u: ArrayLike) -> np.ndarray:
        """States (N + 1, n) from x0 (n,) under controls u (N, m)."""
        x0 = arrays.vector(x0, "x0", self.n)
        u = _trajectory_controls(u, self.N, self.m, "u")
        return simulate_affine(self.A, self.B, self.c, x0, u)

    def __repr__(self) -> str:
        return f"LinearDynamics(N={self.N}, n={self.n}, m={self.m})"


class _FunctionDynamics:
    """x_{t+1} = f(x_t, u_t, t) with Jacobians from ``jacobian(x_t, u_t, t)``."""

    def __init__(self, f: Callable, jacobian: Callable, N: int, n: int, m: int) -> None:
        self.f, self.jac, self.N, self.n, self.m = f, jacobian, N, n, m

    def step(self, x: np.ndarray, u: np.ndarray, t: int) -> np.ndarray:
        out = np.asarray(self.f(x.copy(), u.copy(), t), dtype=float)
        if out.shape != (self.n,):
            raise ValueError(
                f"dynamics: expected f(x, u, t) to return shape ({self.n},), received "
                f"shape {out.shape} at t={t}"
            )
        return out

    def linearize(self, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        A = np.empty((self.N, self.n, self.n))
        B = np.empty((self.N, self.n, self.m))
        for t in range(self.N):
            fx, fu = self.jac(x[t].copy(), u[t].copy(), t)
            fx = np.asarray(fx, dtype=float)
            fu = np.asarray(fu, dtype=float)
            if fu.ndim == 1 and self.m == 1:
                fu = fu[:, None]
            if fx.shape != (self.n, self.n) or fu.shape != (self.n, self.m):
                raise ValueError(
                    f"jacobian: expected ((n, n), (n, m)) = (({self.n}, {self.n}), "
                    f"({self.n}, {self.m})), received ({fx.shape}, {fu.shape}) at t={t}"
                )
            A[t], B[t] = fx, fu
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
            raise ValueError("jacobian: expected finite values, received NaN or inf")
        return A, B

    def forward(self, x0, x_nom, u_nom, k, K, alpha, lo, hi):
        x = np.empty_like(x_nom)
        u = np.empty_like(u_nom)
        x[0] = x0
        for t in range(self.N):
            u[t] = np.clip(u_nom[t] + alpha * k[t] + K[t] @ (x[t] - x_nom[t]), lo[t], hi[t])
            x[t + 1] = self.step(x[t], u[t], t)
            if not np.all(np.isfinite(x[t + 1])):
                x[t + 2 :] = np.nan
                return x, u
        return x, u


class _LinearAdapter:
    def __init__(self, dyn: LinearDynamics) -> None:
        self.dyn = dyn
        self.N, self.n, self.m = dyn.N, dyn.n, dyn.m

    def linearize(self, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.dyn.A, self.dyn.B

    def forward(self, x0, x_nom, u_nom, k, K, alpha, lo, hi):
        return _forward_linear(
            self.dyn.A, self.dyn.B, self.dyn.c, x0, x_nom, u_nom, k, K, alpha, lo, hi
        )


# -- compiled kernels -----------------------------------------------------------------
@numba.njit(cache=True)
def _forward_linear(A, B, c, x0, x_nom, u_nom, k, K, alpha, lo, hi):  # pragma: no cover
    """Closed-loop rollout u_t = clip(ū_t + α k_t + K_t (x_t − x̄_t)) of affine dynamics."""
    N, n, _ = A.shape
    m = B.shape[2]
    x = np.empty((N + 1, n))
    u = np.empty((N, m))
    for i in range(n):  # not x[0] = x0: see _backward
        x[0, i] = x0[i]
    for t in range(N):
        for i in range(m):
            v = u_nom[t, i] + alpha * k[t, i]
            for j in range(n):
                v += K[t, i, j] * (x[t, j] - x_nom[t, j])
            u[t, i] = min(max(v, lo[t, i]), hi[t, i])
        for i in range(n):
            acc = c[t, i]
            for j in range(n):
                acc += A[t, i, j] * x[t, j]
            for j in range(m):
                acc += B[t, i, j] * u[t, j]
            x[t + 1, i] = acc
    return x, u


@numba.njit(cache=True)
def _box_qp(H, g, lower, upper, x0, L):  # pragma: no cover
    """min ½ xᵀHx + gᵀx s.t. lower <= x <= upper, by projected Newton (Tassa et al. 2014).

    Returns (x, free, n_free, ok): the solution, the free set (indices in
    free[:n_free]) and whether H restricted to the free set was positive
    definite. L holds the Cholesky factor of that restricted H.
    """
    m = g.size
    x = np.empty(m)
    for i in range(m):
        x[i] = min(max(x0[i], lower[i]), upper[i])
    clamped = np.zeros(m, dtype=np.bool_)
    old_clamped = np.zeros(m, dtype=np.bool_)
    free = np.empty(m, dtype=np.int64)
    grad = np.empty(m)
    value = 0.0
    for i in range(m):
        s = g[i]
        for j in range(m):
            s += 0.5 * H[i, j] * x[j]
        value += x[i] * s
    n_free = 0
    factored = False
    old_value = value
    for it in range(100):
        if it > 0 and (old_value - value) < 1e-12 * abs(old_value):
            break
        old_value = value
        for i in range(m):
            s = g[i]
            for j in range(m):
                s += H[i, j] * x[j]
            grad[i] = s
        n_free = 0
        changed = not factored
        for i in range(m):
            c = (x[i] == lower[i] and grad[i] > 0.0) or (x[i] == upper[i] and grad[i] < 0.0)
            clamped[i] = c
            if c != old_clamped[i]:
                changed = True
            old_clamped[i] = c
            if not c:
                free[n_free] = i
                n_free += 1
        if n_free == 0:
            break
        if changed:
            if not cholesky(H, free[:n_free], 0.0, L):
                return x, free, n_free, False
            factored = True
        gnorm = 0.0
        for a in range(n_free):
            gnorm += grad[free[a]] ** 2
        if math.sqrt(gnorm) < 1e-13:
            break
        # Newton step on the free set with the clamped variables held fixed.
        rhs = np.empty((n_free, 1))
        for a in range(n_free):
            i = free[a]
            s = g[i]
            for j in range(m):
                if clamped[j]:
                    s += H[i, j] * x[j]
            rhs[a, 0] = s
        # rhs.shape[0] (= n_free): numba types n_free here as the literal 0 at first,
        # which compiled cholesky_solve a second time.
        cholesky_solve(L, rhs.shape[0], rhs)
        search = np.zeros(m)
        for a in range(n_free):
            i = free[a]
            search[i] = -rhs[a, 0] - x[i]
        sdotg = 0.0
        for i in range(m):
            sdotg += search[i] * grad[i]
        if sdotg >= 0.0:
            break
        step = 1.0
        xc = np.empty(m)
        accepted = False
        while step > 1e-20:
            for i in range(m):
                xc[i] = min(max(x[i] + step * search[i], lower[i]), upper[i])
            vc = 0.0
            for i in range(m):
                s = g[i]
                for j in range(m):
                    s += 0.5 * H[i, j] * xc[j]
                vc += xc[i] * s
            if (vc - value) / (step * sdotg) >= 0.1:
                accepted = True
                break
            step *= 0.6
        if not accepted:
            break
        for i in range(m):
            x[i] = xc[i]
        value = vc
    # Free set and factor at the solution, for the feedback gains.
    for i in range(m):
        s = g[i]
        for j in range(m):
            s += H[i, j] * x[j]
        grad[i] = s
    n_free = 0
    for i in range(m):
        if not ((x[i] == lower[i] and grad[i] > 0.0) or (x[i] == upper[i] and grad[i] < 0.0)):
            free[n_free] = i
            n_free += 1
    if n_free > 0 and not cholesky(H, free[:n_free], 0.0, L):
        return x, free, n_free, False
    return x, free, n_free, True


@numba.njit(cache=True)
def _backward(A, B, lx, lu, lxx, luu, lux, u, lo, hi, mu, k_warm):  # pragma: no cover
    """Backward pass of box-DDP on the expansion along (x, u).

    Returns (k, K, dV, failed_at): feedforward steps (N, m), gains (N, m, n),
    the expected cost change coefficients [Σ kᵀQu, ½ Σ kᵀQuu k], and −1 on
    success or the time step where Quu + μI was not positive definite.
    """
    N, n, _ = A.shape
    m = B.shape[2]
    k = np.zeros((N, m))
    K = np.zeros((N, m, n))
    dV = np.zeros(2)
    Vx = lx[N].copy()
    Vxx = lxx[N].copy()
    L = np.empty((m, m))
    Hreg = np.empty((m, m))
    lower = np.empty(m)
    upper = np.empty(m)
    for t in range(N - 1, -1, -1):
        At = A[t]
        Bt = B[t]
        Qx = lx[t] + At.T @ Vx
        Qu = lu[t] + Bt.T @ Vx
        VA = Vxx @ At
        VB = Vxx @ Bt
        Qxx = lxx[t] + At.T @ VA
        Qux = lux[t] + Bt.T @ VA
        Quu = luu[t] + Bt.T @ VB
        for i in range(m):
            for j in range(m):
                Hreg[i, j] = 0.5 * (Quu[i, j] + Quu[j, i])
            Hreg[i, i] += mu
            lower[i] = lo[t, i] - u[t, i]
            upper[i] = hi[t, i] - u[t, i]
        kt, free, n_free, ok = _box_qp(Hreg, Qu, lower, upper, k_warm[t], L)
        if not ok:
            return k, K, dV, t
        # Copies element by element: an array assignment (k[t] = kt) makes numba
        # compile its shape-mismatch error message, string formatting that cost
        # ~2 s of the first ilqg call.
        for i in range(m):
            k[t, i] = kt[i]
        if n_free > 0:
            rhs = np.empty((n_free, n))
            for a in range(n_free):
                for j in range(n):
                    rhs[a, j] = Qux[free[a], j]
            cholesky_solve(L, n_free, rhs)
            for a in range(n_free):
                for j in range(n):
                    K[t, free[a], j] = -rhs[a, j]
        Kt = K[t]
        dV[0] += kt @ Qu
        dV[1] += 0.5 * (kt @ (Quu @ kt))
        QuuK = Quu @ Kt
        Vx = Qx + Kt.T @ (Quu @ kt) + Kt.T @ Qu + Qux.T @ kt
        Vxx = Qxx + Kt.T @ QuuK + Kt.T @ Qux + Qux.T @ Kt
        Vxx = 0.5 * (Vxx + Vxx.T)
    return k, K, dV, -1


# -- input checks -------------------------------------------------------------------
def _trajectory_controls(u: Any, N: int, m: int, name: str) -> np.ndarray:
    """Controls (N, m); a 1-d (N,) array for m = 1 and an extra last row are accepted."""
    arr = arrays.as_float_array(u, name)
    if arr.ndim == 1 and m == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[1] != m or arr.shape[0] not in (N, N + 1):
        raise ValueError(
            f"{name}: expected shape ({N}, {m}) (one control per step, time on axis 0), "
            f"received shape {arr.shape}"
        )
    return np.ascontiguousarray(arr[:N])


def _trajectory(
    x: Any, u: Any, N: int, n: int, m: int, xname: str, uname: str
) -> tuple[np.ndarray, np.ndarray]:
    """A trajectory: states (N + 1, n) and controls (N, m)."""
    xs = arrays.as_float_array(x, xname)
    if xs.ndim == 1 and n == 1:
        xs = xs[:, None]
    if xs.shape != (N + 1, n):
        raise ValueError(
            f"{xname}: expected shape ({N + 1}, {n}) (states x_0 … x_N, time on axis 0), "
            f"received shape {xs.shape}"
        )
    return xs, _trajectory_controls(u, N, m, uname)


def _control_bounds(bounds: Any, N: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """``u_bounds=(lo, hi)``, each a scalar, (m,) or (N, m); ±inf allowed."""
    inf = np.full((N, m), np.inf)
    if bounds is None:
        return -inf, inf
    if not isinstance(bounds, (tuple, list)) or len(bounds) != 2:
        raise TypeError(
            "u_bounds: expected a pair (lower, upper) of scalars, (m,) or (N, m) arrays, "
            f"received {arrays.describe(bounds)}"
        )
    out = []
    for value, label in zip(bounds, ("lower", "upper"), strict=True):
        name = f"u_bounds {label}"
        arr = np.array(value, dtype=float) if value is not None else None
        if arr is None or np.isnan(arr).any():
            raise ValueError(f"{name}: expected real numbers or ±inf, received {value!r}")
        try:
            arr = np.broadcast_to(arr, (N, m)).copy()
        except ValueError:
            raise ValueError(
                f"{name}: expected a scalar or shape ({m},) or ({N}, {m}), received shape "
                f"{np.shape(value)}"
            ) from None
        out.append(arr)
    lo, hi = out
    if np.any(lo > hi):
        t, i = np.argwhere(lo > hi)[0]
        raise ValueError(
            f"u_bounds: expected lower <= upper, received lower {lo[t, i]} > upper {hi[t, i]} "
            f"at step {t}, control {i}"
        )
    if np.any(lo == np.inf) or np.any(hi == -np.inf):
        raise ValueError("u_bounds: expected lower < inf and upper > -inf, received an empty box")
    return lo, hi


def _trust_radius(value: Any) -> float | None:
    """The trust-region radius ε > 0, or None for no trust region."""
    if value is None:
        return None
    return options.positive_scalar(value, "trust_region")


def _trust_weights(value: Any, n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Diagonal trust-region weights (w_x (n,), w_u (m,)), nonnegative."""
    if value is None:
        return np.ones(n), np.ones(m)
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise TypeError(
            "trust_weights: expected a pair (w_x, w_u) of vectors of lengths "
            f"({n}, {m}), received {arrays.describe(value)}"
        )
    wx = arrays.vector(value[0], "trust_weights[0]", n)
    wu = arrays.vector(value[1], "trust_weights[1]", m)
    for w, name in ((wx, "trust_weights[0]"), (wu, "trust_weights[1]")):
        if np.any(w < 0):
            raise ValueError(f"{name}: expected nonnegative weights, received {w.tolist()}")
    if not (wx.any() or wu.any()):
        raise ValueError("trust_weights: expected at least one positive weight, received zeros")
    return wx, wu


def _dynamics(dynamics: Any, jacobian: Any, N: int, n: int, m: int) -> Any:
    """Wrap ``dynamics`` (LTVModel, LinearDynamics or a function) for the solver."""
    if isinstance(dynamics, LinearDynamics):
        return _LinearAdapter(dynamics)
    if hasattr(dynamics, "A") and hasattr(dynamics, "B") and hasattr(dynamics, "k"):
        return _LinearAdapter(LinearDynamics(dynamics.A, dynamics.B))
    if callable(dynamics):
        if not callable(jacobian):
            raise TypeError(
                "jacobian: expected a function jacobian(x, u, t) -> (A_t, B_t) when dynamics is "
                f"a function, received {arrays.describe(jacobian)}"
            )
        return _FunctionDynamics(dynamics, jacobian, N, n, m)
    raise TypeError(
        "dynamics: expected an LTVModel, a LinearDynamics or a function f(x, u, t), received "
        f"{arrays.describe(dynamics)}"
    )


def _cost(cost: Any) -> Any:
    """A cost object with ``stage_costs`` and ``quadratize``."""
    if not isinstance(cost, Cost):
        raise TypeError(
            "cost: expected a QuadraticCost or an object with methods stage_costs(x, u) and "
            f"quadratize(x, u), received {arrays.describe(cost)}"
        )
    return cost


def _expansion(exp: Any, N: int, n: int, m: int) -> CostExpansion:
    """Check the shapes of a user cost's expansion; contiguous float64 copies."""
    shapes = {
        "lx": (N + 1, n),
        "lu": (N, m),
        "lxx": (N + 1, n, n),
        "luu": (N, m, m),
        "lux": (N, m, n),
    }
    out = {}
    for name, shape in shapes.items():
        arr = np.array(getattr(exp, name), dtype=float, order="C")  # a copy: never aliased
        if arr.shape != shape:
            raise ValueError(
                f"cost.quadratize: expected {name} of shape {shape}, received shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"cost.quadratize: expected finite {name}, received NaN or inf")
        out[name] = arr
    return CostExpansion(**out)


# -- the solver ------------------------------------------------------------------------
@dataclass
class ILQGResult:
    """Result of :func:`ilqg`.

    Attributes
    ----------
    x : ndarray, shape (N + 1, n)
        Optimized nominal states x̄_0 … x̄_N (under the given dynamics).
    u : ndarray, shape (N, m)
        Optimized nominal controls ū_0 … ū_{N−1}, within the bounds.
    K : ndarray, shape (N, m, n)
        Feedback gains of the final backward pass: the local controller is
        u_t = clip(ū_t + K_t (x_t − x̄_t)). Rows of clamped controls are zero.
    cost : float
        Predicted cost J(x̄, ū) under the dynamics, without the trust-region penalty.
    objective : float
        The optimized objective J + η Σ_t ‖[x̄_t − x_ref_t; ū_t − u_ref_t]‖²_W.
    cost_trace : ndarray
        Objective after each accepted iteration of the final solve (starting
        with the initial trajectory); nonincreasing.
    iterations : int
        Iterations of the final solve (total over all solves: ``info["total_iterations"]``).
    converged : bool
        Whether the final solve met the tolerance.
    eta : float
        Trust-region multiplier η (0 without a trust region or when the bound is inactive).
    deviation : float
        max_t ‖[x̄_t − x_ref_t; ū_t − u_ref_t]‖_W from the trust-region reference
        (from the initial trajectory when no reference was given).
    lower, upper : ndarray, shape (N, m)
        The control bounds (±inf where unbounded).
    info : dict
        ``total_iterations``, ``solves`` (number of η values tried), ``mu``
        (final regularization), ``trust_region``.
    """

    x: np.ndarray
    u: np.ndarray
    K: np.ndarray
    cost: float
    objective: float
    cost_trace: np.ndarray
    iterations: int
    converged: bool
    eta: float
    deviation: float
    lower: np.ndarray
    upper: np.ndarray
    info: dict = field(default_factory=dict)

    def control(self, t: int, x: ArrayLike) -> np.ndarray:
        """Feedback control u_t = clip(ū_t + K_t (x − x̄_t), lower_t, upper_t), shape (m,)."""
        N, n = self.K.shape[0], self.K.shape[2]
        t = options.integer(t, "t", 0)
        if t >= N:
            raise ValueError(f"t: expected an integer in [0, {N - 1}], received {t}")
        xv = arrays.vector(x, "x", n)
        return np.clip(self.u[t] + self.K[t] @ (xv - self.x[t]), self.lower[t], self.upper[t])

    def __repr__(self) -> str:
        N, m, n = self.K.shape
        return (
            f"ILQGResult(N={N}, n={n}, m={m}, cost={self.cost:.6g}, "
            f"iterations={self.iterations}, converged={self.converged}, "
            f"eta={self.eta:.3g}, deviation={self.deviation:.3g})"
        )


@dataclass
class _Solve:
    x: np.ndarray
    u: np.ndarray
    K: np.ndarray
    objective: float
    trace: list
    iterations: int
    converged: bool
    mu: float


_ALPHAS = 10.0 ** np.linspace(0.0, -3.0, 11)


class _Problem:
    """The objective J + η·penalty and its expansion, with the trust-region terms."""

    def __init__(self, cost, N, n, m, x_ref, u_ref, wx, wu):
        self.cost, self.N, self.n, self.m = cost, N, n, m
        self.x_ref, self.u_ref, self.wx, self.wu = x_ref, u_ref, wx, wu
        self.eta = 0.0

    def base_cost(self, x, u) -> float:
        c = np.asarray(self.cost.stage_costs(x, u), dtype=float)
        if c.shape != (self.N + 1,):
            raise ValueError(
                f"cost.stage_costs: expected shape ({self.N + 1},), received shape {c.shape}"
            )
        return float(np.sum(c))

    def penalty(self, x, u) -> float:
        if self.x_ref is None:
            return 0.0
        dx, du = x - self.x_ref, u - self.u_ref
        return float(np.sum(dx * dx * self.wx) + np.sum(du * du * self.wu))

    def deviation(self, x, u) -> float:
        if self.x_ref is None:
            return 0.0
        dx, du = x - self.x_ref, u - self.u_ref
        d2 = np.sum(dx * dx * self.wx, axis=1)
        d2[:-1] += np.sum(du * du * self.wu, axis=1)
        return float(np.sqrt(np.max(d2)))

    def objective(self, x, u) -> float:
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(u))):
            return np.inf
        value = self.base_cost(x, u)
        if self.eta > 0:
            value += self.eta * self.penalty(x, u)
        return value if np.isfinite(value) else np.inf

    def quadratize(self, x, u) -> CostExpansion:
        e = _expansion(self.cost.quadratize(x, u), self.N, self.n, self.m)
        if self.eta > 0:
            eta2 = 2.0 * self.eta
            e.lx += eta2 * self.wx * (x - self.x_ref)
            e.lu += eta2 * self.wu * (u - self.u_ref)
            e.lxx += eta2 * np.diag(self.wx)
            e.luu += eta2 * np.diag(self.wu)
        return e


def _solve(problem: _Problem, dyn, x0, u_start, lo, hi, *, max_iter, tol, mu_init) -> _Solve:
    """Box-DDP iterations for a fixed η, from the controls ``u_start``."""
    N, n, m = problem.N, problem.n, problem.m
    zeros_k = np.zeros((N, m))
    zeros_K = np.zeros((N, m, n))
    x, u = dyn.forward(x0, np.zeros((N + 1, n)), u_start, zeros_k, zeros_K, 0.0, lo, hi)
    J = problem.objective(x, u)
    if not np.isfinite(J):
        raise ValueError("u_init: the initial trajectory diverges (NaN or inf states or cost)")
    trace = [J]
    mu, dmu = mu_init, 1.0
    mu_min, mu_max, factor = 1e-6, 1e10, 1.6
    k_warm = zeros_k
    K = zeros_K
    converged = False
    it = 0
    while it < max_iter:
        it += 1
        A, B = dyn.linearize(x, u)
        e = problem.quadratize(x, u)
        while True:
            k, K_new, dV, failed = _backward(
                A, B, e.lx, e.lu, e.lxx, e.luu, e.lux, u, lo, hi, mu, k_warm
            )
            if failed < 0:
                break
            dmu = max(dmu * factor, factor)
            mu = max(mu * dmu, mu_min)
            if mu > mu_max:
                raise np.linalg.LinAlgError(
                    "ilqg: Quu is not positive definite even with regularization "
                    f"{mu_max:g} (at step {failed}); is the control weight R positive definite?"
                )
        K = K_new
        k_warm = k
        gnorm = float(np.mean(np.max(np.abs(k) / (np.abs(u) + 1.0), axis=1)))
        if gnorm < tol and mu < 1e-5:
            converged = True
            break
        accepted = False
        for alpha in _ALPHAS:
            x_new, u_new = dyn.forward(x0, x, u, k, K, alpha, lo, hi)
            J_new = problem.objective(x_new, u_new)
            if J_new < J:  # accept only a decrease: monotone cost
                accepted = True
                break
        if accepted:
            dmu = min(dmu / factor, 1.0 / factor)
            mu = mu * dmu if mu * dmu > mu_min else 0.0
            dJ = J - J_new
            x, u, J = x_new, u_new, J_new
            trace.append(J)
            if dJ < tol * max(abs(J), 1.0):
                converged = True
                break
        else:
            dmu = max(dmu * factor, factor)
            mu = max(mu * dmu, mu_min)
            if mu > mu_max:
                break
    # Gains at the final trajectory (from the least regularization that works).
    A, B = dyn.linearize(x, u)
    e = problem.quadratize(x, u)
    for mu_final in (0.0, mu, *(mu_min * 10.0**p for p in range(0, 17, 2))):
        _, K_fin, _, failed = _backward(
            A, B, e.lx, e.lu, e.lxx, e.luu, e.lux, u, lo, hi, mu_final, k_warm
        )
        if failed < 0:
            K = K_fin
            break
    return _Solve(
        x=x, u=u, K=K, objective=J, trace=trace, iterations=it, converged=converged, mu=mu
    )


def ilqg(
    dynamics: Any,
    cost: Any,
    x0: ArrayLike,
    u_init: ArrayLike,
    *,
    jacobian: Callable | None = None,
    u_bounds: tuple[ArrayLike, ArrayLike] | None = None,
    trust_region: float | None = None,
    reference: tuple[ArrayLike, ArrayLike] | None = None,
    trust_weights: tuple[ArrayLike, ArrayLike] | None = None,
    max_iter: int = 200,
    tol: float = 1e-8,
) -> ILQGResult:
    """Optimize a trajectory by iterative LQG with control bounds and a trust region.

    Minimizes J = Σ_{t<N} ℓ_t(x_t, u_t) + ℓ_N(x_N) subject to
    x_{t+1} = f_t(x_t, u_t) from ``x0``, lower_t <= u_t <= upper_t, and (with
    ``trust_region=ε``) max_t ‖[x_t − x_ref_t; u_t − u_ref_t]‖_W <= ε, where
    ‖v‖²_W = Σ_i w_i v_i² (see the module docstring for the algorithm).

    On linear dynamics with a quadratic cost and no bounds, the first iteration
    is the finite-horizon LQR (Riccati) solution and the gains ``K`` are the
    LQR gains.

    Parameters
    ----------
    dynamics : LTVModel, LinearDynamics or callable
        An :class:`~ltvmodels.LTVModel` (x_{t+1} = A_t x_t + B_t u_t, N = model.N
        steps), a :class:`LinearDynamics` (with offsets), or a function
        ``f(x_t, u_t, t) -> x_{t+1}`` (arrays (n,), (m,) → (n,)), which needs
        ``jacobian``.
    cost : QuadraticCost or Cost
        The trajectory cost; see :class:`Cost` for a general twice-differentiable one.
    x0 : array_like, shape (n,)
        Initial state.
    u_init : array_like, shape (N, m)
        Initial controls (projected onto the bounds). For a function
        ``dynamics`` this also sets the horizon N. An extra last row (the data
        convention of :func:`ltvmodels.fit`) is ignored.
    jacobian : callable, optional
        ``jacobian(x_t, u_t, t) -> (A_t (n, n), B_t (n, m))``, the derivatives
        of ``dynamics`` when it is a function.
    u_bounds : (lower, upper), optional
        Control bounds, each a scalar, shape (m,) or (N, m); ±inf for none.
    trust_region : float, optional
        Radius ε > 0 of the trust region around ``reference``.
    reference : (x_ref (N + 1, n), u_ref (N, m)), optional
        The trajectory the trust region is measured from (e.g. the trajectory
        a model was fitted along). Default: the initial trajectory (``u_init``
        rolled out from ``x0``).
    trust_weights : (w_x (n,), w_u (m,)), optional
        Diagonal weights W of the trust-region norm (scale states and
        controls to comparable units); default ones.
    max_iter : int
        Iterations per solve (one solve per trial value of η).
    tol : float
        Convergence tolerance on the relative cost decrease and on the
        feedforward step size.

    Returns
    -------
    ILQGResult
        Nominal trajectory ``x``, ``u``, feedback gains ``K``, the predicted
        ``cost`` and diagnostics.

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument).
    numpy.linalg.LinAlgError
        If the control Hessian cannot be made positive definite.
    """
    x0a = arrays.as_float_array(x0, "x0")
    if x0a.ndim != 1 or x0a.size == 0:
        raise ValueError(
            f"x0: expected a 1-d state vector of shape (n,), received shape {x0a.shape}"
        )
    arrays.representable(x0a, "x0", small=False)
    n = x0a.size
    if isinstance(dynamics, LinearDynamics) or (
        hasattr(dynamics, "A") and hasattr(dynamics, "B") and hasattr(dynamics, "k")
    ):
        N, nd, m = np.shape(dynamics.A)[0], np.shape(dynamics.A)[1], np.shape(dynamics.B)[2]
        if nd != n:
            raise ValueError(
                f"x0: expected length {nd} (the dynamics' state dimension), received length {n}"
            )
        u0 = _trajectory_controls(u_init, N, m, "u_init")
    else:
        ua = arrays.as_float_array(u_init, "u_init")
        if ua.ndim == 1:
            ua = ua[:, None]
        if ua.ndim != 2 or ua.shape[0] < 1:
            raise ValueError(f"u_init: expected shape (N, m), received shape {ua.shape}")
        N, m = ua.shape
        u0 = np.ascontiguousarray(ua)
    dyn = _dynamics(dynamics, jacobian, N, n, m)
    cost = _cost(cost)
    if getattr(cost, "N", N) != N or getattr(cost, "n", n) != n or getattr(cost, "m", m) != m:
        raise ValueError(
            f"cost: expected horizon N={N}, n={n}, m={m} (as the dynamics and u_init), "
            f"received N={cost.N}, n={cost.n}, m={cost.m}"
        )
    lo, hi = _control_bounds(u_bounds, N, m)
    radius = _trust_radius(trust_region)
    wx, wu = _trust_weights(trust_weights, n, m)
    max_iter = options.integer(max_iter, "max_iter", 1)
    tol = options.positive_scalar(tol, "tol")
    u0 = np.clip(u0, lo, hi)

    zeros_k = np.zeros((N, m))
    zeros_K = np.zeros((N, m, n))
    if reference is None:
        x_ref, u_ref = dyn.forward(x0a, np.zeros((N + 1, n)), u0, zeros_k, zeros_K, 0.0, lo, hi)
        if not np.all(np.isfinite(x_ref)):
            raise ValueError("u_init: the initial trajectory diverges (NaN or inf states)")
    else:
        if not isinstance(reference, (tuple, list)) or len(reference) != 2:
            raise TypeError(
                "reference: expected a pair (x_ref (N + 1, n), u_ref (N, m)), received "
                f"{arrays.describe(reference)}"
            )
        x_ref, u_ref = _trajectory(
            reference[0], reference[1], N, n, m, "reference[0]", "reference[1]"
        )
    problem = _Problem(cost, N, n, m, x_ref, u_ref, wx, wu)
    opts = {"max_iter": max_iter, "tol": tol, "mu_init": 0.0}

    sol = _solve(problem, dyn, x0a, u0, lo, hi, **opts)
    solves, total_it = 1, sol.iterations
    eta = 0.0
    if radius is not None and problem.deviation(sol.x, sol.u) > radius:
        sol, eta, solves, total_it = _trust_bisection(
            problem, dyn, x0a, u0, lo, hi, radius, sol, opts, total_it
        )
    problem.eta = eta
    return ILQGResult(
        x=sol.x,
        u=sol.u,
        K=sol.K,
        cost=problem.base_cost(sol.x, sol.u),
        objective=sol.objective,
        cost_trace=np.array(sol.trace),
        iterations=sol.iterations,
        converged=sol.converged,
        eta=eta,
        deviation=problem.deviation(sol.x, sol.u),
        lower=lo,
        upper=hi,
        info={"total_iterations": total_it, "solves": solves, "mu": sol.mu, "trust_region": radius},
    )


def _trust_bisection(problem, dyn, x0, u0, lo, hi, radius, sol0, opts, total_it):
    """Smallest η (to a relative 5 % of the radius) whose solution lies in the trust region."""
    scale = max(abs(sol0.objective), 1.0) / max(problem.penalty(sol0.x, sol0.u), 1e-300)
    eta_lo, eta = 0.0, scale
    best, best_eta = None, None
    solves = 1
    start = u0
    for _ in range(16):  # grow η (16 decades) until the bound holds
        problem.eta = eta
        sol = _solve(problem, dyn, x0, start, lo, hi, **opts)
        solves += 1
        total_it += sol.iterations
        if problem.deviation(sol.x, sol.u) <= radius:
            best, best_eta = sol, eta
            break
        eta_lo = eta
        eta *= 10.0
    if best is None:
        problem.eta = eta
        warn(
            f"ilqg: the trust region of radius {radius:g} could not be met (deviation "
            f"{problem.deviation(sol.x, sol.u):.3g} at eta={eta:.3g}); is the reference "
            "reachable from x0 under the dynamics?",
            ConvergenceWarning,
        )
        return sol, eta, solves, total_it
    for _ in range(30):  # bisect (geometrically) on η
        dev = problem.deviation(best.x, best.u)
        if dev >= 0.95 * radius:
            break
        eta = math.sqrt(eta_lo * best_eta) if eta_lo > 0 else best_eta / 10.0
        problem.eta = eta
        sol = _solve(problem, dyn, x0, best.u, lo, hi, **opts)
        solves += 1
        total_it += sol.iterations
        if problem.deviation(sol.x, sol.u) <= radius:
            best, best_eta = sol, eta
        else:
            eta_lo = eta
        if eta_lo > 0 and best_eta / eta_lo < 1.0 + 1e-3:
            break
    return best, best_eta, solves, total_it
