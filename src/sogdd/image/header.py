"""Image size and frame count from a file's header (Pillow), without decoding the pixels.

Read before decoding so that a decompression bomb (a small file declaring a
huge image) is refused before any memory is allocated for it, and so that a
multi-frame file (animated GIF, APNG or WebP, multi-page TIFF) is recognised.

Pillow reads the header lazily: opening parses the header, the pixels are
decoded only on ``load()``, which is never called here. Every format Pillow
identifies is covered (PNG, JPEG, GIF, BMP, WebP, TIFF and BigTIFF, PNM, grey
PFM, JPEG 2000, Sun raster, AVIF, ...); a file Pillow cannot identify (Radiance
HDR, OpenEXR, PAM, 3-channel float TIFF or PFM) gives ``None``, and
:func:`sogdd.read_image` then checks the size OpenCV decoded, OpenCV's own
pixel limit (2**30) bounding that decoding.

Why the plugin registry and not ``PIL.Image.open``: ``Image.open`` identifies the
file the same way (each registered plugin's ``accept`` test on the first 16
bytes, then its header parser) and then applies Pillow's own decompression-bomb
limit, a process-wide setting (``Image.MAX_IMAGE_PIXELS``, 89 Mpx, an error
past 179 Mpx) that raises without telling the size. sogdd's limit is per call
(``max_pixels``, default 268 Mpx) and its message names the size, so the size
is read without Pillow's check rather than by changing a setting every other
user of Pillow in the process shares.
"""

from __future__ import annotations

import io
import struct
import warnings

from PIL import Image, UnidentifiedImageError

__all__ = ["probe"]

# formats whose frames OpenCV reads (cv2.imdecodemulti); Pillow also counts the
# pictures of an MPO (JPEG) file, which OpenCV decodes as one image
_MULTI_FRAME = frozenset({"TIFF", "GIF", "PNG", "WEBP"})
# what Pillow's header parsers raise on data that is not theirs, or is damaged
_NOT_THIS_FORMAT = (SyntaxError, IndexError, TypeError, ValueError, struct.error, OSError, EOFError,
                    UnidentifiedImageError)


def probe(data: bytes) -> tuple[int, int, int] | None:
    """``(width, height, frames)`` declared by the header of an encoded image, or ``None``.

    ``width`` and ``height`` are those of the first frame, or of the canvas of
    an animation (which bounds every frame); ``None`` for data Pillow does not
    identify as an image.

    Examples
    --------
    >>> import cv2, numpy as np
    >>> probe(cv2.imencode(".png", np.zeros((3, 5), np.uint8))[1].tobytes())
    (5, 3, 1)
    >>> probe(b"not an image") is None
    True
    """
    with warnings.catch_warnings():  # what Pillow says of a damaged header, the decoder says again
        warnings.simplefilter("ignore")
        try:
            im = _open_header(data)
        except Image.DecompressionBombError as exc:  # a GIF frame past its canvas and past Pillow's limit
            raise ValueError(str(exc).split(",")[0]) from None
        if im is None:
            return None
        with im:
            return (*im.size, _frames(im))


def _frames(im: Image.Image) -> int:
    if im.format not in _MULTI_FRAME:
        return 1
    try:
        return max(1, im.n_frames)  # walks the frames' headers (TIFF directories, GIF blocks), no pixels
    except _NOT_THIS_FORMAT:
        return 1  # a damaged frame list: the decoder reports it


def _open_header(data: bytes) -> Image.Image | None:
    """What ``Image.open`` does, without its process-wide pixel limit: the first plugin that
    accepts the data and parses its header (the pixels are not decoded)."""
    tried: set[str] = set()
    for load in (Image.preinit, Image.init):  # the common formats first; the rest only if none fits
        load()
        fmts = [f for f in Image.ID if f not in tried]
        tried.update(fmts)
        for fmt in fmts:
            im = _try(fmt, data)
            if im is not None:
                return im
    return None


def _try(fmt: str, data: bytes) -> Image.Image | None:
    factory, accept = Image.OPEN[fmt]
    try:
        verdict = accept(data[:16]) if accept is not None else True
        if not verdict or isinstance(verdict, str):  # a string is the plugin's reason to refuse
            return None
        return factory(io.BytesIO(data), "")
    except _NOT_THIS_FORMAT:
        return None
