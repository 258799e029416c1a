"""sogdd calibrate end to end on rendered views, with sogdd's own board detectors: outputs, report, the
one-line errors (exit 2), Ctrl-C (exit 130) and an output folder left complete or as it was.

A test that needs a detector to return something particular (two boards in one image, a grid smaller
than --board) replaces the real module's function with monkeypatch and runs with --jobs 1 (in this
process).
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import stat

import cv2
import numpy as np
import pytest

from sogdd.calib import report
from sogdd.calib.files import read_camera
from sogdd.calib.targets.board import Board
from sogdd.calib.targets.chessboard import search as chessboard
from sogdd.cli.main import main

K_TRUE = np.array([[560.0, 0, 322.0], [0, 560.0, 236.0], [0, 0, 1]])
DIST = (-0.2, 0.06, 0.001, -0.0005, 0.0)


@pytest.fixture
def frames(rendered_frames):
    """The eight rendered views of the shared fixture (``tests/conftest.py``); read only."""
    return rendered_frames


def _run(capsys, *argv):
    code = main(["calibrate", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def _done(text, unreadable=False):
    """The exit code of a run that wrote its outputs, by what it printed: 3 when its verdict is bad (the
    rendered views cover the frame's centre only), else 2 when an input could not be read, else 0."""
    bad = '"verdict_level": "bad"' in text or any(line.startswith("  bad: ") for line in text.splitlines())
    return 3 if bad else 2 if unreadable else 0


def _tree(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_end_to_end_writes_every_output(frames, tmp_path, capsys):
    out = tmp_path / "calib"
    old = os.umask(0o022)
    try:
        code, text, err = _run(capsys, str(frames / "*.png"), "--board", "chessboard:9x6", "--square", 25,
                               "--out", out)
    finally:
        os.umask(old)
    assert code == _done(text), err
    assert "RMS" in text and "8 of 8 views used" in text
    fs = cv2.FileStorage(str(out / "camera.yaml"), cv2.FILE_STORAGE_READ)
    K = fs.getNode("camera_matrix").mat()
    assert fs.getNode("image_width").real() == 640 and abs(K[0, 0] - 560.0) < 560 * 0.01
    fs.release()
    assert read_camera(out / "camera.json")["camera_matrix"][1, 1] == pytest.approx(K[1, 1])
    views = list(csv.DictReader(open(out / "views.csv")))
    assert [v["view"] for v in views] == [f"f{k}.png" for k in range(8)]
    assert all(v["corners_found"] == "54" and v["status"] == "used" for v in views)
    assert all(0 < float(v["precision_px"]) < 0.05 and float(v["weight"]) > 0 for v in views)
    corners = list(csv.DictReader(open(out / "corners.csv")))
    assert len(corners) == 8 * 54 and {c["view"] for c in corners} == {f"f{k}.png" for k in range(8)}
    assert list(corners[0])[-2:] == ["sigma_px", "source"] and all(float(c["sigma_px"]) > 0 for c in corners)
    assert {c["source"] for c in corners} == {v["source"] for v in views} == {"sogdd"}  # the own search
    html = (out / "report.html").read_text()
    assert "Verdict" in html and (out / "report" / "coverage.png").is_file()
    assert len(list((out / "report").glob("view_*.png"))) == 8
    # the permissions `sogdd detect` gives: the umask's, not mkstemp's 0600
    assert {stat.S_IMODE(p.stat().st_mode) for p in out.rglob("*") if p.is_file()} == {0o644}
    assert {stat.S_IMODE(p.stat().st_mode) for p in [out, out / "report"]} == {0o755}


@pytest.mark.slow
def test_json_summary_with_two_processes(frames, tmp_path, capsys):
    # this process has run numba's parallel code (the rendering): forked workers would die running it
    code, text, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", tmp_path / "o", "--json",
                           "--no-report", "--jobs", 2)
    assert code == _done(text), err
    d = json.loads(text)
    assert d["views_used"] == 8 and abs(d["fx"] - 560.0) < 6 and d["verdict"] and d["unreadable"] == []
    assert not (tmp_path / "o" / "report.html").exists()
    # what to do next, as camera.json has it
    assert d["guidance"] == json.loads((tmp_path / "o" / "camera.json").read_text())["guidance"]
    assert [r["name"] for r in d["guidance"]["regions"]][4] == "centre" and d["guidance"]["tilts"]["views"] == 8


@pytest.mark.parametrize("spec", ["chessboard", "chessboard:9by6", "chessboard:1x6",
                                  "charuco:5x7:1.5:DICT_5X5_100", "charuco:5x7:0.7:DICT_NOPE", "circles:4x11"])
def test_bad_board_syntax(spec, tmp_path, capsys):
    code, _, err = _run(capsys, tmp_path / "x.png", "--board", spec, "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "--board" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("argv, line", [
    (("--jobs", "-1"), "--jobs must be >= 1, got -1"),
    (("--min-views", "0"), "--min-views must be >= 1, got 0"),
    (("--square", "-2.5"), "--square must be a positive size, got -2.5"),
    (("--square", "inf"), "--square must be a positive size, got inf"),
])
def test_the_librarys_checks_are_one_line_naming_the_flag(argv, line, frames, tmp_path, capsys, monkeypatch):
    """The library checks the numbers, before any image is read; the command names its flags."""
    monkeypatch.setattr(chessboard, "find_boards", lambda *a, **k: pytest.fail("an image was searched"))
    code, _, err = _run(capsys, frames, "--board", "chessboard:9x6", *argv, "--out", tmp_path / "o")
    assert (code, err) == (2, f"sogdd: error: {line}\n")
    assert not (tmp_path / "o").exists()


def test_no_board_in_any_image(tmp_path, capsys):
    for k in range(3):
        cv2.imwrite(str(tmp_path / f"blank{k}.png"), np.full((480, 640), 128, np.uint8))
    code, _, err = _run(capsys, tmp_path, "--board", "chessboard:9x6", "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1
    assert "no board (chessboard:9x6) in any of the 3 image(s)" in err and "blank0.png: no board" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("wrong", ["8x5", "10x7"])
def test_a_board_size_that_contradicts_the_option(frames, tmp_path, capsys, wrong):
    code, _, err = _run(capsys, frames, "--board", f"chessboard:{wrong}", "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1
    assert "contradicts the images" in err and "chessboard:9x6" in err, err


def test_a_board_smaller_than_the_option(frames, tmp_path, capsys, monkeypatch):
    """A detector that returns every view's whole 9x6 grid as a partial board of --board 10x7."""
    real = chessboard.detect_boards

    def grid(img, pattern=None, view_only=False, **kw):
        boards = [Board(b.image_points, b.labels + 1) for b in real(img, (9, 6), **kw)]
        return chessboard.BoardSearch(boards, [])

    monkeypatch.setattr(chessboard, "find_boards", grid)
    code, _, err = _run(capsys, frames, "--board", "chessboard:10x7", "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1
    assert "all 8 boards show exactly 9x6 inner corners; give chessboard:9x6" in err
    assert not (tmp_path / "o").exists()


def test_two_boards_in_one_image_are_one_view_or_two_on_request(frames, tmp_path, capsys, monkeypatch):
    """Each board has its own pose: with --boards all a second board in an image is the view NAME#2; by
    default the image's view is its best board (the most corners), the other one a row "ignored"."""
    real = chessboard.detect_boards

    def two(img, pattern=None, view_only=False, **kw):
        (b,) = real(img, (9, 6), **kw)
        # split where the image says: boards that all showed one same grid would be a miscounted --board
        cut = 2 + int(img.sum()) % 5
        left, right = b.labels[:, 0] < cut, b.labels[:, 0] >= cut
        return chessboard.BoardSearch([Board(b.image_points[left], b.labels[left]),
                                       Board(b.image_points[right], b.labels[right])], [])

    monkeypatch.setattr(chessboard, "find_boards", two)
    code, text, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", tmp_path / "o", "--no-report",
                           "--boards", "all")
    assert code == _done(text), err
    views = list(csv.DictReader(open(tmp_path / "o" / "views.csv")))
    assert [v["view"] for v in views[:2]] == ["f0.png", "f0.png#2"] and len(views) == 16
    found = [int(v["corners_found"]) for v in views]
    assert all(a > b and a + b == 54 for a, b in zip(found[::2], found[1::2])), found  # the larger first
    assert {v["status"] for v in views} == {"used"}
    code, text, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", tmp_path / "o", "--no-report")
    assert code == _done(text), err
    assert "8 of 8 views used" in text
    views = list(csv.DictReader(open(tmp_path / "o" / "views.csv")))
    assert [(v["view"], int(v["corners_found"]), v["status"]) for v in views[:2]] == [
        ("f0.png", found[0], "used"), ("f0.png#2", found[1], "ignored")]
    assert views[1]["reason"].startswith(f"another board in the image ({found[1]} corners, cells of")


def test_a_screen_showing_the_board_is_a_row_ignored_never_a_view(frames, tmp_path, capsys):
    """A copy of the board with cells of 5 px (a monitor in the background) beside a view's board."""
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    cam = render.Camera(K_TRUE, DIST, (640, 480))
    target = render.ChessboardTarget(9, 6, 1.0)
    img = render.render_scene(cam, target, np.array([0.2, 0.3, 0.0]), np.array([-6.0, -4.5, 22.0]), blur=0.8)
    # face on, 112 units away: cells of 560 / 112 = 5 px, round the image centre; put in the bottom right
    screen = render.render_scene(cam, target, np.zeros(3), np.array([-4.0, -2.5, 112.0]), blur=0.6)
    img[380:470, 510:630] = screen[191:281, 262:382]
    imgs = tmp_path / "imgs"
    shutil.copytree(frames, imgs)
    cv2.imwrite(str(imgs / "screen.png"), np.rint(img).astype(np.uint8))
    for extra in ((), ("--boards", "all")):
        out = tmp_path / f"o{len(extra)}"
        code, text, err = _run(capsys, imgs, "--board", "chessboard:9x6", "--out", out, "--no-report", *extra)
        assert code == _done(text), err
        assert "9 of 9 views used" in text
        views = {v["view"]: v for v in csv.DictReader(open(out / "views.csv"))}
        assert views["screen.png"]["status"] == "used"
        if not extra:  # one board per image: the screen, under a third of the board's cells, is left
            assert len(views) == 9 and "screen.png#2" not in text
            continue
        assert len(views) == 10 and "ignored screen.png#2: a small board" in text
        small = views["screen.png#2"]
        assert (small["status"], small["used"], small["corners_found"]) == ("ignored", "0", "54")
        assert "(54 corners, cells of 5.0 px)" in small["reason"]
    with pytest.raises(SystemExit) as info:
        _run(capsys, imgs, "--board", "chessboard:9x6", "--out", tmp_path / "x", "--boards", "two")
    assert info.value.code == 2 and "--boards: invalid choice: 'two'" in capsys.readouterr().err


def test_too_few_views(frames, tmp_path, capsys):
    code, _, err = _run(capsys, frames / "f0.png", frames / "f1.png", "--board", "chessboard:9x6",
                        "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "too few views" in err and "(1 more)" in err


def test_an_unreadable_image_is_a_row_of_every_output(frames, tmp_path, capsys):
    imgs = tmp_path / "imgs"
    shutil.copytree(frames, imgs)
    (imgs / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n not a png")
    out = tmp_path / "o"
    code, text, err = _run(capsys, imgs, "--board", "chessboard:9x6", "--out", out)
    assert code == _done(text, unreadable=True) and "broken.png" in err and "Traceback" not in err
    assert "unreadable broken.png" in text
    views = {v["view"]: v for v in csv.DictReader(open(out / "views.csv"))}
    assert len(views) == 9 and views["broken.png"]["status"] == "unreadable"
    assert views["broken.png"]["used"] == "0" and "broken.png" in views["broken.png"]["reason"]
    js = json.loads((out / "camera.json").read_text())
    assert "broken.png" in js["rejected_views"] and any(v["view"] == "broken.png" for v in js["views"])
    assert "broken.png" in (out / "report.html").read_text()


def test_the_suggested_allow_corrupt_exists(frames, tmp_path, capsys):
    imgs = tmp_path / "imgs"
    shutil.copytree(frames, imgs)
    ok, buf = cv2.imencode(".jpg", cv2.imread(str(frames / "f0.png")))
    data = bytes(buf)
    junk = np.random.default_rng(0).integers(0, 256, 200, dtype=np.uint8).tobytes()
    (imgs / "cut.jpg").write_bytes(data[: len(data) // 2] + junk + data[len(data) // 2:])  # decodes, warning
    code, text, err = _run(capsys, imgs, "--board", "chessboard:9x6", "--out", tmp_path / "o")
    assert code == _done(text, unreadable=True) and "cut.jpg" in err and "--allow-corrupt" in err
    code, text, err = _run(capsys, imgs, "--board", "chessboard:9x6", "--out", tmp_path / "o",
                           "--allow-corrupt")
    assert code == _done(text), err
    views = {v["view"]: v for v in csv.DictReader(open(tmp_path / "o" / "views.csv"))}
    assert views["cut.jpg"]["status"] != "unreadable"


def test_the_output_folder_is_never_an_input(frames, tmp_path, capsys):
    before = _tree(frames)
    for named in (frames, frames / "*.png", frames / "f3.png"):
        code, _, err = _run(capsys, named, "--board", "chessboard:9x6", "--out", frames)
        assert code == 2 and "holds the input" in err and err.count("\n") == 1, err
    code, _, err = _run(capsys, frames / "f0.png", "--board", "chessboard:9x6", "--out", frames / "f0.png")
    assert code == 2 and "not a folder" in err
    assert _tree(frames) == before


def test_a_folder_of_other_files_is_refused(frames, tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    code, _, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", out)
    assert code == 2 and "notes.txt" in err and "did not write" in err and err.count("\n") == 1
    assert [p.name for p in out.iterdir()] == ["notes.txt"]


def test_images_of_different_sizes(frames, tmp_path, capsys):
    imgs = tmp_path / "imgs"
    shutil.copytree(frames, imgs)
    big = cv2.resize(cv2.imread(str(frames / "f0.png"), 0), (800, 600))
    cv2.imwrite(str(imgs / "z.png"), big)
    code, _, err = _run(capsys, imgs, "--board", "chessboard:9x6", "--out", tmp_path / "o")
    assert code == 2 and "images of different sizes" in err


def test_a_rerun_with_fewer_views_leaves_no_stale_figures(frames, tmp_path, capsys):
    out = tmp_path / "calib"
    code, text, _ = _run(capsys, frames, "--board", "chessboard:9x6", "--out", out)
    assert code == _done(text)
    assert (out / "report" / "view_0007.png").is_file() and (out / "report" / "cross_validation.png").is_file()
    code, text, err = _run(capsys, *(frames / f"f{k}.png" for k in range(3)), "--board", "chessboard:9x6",
                           "--out", out)
    assert code == _done(text), err
    assert sorted(p.name for p in (out / "report").iterdir()) == [
        "coverage.png", "distortion.png", "errors_per_view.png", "overlay_0000.png", "overlay_0001.png",
        "overlay_0002.png", "poses.png", "residual_histogram.png", "residuals.png", "view_0000.png",
        "view_0001.png", "view_0002.png"]
    assert [p.name for p in tmp_path.iterdir()] == ["calib"]


def test_ctrl_c_leaves_the_output_folder_as_it_was(frames, tmp_path, capsys, monkeypatch):
    out = tmp_path / "calib"
    code, text, _ = _run(capsys, frames, "--board", "chessboard:9x6", "--model", "pinhole", "--out", out)
    assert code == _done(text)
    before = _tree(out)

    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "_html", interrupt)  # camera.yaml, the CSVs and the figures are written by then
    code, _, err = _run(capsys, frames, "--board", "chessboard:9x6", "--model", "rational", "--out", out)
    assert code == 130
    assert err == f"sogdd: interrupted; {out} left as it was\n"
    assert _tree(out) == before and read_camera(out / "camera.yaml")["model"] == "pinhole"
    assert [p.name for p in tmp_path.iterdir()] == ["calib"]
    # and during the detection, in a new folder: nothing made
    monkeypatch.setattr(chessboard, "find_boards", interrupt)
    code, _, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", tmp_path / "new")
    assert code == 130 and err == f"sogdd: interrupted; {tmp_path / 'new'} left as it was\n"
    assert [p.name for p in tmp_path.iterdir()] == ["calib"]


def test_an_unreachable_scheduler_is_one_line_before_any_work(frames, tmp_path, capsys):
    pytest.importorskip("distributed")
    code, _, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", tmp_path / "o",
                        "--scheduler", "tcp://127.0.0.1:1")
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("sogdd: error: cannot reach the Dask scheduler")
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_sogdds_own_detector_end_to_end(frames, tmp_path, capsys):
    """The real board detector, two processes: every view found, the camera recovered."""
    out = tmp_path / "calib"
    code, text, err = _run(capsys, frames, "--board", "chessboard:9x6", "--out", out, "--jobs", 2)
    assert code == _done(text), err
    cam = read_camera(out / "camera.yaml")
    assert abs(cam["camera_matrix"][0, 0] - 560.0) < 560 * 0.01
    views = list(csv.DictReader(open(out / "views.csv")))
    assert all(v["corners_found"] == "54" and v["used"] == "1" for v in views), views
    assert cam["rms"] < 0.1
    code, text, err = _run(capsys, frames, "--board", "chessboard:auto", "--out", tmp_path / "auto")
    assert code == _done(text), err
    assert abs(read_camera(tmp_path / "auto" / "camera.yaml")["camera_matrix"][0, 0] - 560.0) < 560 * 0.01


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


@pytest.mark.slow
def test_sogdds_own_charuco_detector(charuco_frames, tmp_path, capsys):
    code, text, err = _run(capsys, charuco_frames, "--board", "charuco:5x7:0.7:DICT_5X5_100",
                           "--out", tmp_path / "o", "--no-report")
    assert code == _done(text), err
    cam = read_camera(tmp_path / "o" / "camera.yaml")
    assert abs(cam["camera_matrix"][0, 0] - 560.0) < 560 * 0.02 and cam["rms"] < 0.1
