"""sogdd calibrate --camera NAME PATTERN... end to end on a rendered two-camera rig: rig.yaml read back by
OpenCV with the baseline and rotation recovered, each camera's files, the summary, the one-line errors
(exit 2, no traceback), Ctrl-C (exit 130) and the output folder left complete or as it was."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import shutil

import cv2
import numpy as np
import pytest

from sogdd.calib.targets.chessboard import search as chessboard
from sogdd.cli.main import main


def _run(capsys, *argv):
    code = main(["calibrate", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def _cams(folder, right=None):
    return ("--camera", "left", folder / "left" / "*.png", "--camera", "right",
            (right or folder / "right") / "*.png")


def _done(text, unreadable=False):
    """The exit code of a run that wrote its outputs, by what it printed: 3 when its verdict is bad, else 2
    when an input could not be read, else 0."""
    bad = '"verdict_level": "bad"' in text or any(line.startswith("  bad: ") for line in text.splitlines())
    return 3 if bad else 2 if unreadable else 0


def _tree(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def rig_out(rendered_rig, tmp_path_factory):
    """One run of the command on the rendered rig (pinhole model, no report): (code, stdout, out)."""
    folder, _, _ = rendered_rig
    out = tmp_path_factory.mktemp("run") / "rig"
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = main(["calibrate", *map(str, _cams(folder)), "--board", "chessboard:9x6", "--square", "25",
                     "--model", "pinhole", "--no-report", "--out", str(out), "--quiet"])
    return code, text.getvalue(), out


def test_end_to_end_writes_the_rig_and_each_camera(rendered_rig, rig_out):
    _, R, T = rendered_rig
    code, text, out = rig_out
    assert code == _done(text)
    fs = cv2.FileStorage(str(out / "rig.yaml"), cv2.FILE_STORAGE_READ)
    cams = fs.getNode("cameras")
    assert [cams.at(i).string() for i in range(cams.size())] == ["left", "right"]
    R_right, T_right = fs.getNode("R_right").mat(), fs.getNode("T_right").mat()
    assert T_right.shape == (3, 1)
    assert np.linalg.norm(T_right) == pytest.approx(25 * np.linalg.norm(T), rel=0.02)
    assert np.degrees(np.linalg.norm(cv2.Rodrigues(R_right @ R.T)[0])) < 0.3
    np.testing.assert_allclose(fs.getNode("T").mat(), T_right)  # stereoCalibrate's T: the pair's
    assert fs.getNode("P2").mat().shape == (3, 4) and fs.getNode("Q").mat().shape == (4, 4)
    assert abs(fs.getNode("camera_matrix_right").mat()[0, 0] - 590) < 590 * 0.01
    fs.release()
    d = json.loads((out / "rig.json").read_text())
    assert [c["name"] for c in d["cameras"]] == ["left", "right"] and d["cameras"][1]["std"]["baseline"] > 0
    for name in ("left", "right"):
        rows = list(csv.DictReader(open(out / name / "views.csv")))
        assert [r["view"] for r in rows] == [f"{name}{k:02d}.png" for k in range(1, 9)]
        corners = {c["view"] for c in csv.DictReader(open(out / name / "corners.csv"))}
        assert corners == {r["view"] for r in rows} and (out / name / "camera.yaml").is_file()


def test_the_summary(rig_out):
    lines = rig_out[1].splitlines()
    assert lines[0].startswith("rig of 2 cameras: 8 of 8 frames used, RMS")
    right = next(ln for ln in lines if ln.lstrip().startswith("right "))
    assert "fx 5" in right and "cy " in right and "RMS" in right and "8 of 8 views used" in right
    assert "baseline " in right and " ± " in right and "rotation" in right
    assert lines[-1] == f"written to {rig_out[2]}/: rig.yaml ..."


def test_the_json_summary(rendered_rig, tmp_path, capsys):
    folder, _, T = rendered_rig
    code, text, err = _run(capsys, *_cams(folder), "--board", "chessboard:9x6", "--square", 25, "--model",
                           "pinhole", "--no-report", "--out", tmp_path / "rig", "--json")
    assert code == _done(text), err
    d = json.loads(text)  # one object
    assert [c["name"] for c in d["cameras"]] == ["left", "right"] and d["frames_used"] == 8
    c = d["cameras"][1]
    assert c["baseline"] == pytest.approx(25 * np.linalg.norm(T), rel=0.02) and c["baseline_std"] > 0
    assert {"fx", "fy", "cx", "cy", "rms", "rotation_deg", "rotation_std_deg"} <= set(c)


def test_frames_that_do_not_match_are_one_line_and_nothing_is_written(rendered_rig, tmp_path, capsys):
    folder, _, _ = rendered_rig
    right = tmp_path / "right"
    shutil.copytree(folder / "right", right)
    (right / "right08.png").rename(right / "right09.png")
    code, _, err = _run(capsys, *_cams(folder, right), "--board", "chessboard:9x6", "--out", tmp_path / "rig")
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("sogdd: error: the cameras' frames do not match") and "right lacks frame 8" in err
    assert not (tmp_path / "rig").exists()


@pytest.mark.parametrize("argv, message", [
    (("imgs/*.png", "--camera", "left", "l/*.png", "--camera", "right", "r/*.png"), "not both"),
    ((), "no images: give the image files, or --camera NAME PATTERN"),
    (("--camera", "left", "--camera", "right", "r/*.png"), "--camera left: give the camera's images"),
    (("--camera", "left", "l/*.png", "--camera", "left", "r/*.png"), "--camera left: given twice"),
    (("--camera", "my/cam", "l/*.png", "--camera", "right", "r/*.png"), "camera name 'my/cam'"),
    (("--camera", "left", "l/*.png", "--camera", "right", "r/*.png", "--board", "chessboard:auto"),
     "--board chessboard:auto cannot calibrate a rig"),
    (("--camera", "left", "l/*.png", "--camera", "right", "r/*.png", "--board", "chessboard:9x6", "--boards",
      "all"), "--boards all cannot be used with --camera"),
    (("l/*.png", "--allow-missing-frames"), "--allow-missing-frames is for a rig"),
])
def test_usage_errors_are_one_line(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(capsys, *argv, "--out", tmp_path / "rig")
    assert code == 2 and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "rig").exists()


RIG = ("--camera", "left", "l/*.png", "--camera", "right", "r/*.png")


@pytest.mark.parametrize("argv, line", [
    ((*RIG, "--board", "chessboard:auto"),
     "--board chessboard:auto cannot calibrate a rig: the cameras' corner labels must agree, which needs the "
     "board's size; give --board chessboard:COLSxROWS (inner corners)"),
    ((*RIG, "--board", "chessboard:9x6", "--boards", "all"),
     "--boards all cannot be used with --camera: a rig's frame is one pose of one board"),
    (("--camera", "left", "l/*.png", "--camera", "my/cam", "r/*.png", "--board", "chessboard:9x6"),
     "--camera: camera name 'my/cam': use letters, digits, _ and - only (it names FileStorage nodes and a "
     "folder)"),
    ((*RIG, "--board", "chessboard:9x6", "--jobs", "0"), "--jobs must be >= 1, got 0"),
    ((*RIG, "--board", "chessboard:9x6", "--min-views", "0"), "--min-views must be >= 1, got 0"),
    ((*RIG, "--board", "chessboard:9x6", "--square", "0"), "--square must be a positive size, got 0.0"),
])
def test_the_librarys_rules_are_the_commands_lines_with_its_flags(argv, line, tmp_path, capsys, monkeypatch):
    """The checks now live in the library; the command still says each in one line, naming its flags."""
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(capsys, *argv, "--out", tmp_path / "rig")
    assert (code, err) == (2, f"sogdd: error: {line}\n")
    assert not (tmp_path / "rig").exists()


def test_a_camera_without_images_is_named_by_its_flag(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name in ("l", "r"):
        (tmp_path / name).mkdir()
    (tmp_path / "l" / "left01.png").write_bytes(b"x")
    code, _, err = _run(capsys, "--camera", "left", "l", "--camera", "right", "r", "--board", "chessboard:9x6",
                        "--out", tmp_path / "rig")
    assert (code, err) == (2, "sogdd: error: --camera right: no input images\n")


def test_rig_json_holds_the_rotation_the_summary_prints(rig_out):
    code, text, out = rig_out
    d = json.loads((out / "rig.json").read_text())
    right = d["cameras"][1]
    line = next(ln for ln in text.splitlines() if ln.lstrip().startswith("right "))
    assert f"rotation {right['rotation_deg']:.3f} ± {right['std']['rotation_deg']:.2g} deg" in line
    R = np.array(right["R"])
    assert right["rotation_deg"] == pytest.approx(np.degrees(np.linalg.norm(cv2.Rodrigues(R)[0])), abs=1e-9)


def test_ctrl_c_and_a_folder_of_other_files_leave_the_folder_as_it_was(rendered_rig, rig_out, tmp_path, capsys,
                                                                       monkeypatch):
    folder, _, _ = rendered_rig
    out = tmp_path / "rig"
    shutil.copytree(rig_out[2], out)
    before = _tree(out)

    def interrupt(*a, **k):
        raise KeyboardInterrupt

    # during the detection (in this process: --jobs 1); the library's test interrupts the writing
    monkeypatch.setattr(chessboard, "find_boards", interrupt)
    code, _, err = _run(capsys, *_cams(folder), "--board", "chessboard:9x6", "--model", "pinhole",
                        "--no-report", "--out", out)
    assert code == 130 and err == f"sogdd: interrupted; {out} left as it was\n"
    assert _tree(out) == before and [p.name for p in tmp_path.iterdir()] == ["rig"]
    monkeypatch.undo()
    (out / "right" / "mine.txt").write_text("mine")
    code, _, err = _run(capsys, *_cams(folder), "--board", "chessboard:9x6", "--out", out)
    assert code == 2 and "holds right/mine.txt, which sogdd calibrate did not write" in err
    assert _tree(out) == {**before, "right/mine.txt": b"mine"}


@pytest.mark.slow
def test_an_unreadable_image_is_exit_2_with_the_outputs_written(rendered_rig, tmp_path, capsys):
    folder, _, _ = rendered_rig
    left = tmp_path / "left"
    shutil.copytree(folder / "left", left)
    (left / "left04.png").write_bytes(b"not an image")
    out = tmp_path / "rig"
    code, text, err = _run(capsys, "--camera", "left", left, "--camera", "right", folder / "right", "--board",
                           "chessboard:9x6", "--model", "pinhole", "--out", out)
    assert code == _done(text, unreadable=True) and "left04.png" in err and "Traceback" not in err
    rows = {r["view"]: r for r in csv.DictReader(open(out / "left" / "views.csv"))}
    assert rows["left04.png"]["status"] == "unreadable"
    assert (out / "rig.yaml").is_file() and (out / "report.html").is_file()
    assert (out / "right" / "report.html").is_file()


@pytest.mark.slow
def test_a_charuco_rig(rig_truth, tmp_path, capsys):
    """ChArUco labels are the board's own: the rig needs no chessboard size, and its pose comes back."""
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    lenses, (R, T) = rig_truth
    cams = {n: render.Camera(K, D, (640, 480)) for n, (K, D) in lenses.items()}
    board = cv2.aruco.CharucoBoard((5, 7), 1.0, 0.7, cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_5X5_100))
    outline = np.array([[0.0, 0, 0], [5, 0, 0], [5, 7, 0], [0, 7, 0]])
    kept = 0
    for k, (rv, tv) in enumerate(render.random_sequence(cams["left"], render.ChessboardTarget(5, 7, 1.0), 40,
                                                        seed=5)):
        poses = {"left": (rv, tv), "right": (cv2.Rodrigues(R @ cv2.Rodrigues(rv)[0])[0].ravel(), R @ tv + T)}
        if not all(np.all((p >= 4) & (p <= [635, 475])) for p in
                   (cams[n].project(outline, *poses[n]) for n in cams)):
            continue
        kept += 1
        for n, cam in cams.items():
            (tmp_path / n).mkdir(exist_ok=True)
            view = render.render_charuco(cam, board, *poses[n], blur=0.7, noise=1.0, rng=10 * k + len(n))
            cv2.imwrite(str(tmp_path / n / f"{n}_{kept:03d}.png"), view.image)
        if kept == 6:
            break
    out = tmp_path / "rig"
    code, text, err = _run(capsys, "--camera", "left", tmp_path / "left", "--camera", "right",
                           tmp_path / "right", "--board", "charuco:5x7:0.7:DICT_5X5_100", "--model", "pinhole",
                           "--no-report", "--out", out)
    assert code == _done(text), err
    fs = cv2.FileStorage(str(out / "rig.yaml"), cv2.FILE_STORAGE_READ)
    assert np.linalg.norm(fs.getNode("T_right").mat()) == pytest.approx(np.linalg.norm(T), rel=0.03)
    assert np.degrees(np.linalg.norm(cv2.Rodrigues(fs.getNode("R_right").mat() @ R.T)[0])) < 0.5
    fs.release()
