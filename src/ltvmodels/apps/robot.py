"""A two-link planar robot arm with Coulomb friction and a stiff wall (paper Figs. 2–3).

The arm (joint angles q = (q₁, q₂), point masses at the ends of two links,
horizontal plane, no gravity) follows

    M(q) q̈ + c(q, q̇) + F_c sign(q̇) + F_v q̇ = τ + J_yᵀ f,

where f <= 0 is the force of a rigid wall at end-effector height y = y_w,
present only in contact. A computed-torque controller (with friction
compensation, so its torque jumps when a joint velocity changes sign) tracks a
straight end-effector line that crosses the wall; its torque, plus a
disturbance, is held constant over each sample interval h. The disturbance
is a random walk with N(0, σ²) steps, σ = ``torque_noise``: slow enough
that the well-tuned loop still tracks, large enough that another noise
sequence makes the contact several samples earlier or later. The motion is
integrated by :func:`scipy.integrate.solve_ivp` with events: when the end
effector reaches the wall its position is projected onto it and its normal
velocity removed, and from then on it slides along the wall (a holonomic
constraint with Lagrange multiplier f) for as long as the wall pushes.

The reference line is chosen so that the elbow velocity q̇₂ changes sign
around sample 70 and the contact is made around sample 125 of 200, as in the
paper: the dynamics along the trajectory change abruptly twice, once by the
friction and once by the contact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ..estimators.changepoints import find_changepoints
from ..estimators.fit import fit, lambda_max
from ..plotting.figure import new_figure
from ..results.statespace import LTVModel
from ..validation import options

__all__ = [
    "RobotData",
    "RobotExperiment",
    "plot_robot_experiment",
    "robot_experiment",
    "two_link_robot",
    "hand_position",
]

LINK = 1.0  # both link lengths [m]
MASS = 1.0  # both point masses [kg]
COULOMB = np.array([1.0, 1.0])  # Coulomb friction torques [N m]
VISCOUS = np.array([0.2, 0.2])  # viscous friction [N m s]
FRICTION_WIDTH = 1e-3  # velocity over which the Coulomb friction flips [rad/s]
START = np.array([1.2, 0.2])  # end-effector line, start and end [m]
END = np.array([-0.2, 1.8])
KP, KD = 30.0, 10.0  # controller gains


@dataclass(frozen=True)
class RobotData:
    """A simulated run of the two-link arm.

    Attributes
    ----------
    x : ndarray, shape (T, 4)
        States (q₁, q₂, q̇₁, q̇₂) at the sample times.
    u : ndarray, shape (T, 3)
        Inputs (τ₁, τ₂, 1): the torques held over each interval and a
        constant 1 that lets a linear model absorb friction offsets.
    time : ndarray, shape (T,)
    end_effector : ndarray, shape (T, 2)
    in_contact : ndarray of bool, shape (T,)
    contact_index : int or None
        First sample in contact with the wall.
    sign_change_index : int or None
        First sample after the elbow velocity q̇₂ changed sign.
    wall_height : float
    """

    x: np.ndarray
    u: np.ndarray
    time: np.ndarray
    end_effector: np.ndarray
    in_contact: np.ndarray
    contact_index: int | None
    sign_change_index: int | None
    wall_height: float


def _mass_matrix(q: np.ndarray) -> np.ndarray:
    c2 = np.cos(q[1])
    m12 = MASS * LINK**2 * (1.0 + c2)
    return np.array([[MASS * LINK**2 * (3.0 + 2.0 * c2), m12], [m12, MASS * LINK**2]])


def _bias(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Coriolis and centrifugal torques c(q, q̇) plus friction.

    The Coulomb term F_c sign(q̇) is evaluated as F_c tanh(q̇ / FRICTION_WIDTH):
    under control a joint velocity crosses zero at some rad/s², so the
    friction torque flips within ~1e-4 s, far inside one sample interval —
    a discontinuity at the sampling resolution, without the endless
    chattering of an exact sign() at rest.
    """
    h = MASS * LINK**2 * np.sin(q[1])
    coriolis = np.array([-h * (2.0 * qd[0] * qd[1] + qd[1] ** 2), h * qd[0] ** 2])
    return coriolis + COULOMB * np.tanh(qd / FRICTION_WIDTH) + VISCOUS * qd


def hand_position(q: np.ndarray) -> np.ndarray:
    """Position (horizontal, vertical) of the arm's tip at joint angles q.

    Parameters
    ----------
    q : ndarray, shape (2,)
        The joint angles (shoulder, elbow), in radians.

    Returns
    -------
    ndarray, shape (2,)
        The tip's horizontal and vertical position.
    """
    return LINK * np.array([np.cos(q[0]) + np.cos(q[0] + q[1]), np.sin(q[0]) + np.sin(q[0] + q[1])])


def _jacobian(q: np.ndarray) -> np.ndarray:
    s1, c1 = np.sin(q[0]), np.cos(q[0])
    s12, c12 = np.sin(q[0] + q[1]), np.cos(q[0] + q[1])
    return LINK * np.array([[-s1 - s12, -s12], [c1 + c12, c12]])


def _jacobian_rate(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """J̇(q, q̇) q̇."""
    w1, w12 = qd[0], qd[0] + qd[1]
    return -LINK * np.array(
        [
            np.cos(q[0]) * w1**2 + np.cos(q[0] + q[1]) * w12**2,
            np.sin(q[0]) * w1**2 + np.sin(q[0] + q[1]) * w12**2,
        ]
    )


def _inverse(p: np.ndarray) -> np.ndarray:
    """Joint angles (elbow angle q₂ > 0) that put the end effector at p."""
    c2 = (p @ p - 2.0 * LINK**2) / (2.0 * LINK**2)
    q2 = np.arccos(np.clip(c2, -1.0, 1.0))
    q1 = np.arctan2(p[1], p[0]) - np.arctan2(LINK * np.sin(q2), LINK * (1.0 + np.cos(q2)))
    return np.array([q1, q2])


def _reference(t: float, duration: float):
    """Joint position, velocity and acceleration along the end-effector line."""
    tau = min(max(t / duration, 0.0), 1.0)
    s, sd, sdd = (
        3 * tau**2 - 2 * tau**3,
        (6 * tau - 6 * tau**2) / duration,
        (6 - 12 * tau) / duration**2,
    )
    p, pd, pdd = START + s * (END - START), sd * (END - START), sdd * (END - START)
    q = _inverse(p)
    J = _jacobian(q)
    qd = np.linalg.solve(J, pd)
    qdd = np.linalg.solve(J, pdd - _jacobian_rate(q, qd))
    return q, qd, qdd


def _wall_force(q, qd, torque) -> tuple[np.ndarray, float]:
    """Constrained acceleration on the wall and the wall force f (<= 0 when it pushes)."""
    M = _mass_matrix(q)
    free = torque - _bias(q, qd)
    Jy = _jacobian(q)[1]
    Minv_free = np.linalg.solve(M, free)
    Minv_J = np.linalg.solve(M, Jy)
    f = -(Jy @ Minv_free + _jacobian_rate(q, qd)[1]) / (Jy @ Minv_J)
    return Minv_free + Minv_J * f, f


def two_link_robot(
    T: int = 201,
    h: float = 0.02,
    torque_noise: float = 0.1,
    seed: int | np.random.Generator | None = 0,
    wall_height: float = 1.3,
) -> RobotData:
    """Simulate the arm under computed-torque control along a line into a wall.

    Parameters
    ----------
    T : int, default 201
        Number of samples (N = T − 1 = 200 transitions, as in the paper).
    h : float, default 0.02
        Sample interval [s]; the reference line is traversed in (T − 1)·h.
    torque_noise : float, default 0.1
        Standard deviation σ of the steps of the random-walk disturbance
        added to the held torques [N m].
    seed : int or Generator, optional
        Seeds the torque noise.
    wall_height : float, default 1.3
        Height y_w of the wall [m] (the line goes from y = 0.2 to 1.8).

    Returns
    -------
    RobotData
    """
    T = options.integer(T, "T", minimum=10)
    h = options.positive_scalar(h, "h")
    torque_noise = options.nonnegative_scalar(torque_noise, "torque_noise")
    wall_height = options.positive_scalar(wall_height, "wall_height")
    rng = np.random.default_rng(seed)
    duration = (T - 1) * h
    q, qd = _reference(0.0, duration)[:2]
    x = np.zeros((T, 4))
    u = np.ones((T, 3))
    in_contact = np.zeros(T, dtype=bool)
    contact = False
    disturbance = np.zeros(2)
    for k in range(T):
        x[k] = np.concatenate([q, qd])
        in_contact[k] = contact
        q_r, qd_r, qdd_r = _reference(k * h, duration)
        M = _mass_matrix(q)
        torque = M @ (qdd_r + KD * (qd_r - qd) + KP * (q_r - q)) + _bias(q, qd)
        disturbance += torque_noise * rng.standard_normal(2)
        torque = torque + disturbance
        u[k, :2] = torque
        if k == T - 1:
            break
        q, qd, contact = _step(q, qd, torque, h, contact, wall_height)
    pos = np.array([hand_position(xk[:2]) for xk in x])
    first = np.flatnonzero(in_contact)
    moving = np.flatnonzero(np.abs(x[:, 3]) > 1e-3)  # ignore the start from rest
    flips = moving[1:][np.diff(np.sign(x[moving, 3])) != 0]
    return RobotData(
        x=x,
        u=u,
        time=h * np.arange(T),
        end_effector=pos,
        in_contact=in_contact,
        contact_index=int(first[0]) if first.size else None,
        sign_change_index=int(flips[0]) if flips.size else None,
        wall_height=wall_height,
    )


def _step(q, qd, torque, h, contact, wall_height):
    """Integrate one sample interval with the torque held; returns (q, q̇, in contact).

    An event ends the integration when the end effector reaches the wall
    (then it is projected onto the wall and continues in contact) or when the
    wall stops pushing (then it moves freely again).
    """
    t0 = 0.0
    state = np.concatenate([q, qd])
    while h - t0 > 1e-12:
        if contact:

            def rhs(_t, s):
                return np.concatenate([s[2:], _wall_force(s[:2], s[2:], torque)[0]])

            def event(_t, s):  # the wall force crosses 0 upwards: it would pull
                return _wall_force(s[:2], s[2:], torque)[1]
        else:

            def rhs(_t, s):
                acc = np.linalg.solve(_mass_matrix(s[:2]), torque - _bias(s[:2], s[2:]))
                return np.concatenate([s[2:], acc])

            def event(_t, s):  # the end effector reaches the wall
                return hand_position(s[:2])[1] - wall_height

        event.terminal, event.direction = True, 1.0
        sol = solve_ivp(rhs, (t0, h), state, method="LSODA", events=event, rtol=1e-7, atol=1e-9)
        state, t0 = sol.y[:, -1], sol.t[-1]
        if sol.status == 1:  # the event ended the piece
            contact = not contact
            if contact:
                state = _project_onto_wall(state, wall_height)
    if contact:  # remove the drift of the integration off the wall
        state = _project_onto_wall(state, wall_height)
    return state[:2], state[2:], contact


def _project_onto_wall(state: np.ndarray, wall_height: float) -> np.ndarray:
    """Put the end effector on the wall and remove its velocity normal to it."""
    p = hand_position(state[:2])
    q = _inverse(np.array([p[0], wall_height]))
    J = _jacobian(q)
    pd = J @ state[2:]
    qd = np.linalg.solve(J, np.array([pd[0], 0.0]))
    return np.concatenate([q, qd])


@dataclass
class RobotExperiment:
    """The paper's robot example (Figs. 2–3): a fit on one run, simulated on two.

    Attributes
    ----------
    train, validation : RobotData
        Runs with different torque-noise sequences.
    x_train, u_train, x_validation, u_validation : ndarray
        The normalized data the model sees: states and torques scaled to zero
        mean and unit variance with the training statistics, the constant 1
        input kept.
    model : LTVModel
        ``norm="group"``, order 1, fitted to the training run.
    changepoints : ndarray of int
        :func:`ltvmodels.find_changepoints` of the model with a relative
        threshold of 0.01 (the friction change is ~30 times smaller than the
        contact in the activation).
    simulation_train, simulation_validation : ndarray, shape (T, 4)
        Open-loop simulations of the model from the first state, with the
        recorded inputs (normalized units).
    rms_train, rms_validation : float
        Root-mean-square simulation errors (normalized units).
    """

    train: RobotData
    validation: RobotData
    x_train: np.ndarray
    u_train: np.ndarray
    x_validation: np.ndarray
    u_validation: np.ndarray
    model: LTVModel
    changepoints: np.ndarray
    simulation_train: np.ndarray
    simulation_validation: np.ndarray
    rms_train: float
    rms_validation: float


def robot_experiment(
    seed: int = 0, validation_seed: int = 1, lam_fraction: float = 0.02
) -> RobotExperiment:
    """Fit a piecewise-constant LTV model to one run of the arm, simulate it on two.

    The model is ``ltvmodels.fit(x, u, lam=lam_fraction · λ_max, norm="group",
    order=1)`` on the normalized training run (λ_max: the smallest λ giving
    the LTI model). Its activation peaks where the elbow velocity changes
    sign (the Coulomb friction flips) and where the contact is made; on the
    validation run the contact comes at a different time, which the
    time-indexed model cannot know (paper Fig. 3).

    Parameters
    ----------
    seed, validation_seed : int
        Torque-noise seeds of the two runs.
    lam_fraction : float
        λ as a fraction of λ_max, in (0, 1].

    Returns
    -------
    RobotExperiment
    """
    lam_fraction = options.fraction(lam_fraction, "lam_fraction")
    train = two_link_robot(seed=seed)
    validation = two_link_robot(seed=validation_seed)
    x_mean, x_std = train.x.mean(axis=0), train.x.std(axis=0)
    u_mean, u_std = train.u[:, :2].mean(axis=0), train.u[:, :2].std(axis=0)

    def normalize(run: RobotData) -> tuple[np.ndarray, np.ndarray]:
        u = np.column_stack([(run.u[:, :2] - u_mean) / u_std, np.ones(len(run.u))])
        return (run.x - x_mean) / x_std, u

    xt, ut = normalize(train)
    xv, uv = normalize(validation)
    lam_max = lambda_max(xt, ut, norm="group")
    model = fit(xt, ut, lam=lam_fraction * lam_max, norm="group", order=1)
    sim_t, sim_v = model.simulate(xt[0], ut), model.simulate(xv[0], uv)
    return RobotExperiment(
        train=train,
        validation=validation,
        x_train=xt,
        u_train=ut,
        x_validation=xv,
        u_validation=uv,
        model=model,
        changepoints=find_changepoints(model, threshold=0.01),
        simulation_train=sim_t,
        simulation_validation=sim_v,
        rms_train=float(np.sqrt(np.mean((sim_t - xt) ** 2))),
        rms_validation=float(np.sqrt(np.mean((sim_v - xv) ** 2))),
    )


def plot_robot_experiment(experiment: RobotExperiment, which: str = "train"):
    """Data against the model's open-loop simulation, events marked (paper Figs. 2–3).

    Five panels: the four normalized states (data solid, simulation dashed)
    and the two normalized torques. Dashed vertical lines mark the training
    run's elbow-velocity sign change and contact; for ``which="validation"``
    dotted lines mark the validation run's own events.

    Parameters
    ----------
    experiment : RobotExperiment
        The result of :func:`robot_experiment`.
    which : {"train", "validation"}
        The run to draw.

    Returns
    -------
    matplotlib.figure.Figure
    """
    which = options.choice(which, "which", ("train", "validation"))
    run = experiment.train if which == "train" else experiment.validation
    x = experiment.x_train if which == "train" else experiment.x_validation
    u = experiment.u_train if which == "train" else experiment.u_validation
    sim = experiment.simulation_train if which == "train" else experiment.simulation_validation
    rms = experiment.rms_train if which == "train" else experiment.rms_validation
    fig = new_figure((9.0, 8.0))
    axes = fig.subplots(5, 1, sharex=True)
    names = ["q₁", "q₂", "q̇₁", "q̇₂"]
    for i, ax in enumerate(axes[:4]):
        ax.plot(x[:, i], color="C0", label="data")
        ax.plot(sim[:, i], color="C1", ls="--", label="model simulation")
        ax.set_ylabel(names[i])
    axes[4].plot(u[:, :2])
    axes[4].set_ylabel("torques")
    axes[4].set_xlabel("sample")
    for ax in axes:
        for event in (experiment.train.sign_change_index, experiment.train.contact_index):
            if event is not None:
                ax.axvline(event, color="k", ls="--", lw=0.8)
        if which == "validation":
            for event in (run.sign_change_index, run.contact_index):
                if event is not None:
                    ax.axvline(event, color="C3", ls=":", lw=0.8)
    axes[0].legend(loc="best")
    fig.suptitle(
        f"two-link arm, {which} run: open-loop simulation RMS {rms:.3f} (normalized)\n"
        "dashed: sign change of q̇₂ and contact in the training run"
        + ("; dotted: in this run" if which == "validation" else "")
    )
    return fig
