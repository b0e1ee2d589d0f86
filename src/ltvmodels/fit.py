"""Front-ends: data → regression problem (y, φ) → solver → model.

Every front-end only builds the regression y_t = Θ_t φ_t + e_t
(:class:`~ltvmodels.problem.RegressionProblem`) and hands it to one core,
:func:`_fit_problem`, which validates the options, checks identifiability,
dispatches to the solver of the norm and wraps the result in a model built by
the front-end's factory: :func:`fit` (state space, :class:`LTVModel`),
:func:`fit_regression` (any regressors, :class:`RegressionModel`) and the AR/ARX
front-ends of :mod:`ltvmodels.ar`.
"""

from __future__ import annotations

from functools import partial
from typing import Any, Callable

import numpy as np

from . import _validate, identifiability, priors as _priors
from .changepoints import find_changepoints
from .models import LTVModel, RegressionModel, model_activation
from .piecewise import fit_piecewise
from .problem import RegressionProblem, state_space_problem
from .selection import DEFAULT_METHOD, select_for_problem
from .solvers import admm, ipm
from .solvers.squared import CovarianceBlocks, fit_squared


def _regressor_names(n: int, m: int) -> list[str]:
    return [f"x{i}" for i in range(n)] + [f"u{j}" for j in range(m)]


def fit_lti(x: Any, u: Any = None) -> LTVModel:
    """Least-squares LTI model x[t+1] = A x[t] + B u[t] + v_t (paper eqs. lscost, ls).

    Minimizes Σ_t ‖x_{t+1} − A x_t − B u_t‖². All output rows share the
    regressor φ_t = [x_t; u_t], so this is one least-squares problem with n
    right-hand sides.

    Parameters
    ----------
    x : array_like, shape (T, n)
        States, time on axis 0. Lists and pandas DataFrames are accepted.
    u : array_like, shape (T, m) or (T,), optional
        Inputs.

    Returns
    -------
    LTVModel
        Constant A, B repeated over the N = T − 1 time steps. ``noise_cov`` is
        the unbiased residual covariance EᵀE / (N − p), ``cov`` the covariance
        Σ_v ⊗ (ΦᵀΦ)⁻¹ of k, ``loglik`` the Gaussian log-likelihood at the ML
        noise covariance.

    Raises
    ------
    SingularProblemError
        If the regressors are linearly dependent (no unique solution).
    """
    x, u = _validate.state_and_input(x, u)
    n, m = x.shape[1], u.shape[1]
    problem = state_space_problem(x, u, np.array([-1.0, 1.0]))
    N, p = problem.N, problem.p
    if N < p:
        raise ValueError(
            f"x: too few samples: {N} transitions cannot determine {p} regressors per "
            f"output; need T >= {p + 1}"
        )
    identifiability.check(problem, has_prior=False, regressor_names=_regressor_names(n, m))
    # QR-based least squares: solve, don't form (ΦᵀΦ)⁻¹ for the estimate.
    q, r = np.linalg.qr(problem.phi)
    theta = np.linalg.solve(r, q.T @ problem.y).T  # (n, p)
    resid = problem.y - problem.phi @ theta.T
    dof = N - p
    noise_cov = resid.T @ resid / dof if dof > 0 else np.full((n, n), np.nan)
    r_inv = np.linalg.solve(r, np.eye(p))
    gram_inv = r_inv @ r_inv.T  # (ΦᵀΦ)⁻¹ = R⁻¹R⁻ᵀ
    ml_cov = resid.T @ resid / N
    sign, logdet = np.linalg.slogdet(ml_cov)
    loglik = -0.5 * N * (n * np.log(2 * np.pi) + logdet + n) if sign > 0 else float("inf")
    K = n * p
    k = np.broadcast_to(theta.ravel(), (N, K)).copy()
    cov = None
    if dof > 0:
        cov_k = np.kron(noise_cov, gram_inv)
        cov = CovarianceBlocks(np.broadcast_to(cov_k, (N, K, K)), None)
    info = {"solver": "least-squares (QR)", "rss": float(np.sum(resid**2)), "dof": int(dof)}
    return LTVModel(
        k, n, m, norm="lti", coeffs=None, lam=float("inf"), cov=cov,
        noise_var=float(np.trace(noise_cov) / n) if dof > 0 else float("nan"),
        noise_cov=noise_cov, loglik=float(loglik), info=info,
        changepoints=np.zeros(0, dtype=int),
    )


def fit(
    x: Any,
    u: Any = None,
    *,
    lam: Any,
    norm: str = "sq",
    order: Any = 1,
    prior: Any = None,
    prior_mode: str = "exact",
    noise_var: float | None = None,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
    refine: bool = False,
) -> LTVModel:
    """Identify an LTV model x[t+1] = A_t x[t] + B_t u[t] + v_t.

    With ``norm="sq"`` this is the exact minimizer of (paper eqs. slow, smooth,
    generalkalman)

        Σ_t ‖x_{t+1} − A_t x_t − B_t u_t‖² + λ² Σ_t ‖(Dk)_t‖²,

    with k_t = vec([A_tᵀ B_tᵀ]) and (Dk)_t = Σ_j c_j k_{t+j} the difference
    operator given by ``order``. It is also the posterior mode of the Gaussian
    random walk (paper eq. dynsys) with measurement noise σ² I and parameter
    drift σ²/λ² I, computed in O(N) by one banded Cholesky factorization shared
    by all rows of [A_t B_t].

    Parameters
    ----------
    x : array_like, shape (T, n)
        States, time on axis 0 (lists and pandas DataFrames are accepted).
    u : array_like, shape (T, m) or (T,), optional
        Inputs.
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
        non-squared 2-norm λ Σ_t ‖(Dk)_t‖₂ (paper eqs. pwconstant, pwlinear):
        few time steps where all coefficients change together (piecewise
        constant for order 1, piecewise linear for order 2). "l1":
        λ Σ_t ‖(Dk)_t‖₁ (eq. pwconstant_naive): sparse changes per coefficient.
        The sparse norms take a scalar or (K,) vector λ > 0, where ``np.inf``
        holds a coefficient constant in time (see ``tol`` for the solvers);
        priors, covariances and the likelihood are available for "sq" only.
    order : int or sequence of float
        1: first difference (slowly varying, eq. slow); 2: second difference
        (smooth, eq. smooth); an integer d: d-th difference; or polynomial
        coefficients c_0 … c_d, summing to zero, for (Dk)_t = Σ_j c_j k_{t+j}
        (Proposition 1), e.g. ``[-1, 3, -3, 1]``.
    prior : Prior, OutputPrior, or a list of them, optional
        Gaussian priors on k_t or on the one-step output (paper Section IV).
    prior_mode : {"exact", "posthoc"}
        "exact" solves eq. prioropt exactly (the prior as a second measurement
        in the normal equations); "posthoc" applies the paper's correction
        (eqs. postk–postcov) to the prior-free smoothed estimates.
    noise_var : float, optional
        Noise variance σ²; weighs priors against the data and scales the
        covariances. Default: maximum-likelihood estimate given λ.
    compute_cov : bool
        Compute posterior covariances (selected inversion, O(N)); False skips them.
    max_iter, tol : int, float
        For "group" and "l1" (unused for "sq"): the iteration limit and the
        relative tolerance. With K <= 20 parameters per time step the solver is
        a primal-dual interior-point method whose Newton systems are
        block-banded (:mod:`ltvmodels.solvers.ipm`, 10–30 iterations): ``tol``
        bounds the duality gap relative to the objective
        (``info["duality_gap"]``) and the relative primal and dual residuals.
        If its Newton systems lose definiteness first (this happens near
        degenerate optima, e.g. order 2 close to λ_max), an active-set polish
        (:mod:`ltvmodels.solvers.polish`, orders 1 and 2) solves the problem
        with the zero differences fixed and certifies the result the same
        way; ``info["polished"]`` says so. Otherwise ADMM
        (:mod:`ltvmodels.solvers.admm`): ``tol`` applies to the relative primal
        and dual residuals.
    refine : bool
        Two-step refinement (paper Section III-G): find the change points of
        this fit (:func:`ltvmodels.find_changepoints`, default rules) and refit
        with coefficients constant (order 1) or linear and continuous (order 2)
        between them (:func:`ltvmodels.fit_piecewise`), removing the penalty's
        shrinkage of the changes. The refined model is returned;
        ``info["first_step"]`` summarizes the first fit and
        ``info["first_step_k"]`` holds its coefficients.

    Returns
    -------
    LTVModel
        With ``cov``, ``noise_var``, ``loglik`` (log marginal likelihood, see
        :mod:`ltvmodels.solvers.squared`) and ``info``.

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument).
    SingularProblemError
        The data do not identify the model (with the reason and remedies).
    """
    if not isinstance(refine, bool):
        raise TypeError(f"refine: expected True or False, received {refine!r}")
    if refine:
        first = fit(
            x, u, lam=lam, norm=norm, order=order, prior=prior, prior_mode=prior_mode,
            noise_var=noise_var, compute_cov=False, max_iter=max_iter, tol=tol,
        )
        return _refine(x, u, first)
    x, u = _validate.state_and_input(x, u)
    norm = _validate.norm_name(norm)
    coeffs = _validate.difference_coefficients(order, max_degree=x.shape[0])
    n, m = x.shape[1], u.shape[1]
    return _fit_problem(
        state_space_problem(x, u, coeffs),
        factory=partial(LTVModel, n_states=n, n_inputs=m),
        regressor_names=_regressor_names(n, m),
        data_name="x",
        lam=lam, norm=norm, prior=prior, prior_mode=prior_mode, noise_var=noise_var,
        compute_cov=compute_cov, max_iter=max_iter, tol=tol,
    )


def fit_regression(
    y: Any,
    phi: Any,
    *,
    lam: Any,
    norm: str = "sq",
    order: Any = 1,
    prior: Any = None,
    prior_mode: str = "exact",
    noise_var: float | None = None,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
) -> RegressionModel:
    """Identify a time-varying regression y_t = Θ_t φ_t + e_t (DESIGN §1).

    The general problem behind every front-end: any model linear in its
    parameters (paper, Discussion). With ``norm="sq"`` it is the exact minimizer of

        Σ_t ‖y_t − Θ_t φ_t‖² + λ² Σ_t ‖(Dk)_t‖²,   k_t = Θ_t.ravel() (rows of Θ_t),

    and with ``norm="group"`` / ``"l1"`` of Σ_t ‖y_t − Θ_t φ_t‖² + λ Σ_t ‖(Dk)_t‖
    (2-norm, not squared / 1-norm), solved exactly as in :func:`fit`. The n
    output rows share the regressor φ_t (Θ_t is n × p, K = n·p). :func:`fit`
    is this with y_t = x_{t+1} and φ_t = [x_t; u_t]; for piecewise-constant
    models with a known number of changes use
    :func:`ltvmodels.segments.segment_regression` on the same (y, φ).

    Parameters
    ----------
    y : array_like, shape (N, n) or (N,)
        Outputs, time on axis 0 (lists and pandas objects are accepted).
    phi : array_like, shape (N, p) or (N,)
        Regressors, one row per output row.
    lam, norm, order, prior, prior_mode, noise_var, compute_cov, max_iter, tol
        As in :func:`fit`, with K = n·p parameters per time step (a ``Prior``
        mean is (K,) or (N, K); an ``OutputPrior`` is a prior on Θ_t φ_t).

    Returns
    -------
    RegressionModel
        ``theta`` (N, n, p), ``k`` (N, K), ``predict(phi)`` → (N, n),
        ``cov`` (N, p, p) shared by the rows or (N, K, K), ``noise_var``,
        ``loglik`` and ``info`` as for :func:`fit`.

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument), too few rows for the
        number of regressors and the order.
    SingularProblemError
        The data do not identify the model (with the reason and remedies).

    Examples
    --------
    >>> import numpy as np, ltvmodels as ltv
    >>> rng = np.random.default_rng(0)
    >>> phi = rng.standard_normal((200, 2))
    >>> slope = np.linspace(1.0, 2.0, 200)
    >>> y = slope * phi[:, 0] - 0.5 * phi[:, 1] + 0.01 * rng.standard_normal(200)
    >>> model = ltv.fit_regression(y, phi, lam=100.0, order=2)
    >>> model.theta.shape
    (200, 1, 2)
    >>> bool(np.abs(model.theta[:, 0, 0] - slope).max() < 0.05)
    True
    """
    y, phi = _validate.regression_data(y, phi)
    norm = _validate.norm_name(norm)
    coeffs = _validate.difference_coefficients(order, max_degree=y.shape[0])
    n, p = y.shape[1], phi.shape[1]
    return _fit_problem(
        RegressionProblem(y=y, phi=phi, coeffs=coeffs),
        factory=partial(RegressionModel, n_outputs=n, n_regressors=p),
        regressor_names=[f"phi{j}" for j in range(p)],
        data_name="y",
        lam=lam, norm=norm, prior=prior, prior_mode=prior_mode, noise_var=noise_var,
        compute_cov=compute_cov, max_iter=max_iter, tol=tol,
    )


ModelFactory = Callable[..., RegressionModel]
"""Builds the result from k (N, K) and the keyword arguments of RegressionModel."""


def _fit_problem(
    problem: RegressionProblem,
    *,
    factory: ModelFactory,
    regressor_names: list[str],
    data_name: str,
    lam: Any,
    norm: str,
    prior: Any,
    prior_mode: str,
    noise_var: Any,
    compute_cov: Any,
    max_iter: Any,
    tol: Any,
    rows_note: str = "",
) -> RegressionModel:
    """The core shared by every front-end: a validated (y, φ) problem → model.

    Validates the remaining options, checks the sample count and
    identifiability (naming ``regressor_names`` in messages and ``data_name``
    as the argument), solves with the solver of ``norm`` and builds the model
    with ``factory(k, norm=..., coeffs=..., lam=..., ...)``. ``rows_note`` is
    added to a too-few-samples message (e.g. how the rows relate to T).
    """
    norm = _validate.norm_name(norm)
    prior_mode = _validate.choice(prior_mode, "prior_mode", ("exact", "posthoc"))
    if noise_var is not None:
        noise_var = _validate.positive_scalar(noise_var, "noise_var")
    if not isinstance(compute_cov, bool):
        raise TypeError(f"compute_cov: expected True or False, received {compute_cov!r}")
    selection = None
    if _validate.is_auto(lam, "lam"):
        if prior is not None:
            raise ValueError(
                "lam: 'auto' chooses λ from the data alone and does not take a prior into "
                "account; choose λ with ltvmodels.select_lambda or pass a number"
            )
        _enough_samples(problem, data_name, rows_note)
        identifiability.check(problem, has_prior=False, regressor_names=regressor_names)
        selection = select_for_problem(problem, norm, DEFAULT_METHOD[norm], None)
        lam = selection.lam
    model = _fit_with_lam(
        problem, factory=factory, regressor_names=regressor_names, data_name=data_name,
        lam=lam, norm=norm, prior=prior, prior_mode=prior_mode, noise_var=noise_var,
        compute_cov=compute_cov, max_iter=max_iter, tol=tol, rows_note=rows_note,
    )
    if selection is not None:
        model.info["lam_selection"] = {
            "method": selection.method, "lam": selection.lam,
            "lams": selection.lams.tolist(), "scores": selection.scores.tolist(),
        }
    return model


def _fit_with_lam(
    problem: RegressionProblem, *, factory, regressor_names, data_name, lam, norm, prior,
    prior_mode, noise_var, compute_cov, max_iter, tol, rows_note,
) -> RegressionModel:
    """:func:`_fit_problem` for a given λ, on validated options."""
    n, p = problem.n, problem.p
    N, K = problem.N, problem.K
    if norm != "sq":
        if prior is not None:
            raise NotImplementedError(
                f"prior: priors are available with norm='sq' only, not yet with norm={norm!r}"
            )
        max_iter = _validate.integer(max_iter, "max_iter", minimum=1)
        tol = _validate.positive_scalar(tol, "tol")
        weights = _validate.sparse_weights(lam, K)
        _enough_samples(problem, data_name, rows_note)
        identifiability.check(problem, has_prior=False, regressor_names=regressor_names)
        model, _ = _solve_sparse(
            problem, lam, weights, norm, n, p - n, max_iter=max_iter, tol=tol, factory=factory
        )
        return model
    W = _validate.penalty_weight(lam, K)
    _enough_samples(problem, data_name, rows_note)
    terms = _priors.resolve(prior, N, n, p)

    const = np.isinf(np.diag(W)).reshape(n, p)
    identifiability.check(
        problem,
        has_prior=bool(terms),
        regressor_names=regressor_names,
        const_mask=const.all(axis=0) if const.any() else None,
    )

    exact_terms = terms if prior_mode == "exact" else []
    result = fit_squared(
        problem, W, exact_terms, noise_var=noise_var,
        compute_cov=compute_cov or (prior_mode == "posthoc" and bool(terms)),
    )
    k = result.theta.reshape(N, K)
    cov = result.cov
    info = {
        "solver": "block-banded Cholesky (exact)",
        "iterations": 1,  # one direct solve
        "converged": True,
        "objective": result.objective,
        "rss": result.rss,
        "penalty": result.penalty,
        "prior_cost": result.prior_cost,
        "n_factorizations": result.n_factorizations,
        "noise_var_estimated": result.noise_var_estimated,
        "n_eff": result.n_eff,
        "prior_mode": prior_mode if terms else "none",
        **result.info,
    }
    loglik = result.loglik
    if terms and prior_mode == "posthoc":
        blocks = np.array(cov.full(n, p))
        for term in terms:
            k, blocks = _priors.posthoc_correction(k, blocks, term, problem.phi)
        cov = CovarianceBlocks(blocks, None) if compute_cov else None
        loglik = float("nan")
        info["loglik_note"] = "no likelihood is defined for the posthoc correction"
    noise_cov = np.eye(n) * result.noise_var
    return factory(
        k, norm=norm, coeffs=problem.coeffs,
        lam=float(lam) if np.ndim(lam) == 0 else np.array(lam, float),  # a copy: no aliasing
        cov=cov, noise_var=result.noise_var, noise_cov=noise_cov, loglik=loglik, info=info,
    )


def _enough_samples(problem: RegressionProblem, data_name: str, rows_note: str) -> None:
    if data_name == "x":  # state space: rows are transitions, T = N + 1
        _validate.enough_samples(problem.N, problem.p, problem.degree)
    else:
        _validate.enough_rows(problem.N, problem.p, problem.degree, data_name, rows_note)


# Up to this many parameters per time step the interior-point method's dense
# K × K Newton blocks are cheap; beyond, ADMM's per-row p × p systems win.
IPM_MAX_K = 20


def _solve_sparse(
    problem, lam, weights, norm, n, m, *, max_iter, tol, warm_start=None, factory=None
):
    """Solve on validated inputs; returns (model, ADMM result or None).

    The interior-point method (:mod:`ltvmodels.solvers.ipm`) is used when every
    weight is positive and K <= IPM_MAX_K, ADMM otherwise. ``factory`` builds
    the model (see :func:`_fit_problem`); without it an ``LTVModel`` with n
    states and m inputs (n + m = p).
    """
    N, K = problem.N, problem.K
    if factory is None:
        factory = partial(LTVModel, n_states=n, n_inputs=m)
    n = problem.n
    info: dict = {}
    theta_bar = admm.null_space_fit(problem)
    # The largest finite weight at which this weight pattern gives the LTI fit
    # (weights of inf hold their coefficients constant at any λ).
    finite = weights[np.isfinite(weights)]
    scale = finite.max() if finite.size else np.inf
    lam_max = admm.lambda_max(problem, norm, weights / scale, theta_bar) if finite.size else 0.0
    if np.all(weights > 0) and scale >= lam_max:
        # Dk = 0 is optimal (λ_max's dual certificate): the null-space fit, exactly.
        theta, result = theta_bar, None
        info.update(
            solver="closed form (lam >= lambda_max)", iterations=0, converged=True,
            objective=float(np.sum(problem.residuals(theta) ** 2)), duality_gap=0.0,
        )
    elif K <= IPM_MAX_K and np.all(weights > 0):
        ip = ipm.fit_sparse_ipm(problem, weights, norm, tol=tol, max_iter=max_iter)
        theta, result = ip.theta, None
        info.update(
            solver="interior point (block-banded Newton systems)", iterations=ip.iterations,
            converged=ip.converged, objective=ip.objective, duality_gap=ip.duality_gap,
            primal_residual=ip.primal_residual, dual_residual=ip.dual_residual,
            polished=ip.polished,
        )
    else:
        if np.isinf(weights).any():
            raise NotImplementedError(
                "lam: constant coefficients (lam = inf) with norm='group' or 'l1' need every "
                f"weight > 0 and at most {IPM_MAX_K} parameters per time step, received "
                f"K = {K} and {int(np.sum(weights == 0))} zero weights"
            )
        result = admm.fit_sparse(
            problem, weights, norm, max_iter=max_iter, tol=tol, warm_start=warm_start
        )
        theta = result.theta
        info.update(
            solver="ADMM (banded k-update)", iterations=result.iterations,
            converged=result.converged, objective=result.objective,
            primal_residual=result.primal_residual, dual_residual=result.dual_residual,
            rho=result.rho, n_factorizations=result.n_factorizations,
        )
    k = theta.reshape(N, K)
    rss = float(np.sum(problem.residuals(theta) ** 2))
    noise_var = rss / (N * n)
    info["rss"] = rss
    info["lambda_max"] = lam_max
    model = factory(
        k, norm=norm, coeffs=problem.coeffs,
        lam=float(lam) if np.ndim(lam) == 0 else np.array(lam, float),
        noise_var=noise_var, noise_cov=np.eye(n) * noise_var, info=info,
        changepoints=find_changepoints(model_activation(k, problem.coeffs), degree=problem.degree),
    )
    return model, result


def _refine(x: Any, u: Any, first: LTVModel) -> LTVModel:
    """Second step of the two-step refinement: refit between the change points."""
    degree = len(first.coeffs) - 1
    if degree not in (1, 2):
        raise NotImplementedError(
            f"refine: the refit is defined for order 1 and 2, received a difference "
            f"operator of degree {degree}"
        )
    changepoints = first.changepoints if first.norm != "sq" else find_changepoints(first)
    refined = fit_piecewise(x, u, changepoints, order=degree)
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


def fit_path(
    x: Any,
    u: Any = None,
    *,
    lams: Any,
    norm: str = "sq",
    order: Any = 1,
    compute_cov: bool = True,
    max_iter: int = 10000,
    tol: float = 1e-6,
) -> list[LTVModel]:
    """Fit one model per scalar λ in ``lams`` (a regularization path).

    Equivalent to ``[fit(x, u, lam=lam, norm=norm, order=order) for lam in lams]``,
    but for the sparse norms the path is solved from the largest λ down; where
    ADMM is the solver each run is warm-started from the previous solution (its
    z, w and ρ).

    Parameters
    ----------
    x, u, norm, order, compute_cov, max_iter, tol
        As in :func:`fit`.
    lams : sequence of float
        Scalar λ values (> 0 for "group" and "l1").

    Returns
    -------
    list of LTVModel
        In the order of ``lams``; ``model.info["path_position"]`` is the index
        in the order they were solved.
    """
    values = _validate.as_float_array(lams, "lams")
    if values.ndim != 1 or values.size == 0:
        raise ValueError(f"lams: expected a non-empty 1-d sequence of λ values, received "
                         f"shape {values.shape}")
    norm = _validate.norm_name(norm)
    if norm == "sq":
        return [fit(x, u, lam=float(lam), norm=norm, order=order, compute_cov=compute_cov)
                for lam in values]
    x, u = _validate.state_and_input(x, u)
    coeffs = _validate.difference_coefficients(order, max_degree=x.shape[0])
    max_iter = _validate.integer(max_iter, "max_iter", minimum=1)
    tol = _validate.positive_scalar(tol, "tol")
    n, m = x.shape[1], u.shape[1]
    problem = state_space_problem(x, u, coeffs)
    _validate.enough_samples(problem.N, problem.p, problem.degree)
    identifiability.check(problem, has_prior=False, regressor_names=_regressor_names(n, m))
    models: list[LTVModel | None] = [None] * values.size
    warm = None
    for position, index in enumerate(np.argsort(-values, kind="stable")):
        weights = _validate.sparse_weights(float(values[index]), problem.K)
        model, warm = _solve_sparse(
            problem, float(values[index]), weights, norm, n, m,
            max_iter=max_iter, tol=tol, warm_start=warm,
        )
        model.info["path_position"] = position
        models[index] = model
    return models
