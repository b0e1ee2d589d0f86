"""Active-set polish of a sparse-change solution: exact zeros and a certificate.

Close to the optimum, an interior-point iterate tells which differences
e_c = (ΛDk)_c vanish (cones at their vertex, the set V) and which do not
(the active set A), even when its Newton systems are too ill-conditioned to
close the duality gap (degenerate optima, e.g. order 2 near λ_max). With that
split fixed, the problem

    minimize ‖y − Φk‖² + Σ_{c∈A} ‖e_c‖   subject to  e_c = 0 for c ∈ V

is smooth near its solution, and k lives in a small subspace k = Bθ:
piecewise constant (order 1) or continuous piecewise linear (order 2) with
knots where the active rows of D are (per coefficient for ``l1``, shared by
all coefficients for ``group``). Damped Newton on θ converges in a few steps
on sparse systems of the size of the number of changes, not of N. The
interior-point method calls it as a fallback (on long series with many small
changes the split settles in the last iterations, when polishing no longer
saves time), early for wide group blocks, and first of all for a warm start
along a λ path (:func:`path_polish`): the neighbouring solution's split,
corrected as λ moves, often certifies the new optimum without an iteration.

The result is accepted only with a certificate for the full problem: the
dual vector u with DᵀΛu = −∇f(k) (f the squared loss) is unique because DᵀΛ
has full column rank, and a forward recurrence gives it. With u scaled into
the dual cones (‖u_c‖ <= 1), the duality gap Σ_c (‖e_c‖ − u_cᵀe_c) and the
stationarity residual bound the distance to the optimum, exactly as the
interior-point method's own stopping test does. A wrong split shows up as a
vertex cone with ‖u_c‖ > 1 (a large residual after scaling) and the polish
is rejected.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from . import conekernels as cones
from .penalties import Penalty, named
from .problem import RegressionProblem, apply_difference, apply_difference_adjoint

__all__ = [
    "Certificate",
    "PolishResult",
    "vertex_cones",
    "certificate",
    "stationarity_scale",
    "polish",
    "path_polish",
]

# Newton iterations on the reduced problem (it converges quadratically from an
# interior-point iterate; more means the split is wrong).
MAX_NEWTON = 30
# Halvings of the Newton step in the backtracking line search.
MAX_HALVINGS = 40
# Corrections of the split of the cones into vertex and active ones. Each moves
# only the cones that a step reaches first (active -> vertex, see _reduced_solve)
# or that are most violated (vertex -> active), within SPLIT_TIES of the extreme
# one. A cluster of neighbouring rows that the iterate marks active where the
# optimum has one collapses one cone per split, hence the room.
MAX_SPLITS = 200
SPLIT_TIES = 1.5
# Shift of the reduced Hessian, relative to its largest diagonal entry. The data
# need not determine the reduced problem: at T = 2000 (seed 3, order 2, l1 at
# 0.5 λ_max) the iterate marks active the rows 873–876 of two coefficients of one
# output row; single-sample spikes of both at one time step fit one equation, so
# the Hessian (no curvature from |e|) was singular and its LU step was 1e25. With
# the shift the step follows the flat direction (|e| decreases linearly along it)
# until a cone reaches its vertex; on a definite Hessian it changes the Newton
# steps by a relative 1e-12 of its condition number, which the iteration absorbs.
HESSIAN_SHIFT = 1e-12
# Reduced problems of at most this many unknowns are solved with dense matrices: at
# that size scipy's sparse products and LU cost more in overhead than in arithmetic.
DENSE_SIZE = 600
# A Newton decrement below this fraction of the objective is below the objective's
# rounding (its evaluation cancels terms of the size of ‖y‖²): the line search cannot
# judge such a step, and takes it whole.
RESOLVABLE_DECREASE = 1e-13
# :func:`path_polish` opens a released cone by this fraction of the largest active
# difference ‖(ΛDk)_c‖: small, so that Newton starts next to the last solve's k, but
# far above rounding, so that the cone's direction is that of its dual.
OPEN_FRACTION = 1e-3


@dataclass
class PolishResult:
    """A polished solution with its optimality certificate."""

    k: np.ndarray  # (N, K)
    objective: float
    duality_gap: float
    dual_residual: float
    newton_iterations: int
    dual: np.ndarray  # (N − d, K): the certificate's u, DᵀΛu = −∇f(k), ‖u_c‖ <= 1


class Certificate(NamedTuple):
    """The optimality certificate of a sparse fit's k (:func:`certificate`)."""

    objective: float
    duality_gap: float  # Σ_c (‖e_c‖ − u_cᵀe_c) >= 0
    dual_residual: float  # ‖DᵀΛu + ∇f(k)‖ / stationarity_scale
    dual_norms: np.ndarray  # (n_cones,) ‖u_c‖ before the scaling into the dual cones
    dual: np.ndarray  # (N − d, K) u, scaled so that every ‖u_c‖ <= 1


def vertex_cones(s: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Cones that an interior-point iterate puts at their vertex (boolean, per cone).

    At the optimum a vertex cone has s = 0 with z inside the cone, an active
    one s ≠ 0 with z on the boundary; along the central path s of a vertex
    cone and the distance of z to the boundary of an active one shrink like
    the gap. The scale-free comparison of s₀ / max s₀ with (z₀ − ‖z₁‖)/z₀
    separates the two as soon as the gap is small against the changes.
    """
    s_rel = s[:, 0] / max(float(s[:, 0].max(initial=0.0)), 1e-300)
    z_inside = 1.0 - np.linalg.norm(z[:, 1:], axis=1) / z[:, 0]
    return s_rel < z_inside


def _knot_basis(active_rows: np.ndarray, N: int, degree: int):
    """Scalar basis (rows t, columns, values, size q) of sequences with D v = 0 off the active rows.

    Degree 1: constant between the active rows (a new piece after each).
    Degree 2: continuous piecewise linear with a kink at r + 1 for each active row r.
    """
    t = np.arange(N)
    if degree == 1:
        starts = np.zeros(N, dtype=np.int64)
        starts[active_rows + 1] = 1
        return t, np.cumsum(starts), np.ones(N), len(active_rows) + 1
    knots = np.unique(np.concatenate([[0], active_rows + 1, [N - 1]]))
    left = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
    frac = (t - knots[left]) / (knots[left + 1] - knots[left])
    rows = np.concatenate([t, t])
    cols = np.concatenate([left, left + 1])
    return rows, cols, np.concatenate([1.0 - frac, frac]), len(knots)


def _subspace(vertex: np.ndarray, N: int, K: int, degree: int, group: bool) -> sp.csr_matrix:
    """B (N·K × q): k = Bθ ranges over the coefficients with e_c = 0 on the vertex cones."""
    R = N - degree
    if group:
        rows, cols, vals, q = _knot_basis(np.flatnonzero(~vertex), N, degree)
        coefficient = np.arange(K)
        rows = (rows[:, None] * K + coefficient).ravel()
        cols = (cols[:, None] * K + coefficient).ravel()
        return sp.csr_matrix((np.repeat(vals, K), (rows, cols)), shape=(N * K, q * K))
    parts_r, parts_c, parts_v, offset = [], [], [], 0
    vertex = vertex.reshape(R, K)
    for j in range(K):
        rows, cols, vals, q = _knot_basis(np.flatnonzero(~vertex[:, j]), N, degree)
        parts_r.append(rows * K + j)
        parts_c.append(cols + offset)
        parts_v.append(vals)
        offset += q
    return sp.csr_matrix(
        (np.concatenate(parts_v), (np.concatenate(parts_r), np.concatenate(parts_c))),
        shape=(N * K, offset),
    )


def _block_diagonal(blocks: np.ndarray) -> sp.csr_matrix:
    """Sparse block-diagonal matrix of the (c, g, g) blocks."""
    c, g, _ = blocks.shape
    base = np.arange(c)[:, None, None] * g
    rows = np.broadcast_to(base + np.arange(g)[:, None], blocks.shape)
    cols = np.broadcast_to(base + np.arange(g)[None, :], blocks.shape)
    return sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(c * g, c * g))


class _Operators:
    """The reduced problem of any split (:func:`_reduced_solve`) from sparse Φ (N·q·n × N·K)
    and ΛD (R·K × N·K) acting on vec(k), row-major (t, j), and the subspace basis B."""

    def __init__(self, problem: RegressionProblem, weights: np.ndarray, group: bool) -> None:
        N, q, n, p, K = problem.N, problem.q, problem.n, problem.p, problem.K
        coeffs = np.asarray(problem.coeffs, float)
        d = len(coeffs) - 1
        t, row, i, a = np.meshgrid(
            np.arange(N), np.arange(q), np.arange(n), np.arange(p), indexing="ij"
        )
        self.phi_op = sp.csr_matrix(
            (
                problem.phi[t, row, a].ravel(),
                (((t * q + row) * n + i).ravel(), (t * K + i * p + a).ravel()),
            ),
            shape=(N * q * n, N * K),
        )
        R = N - d
        r, lag, j = np.meshgrid(np.arange(R), np.arange(d + 1), np.arange(K), indexing="ij")
        self.diff_op = sp.csr_matrix(
            (
                (coeffs[lag] * weights[j]).ravel(),
                ((r * K + j).ravel(), ((r + lag) * K + j).ravel()),
            ),
            shape=(R * K, N * K),
        )
        self.problem, self.group = problem, group

    def system(self, vertex: np.ndarray, k: np.ndarray):
        """(gram, rhs, E, θ, expand) of the split ``vertex`` and the projection θ of k (N, K):
        the reduced objective ½θᵀ gram θ − rhsᵀθ + ‖y‖² + Σ_c ‖(Eθ)_c‖ over the active
        cones, and expand(θ) = Bθ as (N, K); None where BᵀB is singular."""
        problem = self.problem
        N, K = problem.N, problem.K
        g = K if self.group else 1
        B = _subspace(vertex, N, K, problem.degree, self.group)
        A = self.phi_op @ B
        active = np.flatnonzero(~vertex)
        E = (self.diff_op @ B)[(active[:, None] * g + np.arange(g)).ravel()].tocsr()
        gram = (2.0 * (A.T @ A)).tocsc()
        rhs = 2.0 * (A.T @ problem.y.ravel())
        try:
            theta = splu((B.T @ B).tocsc()).solve(B.T @ k.ravel())
        except RuntimeError:
            return None
        return gram, rhs, E, theta, lambda th: (B @ th).reshape(N, K)


class _Segments:
    """:class:`_Operators` for group cones and a first difference, where k is constant
    between the active rows: each segment's sums of φφᵀ and φyᵀ and its mean of k
    (np.add.reduceat over the steps), no operator of the size of the data. At K = 60,
    T = 4000 the generic reduced systems took 35 ms each (sparse products with B)."""

    def __init__(self, problem: RegressionProblem, weights: np.ndarray) -> None:
        self.problem, self.weights = problem, np.asarray(weights, float)
        self.gram_steps = problem.gram()  # (N, p, p)
        self.cross_steps = problem.cross()  # (N, p, n)

    def system(self, vertex: np.ndarray, k: np.ndarray):
        """As :meth:`_Operators.system`."""
        problem = self.problem
        N, n, K = problem.N, problem.n, problem.K
        c0, c1 = (float(c) for c in problem.coeffs)
        active = np.flatnonzero(~vertex)  # segment c ends at step active[c]
        starts = np.concatenate([[0], active + 1])
        lengths = np.diff(np.concatenate([starts, [N]]))
        S = starts.size
        # 2 I_n ⊗ Σ_s φφᵀ per segment, and 2 Σ_s φyᵀ in k's (output, regressor) order
        segment_gram = 2.0 * np.add.reduceat(self.gram_steps, starts, axis=0)
        blocks = np.einsum("ij,sab->siajb", np.eye(n), segment_gram).reshape(S, K, K)
        cross = np.add.reduceat(self.cross_steps, starts, axis=0)  # (S, p, n)
        rhs = 2.0 * cross.transpose(0, 2, 1).reshape(S * K)
        # e_c = Λ(c₀θ_c + c₁θ_{c+1}): the difference across the boundary after segment c
        boundary = np.arange(S - 1)[:, None] * K + np.arange(K)
        scaled = np.broadcast_to(self.weights, (S - 1, K))
        gram: np.ndarray | sp.spmatrix
        E: np.ndarray | sp.spmatrix
        if S * K <= DENSE_SIZE:  # dense at once: scipy's sparse constructors cost more
            gram = np.zeros((S, K, S, K))
            gram[np.arange(S), :, np.arange(S), :] = blocks
            gram = gram.reshape(S * K, S * K)
            E = np.zeros(((S - 1) * K, S * K))
            E[boundary.ravel(), boundary.ravel()] = c0 * scaled.ravel()
            E[boundary.ravel(), (boundary + K).ravel()] = c1 * scaled.ravel()
        else:
            gram = _block_diagonal(blocks).tocsc()
            E = sp.csr_matrix(
                (
                    np.concatenate([c0 * scaled.ravel(), c1 * scaled.ravel()]),
                    (
                        np.concatenate([boundary.ravel(), boundary.ravel()]),
                        np.concatenate([boundary.ravel(), (boundary + K).ravel()]),
                    ),
                ),
                shape=((S - 1) * K, S * K),
            )
        theta = (np.add.reduceat(k, starts, axis=0) / lengths[:, None]).ravel()
        return gram, rhs, E, theta, lambda th: np.repeat(th.reshape(S, K), lengths, axis=0)


class _CoefficientSegments(_Segments):
    """:class:`_Segments` for l1 cones, where each coefficient is constant between its
    own active rows (its segments). The gram couples the segments of one output's
    coefficients that overlap in time: the steps of an output are cut at every
    boundary of its coefficients, and each piece's sum of φφᵀ (np.add.reduceat) goes
    to the pairs of segments that contain it. At T = 10⁴, K = 6 a reduced system takes
    1.6 ms; through :class:`_Operators` (sparse products with B) it took 4 ms and
    their construction 5 ms."""

    def system(self, vertex: np.ndarray, k: np.ndarray):
        """As :meth:`_Operators.system`."""
        problem = self.problem
        N, n, p, K = problem.N, problem.n, problem.p, problem.K
        c0, c1 = (float(c) for c in problem.coeffs)
        active = np.flatnonzero(~vertex)  # cone r·K + j: row r of D, coefficient j
        rows, coefficient = np.divmod(active, K)
        # coefficient j's segments start at 0 and after each of its active rows (ascending)
        by_coefficient = np.argsort(coefficient, kind="stable")
        counts = np.bincount(coefficient, minlength=K)
        first_cone = np.concatenate([[0], np.cumsum(counts)])
        starts = [
            np.concatenate([[0], rows[by_coefficient[first_cone[j] : first_cone[j + 1]]] + 1])
            for j in range(K)
        ]
        offset = np.concatenate([[0], np.cumsum(counts + 1)])  # θ's index of segment 0 of j
        size = int(offset[-1])
        lengths = [np.diff(np.concatenate([s, [N]])) for s in starts]
        theta = np.concatenate([np.add.reduceat(k[:, j], starts[j]) / lengths[j] for j in range(K)])
        cross = self.cross_steps
        rhs = 2.0 * np.concatenate(
            [np.add.reduceat(cross[:, j % p, j // p], starts[j]) for j in range(K)]
        )
        # 2 Σ φφᵀ over the pieces of each output: pair (a, b) of a piece couples the
        # segment of coefficient a that holds it with that of coefficient b
        entry_rows, entry_cols, entry_values = [], [], []
        for i in range(n):
            own = range(i * p, (i + 1) * p)
            pieces = np.unique(np.concatenate([starts[j] for j in own]))
            index = np.stack(
                [offset[j] + np.searchsorted(starts[j], pieces, side="right") - 1 for j in own],
                axis=1,
            )  # (pieces, p)
            sums = np.add.reduceat(self.gram_steps, pieces, axis=0)  # (pieces, p, p)
            entry_rows.append(np.broadcast_to(index[:, :, None], sums.shape).ravel())
            entry_cols.append(np.broadcast_to(index[:, None, :], sums.shape).ravel())
            entry_values.append(2.0 * sums.ravel())
        gram = sp.csc_matrix(
            (
                np.concatenate(entry_values),
                (np.concatenate(entry_rows), np.concatenate(entry_cols)),
            ),
            shape=(size, size),
        )  # (duplicates summed)
        # e_c = λ_j(c₀θ_{j,s} + c₁θ_{j,s+1}) for the cone after segment s of coefficient j
        position = np.empty(active.size, dtype=np.int64)
        position[by_coefficient] = np.arange(active.size) - first_cone[coefficient[by_coefficient]]
        left = offset[coefficient] + position
        scaled = self.weights[coefficient]
        E = sp.csr_matrix(
            (
                np.concatenate([c0 * scaled, c1 * scaled]),
                (np.tile(np.arange(active.size), 2), np.concatenate([left, left + 1])),
            ),
            shape=(active.size, size),
        )

        def expand(th: np.ndarray) -> np.ndarray:
            out = np.empty((N, K))
            for j in range(K):
                out[:, j] = np.repeat(th[offset[j] : offset[j + 1]], lengths[j])
            return out

        return gram, rhs, E, theta, expand


def certificate(
    problem: RegressionProblem, weights: np.ndarray, k: np.ndarray, penalty: Penalty
) -> Certificate:
    """The optimality certificate of k (N, K) for the full problem with a sparse ``penalty``:
    its objective, duality gap, relative dual residual, the dual norm per cone and
    the dual u itself (scaled into the dual cones).

    Any k gets one; weights (K,) finite and >= 0. An interior-point iterate's cone
    duals z₁ are −u at its optimum (:class:`~.ipm.InteriorPointResult`). The dual
    solves DᵀΛu = −∇f(k) on the rows t < N − d, the recurrence
    Σ_q c_q (Λu)_{t−q} = −∇f_t; a coefficient without penalty (weight 0) has no
    dual (u = 0): its gradient must vanish, which the stationarity residual
    measures. The group and l1 cones are computed in compiled passes
    (:func:`.conekernels.certificate_terms`), any other penalty's from its norms.
    """
    N, K = problem.N, problem.K
    coeffs = np.ascontiguousarray(problem.coeffs, dtype=float)
    R = N - (len(coeffs) - 1)
    group = {"group": True, "l1": False}.get(penalty.name)  # the cones compiled
    if group is not None:
        n_cones = R if group else R * K
        u, grad = np.empty((R, K)), np.empty((N, K))
        e_norm, u_norm = np.empty(n_cones), np.empty(n_cones)
        loss, reg, gap, stationarity = cones.certificate_terms(
            np.ascontiguousarray(k, dtype=float),
            np.ascontiguousarray(problem.y, dtype=float),
            np.ascontiguousarray(problem.phi, dtype=float),
            coeffs,
            np.ascontiguousarray(weights, dtype=float),
            group,
            u,
            grad,
            e_norm,
            u_norm,
        )
        residual = float(np.sqrt(stationarity)) / stationarity_scale(problem)
        return Certificate(float(loss + reg), float(gap), residual, u_norm, u)
    resid = problem.residuals(k.reshape(N, problem.n, problem.p))
    gradient = -2.0 * np.einsum("tji,tja->tia", resid, problem.phi).reshape(N, K)
    from scipy.signal import lfilter  # (0.4 s to import: only for other penalties)

    lam_u = lfilter([1.0], coeffs, -gradient[:R], axis=0)
    u = np.divide(lam_u, weights, out=np.zeros_like(lam_u), where=weights > 0)
    e = apply_difference(k, coeffs) * weights
    e_norms, u_norms = penalty.cone_norms(e), penalty.dual_norms(u)
    u /= max(1.0, float(u_norms.max(initial=0.0)))
    objective = float(np.sum(resid**2) + e_norms.sum())
    gap = max(float(e_norms.sum() - np.sum(u * e)), 0.0)
    stationarity = apply_difference_adjoint(u * weights, coeffs, N) + gradient
    residual = float(np.linalg.norm(stationarity)) / stationarity_scale(problem)
    return Certificate(objective, gap, residual, u_norms.ravel(), u)


def stationarity_scale(problem: RegressionProblem) -> float:
    """Scale of the stationarity residual 2Φᵀ(Φk − y) − DᵀΛu: 1 + 2‖y‖‖Φ‖.

    Sums of squares, not np.linalg.norm: its BLAS dot woke OpenBLAS's threads,
    which took up to 8 ms per call on a busy machine (T = 10⁴).
    """
    y_norm = np.sqrt(np.sum(np.square(problem.y)))
    phi_norm = np.sqrt(np.sum(np.square(problem.phi)))
    return 1.0 + 2.0 * float(y_norm) * float(phi_norm)


def polish(
    problem: RegressionProblem,
    weights: np.ndarray,
    norm: str,
    k: np.ndarray,
    s: np.ndarray,
    z: np.ndarray,
    tol: float,
    max_splits: int = MAX_SPLITS,
    max_active: int | None = None,
) -> PolishResult | None:
    """Solve the problem with the split of an interior-point iterate fixed; None if not optimal.

    The split is corrected up to MAX_SPLITS times, one decision at a time, as
    in an active-set method: a Newton step that drives active cones through
    their vertex stops where the first of them gets there, that cone moves to
    V and Newton goes on from that point; after a solve, the vertex cones whose
    dual exceeds 1 the most move to A and Newton restarts from the projection
    of the iterate's k, whose differences point the right way (near a
    degenerate optimum the iterate often marks a cluster of neighbouring rows
    active where the optimum has one or two, and moving all crossing cones at
    once overshoots). The reduced Hessian is shifted by HESSIAN_SHIFT: where the
    data leave directions of the subspace undetermined, its steps follow them
    until a cone reaches its vertex.

    Parameters
    ----------
    problem : RegressionProblem
        With a difference operator of degree 1 or 2.
    weights : ndarray, shape (K,)
        Finite positive λ_j.
    norm : {"group", "l1"}
    k : ndarray, shape (N, K)
        The iterate's coefficients (the first Newton start is their projection).
    s, z : ndarray, shape (n_cones, g + 1)
        The iterate's primal slacks and dual variables (cone layout of :mod:`.ipm`).
    tol : float
        Accept when the duality gap relative to the objective and the relative
        stationarity residual are below ``tol``.
    max_splits : int
        Corrections of the split at most (each a reduced solve).
    max_active : int, optional
        Give up (None) when the split has more active cones than this (the
        reduced problems grow with them).

    Returns
    -------
    PolishResult or None
        None when no corrected split passes the certificate.
    """
    return _polish_split(
        problem, weights, norm, k, vertex_cones(s, z), tol, max_splits, max_active, False
    )


def path_polish(
    problem: RegressionProblem,
    weights: np.ndarray,
    norm: str,
    k: np.ndarray,
    dual: np.ndarray,
    tol: float,
    max_splits: int,
    max_active: int,
) -> PolishResult | None:
    """:func:`polish` from the solution of the same problem at other weights (a λ path),
    for a first difference (None for other operators).

    The split starts as that solution's: a cone is at its vertex where its
    difference ‖(ΛDk)_c‖, relative to the largest, is below 1 − ‖z₁_c‖ (the
    rule of :func:`vertex_cones` with s = (‖ΛDk‖, ΛDk) and z = (1, z₁)). Its
    corrections differ where a vertex cone's dual exceeds 1: that solution
    has e_c = 0 there too, so restarting from it gives the cone no direction.
    Only the most violated cone moves to A, and Newton restarts from the last
    solve's k with that cone opened along its dual u_c (the direction in which
    the objective falls at the rate ‖u_c‖ − 1), by OPEN_FRACTION of the largest
    active difference.

    Parameters
    ----------
    problem, weights, norm, tol, max_splits, max_active
        As in :func:`polish` (weights: the new ones).
    k : ndarray, shape (N, K)
        The other solution's coefficients.
    dual : ndarray, shape (n_cones, g)
        Its cone duals z₁ (:class:`~.ipm.InteriorPointResult`'s ``dual``).

    Returns
    -------
    PolishResult or None
    """
    if problem.degree != 1:  # (a first difference: the coefficients sum to zero)
        return None
    g = problem.K if norm == "group" else 1
    e_norms = named(norm).cone_norms(apply_difference(k, problem.coeffs) * weights).reshape(-1)
    largest = max(float(e_norms.max(initial=0.0)), 1e-300)
    inside = 1.0 - np.sqrt(np.sum(dual.reshape(-1, g) ** 2, axis=1))
    vertex = e_norms / largest < inside
    return _polish_split(problem, weights, norm, k, vertex, tol, max_splits, max_active, True)


def _polish_split(
    problem, weights, norm, k, vertex, tol, max_splits, max_active, open_along_dual
) -> PolishResult | None:
    """The active-set iteration of :func:`polish` from the split ``vertex`` (per cone);
    ``open_along_dual``: release cones as :func:`path_polish` does."""
    group = norm == "group"
    reduction: _Operators | _Segments | None = None
    newton_total = 0
    start = k
    for _ in range(max_splits):
        if max_active is not None and np.count_nonzero(~vertex) > max_active:
            return None
        if reduction is None:
            if problem.degree != 1:
                reduction = _Operators(problem, weights, group)
            elif group:
                reduction = _Segments(problem, weights)
            else:
                reduction = _CoefficientSegments(problem, weights)
        solved = _reduced_solve(problem, vertex, start, reduction, group)
        if solved is None:
            return None
        k_split, collapsed, iterations = solved
        newton_total += iterations
        if collapsed is not None:
            # The step stopped where these cones reach their vertex: Newton goes on
            # from there in the smaller subspace (k_split is in it, up to the
            # tangential part of a group cone's difference, which the projection drops).
            vertex = vertex.copy()
            vertex[collapsed] = True
            start = k_split
            continue
        obj, gap, dual_res, u_norm, u = certificate(problem, weights, k_split, named(norm))
        if gap <= tol * obj and dual_res <= tol:
            return PolishResult(
                k=k_split,
                objective=obj,
                duality_gap=gap,
                dual_residual=dual_res,
                newton_iterations=newton_total,
                dual=u,
            )
        violated = vertex & (u_norm > 1.0)
        if not violated.any():
            return None
        if open_along_dual:
            released = int(np.argmax(np.where(vertex, u_norm, 0.0)))
            vertex = vertex.copy()
            vertex[released] = False
            start = k_split + _opening(problem, weights, norm, k_split, u, released, vertex)
            continue
        # Only the most violated cones move: their moving changes all duals.
        violated &= u_norm - 1.0 >= (u_norm[violated].max() - 1.0) / SPLIT_TIES
        vertex = vertex & ~violated
        # A released cone has e_c = 0 at k_split, which gives its Newton step no
        # direction: restart from the iterate's k, whose differences point the right way.
        start = k
    return None


def _opening(problem, weights, norm, k, u, cone, vertex) -> np.ndarray:
    """δk (N, K) with ΛDδk zero but on ``cone``, where it is OPEN_FRACTION of the largest
    active ‖(ΛDk)_c‖ (``vertex``: per cone) along u_c (u (N − 1, K), the certificate's
    dual of k); D a first difference: δk is a step after the cone's row."""
    K = problem.K
    g = K if norm == "group" else 1
    c0, c1 = (float(c) for c in problem.coeffs)
    active = np.flatnonzero(~vertex)
    active = active[active != cone]
    rows = active * g // K  # the rows of D of the active cones, and their differences
    e = (c0 * k[rows] + c1 * k[rows + 1]) * weights
    if g == 1:
        norms = np.abs(e[np.arange(active.size), active % K])
    else:
        norms = np.sqrt(np.sum(e**2, axis=1))
    size = OPEN_FRACTION * float(np.max(norms, initial=0.0))
    if not size > 0.0:  # no active cone: a fraction of the coefficients' scale
        size = OPEN_FRACTION * (float(np.max(np.abs(k) * weights, initial=0.0)) or 1.0)
    row, columns = cone * g // K, slice(cone * g % K, cone * g % K + g)
    direction = u[row, columns]
    step = np.zeros(K)
    step[columns] = size * direction / max(float(np.sqrt(np.sum(direction**2))), 1e-300)
    delta = np.zeros_like(k)
    delta[row + 1 :] = step / np.where(weights > 0, weights, 1.0) / c1
    return delta


def _reduced_solve(problem, vertex, k, reduction, group):
    """Newton on the reduced problem from the projection of k.

    Returns (k, collapsed cones or None, Newton iterations), or None when the
    reduced problem is singular or a step is not finite. A step that drives
    active cones through their vertex stops where the first of them gets there
    (its radial component vanishes) and returns them as collapsed, with the k
    of that point: the caller moves them to V and goes on from there. After
    MAX_NEWTON iterations the iterate is returned (for the certificate to judge).
    """
    K = problem.K
    g = K if group else 1
    active = np.flatnonzero(~vertex)
    system = reduction.system(vertex, k)
    if system is None:
        return None
    gram, rhs, E, theta, expand = system
    dense = gram.shape[0] <= DENSE_SIZE
    if dense and sp.issparse(gram):
        gram, E = gram.toarray(), E.toarray()
    y_sq = float(problem.y.ravel() @ problem.y.ravel())

    def objective(th: np.ndarray) -> float:
        e = (E @ th).reshape(-1, g)
        return float(th @ (0.5 * (gram @ th) - rhs) + y_sq + np.linalg.norm(e, axis=1).sum())

    shift_scale = HESSIAN_SHIFT * max(float(gram.diagonal().max(initial=0.0)), 1e-300)
    unit_matrix = np.eye(gram.shape[0]) if dense else sp.identity(gram.shape[0], format="csc")
    shift = shift_scale * unit_matrix
    current = objective(theta)
    for iteration in range(1, MAX_NEWTON + 1):
        e = (E @ theta).reshape(-1, g)
        e_norm = np.linalg.norm(e, axis=1)
        if e_norm.size and e_norm.min() <= 1e-12 * max(e_norm.max(), 1e-300):
            return expand(theta), active[e_norm <= 1e-12 * e_norm.max()], iteration
        unit = e / e_norm[:, None]
        grad = gram @ theta - rhs + E.T @ unit.ravel()
        hessian = gram
        if g > 1 and e_norm.size:
            # Hessian of ‖e‖: (I − êêᵀ)/‖e‖ per cone, block diagonal.
            blocks = (np.eye(g) - unit[:, :, None] * unit[:, None, :]) / e_norm[:, None, None]
            if dense:
                cones = E.reshape(-1, g, E.shape[1])  # (active cones, g, unknowns)
                hessian = gram + E.T @ np.matmul(blocks, cones).reshape(E.shape)
            else:
                hessian = gram + E.T @ _block_diagonal(blocks) @ E
        try:
            if dense:
                step = np.linalg.solve(hessian + shift, -grad)
            else:
                step = splu((hessian + shift).tocsc()).solve(-grad)
        except (RuntimeError, np.linalg.LinAlgError):
            return None
        decrease = -float(grad @ step)
        if not np.isfinite(decrease):
            return None
        if decrease <= 1e-20 * max(current, 1e-300):  # the gap is O(√decrease)
            return expand(theta), None, iteration
        # Stop at the first cone that the step drives to its vertex (its radial
        # component reverses before α = 1); beyond it |e_c| is no longer smooth and
        # the Newton model is wrong. Only that cone (and ties) moves to V: the step
        # changes once it does.
        toward = -np.sum(unit * (E @ step).reshape(-1, g), axis=1)
        crossed = toward >= e_norm
        first, alpha = None, 1.0
        if crossed.any():
            at = e_norm[crossed] / toward[crossed]
            alpha = float(at.min())
            first = active[crossed][at <= alpha * (1.0 + 1e-9)]
        full = alpha
        # Below RESOLVABLE_DECREASE of the objective its rounding hides any descent:
        # the Newton model is exact there, so its step is taken as it is (halving it
        # would stall the decrement near 1e-17 and leave a gap of O(√1e-17)).
        resolvable = decrease > RESOLVABLE_DECREASE * max(current, 1e-300)
        for _ in range(MAX_HALVINGS):
            trial = objective(theta + alpha * step)
            if trial <= current - 0.25 * alpha * decrease or not resolvable:
                break
            alpha *= 0.5
        else:
            # No descent along the step: the certificate judges the iterate.
            return expand(theta), None, iteration
        theta = theta + alpha * step
        current = trial
        if first is not None and alpha == full:
            return expand(theta), first, iteration
    # The Newton decrement stalled short of 1e-20 (at T = 2000 it settled near 1e-17 of
    # the objective: the rounding of the gradient): the certificate judges the iterate.
    return expand(theta), None, MAX_NEWTON
