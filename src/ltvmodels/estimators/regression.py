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
from dataclasses import dataclass
from functools import partial
from typing import Any, Literal, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from ..core import identifiability
from ..core.covariance import CovarianceBlocks
from ..core.losses import named as named_loss
from ..core.penalties import named
from ..core.priorterms import posthoc_correction
from ..core.problem import RegressionProblem, activation
from ..core.sparse import SparseSolution, solve_sparse
from ..core.squared import fit_squared, weight_diagonal
from ..results.base import signal_names
from ..results.record import FitRecord, FitStatus, iterative_status
from ..results.regression import RegressionModel
from ..validation import options
from ..validation.options import Loss, Norm, PriorMode
from .changepoints import find_changepoints, residue_level
from .piecewise import refine_fit
from .priors import resolve as resolve_priors
from .recordings import regression_data, require_enough_data
from .robust import outlier_info, robust_model
from .selection import select_for_problem
from .spec import FitSpec

__all__ = ["fit_regression", "fit_problem", "sparse_model", "last_segment_unit_cov"]

ModelT = TypeVar("ModelT", bound=RegressionModel)
"""The model a front-end's factory builds (RegressionModel, LTVModel, ARXModel, …)."""
ModelFactory = Callable[..., ModelT]
"""Builds the result: ``factory(k, fit=FitRecord(...))`` with k of shape (N, K), and
``copy=False`` where k is the estimator's own array (see :class:`RegressionModel`)."""


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
    regular: bool = True,
) -> RegressionModel:
    r"""Identify a time-varying regression y_t = Θ_t φ_t + e_t.

    The general problem behind every front-end: any model linear in its
    parameters (paper, Discussion). With ``norm="sq"`` it is the exact minimizer of

    .. math::

        \sum_t \lVert y_t - \Theta_t \varphi_t \rVert_2^2
        + \lambda^2 \sum_t \lVert (Dk)_t \rVert_2^2,
        \qquad k_t = \operatorname{vec}(\Theta_t^\top) \text{ (the rows of } \Theta_t \text{)},

    and with ``norm="group"`` / ``"l1"`` of

    .. math::

        \sum_t \lVert y_t - \Theta_t \varphi_t \rVert_2^2 + \lambda \sum_t \lVert (Dk)_t \rVert_2
        \quad\text{or}\quad
        \sum_t \lVert y_t - \Theta_t \varphi_t \rVert_2^2 + \lambda \sum_t \lVert (Dk)_t \rVert_1,

    with :math:`(Dk)_t = \sum_j c_j k_{t+j}` the difference operator of ``order``
    (equation :eq:`difference-operator` of the user guide), solved exactly as in :func:`fit`. The n
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
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

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
    spec = FitSpec.from_arguments(locals())  # every option, checked once
    problem, description = regression_data(
        y, phi, order=spec.order, weights=weights, regular=regular
    )
    model = fit_problem(
        problem,
        spec,
        factory=partial(RegressionModel, n_outputs=problem.n, n_regressors=problem.p),
        regressor_names=description.names_of("regressor", problem.p)
        or signal_names("phi", problem.p),
        data_name="y",
    )
    model.data = description  # the model of this call: described in place
    return model


def fit_problem(
    problem: RegressionProblem,
    spec: FitSpec,
    *,
    factory: ModelFactory[ModelT],
    regressor_names: list[str],
    data_name: str,
    rows_note: str = "",
) -> ModelT:
    """The core shared by every front-end: a validated (y, φ) problem and a spec → model.

    Checks the options that depend on the problem's sizes (noise variance,
    Huber threshold, λ), the sample count and identifiability (naming
    ``regressor_names`` in messages and ``data_name`` as the argument),
    chooses λ where ``spec.lam`` is "auto" (:func:`ltvmodels.select_lambda`,
    followed by ``spec.progress``), solves with the solver of the norm, and
    builds the model with ``factory(k, fit=FitRecord(...))``; with
    ``spec.refine``, refits between the change points of that fit. ``rows_note``
    is added to a too-few-samples message (e.g. how the rows relate to T).
    """
    noise_var = options.noise_variance(spec.noise_var, problem.n)
    loss = named_loss(spec.loss)
    huber_delta = options.threshold_of(loss.name, loss.threshold, spec.huber_delta, problem.n)
    checks = _Checks(regressor_names, data_name, rows_note)
    first = spec.first_step() if spec.refine else spec
    model = _fit_or_choose_lam(problem, first, noise_var, huber_delta, factory, checks)
    if not spec.refine:
        return model
    return refine_fit(
        problem,
        model,
        names=regressor_names,
        loss=loss.name,
        delta=huber_delta,
        factory=factory,
    )


@dataclass(frozen=True)
class _Checks:
    """What the sample-count and identifiability checks name in their messages."""

    regressor_names: list[str]
    data_name: str
    rows_note: str

    def enough_data(self, problem: RegressionProblem) -> None:
        require_enough_data(problem, self.data_name, self.rows_note)

    def identifiable(self, problem: RegressionProblem, **details: Any) -> None:
        if not problem.rows_are_samples:  # EM's M-step: the recorded data were checked
            return
        identifiability.check(problem, regressor_names=self.regressor_names, **details)


def _fit_or_choose_lam(
    problem: RegressionProblem,
    spec: FitSpec,
    noise_var: Any,
    huber_delta: np.ndarray | None,
    factory: ModelFactory[ModelT],
    checks: _Checks,
) -> ModelT:
    """The fit at ``spec.lam``, or at the λ chosen from the data for ``lam="auto"``."""
    if not spec.lam_is_auto:
        return _fit_with_lam(problem, spec, spec.lam, noise_var, huber_delta, factory, checks)
    if spec.prior is not None:
        raise ValueError(
            "lam: 'auto' chooses λ from the data alone and does not take a prior into "
            "account; choose λ with ltvmodels.select_lambda or pass a number"
        )
    checks.enough_data(problem)
    checks.identifiable(problem, has_prior=False)
    method = named(spec.norm).selection if named_loss(spec.loss).closed_form else "cv"
    solutions: dict = {}  # the L-curve's sparse fits by λ
    selection = select_for_problem(
        problem,
        spec.norm,
        method,
        None,
        loss=spec.loss,
        delta=huber_delta,
        progress=spec.progress,
        solutions=solutions,
    )
    if selection.huber_delta is not None:  # the model has the loss λ was chosen for
        huber_delta = np.array(selection.huber_delta)
    model = _fit_with_lam(
        problem,
        spec,
        selection.lam,
        noise_var,
        huber_delta,
        factory,
        checks,
        checked=True,
        warm_start=solutions.get(selection.lam),
    )
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
    spec: FitSpec,
    lam: Any,
    noise_var: Any,
    huber_delta: np.ndarray | None,
    factory: ModelFactory[ModelT],
    checks: _Checks,
    *,
    checked: bool = False,
    warm_start: SparseSolution | None = None,
) -> ModelT:
    """The fit at a given λ; ``checked``: the sample count and identifiability were checked
    (for a scalar λ chosen from the data); ``warm_start``: a sparse fit of the same
    problem to start from (the selection's at that λ, solved to its own tolerance)."""
    n, p = problem.n, problem.p
    N, K = problem.N, problem.K
    norm, loss, prior_mode = spec.norm, spec.loss, spec.prior_mode
    penalty, robust = named(norm), named_loss(loss)
    if not penalty.closed_form:
        if spec.prior is not None:
            raise NotImplementedError(
                f"prior: priors are available with norm='sq' only, not yet with norm={norm!r}"
            )
        weights = penalty.weights(lam, K)
        if not checked:
            checks.enough_data(problem)
            checks.identifiable(problem, has_prior=False)
        if not robust.closed_form:
            if not penalty.interior_point:
                raise NotImplementedError(
                    f"loss: {loss!r} is available with the built-in norms; norm={norm!r} "
                    "takes loss='squared'"
                )
            _no_robust_option(noise_var, "noise_var", loss)
            return robust_model(
                problem,
                weights,
                loss=loss,
                penalty=penalty,
                lam=_lam_copy(lam),
                norm=norm,
                delta=huber_delta,
                factory=factory,
                max_iter=spec.max_iter,
                tol=spec.tol,
            )
        solution = solve_sparse(
            problem, weights, penalty, max_iter=spec.max_iter, tol=spec.tol, warm_start=warm_start
        )
        return sparse_model(problem, lam, norm, solution, factory)
    if not checked:
        checks.enough_data(problem)  # before a (K, K) λ is checked
    W = penalty.weights(lam, K)
    terms = resolve_priors(spec.prior, N, n, p)
    if not problem.complete and any(term.on == "output" for term in terms):
        raise NotImplementedError(
            "prior: an OutputPrior needs one complete trajectory (no missing samples, "
            "weights or batches); use a Prior on the coefficients instead"
        )

    if not checked:
        const = np.isinf(weight_diagonal(W)).reshape(n, p)
        checks.identifiable(
            problem,
            has_prior=bool(terms),
            const_mask=const.all(axis=0) if const.any() else None,
        )
    if not robust.closed_form:
        if not robust.priors:
            _no_robust_option(spec.prior, "prior", loss)
            _no_robust_option(noise_var, "noise_var", loss)
        elif terms and prior_mode != "exact":
            raise NotImplementedError(
                "prior_mode: 'posthoc' is not available with loss='huber'; use prior_mode='exact'"
            )
        return robust_model(
            problem,
            W,
            loss=loss,
            penalty=penalty,
            lam=_lam_copy(lam),
            norm=norm,
            delta=huber_delta,
            factory=factory,
            max_iter=spec.max_iter,
            tol=spec.tol,
            priors=terms,
            noise_var=None if noise_var is None else np.broadcast_to(noise_var, (n,)).copy(),
        )

    compute_cov = spec.compute_cov
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
    info.update(outlier_info(problem, k.reshape(N, n, p)))
    noise_cov = np.diag(result.noise_var)
    status = FitStatus(
        "closed_form",
        info["solver"],
        1,
        result.objective,
        {"n_factorizations": result.n_factorizations},
    )
    return factory(
        k,  # the solver's own array, which nothing else holds: not copied again
        copy=False,
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
        # the residuals rss was computed from serve the outlier check and the noise
        # variance too (three passes over the data were one)
        **outlier_info(problem, solution.theta, residuals=solution.residuals),
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
    noise_var = problem.output_rss(solution.theta, solution.residuals) / max(problem.n_observed, 1)
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
    gram = problem.gram(start).sum(axis=0)  # the last segment's steps only
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
