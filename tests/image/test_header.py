"""The header read before decoding (Pillow): sizes and frames of every format OpenCV writes, the
pixel limit where Pillow reads no header, and images kept in the frame cv2.imread gives."""

import io
import struct
import zlib

import cv2
import numpy as np
import pytest
from PIL import Image

import sogdd
from sogdd.image.header import probe


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _png_header(w: int, h: int) -> bytes:
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(b"\0" * 100))
            + _chunk(b"IEND", b""))


@pytest.fixture(scope="module")
def colour():
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(0, 256, (37, 53), dtype=np.uint8), (5, 5), 1)
    return np.dstack([img, np.roll(img, 3, axis=1), 255 - img])


@pytest.mark.parametrize("ext", [".png", ".jpg", ".gif", ".bmp", ".webp", ".tif", ".ppm", ".pgm", ".jp2", ".sr",
                                 ".avif"])
def test_the_header_gives_the_size_of_what_opencv_writes(ext, colour):
    img = cv2.cvtColor(colour, cv2.COLOR_BGR2GRAY) if ext == ".pgm" else colour
    ok, buf = cv2.imencode(ext, img)
    assert ok
    assert probe(bytes(buf)) == (53, 37, 1)


def test_a_size_past_pillows_own_limit_is_read_and_judged_by_ours(tmp_path):
    big = _png_header(20_000, 10_000)  # 200 Mpx: past Pillow's 179 Mpx error, within a limit of 268 Mpx
    before = Image.MAX_IMAGE_PIXELS
    assert probe(big) == (20_000, 10_000, 1)
    assert Image.MAX_IMAGE_PIXELS == before  # Pillow's process-wide setting left alone
    f = tmp_path / "big.png"
    f.write_bytes(big)
    with pytest.raises(ValueError, match="big.png: not a readable image"):  # not refused for its size
        sogdd.read_image(f, max_pixels=2**28)
    with pytest.raises(ValueError, match="20000x10000 image .* exceeds the limit of 100000000"):
        sogdd.read_image(f, max_pixels=10**8)


@pytest.mark.parametrize("ext", [".hdr", ".pam"])
def test_formats_without_a_header_reader_have_their_decoded_size_checked(tmp_path, colour, ext):
    f = tmp_path / f"a{ext}"
    assert cv2.imwrite(str(f), colour.astype(np.float32) / 255 if ext == ".hdr" else colour)
    assert probe(f.read_bytes()) is None
    assert sogdd.read_image(f).shape[:2] == (37, 53)
    with pytest.raises(ValueError, match=f"a{ext}: 53x37 image .* exceeds the limit of 1000 pixels"):
        sogdd.read_image(f, max_pixels=1000)


def test_a_multi_picture_jpeg_is_one_image_as_opencv_decodes_it(tmp_path, colour):
    f = tmp_path / "two.mpo"
    first = Image.fromarray(colour)
    first.save(f, "MPO", save_all=True, append_images=[Image.fromarray(255 - colour)])
    assert Image.open(f).n_frames == 2  # Pillow counts the pictures
    assert probe(f.read_bytes()) == (53, 37, 1)
    assert sogdd.read_image(f).shape == colour.shape


def _with_exif_orientation(jpeg: bytes, orientation: int) -> bytes:
    tiff = (b"II*\x00" + struct.pack("<I", 8) + struct.pack("<H", 1)
            + struct.pack("<HHIHH", 0x0112, 3, 1, orientation, 0) + struct.pack("<I", 0))
    app1 = b"\xff\xe1" + struct.pack(">H", 2 + 6 + len(tiff)) + b"Exif\x00\x00" + tiff
    return jpeg[:2] + app1 + jpeg[2:]


@pytest.mark.parametrize("orientation", range(1, 9))
def test_every_exif_orientation_gives_the_frame_cv2_imread_gives(tmp_path, colour, orientation):
    f = tmp_path / f"o{orientation}.jpg"
    jpeg = bytes(cv2.imencode(".jpg", colour, [cv2.IMWRITE_JPEG_QUALITY, 98])[1])
    f.write_bytes(_with_exif_orientation(jpeg, orientation))
    bgr = cv2.imread(str(f))
    assert bgr.shape[:2] == ((53, 37) if orientation >= 5 else (37, 53))
    np.testing.assert_array_equal(sogdd.read_image(f), bgr[:, :, ::-1])
    assert probe(f.read_bytes()) == (53, 37, 1)  # the stored size: the pixel count is the same
    stored = cv2.imread(str(f), cv2.IMREAD_COLOR | cv2.IMREAD_IGNORE_ORIENTATION)
    np.testing.assert_array_equal(sogdd.read_image(f, ignore_orientation=True), stored[:, :, ::-1])


def test_an_animation_and_pages_are_counted(colour):
    frames = [colour, 255 - colour, np.ascontiguousarray(colour[::-1])]
    for ext, n in ((".tiff", 3), (".gif", 3), (".png", 3), (".webp", 3)):
        ok, buf = cv2.imencodemulti(ext, frames)
        assert ok, ext
        assert probe(bytes(buf)) == (53, 37, n), ext
    f = io.BytesIO()
    Image.fromarray(colour).save(f, "GIF", save_all=True, append_images=[Image.fromarray(255 - colour)])
    assert probe(f.getvalue())[2] == 2
