"""Choosing the regularization λ (and the number of changes for the L0 problem).

Every criterion scores a fit per candidate λ. The default candidates span a
range that scales with the data (see :func:`select_lambda`): a coarse grid of
:data:`COARSE_SIZE` log-spaced points finds the criterion's basins, and the
search then refines where the criterion peaks — the likelihood, GCV and
cross-validation by successive parabolic interpolation on log λ from every
local optimum of the grid (:mod:`ltvmodels.core.logsearch`), the L-curve by
halving the spacing around its corner. Candidates given in ``lams`` are
scored as given (the likelihood and GCV still refined between them).

* ``"lcurve"`` (all norms; the paper's choice, Section VI, after Hansen 1994):
  the curve (log ‖y − Φk‖, log R(Dk)) traced by λ, with R the penalty's norm
  (‖Dk‖₂ for "sq", Σ_t‖(Dk)_t‖₂ for "group", Σ_t‖(Dk)_t‖₁ for "l1"); the
  corner is the point of maximum curvature, found on a cubic spline through
  the candidates as functions of log λ. The sparse norms' fits run to a
  relative tolerance of :data:`LCURVE_TOL`: the curvature needs a few digits
  (the default grid's two smallest candidates, far from most corners, to
  :data:`LCURVE_FAR_TOL` unless the corner comes next to them).
* ``"gcv"`` (norm="sq"): generalized cross-validation
  N·n·RSS / (N·n − dof)², with the exact effective degrees of freedom
  dof = tr(Φ H⁻¹ Φᵀ) = Σ_t Σ_i φ_tᵀ (H⁻¹)_{t,i} φ_t from the diagonal blocks of
  H⁻¹ that the squared-norm solver computes by selected inversion (no dense
  hat matrix). Each candidate costs one factorization, substitution and
  selected inversion (:meth:`ltvmodels.core.evidence.ScalarEvidence.solution`),
  not a fit; so do the L-curve's candidates for norm="sq".
* ``"ml"`` (norm="sq"): the log marginal likelihood of the Gaussian random
  walk (noise variance at its maximum-likelihood value for each λ) —
  empirical Bayes. Each candidate costs one banded factorization and forward
  substitution (:mod:`ltvmodels.core.evidence`), not a fit.
* ``"cv"`` (all norms): blocked cross-validation on time. The N steps are cut
  into 5·``n_folds`` contiguous blocks; fold f holds out blocks f, f + n_folds,
  …; the model is fitted without the held-out equations (their rows of y and
  φ set to zero, so the penalty bridges the gaps) and scored by the mean
  squared one-step prediction error on them. With a robust loss ("huber",
  "laplace"; the only criterion then) the folds are fitted with that loss and
  scored by its mean on the held-out residual entries, so held-out outliers
  count as little as in the fit. Huber's δ is the same for every candidate: the
  one given, or the default rule on the squared-loss fit at the middle of the
  grid.

For ``norm="l0"`` (:func:`ltvmodels.fit_segments`) the candidates are numbers
of changes M, all optimal costs come from one dynamic program, and the
criterion is ``"bic"`` or ``"aic"`` for Gaussian noise of unknown variance:
N·n·log(RSS_M / (N·n)) + c·((M + 1)·K + M), c = log(N·n) or 2.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline

from ..core import identifiability
from ..core.evidence import ScalarEvidence
from ..core.logsearch import maximize_on_log_scale
from ..core.losses import named as named_loss
from ..core.penalties import named
from ..core.problem import RegressionProblem, apply_difference
from ..core.robust import default_delta, solve_robust
from ..core.sparse import path_start, solve_sparse
from ..core.sparse_common import lambda_max
from ..core.squared import fit_squared
from ..errors import ConvergenceWarning, PrecisionWarning, SingularProblemError
from ..results.base import signal_names
from ..results.selection import LambdaSelection
from ..validation import arrays, options
from ..validation.options import Loss, Norm, SelectionMethod, SelectionNorm
from .recordings import (
    StateSpaceData,
    regression_problem,
    require_enough_data,
    state_space_data,
)
from .segments import fit_segments

__all__ = [
    "select_lambda",
    "select_lambda_regression",
    "DEFAULT_METHOD",
    "select_for_problem",
    "criterion_fit",
]

# The criterion fit(..., lam="auto") uses for each norm.
DEFAULT_METHOD: dict[SelectionNorm, SelectionMethod] = {
    "sq": "ml",
    "group": "lcurve",
    "l1": "lcurve",
    "l0": "bic",
}
METHODS: dict[SelectionNorm, tuple[SelectionMethod, ...]] = {
    "sq": ("ml", "gcv", "lcurve", "cv"),
    "group": ("lcurve", "cv"),
    "l1": ("lcurve", "cv"),
    "l0": ("bic", "aic"),
}
# The default range is scored on a coarse log-spaced grid, then refined where the
# criterion peaks (:func:`ltvmodels.core.logsearch.maximize_on_log_scale`; the L-curve by
# halving the spacing around its corner). The likelihood and GCV take 6 points over
# the squared norm's 3–9 decades: on 72 test series (jump-linear and random-walk
# systems, T = 60, 300, 2000, orders 1 and 2) the refined maximum of the
# likelihood was as high as the best of 300 points refined to within 1e-4 for order
# 1; for order 2 within 5e-3 on all but one series (1.6e-2 there, where the former
# 30 points missed the higher of two near-equal maxima by 2.9e-2), at 10–11
# evaluations on average (at most 18) instead of the former 33–40 (30 points and a
# bounded scalar search). Cross-validation is noisier and the sparse norms'
# L-curve has several bends: 8 points.
COARSE_SIZE = {"ml": 6, "gcv": 6, "cv": 8, "lcurve": 8}
# The tolerance on log λ of the refined maximum ("ml", "gcv"; the criterion is
# smooth) and of cross-validation (a noisy criterion: 2 % in λ is enough).
ML_XATOL = 1e-3
CV_XATOL = 2e-2
# At most this many refining candidates per local maximum of the coarse grid.
MAX_REFINE = 12
# The L-curve: rounds of halving the spacing around the corner (spacing 0.1 decade
# after two, as the former grid of 30), and the solver tolerance of its fits (the
# corner's curvature needs a few digits of the residual and penalty norms).
# The corner moves with differences at that tolerance: looser or certificate-based
# stops moved the choice on some of the 80 series of benchmarks/bench_lcurve_choices.py
# (run it with --compare before changing how these fits start or stop).
LCURVE_ROUNDS = 2
LCURVE_TOL = 1e-4
# The default grid's LCURVE_FAR_COUNT smallest candidates are solved to LCURVE_FAR_TOL
# only: they are the most expensive (group, order 1, jump-linear T = 10⁴: 21 of the 41
# iterations) and usually far below the corner. Where the corner comes next to one of
# them, that one is solved again to LCURVE_TOL before the corner is taken. On the 80
# series of benchmarks/bench_lcurve_choices.py no choice moved, and the iterations
# went down for every norm and order: group 776 → 751 (order 1) and 1038 → 983
# (order 2), l1 1433 → 1412 and 2196 → 2159; the jump-linear series of T = 10⁴ takes 36
# instead of 41. Solving again the candidates within two of the corner cost more than
# it saved (l1, order 2: 2218), 1e-2 moved 6 choices, and three far candidates 2.
LCURVE_FAR_COUNT = 2
LCURVE_FAR_TOL = 1e-3
# Robust cross-validation: the folds' solver limits (a score needs a few digits, not
# the optimum to 1e-6), and the default grid's size (each candidate costs n_folds
# robust fits).
CV_MAX_ITER = 200
CV_TOL = 1e-4
ROBUST_GRID_SIZE = 15


_Norm = TypeVar("_Norm", bound=SelectionNorm)  # the norms a front-end offers


def select_lambda(
    x: ArrayLike,
    u: ArrayLike | None = None,
    *,
    norm: SelectionNorm = "sq",
    order: int | ArrayLike = 1,
    method: SelectionMethod | None = None,
    lams: ArrayLike | None = None,
    n_folds: int = 5,
    max_changes: int = 10,
    progress: Callable[[int, int], None] | None = None,
    weights: ArrayLike | None = None,
    constant: bool = False,
    loss: Loss = "squared",
    huber_delta: float | ArrayLike | None = None,
    regular: bool = True,
) -> LambdaSelection:
    """Choose λ for :func:`ltvmodels.fit` (state-space data) by a documented criterion.

    See the module docstring for the criteria. The default range: for
    "group"/"l1", λ_max·[1e-3, 1] (λ_max, the smallest λ giving the LTI
    model, from the optimality conditions); for "sq",
    s·[0.1, 2·N^d] with s the root-mean-square norm of the regressors φ_t and
    d the degree of the difference operator (λ/s is then roughly the length,
    in samples, over which the coefficients are averaged, to the power d).
    Both scale with the data, so the choice is equivariant to rescaling x and
    u. It is searched from a coarse grid of 6–8 values, refined where the
    criterion peaks (a robust loss's cross-validation: a grid of 15 values);
    ``n_fits`` of the result counts the fits.

    Parameters
    ----------
    x : array_like, shape (T, n) or (R, T, n)
        States (R trajectories, NaN = missing), as in :func:`ltvmodels.fit`.
    u : array_like, shape (T, m), (T,) or (R, T, m), optional
        Inputs (NaN = missing); None for an autonomous system.
    norm : {"sq", "group", "l1", "l0"}
        "l0" chooses the number of changes of :func:`ltvmodels.fit_segments`.
    order : int or sequence of float
        As in :func:`ltvmodels.fit` (ignored for "l0").
    method : str, optional
        "sq": "ml" (default), "gcv", "lcurve", "cv"; "group"/"l1": "lcurve"
        (default), "cv"; "l0": "bic" (default), "aic".
    lams : array_like, optional
        Candidate λ values (> 0), or for "l0" candidate numbers of changes.
    n_folds : int
        Folds of the blocked cross-validation (method="cv"), >= 2. The folds
        are blocks of time steps, shared by the trajectories.
    max_changes : int
        For "l0" without ``lams``: candidates 0 … max_changes (at most what
        segments of p + 1 transitions allow: each keeps a residual degree of
        freedom, and a number of changes whose optimal segments fit exactly is
        not scored).
    progress : callable, optional
        Called as ``progress(done, total)`` after each candidate is scored
        (e.g. to draw a progress bar). While the search refines, ``total`` is
        an estimate (at least ``done + 1``); the last call has ``done == total``.
    weights, constant
        As in :func:`ltvmodels.fit`.
    loss, huber_delta
        As in :func:`ltvmodels.fit`; a robust loss takes method="cv" (the
        default then), scored with that loss.
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    LambdaSelection
    """
    norm, method, loss = _norm_and_method(norm, method, tuple(METHODS), loss)
    data = state_space_data(
        x,
        u,
        order=1 if norm == "l0" else order,
        weights=weights,
        constant=constant,
        regular=regular,
    )
    _, delta = options.loss_options(loss, huber_delta, data.n)
    if norm == "l0":
        return _select_changes(data, method, lams, max_changes)
    return _select_validated(
        data.problem,
        norm,
        method,
        lams,
        n_folds,
        progress,
        data.regressor_names,
        data_name="x",
        loss=loss,
        delta=delta,
    )


def select_lambda_regression(
    y: ArrayLike,
    phi: ArrayLike,
    *,
    norm: Norm = "sq",
    order: int | ArrayLike = 1,
    method: SelectionMethod | None = None,
    lams: ArrayLike | None = None,
    n_folds: int = 5,
    progress: Callable[[int, int], None] | None = None,
    weights: ArrayLike | None = None,
    loss: Loss = "squared",
    huber_delta: float | ArrayLike | None = None,
    regular: bool = True,
) -> LambdaSelection:
    """:func:`select_lambda` for a regression y_t = Θ_t φ_t + e_t (any front-end).

    For AR/ARX models pass the pair from :func:`ltvmodels.ar_regressors` or
    :func:`ltvmodels.arx_regressors`; the chosen λ is then the one
    ``fit_ar(..., lam="auto")`` uses (with the default method).

    Parameters
    ----------
    y : array_like, shape (N, n), (N,) or (R, N, n)
        Outputs y_t of the regression, time on axis 0.
    phi : array_like, shape (N, p), (N,) or (R, N, p)
        Regressors φ_t, shared by the n outputs.
    norm : {"sq", "group", "l1"}
        The penalty norm, as in :func:`ltvmodels.fit_regression`.
    order, method, lams, n_folds, progress, weights, loss, huber_delta
        As in :func:`select_lambda` (NaN = missing, as in
        :func:`ltvmodels.fit_regression`).
    regular : bool, default True
        As in :func:`ltvmodels.fit` (False: the rows of a time index are
        consecutive samples, whatever their stamps).

    Returns
    -------
    LambdaSelection
        The chosen ``lam``, the candidates and their scores (``plot()`` draws them).
    """
    norm, method, loss = _norm_and_method(norm, method, options.NORMS, loss)
    problem = regression_problem(y, phi, order=order, weights=weights, regular=regular)
    _, delta = options.loss_options(loss, huber_delta, problem.n)
    return _select_validated(
        problem,
        norm,
        method,
        lams,
        n_folds,
        progress,
        signal_names("phi", problem.p),
        data_name="y",
        loss=loss,
        delta=delta,
    )


def _norm_and_method(
    norm: Any, method: Any, norms: tuple[_Norm, ...], loss: Any
) -> tuple[_Norm, SelectionMethod, Loss]:
    """The validated norm, criterion (the default when ``method`` is None) and loss."""
    norm = options.choice(norm, "norm", norms)
    loss = options.choice(loss, "loss", options.LOSSES)
    if loss != "squared":
        if norm == "l0":
            raise ValueError(
                f"loss: norm='l0' (fit_segments) uses the squared loss only, received loss={loss!r}"
            )
        method = options.choice("cv" if method is None else method, "method", ("cv",))
        return norm, method, loss
    method = options.choice(
        DEFAULT_METHOD[norm] if method is None else method, "method", METHODS[norm]
    )
    return norm, method, loss


def _select_validated(
    problem,
    norm,
    method,
    lams,
    n_folds,
    progress,
    regressor_names,
    *,
    data_name: str,
    loss: str = "squared",
    delta: np.ndarray | None = None,
) -> LambdaSelection:
    """Check the sample count, identifiability and ``n_folds``, then
    :func:`select_for_problem`."""
    require_enough_data(problem, data_name)
    n_folds = options.integer(n_folds, "n_folds", minimum=2)
    # as fit does: name the combination of regressors the data do not determine
    identifiability.check(problem, has_prior=False, regressor_names=regressor_names)
    options.callback(progress, "progress")
    return select_for_problem(
        problem,
        norm,
        method,
        lams,
        n_folds=n_folds,
        progress=progress,
        data_name=data_name,
        loss=loss,
        delta=delta,
    )


def select_for_problem(
    problem: RegressionProblem,
    norm: str,
    method: str,
    lams: Any,
    *,
    n_folds: int = 5,
    progress: Callable[[int, int], None] | None = None,
    data_name: str = "lam",
    loss: str = "squared",
    delta: np.ndarray | None = None,
    solutions: dict | None = None,
) -> LambdaSelection:
    """:func:`select_lambda` on a validated regression problem (any front-end).

    ``data_name`` is the argument an error blames when there is nothing to
    choose: ``lam`` for ``lam="auto"``, the data otherwise. A robust ``loss``
    takes method "cv" with Huber thresholds ``delta`` (None: the default rule
    at the middle of the grid). ``solutions``, where given, receives the sparse
    L-curve's solutions by λ (a :class:`~ltvmodels.core.sparse.SparseSolution`
    each): the warm start of a fit at the chosen λ.
    """
    adaptive = lams is None  # the default range: a coarse grid, refined where it matters
    if adaptive:
        low, high = _default_range(problem, norm, data_name)
        size = ROBUST_GRID_SIZE if loss != "squared" else COARSE_SIZE[method]
        grid = np.geomspace(low, high, size)
    else:
        grid = arrays.positive_grid(lams, "lams")

    def scored(values):
        """Yield each candidate, reporting the ones done so far."""
        for i, value in enumerate(values):
            yield value
            if progress is not None:
                progress(i + 1, len(values))

    skipped: list = []  # (λ, why) of candidates whose problem is singular

    def attempt(function: Callable[[float], Any], lam: float) -> Any:
        """function(λ), or None (recorded in ``skipped``) where the problem is singular."""
        try:
            return function(lam)
        except SingularProblemError as exc:
            skipped.append((float(lam), str(exc)))
            return None

    def finish(selection: LambdaSelection) -> LambdaSelection:
        selection.skipped = skipped or None
        return selection

    if not named_loss(loss).closed_form:
        if named_loss(loss).threshold and delta is None:
            middle = float(np.sqrt(grid[0] * grid[-1]))
            delta = default_delta(problem, criterion_fit(problem, norm, middle)["theta"])
        errors = [
            attempt(lambda lam: _robust_cv_error(problem, norm, lam, n_folds, loss, delta), lam)
            for lam in scored(grid)
        ]
        scores = _scores(errors, grid, skipped, data_name, worst=np.inf)
        return finish(
            LambdaSelection(
                float(grid[np.argmin(scores)]),
                grid,
                scores,
                method,
                norm,
                loss=loss,
                huber_delta=None if delta is None else delta.tolist(),
                n_fits=grid.size * n_folds,
            )
        )
    if method == "lcurve":
        return finish(
            _lcurve_selection(
                problem,
                norm,
                grid,
                attempt,
                skipped,
                data_name,
                rounds=LCURVE_ROUNDS if adaptive else 0,
                progress=progress,
                given=not adaptive,
                solutions=solutions,
            )
        )
    fits: dict[float, dict] = {}  # λ → the criterion fit's numbers (gcv)
    if method == "ml":
        evidence = ScalarEvidence(problem)

        def criterion(lam: float) -> float:
            """The fast evaluation, or the full fit where it does not apply."""
            value = evidence.loglik(lam)
            if value is None:
                fit = attempt(lambda value: criterion_fit(problem, norm, value), lam)
                return -np.inf if fit is None else fit["loglik"]
            return value

        xatol, sign = ML_XATOL, 1.0
    elif method == "gcv":
        evidence = ScalarEvidence(problem)

        def criterion(lam: float) -> float:
            fit = evidence.solution(lam, dof=True) or attempt(
                lambda value: criterion_fit(problem, norm, value, compute_cov=True), lam
            )
            if fit is None:
                return -np.inf
            fits[lam] = fit
            return -_gcv(problem, fit["rss"], fit["dof"])

        xatol, sign = ML_XATOL, -1.0
    else:  # cv
        # Each fold's sparse solutions by λ: every candidate starts from its neighbours'.
        paths: list[dict] = [{} for _ in range(n_folds)]

        def criterion(lam: float) -> float:
            value = attempt(lambda value: _cv_error(problem, norm, value, n_folds, paths), lam)
            return -np.inf if value is None else -value

        xatol, sign = CV_XATOL, -1.0
    search = maximize_on_log_scale(
        criterion,
        grid,
        xatol=xatol,
        max_refine=MAX_REFINE if adaptive or method != "cv" else 0,
        progress=progress,
    )
    _scores(
        [None if v == -np.inf else 0.0 for v in search.values],
        search.lams,
        skipped,
        data_name,
        worst=0.0,
    )
    # The candidates reported: every one scored, or the ones given (the choice may lie
    # between them, refined).
    lams_out, values = (search.lams, search.values) if adaptive else (grid, search.grid_values)
    extra: dict[str, np.ndarray] = {}  # the numbers of the gcv fits
    if method == "gcv":
        numbers = [fits.get(lam) for lam in lams_out]
        extra = {
            name: np.array([np.nan if f is None else f[key] for f in numbers])
            for name, key in (
                ("residual_norms", "rss"),
                ("penalty_norms", "penalty_norm"),
                ("dof", "dof"),
            )
        }
        extra["residual_norms"] = np.sqrt(extra["residual_norms"])
    return finish(
        LambdaSelection(
            search.best,
            lams_out,
            sign * values,
            method,
            norm,
            residual_norms=extra.get("residual_norms"),
            penalty_norms=extra.get("penalty_norms"),
            dof=extra.get("dof"),
            n_fits=search.n_evaluations * (n_folds if method == "cv" else 1),
        )
    )


def _lcurve_selection(
    problem, norm, grid, attempt, skipped, data_name, *, rounds, progress, given, solutions
):
    """The L-curve's corner (see :func:`_lcurve_curvature`): fits on ``grid``, then
    ``rounds`` times two more fits halving the spacing on either side of the corner
    so far.

    ``given``: the candidates are the caller's (an error then blames ``lams``).
    ``solutions`` (a dict or None) receives the sparse fits' solutions by λ.
    The sparse norms' fits run up the grid, each warm-started from the fit at the
    next smaller λ (a refinement from both neighbours, :func:`_path_warm_start`;
    group cones then take a few reweighted fits from that k,
    :data:`ltvmodels.core.ipm.WARM_REWEIGHT_STEPS`), to the tolerance LCURVE_TOL. A
    candidate whose penalty is not resolved at that tolerance (λ·R(Dk) below
    LCURVE_TOL times the objective: λ at or near λ_max, where
    Dk = 0) has no place on the logarithmic curve and is left out of the corner:
    its log R(Dk) is noise, and on the former grid of 30 the candidate λ_max
    (R = 0) moved the spline's corner to ~0.4 λ_max where the curvature has no
    maximum. The default grid's smallest candidates are solved to LCURVE_FAR_TOL
    unless the corner comes near them (see LCURVE_FAR_COUNT).
    """
    fits: dict[float, dict | None] = {}
    loose: set[float] = set()  # the candidates solved to LCURVE_FAR_TOL only
    n_fits = 0
    total = len(grid) + 2 * rounds
    evidence = ScalarEvidence(problem) if norm == "sq" else None

    def fit_at(lam: float, tol: float = LCURVE_TOL, warm: Any = None) -> None:
        nonlocal n_fits
        if warm is None:
            solved = {value: f["solution"] for value, f in fits.items() if f and "solution" in f}
            warm = _path_warm_start(solved, lam, problem.K)
        fits[lam] = (evidence and evidence.solution(lam)) or attempt(
            lambda value: criterion_fit(problem, norm, value, tol=tol, warm_start=warm), lam
        )
        n_fits += 1
        if tol > LCURVE_TOL and fits[lam] is not None:
            loose.add(lam)
        else:
            loose.discard(lam)
        if progress is not None:
            progress(n_fits, max(total, n_fits))

    far = 0 if given or evidence is not None else LCURVE_FAR_COUNT
    for index, lam in enumerate(np.sort(grid)):
        fit_at(float(lam), LCURVE_FAR_TOL if index < far else LCURVE_TOL)

    def corner() -> tuple:
        """(candidates, residual norms, penalty norms, curvatures, index of the corner)."""
        lams = np.array(sorted(fits))
        numbers = [fits[lam] for lam in lams]
        _scores([None if f is None else 0.0 for f in numbers], lams, skipped, data_name, worst=0.0)
        residual = np.array([np.sqrt(f["rss"]) if f is not None else np.nan for f in numbers])
        penalty = np.array([f["penalty_norm"] if f is not None else np.nan for f in numbers])
        with np.errstate(invalid="ignore"):
            resolved = lams * penalty > (0.0 if norm == "sq" else LCURVE_TOL) * (
                residual**2 + lams * penalty
            )
        curvature = np.full(lams.size, -np.inf)
        if resolved.sum() >= 2:
            curvature[resolved] = _lcurve_curvature(
                lams[resolved], residual[resolved], penalty[resolved]
            )
        if not np.isfinite(curvature).any():
            ok = np.isfinite(residual)
            same = (
                f"the L-curve has no corner: every candidate gives the same fit (residual "
                f"norm {residual[ok][0]:.6g})"
            )
            lam_max = lambda_max(problem, named(norm))
            if given:
                raise ValueError(
                    f"lams: {same}, e.g. all at or above λ_max = "
                    f"{lam_max:.6g}; pass candidates below λ_max, or none for "
                    "the default grid"
                )
            raise ValueError(
                f"{data_name}: {same} over the default range λ_max·[1e-3, 1] (λ_max = "
                f"{lam_max:.6g}: the data leave nothing to choose); pass a "
                "number for lam"
            )
        return lams, residual, penalty, curvature, int(np.argmax(curvature))

    for round_ in range(rounds + 1):
        lams, residual, penalty, curvature, best = corner()
        # the corner and its neighbours need every digit: loose ones are solved again
        while near := [lam for lam in lams[max(best - 1, 0) : best + 2] if lam in loose]:
            for lam in near:
                fit_at(float(lam), warm=fits[lam]["solution"])
            lams, residual, penalty, curvature, best = corner()
        if round_ == rounds:
            break
        for neighbour in (best - 1, best + 1):  # halve the spacing around the corner
            if 0 <= neighbour < lams.size:
                fit_at(float(np.sqrt(lams[best] * lams[neighbour])))
    if progress is not None and n_fits < total:  # fewer than planned: the bar ends full
        progress(n_fits, n_fits)
    if solutions is not None:
        solutions.update({lam: f["solution"] for lam, f in fits.items() if f and "solution" in f})
    return LambdaSelection(
        float(lams[best]), lams, curvature, "lcurve", norm, residual, penalty, n_fits=n_fits
    )


def _path_warm_start(solutions: dict, lam: float, K: int) -> Any:
    """The warm start of a sparse fit at ``lam`` from the solutions at other λ (or None).

    The solution at the next smaller λ (up a path its rescaled duals stay
    feasible, :func:`ltvmodels.core.ipm.warm_dual`), or, between two solved
    neighbours (the refinements), the interpolation of both
    (:func:`ltvmodels.core.sparse.path_start`): on the L-curve of the
    jump-linear system (T = 10⁴, group, order 1) its refinements took 14
    iterations instead of 17.
    """
    below = [value for value in solutions if value < lam]
    above = [value for value in solutions if value > lam]
    warm = solutions[max(below)] if below else None
    if warm is not None and above:
        warm = path_start(warm, solutions[min(above)], np.full(K, lam)) or warm
    return warm


def _scores(
    values: list, grid: np.ndarray, skipped: list, data_name: str, *, worst: float
) -> np.ndarray:
    """The scores with ``worst`` for skipped candidates; an error if every one was skipped."""
    if all(value is None for value in values):
        lam, why = skipped[0]
        raise SingularProblemError(
            f"{data_name}: every candidate λ ({grid[0]:.3g} … {grid[-1]:.3g}) gives a "
            f"singular problem; at λ = {lam:.3g}: {why}"
        )
    return np.array([worst if value is None else value for value in values], dtype=float)


# -- fits and criteria --------------------------------------------------------------------


def criterion_fit(
    problem: RegressionProblem,
    norm: str,
    lam: float,
    *,
    compute_cov: bool = False,
    tol: float = 1e-6,
    warm_start: Any = None,
) -> dict:
    """One fit for the criteria at a scalar λ, without building a model.

    Returns a dict with "theta" (N, n, p), "rss", "penalty_norm" (R(Dk), see
    the module docstring) and, for norm="sq", "loglik" and (with
    ``compute_cov``) "dof", the effective degrees of freedom tr(Φ H⁻¹ Φᵀ); for
    the sparse norms "solution", which ``warm_start`` of the next λ takes (see
    :func:`ltvmodels.core.sparse.solve_sparse`), and ``tol`` is their solver's
    tolerance.
    """
    K = problem.K
    if norm == "sq":
        with warnings.catch_warnings():
            # The largest grid values (averaging over the whole record) may lose
            # digits; they are scored all the same and are rarely the choice.
            warnings.simplefilter("ignore", PrecisionWarning)
            result = fit_squared(
                problem, np.full(K, lam**2), [], noise_var=None, compute_cov=compute_cov
            )
        out = {
            "theta": result.theta,
            "rss": result.rss,
            "loglik": result.loglik,
            "penalty_norm": float(np.sqrt(result.penalty)) / lam,
        }
        if compute_cov:
            out["dof"] = _effective_dof(problem, result)
        return out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        solution = solve_sparse(
            problem, np.full(K, lam), named(norm), max_iter=200, tol=tol, warm_start=warm_start
        )
    k = solution.theta.reshape(problem.N, K)
    reg = named(norm).value(apply_difference(k, problem.coeffs))
    return {
        "theta": solution.theta,
        "rss": solution.rss,
        "penalty_norm": float(reg),
        "solution": solution,
    }


def _effective_dof(problem: RegressionProblem, result: Any) -> float:
    """tr(Φ H⁻¹ Φᵀ) from the diagonal blocks of H⁻¹ (σ² divided out of the covariances)."""
    n, p = problem.n, problem.p
    cov = result.cov
    phi = problem.phi
    if cov.row_group is not None:  # rows independent: blocks (G, N, p, p), row i has σ_i²
        per_group = np.einsum("tja,gtab,tjb->g", phi, cov.blocks, phi)
        return float(np.sum(per_group[cov.row_group] * cov.scales(n) / result.noise_var))
    full = cov.blocks.reshape(problem.N, n, p, n, p)
    return float(np.einsum("tja,tiaib,tjb->", phi, full, phi)) / float(result.noise_var[0])


def _gcv(problem: RegressionProblem, rss: float, dof: float) -> float:
    size = problem.n_observed * problem.n
    return size * rss / max(size - dof, 1e-12) ** 2


def _lcurve_curvature(grid: np.ndarray, residual: np.ndarray, penalty: np.ndarray) -> np.ndarray:
    """Signed curvature of (log residual, log penalty) as functions of log λ at the grid.

    Positive where the curve bends like the corner of an L (Hansen's sign
    convention); computed from a cubic spline through the grid points.
    """
    t = np.log(grid)
    tiny = np.finfo(float).tiny
    rho = CubicSpline(t, np.log(np.maximum(residual, tiny)))
    eta = CubicSpline(t, np.log(np.maximum(penalty, tiny)))
    r1, r2, e1, e2 = rho(t, 1), rho(t, 2), eta(t, 1), eta(t, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = (r1 * e2 - r2 * e1) / (r1**2 + e1**2) ** 1.5
    kappa[~np.isfinite(kappa)] = -np.inf  # flat stretches (e.g. the LTI end) have no corner
    return kappa


def _cv_error(
    problem: RegressionProblem,
    norm: str,
    lam: float,
    n_folds: int,
    paths: list[dict] | None = None,
) -> float:
    """Mean squared one-step prediction error on held-out blocks (blocked CV on time).

    ``paths`` (one dict per fold, λ → sparse solution) collects the folds' sparse
    solutions, from which each fit of another λ is warm-started (:func:`_path_warm_start`).
    """
    fold = _folds(problem.N, n_folds)
    errors = 0.0
    for f in range(n_folds):
        held = fold == f
        warm = None if paths is None else _path_warm_start(paths[f], lam, problem.K)
        fit = criterion_fit(_without(problem, held), norm, lam, warm_start=warm)
        if paths is not None and "solution" in fit:
            paths[f][lam] = fit["solution"]
        theta = fit["theta"]
        pred = np.einsum("tij,tqj->tqi", theta[held], problem.phi[held])
        errors += float(np.sum((problem.y[held] - pred) ** 2))  # unobserved rows are 0
    return errors / (problem.n_observed * problem.n)


def _folds(N: int, n_folds: int) -> np.ndarray:
    """The fold of each time step: 5·n_folds contiguous blocks, dealt out in turn."""
    n_blocks = min(5 * n_folds, N // 2)
    block = np.minimum(np.arange(N) * n_blocks // N, n_blocks - 1)
    return block % n_folds


def _without(problem: RegressionProblem, held: np.ndarray) -> RegressionProblem:
    """The problem with the time steps ``held`` (N,) unobserved (the penalty bridges them)."""
    return RegressionProblem(
        y=problem.y,
        phi=problem.phi,
        coeffs=problem.coeffs,
        row_scale=problem.row_scale,
        observed=problem.observed & ~held[:, None],
        rows_are_samples=problem.rows_are_samples,
    )


def _robust_cv_error(
    problem: RegressionProblem,
    norm: str,
    lam: float,
    n_folds: int,
    loss: str,
    delta: np.ndarray | None,
) -> float:
    """Mean robust loss of the one-step predictions on held-out blocks (blocked CV)."""
    penalty, robust = named(norm), named_loss(loss)
    weights = np.full(problem.K, lam**2 if penalty.closed_form else lam)
    fold = _folds(problem.N, n_folds)
    total = 0.0
    for f in range(n_folds):
        held = fold == f
        with warnings.catch_warnings():  # a fold's fit is scored, not reported
            warnings.simplefilter("ignore", ConvergenceWarning)
            theta = solve_robust(
                _without(problem, held),
                weights,
                loss=robust,
                penalty=penalty,
                delta=delta,
                max_iter=CV_MAX_ITER,
                tol=CV_TOL,
            ).theta
        r = problem.residuals(theta)[held]  # scaled rows; unobserved rows are 0
        total += robust.value(r, problem.row_scale[held][:, :, None], delta)
    return total / (problem.n_observed * problem.n)


def _default_range(problem: RegressionProblem, norm: str, data_name: str) -> tuple[float, float]:
    """The ends of the default range of λ (see :func:`select_lambda`)."""
    if norm == "sq":
        # root-mean-square ‖φ‖ of the observed rows
        scale = float(np.sqrt(np.sum(problem.phi**2) / max(problem.n_observed, 1)))
        return 0.1 * scale, 2.0 * problem.N**problem.degree * scale
    lam_max = lambda_max(problem, named(norm))
    if not lam_max > 0:
        raise ValueError(
            f"{data_name}: there is no λ to choose: coefficients in the null space of the "
            "difference operator (constant for order 1, linear in time for order 2) already "
            "fit the data exactly (λ_max = 0), so every λ > 0 gives that fit; pass a number "
            "for lam"
        )
    return 1e-3 * lam_max, lam_max


def _select_changes(
    data: StateSpaceData, method: str, lams: Any, max_changes: Any
) -> LambdaSelection:
    """Number of changes for fit_segments by BIC/AIC over one dynamic program."""
    if lams is None:
        max_changes = options.integer(max_changes, "max_changes", minimum=0)
        candidates = np.arange(max_changes + 1)
    else:
        candidates = arrays.count_grid(lams, "lams")
    N, n, p = data.problem.N, data.n, data.problem.p
    # Every segment keeps a residual degree of freedom: a segment of p samples
    # fits exactly, and RSS = 0 would make the criterion −∞ (any M wins).
    min_size = p + 1
    M_max = min(int(candidates.max()), N // min_size - 1)
    if M_max < 0:
        raise ValueError(
            f"x: too few samples to compare numbers of changes: {N} transitions, and one "
            f"segment needs more than p = {p}"
        )
    costs = fit_segments(
        data.x,
        data.inputs,
        n_changes=M_max,
        compute_cov=False,
        min_size=min_size,
        weights=data.weights,
        constant=data.constant,
    ).info["costs_by_n_changes"]
    candidates = candidates[candidates <= M_max]
    if candidates.size == 0:
        raise ValueError(
            f"lams: every candidate exceeds the {M_max} changes the data can hold (segments "
            f"of more than p = {p} transitions); pass numbers up to {M_max}"
        )
    size = data.problem.n_observed * n
    c = np.log(size) if method == "bic" else 2.0
    with np.errstate(divide="ignore"):
        scores = np.array(
            [
                size * np.log(costs[M] / size) + c * ((M + 1) * n * p + M)
                if costs[M] > 0
                else np.inf  # an exact fit: degenerate
                for M in candidates
            ]
        )
    if not np.isfinite(scores).any():
        raise ValueError(
            "x: every candidate number of changes fits the data exactly (zero residuals), so "
            "no criterion can compare them; use data with noise or fewer changes"
        )
    best = int(candidates[np.argmin(scores)])
    return LambdaSelection(
        float(best),
        candidates.astype(float),
        scores,
        method,
        "l0",
        residual_norms=np.sqrt(costs[candidates]),
        n_fits=1,
    )
