"""Coercion and validation of every public input, in one place.

:mod:`.arrays` checks array inputs (data, covariances, change points) and
:mod:`.options` scalar options, choices and counts. Every check raises
:class:`ValueError` or :class:`TypeError` with a message that names the
argument, what was expected and what was received.
"""

__all__: list[str] = []
