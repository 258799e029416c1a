"""Stage 1, the image: from a file or an array to grey levels on the 0-255 scale.

In: a path (:func:`read_image`) or an array of any supported dtype and layout.
Out: a validated grey image on the 0-255 scale the paper's threshold assumes,
whole (:func:`to_gray255`) or crop by crop (:class:`~sogdd.image.rows.GreyRows`).

========================  ==============================================================
module                    what it does
========================  ==============================================================
:mod:`.files`             reads image files: header check (pixel limit), decoding, EXIF
                          orientation, frames, folder listing
:mod:`.header`            pixel counts from PNG/JPEG/GIF/BMP/WebP/TIFF/PNM headers
:mod:`.validate`          validation at the door: dtype, shape, NaN/inf, value range, mask
:mod:`.grey`              grey conversion, the one home (luma weights, the 0-255 scale)
:mod:`.rows`              reading the grey image: band-wise grey rows (a colour or uint16
                          image converted only in the crops the measure reads), and the
                          exact grey the compiled filters read
:mod:`.pyramid`           the image pyramid: the grey image resized level by level
========================  ==============================================================
"""

from .files import DEFAULT_MAX_PIXELS, IMAGE_SUFFIXES, list_images, read_image
from .grey import BT601, MATLAB_RGB2GRAY, to_gray255, to_uint8_grey
from .rows import GreyRows, exact_grey
from .validate import check_mask, check_value_range, validate_image

__all__ = [
    "BT601",
    "DEFAULT_MAX_PIXELS",
    "IMAGE_SUFFIXES",
    "MATLAB_RGB2GRAY",
    "GreyRows",
    "check_mask",
    "check_value_range",
    "exact_grey",
    "list_images",
    "read_image",
    "to_gray255",
    "to_uint8_grey",
    "validate_image",
]
