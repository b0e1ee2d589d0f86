"""Well-posedness checks (paper Section V, Propositions 2 and 3).

The squared-difference problem has a unique minimizer for λ > 0 iff no
coefficient trajectory left unpenalized by the difference operator is invisible
in the data. For the first difference that trajectory is a constant, and the
condition is the LTI one: Σ_t φ_t φ_tᵀ nonsingular (Proposition 2). For higher
orders it is any sequence in the null space of D (e.g. k_t = a + b·t for the
second difference): with basis b(t) ∈ R^d of that null space the condition is
that M = Σ_t (b(t) ⊗ φ_t)(b(t) ⊗ φ_t)ᵀ is nonsingular. (Proposition 3 states it
for the direction b(t) = t alone; M covers the whole null space.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import IdentifiabilityWarning, SingularProblemError, warn
from .problem import RegressionProblem, null_space_basis

__all__ = [
    "SINGULAR_TOL",
    "ILL_CONDITIONED_TOL",
    "Diagnosis",
    "scaled_min_eig",
    "describe_direction",
    "check",
]

SINGULAR_TOL = 1e-10  # smallest eigenvalue of the correlation-scaled matrix
ILL_CONDITIONED_TOL = 1e-7


@dataclass
class Diagnosis:
    """Outcome of the identifiability check."""

    lti_min_eig: float
    null_space_min_eig: float
    direction: np.ndarray  # least identified combination of the regressors (p,)

    @property
    def lti_identifiable(self) -> bool:
        return self.lti_min_eig > SINGULAR_TOL

    @property
    def identifiable(self) -> bool:
        return self.null_space_min_eig > SINGULAR_TOL


def scaled_min_eig(M: np.ndarray) -> tuple[float, np.ndarray]:
    """Smallest eigenvalue (and eigenvector) of M scaled to unit diagonal."""
    diag = M.diagonal().copy()
    if diag.min() <= 0:
        v = np.zeros(M.shape[0])
        v[int(np.argmin(diag))] = 1.0
        return 0.0, v
    s = 1.0 / np.sqrt(diag)
    eig, vec = np.linalg.eigh(M * s[:, None] * s[None, :])
    return float(max(eig[0], 0.0)), vec[:, 0] * s


def _diagnose(problem: RegressionProblem, const_mask: np.ndarray | None = None) -> Diagnosis:
    """Compute the identifiability diagnostics of a regression problem.

    ``const_mask`` (p,) marks regressors whose coefficients are held constant in
    every row; their unpenalized trajectories are constants only.
    """
    N, p = problem.N, problem.p
    phi = problem.phi.reshape(N * problem.q, p)  # rows (t, j)
    lti_eig, lti_dir = scaled_min_eig(phi.T @ phi)
    if problem.degree == 1:  # null space: constants, the LTI condition itself
        return Diagnosis(lti_min_eig=lti_eig, null_space_min_eig=lti_eig, direction=lti_dir)
    basis = null_space_basis(N, problem.coeffs)
    if const_mask is None:
        const_mask = np.zeros(p, dtype=bool)
    # Columns b_l(t)·φ_{t,j} for varying j and every null-space sequence l,
    # and φ_{t,j} alone for constant j.
    basis = np.repeat(basis, problem.q, axis=0)  # one row per (t, j)
    varying = basis[:, :, None] * phi[:, None, ~const_mask]  # (N·q, d, #varying)
    Z = np.concatenate([varying.reshape(N * problem.q, -1), phi[:, const_mask]], axis=1)
    ns_eig, _ = scaled_min_eig(Z.T @ Z)
    return Diagnosis(lti_min_eig=lti_eig, null_space_min_eig=ns_eig, direction=lti_dir)


def describe_direction(direction: np.ndarray, names: list[str]) -> str:
    v = direction / np.abs(direction).max()
    terms = [f"{c:+.3g}·{name}" for c, name in zip(v, names, strict=True) if abs(c) > 1e-3]
    return " ".join(terms) if terms else "0"


def check(
    problem: RegressionProblem,
    *,
    has_prior: bool,
    regressor_names: list[str],
    const_mask: np.ndarray | None = None,
) -> Diagnosis:
    """Raise or warn when the data do not identify the model.

    Without a prior a non-identifiable problem raises
    :class:`~ltvmodels.errors.SingularProblemError` (there is no unique answer to
    return); with a prior it warns, since the prior then decides the directions
    the data cannot. Ill-conditioning only warns.
    """
    diag = _diagnose(problem, const_mask)
    remedy_prior = "a prior (ltvmodels.Prior)" if not has_prior else "a more informative prior"
    if not diag.lti_identifiable:
        message = (
            "the regressors are linearly dependent over the whole data set: the combination "
            f"{describe_direction(diag.direction, regressor_names)} is (numerically) zero, so "
            "the parameters are not identifiable even for an LTI model (paper Proposition 2). "
            f"Remedies: more excitation (a persistently exciting input), removing redundant "
            f"states or inputs, or {remedy_prior}."
        )
    elif not diag.identifiable:
        message = (
            "the data do not identify the coefficient trajectories left unpenalized by the "
            f"difference operator of degree {problem.degree} (paper Proposition 3: the "
            "regressors are orthogonal to a trajectory such as a linear trend in time). "
            f"Remedies: more excitation, a lower order, or {remedy_prior}."
        )
    else:
        worst = min(diag.lti_min_eig, diag.null_space_min_eig)
        if worst < ILL_CONDITIONED_TOL:
            warn(
                f"the identification problem is ill-conditioned (smallest scaled eigenvalue "
                f"{worst:.1e}); estimates along the direction "
                f"{describe_direction(diag.direction, regressor_names)} are unreliable. "
                "More excitation or a prior helps.",
                IdentifiabilityWarning,
            )
        return diag
    if has_prior:
        warn(
            message + " The prior determines these directions.",
            IdentifiabilityWarning,
        )
        return diag
    raise SingularProblemError(message)
