"""Penalties on the coefficients' differences, as objects the solvers dispatch on.

A fit minimizes Σ_t ‖y_t − Θ_t φ_t‖² + Σ_t R(Λ (Dk)_t) (the paper's
slowly varying, piecewise constant and coefficient-wise problems), with D the difference
operator of the fit's order and Λ = diag(λ_j) the weights of λ. A :class:`Penalty` is R with what
the solvers need of it:

* the squared norm (``closed_form``) is solved exactly by one banded
  factorization (:mod:`.squared`); its weights are λ² (a vector, or the
  (K, K) matrix Λ);
* a sparse penalty R(z) = Σ_c ‖z_c‖ is a sum of norms over "cones" c (the
  rows of z for "group", its entries for "l1"). It gives :meth:`cone_norms`,
  the :meth:`dual_norms` of its cones (the optimality conditions: λ_max, the
  duality gap certificate of every solver), and its proximal operator
  (:meth:`prox`, ADMM's step). Those are enough for the general route: the
  closed form at λ ≥ λ_max, then ADMM (:mod:`.admm`), certified by the
  duality gap. The built-in cones also have the interior-point method and its
  polish (``interior_point``: the compiled kernels of :mod:`.ipm` know them
  by name).

The penalties are registered by name (:data:`PENALTIES`, ``fit(norm=name)``);
:func:`register` adds one. ARCHITECTURE.md ("Adding a norm") lists what else a
new built-in penalty touches.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..validation.options import penalty_weight, sparse_weights

__all__ = ["GroupNorm", "L1Norm", "PENALTIES", "Penalty", "SquaredNorm", "named", "register"]


class Penalty:
    """A penalty R on the weighted differences z_t = Λ (Dk)_t (see the module docstring).

    Attributes
    ----------
    name : str
        The ``norm`` a fit takes.
    selection : str
        The criterion of ``lam="auto"`` (:func:`ltvmodels.select_lambda`'s ``method``).
    closed_form : bool
        The squared norm: an exact banded solve, with a likelihood and covariances.
    interior_point : bool
        The interior-point method (:mod:`.ipm`) has this penalty's cones.
    separable : bool
        R is a sum over the entries of z (each output's coefficients can be fitted
        alone, as the robust losses' solvers do).
    """

    name: str = ""
    selection: str = "lcurve"
    closed_form: bool = False
    interior_point: bool = False
    separable: bool = False

    def weights(self, lam: Any, K: int) -> np.ndarray:
        """The solver's weights of a λ checked by the fit: (K,) λ_j >= 0 (``inf``: held
        constant) for a sparse penalty."""
        return sparse_weights(lam, K)

    def cone_norms(self, z: np.ndarray) -> np.ndarray:
        """‖z_c‖ of each cone of z (N', K); R(z) is their sum."""
        raise NotImplementedError

    def dual_norms(self, u: np.ndarray) -> np.ndarray:
        """The dual norm of each cone of u (N', K), in the layout of :meth:`cone_norms`."""
        raise NotImplementedError

    def prox(self, v: np.ndarray, threshold: float) -> np.ndarray:
        """argmin_z threshold·R(z) + ½‖z − v‖² for v (N', K)."""
        raise NotImplementedError

    def value(self, z: np.ndarray) -> float:
        """R(z) for the weighted differences z (N', K)."""
        return float(self.cone_norms(z).sum())

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class SquaredNorm(Penalty):
    """R(z) = Σ_t ‖z_t‖² with z_t = Λ(Dk)_t, or (Dk)_tᵀ Λ (Dk)_t for a (K, K) λ (slowly varying)."""

    name = "sq"
    selection = "ml"
    closed_form = True

    def weights(self, lam: Any, K: int) -> np.ndarray:
        return penalty_weight(lam, K)

    def cone_norms(self, z: np.ndarray) -> np.ndarray:
        return np.square(z)

    def value(self, z: np.ndarray) -> float:
        return float(np.sum(np.square(z)))


class GroupNorm(Penalty):
    """R(z) = Σ_t ‖z_t‖₂: all coefficients change together (piecewise constant or linear)."""

    name = "group"
    interior_point = True

    def cone_norms(self, z: np.ndarray) -> np.ndarray:
        return np.linalg.norm(z, axis=1)

    def dual_norms(self, u: np.ndarray) -> np.ndarray:
        return np.linalg.norm(u, axis=1)

    def prox(self, v: np.ndarray, threshold: float) -> np.ndarray:
        size = np.linalg.norm(v, axis=1, keepdims=True)
        return v * np.maximum(0.0, 1.0 - threshold / np.maximum(size, 1e-300))


class L1Norm(Penalty):
    """R(z) = Σ_t ‖z_t‖₁: sparse changes per coefficient (coefficient-wise changes)."""

    name = "l1"
    interior_point = True
    separable = True

    def cone_norms(self, z: np.ndarray) -> np.ndarray:
        return np.abs(z)

    def dual_norms(self, u: np.ndarray) -> np.ndarray:
        return np.abs(u)

    def prox(self, v: np.ndarray, threshold: float) -> np.ndarray:
        return np.sign(v) * np.maximum(np.abs(v) - threshold, 0.0)


PENALTIES: dict[str, Penalty] = {}
"""The penalties by name, in the order of the ``norm`` choices."""


def register(penalty: Penalty) -> Penalty:
    """Make ``penalty`` available as ``fit(..., norm=penalty.name)``; returns it.

    A penalty registered under a name already taken replaces it.
    """
    if not isinstance(penalty, Penalty) or not isinstance(penalty.name, str) or not penalty.name:
        raise TypeError(f"penalty: expected a Penalty with a name, received {penalty!r}")
    PENALTIES[penalty.name] = penalty
    return penalty


def named(norm: str) -> Penalty:
    """The registered penalty ``norm`` (a name the fit's options check has accepted)."""
    return PENALTIES[norm]


register(SquaredNorm())
register(GroupNorm())
register(L1Norm())
