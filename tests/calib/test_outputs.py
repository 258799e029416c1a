"""The calibration's files: camera.yaml read back by cv2.FileStorage, JSON, the CSVs, and safe writing."""

from __future__ import annotations

import csv
import json
import os

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.demo import demo_calibration
from sogdd.calib.files import read_camera, write_calibration, write_camera_yaml
from sogdd.calib.fit import calibrate
from sogdd.calib.targets.board import Board


@pytest.fixture(scope="module")
def cal():
    """A calibration with a view without a board, a rejected view and a rejected corner."""
    K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    rng = np.random.default_rng(2)
    boards = []
    for a in range(9):
        rv, tv = (0.4 * np.sin(a), 0.4 * np.cos(a), 0.1), (-4.0 + 0.5 * np.cos(2 * a), -2.5, 12.0 + a % 3)
        pts = project(obj, K, np.array([-0.2, 0.05, 0, 0, 0]), "pinhole", rv, tv)
        boards.append(Board(pts + rng.normal(0, 0.03, pts.shape), obj[:, :2].astype(int)))
    pts = boards[2].image_points.copy()
    pts[7] += (2.0, 1.0)
    boards[2] = Board(pts, boards[2].labels)
    boards[4] = Board(boards[4].image_points + rng.normal(0, 2.0, pts.shape), boards[4].labels)
    return calibrate(boards + [None], (640, 480), names=[f"f{v}.png" for v in range(10)])


def test_camera_yaml_reads_back_through_opencv(cal, tmp_path):
    files = write_calibration(cal, tmp_path / "out")
    assert files["camera.yaml"].read_text().startswith("%YAML")  # YAML, as its name says, not XML
    fs = cv2.FileStorage(str(files["camera.yaml"]), cv2.FILE_STORAGE_READ)
    assert fs.isOpened()
    np.testing.assert_allclose(fs.getNode("camera_matrix").mat(), cal.K, rtol=1e-12)
    np.testing.assert_allclose(fs.getNode("distortion_coefficients").mat().ravel(), cal.dist, rtol=1e-12)
    assert int(fs.getNode("image_width").real()) == 640 and int(fs.getNode("image_height").real()) == 480
    assert fs.getNode("model").string() == "pinhole"
    assert fs.getNode("rms").real() == pytest.approx(cal.rms)
    assert int(fs.getNode("views_used").real()) == cal.n_used == 8
    fs.release()
    js = json.loads(files["camera.json"].read_text())
    np.testing.assert_allclose(js["camera_matrix"], cal.K)
    assert js["rejected_views"] == {"f4.png": cal.reasons[4], "f9.png": "no board"}
    assert js["cross_validation"]["mean"] == pytest.approx(cal.cross_validation.mean)
    for name in ("camera.yaml", "camera.json"):
        back = read_camera(files[name])
        np.testing.assert_allclose(back["camera_matrix"], cal.K)
        assert back["model"] == "pinhole"
    assert sorted(os.listdir(tmp_path / "out")) == ["camera.json", "camera.yaml", "corners.csv", "views.csv"]


@pytest.mark.parametrize("text", ["%YAML:1.0\ncamera_matrix: [1,2", "<?xml version='1.0'?><opencv_storage><a>"])
def test_a_broken_storage_file_is_a_one_line_error(tmp_path, text):
    """A truncated FileStorage file: OpenCV's parser raises (as SystemError in its Python binding); the reader
    says which file in one line."""
    path = tmp_path / ("camera.xml" if text.startswith("<") else "camera.yaml")
    path.write_text(text)
    with pytest.raises(ValueError, match=r"camera\.(yaml|xml): not an OpenCV FileStorage file$"):
        read_camera(path)


def test_views_and_corners_csv(cal, tmp_path):
    files = write_calibration(cal, tmp_path)
    views = list(csv.DictReader(open(files["views.csv"])))
    assert [v["view"] for v in views] == list(cal.names)
    assert views[9]["corners_found"] == "0" and views[9]["used"] == "0" and views[9]["reason"] == "no board"
    assert views[4]["used"] == "0" and views[4]["reason"] and float(views[4]["rms"]) > 1.0
    assert views[2]["used"] == "1" and views[2]["corners_used"] == "53" and views[2]["corners_found"] == "54"
    corners = list(csv.DictReader(open(files["corners.csv"])))
    assert list(corners[0]) == ["view", "i", "j", "x", "y", "residual", "used", "sigma_px", "source"]
    assert views[9]["source"] == "" and views[2]["source"] == corners[0]["source"] == "sogdd"
    assert all(c["sigma_px"] == "" for c in corners)  # boards without a measured precision
    assert len(corners) == 9 * 54
    planted = [c for c in corners if c["view"] == "f2.png" and (c["i"], c["j"]) == ("7", "0")]
    assert len(planted) == 1 and planted[0]["used"] == "0" and float(planted[0]["residual"]) > 1.5
    np.testing.assert_allclose(float(planted[0]["x"]), cal.boards[2].image_points[7, 0], atol=1e-4)
    assert all(c["used"] == "0" for c in corners if c["view"] == "f4.png")
    used = [float(c["residual"]) for c in corners if c["used"] == "1"]
    assert np.sqrt(np.mean(np.square(used))) == pytest.approx(cal.rms, rel=1e-3)


def test_an_input_is_never_overwritten(tmp_path):
    img = tmp_path / "views.csv"
    img.write_bytes(b"not really an image")
    with pytest.raises(ValueError, match="that is the input"):
        write_calibration(demo_calibration(), tmp_path, inputs=[img])
    assert img.read_bytes() == b"not really an image"
    assert not (tmp_path / "camera.yaml").exists()


def test_a_failed_write_is_an_error_and_leaves_the_folder_as_it_was(tmp_path, monkeypatch):
    """Whoever runs it (root writes into a read-only folder, so the failures are made otherwise)."""
    from sogdd.formats import safe_write

    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="not a folder"):
        write_calibration(demo_calibration(), tmp_path / "file")
    with pytest.raises(OSError):  # a folder under a regular file cannot exist
        write_camera_yaml(demo_calibration(), tmp_path / "file" / "camera.yaml")
    assert sorted(os.listdir(tmp_path)) == ["file"] and (tmp_path / "file").read_text() == "x"
    out = tmp_path / "out"
    write_calibration(demo_calibration(), out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def full(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(safe_write.os, "fsync", full)  # the disk fills while the files are written
    with pytest.raises(OSError, match="No space"):
        write_calibration(demo_calibration(), out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # no temporary file left either


def test_views_csv_and_camera_json_account_for_every_input(cal, tmp_path):
    from sogdd.calib import ViewRecord

    views = [ViewRecord(n, f"in/{n}", "used" if cal.view_used[v] else "rejected", cal.reasons[v], v)
             for v, n in enumerate(cal.names)]
    views.insert(3, ViewRecord("bad.png", "in/bad.png", "unreadable", "in/bad.png: not a readable image"))
    files = write_calibration(cal, tmp_path, views=views)
    rows = list(csv.DictReader(open(files["views.csv"])))
    assert [r["view"] for r in rows] == [v.name for v in views]
    assert rows[3] == {"view": "bad.png", "corners_found": "0", "corners_used": "0", "rms": "", "used": "0",
                       "reason": "in/bad.png: not a readable image", "status": "unreadable", "precision_px": "",
                       "weight": "", "source": "", "reasons": ""}
    assert rows[4]["view"] == "f3.png" and rows[4]["corners_found"] == "54"
    js = json.loads(files["camera.json"].read_text())
    assert js["rejected_views"]["bad.png"] == "in/bad.png: not a readable image"
    assert js["views"][3] == {"view": "bad.png", "file": "in/bad.png", "status": "unreadable",
                              "reason": "in/bad.png: not a readable image"}


def test_an_interrupted_write_keeps_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    from sogdd.formats import safe_write

    old = tmp_path / "camera.json"
    old.write_text("old")

    def fail(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(safe_write.os, "replace", fail)
    with pytest.raises(OSError, match="No space"):
        write_calibration(demo_calibration(), tmp_path)
    assert old.read_text() == "old"
    assert sorted(os.listdir(tmp_path)) == ["camera.json"]
