"""The grey 0-255 image converted on demand, a block of rows at a time.

:func:`sogdd.image.grey.to_gray255` is a per-pixel formula (weights, optional rounding,
scale), so converting a crop of the input gives the crop of the converted image
bit for bit. Banded detection (:mod:`sogdd.select.bands`) reads the grey image in
crops, so with :class:`GreyRows` no H x W float64 grey image exists (192 MB at
24 MP); whoever needs the whole image gets it from ``np.asarray(grey, dtype)``,
built band by band in that dtype (float32 for sub-pixel refinement: half the size).
"""

from __future__ import annotations

import numpy as np

from .grey import to_gray255

__all__ = ["GreyRows", "exact_grey", "measure_rows"]

_BLOCK = 512  # rows per block when the whole image is asked for


class GreyRows:
    """A validated image seen as its grey 0-255 float64 image; crops are converted when indexed.

    Parameters
    ----------
    image : ndarray
        A validated (H, W) or (H, W, 3|4) image (:func:`sogdd.image.validate.validate_image`).
    **gray : dict
        The keyword arguments of :func:`sogdd.image.grey.to_gray255`.

    Examples
    --------
    >>> from sogdd.image.grey import to_gray255
    >>> img = np.random.default_rng(0).integers(0, 256, (40, 30, 3), dtype=np.uint8)
    >>> g = GreyRows(img, round_integer=True)
    >>> g.shape, bool(np.array_equal(g[5:9, 2:7], to_gray255(img, round_integer=True)[5:9, 2:7]))
    ((40, 30), True)
    >>> bool(np.array_equal(np.asarray(g, np.float32), to_gray255(img, round_integer=True).astype(np.float32)))
    True
    """

    ndim = 2
    dtype = np.dtype(np.float64)

    def __init__(self, image: np.ndarray, **gray) -> None:
        self.image = image
        self.gray = gray
        self.shape = tuple(image.shape[:2])

    def __getitem__(self, key) -> np.ndarray:
        key = key if isinstance(key, tuple) else (key,)
        if len(key) > 2 or not all(isinstance(k, slice) and k.step in (None, 1) for k in key):
            raise TypeError("GreyRows takes contiguous slices of rows and columns only")
        return to_gray255(self.image[key], **self.gray)

    def exact_rows(self, r0: int, r1: int) -> np.ndarray:
        """Rows ``r0 .. r1 - 1`` of the grey image, as the input's own uint8 rows where those are it.

        A 2-D uint8 input without ``value_range`` is its own grey image (the
        conversion is a cast), and the measure reads uint8 exactly, so the cast,
        and the page faults of a fresh float64 band, are skipped.
        """
        if self.image.ndim == 2 and self.image.dtype == np.uint8 and self.gray.get("value_range") is None:
            return self.image[r0:r1]
        return self[r0:r1]

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = np.empty(self.shape, dtype=np.float64 if dtype is None else dtype)
        for r0 in range(0, self.shape[0], _BLOCK):
            out[r0 : r0 + _BLOCK] = self.exact_rows(r0, r0 + _BLOCK)  # integers cast exactly
        return out


def measure_rows(grey, r0: int, r1: int) -> np.ndarray:
    """Rows ``r0 .. r1 - 1`` of an array or a :class:`GreyRows`, for :func:`sogdd.measure.soddc.soddc_measure`.

    Examples
    --------
    >>> img = np.arange(12, dtype=np.uint8).reshape(4, 3)
    >>> measure_rows(GreyRows(img), 1, 3).dtype, measure_rows(GreyRows(img), 1, 3).tolist()
    (dtype('uint8'), [[3, 4, 5], [6, 7, 8]])
    >>> measure_rows(GreyRows(img, value_range=(0, 11)), 1, 3).dtype
    dtype('float64')
    """
    return grey.exact_rows(r0, r1) if isinstance(grey, GreyRows) else grey[r0:r1]


def exact_grey(image: np.ndarray) -> np.ndarray:
    """A C-contiguous image the compiled filters read: uint8 as it is (each value exact), else float64.

    Examples
    --------
    >>> exact_grey(np.zeros((2, 3), np.uint8)).dtype, exact_grey(np.zeros((2, 3), np.float32)).dtype
    (dtype('uint8'), dtype('float64'))
    """
    if isinstance(image, np.ndarray) and image.dtype == np.uint8:
        return np.ascontiguousarray(image)
    return np.ascontiguousarray(image, dtype=np.float64)
