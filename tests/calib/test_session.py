"""calibrate_images and write_outputs: every input accounted for, and an output folder a user can trust."""

from __future__ import annotations

import csv
import errno
import json
import os
import shutil
import stat
import subprocess
import sys
import textwrap

import cv2
import numpy as np
import pytest

from sogdd.calib import calibrate_images, check_output_folder, detection, report, session, write_outputs
from sogdd.calib.files import read_camera
from sogdd.formats import safe_write


def _tree(folder):
    """Every file under ``folder`` with its bytes: what a run may not change."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def inputs(rendered_frames, tmp_path_factory):
    """The eight frames, a file that is not an image and a blank image."""
    folder = tmp_path_factory.mktemp("inputs")
    for p in rendered_frames.iterdir():
        shutil.copy(p, folder / p.name)
    (folder / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n not a png")
    cv2.imwrite(str(folder / "blank.png"), np.full((480, 640), 128, np.uint8))
    return folder


@pytest.fixture(scope="module")
def result(inputs):
    return calibrate_images(inputs, "chessboard:9x6", square=25.0)


def test_every_input_has_a_fate(result):
    fates = {v.name: (v.status, v.reason) for v in result.views}
    assert list(fates) == ["blank.png", "broken.png", *(f"f{k}.png" for k in range(8))]
    assert fates["blank.png"] == ("no board", "no board")
    assert fates["broken.png"][0] == "unreadable" and "broken.png" in fates["broken.png"][1]
    assert all(fates[f"f{k}.png"] == ("used", "") for k in range(8))
    cal = result.calibration
    assert cal.n_used == 8 and abs(cal.K[0, 0] - 560.0) < 5.6
    assert [os.path.basename(v.file) for v in result.unreadable] == ["broken.png"]
    # the views of the calibration and their thumbnails, made where the images were read
    assert len(result.thumbnails) == len(cal.names) == 9
    assert all(t.image.shape == (180, 240) and t.image.dtype == np.uint8 for t in result.thumbnails)


def test_an_image_too_small_to_search_costs_only_itself(rendered_frames, tmp_path):
    """A 2 x 2 image is an image, but too small for a board: its view says so, by name; the batch goes on."""
    folder = tmp_path / "in"
    shutil.copytree(rendered_frames, folder)
    cv2.imwrite(str(folder / "tiny.png"), np.zeros((2, 2), np.uint8))
    fates = {v.name: (v.status, v.reason) for v in calibrate_images(folder, "chessboard:9x6").views}
    assert fates["tiny.png"][0] == "unreadable" and "tiny.png" in fates["tiny.png"][1]
    assert "8 x 8" in fates["tiny.png"][1]
    assert sum(s == "used" for s, _ in fates.values()) == 8


def test_a_board_of_another_size_is_ignored_and_says_so(rendered_frames, tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    img = cv2.imread(str(rendered_frames / "f0.png"), cv2.IMREAD_GRAYSCALE)
    big = np.full((480, 640), 255, np.uint8)
    sq = np.kron((np.indices((8, 11)).sum(axis=0) % 2) * 200 + 30, np.ones((30, 30))).astype(np.uint8)
    big[100:340, 100:430] = sq  # 10 x 7 inner corners: larger than the 9 x 6 board, so not a view of it
    for k in range(4):
        shutil.copy(rendered_frames / f"f{k}.png", folder / f"f{k}.png")
    cv2.imwrite(str(folder / "other.png"), cv2.GaussianBlur(big, (0, 0), 1.0))
    assert img.shape == big.shape
    res = calibrate_images(folder, "chessboard:9x6", min_views=2)
    (other,) = [v for v in res.views if v.name == "other.png"]
    assert other.status == "ignored"
    assert "10x7 inner corners" in other.reason and "chessboard:9x6" in other.reason


def test_the_library_checks_its_parameters_before_any_work(inputs):
    for kw, text in [({"square": 0}, "square must be a positive size"), ({"model": "nope"}, "unknown camera"),
                     ({"jobs": 0}, "jobs must be"), ({"read_options": {"maxpixels": 3}}, "unknown option")]:
        with pytest.raises(ValueError, match=text):
            calibrate_images(inputs / "f0.png", "chessboard:9x6", **kw)
    with pytest.raises(ValueError, match="board"):
        calibrate_images(inputs / "f0.png", "chessboard:9by6")
    with pytest.raises(ValueError, match="none of the 1 image"):
        calibrate_images(inputs / "broken.png", "chessboard:9x6")


@pytest.mark.parametrize("given, library, command", [
    ({"square": 0.0}, "square must be a positive size, got 0.0", "--square must be a positive size, got 0.0"),
    ({"square": -1}, "square must be a positive size, got -1", "--square must be a positive size, got -1"),
    ({"square": 1e9}, "square must be from 1e-06 to 1e+06 (the board's square in any unit), got 1000000000.0",
     "--square must be from 1e-06 to 1e+06 (the board's square in any unit), got 1000000000.0"),
    ({"jobs": 0}, "jobs must be >= 1, got 0", "--jobs must be >= 1, got 0"),
    ({"jobs": 1.5}, "jobs must be an integer, got 1.5", "--jobs must be an integer, got 1.5"),
    ({"min_views": 0}, "min_views must be >= 1, got 0", "--min-views must be >= 1, got 0"),
    ({"min_views": True}, "min_views must be an integer, got True", "--min-views must be an integer, got True"),
])
def test_the_numbers_are_checked_at_the_door_as_the_command_said(given, library, command, inputs, tmp_path,
                                                                 monkeypatch):
    """The checks the command made are the library's: one line naming the parameter, the flag in its words."""
    monkeypatch.setattr(session, "detect_files", lambda *a, **k: pytest.fail("the images were read"))
    for call in (lambda: calibrate_images(inputs, "chessboard:9x6", **given),
                 lambda: session.calibrate_into(inputs, tmp_path / "out", "chessboard:9x6", **given)):
        with pytest.raises(session.ParameterError) as info:
            call()
        assert str(info.value) == library
        assert info.value.worded(square="--square", jobs="--jobs", min_views="--min-views") == command
    assert not (tmp_path / "out").exists()


def test_a_parameter_error_keeps_its_words_through_a_pickle():
    """A worker process (or a Dask client) that sends the error on still lets the command word it."""
    import pickle

    exc = session.ParameterError("{jobs} must be >= 1, got {value}", jobs="jobs", value={"a": 1})
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is session.ParameterError and str(back) == str(exc) == "jobs must be >= 1, got {'a': 1}"
    assert back.worded(jobs="--jobs") == "--jobs must be >= 1, got {'a': 1}"


@pytest.mark.parametrize("kind", ["device", "fifo"])
def test_calibrate_into_refuses_a_device_or_a_fifo_before_any_work(kind, inputs, tmp_path, monkeypatch):
    if kind == "device":
        odd, what = "/dev/zero", "a device"
    else:
        odd, what = str(tmp_path / "f.png"), "a FIFO (named pipe)"
        os.mkfifo(odd)
    monkeypatch.setattr(session, "detect_files", lambda *a, **k: pytest.fail("the images were read"))
    with pytest.raises(ValueError) as info:
        session.calibrate_into([inputs / "f0.png", odd], tmp_path / "out", "chessboard:9x6")
    assert str(info.value) == f"{odd}: {what}, not a file; give an image file"
    assert not (tmp_path / "out").exists()


def test_calibrate_into_checks_the_output_folder_before_any_work(inputs, tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    monkeypatch.setattr(session, "detect_files", lambda *a, **k: pytest.fail("the images were read"))
    with pytest.raises(ValueError, match="holds notes.txt, which sogdd calibrate did not write"):
        session.calibrate_into(inputs, out, "chessboard:9x6")
    with pytest.raises(ValueError, match="holds the input"):
        session.calibrate_into(inputs / "*.png", inputs, "chessboard:9x6")
    with pytest.raises(ValueError, match="^no input images$"):
        session.calibrate_into([], out, "chessboard:9x6")
    assert [p.name for p in out.iterdir()] == ["notes.txt"]


def test_the_report_never_reads_an_image_file(inputs, tmp_path, monkeypatch):
    reads = []
    real, imread = detection.read_image_and_orientation, cv2.imread
    monkeypatch.setattr(detection, "read_image_and_orientation",
                        lambda p, **kw: reads.append(p) or real(p, **kw))
    res = calibrate_images(inputs, "chessboard:9x6")
    assert sorted(map(str, reads)) == sorted(str(p) for p in inputs.iterdir())  # each once
    import sogdd

    monkeypatch.setattr(sogdd, "read_image", lambda *a, **k: pytest.fail("the report read a file"))
    monkeypatch.setattr(cv2, "imread", lambda *a, **k: pytest.fail("the report read a file"))
    write_outputs(res, tmp_path / "out", inputs=list(inputs.iterdir()))
    vis = imread(str(tmp_path / "out" / "report" / "view_0002.png"))
    assert vis.shape == (180, 240, 3) and (vis[..., 1] > 150).any()  # the image with green corners


def test_the_output_folder_is_complete_accounts_for_every_input_and_gets_the_umask(result, inputs, tmp_path):
    old = os.umask(0o022)
    try:
        files = write_outputs(result, tmp_path / "a" / "calib", inputs=list(inputs.iterdir()))
    finally:
        os.umask(old)
    out = tmp_path / "a" / "calib"
    assert sorted(p.name for p in out.iterdir()) == ["camera.json", "camera.yaml", "corners.csv", "report",
                                                      "report.html", "views.csv"]
    assert set(files) == {"camera.json", "camera.yaml", "corners.csv", "views.csv", "report.html", "report"}
    modes = {p.relative_to(tmp_path).as_posix(): stat.S_IMODE(p.stat().st_mode) for p in tmp_path.rglob("*")}
    assert {m for p, m in modes.items() if (tmp_path / p).is_file()} == {0o644}, modes
    assert {m for p, m in modes.items() if (tmp_path / p).is_dir()} == {0o755}, modes
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith(safe_write.TMP_SUFFIX)]
    views = list(csv.DictReader(open(out / "views.csv")))
    assert [v["view"] for v in views] == [v.name for v in result.views]
    broken = next(v for v in views if v["view"] == "broken.png")
    assert broken["status"] == "unreadable" and "broken.png" in broken["reason"] and broken["used"] == "0"
    js = json.loads((out / "camera.json").read_text())
    assert [v["view"] for v in js["views"]] == [v["view"] for v in views]
    assert "broken.png" in js["rejected_views"] and js["rejected_views"]["blank.png"] == "no board"
    html = (out / "report.html").read_text()
    assert "broken.png" in html and "unreadable" in html
    assert read_camera(out / "camera.yaml")["camera_matrix"][0, 0] == pytest.approx(result.calibration.K[0, 0])


def test_a_rerun_with_fewer_views_leaves_no_stale_figures(result, inputs, rendered_frames, tmp_path):
    out = tmp_path / "calib"
    write_outputs(result, out)
    assert (out / "report" / "view_0008.png").is_file() and (out / "report" / "cross_validation.png").is_file()
    few = calibrate_images([rendered_frames / f"f{k}.png" for k in range(3)], "chessboard:9x6")
    write_outputs(few, out)
    assert sorted(p.name for p in (out / "report").iterdir()) == [
        "coverage.png", "distortion.png", "errors_per_view.png", "overlay_0000.png", "overlay_0001.png",
        "overlay_0002.png", "poses.png", "residual_histogram.png", "residuals.png", "view_0000.png",
        "view_0001.png", "view_0002.png"]
    assert len(list(csv.DictReader(open(out / "views.csv")))) == 3
    assert [p.name for p in tmp_path.iterdir()] == ["calib"]  # no folder left beside it


def test_an_interrupted_rerun_leaves_the_folder_as_it_was(result, inputs, tmp_path, monkeypatch):
    out = tmp_path / "calib"
    write_outputs(result, out)
    before = _tree(out)
    rational = calibrate_images(inputs, "chessboard:9x6", model="rational")

    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "_html", interrupt)  # the camera files are written by then
    with pytest.raises(KeyboardInterrupt):
        write_outputs(rational, out)
    assert _tree(out) == before
    assert read_camera(out / "camera.yaml")["model"] == result.calibration.model != rational.calibration.model
    assert [p.name for p in tmp_path.iterdir()] == ["calib"]


def test_a_failed_write_leaves_the_folder_as_it_was(result, tmp_path, monkeypatch):
    out = tmp_path / "calib"
    write_outputs(result, out, report=False)
    before = _tree(out)
    real = os.replace

    def full(src, dst):
        if str(dst).endswith("corners.csv"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(src, dst)

    monkeypatch.setattr(safe_write.os, "replace", full)
    with pytest.raises(OSError) as info:
        write_outputs(result, out)
    msg = str(info.value)
    assert "No space left on device" in msg and f"{out} left as it was" in msg and "\n" not in msg
    assert ".sogdd.tmp" not in msg  # names the folder, not the temporary one
    assert _tree(out) == before
    # a new folder, with parents to make: nothing at all is left
    with pytest.raises(OSError, match="not created"):
        write_outputs(result, tmp_path / "new" / "deeper" / "calib")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calib"]


def test_an_output_under_a_regular_file_is_refused(result, tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="exists and is not a folder"):
        write_outputs(result, tmp_path / "file")
    with pytest.raises(OSError):
        write_outputs(result, tmp_path / "file" / "calib")
    assert (tmp_path / "file").read_text() == "x" and [p.name for p in tmp_path.iterdir()] == ["file"]


def test_which_folders_may_be_replaced(result, inputs, tmp_path, monkeypatch):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("my notes")
    with pytest.raises(ValueError, match="holds notes.txt, which sogdd calibrate did not write"):
        write_outputs(result, mine)
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]
    empty = tmp_path / "empty"
    empty.mkdir()
    write_outputs(result, empty, report=False)
    (empty / "report").mkdir()
    (empty / "report" / "photo.jpg").write_bytes(b"x")
    with pytest.raises(ValueError, match="holds report/photo.jpg"):
        write_outputs(result, empty)
    # an input inside, however the inputs were named
    for named in ([inputs / "f0.png"], [str(inputs / "*.png")], [inputs]):
        with pytest.raises(ValueError, match="holds the input"):
            check_output_folder(inputs, named)
    monkeypatch.chdir(empty)
    with pytest.raises(ValueError, match="current folder"):
        check_output_folder(".")


def test_the_folders_keep_a_replaced_folders_permissions(result, tmp_path):
    out = tmp_path / "calib"
    out.mkdir()
    out.chmod(0o750)
    write_outputs(result, out, report=False)
    assert stat.S_IMODE(out.stat().st_mode) == 0o750


@pytest.mark.slow
def test_worker_processes_after_numba_parallel_code_in_the_parent(inputs):
    """The parent has run numba's parallel code (the rendering, the refinement): forked workers would die."""
    res = calibrate_images(inputs, "chessboard:9x6", jobs=2)
    assert [v.status for v in res.views].count("used") == 8 and len(res.unreadable) == 1


KILLER = '''
import os, signal, sys
from sogdd.calib import calibrate_images, detection

real = detection.read_image_and_orientation

def read_or_die(path, **kw):  # the out-of-memory killer, deterministically, in the worker
    if str(path).endswith("f3.png"):
        os.kill(os.getpid(), signal.SIGKILL)
    return real(path, **kw)

# forked workers inherit it (this fresh process ran no parallel code)
detection.read_image_and_orientation = read_or_die
res = calibrate_images(sys.argv[1], "chessboard:9x6", jobs=2)
for v in res.views:
    print(v.name, v.status, v.reason, sep="|")
'''


@pytest.mark.slow
def test_a_worker_that_dies_costs_only_its_image(rendered_frames, tmp_path):
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(KILLER), str(rendered_frames)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = [line.split("|") for line in proc.stdout.splitlines()]
    fates = {name: (status, reason) for name, status, reason in rows}
    assert fates["f3.png"][0] == "unreadable" and "worker process died" in fates["f3.png"][1]
    assert sum(s == "used" for s, _ in fates.values()) == 7


@pytest.mark.slow
def test_detection_on_a_dask_cluster(inputs):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        res = calibrate_images(inputs, "chessboard:9x6", scheduler=cluster.scheduler_address)
    assert [v.status for v in res.views].count("used") == 8 and len(res.unreadable) == 1


def test_the_session_is_the_library_entry_point():
    import sogdd.calib

    for name in ("calibrate_images", "write_outputs", "check_output_folder", "ImageCalibration", "ViewRecord"):
        assert getattr(sogdd.calib, name) is getattr(session if hasattr(session, name) else detection, name)


# --------------------------------------------------------------------------------------------------
# one board per image: a screen in the background showing the board is never a view

SCENE_K = np.array([[560.0, 0, 322.0], [0, 560.0, 236.0], [0, 0, 1]])


@pytest.fixture(scope="module")
def scenes(render, tmp_path_factory):
    """Four rendered views of a 9x6 board, one with a small copy of it (cells of 5 px, complete: a screen in
    the background) pasted in the frame's corner farthest from the board, and one with two boards side by
    side and a small copy below them."""
    cam = render.Camera(SCENE_K, (-0.2, 0.06, 0.001, -0.0005, 0.0), (640, 480))
    target = render.Board(9, 6, 1.0)
    # face on, 112 units away: cells of 560 / 112 = 5 px round the image centre
    screen = render.render_scene(cam, target, np.zeros(3), np.array([-4.0, -2.5, 112.0]), blur=0.6)[191:281,
                                                                                                        262:382]
    rng = np.random.default_rng(0)
    folder = tmp_path_factory.mktemp("scenes")
    for k, (rv, tv) in enumerate(render.random_poses(cam, target, 4, seed=3)):
        view = render.render_view(cam, target, rv, tv, blur=0.8, noise=2.0, rng=k)
        img = view.image
        if k == 0:
            y, x = max([(5, 5), (5, 515), (385, 5), (385, 515)], key=lambda c: np.hypot(
                *(view.corners - [c[1] + 60, c[0] + 45]).T).min())
            img[y:y + 90, x:x + 120] = np.rint(screen).astype(np.uint8)
        cv2.imwrite(str(folder / ("screen.png" if k == 0 else f"f{k}.png")), img)
    left = render.render_scene(cam, target, np.array([0.2, 0.3, 0.0]), np.array([-10.5, -2.5, 25.0]), blur=0.8)
    right = render.render_scene(cam, target, np.array([-0.15, -0.25, 0.1]), np.array([2.5, -2.5, 25.0]),
                                blur=0.8)
    two = np.where(np.arange(640) < 320, left, right)
    two[380:470, 260:380] = screen
    two = np.clip(np.rint(two + rng.normal(0, 2, two.shape)), 0, 255)
    cv2.imwrite(str(folder / "two.png"), two.astype(np.uint8))
    return folder


def _fates(res):
    return {v.name: v for v in res.views}


def test_an_image_gives_one_view_the_best_board_and_says_what_else_it_saw(scenes):
    res = calibrate_images(scenes, "chessboard:9x6")
    fates = _fates(res)
    # one board per image: a board whose cells are under a third of a complete one's is not refined, so the
    # 5 px screens are not rows (boards="all" below reports them)
    assert list(fates) == ["f1.png", "f2.png", "f3.png", "screen.png", "two.png", "two.png#2"]
    cal = res.calibration
    assert list(cal.names) == ["f1.png", "f2.png", "f3.png", "screen.png", "two.png"] and cal.n_used == 5
    assert detection.cell_size(cal.boards[cal.names.index("screen.png")]) > 15  # the board, not the screen
    other = fates["two.png#2"]
    assert other.status == "ignored" and other.reason.startswith("another board in the image (54 corners")
    assert abs(cal.K[0, 0] - 560.0) < 560 * 0.02
    # a thumbnail per view of the calibration: none for an ignored board
    assert len(res.thumbnails) == len(cal.names)


def test_every_board_on_request_but_never_the_small_copy(scenes, tmp_path):
    res = calibrate_images(scenes, "chessboard:9x6", boards="all")
    fates = _fates(res)
    assert list(res.calibration.names) == ["f1.png", "f2.png", "f3.png", "screen.png", "two.png", "two.png#2"]
    assert fates["two.png#2"].status == "used" and fates["two.png#3"].status == "ignored"
    assert fates["screen.png#2"].status == "ignored" and "cells of 5.0 px" in fates["screen.png#2"].reason
    write_outputs(res, tmp_path / "o", report=False)
    rows = {r["view"]: r for r in csv.DictReader(open(tmp_path / "o" / "views.csv"))}
    assert rows["two.png#3"]["status"] == "ignored" and rows["two.png#3"]["corners_found"] == "54"
    assert rows["two.png#3"]["used"] == "0" and rows["two.png#2"]["status"] == "used"
    js = json.loads((tmp_path / "o" / "camera.json").read_text())
    assert "cells of 5.0 px" in js["rejected_views"]["two.png#3"]
    with pytest.raises(ValueError, match="^boards must be one of best, all, got 'every'$"):
        calibrate_images(scenes, "chessboard:9x6", boards="every")


def test_each_frame_is_made_grey_once(rendered_frames, monkeypatch):
    """The detector converts the frame; the report's thumbnail is made from a shrunk copy, not a second
    full-size conversion."""
    import sogdd.image

    real = sogdd.image.to_gray255
    sizes = []

    def counted(image, **kw):
        sizes.append(np.shape(image)[:2])
        return real(image, **kw)

    monkeypatch.setattr(sogdd.image, "to_gray255", counted)
    monkeypatch.setattr(detection, "to_gray255", counted)
    r = detection.detect_view(rendered_frames / "f0.png", detection.BoardSpec("chessboard", pattern=(9, 6)))
    assert len(r.boards) == 1 and r.thumbnail is not None
    assert sizes.count((480, 640)) == 1, sizes
