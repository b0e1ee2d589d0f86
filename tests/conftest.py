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

from ltvmodels.core import banded  # noqa: E402

# The kernels compiled for a constant block size b (banded.kernel_size) are the same
# source as those for a run-time b, compiled once per b: for every b up to 8 they took
# about 100 s of the suite's compilation, a sixth of its time. Here they serve b <= 3
# (and long series, and worker processes); larger blocks take the run-time-size
# kernels, and tests/core/test_kernels.py compares the two.
banded.FIXED_BLOCK_SMALL_B = 3


@pytest.fixture
def ltv_data():
    """A slowly varying 2-state, 1-input system: x (60, 2), u (60, 1), true k (59, 6)."""
    return simulate_ltv(0, T=60, n=2, m=1)
