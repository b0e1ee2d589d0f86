"""The files that carry a pool task's results back (``estimators.pool_results``)."""

import numpy as np
import pytest

from ltvmodels.estimators import pool_results


@pytest.fixture
def directory(tmp_path):
    return str(tmp_path)


def round_trip(value, directory):
    return pool_results.read(pool_results.write(value, directory))


def test_arrays_of_every_kind_come_back_equal(directory):
    a = np.arange(12.0).reshape(3, 4)
    value = {
        "matrix": a,
        "transposed": a.T,  # not C-contiguous: pickled as usual
        "strided": a[:, ::2],
        "empty": np.empty((0, 3)),
        "zero_d": np.array(2.5),
        "scalar": np.float64(3.0),
        "objects": np.array([None, 1], dtype=object),
        "ints": np.arange(5, dtype=np.int32),
        "big_endian": np.arange(3, dtype=">f8"),
        "text": np.array(["ab", "c"]),
        "flags": np.array([True, False]),
        "dates": np.array(["2024-01-01", "2024-02-01"], dtype="datetime64[D]"),
        "durations": np.array([1, 2], dtype="timedelta64[s]"),
        "complex": np.array([1 + 2j, 3j]),
        "masked": np.ma.array([1.0, 2.0], mask=[False, True]),
    }
    back = round_trip(value, directory)
    for name, original in value.items():
        assert type(back[name]) is type(original), name
        if isinstance(original, np.ndarray):
            assert back[name].dtype == original.dtype, name
            assert back[name].shape == original.shape, name
        np.testing.assert_array_equal(np.asarray(back[name]), np.asarray(original))
    np.testing.assert_array_equal(back["masked"].mask, [False, True])


def test_many_arrays_of_one_kind_keep_their_order_and_identity(directory):
    rng = np.random.default_rng(0)
    arrays = [rng.normal(size=(7, 3)) for _ in range(50)]
    shared = arrays[3]
    back = round_trip({"arrays": arrays, "again": shared}, directory)
    for original, received in zip(arrays, back["arrays"]):
        np.testing.assert_array_equal(received, original)
    assert back["again"] is back["arrays"][3]  # one object, as pickle promises


def test_arrays_come_back_writable_and_private(directory):
    a = np.zeros((4, 4))
    first, second = round_trip([a, a.copy()], directory)
    first[0, 0] = 1.0
    assert second[0, 0] == 0.0 and a[0, 0] == 0.0
    assert first.flags.writeable


def test_the_file_is_removed_once_read(directory, tmp_path):
    path = pool_results.write([np.ones(3)], directory)
    assert [p.name for p in tmp_path.iterdir()] == [path.rsplit("/", 1)[1]]
    pool_results.read(path)
    assert list(tmp_path.iterdir()) == []
