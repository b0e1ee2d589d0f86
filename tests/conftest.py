"""Shared configuration for the test suite.

The dense references and seeded data generators live in ``dense_reference.py``
next to this file; make sure it is importable whatever pytest's import mode.
"""

from __future__ import annotations

import os
import sys

import pytest

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

from dense_reference import simulate_ltv  # noqa: E402


@pytest.fixture
def ltv_data():
    """A slowly varying 2-state, 1-input system: x (60, 2), u (60, 1), true k (59, 6)."""
    return simulate_ltv(0, T=60, n=2, m=1)
