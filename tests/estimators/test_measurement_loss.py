"""Robust measurement losses of the measurement model and ``model.sample_outliers``.

References: the bound of each loss against the exact log-density of its
measurement model (scipy's Student-t; Huber's ρ by its definition) for a
known state, where the bound is tight; the estimates against the true
coefficients of ``systems.jump_linear`` with recorded samples corrupted by
a known shift (the corrupted samples are known, so detection is counted).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import ltvmodels as ltv
from ltvmodels.core import measurement_weights as mw


def _mean_error(model, data):
    return float(np.abs(model.A - data.A).mean())


def _corrupted(T=400, seed=12, count=20, shift=5.0):
    """jump_linear(T, seed) with ``count`` recorded samples (every state) shifted by
    ``shift``; the samples are ``default_rng(seed).choice(T, count, replace=False)``."""
    data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
    hit = np.sort(np.random.default_rng(seed).choice(T, count, replace=False))
    x = data.x.copy()
    x[hit] += shift
    return data, x, hit


# -- the bounds that EM increases ------------------------------------------------


@pytest.mark.parametrize("loss", ["huber", "student"])
def test_bound_is_the_log_density_at_a_known_state(loss):
    # with the state known (Var = 0) the optimal weight makes the bound tight: the
    # Gaussian likelihood at σ²/ω plus the correction is the model's own log-density
    sigma2 = 0.3
    e = np.array([0.0, 0.2, -0.9, 1.7, 4.0, -12.0])[None, :, None]  # (R, T, n)
    y = e.copy()
    observed = np.isfinite(y)
    s = mw.standardized_square(y, np.zeros_like(y), np.zeros_like(y), np.array([sigma2]))
    w = mw.measurement_weights(loss, s, observed)
    gauss = stats.norm.logpdf(e, scale=np.sqrt(sigma2 / w)).sum()
    bound = gauss + mw.bound_correction(loss, w, s, observed)
    z = e / np.sqrt(sigma2)
    if loss == "student":
        exact = stats.t.logpdf(e, df=mw.STUDENT_DOF, scale=np.sqrt(sigma2)).sum()
    else:
        d = mw.HUBER_DELTA
        rho = np.where(np.abs(z) <= d, 0.5 * z**2, d * np.abs(z) - 0.5 * d**2)
        exact = np.sum(-rho - 0.5 * np.log(2 * np.pi * sigma2))
    assert bound == pytest.approx(exact, rel=1e-12, abs=1e-12)
    # any other weight (for "student": q(τ) = Gamma(a, b') of mean ω') gives less
    for scale in (0.5, 0.9, 1.1, 2.0):
        other = np.minimum(w * scale, 1.0) if loss == "huber" else w * scale
        made_from = (mw.STUDENT_DOF + 1.0) / other - mw.STUDENT_DOF if loss == "student" else s
        if np.any(made_from < 0):
            continue
        gauss_other = stats.norm.logpdf(e, scale=np.sqrt(sigma2 / other)).sum()
        assert gauss_other + mw.bound_correction(loss, other, made_from, observed) <= bound + 1e-9


@pytest.mark.parametrize("loss", ["huber", "student"])
def test_em_increases_the_bound_of_the_robust_loss(loss):
    data, x, _ = _corrupted(T=200, seed=3, count=10)
    model = ltv.fit(
        x, data.u, lam=10.0, norm="sq", measurement_noise="estimate", measurement_loss=loss
    )
    path = np.asarray(model.info["em_objectives"])
    assert path.size > 3
    assert np.diff(path).min() >= -1e-9 * abs(path[-1])
    assert model.info["measurement_loss"] == loss


# -- acceptance: outliers in the recorded states -----------------------------------


@pytest.mark.parametrize("loss", ["huber", "student"])
def test_corrupted_samples_are_down_weighted_and_found(loss):
    # Context (fits without measurement noise on the same data, norm="group",
    # λ = 17, refine=True): squared loss ≈ 0.26, Huber ≈ 0.16, the corrupted
    # samples set to NaN ≈ 0.036 (mean |Â − A|). The issue's own draw of the 20
    # samples was not stated; its numbers were 0.126, 0.094 and 0.039.
    data, x, hit = _corrupted()
    kwargs = dict(lam=17.0, norm="group", refine=True)
    squared = ltv.fit(x, data.u, **kwargs)
    model = ltv.fit(x, data.u, **kwargs, measurement_noise="estimate", measurement_loss=loss)
    error = _mean_error(model, data)
    assert error <= 0.06
    assert error < 0.5 * _mean_error(squared, data)
    flagged = model.sample_outliers
    assert flagged.shape == (400,) and flagged.dtype == bool
    clean = np.ones(400, bool)
    clean[hit] = False
    assert flagged[hit].sum() >= 19
    assert flagged[clean].sum() <= 0.01 * clean.sum()
    assert model.info["n_sample_outliers"] == int(flagged.sum())


def test_squared_measurement_loss_defines_sample_outliers_and_trajectories():
    runs = [ltv.systems.jump_linear(120, change_at=60, seed=s) for s in (4, 5)]
    x = np.stack([r.x for r in runs])
    u = np.stack([r.u for r in runs])
    x[1, 30] += 5.0
    model = ltv.fit(x, u, lam=10.0, measurement_noise="estimate", measurement_loss="student")
    assert model.sample_outliers.shape == (2, 120)
    assert model.sample_outliers[1, 30]
    plain = ltv.fit(x[0], u[0], lam=10.0, measurement_noise=0.04, em_max_iter=20)
    assert plain.sample_outliers.shape == (120,)
    assert plain.info["measurement_loss"] == "squared"
    assert ltv.fit(x[0], u[0], lam=10.0).sample_outliers is None


def test_lti_and_piecewise_take_the_measurement_loss():
    data, x, hit = _corrupted(T=200, seed=7, count=8)
    lti = ltv.fit_lti(x, data.u, measurement_noise="estimate", measurement_loss="student")
    assert set(np.flatnonzero(lti.sample_outliers)) >= set(hit[1:])  # x[0] may be missed
    piecewise = ltv.fit_piecewise(
        x, data.u, [100], measurement_noise="estimate", measurement_loss="huber", em_max_iter=50
    )
    assert piecewise.sample_outliers[hit].sum() >= 6


# -- options and outputs --------------------------------------------------------------


def test_options_are_checked():
    data = ltv.systems.jump_linear(60, change_at=30, seed=1)
    with pytest.raises(ValueError, match="measurement_loss"):
        ltv.fit(data.x, data.u, lam=5.0, measurement_noise="estimate", measurement_loss="t")
    with pytest.raises(ValueError, match="measurement_loss.*measurement_noise='estimate'"):
        ltv.fit(data.x, data.u, lam=5.0, measurement_loss="huber")
    with pytest.raises(ValueError, match="measurement_loss"):
        ltv.fit_lti(data.x, data.u, measurement_loss="student")
    with pytest.raises(ValueError, match="measurement_loss"):
        ltv.fit_piecewise(data.x, data.u, [30], measurement_loss=1)


def test_outputs_file_summary_plot_and_command_line(tmp_path):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("matplotlib")
    from ltvmodels.cli import main

    data, x, hit = _corrupted(T=150, seed=2, count=5)
    model = ltv.fit(x, data.u, lam=10.0, measurement_noise="estimate", measurement_loss="huber")
    path = tmp_path / "m.npz"
    model.save(path)
    loaded = ltv.load(path)
    np.testing.assert_array_equal(loaded.sample_outliers, model.sample_outliers)
    assert loaded.sample_outliers.dtype == bool
    assert "sample outliers" in str(loaded.summary())
    fig = ltv.plotting.plot_states(model, x)
    crosses = [line for ax in fig.axes for line in ax.lines if line.get_label() == "sample outlier"]
    assert len(crosses) == 2 and len(crosses[0].get_xdata()) == int(model.sample_outliers.sum())
    csv = tmp_path / "x.csv"
    pd.DataFrame({"x0": x[:, 0], "x1": x[:, 1], "u0": data.u[:, 0]}).to_csv(csv, index=False)
    out = tmp_path / "cli.npz"
    code = main(
        ["fit", str(csv), "--state", "x0,x1", "--input", "u0", "--lam", "10",
         "--measurement-noise", "estimate", "--measurement-loss", "huber", "--out", str(out)]
    )  # fmt: skip
    assert code in (0, None)
    np.testing.assert_array_equal(ltv.load(out).sample_outliers, model.sample_outliers)
