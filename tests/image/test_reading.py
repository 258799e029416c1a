"""Reading images: bombs, corrupt data, orientation, frames, folders, ranges."""

import struct
import zlib

import cv2
import numpy as np
import pytest

import sogdd
from sogdd.cli.main import main
from sogdd.collection import expand_inputs
from sogdd.image.header import probe
from sogdd.synthetic import pattern_image


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _png_bomb(w: int, h: int) -> bytes:
    """A valid PNG header declaring w x h grey pixels, with a few bytes of data."""
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(b"\0" * 1000))
            + _chunk(b"IEND", b""))


@pytest.fixture(scope="module")
def colour():
    img, _ = pattern_image((120, 160), seed=1)
    return np.dstack([img, np.roll(img, 3, axis=1), 255 - img])


def _one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip() and "it/s" not in ln and "img/s" not in ln]
    assert "Traceback" not in err and "cv2.error" not in err
    errors = [ln for ln in lines if ln.startswith("sogdd: error:")]
    assert len(errors) == 1, err
    return errors[0]


@pytest.mark.parametrize("w, h", [(100_000, 100_000), (30_000, 30_000)])
def test_bomb_header_refused_before_decoding(tmp_path, capsys, w, h):
    f = tmp_path / "bomb.png"
    f.write_bytes(_png_bomb(w, h))
    with pytest.raises(ValueError, match=f"{w}x{h} image .* exceeds the limit"):
        sogdd.read_image(f)
    assert main(["detect", str(f)]) == 2
    assert "bomb.png" in _one_error_line(capsys.readouterr().err)


def test_pixel_limit_from_argument_option_and_environment(tmp_path, monkeypatch, capsys):
    f = tmp_path / "a.png"
    cv2.imwrite(str(f), pattern_image((120, 160))[0])
    with pytest.raises(ValueError, match="exceeds the limit of 4000"):
        sogdd.read_image(f, max_pixels=4000)
    assert sogdd.read_image(f, max_pixels=120 * 160).shape == (120, 160)
    assert main(["detect", str(f), "--max-pixels", "4000"]) == 2
    assert "exceeds" in _one_error_line(capsys.readouterr().err)
    monkeypatch.setenv("SOGDD_MAX_PIXELS", "4000")
    with pytest.raises(ValueError, match="exceeds"):
        sogdd.read_image(f)
    monkeypatch.setenv("SOGDD_MAX_PIXELS", "lots")
    assert main(["detect", str(f)]) == 2
    assert "SOGDD_MAX_PIXELS must be a positive integer" in _one_error_line(capsys.readouterr().err)


def test_no_cv2_error_escapes_a_header_opencv_itself_refuses(tmp_path, monkeypatch):
    f = tmp_path / "bomb.png"
    f.write_bytes(_png_bomb(100_000, 100_000))
    with pytest.raises(ValueError, match="bomb.png: not a readable image"):
        sogdd.read_image(f, max_pixels=10**12)  # past our limit, OpenCV's own check raises cv2.error


def test_corrupt_jpeg_is_an_error_and_its_chatter_stays_off_stderr(tmp_path, colour, capfd):
    ok, buf = cv2.imencode(".jpg", colour)
    data = bytes(buf)
    rng = np.random.default_rng(0)
    bad = data[: len(data) // 2] + rng.integers(0, 256, 200, dtype=np.uint8).tobytes() + data[len(data) // 2:]
    f = tmp_path / "corrupt.jpg"
    f.write_bytes(bad)
    with pytest.raises(ValueError, match="corrupt.jpg: corrupt or truncated image data"):
        sogdd.read_image(f)
    assert capfd.readouterr().err == ""  # libjpeg's own line was captured, not printed
    assert sogdd.read_image(f, allow_corrupt=True).shape == colour.shape
    assert main(["detect", str(f)]) == 2
    err = capfd.readouterr().err
    assert "Corrupt JPEG data" not in err.split("sogdd: error:")[0]  # nothing ahead of our line
    assert "corrupt.jpg" in _one_error_line(err)
    assert main(["detect", str(f), "--allow-corrupt"]) == 0
    (tmp_path / "trunc.jpg").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="trunc.jpg"):
        sogdd.read_image(tmp_path / "trunc.jpg")


def _with_exif_orientation(jpeg: bytes, orientation: int) -> bytes:
    tiff = (b"II*\x00" + struct.pack("<I", 8) + struct.pack("<H", 1)
            + struct.pack("<HHIHH", 0x0112, 3, 1, orientation, 0) + struct.pack("<I", 0))
    app1 = b"\xff\xe1" + struct.pack(">H", 2 + 6 + len(tiff)) + b"Exif\x00\x00" + tiff
    return jpeg[:2] + app1 + jpeg[2:]


def test_exif_orientation_is_applied_as_cv2_imread_does(tmp_path, colour, capsys):
    f = tmp_path / "rotated.jpg"
    jpeg = bytes(cv2.imencode(".jpg", colour, [cv2.IMWRITE_JPEG_QUALITY, 98])[1])
    f.write_bytes(_with_exif_orientation(jpeg, 6))
    bgr = cv2.imread(str(f))
    assert bgr.shape[:2] == (160, 120)  # cv2.imread rotated it
    img = sogdd.read_image(f)
    np.testing.assert_array_equal(img, bgr[:, :, ::-1])
    assert sogdd.read_image(f, ignore_orientation=True).shape[:2] == (120, 160)
    assert main(["detect", str(f), "--format", "json", "--max-corners", "20"]) == 0
    import json

    (obj,) = json.loads(capsys.readouterr().out)
    kp = sogdd.SOGDD(max_corners=20).detect(bgr)
    np.testing.assert_allclose(np.array([obj["x"], obj["y"]]).T, [k.pt for k in kp], atol=1e-3)
    assert obj["image_shape"] == [160, 120]


def test_multi_frame_files_need_a_frame(tmp_path, colour):
    frames = [colour, colour[::-1].copy(), np.ascontiguousarray(colour[:, ::-1])]
    tif = tmp_path / "pages.tif"
    ok, buf = cv2.imencodemulti(".tiff", frames)
    tif.write_bytes(bytes(buf))
    gif = tmp_path / "anim.gif"
    ok, buf = cv2.imencodemulti(".gif", frames[:2])
    gif.write_bytes(bytes(buf))
    for f, n in ((tif, 3), (gif, 2)):
        with pytest.raises(ValueError, match=rf"{n} frames .* name one as '.*{f.name}\[0\]'"):
            sogdd.read_image(f)
        assert probe(f.read_bytes())[2] == n
    np.testing.assert_array_equal(sogdd.read_image(f"{tif}[1]"), frames[1][:, :, ::-1])  # BGR written
    assert sogdd.read_image(f"{gif}[1]").shape == colour.shape
    with pytest.raises(ValueError, match="frame 5 requested, the file has 3"):
        sogdd.read_image(f"{tif}[5]")
    assert expand_inputs([f"{tif}[2]"]) == [tif.parent / "pages.tif[2]"]


def test_folders_of_every_readable_format_and_recursive(tmp_path, colour):
    for ext in (".gif", ".webp", ".bmp", ".tif", ".ppm"):
        assert cv2.imwrite(str(tmp_path / f"a{ext}"), colour)
    (tmp_path / "sub").mkdir()
    cv2.imwrite(str(tmp_path / "sub" / "b.gif"), colour)
    assert len(expand_inputs([str(tmp_path)])) == 5
    found = expand_inputs([str(tmp_path)], recursive=True)
    assert len(found) == 6 and found[-1].name == "b.gif"
    for p in found:
        assert sogdd.read_image(p).shape[:2] == (120, 160)


def test_value_range_for_12_bit_and_0_255_float_data(tmp_path, capsys):
    img, _ = pattern_image((120, 160), seed=3)
    twelve = (img.astype(np.uint16) * 16)  # 12-bit data in a uint16 container
    ref = sogdd.detect_corners(img)
    assert len(sogdd.detect_corners(twelve)) == 0  # the silent failure the hint is for
    got = sogdd.detect_corners(twelve, value_range=(0, 4095))
    assert len(got) == len(ref) >= 8
    f = tmp_path / "twelve.png"
    cv2.imwrite(str(f), twelve)
    assert main(["detect", str(f)]) == 0
    err = capsys.readouterr().err
    assert err.count("sogdd: note:") == 1 and "--value-range 0,4095" in err
    assert main(["detect", str(f), "--value-range", "0,4095", "--format", "json"]) == 0
    assert len(__import__("json").loads(capsys.readouterr().out)[0]["x"]) == len(ref)
    as_float = img.astype(np.float64)
    with pytest.raises(ValueError, match=r"value_range=\(lo, hi\).*--value-range"):
        sogdd.detect_corners(as_float)
    np.testing.assert_allclose(sogdd.detect_corners(as_float, value_range=(0, 255)).xy, ref.xy)
    with pytest.raises(ValueError, match="value_range must be two finite numbers"):
        sogdd.detect_corners(img, value_range=(3, 3))


def test_low_count_hint_suggests_a_relative_selection(tmp_path, capsys):
    img, _ = pattern_image((120, 160), seed=3)
    f = tmp_path / "faint.png"
    cv2.imwrite(str(f), (img // 8 + 100).astype(np.uint8))  # structure, but weak contrast
    assert main(["detect", str(f)]) == 0
    err = capsys.readouterr().err
    assert "--threshold none --max-corners N" in err
    flat = tmp_path / "flat.png"
    cv2.imwrite(str(flat), np.full((60, 80), 128, np.uint8))
    assert main(["detect", str(flat)]) == 0
    assert "note" not in capsys.readouterr().err  # nothing to find: no advice


def test_symlink_loop_and_unreadable_names_say_what_they_are(tmp_path):
    loop = tmp_path / "loop.png"
    loop.symlink_to(loop)
    with pytest.raises(ValueError, match="loop.png: symbolic link loop"):
        sogdd.read_image(loop)
    with pytest.raises(ValueError, match="not a file"):
        sogdd.read_image(tmp_path)


@pytest.mark.parametrize("ext", [".png", ".jpg", ".gif", ".bmp", ".webp", ".tif", ".ppm"])
def test_header_probe_reads_the_size_of_each_format(ext):
    img = np.random.default_rng(0).integers(0, 256, (37, 53, 3), dtype=np.uint8)
    ok, buf = cv2.imencode(ext, img)
    assert probe(bytes(buf)) == (53, 37, 1)


def test_a_truncated_image_is_one_plain_line(tmp_path):
    """The decoder's words, without OpenCV's log prefix, source path and function name."""
    path = tmp_path / "trunc.pgm"
    path.write_bytes(b"P5\n4 4\n255\n")
    with pytest.raises(ValueError) as err:
        sogdd.read_image(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: not a readable image") and "\n" not in msg
    assert not any(w in msg for w in ("[ERROR", "loadsave", ".cpp", "OpenCV(", "in function")), msg
