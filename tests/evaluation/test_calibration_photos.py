"""``sogdd eval calibration --photos``: board files, set discovery, counting, hand labels, the command."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.calibration.comparators import Detection
from sogdd.evaluation.calibration.photo_sets import (
    hand_lattice,
    parse_info_txt,
    parse_target_yaml,
    photo_sets,
    read_reference,
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
