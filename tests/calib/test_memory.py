"""Memory: the calibration's detection of a view holds at most its documented bound per image pixel, and the
default pixel limit keeps two workers of it within a 2-core, 24 GB machine; a small file of a huge image is
refused from its header, before any decoding."""

from __future__ import annotations

import struct
import tracemalloc
import zlib

import cv2
import numpy as np
import pytest

from sogdd.calib import parse_board
from sogdd.calib.detection import detect_view
from sogdd.cli.main import main
from sogdd.image.files import DEFAULT_MAX_PIXELS, PEAK_BYTES_FIXED, PEAK_BYTES_PER_PIXEL, read_image


def _flat_png(w: int, h: int) -> bytes:
    """A valid grey PNG of w x h pixels of one level, compressed to almost nothing (no w x h array made)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    z, row, parts = zlib.compressobj(9), b"\0" + b"\x80" * w, []
    for _ in range(h):
        parts.append(z.compress(row))
    parts.append(z.flush())
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", b"".join(parts)) + chunk(b"IEND", b"")


def test_a_small_file_of_a_huge_image_is_refused_before_decoding(tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    bomb = folder / "flat.png"
    bomb.write_bytes(_flat_png(16000, 16000))
    assert bomb.stat().st_size < 400_000
    with pytest.raises(ValueError, match=r"16000x16000 image \(256000000 pixels\) exceeds the limit of 134217"):
        read_image(bomb)
    assert main(["calibrate", str(folder), "--out", str(tmp_path / "out"), "--quiet", "--jobs", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "exceeds the limit of 134217728 pixels" in err
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_the_default_limit_holds_two_workers_on_a_24_gb_machine():
    worker = DEFAULT_MAX_PIXELS * PEAK_BYTES_PER_PIXEL + PEAK_BYTES_FIXED
    assert 2 * worker <= 12 * 10**9  # half the machine, the rest for the system and the main process
    assert DEFAULT_MAX_PIXELS >= 11648 * 8736  # a 102 Mpx medium-format sensor is read


@pytest.fixture(scope="module")
def frames(render, tmp_path_factory):
    """A rendered board as a grey PNG and a colour JPEG (1600 x 1200), and a flat 2000 x 1500 grey PNG (the
    search's worst case per pixel near this size)."""
    folder = tmp_path_factory.mktemp("memory")
    cam = render.camera_for(1600, 1200)
    board = render.Board(9, 6, 1.0)
    (rv, tv), = render.random_poses(cam, board, 1, seed=2)
    grey = render.render_view(cam, board, rv, tv, supersample=2, blur=1.0, noise=2.0, rng=0).image
    cv2.imwrite(str(folder / "board.png"), grey)
    cv2.imwrite(str(folder / "board.jpg"), cv2.merge([grey, grey // 2 + 60, 255 - grey]))
    cv2.imwrite(str(folder / "flat.png"), np.full((1500, 2000), 128, np.uint8))
    return folder


@pytest.mark.parametrize("name", ["board.png", "board.jpg", "flat.png"])
@pytest.mark.parametrize("board", ["chessboard:9x6", "chessboard:auto"])
def test_the_detection_of_a_view_holds_at_most_its_bound_per_pixel(frames, name, board):
    spec, path = parse_board(board), frames / name
    detect_view(frames / "board.png", spec)  # compiled, and the libraries' first allocations made
    h, w = cv2.imread(str(path), cv2.IMREAD_UNCHANGED).shape[:2]
    tracemalloc.start()
    try:
        r = detect_view(path, spec)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert not r.error and (name == "flat.png" or len(r.boards) == 1)
    assert peak <= PEAK_BYTES_PER_PIXEL * w * h + PEAK_BYTES_FIXED, f"{peak / (w * h):.1f} bytes per pixel"
