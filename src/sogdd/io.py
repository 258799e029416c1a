"""Image reading and conversion to the grey 0-255 float64 scale the measure uses.

The paper's threshold (T_h = 1e9) assumes intensities on a 0-255 scale, and the
measure scales as intensity**(2K - 2), so every input is brought to that scale:

============  ======================================================
input dtype   conversion
============  ======================================================
uint8         taken as is (0..255)
uint16        multiplied by 255 / 65535
float32/64    taken to be on [0, 1] (scikit-image's convention) and
              multiplied by 255; values outside [0, 1] are an error
bool          False -> 0, True -> 255
============  ======================================================

Colour images (H, W, 3) or (H, W, 4) (alpha dropped) are converted to grey with
luma weights: ITU-R BT.601 (0.299, 0.587, 0.114) by default, or MATLAB's
``rgb2gray`` weights for the ``authors`` preset (rounded back to the integer
dtype first, as MATLAB does). Arrays are RGB unless ``channel_order="bgr"``
(what ``cv2.imread`` returns); :func:`read_image` always returns RGB.
"""

from __future__ import annotations

import os

import numpy as np

# reading files lives in sogdd.imagefile; re-exported here, where the rest of the package looks
from .imagefile import (
    DEFAULT_MAX_PIXELS,
    IMAGE_SUFFIXES,
    list_images,
    max_pixels_limit,
    opencv_message,
    read_image,
)

__all__ = [
    "BT601",
    "DEFAULT_MAX_PIXELS",
    "IMAGE_SUFFIXES",
    "MATLAB_RGB2GRAY",
    "check_mask",
    "check_value_range",
    "intensity_hint",
    "list_images",
    "opencv_message",
    "max_pixels_limit",
    "read_image",
    "to_gray255",
    "to_uint8_grey",
    "validate_image",
]

BT601 = (0.299, 0.587, 0.114)
MATLAB_RGB2GRAY = (0.298936021293775, 0.587043074451121, 0.114020904255103)

_FLOAT_TOL = 1e-6
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
    finite values (they are mapped from that range).
    """
    image = _as_array(image)
    if image.dtype == object or not any(image.dtype == d for d in _DTYPES):
        raise ValueError(
            f"unsupported dtype {image.dtype}; use uint8, uint16, float32, float64 or bool"
        )
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


def _as_array(image: object) -> np.ndarray:
    if isinstance(image, np.ndarray):
        return image
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
    if unit_range and (lo < -_FLOAT_TOL or hi > 1 + _FLOAT_TOL):
        raise ValueError(
            f"float images must be on [0, 1] (got [{lo:g}, {hi:g}]); give their range: "
            "value_range=(lo, hi) in the API, --value-range LO,HI on the command line"
        )


def to_gray255(
    image: np.ndarray, *, weights: tuple[float, float, float] = BT601, round_integer: bool = False,
    channel_order: str = "rgb", value_range: tuple[float, float] | None = None,
) -> np.ndarray:
    """Convert a validated image to a grey float64 array on the 0-255 scale.

    Grey = w_r R + w_g G + w_b B, evaluated in float64 in blocks of rows so that
    no float64 (H, W, 3) copy of a colour image is made. ``round_integer``
    rounds the grey value of an integer colour image back to its integer dtype
    before scaling (MATLAB ``rgb2gray`` behaviour). The scale is then the
    dtype's (see the module docstring), or with ``value_range=(lo, hi)``
    ``255 (g - lo) / (hi - lo)`` clipped to [0, 255], for any dtype.

    Examples
    --------
    >>> to_gray255(np.array([[0, 4095]], np.uint16), value_range=(0, 4095)).tolist()
    [[0.0, 255.0]]
    """
    img = image
    if img.ndim == 3:
        if channel_order not in ("rgb", "bgr"):
            raise ValueError(f"channel_order must be 'rgb' or 'bgr', got {channel_order!r}")
        chans = (0, 1, 2) if channel_order == "rgb" else (2, 1, 0)
        grey = np.empty(img.shape[:2], dtype=np.float64)
        step = max(1, (1 << 20) // max(1, img.shape[1]))  # about 8 MB of float64 per block
        for r0 in range(0, img.shape[0], step):
            blk, out = img[r0 : r0 + step], grey[r0 : r0 + step]
            np.multiply(blk[:, :, chans[0]], weights[0], out=out, dtype=np.float64)
            out += blk[:, :, chans[1]] * np.float64(weights[1])
            out += blk[:, :, chans[2]] * np.float64(weights[2])
            if round_integer and img.dtype.kind in "ub":
                np.round(out, out=out)
    else:
        grey = img.astype(np.float64)
    if value_range is not None:
        lo, hi = check_value_range(value_range)
        if img.dtype == np.bool_:
            grey *= 1.0  # bool -> 0/1 already
        grey -= lo
        grey *= 255.0 / (hi - lo)
        return np.clip(grey, 0.0, 255.0, out=grey)
    if img.dtype == np.uint8:
        return grey
    if img.dtype == np.uint16:
        grey *= 255.0 / 65535.0
        return grey
    if img.dtype == np.bool_:
        grey *= 255.0
        return grey
    np.clip(grey, 0.0, 1.0, out=grey)
    grey *= 255.0
    return grey


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


def to_uint8_grey(image, channel_order: str = "rgb") -> np.ndarray:
    """Validate an image and convert it to the uint8 grey image OpenCV's detectors need.

    Examples
    --------
    >>> to_uint8_grey(np.array([[0.0, 0.5], [1.0, 1.0]])).tolist()
    [[0, 128], [255, 255]]
    """
    grey = to_gray255(validate_image(image), channel_order=channel_order)
    return np.clip(np.round(grey), 0, 255).astype(np.uint8)


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
