"""mrgingham's corners.vnl of a calibration's corners: its layout, from a result or an output folder, read by
mrcal's own reader, and mrcal-calibrate-cameras calibrating from it (where mrcal is installed)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from sogdd.calib.demo import demo_calibration
from sogdd.calib.exchange.mrgingham import (
    CornerView,
    corner_views,
    corners_vnl_text,
    read_corners_vnl,
    write_corners_vnl,
)
from sogdd.calib.files import write_calibration
from sogdd.calib.rig import write_rig
from sogdd.calib.rig.demo import demo_rig
from sogdd.cli.main import main


def test_the_grid_is_row_by_row_with_dashes_where_no_corner_is():
    xy = np.array([[5.0, 6.0], [1.0, 2.0], [3.0, 4.5]])
    views = [CornerView("a.png", np.array([[2, 1], [0, 0], [1, 1]]), xy, np.array([True, True, False])),
             CornerView("none.png", None, None, None)]
    lines = corners_vnl_text(views, (3, 2)).splitlines()
    assert lines[0] == "# filename x y level"
    assert lines[1:] == ["a.png 1.0 2.0 0", "a.png - - -", "a.png - - -",      # j = 0: i = 0, 1, 2
                         "a.png - - -", "a.png 3.0 4.5 0", "a.png 5.0 6.0 0",  # j = 1
                         "none.png - - -"]
    used = corners_vnl_text(views, (3, 2), used_only=True).splitlines()
    assert used[5] == "a.png - - -" and used[6] == "a.png 5.0 6.0 0"


def test_labels_that_do_not_fit_the_grid_are_refused():
    v = CornerView("a.png", np.array([[0, 0], [3, 0]]), np.zeros((2, 2)), None)
    with pytest.raises(ValueError, match="outside the 3 x 2 grid"):
        corners_vnl_text([v], (3, 2))
    with pytest.raises(ValueError, match="labels are relative"):
        corners_vnl_text([CornerView("a.png", np.array([[-1, 0]]), np.zeros((1, 2)), None)])
    with pytest.raises(ValueError, match="no white space"):
        corners_vnl_text([CornerView("a b.png", np.array([[0, 0]]), np.zeros((1, 2)), None)])


def test_a_result_and_its_output_folder_give_the_same_corners(tmp_path):
    cal = demo_calibration()
    write_calibration(cal, tmp_path / "calib")
    a = read_corners_vnl(write_corners_vnl(cal, tmp_path / "a.vnl"), (9, 6))
    b = read_corners_vnl(write_corners_vnl(tmp_path / "calib", tmp_path / "b.vnl"), (9, 6))
    seen = sorted(n for n, b in zip(cal.names, cal.boards) if b is not None)
    assert sorted(a) == sorted(b) == seen and len(seen) >= 6
    for name in a:
        assert np.nanmax(np.abs(a[name] - b[name])) <= 5e-5  # corners.csv holds 4 decimals
    board = cal.boards[0]
    k = int(np.flatnonzero((board.labels == [4, 2]).all(axis=1))[0])
    assert a[cal.names[0]][2 * 9 + 4, :2].tolist() == board.image_points[k].tolist()  # exact from the result


def test_a_rigs_views_are_named_by_camera(tmp_path):
    rig = demo_rig()
    write_rig(rig, tmp_path / "rig")
    from_result = {v.name for v in corner_views(rig)}
    from_folder = {v.name for v in corner_views(tmp_path / "rig") if v.labels is not None}
    assert from_folder <= from_result
    assert {n.split("/")[0] for n in from_folder} == {"left", "right"}


def test_the_command_writes_it_and_keeps_its_input(tmp_path, capsys):
    write_calibration(demo_calibration(), tmp_path)
    assert main(["convert", str(tmp_path), str(tmp_path / "corners.vnl"), "--to", "mrgingham",
                 "--pattern", "9x6", "--used-only"]) == 0
    assert "corners.vnl" in capsys.readouterr().out
    grid = read_corners_vnl(tmp_path / "corners.vnl", (9, 6))
    assert len(grid) == sum(b is not None for b in demo_calibration().boards)
    assert main(["convert", str(tmp_path), str(tmp_path / "corners.csv"), "--to", "mrgingham"]) == 2
    assert "that is the input" in capsys.readouterr().err


def test_mrcals_reader_sees_our_corners(tmp_path, mrcal_python):
    cal = demo_calibration()
    path = write_corners_vnl(cal, tmp_path / "corners.vnl")
    script = ("import json, sys, mrcal\n"
              "obs, idx, files = mrcal.compute_chessboard_corners(9, 6, globs_per_camera=('*.png',), "
              "corners_cache_vnl=sys.argv[1])\n"
              "print(json.dumps({'obs': obs.tolist(), 'files': list(files)}))\n")
    run = subprocess.run([mrcal_python, "-c", script, str(path)], capture_output=True, text=True, timeout=120,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    obs = np.array(out["obs"])  # (views, H, W, 3): x, y, weight
    with_board = sum(b is not None for b in cal.boards)  # a view without one is mrgingham's 'name - - -'
    assert with_board >= 6 and obs.shape == (with_board, 6, 9, 3) and np.all(obs[..., 2] == 1.0)
    for v, f in enumerate(out["files"]):
        board = cal.boards[cal.names.index(f.rsplit("/", 1)[-1])]
        for (i, j), xy in zip(board.labels, board.image_points):
            assert obs[v, j, i, :2].tolist() == xy.tolist()


@pytest.mark.skipif(shutil.which("mrcal-calibrate-cameras") is None, reason="mrcal's tools are not installed "
                    "(apt-get install mrcal)")
def test_mrcal_calibrates_from_our_corners(tmp_path):
    cal = demo_calibration()
    write_corners_vnl(cal, tmp_path / "corners.vnl")
    cmd = ["mrcal-calibrate-cameras", "--corners-cache", "corners.vnl", "--lensmodel", "LENSMODEL_OPENCV5",
           "--focal", "600", "--imagersize", "640", "480", "--object-spacing", repr(float(cal.square)),
           "--object-width-n", "9", "--object-height-n", "6", "--outdir", str(tmp_path), "*.png"]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    text = (tmp_path / "camera-0.cameramodel").read_text()
    intr = [float(v) for v in re.search(r"'intrinsics':\s*\[([^\]]*)\]", text).group(1).split(",") if v.strip()]
    assert abs(intr[0] / cal.K[0, 0] - 1) < 0.005 and abs(intr[1] / cal.K[1, 1] - 1) < 0.005
    assert abs(intr[2] - cal.K[0, 2]) < 2 and abs(intr[3] - cal.K[1, 2]) < 2
