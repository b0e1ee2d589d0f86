"""State-space front-ends: x[t+1] = A_t x[t] + B_t u[t] + v_t from recorded states and inputs.

:func:`fit` (any penalty, with the two-step refinement), :func:`fit_lti` (least
squares), :func:`fit_path` (a regularization path) and :func:`lambda_max`. Each
builds the regression y_t = x_{t+1}, φ_t = [x_t; u_t] and hands it to the shared
core :func:`.regression.fit_problem`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..core import identifiability, penalties
from ..core.covariance import CovarianceBlocks
from ..core.problem import RegressionProblem
from ..core.sparse import solve_sparse
from ..core.sparse_common import lambda_max as problem_lambda_max
from ..results.record import FitRecord, FitStatus
from ..results.statespace import LTVModel
from ..validation import arrays, options
from ..validation.options import Loss, MeasurementLoss, Norm, PriorMode, SparseNorm
from .measurement import measurement_fit, process_variance
from .piecewise import refine_fit, residual_noise
from .recordings import StateSpaceData, state_space_data
from .regression import fit_problem, sparse_model
from .robust import outlier_info, robust_model
from .spec import FitSpec

__all__ = ["fit_lti", "fit", "fit_path", "lambda_max"]

# Newton steps and tolerance of fit_lti(loss="huber"/"laplace") (it takes no solver options).
LTI_HUBER_MAX_ITER = 500
LTI_HUBER_TOL = 1e-10


def fit_lti(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
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
    """Least-squares LTI model x[t+1] = A x[t] + B u[t] (+ c) + v_t.

    Minimizes Σ_r Σ_t w_rt ‖x^r_{t+1} − A x^r_t − B u^r_t (− c)‖² over the observed
    transitions. All output rows share the regressor φ_t = [x_t; u_t (; 1)],
    so this is one least-squares problem with n right-hand sides.

    Parameters
    ----------
    x : array_like, shape (T, n), (R, T, n) or a list of R (T, n) arrays
        States, time on axis 0 (lists and pandas DataFrames are accepted);
        R time-aligned trajectories share the model; NaN marks a missing sample.
    u : array_like, shape (T, m), (T,) or (R, T, m), optional
        Inputs.
    weights : array_like, shape (T − 1,) or (R, T − 1), optional
        Weights >= 0 of the transitions (inverse relative noise variances).
    constant : bool
        Fit an intercept c.
    loss, huber_delta
        As in :func:`fit`: ``loss="huber"`` minimizes Σ w h_δ(r) over the
        entries of the residuals instead (to a KKT residual of 1e-10), with
        ``model.beyond_delta``; ``loss="laplace"`` minimizes Σ w|r| (to a relative
        duality gap of 1e-10); then no ``cov``, ``loglik`` None.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).
    measurement_noise, measurement_loss, em_tol, em_max_iter, em_accelerate
        As in :func:`ltvmodels.fit`: the recorded states as noisy measurements;
        the maximum-likelihood LTI model by EM (squared loss only).

    Returns
    -------
    LTVModel
        Constant A, B (c) repeated over the N = T − 1 time steps. ``noise_cov`` is
        the unbiased residual covariance EᵀE / (M − p) over the M observed
        transitions, ``noise_var`` its diagonal, ``cov`` the covariance
        Σ_v ⊗ (ΦᵀΦ)⁻¹ of k, ``loglik`` the Gaussian log-likelihood at the ML
        noise covariance.

    Raises
    ------
    SingularProblemError
        If the regressors are linearly dependent (no unique solution).
    """
    data = state_space_data(x, u, order=1, weights=weights, constant=constant, regular=regular)
    problem = data.problem
    n, m = data.n, data.m
    robust = options.choice(measurement_loss, "measurement_loss", options.MEASUREMENT_LOSSES)
    options.measurement_loss_needs_noise(robust, measurement_noise)
    if measurement_noise is not None:
        if options.choice(loss, "loss", options.LOSSES) != "squared":
            raise NotImplementedError(
                f"loss: {loss!r} with measurement_noise is not available yet; use "
                "loss='squared' with measurement_noise, or measurement_noise=None"
            )
        options.enough_samples(
            problem.N, problem.p, 1, observed=problem.n_observed, n_rows=problem.N * problem.q
        )
        identifiability.check(problem, has_prior=False, regressor_names=data.regressor_names)
        tol = options.positive_scalar(em_tol, "em_tol")
        max_iter = options.integer(em_max_iter, "em_max_iter", minimum=0)
        options.measurement_noise(measurement_noise, n)  # before the first fit
        lti_step = partial(_lti_step, n=n, m=m, constant=data.constant)
        return data.describe(
            measurement_fit(
                data,
                lti_step(problem, 1.0),
                lti_step,
                measurement_noise=measurement_noise,
                noise_var=None,
                tol=tol,
                max_iter=max_iter,
                label="lti",
                measurement_loss=robust,
                accelerate=options.flag(em_accelerate, "em_accelerate"),
            )
        )
    N, p = problem.N, problem.p
    M = problem.n_observed
    options.enough_samples(N, p, 1, observed=M, n_rows=N * problem.q)
    identifiability.check(problem, has_prior=False, regressor_names=data.regressor_names)
    loss, delta = options.loss_options(loss, huber_delta, n)
    if loss != "squared":  # every coefficient held constant: λ = inf
        model = robust_model(
            problem,
            np.full(n * p, np.inf),
            loss=loss,
            penalty=penalties.named("sq"),  # with every coefficient held constant
            lam=float("inf"),
            norm="lti",
            delta=delta,
            factory=partial(LTVModel, n_states=n, n_inputs=m, constant=data.constant),
            max_iter=LTI_HUBER_MAX_ITER,
            tol=LTI_HUBER_TOL,
        )
        return data.describe(model)
    phi, y = problem.stacked_rows()
    # QR-based least squares: solve, don't form (ΦᵀΦ)⁻¹ for the estimate.
    q, r = np.linalg.qr(phi)
    theta = np.linalg.solve(r, q.T @ y).T  # (n, p)
    resid = y - phi @ theta.T
    dof = M - p
    noise_cov, loglik, loglik_note = residual_noise(resid.T @ resid, M, p, "x: more samples")
    r_inv = np.linalg.solve(r, np.eye(p))
    gram_inv = r_inv @ r_inv.T  # (ΦᵀΦ)⁻¹ = R⁻¹R⁻ᵀ
    K = n * p
    k = np.broadcast_to(theta.ravel(), (N, K)).copy()
    cov_k = np.kron(noise_cov, gram_inv)
    cov = CovarianceBlocks(np.broadcast_to(cov_k, (N, K, K)), None)
    rss = float(np.sum(resid**2))
    info: dict[str, Any] = {
        "solver": "least-squares (QR)",
        "rss": rss,
        "dof": int(dof),
        **outlier_info(problem, np.broadcast_to(theta, (N, n, p))),
    }
    if loglik_note:
        info["loglik_note"] = loglik_note
    return data.describe(
        LTVModel(
            k,
            n,
            m,
            FitRecord(
                norm="lti",
                coeffs=None,
                lam=float("inf"),
                cov=cov,
                noise_var=np.diag(noise_cov).copy(),
                noise_cov=noise_cov,
                loglik=loglik,
                info=info,
                changepoints=np.zeros(0, dtype=int),
                status=FitStatus("closed_form", info["solver"], 0, rss),
            ),
            constant=data.constant,
        )
    )


def fit(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
    lam: float | ArrayLike | Literal["auto"],
    norm: Norm = "sq",
    order: int | ArrayLike = 1,
    prior: Any = None,
    prior_mode: PriorMode = "exact",
    noise_var: float | ArrayLike | None = None,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
    refine: bool = False,
    weights: ArrayLike | None = None,
    constant: bool = False,
    loss: Loss = "squared",
    huber_delta: float | ArrayLike | None = None,
    progress: Callable[[int, int], None] | None = None,
    regular: bool = True,
    measurement_noise: float | ArrayLike | Literal["estimate"] | None = None,
    measurement_loss: MeasurementLoss = "squared",
    em_tol: float = 1e-6,
    em_max_iter: int = 500,
    em_accelerate: bool = True,
) -> LTVModel:
    r"""Identify an LTV model x[t+1] = A_t x[t] + B_t u[t] (+ c_t) + v_t.

    With ``norm="sq"`` this is the exact minimizer of the squared-difference
    objective (the paper's slowly varying, smooth and general Kalman-model
    problems; equation :eq:`squared-objective` of the user guide)

    .. math::

        \sum_{r=1}^{R} \sum_t w_{rt} \lVert x^r_{t+1} - A_t x^r_t - B_t u^r_t \rVert_2^2
        + \lambda^2 \sum_t \lVert (Dk)_t \rVert_2^2,

    with :math:`k_t = \operatorname{vec}([A_t^\top \; B_t^\top])` and
    :math:`(Dk)_t = \sum_j c_j k_{t+j}` the difference operator given by
    ``order`` (equation :eq:`difference-operator` of the user guide). The data term runs over
    the R trajectories and the observed transitions (w_rt = 1 unless
    ``weights`` are given). With ``norm="group"`` or ``"l1"`` the penalty is
    :math:`\lambda \sum_t \lVert (Dk)_t \rVert_2` or
    :math:`\lambda \sum_t \lVert (Dk)_t \rVert_1` instead (see
    :doc:`/user_guide/methods` for the paper's Table I as calls). The
    squared fit is also the posterior mode of the Gaussian random walk of the
    coefficients
    with measurement noise σ_i² in state equation i and parameter drift
    σ_i²/λ² in its row, computed in O(N) by one banded Cholesky factorization
    shared by all rows of [A_t B_t].

    Parameters
    ----------
    x : array_like, shape (T, n), (R, T, n) or a list of R (T, n) arrays
        States, time on axis 0 (lists and pandas DataFrames are accepted).
        R time-aligned trajectories (repeated experiments, rollouts) share
        A_t, B_t. NaN marks a missing sample: a transition enters the data
        term only if x[t], u[t] and x[t+1] are observed; the coefficients of
        the steps in a gap are still estimated (the penalty carries them
        across) and their covariances grow there. Records joined with a NaN
        row between them are fitted as independent experiments in sequence.
    u : array_like, shape (T, m), (T,) or (R, T, m), optional
        Inputs (NaN = missing).
    lam : float, array_like (K,) or (K, K), or "auto"
        Regularization. A scalar λ >= 0 gives λ² Σ‖(Dk)_t‖². A (K,) vector gives
        Σ_j λ_j² ‖(Dk_j)‖²: ``np.inf`` holds coefficient j constant in time and
        0 leaves it free. A (K, K) positive semidefinite matrix Λ gives
        Σ_t (Dk)_tᵀ Λ (Dk)_t (the paper's Discussion). Large λ → LTI model.
        "auto" chooses a scalar λ by :func:`ltvmodels.select_lambda` with the
        default criterion of the norm (``selection.DEFAULT_METHOD``: maximum
        marginal likelihood for "sq", the L-curve corner for "group" and
        "l1") and records the choice in ``info["lam_selection"]``.
    norm : {"sq", "group", "l1"}
        "sq": squared 2-norm (slowly varying / smooth). "group": the
        non-squared 2-norm λ Σ_t ‖(Dk)_t‖₂ (the paper's piecewise constant and
        piecewise linear problems):
        few time steps where all coefficients change together (piecewise
        constant for order 1, piecewise linear for order 2). "l1":
        λ Σ_t ‖(Dk)_t‖₁ (the paper's coefficient-wise variant of the piecewise
        constant problem): sparse changes per coefficient.
        The sparse norms take a scalar or (K,) vector λ > 0, where ``np.inf``
        holds a coefficient constant in time (see ``tol`` for the solvers);
        priors, covariances and the likelihood are available for "sq" only.
    order : int or sequence of float
        1: first difference (slowly varying); 2: second difference (smooth); an integer d: d-th
        difference; or polynomial coefficients c_0 … c_d, summing to zero, for (Dk)_t = Σ_j c_j
        k_{t+j} (Proposition 1), e.g. ``[-1, 3, -3, 1]``.
    prior : Prior, OutputPrior, or a list of them, optional
        Gaussian priors on k_t or on the one-step output (paper Section IV).
    prior_mode : {"exact", "posthoc"}
        "exact" finds the maximum a posteriori estimate under the prior exactly (the prior as a
        second measurement in the normal equations); "posthoc" applies the paper's correction
        (its repeated Kalman correction step) to the prior-free smoothed estimates.
    noise_var : float or array_like of shape (n,), optional
        Noise variance, shared or one per state equation; weighs priors
        against the data and scales the covariances. Default:
        maximum-likelihood estimate given λ, one per state equation
        (``model.noise_var`` has shape (n,)); where a (K, K) λ or a prior
        couples the equations' rows of [A_t B_t], one variance shared by all.
    compute_cov : bool
        Compute posterior covariances (selected inversion, O(N)); False skips them.
    max_iter, tol : int, float
        For "group" and "l1" (unused for "sq"): the iteration limit and the
        relative tolerance. For "l1", and for "group" with K <= 64 parameters
        per time step, the solver is a primal-dual interior-point method whose
        Newton systems are
        block-banded (:mod:`ltvmodels.core.ipm`, 10–30 iterations): ``tol``
        bounds the duality gap relative to the objective
        (``info["duality_gap"]``) and the relative primal and dual residuals.
        If its Newton systems lose definiteness first (this happens near
        degenerate optima, e.g. order 2 close to λ_max), an active-set polish
        (:mod:`ltvmodels.core.polish`, orders 1 and 2) solves the problem
        with the zero differences fixed and certifies the result the same
        way; ``info["polished"]`` says so. Otherwise ADMM
        (:mod:`ltvmodels.core.admm`) stops on the same certificate (the
        duality gap relative to the objective and the relative stationarity
        residual below ``tol``; ``info["duality_gap"]``,
        ``info["stationarity"]``), or warns.
    refine : bool
        Two-step refinement (paper Section III-G): find the change points of
        this fit (:func:`ltvmodels.find_changepoints`, default rules) and refit
        with coefficients constant (order 1) or linear and continuous (order 2)
        between them (:func:`ltvmodels.fit_piecewise`), removing the penalty's
        shrinkage of the changes; a robust ``loss`` is kept for the refit. The
        refined model is returned; ``info["first_step"]`` summarizes the first fit and
        ``info["first_step_k"]`` holds its coefficients.
    weights : array_like, shape (T − 1,) or (R, T − 1), optional
        Weights >= 0 of the transitions' squared residuals (inverse relative
        noise variances; 0 drops a transition).
    constant : bool
        Fit an intercept: x[t+1] = A_t x[t] + B_t u[t] + c_t, with
        ``model.c`` (N, n) and k_t = rows of [A_t B_t c_t]. ``predict`` and
        ``simulate`` include it.
    loss : {"squared", "huber", "laplace"}
        The loss of each residual entry, with every norm:

        * "huber": h_δ(r) = r² for abs(r) <= δ and 2δ·abs(r) − δ² beyond (cvxpy's
          ``huber``), so λ keeps its meaning and a gross outlier pulls the fit
          as little as one δ away. Exact: damped Newton steps on reweighted
          squared-loss fits ("sq", stopped on the KKT residual), or the
          interior-point method with one more cone pair per residual entry
          ("group", "l1", stopped on its duality gap and residuals; proximal
          Newton on reweighted sparse fits where it does not apply); ``tol``
          and ``max_iter`` apply. ``model.beyond_delta`` marks the residuals
          beyond δ (Huber's linear region); ``info`` holds "huber_delta",
          "n_beyond_delta" and "kkt_residual". ``huber_delta`` below 1e-4 ×
          the robust scale of the squared-loss residuals is an error (use
          "laplace"). With a sparse norm and λ at or beyond the loss's own
          λ_max the answer is the robust fit with Dk = 0, computed directly.
        * "laplace": abs(r) (the paper's Laplacian noise, Section IV-A), the most
          robust. Exact: the interior-point method with one more cone pair
          per residual entry (Huber smoothing with an exact active-set polish
          where coefficients are held constant), stopped when a rigorous
          duality gap ("duality_gap" in ``info``, relative) is below ``tol``.

        With either, ``loglik`` is None, no ``cov`` is computed and
        ``noise_var`` is the residual mean square. "huber" with norm="sq"
        takes a ``Prior`` on the coefficients (prior_mode="exact"): the
        objective gains σ_i² Σ_t (k_t − μ_t)ᵀΣ_t⁻¹(k_t − μ_t) per output as for
        the squared loss, with σ_i² = ``noise_var`` or (δ_i / 1.345)².
        ``lam="auto"`` chooses λ by blocked cross-validation scored with the
        same loss (see :func:`ltvmodels.select_lambda`).
    huber_delta : float or array_like of shape (n,), optional
        δ in the units of x, shared or one per state. Default: 1.345 × 1.4826
        · MAD of each state's squared-loss residuals (Huber's 95 % efficiency
        at Gaussian noise).
    progress : callable, optional
        With ``lam="auto"``: called as ``progress(done, total)`` after each
        candidate λ is scored (see :func:`ltvmodels.select_lambda`), e.g. to
        draw a progress bar.
    regular : bool, default True
        Whether the time index of pandas data must lie on a regular grid (a fixed
        step or a calendar frequency): stamps missing from it become missing
        samples, with a :class:`~ltvmodels.DataWarning`. ``regular=False``
        declares the rows consecutive samples whatever their stamps (which must
        still increase); the model keeps them as its time axis.
    measurement_noise : None, float, array_like of shape (n,), or "estimate"
        None (default): the recorded states are exact. Otherwise they are
        measurements y_t = x_t + e_t of the states, e_{t,i} ~ N(0, σ_{e,i}²), with
        σ_{e,i}² given (one variance, or one per state) or estimated
        (``"estimate"``), and the process noise is N(0, σ_w² I / w_t) with one
        σ_w² (``noise_var``: a given value, else estimated). The model is fitted by
        expectation–maximization (:mod:`ltvmodels.estimators.measurement`): a Kalman
        smoother of the states, then this fit's own problem on their expected
        statistics, then the noise variances in closed form, increasing the
        penalized likelihood log p(x | Θ, σ²) − P(Θ)/(2σ_w²) (P the penalty). A
        sample with some entries missing contributes the others. ``lam="auto"``
        chooses λ on the recorded states first; ``refine=True`` runs EM with the
        penalty, then between its change points. The model has ``states`` and
        ``states_std`` (smoothed), ``measurement_noise`` (n,), ``loglik`` (the
        measurement model's likelihood of the recorded x), ``noise_var`` = σ_w²,
        no ``cov``, and ``info["em_iterations"]``, ``"em_converged"``,
        ``"em_objectives"``. Takes the squared loss.
    measurement_loss : {"squared", "huber", "student"}, default "squared"
        With ``measurement_noise``: the distribution of the measurement errors e.
        ``"squared"``: Gaussian. ``"student"``: Student-t with ν = 4 degrees of
        freedom (scale σ_{e,i}); ``"huber"``: Huber's density with δ = 1.345 σ_{e,i}.
        A corrupted recorded state is down-weighted in both of its roles (target
        and regressor): each EM iteration reweights every recorded entry by
        ω_ti (t: (ν + 1)/(ν + s_ti), Huber: min(1, δ/√s_ti), s_ti =
        E[(x_ti − state)²]/σ_{e,i}²), the smoother sees the variance σ_{e,i}²/ω_ti
        and σ_{e,i}² is updated as the weighted mean Σ ω E[(x − state)²] / count.
        EM then increases a lower bound of the robust model's penalized likelihood
        (:mod:`ltvmodels.core.measurement_weights`), reported as
        ``info["em_objectives"]``. A gross error's weight decays as 1/s with
        "student" and as 1/√s with "huber" (which therefore inflates σ_e more).
        ``model.sample_outliers`` ((T,) or (R, T) booleans, with every
        ``measurement_loss``) marks the samples with a standardized smoothed
        measurement residual abs(x_ti − E[state]) / √(σ_{e,i}² + Var(state)) above 3
        in an observed state. Needs ``measurement_noise`` (an error without it).
    em_tol, em_max_iter : float, int
        With ``measurement_noise``: EM stops when the relative change of its
        objective is at most ``em_tol`` (default 1e-6), or after ``em_max_iter``
        M-steps (default 500; 0 returns the fit on the recorded states with
        its smoothed states); ``model.status`` says which.
    em_accelerate : bool, default True
        With ``measurement_noise``: SQUAREM cycles (Varadhan & Roland 2008) —
        two EM iterations, an extrapolation of (Θ, log σ²) and one more EM
        iteration from it, accepted only where the objective increased, else
        the plain EM iterate — instead of plain EM (False). Both increase the
        objective at every accepted point and stop on the same rule;
        ``info["em_iterations"]`` counts M-steps, ``info["em_extrapolations"]``
        the extrapolations tried and accepted.

    Returns
    -------
    LTVModel
        With ``cov``, ``noise_var``, ``loglik`` (log marginal likelihood, see
        :mod:`ltvmodels.core.squared`) and ``info``.

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument).
    SingularProblemError
        The data do not identify the model (with the reason and remedies); also
        where one recorded sample dominates the objective of the squared loss with
        ``norm="group"`` or ``"l1"`` (more than 1e6 robust scales from its output's
        median, and the interior-point method cannot start): the message names the
        sample and says to mark it missing (NaN) or to use a robust loss.
    """
    spec = FitSpec.from_arguments(locals())  # every option, checked once
    data = state_space_data(
        x, u, order=spec.order, weights=weights, constant=constant, regular=regular
    )
    factory = partial(LTVModel, n_states=data.n, n_inputs=data.m, constant=data.constant)
    if spec.measurement_noise is not None:
        return data.describe(_fit_measured(data, spec, factory))
    model = fit_problem(
        data.problem,
        spec,
        factory=factory,
        regressor_names=data.regressor_names,
        data_name="x",
    )
    return data.describe(model)


def _fit_measured(
    data: StateSpaceData, spec: FitSpec, factory: Callable[..., LTVModel]
) -> LTVModel:
    """:func:`fit` with measurement noise: EM from the fit on the recorded states, at
    its λ (see :mod:`ltvmodels.estimators.measurement`)."""
    n, names = data.n, data.regressor_names
    options.measurement_noise(spec.measurement_noise, n)  # before the first fit
    if spec.loss != "squared":
        raise NotImplementedError(
            f"loss: {spec.loss!r} with measurement_noise is not available yet; use "
            "loss='squared' with measurement_noise, or measurement_noise=None"
        )
    noise_var = process_variance(spec.noise_var, n)
    first_spec = replace(spec, refine=False, compute_cov=False)
    first = fit_problem(
        data.problem, first_spec, factory=factory, regressor_names=names, data_name="x"
    )
    em_spec = replace(first_spec, lam=first.lam, progress=None)

    def mstep(problem: RegressionProblem, process_var: float) -> LTVModel:
        # σ_w² weighs a prior against the expected data term; without one it only
        # scales what the M-step's model reports, which EM replaces
        step = replace(em_spec, noise_var=process_var)
        return fit_problem(problem, step, factory=factory, regressor_names=names, data_name="x")

    def second(stage_one: LTVModel) -> Callable[[RegressionProblem, float], LTVModel]:
        def refit(problem: RegressionProblem, process_var: float) -> LTVModel:
            model: LTVModel = refine_fit(
                problem, stage_one, names=names, loss="squared", delta=None, factory=factory
            )
            return model

        return refit

    model: LTVModel = measurement_fit(
        data,
        first,
        mstep,
        measurement_noise=spec.measurement_noise,
        noise_var=noise_var,
        tol=spec.em_tol,
        max_iter=spec.em_max_iter,
        accelerate=spec.em_accelerate,
        label=spec.norm,
        second=second if spec.refine else None,
        measurement_loss=spec.measurement_loss,
    )
    if "lam_selection" in first.info:
        model.info["lam_selection"] = first.info["lam_selection"]
    return model


def _lti_step(
    problem: RegressionProblem, process_var: float, *, n: int, m: int, constant: bool
) -> LTVModel:
    """The LTI model of a problem's rows by least squares (the M-step of
    ``fit_lti(measurement_noise=...)``; ``process_var`` is unused: no prior)."""
    gram = problem.gram().sum(axis=0)
    cross = problem.cross().sum(axis=0)
    theta = np.linalg.solve(gram, cross).T  # (n, p)
    rss = float(problem.output_rss(np.broadcast_to(theta, (problem.N,) + theta.shape)).sum())
    k = np.broadcast_to(theta.ravel(), (problem.N, theta.size)).copy()
    solver = "least squares (normal equations)"
    return LTVModel(
        k,
        n,
        m,
        FitRecord(
            norm="lti",
            lam=float("inf"),
            noise_var=np.full(n, rss / max(problem.n_observed, 1)),
            info={"solver": solver, "rss": rss},
            changepoints=np.zeros(0, dtype=int),
            status=FitStatus("closed_form", solver, 0, rss),
        ),
        constant=constant,
    )


def fit_path(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
    lams: ArrayLike,
    norm: Norm = "sq",
    order: int | ArrayLike = 1,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
    weights: ArrayLike | None = None,
    constant: bool = False,
    regular: bool = True,
) -> list[LTVModel]:
    """Fit one model per scalar λ in ``lams`` (a regularization path).

    Equivalent to ``[fit(x, u, lam=lam, norm=norm, order=order) for lam in lams]``,
    but for the sparse norms the path is solved from the largest λ down, each
    run warm-started from the previous solution (the interior-point method from
    its primal-dual pair, ADMM from its z, w and ρ).

    Parameters
    ----------
    x, u, norm, order, compute_cov, max_iter, tol, weights, constant
        As in :func:`fit`.
    lams : sequence of float
        Scalar λ values (> 0 for "group" and "l1").
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    list of LTVModel
        In the order of ``lams``; ``model.info["path_position"]`` is the index
        in the order they were solved.
    """
    values = arrays.as_float_array(lams, "lams")
    if values.ndim != 1 or values.size == 0:
        raise ValueError(
            f"lams: expected a non-empty 1-d sequence of λ values, received shape {values.shape}"
        )
    for lam in values:  # each as fit checks lam, named as passed here
        try:
            options.penalty_weight(lam, 1)
        except ValueError as exc:
            raise ValueError("lams: " + str(exc).removeprefix("lam: ")) from None
    norm = options.norm_name(norm)
    if norm == "sq":
        return [
            fit(
                x,
                u,
                lam=float(lam),
                norm=norm,
                order=order,
                compute_cov=compute_cov,
                weights=weights,
                constant=constant,
                regular=regular,
            )
            for lam in values
        ]
    penalty = penalties.named(norm)
    data = _identifiable_data(x, u, order, weights, constant, regular)
    problem = data.problem
    max_iter = options.integer(max_iter, "max_iter", minimum=1)
    tol = options.positive_scalar(tol, "tol")
    factory = partial(LTVModel, n_states=data.n, n_inputs=data.m, constant=data.constant)
    models: dict[int, LTVModel] = {}  # by position in lams
    warm = None
    for position, index in enumerate(np.argsort(-values, kind="stable")):
        lam = float(values[index])
        weights = penalty.weights(lam, problem.K)
        solution = solve_sparse(
            problem, weights, penalty, max_iter=max_iter, tol=tol, warm_start=warm
        )
        warm = solution
        model = sparse_model(problem, lam, norm, solution, factory)
        model.info["path_position"] = position
        models[int(index)] = model
    return [models[i] for i in range(values.size)]


def lambda_max(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
    norm: SparseNorm,
    order: int | ArrayLike = 1,
    weights: ArrayLike | None = None,
    constant: bool = False,
    regular: bool = True,
) -> float:
    """The smallest λ at which ``fit(x, u, lam=λ, norm=norm, order=order)`` has Dk = 0.

    For the sparse norms, λ ≥ λ_max gives the null-space fit (the LTI model
    for ``order=1``, coefficients linear in time for ``order=2``) exactly; the
    interesting range of λ is below it (the default grid of
    :func:`ltvmodels.select_lambda` spans λ_max·[1e-3, 1]). λ_max follows from
    the optimality conditions of the null-space fit k̄: the unique dual vector
    ν with Dᵀν = −∇‖y − Φk̄‖² must satisfy ‖ν_t‖₂ ≤ λ (group) or
    abs(ν_tj) ≤ λ (l1) for every t, so λ_max = max_t ‖ν_t‖₂ (group) or
    max_tj abs(ν_tj) (l1). Costs one banded solve: no fit is run.

    Parameters
    ----------
    x : array_like, shape (T, n)
        States, time on axis 0 (lists and pandas DataFrames are accepted).
    u : array_like, shape (T, m) or (T,), optional
        Inputs.
    norm : {"group", "l1"}
        The sparse penalty (for ``norm="sq"`` every finite λ changes the
        model, so there is no λ_max).
    order, weights, constant
        As in :func:`fit`.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    float
        λ_max (the ``info["lambda_max"]`` of such a fit).

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument).
    SingularProblemError
        The data do not identify the null-space fit.

    Examples
    --------
    >>> import ltvmodels as ltv
    >>> data = ltv.systems.jump_linear(seed=0)
    >>> lmax = ltv.lambda_max(data.x, data.u, norm="group")
    >>> model = ltv.fit(data.x, data.u, lam=lmax, norm="group")
    >>> bool(model.status.status == "closed_form" and model.changepoints.size == 0)
    True
    """
    norm = options.choice(norm, "norm", options.SPARSE_NORMS)
    problem = _identifiable_data(x, u, order, weights, constant, regular).problem
    return problem_lambda_max(problem, penalties.named(norm))


def _identifiable_data(
    x: Any, u: Any, order: Any, weights: Any, constant: Any, regular: Any
) -> StateSpaceData:
    """Validated state-space data, checked for samples and identifiability."""
    data = state_space_data(x, u, order=order, weights=weights, constant=constant, regular=regular)
    problem = data.problem
    options.enough_samples(
        problem.N,
        problem.p,
        problem.degree,
        observed=problem.n_observed,
        n_rows=problem.N * problem.q,
    )
    identifiability.check(problem, has_prior=False, regressor_names=data.regressor_names)
    return data
