"""Arrays the detector does not take say what to do; a big-endian array is taken as it is
(not byte-swapped into a copy)."""

import numpy as np
import pytest

import sogdd
from sogdd.synthetic import pattern_image


@pytest.fixture(scope="module")
def image():
    return pattern_image((120, 160), seed=2)[0]


@pytest.mark.parametrize("dtype", [">u2", ">f4", ">f8"])
def test_big_endian_arrays_give_the_corners_of_native_ones(image, dtype):
    native = np.dtype(dtype).newbyteorder("=")
    a = image.astype(np.uint16) * 257 if native.kind == "u" else image / 255.0
    a = a.astype(native)
    want = sogdd.detect_corners(a)
    got = sogdd.detect_corners(a.astype(dtype))
    assert len(want) > 5
    np.testing.assert_array_equal(got.xy, want.xy)
    np.testing.assert_array_equal(sogdd.corner_response(a.astype(dtype)), sogdd.corner_response(a))


def test_a_list_of_ints_says_which_dtype_to_use(image):
    with pytest.raises(ValueError) as info:
        sogdd.detect_corners(image.tolist())
    msg = str(info.value)
    assert "list" in msg and "np.asarray(image, np.uint8)" in msg and "\n" not in msg
    assert len(sogdd.detect_corners(np.asarray(image.tolist(), np.uint8))) == len(sogdd.detect_corners(image))


def test_an_int_array_says_how_to_convert_it():
    with pytest.raises(ValueError, match=r"unsupported dtype int32; use uint8.*np.asarray\(image, np.uint8\)"):
        sogdd.detect_corners(np.zeros((8, 8), np.int32))
