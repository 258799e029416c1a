"""OpenCV's detectors as a second source: proposals are refined, checked and labelled as sogdd's own boards."""

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.board import grid_dims
from sogdd.calib.targets.chessboard import detect_board, find_boards
from sogdd.calib.targets.chessboard.proposals import propose

CAM = Camera(np.array([[700.0, 0, 319.5], [0, 700.0, 239.5], [0, 0, 1]]), (-0.05, 0.0, 0, 0), (640, 480))


def view(render, cols=9, rows=6, square=0.03):
    R = np.array([0.3, -0.2, 0.1])
    Rm, _ = cv2.Rodrigues(R)
    t = np.array([0.0, 0.0, 1.0]) - Rm @ np.array([(cols - 1) * square / 2, (rows - 1) * square / 2, 0.0])
    return render.render_view(CAM, render.Board(cols, rows, square), R, t, blur=1.0, noise=2.0, rng=0)


def test_a_proposal_is_measured_by_sogdd_and_says_where_it_came_from(render):
    v = view(render)
    # a threshold no X-corner reaches: the own search finds nothing, OpenCV's board is all there is
    b = detect_board(v.image, (9, 6), min_strength=1e6)
    assert b is not None and b.source == "opencv" and b.size == (9, 6) and len(b) == 54
    d, k = cKDTree(v.corners).query(b.image_points)
    assert d.max() < 0.1  # refined at full resolution, not OpenCV's own positions
    raw = propose(v.image.astype(float), (9, 6))[0].xy
    assert np.abs(raw - b.image_points).max() > 0  # ... which it moved
    assert detect_board(v.image, (9, 6), min_strength=1e6, proposals=False) is None


@pytest.mark.parametrize("part", [(8, 6), (4, 3)])
def test_a_proposal_that_is_part_of_a_larger_board_is_no_board_of_the_pattern(render, part):
    v = view(render, cols=9, rows=6)
    # on this view OpenCV's classic detector finds an 8 x 6 block of the 9 x 6 board and SB a 4 x 3 one
    assert propose(v.image.astype(float), part)
    # the grid goes on beyond the block, so it is not the board
    found = find_boards(v.image, part)
    assert found.boards == []
    assert (9, 6) in [grid_dims(b) or () for b in found.others]


def test_the_own_search_carries_the_load(render):
    v = view(render)
    b = detect_board(v.image, (9, 6))
    assert b is not None and b.source == "sogdd" and len(b) == 54


def test_a_complete_screen_of_the_pattern_does_not_stop_the_proposals(render, monkeypatch):
    from sogdd.calib.targets.board import Board
    from sogdd.calib.targets.chessboard import search
    from sogdd.calib.targets.chessboard.proposals import Proposal

    v = view(render)
    k = np.arange(54)
    grid = np.stack([k % 9, k // 9], axis=1)
    # the own search's boards: the view's board with a column missing, and a complete copy of the pattern
    # with 4 px cells (a screen behind it)
    whole = detect_board(v.image, (9, 6), proposals=False)
    keep = whole.labels[:, 0] > 0
    partial = Board(whole.image_points[keep], whole.labels[keep])
    screen = Board(grid * 4.0 + 10.0, grid, size=(9, 6))
    monkeypatch.setattr(search, "_boards", lambda *a, **kw: [screen, partial])
    monkeypatch.setattr(search, "propose", lambda grey, pattern: [Proposal(v.corners.copy(), grid, "opencv")])
    b = detect_board(v.image, (9, 6))
    assert b is not None and b.source == "opencv" and len(b) == 54
    assert cKDTree(v.corners).query(b.image_points)[0].max() < 0.1
