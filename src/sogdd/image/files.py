"""Reading image files: size limits, corrupt data, EXIF orientation, frames, folders.

:func:`read_image` reads the header first (:mod:`sogdd.image.header`, with
Pillow), so a decompression bomb is refused before any pixel is decoded; decodes with
OpenCV in the frame ``cv2.imread`` returns (EXIF orientation applied);
captures what the decoders print, so that corrupt or truncated data becomes a
one-line ``ValueError`` instead of chatter on stderr and a silently damaged
image; and refuses to pick the first frame of a multi-frame file silently
(``name.tif[2]`` selects one).
"""

from __future__ import annotations

import errno
import os
import re
import stat
import sys
import tempfile
import threading
from pathlib import Path

import cv2
import numpy as np

from .header import Header, read_header

__all__ = ["DEFAULT_MAX_PIXELS", "IMAGE_SUFFIXES", "PEAK_BYTES_FIXED", "PEAK_BYTES_PER_PIXEL", "decoder_words",
           "list_images", "max_pixels_limit", "opencv_message", "read_image", "read_image_and_orientation",
           "undo_orientation"]

# file suffixes that folder expansion treats as images (what cv2.imdecode reads)
IMAGE_SUFFIXES = frozenset(
    {".png", ".apng", ".jpg", ".jpeg", ".jpe", ".jfif", ".bmp", ".dib", ".ppm", ".pgm", ".pbm", ".pnm",
     ".pam", ".pfm", ".tif", ".tiff", ".webp", ".jp2", ".sr", ".ras", ".exr", ".hdr", ".pic", ".gif",
     ".avif"}
)

#: the most memory the calibration's detection of one view holds (reading, the grey image, the board search,
#: the corners' precision; :func:`sogdd.calib.detection.detect_view`): this many bytes per image pixel plus
#: :data:`PEAK_BYTES_FIXED`, measured on 1 to 256 Mpx frames, flat, noise and boards, grey and colour
#: (``benchmarks/bench_memory.py``; docs/user-guide/reading-images.md)
PEAK_BYTES_PER_PIXEL = 32
PEAK_BYTES_FIXED = 100 * 2**20
#: the default pixel limit, 2**27 (134 Mpx): a worker then holds at most 4.4 GB, two (``--jobs 2``) 8.8 GB,
#: which a 2-core machine of 24 GB holds with room to spare
DEFAULT_MAX_PIXELS = 2**27
_FRAME_RE = re.compile(r"^(.*)\[(\d+)\]$")
_STDERR_LOCK = threading.Lock()
# what the decoders (libjpeg, libpng, libtiff, libwebp, OpenCV) say about damaged data
#: the decorations of an OpenCV log line: its level and place, an error's version, source line and code, and
#: its function (:func:`decoder_words` strips them)
_LOG_PLACE = re.compile(r"^\[\s*[A-Z]+:[^\]]*\]\s*(?:global\s+\S+\s+\S+\s+)?")
_CV_ERROR = re.compile(r"OpenCV\([^)]*\)\s+\S+:\d+:\s+error:\s+\([^)]*\)\s*")
_IN_FUNCTION = re.compile(r"\s+in function '[^']*'\s*$")

_CORRUPT_RE = re.compile(
    r"corrupt|premature|truncat|incomplete|extraneous|crc error|libpng error|tiff_error|invalid|bad ", re.I
)

def list_images(folder: str | os.PathLike, *, recursive: bool = False) -> list[Path]:
    """The image files of a folder (by suffix, case-insensitive), sorted by path.

    ``recursive`` descends into sub-folders (symbolic links to folders are not
    followed, so a link loop cannot recurse forever).

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> (d / "sub").mkdir()
    >>> for name in ("b.PNG", "a.jpg", "anim.gif", "notes.txt", "sub/c.tif"):
    ...     _ = (d / name).write_bytes(b"")
    >>> [p.name for p in list_images(d)]
    ['a.jpg', 'anim.gif', 'b.PNG']
    >>> [p.relative_to(d).as_posix() for p in list_images(d, recursive=True)]
    ['a.jpg', 'anim.gif', 'b.PNG', 'sub/c.tif']
    """
    root = Path(folder)
    if not recursive:
        return sorted(q for q in root.iterdir() if q.is_file() and q.suffix.lower() in IMAGE_SUFFIXES)
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames.sort()
        out += [Path(dirpath) / f for f in filenames if Path(f).suffix.lower() in IMAGE_SUFFIXES]
    return sorted((q for q in out if q.is_file()), key=lambda q: q.relative_to(root).parts)


def max_pixels_limit(max_pixels: int | None = None) -> int:
    """The pixel limit in force: ``max_pixels``, else ``$SOGDD_MAX_PIXELS``, else :data:`DEFAULT_MAX_PIXELS`
    (2**27).

    Examples
    --------
    >>> max_pixels_limit() == 2**27 or "SOGDD_MAX_PIXELS" in os.environ
    True
    >>> max_pixels_limit(0)
    Traceback (most recent call last):
    ...
    ValueError: max_pixels must be a positive integer, got 0
    """
    if max_pixels is None:
        env = os.environ.get("SOGDD_MAX_PIXELS")
        if not env:
            return DEFAULT_MAX_PIXELS
        try:
            max_pixels = int(env)
        except ValueError:
            raise ValueError(f"SOGDD_MAX_PIXELS must be a positive integer, got {env!r}") from None
        if max_pixels < 1:
            raise ValueError(f"SOGDD_MAX_PIXELS must be a positive integer, got {env!r}")
    if not isinstance(max_pixels, (int, np.integer)) or isinstance(max_pixels, bool) or max_pixels < 1:
        raise ValueError(f"max_pixels must be a positive integer, got {max_pixels!r}")
    return int(max_pixels)


def _split_frame(path: str | os.PathLike) -> tuple[Path, int | None]:
    """``photo.tif[2]`` -> (``photo.tif``, 2), unless a file of that exact name exists."""
    text = os.fsdecode(path)  # a bytes path too, as open() takes
    m = _FRAME_RE.match(text)
    if m and not os.path.lexists(text):
        return Path(m.group(1)), int(m.group(2))
    return Path(text), None


def _read_bytes(p: Path) -> bytes:
    try:
        st = os.stat(p)
    except OSError as exc:
        if exc.errno == errno.ENOENT:
            raise ValueError(f"{p}: no such file") from None
        if exc.errno == errno.ELOOP:
            raise ValueError(f"{p}: symbolic link loop") from None
        raise ValueError(f"{p}: {exc.strerror.lower()}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{p}: not a file")
    try:
        return p.read_bytes()
    except OSError as exc:
        raise ValueError(f"{p}: cannot read ({exc.strerror.lower()})") from None


def _decode(data: bytes, flags: int, frame: int | None) -> tuple[np.ndarray | None, str]:
    """Decode with the decoders' stderr chatter captured (fd 2), so it can be judged, not printed.

    Why file descriptor 2: a JPEG with damaged entropy-coded data still decodes;
    libjpeg only warns ("Corrupt JPEG data: 15 extraneous bytes before marker
    0xd9"), and it, libpng ("libpng error: ...") and OpenCV's loaders print to
    the process's stderr themselves. Neither decoder reports it another way:
    ``cv2.imdecode`` returns the image with no status, OpenCV's Python logging
    API only sets a level (no handler to receive messages), and Pillow's
    ``load()`` and ``verify()`` both accept that JPEG without a warning (Pillow
    discards libjpeg's warnings); the corrupt-data tests in ``tests/image``
    fail without the capture. C's ``stderr`` is unbuffered, so every line is
    in the file when fd 2 is restored (no ``fflush`` needed). The lock keeps
    two decodes from swapping fd 2 under each other; anything else the
    process writes to stderr meanwhile goes to the same capture.
    """
    buf = np.frombuffer(data, np.uint8)
    with _STDERR_LOCK, tempfile.TemporaryFile() as log:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(log.fileno(), 2)
        try:
            if frame is None:
                img = cv2.imdecode(buf, flags)
            else:
                ok, mats = cv2.imdecodemulti(buf, flags, range=(frame, frame + 1))
                img = mats[0] if ok and len(mats) else None
        except cv2.error as exc:
            img, err = None, opencv_message(exc)
        else:
            err = ""
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        log.seek(0)
        text = log.read().decode("utf-8", "replace")
    return img, "\n".join(x for x in (text.strip(), err) if x)


def _check_header(p: Path, data: bytes, limit: int, frame: int | None) -> Header | None:
    """Refuse what the header declares past the limit, or an unnamed frame of a multi-frame file;
    ``None`` when no header was read (the decoded size is then checked)."""
    try:
        head = read_header(data)
    except ValueError as exc:
        raise ValueError(f"{p}: {exc}") from None
    if head is None:
        return None
    w, h, frames = head.width, head.height, head.frames
    _check_size(p, w, h, limit)
    if frames > 1 and frame is None:
        raise ValueError(
            f"{p}: {frames} frames (multi-page or animated); name one as '{p}[0]' .. '{p}[{frames - 1}]'"
        )
    if frame is not None and frame >= frames:
        raise ValueError(f"{p}: frame {frame} requested, the file has {frames}")
    return head


def _check_size(p: Path, w: int, h: int, limit: int) -> None:
    if w * h > limit:
        raise ValueError(
            f"{p}: {w}x{h} image ({w * h} pixels) exceeds the limit of {limit} pixels "
            "(max_pixels, --max-pixels, SOGDD_MAX_PIXELS)"
        )


def read_image(
    path: str | os.PathLike,
    *,
    max_pixels: int | None = None,
    allow_corrupt: bool = False,
    ignore_orientation: bool = False,
) -> np.ndarray:
    """Read an image file as a numpy array (grey or RGB), keeping its bit depth
    (:func:`read_image_and_orientation` also says the file's EXIF orientation).

    Parameters
    ----------
    path : str or path-like
        The file. ``"name.tif[2]"`` selects frame 2 (from 0) of a multi-page or
        animated file; such a file without a frame is an error, never silently
        its first frame.
    max_pixels : int, optional
        Largest width x height accepted, checked from the file header before
        any decoding (decompression bombs), or after it for the few formats
        whose header Pillow does not read (HDR, EXR, PAM; OpenCV's own limit
        of 2**30 pixels then bounds the decoding). Default
        ``$SOGDD_MAX_PIXELS`` or 2**27 (134 Mpx; :data:`DEFAULT_MAX_PIXELS`).
    allow_corrupt : bool
        Accept an image whose decoder reported corrupt or truncated data
        (default: a ``ValueError``). Decoder messages never reach stderr.
    ignore_orientation : bool
        Keep the stored pixel order (a TIFF's too, which OpenCV turns whatever its
        flags). By default the EXIF orientation is applied, as ``cv2.imread``
        does, so corners are in the frame ``cv2.imread`` returns.

    Raises ``ValueError`` (one line naming the file) for a missing, unreadable,
    oversized, multi-frame or corrupt file. An alpha channel is dropped.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "grey.png"
    >>> _ = cv2.imwrite(str(path), np.full((4, 6), 200, np.uint8))
    >>> img = read_image(path)
    >>> img.shape, img.dtype.name, int(img[0, 0])
    ((4, 6), 'uint8', 200)
    >>> read_image(path, max_pixels=20)
    Traceback (most recent call last):
    ...
    ValueError: ...grey.png: 6x4 image (24 pixels) exceeds the limit of 20 pixels (max_pixels, ...)
    >>> read_image(path.with_name("missing.png"))
    Traceback (most recent call last):
    ...
    ValueError: ...missing.png: no such file
    """
    return read_image_and_orientation(path, max_pixels=max_pixels, allow_corrupt=allow_corrupt,
                                      ignore_orientation=ignore_orientation)[0]


def read_image_and_orientation(
    path: str | os.PathLike,
    *,
    max_pixels: int | None = None,
    allow_corrupt: bool = False,
    ignore_orientation: bool = False,
) -> tuple[np.ndarray, int]:
    """:func:`read_image`, and the file's EXIF orientation (1-8; 1 when it has none), which was applied
    unless ``ignore_orientation``.

    Examples
    --------
    >>> import io, tempfile
    >>> from PIL import Image
    >>> exif = Image.Exif()
    >>> exif[0x0112] = 6  # stored 6 x 4, shown turned a quarter clockwise
    >>> path = Path(tempfile.mkdtemp()) / "turned.png"
    >>> Image.new("L", (6, 4)).save(path, exif=exif.tobytes())
    >>> img, turn = read_image_and_orientation(path)
    >>> img.shape, turn, read_image_and_orientation(path, ignore_orientation=True)[0].shape
    ((6, 4), 6, (4, 6))
    """
    p, frame = _split_frame(path)
    limit = max_pixels_limit(max_pixels)
    data = _read_bytes(p)
    if not data:
        raise ValueError(f"{p}: empty file")
    head = _check_header(p, data, limit, frame)
    flags = cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH
    if ignore_orientation:
        flags |= cv2.IMREAD_IGNORE_ORIENTATION
    try:
        img, log = _decode(data, flags, frame)
    except MemoryError:
        raise ValueError(f"{p}: not enough memory to decode it") from None
    first = decoder_words(log.splitlines()[0]) if log.strip() else ""
    if img is None:
        why = f": {first}" if first else " (corrupt or unsupported format)"
        raise ValueError(f"{p}: not a readable image{why}")
    if head is None:  # a format whose header Pillow does not read: OpenCV's own limit bounded the decoding
        _check_size(p, img.shape[1], img.shape[0], limit)
    if _CORRUPT_RE.search(log) and not allow_corrupt:
        raise ValueError(f"{p}: corrupt or truncated image data ({first}); --allow-corrupt to use it anyway")
    if img.ndim == 3 and img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB, dst=img)  # in place: no second copy of a large photo
    elif img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    turn = 1 if head is None else head.orientation
    if ignore_orientation and head is not None and head.format == "TIFF" and turn > 1 and (
            turn < 5 or img.shape[:2] == (head.width, head.height)):
        img = undo_orientation(img, turn)  # OpenCV turns a TIFF whatever its flags (tests/image check it)
    return img, turn


def undo_orientation(image: np.ndarray, orientation: int) -> np.ndarray:
    """The stored pixels of an image shown with EXIF ``orientation`` applied (1-8): the inverse transform.

    Examples
    --------
    >>> a = np.arange(6).reshape(2, 3)
    >>> undo_orientation(np.rot90(a, -1), 6).tolist()  # 6: shown turned a quarter clockwise
    [[0, 1, 2], [3, 4, 5]]
    """
    img = np.asarray(image)
    undo = {2: lambda a: a[:, ::-1], 3: lambda a: a[::-1, ::-1], 4: lambda a: a[::-1],
            5: lambda a: a.swapaxes(0, 1), 6: lambda a: np.rot90(a, 1),
            7: lambda a: a[::-1, ::-1].swapaxes(0, 1), 8: lambda a: np.rot90(a, -1)}.get(int(orientation))
    return img if undo is None else np.ascontiguousarray(undo(img))


def decoder_words(line: str) -> str:
    """A decoder's log line in its own words: OpenCV's level, source place, version and function cut away.

    Examples
    --------
    >>> decoder_words("[ERROR:0@0.9] global loadsave.cpp:1412 imdecode_ imdecode_(''): can't read data: "
    ...               "OpenCV(5.1.0) /io/bitstrm.cpp:59: error: (-2:Unspecified error) Unexpected end of "
    ...               "input stream in function 'readBlock'")
    'Unexpected end of input stream'
    >>> decoder_words("Corrupt JPEG data: premature end of data segment")
    'Corrupt JPEG data: premature end of data segment'
    """
    line = _LOG_PLACE.sub("", line)
    cut = _CV_ERROR.search(line)
    if cut:
        line = line[cut.end():]
    return _IN_FUNCTION.sub("", line).strip()


def opencv_message(exc: BaseException) -> str:
    """The one-line message of an OpenCV error (``cv2.error`` spreads it over lines; the last says it all).

    Examples
    --------
    >>> try:
    ...     cv2.cornerSubPix(np.zeros((5, 5), np.float32), np.zeros((1, 1, 2), np.float32), (3, 3), (-1, -1),
    ...                      (cv2.TERM_CRITERIA_COUNT, 1, 0))
    ... except cv2.error as exc:
    ...     print(opencv_message(exc).split(": error: ")[1][:26])
    (-215:Assertion failed) sr
    """
    lines = str(exc).strip().splitlines()
    return lines[-1] if lines else type(exc).__name__
