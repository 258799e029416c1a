"""calibrate_rig_images, write_rig_outputs and calibrate_rig_into (the two in one, what the command runs) on a
rendered two-camera rig: the rig recovered, every input accounted for, the rig's rules and the other one-line
errors before any work (the command's, in the library's words), and the output folder complete or as it was."""

from __future__ import annotations

import csv
import json
import os
import shutil

import cv2
import numpy as np
import pytest

from sogdd.calib.rig import files as rig_files
from sogdd.calib.rig import session as rig_session
from sogdd.calib.rig.files import read_rig
from sogdd.calib.rig.session import (
    calibrate_rig_images,
    calibrate_rig_into,
    check_rig_output_folder,
    write_rig_outputs,
)
from sogdd.calib.session import ParameterError

#: the command's words for the library's parameters (``sogdd calibrate``'s flags), which its errors use
FLAGS = {"board": "--board", "boards": "--boards", "square": "--square", "jobs": "--jobs",
         "min_views": "--min-views", "camera": "--camera", "cameras": "--camera"}


@pytest.fixture(scope="module")
def rig_run(rendered_rig, tmp_path_factory):
    """The rendered rig calibrated once into a folder (pinhole model, square 25, no report), as the command
    runs it: ``(result, files, out)``."""
    folder, _, _ = rendered_rig
    out = tmp_path_factory.mktemp("run") / "rig"
    result, files = calibrate_rig_into({"left": folder / "left", "right": folder / "right"}, out,
                                       "chessboard:9x6", square=25.0, model="pinhole", report=False)
    return result, files, out


@pytest.fixture(scope="module")
def rig_result(rig_run):
    """The rendered rig's calibration, for the tests that only read it."""
    return rig_run[0]


def _tree(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _angle_deg(A, B) -> float:
    return float(np.degrees(np.linalg.norm(cv2.Rodrigues(A @ B.T)[0])))


def test_the_rig_is_recovered(rendered_rig, rig_result):
    _, R, T = rendered_rig
    rig = rig_result.rig
    assert rig.names == ("left", "right") and rig_result.frames == tuple(str(k) for k in range(1, 9))
    right = rig.camera("right")
    assert right.baseline == pytest.approx(25.0 * np.linalg.norm(T), rel=0.02)
    assert _angle_deg(right.R, R) < 0.3
    np.testing.assert_allclose(right.T, 25.0 * T, atol=0.03 * 25.0 * np.linalg.norm(T))
    assert abs(rig.camera("left").K[0, 0] - 560.0) < 560 * 0.01 and abs(right.K[0, 0] - 590.0) < 590 * 0.01
    np.testing.assert_array_equal(rig.camera("left").R, np.eye(3))


def test_the_square_does_not_change_the_rig(rig_result):
    """The rendered rig's boards fitted with squares from 1e-6 to 1e6: the same cameras, the same residuals,
    every translation and its uncertainty scaled with the square."""
    from sogdd.calib.rig import calibrate_rig
    cams = rig_result.rig.cameras
    boards = {c.name: list(c.calibration.boards) for c in cams}
    sizes = {c.name: c.image_size for c in cams}
    ref = calibrate_rig(boards, sizes, square=1.0, pattern=(9, 6))
    for s in (1e-6, 25.0, 1e6):
        rig = calibrate_rig(boards, sizes, square=s, pattern=(9, 6))
        assert rig.square == s and rig.rms == pytest.approx(ref.rms, rel=1e-9)
        np.testing.assert_allclose(rig.tvecs / s, ref.tvecs, rtol=1e-9, atol=1e-12)
        d = np.ones(len(ref.covariance))
        for key, sl in ref.layout.items():
            d[sl] = [1, 1, 1, s, s, s] if key.endswith(".pose") else 1
        np.testing.assert_allclose(rig.covariance / np.outer(d, d), ref.covariance, rtol=1e-6,
                                   atol=1e-9 * np.abs(ref.covariance).max())
        for cam, want in zip(rig.cameras, ref.cameras):
            np.testing.assert_allclose(cam.K, want.K, rtol=1e-9, atol=0)
            np.testing.assert_allclose(cam.dist, want.dist, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(cam.R, want.R, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(cam.T / s, want.T, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(cam.calibration.tvecs / s, want.calibration.tvecs, rtol=1e-9)
            assert cam.std["baseline"] / s == pytest.approx(want.std["baseline"], rel=1e-6, abs=1e-12)
            assert cam.std["fx"] == pytest.approx(want.std["fx"], rel=1e-6)
            assert cam.calibration.square == s


def test_every_image_is_a_record_named_by_its_file(rig_result):
    for name in ("left", "right"):
        views = rig_result.views[name]
        assert [v.name for v in views] == [f"{name}{k:02d}.png" for k in range(1, 9)]
        assert [v.view for v in views] == list(range(8)) and {v.status for v in views} == {"used"}
        assert rig_result.rig.camera(name).calibration.names == tuple(v.name for v in views)


def test_parameters_fail_before_any_image_is_read(tmp_path):
    cams = {"left": tmp_path / "nothing-here", "right": tmp_path / "nor-here"}
    with pytest.raises(ValueError, match="chessboard:auto cannot calibrate a rig.*give board chessboard:COLS"):
        calibrate_rig_images(cams)
    with pytest.raises(ValueError, match="no camera given"):
        calibrate_rig_images({}, "chessboard:9x6")
    with pytest.raises(ValueError, match="camera name 'my cam'"):
        calibrate_rig_images({"left": tmp_path, "my cam": tmp_path}, "chessboard:9x6")
    with pytest.raises(ValueError, match="boards all cannot be used with a rig"):
        calibrate_rig_images(cams, "chessboard:9x6", boards="all")
    with pytest.raises(ValueError, match="boards must be one of best, all, got 'every'"):
        calibrate_rig_images(cams, "chessboard:9x6", boards="every")
    with pytest.raises(ValueError, match="one per camera"):
        calibrate_rig_images(cams, "chessboard:9x6", model={"left": "pinhole", "centre": "pinhole"})
    with pytest.raises(ValueError, match="unknown camera model"):
        calibrate_rig_images(cams, "chessboard:9x6", model={"left": "pinhole", "right": "pinhol"})


# each rule as the library says it, and as the command said it before the rule moved here (its flags)
RULES = [
    ({"board": "chessboard:auto"},
     "board chessboard:auto cannot calibrate a rig: the cameras' corner labels must agree, which needs the "
     "board's size; give board chessboard:COLSxROWS (inner corners)",
     "--board chessboard:auto cannot calibrate a rig: the cameras' corner labels must agree, which needs the "
     "board's size; give --board chessboard:COLSxROWS (inner corners)"),
    ({"boards": "all"}, "boards all cannot be used with a rig: a rig's frame is one pose of one board",
     "--boards all cannot be used with --camera: a rig's frame is one pose of one board"),
    ({"square": 0.0}, "square must be a positive size, got 0.0", "--square must be a positive size, got 0.0"),
    ({"square": float("inf")}, "square must be a positive size, got inf",
     "--square must be a positive size, got inf"),
    ({"square": 1e-30}, "square must be from 1e-06 to 1e+06 (the board's square in any unit), got 1e-30",
     "--square must be from 1e-06 to 1e+06 (the board's square in any unit), got 1e-30"),
    ({"jobs": 0}, "jobs must be >= 1, got 0", "--jobs must be >= 1, got 0"),
    ({"min_views": -2}, "min_views must be >= 1, got -2", "--min-views must be >= 1, got -2"),
    ({"cameras": {}}, "cameras: no camera given", "--camera: no camera given"),
    ({"cameras": {"left": "l", "my/cam": "r"}},
     "cameras: camera name 'my/cam': use letters, digits, _ and - only (it names FileStorage nodes and a "
     "folder)",
     "--camera: camera name 'my/cam': use letters, digits, _ and - only (it names FileStorage nodes and a "
     "folder)"),
]


@pytest.mark.parametrize("given, library, command", RULES)
def test_the_rigs_rules_are_the_librarys_and_say_what_the_command_said(given, library, command, tmp_path):
    """A Python caller gets each rule the command had, before any work: one line naming the parameter,
    which the command words with its flags."""
    kw = {"cameras": {"left": tmp_path / "l", "right": tmp_path / "r"}, "board": "chessboard:9x6", **given}
    cameras = kw.pop("cameras")
    for call in (lambda: calibrate_rig_images(cameras, **kw),
                 lambda: calibrate_rig_into(cameras, tmp_path / "out", **kw)):
        with pytest.raises(ParameterError) as info:
            call()
        assert str(info.value) == library and info.value.worded(**FLAGS) == command
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no folder made, no image looked for


def test_a_camera_without_images_is_named(tmp_path):
    (tmp_path / "l").mkdir()
    (tmp_path / "r").mkdir()
    (tmp_path / "l" / "left01.png").write_bytes(b"x")
    cameras = {"left": tmp_path / "l", "right": tmp_path / "r"}
    with pytest.raises(ParameterError) as info:
        calibrate_rig_into(cameras, tmp_path / "out", "chessboard:9x6")
    assert str(info.value) == "camera right: no input images"
    assert info.value.worded(**FLAGS) == "--camera right: no input images"
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("kind", ["device", "fifo"])
def test_a_device_or_a_fifo_is_refused_before_any_work(rendered_rig, tmp_path, monkeypatch, kind):
    folder, _, _ = rendered_rig
    if kind == "device":
        odd = "/dev/zero"
    else:
        odd = str(tmp_path / "right01.png")
        os.mkfifo(odd)
    monkeypatch.setattr(rig_session, "detect_files", lambda *a, **k: pytest.fail("the images were read"))
    what = "a device" if kind == "device" else "a FIFO (named pipe)"
    with pytest.raises(ValueError) as info:
        calibrate_rig_into({"left": folder / "left" / "left01.png", "right": odd}, tmp_path / "out",
                           "chessboard:9x6")
    assert str(info.value) == f"{odd}: {what}, not a file; give an image file"
    assert not (tmp_path / "out").exists()


def test_the_output_folder_is_checked_before_any_work(rendered_rig, tmp_path, monkeypatch):
    folder, _, _ = rendered_rig
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    monkeypatch.setattr(rig_session, "detect_files", lambda *a, **k: pytest.fail("the images were read"))
    with pytest.raises(ValueError, match="holds notes.txt, which sogdd calibrate did not write"):
        calibrate_rig_into({"left": folder / "left", "right": folder / "right"}, out, "chessboard:9x6")
    with pytest.raises(ValueError, match="holds the input"):
        calibrate_rig_into({"left": folder / "left", "right": folder / "right"}, folder, "chessboard:9x6")
    assert [p.name for p in out.iterdir()] == ["notes.txt"]


def test_calibrate_rig_into_writes_the_commands_folder(rig_run):
    result, files, out = rig_run
    assert sorted(files) == sorted(["rig.yaml", "rig.json"] + [f"{n}/{f}" for n in ("left", "right") for f in
                                   ("camera.yaml", "camera.json", "views.csv", "corners.csv")])
    assert all(files[n] == out / n and files[n].is_file() for n in files)
    assert not (out / "report.html").exists()  # report=False


def test_rig_json_holds_the_rotation_and_what_the_report_shows(rig_run, rendered_rig):
    """rotation_deg is the angle of R as rig.yaml holds it (and its std the fit's); the report's figures too."""
    result, _, out = rig_run
    _, R_true, _ = rendered_rig
    d = json.loads((out / "rig.json").read_text())
    fs = cv2.FileStorage(str(out / "rig.yaml"), cv2.FILE_STORAGE_READ)
    R = fs.getNode("R_right").mat()
    fs.release()
    left, right = d["cameras"]
    assert right["rotation_deg"] == pytest.approx(np.degrees(np.linalg.norm(cv2.Rodrigues(R)[0])), abs=1e-9)
    assert right["rotation_deg"] == pytest.approx(np.degrees(np.linalg.norm(cv2.Rodrigues(R_true)[0])), abs=0.3)
    assert right["std"]["rotation_deg"] == result.rig.camera("right").std["rotation_deg"] > 0
    assert left["rotation_deg"] == 0.0 and left["std"]["rotation_deg"] == 0.0
    assert d["frames_used"] == 8 and right["views_used"] == right["views"] == 8
    assert [f["rms"]["right"] for f in d["frames"]] == pytest.approx(
        list(result.rig.camera("right").calibration.view_rms))
    assert left["rectified"] is None and right["rectified"]["shared_corners"] == 54
    assert 0 <= right["rectified"]["vertical_disparity_px"] < 0.2
    assert right["rectified"]["frame"] in result.frames
    assert 0 < right["projection_uncertainty_px"]["centre"] <= right["projection_uncertainty_px"]["worst"]
    assert d["verdict"] and {v["level"] for v in d["verdict"]} <= {"ok", "warn", "bad"}
    assert any("rotation" in v["text"] for v in d["verdict"])


def test_an_image_given_to_two_cameras_is_refused(rendered_rig):
    folder, _, _ = rendered_rig
    twice = [folder / "right", folder / "left" / "left01.png"]
    with pytest.raises(ValueError, match="is an image of both camera left and camera right"):
        calibrate_rig_images({"left": folder / "left", "right": twice}, "chessboard:9x6")


def test_frames_that_do_not_match_are_one_line(rendered_rig, tmp_path):
    folder, _, _ = rendered_rig
    right = tmp_path / "right"
    shutil.copytree(folder / "right", right)
    (right / "right08.png").rename(right / "right09.png")
    with pytest.raises(ValueError, match=r"left lacks frame 9; right lacks frame 8"):
        calibrate_rig_images({"left": folder / "left", "right": right}, "chessboard:9x6")


def _renamed_by(folder, tmp_path, shift: int):
    """The rendered rig with the right camera's k-th image named as its (k + shift)-th (cyclically): each
    right image paired with the left one ``shift`` frames later."""
    right = tmp_path / "right"
    right.mkdir()
    files = sorted((folder / "right").iterdir())
    for k, p in enumerate(files):
        shutil.copy(p, right / files[(k + shift) % len(files)].name)
    return right


@pytest.mark.parametrize("shift", [1, -2])
def test_frames_paired_off_by_a_shift_stop_naming_the_shift(rendered_rig, tmp_path, shift):
    """Images paired with the wrong moment are not a rig: the run stops, says the shared frames disagree and
    names the shift under which they agree, and writes nothing."""
    folder, _, _ = rendered_rig
    right = _renamed_by(folder, tmp_path, shift)
    out = tmp_path / "out"
    with pytest.raises(ValueError, match="the shared frames disagree") as info:
        calibrate_rig_into({"left": folder / "left", "right": right}, out, "chessboard:9x6", model="pinhole",
                           report=False)
    text = str(info.value)
    assert f"shifted by {shift:+d}" in text and "\n" not in text
    first = f"left{1 + max(0, -shift):02d}.png with right{1 + max(0, shift):02d}.png"
    assert first in text and f"{abs(shift)} frame(s) off" in text
    assert not out.exists()


def test_frames_paired_one_off_are_told_on_opencvs_stereo_pair(data_dir, tmp_path):
    """OpenCV's own sample pair, its right images renamed one frame on: the shift is found."""
    src = data_dir / "calibration" / "opencv_stereo"
    if not src.is_dir():
        pytest.skip("no opencv_stereo in the shared data")
    left = tmp_path / "left"
    left.mkdir()
    for p in sorted(src.glob("left[0-9]*.jpg")):
        shutil.copy(p, left / p.name)
    (tmp_path / "pair" / "right").mkdir(parents=True)
    for p in sorted(src.glob("right[0-9]*.jpg")):
        shutil.copy(p, tmp_path / "pair" / "right" / p.name)
    right = _renamed_by(tmp_path / "pair", tmp_path, 1)
    with pytest.raises(ValueError, match=r"the shared frames disagree.*shifted by \+1 \(left01.jpg with "
                                         r"right02.jpg"):
        calibrate_rig_images({"left": left, "right": right}, "chessboard:9x6", model="pinhole")


@pytest.mark.slow
def test_an_unreadable_image_and_a_missing_frame_leave_that_view_absent(rendered_rig, tmp_path):
    folder, _, T = rendered_rig
    left, right = tmp_path / "left", tmp_path / "right"
    shutil.copytree(folder / "left", left)
    shutil.copytree(folder / "right", right)
    (left / "left03.png").write_bytes(b"not an image")
    (right / "right05.png").unlink()
    with pytest.raises(ValueError, match="right lacks frame 5"):
        calibrate_rig_images({"left": left, "right": right}, "chessboard:9x6", model="pinhole")
    result = calibrate_rig_images({"left": left, "right": right}, "chessboard:9x6", square=25.0,
                                  model="pinhole", allow_missing=True, thumbnails=False)
    assert [v.name for v in result.unreadable] == ["left03.png"]
    assert "left03.png" in result.unreadable[0].reason
    assert [v.name for v in result.views["right"]] == [f"right{k:02d}.png" for k in (1, 2, 3, 4, 6, 7, 8)]
    rig = result.rig
    assert rig.camera("left").calibration.boards[2] is None
    assert rig.camera("right").calibration.boards[4] is None
    assert rig.camera("right").baseline == pytest.approx(25.0 * np.linalg.norm(T), rel=0.03)


@pytest.mark.slow
def test_auto_chooses_each_cameras_model(rendered_rig):
    folder, _, _ = rendered_rig
    result = calibrate_rig_images({"left": folder / "left", "right": folder / "right"}, "chessboard:9x6",
                                  thumbnails=False)
    sel = result.rig.model_selection
    assert set(sel) == {"left", "right"}
    assert [result.rig.camera(n).model for n in ("left", "right")] == [sel["left"].chosen, sel["right"].chosen]


def test_the_output_folder_is_complete_or_as_it_was(rig_result, tmp_path, monkeypatch):
    out = tmp_path / "rig"
    written = write_rig_outputs(rig_result, out, report=False)
    assert {"rig.yaml", "rig.json", "left/camera.yaml", "right/corners.csv"} <= set(written)
    assert sorted(p.name for p in out.iterdir()) == ["left", "rig.json", "rig.yaml", "right"]
    assert list(read_rig(out / "rig.yaml")["cameras"]) == ["left", "right"]
    rows = list(csv.DictReader(open(out / "right" / "views.csv")))
    assert [r["view"] for r in rows] == [f"right{k:02d}.png" for k in range(1, 9)]
    # each camera's views and corners carry their measured precision, and the joint fit's weights
    assert all(0 < float(r["precision_px"]) < 0.1 and 0.5 < float(r["weight"]) <= 2 for r in rows)
    corners = list(csv.DictReader(open(out / "left" / "corners.csv")))
    assert all(0 < float(c["sigma_px"]) < 0.2 for c in corners)
    before = _tree(out)

    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(rig_files, "write_rig_json", interrupt)  # rig.yaml is written by then
    with pytest.raises(KeyboardInterrupt):
        write_rig_outputs(rig_result, out, report=False)
    assert _tree(out) == before and [p.name for p in tmp_path.iterdir()] == ["rig"]
    monkeypatch.undo()
    write_rig_outputs(rig_result, out, report=False)  # a previous output is replaced
    assert _tree(out).keys() == before.keys()


def test_a_folder_holding_other_files_or_an_input_is_refused(rig_result, rendered_rig, tmp_path):
    folder, _, _ = rendered_rig
    out = tmp_path / "rig"
    write_rig_outputs(rig_result, out, report=False)
    (out / "left" / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="holds left/notes.txt, which sogdd calibrate did not write"):
        write_rig_outputs(rig_result, out, report=False)
    (out / "left" / "notes.txt").unlink()
    (out / "mine").mkdir()
    with pytest.raises(ValueError, match="holds mine, which"):
        check_rig_output_folder(out)
    # the images of the result are inputs even when not named: never an output folder
    with pytest.raises(ValueError, match="holds the input"):
        write_rig_outputs(rig_result, folder, report=False)


def test_a_rig_of_one_is_its_camera_through_the_joint_solver(rendered_rig, tmp_path):
    """One camera given as a rig: fitted by the rig's solver, the one-camera calibration's numbers (to the fits'
    tolerance), and written as a rig: rig.yaml with its one camera and no pair's nodes, NAME/ its files."""
    from sogdd.calib import calibrate_images

    folder, _, _ = rendered_rig
    result, files = calibrate_rig_into({"left": folder / "left"}, tmp_path / "one", "chessboard:9x6",
                                       model="pinhole", report=False)
    alone = calibrate_images(folder / "left", "chessboard:9x6", model="pinhole").calibration
    cam = result.rig.cameras[0]
    assert result.rig.names == ("left",) and cam.calibration.n_used == alone.n_used == 8
    assert abs(cam.K[0, 0] - alone.K[0, 0]) < 1e-3 * alone.K[0, 0] and abs(cam.K[0, 2] - alone.K[0, 2]) < 0.5
    assert {"rig.yaml", "rig.json", "left/camera.yaml", "left/views.csv"} <= set(files)
    stored = read_rig(files["rig.yaml"])
    assert list(stored["cameras"]) == ["left"] and "E" not in stored


def test_an_unreadable_image_is_said_so_not_counted_as_no_board(rendered_rig, tmp_path):
    from sogdd.calib.verdict import verdict

    folder, _, _ = rendered_rig
    shutil.copytree(folder / "left", tmp_path / "left")
    (tmp_path / "left" / "left09.png").write_bytes(b"\x89PNG\r\n\x1a\n not a png")
    cal = calibrate_rig_images({"left": tmp_path / "left"}, "chessboard:9x6", model="pinhole").rig.cameras[0]
    cal = cal.calibration
    assert cal.reasons[-1].startswith("unreadable: ") and "left09.png" in cal.reasons[-1]
    texts = [t for _, t in verdict(cal)]
    assert "1 of 9 views could not be read (views.csv)" in texts
    assert not any(t.startswith(("no board found", "1 of 9 views rejected")) for t in texts), texts
