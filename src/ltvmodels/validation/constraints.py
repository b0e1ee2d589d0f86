"""Declared constraints on options: each checks a value and can name values it rejects.

A front-end declares the constraints of its options once, as a mapping from
the option's name to a :class:`Constraint` (e.g. ``FIT_CONSTRAINTS`` in
:mod:`ltvmodels.estimators.spec`), and checks them all in one call
(:func:`check_all`). The same declarations give the fuzz tests values that
must be rejected (:meth:`Constraint.invalid_examples`), so that a check and
its tests cannot drift apart. The messages are those of
:mod:`ltvmodels.validation.options`: they name the option, what was expected
and what was received.

Options whose check needs the data's sizes (λ against K, the noise variance
and the Huber threshold against n, the difference operator against N) are
declared with :class:`Deferred`: the entry only checks their type, and the
fit checks them once against the problem.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

from . import options

__all__ = [
    "Callback",
    "Choice",
    "Constraint",
    "Deferred",
    "Flag",
    "Integer",
    "LamValue",
    "Positive",
    "check_all",
]


class Constraint:
    """A constraint on one option: :meth:`check` returns the value as the fit uses it."""

    def check(self, value: Any, name: str) -> Any:
        raise NotImplementedError

    def invalid_examples(self) -> list[Any]:
        """Values that :meth:`check` rejects (for the fuzz tests)."""
        raise NotImplementedError


@dataclass(frozen=True)
class Choice(Constraint):
    """One of the strings ``values`` (a sequence, or a registry's names: a mapping read at
    each check, so that what is registered later is accepted)."""

    values: Collection[str]

    def check(self, value: Any, name: str) -> Any:
        return options.choice(value, name, tuple(self.values))

    def invalid_examples(self) -> list[Any]:
        return ["", "none", next(iter(self.values)).upper(), 1, None]


@dataclass(frozen=True)
class Flag(Constraint):
    """True or False (no other truthy values)."""

    def check(self, value: Any, name: str) -> bool:
        return options.flag(value, name)

    def invalid_examples(self) -> list[Any]:
        return [1, 0, "yes", None]


@dataclass(frozen=True)
class Integer(Constraint):
    """An integer >= ``minimum``."""

    minimum: int

    def check(self, value: Any, name: str) -> int:
        return options.integer(value, name, self.minimum)

    def invalid_examples(self) -> list[Any]:
        return [self.minimum - 1, 2.5, True, "10"]


@dataclass(frozen=True)
class Positive(Constraint):
    """A finite real number > 0."""

    def check(self, value: Any, name: str) -> float:
        return options.positive_scalar(value, name)

    def invalid_examples(self) -> list[Any]:
        return [0.0, -1e-6, float("nan"), float("inf"), "1e-6"]


@dataclass(frozen=True)
class Callback(Constraint):
    """A function ``f(done, total)`` or None."""

    def check(self, value: Any, name: str) -> Any:
        return options.callback(value, name)

    def invalid_examples(self) -> list[Any]:
        return [1, "print"]


@dataclass(frozen=True)
class LamValue(Constraint):
    """A number, an array or the string "auto"; the values are checked against the problem
    (:func:`ltvmodels.validation.options.penalty_weight`, ``sparse_weights``)."""

    def check(self, value: Any, name: str) -> Any:
        options.is_auto(value, name)
        return value

    def invalid_examples(self) -> list[Any]:
        return ["automatic", ""]


@dataclass(frozen=True)
class Deferred(Constraint):
    """Checked by the fit against the data's sizes (see the module docstring)."""

    def check(self, value: Any, name: str) -> Any:
        return value

    def invalid_examples(self) -> list[Any]:
        return []


def check_all(
    constraints: Mapping[str, Constraint],
    values: Mapping[str, Any],
    defaults: Mapping[str, Any] | None = None,
) -> dict:
    """Every option of ``values`` checked by its constraint, in the declared order.

    A value equal to its entry in ``defaults`` (and of its type) is taken as it
    is: defaults are valid, most calls pass most options at their defaults, and
    a fit of a short series takes a few hundred microseconds.
    """
    defaults = defaults or {}
    checked = {}
    for name, constraint in constraints.items():
        value = values[name]
        default = defaults.get(name, _NO_DEFAULT)
        is_default = type(value) is type(default) and value == default
        checked[name] = value if is_default else constraint.check(value, name)
    return checked


_NO_DEFAULT = object()  # an option without a default
