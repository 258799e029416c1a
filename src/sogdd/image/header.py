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
(``max_pixels``, default 134 Mpx) and its message names the size, so the size
is read without Pillow's check rather than by changing a setting every other
user of Pillow in the process shares.
"""

from __future__ import annotations

import io
import struct
import warnings
from typing import NamedTuple

from PIL import Image, UnidentifiedImageError

__all__ = ["Header", "probe", "read_header"]

# formats whose frames OpenCV reads (cv2.imdecodemulti); Pillow also counts the
# pictures of an MPO (JPEG) file, which OpenCV decodes as one image
_MULTI_FRAME = frozenset({"TIFF", "GIF", "PNG", "WEBP"})
# what Pillow's header parsers raise on data that is not theirs, or is damaged
_NOT_THIS_FORMAT = (SyntaxError, IndexError, TypeError, ValueError, struct.error, OSError, EOFError,
                    UnidentifiedImageError)


#: the EXIF orientation tag
_ORIENTATION = 0x0112


class Header(NamedTuple):
    """What an image file's header declares: ``width`` and ``height`` as stored (before any EXIF
    orientation), ``frames``, the EXIF ``orientation`` (1-8, 1 when none) and Pillow's ``format``."""

    width: int
    height: int
    frames: int
    orientation: int
    format: str


def probe(data: bytes) -> tuple[int, int, int] | None:
    """``(width, height, frames)`` declared by the header of an encoded image, or ``None``
    (:func:`read_header`'s first three).

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
    head = read_header(data)
    return None if head is None else (head.width, head.height, head.frames)


def read_header(data: bytes) -> Header | None:
    """The :class:`Header` of an encoded image, or ``None`` for data Pillow does not identify as an image.

    ``width`` and ``height`` are those of the stored pixels (a TIFF's too, which
    Pillow reports turned by its orientation). The orientation is read from the
    EXIF data the header holds (JPEG, WebP, PNG with its ``eXIf`` chunk before the
    pixels, TIFF's tag), never by decoding.

    Examples
    --------
    >>> import io
    >>> from PIL import Image
    >>> exif = Image.Exif()
    >>> exif[0x0112] = 6
    >>> buf = io.BytesIO()
    >>> Image.new("L", (5, 3)).save(buf, "JPEG", exif=exif.tobytes())
    >>> read_header(buf.getvalue())
    Header(width=5, height=3, frames=1, orientation=6, format='JPEG')
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
            (w, h), turn = im.size, _orientation(im)
            if im.format == "TIFF" and turn >= 5:  # Pillow gives a TIFF's size turned by its orientation
                w, h = h, w
            return Header(int(w), int(h), _frames(im), turn, str(im.format))


def _orientation(im: Image.Image) -> int:
    """The EXIF orientation the header holds (1 when none or not 1-8); ``Image.getexif`` is not used: for a
    PNG whose ``eXIf`` chunk follows the pixels it decodes them."""
    try:
        if im.format == "TIFF":
            value = im.tag_v2.get(_ORIENTATION)
        else:
            raw = im.info.get("exif")
            if not raw:
                return 1
            exif = Image.Exif()
            exif.load(raw)
            value = exif.get(_ORIENTATION)
    except _NOT_THIS_FORMAT:
        return 1
    return int(value) if isinstance(value, int) and 1 <= value <= 8 else 1


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
