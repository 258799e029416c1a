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
from pathlib import Path

import cv2
import numpy as np

__all__ = [
    "BT601",
    "IMAGE_SUFFIXES",
    "MATLAB_RGB2GRAY",
    "check_mask",
    "list_images",
    "read_image",
    "to_gray255",
    "to_uint8_grey",
    "validate_image",
]

BT601 = (0.299, 0.587, 0.114)
MATLAB_RGB2GRAY = (0.298936021293775, 0.587043074451121, 0.114020904255103)

# file suffixes that folder expansion treats as images (what cv2.imdecode reads)
IMAGE_SUFFIXES = frozenset(
    {".png", ".jpg", ".jpeg", ".jpe", ".bmp", ".dib", ".ppm", ".pgm", ".pbm", ".pnm", ".tif", ".tiff",
     ".webp", ".jp2", ".sr", ".ras", ".exr", ".hdr", ".pic", ".gif"}
)

_FLOAT_TOL = 1e-6
_DTYPES = (np.uint8, np.uint16, np.float32, np.float64, np.bool_)


def list_images(folder: str | os.PathLike) -> list[Path]:
    """The image files of a folder (by suffix, case-insensitive), sorted by name.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> for name in ("b.PNG", "a.jpg", "notes.txt"):
    ...     _ = (d / name).write_bytes(b"")
    >>> [p.name for p in list_images(d)]
    ['a.jpg', 'b.PNG']
    """
    return sorted(q for q in Path(folder).iterdir() if q.is_file() and q.suffix.lower() in IMAGE_SUFFIXES)


def read_image(path: str | os.PathLike) -> np.ndarray:
    """Read an image file as a numpy array (grey, or RGB/RGBA), keeping its dtype.

    Raises ``ValueError`` (one line) for a missing, unreadable or corrupt file.

    Examples
    --------
    >>> import tempfile, cv2
    >>> path = Path(tempfile.mkdtemp()) / "grey.png"
    >>> _ = cv2.imwrite(str(path), np.full((4, 6), 200, np.uint8))
    >>> img = read_image(path)
    >>> img.shape, img.dtype.name, int(img[0, 0])
    ((4, 6), 'uint8', 200)
    >>> read_image(path.with_name("missing.png"))
    Traceback (most recent call last):
    ...
    ValueError: ...missing.png: no such file
    """
    p = Path(path)
    if not p.exists():
        raise ValueError(f"{p}: no such file")
    if not p.is_file():
        raise ValueError(f"{p}: not a file")
    data = np.fromfile(str(p), dtype=np.uint8)  # also handles non-ASCII paths
    img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
    if img is None:
        raise ValueError(f"{p}: not a readable image (corrupt or unsupported format)")
    if img.ndim == 3 and img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    elif img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA)
    return img


def validate_image(image: object) -> np.ndarray:
    """Check an input image's type, shape, dtype and values; return it as an array.

    Raises ``ValueError`` with a one-line message for anything the detector can't
    give a meaningful answer on.
    """
    if not isinstance(image, np.ndarray):
        if isinstance(image, (str, os.PathLike)):
            raise ValueError("expected an image array; use sogdd.read_image(path) to load a file")
        try:
            image = np.asarray(image)
        except Exception as exc:  # noqa: BLE001 - anything unconvertible is bad input
            raise ValueError(f"expected an image array, got {type(image).__name__}") from exc
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
        if not np.isfinite(image).all():
            raise ValueError("image contains NaN or inf")
        lo, hi = float(image.min()), float(image.max())
        if lo < -_FLOAT_TOL or hi > 1 + _FLOAT_TOL:
            raise ValueError(
                f"float images must be on [0, 1] (got [{lo:g}, {hi:g}]); "
                "divide by 255 or pass uint8"
            )
    return image


def to_gray255(
    image: np.ndarray, *, weights: tuple[float, float, float] = BT601, round_integer: bool = False,
    channel_order: str = "rgb",
) -> np.ndarray:
    """Convert a validated image to a grey float64 array on the 0-255 scale.

    ``round_integer`` rounds the grey value of an integer colour image back to its
    integer dtype before scaling (MATLAB ``rgb2gray`` behaviour).
    """
    img = image
    if img.ndim == 3:
        rgb = img[:, :, :3].astype(np.float64)
        if channel_order == "bgr":
            rgb = rgb[:, :, ::-1]
        elif channel_order != "rgb":
            raise ValueError(f"channel_order must be 'rgb' or 'bgr', got {channel_order!r}")
        grey = rgb @ np.asarray(weights, dtype=np.float64)
        if round_integer and img.dtype.kind in "ub":
            grey = np.round(grey)
    else:
        grey = img.astype(np.float64)
    if img.dtype == np.uint8:
        return grey
    if img.dtype == np.uint16:
        return grey * (255.0 / 65535.0)
    if img.dtype == np.bool_:
        return grey * 255.0
    return np.clip(grey, 0.0, 1.0) * 255.0


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
