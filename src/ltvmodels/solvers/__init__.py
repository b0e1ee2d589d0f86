"""Numerical solvers behind :func:`ltvmodels.fit` (not public API)."""
