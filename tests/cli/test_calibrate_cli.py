"""sogdd calibrate end to end on rendered views: outputs, report, and the one-line errors (exit 2).

Most tests run the command with a stand-in board detector (OpenCV's
findChessboardCorners + cornerSubPix), so that the command's own logic is
tested whatever the state of sogdd's detector; the last ones run sogdd's own
detector (sogdd.calib.targets.chessboard), with --jobs 2.
"""

from __future__ import annotations

import csv
import json
import shutil
import sys
import types

import cv2
import numpy as np
import pytest

import sogdd.calib
from sogdd.calib.files import read_camera
from sogdd.calib.targets.board import Board
from sogdd.cli.main import main

K_TRUE = np.array([[560.0, 0, 322.0], [0, 560.0, 236.0], [0, 0, 1]])
DIST = (-0.2, 0.06, 0.001, -0.0005, 0.0)
SIZES = [(9, 6), (8, 5), (7, 5)]  # what the stand-in looks for when the size is unknown


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    """Eight rendered 640x480 views of a 9x6 board (blur 0.8 px, noise 2 grey levels)."""
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    cam = render.Camera(K_TRUE, DIST, (640, 480))
    target = render.ChessboardTarget(9, 6, 1.0)
    folder = tmp_path_factory.mktemp("frames")
    for k, (rv, tv) in enumerate(render.random_sequence(cam, target, 8, seed=3)):
        view = render.render_view(cam, target, rv, tv, blur=0.8, noise=2.0, rng=k)
        assert cv2.imwrite(str(folder / f"f{k}.png"), view.image)
    return folder


def _opencv_boards(img, pattern=None):
    for size in [pattern] if pattern is not None else SIZES:
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_FAST_CHECK
        ok, c = cv2.findChessboardCorners(img, size, flags=flags)
        if ok:
            crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 1e-3)
            c = cv2.cornerSubPix(img, c, (5, 5), (-1, -1), crit)
            j, i = np.mgrid[0:size[1], 0:size[0]]
            return [Board(c.reshape(-1, 2), np.c_[i.ravel(), j.ravel()], size=size)]
    return []


@pytest.fixture
def stand_in(monkeypatch):
    """sogdd.calib.targets.chessboard replaced by OpenCV's detector (in this process: --jobs 1)."""
    fake = types.ModuleType("sogdd.calib.targets.chessboard")
    fake.detect_boards = _opencv_boards
    monkeypatch.setitem(sys.modules, "sogdd.calib.targets.chessboard", fake)
    monkeypatch.setattr(sogdd.calib, "detect", fake, raising=False)


def _run(capsys, *argv):
    code = main(["calibrate", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def test_end_to_end_writes_every_output(frames, tmp_path, capsys, stand_in):
    out = tmp_path / "calib"
    code, text, err = _run(capsys, str(frames / "*.png"), "--board", "chessboard:9x6", "--square", 25,
                           "--out", out)
    assert code == 0, err
    assert "RMS" in text and "8 of 8 views used" in text
    fs = cv2.FileStorage(str(out / "camera.yaml"), cv2.FILE_STORAGE_READ)
    K = fs.getNode("camera_matrix").mat()
    assert fs.getNode("image_width").real() == 640 and abs(K[0, 0] - 560.0) < 560 * 0.01
    fs.release()
    assert read_camera(out / "camera.json")["camera_matrix"][1, 1] == pytest.approx(K[1, 1])
    views = list(csv.DictReader(open(out / "views.csv")))
    assert [v["view"] for v in views] == [f"f{k}.png" for k in range(8)]
    assert all(v["corners_found"] == "54" for v in views)
    corners = list(csv.DictReader(open(out / "corners.csv")))
    assert len(corners) == 8 * 54 and {c["view"] for c in corners} == {f"f{k}.png" for k in range(8)}
    html = (out / "report.html").read_text()
    assert "Verdict" in html and (out / "report" / "coverage.png").is_file()
    assert len(list((out / "report").glob("view_*.png"))) == 8


def test_json_summary_with_two_processes(frames, tmp_path, capsys, stand_in):
    # the workers are forked, so they inherit the stand-in detector
    code, text, _ = _run(capsys, frames, "--board", "chessboard:9x6", "--out", tmp_path / "o", "--json",
                         "--no-report", "--jobs", 2)
    d = json.loads(text)
    assert code == 0 and d["views_used"] == 8 and abs(d["fx"] - 560.0) < 6 and d["verdict"]
    assert not (tmp_path / "o" / "report.html").exists()


@pytest.mark.parametrize("spec", ["chessboard", "chessboard:9by6", "chessboard:1x6",
                                  "charuco:5x7:1.5:DICT_5X5_100", "charuco:5x7:0.7:DICT_NOPE", "circles:4x11"])
def test_bad_board_syntax(spec, tmp_path, capsys):
    code, _, err = _run(capsys, tmp_path / "x.png", "--board", spec, "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "--board" in err
    assert not (tmp_path / "o").exists()


def test_no_board_in_any_image(tmp_path, capsys, stand_in):
    for k in range(3):
        cv2.imwrite(str(tmp_path / f"blank{k}.png"), np.full((480, 640), 128, np.uint8))
    code, _, err = _run(capsys, tmp_path, "--board", "chessboard:9x6", "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1
    assert "no board (chessboard:9x6) in any of the 3 image(s)" in err and "blank0.png: no board" in err


def test_a_board_size_that_contradicts_the_option(frames, tmp_path, capsys, stand_in):
    code, _, err = _run(capsys, frames, "--board", "chessboard:8x5", "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1
    assert "contradicts the images: 8 of 8 show a board of 9x6 inner corners" in err
    assert "--board chessboard:9x6" in err


def test_a_board_smaller_than_the_option(frames, tmp_path, capsys, monkeypatch):
    """A detector that returns every view's whole 9x6 grid as a partial board of --board 10x7."""
    fake = types.ModuleType("sogdd.calib.targets.chessboard")
    fake.detect_boards = lambda img, pattern=None: [Board(b.image_points, b.labels + 1)
                                                    for b in _opencv_boards(img, (9, 6))]
    monkeypatch.setitem(sys.modules, "sogdd.calib.targets.chessboard", fake)
    monkeypatch.setattr(sogdd.calib, "detect", fake, raising=False)
    code, _, err = _run(capsys, frames, "--board", "chessboard:10x7", "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1
    assert "all 8 boards show exactly 9x6 inner corners; give --board chessboard:9x6" in err
    assert not (tmp_path / "o").exists()


def test_two_boards_in_one_image_are_two_views(frames, tmp_path, capsys, monkeypatch):
    """Each board has its own pose: a second board in an image is the view NAME#2."""
    def two(img, pattern=None):
        (b,) = _opencv_boards(img, (9, 6))
        left, right = b.labels[:, 0] < 4, b.labels[:, 0] >= 4
        return [Board(b.image_points[left], b.labels[left]), Board(b.image_points[right], b.labels[right])]

    fake = types.ModuleType("sogdd.calib.targets.chessboard")
    fake.detect_boards = two
    monkeypatch.setitem(sys.modules, "sogdd.calib.targets.chessboard", fake)
    monkeypatch.setattr(sogdd.calib, "detect", fake, raising=False)
    code, _, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", tmp_path / "o", "--no-report")
    assert code == 0, err
    views = list(csv.DictReader(open(tmp_path / "o" / "views.csv")))
    assert [v["view"] for v in views[:2]] == ["f0.png", "f0.png#2"] and len(views) == 16
    assert views[0]["corners_found"] == "24" and views[1]["corners_found"] == "30"


def test_too_few_views(frames, tmp_path, capsys, stand_in):
    code, _, err = _run(capsys, frames / "f0.png", frames / "f1.png", "--board", "chessboard:9x6",
                        "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "too few views" in err and "(1 more)" in err


def test_an_unreadable_image_keeps_the_others(frames, tmp_path, capsys, stand_in):
    imgs = tmp_path / "imgs"
    shutil.copytree(frames, imgs)
    (imgs / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n not a png")
    code, _, err = _run(capsys, imgs, "--board", "chessboard:9x6", "--out", tmp_path / "o")
    assert code == 2 and "broken.png" in err
    assert (tmp_path / "o" / "camera.yaml").is_file()
    names = [v["view"] for v in csv.DictReader(open(tmp_path / "o" / "views.csv"))]
    assert len(names) == 8 and "broken.png" not in names


def test_the_output_folder_is_never_an_input(frames, tmp_path, capsys):
    code, _, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", frames)
    assert code == 2 and "is an input folder" in err
    code, _, err = _run(capsys, frames / "f0.png", "--board", "chessboard:9x6", "--out", frames / "f0.png")
    assert code == 2 and "not a folder" in err
    assert sorted(p.name for p in frames.iterdir()) == [f"f{k}.png" for k in range(8)]


def test_images_of_different_sizes(frames, tmp_path, capsys, stand_in):
    imgs = tmp_path / "imgs"
    shutil.copytree(frames, imgs)
    big = cv2.resize(cv2.imread(str(frames / "f0.png"), 0), (800, 600))
    cv2.imwrite(str(imgs / "z.png"), big)
    code, _, err = _run(capsys, imgs, "--board", "chessboard:9x6", "--out", tmp_path / "o")
    assert code == 2 and "images of different sizes" in err


def test_sogdds_own_detector_end_to_end(frames, tmp_path, capsys):
    """The real board detector, two processes: every view found, the camera recovered."""
    pytest.importorskip("sogdd.calib.targets.chessboard", reason="sogdd's board detector is missing")
    out = tmp_path / "calib"
    code, text, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", out, "--jobs", 2)
    assert code == 0, err
    cam = read_camera(out / "camera.yaml")
    assert abs(cam["camera_matrix"][0, 0] - 560.0) < 560 * 0.01
    views = list(csv.DictReader(open(out / "views.csv")))
    assert all(v["corners_found"] == "54" and v["used"] == "1" for v in views), views
    assert cam["rms"] < 0.1
    code, text, err = _run(capsys, frames, "--board", "chessboard:auto", "--out", tmp_path / "auto")
    assert code == 0, err
    assert abs(read_camera(tmp_path / "auto" / "camera.yaml")["camera_matrix"][0, 0] - 560.0) < 560 * 0.01
    for wrong in ("8x5", "10x7"):
        code, text, err = _run(capsys, frames, "--board", f"chessboard:{wrong}", "--out", tmp_path / wrong)
        assert code == 2 and "contradicts the images" in err and "chessboard:9x6" in err, err


def _opencv_charuco(img, board):
    corners, ids, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(img)
    if ids is None or len(ids) < 4:
        return None
    ids = ids.ravel().astype(int)
    nx = board.getChessboardSize()[0]
    return Board(corners.reshape(-1, 2), np.c_[ids % (nx - 1), ids // (nx - 1)], ids=ids)


@pytest.fixture(scope="module")
def charuco_frames(tmp_path_factory):
    """Six rendered 640x480 views of a ChArUco board of 5x7 squares, markers 0.7 of a square, DICT_5X5_100."""
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    cam = render.Camera(K_TRUE, DIST, (640, 480))
    board = cv2.aruco.CharucoBoard((5, 7), 1.0, 0.7, cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_5X5_100))
    folder = tmp_path_factory.mktemp("charuco")
    for k, (rv, tv) in enumerate(render.random_sequence(cam, render.ChessboardTarget(5, 7, 1.0), 6, seed=5)):
        view = render.render_charuco(cam, board, rv, tv, blur=0.7, noise=1.0, rng=k)
        cv2.imwrite(str(folder / f"c{k}.png"), view.image)
    return folder


def test_charuco_board(charuco_frames, tmp_path, capsys, monkeypatch):
    """charuco:COLSxROWS:MARKER:DICT reaches the ChArUco detector (here OpenCV's) with that board."""
    fake = types.ModuleType("sogdd.calib.targets.charuco")
    seen = []

    def detect_charuco(img, board):
        seen.append(tuple(board.getChessboardSize()))
        return _opencv_charuco(img, board)

    fake.detect_charuco = detect_charuco
    monkeypatch.setitem(sys.modules, "sogdd.calib.targets.charuco", fake)
    monkeypatch.setattr(sogdd.calib, "charuco", fake, raising=False)
    code, _, err = _run(capsys, charuco_frames, "--board", "charuco:5x7:0.7:DICT_5X5_100",
                        "--out", tmp_path / "o", "--no-report")
    assert code == 0, err
    assert seen and all(s == (5, 7) for s in seen)
    assert abs(read_camera(tmp_path / "o" / "camera.yaml")["camera_matrix"][0, 0] - 560.0) < 560 * 0.02


def test_sogdds_own_charuco_detector(charuco_frames, tmp_path, capsys):
    pytest.importorskip("sogdd.calib.targets.charuco", reason="sogdd's ChArUco detector is missing")
    code, _, err = _run(capsys, charuco_frames, "--board", "charuco:5x7:0.7:DICT_5X5_100",
                        "--out", tmp_path / "o", "--no-report")
    assert code == 0, err
    cam = read_camera(tmp_path / "o" / "camera.yaml")
    assert abs(cam["camera_matrix"][0, 0] - 560.0) < 560 * 0.02 and cam["rms"] < 0.1
