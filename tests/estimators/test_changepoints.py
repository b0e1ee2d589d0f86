"""ltvmodels.find_changepoints: rules, index convention, and detection on simulated systems."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core.problem import apply_difference
from ltvmodels.estimators.changepoints import detection_level


def difference(order: int) -> np.ndarray:
    coeffs = np.array([1.0])
    for _ in range(order):
        coeffs = np.convolve(coeffs, [-1.0, 1.0])
    return coeffs


def activation_of(k: np.ndarray, order: int) -> np.ndarray:
    return np.linalg.norm(apply_difference(k, difference(order)), axis=1)


def spikes(length: int, where: dict[int, float], background: np.ndarray | None = None):
    a = np.zeros(length) if background is None else background.copy()
    for t, value in where.items():
        a[t] = value
    return a


# -- synthetic activations ------------------------------------------------------------------


def test_single_spike_maps_to_the_next_index():
    # (Dk)_t = k_{t+1} − k_t: a large a_49 means k_50 ≠ k_49, change point 50.
    found = ltv.find_changepoints(spikes(100, {49: 1.0}))
    assert found.tolist() == [50]
    assert found.dtype.kind == "i"


@pytest.mark.parametrize("t,expected", [(0, 1), (99, 100)])
def test_spikes_at_the_ends_are_found(t, expected):
    # Activation of length N − 1 = 100: change points 1 … N − 1 = 100.
    assert ltv.find_changepoints(spikes(100, {t: 1.0})).tolist() == [expected]


def test_two_close_spikes_versus_min_distance():
    a = spikes(200, {50: 1.0, 55: 0.8, 120: 0.6})
    assert ltv.find_changepoints(a).tolist() == [51, 121]  # default 10: 55 merged into 50
    assert ltv.find_changepoints(a, min_distance=6).tolist() == [51, 121]
    assert ltv.find_changepoints(a, min_distance=5).tolist() == [51, 56, 121]
    assert ltv.find_changepoints(a, min_distance=80).tolist() == [51]
    # Equal heights: the earlier one wins (the result depends on the values only).
    tie = spikes(200, {50: 1.0, 55: 1.0})
    assert ltv.find_changepoints(tie).tolist() == [51]


def test_plateau_and_shoulders_give_one_change():
    bump = np.exp(-0.5 * ((np.arange(100) - 40) / 6.0) ** 2)  # many samples above the level
    assert ltv.find_changepoints(bump, min_distance=1).tolist() == [41]
    plateau = spikes(100, {30: 1.0, 31: 1.0, 32: 1.0})
    assert ltv.find_changepoints(plateau, min_distance=1).tolist() == [31]  # first index


def test_relative_threshold():
    a = spikes(300, {50: 1.0, 150: 0.3, 250: 0.2})
    assert ltv.find_changepoints(a).tolist() == [51, 151]  # 0.2 is not above 0.25
    assert ltv.find_changepoints(a, threshold=0.1).tolist() == [51, 151, 251]
    assert ltv.find_changepoints(a, threshold=0.5).tolist() == [51]


def test_noise_floor_rejects_the_background():
    rng = np.random.default_rng(0)
    noise = np.abs(rng.standard_normal(400))  # a background of half-normal values
    # The relative rule alone always accepts the largest value and, with a small
    # threshold, many background peaks; the robust floor accepts none of them.
    assert ltv.find_changepoints(noise, noise_factor=None).size >= 1
    assert ltv.find_changepoints(noise, threshold=0.0, noise_factor=None).size > 20
    assert ltv.find_changepoints(noise).size == 0
    # A spike 12 robust standard deviations above the median is found.
    median = np.median(noise)
    sigma = 1.4826 * np.median(np.abs(noise - median))
    with_change = spikes(400, {200: median + 12 * sigma}, noise)
    assert ltv.find_changepoints(with_change).tolist() == [201]
    assert ltv.find_changepoints(with_change, noise_factor=20.0).size == 0
    level = detection_level(with_change, 0.0, 8.0)
    assert level == pytest.approx(
        np.median(with_change)
        + 8 * 1.4826 * np.median(np.abs(with_change - np.median(with_change)))
    )


def test_sparse_activation_has_zero_floor():
    a = spikes(300, {100: 1e-3, 200: 2e-3})  # tiny but exact: the MAD of a sparse array is 0
    assert ltv.find_changepoints(a).tolist() == [101, 201]


def test_max_changes_keeps_the_largest():
    a = spikes(300, {50: 0.5, 150: 1.0, 250: 0.8})
    assert ltv.find_changepoints(a, max_changes=2).tolist() == [151, 251]
    assert ltv.find_changepoints(a, max_changes=0).size == 0
    assert ltv.find_changepoints(a, max_changes=10).tolist() == [51, 151, 251]


def test_no_activation_gives_no_change():
    assert ltv.find_changepoints(np.zeros(50)).size == 0
    empty = ltv.find_changepoints(np.zeros(0))
    assert empty.size == 0 and empty.dtype.kind == "i"


# -- index convention for every degree -----------------------------------------------------


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_break_of_a_piecewise_polynomial_is_found_at_its_index(degree):
    """k_t = (t − c)_+^(d−1) (a step for d = 1, a kink for d = 2): found at c."""
    N, c = 120, 61
    t = np.arange(N, dtype=float)
    ramp = np.maximum(t - c, 0.0) ** (degree - 1) if degree > 1 else (t >= c).astype(float)
    k = np.outer(ramp, [1.0, -0.5, 0.25])
    a = activation_of(k, degree)
    assert ltv.find_changepoints(a, degree=degree).tolist() == [c]


def test_model_input_uses_the_models_degree():
    rng = np.random.default_rng(3)
    N, n, p = 150, 2, 3
    knots = [0, 70, N - 1]
    values = rng.standard_normal((3, n * p))
    k = np.stack([np.interp(np.arange(N), knots, values[:, j]) for j in range(n * p)], axis=1)
    smooth = ltv.LTVModel(k, n, p - n, ltv.FitRecord(norm="sq", coeffs=[1.0, -2.0, 1.0], lam=1.0))
    assert ltv.find_changepoints(smooth).tolist() == [70]  # the kink, via d = 2
    assert ltv.find_changepoints(smooth, degree=2).tolist() == [70]
    with pytest.raises(ValueError, match=r"^degree: the model's difference operator has degree 2"):
        ltv.find_changepoints(smooth, degree=1)
    # Through the first difference the activation is a step (|slope| per segment),
    # flat up to rounding: the only peak is the start of the higher plateau.
    slow = ltv.LTVModel(k, n, p - n, ltv.FitRecord(norm="sq", coeffs=[-1.0, 1.0], lam=1.0))
    act = slow.activation()
    higher_first = act[:69].mean() > act[70:].mean()
    assert ltv.find_changepoints(slow).tolist() == ([1] if higher_first else [71])


# -- on fitted models -----------------------------------------------------------------------


def test_jump_linear_squared_norm_fit():
    data = ltv.systems.jump_linear(seed=0)
    model = ltv.fit(data.x, data.u, lam=30.0)
    found = ltv.find_changepoints(model)
    assert len(found) == 1 and abs(int(found[0]) - 200) <= 3
    refit = ltv.fit_piecewise(data.x, data.u, found)
    assert np.abs(refit.A[10] - data.A[10]).max() < 0.05


def test_piecewise_models_give_back_their_changepoints():
    data = ltv.systems.jump_linear(seed=1)
    for order in (1, 2):
        model = ltv.fit_piecewise(data.x, data.u, [120, 250], order=order)
        assert ltv.find_changepoints(model, threshold=0.0).tolist() == [120, 250]


def three_switch_system(seed: int, T: int = 800, noise: float = 0.2):
    """Two states, one input; A switches at 200, 400 and 600 (B constant)."""
    rng = np.random.default_rng(seed)
    As = [
        [[0.9, 0.2], [0.0, 0.8]],
        [[0.5, 0.2], [-0.3, 0.6]],
        [[0.7, -0.2], [0.1, 0.9]],
        [[0.3, 0.0], [0.2, 0.4]],
    ]
    changepoints = np.array([200, 400, 600])
    N = T - 1
    A = np.empty((N, 2, 2))
    for j, (a, b) in enumerate(itertools.pairwise([0, *changepoints, N])):
        A[a:b] = As[j]
    B = np.array([[0.5], [1.0]])
    u = rng.standard_normal((T, 1))
    x = np.zeros((T, 2))
    for t in range(N):
        x[t + 1] = A[t] @ x[t] + B @ u[t] + noise * rng.standard_normal(2)
    k = np.concatenate([A, np.broadcast_to(B, (N, 2, 1))], axis=2).reshape(N, 6)
    return x, u, k, changepoints


def test_three_switches_from_the_true_coefficients():
    _, _, k, changepoints = three_switch_system(0)
    np.testing.assert_array_equal(ltv.find_changepoints(activation_of(k, 1)), changepoints)


def test_three_switches_from_a_squared_norm_fit():
    # The squared-norm activation is a wide, noisy bump per switch: with the number
    # of switches known, take the three largest peaks at least 20 samples apart.
    x, u, _, changepoints = three_switch_system(0)
    model = ltv.fit(x, u, lam=30.0)
    found = ltv.find_changepoints(model, noise_factor=None, min_distance=20, max_changes=3)
    assert found.shape == (3,)
    assert np.abs(found - changepoints).max() <= 3


def test_two_step_refinement_with_the_group_norm():
    """Paper III-G: group-lasso fit → change points → piecewise-constant refit."""
    x, u, k, changepoints = three_switch_system(3)
    first = ltv.fit(x, u, lam=30.0, norm="group")
    found = ltv.find_changepoints(first)
    assert found.shape == (3,)
    assert np.abs(found - changepoints).max() <= 3
    refit = ltv.fit_piecewise(x, u, found)
    segments = np.r_[0, changepoints, len(k)]
    inner = np.concatenate([np.arange(a + 5, b - 5) for a, b in itertools.pairwise(segments)])
    assert np.abs(refit.k[inner] - k[inner]).max() < 0.1
    assert np.abs(refit.k[inner] - k[inner]).mean() < np.abs(first.k[inner] - k[inner]).mean()


# -- change points on the data's axis ---------------------------------------------------


def ar2_series_with_a_change(sample: int, T: int = 300, seed: int = 0) -> np.ndarray:
    """y[t] = a1 y[t−1] + a2 y[t−2] + e[t]: (1.5, −0.9) before ``sample``, (0.4, 0.3) from
    it on (y[sample] is the first sample the new coefficients produce)."""
    rng = np.random.default_rng(seed)
    y = np.zeros(T)
    for t in range(2, T):
        a1, a2 = (1.5, -0.9) if t < sample else (0.4, 0.3)
        y[t] = a1 * y[t - 1] + a2 * y[t - 2] + rng.standard_normal()
    return y


def test_an_ar_change_is_reported_at_its_sample_and_date():
    """The change of an AR(2) model at sample s is model step s − 2 (its row), reported
    at sample s and, for a dated series, at the date of sample s."""
    pd = pytest.importorskip("pandas")
    s = 150
    y = ar2_series_with_a_change(s)
    found = ltv.find_changepoints(ltv.fit_ar(y, 2, lam=100.0, norm="group"))
    assert found.tolist() == [s - 2]  # the model's steps, as before (fit_piecewise's index)
    assert found.sample_indices.tolist() == [s] and found.times is None
    days = pd.date_range("2020-01-01", periods=y.size, freq="D")
    model = ltv.fit_ar(pd.Series(y, index=days), 2, lam=100.0, norm="group")
    found = ltv.find_changepoints(model)
    assert found.sample_indices.tolist() == [s]
    np.testing.assert_array_equal(found.times, days[[s]].to_numpy())
    assert str(found.times[0])[:10] == "2020-05-30"
    np.testing.assert_array_equal(found.times, model.changepoint_times)  # one convention


def test_changepoints_on_the_axis_of_each_kind_of_model():
    """The first observation produced under new coefficients: y[lag + c] of an ARX model,
    y[c] of a regression, x[c + 1] of a state-space model (exact coefficients)."""
    k = np.repeat([[0.5, 1.0], [-0.3, 1.0]], [40, 60], axis=0)  # a jump at step 40
    arx = ltv.ARXModel(k, n_outputs=1, n_inputs=1, na=1, nb=1, nk=3, constant=False)
    assert arx.lag == 3
    found = ltv.find_changepoints(arx)
    assert found.tolist() == [40] and found.sample_indices.tolist() == [43]
    regression = ltv.RegressionModel(k, n_outputs=1, n_regressors=2)
    assert ltv.find_changepoints(regression).sample_indices.tolist() == [40]
    data = ltv.systems.jump_linear(seed=0)
    model = ltv.fit(data.x, data.u, lam=30.0, norm="group")
    found = ltv.find_changepoints(model)
    np.testing.assert_array_equal(found.sample_indices, found.changepoints + 1)


def test_changepoints_stay_an_integer_array_of_steps():
    """Code written for the plain array keeps working: indexing, arithmetic (plain results),
    fit_piecewise, pickling (with the axis)."""
    import pickle

    k = np.repeat([[0.5, 0.1], [-0.3, 0.1]], [40, 60], axis=0)
    found = ltv.find_changepoints(ltv.ARModel(k, n_outputs=1, na=2, constant=False))
    assert isinstance(found, np.ndarray) and found.dtype == np.int64
    assert type(found + 1) is np.ndarray and (found + 1).tolist() == [41]
    assert type(found == 40) is np.ndarray and int(found[0]) == 40
    assert found[:1].sample_indices.tolist() == [42]
    again = pickle.loads(pickle.dumps(found))
    assert again.tolist() == [40] and again.sample_indices.tolist() == [42]
    assert type(found.changepoints) is np.ndarray
    assert "sample_indices=[42]" in repr(found)
    empty = ltv.find_changepoints(ltv.ARModel(k, n_outputs=1, na=2, constant=False), max_changes=0)
    assert empty.sample_indices.tolist() == []
    # An activation has no data axis: a plain array of steps, as before.
    assert type(ltv.find_changepoints(spikes(100, {49: 1.0}))) is np.ndarray


# -- bad input ------------------------------------------------------------------------------


ACT = r"^model_or_activation: "
BAD = [
    ("none", dict(model_or_activation=None), TypeError, ACT),
    ("text", dict(model_or_activation="abc"), TypeError, ACT),
    ("2d", dict(model_or_activation=np.ones((5, 2))), ValueError, ACT + r".*1-d"),
    ("negative", dict(model_or_activation=[0.0, -1.0]), ValueError, ACT + "expected nonnegative"),
    ("nan", dict(model_or_activation=[0.0, np.nan]), ValueError, ACT + "expected finite"),
    ("threshold-negative", dict(threshold=-0.1), ValueError, r"^threshold:"),
    ("threshold-large", dict(threshold=1.5), ValueError, r"^threshold: expected a number in \["),
    ("threshold-text", dict(threshold="0.2"), TypeError, r"^threshold:"),
    ("threshold-nan", dict(threshold=np.nan), ValueError, r"^threshold:"),
    ("noise-negative", dict(noise_factor=-1.0), ValueError, r"^noise_factor:"),
    ("noise-inf", dict(noise_factor=np.inf), ValueError, r"^noise_factor:"),
    ("distance-zero", dict(min_distance=0), ValueError, r"^min_distance: expected an integer >= 1"),
    ("distance-float", dict(min_distance=2.5), ValueError, r"^min_distance:"),
    ("max-negative", dict(max_changes=-1), ValueError, r"^max_changes: expected an integer >= 0"),
    ("max-bool", dict(max_changes=True), ValueError, r"^max_changes:"),
    ("degree-zero", dict(degree=0), ValueError, r"^degree: expected an integer >= 1"),
]


@pytest.mark.parametrize("case,kwargs,exc,match", BAD, ids=[b[0] for b in BAD])
def test_bad_input_raises_naming_the_argument(case, kwargs, exc, match):
    arguments = dict(model_or_activation=spikes(50, {20: 1.0}))
    arguments.update(kwargs)
    activation = arguments.pop("model_or_activation")
    with pytest.raises(exc, match=match):
        ltv.find_changepoints(activation, **arguments)


def test_the_activation_is_not_modified():
    a = spikes(60, {20: 1.0})
    before = a.copy()
    ltv.find_changepoints(a.tolist())
    ltv.find_changepoints(a)
    np.testing.assert_array_equal(a, before)
