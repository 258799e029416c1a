"""``sogdd eval calibration --photos``: board files, set discovery, counting, hand labels, the command."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.calibration.comparators import Detection
from sogdd.evaluation.calibration.photo_sets import (
    camera_prefixes,
    hand_lattice,
    infer_target,
    parse_info_txt,
    parse_target_yaml,
    photo_sets,
    read_reference,
    read_storage,
)
from sogdd.evaluation.calibration.photos import count_view, merge_photos, run_set
from sogdd.evaluation.calibration.render import Camera, ChessboardTarget, render_view

# BoofCV's own layout, as in the shared data's fisheye set: 7 rows and 5 columns of squares
_GRID_YAML = """# Serialized boofcv.alg.fiducial.calib.ConfigCalibrationTarget
boofcv.alg.fiducial.calib.ConfigCalibrationTarget:
  grid:
    numRows: 7
    shapeSize: 1.0
    numCols: 5
BoofCV.Version: 0.39-SNAPSHOT
"""
# ECoCheck's marker shapes are a YAML list whose "- " sits at its key's indent
_ECO_YAML = """boofcv.alg.fiducial.calib.ConfigCalibrationTarget:
  ecocheck:
    markerShapes:
    - numRows: 14
      squareSize: 1.0
      numCols: 10
  type: ECOCHECK
"""


def test_target_squares_become_inner_corners_in_opencv_order():
    # (cols, rows) of inner corners: a swap gives (6, 4), squares left as they are (5, 7)
    assert parse_target_yaml(_GRID_YAML).pattern == (4, 6)
    eco = parse_target_yaml(_ECO_YAML)
    assert (eco.kind, eco.pattern, eco.chessboard_like) == ("ecocheck", (9, 13), True)
    assert parse_info_txt("# comment\nchess true 4 3 33").pattern == (6, 4)  # black squares per side
    assert not parse_info_txt("square true 4 3 30 30").chessboard_like
    with pytest.raises(ValueError, match="no grid"):
        parse_target_yaml("x:\n  type: CHESSBOARD\n")


def test_counting_complete_partial_extra_and_wrong_labels():
    lab = np.array([(i, j) for j in range(6) for i in range(4)])
    pts = lab * 30.0 + 50
    full = Detection(pts, lab)
    c = count_view([full, Detection(pts + 200, lab)], (4, 6), hand=pts[::-1])
    assert (c.complete, c.partial, c.extra, c.wrong) == (True, False, 1, 0)
    assert count_view([full], (6, 4)).complete  # a board either way round
    assert count_view([Detection(pts[:20], lab[:20])], (4, 6)).partial
    lab38 = np.array([(i, j) for j in range(8) for i in range(3)])  # 24 corners, but not a 4 x 6 board
    assert count_view([Detection(lab38 * 30.0, lab38)], (4, 6)).partial
    swapped = lab.copy()
    swapped[[0, 5]] = swapped[[5, 0]]  # two corners with each other's labels
    assert count_view([Detection(pts, swapped)], (4, 6), hand=pts).wrong == 2
    empty = count_view([], (4, 6))
    assert (empty.complete, empty.partial, empty.extra) == (False, False, 0)


def test_hand_lattice_does_not_trust_the_file_order():
    g = np.array([(i, j) for j in range(4) for i in range(6)], dtype=float)
    H = np.array([[38.0, 6, 120], [-4, 41, 90], [0.01, 0.004, 1]])  # a tilted view
    pts = cv2.perspectiveTransform(g.reshape(-1, 1, 2), H).reshape(-1, 2)
    order = np.random.default_rng(3).permutation(len(g))
    lab = hand_lattice(pts[order], (6, 4))
    assert lab is not None
    assert count_view([Detection(pts, g.astype(int))], (6, 4), hand=pts[order]).wrong == 0
    assert hand_lattice(pts[:-1], (6, 4)) is None


def test_omnidirectional_reference_is_made_comparable(tmp_path):
    (tmp_path / "fisheye.yaml").write_text("pinhole:\n  fx: 398.0\n  fy: 396.0\n  cx: 319.0\n  cy: 320.0\n"
                                          "model: omnidirectional_universal\nmirror_offset: 1.0\n")
    ref = read_reference(tmp_path)
    assert (ref["fx"], ref["fy"], ref["cx"], ref["cy"]) == (199.0, 198.0, 319.0, 320.0)


def _render_set(folder):
    """Three views of a 4 x 6 board (upright: 4 corners across): complete, two boards, cut by the frame."""
    cam = Camera(np.array([[400.0, 0, 239.5], [0, 400, 179.5], [0, 0, 1]]), np.zeros(4), (480, 360))
    target = ChessboardTarget(4, 6, 1.0)

    def view(tx: float, z: float = 16.0):
        return render_view(cam, target, np.array([0.1, -0.15, 0.0]), np.array([tx, -2.5, z]), blur=0.8,
                           noise=1.0, rng=1)

    one = view(-1.5)
    two = np.hstack([view(-6.0, 19.0).image[:, :240], view(3.0, 19.0).image[:, 240:]])
    cut = view(7.0)
    folder.mkdir(parents=True)
    for name, img in (("1.png", one.image), ("2.png", two), ("10.png", cut.image)):
        cv2.imwrite(str(folder / name), img)
    (folder / "calibration_target.yaml").write_text(_GRID_YAML)
    lines = ["# list of hand selected 2D points"] + [f"{x} {y}" for x, y in one.corners]
    (folder / "1.txt").write_text("\n".join(lines) + "\n")


def test_a_rendered_set_counts_complete_partial_and_extra_boards(tmp_path):
    _render_set(tmp_path / "board")
    (s,) = photo_sets(tmp_path)
    assert [p.name for p in s.images] == ["1.png", "2.png", "10.png"]  # natural order
    assert s.target.pattern == (4, 6) and s.n_labelled == 1
    rows, notes = run_set(s, ["sogdd", "opencv"])
    by = {r["method"]: r for r in rows}
    sogdd, cv = by["sogdd"], by["opencv"]
    assert (sogdd["complete"], sogdd["partial"], sogdd["extra"]) == (2, 1, 1)
    assert sogdd["wrong_labels"] == 0 and sogdd["labelled_views"] == 1
    assert cv["complete"] >= 1 and cv["partial"] == 0 and cv["wrong_labels"] == 0
    assert sogdd["calibration"][0]["note"].startswith("2 complete boards")
    assert notes == []


def test_command_writes_json_and_markdown_and_merges(tmp_path, capsys):
    _render_set(tmp_path / "data" / "board")
    out = tmp_path / "out"
    base = ["eval", "calibration", "--photos", "--data", str(tmp_path / "data"), "--quiet", "--out", str(out)]
    assert main([*base, "--methods", "opencv", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["command"].startswith("sogdd eval calibration --photos --methods opencv")
    assert [r["method"] for r in res["rows"]] == ["opencv"]
    assert main([*base, "--methods", "sogdd", "--merge"]) == 0
    assert "| board | sogdd | 3 | 2 | 1 (" in capsys.readouterr().out
    merged = json.loads((out / "photos.json").read_text())
    assert [r["method"] for r in merged["rows"]] == ["opencv", "sogdd"]
    assert "| board | opencv | 3 |" in (out / "photos.md").read_text()
    assert main([*base, "--sets", "nope"]) == 2
    assert "unknown photo set" in capsys.readouterr().err
    assert main([*base, "--methods", "hr"]) == 2
    assert "points only" in capsys.readouterr().err


def test_merge_replaces_rows_of_the_same_set_and_method():
    old = {"sets": {"a": {}}, "rows": [{"set": "a", "method": "m", "v": 1},
                                       {"set": "a", "method": "n", "v": 0}]}
    new = {"sets": {"b": {}}, "rows": [{"set": "a", "method": "m", "v": 2}]}
    rows = merge_photos(old, new)["rows"]
    assert sorted((r["method"], r["v"]) for r in rows) == [("m", 2), ("n", 0)]


def test_shared_photo_sets(data_dir):
    root = data_dir / "calibration"
    if not root.is_dir():
        pytest.skip("no calibration photos in the shared data")
    sets = {s.name: s for s in photo_sets(root)}
    assert sets["fisheye_chessboard"].target.pattern == (4, 6) and sets["fisheye_chessboard"].model == "fisheye"
    assert {sets[f"rig3_ecocheck/{c}"].target.pattern for c in ("left", "middle", "right")} == {(9, 13)}
    assert sets["chessboard_border"].target.pattern == (6, 4)  # borrowed from chessboard_sony's info.txt
    for name in ("chessboard_sony", "chessboard_border", "chessboard_hard"):
        assert all(hand_lattice(lab, (6, 4)) is not None for lab in sets[name].labels)
    rows, _ = run_set(sets["chessboard_hard"], ["opencv"])
    assert (rows[0]["complete"], rows[0]["wrong_labels"]) == (1, 0)
    ref = sets["chessboard_sony"].reference
    assert ref["fx"] == pytest.approx(701.58, abs=0.01) and ref["cy"] == pytest.approx(246.63, abs=0.01)


# OpenCV's calibration sample writes its board (inner corners) and camera this way (FileStorage YAML)
_OPENCV_YML = """%YAML:1.0
---
image_width: 480
image_height: 360
board_width: 5
board_height: 4
square_size: 2.5e-02
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 4.0e+02, 0., 2.395e+02, 0., 4.01e+02, 1.795e+02, 0., 0., 1. ]
"""
# ROS 2 camera_calibration's ost.yaml (camera_info): no %YAML line, matrices as rows/cols/data maps
_ROS_YAML = """image_width: 1440
image_height: 1080
camera_name: narrow_stereo
camera_matrix:
  rows: 3
  cols: 3
  data: [1820.89015,    0.     ,  704.20841,
            0.     , 1825.42277,  536.74904,
            0.     ,    0.     ,    1.     ]
distortion_model: %s
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.070137, 0.132547, -0.002117, 0.000433, 0.000000]
"""


def _matrix(fx: float, cx: float) -> str:
    return (f"!!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
            f"   data: [ {fx}, 0., {cx}, 0., {fx}, 240., 0., 0., 1. ]\n")


def _render_views(folder, names, pattern=(5, 4)):
    """Views of a ``pattern`` board (inner corners, 5 across, 4 down), complete in every view, one pose each."""
    cam = Camera(np.array([[400.0, 0, 239.5], [0, 400, 179.5], [0, 0, 1]]), np.zeros(4), (480, 360))
    target = ChessboardTarget(*pattern, 1.0)
    folder.mkdir(parents=True, exist_ok=True)
    for k, name in enumerate(names):
        rvec = np.array([0.15 * np.cos(k), 0.2 * np.sin(k), 0.05 * k])
        view = render_view(cam, target, rvec, np.array([-2.0 + 0.3 * k, -1.5, 11.0 + k]), blur=0.8, noise=1.0,
                           rng=k)
        cv2.imwrite(str(folder / name), view.image)


def test_opencv_filestorage_gives_the_board_and_the_reference(tmp_path):
    folder = tmp_path / "data" / "cam"
    _render_views(folder, ["view1.png", "view2.png", "view3.png"])
    (folder / "calib.yml").write_text(_OPENCV_YML)
    (folder / "boofcv_like.yaml").write_text("a:\n  b: 1\n c: 2\n")  # not OpenCV's YAML: passed over
    (s,) = photo_sets(tmp_path / "data")
    assert s.name == "cam" and s.prefix is None and len(s.images) == 3
    t = s.target
    assert (t.kind, t.pattern, t.square, t.inferred) == ("chessboard", (5, 4), 0.025, False)
    assert s.target.source == str(folder / "calib.yml")
    ref = s.reference
    assert (ref["fx"], ref["fy"], ref["cx"], ref["cy"], ref["model"]) == (400.0, 401.0, 239.5, 179.5, "pinhole")
    assert ref["size"] == [480, 360] and "cam/calib.yml" in ref["note"] and "not ground truth" in ref["note"]
    rows, notes = run_set(s, ["sogdd", "opencv"])
    assert notes == []  # the board is the set's own file
    assert {r["method"]: r["complete"] for r in rows} == {"sogdd": 3, "opencv": 3}
    assert read_storage(folder / "boofcv_like.yaml") is None
    (folder / "calib.yml").write_text(_OPENCV_YML.replace("board_width: 5", "board_width: 1"))
    with pytest.raises(ValueError, match="board_width"):
        photo_sets(tmp_path / "data")


def test_a_board_with_no_file_is_inferred_from_a_clear_majority_of_views(tmp_path):
    folder = tmp_path / "data" / "cam"
    _render_views(folder, ["a1.png", "a2.png", "a3.png", "a4.png"])
    (s,) = photo_sets(tmp_path / "data")
    t = s.target
    assert (t.kind, t.pattern, t.inferred, t.square) == ("chessboard", (5, 4), True, 1.0)
    assert t.source.startswith("inferred from 3 of 3 views")  # stops once 3 views agree
    rows, notes = run_set(s, ["opencv"])
    assert rows[0]["complete"] == 4  # OpenCV is given the inferred pattern
    assert len(notes) == 1 and "5 x 4 board inferred from 3 of 3 views" in notes[0]
    blank = np.full((360, 480), 128, np.uint8)
    one = cv2.imread(str(s.images[0]), cv2.IMREAD_GRAYSCALE)
    assert infer_target([blank, one, blank, one]) is None  # 2 views agree: too few
    wide = tmp_path / "wide"
    _render_views(wide, ["w1.png", "w2.png"], pattern=(6, 4))
    six = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted(wide.iterdir())]
    five = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in s.images]
    assert infer_target([*six, *five[:3]]) is None  # 3 against 2: no clear majority
    assert infer_target([*six, *five]).pattern == (5, 4)  # 4 against 2
    assert infer_target([five[0].T.copy(), five[1], five[2].T.copy()]).pattern == (4, 5)  # seen turned most


def test_ros_camera_info_is_a_reference(tmp_path):
    (tmp_path / "ost.yaml").write_text(_ROS_YAML % "plumb_bob")
    ref = read_reference(tmp_path)
    assert (ref["fx"], ref["fy"], ref["cx"], ref["cy"]) == (1820.8901, 1825.4228, 704.2084, 536.749)
    assert (ref["model"], ref["size"], ref["source"]) == ("pinhole", [1440, 1080], str(tmp_path / "ost.yaml"))
    assert "ROS camera_info" in ref["note"] and "not ground truth" in ref["note"]
    (tmp_path / "ost.yaml").write_text(_ROS_YAML % "equidistant")  # ROS's fisheye model
    assert read_reference(tmp_path)["model"] == "fisheye"


def _write_blank(folder, names):
    folder.mkdir(parents=True, exist_ok=True)
    for n in names:
        cv2.imwrite(str(folder / n), np.zeros((8, 8), np.uint8))


def test_a_folder_of_two_name_prefixes_is_two_cameras(tmp_path):
    stereo = tmp_path / "data" / "stereo"
    _write_blank(stereo, [f"{c}{k:02d}.jpg" for c in ("left", "right") for k in (1, 2, 3, 11)])
    stereo_yml = "%YAML:1.0\nM1: " + _matrix(500.0, 330.0) + "M2: " + _matrix(510.0, 331.0)
    (stereo / "intrinsics.yml").write_text(stereo_yml)
    (stereo / "left_intrinsics.yml").write_text("%YAML:1.0\nboard_width: 9\nboard_height: 6\n"
                                                "square_size: 0.025\ncamera_matrix: " + _matrix(536.0, 342.0))
    mono = tmp_path / "data" / "mono"
    _write_blank(mono, [f"left-{k:04d}.png" for k in (0, 3, 5, 8)])
    (mono / "ost.yaml").write_text(_ROS_YAML % "plumb_bob")
    (mono / "info.txt").write_text("chess true 5 4 24")
    sets = {s.name: s for s in photo_sets(tmp_path / "data")}
    assert sorted(sets) == ["mono", "stereo/left", "stereo/right"]
    left, right = sets["stereo/left"], sets["stereo/right"]
    assert [p.name for p in left.images] == ["left01.jpg", "left02.jpg", "left03.jpg", "left11.jpg"]
    assert [p.name for p in right.images] == ["right01.jpg", "right02.jpg", "right03.jpg", "right11.jpg"]
    assert (left.prefix, right.prefix, left.folder, right.folder) == ("left", "right", stereo, stereo)
    assert left.target.pattern == right.target.pattern == (9, 6)  # the folder's board, for both cameras
    assert left.reference["fx"] == 536.0 and "left_intrinsics.yml" in left.reference["source"]  # its own file
    assert (right.reference["fx"], right.reference["cx"]) == (510.0, 331.0) and "M2" in right.reference["note"]
    (stereo / "left_intrinsics.yml").write_text("%YAML:1.0\nboard_width: 9\nboard_height: 6\n")
    # with no camera_matrix of its own, the stereo file's M1
    assert photo_sets(tmp_path / "data", ["stereo/left"])[0].reference["fx"] == 500.0
    assert [s.name for s in photo_sets(tmp_path / "data", ["stereo"])] == ["stereo/left", "stereo/right"]
    assert len(sets["mono"].images) == 4 and sets["mono"].reference["fx"] == 1820.8901  # one prefix: one set
    assert camera_prefixes(["left1.jpg", "left2.jpg", "left3.jpg", "right1.jpg", "right2.jpg"]) is None
    assert camera_prefixes(["a1.jpg", "a2.jpg", "a3.jpg", "b1.jpg", "b2.jpg", "b3.jpg", "c.jpg"]) is None
    assert camera_prefixes(["cam0_1.png", "cam0_2.png", "cam0_3.png", "cam1_1.png", "cam1_2.png",
                            "cam1_3.png"]) == {"cam0": "cam0_", "cam1": "cam1_"}


def test_shared_stereo_and_ros_sets(data_dir):
    root = data_dir / "calibration"
    if not (root / "opencv_stereo").is_dir() or not (root / "hik_mono_1440").is_dir():
        pytest.skip("no opencv_stereo or hik_mono_1440 in the shared data")
    sets = {s.name: s for s in photo_sets(root, ["opencv_stereo", "hik_mono_1440"])}
    assert sorted(sets) == ["hik_mono_1440", "opencv_stereo/left", "opencv_stereo/right"]
    left, right, hik = sets["opencv_stereo/left"], sets["opencv_stereo/right"], sets["hik_mono_1440"]
    assert len(left.images) == len(right.images) == 13
    assert all(p.name.startswith("left") for p in left.images) and left.images[-1].name == "left14.jpg"
    assert left.target.pattern == (9, 6) and left.target.square == pytest.approx(0.025)
    assert left.target.source.endswith("left_intrinsics.yml") and not left.target.inferred
    assert left.reference["fx"] == pytest.approx(535.9157) and left.reference["cx"] == pytest.approx(342.2832)
    assert right.reference["fx"] == pytest.approx(534.8033) and right.reference["cy"] == pytest.approx(242.0532)
    assert len(hik.images) == 30 and hik.target.inferred and sorted(hik.target.pattern) == [6, 9]
    assert hik.reference["fx"] == pytest.approx(1820.8901) and hik.reference["cy"] == pytest.approx(536.749)
    rows, _ = run_set(right, ["opencv"], views=3)
    assert rows[0]["complete"] == 3
