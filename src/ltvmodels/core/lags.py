"""The lagged regression of (V)ARX models: which past samples φ_t holds.

    y[t] = Σ_{i=1}^{na} A_{t,i} y[t−i] + Σ_{j=1}^{nb} B_{t,j} u[t−nk−j+1] + c_t + e[t]

is the regression y_t = Θ_t φ_t + e_t with

    φ_t = [y[t−1]; …; y[t−na]; u[t−nk]; …; u[t−nk−nb+1]; 1],

starting at the first sample whose lags all exist, t = L = max(na, nk + nb − 1).
"""

from __future__ import annotations

import numpy as np

__all__ = ["lag_length", "lagged_regressors", "lag_regressor_names"]


def lag_length(na: int, nb: int, nk: int) -> int:
    """L: how far the regressors reach back (the first regression row is y[L])."""
    return max(na, nk + nb - 1 if nb else 0)


def lagged_regressors(
    y: np.ndarray, u: np.ndarray, na: int, nb: int, nk: int, constant: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(y[L:], φ) for validated y (…, T, n), u (…, T, m); φ has the column order of the module.

    Time is the second-to-last axis, so R trajectories (R, T, ·) give (R, N, ·).
    A NaN in y or u makes NaN every row of φ that holds it as a lag.
    """
    T = y.shape[-2]
    L = lag_length(na, nb, nk)
    N = T - L
    lead = y.shape[:-2]
    cols = [y[..., L - i : T - i, :] for i in range(1, na + 1)]
    cols += [u[..., L - nk - j : T - nk - j, :] for j in range(nb)]
    if constant:
        cols.append(np.ones(lead + (N, 1)))
    phi = np.concatenate(cols, axis=-1) if cols else np.zeros(lead + (N, 0))
    return y[..., L:, :].copy(), np.ascontiguousarray(phi)


def lag_regressor_names(
    n: int,
    m: int,
    na: int,
    nb: int,
    nk: int,
    constant: bool,
    *,
    output_names: list[str] | None = None,
    input_names: list[str] | None = None,
) -> list[str]:
    """Names of the regressors of :func:`lagged_regressors`, in their order:
    y[t-1] (y0[t-1], y1[t-1], … for several outputs), …, u[t-nk], …, 1 — with the
    signals' own names when given."""
    ys = output_names or (["y"] if n == 1 else [f"y{i}" for i in range(n)])
    us = input_names or (["u"] if m == 1 else [f"u{i}" for i in range(m)])
    names = [f"{y}[t-{lag}]" for lag in range(1, na + 1) for y in ys]
    names += [f"{u}[t-{nk + j}]" if nk + j else f"{u}[t]" for j in range(nb) for u in us]
    return names + (["1"] if constant else [])
