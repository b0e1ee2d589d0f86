"""Piecewise refits given the change points: the second step of the two-step refinement.

Paper Section III-G ("Two-step refinement"): once the change points (knots)
c_1 < … < c_M are known, the penalty is dropped and equality constraints tie
the coefficients together wherever no change was found. The result is an
ordinary least-squares problem,

    minimize  Σ_t ‖x_{t+1} − A_t x_t − B_t u_t‖²   subject to the structure below,

whose estimates are not shrunk towards "no change" as those of the penalized
first step are. With knots τ_0 = 0 < τ_1 = c_1 < … < τ_M = c_M and segments
[c_j, c_{j+1}) of model indices (c_0 = 0, c_{M+1} = N):

* ``order=1`` (piecewise constant, paper III-C): k_t is constant on each
  segment, k_c ≠ k_{c−1} only at the change points. The problem splits into
  M + 1 independent least-squares problems, one per segment, each with the n
  output rows sharing the regressor φ_t = [x_t; u_t] (p = n + m unknowns per
  row and segment).
* ``order=2`` (piecewise linear and continuous, paper III-E): k_t is a linear
  spline in t with knots τ_0 = 0, c_1 … c_M, τ_{M+1} = N − 1,

      k_t = Σ_j h_j(t) γ_j,

  with the hat functions h_j (1 at τ_j, 0 at the other knots, linear in
  between), so the slope of k changes only at the change points and k is
  continuous there. Row i of Θ_t = Σ_j h_j(t) Γ_j is fitted by the
  regression y_{t,i} = z_tᵀ g_i with z_t = h(t) ⊗ φ_t: one system of
  P = (M + 2)·p unknowns per row, shared by all rows. Its normal matrix ZᵀZ
  is block tridiagonal and is accumulated per segment in O(N p²).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from functools import partial
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..core import losses, penalties
from ..core.covariance import CovarianceBlocks
from ..core.identifiability import (
    ILL_CONDITIONED_TOL,
    SINGULAR_TOL,
    describe_direction,
    scaled_min_eig,
)
from ..core.problem import RegressionProblem
from ..core.robust import solve_robust
from ..errors import IdentifiabilityWarning, SingularProblemError, warn
from ..results.record import FitRecord, FitStatus
from ..results.statespace import LTVModel
from ..validation import arrays, options
from ..validation.options import Loss, MeasurementLoss
from .changepoints import find_changepoints
from .measurement import measurement_fit
from .recordings import state_space_data
from .robust import outlier_info, robust_record_parts

__all__ = ["fit_piecewise", "piecewise_fit", "refine_fit", "residual_noise"]

_DIFFERENCE = {1: np.array([-1.0, 1.0]), 2: np.array([1.0, -2.0, 1.0])}


def fit_piecewise(
    x: ArrayLike,
    u: ArrayLike | None = None,
    changepoints: ArrayLike | None = None,
    *,
    order: int = 1,
    compute_cov: bool = True,
    weights: ArrayLike | None = None,
    constant: bool = False,
    loss: Loss = "squared",
    huber_delta: float | ArrayLike | None = None,
    regular: bool = True,
    measurement_noise: float | ArrayLike | Literal["estimate"] | None = None,
    measurement_loss: MeasurementLoss = "squared",
    em_tol: float = 1e-6,
    em_max_iter: int = 500,
    em_accelerate: bool = True,
) -> LTVModel:
    r"""Least-squares LTV model that is piecewise constant or linear between given change points.

    Solves the equality-constrained second step of the paper's two-step
    refinement (Section III-G) exactly: with :math:`\mathcal{C}` the change points,

    .. math::

        \min_{k} \sum_t \lVert x_{t+1} - A_t x_t - B_t u_t \rVert_2^2
        \quad \text{subject to} \quad k_t = k_{t-1} \text{ for } t \notin \mathcal{C}

    for ``order=1``, and for ``order=2`` subject to :math:`k_t` being linear in
    :math:`t` between consecutive change points and continuous at them; see
    :mod:`ltvmodels.estimators.piecewise` for the parametrization. Typically the change points
    come from :func:`ltvmodels.find_changepoints` applied to a first-step fit.

    Parameters
    ----------
    x : array_like, shape (T, n)
        States, time on axis 0 (lists and pandas DataFrames are accepted).
    u : array_like, shape (T, m) or (T,), optional
        Inputs.
    changepoints : array_like of int, shape (M,)
        Strictly increasing model indices; c means that a new segment starts
        at model index c (for ``order=1``: k_c ≠ k_{c−1}; for ``order=2``: the
        slope of k changes at c). Values in [1, N − 1] for ``order=1`` and
        [1, N − 2] for ``order=2`` (N = T − 1). Empty: a single segment (the
        LTI model for ``order=1``, coefficients linear in time for
        ``order=2``). Unsorted or repeated values are an error, not silently
        fixed.
    order : {1, 2}
        1: piecewise constant; 2: piecewise linear and continuous at the
        change points. Higher orders raise NotImplementedError.
    compute_cov : bool, default True
        Compute the covariance of the estimates (O(n N p²) memory).
    weights, constant
        As in :func:`ltvmodels.fit`; x and u may also hold R trajectories and
        NaN for missing samples, as there.
    loss, huber_delta
        As in :func:`ltvmodels.fit`: "huber" or "laplace" fit the same
        piecewise model with that loss (a static robust regression on the
        segment or hat-function regressors; exact, with the certificate in
        ``info``); then ``cov`` and ``loglik`` are None and ``noise_var`` is
        the residual mean square. The regressors of that regression take
        N·q·(M + 2)·p numbers; beyond ROBUST_MAX_ENTRIES (2e7) it is refused.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).
    measurement_noise, measurement_loss, em_tol, em_max_iter, em_accelerate
        As in :func:`ltvmodels.fit`: the recorded states as noisy measurements;
        the maximum-likelihood piecewise model by EM (squared loss only; then
        ``cov`` is None).

    Returns
    -------
    LTVModel
        ``norm="piecewise"``; ``coeffs`` the difference operator of the order
        ([-1, 1] or [1, -2, 1]), so that ``activation()`` is nonzero only at
        the change points; ``lam=inf`` (the constraints are the λ → ∞ limit of
        a penalty on every difference but those at the change points);
        ``changepoints`` as given. ``noise_cov`` is EᵀE / (N − P) with
        residuals E (N, n) and P unknowns per row ((M + 1)·p for order 1,
        (M + 2)·p for order 2), ``noise_var`` its trace / n, ``loglik`` the
        Gaussian log-likelihood at the maximum-likelihood noise covariance
        EᵀE / N (it grows with M: penalize it, e.g. by BIC, to compare change
        point sets). ``cov`` holds the covariance of the least-squares
        estimate of each row i of [A_t B_t], Σ_v[i, i] S_t with
        S_t = (Φ_sᵀΦ_s)⁻¹ on segment s for order 1 and
        S_t = H_t (ZᵀZ)⁻¹ H_tᵀ, H_t = h(t)ᵀ ⊗ I_p, for order 2, so
        ``std()`` is exact; the covariances between rows, Σ_v[i, i'] S_t, are
        not stored (``cov_full()`` shows them as 0). None when
        ``compute_cov`` is False or N <= P. ``info`` has "solver",
        "order", "segments" (a list of [start, stop)), "knots" (order 2),
        "rss", "dof" and "n_params_per_row".

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument), e.g. change points
        out of range, unsorted or repeated, or a segment with fewer samples
        than unknowns.
    SingularProblemError
        A segment (order 1) or knot (order 2) whose coefficients the data do
        not determine; the message starts with "changepoints:" ("x:" when
        there are none) and says which segment or knot, and which combination
        of the regressors is not excited there.
    NotImplementedError
        ``order`` >= 3.

    Examples
    --------
    >>> import ltvmodels as ltv
    >>> data = ltv.systems.jump_linear(seed=0)
    >>> model = ltv.fit_piecewise(data.x, data.u, [200])
    >>> model.changepoints.tolist(), model.info["segments"]
    ([200], [[0, 200], [200, 399]])
    """
    data = state_space_data(x, u, weights=weights, constant=constant, regular=regular)
    order = options.piecewise_order(order)
    if not isinstance(compute_cov, bool):
        raise TypeError(f"compute_cov: expected True or False, received {compute_cov!r}")
    loss, delta = options.loss_options(loss, huber_delta, data.n)
    factory = partial(LTVModel, n_states=data.n, n_inputs=data.m, constant=data.constant)
    robust = options.choice(measurement_loss, "measurement_loss", options.MEASUREMENT_LOSSES)
    options.measurement_loss_needs_noise(robust, measurement_noise)
    if measurement_noise is not None:
        if loss != "squared":
            raise NotImplementedError(
                f"loss: {loss!r} with measurement_noise is not available yet; use "
                "loss='squared' with measurement_noise, or measurement_noise=None"
            )
        tol = options.positive_scalar(em_tol, "em_tol")
        max_iter = options.integer(em_max_iter, "em_max_iter", minimum=0)
        options.measurement_noise(measurement_noise, data.n)  # before the first fit
        step = partial(
            _piecewise_step,
            changepoints=changepoints,
            order=order,
            names=data.regressor_names,
            factory=factory,
        )
        return data.describe(
            measurement_fit(
                data,
                step(data.problem, 1.0),
                step,
                measurement_noise=measurement_noise,
                noise_var=None,
                tol=tol,
                max_iter=max_iter,
                label="piecewise",
                measurement_loss=robust,
                accelerate=options.flag(em_accelerate, "em_accelerate"),
            )
        )
    return data.describe(
        piecewise_fit(
            data.problem,
            changepoints,
            order=order,
            compute_cov=compute_cov,
            names=data.regressor_names,
            loss=loss,
            delta=delta,
            factory=factory,
        )
    )


def _piecewise_step(
    problem: RegressionProblem,
    process_var: float,
    *,
    changepoints: Any,
    order: int,
    names: list[str],
    factory: Callable[..., Any],
) -> Any:
    """The M-step of ``fit_piecewise(measurement_noise=...)`` (``process_var`` unused)."""
    return piecewise_fit(
        problem,
        changepoints,
        order=order,
        compute_cov=False,
        names=names,
        loss="squared",
        delta=None,
        factory=factory,
    )


def piecewise_fit(
    problem: RegressionProblem,
    changepoints: Any,
    *,
    order: int,
    compute_cov: bool,
    names: list[str],
    loss: str,
    delta: np.ndarray | None,
    factory: Callable[..., Any],
    fixed: tuple[int, ...] = (),
) -> Any:
    """:func:`fit_piecewise` on a validated regression problem (any front-end): the model
    ``factory(k, fit=FitRecord(...))``; ``changepoints`` are validated here.

    ``fixed`` (order 1, squared loss): the regressor columns whose coefficients are
    common to all segments (the partial structural-change model; see
    :func:`_fit_constant_partial`), validated by the caller."""
    n = problem.n
    N, p = problem.N, problem.p
    note = "; order=2 needs a sample after the last knot" if order == 2 else ""
    changepoints = arrays.changepoint_indices(changepoints, N, last=N - order, note=note)
    phi, y = problem.phi, problem.y  # (N, R, p), (N, R, n); unobserved rows are 0
    bounds = np.concatenate([[0], changepoints, [N]])
    segments = [[int(a), int(b)] for a, b in itertools.pairwise(bounds)]

    if order == 1 and fixed:
        theta, unit_cov = _fit_constant_partial(phi, y, problem.observed, bounds, names, fixed)
        n_params = (len(changepoints) + 1) * (p - len(fixed)) + len(fixed)
        info_extra: dict[str, Any] = {"fixed": list(fixed)}
    elif order == 1:
        theta, unit_cov = _fit_constant(phi, y, problem.observed, bounds, names)
        n_params = (len(changepoints) + 1) * p
        info_extra = {}
    else:
        knots = np.concatenate([[0], changepoints, [N - 1]])
        theta, unit_cov = _fit_linear(phi, y, problem.n_observed, knots, names)
        n_params = (len(changepoints) + 2) * p
        info_extra = {"knots": [int(t) for t in knots]}

    if loss != "squared":  # the squared-loss fit above checked the segments
        return _fit_robust(
            problem,
            order,
            bounds,
            changepoints,
            loss,
            delta,
            factory,
            {
                "order": order,
                "segments": segments,
                **info_extra,
                "n_params_per_row": int(n_params),
            },
        )
    resid = problem.residuals(theta).reshape(-1, n)
    rss_matrix = resid.T @ resid
    M = problem.n_observed
    dof = M - n_params
    noise_cov, loglik, loglik_note = residual_noise(
        rss_matrix,
        M,
        n_params,
        "changepoints: fewer change points (or a segment with more samples)",
    )
    cov = None
    if compute_cov:
        # Row i of Θ_t: Σ_v[i, i] S_t (one group per row, O(n N p²) memory). The
        # cross-row blocks Σ_v[i, i'] S_t are not stored: CovarianceBlocks has
        # no Kronecker form, and the full (N, K, K) array is n times larger.
        variances = np.diag(noise_cov)[:, None, None, None]
        cov = CovarianceBlocks(variances * unit_cov[None], np.arange(n))
    info = {
        "solver": "piecewise least squares",
        "order": order,
        "segments": segments,
        **info_extra,
        "rss": float(np.trace(rss_matrix)),
        "dof": int(dof),
        "n_params_per_row": int(n_params),
        **outlier_info(problem, theta),
    }
    if loglik_note:
        info["loglik_note"] = loglik_note
    return factory(
        theta.reshape(N, n * p),
        fit=FitRecord(
            norm="piecewise",
            coeffs=_DIFFERENCE[order].copy(),
            lam=float("inf"),
            cov=cov,
            noise_var=np.diag(noise_cov).copy(),
            noise_cov=noise_cov,
            loglik=loglik,
            info=info,
            changepoints=changepoints,
            status=FitStatus("closed_form", info["solver"], 0, info["rss"]),
        ),
    )


def refine_fit(
    problem: RegressionProblem,
    first: Any,
    *,
    names: list[str],
    loss: str,
    delta: np.ndarray | None,
    factory: Callable[..., Any],
) -> Any:
    """Second step of the two-step refinement (paper Section III-G): refit ``first``'s
    problem between its change points, with the same loss (any front-end).

    The refined model's ``info["first_step"]`` summarizes ``first``, and
    ``info["first_step_k"]`` holds its coefficients.
    """
    degree = len(first.coeffs) - 1
    if degree not in (1, 2):
        raise NotImplementedError(
            f"refine: the refit is defined for order 1 and 2, received a difference "
            f"operator of degree {degree}"
        )
    changepoints = first.changepoints if first.norm != "sq" else find_changepoints(first)
    try:
        refined = piecewise_fit(
            problem,
            changepoints,
            order=degree,
            compute_cov=True,
            names=names,
            loss=loss,
            delta=delta,
            factory=factory,
        )
    except ValueError as exc:  # the change points are ours, not the caller's
        if not str(exc).startswith("changepoints:"):
            raise
        raise type(exc)(
            f"refine: the change points found in the first step, {changepoints.tolist()}, "
            f"cannot be refitted ({str(exc).removeprefix('changepoints: ')}); use a larger "
            "lam (fewer changes) or refine=False"
        ) from exc
    refined.info["first_step"] = {
        "norm": first.norm,
        "lam": first.lam if np.ndim(first.lam) == 0 else np.asarray(first.lam).tolist(),
        "objective": first.info.get("objective"),
        "iterations": first.info.get("iterations"),
        "converged": first.info.get("converged"),
        "changepoints": [int(c) for c in changepoints],
    }
    if "lam_selection" in first.info:
        refined.info["lam_selection"] = first.info["lam_selection"]
    refined.info["first_step_k"] = np.array(first.k)
    return refined


# Robust piecewise fits: the largest lifted regressor array (numbers), and the
# solver's tolerance and step limit (fit_piecewise takes no solver options).
ROBUST_MAX_ENTRIES = 20_000_000
ROBUST_TOL = 1e-9
ROBUST_MAX_ITER = 500


def _fit_robust(
    problem: RegressionProblem,
    order: int,
    bounds: np.ndarray,
    changepoints: np.ndarray,
    loss: str,
    delta: np.ndarray | None,
    factory: Callable[..., Any],
    info_extra: dict,
) -> Any:
    """The piecewise model with loss "huber" or "laplace".

    With basis functions B (N, J) — segment indicators (order 1) or hat
    functions (order 2) — Θ_t = Σ_l B_tl Γ_l, and each output row is the
    static regression y_tji = Σ_l B_tl φ_tjᵀ Γ_li: one time step with N·q rows
    and J·p regressors, solved by :func:`ltvmodels.core.robust.solve_robust` with every
    coefficient held constant.
    """
    n = problem.n
    N, q, p = problem.N, problem.q, problem.p
    if order == 1:
        inside = (np.arange(N)[:, None] >= bounds[None, :-1]) & (
            np.arange(N)[:, None] < bounds[None, 1:]
        )
        basis = inside.astype(float)
    else:
        knots = np.concatenate([[0], changepoints, [N - 1]])
        left, w = _hat_weights(knots, N)
        basis = np.zeros((N, len(knots)))
        basis[np.arange(N), left] = 1.0 - w
        basis[np.arange(N), left + 1] = w
    J = basis.shape[1]
    if N * q * J * p > ROBUST_MAX_ENTRIES:
        raise NotImplementedError(
            f"loss: a robust piecewise fit with {len(changepoints)} change points takes "
            f"{N * q * J * p:.3g} regressor entries (more than {ROBUST_MAX_ENTRIES:.0e}); use "
            "fewer change points or loss='squared'"
        )
    lifted = (basis[:, None, :, None] * problem.phi[:, :, None, :]).reshape(1, N * q, J * p)
    static = RegressionProblem(
        y=problem.y.reshape(1, N * q, n),
        phi=lifted,
        coeffs=_DIFFERENCE[1],
        observed=problem.observed.reshape(1, N * q),
        row_scale=problem.row_scale.reshape(1, N * q),
    )
    solution = solve_robust(
        static,
        np.full(n * J * p, np.inf),  # every coefficient constant
        loss=losses.named(loss),
        penalty=penalties.named("sq"),
        delta=delta,
        max_iter=ROBUST_MAX_ITER,
        tol=ROBUST_TOL,
    )
    gamma = solution.theta[0].reshape(n, J, p)
    theta = np.einsum("tl,ilp->tip", basis, gamma)
    if solution.beyond_delta is not None:
        solution.beyond_delta = solution.beyond_delta.reshape(N, q, n)
    info, status = robust_record_parts(solution, loss)
    noise_var = problem.output_rss(theta) / max(problem.n_observed, 1)
    return factory(
        theta.reshape(N, n * p),
        fit=FitRecord(
            norm="piecewise",
            coeffs=_DIFFERENCE[order].copy(),
            lam=float("inf"),
            noise_var=noise_var,
            noise_cov=np.diag(noise_var),
            info={**info, **info_extra, **outlier_info(problem, theta)},
            changepoints=changepoints,
            status=status,
        ),
    )


def residual_noise(
    rss_matrix: np.ndarray, n_obs: int, n_params: int, remedy: str
) -> tuple[np.ndarray, float | None, str | None]:
    """Noise covariance and Gaussian log-likelihood of a least-squares fit.

    ``rss_matrix`` (n, n) is the residual cross-product of ``n_obs`` observed
    rows fitted with ``n_params`` coefficients per output. Returns the
    unbiased noise covariance RSS / (n_obs − n_params), the log-likelihood at
    the ML covariance RSS / n_obs, −½ n_obs (n log 2π + log det(RSS / n_obs) + n),
    and a note. The likelihood is None (with the note saying why) when that
    covariance is singular: an exact fit in some direction makes it unbounded.

    Raises ValueError when no residual degree of freedom is left, naming the
    argument to change in ``remedy``.
    """
    dof = n_obs - n_params
    if dof <= 0:
        argument, _, advice = remedy.partition(": ")
        raise ValueError(
            f"{argument}: {n_obs} observed transitions and {n_params} coefficients per "
            "equation leave no residual degree of freedom to estimate the noise; use "
            f"{advice}"
        )
    noise_cov = rss_matrix / dof
    sign, logdet = np.linalg.slogdet(rss_matrix / n_obs)
    if sign <= 0:
        return (
            noise_cov,
            None,
            (
                "the residual covariance is singular (an exact fit in some direction), so the "
                "Gaussian likelihood is unbounded; loglik is None"
            ),
        )
    n = rss_matrix.shape[0]
    return noise_cov, float(-0.5 * n_obs * (n * np.log(2 * np.pi) + logdet + n)), None


# -- order 1: piecewise constant --------------------------------------------------------


def _fit_constant(
    phi: np.ndarray, y: np.ndarray, observed: np.ndarray, bounds: np.ndarray, names: list[str]
) -> tuple[np.ndarray, np.ndarray]:
    """Per-segment least squares.

    Parameters
    ----------
    phi : ndarray, shape (N, R, p)
    y : ndarray, shape (N, R, n)
    observed : ndarray of bool, shape (N, R)
    bounds : ndarray of int, shape (M + 2,)
        Segment boundaries 0 = b_0 < … < b_{M+1} = N; segment s is [b_s, b_{s+1}).
    names : list of str
        Regressor names for error messages.

    Returns
    -------
    theta : ndarray, shape (N, n, p)
        [A_t B_t], constant on each segment.
    unit_cov : ndarray, shape (N, p, p)
        (Φ_sᵀΦ_s)⁻¹ of the segment containing t.
    """
    N, _, p = phi.shape
    n = y.shape[2]
    theta = np.empty((N, n, p))
    unit_cov = np.empty((N, p, p))
    single = len(bounds) == 2
    for s, (start, stop) in enumerate(itertools.pairwise(bounds)):
        where = _segment_text(s, start, stop, single)
        phi_s = phi[start:stop].reshape(-1, p)
        count = int(observed[start:stop].sum())
        if count < p:
            raise ValueError(
                f"{where} has {count} transition(s) with data, fewer than the p = {p} regressors "
                f"of each output row, so its [A B] is not determined; "
                f"{_remedy(single, 'segment', p)}"
            )
        gram = phi_s.T @ phi_s
        min_eig, direction = scaled_min_eig(gram)
        if min_eig <= SINGULAR_TOL:
            raise SingularProblemError(
                f"{where}: the regressors are linearly dependent on this segment (the "
                f"combination {describe_direction(direction, names)} is numerically zero), "
                f"so its [A B] is not identifiable; {_remedy(single, 'segment', p)}"
            )
        _warn_if_ill_conditioned(min_eig, where)
        q, r = np.linalg.qr(phi_s)
        theta_s = np.linalg.solve(r, q.T @ y[start:stop].reshape(-1, n)).T  # (n, p)
        r_inv = np.linalg.solve(r, np.eye(p))
        theta[start:stop] = theta_s
        unit_cov[start:stop] = r_inv @ r_inv.T  # (Φ_sᵀΦ_s)⁻¹ = R⁻¹R⁻ᵀ
    return theta, unit_cov


def _fit_constant_partial(
    phi: np.ndarray,
    y: np.ndarray,
    observed: np.ndarray,
    bounds: np.ndarray,
    names: list[str],
    fixed: tuple[int, ...],
) -> tuple[np.ndarray, np.ndarray]:
    """Joint least squares with the ``fixed`` columns' coefficients common to all segments.

    With z the changing and x the fixed columns of φ, the model on segment s is
    y_t = Θ_s z_t + Γ x_t; the design has one block of z columns per segment and
    one x block, P = (M + 1)·p_z + p_x unknowns per output row. It is solved by
    block elimination on QR factors, O(N p²) time and O(M p² + N p²) memory,
    never forming the P × P matrix: a QR of each segment's [Z_s X_s Y_s] gives
    [R_s A_s a_s; 0 B_s b_s]; the stacked [B_s b_s] give Γ by one more QR
    ([C c]: Γᵀ = C⁻¹c), and Θ_sᵀ = R_s⁻¹(a_s − A_s Γᵀ). The unit covariances
    (the inverse of the joint normal matrix, by blocks) are
    cov(Γ) = (CᵀC)⁻¹, cov(Θ_s) = (R_sᵀR_s)⁻¹ + D_s (CᵀC)⁻¹ D_sᵀ and
    cov(Θ_s, Γ) = −D_s (CᵀC)⁻¹ with D_s = R_s⁻¹A_s.

    Returns theta (N, n, p) and unit_cov (N, p, p) as :func:`_fit_constant`, the
    x columns the same on every segment.
    """
    N, _, p = phi.shape
    n = y.shape[2]
    fixed_index = np.array(fixed, dtype=int)
    changing = np.setdiff1d(np.arange(p), fixed_index)
    pz, px = changing.size, fixed_index.size
    single = len(bounds) == 2
    factors = []
    lower, lower_rhs = [], []
    for s, (start, stop) in enumerate(itertools.pairwise(bounds)):
        where = _segment_text(s, start, stop, single)
        kept = observed[start:stop].reshape(-1)
        rows_phi = phi[start:stop].reshape(-1, p)[kept]
        z, x = rows_phi[:, changing], rows_phi[:, fixed_index]
        rows_y = y[start:stop].reshape(-1, n)[kept]
        if z.shape[0] < pz:
            raise ValueError(
                f"{where} has {z.shape[0]} row(s) with data, fewer than the p_z = {pz} changing "
                f"regressors, so its coefficients are not determined; "
                f"{_remedy(single, 'segment', pz)}"
            )
        min_eig, direction = scaled_min_eig(z.T @ z)
        if min_eig <= SINGULAR_TOL:
            raise SingularProblemError(
                f"{where}: the changing regressors are linearly dependent on this segment (the "
                f"combination {describe_direction(direction, [names[i] for i in changing])} "
                f"is numerically zero), so its coefficients are not identifiable; "
                f"{_remedy(single, 'segment', pz)}"
            )
        _warn_if_ill_conditioned(min_eig, where)
        _, r = np.linalg.qr(np.concatenate([z, x, rows_y], axis=1), mode="reduced")
        if r.shape[0] < pz + px + n:  # fewer rows than columns: pad the factor with zeros
            r = np.vstack([r, np.zeros((pz + px + n - r.shape[0], r.shape[1]))])
        factors.append(r)
        lower.append(r[pz : pz + px, pz : pz + px])
        lower_rhs.append(r[pz : pz + px, pz + px :])
    gram_fixed = sum(block.T @ block for block in lower)
    min_eig, direction = scaled_min_eig(gram_fixed)
    if min_eig <= SINGULAR_TOL:
        raise SingularProblemError(
            f"{'phi' if single else 'changepoints'}: the fixed regressors are not determined "
            f"beside the segments' changing ones (the combination "
            f"{describe_direction(direction, [names[i] for i in fixed_index])} of the fixed "
            "regressors is explained by the changing regressors on every segment); fix fewer "
            "regressors or move the change points"
        )
    _, c_full = np.linalg.qr(
        np.concatenate([np.vstack(lower), np.vstack(lower_rhs)], axis=1), mode="reduced"
    )
    c, c_rhs = c_full[:px, :px], c_full[:px, px:]
    gamma_t = np.linalg.solve(c, c_rhs)  # (p_x, n)
    c_inv = np.linalg.solve(c, np.eye(px))
    cov_gamma = c_inv @ c_inv.T
    theta = np.empty((N, n, p))
    unit_cov = np.empty((N, p, p))
    for (start, stop), r in zip(itertools.pairwise(bounds), factors):
        r_z, a, a_rhs = r[:pz, :pz], r[:pz, pz : pz + px], r[:pz, pz + px :]
        theta_t = np.linalg.solve(r_z, a_rhs - a @ gamma_t)  # (p_z, n)
        d = np.linalg.solve(r_z, a)
        r_inv = np.linalg.solve(r_z, np.eye(pz))
        cov = np.empty((p, p))
        cov[np.ix_(changing, changing)] = r_inv @ r_inv.T + d @ cov_gamma @ d.T
        cov[np.ix_(changing, fixed_index)] = -d @ cov_gamma
        cov[np.ix_(fixed_index, changing)] = (-d @ cov_gamma).T
        cov[np.ix_(fixed_index, fixed_index)] = cov_gamma
        theta[start:stop][:, :, changing] = theta_t.T
        theta[start:stop][:, :, fixed_index] = gamma_t.T
        unit_cov[start:stop] = cov
    return theta, unit_cov


# -- order 2: piecewise linear, continuous ----------------------------------------------


def _hat_weights(knots: np.ndarray, N: int) -> tuple[np.ndarray, np.ndarray]:
    """Linear-spline (hat function) weights of each time step.

    Parameters
    ----------
    knots : ndarray of int, shape (J,), J >= 2
        Strictly increasing knots τ_0 = 0 < … < τ_{J−1} = N − 1.
    N : int
        Number of time steps.

    Returns
    -------
    left : ndarray of int, shape (N,)
        Index j of the knot interval [τ_j, τ_{j+1}] containing t (the last
        interval includes its right end).
    w : ndarray, shape (N,)
        h_{j+1}(t) = (t − τ_j) / (τ_{j+1} − τ_j); h_j(t) = 1 − w, every other
        hat function is 0 at t.
    """
    t = np.arange(N)
    left = np.searchsorted(knots[1:-1], t, side="right")
    w = (t - knots[left]) / (knots[left + 1] - knots[left])
    return left, w


def _fit_linear(
    phi: np.ndarray, y: np.ndarray, n_observed: int, knots: np.ndarray, names: list[str]
) -> tuple[np.ndarray, np.ndarray]:
    """Least squares over linear splines with the given knots.

    Parameters
    ----------
    phi : ndarray, shape (N, R, p)
    y : ndarray, shape (N, R, n)
    n_observed : int
        Observed rows (the others are zero).
    knots : ndarray of int, shape (J,)
        τ_0 = 0 < τ_1 < … < τ_{J−1} = N − 1 (J = M + 2).
    names : list of str
        Regressor names for error messages.

    Returns
    -------
    theta : ndarray, shape (N, n, p)
        [A_t B_t] = Σ_j h_j(t) Γ_j.
    unit_cov : ndarray, shape (N, p, p)
        H_t (ZᵀZ)⁻¹ H_tᵀ, the covariance of a row of Θ_t per unit noise variance.
    """
    N, _, p = phi.shape
    n = y.shape[2]
    J = len(knots)
    single = J == 2
    if n_observed < J * p:
        raise ValueError(
            f"{'x' if single else 'changepoints'}: {n_observed} transitions (with data) cannot "
            f"determine the "
            f"{J * p} unknowns per output row of a linear spline with {J} knots "
            f"({J - 2} change points, p = {p} regressors); "
            f"{_remedy(single, 'knot', p)}"
        )
    left, w = _hat_weights(knots, N)
    z_left = (1.0 - w)[:, None, None] * phi  # regressors of γ_j, j = left[t]
    z_right = w[:, None, None] * phi  # regressors of γ_{j+1}
    # Normal equations ZᵀZ g = Zᵀy, block tridiagonal with J blocks of size p,
    # accumulated interval by interval.
    gram_blocks = np.zeros((J, p, J, p))
    rhs = np.zeros((J, p, n))
    for j in range(J - 1):
        sl = slice(knots[j], knots[j + 1] if j < J - 2 else N)
        zl, zr = z_left[sl].reshape(-1, p), z_right[sl].reshape(-1, p)
        ys = y[sl].reshape(-1, n)
        gram_blocks[j, :, j, :] += zl.T @ zl
        gram_blocks[j, :, j + 1, :] += zl.T @ zr
        gram_blocks[j + 1, :, j, :] += zr.T @ zl
        gram_blocks[j + 1, :, j + 1, :] += zr.T @ zr
        rhs[j] += zl.T @ ys
        rhs[j + 1] += zr.T @ ys
    gram = gram_blocks.reshape(J * p, J * p)
    gram_inv = _inverse_or_raise(gram, knots, p, names, single)
    gamma = (gram_inv @ rhs.reshape(J * p, -1)).reshape(J, p, -1)  # Γ_jᵀ stacked
    theta = (1.0 - w)[:, None, None] * gamma[left] + w[:, None, None] * gamma[left + 1]
    theta = theta.transpose(0, 2, 1)  # (N, n, p)
    blocks = gram_inv.reshape(J, p, J, p)
    b_ll = blocks[left, :, left, :]
    b_lr = blocks[left, :, left + 1, :]
    b_rl = blocks[left + 1, :, left, :]
    b_rr = blocks[left + 1, :, left + 1, :]
    a, b = (1.0 - w)[:, None, None], w[:, None, None]
    unit_cov = a * a * b_ll + a * b * (b_lr + b_rl) + b * b * b_rr
    return np.ascontiguousarray(theta), unit_cov


def _inverse_or_raise(
    gram: np.ndarray, knots: np.ndarray, p: int, names: list[str], single: bool
) -> np.ndarray:
    """(ZᵀZ)⁻¹, or SingularProblemError naming the least determined knot.

    Identifiability is judged on ZᵀZ scaled to unit diagonal (as in
    :mod:`ltvmodels.core.identifiability`); its eigendecomposition also gives the
    inverse.
    """
    min_eig, direction = scaled_min_eig(gram)
    if min_eig <= SINGULAR_TOL:
        J = len(knots)
        per_knot = direction.reshape(J, p)
        j = int(np.argmax(np.linalg.norm(per_knot, axis=1)))
        lo, hi = int(knots[max(j - 1, 0)]), int(knots[min(j + 1, J - 1)])
        raise SingularProblemError(
            f"{'x' if single else 'changepoints'}: the coefficients at the knot t = "
            f"{knots[j]} (its hat function covers model indices [{lo}, {hi}]) are not "
            f"determined by the data: the combination "
            f"{describe_direction(per_knot[j], names)} of the regressors is not excited "
            f"there; {_remedy(single, 'knot', p)}"
        )
    _warn_if_ill_conditioned(min_eig, "x" if single else "changepoints")
    scale = 1.0 / np.sqrt(np.diag(gram))
    eig, vec = np.linalg.eigh(gram * scale[:, None] * scale[None, :])
    inv = ((vec / eig) @ vec.T) * scale[:, None] * scale[None, :]
    return 0.5 * (inv + inv.T)


# -- shared helpers ------------------------------------------------------------------------


def _warn_if_ill_conditioned(min_eig: float, where: str) -> None:
    """IdentifiabilityWarning when the scaled normal matrix is nearly singular."""
    if min_eig < ILL_CONDITIONED_TOL:
        warn(
            f"{where}: the least-squares problem is ill-conditioned (smallest scaled "
            f"eigenvalue {min_eig:.1e}); the estimates are unreliable. More excitation or "
            "fewer change points helps.",
            IdentifiabilityWarning,
        )


def _segment_text(s: int, start: int, stop: int, single: bool) -> str:
    if single:
        return f"x: the data (model indices [{start}, {stop}))"
    return f"changepoints: segment {s} = [{start}, {stop})"


def _remedy(single: bool, part: str, p: int) -> str:
    if single:
        return "more data or more excitation is needed"
    return (
        f"remove or move change points so that every {part} has well-excited data "
        f"(several times p = {p} samples)"
    )
