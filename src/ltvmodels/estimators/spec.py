"""``FitSpec``: the options of a penalized fit, checked once where the user's call enters.

:func:`ltvmodels.fit`, :func:`ltvmodels.fit_regression`, :func:`ltvmodels.fit_ar`
and :func:`ltvmodels.fit_arx` keep their keyword signatures; each builds one
:class:`FitSpec` from its keywords (:meth:`FitSpec.from_arguments`) and passes it down,
so that everything below takes the spec, not loose keywords, and no option is
checked twice. The constraints are declared in :data:`FIT_CONSTRAINTS`; the
options that depend on the data's sizes are checked by the fit against the
problem (see :mod:`ltvmodels.validation.constraints`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

from ..core.losses import LOSSES
from ..core.penalties import PENALTIES
from ..validation import options
from ..validation.constraints import (
    Callback,
    Choice,
    Constraint,
    Deferred,
    Flag,
    Integer,
    LamValue,
    Positive,
    check_all,
)
from ..validation.options import Loss, MeasurementLoss, Norm, PriorMode

__all__ = ["FIT_CONSTRAINTS", "MEASUREMENT_CONSTRAINTS", "FitSpec"]

FIT_CONSTRAINTS: dict[str, Constraint] = {
    "lam": LamValue(),
    "norm": Choice(PENALTIES),  # the registered penalties
    "order": Deferred(),  # the difference operator, against the series length
    "prior": Deferred(),  # against the number of steps and parameters
    "prior_mode": Choice(options.PRIOR_MODES),
    "noise_var": Deferred(),  # against the number of outputs
    "compute_cov": Flag(),
    "max_iter": Integer(1),
    "tol": Positive(),
    "refine": Flag(),
    "loss": Choice(LOSSES),  # the registered losses
    "huber_delta": Deferred(),  # with the loss, against the number of outputs
    "progress": Callback(),
}
"""The constraint of each option of :class:`FitSpec`, checked in this order."""

MEASUREMENT_CONSTRAINTS: dict[str, Constraint] = {
    "measurement_noise": Deferred(),  # against the number of states
    "measurement_loss": Choice(options.MEASUREMENT_LOSSES),
    "em_tol": Positive(),
    "em_max_iter": Integer(0),
    "em_accelerate": Flag(),
}
"""The options of the measurement model, which only the state-space :func:`ltvmodels.fit`
takes (checked where its arguments have them)."""


@dataclass(frozen=True)
class FitSpec:
    """The options of one penalized fit (their meanings: :func:`ltvmodels.fit`).

    Build it with :meth:`from_arguments`, which checks every option; ``order``,
    ``prior``, ``noise_var``, ``huber_delta`` and the values of ``lam`` are
    checked by the fit against the problem's sizes.
    """

    lam: Any
    norm: Norm = "sq"
    order: Any = 1
    prior: Any = None
    prior_mode: PriorMode = "exact"
    noise_var: Any = None
    compute_cov: bool = True
    max_iter: int = 10000
    tol: float = 1e-6
    refine: bool = False
    loss: Loss = "squared"
    huber_delta: Any = None
    progress: Callable[[int, int], None] | None = None
    measurement_noise: Any = None
    measurement_loss: MeasurementLoss = "squared"
    em_tol: float = 1e-6
    em_max_iter: int = 500
    em_accelerate: bool = True

    @classmethod
    def from_arguments(cls, arguments: Mapping[str, Any]) -> FitSpec:
        """The spec of a front-end's call: its arguments named as the fields of
        :class:`FitSpec` (a front-end passes ``locals()`` first thing; the others are
        ignored, a field it does not take keeps its default), each checked by its
        constraint (:data:`FIT_CONSTRAINTS`).

        Raises
        ------
        ValueError, TypeError
            An invalid option (the message names it).
        """
        values = {name: arguments.get(name, _DEFAULTS.get(name)) for name in FIT_CONSTRAINTS}
        checked = check_all(FIT_CONSTRAINTS, values, _DEFAULTS)
        measured = {name: arguments[name] for name in MEASUREMENT_CONSTRAINTS if name in arguments}
        if measured:  # a front-end that takes them (the others keep the defaults)
            checked.update(check_all(MEASUREMENT_CONSTRAINTS, measured, _DEFAULTS))
            options.measurement_loss_needs_noise(
                checked.get("measurement_loss", "squared"), checked.get("measurement_noise")
            )
        return cls(**checked)

    @property
    def lam_is_auto(self) -> bool:
        """True where λ is to be chosen from the data (``lam="auto"``)."""
        return isinstance(self.lam, str)

    def first_step(self) -> FitSpec:
        """The spec of the first fit of a two-step refinement (no covariance needed)."""
        return replace(self, refine=False, compute_cov=False)


_DEFAULTS = {field.name: field.default for field in fields(FitSpec) if field.name != "lam"}
"""The default of each option but λ (which has none)."""
