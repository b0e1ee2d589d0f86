"""Models as python-control systems and from known matrices: ``LTVModel.to_statespace``,
``LTVModel.from_arrays``.

``to_statespace`` is checked against the model's own matrices and, through
python-control itself, against the model's simulation (forced responses,
poles); ``from_arrays`` by round trips: the coefficients of a fitted model give
the same simulation, predictions, forecasts and files.
"""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

import ltvmodels as ltv

LAM = 10.0


@pytest.fixture(scope="module")
def data():
    return ltv.systems.jump_linear(seed=0)  # N = 399, n = 2, m = 1; A jumps at t = 200


@pytest.fixture(scope="module")
def fitted(data):
    return ltv.fit(data.x, data.u, lam=LAM)


@pytest.fixture(scope="module")
def control():
    # tests/control/ (no __init__.py) is importable as a namespace package named
    # "control" when tests/ is on sys.path; only the real python-control has statesp.
    pytest.importorskip("control.statesp")
    import control

    return control


def _simulate_statespace(systems, x0, u):
    """x[k+1] = A x[k] + B u[k] with the matrices of one python-control system per step."""
    x = [np.asarray(x0, dtype=float)]
    for k, sys_k in enumerate(systems):
        x.append(sys_k.A @ x[-1] + sys_k.B @ u[k])
    return np.array(x)


# -- to_statespace: the matrices ---------------------------------------------------------------


@pytest.mark.parametrize("t", [0, 1, 199, 200, 398, -1, -2, -199, -399])
def test_matrices_are_the_model_at_step_t(control, fitted, t):
    sys_t = fitted.to_statespace(t)
    assert isinstance(sys_t, control.StateSpace)
    np.testing.assert_array_equal(sys_t.A, fitted.A[t])
    np.testing.assert_array_equal(sys_t.B, fitted.B[t])
    np.testing.assert_array_equal(sys_t.C, np.eye(2))
    np.testing.assert_array_equal(sys_t.D, np.zeros((2, 1)))
    assert sys_t.dt == 1
    assert sys_t.isdtime(strict=True)
    assert sys_t.name == f"ltv_t{t % fitted.N}"


def test_default_step_is_the_last(control, fitted):
    np.testing.assert_array_equal(fitted.to_statespace().A, fitted.A[-1])
    np.testing.assert_array_equal(fitted.to_statespace().A, fitted.to_statespace(398).A)


def test_signal_labels_are_the_model_names(control, fitted):
    sys_t = fitted.to_statespace(5)
    assert sys_t.input_labels == ["u0"]
    assert sys_t.state_labels == ["x0", "x1"]
    assert sys_t.output_labels == ["x0", "x1"]
    assert (sys_t.ninputs, sys_t.noutputs, sys_t.nstates) == (1, 2, 2)


@pytest.mark.parametrize("dt", [0.01, 0.5, 2, 3.0, np.float32(0.25)])
def test_sampling_period(control, fitted, dt):
    sys_t = fitted.to_statespace(0, dt=dt)
    assert sys_t.dt == pytest.approx(float(dt))
    np.testing.assert_array_equal(sys_t.A, fitted.A[0])  # dt does not change the matrices


def test_system_is_a_copy(control, fitted):
    sys_t = fitted.to_statespace(10)
    sys_t.A[0, 0] += 1.0
    assert fitted.A[10, 0, 0] != sys_t.A[0, 0]
    np.testing.assert_array_equal(fitted.to_statespace(10).A, fitted.A[10])


# -- to_statespace: python-control agrees with the model ---------------------------------------


@pytest.mark.parametrize("t", [0, 100, 250, -1])
def test_poles_are_the_eigenvalues_of_A_t(control, fitted, t):
    poles = np.sort_complex(np.asarray(fitted.to_statespace(t).poles(), dtype=complex))
    eig = np.sort_complex(np.linalg.eigvals(fitted.A[t]).astype(complex))
    np.testing.assert_allclose(poles, eig, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("t", [0, 200, -1])
def test_forced_response_equals_the_simulation_of_a_constant_segment(control, fitted, t):
    # the model frozen at step t for 30 steps: python-control's forced response
    # of to_statespace(t) is the model's simulation
    frozen = ltv.LTVModel.from_arrays(fitted.A[t], fitted.B[t], steps=30)
    u = np.random.default_rng(1).standard_normal((31, 1))
    x0 = np.array([0.5, -1.0])
    response = control.forced_response(fitted.to_statespace(t), T=np.arange(31), U=u.T, X0=x0)
    np.testing.assert_allclose(response.states.T, frozen.simulate(x0, u), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        response.outputs.T, frozen.simulate(x0, u), rtol=1e-12, atol=1e-12
    )  # C = I: the outputs are the states


def test_stepping_the_systems_equals_the_simulation(control, fitted, data):
    systems = [fitted.to_statespace(t) for t in range(fitted.N)]
    x0 = data.x[0]
    np.testing.assert_allclose(
        _simulate_statespace(systems, x0, data.u),
        fitted.simulate(x0, data.u),
        rtol=1e-12,
        atol=1e-12,
    )


def test_intercept_is_a_last_input_held_at_one(control, data):
    model = ltv.fit(data.x, data.u, lam=LAM, constant=True)
    sys_t = model.to_statespace(7)
    assert sys_t.input_labels == ["u0", "const"]
    np.testing.assert_array_equal(sys_t.B, np.column_stack([model.B[7], model.c[7]]))
    np.testing.assert_array_equal(sys_t.D, np.zeros((2, 2)))
    systems = [model.to_statespace(t) for t in range(model.N)]
    augmented = np.column_stack([data.u, np.ones(len(data.u))])
    np.testing.assert_allclose(
        _simulate_statespace(systems, data.x[0], augmented),
        model.simulate(data.x[0], data.u),
        rtol=1e-12,
        atol=1e-12,
    )
    frozen = ltv.LTVModel.from_arrays(model.A[7], model.B[7], c=model.c[7], steps=20)
    response = control.forced_response(sys_t, T=np.arange(21), U=augmented[:21].T, X0=data.x[0])
    np.testing.assert_allclose(
        response.states.T, frozen.simulate(data.x[0], data.u[:21]), rtol=1e-12, atol=1e-12
    )


def test_labels_are_the_data_column_names(control, data):
    pd = pytest.importorskip("pandas")
    x = pd.DataFrame(data.x, columns=["pos", "vel"])
    u = pd.DataFrame(data.u, columns=["const"])  # the intercept's label gives way
    model = ltv.fit(x, u, lam=LAM, constant=True)
    sys_t = model.to_statespace()
    assert sys_t.state_labels == sys_t.output_labels == ["pos", "vel"]
    assert sys_t.input_labels == ["const", "const_"]


@pytest.mark.parametrize(
    "states, inputs, state_labels, input_labels",
    [
        (["pos.x", "pos.y"], ["f.x"], ["pos_x", "pos_y"], ["f_x", "const"]),
        ([1.5, 2.5], [0.5], ["1_5", "2_5"], ["0_5", "const"]),
        (["p.v", "p_v"], ["const"], ["p_v", "p_v_"], ["const", "const_"]),
    ],
)
def test_names_python_control_cannot_take_are_exported_as_valid_labels(
    control, data, states, inputs, state_labels, input_labels
):
    # A "." in a name (a float column name has one) made python-control raise
    # "invalid signal name"; the model keeps its own names.
    pd = pytest.importorskip("pandas")
    x = pd.DataFrame(data.x, columns=states)
    u = pd.DataFrame(data.u, columns=inputs)
    model = ltv.fit(x, u, lam=LAM, constant=True)
    sys_t = model.to_statespace()
    assert sys_t.state_labels == sys_t.output_labels == state_labels
    assert sys_t.input_labels == input_labels
    assert model.state_names == [str(name) for name in states]
    np.testing.assert_array_equal(sys_t.A, model.A[-1])


def test_repeated_column_names_are_an_error_when_the_data_are_read(data):
    # ['p', 'p'] gave a system of 2 states labelled ['p'] (python-control keeps one
    # signal per name), and an AttributeError for a table with a text column.
    pd = pytest.importorskip("pandas")
    with pytest.raises(
        ValueError, match=r"^x: column 'p' appears twice \(columns 0 and 1\); rename one"
    ):
        ltv.fit(pd.DataFrame(data.x, columns=["p", "p"]), data.u, lam=LAM)
    with pytest.raises(ValueError, match=r"^u: column '1' appears twice \(columns 0 and 1\)"):
        ltv.fit(data.x, pd.DataFrame(np.c_[data.u, data.u], columns=[1, "1"]), lam=LAM)


@pytest.mark.parametrize("time", [np.arange(400)[::-1] * 1.0, np.full(400, 3.0)])
def test_a_time_index_that_does_not_increase_gives_no_sampling_period(control, fitted, time):
    # Set by hand (a fit checks the time order): the step is no sampling period.
    model = fitted.with_data(ltv.DataDescription.of(time=time))
    with pytest.raises(ValueError, match=r"^dt: the model's time index .* does not increase"):
        model.to_statespace()
    assert model.to_statespace(dt=0.5).dt == 0.5
    one_sample = fitted.with_data(ltv.DataDescription.of(time=np.array([2.0])))
    assert one_sample.to_statespace().dt == 1


def test_model_without_inputs_gives_a_system_without_inputs(control, data):
    model = ltv.fit(data.x, None, lam=LAM)
    sys_t = model.to_statespace(-1)
    assert sys_t.ninputs == 0 and sys_t.input_labels == []
    assert sys_t.B.shape == (2, 0) and sys_t.D.shape == (2, 0)
    np.testing.assert_array_equal(sys_t.A, model.A[-1])
    frozen = ltv.LTVModel.from_arrays(model.A[-1], steps=10)
    response = control.forced_response(sys_t, T=np.arange(11), X0=[1.0, 2.0])
    np.testing.assert_allclose(
        response.states.T, frozen.simulate([1.0, 2.0]), rtol=1e-12, atol=1e-12
    )


def test_model_with_only_an_intercept_has_one_input(control, data):
    model = ltv.fit(data.x, None, lam=LAM, constant=True)
    sys_t = model.to_statespace(0)
    assert sys_t.input_labels == ["const"]
    np.testing.assert_array_equal(sys_t.B, model.c[0][:, None])


# -- to_statespace: errors ---------------------------------------------------------------------


@pytest.mark.parametrize("t", [399, 1000, -400])
def test_step_out_of_range(fitted, t):
    with pytest.raises(
        ValueError,
        match=r"^t: expected a model step in \[-399, 398\].*N = 399.*"
        rf"received {t}$",
    ):
        fitted.to_statespace(t)


@pytest.mark.parametrize("t", [1.0, 1.5, True, "1", None, [1]])
def test_step_not_an_integer(fitted, t):
    with pytest.raises(TypeError, match=r"^t: expected an integer model step in \[-399, 398\]"):
        fitted.to_statespace(t)


def test_numpy_integer_steps(control, fitted):
    np.testing.assert_array_equal(fitted.to_statespace(np.int64(-3)).A, fitted.A[-3])
    np.testing.assert_array_equal(fitted.to_statespace(np.uint8(3)).A, fitted.A[3])


@pytest.mark.parametrize(
    "dt, error",
    [
        (0, ValueError),
        (-1.0, ValueError),
        (np.nan, ValueError),
        (np.inf, ValueError),
        ("1", TypeError),
        (True, TypeError),
    ],
)
def test_invalid_sampling_period(fitted, dt, error):
    with pytest.raises(error, match="^dt: expected"):
        fitted.to_statespace(dt=dt)


def test_dt_is_keyword_only(fitted):
    with pytest.raises(TypeError):
        fitted.to_statespace(0, 1.0)


@pytest.mark.parametrize(
    "module", [None, types.ModuleType("control")], ids=["not-installed", "not-python-control"]
)
def test_missing_python_control_says_how_to_install_it(fitted, monkeypatch, module):
    monkeypatch.setitem(sys.modules, "control", module)
    with pytest.raises(ImportError, match=r"pip install 'ltvmodels\[control\]'"):
        fitted.to_statespace()


def test_arguments_are_checked_before_the_import(fitted, monkeypatch):
    monkeypatch.setitem(sys.modules, "control", None)
    with pytest.raises(ValueError, match="^t: "):
        fitted.to_statespace(400)


# -- from_arrays: round trips ------------------------------------------------------------------


def test_coefficients_of_a_fitted_model_give_the_same_model(fitted, data):
    given = ltv.LTVModel.from_arrays(fitted.A, fitted.B)
    assert isinstance(given, ltv.LTVModel)
    np.testing.assert_array_equal(given.k, fitted.k)
    assert (given.N, given.n_states, given.n_inputs, given.constant) == (399, 2, 1, False)
    np.testing.assert_array_equal(
        given.simulate(data.x[0], data.u), fitted.simulate(data.x[0], data.u)
    )
    np.testing.assert_array_equal(given.predict(data.x, data.u), fitted.predict(data.x, data.u))
    batch = np.stack([data.x[0], -data.x[0]])
    np.testing.assert_array_equal(given.simulate(batch, data.u), fitted.simulate(batch, data.u))


def test_given_model_records_no_fit(fitted):
    given = ltv.LTVModel.from_arrays(fitted.A, fitted.B)
    for name in ("norm", "lam", "cov", "noise_var", "noise_cov", "loglik", "status", "coeffs"):
        assert getattr(given, name) is None, name
    assert given.info == {}
    assert given.std() is None
    assert "norm=None" in repr(given)


def test_given_arrays_are_copied(fitted):
    A, B = np.array(fitted.A), np.array(fitted.B)
    given = ltv.LTVModel.from_arrays(A, B)
    A[:] = 0.0
    B[:] = 0.0
    np.testing.assert_array_equal(given.A, fitted.A)
    np.testing.assert_array_equal(given.B, fitted.B)


def test_intercept_round_trip(data):
    model = ltv.fit(data.x, data.u, lam=LAM, constant=True)
    given = ltv.LTVModel.from_arrays(model.A, model.B, c=model.c)
    assert given.constant
    np.testing.assert_array_equal(given.k, model.k)
    np.testing.assert_array_equal(
        given.simulate(data.x[0], data.u), model.simulate(data.x[0], data.u)
    )


def test_zero_intercept_still_makes_a_constant_model():
    given = ltv.LTVModel.from_arrays(np.eye(2) * 0.5, c=np.zeros(2), steps=3)
    assert given.constant and given.n_inputs == 0
    np.testing.assert_array_equal(given.c, np.zeros((3, 2)))


def test_one_matrix_repeated_over_steps():
    A = [[0.9, 0.1], [0.0, 0.8]]
    B = [[0.0], [1.0]]
    c = [0.1, -0.2]
    given = ltv.LTVModel.from_arrays(A, B, c=c, steps=5)
    assert given.N == 5
    np.testing.assert_array_equal(given.A, np.broadcast_to(A, (5, 2, 2)))
    np.testing.assert_array_equal(given.B, np.broadcast_to(B, (5, 2, 1)))
    np.testing.assert_array_equal(given.c, np.broadcast_to(c, (5, 2)))
    u = np.arange(6.0)
    x = given.simulate([1.0, 1.0], u)
    expected = [np.array([1.0, 1.0])]
    for t in range(5):
        expected.append(np.asarray(A) @ expected[-1] + np.asarray(B)[:, 0] * u[t] + c)
    np.testing.assert_allclose(x, expected, rtol=1e-14)


def test_time_varying_A_with_constant_B():
    A = np.stack([np.eye(2) * a for a in (0.1, 0.2, 0.3)])
    given = ltv.LTVModel.from_arrays(A, [[1.0], [2.0]], steps=3)
    np.testing.assert_array_equal(given.A, A)
    np.testing.assert_array_equal(given.B[2], [[1.0], [2.0]])


def test_model_without_inputs(data):
    given = ltv.LTVModel.from_arrays(data.A)
    assert given.n_inputs == 0 and given.B.shape == (399, 2, 0)
    x = given.simulate(data.x[0])
    assert x.shape == (400, 2)
    np.testing.assert_allclose(x[1], data.A[0] @ data.x[0])


def test_save_and_load_keep_the_model(fitted, data, tmp_path):
    given = ltv.LTVModel.from_arrays(
        fitted.A, fitted.B, c=np.full(2, 0.01), noise_cov=[[0.04, 0.01], [0.01, 0.09]], order=2
    )
    path = tmp_path / "given.npz"
    given.save(path)
    loaded = ltv.load(path)
    assert type(loaded) is ltv.LTVModel
    np.testing.assert_array_equal(loaded.k, given.k)
    assert (loaded.n_states, loaded.n_inputs, loaded.constant) == (2, 1, True)
    np.testing.assert_array_equal(loaded.noise_cov, given.noise_cov)
    np.testing.assert_array_equal(loaded.noise_var, [0.04, 0.09])
    np.testing.assert_array_equal(loaded.coeffs, [1.0, -2.0, 1.0])
    for name in ("norm", "lam", "cov", "loglik", "status"):
        assert getattr(loaded, name) is None, name
    np.testing.assert_array_equal(
        loaded.simulate(data.x[0], data.u), given.simulate(data.x[0], data.u)
    )
    u_future = np.ones((4, 1))
    a, b = loaded.forecast(data.x[-1], u_future), given.forecast(data.x[-1], u_future)
    np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(a.cov, b.cov)


def test_save_and_load_a_model_of_one_step(tmp_path):
    given = ltv.LTVModel.from_arrays([[0.5]], steps=1)
    given.save(tmp_path / "one.npz")
    loaded = ltv.load(tmp_path / "one.npz")
    np.testing.assert_array_equal(loaded.k, [[0.5]])
    assert loaded.n_inputs == 0


# -- from_arrays: forecasts, priors, plots -----------------------------------------------------


def test_forecast_needs_a_noise_covariance(fitted, data):
    given = ltv.LTVModel.from_arrays(fitted.A, fitted.B)
    with pytest.raises(ValueError, match="^noise_cov: the model has no noise covariance"):
        given.forecast(data.x[-1], np.ones((3, 1)))
    stored = ltv.LTVModel.from_arrays(fitted.A, fitted.B, noise_cov=0.04)
    passed = given.forecast(data.x[-1], np.ones((3, 1)), noise_cov=0.04)
    np.testing.assert_array_equal(stored.forecast(data.x[-1], np.ones((3, 1))).cov, passed.cov)


def test_forecast_of_known_coefficients_is_exact(fitted, data):
    noise = np.array([0.04, 0.09])
    given = ltv.LTVModel.from_arrays(fitted.A, fitted.B, noise_cov=noise)
    np.testing.assert_array_equal(given.noise_cov, np.diag(noise))
    u_future = np.random.default_rng(3).standard_normal((6, 1))
    forecast = given.forecast(data.x[-1], u_future)
    assert forecast.method == "gaussian"  # no coefficient uncertainty, nothing sampled
    # the mean is the noise-free simulation with the last coefficients (order 1: constant)
    frozen = ltv.LTVModel.from_arrays(fitted.A[-1], fitted.B[-1], steps=6)
    np.testing.assert_allclose(
        forecast.mean, frozen.simulate(data.x[-1], u_future)[1:], rtol=1e-12, atol=1e-12
    )
    # covariance: P_{j+1} = A P_j Aᵀ + Q, P_0 = Q
    A, Q = fitted.A[-1], np.diag(noise)
    P = Q.copy()
    for j in range(6):
        np.testing.assert_allclose(forecast.cov[j], P, rtol=1e-12, atol=1e-15)
        P = A @ P @ A.T + Q


def test_order_two_continues_the_straight_line():
    A = np.stack([np.eye(1) * (0.1 + 0.01 * t) for t in range(10)])
    given = ltv.LTVModel.from_arrays(A, noise_cov=1e-4, order=2)
    forecast = given.forecast([1.0], steps=3)
    np.testing.assert_allclose(forecast.coefficients[:, 0, 0], [0.20, 0.21, 0.22], rtol=1e-12)
    constant = ltv.LTVModel.from_arrays(A, noise_cov=1e-4)  # default: the first difference
    np.testing.assert_allclose(constant.forecast([1.0], steps=3).coefficients[:, 0, 0], 0.19)
    np.testing.assert_allclose(given.activation(), 0.0, atol=1e-15)  # linear: D²k = 0
    np.testing.assert_allclose(constant.activation(), 0.01, rtol=1e-10)


def test_prior_mean(data):
    truth = ltv.LTVModel.from_arrays(data.A, data.B)
    prior = ltv.Prior(mean=truth, cov=1e-10)
    np.testing.assert_array_equal(prior.mean, truth.k)
    free = ltv.fit(data.x, data.u, lam=LAM)
    pinned = ltv.fit(data.x, data.u, lam=LAM, prior=prior)
    assert np.abs(free.k - truth.k).max() > 0.05
    np.testing.assert_allclose(pinned.k, truth.k, atol=1e-4)


def test_plot(fitted):
    pytest.importorskip("matplotlib")
    fig = ltv.LTVModel.from_arrays(fitted.A, fitted.B).plot(truth=fitted)
    assert len(fig.axes) == 6
    titles = [ax.get_title() for ax in fig.axes]
    assert titles == [ax.get_title() for ax in fitted.plot().axes]
    for ax, k_j in zip(fig.axes, fitted.k.T):
        assert any(np.array_equal(line.get_ydata(), k_j) for line in ax.lines)


# -- from_arrays: errors -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "A, match",
    [
        (np.ones(3), r"^A: expected shape \(N, n, n\) or \(n, n\).*received shape \(3,\)"),
        (np.ones((2, 3)), r"^A: expected shape \(N, n, n\).*received shape \(2, 3\)"),
        (np.ones((4, 2, 3)), r"^A: expected shape \(N, n, n\).*received shape \(4, 2, 3\)"),
        (np.ones((1, 1, 2, 2)), r"^A: expected shape \(N, n, n\)"),
        (np.ones((4, 0, 0)), r"^A: expected shape \(N, n, n\) or \(n, n\) with n >= 1"),
        (np.ones((0, 2, 2)), r"^A: expected at least one time step, received shape \(0, 2, 2\)"),
        (np.array([[np.nan, 0], [0, 1]]), r"^A: expected finite values, received NaN or inf"),
        (np.array([[np.inf, 0], [0, 1]]), r"^A: expected finite values, received NaN or inf"),
        (np.array([[1e101, 0], [0, 1]]), r"^A: expected finite values of magnitude up to 1e\+100"),
    ],
)
def test_invalid_A(A, match):
    with pytest.raises(ValueError, match=match):
        ltv.LTVModel.from_arrays(A, steps=4)


@pytest.mark.parametrize("A", ["abc", [[1, 2], [3]], [[1j, 0], [0, 1]], None])
def test_A_not_numbers(A):
    with pytest.raises(TypeError, match="^A: expected"):
        ltv.LTVModel.from_arrays(A, steps=2)


def test_steps():
    with pytest.raises(ValueError, match=r"^steps: required when A is one \(2, 2\) matrix"):
        ltv.LTVModel.from_arrays(np.eye(2))
    with pytest.raises(ValueError, match=r"^steps: expected None or 3 \(the length of A"):
        ltv.LTVModel.from_arrays(np.ones((3, 2, 2)), steps=4)
    assert ltv.LTVModel.from_arrays(np.ones((3, 2, 2)), steps=3).N == 3
    for steps in (0, -1, 2.0, True):
        with pytest.raises(ValueError, match="^steps: expected an integer >= 1"):
            ltv.LTVModel.from_arrays(np.eye(2), steps=steps)


def test_steps_beyond_the_memory_are_an_error_before_allocating():
    # numpy was asked for 29.1 TiB (a MemoryError about an array nobody named).
    with pytest.raises(
        ValueError,
        match=r"^steps: expected at most \d+ \(what fits in this machine's .* of memory\), "
        r"received 1000000000000: the coefficients of 1000000000000 steps \(4 numbers each\) "
        r"would need 29.1 TiB; pass fewer steps$",
    ):
        ltv.LTVModel.from_arrays(np.eye(2), steps=10**12)


def test_the_bound_of_steps_is_the_physical_memory(monkeypatch):
    from ltvmodels.validation import memory

    monkeypatch.setattr(memory, "physical_memory", lambda: 1000)  # bytes
    # n = 2, m = 1 and c: K = 2·(2 + 1 + 1) = 8 numbers, 64 bytes a step
    assert ltv.LTVModel.from_arrays(np.eye(2), np.ones((2, 1)), c=np.ones(2), steps=15).N == 15
    with pytest.raises(ValueError, match=r"^steps: expected at most 15 .* received 16: .* 1.0 KiB"):
        ltv.LTVModel.from_arrays(np.eye(2), np.ones((2, 1)), c=np.ones(2), steps=16)


def test_the_physical_memory_and_its_text():
    from ltvmodels.validation import memory

    assert memory.physical_memory() >= 2**20  # a real machine's, in bytes
    texts = [memory.size_text(n) for n in (512, 1536, 2**30, 32 * 10**12)]
    assert texts == ["512 B", "1.5 KiB", "1.0 GiB", "29.1 TiB"]


@pytest.mark.parametrize(
    "B, match",
    [
        (np.ones((3, 1)), r"^B: expected shape \(5, 2, m\) or \(2, m\) .*received shape \(3, 1\)"),
        (np.ones(2), r"^B: expected shape \(5, 2, m\) or \(2, m\)"),
        (np.ones((4, 2, 1)), r"^B: expected shape \(5, 2, m\).*received shape \(4, 2, 1\)"),
        (np.ones((5, 3, 1)), r"^B: expected shape \(5, 2, m\)"),
        (np.full((2, 1), np.nan), r"^B: expected finite values"),
        (np.full((2, 1), 1e200), r"^B: expected finite values of magnitude up to 1e\+100"),
    ],
)
def test_invalid_B(B, match):
    with pytest.raises(ValueError, match=match):
        ltv.LTVModel.from_arrays(np.ones((5, 2, 2)), B)


def test_B_without_columns_is_a_model_without_inputs():
    given = ltv.LTVModel.from_arrays(np.ones((5, 2, 2)), np.ones((2, 0)))
    assert given.n_inputs == 0


@pytest.mark.parametrize(
    "c, match",
    [
        (np.ones(3), r"^c: expected shape \(5, 2\) or \(2,\) .*received shape \(3,\)"),
        (np.ones((4, 2)), r"^c: expected shape \(5, 2\) or \(2,\)"),
        (np.ones((5, 2, 1)), r"^c: expected shape \(5, 2\) or \(2,\)"),
        (np.array([0.0, np.inf]), r"^c: expected finite values"),
    ],
)
def test_invalid_c(c, match):
    with pytest.raises(ValueError, match=match):
        ltv.LTVModel.from_arrays(np.ones((5, 2, 2)), c=c)


@pytest.mark.parametrize(
    "noise_cov, match",
    [
        (np.ones(3), r"^noise_cov: expected a \(2, 2\) covariance matrix"),
        ([[1.0, 0.5], [0.0, 1.0]], r"^noise_cov: expected a symmetric matrix"),
        ([[1.0, 2.0], [2.0, 1.0]], r"^noise_cov: expected a positive semidefinite matrix"),
        (np.nan, r"^noise_cov: expected finite values"),
    ],
)
def test_invalid_noise_cov(noise_cov, match):
    with pytest.raises(ValueError, match=match):
        ltv.LTVModel.from_arrays(np.ones((5, 2, 2)), noise_cov=noise_cov)


@pytest.mark.parametrize(
    "order, error, match",
    [
        (0, ValueError, r"^order: expected an integer >= 1"),
        (5, ValueError, r"^order: expected a degree of at most 4"),
        ([1.0, 1.0], ValueError, r"^order: polynomial coefficients must sum to zero"),
        ([-1.0, 0.0, 0.0, 0.0, 0.0, 1.0], ValueError, r"^order: expected at most 5 coefficients"),
        (1.5, TypeError, r"^order: expected an integer >= 1 or a sequence"),
    ],
)
def test_invalid_order(order, error, match):
    with pytest.raises(error, match=match):
        ltv.LTVModel.from_arrays(np.ones((5, 2, 2)), order=order)


def test_arguments_after_B_are_keyword_only():
    with pytest.raises(TypeError):
        ltv.LTVModel.from_arrays(np.ones((5, 2, 2)), None, np.ones(2))
