"""calibrate_rig_images and write_rig_outputs on a rendered two-camera rig: the rig recovered, every input
accounted for, the one-line errors before any work, and the output folder complete or as it was."""

from __future__ import annotations

import csv
import shutil

import cv2
import numpy as np
import pytest

from sogdd.calib.rig import files as rig_files
from sogdd.calib.rig.files import read_rig
from sogdd.calib.rig.session import calibrate_rig_images, check_rig_output_folder, write_rig_outputs


@pytest.fixture(scope="module")
def rig_result(rendered_rig):
    """The rendered rig calibrated once (pinhole model, square 25), for the tests that only read it."""
    folder, _, _ = rendered_rig
    return calibrate_rig_images({"left": folder / "left", "right": folder / "right"}, "chessboard:9x6",
                                square=25.0, model="pinhole", thumbnails=False)


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


def test_every_image_is_a_record_named_by_its_file(rig_result):
    for name in ("left", "right"):
        views = rig_result.views[name]
        assert [v.name for v in views] == [f"{name}{k:02d}.png" for k in range(1, 9)]
        assert [v.view for v in views] == list(range(8)) and {v.status for v in views} == {"used"}
        assert rig_result.rig.camera(name).calibration.names == tuple(v.name for v in views)


def test_parameters_fail_before_any_image_is_read(tmp_path):
    cams = {"left": tmp_path / "nothing-here", "right": tmp_path / "nor-here"}
    with pytest.raises(ValueError, match="chessboard:auto cannot calibrate a rig.*give chessboard:COLSxROWS"):
        calibrate_rig_images(cams)
    with pytest.raises(ValueError, match="two or more cameras"):
        calibrate_rig_images({"left": tmp_path}, "chessboard:9x6")
    with pytest.raises(ValueError, match="camera name 'my cam'"):
        calibrate_rig_images({"left": tmp_path, "my cam": tmp_path}, "chessboard:9x6")
    with pytest.raises(ValueError, match="boards must be 'best' for a rig"):
        calibrate_rig_images(cams, "chessboard:9x6", boards="all")
    with pytest.raises(ValueError, match="one per camera"):
        calibrate_rig_images(cams, "chessboard:9x6", model={"left": "pinhole", "centre": "pinhole"})
    with pytest.raises(ValueError, match="unknown camera model"):
        calibrate_rig_images(cams, "chessboard:9x6", model={"left": "pinhole", "right": "pinhol"})


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
