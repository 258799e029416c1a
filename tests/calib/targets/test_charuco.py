"""ChArUco: OpenCV's IDs, sogdd's corners, on a rendered board with known corners."""

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.charuco import detect_charuco, other_layout
from sogdd.calib.targets.spec import parse_board, view_boards

DICT = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
BOARD = cv2.aruco.CharucoBoard((7, 5), 0.04, 0.02, DICT)
CAM = Camera(np.array([[700.0, 0, 319.5], [0, 700.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))


def view(render, blur=1.0, roll=0.2):
    R = np.array([0.3, -0.2, roll])
    Rm, _ = cv2.Rodrigues(R)
    t = np.array([0.0, 0.0, 0.5]) - Rm @ np.array([0.14, 0.10, 0.0])
    return render.render_charuco(CAM, BOARD, R, t, blur=blur, noise=2.0, rng=3)


def test_ids_labels_and_accuracy_better_than_opencvs(render):
    v = view(render)
    b = detect_charuco(v.image, BOARD)
    assert b is not None and len(b) >= 20 and set(b.ids.tolist()) <= set(range(24))
    assert (b.size == (6, 4)) == (len(b) == 24)
    truth = dict(zip(v.ids.tolist(), v.corners))
    assert np.array_equal(b.labels, v.labels[np.searchsorted(v.ids, b.ids)])
    ours = np.hypot(*(b.image_points - np.array([truth[k] for k in b.ids])).T)
    raw = detect_charuco(v.image, BOARD, refine=False)
    theirs = np.hypot(*(raw.image_points - np.array([truth[k] for k in raw.ids])).T)
    assert ours.mean() < 0.05 and ours.max() < 0.2
    assert ours.mean() < theirs.mean()


def test_no_board_and_bad_arguments():
    assert detect_charuco(np.full((200, 200), 128, np.uint8), BOARD) is None
    with pytest.raises(TypeError, match="CharucoBoard"):
        detect_charuco(np.zeros((20, 20), np.uint8), "board")
    with pytest.raises(ValueError, match="min_corners"):
        detect_charuco(np.zeros((20, 20), np.uint8), BOARD, min_corners=0)


def test_float_images_follow_the_cores_contract(render):
    # floats on [0, 1], else value_range (OpenCV's float images of grey levels: (0, 255)), as the detector
    v = view(render)
    ref = detect_charuco(v.image, BOARD)
    levels = v.image.astype(np.float64)
    with pytest.raises(ValueError, match=r"float images must be on \[0, 1\].*value_range"):
        detect_charuco(levels, BOARD)
    for img, rng in ((levels, (0, 255)), (levels / 255, None)):
        b = detect_charuco(img, BOARD, value_range=rng)
        assert np.array_equal(b.ids, ref.ids)
        assert np.abs(b.image_points - ref.image_points).max() < 1e-3  # rounding, far below the accuracy


@pytest.mark.parametrize("squares", [(5, 6), (6, 8)])
def test_a_board_printed_in_the_layout_before_opencv_4_6_is_found(squares):
    """An even number of rows: OpenCV 4.6 moved the markers to the other squares. A board printed in the old
    layout (``setLegacyPattern``) is found by the spec, with the same corners and labels as the new layout's
    board would give at the same place."""
    spec = parse_board(f"charuco:{squares[0]}x{squares[1]}:0.7:DICT_5X5_100")
    old = spec.charuco_board()
    old.setLegacyPattern(True)
    size = (squares[0] * 80 + 80, squares[1] * 80 + 80)
    img = cv2.GaussianBlur(old.generateImage(size, marginSize=40), (0, 0), 1.0)
    assert detect_charuco(img, spec.charuco_board()) is None  # the new layout's board sees none in it
    found = view_boards(img, spec).boards
    n = (squares[0] - 1) * (squares[1] - 1)
    assert len(found) == 1 and len(found[0]) == n and found[0].size == (squares[0] - 1, squares[1] - 1)
    new = cv2.GaussianBlur(spec.charuco_board().generateImage(size, marginSize=40), (0, 0), 1.0)
    ref = view_boards(new, spec).boards[0]
    assert np.array_equal(found[0].labels, ref.labels)
    assert np.abs(found[0].image_points - ref.image_points).max() < 0.05


def test_an_odd_board_has_one_layout():
    spec = parse_board("charuco:5x7:0.7:DICT_5X5_100")
    assert other_layout(spec.charuco_board()) is None
    twin = other_layout(parse_board("charuco:5x6:0.7:DICT_5X5_100").charuco_board())
    assert twin is not None and twin.getLegacyPattern()


def test_a_view_without_the_board_says_whether_its_markers_were_there():
    """Markers of the dictionary but no corners: the board's size is wrong (squares given as inner corners,
    or turned), and the message says so; no markers at all: the dictionary or the image."""
    spec = parse_board("charuco:5x7:0.7:DICT_5X5_100")
    img = cv2.GaussianBlur(spec.charuco_board().generateImage((480, 640), marginSize=40), (0, 0), 1.0)
    turned = view_boards(img, parse_board("charuco:7x5:0.7:DICT_5X5_100"))
    assert turned.boards == ()
    assert "DICT_5X5_100 marker(s) but no corners of a board of 7x5 squares" in turned.seen
    other = view_boards(img, parse_board("charuco:5x7:0.7:DICT_4X4_50"))
    assert other.boards == () and other.seen == "no ChArUco markers (DICT_4X4_50)"


def test_a_board_in_negative_is_found_with_the_same_corners():
    """A heated board in a thermal camera shows its markers in negative: the spec finds it, its corners and IDs
    those of the positive image."""
    spec = parse_board("charuco:5x7:0.7:DICT_5X5_100")
    img = cv2.GaussianBlur(spec.charuco_board().generateImage((480, 640), marginSize=40), (0, 0), 1.0)
    pos, neg = view_boards(img, spec).boards, view_boards(255 - img, spec).boards
    assert len(pos) == len(neg) == 1 and len(neg[0]) == 24
    assert np.array_equal(pos[0].ids, neg[0].ids)
    assert np.abs(pos[0].image_points - neg[0].image_points).max() < 0.02
