"""Partial structural change: breaks in some coefficients, the others common (Bai–Perron).

The regressors φ_t = (z_t, x_t) are split into p_z changing ones z and p_x
fixed ones x; on segment j

    y_t = Θ_j z_t + Γ x_t + e_t,   Θ_j ∈ R^{n×p_z},  Γ ∈ R^{n×p_x} common to all segments,

and the searches minimize the total residual sum of squares over the break
dates, Θ_1 … Θ_{M+1} and Γ. Γ couples the segments, so the cost is no longer
a sum of segment costs and the dynamic program of
:mod:`ltvmodels.core.segmentation` does not apply directly.

The data here are the scaled rows [z̃ x̃ ỹ] (N, q, p_z + p_x + n), from
:func:`ltvmodels.core.segmentation.scale_data` with the columns of φ ordered
changing first.

One break, exactly (:func:`one_change_partial`)
-----------------------------------------------
For a break at k the joint least squares of y on [z·1{t<k}, z·1{t≥k}, x] is
solved for every admissible k in O(N K²), K = p_z + p_x, with no normal
equations. A forward sequential QR (Givens rotations, as in the segment costs
of :mod:`ltvmodels.core.segmentation`) of the rows [z x y] 0 … k−1 gives an
upper-triangular factor

    [R₁₁ R₁₂ r₁]
    [ 0  R₂₂ r₂]      (p_z + p_x rows)

and the sum h(k) of the squared left-overs; a backward pass over rows
N−1 … k gives [S₁₁ S₁₂ s₁; 0 S₂₂ s₂] and t(k). Orthogonal transformations
keep the residual sum of squares, so RSS(k) = h(k) + t(k) + the least-squares
residual of the stacked factors. The changing coefficients of each side
appear only in that side's first p_z rows, with R₁₁ and S₁₁ nonsingular when
both segments identify Θ, so those rows are fitted exactly and what is left is
the small problem [R₂₂ r₂; S₂₂ s₂] in Γ alone: the p_x rows of the backward
block are rotated into a copy of the forward block, O(p_x² (p_x + n)) per k.
Every term is a sum of squares: no difference of large numbers, so a
near-perfect fit keeps its digits. The forward and backward blocks are kept for
every k: O(N p_x (p_x + n)) memory.

Several breaks (:func:`joint_fit` and the alternation in the estimator)
-----------------------------------------------------------------------
For given breaks the joint least squares is the same construction over
M + 1 segments (:func:`joint_fit`): a sequential QR per segment and the
segments' lower blocks stacked into one factor of Γ. Bai and Perron's (2003,
section 3.2) iterated procedure alternates it with the exact search for the
breaks of y − Γx on z (:func:`ltvmodels.core.segmentation.dynamic_program` or
``pelt``), each step not increasing the RSS.

Feasible segments: Θ_j must be identifiable, so the segments are those of the
feasibility rule of :mod:`ltvmodels.core.segmentation` applied to the changing
regressors z alone (``a_max`` from ``feasible_starts`` on [z̃ ỹ]); Γ is
identified by the whole sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from .segmentation import (
    PRUNE_MARGIN,
    add_row,
    add_step,
    backtrack_last,
    backtrack_layers,
    dynamic_program,
    pelt,
)

__all__ = [
    "TOLERANCE",
    "MAX_ITERATIONS",
    "Alternation",
    "one_change_partial",
    "joint_fit",
    "fixed_solution",
    "adjusted_data",
    "alternate",
]

TOLERANCE = 1e-10  # on the relative decrease of the objective per alternation
MAX_ITERATIONS = 100


@numba.njit(cache=True)
def _lower_blocks(data, pz, px, backward):  # pragma: no cover - compiled
    """Sequential QR in one direction: the left-over sums and the Γ blocks at each k.

    Forward: rss[k] and block[k] for rows 0 … k−1; backward: for rows k … N−1.
    block[k] is the (p_x, p_x + n) lower-right part [R₂₂ r₂] of the factor.
    """
    N = data.shape[0]
    q = data.shape[2]
    p = pz + px
    width = q - pz
    W = np.zeros((p, q))
    v = np.empty(q)
    rss = np.zeros(N + 1)
    block = np.zeros((N + 1, px, width))
    total = 0.0
    for i in range(N):
        t = N - 1 - i if backward else i
        total += add_step(W, v, data, t, p, q)
        k = t if backward else t + 1
        rss[k] = total
        for r in range(px):
            for c in range(width):
                block[k, r, c] = W[pz + r, pz + c]
    return rss, block


@numba.njit(cache=True)
def one_change_partial(data, pz, px, a_max):  # pragma: no cover - compiled
    """RSS(k) of the partial model with one break at k, for every k (see the module docstring).

    Parameters
    ----------
    data : ndarray, shape (N, q, p_z + p_x + n)
        Scaled rows [z̃ x̃ ỹ].
    pz, px : int
        Numbers of changing and fixed regressors (p_x >= 1).
    a_max : ndarray of int64, shape (N + 1,)
        ``feasible_starts`` of the changing regressors: [a, b) is feasible iff
        a <= a_max[b].

    Returns
    -------
    rss : ndarray, shape (N + 1,)
        rss[k] = min over Θ₁, Θ₂, Γ of Σ_t ‖ỹ_t − Θ_{j(t)} z̃_t − Γ x̃_t‖² with
        the break at k (segments [0, k) and [k, N)); inf where a segment is
        infeasible. rss[0] and rss[N] are inf.
    no_change : float
        The RSS without a break (the least squares of ỹ on [z̃ x̃]).
    """
    N = data.shape[0]
    width = data.shape[2] - pz
    head, forward = _lower_blocks(data, pz, px, False)
    tail, backward = _lower_blocks(data, pz, px, True)
    out = np.full(N + 1, np.inf)
    Wc = np.empty((px, width))
    u = np.empty(width)
    for k in range(1, a_max[N] + 1):  # [k, N) feasible
        if a_max[k] < 0:  # [0, k) infeasible
            continue
        for r in range(px):
            for c in range(width):
                Wc[r, c] = forward[k, r, c]
        extra = 0.0
        for r in range(px):
            for c in range(width):
                u[c] = backward[k, r, c]
            extra += add_row(Wc, u, px, width)
        out[k] = head[k] + tail[k] + extra
    return out, head[N]


@numba.njit(cache=True)
def joint_fit(data, pz, px, bounds):  # pragma: no cover - compiled
    """The joint least squares of the partial model for given segments.

    Parameters
    ----------
    data : ndarray, shape (N, q, p_z + p_x + n)
        Scaled rows [z̃ x̃ ỹ].
    pz, px : int
    bounds : ndarray of int64, shape (M + 2,)
        0 = b_0 < … < b_{M+1} = N; segment j is [b_j, b_{j+1}).

    Returns
    -------
    rss : float
        min over Θ_j, Γ of the total residual sum of squares (scaled units).
    factor : ndarray, shape (p_x, p_x + n)
        [R r], upper-triangular R with RᵀR the Schur complement of the fixed
        regressors given the segments' changing ones, Σ_j X_jᵀ(I − P_{Z_j})X_j:
        Γᵀ = R⁻¹ r (:func:`fixed_solution`).
    """
    q = data.shape[2]
    p = pz + px
    width = q - pz
    W = np.zeros((p, q))
    v = np.empty(q)
    factor = np.zeros((px, width))
    u = np.empty(width)
    rss = 0.0
    for j in range(bounds.shape[0] - 1):
        for r in range(p):
            for c in range(q):
                W[r, c] = 0.0
        for t in range(bounds[j], bounds[j + 1]):
            rss += add_step(W, v, data, t, p, q)
        for r in range(px):
            for c in range(width):
                u[c] = W[pz + r, pz + c]
            rss += add_row(factor, u, px, width)
    return rss, factor


def fixed_solution(factor: np.ndarray, px: int) -> np.ndarray:
    """Γ̃ (n, p_x) from :func:`joint_fit`'s factor [R r] (least squares: minimum norm
    where R is singular, when the fixed regressors are not identified)."""
    return np.linalg.lstsq(factor[:, :px], factor[:, px:], rcond=None)[0].T


def adjusted_data(data: np.ndarray, pz: int, px: int, gamma: np.ndarray) -> np.ndarray:
    """Rows [z̃  ỹ − Γ̃ x̃] (N, q, p_z + n): the pure-change search data for a given Γ̃ (n, p_x)."""
    z = data[..., :pz]
    x = data[..., pz : pz + px]
    y = data[..., pz + px :]
    return np.ascontiguousarray(np.concatenate([z, y - x @ gamma.T], axis=2))


@dataclass
class Alternation:
    """One run of the iterated procedure (:func:`alternate`).

    Attributes
    ----------
    changepoints : ndarray of int64
        The best breaks met (the last ones: the objective never increases).
    objective : float
        Their objective, RSS (+ β · #changes), scaled units; inf if no
        segmentation was feasible.
    iterations : int
        Alternations done.
    converged : bool
        Stopped on the tolerance or at a fixed point (the same breaks twice).
    history : list of float
        The objective at the start, then after each alternation.
    work : int
        Rows rotated by the searches.
    """

    changepoints: np.ndarray
    objective: float
    iterations: int
    converged: bool
    history: list = field(default_factory=list)
    work: int = 0


def alternate(
    data: np.ndarray,
    pz: int,
    px: int,
    gamma: np.ndarray,
    changepoints: np.ndarray | None,
    objective: float,
    *,
    n_changes: int,
    beta: float | None,
    min_size: int,
    a_max: np.ndarray,
    tolerance: float = TOLERANCE,
    max_iterations: int = MAX_ITERATIONS,
) -> Alternation:
    """Bai and Perron's (2003, section 3.2) iterated procedure from Γ̃ = ``gamma``.

    Alternates (a) the exact search for the breaks of ỹ − Γ̃x̃ on z̃ — dynamic
    programming with exactly ``n_changes`` changes, or PELT with ``beta`` per
    change — and (b) the joint least squares of (Θ_j, Γ) given those breaks
    (:func:`joint_fit`). Step (a) at the previous breaks reproduces the previous
    joint RSS (Θ_j is optimal given Γ), so neither step increases the objective.
    Stops when the objective decreases by at most ``tolerance`` times itself, at
    a fixed point (the same breaks twice: the same Γ follows), or after
    ``max_iterations``.

    Parameters
    ----------
    data : ndarray, shape (N, q, p_z + p_x + n)
        Scaled rows [z̃ x̃ ỹ].
    pz, px : int
    gamma : ndarray, shape (n, p_x)
        The starting Γ̃.
    changepoints : ndarray of int or None
        The breaks ``gamma`` was fitted on (None: not from breaks).
    objective : float
        Their objective (inf when ``changepoints`` is None).
    n_changes : int
        M for the dynamic program (ignored with ``beta``).
    beta : float or None
        The penalty per change in scaled units (PELT), or None.
    min_size : int
    a_max : ndarray of int64, shape (N + 1,)
        ``feasible_starts`` of the changing regressors.

    Returns
    -------
    Alternation
    """
    N = data.shape[0]
    start = np.zeros(0, dtype=np.int64) if changepoints is None else changepoints
    run = Alternation(start, objective, 0, False, [objective])
    previous = changepoints
    for iteration in range(1, max_iterations + 1):
        adjusted = adjusted_data(data, pz, px, gamma)
        if beta is None:
            costs, starts = dynamic_program(adjusted, pz, n_changes, min_size, a_max)
            run.work += N * (N + 1) // 2
            if not np.isfinite(costs[n_changes]):
                return run
            found = backtrack_layers(starts, n_changes)
        else:
            margin = PRUNE_MARGIN * float(np.sum(adjusted[..., pz:] ** 2))
            last, _, rows = pelt(adjusted, pz, beta, min_size, a_max, margin)
            run.work += int(rows)
            found = backtrack_last(last)
        bounds = np.concatenate([[0], found, [N]]).astype(np.int64)
        rss, factor = joint_fit(data, pz, px, bounds)
        gamma = fixed_solution(factor, px)
        value = rss + (0.0 if beta is None else beta * len(found))
        run.history.append(value)
        decrease = run.objective - value
        if value <= run.objective:
            run.changepoints, run.objective = found, value
        run.iterations = iteration
        same = previous is not None and np.array_equal(found, previous)
        if same or (np.isfinite(decrease) and decrease <= tolerance * value):
            run.converged = True
            return run
        previous = found
    return run
