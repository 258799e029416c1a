"""Grey conversion, the one home: every input on the 0-255 scale the paper's threshold assumes.

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
(what ``cv2.imread`` returns); :func:`sogdd.image.read_image` always returns RGB.

The compiled filters read :func:`sogdd.image.rows.exact_grey`: uint8 as it is, anything else as float64.
"""

from __future__ import annotations

import numpy as np

from .validate import check_value_range, validate_image

__all__ = ["BT601", "MATLAB_RGB2GRAY", "to_gray255", "to_uint8_grey"]

#: ITU-R BT.601 luma weights (R, G, B), the default
BT601 = (0.299, 0.587, 0.114)
#: MATLAB rgb2gray's weights (the authors' code)
MATLAB_RGB2GRAY = (0.298936021293775, 0.587043074451121, 0.114020904255103)


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


def to_uint8_grey(image, channel_order: str = "rgb") -> np.ndarray:
    """Validate an image and convert it to the uint8 grey image OpenCV's detectors need.

    Examples
    --------
    >>> to_uint8_grey(np.array([[0.0, 0.5], [1.0, 1.0]])).tolist()
    [[0, 128], [255, 255]]
    """
    grey = to_gray255(validate_image(image), channel_order=channel_order)
    return np.clip(np.round(grey), 0, 255).astype(np.uint8)



