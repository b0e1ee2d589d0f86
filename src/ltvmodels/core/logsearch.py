"""Maximize a criterion of λ over a range: a coarse log-spaced grid, then local refinement.

Choosing λ scores a fit (or one factorization) per candidate, so the number of
candidates is the cost. A fine grid over many decades spends most of them far
from the optimum. Instead :func:`maximize_on_log_scale` scores a coarse grid,
which is there to find every basin (criteria such as the marginal likelihood
can have several local maxima), and then refines each local maximum of the
grid by Brent's safeguarded parabolic search on log λ: the parabola through
the three best points so far predicts the maximum, which is scored next,
with a golden-section step where the parabola is not trusted. On a smooth
criterion this converges superlinearly (order about 1.3), so a few candidates
per basin reach the tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["LogSearch", "maximize_on_log_scale"]

GOLDEN = 0.381966011250105  # (3 − √5) / 2, the golden-section fraction
# The candidates a refinement typically takes (for the progress reported).
EXPECTED_REFINE = 4


@dataclass
class LogSearch:
    """The candidates a search scored and the best of them.

    Attributes
    ----------
    lams : ndarray, shape (G,)
        Every λ scored, increasing.
    values : ndarray, shape (G,)
        The criterion at ``lams`` (-inf where it was not available).
    best : float
        The λ with the largest value.
    n_evaluations : int
        Calls of the criterion (G).
    grid_values : ndarray, shape (len(grid),)
        The criterion at the grid the search started from.
    """

    lams: np.ndarray
    values: np.ndarray
    best: float
    n_evaluations: int
    grid_values: np.ndarray


def maximize_on_log_scale(
    criterion: Callable[[float], float],
    grid: np.ndarray,
    *,
    xatol: float,
    max_refine: int = 12,
    progress: Callable[[int, int], None] | None = None,
) -> LogSearch:
    """Maximize ``criterion(λ)``: score ``grid``, then refine each interior local maximum.

    Parameters
    ----------
    criterion : callable
        λ → value to maximize (a float; -inf where not available).
    grid : ndarray, shape (G,)
        The coarse candidates, positive and increasing (log-spaced, so that
        every basin of the criterion wider than the spacing holds a point).
    xatol : float
        Absolute tolerance on log λ of the refined maxima.
    max_refine : int
        Limit on the candidates scored per refined maximum.
    progress : callable, optional
        ``progress(done, total)`` after each candidate; until the search ends
        ``total`` counts the grid and a typical refinement (or one more than
        ``done``), then ``done``.

    Returns
    -------
    LogSearch
        A maximum at an end of the grid is refined within the last interval
        if the interval's midpoint is higher; otherwise the end is kept (the
        criterion may still rise beyond it: the grid should be wider).
    """
    scored: dict[float, tuple[float, float]] = {}  # log λ → (λ as evaluated, value)

    def evaluate(log_lam: float, lam: float | None = None) -> float:
        """The criterion at λ = exp(log_lam) (or at ``lam``, a grid value as given)."""
        lam = math.exp(log_lam) if lam is None else lam
        value = float(criterion(lam))
        value = value if value == value else -math.inf  # NaN: not available
        scored[log_lam] = (lam, value)
        if progress is not None:
            progress(
                len(scored), max(grid.size + min(max_refine, EXPECTED_REFINE), len(scored) + 1)
            )
        return value

    grid = np.asarray(grid, dtype=float)
    logs = np.log(grid)
    values = [evaluate(float(v), float(lam)) for v, lam in zip(logs, grid, strict=True)]
    for i in range(1, len(logs) - 1):
        if values[i] > -math.inf and values[i] >= values[i - 1] and values[i] >= values[i + 1]:
            _refine(
                evaluate,
                (logs[i - 1], logs[i], logs[i + 1]),
                (values[i - 1], values[i], values[i + 1]),
                xatol,
                max_refine,
                _cubic_maximum(logs, np.array(values), i),
            )
    for end, neighbour in ((0, 1), (len(logs) - 1, len(logs) - 2)):
        # A maximum at an end of the grid may still lie inside the last interval: the
        # midpoint decides, and if it is higher, it brackets a maximum to refine.
        if len(logs) < 2 or max_refine == 0 or not values[end] >= values[neighbour] > -math.inf:
            continue
        middle = 0.5 * (logs[end] + logs[neighbour])
        value = evaluate(middle)
        if value > values[end]:
            low, high = sorted((end, neighbour))
            _refine(
                evaluate,
                (logs[low], middle, logs[high]),
                (values[low], value, values[high]),
                xatol,
                max_refine - 1,
            )
    lams, out = (np.array(column) for column in zip(*(scored[v] for v in sorted(scored))))
    if progress is not None:
        progress(len(scored), len(scored))
    return LogSearch(
        lams=lams,
        values=out,
        best=float(lams[np.argmax(out)]),
        n_evaluations=len(scored),
        grid_values=np.array(values),
    )


def _cubic_maximum(logs: np.ndarray, values: np.ndarray, i: int) -> float | None:
    """The maximum in [logs[i-1], logs[i+1]] of the cubic through four grid points
    around i (a better first step than the parabola: it sees the bracket's skew), or
    None where there are not four finite values.

    In closed form: the cubic in Newton's divided-difference form, centred at
    logs[i], and the largest of its values at the interval's ends and at the roots
    of its derivative inside (four points: Python floats beat numpy's per-call cost).
    """
    start = i - 2 if i + 2 >= len(logs) or (i >= 2 and values[i - 1] > values[i + 1]) else i - 1
    if start < 0 or start + 4 > len(logs) or not np.all(np.isfinite(values[start : start + 4])):
        return None
    centre = float(logs[i])
    x = [float(v) - centre for v in logs[start : start + 4]]  # centred: well conditioned
    f = [float(v) for v in values[start : start + 4]]
    # divided differences: p(s) = f0 + d1 (s − x0) + d2 (s − x0)(s − x1) + d3 (…)(s − x2)
    d1 = [(f[k + 1] - f[k]) / (x[k + 1] - x[k]) for k in range(3)]
    d2 = [(d1[k + 1] - d1[k]) / (x[k + 2] - x[k]) for k in range(2)]
    d3 = (d2[1] - d2[0]) / (x[3] - x[0])
    # the same cubic as a s³ + b s² + c s + e
    a = d3
    b = d2[0] - d3 * (x[0] + x[1] + x[2])
    c = d1[0] - d2[0] * (x[0] + x[1]) + d3 * (x[0] * x[1] + x[0] * x[2] + x[1] * x[2])

    def cubic(s: float) -> float:
        return ((a * s + b) * s + c) * s

    low, high = float(logs[i - 1]) - centre, float(logs[i + 1]) - centre
    candidates = [low, high]
    if a != 0.0:  # p'(s) = 3a s² + 2b s + c
        discriminant = b * b - 3.0 * a * c
        if discriminant >= 0.0:
            root = math.sqrt(discriminant)
            candidates += [(-b + root) / (3.0 * a), (-b - root) / (3.0 * a)]
    elif b != 0.0:
        candidates.append(-c / (2.0 * b))
    inside = [s for s in candidates if low <= s <= high]
    best = centre + max(inside, key=cubic)
    return min(max(best, float(logs[i - 1])), float(logs[i + 1]))  # rounding of the centring


def _refine(
    evaluate: Callable[[float], float],
    points: tuple,
    values: tuple,
    xatol: float,
    max_refine: int,
    first: float | None = None,
) -> None:
    """Brent's parabolic search for the maximum in the bracket a < b < c, f(b) ≥ f(a), f(c).

    Each step fits the parabola through the three best points so far (not
    the bracket's ends, which may stay far away and make the parabola a poor
    model); it is taken if it falls inside the bracket (the nearest scored
    points around the best) and is less than half the step before the last,
    otherwise a golden-section step into the larger side is. The first step
    is ``first`` if given. Stops when the parabola puts the maximum within
    ``xatol`` of the best point (the parabola's own error adds to that: on
    the likelihood of short series up to another 1e-3 at ``xatol`` = 1e-3).
    """
    xs, fs = list(points), list(values)
    steps = [math.inf, math.inf]  # the last two steps' lengths
    for _ in range(max_refine):
        order = np.argsort(-np.asarray(fs), kind="stable")  # the first of equal values first
        best = int(order[0])
        if best in (0, len(xs) - 1):  # level with a bracket end: nothing to refine
            return
        a, b, c = xs[best - 1], xs[best], xs[best + 1]
        if c - a <= 2.0 * xatol:
            return
        vertex: float | None
        if first is not None:
            vertex, first = first, None
        else:
            three = sorted(order[:3])
            vertex = _parabola_vertex(*(xs[k] for k in three), *(fs[k] for k in three))
        if (
            vertex is None
            or not a + xatol <= vertex <= c - xatol
            or abs(vertex - b) > 0.5 * steps[-2]
        ):
            u = b + GOLDEN * (c - b) if c - b > b - a else b - GOLDEN * (b - a)
        else:
            u = vertex
            if abs(u - b) < xatol:  # the predicted maximum is b, to the tolerance
                return
        steps = [steps[-1], abs(u - b)]
        fu = evaluate(u)
        position = int(np.searchsorted(xs, u))
        xs.insert(position, u)
        fs.insert(position, fu)


def _parabola_vertex(a: float, b: float, c: float, fa: float, fb: float, fc: float) -> float | None:
    """The abscissa of the maximum of the parabola through three points a < b < c, or
    None if it has none."""
    if not (math.isfinite(fa) and math.isfinite(fc)):
        return None
    p = (b - a) ** 2 * (fb - fc) - (b - c) ** 2 * (fb - fa)
    q = (b - a) * (fb - fc) - (b - c) * (fb - fa)
    # q = −f[a, b, c]·(b − a)(c − b)(c − a) with f[a, b, c] the second divided
    # difference: q > 0 for a concave parabola (one with a maximum)
    if not q > 0.0:
        return None
    return b - 0.5 * p / q
