"""One recorded sample far beyond the others, inside the accepted range of magnitudes.

A state sample of 1e10 … 1e90 (the validation accepts up to 1e100) enters the
fit twice: as an output y (x[t + 1]) and as a regressor φ. The robust losses
count its residual linearly, so their fits must not depend on how far out it
lies (beyond the other samples' scale). With the squared loss and a sparse norm the sample
dominates the objective: that is a documented error naming the sample.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core.problem import row_norms
from ltvmodels.errors import ConvergenceWarning, SingularProblemError

SPIKES = (1e10, 1e30, 1e50, 1e90)
AT = 50  # the spiked sample x[AT, 0]: the output of step AT - 1, a regressor of step AT
NEAR = slice(AT - 3, AT + 3)  # steps whose coefficients the spike itself sets


@pytest.fixture(scope="module")
def data():
    return ltv.systems.jump_linear(200, change_at=100, seed=0)


def _spiked(data, spike):
    x = data.x.copy()
    x[AT, 0] = spike
    return x


def _fit(x, u, lam, **options):
    # The certificates of the steps whose regressor is the spike are computed with
    # the spike's rounding; the fits are judged by the comparisons below.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        return ltv.fit(x, u, lam=lam, **options)


def _away(model):
    """A and B at the steps the spike does not enter."""
    keep = np.ones(model.A.shape[0], dtype=bool)
    keep[NEAR] = False
    return np.concatenate([model.A[keep].ravel(), model.B[keep].ravel()])


@pytest.mark.parametrize("norm", ["sq", "group", "l1"])
@pytest.mark.parametrize("loss", ["huber", "laplace"])
def test_robust_fit_does_not_depend_on_how_far_out_the_spike_is(data, loss, norm):
    # a given threshold: the default one follows the squared-loss residuals, which the
    # spike moves
    options = {"norm": norm, "loss": loss, "huber_delta": 0.37 if loss == "huber" else None}
    # a regressor of 1e10 leaves the penalty O(1e-10) of the coefficient it multiplies
    reference = _fit(_spiked(data, SPIKES[0]), data.u, 5.0, **options)
    for spike in SPIKES[1:]:
        model = _fit(_spiked(data, spike), data.u, 5.0, **options)
        assert np.isfinite(model.A).all() and np.isfinite(model.B).all()
        scale = np.abs(_away(reference)).max()
        # The solvers' tolerances are relative to an objective that the spike's linear
        # cost dominates: the sparse norms' fits agree to about 1e-4 of the coefficients.
        np.testing.assert_allclose(_away(model), _away(reference), rtol=0, atol=1e-3 * scale)
        # the reported objective counts the sample as given: it grows with the spike
        assert model.info["objective"] > spike * 1e-3


@pytest.mark.parametrize("spike", [1e6, 1e7])
def test_huber_converges_with_a_regressor_far_beyond_the_others(data, spike):
    """A sample 10⁶-10⁷ times the others is a regressor whose row's update in the Kalman
    form cancels 12-14 digits of the covariance (its Newton steps then stalled at a
    KKT residual of 1e-4 to 1): such outputs are factored instead
    (huber.KALMAN_MAX_REDUCTION), and the fit converges to its tolerance."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        model = ltv.fit(_spiked(data, spike), data.u, lam=5.0, loss="huber")
    assert model.info["converged"]


@pytest.mark.parametrize("spike", SPIKES)
@pytest.mark.parametrize("norm", ["group", "l1"])
def test_squared_loss_with_a_sparse_norm_names_the_dominating_sample(data, norm, spike):
    with pytest.raises(SingularProblemError) as caught:
        ltv.fit(_spiked(data, spike), data.u, lam=5.0, norm=norm)
    message = str(caught.value)
    assert f"x[{AT}, 0]" in message and f"{spike:.3g}" in message
    assert "NaN" in message and "loss='huber'" in message


def test_a_spike_marked_missing_fits(data):
    # what the error advises
    x = _spiked(data, 1e90)
    x[AT, 0] = np.nan
    model = ltv.fit(x, data.u, lam=5.0, norm="group")
    assert model.info["converged"] and np.isfinite(model.A).all()


def test_row_norms_do_not_overflow_near_the_largest_floats():
    """row_norms (the activation, a model's change points) scales rows whose squares
    would overflow by a power of two: exact, and without numpy's overflow warning."""
    v = np.random.default_rng(4).standard_normal((6, 4))
    np.testing.assert_array_equal(row_norms(v), np.linalg.norm(v, axis=1))
    huge = v * 2.0**1000  # about 1e301: squares overflow
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scaled = row_norms(huge)
    np.testing.assert_array_equal(scaled, np.linalg.norm(v, axis=1) * 2.0**1000)
