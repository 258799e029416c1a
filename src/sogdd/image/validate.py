"""Validation at the door: image arrays, value ranges and masks.

:func:`validate_image` refuses, with a one-line ``ValueError``, anything the
detector cannot give a meaningful answer on (dtype, shape, size, NaN/inf, a
float image outside [0, 1] without a ``value_range``); :mod:`sogdd.image.grey`
then brings what passes to the 0-255 scale.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["FLOAT_TOL", "check_mask", "check_value_range", "intensity_hint", "validate_image"]

#: how far a float image may stray outside [0, 1] (rounding of a conversion)
FLOAT_TOL = 1e-6
_DTYPES = (np.uint8, np.uint16, np.float32, np.float64, np.bool_)


def check_value_range(value_range) -> tuple[float, float] | None:
    """Validate ``value_range=(lo, hi)``: finite numbers with lo < hi.

    Examples
    --------
    >>> check_value_range((0, 4095))
    (0.0, 4095.0)
    >>> check_value_range((5, 5))
    Traceback (most recent call last):
    ...
    ValueError: value_range must be two finite numbers lo < hi, got (5, 5)
    """
    if value_range is None:
        return None
    try:
        lo, hi = (float(v) for v in value_range)
        ok = np.isfinite(lo) and np.isfinite(hi) and lo < hi
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"value_range must be two finite numbers lo < hi, got {value_range!r}")
    return lo, hi


def validate_image(image: object, *, value_range=None) -> np.ndarray:
    """Check an input image's type, shape, dtype and values; return it as an array.

    Raises ``ValueError`` with a one-line message for anything the detector can't
    give a meaningful answer on. With ``value_range`` a float image may hold any
    finite values (they are mapped from that range). A supported dtype in the
    other byte order (big-endian ``>u2`` from a FITS or raw file) is converted to
    the native order: the same values.

    Examples
    --------
    >>> validate_image(np.array([[1, 2], [3, 4]], ">u2")).dtype.str
    '<u2'
    >>> validate_image([[0, 255], [255, 0]])
    Traceback (most recent call last):
    ...
    ValueError: a list becomes an int64 array, which the detector does not take; convert it: ...
    """
    given = image
    image = _as_array(image)
    if image.dtype.byteorder not in ("=", "|") and image.dtype.newbyteorder("=") in _DTYPES:
        image = image.astype(image.dtype.newbyteorder("="))  # the same values in native order
    if image.dtype == object or not any(image.dtype == d for d in _DTYPES):
        raise ValueError(_dtype_message(given, image.dtype))
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if image.ndim == 3 and image.shape[2] not in (3, 4):
        raise ValueError(
            f"a 3-D array must be colour (H, W, 3) or (H, W, 4); got shape {image.shape}"
        )
    if image.ndim not in (2, 3):
        raise ValueError(f"expected a 2-D grey or (H, W, 3) colour image; got shape {image.shape}")
    h, w = image.shape[:2]
    if h == 0 or w == 0:
        raise ValueError(f"empty image (shape {image.shape})")
    if h < 2 or w < 2:
        raise ValueError(f"image too small: {h}x{w} (need at least 2x2)")
    if image.dtype.kind == "f":
        _check_float(image, value_range is None)
    return image


def _dtype_message(given: object, dtype: np.dtype) -> str:
    """What to do about an unsupported dtype: the conversion, when the values say which."""
    fix = "np.asarray(image, np.uint8) for 0-255 values (np.uint16 for 0-65535, float32 for 0-1)"
    if not isinstance(given, np.ndarray) and dtype.kind in "iu":
        return (f"a {type(given).__name__} becomes an {dtype} array, which the detector does not take; "
                f"convert it: {fix}")
    if dtype.kind in "iu":
        return f"unsupported dtype {dtype}; use uint8, uint16, float32, float64 or bool: {fix}"
    return f"unsupported dtype {dtype}; use uint8, uint16, float32, float64 or bool"


def _as_array(image: object) -> np.ndarray:
    if isinstance(image, np.ndarray):
        return image
    if image is None:
        raise ValueError("expected an image array, got None (did reading the image fail?)")
    if isinstance(image, (str, os.PathLike)):
        raise ValueError("expected an image array; use sogdd.read_image(path) to load a file")
    try:
        return np.asarray(image)
    except Exception as exc:  # noqa: BLE001 - anything unconvertible is bad input
        raise ValueError(f"expected an image array, got {type(image).__name__}") from exc


def _check_float(image: np.ndarray, unit_range: bool) -> None:
    lo, hi = float(image.min()), float(image.max())
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ValueError("image contains NaN or inf")
    if unit_range and (lo < -FLOAT_TOL or hi > 1 + FLOAT_TOL):
        raise ValueError(
            f"float images must be on [0, 1] (got [{lo:g}, {hi:g}]); give their range: "
            "value_range=(lo, hi) in the API, --value-range LO,HI on the command line"
        )


def intensity_hint(image: np.ndarray) -> str | None:
    """Advice when an integer image uses only part of its dtype's range (12-bit data in uint16).

    Examples
    --------
    >>> intensity_hint(np.array([[0, 4000]], np.uint16))
    'uint16 values only reach 4000 (12-bit data?): try value_range=(0, 4095) / --value-range 0,4095'
    >>> intensity_hint(np.array([[0, 60000]], np.uint16)) is None
    True
    """
    if image.dtype != np.uint16:
        return None
    top = int(image.max())
    for bits in (8, 10, 12, 14):
        full = (1 << bits) - 1
        if top <= full:
            return (f"uint16 values only reach {top} ({bits}-bit data?): try value_range=(0, {full}) / "
                    f"--value-range 0,{full}")
    return None


def check_mask(mask, shape: tuple[int, int]) -> np.ndarray | None:
    """Validate an OpenCV-style mask (uint8 or bool, image-sized); return it as bool.

    Examples
    --------
    >>> check_mask(np.array([[0, 255]], np.uint8), (1, 2)).tolist()
    [[False, True]]
    """
    if mask is None:
        return None
    m = np.asarray(mask)
    if m.dtype not in (np.uint8, np.bool_):
        raise ValueError(f"mask must be uint8 or bool, got {m.dtype}")
    if m.shape != shape:
        raise ValueError(f"mask shape {m.shape} does not match image shape {shape}")
    return m.astype(bool)
