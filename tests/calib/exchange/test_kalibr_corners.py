"""Kalibr-style observations of a calibration's corners: Kalibr's ids and target points for a chessboard and an
AprilGrid, from a result or an output folder, a rig's files, --used-only, the command, and bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sogdd.calib.demo import demo_calibration
from sogdd.calib.exchange.kalibr_corners import (
    COLUMNS,
    kalibr_cameras,
    kalibr_observations,
    read_kalibr_corners,
    write_kalibr_corners,
)
from sogdd.calib.files import write_calibration
from sogdd.calib.rig import write_rig
from sogdd.calib.rig.demo import demo_rig
from sogdd.calib.targets.aprilgrid import AprilGrid
from sogdd.calib.targets.board import Board
from sogdd.cli.main import main

GRID = AprilGrid(4, 4, 0.088, 0.3)  # 64 Kalibr points: room for the demo's 54 corners a view


def kalibr_checkerboard(W: int, H: int, spacing: float) -> dict[tuple[int, int], tuple[int, tuple]]:
    """Kalibr's GridCalibrationTargetCheckerboard, loop for loop: (c, r) -> (point number, (x, y))."""
    points, n = {}, 0
    for r in range(H):
        for c in range(W):
            points[(c, r)] = (n, (spacing * r, spacing * c))  # createGridPoints: (rowSpacing r, colSpacing c)
            n += 1
    return points


def aprilgrid_calibration():
    """The demo's views with their corners numbered as an AprilGrid's (Kalibr's points 0..53 of GRID)."""
    cal = demo_calibration()
    boards = []
    for b in cal.boards:
        if b is None:
            boards.append(None)
            continue
        ids = np.arange(len(b))[::-1].copy()  # not in the order of the ids: the file sorts them
        boards.append(Board(b.image_points, GRID.labels()[ids], ids=ids, source="aprilgrid"))
    return dataclasses.replace(cal, boards=tuple(boards))


def test_a_round_trip_is_exact(tmp_path):
    cal = demo_calibration()
    expected = kalibr_observations(kalibr_cameras(cal)[0], width=9)
    path, = write_kalibr_corners(cal, tmp_path / "obs.csv", pattern=(9, 6))
    assert path == tmp_path / "obs.csv"
    assert path.read_text().splitlines()[0] == ",".join(COLUMNS)
    back = read_kalibr_corners(path)
    assert back == expected and len(back) == sum(b is not None for b in cal.boards) >= 6
    v = cal.names.index(back[2].view)
    assert sorted(back[2].xy.tolist()) == sorted(cal.boards[v].image_points.tolist())  # bit for bit


def test_chessboard_ids_and_points_are_kalibrs(tmp_path):
    cal = dataclasses.replace(demo_calibration(), square=25.0)
    kalibr = kalibr_checkerboard(9, 6, 25.0)
    obs = {o.view: o for o in read_kalibr_corners(write_kalibr_corners(cal, tmp_path, pattern=(9, 6))[0])}
    assert (tmp_path / "observations.csv").is_file()
    checked = 0
    for name, b in zip(cal.names, cal.boards):
        if b is None:
            assert name not in obs  # Kalibr has no observation of a view without a board
            continue
        o = obs[name]
        assert o.ids.tolist() == sorted(o.ids.tolist())
        for (i, j), xy in zip(b.labels, b.image_points):
            k, point = kalibr[(int(i), int(j))]
            row = int(np.flatnonzero(o.ids == k)[0])
            assert o.xy[row].tolist() == xy.tolist() and tuple(o.target[row]) == point
            checked += 1
    assert checked == 54 * len(obs)
    assert obs["view0.png"].timestamp_ns == 0 and obs["view7.png"].timestamp_ns == 7  # frame number in the name


def test_a_wider_pattern_changes_the_ids(tmp_path):
    cal = demo_calibration()
    o = kalibr_observations(kalibr_cameras(cal)[0], width=11)[0]
    b = cal.boards[0]
    k = int(np.flatnonzero((b.labels == [4, 2]).all(axis=1))[0])
    assert o.xy[int(np.flatnonzero(o.ids == 2 * 11 + 4)[0])].tolist() == b.image_points[k].tolist()


def test_aprilgrid_ids_come_from_the_board(tmp_path):
    cal = aprilgrid_calibration()
    obs = kalibr_observations(kalibr_cameras(cal)[0], grid=GRID, scale=1000.0)
    b = cal.boards[cal.names.index(obs[0].view)]
    assert obs[0].ids.tolist() == sorted(b.ids.tolist()) == list(range(54))
    k = int(np.flatnonzero(b.ids == 9)[0])  # point 9: grid column 1, row 1 of the 8-wide grid: (s, s)
    assert obs[0].xy[9].tolist() == b.image_points[k].tolist()
    assert obs[0].target[9].tolist() == pytest.approx([88.0, 88.0], abs=1e-9)
    assert obs[0].target[10].tolist() == pytest.approx([1.3 * 88.0, 88.0], abs=1e-9)  # column 2: one pitch
    with pytest.raises(ValueError, match="geometry"):
        kalibr_observations(kalibr_cameras(cal)[0])
    with pytest.raises(ValueError, match="not its labels'"):
        kalibr_observations(kalibr_cameras(cal)[0], grid=AprilGrid(5, 4, 0.088, 0.3))


def test_aprilgrid_ids_from_an_output_folder_are_the_boards(tmp_path):
    cal = aprilgrid_calibration()
    write_calibration(cal, tmp_path / "calib")  # corners.csv: labels and source, no ids
    a = read_kalibr_corners(write_kalibr_corners(cal, tmp_path / "a.csv", grid=GRID)[0])
    b = read_kalibr_corners(write_kalibr_corners(tmp_path / "calib", tmp_path / "b.csv",
                                                 grid="aprilgrid:4x4:0.088:0.3")[0])
    assert [o.view for o in a] == [o.view for o in b] and len(a) >= 6
    for x, y in zip(a, b):
        assert x.ids.tolist() == y.ids.tolist() and np.array_equal(x.target, y.target)
        assert np.max(np.abs(x.xy - y.xy)) <= 5e-5  # corners.csv holds 4 decimals


def test_the_command_wants_the_aprilgrids_geometry(tmp_path, capsys):
    write_calibration(aprilgrid_calibration(), tmp_path / "calib")
    out = tmp_path / "obs.csv"
    assert main(["convert", str(tmp_path / "calib"), str(out), "--to", "kalibr-corners"]) == 2
    assert "--board aprilgrid:" in capsys.readouterr().err and not out.exists()
    assert main(["convert", str(tmp_path / "calib"), str(out), "--to", "kalibr-corners", "--board",
                 "chessboard:9x6"]) == 2
    assert "AprilGrid's geometry" in capsys.readouterr().err and not out.exists()
    assert main(["convert", str(tmp_path / "calib"), str(out), "--to", "kalibr-corners", "--board",
                 "aprilgrid:4x4:0.088:0.3"]) == 0
    assert read_kalibr_corners(out)[0].ids.tolist() == list(range(54))


def test_a_rig_writes_one_file_per_camera(tmp_path):
    rig = demo_rig()
    write_rig(rig, tmp_path / "rig")
    files = write_kalibr_corners(rig, tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["left.csv", "right.csv"]
    assert files == [tmp_path / "out" / "left.csv", tmp_path / "out" / "right.csv"]
    left, right = (read_kalibr_corners(p) for p in files)
    seen = [v for v, u in enumerate(rig.cameras[0].calibration.corner_used) if u is not None]
    assert [o.timestamp_ns for o in left] == seen  # views named 0, 1, ...: their frame numbers
    assert {o.view for o in right} <= set(rig.cameras[1].calibration.names)
    from_folder = write_kalibr_corners(tmp_path / "rig", tmp_path / "out2")
    assert [p.name for p in from_folder] == ["left.csv", "right.csv"]
    assert [o.timestamp_ns for o in read_kalibr_corners(from_folder[0])] == seen
    with pytest.raises(ValueError, match="one file per camera"):
        write_kalibr_corners(rig, tmp_path / "rig.csv")


def test_used_only_leaves_out_the_rejected_corners(tmp_path):
    cal = demo_calibration()
    used = [None if u is None else u.copy() for u in cal.corner_used]
    used[0][[3, 10, 11]] = False
    cal = dataclasses.replace(cal, corner_used=tuple(used))
    every = read_kalibr_corners(write_kalibr_corners(cal, tmp_path / "all.csv")[0])
    only = read_kalibr_corners(write_kalibr_corners(cal, tmp_path / "used.csv", used_only=True)[0])
    assert len(every[0].ids) == 54 and every[0].used.sum() == 51
    assert len(only[0].ids) == 51 and only[0].used.all()
    gone = set(every[0].ids.tolist()) - set(only[0].ids.tolist())
    assert gone == {int(j) * 9 + int(i) for i, j in cal.boards[0].labels[[3, 10, 11]]}
    assert [len(o.ids) for o in only[1:]] == [len(o.ids) for o in every[1:]]


def test_the_command_writes_them(tmp_path, capsys):
    write_calibration(demo_calibration(), tmp_path / "calib")
    assert main(["convert", str(tmp_path / "calib"), str(tmp_path / "obs"), "--to", "kalibr-corners",
                 "--pattern", "9x6", "--scale", "0.001", "--used-only"]) == 0
    assert "observations.csv" in capsys.readouterr().out
    obs = read_kalibr_corners(tmp_path / "obs" / "observations.csv")
    expected = kalibr_observations(kalibr_cameras(tmp_path / "calib")[0], width=9, scale=0.001, used_only=True)
    assert obs == expected
    assert obs[0].target[1].tolist() == [0.0, 0.001]  # square 1, in thousandths
    assert main(["convert", str(tmp_path / "calib"), str(tmp_path / "calib" / "corners.csv"), "--to",
                 "kalibr-corners"]) == 2
    assert "that is the input" in capsys.readouterr().err


def test_bad_input_is_one_line(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert main(["convert", str(tmp_path / "empty"), str(tmp_path / "o.csv"), "--to", "kalibr-corners"]) == 2
    err = capsys.readouterr().err
    assert "no corners.csv" in err and len(err.strip().splitlines()) == 1
    bad = tmp_path / "bad" / "corners.csv"
    bad.parent.mkdir()
    bad.write_text("view,x,y\na.png,1,2\n")
    assert main(["convert", str(bad.parent), str(tmp_path / "o.csv"), "--to", "kalibr-corners"]) == 2
    err = capsys.readouterr().err
    assert "not sogdd's corners.csv" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.csv").exists()
    obs = tmp_path / "obs.csv"
    obs.write_text(",".join(COLUMNS) + "\n0,a.png,x,1.0,2.0,0.0,0.0,1\n")
    with pytest.raises(ValueError, match=r"obs.csv:2: a row is") as exc:
        read_kalibr_corners(obs)
    assert "\n" not in str(exc.value)
    obs.write_text("view,x,y\n")
    with pytest.raises(ValueError, match="not Kalibr-style observations"):
        read_kalibr_corners(obs)


@pytest.mark.parametrize("scale", ["nan", "-1", "0", "inf"])
def test_a_scale_that_is_no_unit_is_refused_before_anything_is_written(tmp_path, capsys, scale):
    write_calibration(demo_calibration(), tmp_path / "calib")
    out = tmp_path / "o.csv"
    assert main(["convert", str(tmp_path / "calib"), str(out), "--to", "kalibr-corners", "--scale", scale]) == 2
    err = capsys.readouterr().err
    assert "the scale must be a positive number" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
    with pytest.raises(ValueError, match="the scale must be a positive number"):
        kalibr_observations(kalibr_cameras(demo_calibration())[0], width=9, scale=float(scale))
