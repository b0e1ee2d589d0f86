"""Exact L0 segmentation of a regression: dynamic programming and PELT (paper eq:l0).

The data are y_t ∈ R^n and φ_t ∈ R^p, t = 0 … N-1, and a segmentation
0 = τ_0 < τ_1 < … < τ_{M+1} = N fits one least-squares model per segment
[τ_j, τ_{j+1}). The cost of a segment [a, b) is its residual sum of squares

    C(a, b) = min_Θ Σ_{t=a}^{b-1} ‖y_t − Θ φ_t‖²  (Θ ∈ R^{n×p}),

and the solvers minimize Σ_j C(τ_j, τ_{j+1}) over all segmentations with M
changes (dynamic programming, every M' = 0 … M at once) or with a penalty β
per change (PELT).

How a segment cost is computed
------------------------------
For a fixed segment end b the starts a = b-1, b-2, … are visited in turn and
the row [φ_aᵀ y_aᵀ] is rotated into an upper-triangular factor [R Z] of the
augmented data matrix by p Givens rotations (sequential QR, as in recursive
least squares in square-root form). What is left of the row after the
rotations, an n-vector, is an orthogonal component of the residual, so
C(a, b) = C(a + 1, b) + ‖left-over‖²: every cost of every start for that end
in O(p (p + n)) operations per start, with no p×p inverse, no normal
equations and no difference of large prefix sums (the usual
Σyᵀy − tr(SφyᵀSφφ⁻¹Sφy) loses every digit when the fit is good). All output
rows share the rotations of φ. The costs are sums of nonnegative terms, so
they are never negative and never decrease as a segment grows.

Feasible segments
-----------------
A segment is feasible when it has at least ``min_size`` samples and the Gram
matrix G(a, b) = Σ φ̃_t φ̃_tᵀ of the regressors, scaled to unit RMS per column
over the whole data, has smallest eigenvalue above τ = 1e-10 · N (its
correlation-scaled version then has smallest eigenvalue above 1e-10, the
identifiability threshold of :mod:`ltvmodels.core.identifiability`). Adding rows
only increases G, so feasibility is monotone: [a, b) feasible implies every
segment containing it is feasible. For each end b the feasible starts are
therefore 0 … a_max(b) with a_max nondecreasing, found by a two-pointer sweep
with a sliding Gram matrix and a Cholesky test of G − τI. Infeasible segments
(too short, or with regressors that are numerically linearly dependent) are
never used; their least-squares cost is not meaningful.

PELT with a minimum segment size
--------------------------------
F(b) = min_a F(a) + β + C(a, b), F(0) = −β. Because least-squares costs are
superadditive, C(a, b') ≥ C(a, b) + C(b, b'), a start a with
F(a) + C(a, b) ≥ F(b) can never beat b as the last change for any end b' for
which [b, b') is feasible (pruning constant K = 0). With a minimum size and
infeasible stretches that is not every b' > b: the candidate is dropped only
from the first end b' with a_max(b') >= b on (feasibility is monotone, so then
for all later ends too), which keeps PELT exact. A tiny margin (1e-12 of the
total sum of squares) keeps roundoff from pruning an optimal start.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .dense import cholesky

__all__ = [
    "FEASIBILITY_TOL",
    "PRUNE_MARGIN",
    "ScaledData",
    "scale_data",
    "feasible_starts",
    "dynamic_program",
    "one_change",
    "split_costs",
    "pelt",
    "backtrack_layers",
    "backtrack_last",
    "add_row",
    "add_step",
]

FEASIBILITY_TOL = 1e-10  # τ = FEASIBILITY_TOL · N on the unit-RMS-scaled Gram matrix
PRUNE_MARGIN = 1e-12  # relative to the total sum of squares of the scaled outputs


@dataclass(frozen=True)
class ScaledData:
    """The regression data scaled for the solvers (costs scale by ``y_scale``²).

    Attributes
    ----------
    data : ndarray, shape (N, q, p + n)
        Rows [φ̃_tjᵀ ỹ_tjᵀ] (q per time step: trajectories; missing rows are
        zero), C-contiguous: φ columns divided by their RMS, y by the RMS of
        all its entries (one scalar, so the cost is only rescaled).
    p : int
        Number of regressors.
    y_scale : float
        The RMS of y; a cost in original units is ``y_scale**2`` times the
        scaled cost.
    """

    data: np.ndarray
    p: int
    y_scale: float


def scale_data(y: np.ndarray, phi: np.ndarray, n_observed: int | None = None) -> ScaledData:
    """Scale φ per column and y by one scalar (see :class:`ScaledData`).

    y (N, q, n) and φ (N, q, p) (2-d: q = 1); the root mean squares are over
    the ``n_observed`` observed rows (default all). Columns of φ that are
    identically zero are left as they are (every segment is then infeasible).
    """
    if y.ndim == 2:
        y, phi = y[:, None], phi[:, None]
    rows = y.shape[0] * y.shape[1] if n_observed is None else max(n_observed, 1)
    col = np.sqrt(np.sum(phi**2, axis=(0, 1)) / rows)
    col[col == 0] = 1.0
    y_scale = float(np.sqrt(np.sum(y**2) / (rows * y.shape[2])))
    if y_scale == 0 or not np.isfinite(y_scale):
        y_scale = 1.0
    data = np.ascontiguousarray(np.concatenate([phi / col, y / y_scale], axis=2))
    return ScaledData(data=data, p=phi.shape[2], y_scale=y_scale)


@numba.njit(cache=True)
def _add_row(W, v, p, q):  # pragma: no cover - compiled
    """Rotate the row v (length q = p + n, overwritten) into W = [R Z] (p × q).

    Returns the squared norm of what is left of the row's y part: the increase
    of the residual sum of squares.
    """
    for j in range(p):
        vj = v[j]
        if vj == 0.0:
            continue
        wjj = W[j, j]
        r = np.sqrt(wjj * wjj + vj * vj)
        c = wjj / r
        s = vj / r
        W[j, j] = r
        for k in range(j + 1, q):
            wk = W[j, k]
            vk = v[k]
            W[j, k] = c * wk + s * vk
            v[k] = c * vk - s * wk
    inc = 0.0
    for k in range(p, q):
        inc += v[k] * v[k]
    return inc


@numba.njit(cache=True)
def _add_step(W, v, data, t, p, q):  # pragma: no cover - compiled
    """Rotate the rows of time step t (data[t], one per trajectory) into W; the RSS increase."""
    inc = 0.0
    for r in range(data.shape[1]):
        for j in range(q):
            v[j] = data[t, r, j]
        inc += _add_row(W, v, p, q)
    return inc


# The Givens kernels, for the other searches built on the same sequential QR
# (:mod:`ltvmodels.core.partial_change`).
add_row = _add_row
add_step = _add_step


@numba.njit(cache=True)
def feasible_starts(data, p, min_size, tau):  # pragma: no cover - compiled
    """a_max[b]: the largest start a with [a, b) feasible, −1 when there is none.

    Parameters
    ----------
    data : ndarray, shape (N, q, p + n)
        Scaled rows [φ̃ ỹ].
    p, min_size : int
    tau : float
        Threshold on the smallest eigenvalue of the scaled Gram matrix.

    Returns
    -------
    ndarray of int64, shape (N + 1,), nondecreasing.
    """
    N = data.shape[0]
    a_max = np.full(N + 1, -1, dtype=np.int64)
    G = np.zeros((p, p))
    L = np.zeros((p, p))
    index = np.arange(p)
    lo = 0  # G = Σ_{t=lo}^{b-1} φ̃_t φ̃_tᵀ; cur = lo − 1 is the current a_max
    for b in range(N + 1):
        if b > 0:
            for i in range(p):
                for j in range(p):
                    for r in range(data.shape[1]):
                        G[i, j] += data[b - 1, r, i] * data[b - 1, r, j]
        while b - lo >= min_size and cholesky(G, index, tau, L):
            for i in range(p):
                for j in range(p):
                    for r in range(data.shape[1]):
                        G[i, j] -= data[lo, r, i] * data[lo, r, j]
            lo += 1
        a_max[b] = lo - 1
    return a_max


@numba.njit(cache=True)
def _first_feasible_ends(a_max):  # pragma: no cover - compiled
    """first_end[s] = min{b : a_max[b] >= s} (len(a_max) when none): [s, b) feasible iff b >= it."""
    n1 = a_max.shape[0]
    out = np.full(n1, n1, dtype=np.int64)
    b = 0
    for s in range(n1):
        while b < n1 and a_max[b] < s:
            b += 1
        out[s] = b
    return out


@numba.njit(cache=True)
def _segment_costs_ending_at(data, p, b, lowest, costs, W, v):  # pragma: no cover - compiled
    """costs[a] = C(a, b) for a = b−1 down to ``lowest`` (one sequential-QR pass)."""
    q = data.shape[2]
    for i in range(p):
        for j in range(q):
            W[i, j] = 0.0
    rss = 0.0
    for a in range(b - 1, lowest - 1, -1):
        rss += _add_step(W, v, data, a, p, q)
        costs[a] = rss


@numba.njit(cache=True)
def dynamic_program(data, p, n_changes, min_size, a_max):  # pragma: no cover - compiled
    """Optimal segmentations with 0 … M changes (segment neighbourhood, Bellman).

    Parameters
    ----------
    data : ndarray, shape (N, q, p + n)
    p, n_changes, min_size : int
    a_max : ndarray of int64, shape (N + 1,)
        From :func:`feasible_starts`.

    Returns
    -------
    best : ndarray, shape (M + 1,)
        best[m]: the smallest total cost with exactly m changes (inf if none is
        feasible).
    starts : ndarray of int64, shape (M + 1, N + 1)
        starts[m, b]: the start of the last segment of the optimal
        segmentation of [0, b) with m changes (−1 if none).
    """
    N = data.shape[0]
    q = data.shape[2]
    M = n_changes
    F = np.full((M + 1, N + 1), np.inf)
    starts = np.full((M + 1, N + 1), -1, dtype=np.int64)
    costs = np.empty(N + 1)
    W = np.zeros((p, q))
    v = np.empty(q)
    for b in range(min_size, N + 1):
        amax = a_max[b]
        if amax < 0:
            continue
        _segment_costs_ending_at(data, p, b, 0, costs, W, v)
        F[0, b] = costs[0]
        starts[0, b] = 0
        # layer M is needed at b = N only; m changes need (m + 1) · min_size samples
        last_layer = M if b == N else min(M - 1, (b // min_size) - 1)
        for m in range(1, last_layer + 1):
            best = np.inf
            arg = -1
            prev = F[m - 1]
            for a in range(m * min_size, amax + 1):
                val = prev[a] + costs[a]
                if val < best:
                    best = val
                    arg = a
            F[m, b] = best
            starts[m, b] = arg
    return F[:, N].copy(), starts


@numba.njit(cache=True)
def split_costs(data, p):  # pragma: no cover - compiled
    """The costs of both sides of every split of the data, in O(N).

    C(0, b) for every b comes from rotating rows 0, 1, … in turn, C(b, N)
    from rows N−1, N−2, … (sequential QR, see the module docstring).

    Parameters
    ----------
    data : ndarray, shape (N, q, p + n)
        Scaled rows [φ̃ ỹ] (any contiguous range of rows of a series).
    p : int

    Returns
    -------
    head, tail : ndarray, shape (N + 1,)
        head[b] = C(0, b) and tail[b] = C(b, N) (scaled units; meaningful
        where the segment is feasible).
    """
    N = data.shape[0]
    q = data.shape[2]
    W = np.zeros((p, q))
    v = np.empty(q)
    head = np.empty(N + 1)
    head[0] = 0.0
    rss = 0.0
    for b in range(1, N + 1):
        rss += _add_step(W, v, data, b - 1, p, q)
        head[b] = rss
    tail = np.empty(N + 1)
    tail[N] = 0.0
    _segment_costs_ending_at(data, p, N, 0, tail, W, v)
    return head, tail


@numba.njit(cache=True)
def one_change(data, p, a_max):  # pragma: no cover - compiled
    """The dynamic program for M = 1 in O(N): one forward and one backward pass.

    The best split minimizes C(0, b) + C(b, N) (:func:`split_costs`) over the
    b with both segments feasible. Returns the same as :func:`dynamic_program`.
    """
    N = data.shape[0]
    head, tail = split_costs(data, p)
    best = np.full(2, np.inf)
    starts = np.full((2, N + 1), -1, dtype=np.int64)
    best[0] = head[N]
    starts[0, N] = 0
    for b in range(1, a_max[N] + 1):  # [b, N) feasible
        if a_max[b] < 0:  # [0, b) infeasible
            continue
        val = head[b] + tail[b]
        if val < best[1]:
            best[1] = val
            starts[1, N] = b
    return best, starts


@numba.njit(cache=True)
def pelt(data, p, beta, min_size, a_max, margin):  # pragma: no cover - compiled
    """Minimize Σ C + β · #changes exactly by PELT (see the module docstring).

    Returns
    -------
    last : ndarray of int64, shape (N + 1,)
        last[b]: start of the last segment of the optimal segmentation of [0, b).
    objective : float
        F(N) = optimal cost + β · #changes (scaled units).
    n_evaluations : int
        Rows rotated in (the work done).
    """
    N = data.shape[0]
    q = data.shape[2]
    first_end = _first_feasible_ends(a_max)
    F = np.full(N + 1, np.inf)
    F[0] = -beta
    last = np.full(N + 1, -1, dtype=np.int64)
    kill = np.full(N + 1, np.iinfo(np.int64).max, dtype=np.int64)
    cand = np.empty(N + 1, dtype=np.int64)  # active starts, increasing
    cand[0] = 0
    ncand = 1
    cval = np.empty(N + 1)  # C(cand[i], b) for the current b
    W = np.zeros((p, q))
    v = np.empty(q)
    n_rows = 0
    for b in range(1, N + 1):
        # drop the candidates whose pruning applies from this end on
        k = 0
        for i in range(ncand):
            if kill[cand[i]] > b:
                cand[k] = cand[i]
                k += 1
        ncand = k
        amax = a_max[b]
        # the valid candidates are cand[0 .. nvalid-1] (those <= a_max(b))
        nvalid = 0
        while nvalid < ncand and cand[nvalid] <= amax:
            nvalid += 1
        if nvalid > 0:
            for i in range(p):
                for j in range(q):
                    W[i, j] = 0.0
            rss = 0.0
            i = nvalid - 1
            lowest = cand[0]
            for a in range(b - 1, lowest - 1, -1):
                rss += _add_step(W, v, data, a, p, q)
                if a == cand[i]:
                    cval[i] = rss
                    i -= 1
            n_rows += b - lowest
            best = np.inf
            arg = -1
            for i in range(nvalid):
                val = F[cand[i]] + beta + cval[i]
                if val < best:
                    best = val
                    arg = cand[i]
            F[b] = best
            last[b] = arg
            bound = best + margin
            ends = first_end[b]
            for i in range(nvalid):
                a = cand[i]
                if F[a] + cval[i] > bound and ends < kill[a]:
                    kill[a] = ends
        if F[b] < np.inf and b < N:
            cand[ncand] = b
            ncand += 1
    return last, F[N], n_rows


def backtrack_layers(starts: np.ndarray, m: int) -> np.ndarray:
    """Change points of the optimal segmentation with m changes (from :func:`dynamic_program`)."""
    N = starts.shape[1] - 1
    out = []
    b = N
    for layer in range(m, 0, -1):
        a = int(starts[layer, b])
        out.append(a)
        b = a
    return np.array(out[::-1], dtype=np.int64)


def backtrack_last(last: np.ndarray) -> np.ndarray:
    """Change points from PELT's ``last`` array."""
    out = []
    b = last.shape[0] - 1
    while b > 0:
        a = int(last[b])
        if a > 0:
            out.append(a)
        b = a
    return np.array(out[::-1], dtype=np.int64)
