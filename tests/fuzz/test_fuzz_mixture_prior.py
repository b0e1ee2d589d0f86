"""Fuzz GMMPrior: drawn recordings (missing samples, trajectories, odd forms) and options.

The mixture is fitted to the drawn data and conditioned along the same data;
an accepted prior must have the shapes ``fit`` expects, finite moments and
symmetric positive definite covariances, and ``fit`` must accept it.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from fuzz_oracle import FuzzFailure, check_call, inspect_model
from fuzz_strategies import datasets, fuzz_test
from hypothesis import strategies as st

import ltvmodels as ltv

pytest.importorskip("sklearn")


def mixture_options(any_value: bool = True) -> st.SearchStrategy:
    counts = st.one_of(st.none(), st.integers(1, 3))
    if any_value:
        counts = st.one_of(counts, st.just(0), st.just(2.5))
    return st.fixed_dictionaries(
        {
            "n_components": counts,
            "max_components": st.integers(1, 3),
            "seed": st.integers(0, 5),
        },
        optional={"reg_covar": st.sampled_from([0.0, 1e-6, 1e-2] + ([-1.0] if any_value else []))},
    )


def conditioned(x, u, constant, mixture, result, call, context) -> str:
    n = mixture.n_states
    K = n * (n + mixture.n_inputs + (1 if constant else 0))
    mean, cov = result.mean, result.cov
    if mean.ndim != 2 or mean.shape[1] != K or cov.shape != (mean.shape[0], K, K):
        raise FuzzFailure(call.label, "prior shapes", f"{mean.shape} {cov.shape}", call.describe())
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
        raise FuzzFailure(call.label, "non-finite prior moments", "", call.describe())
    if not np.allclose(cov, np.swapaxes(cov, 1, 2), rtol=1e-10, atol=0):
        raise FuzzFailure(call.label, "prior covariance not symmetric", "", call.describe())
    model = check_call(
        ltv.fit, x, u, lam=1.0, constant=constant, prior=result, label="fit(prior=GMMPrior.at)"
    )
    if model is not None:
        inspect_model(model, call, context)
    return "finite"


@fuzz_test(
    datasets(max_T=40, max_n=3),
    mixture_options(),
    st.booleans(),
    examples=0.3,
    valid=(datasets(forms=False, max_T=40, max_n=3), mixture_options(False), st.booleans()),
)
def test_gmm_prior(data, options, constant):
    """GMMPrior on drawn recordings; its prior along them is well formed and fit takes it."""
    x, u = data.xu()
    mixture = check_call(ltv.GMMPrior, x, u, **options)
    if mixture is None:
        return
    check_call(
        mixture.at,
        x,
        u,
        constant=constant,
        label="GMMPrior.at",
        inspector=partial(conditioned, x, u, constant, mixture),
    )
