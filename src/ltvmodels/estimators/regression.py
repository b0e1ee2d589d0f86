"""The shared core of every front-end: a regression problem (y, φ) → solver → model.

Every front-end only builds the regression y_t = Θ_t φ_t + e_t
(:class:`~ltvmodels.core.problem.RegressionProblem`) and hands it to
:func:`fit_problem`, which validates the options, checks identifiability,
dispatches to the solver of the norm and wraps the result in a model built by
the front-end's factory: :func:`ltvmodels.fit` (state space,
:class:`~ltvmodels.LTVModel`), :func:`fit_regression` (any regressors,
:class:`~ltvmodels.RegressionModel`) and :func:`ltvmodels.fit_ar` /
:func:`ltvmodels.fit_arx` (:class:`~ltvmodels.ARXModel`).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any, Literal, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from ..core import identifiability
from ..core.covariance import CovarianceBlocks
from ..core.priorterms import posthoc_correction
from ..core.problem import RegressionProblem, activation
from ..core.sparse import SparseSolution, solve_sparse
from ..core.squared import fit_squared, weight_diagonal
from ..results.base import signal_names
from ..results.record import FitRecord, FitStatus, iterative_status
from ..results.regression import RegressionModel
from ..validation import arrays, options
from ..validation.options import Loss, Norm, PriorMode
from .changepoints import find_changepoints, residue_level
from .piecewise import refine_fit
from .priors import resolve as resolve_priors
from .recordings import regression_problem, require_enough_data
from .robust import robust_model
from .selection import DEFAULT_METHOD, select_for_problem

__all__ = ["fit_regression", "fit_problem", "sparse_model", "last_segment_unit_cov"]

ModelT = TypeVar("ModelT", bound=RegressionModel)
"""The model a front-end's factory builds (RegressionModel, LTVModel, ARXModel, …)."""
ModelFactory = Callable[..., ModelT]
"""Builds the result: ``factory(k, fit=FitRecord(...))`` with k of shape (N, K)."""


def fit_regression(
    y: ArrayLike,
    phi: ArrayLike,
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
    weights: ArrayLike | None = None,
    loss: Loss = "squared",
    huber_delta: float | ArrayLike | None = None,
    refine: bool = False,
) -> RegressionModel:
    """Identify a time-varying regression y_t = Θ_t φ_t + e_t.

    The general problem behind every front-end: any model linear in its
    parameters (paper, Discussion). With ``norm="sq"`` it is the exact minimizer of

        Σ_t ‖y_t − Θ_t φ_t‖² + λ² Σ_t ‖(Dk)_t‖²,   k_t = Θ_t.ravel() (rows of Θ_t),

    and with ``norm="group"`` / ``"l1"`` of Σ_t ‖y_t − Θ_t φ_t‖² + λ Σ_t ‖(Dk)_t‖
    (2-norm, not squared / 1-norm), solved exactly as in :func:`fit`. The n
    output rows share the regressor φ_t (Θ_t is n × p, K = n·p). :func:`fit`
    is this with y_t = x_{t+1} and φ_t = [x_t; u_t]; for piecewise-constant
    models with a known number of changes use
    :func:`ltvmodels.segment_regression` on the same (y, φ).

    Parameters
    ----------
    y : array_like, shape (N, n), (N,) or (R, N, n)
        Outputs, time on axis 0 (lists and pandas objects are accepted); R
        time-aligned series share Θ_t. NaN marks a missing sample: a row
        enters the data term only if y_t and φ_t are observed.
    phi : array_like, shape (N, p), (N,) or (R, N, p)
        Regressors, one row per output row.
    lam, norm, order, prior, prior_mode, noise_var, compute_cov, max_iter, tol, weights
        As in :func:`fit`, with K = n·p parameters per time step (a ``Prior``
        mean is (K,) or (N, K); an ``OutputPrior`` is a prior on Θ_t φ_t).
    loss, huber_delta
        As in :func:`fit` (δ in the units of y).
    refine : bool
        The two-step refinement, as in :func:`fit`: refit with coefficients
        constant (order 1) or linear and continuous (order 2) between the
        change points of this fit, removing the penalty's shrinkage of the
        changes (``info["first_step"]`` summarizes the first fit).

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
    if not isinstance(refine, bool):
        raise TypeError(f"refine: expected True or False, received {refine!r}")
    problem = regression_problem(y, phi, order=order, weights=weights)
    norm = options.norm_name(norm)
    n, p = problem.n, problem.p
    factory = partial(RegressionModel, n_outputs=n, n_regressors=p)
    columns = {"output": arrays.column_names(y, n), "regressor": arrays.column_names(phi, p)}
    described = {key: value for key, value in columns.items() if value is not None}
    time = arrays.time_index(y, problem.N) if problem.q == 1 else None
    names = described.get("regressor", signal_names("phi", p))
    model = fit_problem(
        problem,
        factory=factory,
        regressor_names=names,
        data_name="y",
        lam=lam,
        norm=norm,
        prior=prior,
        prior_mode=prior_mode,
        noise_var=noise_var,
        compute_cov=compute_cov and not refine,
        max_iter=max_iter,
        tol=tol,
        loss=loss,
        huber_delta=huber_delta,
    )
    if refine:
        _, delta = options.loss_options(loss, huber_delta, n)
        model = refine_fit(
            problem,
            model,
            names=names,
            loss=loss,
            delta=delta,
            factory=factory,
            n_missing=int((~problem.observed).sum()),
        )
    if described:
        model.info["signal_names"] = described
    if time is not None:
        model.info["time"] = time
    return model


def fit_problem(
    problem: RegressionProblem,
    *,
    factory: ModelFactory[ModelT],
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
    loss: Any = "squared",
    huber_delta: Any = None,
    progress: Any = None,
) -> ModelT:
    """The core shared by every front-end: a validated (y, φ) problem → model.

    Validates the remaining options, checks the sample count and
    identifiability (naming ``regressor_names`` in messages and ``data_name``
    as the argument), solves with the solver of ``norm`` and builds the model
    with ``factory(k, fit=FitRecord(...))``. ``rows_note`` is
    added to a too-few-samples message (e.g. how the rows relate to T).
    ``progress`` follows the choice of λ for ``lam="auto"`` (see
    :func:`ltvmodels.select_lambda`).
    """
    norm = options.norm_name(norm)
    prior_mode = options.choice(prior_mode, "prior_mode", options.PRIOR_MODES)
    noise_var = options.noise_variance(noise_var, problem.n)
    loss, huber_delta = options.loss_options(loss, huber_delta, problem.n)
    if not isinstance(compute_cov, bool):
        raise TypeError(f"compute_cov: expected True or False, received {compute_cov!r}")
    selection = None
    if options.is_auto(lam, "lam"):
        if prior is not None:
            raise ValueError(
                "lam: 'auto' chooses λ from the data alone and does not take a prior into "
                "account; choose λ with ltvmodels.select_lambda or pass a number"
            )
        require_enough_data(problem, data_name, rows_note)
        identifiability.check(problem, has_prior=False, regressor_names=regressor_names)
        method = DEFAULT_METHOD[norm] if loss == "squared" else "cv"
        selection = select_for_problem(
            problem,
            norm,
            method,
            None,
            loss=loss,
            delta=huber_delta,
            progress=options.callback(progress, "progress"),
        )
        lam = selection.lam
        if selection.huber_delta is not None:  # the model has the loss λ was chosen for
            huber_delta = np.array(selection.huber_delta)
    model = _fit_with_lam(
        problem,
        factory=factory,
        regressor_names=regressor_names,
        data_name=data_name,
        lam=lam,
        norm=norm,
        prior=prior,
        prior_mode=prior_mode,
        noise_var=noise_var,
        compute_cov=compute_cov,
        max_iter=max_iter,
        tol=tol,
        rows_note=rows_note,
        loss=loss,
        huber_delta=huber_delta,
    )
    if selection is not None:
        model.info["lam_selection"] = {
            "method": selection.method,
            "lam": selection.lam,
            "lams": selection.lams.tolist(),
            # None where there is no score (a skipped candidate, an L-curve without a bend)
            "scores": [float(v) if np.isfinite(v) else None for v in selection.scores],
            "loss": selection.loss,
            "n_fits": selection.n_fits,
        }
        if selection.skipped:
            model.info["lam_selection"]["skipped"] = [list(item) for item in selection.skipped]
    return model


def _fit_with_lam(
    problem: RegressionProblem,
    *,
    factory: ModelFactory[ModelT],
    regressor_names,
    data_name,
    lam,
    norm,
    prior,
    prior_mode,
    noise_var,
    compute_cov,
    max_iter,
    tol,
    rows_note,
    loss="squared",
    huber_delta=None,
) -> ModelT:
    """:func:`fit_problem` for a given λ, on validated options."""
    n, p = problem.n, problem.p
    N, K = problem.N, problem.K
    if norm != "sq":
        if prior is not None:
            raise NotImplementedError(
                f"prior: priors are available with norm='sq' only, not yet with norm={norm!r}"
            )
        max_iter = options.integer(max_iter, "max_iter", minimum=1)
        tol = options.positive_scalar(tol, "tol")
        weights = options.sparse_weights(lam, K)
        require_enough_data(problem, data_name, rows_note)
        identifiability.check(problem, has_prior=False, regressor_names=regressor_names)
        if loss != "squared":
            _no_robust_option(noise_var, "noise_var", loss)
            return robust_model(
                problem,
                weights,
                loss=loss,
                lam=_lam_copy(lam),
                norm=norm,
                delta=huber_delta,
                factory=factory,
                max_iter=max_iter,
                tol=tol,
            )
        solution = solve_sparse(problem, weights, norm, max_iter=max_iter, tol=tol)
        return sparse_model(problem, lam, norm, solution, factory)
    require_enough_data(problem, data_name, rows_note)  # before a (K, K) λ is checked
    W = options.penalty_weight(lam, K)
    terms = resolve_priors(prior, N, n, p)
    if not problem.complete and any(term.on == "output" for term in terms):
        raise NotImplementedError(
            "prior: an OutputPrior needs one complete trajectory (no missing samples, "
            "weights or batches); use a Prior on the coefficients instead"
        )

    const = np.isinf(weight_diagonal(W)).reshape(n, p)
    identifiability.check(
        problem,
        has_prior=bool(terms),
        regressor_names=regressor_names,
        const_mask=const.all(axis=0) if const.any() else None,
    )
    if loss != "squared":
        if loss == "laplace":
            _no_robust_option(prior, "prior", loss)
            _no_robust_option(noise_var, "noise_var", loss)
        elif terms and prior_mode != "exact":
            raise NotImplementedError(
                "prior_mode: 'posthoc' is not available with loss='huber'; use prior_mode='exact'"
            )
        return robust_model(
            problem,
            W,
            loss=loss,
            lam=_lam_copy(lam),
            norm=norm,
            delta=huber_delta,
            factory=factory,
            max_iter=options.integer(max_iter, "max_iter", minimum=1),
            tol=options.positive_scalar(tol, "tol"),
            priors=terms,
            noise_var=None if noise_var is None else np.broadcast_to(noise_var, (n,)).copy(),
        )

    exact_terms = terms if prior_mode == "exact" else []
    result = fit_squared(
        problem,
        W,
        exact_terms,
        noise_var=noise_var,
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
        if cov is None:  # fit_squared computes it for this correction
            raise RuntimeError("the post-hoc prior correction needs the posterior covariance")
        blocks = np.array(cov.full(n, p))
        for term in terms:
            k, blocks = posthoc_correction(k, blocks, term, problem.phi[:, 0])
        cov = CovarianceBlocks(blocks, None) if compute_cov else None
        loglik = None
        info["loglik_note"] = "no likelihood is defined for the posthoc correction"
    noise_cov = np.diag(result.noise_var)
    status = FitStatus(
        "closed_form",
        info["solver"],
        1,
        result.objective,
        {"n_factorizations": result.n_factorizations},
    )
    return factory(
        k,
        fit=FitRecord(
            norm=norm,
            coeffs=problem.coeffs,
            lam=_lam_copy(lam),
            cov=cov,
            noise_var=result.noise_var,
            noise_cov=noise_cov,
            loglik=loglik,
            info=info,
            status=status,
        ),
    )


def sparse_model(
    problem: RegressionProblem,
    lam: Any,
    norm: str,
    solution: SparseSolution,
    factory: ModelFactory[ModelT],
) -> ModelT:
    """The model of a sparse-norm solution: noise from the residuals, change points detected.

    ``noise_var`` is the residual mean square of each output, RSS_i / (observed
    rows); ``changepoints``
    are :func:`~ltvmodels.find_changepoints` of the activation with the
    default rules.
    """
    N, K = problem.N, problem.K
    k = solution.theta.reshape(N, K)
    info = {
        "solver": solution.solver,
        "iterations": solution.iterations,
        "converged": solution.converged,
        "objective": solution.objective,
        **solution.details,
        "rss": solution.rss,
        "lambda_max": solution.lambda_max,
    }
    status = FitStatus(
        "closed_form"
        if solution.closed_form
        else iterative_status(
            solution.converged, polished=solution.polished, stalled=solution.stalled
        ),
        solution.solver,
        solution.iterations,
        solution.objective,
        {**solution.details, "lambda_max": solution.lambda_max},
    )
    noise_var = problem.output_rss(solution.theta) / max(problem.n_observed, 1)
    info["loglik_note"] = f"norm={norm!r} has no Gaussian likelihood; loglik is None"
    changepoints = find_changepoints(
        activation(k, problem.coeffs), degree=problem.degree, min_level=residue_level(k)
    )
    unit = last_segment_unit_cov(problem, changepoints)
    if unit is not None:
        info["last_segment_unit_cov"] = unit
    return factory(
        k,
        fit=FitRecord(
            norm=norm,
            coeffs=problem.coeffs,
            lam=_lam_copy(lam),
            noise_var=noise_var,
            noise_cov=np.diag(noise_var),
            info=info,
            changepoints=changepoints,
            status=status,
        ),
    )


def last_segment_unit_cov(
    problem: RegressionProblem, changepoints: np.ndarray
) -> np.ndarray | None:
    """(Σ_{t >= c} Σ_j φ_tj φ_tjᵀ)⁻¹ over the last segment [c, N) of a piecewise-constant
    fit (order 1), the least-squares covariance of its coefficients per unit noise
    variance, (p, p); None for other orders or where the segment does not determine
    them. A forecast uses it as the uncertainty of the last estimate."""
    if problem.degree != 1:
        return None
    start = int(changepoints[-1]) if len(changepoints) else 0
    gram = problem.gram()[start:].sum(axis=0)
    try:
        factor = np.linalg.cholesky(gram)
    except np.linalg.LinAlgError:
        return None
    inverse = np.linalg.solve(factor, np.eye(gram.shape[0]))
    unit = inverse.T @ inverse
    return unit if np.all(np.isfinite(unit)) else None


def _no_robust_option(value: Any, name: str, loss: str) -> None:
    if value is not None:
        raise NotImplementedError(f"{name}: not available with loss={loss!r} yet")


def _lam_copy(lam: Any) -> Any:
    """λ as the model keeps it: a float, or a new array (never the caller's)."""
    return float(lam) if np.ndim(lam) == 0 else np.array(lam, float)
