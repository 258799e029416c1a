"""EXIF orientation from the header, and ``ignore_orientation`` keeping the stored pixels in every format."""

import io

import numpy as np
import pytest
from PIL import Image

import sogdd
from sogdd.image.files import read_image_and_orientation, undo_orientation
from sogdd.image.header import read_header

#: stored 24 x 36 pixels with no symmetry, so that each orientation is told apart
STORED = np.kron(np.arange(24, dtype=np.uint8).reshape(4, 6) * 10, np.ones((6, 6), np.uint8))


def _tagged(fmt: str, turn: int) -> bytes:
    exif = Image.Exif()
    exif[0x0112] = turn
    buf = io.BytesIO()
    Image.fromarray(STORED).save(buf, fmt, exif=exif.tobytes(), **({"quality": 100} if fmt == "JPEG" else {}))
    return buf.getvalue()


@pytest.mark.parametrize("fmt,ext", [("JPEG", "jpg"), ("PNG", "png"), ("WEBP", "webp"), ("TIFF", "tif")])
@pytest.mark.parametrize("turn", range(1, 9))
def test_the_stored_pixels_and_the_orientation_in_every_format(fmt, ext, turn, tmp_path):
    data = _tagged(fmt, turn)
    head = read_header(data)
    assert (head.width, head.height, head.orientation) == (36, 24, turn)  # a TIFF's size as stored too
    f = tmp_path / f"t.{ext}"
    f.write_bytes(data)
    stored, said = read_image_and_orientation(f, ignore_orientation=True)
    grey = stored if stored.ndim == 2 else stored[..., 1]
    assert said == turn and grey.shape == STORED.shape  # OpenCV turns a TIFF whatever its flags
    assert np.abs(grey.astype(float) - STORED).mean() < 2
    shown = sogdd.read_image(f)
    shown = shown if shown.ndim == 2 else shown[..., 1]
    assert np.abs(undo_orientation(shown, turn).astype(float) - STORED).mean() < 2
