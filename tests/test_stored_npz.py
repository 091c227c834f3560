"""A sweep's `.npz` files written in one pass: the bytes zipfile writes, loadable by numpy."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

from quadsim.io.stored_npz import stored_npz_bytes, zipfile_npz_bytes

DATE = (1980, 1, 1, 0, 0, 0)


def _arrays():
    rng = np.random.default_rng(3)
    grid = rng.normal(size=(7, 5, 3))
    return {
        "format": np.array("quadsim-npz"),
        "format_version": np.array(1),
        "fps": np.array(60.0),
        "positions": grid,
        "fortran": np.asfortranarray(rng.normal(size=(4, 6))),
        "strided": grid[:, ::2, 1],
        "names": np.array(["root", "spine", "ñandú"], dtype=str),
        "contacts": rng.random((9, 4)) > 0.5,
        "parents": np.array([-1, 0, 1], dtype=np.int64),
        "empty": np.zeros((0, 4)),
        "gaits": np.array(["walk"] * 5, dtype=str),
        "größe": np.arange(3, dtype=np.float32),
    }


def test_the_bytes_are_those_zipfile_writes_for_the_same_arrays():
    arrays = _arrays()
    assert stored_npz_bytes(arrays, DATE) == zipfile_npz_bytes(arrays, DATE)


def test_numpy_loads_every_array_back_unchanged_without_pickles():
    arrays = _arrays()
    data = stored_npz_bytes(arrays, DATE)
    assert zipfile.ZipFile(io.BytesIO(data)).testzip() is None
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        assert list(z.keys()) == list(arrays)
        for key, value in arrays.items():
            got = z[key]
            assert got.dtype == value.dtype and got.shape == value.shape
            np.testing.assert_array_equal(got, value)


def test_every_member_carries_the_fixed_date_and_the_same_arrays_give_the_same_bytes():
    arrays = _arrays()
    data = stored_npz_bytes(arrays, DATE)
    assert {i.date_time for i in zipfile.ZipFile(io.BytesIO(data)).infolist()} == {DATE}
    assert stored_npz_bytes(_arrays(), DATE) == data
    changed = dict(arrays, fps=np.array(30.0))
    assert stored_npz_bytes(changed, DATE) != data


def test_object_arrays_are_refused():
    with pytest.raises(ValueError, match="object"):
        stored_npz_bytes({"x": np.array([None, 1], dtype=object)}, DATE)


def test_the_checksum_is_zlibs_crc32_for_any_data_and_running_value():
    """The members' checksum (zlib-ng's when installed) is zlib's CRC-32, chained as
    a member's header then its data, for lengths around its vector blocks."""
    import zlib

    from quadsim.io.stored_npz import crc32

    rng = np.random.default_rng(5)
    for n in (0, 1, 15, 16, 63, 64, 65, 4095, 100_003):
        data = rng.integers(0, 256, n, dtype=np.uint8).tobytes()
        start = int(rng.integers(0, 2**32))
        assert crc32(data) == zlib.crc32(data)
        assert crc32(data, start) == zlib.crc32(data, start)
