"""Confidence intervals of break dates (Bai 1997), as R's strucchange computes them.

Around a break between a segment with coefficients β₁ and one with β₂, the
estimated break date, in units of (δᵀQ₁δ / σ₁²)⁻¹ with δ = β₂ − β₁, converges
to the argmax of a two-sided Brownian motion with drift,

    V(s) = W₁(−s) − |s|/2                       for s ≤ 0,
    V(s) = √ξ (φ₂/φ₁) W₂(s) − ξ |s|/2           for s > 0,

where ξ = δᵀQ₂δ / δᵀQ₁δ compares the regressors' second moments Q on the two
sides and φᵢ the noise standard deviations (Bai 1997, "Estimation of a change
point in multiple regression models", Proposition 3). :func:`argmax_cdf` is
the closed-form distribution function of that argmax (strucchange's
``pargmaxV``); :func:`break_interval` inverts it at (1 ± level)/2 and scales
the quantiles back to observations, as strucchange's
``confint.breakpointsfull`` does with its defaults (the Q and σ² of each
segment: ``het.reg = TRUE, het.err = TRUE``), or with the whole sample's.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.special import log_ndtr

__all__ = ["argmax_cdf", "break_interval", "segment_moments", "information_criteria"]

# The search for a bracket of the quantiles widens by this many units at a time,
# at most this many times (strucchange widens by 1000 without a bound).
BRACKET_STEP = 1000.0
MAX_BRACKET_STEPS = 10_000


def argmax_cdf(x: float, xi: float, phi1: float, phi2: float) -> float:
    """P(argmax V ≤ x) for the process V of the module docstring.

    Parameters
    ----------
    x : float
        The point, in the units of the limit (|δ|² Q₁ / σ₁² observations).
    xi : float
        ξ = δᵀQ₂δ / δᵀQ₁δ > 0.
    phi1, phi2 : float
        The noise standard deviations before and after the break, > 0.

    Returns
    -------
    float
        The probability, in [0, 1].
    """
    phi = xi * (phi2 / phi1) ** 2
    s = abs(x)
    with np.errstate(divide="ignore"):  # log(0) = −inf at x = 0: exp gives 0
        half_log_s = 0.5 * np.log(s)
    if x < 0:
        frac = xi / phi
        value = (
            -np.exp(half_log_s - s / 8 - 0.5 * np.log(2 * np.pi))
            - (phi / xi * (phi + 2 * xi) / (phi + xi))
            * np.exp(frac * (1 + frac) * s / 2 + log_ndtr(-(0.5 + frac) * np.sqrt(s)))
            + np.exp(
                np.log(s / 2 - 2 + (phi + 2 * xi) ** 2 / ((phi + xi) * xi))
                + log_ndtr(-np.sqrt(s) / 2)
            )
        )
        return float(value)
    frac = xi**2 / phi
    value = (
        1
        + np.sqrt(frac) * np.exp(half_log_s - frac * s / 8 - 0.5 * np.log(2 * np.pi))
        + (xi / phi * (2 * phi + xi) / (phi + xi))
        * np.exp((phi + xi) * s / 2 + log_ndtr(-(phi + xi / 2) / np.sqrt(phi) * np.sqrt(s)))
        - np.exp(
            np.log((2 * phi + xi) ** 2 / ((phi + xi) * phi) - 2 + frac * s / 2)
            + log_ndtr(-np.sqrt(frac) * np.sqrt(s) / 2)
        )
    )
    return float(value)


def break_interval(
    delta: np.ndarray,
    q_before: np.ndarray,
    q_after: np.ndarray,
    var_before: float,
    var_after: float,
    level: float,
) -> tuple[float, float] | None:
    """The offsets (lower, upper) of a break date's confidence interval, in observations.

    The interval of a break estimated at c is [c − ⌈upper⌉, c − ⌊lower⌋]
    (``lower`` < 0 < ``upper``: an interval reaching further back for a larger
    ``upper``), as strucchange writes it.

    Parameters
    ----------
    delta : ndarray, shape (p,)
        β₂ − β₁, the change of the coefficients at the break.
    q_before, q_after : ndarray, shape (p, p)
        The regressors' second moments (ΦᵀΦ / rows) before and after the break
        (the same matrix, the whole sample's, for homogeneous regressors).
    var_before, var_after : float
        The noise variances before and after (the same for homogeneous errors).
    level : float
        The coverage, in (0, 1).

    Returns
    -------
    (float, float) or None
        None where the interval cannot be computed: P(argmax V ≤ 0) is not
        within the interval's tails (strucchange's warning "cannot be computed").
    """
    tail = (1 - level) / 2
    q_prod_before = float(delta @ q_before @ delta)
    q_prod_after = float(delta @ q_after @ delta)
    xi = q_prod_after / q_prod_before
    phi1, phi2 = np.sqrt(var_before), np.sqrt(var_after)
    p0 = argmax_cdf(0.0, xi, phi1, phi2)
    if not np.isfinite(p0) or p0 < tail or p0 > 1 - tail:
        return None

    def quantile(target: float, direction: float) -> float:
        edge = 0.0
        for _ in range(MAX_BRACKET_STEPS):
            edge += direction * BRACKET_STEP
            if (argmax_cdf(edge, xi, phi1, phi2) - target) * direction >= 0:
                break
        else:  # pragma: no cover - the distribution function reaches 0 and 1
            raise ArithmeticError("the break date's distribution did not reach its quantile")
        ends = (0.0, edge) if direction > 0 else (edge, 0.0)
        return brentq(lambda s: argmax_cdf(s, xi, phi1, phi2) - target, *ends, xtol=1e-10)

    scale = var_before / q_prod_before  # φ₁² / δᵀQ₁δ: from the limit's units to rows
    return quantile(tail, -1.0) * scale, quantile(1 - tail, 1.0) * scale


def segment_moments(
    y: np.ndarray, phi: np.ndarray, observed: np.ndarray, changepoints: np.ndarray
) -> dict[str, np.ndarray]:
    """The least-squares fit of each segment and the moments a break's interval needs.

    Parameters
    ----------
    y : ndarray, shape (N, q, n)
        Outputs (rows scaled by √w), as a regression problem holds them.
    phi : ndarray, shape (N, q, p)
        Regressors, scaled alike.
    observed : ndarray of bool, shape (N, q)
        The rows that hold data.
    changepoints : ndarray of int, shape (M,)
        The first row of each new segment.

    Returns
    -------
    dict
        ``coefficients`` (M + 1, p, n), the segments' least-squares β;
        ``second_moments`` (M + 1, p, p), ΦᵀΦ / rows of each segment;
        ``variances`` (M + 1, n), RSS / rows of each segment (maximum
        likelihood, as strucchange); ``rows`` (M + 1,) observed rows; and the
        whole sample's ``pooled_second_moment`` (p, p) and ``pooled_variance``
        (n,) (the RSS of the segmented fit over all rows).
    """
    bounds = np.concatenate([[0], np.asarray(changepoints, dtype=int), [y.shape[0]]])
    coefficients, moments, variances, rows, rss = [], [], [], [], []
    for start, stop in zip(bounds[:-1], bounds[1:]):
        kept = observed[start:stop]
        outputs, regressors = y[start:stop][kept], phi[start:stop][kept]
        beta = np.linalg.lstsq(regressors, outputs, rcond=None)[0]
        residual = outputs - regressors @ beta
        count = outputs.shape[0]
        coefficients.append(beta)
        moments.append(regressors.T @ regressors / count)
        rss.append(np.sum(residual**2, axis=0))
        variances.append(rss[-1] / count)
        rows.append(count)
    rows_array = np.array(rows)
    moments_array = np.array(moments)
    total = rows_array.sum()
    return {
        "coefficients": np.array(coefficients),
        "second_moments": moments_array,
        "variances": np.array(variances),
        "rows": rows_array,
        "pooled_second_moment": np.tensordot(rows_array, moments_array, axes=1) / total,
        "pooled_variance": np.sum(rss, axis=0) / total,
    }


def information_criteria(
    costs: np.ndarray,
    rows: int,
    n_outputs: int,
    n_changing: int,
    n_fixed: int = 0,
    cost: str = "rss",
) -> dict[str, np.ndarray | int]:
    """Information criteria of the optimal segmentations with 0 … M changes.

    With the optimal cost C_m of each number of changes m (``costs``, from the
    dynamic program), over ``rows`` observed rows of n outputs, p_z changing
    and p_x fixed regressors per output:

    * ``cost="rss"`` (C_m a residual sum of squares, one noise variance for
      all segments and outputs): ℓ_m = −(r/2) (log(C_m / r) + 1 + log 2π),
      r = rows · n; BIC_m = −2ℓ_m + k_m log(rows) with
      k_m = n p_x + n p_z (m + 1) + m + 1 (the coefficients, the break dates
      and the variance: strucchange's count, Bai and Perron 2003); LWZ_m =
      log(C_m / (r − k*)) + k* · 0.299 (log r)^2.1 / r with k* = k_m − 1 (Liu,
      Wu and Zidek 1997); AIC_m = −2ℓ_m + 2 k_m.
    * ``cost="normal"`` (C_m = −2ℓ_m − r log 2π, a variance per segment and
      output): ℓ_m = −(C_m + r log 2π)/2, k_m = n p_x + (n p_z + n)(m + 1) + m;
      no LWZ (it assumes one variance).

    Parameters
    ----------
    costs : ndarray, shape (M + 1,)
        C_0 … C_M (inf where no segmentation has m changes).
    rows : int
        The observed rows.
    n_outputs, n_changing, n_fixed : int
        n, p_z and p_x.
    cost : {"rss", "normal"}

    Returns
    -------
    dict
        ``n_changes`` (0 … M), ``loglik``, ``bic``, ``aic`` (and ``lwz`` for
        "rss"), each (M + 1,), and ``best_bic``, ``best_aic`` (``best_lwz``):
        the m that minimizes each.
    """
    costs = np.asarray(costs, dtype=float)
    m = np.arange(costs.size)
    n, observations = n_outputs, rows * n_outputs
    with np.errstate(divide="ignore", invalid="ignore"):
        if cost == "normal":
            loglik = -0.5 * (costs + observations * np.log(2 * np.pi))
            params = n * n_fixed + (n * n_changing + n) * (m + 1) + m
        else:
            loglik = -0.5 * observations * (np.log(costs / observations) + 1 + np.log(2 * np.pi))
            params = n * n_fixed + n * n_changing * (m + 1) + m + 1
        table: dict[str, np.ndarray | int] = {
            "n_changes": m,
            "loglik": loglik,
            "bic": -2 * loglik + params * np.log(rows),
            "aic": -2 * loglik + 2 * params,
        }
        if cost != "normal":
            free = params - 1
            table["lwz"] = (
                np.log(costs / (observations - free))
                + free * 0.299 * np.log(observations) ** 2.1 / observations
            )
    for name in ("bic", "aic", "lwz"):
        if name in table:
            values = np.asarray(table[name])
            table[f"best_{name}"] = int(np.nanargmin(np.where(np.isfinite(values), values, np.nan)))
    return table
