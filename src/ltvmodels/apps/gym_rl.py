"""Model-based reinforcement learning on gymnasium's ``Pendulum-v1`` with LTV vs LTI models.

The loop of :mod:`ltvmodels.apps.rl` on a simulator nobody here wrote: the
pendulum of `gymnasium <https://gymnasium.farama.org>`_ (torque bounded to ±2,
dt = 0.05 s, episodes of 200 steps, reward −(θ_norm² + 0.1 θ̇² + 0.001 u²)) is
only reset and stepped (``env.reset(seed=s)``, ``env.step``); its equations
are never used. Every rollout starts from the same random initial state
(``env.reset(seed=seed)``: θ uniform in [−π, π], θ̇ in [−1, 1]). The torque
limit is too weak to lift the pendulum from hanging: a swing-up must pump
energy. gymnasium is an optional dependency (``pip install "ltvmodels[rl]"``),
imported when a function here needs it.

State and input. The observation is [cos θ, sin θ, θ̇] (θ = 0 upright); the
model state is x = (θ, θ̇) with θ unwrapped along the rollout
(:func:`state_from_observations`, the same as ``np.unwrap(np.arctan2(sin,
cos))``), the input u the applied torque.

Each learning iteration (:func:`learn_pendulum`):

1. rolls out the current controller u_t = clip(ū_t + K_t (x_t − x̄_t), ±2)
   (the angle error wrapped to [−π, π)) R times from the same initial state
   (``rollouts_per_iteration``, default 8): rollout 0 without noise — the
   controller itself, the one evaluated — and rollouts 1 … R − 1 each with
   its own seeded exploration noise e_t ~ N(0, 0.03²) on the torque,
   reflected at the torque bounds (clipped, it would vanish wherever the
   swing saturates the torque, and with it the information on B_t). The
   first controller is a seeded random torque sequence (standard deviation
   0.2), which breaks the symmetry of the hanging rest state;
2. compares the noise-free rollout with the incumbent (the best one so
   far) on the surrogate cost (:class:`PendulumCost`) over the planning
   horizon H: a worse rollout is rejected and the incumbent kept; the
   trust-region radius adapts by :func:`ltvmodels.apps.rl.learn`'s rule
   (ρ = actual / predicted decrease of the surrogate, and the realized change
   of the states over the H planned steps), kept at least ``min_trust_region``;
3. fits a dynamics model on the incumbent's batch of R rollouts, x of shape
   (R, 201, 2) (:func:`fit_rollouts`) — LTV: :func:`ltvmodels.fit`
   (``norm="sq"``, ``order=2``, λ = ``lam``, ``constant=True``); LTI:
   :func:`ltvmodels.fit_lti` (``constant=True``) — both with the same
   transition weights exp(−d²/(2 · 0.3²)), d the distance to the noise-free
   rollout (:func:`locality_weights`: the swing amplifies the noise, and a
   rollout that diverged belongs to another linearization). Its Jacobians
   are the linearization through the incumbent
   (:meth:`ltvmodels.control.LinearDynamics.through`);
4. optimizes the surrogate over the first H steps under the model with
   :func:`ltvmodels.control.ilqg` (torque bounds, trust region around the
   incumbent); the next controller is its nominal trajectory with the
   feedback gains of the model's LQR problem along it (the Riccati gains
   without the torque bounds: box-DDP's gains are zero wherever the plan's
   torque saturates, which leaves a bang-bang swing-up without feedback);
   after step H it regulates to the plan's last state with the plan's last
   gains (``tail="hold"``: a plan that ends balanced upright stays there to
   the end of the episode). H starts at ``horizon_start`` = 10 steps and
   grows by ``horizon_step`` = 5 whenever a rollout is accepted (or the
   radius has shrunk to its minimum), up to the episode: the start of the
   swing is settled before the rest of the episode is planned.

Why several rollouts: along one rollout, each step gives one equation for
the 4 unknowns of each row of [A_t B_t c_t]; the smoothness penalty decides
the rest, and carries the Jacobians of the swing over to where the pendulum
is balanced (and vice versa). Across R rollouts of the same controller the
differences at each step identify them (R >= 4) up to the nonlinearity of
the (deterministic) simulator; the penalty then only has to bridge the steps
where the rollouts coincide (all start from the same state). Hence a small
λ (``lam`` = 0.01): the differences between the rollouts are of the size of
the noise, and a large λ over-smooths them.

Performance is measured with gymnasium's own episode return (the sum of the
env's rewards) of the noise-free rollout, never with the surrogate or the
noisy rollouts. The swing-up criterion (:func:`swung_up`): abs(θ_norm) < 0.3 rad
for the last 40 observations (2 s) of the episode of the final incumbent.
:func:`run_pendulum_experiment` compares the models over several seeds
(``table()``); :func:`plot_pendulum_experiment` draws the learning curves.

Findings (``python examples/gym_pendulum.py``: ``env.reset`` seeds 0 … 19,
40 iterations of 8 episodes, the defaults for both models; about 70 s on
two cores):

=========================================  ==============  ==============
                                           LTV             LTI
=========================================  ==============  ==============
seeds swung up at the end                  20/20           4/20
median iterations to swing-up (for good)   7.5             19.5
median final return                        −123            −907
final return, 25 % / 75 % quantiles        −216 / −117     −1168 / −398
mean final return                          −128            −816
=========================================  ==============  ==============

The LTV model swings up every initial state, with a mean final return of
−128 against gymnasium's usual good return of about −150 (a mean over random
initial states); no run ends with extra turns (starts near upright end at
about 0, starts near hanging at about −220). The LTI model,
fitted on the same rollouts with the same weights, cannot follow the
Jacobians of a swing (∂θ̇⁺/∂θ changes sign between hanging and upright) nor
hold the pendulum with its gains. The settings were tuned on these 20 seeds;
on seeds 20 … 39 (same settings) the LTV model swings up 20/20 (median final
return −119, quartiles −122 / −115), the LTI model 10/20 (−484). Ablations
of the LTV loop (seeds 0 … 19; swung up at the end / median final return):
one rollout per iteration (R = 1) 8/20, −129 (quartiles −877 / −120); R = 4
20/20, −123; λ = 100 (the Jacobians over-smoothed) 12/20, −246;
``tail="zero"`` 17/20, −123; ``tail="incumbent"`` 10/20, −226; no locality
weights, noise 0.1 or horizon step 10: 20/20, −123 to −124. The LTI model
with ``tail="zero"``: 1/20, −247 (quartiles −844 / −131).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from ..control import CostExpansion, LinearDynamics, ilqg
from ..errors import ConvergenceWarning, IdentifiabilityWarning, SingularProblemError
from ..estimators.fit import fit, fit_lti
from ..estimators.mixture_prior import GMMPrior
from ..plotting.figure import new_figure
from ..validation import arrays, options
from .learning import (
    adapt_radius,
    draw_learning_curves,
    improvement_ratio,
    median_by_model,
    padded_inputs,
    quartiles_by_model,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = [
    "make_env",
    "PendulumCost",
    "state_from_observations",
    "swung_up",
    "pendulum_rollout",
    "pendulum_rollouts",
    "fit_rollouts",
    "locality_weights",
    "learn_pendulum",
    "PendulumLearningResult",
    "run_pendulum_experiment",
    "PendulumExperiment",
    "plot_pendulum_experiment",
    "PENDULUM_MODELS",
    "GOOD_RETURN",
    "riccati_gains",
]

ENV_ID = "Pendulum-v1"
EPISODE_STEPS = 200
"""Steps of a Pendulum-v1 episode (truncation by gymnasium's time limit)."""
PENDULUM_MODELS = ("ltv", "lti", "learned")
LEARNED_AFTER = 1
"""Iterations whose rollouts the mixture must hold before the learned prior is used."""
LEARNED_SAMPLES = 5.0
"""How many transitions the learned prior counts as at most per step (``max_samples``):
the 8 rollouts of an iteration identify the Jacobians, the prior only settles the rest."""
MODEL_LABELS = {"ltv": "LTV model", "lti": "LTI model", "learned": "LTV + learned prior"}
GOOD_RETURN = -150.0
"""gymnasium's usual good Pendulum-v1 return (a mean over random initial states)."""
DEFAULT_ROLLOUTS = 8
"""Rollouts per learning iteration of :func:`learn_pendulum` (R)."""
SWING_UP_ANGLE = 0.3
SWING_UP_STEPS = 40
# Trust-region norm: typical sizes of θ [rad], θ̇ [rad/s] and the torque.
_STATE_SCALES = np.array([1.0, 4.0])
_TORQUE_SCALE = 2.0


def _gymnasium() -> Any:
    """The gymnasium module, or an ImportError that says how to install it."""
    try:
        import gymnasium
    except ImportError as exc:  # pragma: no cover - exercised without gymnasium only
        raise ImportError(
            "ltvmodels.apps.gym_rl needs gymnasium >= 1.0: install ltvmodels[rl] "
            "(pip install 'ltvmodels[rl]')"
        ) from exc
    return gymnasium


def make_env() -> Any:
    """A new ``gymnasium.make("Pendulum-v1")`` environment.

    Returns
    -------
    gymnasium.Env
        Needs gymnasium (``pip install "ltvmodels[rl]"``); ImportError without it.
    """
    return _gymnasium().make(ENV_ID)


_Angle = TypeVar("_Angle", np.ndarray, float)


def _wrap(angle: _Angle) -> _Angle:
    """Angle(s) wrapped to [−π, π)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


# -- state, criterion and cost -------------------------------------------------------------
def state_from_observations(obs: Any) -> np.ndarray:
    """States x = (θ, θ̇) from Pendulum observations [cos θ, sin θ, θ̇].

    θ = ``np.unwrap(np.arctan2(sin θ, cos θ))``: continuous along the
    sequence (consecutive observations are assumed less than π apart, as
    abs(θ̇) <= 8 rad/s and dt = 0.05 s guarantee), starting in (−π, π].

    Parameters
    ----------
    obs : array_like, shape (T, 3)
        Observations [cos θ, sin θ, θ̇] of consecutive steps.

    Returns
    -------
    ndarray, shape (T, 2)
    """
    arr = arrays.as_time_series(obs, "obs", allow_1d=False)
    if arr.shape[1] != 3:
        raise ValueError(f"obs: expected shape (T, 3) (cos θ, sin θ, θ̇), received {arr.shape}")
    x = np.empty((arr.shape[0], 2))
    x[:, 0] = np.unwrap(np.arctan2(arr[:, 1], arr[:, 0]))
    x[:, 1] = arr[:, 2]
    return x


def swung_up(x: Any, *, angle: float = SWING_UP_ANGLE, steps: int = SWING_UP_STEPS) -> bool:
    """Whether a trajectory ends swung up: abs(θ_norm) < ``angle`` for its last ``steps`` states.

    Parameters
    ----------
    x : array_like, shape (T, 2)
        States (θ, θ̇), θ in radians from upright (any multiple of 2π is upright).
    angle : float
        Largest allowed abs(θ) [rad] after wrapping to [−π, π).
    steps : int
        Number of final states that must be upright (40: the last 2 s of an episode).

    Returns
    -------
    bool
    """
    xs = arrays.as_time_series(x, "x", allow_1d=False)
    if xs.shape[1] != 2:
        raise ValueError(f"x: expected shape (T, 2) (θ, θ̇), received {xs.shape}")
    angle = options.positive_scalar(angle, "angle")
    steps = options.integer(steps, "steps", 1)
    if steps > xs.shape[0]:
        raise ValueError(
            f"steps: expected at most {xs.shape[0]} (the length of x), received {steps}"
        )
    return bool(np.all(np.abs(_wrap(xs[-steps:, 0])) < angle))


class PendulumCost:
    """Smooth periodic surrogate of Pendulum-v1's cost, for :func:`ltvmodels.control.ilqg`.

    For a trajectory x (N + 1, 2), u (N, 1) of any horizon N:

        ℓ_t = w_θ (1 − cos θ_t) + w_v θ̇_t² + w_u u_t²        (t < N)
        ℓ_N = w_θN (1 − cos θ_N) + w_vN θ̇_N²

    Unlike gymnasium's θ_norm², it is smooth at the hanging position. With w_θ
    = 5 (about π²/2, gymnasium's cost at the bottom is π²) the hanging rest
    state is not a local minimum: with w_θ = 2 (gymnasium's curvature at the
    top) the velocity term outweighs the angle term for small swings about
    the bottom and the optimizer stays there.

    The second derivative of w_θ (1 − cos θ) is w_θ cos θ, negative below the
    horizontal; :meth:`quadratize` uses a positive semidefinite approximation:
    ``hessian="clipped"`` w_θ max(cos θ, 0), or ``hessian="gauss-newton"``
    w_θ (the Gauss–Newton Hessian of the residuals sin θ and 1 − cos θ, whose
    squares sum to 2 (1 − cos θ); it treats the bottom as a minimum).

    Parameters
    ----------
    angle_weight, velocity_weight, torque_weight : float
        w_θ, w_v, w_u (defaults 5, 0.1 and gymnasium's 0.001).
    terminal_angle_weight, terminal_velocity_weight : float
        w_θN, w_vN: the cost of the last state of a (possibly truncated) horizon.
    hessian : {"clipped", "gauss-newton"}
    """

    n = 2
    m = 1

    def __init__(
        self,
        *,
        angle_weight: float = 5.0,
        velocity_weight: float = 0.1,
        torque_weight: float = 0.001,
        terminal_angle_weight: float = 10.0,
        terminal_velocity_weight: float = 0.5,
        hessian: str = "clipped",
    ) -> None:
        self.angle_weight = options.positive_scalar(angle_weight, "angle_weight")
        self.velocity_weight = options.nonnegative_scalar(velocity_weight, "velocity_weight")
        self.torque_weight = options.positive_scalar(torque_weight, "torque_weight")
        self.terminal_angle_weight = options.nonnegative_scalar(
            terminal_angle_weight, "terminal_angle_weight"
        )
        self.terminal_velocity_weight = options.nonnegative_scalar(
            terminal_velocity_weight, "terminal_velocity_weight"
        )
        self.hessian = options.choice(hessian, "hessian", ("clipped", "gauss-newton"))

    def __repr__(self) -> str:
        return (
            f"PendulumCost(angle_weight={self.angle_weight:g}, "
            f"velocity_weight={self.velocity_weight:g}, "
            f"torque_weight={self.torque_weight:g}, hessian={self.hessian!r})"
        )

    def _weights(self, T: int) -> tuple[np.ndarray, np.ndarray]:
        wa = np.full(T, self.angle_weight)
        wv = np.full(T, self.velocity_weight)
        wa[-1] = self.terminal_angle_weight
        wv[-1] = self.terminal_velocity_weight
        return wa, wv

    def _check(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        xs = np.asarray(x, dtype=float)
        us = np.asarray(u, dtype=float)
        if xs.ndim != 2 or xs.shape[1] != 2 or xs.shape[0] < 2:
            raise ValueError(f"x: expected shape (N + 1, 2) with N >= 1, received {xs.shape}")
        if us.shape != (xs.shape[0] - 1, 1):
            raise ValueError(f"u: expected shape ({xs.shape[0] - 1}, 1), received {us.shape}")
        return xs, us

    def stage_costs(self, x: Any, u: Any) -> np.ndarray:
        """Costs ℓ_0 … ℓ_{N−1}, ℓ_N of x (N + 1, 2), u (N, 1); shape (N + 1,)."""
        xs, us = self._check(x, u)
        wa, wv = self._weights(xs.shape[0])
        c = wa * (1.0 - np.cos(xs[:, 0])) + wv * xs[:, 1] ** 2
        c[:-1] += self.torque_weight * us[:, 0] ** 2
        return c

    def quadratize(self, x: Any, u: Any) -> CostExpansion:
        """Gradients and positive semidefinite Hessians at (x, u) (see the class docstring)."""
        xs, us = self._check(x, u)
        T, N = xs.shape[0], us.shape[0]
        wa, wv = self._weights(T)
        theta = xs[:, 0]
        lx = np.stack([wa * np.sin(theta), 2.0 * wv * xs[:, 1]], axis=1)
        lxx = np.zeros((T, 2, 2))
        curvature = np.maximum(np.cos(theta), 0.0) if self.hessian == "clipped" else 1.0
        lxx[:, 0, 0] = wa * curvature
        lxx[:, 1, 1] = 2.0 * wv
        return CostExpansion(
            lx=lx,
            lu=2.0 * self.torque_weight * us,
            lxx=lxx,
            luu=np.full((N, 1, 1), 2.0 * self.torque_weight),
            lux=np.zeros((N, 1, 2)),
        )

    def total(self, x: Any, u: Any) -> float:
        """The trajectory cost Σ_t ℓ_t."""
        return float(np.sum(self.stage_costs(x, u)))


# -- rollouts ---------------------------------------------------------------------------------
def _check_env(env: Any) -> Any:
    if env is None:
        return make_env()
    if not (callable(getattr(env, "reset", None)) and callable(getattr(env, "step", None))):
        raise TypeError(
            f"env: expected a gymnasium environment (with reset and step), "
            f"received {arrays.describe(env)}"
        )
    return env


def _torque_limit(env: Any) -> float:
    space = getattr(env, "action_space", None)
    high = getattr(space, "high", None)
    return float(np.asarray(high, dtype=float).reshape(-1)[0]) if high is not None else 2.0


def pendulum_rollout(
    env: Any,
    seed: int,
    u_nom: Any,
    x_nom: Any = None,
    K: Any = None,
    *,
    noise: Any = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One episode of u_t = clip(ū_t + K_t (x_t − x̄_t), ±max torque) ⊕ e_t on a Pendulum env.

    The environment is reset with ``seed`` and stepped until its time limit;
    the states come from the observations only (:func:`state_from_observations`,
    computed online). The angle error θ_t − θ̄_t is wrapped to [−π, π). The
    exploration noise e_t is added to the clipped torque and reflected at the
    bounds (``⊕``: a torque beyond +max becomes 2 max − v), so a saturated
    torque is still perturbed (inward, by abs(e_t)).

    Parameters
    ----------
    env : gymnasium.Env or None
        A Pendulum-v1 environment (``gymnasium.make("Pendulum-v1")``; None:
        a new one).
    seed : int
        Seed of ``env.reset``: the initial state.
    u_nom : array_like, shape (N, 1) or (N,)
        Nominal torques ū (N = 200 for Pendulum-v1).
    x_nom : array_like, shape (N + 1, 2), optional
        Nominal states x̄ (needed with ``K``).
    K : array_like, shape (N, 1, 2), optional
        Feedback gains (default 0: open loop).
    noise : array_like, shape (N,), optional
        Exploration noise e_t (default none), added after clipping and
        reflected at the bounds.

    Returns
    -------
    x : ndarray, shape (N + 1, 2)
        States (θ unwrapped, θ̇).
    u : ndarray, shape (N, 1)
        Applied torques (within the bounds).
    rewards : ndarray, shape (N,)
        The env's rewards; their sum is the episode return.
    """
    env = _check_env(env)
    seed = options.integer(seed, "seed", 0)
    us = arrays.as_time_series(u_nom, "u_nom")
    N = us.shape[0]
    if us.shape[1] != 1:
        raise ValueError(f"u_nom: expected shape (N, 1) or (N,), received {us.shape}")
    if K is None:
        Ka = np.zeros((N, 1, 2))
        xn = np.zeros((N + 1, 2)) if x_nom is None else arrays.as_float_array(x_nom, "x_nom")
    else:
        Ka = arrays.as_float_array(K, "K")
        if x_nom is None:
            raise ValueError("x_nom: the nominal states are needed with feedback gains K")
        xn = arrays.as_float_array(x_nom, "x_nom")
    if xn.shape != (N + 1, 2):
        raise ValueError(f"x_nom: expected shape ({N + 1}, 2), received {xn.shape}")
    if Ka.shape != (N, 1, 2):
        raise ValueError(f"K: expected shape ({N}, 1, 2), received {Ka.shape}")
    e = np.zeros(N) if noise is None else arrays.as_float_array(noise, "noise")
    if e.shape != (N,):
        raise ValueError(f"noise: expected shape ({N},), received {e.shape}")
    limit = _torque_limit(env)
    x = np.empty((N + 1, 2))
    u = np.empty((N, 1))
    rewards = np.empty(N)
    obs, _ = env.reset(seed=seed)
    theta = math.atan2(float(obs[1]), float(obs[0]))
    x[0] = theta, float(obs[2])
    for t in range(N):
        v = us[t, 0] + Ka[t, 0, 0] * _wrap(x[t, 0] - xn[t, 0]) + Ka[t, 0, 1] * (x[t, 1] - xn[t, 1])
        v = min(max(v, -limit), limit) + e[t]
        # Reflected at the bounds rather than clipped: noise on a saturated torque would
        # otherwise vanish, and with it the excitation of B_t along a bang-bang swing.
        if v > limit:
            v = 2.0 * limit - v
        elif v < -limit:
            v = -2.0 * limit - v
        v = min(max(v, -limit), limit)  # only for noise larger than the whole range
        u[t, 0] = v
        obs, reward, terminated, truncated, _ = env.step(np.array([v]))
        # Online unwrapping: the step of the angle, wrapped, added to the previous angle.
        theta += _wrap(math.atan2(float(obs[1]), float(obs[0])) - theta)
        x[t + 1] = theta, float(obs[2])
        rewards[t] = float(reward)
        if (terminated or truncated) and t < N - 1:
            raise ValueError(
                f"u_nom: the episode ended after {t + 1} steps, before the {N} steps of u_nom"
            )
    return x, u, rewards


def pendulum_rollouts(
    env: Any,
    seed: int,
    u_nom: Any,
    x_nom: Any = None,
    K: Any = None,
    *,
    noise: Any,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """R episodes of the same controller from the same initial state, one per noise sequence.

    Rollout r is :func:`pendulum_rollout` with ``noise[r]`` (all reset with
    ``seed``): a row of zeros gives the noise-free rollout.

    Parameters
    ----------
    env, seed, u_nom, x_nom, K
        As in :func:`pendulum_rollout`.
    noise : array_like, shape (R, N)
        Exploration noise of each rollout.

    Returns
    -------
    x : ndarray, shape (R, N + 1, 2)
    u : ndarray, shape (R, N, 1)
    rewards : ndarray, shape (R, N)
    """
    e = arrays.as_float_array(noise, "noise")
    if e.ndim != 2 or e.shape[0] < 1:
        raise ValueError(f"noise: expected shape (R, N) with R >= 1, received {e.shape}")
    # The env is stepped one episode at a time: a loop over rollouts, not over time.
    runs = [pendulum_rollout(env, seed, u_nom, x_nom, K, noise=er) for er in e]
    return tuple(np.stack(parts) for parts in zip(*runs))  # type: ignore[return-value]


def fit_rollouts(
    model: str,
    x: Any,
    u: Any,
    lam: float,
    weights: Any = None,
    learned: GMMPrior | None = None,
    learned_samples: float | None = None,
    measurement_noise: Any = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians A (N, n, n), B (N, n, m) of an affine model fitted on R time-aligned rollouts.

    "ltv": :func:`ltvmodels.fit` (``norm="sq"``, ``order=2``, λ = ``lam``);
    "lti": :func:`ltvmodels.fit_lti`; both with an intercept (``constant=True``:
    x_{t+1} = A_t x_t + B_t u_t + c_t, the offset of the linearization, which
    :meth:`ltvmodels.control.LinearDynamics.through` recomputes along the
    incumbent). A_t, B_t are shared by the rollouts; the data term sums over them.

    Parameters
    ----------
    model : {"ltv", "lti", "learned"}
        "learned": the LTV fit with the prior ``learned.at(x, u, constant=True,
        weights=weights, max_samples=learned_samples)`` (the plain LTV fit when
        ``learned`` is None).
    x : array_like, shape (R, N + 1, n)
        States of the rollouts.
    u : array_like, shape (R, N, m)
        Their inputs.
    lam : float
        λ of the LTV fit.
    weights : array_like, shape (R, N), optional
        Weights >= 0 of the transitions (default 1).
    learned : GMMPrior, optional
        The mixture of earlier transitions, for ``model="learned"``.
    learned_samples : float, optional
        ``max_samples`` of its prior.
    measurement_noise : None, float, array_like or "estimate"
        The recorded states' measurement noise, as in :func:`ltvmodels.fit`
        (None: the states are exact).

    Returns
    -------
    A : ndarray, shape (N, n, n)
    B : ndarray, shape (N, n, m)
    """
    model = _model_name(model)
    xs = arrays.as_float_array(x, "x")
    us = arrays.as_float_array(u, "u")
    if xs.ndim != 3 or us.ndim != 3 or us.shape[:2] != (xs.shape[0], xs.shape[1] - 1):
        raise ValueError(
            f"x, u: expected shapes (R, N + 1, n) and (R, N, m), received {xs.shape} and {us.shape}"
        )
    # fit's data convention has one input row per state sample; the last is never used.
    ua = np.concatenate([us, np.zeros((us.shape[0], 1, us.shape[2]))], axis=1)
    with warnings.catch_warnings():
        # Unexcited directions are expected (all rollouts start from the same state, so the
        # data do not determine A_0); the smoothness penalty (LTV) or the pooling over
        # time (LTI) decides them.
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        if model == "lti":
            fitted = fit_lti(
                xs, ua, constant=True, weights=weights, measurement_noise=measurement_noise
            )
        else:
            prior = None
            if model == "learned" and learned is not None:
                prior = learned.at(
                    xs,
                    padded_inputs(us),
                    constant=True,
                    weights=weights,
                    max_samples=learned_samples,
                )
            fitted = fit(
                xs,
                ua,
                lam=lam,
                norm="sq",
                order=2,
                constant=True,
                compute_cov=False,
                weights=weights,
                prior=prior,
                measurement_noise=measurement_noise,
            )
    return fitted.A, fitted.B


# -- learning -----------------------------------------------------------------------------------
@dataclass
class PendulumLearningResult:
    """Result of :func:`learn_pendulum`.

    Attributes
    ----------
    model : str
        "ltv" or "lti".
    seed : int
    returns : ndarray, shape (iterations,)
        Episode return (sum of gymnasium's rewards) of each iteration's
        noise-free rollout (the controller itself).
    batch_returns : ndarray, shape (iterations, R)
        Returns of all rollouts of each iteration (column 0: the noise-free
        one; the others with exploration noise).
    incumbent_returns : ndarray, shape (iterations,)
        Return of the incumbent (the learned controller's rollout) after each
        iteration; a rejected rollout leaves it unchanged.
    accepted : ndarray of bool, shape (iterations,)
        Whether each noise-free rollout became the incumbent (the first always does).
    swung_up : ndarray of bool, shape (iterations,)
        Whether the incumbent after each iteration meets :func:`swung_up`.
    swing_up_iteration : int or None
        First iteration (1-based; R episodes each) from which on the incumbent
        stays swung up to the last iteration; None if the final incumbent is
        not swung up.
    final_return : float
        The incumbent's return after the last iteration.
    initial_return : float
        Return of the first rollout (the random-torque controller).
    radii, horizons, predicted : ndarray, shape (iterations − 1,)
        Trust-region radius, planning horizon H and the surrogate cost the
        model predicted for each new controller.
    x, u, rewards : ndarray
        The incumbent rollout: (201, 2), (200, 1), (200,).
    elapsed : float
        Wall time [s].
    """

    model: str
    seed: int
    returns: np.ndarray
    batch_returns: np.ndarray
    incumbent_returns: np.ndarray
    accepted: np.ndarray
    swung_up: np.ndarray
    swing_up_iteration: int | None
    final_return: float
    initial_return: float
    radii: np.ndarray
    horizons: np.ndarray
    predicted: np.ndarray
    x: np.ndarray
    u: np.ndarray
    rewards: np.ndarray
    elapsed: float = 0.0

    @property
    def rollouts_per_iteration(self) -> int:
        """R: the episodes of each iteration."""
        return int(self.batch_returns.shape[1])

    def __repr__(self) -> str:
        return (
            f"PendulumLearningResult(model={self.model!r}, seed={self.seed}, "
            f"iterations={self.returns.size}, "
            f"rollouts_per_iteration={self.rollouts_per_iteration}, "
            f"swing_up_iteration={self.swing_up_iteration}, "
            f"final_return={self.final_return:.1f})"
        )


def _model_name(model: Any) -> str:
    return options.choice(model, "model", PENDULUM_MODELS)


def riccati_gains(A: np.ndarray, B: np.ndarray, e: CostExpansion) -> np.ndarray:
    """LQR gains K_t (N, m, n) of the quadratic expansion ``e`` along linear dynamics (A, B).

    The Riccati recursion without control bounds (the gains of the closed loop
    u = ū + K (x − x̄) around the nominal trajectory).

    Parameters
    ----------
    A : ndarray, shape (N, n, n)
        A_t of the dynamics x_{t+1} = A_t x_t + B_t u_t (deviations from the nominal).
    B : ndarray, shape (N, n, m)
        B_t.
    e : ltvmodels.control.CostExpansion
        The cost's second-order expansion at the nominal trajectory.

    Returns
    -------
    ndarray, shape (N, m, n)
        K_t.
    """
    N, n, _ = A.shape
    m = B.shape[2]
    K = np.zeros((N, m, n))
    Vxx = e.lxx[N]
    for t in range(N - 1, -1, -1):
        At, Bt = A[t], B[t]
        VA = Vxx @ At
        Quu = e.luu[t] + Bt.T @ Vxx @ Bt
        Qux = e.lux[t] + Bt.T @ VA
        Kt = -np.linalg.solve(0.5 * (Quu + Quu.T), Qux)
        K[t] = Kt
        Vxx = e.lxx[t] + At.T @ VA + Qux.T @ Kt
        Vxx = 0.5 * (Vxx + Vxx.T)
    return K


def locality_weights(x: Any, scale: float | None) -> np.ndarray | None:
    """Weights of the transitions of R rollouts by their distance to rollout 0.

    w_rt = exp(−d_rt² / (2 s²)), d_rt = ‖((θ^r_t − θ^0_t), (θ̇^r_t − θ̇^0_t)/4)‖
    (the state part of the trust-region norm; θ unwrapped, so a rollout that went
    over the top the other way is far). A linear model at step t is only valid
    near the nominal rollout: the swing amplifies the exploration noise, and
    rollouts that diverged from the nominal would otherwise be fitted by the
    same A_t, B_t.

    Parameters
    ----------
    x : array_like, shape (R, N + 1, 2)
        States of the rollouts; rollout 0 is the nominal (weight 1).
    scale : float or None
        s (> 0); None: no weighting (returns None).

    Returns
    -------
    ndarray, shape (R, N), or None
    """
    if scale is None:
        return None
    xs = arrays.as_float_array(x, "x")
    if xs.ndim != 3 or xs.shape[2] != 2:
        raise ValueError(f"x: expected shape (R, N + 1, 2), received {xs.shape}")
    d2 = np.sum((xs[:, :-1] - xs[0, :-1]) ** 2 / _STATE_SCALES**2, axis=2)
    w = np.exp(-0.5 * d2 / scale**2)
    # Beyond ~15 s the weight is negligible: 0, not a subnormal number fit would reject.
    return np.where(w < 1e-50, 0.0, w)


def learn_pendulum(
    model: str = "ltv",
    *,
    seed: int = 0,
    iterations: int = 40,
    lam: float = 0.01,
    rollouts_per_iteration: int = DEFAULT_ROLLOUTS,
    noise_std: float = 0.03,
    locality: float | None = 0.3,
    initial_torque_std: float = 0.2,
    trust_region: float = 2.0,
    max_trust_region: float = 2.0,
    min_trust_region: float = 0.05,
    horizon_start: int = 10,
    horizon_step: int = 5,
    tail: str = "hold",
    reject_worse: bool = True,
    feedback: str = "riccati",
    cost: PendulumCost | None = None,
    env: Any = None,
    learned_samples: float | None = LEARNED_SAMPLES,
    learned_after: int = LEARNED_AFTER,
    state_noise_std: float = 0.0,
    measurement_noise: Any = None,
) -> PendulumLearningResult:
    """Learn to swing up gymnasium's Pendulum-v1 from batches of rollouts with an LTV or LTI model.

    See the module docstring for the loop. Every rollout starts from
    ``env.reset(seed=seed)``; ``seed`` also seeds the initial random torques
    and the exploration noise (the same for both models).

    Parameters
    ----------
    model : {"ltv", "lti", "learned"}
        "ltv": :func:`ltvmodels.fit` (``norm="sq"``, ``order=2``, λ = ``lam``,
        ``constant=True``); "lti": :func:`ltvmodels.fit_lti` (``constant=True``);
        both on the same batch of rollouts with the same weights (:func:`fit_rollouts`);
        "learned": the "ltv" fit with the prior of a Gaussian mixture of all
        earlier iterations' rollouts (:class:`ltvmodels.GMMPrior`, updated after
        every iteration, accepted or not), once it holds ``learned_after`` iterations.
    seed : int
        Seed (>= 0) of the initial state, the initial torques and the noise.
    iterations : int
        Number of learning iterations, each a batch of ``rollouts_per_iteration``
        episodes of one controller; the first with the initial controller.
    lam : float
        λ of the LTV fits (> 0). The simulator is deterministic: the data term
        holds only the differences between the rollouts (of the size of the
        exploration noise) and the nonlinearity, so λ must be small for the
        fit to follow them; λ = 100 over-smooths the Jacobians (see the module
        docstring).
    rollouts_per_iteration : int
        R (>= 1): episodes per iteration, rollout 0 without noise (the
        controller itself: evaluated, and the candidate incumbent), the others
        with independent exploration noise. R = 1 is the loop without
        exploration. A_t, B_t and c_t have 4 unknowns per state equation, so
        R >= 4 is needed to identify them at each step from the batch alone.
    noise_std : float
        Standard deviation of the exploration noise on the torque of rollouts
        1 … R − 1 (reflected at the torque bounds, see :func:`pendulum_rollout`).
    locality : float or None
        Scale s of the transition weights :func:`locality_weights` (in the
        trust-region norm); None: all transitions weigh 1.
    initial_torque_std : float
        Standard deviation of the initial random torques (clipped to ±2).
    trust_region, max_trust_region, min_trust_region : float
        Initial, largest and smallest trust-region radius in the norm
        ‖(θ, θ̇/4, u/2)‖ (rad, rad/s, torque).
    horizon_start, horizon_step : int
        Planning horizon H of the first optimization and its growth.
    tail : {"hold", "zero", "incumbent"}
        The next controller after the planned H steps: "hold": u_t =
        K_{H−1} (x_t − x̄_H), the LQR feedback of the plan's last step towards
        its last state (a plan that ends balanced upright stays there to the
        end of the episode); "zero": no torque (the pendulum swings freely);
        "incumbent": the incumbent's torques replayed open loop (after a
        changed plan they kick the pendulum off the top).
    reject_worse : bool
        Keep the incumbent when a rollout's surrogate cost is higher (True),
        or always continue from the latest rollout (False, as
        :func:`ltvmodels.apps.rl.learn`).
    feedback : {"riccati", "ilqg"}
        Feedback gains of the controller: the model's LQR gains without torque
        bounds ("riccati"), or box-DDP's gains from :func:`ltvmodels.control.ilqg`
        (zero where the plan's torque saturates).
    cost : PendulumCost, optional
        The surrogate optimized (default ``PendulumCost()``).
    env : gymnasium.Env, optional
        A Pendulum-v1 environment (default ``gymnasium.make("Pendulum-v1")``).
    learned_samples : float or None
        For ``model="learned"``: ``max_samples`` of the mixture's prior (None:
        the components' own transition counts).
    learned_after : int
        For ``model="learned"``: iterations whose rollouts the mixture must hold
        before its prior is used.
    state_noise_std : float
        Standard deviation (>= 0) of Gaussian sensor noise on the recorded states
        the models are fitted on (angle in rad, velocity in rad/s; seeded by
        ``seed`` on a stream of its own); the controller, the incumbent test and
        the returns use the true states. Default 0: exact records.
    measurement_noise : None, float, array_like or "estimate"
        How the fits treat the recorded states (:func:`ltvmodels.fit`): None as
        exact, else by EM with this measurement noise.

    Returns
    -------
    PendulumLearningResult
        Returns per iteration, the swing-up iteration and the final incumbent.
    """
    model = _model_name(model)
    seed = options.integer(seed, "seed", 0)
    iterations = options.integer(iterations, "iterations", 1)
    lam = options.positive_scalar(lam, "lam")
    R = options.integer(rollouts_per_iteration, "rollouts_per_iteration", 1)
    noise_std = options.nonnegative_scalar(noise_std, "noise_std")
    if locality is not None:
        locality = options.positive_scalar(locality, "locality")
    initial_torque_std = options.nonnegative_scalar(initial_torque_std, "initial_torque_std")
    radius = options.positive_scalar(trust_region, "trust_region")
    max_radius = options.positive_scalar(max_trust_region, "max_trust_region")
    min_radius = options.positive_scalar(min_trust_region, "min_trust_region")
    if not min_radius <= radius <= max_radius:
        raise ValueError(
            "trust_region: expected min_trust_region <= trust_region <= max_trust_region, "
            f"received {min_radius:g}, {radius:g}, {max_radius:g}"
        )
    horizon = options.integer(horizon_start, "horizon_start", 2)
    if horizon > EPISODE_STEPS:
        raise ValueError(
            f"horizon_start: expected at most {EPISODE_STEPS} (the episode), received {horizon}"
        )
    horizon_step = options.integer(horizon_step, "horizon_step", 0)
    tail = options.choice(tail, "tail", ("hold", "zero", "incumbent"))
    reject_worse = options.flag(reject_worse, "reject_worse")
    if learned_samples is not None:
        learned_samples = options.positive_scalar(learned_samples, "learned_samples")
    learned_after = options.integer(learned_after, "learned_after", 1)
    feedback = options.choice(feedback, "feedback", ("riccati", "ilqg"))
    if cost is None:
        cost = PendulumCost()
    elif not isinstance(cost, PendulumCost):
        raise TypeError(f"cost: expected a PendulumCost, received {arrays.describe(cost)}")
    env = _check_env(env)

    state_noise_std = options.nonnegative_scalar(state_noise_std, "state_noise_std")
    start = time.perf_counter()
    rng = options.random_generator(seed)
    sensor = np.random.default_rng([int(seed), 1])  # its own stream: the rest is unchanged
    N = EPISODE_STEPS
    limit = _torque_limit(env)
    weights = (1.0 / _STATE_SCALES**2, np.array([1.0 / _TORQUE_SCALE**2]))
    u_nom = np.clip(initial_torque_std * rng.standard_normal((N, 1)), -limit, limit)
    x_nom = np.zeros((N + 1, 2))
    K = np.zeros((N, 1, 2))
    returns: list[float] = []
    batch_returns: list[np.ndarray] = []
    incumbent_returns: list[float] = []
    accepted: list[bool] = []
    swung: list[bool] = []
    radii: list[float] = []
    horizons: list[int] = []
    predicted: list[float] = []
    learned = None  # the mixture of the earlier iterations' rollouts (model "learned")
    inc = None  # the incumbent rollout (x, u, rewards)
    inc_batch = None  # the rollouts of the incumbent's iteration (x, u), the data of the fits
    plan_horizon = horizon
    for i in range(iterations):
        # Rollout 0 is the controller itself (noise-free): it is what is evaluated and
        # what may become the incumbent. The others explore around it, each with its own
        # noise, so that the fit sees several (x_t, u_t) at every t, upright included.
        noise = np.zeros((R, N))
        noise[1:] = noise_std * rng.standard_normal((R - 1, N))
        xb, ub, rb = pendulum_rollouts(env, seed, u_nom, x_nom, K, noise=noise)
        x, u, rewards = xb[0], ub[0], rb[0]
        if state_noise_std > 0:  # what a sensor records of the batch: the fits' data
            xb = xb + state_noise_std * sensor.standard_normal(xb.shape)
        returns.append(float(np.sum(rewards)))
        batch_returns.append(np.sum(rb, axis=1))
        if inc is None or inc_batch is None:  # the first rollout: the first incumbent
            take = True
            inc, inc_batch = (x, u, rewards), (xb, ub)
        else:
            H = plan_horizon
            J_inc = cost.total(inc[0][: H + 1], inc[1][:H])
            J_new = cost.total(x[: H + 1], u[:H])
            rho = improvement_ratio(J_inc, J_new, predicted[-1])
            # The realized change of the states over the planned steps (rl.learn's d).
            moved = float(
                np.sqrt(np.max(np.sum((x[: H + 1] - inc[0][: H + 1]) ** 2 * weights[0], axis=1)))
            )
            radius = adapt_radius(
                radius, rho, max_radius=max_radius, moved=moved, min_radius=min_radius
            )
            take = J_new <= J_inc or not reject_worse
            if take or radius <= min_radius:
                horizon = min(horizon + horizon_step, N)
            if take:
                inc, inc_batch = (x, u, rewards), (xb, ub)
        accepted.append(take)
        incumbent_returns.append(float(np.sum(inc[2])))
        swung.append(swung_up(inc[0]))
        if i == iterations - 1:
            break
        # Plan the first H steps under the model fitted on the incumbent's rollouts,
        # linearized through the incumbent.
        xi, ui = inc[0], inc[1]
        H = plan_horizon = horizon
        plan = None
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            # Not meeting the trust region exactly is expected with poor models; the
            # rejection test handles the consequences.
            warnings.simplefilter("ignore", ConvergenceWarning)
            try:
                A, B = fit_rollouts(
                    model,
                    inc_batch[0],
                    inc_batch[1],
                    lam,
                    locality_weights(inc_batch[0], locality),
                    learned if i >= learned_after else None,
                    learned_samples,
                    measurement_noise,
                )
                dyn = LinearDynamics.through(A[:H], B[:H], xi[: H + 1], ui[:H])
                plan = ilqg(
                    dyn,
                    cost,
                    xi[0],
                    ui[:H],
                    u_bounds=(-limit, limit),
                    trust_region=radius,
                    reference=(xi[: H + 1], ui[:H]),
                    trust_weights=weights,
                )
                gains = (
                    riccati_gains(dyn.A, dyn.B, cost.quadratize(plan.x, plan.u))
                    if feedback == "riccati"
                    else plan.K
                )
                if not (np.isfinite(plan.cost) and np.all(np.isfinite(gains))):
                    plan = None
            except (np.linalg.LinAlgError, SingularProblemError):  # no usable model
                plan = None
        x_nom = xi.copy()
        u_nom = ui.copy()
        K = np.zeros((N, 1, 2))
        if plan is None:  # replay the incumbent; its rollout then decides the radius
            predicted.append(cost.total(xi[: H + 1], ui[:H]))
        else:
            x_nom[: H + 1] = plan.x
            u_nom[:H] = plan.u
            K[:H] = gains
            predicted.append(plan.cost)
        # After step H. The incumbent's torques belong to its own past: replayed after a
        # changed plan they kick a balanced pendulum off the top, and the next extension
        # of H starts from a fall. "hold" regulates to the plan's last state with its last
        # LQR gains (those of the terminal cost), which keeps a plan that ends balanced
        # upright there to the end of the episode; mid-swing, it only pushes towards a
        # state that the later, longer plans replace.
        if tail != "incumbent":
            u_nom[H:] = 0.0
        if tail == "hold" and plan is not None:
            x_nom[H + 1 :] = plan.x[H]
            K[H:] = gains[H - 1]
        radii.append(radius)
        horizons.append(H)
        if model == "learned":  # this iteration's rollouts join the mixture for the next ones
            learned = (
                GMMPrior(xb, padded_inputs(ub), seed=seed)
                if learned is None
                else learned.update(xb, padded_inputs(ub))
            )
    if inc is None:  # iterations >= 1, and the first rollout is always the incumbent
        raise RuntimeError("no rollout became the incumbent")
    swung_arr = np.array(swung, dtype=bool)
    # Swung up for good: the start of the final stretch of swung-up incumbents. An
    # incumbent can be swung up and a later one, better over the planned H steps, fall
    # after them; counting the first swing-up would credit runs that end hanging.
    first = None
    if swung_arr[-1]:
        down = np.flatnonzero(~swung_arr)
        first = int(down[-1]) + 2 if down.size else 1
    return PendulumLearningResult(
        model=model,
        seed=seed,
        returns=np.array(returns),
        batch_returns=np.array(batch_returns),
        incumbent_returns=np.array(incumbent_returns),
        accepted=np.array(accepted, dtype=bool),
        swung_up=swung_arr,
        swing_up_iteration=first,
        final_return=incumbent_returns[-1],
        initial_return=returns[0],
        radii=np.array(radii),
        horizons=np.array(horizons),
        predicted=np.array(predicted),
        x=inc[0],
        u=inc[1],
        rewards=inc[2],
        elapsed=time.perf_counter() - start,
    )


# -- the experiment -------------------------------------------------------------------------------
QUICK_SEEDS = (7, 19)
"""Seeds of the quick experiment (initial states above the horizontal: fast swing-ups)."""
QUICK_ITERATIONS = 20
FULL_SEEDS = 20
FULL_ITERATIONS = 40


@dataclass
class PendulumExperiment:
    """Result of :func:`run_pendulum_experiment`.

    Attributes
    ----------
    returns : dict[str, ndarray]
        For each model, the incumbent's episode return after each iteration,
        shape (runs, iterations).
    rollout_returns : dict[str, ndarray]
        The return of each iteration's noise-free rollout, shape (runs, iterations).
    swing_up : dict[str, list[int or None]]
        Iteration from which each run's incumbent stays swung up (None: the
        final incumbent is not swung up); see
        :attr:`PendulumLearningResult.swing_up_iteration`.
    swung : dict[str, ndarray of bool]
        Whether each run's incumbent is swung up after each iteration, shape
        (runs, iterations).
    final : dict[str, ndarray]
        Final incumbent return of each run, shape (runs,).
    models : tuple[str, ...]
    seeds : tuple[int, ...]
        The ``env.reset`` seed of each run.
    iterations : int
    quick : bool
    elapsed : float
        Wall time [s].
    settings : dict
        Keyword arguments given to :func:`learn_pendulum`.
    rollouts_per_iteration : int
        R: the episodes of each iteration.
    """

    returns: dict
    rollout_returns: dict
    swing_up: dict
    swung: dict
    final: dict
    models: tuple
    seeds: tuple
    iterations: int
    quick: bool
    elapsed: float
    settings: dict = field(default_factory=dict)
    rollouts_per_iteration: int = DEFAULT_ROLLOUTS

    @property
    def runs(self) -> int:
        """Number of runs (seeds) per model."""
        return len(self.seeds)

    def median(self) -> dict:
        """Median incumbent return per iteration for each model, arrays of shape (iterations,)."""
        return median_by_model(self.returns)

    def quartiles(self) -> dict:
        """(25 %, 75 %) quantiles per iteration for each model, shape (2, iterations)."""
        return quartiles_by_model(self.returns)

    def swung_up_count(self) -> dict:
        """Number of runs whose final incumbent is swung up, per model."""
        return {m: sum(s is not None for s in self.swing_up[m]) for m in self.models}

    def median_swing_up_iteration(self) -> dict:
        """Median iteration from which the runs that end swung up stay so (None if none)."""
        out = {}
        for m in self.models:
            its = [s for s in self.swing_up[m] if s is not None]
            out[m] = float(np.median(its)) if its else None
        return out

    def table(self, *, every: int = 5) -> str:
        """Median [25 %, 75 %] of the return per iteration, then the swing-up summary.

        Parameters
        ----------
        every : int
            Show every ``every``-th iteration (and the first and the last).
        """
        every = options.integer(every, "every", 1)
        med, quart = self.median(), self.quartiles()
        width, label = 22, 30
        R = self.rollouts_per_iteration
        lines = [
            f"{ENV_ID}: {self.runs} initial states (seeds), {self.iterations} iterations "
            f"of {R} episode{'s' if R > 1 else ''} each (one without exploration noise: "
            "the controller's return below)",
            "episode return of the learned controller, median [25 %, 75 %]:",
            f"{'iteration':<{label}}" + "".join(f"{MODEL_LABELS[m]:>{width}}" for m in self.models),
        ]
        shown = sorted({0, self.iterations - 1, *range(every - 1, self.iterations, every)})
        for i in shown:
            cells = "".join(
                f"{f'{med[m][i]:.0f} [{quart[m][0, i]:.0f}, {quart[m][1, i]:.0f}]':>{width}}"
                for m in self.models
            )
            lines.append(f"{i + 1:<{label}d}{cells}")
        count, its = self.swung_up_count(), self.median_swing_up_iteration()
        rows = [
            ("seeds swung up at the end", {m: f"{count[m]}/{self.runs}" for m in self.models}),
            (
                "median iterations to swing-up",
                {m: "-" if its[m] is None else f"{its[m]:g}" for m in self.models},
            ),
            ("median final return", {m: f"{np.median(self.final[m]):.0f}" for m in self.models}),
            (
                "final return [25 %, 75 %]",
                {
                    m: "[{:.0f}, {:.0f}]".format(*np.quantile(self.final[m], [0.25, 0.75]))
                    for m in self.models
                },
            ),
            # gymnasium's good return is a mean: this is the number to compare with it.
            ("mean final return", {m: f"{np.mean(self.final[m]):.0f}" for m in self.models}),
        ]
        for name, by_model in rows:
            lines.append(
                f"{name:<{label}}" + "".join(f"{by_model[m]:>{width}}" for m in self.models)
            )
        lines.append(
            f"(swung up: |θ| < {SWING_UP_ANGLE:g} rad over the last {SWING_UP_STEPS} "
            "steps of the final incumbent; iterations to swing-up: from which on the "
            "incumbent stays swung up, over the seeds swung up at the end)"
        )
        lines.append(
            f"gymnasium's usual good return: about {GOOD_RETURN:.0f} (a mean over "
            "random initial states)"
        )
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (
            f"PendulumExperiment(models={self.models}, runs={self.runs}, "
            f"iterations={self.iterations}, swung_up={self.swung_up_count()}, "
            f"elapsed={self.elapsed:.1f}s)"
        )


def _model_names(models: Any) -> tuple[str, ...]:
    if isinstance(models, str) or not isinstance(models, Sequence) or len(models) == 0:
        raise TypeError(
            f"models: expected a non-empty sequence of names from "
            f"{PENDULUM_MODELS}, received {arrays.describe(models)}"
        )
    out = tuple(_model_name(m) for m in models)
    if len(set(out)) != len(out):
        raise ValueError(f"models: expected distinct names, received {list(models)}")
    return out


def _seed_list(seeds: Any) -> tuple[int, ...]:
    if (
        isinstance(seeds, (str, bytes))
        or not isinstance(seeds, (Sequence, range))
        or len(seeds) == 0
    ):
        raise TypeError(
            f"seeds: expected a non-empty sequence of integers >= 0, received "
            f"{arrays.describe(seeds)}"
        )
    return tuple(options.integer(s, "seeds", 0) for s in seeds)


def run_pendulum_experiment(
    *,
    seeds: Sequence[int] | None = None,
    models: Sequence[str] = PENDULUM_MODELS,
    iterations: int | None = None,
    quick: bool = False,
    progress: Callable[[str], None] | None = None,
    **learn_options: Any,
) -> PendulumExperiment:
    """Compare LTV and LTI models on Pendulum-v1 over several initial states.

    Each seed s is one run: every model learns from ``env.reset(seed=s)`` with
    :func:`learn_pendulum` (the same initial torques and noise for all models).

    Parameters
    ----------
    seeds : sequence of int, optional
        The runs' seeds; default ``range(20)``, or ``QUICK_SEEDS`` in quick mode.
    models : sequence of {"ltv", "lti", "learned"}
    iterations : int, optional
        Learning iterations per run, each of R episodes (default 40, or 20 in
        quick mode).
    quick : bool
        Quick mode: 2 seeds of 20 iterations.
    progress : callable, optional
        Called with a line of text after each run.
    **learn_options
        Further keyword arguments of :func:`learn_pendulum` (``lam``,
        ``noise_std``, ...).

    Returns
    -------
    PendulumExperiment
    """
    quick = options.flag(quick, "quick")
    seeds = _seed_list((QUICK_SEEDS if quick else range(FULL_SEEDS)) if seeds is None else seeds)
    models = _model_names(models)
    iterations = (
        (QUICK_ITERATIONS if quick else FULL_ITERATIONS)
        if iterations is None
        else options.integer(iterations, "iterations", 1)
    )
    if progress is not None and not callable(progress):
        raise TypeError(
            f"progress: expected a function or None, received {arrays.describe(progress)}"
        )
    for name in ("model", "seed", "env"):
        if name in learn_options:
            raise TypeError(f"{name}: not an option of run_pendulum_experiment (set by it)")
    start = time.perf_counter()
    env = make_env()
    runs = len(seeds)
    returns = {m: np.empty((runs, iterations)) for m in models}
    rollout_returns = {m: np.empty((runs, iterations)) for m in models}
    swing_up: dict = {m: [] for m in models}
    swung = {m: np.zeros((runs, iterations), dtype=bool) for m in models}
    final = {m: np.empty(runs) for m in models}
    rollouts = DEFAULT_ROLLOUTS
    for r, s in enumerate(seeds):
        for m in models:
            res = learn_pendulum(m, seed=s, iterations=iterations, env=env, **learn_options)
            rollouts = res.rollouts_per_iteration
            returns[m][r] = res.incumbent_returns
            rollout_returns[m][r] = res.returns
            swing_up[m].append(res.swing_up_iteration)
            swung[m][r] = res.swung_up
            final[m][r] = res.final_return
        if progress is not None:
            text = ", ".join(
                f"{m} {final[m][r]:.0f}"
                + ("" if swing_up[m][-1] is None else f" (up at {swing_up[m][-1]})")
                for m in models
            )
            progress(
                f"seed {s} ({r + 1}/{runs}): final return {text} "
                f"({time.perf_counter() - start:.0f} s)"
            )
    env.close()
    return PendulumExperiment(
        returns=returns,
        rollout_returns=rollout_returns,
        swing_up=swing_up,
        swung=swung,
        final=final,
        models=models,
        seeds=seeds,
        iterations=iterations,
        quick=quick,
        elapsed=time.perf_counter() - start,
        settings=dict(learn_options),
        rollouts_per_iteration=rollouts,
    )


_COLORS = {"ltv": "C0", "lti": "C1", "learned": "C2"}


def plot_pendulum_experiment(result: PendulumExperiment, *, axes: Any = None) -> Figure:
    """Learning curves: the median return with its inter-quartile band, and the swung-up share.

    The top panel shows the learned controller's episode return per iteration
    (median over the seeds, band: 25–75 %) with gymnasium's usual good return
    dashed; the bottom panel the fraction of seeds swung up.

    Parameters
    ----------
    result : PendulumExperiment
        From :func:`run_pendulum_experiment`.
    axes : pair of matplotlib.axes.Axes, optional
        Axes to draw into; default: a new figure (no display needed).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(result, PendulumExperiment):
        raise TypeError(
            f"result: expected a PendulumExperiment, received {arrays.describe(result)}"
        )
    from matplotlib.ticker import MaxNLocator

    if axes is None:
        fig = new_figure((7.0, 6.0))
        ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2.2, 1.0])
    else:
        if not isinstance(axes, (tuple, list)) or len(axes) != 2:
            raise TypeError(
                f"axes: expected a pair of matplotlib Axes, received {arrays.describe(axes)}"
            )
        ax, ax2 = axes
        fig = ax.figure
    it = np.arange(1, result.iterations + 1)
    count = result.swung_up_count()
    draw_learning_curves(
        ax,
        result.returns,
        result.models,
        _COLORS,
        {m: f"{MODEL_LABELS[m]} (swung up {count[m]}/{result.runs})" for m in result.models},
    )
    for m in result.models:
        ax2.step(
            it,
            result.swung[m].mean(axis=0),
            where="post",
            color=_COLORS[m],
            lw=2,
            label=MODEL_LABELS[m],
        )
    ax.axhline(
        GOOD_RETURN,
        color="k",
        ls="--",
        lw=1.2,
        label=f"gymnasium's usual good return ({GOOD_RETURN:.0f})",
    )
    ax.set_ylabel("Episode return")
    ax.set_title(f"{ENV_ID}: median over {result.runs} initial states (band: inter-quartile range)")
    ax.legend(fontsize="small", loc="lower right")
    ax2.set_ylim(-0.03, 1.03)
    ax2.set_xlim(1, max(result.iterations, 2))
    ax2.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax2.set_xlabel(f"Learning iteration ({result.rollouts_per_iteration} episodes each)")
    ax2.set_ylabel("Swung up (share)")
    return fig
