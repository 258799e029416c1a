"""Image size and frame count from a file's header, without decoding the pixels.

Read before decoding so that a decompression bomb (a small file declaring a
huge image) is refused before any memory is allocated for it, and so that a
multi-frame file (animated GIF, APNG or WebP, multi-page TIFF) is recognised.
Covers PNG, JPEG, GIF, BMP, WebP, TIFF and PNM; anything else gives ``None``
(OpenCV's own pixel limit and error handling then apply).
"""

from __future__ import annotations

import re
import struct

__all__ = ["probe"]

# JPEG start-of-frame markers (not DHT C4, JPG C8, DAC CC)
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_MAX_IFDS = 100_000


def probe(data: bytes) -> tuple[int, int, int] | None:
    """``(width, height, frames)`` declared by the header of an encoded image, or ``None``.

    ``width`` and ``height`` are the largest declared by any frame (so the
    pixel count bounds what decoding one frame allocates).

    Examples
    --------
    >>> import cv2, numpy as np
    >>> probe(cv2.imencode(".png", np.zeros((3, 5), np.uint8))[1].tobytes())
    (5, 3, 1)
    >>> probe(b"not an image") is None
    True
    """
    try:
        for sig, fn in _PARSERS:
            if data.startswith(sig):
                return fn(data)
        if re.match(rb"P[1-7]\s", data[:3]):
            return _pnm(data)
    except (struct.error, IndexError, ValueError):
        return None
    return None


def _png(d: bytes) -> tuple[int, int, int]:
    w, h = struct.unpack(">II", d[16:24])
    frames, pos = 1, 8
    while pos + 8 <= len(d):
        n, kind = struct.unpack(">I4s", d[pos : pos + 8])
        if kind == b"acTL":  # APNG: the number of frames comes before the image data
            frames = struct.unpack(">I", d[pos + 8 : pos + 12])[0]
        if kind in (b"IDAT", b"IEND"):
            break
        pos += 12 + n
    return w, h, max(1, frames)


def _jpeg(d: bytes) -> tuple[int, int, int] | None:
    pos = 2
    while pos + 4 <= len(d):
        if d[pos] != 0xFF:
            return None
        marker = d[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            pos += 2
            continue
        n = struct.unpack(">H", d[pos + 2 : pos + 4])[0]
        if marker in _SOF:
            h, w = struct.unpack(">HH", d[pos + 5 : pos + 9])
            return w, h, 1
        pos += 2 + n
    return None


def _gif(d: bytes) -> tuple[int, int, int]:
    w, h, flags = struct.unpack("<HHB", d[6:11])
    pos = 13 + (3 << ((flags & 7) + 1) if flags & 0x80 else 0)
    frames = 0
    while pos < len(d):
        block = d[pos]
        if block == 0x3B:  # trailer
            break
        if block == 0x2C:  # image descriptor
            fw, fh, fflags = struct.unpack("<HHB", d[pos + 5 : pos + 10])
            w, h = max(w, fw), max(h, fh)
            frames += 1
            pos += 10 + (3 << ((fflags & 7) + 1) if fflags & 0x80 else 0) + 1  # + LZW code size
        elif block == 0x21:  # extension: label, then sub-blocks
            pos += 2
        else:
            break
        while pos < len(d) and d[pos]:  # data sub-blocks
            pos += 1 + d[pos]
        pos += 1
    return w, h, max(1, frames)


def _bmp(d: bytes) -> tuple[int, int, int]:
    if struct.unpack("<I", d[14:18])[0] == 12:
        w, h = struct.unpack("<HH", d[18:22])
    else:
        w, h = struct.unpack("<ii", d[18:26])
    return abs(w), abs(h), 1


def _webp(d: bytes) -> tuple[int, int, int] | None:
    if d[8:12] != b"WEBP":
        return None
    kind, body = d[12:16], d[20:]
    if kind == b"VP8X":
        w = int.from_bytes(body[4:7], "little") + 1
        h = int.from_bytes(body[7:10], "little") + 1
        return w, h, max(1, d.count(b"ANMF")) if body[0] & 0x02 else 1
    if kind == b"VP8 ":
        w, h = struct.unpack("<HH", body[6:10])
        return w & 0x3FFF, h & 0x3FFF, 1
    if kind == b"VP8L":
        bits = struct.unpack("<I", body[1:5])[0]
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1, 1
    return None


def _tiff(d: bytes) -> tuple[int, int, int] | None:
    e = "<" if d[:2] == b"II" else ">"
    if struct.unpack(e + "H", d[2:4])[0] != 42:  # BigTIFF and others: not parsed
        return None
    off = struct.unpack(e + "I", d[4:8])[0]
    w = h = frames = 0
    seen = set()
    while off and off not in seen and frames < _MAX_IFDS:
        seen.add(off)
        n = struct.unpack(e + "H", d[off : off + 2])[0]
        for i in range(n):
            tag, typ, _, val = struct.unpack(e + "HHI4s", d[off + 2 + 12 * i : off + 14 + 12 * i])
            if tag in (256, 257):
                v = struct.unpack(e + ("H" if typ == 3 else "I"), val[: 2 if typ == 3 else 4])[0]
                w, h = (max(w, v), h) if tag == 256 else (w, max(h, v))
        frames += 1
        off = struct.unpack(e + "I", d[off + 2 + 12 * n : off + 6 + 12 * n])[0]
    return w, h, max(1, frames)


def _pnm(d: bytes) -> tuple[int, int, int] | None:
    text = re.sub(rb"#[^\n]*", b" ", d[:1024])
    tokens = text.split()
    if tokens[0] == b"P7":  # PAM: WIDTH/HEIGHT keywords
        kv = dict(zip(tokens[1::2], tokens[2::2]))
        return int(kv[b"WIDTH"]), int(kv[b"HEIGHT"]), 1
    return int(tokens[1]), int(tokens[2]), 1


_PARSERS = (
    (b"\x89PNG\r\n\x1a\n", _png),
    (b"\xff\xd8", _jpeg),
    (b"GIF87a", _gif),
    (b"GIF89a", _gif),
    (b"BM", _bmp),
    (b"RIFF", _webp),
    (b"II*\x00", _tiff),
    (b"MM\x00*", _tiff),
)
