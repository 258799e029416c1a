"""sogdd calibrate VIDEO: a rendered video of a board before a known camera (``board_video``, tests/conftest.py)
calibrated as its stills are, views.csv naming each frame chosen and why, and the one-line errors (exit 2)."""

from __future__ import annotations

import csv
import json
import re

import cv2
import numpy as np

from sogdd.calib import calibrate_images
from sogdd.cli.main import main


def _run(capsys, *argv):
    code = main(["calibrate", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def test_a_video_calibrates_as_its_stills_do(board_video, tmp_path, capsys):
    out = tmp_path / "calib"
    code, text, err = _run(capsys, board_video.path, "--board", "chessboard:9x6", "--model", "pinhole",
                           "--no-report", "--json", "--out", out)
    assert code in (0, 3), err
    got = json.loads(text)
    stills = calibrate_images(board_video.stills, "chessboard:9x6", model="pinhole").calibration
    fx_true = board_video.K[0, 0]
    assert abs(got["fx"] - stills.K[0, 0]) < 0.01 * stills.K[0, 0]
    assert abs(got["fx"] - fx_true) < 0.01 * fx_true and abs(got["fy"] - fx_true) < 0.01 * fx_true
    assert abs(stills.K[0, 0] - fx_true) < 0.01 * fx_true
    rows = list(csv.DictReader(open(out / "views.csv")))
    assert 8 <= len(rows) <= 40 and got["views"] == len(rows)
    for r in rows:
        index = int(re.fullmatch(r"board\.avi#frame(\d{6})", r["view"]).group(1))
        assert index not in board_video.blurred
        assert r["reasons"].startswith("sharp (") and "new pose (" in r["reasons"]
    assert any("new coverage (" in r["reasons"] for r in rows)


def test_the_stills_have_no_reasons(board_video, tmp_path, capsys):
    out = tmp_path / "calib"
    code, _, err = _run(capsys, board_video.stills, "--board", "chessboard:9x6", "--model", "pinhole",
                        "--no-report", "--out", out)
    assert code in (0, 3), err
    rows = list(csv.DictReader(open(out / "views.csv")))
    assert rows and {r["reasons"] for r in rows} == {""}


def test_bad_video_inputs_are_one_line_errors(board_video, tmp_path, capsys):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    blank = tmp_path / "blank.avi"
    w = cv2.VideoWriter(str(blank), cv2.VideoWriter_fourcc(*"MJPG"), 25, (160, 120), False)
    for k in range(6):
        w.write(np.full((120, 160), 100 + k, np.uint8))
    w.release()
    cases = [((bad,), "not a video OpenCV can read"),
             ((blank,), "no board (chessboard:9x6) in any frame read"),
             ((board_video.path, "--max-views", 0), "--max-views must be >= 1, got 0"),
             ((board_video.path, "--video-step", 0), "--video-step must be >= 1, got 0"),
             ((board_video.path, blank), "a video is calibrated alone"),
             (("--camera", "left", board_video.path, "--camera", "right", blank),
              "camera right: no board (chessboard:9x6) in any frame read of blank.avi")]
    for args, words in cases:
        out = tmp_path / "out"
        code, _, err = _run(capsys, *args, "--board", "chessboard:9x6", "--out", out)
        assert code == 2, (args, err)
        assert words in err and len(err.strip().splitlines()) == 1, (args, err)
        assert not out.exists()
