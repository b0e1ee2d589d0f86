"""The one problem every estimator solves: time-varying linear regression.

    y_t = Θ_t φ_t + e_t,   t = 0 … N-1,   y_t ∈ R^n,  φ_t ∈ R^p,  Θ_t ∈ R^{n×p}

with a penalty on the time differences (DΘ)_t = Σ_j c_j Θ_{t+j} of the
coefficients, where c_0 … c_d are the coefficients of the difference
polynomial P(z) (paper Proposition 1): c = (-1, 1) is the first difference,
(1, -2, 1) the second. The parameter vector of the paper is
k_t = vec([A_tᵀ B_tᵀ]) = Θ_t.ravel() (rows of Θ_t concatenated), K = n·p.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .blockkernels import rowwise_matvec
from .robust_scale import MAD_TO_STD, column_center_spread

__all__ = [
    "RegressionProblem",
    "weighted_problem",
    "state_space_problem",
    "apply_difference",
    "activation",
    "row_norms",
    "apply_difference_adjoint",
    "gram_bands",
    "null_space_basis",
    "OutputSpread",
    "output_spread",
]


@dataclass(frozen=True, init=False)
class RegressionProblem:
    """Data of a time-varying regression with q rows per time step.

    The data term is Σ_t Σ_j ‖y_tj − Θ_t φ_tj‖²: row j of step t is one
    trajectory's sample (q = R time-aligned trajectories share Θ_t), already
    multiplied by the square root of its weight. A missing or zero-weight row
    is stored as zeros, so it adds nothing to any sum, and is marked False in
    ``observed`` (which only the counts — likelihood, degrees of freedom —
    read).

    Attributes
    ----------
    y : ndarray, shape (N, q, n)
        Outputs (for a state-space model, x[1:]). (N, n) is accepted (q = 1).
    phi : ndarray, shape (N, q, p)
        Regressors shared by all output rows (for a state-space model,
        [x[:-1], u[:-1]]). (N, p) is accepted (q = 1).
    coeffs : ndarray, shape (d + 1,)
        Difference-operator coefficients c_0 … c_d.
    observed : ndarray of bool, shape (N, q), optional
        Which rows hold data (default: all).
    row_scale : ndarray, shape (N, q), optional
        The √w each row was multiplied by (default: 1 where observed, 0
        elsewhere); losses other than the squared one need it (a threshold in
        the units of y is δ√w on a scaled row).
    rows_are_samples : bool, default True
        Whether each row is a recorded sample; False for pseudo-rows that only
        reproduce sums (the expected statistics of EM's M-step), whose residuals
        are no samples' (so they have no outliers).
    """

    y: np.ndarray
    phi: np.ndarray
    coeffs: np.ndarray
    observed: np.ndarray
    row_scale: np.ndarray
    rows_are_samples: bool
    # The count, kept: the likelihood, the checks and the reports each ask for it.
    _n_observed: int = field(init=False, repr=False, compare=False)

    def __init__(
        self,
        y: np.ndarray,
        phi: np.ndarray,
        coeffs: np.ndarray,
        observed: np.ndarray | None = None,
        row_scale: np.ndarray | None = None,
        rows_are_samples: bool = True,
    ) -> None:
        # C order for every kernel: compiled kernels specialize on the memory
        # layout, and a fit must not depend on how the caller's arrays were laid
        # out (pandas frames arrive in Fortran order).
        y = np.asarray(y, dtype=float)
        phi = np.asarray(phi, dtype=float)
        if y.ndim == 2:
            y, phi = y[:, None, :], phi[:, None, :]
        if observed is None:
            observed = np.ones(y.shape[:2], dtype=bool)
            n_observed = observed.size
        else:
            observed = np.asarray(observed, dtype=bool)
            n_observed = int(np.count_nonzero(observed))
        if n_observed < observed.size:  # an unobserved row must not add to any sum
            y = np.where(observed[:, :, None], y, 0.0)
            phi = np.where(observed[:, :, None], phi, 0.0)
        row_scale = (
            observed.astype(float)
            if row_scale is None
            else np.where(observed, np.asarray(row_scale, dtype=float), 0.0)
        )
        # frozen: the fields are set once, here
        object.__setattr__(self, "y", np.ascontiguousarray(y))
        object.__setattr__(self, "phi", np.ascontiguousarray(phi))
        object.__setattr__(self, "coeffs", coeffs)
        # C order: a Fortran-ordered mask (e.g. a transposed one) would compile the
        # kernels that read it once more
        object.__setattr__(self, "observed", np.ascontiguousarray(observed))
        object.__setattr__(self, "row_scale", row_scale)
        object.__setattr__(self, "rows_are_samples", bool(rows_are_samples))
        object.__setattr__(self, "_n_observed", n_observed)

    @property
    def N(self) -> int:
        return self.y.shape[0]

    @property
    def q(self) -> int:
        """Rows per time step (trajectories)."""
        return self.y.shape[1]

    @property
    def n(self) -> int:
        return self.y.shape[2]

    @property
    def p(self) -> int:
        return self.phi.shape[2]

    @property
    def K(self) -> int:
        return self.n * self.p

    @property
    def degree(self) -> int:
        return len(self.coeffs) - 1

    @property
    def n_observed(self) -> int:
        """Number of observed rows (each with n outputs)."""
        return self._n_observed

    @property
    def complete(self) -> bool:
        """One trajectory, every row observed: the paper's problem."""
        return self.q == 1 and self._n_observed == self.observed.size

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """y_tj − Θ_t φ_tj for Θ of shape (N, n, p); returns (N, q, n), 0 where unobserved."""
        fitted = np.empty_like(self.y)
        # writable: numba compiles a kernel once more for a read-only array (a result's)
        rowwise_matvec(np.require(theta, float, ("C", "W")), self.phi, fitted)
        return np.subtract(self.y, fitted, out=fitted)

    def output_rss(self, theta: np.ndarray, residuals: np.ndarray | None = None) -> np.ndarray:
        """Residual sum of squares per output, shape (n,); ``residuals`` (N, q, n):
        :meth:`residuals` of ``theta`` where the caller has them already."""
        resid = self.residuals(theta) if residuals is None else residuals
        return np.einsum("tji,tji->i", resid, resid)

    def gram(self, start: int = 0) -> np.ndarray:
        """Σ_j φ_tj φ_tjᵀ per step t >= ``start``, shape (N − start, p, p)."""
        phi = self.phi[start:]
        return np.einsum("tja,tjb->tab", phi, phi)

    def cross(self) -> np.ndarray:
        """Σ_j φ_tj y_tjᵀ per step, shape (N, p, n)."""
        if self.q == 1:
            return self.phi[:, 0, :, None] * self.y[:, 0, None, :]
        return np.einsum("tja,tji->tai", self.phi, self.y)

    def gradient(self, theta: np.ndarray) -> np.ndarray:
        """∇_k Σ‖y − Θφ‖² = −2 Σ_j r_tj φ_tjᵀ, shape (N, K)."""
        resid = self.residuals(theta)
        return -2.0 * np.einsum("tji,tja->tia", resid, self.phi).reshape(self.N, self.K)

    def stacked_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The observed rows stacked over time: φ (M, p) and y (M, n)."""
        mask = self.observed
        return self.phi[mask], self.y[mask]


def weighted_problem(
    y: np.ndarray, phi: np.ndarray, coeffs: np.ndarray, weights: np.ndarray | None = None
) -> RegressionProblem:
    """The problem of R trajectories: y (R, N, n), φ (R, N, p), NaN = missing.

    A row enters the data term only if all of y_t and φ_t are finite (and its
    weight is > 0); it is scaled by √w so its squared residual counts w times.
    """
    if weights is None and _all_finite(y) and _all_finite(phi):
        # every row observed: the problem needs no mask (nor a count of it)
        return RegressionProblem(y=np.swapaxes(y, 0, 1), phi=np.swapaxes(phi, 0, 1), coeffs=coeffs)
    observed = _finite_rows(y) & _finite_rows(phi)
    scale = None
    if weights is not None:
        observed &= weights > 0
        scale = np.sqrt(np.where(observed, weights, 0.0))
        y, phi = y * scale[:, :, None], phi * scale[:, :, None]
    return RegressionProblem(
        y=np.swapaxes(y, 0, 1),
        phi=np.swapaxes(phi, 0, 1),
        coeffs=coeffs,
        observed=observed.T,
        row_scale=None if scale is None else scale.T,
    )


def _all_finite(values: np.ndarray) -> bool:
    """Whether every entry is finite (not by a sum, which may warn of an overflow)."""
    return bool(np.isfinite(values).all())


def _finite_rows(values: np.ndarray) -> np.ndarray:
    """Rows (last axis) with only finite entries; one fast sum when all are."""
    if np.isfinite(values.sum()):  # an overflowing sum only falls through to the check
        return np.ones(values.shape[:-1], dtype=bool)
    return np.all(np.isfinite(values), axis=-1)


def state_space_problem(
    x: np.ndarray,
    u: np.ndarray,
    coeffs: np.ndarray,
    *,
    weights: np.ndarray | None = None,
    constant: bool = False,
) -> RegressionProblem:
    """Regression form of x[t+1] = A_t x[t] + B_t u[t] (+ c_t): y = x[1:], φ = [x, u, 1][:-1].

    x (T, n) or (R, T, n), u likewise; weights (R, T − 1) or None.
    """
    if x.ndim == 2:
        x, u = x[None], u[None]
    parts = [x[:, :-1], u[:, :-1]]
    if constant:
        parts.append(np.ones(x.shape[:2] + (1,))[:, :-1])
    return weighted_problem(x[:, 1:], np.concatenate(parts, axis=2), coeffs, weights)


def apply_difference(values: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    """(Dv)_t = Σ_j c_j v_{t+j} along axis 0; returns N − d rows."""
    d = len(coeffs) - 1
    N = values.shape[0]
    out = coeffs[0] * values[: N - d]
    for j in range(1, d + 1):
        out = out + coeffs[j] * values[j : N - d + j]
    return out


def activation(k: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    """a_t = ‖(Dk)_t‖₂ for t = 0 … N − d − 1 (paper Section III-G); k is (N, K)."""
    return row_norms(apply_difference(k, coeffs))


def row_norms(values: np.ndarray) -> np.ndarray:
    """‖v_t‖₂ of each row of ``values`` (N, K), also where the squares would overflow:
    entries beyond 1e150 are scaled by a power of two first (exactly; below that the
    plain norms, bit for bit)."""
    largest = float(np.abs(values).max(initial=0.0))
    if not (np.isfinite(largest) and largest > 1e150):
        return np.linalg.norm(values, axis=1)
    exponent = int(np.frexp(largest)[1])
    return np.ldexp(np.linalg.norm(np.ldexp(values, -exponent), axis=1), exponent)


def apply_difference_adjoint(values: np.ndarray, coeffs: np.ndarray, N: int) -> np.ndarray:
    """(Dᵀv)_s = Σ_j c_j v_{s−j} for v with N − d rows; returns N rows."""
    d = len(coeffs) - 1
    out = np.zeros((N,) + values.shape[1:])
    for j in range(d + 1):
        out[j : N - d + j] += coeffs[j] * values
    return out


def gram_bands(N: int, coeffs: np.ndarray) -> list[np.ndarray]:
    """Lower diagonals of DᵀD: entry lag (length N − lag) holds (DᵀD)_{s+lag, s}.

    Computed in O(N d²) without forming D: (DᵀD)_{s+lag,s} = Σ_t c_{s+lag−t} c_{s−t}
    over the rows t of D that touch both columns.
    """
    d = len(coeffs) - 1
    bands = [np.zeros(N - lag) for lag in range(d + 1)]
    rows = N - d  # number of rows of D
    for lag in range(d + 1):
        for j in range(d + 1 - lag):
            # row t of D contributes c_j c_{j+lag} to column s = t + j, row s + lag.
            bands[lag][j : j + rows] += coeffs[j] * coeffs[j + lag]
    return bands


def null_space_basis(N: int, coeffs: np.ndarray) -> np.ndarray:
    """Basis (N, d) of the sequences v with Dv = 0 (unpenalized trajectories).

    Built from the roots r of the polynomial (sequences t^m r^t for a root of
    multiplicity > m); time is scaled to [0, 1] and roots outside the unit circle
    are referenced to the last sample so that nothing overflows. Complex roots
    contribute their real and imaginary parts. Columns are orthonormalized.
    """
    d = len(coeffs) - 1
    roots = np.roots(coeffs[::-1])  # P(z) = Σ c_j z^j
    t = np.arange(N, dtype=float)
    cols: list[np.ndarray] = []
    used = np.zeros(len(roots), dtype=bool)
    for i, r in enumerate(roots):
        if used[i] or (np.iscomplex(r) and r.imag < 0):
            used[i] = True
            continue
        same = np.isclose(roots, r, atol=1e-6)
        multiplicity = int(same.sum())
        used |= same
        ref = 0.0 if abs(r) <= 1 else N - 1.0
        if abs(r) < 1e-12:
            continue  # a root at 0 contributes no persistent sequence
        if r == 1:  # the root of every difference operator: 1^t, no complex powers
            base = np.ones(N)
        else:
            base = np.exp((t - ref) * np.log(complex(r)))
        for m in range(multiplicity):
            seq = base * (t / max(N - 1, 1)) ** m
            cols.append(seq.real)
            if abs(r.imag) > 1e-12:
                cols.append(seq.imag)
    basis = np.column_stack(cols)[:, :d] if cols else np.zeros((N, 0))
    q, _ = np.linalg.qr(basis)
    return q


@dataclass(frozen=True)
class OutputSpread:
    """Where each output's entries lie (:func:`output_spread`), in the units of y.

    ``given`` (N, q, n) are the outputs with the rows' √w divided out (0 where
    unobserved); ``center`` (n,) their medians and ``spread`` (n,) their robust
    scales 1.4826 · MAD over the observed rows (0 where more than half are
    equal); ``scales`` (N, q, n) is each entry's distance from its center in
    those scales (0 where unobserved or the spread is 0).
    """

    given: np.ndarray
    center: np.ndarray
    spread: np.ndarray
    scales: np.ndarray


def output_spread(problem: RegressionProblem) -> OutputSpread | None:
    """Each output entry's distance from its column's median in robust scales; None
    where no row is observed."""
    if not problem.observed.any():
        return None
    row_scale = problem.row_scale[:, :, None]
    given = problem.y / np.where(row_scale > 0, row_scale, 1.0)
    n = problem.n
    center, mad, rms = np.empty(n), np.empty(n), np.empty(n)
    column_center_spread(given, problem.observed, center, mad, rms)
    spread = MAD_TO_STD * mad
    # in place: each (N, q, n) temporary costs its page faults at large N
    scales = np.subtract(given, center)
    np.abs(scales, out=scales)
    np.divide(scales, np.where(spread > 0, spread, np.inf), out=scales)
    scales[~problem.observed] = 0.0
    return OutputSpread(given, center, spread, scales)
