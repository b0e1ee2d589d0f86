"""Inputs that used to give a silent wrong result or a foreign exception."""

from __future__ import annotations

import numpy as np
import pytest

import ltvmodels as ltv


@pytest.fixture(scope="module")
def data():
    d = ltv.systems.jump_linear(T=120, change_at=60, seed=0)
    return d.x, d.u


def test_masked_entries_are_missing_samples(data):
    x, u = data
    spoiled = x.copy()
    spoiled[50, 0] = 999.0
    masked = np.ma.masked_array(spoiled, mask=np.zeros_like(spoiled, dtype=bool))
    masked.mask[50, 0] = True
    with_nan = x.copy()
    with_nan[50, 0] = np.nan
    np.testing.assert_array_equal(ltv.fit(masked, u, lam=5.0).k, ltv.fit(with_nan, u, lam=5.0).k)
    seg = ltv.fit_segments(masked, u, n_changes=1)
    np.testing.assert_array_equal(
        seg.changepoints, ltv.fit_segments(with_nan, u, n_changes=1).changepoints
    )
    y = np.ma.masked_array(spoiled[:, 0], mask=masked.mask[:, 0])
    ar_masked, ar_nan = ltv.fit_ar(y, 2, lam=10.0), ltv.fit_ar(with_nan[:, 0], 2, lam=10.0)
    np.testing.assert_array_equal(ar_masked.k, ar_nan.k)


def test_masked_entries_where_nothing_can_be_missing(data):
    x, u = data
    lam = np.ma.masked_array(np.ones(6), mask=[1, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"^lam: received a masked array"):
        ltv.fit(x, u, lam=lam)
    mean = np.ma.masked_array(np.zeros(6), mask=[1, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"^mean: received a masked array"):
        ltv.Prior(mean, 1.0)
    # an array without masked entries is just its data
    plain = np.ma.masked_array(np.zeros(6))
    assert np.array_equal(ltv.Prior(plain, 1.0).mean, np.zeros(6))


@pytest.mark.parametrize("lam", [1e200, 1e300])
def test_lam_whose_square_overflows_is_an_error_not_inf(data, lam):
    x, u = data
    with pytest.raises(ValueError, match=r"^lam: expected a finite λ below .*lam=np.inf"):
        ltv.fit(x, u, lam=lam)
    vector = np.full(6, 1.0)
    vector[2] = lam
    with pytest.raises(ValueError, match=r"^lam: expected a finite λ below"):
        ltv.fit(x, u, lam=vector)
    # a huge λ whose square is finite gets the precision message that names lam=np.inf
    with pytest.raises(ltv.SingularProblemError, match=r"lam is too large .* lam=np.inf"):
        ltv.fit(x, u, lam=1e150)


def test_save_takes_paths_only(data, tmp_path):
    x, u = data
    model = ltv.fit(x, u, lam=5.0)
    with open(tmp_path / "m.npz", "wb") as fh:
        with pytest.raises(TypeError, match=r"^path: expected a file path"):
            model.save(fh.fileno())
        with pytest.raises(TypeError, match=r"^path: expected a file path"):
            model.save(fh)
    assert (tmp_path / "m.npz").stat().st_size == 0
    model.save(tmp_path / "ok.npz")
    np.testing.assert_array_equal(ltv.load(tmp_path / "ok.npz").k, model.k)


def _saved(tmp_path, data):
    x, u = data
    path = tmp_path / "m.npz"
    ltv.fit(x, u, lam=5.0).save(path)
    return path


@pytest.mark.parametrize(
    "damage", ["csv", "truncated", "garbage-zip", "nan-k", "bad-json", "wrong-shape", "missing-k"]
)
def test_load_names_the_file_for_every_damage(tmp_path, data, damage):
    import json
    import zipfile

    path = _saved(tmp_path, data)
    bad = tmp_path / f"{damage}.npz"
    if damage == "csv":
        bad.write_text("a,b\n1,2\n")
    elif damage == "truncated":
        bad.write_bytes(path.read_bytes()[:200])
    elif damage == "garbage-zip":
        with zipfile.ZipFile(bad, "w") as z:
            z.writestr("k.npy", b"not an array")
            z.writestr("meta.npy", b"nor this")
    else:
        with np.load(path) as f:
            content = {key: f[key] for key in f.files}
        meta = json.loads(str(content["meta"]))
        if damage == "nan-k":
            content["k"] = np.where(
                np.arange(content["k"].size).reshape(content["k"].shape) == 3, np.nan, content["k"]
            )
        elif damage == "bad-json":
            content["meta"] = np.array("{not json")
        elif damage == "wrong-shape":
            content["k"] = content["k"][:, :5]
        elif damage == "missing-k":
            del content["k"]
        if damage != "bad-json":
            content["meta"] = np.array(json.dumps(meta))
        np.savez(bad, **content)
    with pytest.raises(ltv.ModelFileError, match=rf"^path: {tmp_path}.*{damage}\.npz"):
        ltv.load(bad)


def test_load_says_plainly_that_a_file_is_not_a_model(tmp_path, data):
    """A CSV, garbage, an empty or truncated archive, pickled objects: one message, and
    never numpy's advice to load pickles unsafely."""
    model = ltv.fit(*data, lam=10.0)
    model.save(tmp_path / "model.npz")
    whole = (tmp_path / "model.npz").read_bytes()
    files = {
        "data.csv": b"a,b\n1,2\n",
        "garbage.npz": b"\x00\x01 not a model",
        "empty.npz": b"",
        "truncated.npz": whole[: len(whole) // 2],
    }
    for name, content in files.items():
        (tmp_path / name).write_bytes(content)
    np.savez(tmp_path / "objects.npz", meta=np.array([{"k": 1}], dtype=object), k=np.ones((3, 6)))
    for name in [*files, "objects.npz"]:
        with pytest.raises(ltv.ModelFileError) as info:
            ltv.load(tmp_path / name)
        text = str(info.value)
        assert text.startswith(f"path: {tmp_path / name} is not ")
        assert "ltvmodels model file" in text and "allow_pickle" not in text


def test_load_keeps_file_system_errors_and_takes_paths_only(tmp_path):
    with pytest.raises(FileNotFoundError):
        ltv.load(tmp_path / "absent.npz")
    with pytest.raises(TypeError, match=r"^path: expected a file path"):
        ltv.load(3)


def test_lam_auto_on_data_the_null_space_fits_exactly():
    with pytest.raises(ValueError, match=r"^lam: there is no λ to choose.*λ_max = 0"):
        ltv.fit(np.ones((8, 1)), lam="auto", norm="group", order=2)


def test_ragged_lam_is_named_and_huge_sparse_lam_is_the_null_space_fit():
    d = ltv.systems.jump_linear(T=80, change_at=40, seed=1)
    with pytest.raises(TypeError, match=r"^lam: expected a number >= 0"):
        ltv.fit(d.x, d.u, lam=[[1, 2], [3]])
    # λ is not squared for the sparse norms: 1e200 is above λ_max, the exact null-space fit
    huge = ltv.fit(d.x, d.u, lam=1e200, norm="group", order=2)
    at_max = ltv.fit(
        d.x, d.u, lam=ltv.lambda_max(d.x, d.u, norm="group", order=2), norm="group", order=2
    )
    assert huge.status.status == "closed_form"
    np.testing.assert_allclose(huge.k, at_max.k, rtol=1e-10, atol=1e-12)


def test_l0_selection_does_not_reward_exact_fits_of_short_segments():
    d = ltv.systems.jump_linear(seed=0)  # one change, at 200
    sel = ltv.select_lambda(d.x, d.u, norm="l0", max_changes=10**6)
    assert sel.lam == 1.0
    assert np.all(np.isfinite(sel.scores))
    assert sel.lams.max() <= d.x.shape[0] // 4  # segments of at least p + 1 = 4 transitions


def test_a_diverging_simulation_warns():
    k = np.tile([[1e100, 0.0]], (40, 1))  # x[t+1] = 1e100 x[t] + 0 u[t]
    model = ltv.LTVModel(k, 1, 1)
    with pytest.warns(ltv.DivergenceWarning, match="from time step 4 on"):
        x = model.simulate([1.0], np.zeros(41))
    assert np.isinf(x[4, 0]) and np.isfinite(x[3, 0])


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_sparse_fits_have_no_likelihood(data, norm):
    x, u = data
    model = ltv.fit(x, u, lam=5.0, norm=norm)
    assert model.loglik is None and norm in model.info["loglik_note"]
    assert "loglik=None" in repr(model)
    assert np.all(np.isfinite(model.noise_var))


def test_no_residual_degree_of_freedom_raises_and_exact_fits_have_no_likelihood():
    x = np.array([[1.0, 0.0], [2.0, 1.0], [0.5, 3.0]])  # two transitions, two coefficients
    with pytest.raises(ValueError, match=r"^x: 2 observed transitions and 2 coefficients"):
        ltv.fit_lti(x)
    exact = ltv.fit_lti(2.0 ** np.arange(6)[:, None])  # x[t+1] = 2 x[t]: zero residuals
    assert exact.A[0, 0, 0] == pytest.approx(2.0)
    assert exact.loglik is None and "singular" in exact.info["loglik_note"]
    rng = np.random.default_rng(3)
    walk = np.cumsum(rng.standard_normal((199, 2)), axis=0)
    with pytest.raises(ValueError, match=r"^penalty: the 99 segments found use 198"):
        ltv.fit_segments(walk, penalty=0.0)  # every segment holds exactly its 2 unknowns
    nearly = ltv.fit_segments(walk[:-1], penalty=0.0)  # one residual left, n = 2 outputs
    assert nearly.loglik is None and np.all(np.isfinite(nearly.noise_var))


@pytest.mark.parametrize("scale, what", [(1e300, "large"), (1e-300, "small")])
def test_data_beyond_double_precision_is_named(data, scale, what):
    x, u = data
    with pytest.raises(ValueError, match=rf"^x: column 0 has values .* too {what}"):
        ltv.fit(x * scale, u, lam=5.0)
    with pytest.raises(ValueError, match=rf"^u: column 0 has values .* too {what}"):
        ltv.select_lambda(x, u * scale)
    with pytest.raises(ValueError, match=rf"^y: column 0 has values .* too {what}"):
        ltv.fit_ar(x[:, 0] * scale, 2, lam=5.0)
    zeros = np.zeros((50, 1))
    zeros[10] = scale
    with pytest.raises(ValueError, match=rf"too {what}"):
        ltv.fit_segments(zeros, n_changes=1)


def test_select_lambda_names_the_unidentifiable_combination(data):
    x, _ = data
    with pytest.raises(ltv.SingularProblemError, match=r"the combination [+-]1·x0 [+-]1·u0"):
        ltv.select_lambda(x, x[:, 0])
    with pytest.raises(ltv.SingularProblemError, match=r"phi1"):
        ltv.select_lambda_regression(x[1:, 0], np.c_[x[:-1, 0], 2 * x[:-1, 0]])


def test_empty_series_blames_the_data():
    with pytest.raises(ValueError, match=r"^y: expected at least one sample"):
        ltv.fit_regression(np.zeros((0, 1)), np.zeros((0, 2)), lam=1.0)
    with pytest.raises(ValueError, match=r"^x: expected at least one sample"):
        ltv.fit(np.zeros((2, 0, 3)), lam=1.0)


def test_given_coefficients_have_no_noise_estimate(tmp_path):
    model = ltv.LTVModel(np.ones((5, 2)), 1, 1)
    assert model.noise_var is None and model.noise_cov is None and model.loglik is None
    model.save(tmp_path / "given.npz")
    loaded = ltv.load(tmp_path / "given.npz")
    assert loaded.noise_var is None and loaded.noise_cov is None and loaded.loglik is None


def test_wide_scalar_lam_allocates_no_k_by_k_matrix():
    import tracemalloc

    n, T = 60, 80  # K = 3600: a K x K float64 array is 104 MB
    rng = np.random.default_rng(0)
    x = rng.standard_normal((T, n))
    ltv.fit(x[: n + 5], lam=10.0, compute_cov=False)  # compile outside the measurement
    tracemalloc.start()
    try:
        model = ltv.fit(x, lam=10.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert model.cov.shape == (T - 1, n, n, n)  # a (p, p) block per row, p = n
    assert peak < 40e6, f"peak {peak / 1e6:.0f} MB"


def test_solver_residue_is_no_change_point():
    walk = np.cumsum(np.random.default_rng(0).standard_normal((100, 2)), axis=0)
    lti = ltv.fit(walk, lam=1e150, norm="group")  # beyond lambda_max: constant coefficients
    assert lti.activation().max() < 1e-12  # rounding, which the relative level alone would take
    assert lti.changepoints.size == 0 and ltv.find_changepoints(lti).size == 0
    residue = np.zeros(98)
    residue[0] = 1.3e-15
    assert ltv.find_changepoints(residue).tolist() == [1]  # an array has no scale of its own
    assert ltv.find_changepoints(residue, min_level=1e-12).size == 0


def test_more_inputs_found_by_fuzzing(data, tmp_path):
    x, u = data
    with pytest.raises(ValueError, match=r"^k: expected finite values"):
        ltv.LTVModel(np.full((5, 2), np.nan), 1, 1)
    assert "lam=None" in repr(ltv.LTVModel(np.ones((5, 2)), 1, 1))
    with pytest.raises(ValueError, match=r"^order: expected polynomial coefficients of magn"):
        ltv.fit(x, u, lam=1.0, order=[-1e300, 1e300])
    with pytest.raises(ValueError, match=r"^mean: column 0 has values .* too large"):
        ltv.Prior(np.full(6, 1e300), 1.0)
    with pytest.raises(ValueError, match=r"^lams: the L-curve has no corner"):
        ltv.select_lambda(x, u, norm="l1", lams=[1e6, 2e6, 3e6])
    with pytest.raises(ValueError, match=r"^y: too few samples"):
        ltv.select_lambda_regression(x[1:4], np.c_[x[:3], u[:3]], order=2)
    with pytest.raises(ValueError, match=r"^y: the noise variance cannot be estimated"):
        ltv.noise_variance_estimate(np.zeros(3), np.ones((3, 3)))


@pytest.mark.parametrize(
    "member, value",
    [
        ("changepoints", np.array([-3, 10**6])),
        ("coeffs", np.zeros((2, 2))),
        ("cov_blocks", np.zeros((3, 3))),
        ("noise_cov", np.array([[1.0, np.nan], [np.nan, 1.0]])),
    ],
)
def test_load_checks_every_member(data, tmp_path, member, value):
    x, u = data
    path = tmp_path / "model.npz"
    ltv.fit(x, u, lam=5.0, norm="group").save(path)
    with np.load(path) as stored:
        members = dict(stored)
    members[member] = value
    np.savez(path, **members)
    with pytest.raises(ltv.ModelFileError, match=rf"^path: {path} holds an invalid"):
        ltv.load(path)


def test_inputs_found_by_the_long_fuzzing_profile(data):
    x, u = data
    N = x.shape[0] - 1
    rng = np.random.default_rng(0)
    assert ltv.fit(rng.standard_normal((3, 1)), lam=1.0, norm="group").k.shape == (2, 1)
    with pytest.raises(ValueError, match=r"^weights: expected weights of 0 or between"):
        ltv.fit(x, u, lam=1.0, weights=np.full(N, 1e300))
    with pytest.raises(ValueError, match=r"^lam: expected a finite λ below"):
        ltv.fit(x, u, lam=np.array([1e200, 3, 3, 3, 3, 3.0]), norm="group")
    with pytest.raises(ValueError, match=r"^lams: expected a finite real number >= 0"):
        ltv.fit_path(x, u, lams=[-1.0])
    with pytest.raises(ValueError, match=r"^noise_var: expected a variance between"):
        ltv.kalman_smoother(x, u, lam=100.0, noise_var=1e300)
    online = ltv.OnlineParameterFilter(2, 1, lam=10.0)
    with pytest.raises(ValueError, match=r"^x_t: column 0 has values .* too large"):
        online.update(x[0] * 1e292, u[0], x[1])
    with pytest.raises(ValueError, match=r"^lams: every candidate exceeds"):
        ltv.select_lambda(rng.standard_normal((13, 6)), norm="l0", lams=[4, 2, 3], constant=True)
    with pytest.raises(TypeError, match=r"^progress: expected a function"):
        ltv.select_lambda(x, u, progress="bar")
    with pytest.raises(ValueError, match=r"^n_states: expected an integer"):
        ltv.LTVModel(np.zeros((8, 3)), None, 2)
    with pytest.raises(ValueError, match=r"^k: expected at least one time step"):
        ltv.LTVModel(np.zeros((0, 4)), 2, 0)
    with pytest.raises(ValueError, match=r"^x0: expected at least one initial state"):
        ltv.fit(x, u, lam=10.0).simulate(np.zeros((0, 2)), u)
    with pytest.raises(ValueError, match=r"^x: the noise variance cannot be estimated"):
        ltv.fit_segments(rng.standard_normal((2, 1)))
