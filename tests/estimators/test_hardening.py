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
    np.testing.assert_array_equal(seg.changepoints, ltv.fit_segments(with_nan, u, n_changes=1)
                                  .changepoints)
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


@pytest.mark.parametrize("damage", ["csv", "truncated", "garbage-zip", "nan-k", "bad-json",
                                    "wrong-shape", "missing-k"])
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
            content["k"] = np.where(np.arange(content["k"].size).reshape(content["k"].shape)
                                    == 3, np.nan, content["k"])
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
    at_max = ltv.fit(d.x, d.u, lam=ltv.lambda_max(d.x, d.u, norm="group", order=2),
                     norm="group", order=2)
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
