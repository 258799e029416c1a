"""Chessboard detection on rendered boards with known corners: labels, partial views, no false boards."""

import inspect
from functools import cache

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.board import view_board
from sogdd.calib.targets.chessboard import detect_board, detect_boards, find_boards
from sogdd.calib.targets.chessboard.xcorners import default_scale

CAM = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (0.0, 0, 0, 0), (480, 360))


@cache
def view(render, cols=9, rows=6, square=0.03, roll=0.1, tilt=(0.3, -0.2), shift=(0.0, 0.0), dist=0.8, blur=1.0,
         noise=2.0, cam=CAM):
    R = np.array([tilt[0], tilt[1], roll])
    import cv2

    Rm, _ = cv2.Rodrigues(R)
    centre = np.array([(cols - 1) * square / 2, (rows - 1) * square / 2, 0.0])
    t = np.array([shift[0], shift[1], dist]) - Rm @ centre
    return render.render_view(cam, render.Board(cols, rows, square), R, t, blur=blur, noise=noise, rng=1)


def match(board, v):
    """Distances to the true corners and the integer map label -> true label (A, t): true = A @ label + t."""
    d, k = cKDTree(v.corners).query(board.image_points)
    truth = v.labels[k]
    X = np.c_[board.labels, np.ones(len(board))]
    sol = np.rint(np.linalg.lstsq(X, truth, rcond=None)[0])
    wrong = int(np.count_nonzero(np.abs(X @ sol - truth).sum(axis=1)))
    return d, sol[:2].T, sol[2], wrong


def handed(board):
    """The sign of a_i x a_j (image directions of +i and +j): +1 right-handed."""
    pos = {tuple(q): p for q, p in zip(board.labels.tolist(), board.image_points)}
    ai = np.mean([pos[(i + 1, j)] - p for (i, j), p in pos.items() if (i + 1, j) in pos], axis=0)
    aj = np.mean([pos[(i, j + 1)] - p for (i, j), p in pos.items() if (i, j + 1) in pos], axis=0)
    return np.sign(ai[0] * aj[1] - ai[1] * aj[0])


@pytest.mark.parametrize("roll", [0.1, 0.1 + np.pi / 2, 0.1 + np.pi])
def test_full_board_labels_are_the_boards_own_at_any_roll(render, roll):
    # 9 x 6: cols + rows odd, so the dark outer square fixes (0, 0) on the same physical corner
    v = view(render, roll=roll)
    b = detect_board(v.image, (9, 6))
    assert b is not None and b.size == (9, 6) and len(b) == 54
    d, A, t, wrong = match(b, v)
    assert wrong == 0
    assert np.array_equal(A, np.eye(2)) and np.array_equal(t, [0, 0])
    assert d.mean() < 0.03 and d.max() < 0.1
    assert handed(b) == 1


def test_symmetric_board_turned_half_keeps_i_left_to_right(render):
    # 8 x 6: a half turn maps the board onto itself; (0, 0) goes to the end that puts +i to the right
    v = view(render, cols=8, rows=6, roll=np.pi + 0.1)
    b = detect_board(v.image, (8, 6))
    assert b is not None and b.size == (8, 6)
    d, A, t, wrong = match(b, v)
    assert wrong == 0 and np.array_equal(A, -np.eye(2)) and np.array_equal(t, [7, 5])
    assert handed(b) == 1
    labs = b.labels.tolist()
    first, last = b.image_points[labs.index([0, 0])], b.image_points[labs.index([7, 0])]
    assert first[0] < last[0]


def test_unknown_size_gives_relative_right_handed_labels(render):
    v = view(render, roll=0.1 + np.pi / 2)
    b = detect_board(v.image)
    assert b is not None and b.size is None and len(b) == 54
    assert b.labels.min(axis=0).tolist() == [0, 0]
    d, A, t, wrong = match(b, v)
    assert wrong == 0 and round(np.linalg.det(A)) == 1
    assert handed(b) == 1


def test_partial_board_cut_by_the_frame(render):
    v = view(render, cols=11, rows=8, square=0.03, shift=(0.3, 0.1), tilt=(0.2, 0.3))
    inside = int(v.inside.sum())
    assert 20 < inside < 88  # the view really is cut
    b = detect_board(v.image, (11, 8))
    assert b is not None and b.size is None
    d, A, t, wrong = match(b, v)
    assert wrong == 0 and round(np.linalg.det(A)) == 1
    assert len(b) >= inside - 4 and d.max() < 0.1


@pytest.mark.parametrize("small_first", [False, True])
def test_two_boards_in_one_image_largest_first(render, small_first):
    # either board on the left, and the larger one blurred more (its corners weaker, so the search
    # reaches the smaller board first): the result is ordered by size, not by where or how strongly found
    a, c = view(render, roll=0.2, blur=1.6), view(render, cols=7, rows=5, roll=-0.4, tilt=(-0.3, 0.2))
    left, right = (c, a) if small_first else (a, c)
    img = np.concatenate([left.image, right.image], axis=1)
    boards = detect_boards(img)
    assert [len(b) for b in boards] == [54, 35]
    for b in boards:
        v, off = (left, 0) if b.image_points[:, 0].mean() < 480 else (right, 480)
        shifted = type(v)(v.image, v.corners + [off, 0], v.labels, v.inside)
        d, A, t, wrong = match(b, shifted)
        assert wrong == 0 and d.max() < 0.1


@pytest.mark.parametrize("pattern", [(9, 6), None])
def test_upright_board_labels_i_along_columns_left_to_right_in_object_point_order(render, pattern):
    # upright and nearly face on: label (i, j) is the target's inner corner (i, j), i = column (along x),
    # j = row (along y), listed row by row like the target's object points (OpenCV's order)
    v = view(render, roll=0.0, tilt=(0.15, -0.1))
    b = detect_board(v.image, pattern)
    target = render.Board(9, 6, 0.03)
    assert b is not None and len(b) == 54 and b.size == pattern
    assert b.labels.tolist() == target.labels().tolist()
    assert np.array_equal(b.object_points(0.03), target.object_points())
    assert np.abs(b.image_points - v.corners).max() < 0.1  # each label on its own true corner
    top_left, top_right = b.image_points[b.labels.tolist().index([0, 0])], b.image_points[8]
    assert b.labels[8].tolist() == [8, 0] and top_right[0] - top_left[0] > 100 > abs(top_right[1] - top_left[1])
    grid = b.image_points.reshape(6, 9, 2)
    assert np.all(np.diff(grid[:, :, 0], axis=1) > 10)  # i increases with x along every row
    assert np.all(np.diff(grid[:, :, 1], axis=0) > 10)  # j increases with y down every column


def test_unrefined_corners_at_a_reduced_scale_are_not_shifted(render):
    # refine=False returns the saddle points, found at a reduced scale and mapped back to full scale:
    # coarse, but a mapping off by half a pixel of the reduced image would shift them all
    v = view(render)
    big = np.full((1800, 2400), 110, np.uint8)  # the renderer's background level, above the pixel budget
    big[687 : 687 + 360, 1013 : 1013 + 480] = v.image
    assert default_scale(big.shape) < 0.7
    for img, off, scale in ((v.image, (0, 0), 0.5), (big, (1013, 687), None)):
        (b,) = detect_boards(img, (9, 6), scale=scale, refine=False)
        shifted = type(v)(img, v.corners + off, v.labels, v.inside)
        d, A, t, wrong = match(b, shifted)
        assert wrong == 0 and len(b) == 54
        err = b.image_points - shifted.corners[cKDTree(shifted.corners).query(b.image_points)[1]]
        assert d.max() < 0.25 and np.all(np.abs(err.mean(axis=0)) < 0.1), scale


def test_detect_board_takes_the_keywords_of_detect_boards(render):
    def keywords(f):
        return [(p.name, p.kind, p.default) for p in inspect.signature(f).parameters.values()]

    assert keywords(detect_board) == keywords(detect_boards)
    v = view(render)
    b = detect_board(v.image, (9, 6), refine=False)  # passed through: the unrefined saddle points
    (raw,) = find_boards(v.image, (9, 6), refine=False, view_only=True).boards
    assert np.array_equal(b.image_points, raw.image_points)
    assert np.abs(b.image_points - detect_board(v.image, (9, 6)).image_points).max() > 0.01
    with pytest.raises(ValueError, match="min_corners"):
        detect_board(v.image, min_corners=4)


def test_float_images_follow_the_cores_contract(render):
    # floats on [0, 1], else value_range (OpenCV's float images of grey levels: (0, 255)), as the detector
    v = view(render)
    ref = detect_board(v.image, (9, 6))
    (ref_all,) = detect_boards(v.image, (9, 6))  # every level searched: its own reference
    levels = v.image.astype(np.float64)
    for f in (detect_boards, detect_board):
        with pytest.raises(ValueError, match=r"float images must be on \[0, 1\].*value_range"):
            f(levels, (9, 6))
    for img, rng in ((levels, (0, 255)), (levels / 255, None)):
        b = detect_board(img, (9, 6), value_range=rng)
        assert b.labels.tolist() == ref.labels.tolist()
        assert np.abs(b.image_points - ref.image_points).max() < 1e-3  # rounding, far below the accuracy
        (b,) = detect_boards(img, (9, 6), value_range=rng)
        assert np.abs(b.image_points - ref_all.image_points).max() < 1e-3


def test_occluded_corners_are_dropped_not_mislabelled(render):
    v = view(render)
    img = v.image.copy()
    x, y = v.corners[22]
    img[int(y) - 12 : int(y) + 13, int(x) - 12 : int(x) + 13] = 128  # a blob over a few corners
    b = detect_board(img, (9, 6))
    assert b is not None
    d, A, t, wrong = match(b, v)
    assert wrong == 0 and d.max() < 0.1
    assert 40 <= len(b) < 54


def test_strong_blur_keeps_every_corner_near(render):
    v = view(render, blur=2.5, noise=4.0, dist=0.55)  # cells of about 27 px, blurred over 5 px
    b = detect_board(v.image, (9, 6))
    assert b is not None and len(b) >= 50
    d, A, t, wrong = match(b, v)
    assert wrong == 0
    assert d.mean() < 0.05 and d.max() < 0.5


def test_tiny_cells(render):
    v = view(render, dist=2.5, blur=0.8)  # cells of about 6 px
    cell = np.median(np.hypot(*np.diff(v.corners[:9], axis=0).T))
    assert cell < 6.5
    b = detect_board(v.image, (9, 6))
    assert b is not None and b.size == (9, 6)
    d, A, t, wrong = match(b, v)
    assert wrong == 0 and d.mean() < 0.06


def test_a_board_of_fewer_corners_than_min_corners_is_found_whole(render):
    # 3 x 3 inner corners: 9, under the default min_corners of 12, which must not ask more of a board
    # than its pattern has
    v = view(render, cols=3, rows=3, square=0.06, dist=0.7)
    b = detect_board(v.image, (3, 3))
    assert b is not None and len(b) == 9 and tuple(b.size) == (3, 3)
    d, A, _, wrong = match(b, v)
    assert d.max() < 0.3 and wrong == 0


def test_pattern_that_does_not_fit_gives_no_board(render):
    v = view(render)
    assert detect_boards(v.image, (5, 4)) == []


def test_noise_gives_no_board():
    rng = np.random.default_rng(3)
    for sigma in (10.0, 40.0):
        img = np.clip(rng.normal(128, sigma, (360, 480)), 0, 255).astype(np.uint8)
        assert detect_boards(img) == []


def _small_board(cols, rows, cell=24):
    """A fronto-parallel board of ``cols x rows`` inner corners on white paper, blurred 1 px."""
    sq = np.kron((np.indices((rows + 1, cols + 1)).sum(axis=0) % 2) * 180.0 + 35, np.ones((cell, cell)))
    return cv2.GaussianBlur(np.pad(sq, 40, constant_values=215.0), (0, 0), 1.0).astype(np.uint8)


def test_detect_board_gives_none_where_there_is_no_board(render):
    """The view's board (detect_board, not only the list of detect_boards) is None: on a flat image, on noise,
    on a grid of fewer corners than min_corners, and on a board that is not the pattern asked for."""
    rng = np.random.default_rng(3)
    empty = [np.full((360, 480), 128, np.uint8)]
    empty += [np.clip(rng.normal(128, s, (360, 480)), 0, 255).astype(np.uint8) for s in (10.0, 40.0)]
    small = _small_board(3, 3)  # 9 corners, under the 12 of min_corners
    assert len(detect_board(small, min_corners=9)) == 9  # the premise: a grid is there to find
    for k, img in enumerate([*empty, small]):
        for pattern in (None, (9, 6)):
            b = detect_board(img, pattern)
            assert b is None, f"image {k}, pattern {pattern}: a board of {len(b)} corners"
        assert find_boards(img).boards == []
    # a whole 9 x 6 board is found, but it is no 5 x 4 board: none of the pattern in the view
    v = view(render)
    assert find_boards(v.image, (5, 4)).others  # the premise: the search saw the 9 x 6 grid
    b = detect_board(v.image, (5, 4))
    assert b is None, f"pattern (5, 4): a board of {len(b)} corners, size {b.size}"
    assert view_board([]) is None


def test_photo_without_a_board_gives_no_board(data_dir):
    import cv2

    from sogdd import read_image

    path = data_dir / "multiview" / "fountain-P11" / "images" / "0000.jpg"
    if not path.exists():
        pytest.skip(f"{path} not available")
    img = read_image(path)
    small = cv2.resize(img, (img.shape[1] // 2, img.shape[0] // 2), interpolation=cv2.INTER_AREA)
    assert detect_boards(small) == []
    assert detect_board(small) is None and detect_board(small, (9, 6)) is None


@pytest.mark.parametrize("bad, message", [
    (dict(pattern=(9,)), "pattern"), (dict(pattern=(1, 5)), "pattern"), (dict(pattern=(9.0, 6)), "pattern"),
    (dict(min_corners=4), "min_corners"), (dict(scale=2.0), "scale"), (dict(min_strength=-1.0), "min_strength"),
    (dict(mask=np.ones((5, 5), bool)), "mask"), (dict(value_range=(0, np.inf)), "value_range"),
])
def test_bad_arguments_are_one_line_errors(bad, message):
    img = np.zeros((40, 40), np.uint8)
    with pytest.raises(ValueError, match=message):
        detect_boards(img, **bad)


def test_not_an_array_is_a_type_error():
    with pytest.raises(TypeError, match="numpy array"):
        detect_boards([[0, 1], [1, 0]])


def test_dense_board_blurred_beyond_recognition_gives_no_wrong_labels(render):
    # cells of 6-8 px under a blur of 2.5 px: the edge lines blur away, and a lattice of knight's
    # moves over the true corners once passed every local check
    cam = Camera(np.array([[700.0, 0, 319.5], [0, 700.0, 239.5], [0, 0, 1]]), (-0.12, 0.03, 0.001, -0.001),
                 (640, 480))
    target = render.Board(20, 14, 0.01)
    # (here a blur of 2 px leaves part of the board to find: a loop over nothing would prove nothing)
    r, t = render.random_poses(cam, target, 3, seed=1, cell_px=(6, 8), tilt_max=40.0)[2]
    v = render.render_view(cam, target, r, t, blur=2.0, noise=4.0, rng=2)
    boards = detect_boards(v.image, (20, 14))
    assert boards
    for b in boards:
        d, A, t, wrong = match(b, v)
        assert wrong == 0 and round(abs(np.linalg.det(A))) == 1


def test_every_sony_frame_gives_its_complete_board(data_dir):
    """Real photos: every inner corner of each of the 13 ValidationBoof Sony frames (a border corner's cut
    window must not cost it when the full one fitted better)."""
    import sogdd

    frames = sorted((data_dir / "calibration" / "chessboard_sony").glob("frame*.jpg"))
    if len(frames) != 13:
        pytest.skip("the chessboard_sony frames are not there")
    counts = {}
    for f in frames:
        boards = detect_boards(cv2.cvtColor(sogdd.read_image(f), cv2.COLOR_RGB2GRAY), (6, 4))
        counts[f.name] = len(boards[0]) if boards else 0
    assert counts == {f.name: 24 for f in frames}


def _checker_where(mask, cell=24, blur=1.0):
    """Chessboard squares (``cell`` px, dark where ``a + b`` is even) where ``mask`` (rows x cols of squares)
    is set, white paper elsewhere and around, blurred ``blur`` px: X-junctions on a lattice, but no board."""
    squares = (np.indices(mask.shape).sum(axis=0) % 2) * 180.0 + 35
    sq = np.kron(np.where(mask, squares, 215.0), np.ones((cell, cell)))
    return cv2.GaussianBlur(np.pad(sq, 30, constant_values=215.0), (0, 0), blur).astype(np.uint8)


def test_a_plus_of_thin_checker_strips_is_no_board():
    """Two crossing strips of checker three squares wide: 36 X-junctions on one lattice, each arm two corners
    wide, so no corner has all eight neighbours (no 3 x 3 block of corners anywhere). Every other check
    passes (the corners are true X-junctions, linked along true edges, none left out), so the block is
    what tells this from a board: without it detect_board returns a board of 36 corners."""
    mask = np.zeros((11, 11), bool)
    mask[4:7, :] = mask[:, 4:7] = True
    img = _checker_where(mask)
    # the premise: the same strips four squares wide (3 x 3 blocks at the crossing) are found as a board
    wide = np.zeros((11, 11), bool)
    wide[4:8, :] = wide[:, 4:8] = True
    assert detect_board(_checker_where(wide)) is not None
    b = detect_board(img)
    assert b is None, f"a board of {len(b)} corners"
    assert detect_boards(img) == []


def test_strips_of_checker_one_row_of_paper_apart_are_no_board():
    """Strips of checker two squares tall (one row of X-junctions each), one square of paper between them:
    the X-junctions of the strips make one lattice of 48 corners, a row every second square, but its links
    across the paper run along no edge between a dark and a light square (the edge-link check)."""
    mask = np.repeat((np.arange(13) % 3 < 2)[:, None], 13, axis=1)
    img = _checker_where(mask, cell=22)
    b = detect_board(img)
    assert b is None, f"a board of {len(b)} corners"
    assert detect_boards(img) == []
