"""A dynamics prior learned from transitions: a Gaussian mixture of p(x_{t+1}, x_t, u_t).

The paper (Section IV) names where a prior comes from in practice: "an
estimated global model such as a Gaussian mixture model (GMM). A statistical
model of the joint density p(x_{t+1}, x_t, u_t) constructed from previously
collected tuples provides a dynamical model of the system through the
conditional pdf p(x_{t+1} | x_t, u_t)". :class:`GMMPrior` fits that mixture
(scikit-learn's ``GaussianMixture``, full covariances) to the transitions of
any number of recordings, and turns it, along a new recording, into a
:class:`~ltvmodels.Prior` on k_t = vec([A_t B_t (c_t)]) for :func:`ltvmodels.fit`.

The moments, with z = [ξ; y], ξ = [x_t; u_t] (d = n + m entries), y = x_{t+1}
and φ = [ξ; 1] (p = d + 1 entries):

* Component c (weight π_c, mean μ_c, covariance Σ_c) is a linear-Gaussian
  model y | ξ, c ~ N(Θ_c φ, S_c) with Θ_c = [W_c b_c],
  W_c = Σ_yξ Σ_ξξ⁻¹, b_c = μ_y − W_c μ_ξ, S_c = Σ_yy − W_c Σ_ξy. It is the
  least-squares fit to the component's N_c = π_c M of the M transitions
  (exactly so for one component); the covariance of that estimate,
  V_c = S̃_c ⊗ G_c⁻¹ with G_c = N_c E_c[φ φᵀ] and S̃_c = S_c N_c / (N_c − p),
  is the uncertainty of θ_c = vec(Θ_c) (row by row, as k_t). For one
  component, θ and V are :func:`ltvmodels.fit_lti`'s ``k`` and ``cov`` with
  ``constant=True``.
* Along a recording, step t's responsibilities ρ_tc = p(c | z_t) come from
  the observed entries of z_t (missing entries are marginalized; the
  trajectories' responsibilities are averaged with their weights; a step
  with nothing observed gets π). The prior on k_t is the exact moment match
  of the mixture Σ_c ρ_tc N(θ_c, V_c):

      mean_t = Σ_c ρ_tc θ_c,   cov_t = Σ_c ρ_tc (V_c + (θ_c − mean_t)(θ_c − mean_t)ᵀ).

  The responsibilities use the whole transition, x_{t+1} included, as in
  guided policy search (Levine & Abbeel 2014): two regimes that visit the
  same states are told apart by where they go.

A component is a global model; its Jacobians are those of the region it
covers, and V_c shrinks as 1/N_c however nonlinear the system is inside the
region. ``max_samples`` caps N_c in V_c (Levine & Abbeel normalize their
normal–inverse-Wishart prior to the strength of a few samples for the same
reason), so that the prior decides only the directions the recording itself
leaves open.
"""

from __future__ import annotations

import copy
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import linalg
from scipy.special import logsumexp

from ..errors import ConvergenceWarning, SingularProblemError, warn
from ..validation import arrays, options
from .priors import Prior
from .recordings import timed_recordings

__all__ = ["GMMPrior"]


def _gaussian_mixture() -> Any:
    """scikit-learn's GaussianMixture, or an ImportError that says how to install it."""
    try:
        from sklearn.mixture import GaussianMixture
    except ImportError as exc:  # pragma: no cover - exercised without scikit-learn only
        raise ImportError(
            "ltvmodels.GMMPrior needs scikit-learn: install ltvmodels[gmm] "
            "(pip install 'ltvmodels[gmm]')"
        ) from exc
    return GaussianMixture


def _joint_points(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """z_t = [x_t; u_t; x_{t+1}] of every transition, shape (R, T − 1, 2n + m)."""
    return np.concatenate([x[:, :-1], u[:, :-1], x[:, 1:]], axis=2)


def _transitions(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The complete transitions z_t of validated recordings (nothing missing), (M, 2n + m)."""
    points = _joint_points(x, u)
    flat = points.reshape(-1, points.shape[2])
    return flat[~np.isnan(flat).any(axis=1)]


class GMMPrior:
    """A Gaussian mixture of the transitions (x_{t+1}, x_t, u_t), conditioned into priors.

    See the module docstring for the model and the moments; :meth:`at` gives
    the :class:`~ltvmodels.Prior` along a recording and :meth:`update` adds
    transitions.

    Parameters
    ----------
    x : array_like, shape (T, n), (R, T, n) or a list of R (T, n) arrays
        States of the recordings to learn from, time on axis 0; NaN marks a
        missing sample (pad shorter trajectories with NaN rows). Only
        transitions with x_t, u_t and x_{t+1} all observed are used.
    u : array_like, shape (T, m), (R, T, m), or None
        Inputs (None: an autonomous system, m = 0).
    n_components : int, optional
        Number of mixture components; default: the one of 1 …
        ``max_components`` with the smallest BIC (at most one per 2n + m + 1
        transitions).
    max_components : int
        Largest count tried by the BIC selection.
    reg_covar : float
        Added to the diagonal of every component covariance, in coordinates
        where each entry of z has unit variance over the data (so that a
        constant input leaves its coefficients to a broad prior instead of
        failing); 0 gives the exact maximum-likelihood moments.
    max_iter : int
        EM iterations per mixture fit (a ``ConvergenceWarning`` if reached).
    seed : int, numpy.random.Generator or None
        Seeds the k-means initializations; the same seed and the same calls
        give the same mixtures.
    regular : bool, default True
        As for :func:`ltvmodels.fit`: whether the time index of pandas data
        must lie on a regular grid (missing stamps become missing samples), or
        (False) the rows are consecutive samples. It holds for the recordings
        given to the mixture's methods too, so that :meth:`at` sees the grid a
        fit with the same ``regular`` uses.

    Attributes
    ----------
    mixture : sklearn.mixture.GaussianMixture
        The fitted mixture, in the standardized coordinates.
    n_components, n_states, n_inputs, n_transitions : int
    bic : float
        The mixture's BIC on the transitions it was fitted to (standardized
        coordinates).
    weights : ndarray, shape (C,)
        π_c.
    means, covariances : ndarrays, shapes (C, 2n + m), (C, 2n + m, 2n + m)
        μ_c and Σ_c of z = [x_t; u_t; x_{t+1}], in the units of the data.
    A, B, c, noise_cov : ndarrays, shapes (C, n, n), (C, n, m), (C, n), (C, n, n)
        Each component's conditional model x_{t+1} = A x_t + B u_t + c + v,
        v ~ N(0, noise_cov) (the maximum-likelihood S_c).

    Raises
    ------
    ImportError
        Without scikit-learn (``pip install 'ltvmodels[gmm]'``).

    Examples
    --------
    >>> prior = ltv.GMMPrior(x_earlier, u_earlier, seed=0)      # doctest: +SKIP
    >>> model = ltv.fit(x, u, lam=1.0, constant=True,
    ...                 prior=prior.at(x, u, constant=True))     # doctest: +SKIP
    """

    def __init__(
        self,
        x: ArrayLike,
        u: ArrayLike | None = None,
        *,
        n_components: int | None = None,
        max_components: int = 6,
        reg_covar: float = 1e-6,
        max_iter: int = 200,
        seed: int | np.random.Generator | None = 0,
        regular: bool = True,
    ) -> None:
        self.regular = options.flag(regular, "regular")
        x, u = _on_grid(x, u, self.regular)
        self.n_states, self.n_inputs = x.shape[2], u.shape[2]
        self._fixed_count = options.optional_integer(n_components, "n_components", 1)
        self._max_components = options.integer(max_components, "max_components", 1)
        self._reg_covar = options.nonnegative_scalar(reg_covar, "reg_covar")
        self._max_iter = options.integer(max_iter, "max_iter", 1)
        self._rng = options.random_generator(seed)
        points = _transitions(x, u)
        dz = points.shape[1]
        if points.shape[0] <= dz:
            raise ValueError(
                f"x: expected more than {dz} complete transitions (x_t, u_t, x_{{t+1}} all "
                f"observed) to fit a mixture of {dz}-dimensional transitions, received "
                f"{points.shape[0]}; record more data"
            )
        if self._fixed_count is not None and self._fixed_count > points.shape[0] // (dz + 1):
            raise ValueError(
                f"n_components: expected at most {points.shape[0] // (dz + 1)} (one component "
                f"per {dz + 1} complete transitions), received {self._fixed_count}; record "
                "more data or use fewer components"
            )
        # Standardized coordinates: k-means (the initialization) and reg_covar do not
        # depend on the units of the signals. Kept fixed by update(), so that the
        # previous mixture stays a valid warm start.
        self._center = points.mean(axis=0)
        spread = points.std(axis=0)
        self._scale = np.where(spread > 0, spread, 1.0)
        self._set_points(points)
        if self._fixed_count is not None:
            self.mixture = self._fit(self._fixed_count)
        else:
            counts = range(1, self._largest_count() + 1)
            self.mixture = min((self._fit(count) for count in counts), key=self._bic)
        self._set_components()

    # -- fitting ---------------------------------------------------------------------
    def _set_points(self, points: np.ndarray) -> None:
        """The pooled transitions and, once, their standardized coordinates (what EM and
        BIC see)."""
        self._points = points
        self._standardized = (points - self._center) / self._scale

    def _largest_count(self) -> int:
        """The BIC candidates' upper end: at most one component per 2n + m + 1 points."""
        dz = self._points.shape[1]
        return max(1, min(self._max_components, self._points.shape[0] // (dz + 1)))

    def _bic(self, mixture: Any) -> float:
        return float(mixture.bic(self._standardized))

    def _fit(self, count: int, warm: Any = None) -> Any:
        """EM on the standardized transitions: ``count`` components from a seeded k-means
        start, or continuing from the mixture ``warm`` (a copy; it is not modified)."""
        if warm is not None:
            mixture = copy.deepcopy(warm)
            mixture.set_params(warm_start=True)
        else:
            mixture = _gaussian_mixture()(
                n_components=count,
                covariance_type="full",
                reg_covar=self._reg_covar,
                max_iter=self._max_iter,
                random_state=int(self._rng.integers(2**31 - 1)),
            )
        with warnings.catch_warnings():
            # scikit-learn's own warning is replaced by ours below, with a remedy.
            warnings.simplefilter("ignore")
            try:
                mixture.fit(self._standardized)
            except ValueError as exc:  # a covariance that is not positive definite
                raise SingularProblemError(
                    f"GMMPrior: the mixture's covariances are singular ({exc}); some entries "
                    "of (x_t, u_t, x_{t+1}) are linear functions of the others: use "
                    "reg_covar > 0 or excite the system more"
                ) from None
        if not mixture.converged_:
            warn(
                f"GMMPrior: EM stopped at max_iter={self._max_iter} before converging "
                f"({count} components); raise max_iter",
                ConvergenceWarning,
            )
        return mixture

    def update(self, x: ArrayLike, u: ArrayLike | None = None) -> GMMPrior:
        """Add the transitions of new recordings and refit, starting from the current mixture.

        EM continues from the current components on all transitions so far (a
        warm start: a few iterations instead of a new fit). When the count was
        chosen by BIC, one more component (from a seeded k-means start) is
        tried too and kept if its BIC is lower: the mixture grows with the
        data.

        Parameters
        ----------
        x, u : array_like
            As for the constructor (the same n and m).

        Returns
        -------
        GMMPrior
            ``self``, updated.
        """
        x, u = self._recordings(x, u)
        new = _transitions(x, u)
        if new.shape[0] == 0:
            raise ValueError(
                "x: expected at least one complete transition (x_t, u_t, x_{t+1} all "
                "observed), received none; nothing to learn from"
            )
        self._set_points(np.concatenate([self._points, new]))
        count = self.n_components
        candidates = [self._fit(count, warm=self.mixture)]
        if self._fixed_count is None and count < self._largest_count():
            candidates.append(self._fit(count + 1))
        self.mixture = min(candidates, key=self._bic)
        self._set_components()
        return self

    def _set_components(self) -> None:
        """Each component's conditional model and the moments of its regressors."""
        n, d = self.n_states, self.n_states + self.n_inputs
        mean, cov = self.means, self.covariances
        C = mean.shape[0]
        theta = np.empty((C, n, d + 1))
        noise = np.empty((C, n, n))
        moment_inv = np.empty((C, d + 1, d + 1))
        for c in range(C):  # a handful of components: a loop over them, not over time
            mu_xi, mu_y = mean[c, :d], mean[c, d:]
            s_xx, s_xy, s_yy = cov[c, :d, :d], cov[c, :d, d:], cov[c, d:, d:]
            try:
                factor = linalg.cho_factor(s_xx) if d else None
            except linalg.LinAlgError:
                raise SingularProblemError(
                    f"GMMPrior: component {c}'s covariance of (x_t, u_t) is singular; use "
                    "reg_covar > 0 or excite the system more"
                ) from None
            W = linalg.cho_solve(factor, s_xy).T if d else np.zeros((n, 0))
            theta[c, :, :d] = W
            theta[c, :, d] = mu_y - W @ mu_xi
            S = s_yy - W @ s_xy
            noise[c] = 0.5 * (S + S.T)
            # E_c[φ φᵀ] with φ = [ξ; 1], inverted by its Cholesky factor (p × p, small).
            second = np.empty((d + 1, d + 1))
            second[:d, :d] = s_xx + np.outer(mu_xi, mu_xi)
            second[:d, d] = second[d, :d] = mu_xi
            second[d, d] = 1.0
            inv = linalg.cho_solve(linalg.cho_factor(second), np.eye(d + 1))
            moment_inv[c] = 0.5 * (inv + inv.T)
        self._theta = theta
        self._noise = noise
        self._moment_inv = moment_inv

    # -- what the mixture says ---------------------------------------------------------
    @property
    def n_components(self) -> int:
        return int(self.mixture.n_components)

    @property
    def n_transitions(self) -> int:
        return int(self._points.shape[0])

    @property
    def bic(self) -> float:
        return self._bic(self.mixture)

    @property
    def weights(self) -> np.ndarray:
        return self.mixture.weights_.copy()

    @property
    def means(self) -> np.ndarray:
        return self._center + self.mixture.means_ * self._scale

    @property
    def covariances(self) -> np.ndarray:
        return self.mixture.covariances_ * self._scale[:, None] * self._scale[None, :]

    @property
    def A(self) -> np.ndarray:
        return self._theta[:, :, : self.n_states].copy()

    @property
    def B(self) -> np.ndarray:
        n = self.n_states
        return self._theta[:, :, n : n + self.n_inputs].copy()

    @property
    def c(self) -> np.ndarray:
        return self._theta[:, :, -1].copy()

    @property
    def noise_cov(self) -> np.ndarray:
        return self._noise.copy()

    def __repr__(self) -> str:
        return (
            f"GMMPrior(n_components={self.n_components}, n_states={self.n_states}, "
            f"n_inputs={self.n_inputs}, n_transitions={self.n_transitions})"
        )

    def _recordings(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """Validated recordings with the mixture's numbers of states and inputs."""
        x, u = _on_grid(x, u, self.regular)
        if x.shape[2] != self.n_states:
            raise ValueError(
                f"x: expected {self.n_states} states (as the transitions the "
                f"mixture was fitted to), received {x.shape[2]}"
            )
        if u.shape[2] != self.n_inputs:
            raise ValueError(
                f"u: expected {self.n_inputs} inputs (as the transitions the "
                f"mixture was fitted to), received {u.shape[2]}"
            )
        return x, u

    def responsibilities(self, x: ArrayLike, u: ArrayLike | None = None) -> np.ndarray:
        """p(c | z_t) of every transition z_t = [x_t; u_t; x_{t+1}] of a recording.

        Missing entries of z_t are marginalized out; a transition with nothing
        observed gets the weights π.

        Parameters
        ----------
        x, u : array_like, shapes (T, n), (T, m) or (R, T, n), (R, T, m)
            A recording (NaN = missing).

        Returns
        -------
        ndarray, shape (T − 1, C), or (R, T − 1, C) for R trajectories
        """
        batch = arrays.is_batch(x)
        x, u = self._recordings(x, u)
        resp = self._responsibilities(_joint_points(x, u))
        return resp if batch else resp[0]

    def _responsibilities(self, points: np.ndarray) -> np.ndarray:
        """(R, N, C) responsibilities of (R, N, dz) points, NaN = missing."""
        R, N, dz = points.shape
        z = ((points - self._center) / self._scale).reshape(-1, dz)
        log_weights = np.log(self.mixture.weights_)
        log_post = np.broadcast_to(log_weights, (z.shape[0], log_weights.size)).copy()
        missing = np.isnan(z)
        # One marginal density per pattern of missing entries (few: complete rows, gaps).
        patterns, which = np.unique(missing, axis=0, return_inverse=True)
        which = which.reshape(-1)
        for k, pattern in enumerate(patterns):
            seen = ~pattern
            if not seen.any():
                continue
            rows = np.flatnonzero(which == k)
            zs = z[np.ix_(rows, seen)]
            for c in range(log_weights.size):
                cov = self.mixture.covariances_[c][np.ix_(seen, seen)]
                L = linalg.cholesky(cov, lower=True)
                r = linalg.solve_triangular(L, (zs - self.mixture.means_[c, seen]).T, lower=True)
                log_post[rows, c] += (
                    -0.5 * np.sum(r * r, axis=0)
                    - np.sum(np.log(np.diag(L)))
                    - 0.5 * seen.sum() * np.log(2.0 * np.pi)
                )
        log_post -= logsumexp(log_post, axis=1, keepdims=True)
        return np.exp(log_post).reshape(R, N, -1)

    def _component_moments(
        self, constant: bool, max_samples: float | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """θ_c (C, K) and V_c (C, K, K) on vec([A B c]) (or vec([A B]))."""
        n, p = self.n_states, self.n_states + self.n_inputs + 1
        counts = self.mixture.weights_ * self.n_transitions
        # The unbiased noise covariance of a least-squares fit on N_c points.
        unbiased = self._noise * (counts / np.maximum(counts - p, 1.0))[:, None, None]
        strength = counts if max_samples is None else np.minimum(counts, max_samples)
        gram_inv = self._moment_inv / strength[:, None, None]
        C = counts.size
        theta = self._theta.reshape(C, n * p)
        V = np.stack([np.kron(unbiased[c], gram_inv[c]) for c in range(C)])
        if not constant:  # drop c from every row of [A B c]
            keep = (np.arange(n)[:, None] * p + np.arange(p - 1)[None, :]).ravel()
            theta, V = theta[:, keep], V[:, keep][:, :, keep]
        return theta, V

    def at(
        self,
        x: ArrayLike,
        u: ArrayLike | None = None,
        *,
        constant: bool = False,
        weights: ArrayLike | None = None,
        max_samples: float | None = None,
    ) -> Prior:
        """The mixture's prior on k_t along a recording (see the module docstring).

        Parameters
        ----------
        x : array_like, shape (T, n), (R, T, n) or a list of R (T, n) arrays
            The recording the prior is for (the one given to :func:`ltvmodels.fit`);
            NaN marks a missing sample.
        u : array_like, shape (T, m) or (R, T, m), or None
            Its inputs.
        constant : bool
            True: the prior is on vec([A_t B_t c_t]), for ``fit(..., constant=True)``;
            False: on vec([A_t B_t]), the marginal of the components' affine
            models (their slopes; the intercepts are left out).
        weights : array_like, shape (T − 1,) or (R, T − 1), optional
            Weights >= 0 of the trajectories' transitions in the average of the
            responsibilities (e.g. the weights given to ``fit``).
        max_samples : float, optional
            Caps each component's count N_c in its covariance V_c: the prior
            counts as at most this many transitions per step (default: no cap,
            the components' own counts).

        Returns
        -------
        Prior
            Mean of shape (T − 1, K), covariance (T − 1, K, K), K = n (n + m + 1)
            with ``constant``, else n (n + m).
        """
        x, u = self._recordings(x, u)
        R, T, _ = x.shape
        constant = options.flag(constant, "constant")
        w = arrays.row_weights(weights, R, T - 1)
        if max_samples is not None:
            max_samples = options.positive_scalar(max_samples, "max_samples")
        points = _joint_points(x, u)
        resp = self._responsibilities(points)
        seen = (~np.isnan(points)).any(axis=2).astype(float)
        if w is not None:
            seen *= w
        total = seen.sum(axis=0)  # (N,)
        step = np.einsum("rt,rtc->tc", seen, resp)
        empty = total <= 0
        step[~empty] /= total[~empty, None]
        step[empty] = self.mixture.weights_
        theta, V = self._component_moments(constant, max_samples)
        mean = step @ theta
        cov = np.einsum("tc,ckl->tkl", step, V)
        for c in range(theta.shape[0]):  # + the spread of the components' means
            dev = theta[c] - mean
            cov += step[:, c, None, None] * dev[:, :, None] * dev[:, None, :]
        return Prior(mean, 0.5 * (cov + np.swapaxes(cov, 1, 2)))


def _on_grid(x: Any, u: Any, regular: bool) -> tuple[np.ndarray, np.ndarray]:
    """Validated recordings (R, T, ·), their rows on the regular grid of x's time index
    (the grid a fit of the same data uses; ``regular=False``: the rows as they are)."""
    x, u, grid = timed_recordings(x, u, regular)
    return (x, u) if grid is None else (grid.spread(x), grid.spread(u))
