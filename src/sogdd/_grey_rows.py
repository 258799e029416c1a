"""The grey 0-255 image converted on demand, a block of rows at a time.

:func:`sogdd.io.to_gray255` is a per-pixel formula (weights, optional rounding,
scale), so converting a crop of the input gives the crop of the converted image
bit for bit. Banded detection (:mod:`sogdd._banded`) reads the grey image in
crops, so with :class:`GreyRows` no H x W float64 grey image exists (192 MB at
24 MP); whoever needs the whole image gets it from ``np.asarray(grey, dtype)``,
built band by band in that dtype (float32 for sub-pixel refinement: half the size).
"""

from __future__ import annotations

import numpy as np

from .io import to_gray255

__all__ = ["GreyRows"]

_BLOCK = 512  # rows per block when the whole image is asked for


class GreyRows:
    """A validated image seen as its grey 0-255 float64 image; crops are converted when indexed.

    Parameters
    ----------
    image : ndarray
        A validated (H, W) or (H, W, 3|4) image (:func:`sogdd.io.validate_image`).
    **gray : dict
        The keyword arguments of :func:`sogdd.io.to_gray255`.

    Examples
    --------
    >>> from sogdd.io import to_gray255
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

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = np.empty(self.shape, dtype=np.float64 if dtype is None else dtype)
        for r0 in range(0, self.shape[0], _BLOCK):
            out[r0 : r0 + _BLOCK] = self[r0 : r0 + _BLOCK]
        return out
