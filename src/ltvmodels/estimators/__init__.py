"""The estimators: validate the user's data and options, build (y, φ), call the core, wrap results.

:mod:`.fit` (state space), :mod:`.regression` (any regressors, and the shared
core of the front-ends), :mod:`.ar`, :mod:`.piecewise`, :mod:`.segments`,
:mod:`.changepoints`, :mod:`.selection` (λ), :mod:`.priors` and
:mod:`.kalman`. Their public functions are exported by :mod:`ltvmodels`.
"""

__all__: list[str] = []
