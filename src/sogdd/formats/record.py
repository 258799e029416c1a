"""One image's record in a feature file: its corners and their provenance.

The schema is described in :mod:`sogdd.formats.features`; this module holds the
record type and what makes one (the source file's stamp, the parameters, a
check that the image name can be written).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import stat
from dataclasses import dataclass

import numpy as np

from .._version import __version__
from ..corners import Corners

__all__ = ["META", "FeatureRecord", "check_name", "make_record", "mask_id", "params_dict", "record",
           "source_stamp"]

#: the provenance fields of a record, in every encoding
META = ("params", "sogdd_version", "source_size", "source_mtime_ns", "source_sha256")


@dataclass(frozen=True)
class FeatureRecord:
    """One image's corners with their provenance (the schema: :mod:`sogdd.formats.features`)."""

    image: str
    corners: Corners
    image_shape: tuple[int, int]
    params: dict | None = None
    sogdd_version: str | None = None
    source_size: int | None = None
    source_mtime_ns: int | None = None
    source_sha256: str | None = None

    def meta(self) -> dict:
        """The provenance fields and the image shape, JSON-ready."""
        return {"image": self.image, "image_shape": [int(v) for v in self.image_shape],
                **{k: getattr(self, k) for k in META}}


def params_dict(preset: str, params, mask=None) -> dict:
    """Resolved :class:`~sogdd.params.Params` as a JSON-ready dict, with the preset's name.

    With a ``mask``, its :func:`mask_id` is one more entry, ``mask``: a changed
    mask is a changed parameter (``--resume`` redoes the file).
    """
    d = {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(params).items()}
    return {"preset": preset, **d, **({"mask": mask_id(mask)} if mask is not None else {})}


def mask_id(mask) -> str:
    """A short name of a mask's content: its shape and the SHA-256 of its pixels, as booleans.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.zeros((4, 6), np.uint8); a[1, 2] = 255
    >>> mask_id(a) == mask_id(a.astype(bool)), mask_id(a) == mask_id(np.zeros((4, 6), bool))
    (True, False)
    >>> mask_id(a)[:8]
    '4x6:sha2'
    """
    m = np.ascontiguousarray(np.asarray(mask) != 0)
    return f"{m.shape[0]}x{m.shape[1]}:sha256:" + hashlib.sha256(np.packbits(m).tobytes()).hexdigest()[:16]


def check_name(name: str) -> str:
    r"""``name`` if it can be written into a feature file (valid UTF-8); else ``ValueError`` naming it.

    A file name that is not valid UTF-8 (bytes such as ``caf\xe9.png`` on Linux,
    which Python holds as lone surrogates) cannot go into a CSV, an npz member
    name or strict JSON; the message shows it with its bad bytes escaped.

    Examples
    --------
    >>> check_name("café.png")
    'café.png'
    >>> check_name(os.fsdecode(b"caf\xe9.png"))
    Traceback (most recent call last):
    ...
    ValueError: caf\xe9.png: the file name is not valid UTF-8; rename the file (e.g. convmv -f latin1 -t utf8)
    """
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        shown = name.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
        raise ValueError(f"{shown}: the file name is not valid UTF-8; rename the file "
                         "(e.g. convmv -f latin1 -t utf8)") from None
    return name


def source_stamp(image: str | os.PathLike) -> tuple[int | None, int | None, str | None]:
    """``(size, mtime_ns, sha256)`` of the file ``image``, or ``(None, None, None)`` if it is not one.

    Taken before the image is read, so a file edited during detection never gets
    the stamp of its new content. Only a regular file has one (a device or a
    FIFO could be read for ever), and at most the size ``stat`` reports is read.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "x.png"
    >>> _ = f.write_bytes(b"abc")
    >>> size, _, digest = source_stamp(f)
    >>> size, digest[:16]
    (3, 'ba7816bf8f01cfea')
    >>> source_stamp(f.parent / "missing.png")
    (None, None, None)
    """
    try:
        if not stat.S_ISREG(os.stat(image).st_mode):  # a FIFO's open() would wait for a writer
            return None, None, None
        # non-blocking: a file swapped for a FIFO since the stat is not waited on
        fd = os.open(image, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):
                return None, None, None
            digest = _sha256_of(f, st.st_size)
    except (OSError, ValueError, TypeError):
        return None, None, None
    return int(st.st_size), int(st.st_mtime_ns), digest


def _sha256_of(f, size: int) -> str:
    """SHA-256 of the first ``size`` bytes of ``f``: never more than the size stat reported, so a
    file that grows while it is read (or a device that never ends) cannot keep the reader for ever."""
    h = hashlib.sha256()
    left = int(size)
    while left > 0:
        chunk = f.read(min(left, 1 << 20))
        if not chunk:
            break
        h.update(chunk)
        left -= len(chunk)
    return h.hexdigest()


def make_record(image: str | os.PathLike, corners: Corners, shape: tuple[int, ...], preset: str,
                params, source: tuple | None = None, *, mask=None) -> FeatureRecord:
    """A record for ``corners`` detected on the file ``image`` with resolved ``params`` (and ``mask``).

    ``source`` is the :func:`source_stamp` taken before the image was read
    (taken now if not given).
    """
    size, mtime, digest = source if source is not None else source_stamp(image)
    return FeatureRecord(str(image), corners, (int(shape[0]), int(shape[1])),
                         params_dict(preset, params, mask), __version__, size, mtime, digest)


def record(image, c: Corners, shape, meta: dict) -> FeatureRecord:
    """A record from the provenance fields found in ``meta`` (missing ones are ``None``)."""
    return FeatureRecord(str(image), c, tuple(int(v) for v in shape), meta.get("params"),
                         meta.get("sogdd_version") or None, meta.get("source_size"),
                         meta.get("source_mtime_ns"), meta.get("source_sha256") or None)
