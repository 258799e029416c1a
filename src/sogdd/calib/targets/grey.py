"""An image made grey for the board detectors: the core's conversion, checked at the door."""

from __future__ import annotations

import numpy as np

__all__ = ["to_grey"]


def to_grey(image: object, value_range: tuple[float, float] | None = None) -> np.ndarray:
    """A grey float64 image on the 0-255 scale: the core's conversion and contract.

    :func:`sogdd.image.validate_image` then :func:`sogdd.image.to_gray255`, so
    calibration reads an image exactly as the corner detector does: uint8 as it
    is, uint16 times ``255 / 65535``, float on [0, 1] times 255 (floats outside
    [0, 1] are refused with a one-line ``ValueError``), colour by BT.601 luma
    (RGB order); with ``value_range=(lo, hi)`` any dtype becomes
    ``255 (g - lo) / (hi - lo)``, clipped to [0, 255]. The search needs at least
    8 x 8 pixels.

    Examples
    --------
    >>> img = np.array([[0.0, 127.5], [255.0, 255.0]]).repeat(4, axis=0).repeat(4, axis=1)
    >>> to_grey(img, value_range=(0, 255))[::4, ::4].tolist()  # OpenCV's float images: grey levels
    [[0.0, 127.5], [255.0, 255.0]]
    >>> to_grey(img)
    Traceback (most recent call last):
    ...
    ValueError: float images must be on [0, 1] (got [0, 255]); give their range: value_range=(lo, hi) ...
    """
    from sogdd.image import check_value_range, to_gray255, validate_image

    if not isinstance(image, np.ndarray):
        raise TypeError(f"image must be a numpy array, got {type(image).__name__}")
    rng = check_value_range(value_range)
    img = validate_image(image, value_range=rng)
    if min(img.shape[:2]) < 8:
        raise ValueError(f"image must be at least 8 x 8 pixels, got {image.shape}")
    return to_gray255(img, value_range=rng)
