"""Model-based reinforcement learning with LTV models (paper Section VIII, Fig. 4).

A pendulum on a cart starts close to the upright (unstable) equilibrium and
falls; the task is to damp the pendulum's oscillation about the hanging
(stable) equilibrium by moving the cart with a bounded force, under a quadratic
cost on the state and the force over T = 500 steps of 10 ms. The linearizations
at the initial (upright) and final (hanging) states have poles on opposite sides
of the imaginary axis (:meth:`CartPole.continuous_jacobian`), which is why a
single LTI model fails.

Learning iterates, as in guided policy search (Levine & Koltun 2013):

1. roll out the current controller u_t = clip(ū_t + K_t (x_t − x̄_t) + e_t)
   with a small exploration noise e_t on the system;
2. fit a dynamics model along that trajectory;
3. optimize the cost under the model with the box-constrained, trust-region
   iLQG of :func:`ltvmodels.control.ilqg` (the trust region keeps the new
   trajectory close to the one the model was fitted along); its nominal
   trajectory and feedback gains are the next controller.

Models (``MODELS``): ``"true"`` — the simulator's exact Jacobians along the
trajectory; ``"ltv"`` — :func:`ltvmodels.fit` with ``norm="sq"``, ``order=2``
(the paper's smooth problem); ``"lti"`` — :func:`ltvmodels.fit_lti`; ``"prior"`` — the
LTV fit with a Gaussian prior (the paper's maximum a posteriori problem) centred on the true model
linearized along the trajectory. The fitted models are affine (a constant input
column); every model is used as a linearization through the measured trajectory
(:meth:`ltvmodels.control.LinearDynamics.through`), so the models differ only
in their Jacobians A_t, B_t. The trust-region radius adapts between iterations
(see :func:`learn`).

:func:`run_experiment` runs the Monte-Carlo comparison and returns the cost
table; :func:`plot_experiment` draws Fig. 4. The simulator integrates the
equations of motion with a fixed-step Runge–Kutta method (zero-order hold on
the force), checked against :func:`scipy.integrate.solve_ivp`
(``CartPole.simulate(..., method="scipy")``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from ..control import ILQGResult, LinearDynamics, QuadraticCost, ilqg
from ..estimators.mixture_prior import GMMPrior
from ..estimators.priors import Prior
from ..plotting.figure import new_axes
from ..validation import arrays, options
from .learning import (
    adapt_radius,
    draw_learning_curves,
    fit_affine,
    improvement_ratio,
    median_by_model,
    padded_inputs,
    quartiles_by_model,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = [
    "CartPole",
    "CartPoleTask",
    "cartpole_task",
    "learn",
    "LearningResult",
    "optimal_control",
    "run_experiment",
    "RLExperiment",
    "plot_experiment",
    "MODELS",
    "PAPER_MODELS",
    "QUICK_RUNS",
    "QUICK_ITERATIONS",
]

MODELS = ("true", "ltv", "lti", "prior", "learned")
"""Model kinds of the experiment: the paper's four, in the order of its legend, and the
LTV model with the prior learned from the earlier rollouts (needs scikit-learn)."""
PAPER_MODELS = MODELS[:4]

LEARNED_SAMPLES = None
"""How many transitions the learned prior counts as at most (``GMMPrior.at``'s max_samples)."""

LEARNED_AFTER = 3
"""Rollouts the mixture must have seen before the learned prior is used."""

MODEL_LABELS = {
    "true": "True model",
    "ltv": "LTV model",
    "lti": "LTI model",
    "prior": "LTV with prior",
    "learned": "LTV + learned prior",
}


# -- the simulator --------------------------------------------------------------------
@numba.njit(cache=True)
def _deriv(x, F, par):  # pragma: no cover - compiled
    """ẋ and its Jacobians (∂ẋ/∂x (4, 4), ∂ẋ/∂F (4,)) of the cart-pole."""
    M, mp, ell, g, bc, bp = par[0], par[1], par[2], par[3], par[4], par[5]
    v, th, w = x[1], x[2], x[3]
    s, c = math.sin(th), math.cos(th)
    # Mass matrix [[M + mp, mp ell c], [mp ell c, mp ell²]] a = r.
    r1 = F - bc * v + mp * ell * w * w * s
    r2 = -mp * g * ell * s - bp * w
    det = mp * ell * ell * (M + mp * s * s)
    i11, i12, i22 = mp * ell * ell / det, -mp * ell * c / det, (M + mp) / det
    pdd = i11 * r1 + i12 * r2
    tdd = i12 * r1 + i22 * r2
    xd = np.array([v, pdd, w, tdd])
    # ∂a/∂z = M⁻¹ (∂r/∂z − (∂M/∂θ) a δ_zθ), ∂M/∂θ = [[0, −mp ell s], [−mp ell s, 0]].
    d1 = np.array([0.0, -bc, mp * ell * w * w * c + mp * ell * s * tdd, 2.0 * mp * ell * w * s])
    d2 = np.array([0.0, 0.0, -mp * g * ell * c + mp * ell * s * pdd, -bp])
    J = np.zeros((4, 4))
    J[0, 1] = 1.0
    J[2, 3] = 1.0
    # Element by element: an array assignment (J[1] = i11 * d1 + i12 * d2) makes
    # numba compile its shape-mismatch error message, ~2 s on first use.
    for a in range(4):
        J[1, a] = i11 * d1[a] + i12 * d2[a]
        J[3, a] = i12 * d1[a] + i22 * d2[a]
    b = np.array([0.0, i11, 0.0, i12])
    return xd, J, b


@numba.njit(cache=True, inline="always")
def _rk4(x, F, par, h, substeps, with_jacobian):  # pragma: no cover - compiled
    """One sampling interval (force held constant) by RK4, with the exact Jacobian of the map.

    Inlined with a constant ``with_jacobian`` into the kernels below: passed to a
    compiled function, the constants True and False are types of their own, each
    compiled separately (and a third time for a flag from Python).
    """
    dt = h / substeps
    Phi = np.eye(4)
    Gam = np.zeros(4)
    for _ in range(substeps):
        k1, J1, b1 = _deriv(x, F, par)
        x2 = x + 0.5 * dt * k1
        k2, J2, b2 = _deriv(x2, F, par)
        x3 = x + 0.5 * dt * k2
        k3, J3, b3 = _deriv(x3, F, par)
        x4 = x + dt * k3
        k4, J4, b4 = _deriv(x4, F, par)
        if with_jacobian:
            dP1 = J1 @ Phi
            dG1 = J1 @ Gam + b1
            dP2 = J2 @ (Phi + 0.5 * dt * dP1)
            dG2 = J2 @ (Gam + 0.5 * dt * dG1) + b2
            dP3 = J3 @ (Phi + 0.5 * dt * dP2)
            dG3 = J3 @ (Gam + 0.5 * dt * dG2) + b3
            dP4 = J4 @ (Phi + dt * dP3)
            dG4 = J4 @ (Gam + dt * dG3) + b4
            Phi = Phi + dt / 6.0 * (dP1 + 2.0 * dP2 + 2.0 * dP3 + dP4)
            Gam = Gam + dt / 6.0 * (dG1 + 2.0 * dG2 + 2.0 * dG3 + dG4)
        x = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x, Phi, Gam


@numba.njit(cache=True)
def _rk4_step(x, F, par, h, substeps):  # pragma: no cover - compiled
    """The state one sampling interval later (:func:`_rk4`)."""
    return _rk4(x, F, par, h, substeps, False)[0]


@numba.njit(cache=True)
def _rk4_jacobian(x, F, par, h, substeps):  # pragma: no cover - compiled
    """(next state, Φ (4, 4), Γ (4,)): :func:`_rk4` with the Jacobians of the map."""
    return _rk4(x, F, par, h, substeps, True)


@numba.njit(cache=True)
def _linearize(x, u, par, h, substeps):  # pragma: no cover - compiled
    N = u.shape[0]
    A = np.empty((N, 4, 4))
    B = np.empty((N, 4, 1))
    for t in range(N):
        _, Phi, Gam = _rk4(x[t], u[t, 0], par, h, substeps, True)
        for i in range(4):  # element by element: see _deriv
            for j in range(4):
                A[t, i, j] = Phi[i, j]
            B[t, i, 0] = Gam[i]
    return A, B


@numba.njit(cache=True)
def _closed_loop(x0, x_nom, u_nom, K, noise, lo, hi, par, h, substeps):  # pragma: no cover
    """u_t = clip(ū_t + K_t (x_t − x̄_t) + e_t, lo, hi) applied to the cart-pole."""
    N = u_nom.shape[0]
    x = np.empty((N + 1, 4))
    u = np.empty((N, 1))
    for j in range(4):  # element by element: see _deriv
        x[0, j] = x0[j]
    for t in range(N):
        v = u_nom[t, 0] + noise[t]
        for j in range(4):
            v += K[t, 0, j] * (x[t, j] - x_nom[t, j])
        v = min(max(v, lo), hi)
        u[t, 0] = v
        xn, _, _ = _rk4(x[t], v, par, h, substeps, False)
        for j in range(4):
            x[t + 1, j] = xn[j]
    return x, u


def _positive(value: Any, name: str) -> float:
    return options.positive_scalar(value, name)


@dataclass(frozen=True)
class CartPole:
    """A pendulum on a cart driven by a bounded horizontal force.

    State x = (p, v, θ, ω): cart position [m] and velocity [m/s], pole angle
    [rad] from the hanging position (θ = π is upright) and angular velocity
    [rad/s]; input u = (F,), the force on the cart [N], abs(F) <= ``force_limit``.
    The pole is a point mass ``pole_mass`` at distance ``length`` from the
    pivot:

        (M + m) p̈ + m l cos θ θ̈ = F − b_c v + m l ω² sin θ
        m l cos θ p̈ + m l² θ̈ = −m g l sin θ − b_p ω

    Discretized with the force held constant over each sampling interval
    ``dt``, integrated by ``substeps`` classical Runge–Kutta steps.
    """

    cart_mass: float = 1.0
    pole_mass: float = 0.2
    length: float = 0.35
    gravity: float = 9.81
    cart_friction: float = 0.0
    pole_damping: float = 0.01
    dt: float = 0.01
    substeps: int = 2
    force_limit: float = 3.0

    def __post_init__(self) -> None:
        for name in ("cart_mass", "pole_mass", "length", "gravity", "dt", "force_limit"):
            _positive(getattr(self, name), name)
        for name in ("cart_friction", "pole_damping"):
            options.nonnegative_scalar(getattr(self, name), name)
        options.integer(self.substeps, "substeps", 1)

    @property
    def _par(self) -> np.ndarray:
        return np.array(
            [
                self.cart_mass,
                self.pole_mass,
                self.length,
                self.gravity,
                self.cart_friction,
                self.pole_damping,
            ],
            dtype=float,
        )

    def _state(self, x: Any, name: str = "x") -> np.ndarray:
        return arrays.vector(x, name, 4)

    def _force(self, u: Any, name: str = "u") -> float:
        arr = arrays.as_float_array(u, name)
        if arr.size != 1:
            raise ValueError(
                f"{name}: expected one force (a scalar or shape (1,)), received shape {arr.shape}"
            )
        return float(arr.reshape(()))

    def derivative(self, x: Any, u: Any) -> np.ndarray:
        """Continuous-time ẋ = f(x, F), shape (4,)."""
        xd, _, _ = _deriv(self._state(x), self._force(u), self._par)
        return xd

    def continuous_jacobian(self, x: Any, u: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """∂f/∂x (4, 4) and ∂f/∂F (4, 1) of the continuous-time dynamics at (x, F)."""
        _, J, b = _deriv(self._state(x), self._force(u), self._par)
        return J, b[:, None]

    def step(self, x: Any, u: Any) -> np.ndarray:
        """The state one sampling interval later, shape (4,) (the force is not clipped)."""
        return _rk4_step(
            self._state(x), self._force(u), self._par, float(self.dt), int(self.substeps)
        )

    def jacobian(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """Exact Jacobians (A (4, 4), B (4, 1)) of :meth:`step` at (x, u)."""
        _, Phi, Gam = _rk4_jacobian(
            self._state(x), self._force(u), self._par, float(self.dt), int(self.substeps)
        )
        return Phi, Gam[:, None]

    def linearize(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """Jacobians of :meth:`step` along a trajectory: A (N, 4, 4), B (N, 4, 1).

        x has shape (N + 1, 4) or (N, 4) and u shape (N, 1) or (N,).
        """
        xs = arrays.as_time_series(x, "x", allow_1d=False)
        us = arrays.as_time_series(u, "u")
        N = us.shape[0]
        if xs.shape[1] != 4 or xs.shape[0] not in (N, N + 1) or us.shape[1] != 1:
            raise ValueError(
                f"x, u: expected shapes ({N} or {N + 1}, 4) and ({N}, 1), received "
                f"{xs.shape} and {us.shape}"
            )
        return _linearize(xs, us, self._par, float(self.dt), int(self.substeps))

    def simulate(self, x0: Any, u: Any, *, method: str = "rk4") -> np.ndarray:
        """Open-loop simulation: states (N + 1, 4) from x0 under forces u (N, 1).

        ``method="rk4"`` uses the discretization of :meth:`step`;
        ``method="scipy"`` integrates each interval with
        :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-10): slower, used as
        an independent reference.
        """
        x = self._state(x0, "x0")
        us = arrays.as_time_series(u, "u")
        if us.shape[1] != 1:
            raise ValueError(f"u: expected shape (N, 1) or (N,), received {us.shape}")
        method = options.choice(method, "method", ("rk4", "scipy"))
        out = np.empty((us.shape[0] + 1, 4))
        out[0] = x
        if method == "rk4":
            for t in range(us.shape[0]):
                out[t + 1] = self.step(out[t], us[t])
            return out
        from scipy.integrate import solve_ivp

        par = self._par
        for t in range(us.shape[0]):
            F = float(us[t, 0])
            sol = solve_ivp(
                lambda _s, y, F=F: _deriv(y, F, par)[0],
                (0.0, float(self.dt)),
                out[t],
                method="DOP853",
                rtol=1e-10,
                atol=1e-12,
            )
            out[t + 1] = sol.y[:, -1]
        return out

    def rollout(
        self,
        x0: Any,
        x_nom: Any,
        u_nom: Any,
        K: Any = None,
        *,
        noise_std: float = 0.0,
        seed: Any = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Closed-loop rollout of u_t = clip(ū_t + K_t (x_t − x̄_t) + e_t, ±force_limit).

        Parameters
        ----------
        x0 : array_like, shape (4,)
        x_nom : array_like, shape (N + 1, 4)
            Nominal states x̄.
        u_nom : array_like, shape (N, 1) or (N,)
            Nominal forces ū.
        K : array_like, shape (N, 1, 4), optional
            Feedback gains (default 0: open loop).
        noise_std : float
            Standard deviation of the exploration noise e_t ~ N(0, σ²) [N].
        seed : int, numpy.random.Generator or None
            Seeds the exploration noise.

        Returns
        -------
        x : ndarray, shape (N + 1, 4)
        u : ndarray, shape (N, 1)
            The applied (noisy, clipped) forces.
        """
        x0 = self._state(x0, "x0")
        us = arrays.as_time_series(u_nom, "u_nom")
        N = us.shape[0]
        if us.shape[1] != 1:
            raise ValueError(f"u_nom: expected shape ({N}, 1) or ({N},), received {us.shape}")
        xn = arrays.as_float_array(x_nom, "x_nom")
        if xn.shape != (N + 1, 4):
            raise ValueError(f"x_nom: expected shape ({N + 1}, 4), received {xn.shape}")
        Ka = np.zeros((N, 1, 4)) if K is None else arrays.as_float_array(K, "K")
        if Ka.shape != (N, 1, 4):
            raise ValueError(f"K: expected shape ({N}, 1, 4), received {Ka.shape}")
        sigma = options.nonnegative_scalar(noise_std, "noise_std")
        rng = options.random_generator(seed)
        noise = sigma * rng.standard_normal(N) if sigma > 0 else np.zeros(N)
        lim = float(self.force_limit)
        return _closed_loop(
            x0, xn, us, Ka, noise, -lim, lim, self._par, float(self.dt), int(self.substeps)
        )


# -- the task ---------------------------------------------------------------------------
@dataclass
class CartPoleTask:
    """The learning task of paper Section VIII.

    Attributes
    ----------
    system : CartPole
    x0 : ndarray, shape (4,)
        Initial state (pole close to upright, at rest).
    cost : QuadraticCost
        Σ_t (x_tᵀ Q x_t + r F_t²) + x_Nᵀ Q x_N towards the hanging rest state 0.
    horizon : int
        N, the number of control steps.
    trust_weights : (ndarray (4,), ndarray (1,))
        Scaling of the trust-region norm: 1/s² with s the typical size of
        each state and the force limit.
    """

    system: CartPole
    x0: np.ndarray
    cost: QuadraticCost
    horizon: int
    trust_weights: tuple[np.ndarray, np.ndarray]

    @property
    def bounds(self) -> tuple[float, float]:
        """Force bounds (lower, upper)."""
        lim = float(self.system.force_limit)
        return -lim, lim

    def trajectory_cost(self, x: np.ndarray, u: np.ndarray) -> float:
        """The cost J of a trajectory x (N + 1, 4), u (N, 1)."""
        return float(np.sum(self.cost.stage_costs(x, u)))


def cartpole_task(
    *,
    horizon: int = 500,
    initial_angle: float = math.pi - 0.2,
    system: CartPole | None = None,
) -> CartPoleTask:
    """The cart-pole damping task: start near upright at rest, damp the swing.

    The cost is J = Σ_{t<T} (x_tᵀ Q x_t + r F_t²) + x_Tᵀ Q x_T with
    Q = dt·diag(1, 0.1, 10, 0.1) and r = 0.1·dt (the target is the hanging rest
    state x = 0); the force is bounded by ``system.force_limit``.

    Parameters
    ----------
    horizon : int
        Number of control steps T (500 in the paper).
    initial_angle : float
        θ_0 in radians (π is upright).
    system : CartPole, optional
        Default: ``CartPole()``.

    Returns
    -------
    CartPoleTask
    """
    horizon = options.integer(horizon, "horizon", 2)
    theta0 = arrays.as_float_array(initial_angle, "initial_angle")
    if theta0.ndim != 0:
        raise ValueError(f"initial_angle: expected a scalar, received shape {theta0.shape}")
    if system is None:
        system = CartPole()
    elif not isinstance(system, CartPole):
        raise TypeError(f"system: expected a CartPole, received {type(system).__name__}")
    dt = float(system.dt)
    Q = dt * np.diag([1.0, 0.1, 10.0, 0.1])
    R = dt * np.array([[0.1]])
    cost = QuadraticCost(Q, R, horizon)
    scales = np.array([0.5, 1.0, 1.0, 5.0])
    wx = 1.0 / scales**2
    wu = np.array([1.0 / float(system.force_limit) ** 2])
    x0 = np.array([0.0, 0.0, float(theta0), 0.0])
    return CartPoleTask(system=system, x0=x0, cost=cost, horizon=horizon, trust_weights=(wx, wu))


# -- learning -------------------------------------------------------------------------------
@dataclass
class LearningResult:
    """Result of :func:`learn`.

    Attributes
    ----------
    costs : ndarray, shape (iterations,)
        Cost J of the rollout at each learning iteration (iteration 1 is the
        initial zero-force controller).
    predicted : ndarray, shape (iterations − 1,)
        Cost of each new controller's nominal trajectory predicted by the model.
    radii : ndarray, shape (iterations − 1,)
        Trust-region radius of each optimization.
    controller : ILQGResult or None
        The last optimized controller (None for a single iteration).
    x, u : ndarray
        The last rollout, shapes (N + 1, 4) and (N, 1).
    """

    costs: np.ndarray
    predicted: np.ndarray
    radii: np.ndarray
    controller: ILQGResult | None
    x: np.ndarray
    u: np.ndarray


def _model_kind(model: Any) -> str:
    """One of ``MODELS``."""
    if not isinstance(model, str) or model not in MODELS:
        raise ValueError(f"model: expected one of {MODELS}, received {arrays.describe(model)}")
    return model


def _model_list(models: Any) -> tuple[str, ...]:
    """A non-empty sequence of distinct names from ``MODELS``."""
    if isinstance(models, str) or not isinstance(models, Sequence) or len(models) == 0:
        raise TypeError(
            f"models: expected a non-empty sequence of names from {MODELS}, received "
            f"{arrays.describe(models)}"
        )
    out = tuple(_model_kind(m) for m in models)
    if len(set(out)) != len(out):
        raise ValueError(f"models: expected distinct names, received {list(models)}")
    return out


def _optional_positive(value: Any, name: str) -> float | None:
    """None, or a finite real number > 0."""
    return None if value is None else options.positive_scalar(value, name)


def _fit_jacobians(
    kind: str,
    task: CartPoleTask,
    x: np.ndarray,
    u: np.ndarray,
    lam: float,
    prior_std: float,
    weak_prior_std: float | None,
    learned: GMMPrior | None = None,
    learned_samples: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians A (N, 4, 4), B (N, 4, 1) of the chosen model along the rollout (x, u)."""
    N = u.shape[0]
    if kind == "true":
        return task.system.linearize(x, u)
    priors = []
    if kind in ("ltv", "learned") and weak_prior_std is not None:  # persistence x_{t+1} = x_t
        mean = np.hstack([np.eye(4), np.zeros((4, 2))]).ravel()
        priors.append(Prior(mean, weak_prior_std**2))
    if kind == "prior":  # the true model linearized along the rollout
        A, B = task.system.linearize(x, u)
        c = x[1:] - np.einsum("tij,tj->ti", A, x[:-1]) - B[:, :, 0] * u
        means = np.concatenate([A, B, c[:, :, None]], axis=2).reshape(N, -1)
        priors = [Prior(means, prior_std**2)]
    if kind == "learned" and learned is not None:  # the mixture of the earlier rollouts
        priors.append(learned.at(x, padded_inputs(u), constant=True, max_samples=learned_samples))
    return fit_affine("ltv" if kind == "learned" else kind, x, u, lam, priors)


def learn(
    task: CartPoleTask,
    model: str = "ltv",
    *,
    iterations: int = 14,
    seed: Any = 0,
    lam: float = 1.0,
    trust_region: float = 1.5,
    max_trust_region: float = 8.0,
    adapt_trust_region: bool = True,
    noise_std: float = 0.3,
    prior_std: float = 0.01,
    weak_prior_std: float | None = 0.3,
    learned_samples: float | None = LEARNED_SAMPLES,
    learned_after: int = LEARNED_AFTER,
) -> LearningResult:
    """Model-based learning of the cart-pole task (paper Section VIII).

    Each iteration rolls out the current controller with exploration noise,
    fits the ``model`` along the rollout (x, u), and re-optimizes the
    controller under it with :func:`ltvmodels.control.ilqg`: force bounds, and a
    trust region of radius ε around the rollout in the norm of
    ``task.trust_weights``. The model is used as the linearization
    x_{t+1} ≈ x_{t+1}^roll + A_t (x_t − x_t^roll) + B_t (u_t − u_t^roll)
    (:meth:`~ltvmodels.control.LinearDynamics.through`).

    With ``adapt_trust_region`` the radius follows a trust-region rule after
    each rollout, with ρ = (actual cost decrease) / (decrease predicted by the
    model) and d = max_t ‖x_t − x_t^prev‖ the realized change of the states:
    ρ < 0.1 halves ε; otherwise d > 1.5 ε (the model mispredicted the size of
    its step) shrinks ε to max(ε/4, ε²/d); otherwise ρ > 0.5 triples ε (at most
    ``max_trust_region``). The optimization starts from, and the trust region
    is centred on, the rollout's states and the controller's noise-free output
    at them (so that the exploration noise does not accumulate in the nominal
    controls); ε is kept at least twice the distance the model predicts
    between those controls' trajectory and the rollout.

    Parameters
    ----------
    task : CartPoleTask
        From :func:`cartpole_task`.
    model : {"true", "ltv", "lti", "prior", "learned"}
        "true": the simulator's Jacobians along the rollout; "ltv":
        :func:`ltvmodels.fit` with ``norm="sq"``, ``order=2`` (the paper's smooth problem)
        and a constant input column; "lti": :func:`ltvmodels.fit_lti` with a
        constant input column; "prior": the LTV fit with the prior
        N(true linearization along the rollout, ``prior_std``² I) (paper eq.
        prioropt); "learned": the "ltv" fit with, in addition, the prior of a
        Gaussian mixture of the earlier rollouts' transitions
        (:class:`ltvmodels.GMMPrior`, ``at(x, u, constant=True)``; nothing from the
        true model), once the mixture holds ``learned_after`` rollouts.
    iterations : int
        Number of rollouts (the first uses the initial zero-force controller).
    seed : int, numpy.random.Generator or None
        Seeds the exploration noise.
    lam : float
        λ of the LTV fits.
    trust_region : float
        Initial trust-region radius ε.
    max_trust_region : float
        Largest radius the adaptation may reach.
    adapt_trust_region : bool
        Adapt ε between iterations (else it stays fixed).
    noise_std : float
        Standard deviation [N] of the exploration noise on the force.
    prior_std : float
        Prior standard deviation of each coefficient for ``model="prior"``.
    weak_prior_std : float or None
        For ``model="ltv"``: standard deviation of a weak prior centred on the
        persistence model x_{t+1} = x_t (A = I, B = 0). From one trajectory the
        cart-position column of A_t is nearly collinear with the constant
        column; this prior settles such directions that neither the data nor
        the smoothness penalty determine. None: no prior.
    learned_samples : float or None
        For ``model="learned"``: ``max_samples`` of the mixture's prior (None:
        the components' own transition counts).
    learned_after : int
        For ``model="learned"``: rollouts the mixture must hold before its
        prior is used (the fits before are those of "ltv"). Fitted along one
        or two falls, a component's Jacobians across the trajectory are
        confounded with its curvature (see the user guide's page on model-based RL).

    Returns
    -------
    LearningResult
        Rollout costs per iteration and the last controller.
    """
    if not isinstance(task, CartPoleTask):
        raise TypeError(f"task: expected a CartPoleTask, received {arrays.describe(task)}")
    kind = _model_kind(model)
    iterations = options.integer(iterations, "iterations", 1)
    lam = options.positive_scalar(lam, "lam")
    radius = options.positive_scalar(trust_region, "trust_region")
    max_radius = options.positive_scalar(max_trust_region, "max_trust_region")
    if not isinstance(adapt_trust_region, bool):
        raise TypeError(
            f"adapt_trust_region: expected True or False, received "
            f"{arrays.describe(adapt_trust_region)}"
        )
    noise_std = options.nonnegative_scalar(noise_std, "noise_std")
    prior_std = options.positive_scalar(prior_std, "prior_std")
    weak_prior_std = _optional_positive(weak_prior_std, "weak_prior_std")
    learned_samples = _optional_positive(learned_samples, "learned_samples")
    learned_after = options.integer(learned_after, "learned_after", 1)
    rng = options.random_generator(seed)
    N = task.horizon
    wx = task.trust_weights[0]
    x_nom = np.tile(task.x0, (N + 1, 1))
    u_nom = np.zeros((N, 1))
    K = np.zeros((N, 1, 4))
    costs: list[float] = []
    predicted: list[float] = []
    radii: list[float] = []
    controller = None
    x_prev = None
    learned: GMMPrior | None = None
    for i in range(iterations):
        x, u = task.system.rollout(task.x0, x_nom, u_nom, K, noise_std=noise_std, seed=rng)
        costs.append(task.trajectory_cost(x, u))
        if i == iterations - 1:
            break
        if adapt_trust_region and x_prev is not None:
            rho = improvement_ratio(costs[-2], costs[-1], predicted[-1])
            moved = float(np.sqrt(np.max(np.sum((x - x_prev) ** 2 * wx, axis=1))))
            radius = adapt_radius(radius, rho, max_radius=max_radius, moved=moved)
        x_prev = x
        ready = learned if i >= learned_after else None
        A, B = _fit_jacobians(
            kind, task, x, u, lam, prior_std, weak_prior_std, ready, learned_samples
        )
        if kind == "learned":  # this rollout joins the mixture for the next iterations
            learned = (
                GMMPrior(x, padded_inputs(u), seed=0)
                if learned is None
                else learned.update(x, padded_inputs(u))
            )
        dyn = LinearDynamics.through(A, B, x, u)
        # The controller's noise-free output at the visited states: the exploration noise
        # must not accumulate in the nominal controls from one iteration to the next.
        u_clean = np.clip(u_nom + np.einsum("tij,tj->ti", K, x[:-1] - x_nom[:-1]), *task.bounds)
        # Under the model these controls reproduce the rollout only up to the effect of the
        # noise; the radius never goes below twice that distance (else it cannot be met).
        noise_gap = float(
            np.sqrt(np.max(np.sum((dyn.simulate(x[0], u_clean) - x) ** 2 * wx, axis=1)))
        )
        radius = max(radius, 2.0 * noise_gap)
        controller = ilqg(
            dyn,
            task.cost,
            x[0],
            u_clean,
            u_bounds=task.bounds,
            trust_region=radius,
            reference=(x, u_clean),
            trust_weights=task.trust_weights,
        )
        predicted.append(controller.cost)
        radii.append(radius)
        x_nom, u_nom, K = controller.x, controller.u, controller.K
    return LearningResult(
        costs=np.array(costs),
        predicted=np.array(predicted),
        radii=np.array(radii),
        controller=controller,
        x=x,
        u=u,
    )


def optimal_control(task: CartPoleTask) -> ILQGResult:
    """iLQG on the true nonlinear model from ``task.x0`` (no noise, force bounds).

    The reference cost of the experiment (the dashed line of paper Fig. 4).

    Parameters
    ----------
    task : CartPoleTask
        The system, initial state, horizon and cost (:func:`cartpole_task`).

    Returns
    -------
    ILQGResult
        The optimized trajectory, controls, gains and cost.
    """
    if not isinstance(task, CartPoleTask):
        raise TypeError(f"task: expected a CartPoleTask, received {arrays.describe(task)}")
    sysm = task.system
    par, h, sub = sysm._par, float(sysm.dt), int(sysm.substeps)

    def step(x: np.ndarray, u: np.ndarray, t: int) -> np.ndarray:
        return _rk4_step(x, float(u[0]), par, h, sub)

    def jacobian(x: np.ndarray, u: np.ndarray, t: int) -> tuple[np.ndarray, np.ndarray]:
        _, Phi, Gam = _rk4_jacobian(x, float(u[0]), par, h, sub)
        return Phi, Gam[:, None]

    return ilqg(
        step,
        task.cost,
        task.x0,
        np.zeros((task.horizon, 1)),
        jacobian=jacobian,
        u_bounds=task.bounds,
    )


# -- the Monte-Carlo experiment -------------------------------------------------------------
QUICK_RUNS = 3
QUICK_ITERATIONS = 8


@dataclass
class RLExperiment:
    """Result of :func:`run_experiment` (paper Fig. 4).

    Attributes
    ----------
    costs : dict[str, ndarray]
        For each model, rollout costs of shape (runs, iterations).
    optimum : float
        Cost of iLQG on the true nonlinear model (:func:`optimal_control`).
    models : tuple[str, ...]
    runs, iterations, seed : int
    quick : bool
    elapsed : float
        Wall time of the experiment [s].
    settings : dict
        The keyword arguments given to :func:`learn`.
    """

    costs: dict
    optimum: float
    models: tuple
    runs: int
    iterations: int
    seed: int
    quick: bool
    elapsed: float
    settings: dict = field(default_factory=dict)

    def median(self) -> dict:
        """Median cost per iteration for each model, arrays of shape (iterations,)."""
        return median_by_model(self.costs)

    def quartiles(self) -> dict:
        """(25 %, 75 %) quantiles per iteration for each model, shape (2, iterations)."""
        return quartiles_by_model(self.costs)

    def table(self) -> str:
        """The median cost per iteration as a text table."""
        med = self.median()
        names = [MODEL_LABELS[m] for m in self.models]
        width = max(14, *(len(n) + 2 for n in names))
        lines = ["iteration" + "".join(f"{n:>{width}}" for n in names)]
        for i in range(self.iterations):
            lines.append(f"{i + 1:>9d}" + "".join(f"{med[m][i]:>{width}.2f}" for m in self.models))
        lines.append(f"optimum (iLQG on the true model): {self.optimum:.2f}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (
            f"RLExperiment(models={self.models}, runs={self.runs}, "
            f"iterations={self.iterations}, optimum={self.optimum:.4g}, "
            f"elapsed={self.elapsed:.1f}s)"
        )


def run_experiment(
    *,
    quick: bool = False,
    runs: int | None = None,
    iterations: int | None = None,
    seed: int = 0,
    models: Sequence[str] = MODELS,
    task: CartPoleTask | None = None,
    progress: Callable[[str], None] | None = None,
) -> RLExperiment:
    """Monte-Carlo comparison of the dynamics models (paper Fig. 4).

    For each run, every model learns the task by :func:`learn` with the same
    exploration-noise sequence (common random numbers); run r uses the r-th
    child of ``numpy.random.SeedSequence(seed)``.

    Parameters
    ----------
    quick : bool
        Quick mode: by default 3 runs of 8 iterations (the paper: 20 runs of 14).
    runs : int, optional
        Number of Monte-Carlo runs (default 20, or 3 in quick mode).
    iterations : int, optional
        Learning iterations (default 14, or 8 in quick mode).
    seed : int
        Seed of the experiment (>= 0).
    models : sequence of str
        Subset of ``MODELS``.
    task : CartPoleTask, optional
        Default: :func:`cartpole_task` (T = 500).
    progress : callable, optional
        Called with a line of text after each run.

    Returns
    -------
    RLExperiment
        ``costs[model]`` (runs, iterations), the optimum; ``table()`` and
        :func:`plot_experiment` present them.
    """
    if not isinstance(quick, bool):
        raise TypeError(f"quick: expected True or False, received {arrays.describe(quick)}")
    runs = (QUICK_RUNS if quick else 20) if runs is None else options.integer(runs, "runs", 1)
    iterations = (
        (QUICK_ITERATIONS if quick else 14)
        if iterations is None
        else options.integer(iterations, "iterations", 1)
    )
    seed = options.integer(seed, "seed", 0)
    models = _model_list(models)
    if task is None:
        task = cartpole_task()
    elif not isinstance(task, CartPoleTask):
        raise TypeError(f"task: expected a CartPoleTask, received {arrays.describe(task)}")
    if progress is not None and not callable(progress):
        raise TypeError(
            f"progress: expected a function or None, received {arrays.describe(progress)}"
        )
    start = time.perf_counter()
    optimum = optimal_control(task).cost
    children = np.random.SeedSequence(seed).spawn(runs)
    costs = {m: np.empty((runs, iterations)) for m in models}
    for r, child in enumerate(children):
        for m in models:
            costs[m][r] = learn(
                task, m, iterations=iterations, seed=np.random.default_rng(child)
            ).costs
        if progress is not None:
            last = ", ".join(f"{m} {costs[m][r, -1]:.1f}" for m in models)
            progress(
                f"run {r + 1}/{runs}: final costs {last} ({time.perf_counter() - start:.0f} s)"
            )
    return RLExperiment(
        costs=costs,
        optimum=float(optimum),
        models=models,
        runs=runs,
        iterations=iterations,
        seed=seed,
        quick=quick,
        elapsed=time.perf_counter() - start,
    )


_COLORS = {"ltv": "C0", "lti": "C1", "prior": "C2", "learned": "C3", "true": "0.35"}


def plot_experiment(result: RLExperiment, *, ax: Any = None) -> Figure:
    """Median cost per learning iteration with the inter-quartile band (paper Fig. 4).

    Parameters
    ----------
    result : RLExperiment
        From :func:`run_experiment`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; default: a new figure (no display needed).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(result, RLExperiment):
        raise TypeError(f"result: expected an RLExperiment, received {arrays.describe(result)}")
    if ax is None:
        ax = new_axes((7.0, 4.2))
    fig = ax.figure
    med = result.median()
    draw_learning_curves(ax, result.costs, result.models, _COLORS, MODEL_LABELS)
    ax.axhline(result.optimum, color="k", ls="--", lw=1.2, label="Optimum (true model)")
    first = max(float(np.max([med[m][0] for m in result.models])), result.optimum)
    ax.set_ylim(0.9 * result.optimum, 1.25 * first)
    ax.set_xlim(1, max(result.iterations, 2))
    ax.set_xlabel("Learning iteration")
    ax.set_ylabel("Cost")
    ax.set_title(f"Median over {result.runs} Monte-Carlo runs (band: inter-quartile range)")
    ax.legend(ncol=3, fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.14))
    return fig
