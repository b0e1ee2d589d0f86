"""Gaussian priors on the coefficients or on the output (paper Section IV).

A prior is a second, independent measurement (the paper's Kalman correction step):

* :class:`Prior` — k_t ~ N(μ_t, Σ_t): the term Σ_t ‖μ_t − k_t‖²_{Σ_t⁻¹} of
  the paper's maximum a posteriori problem;
* :class:`OutputPrior` — x_{t+1} = A_t x_t + B_t u_t ~ N(ȳ_t, S_t): a belief
  about the model's one-step output, entering as an extra measurement update.

With ``prior_mode="exact"`` both enter the normal equations, weighted against
the data by the noise variance σ², and the MAP estimate of that problem is
obtained exactly. ``prior_mode="posthoc"`` applies the paper's repeated
correction to the smoothed estimates instead (kept for comparison; it is not
the MAP estimate).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..core.priorterms import PriorTerm, precision_matrix
from ..results.regression import RegressionModel
from ..validation import arrays

__all__ = ["Prior", "OutputPrior", "resolve"]


class Prior:
    """Gaussian prior on the parameter vectors k_t = vec([A_tᵀ B_tᵀ]).

    Parameters
    ----------
    mean : array_like, shape (N, K) or (K,), or LTVModel
        Prior mean μ_t; a (K,) vector applies to every time step; a fitted
        :class:`~ltvmodels.LTVModel` (or any fitted model, e.g. from
        :func:`ltvmodels.fit_regression` or :func:`ltvmodels.fit_ar`) contributes
        its coefficients ``k``.
    cov : float or array_like, shape (K, K) or (N, K, K)
        Prior covariance Σ_t (a scalar means σ_0² I). Must be positive definite.

    Notes
    -----
    Shapes are checked against the data when the prior is used by
    :func:`ltvmodels.fit`. K = n·(n + m) and k_t is ``np.hstack([A_t, B_t]).ravel()``.
    """

    def __init__(self, mean: ArrayLike | RegressionModel, cov: float | ArrayLike) -> None:
        if hasattr(mean, "k") and hasattr(mean, "theta"):
            mean = mean.k
        self.mean = arrays.as_float_array(mean, "mean")
        if self.mean.ndim not in (1, 2):
            raise ValueError(
                f"mean: expected shape (K,) or (N, K), received shape {self.mean.shape}"
            )
        arrays.representable(self.mean, "mean", small=False)
        self.cov = arrays.as_float_array(cov, "cov")
        if self.cov.ndim not in (0, 2, 3):
            raise ValueError(
                f"cov: expected a scalar, (K, K) or (N, K, K), received shape {self.cov.shape}"
            )

    def __repr__(self) -> str:
        return f"Prior(mean shape={self.mean.shape}, cov shape={self.cov.shape})"


class OutputPrior:
    """Gaussian prior on the model output y_t = A_t x_t + B_t u_t (≈ x_{t+1}).

    Parameters
    ----------
    mean : array_like, shape (N, n) or (n,)
        Prior mean ȳ_t of the one-step output.
    cov : float or array_like, shape (n, n) or (N, n, n)
        Its covariance S_t, positive definite.
    """

    def __init__(self, mean: ArrayLike, cov: float | ArrayLike) -> None:
        self.mean = arrays.as_float_array(mean, "mean")
        if self.mean.ndim not in (1, 2):
            raise ValueError(
                f"mean: expected shape (n,) or (N, n), received shape {self.mean.shape}"
            )
        arrays.representable(self.mean, "mean", small=False)
        self.cov = arrays.as_float_array(cov, "cov")
        if self.cov.ndim not in (0, 2, 3):
            raise ValueError(
                f"cov: expected a scalar, (n, n) or (N, n, n), received shape {self.cov.shape}"
            )

    def __repr__(self) -> str:
        return f"OutputPrior(mean shape={self.mean.shape}, cov shape={self.cov.shape})"


def resolve(priors: Any, N: int, n: int, p: int) -> list[PriorTerm]:
    """Validate ``prior=`` of :func:`ltvmodels.fit` against the data sizes."""
    if priors is None:
        return []
    items = list(priors) if isinstance(priors, (list, tuple)) else [priors]
    terms = []
    K = n * p
    for item in items:
        if isinstance(item, Prior):
            on, d = "parameters", K
        elif isinstance(item, OutputPrior):
            on, d = "output", n
        else:
            raise TypeError(
                "prior: expected an ltvmodels.Prior, an ltvmodels.OutputPrior or a list of "
                f"them, received {type(item).__name__}"
            )
        label = "prior.mean" if on == "parameters" else "output prior mean"
        mean = arrays.mean_sequence(item.mean, label, N, d)
        cov = arrays.covariance(item.cov, label.replace("mean", "cov"), N, d)
        prec = precision_matrix(cov)
        if prec.ndim == 0:
            prec = np.eye(d) * float(prec)
        terms.append(PriorTerm(on=on, precision=prec, mean=mean))
    return terms
