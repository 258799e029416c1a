"""The board search over the pyramid and against the image's noise: a board is found at the scale where it is
clearest, with thresholds measured on the image (smear, noise and large cells rendered with known corners)."""

import os
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.board import cell_size, view_board
from sogdd.calib.targets.chessboard import detect_board, find_boards
from sogdd.calib.targets.chessboard.xcorners import NOISE_FACTOR, noise_strength, search, search_levels

CAM = Camera(np.array([[900.0, 0, 479.5], [0, 900.0, 359.5], [0, 0, 1]]), (0.0, 0, 0, 0), (960, 720))


def board_view(render, square=0.03, tilt=(0.25, -0.15), noise=1.0, blur=0.8, seed=3):
    R = np.array([tilt[0], tilt[1], 0.1])
    Rm, _ = cv2.Rodrigues(R)
    t = np.array([0.0, 0.0, 1.0]) - Rm @ np.array([4 * square, 2.5 * square, 0.0])
    return render.render_view(CAM, render.Board(9, 6, square), R, t, blur=blur, noise=0.0, rng=seed), noise


def smear(img: np.ndarray, length: int, angle_deg: float) -> np.ndarray:
    """A motion blur: the image averaged along a line of ``length`` px (symmetric about its centre)."""
    k = np.zeros((length | 1, length | 1), np.float32)
    c = (length | 1) // 2
    d = np.array([np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))])
    for t in np.linspace(-length / 2, length / 2, 4 * length):
        x, y = np.rint(c + t * d).astype(int)
        k[y, x] = 1.0
    return cv2.filter2D(img.astype(np.float32), -1, k / k.sum(), borderType=cv2.BORDER_REPLICATE)


def assert_exact(board, view, tol):
    assert board is not None and board.size == (9, 6) and len(board) == 54
    d, _ = cKDTree(view.corners).query(board.image_points)
    assert d.max() < tol


def test_a_smeared_board_is_found_at_a_coarser_level_and_measured_at_full_resolution(render):
    v, _ = board_view(render)
    img = np.clip(smear(v.image, 17, 30.0) + np.random.default_rng(0).normal(0, 1.0, v.image.shape), 0, 255)
    img = img.astype(np.uint8)
    # at full resolution the smear leaves too little saddle strength for a board to be grown there
    full = search(img.astype(np.float64), 8.0, 1.0, None)
    assert len(full) < 54
    b = detect_board(img, (9, 6), proposals=False)
    assert_exact(b, v, 0.35)  # a symmetric smear keeps each corner point-symmetric


def test_a_noisy_board_of_large_cells_is_found_without_opencv(render):
    v, _ = board_view(render, square=0.06, tilt=(0.1, -0.05))
    img = np.clip(v.image + np.random.default_rng(1).normal(0, 12.0, v.image.shape), 0, 255).astype(np.uint8)
    b = detect_board(img, (9, 6), proposals=False)
    assert_exact(b, v, 0.5)
    assert b.source == "sogdd"


def test_noise_sets_the_threshold_not_a_grey_level():
    rng = np.random.default_rng(2)
    for sigma in (2.0, 10.0):
        noise = 128 + sigma * rng.standard_normal((300, 300))
        found = search(noise, 0.0, 1.0, None)  # the floor at 0: only the measured noise bounds it
        assert len(found) <= 3, sigma  # noise alone stays under NOISE_FACTOR times its measured strength
        assert noise_strength(noise) * NOISE_FACTOR > 0


def test_the_pyramid_goes_down_in_octaves_to_a_useful_size():
    lv = search_levels((720, 1280))
    assert lv[0] == 1.0 and all(b == a / 2 for a, b in zip(lv, lv[1:]))
    assert 720 * lv[-1] >= 100 > 720 * lv[-1] / 2


DATA = Path(os.environ.get("SOGDD_DATA", "")) / "calibration" / "opencv_stereo"


@pytest.mark.skipif(not DATA.is_dir(), reason="needs $SOGDD_DATA/calibration/opencv_stereo")
@pytest.mark.parametrize("side", ["left", "right"])
def test_opencv_sample_boards_are_complete_by_the_own_search(side):
    # the outer squares are cut narrow by the board's edge and the prints' edges do not quite meet: the
    # border corners are real though their windows are less symmetric than the inner ones
    import sogdd

    files = sorted(DATA.glob(f"{side}*.jpg"))
    complete = 0
    for f in files:
        b = detect_board(sogdd.read_image(f), (9, 6), proposals=False)
        complete += b is not None and len(b) == 54
    assert complete == len(files) == 13


RIG = Path(os.environ.get("SOGDD_DATA", "")) / "calibration" / "rig3_ecocheck" / "left"


@pytest.mark.skipif(not RIG.is_dir(), reason="needs $SOGDD_DATA/calibration/rig3_ecocheck")
def test_one_board_per_image_measures_the_corners_as_the_whole_search_does():
    """The one-board search settles the view at the coarsest level it can: its lattice starts the corners
    pixels off. The ECoCheck board's border corners refine their cut windows from the full window's fit
    (a start the short window reaches), and the camera calibrated from the one-board search's corners fits
    them as well as from the whole search's (from the coarse starts themselves: RMS 18 % higher)."""
    rms = {}
    for view_only in (False, True):
        obj, img = [], []
        for f in sorted(RIG.glob("*.jpg")):
            grey = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
            b = view_board(find_boards(grey, (9, 13), proposals=False, view_only=view_only).boards)
            if b is not None and len(b) == 117:
                obj.append(np.c_[b.labels, np.zeros(len(b))].astype(np.float32))
                img.append(b.image_points.astype(np.float32))
        assert len(obj) >= 25
        rms[view_only] = cv2.calibrateCamera(obj, img, grey.shape[::-1], None, None, flags=cv2.CALIB_FIX_K3)[0]
    assert rms[True] < 1.03 * rms[False] and rms[False] < 0.1


def test_a_dim_board_is_searched_as_a_bright_one(render):
    # the floor follows the image's range: a board at a quarter of the light gives the same corners
    v, _ = board_view(render)
    bright = v.image.astype(np.float64)
    dim = 0.05 * bright + 20.0  # contrast under 10 grey levels
    # one level, so that the pyramid's reduced blur cannot make up for a threshold in grey levels
    b1 = detect_board(bright, (9, 6), value_range=(0, 255), proposals=False, scale=1.0)
    b2 = detect_board(dim, (9, 6), value_range=(0, 255), proposals=False, scale=1.0)
    assert b1 is not None and b2 is not None and len(b1) == len(b2) == 54
    assert np.abs(b1.image_points - b2.image_points).max() < 0.05


def test_a_small_board_found_first_does_not_hide_the_view_board(render):
    # a screen in the background shows the same pattern, small and sharp: it is complete at the finest
    # level, where the view's own board, smeared, is not; the coarser levels find the view's board
    v, _ = board_view(render)
    img = smear(v.image, 17, 30.0)
    small = np.kron((np.indices((7, 10)).sum(axis=0) % 2) * 180.0 + 40, np.ones((6, 6)))  # 9 x 6, 6 px cells
    img[8:8 + 54, 8:8 + 72] = cv2.GaussianBlur(np.pad(small, 6, constant_values=220.0), (0, 0), 0.7)[:54, :72]
    img = np.clip(img + np.random.default_rng(0).normal(0, 1.0, img.shape), 0, 255).astype(np.uint8)
    b = detect_board(img, (9, 6), proposals=False)
    assert_exact(b, v, 0.35)


def _with_screen(render, square: float, cell: int) -> tuple[np.ndarray, object]:
    """The board of :func:`board_view` (cells of ``900 square`` px) and a sharp 9 x 6 screen of ``cell`` px
    cells."""
    v, _ = board_view(render, square=square)
    small = np.kron((np.indices((7, 10)).sum(axis=0) % 2) * 180.0 + 40, np.ones((cell, cell)))
    img = v.image.astype(np.float64)
    screen = cv2.GaussianBlur(np.pad(small, cell, constant_values=220.0), (0, 0), 0.7)
    img[8:8 + screen.shape[0], 8:8 + screen.shape[1]] = screen
    return np.clip(img + np.random.default_rng(0).normal(0, 1.0, img.shape), 0, 255).astype(np.uint8), v


@pytest.mark.parametrize("screen", [4, 6])
def test_one_board_per_image_stops_once_the_view_is_settled(render, screen):
    # the board's cells of 27 px; a screen of 4 px cells shows at the finest level alone, one of 6 px at the
    # half scale too, where it is grown but not refined: its cells are under a third of the board's
    img, v = _with_screen(render, 0.03, screen)
    every = find_boards(img, (9, 6), proposals=False)
    assert sorted(cell_size(b) < 8 for b in every.boards) == [False, True]  # the full search: the screen too
    view = find_boards(img, (9, 6), proposals=False, view_only=True)
    assert len(view.boards) == 1  # the coarser levels settle the view; the screen is left
    a, b = view_board(every.boards), view_board(view.boards)
    assert_exact(b, v, 0.1)
    assert np.array_equal(a.labels, b.labels) and np.abs(a.image_points - b.image_points).max() < 0.02


def test_one_board_per_image_searches_every_level_while_the_view_is_incomplete(render):
    img, v = _with_screen(render, 0.03, 4)
    img[340:460, 540:620] = 128  # a hand over the board's right side: no complete board anywhere
    view = find_boards(img, (9, 6), proposals=False, view_only=True)
    every = find_boards(img, (9, 6), proposals=False)
    assert sorted(cell_size(b) < 8 for b in view.boards) == [False, True]  # the screen too: every level
    assert [len(b) for b in view.boards] == [len(b) for b in every.boards] and len(view_board(view.boards)) < 54


def test_of_two_complete_boards_the_view_is_the_one_of_larger_cells(render):
    img, v = _with_screen(render, 0.0085, 6)  # the board's cells of 7.7 px, the screen's (found first) of 6 px
    boards = find_boards(img, (9, 6), proposals=False).boards
    assert [len(b) for b in boards] == [54, 54]
    assert_exact(view_board(boards), v, 0.1)
    assert_exact(detect_board(img, (9, 6), proposals=False), v, 0.1)


@pytest.mark.parametrize("seed", range(6))
def test_a_column_just_outside_the_frame_gets_no_label(render, seed):
    # the board's first column of corners lies 0.5-6 px beyond the left edge: nothing near the edge may take
    # its label (a saddle where the squares' edges meet the frame), and every point returned is a corner
    rng = np.random.default_rng(seed)
    cam = Camera(np.array([[800.0, 0, 319.5], [0, 800.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))
    square, out = rng.uniform(0.02, 0.08), rng.uniform(0.5, 6.0)
    y0 = rng.uniform(20, 460 - 5 * square * 800)
    t = np.array([(-out - 319.5) / 800.0, (y0 - 239.5) / 800.0, 1.0])
    v = render.render_view(cam, render.Board(9, 6, square), np.array([0.0, 0.0, rng.uniform(-0.05, 0.05)]), t,
                    blur=rng.uniform(0.5, 3.0), noise=rng.uniform(0, 4), rng=seed, border=0.0)
    b = detect_board(v.image, (9, 6))
    assert b is not None and len(b) >= 40
    d, k = cKDTree(v.corners).query(b.image_points)
    assert d.max() < 1.0 and (v.corners[k, 0] >= 0).all()  # on a corner, and that corner in the frame
    lab = b.labels - b.labels.min(axis=0)
    truth = v.labels[k] - v.labels[k].min(axis=0)
    assert np.array_equal(lab, truth) or np.array_equal(lab.max(axis=0) - lab, truth)  # one labelling


def _textured(render, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A 7 x 9 board of 55 grey levels' contrast (89 and 144) over a background textured far more strongly
    (smooth noise of three octaves, 46 grey levels std), smeared 19 px at a random angle, noise 3, JPEG
    quality 35: the image and its true corners."""
    rng = np.random.default_rng(seed)
    cam = Camera(np.array([[700.0, 0, 319.5], [0, 700.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))
    R = np.array([0.4, -0.3, 0.2]) + rng.normal(0, 0.15, 3)
    t = np.array([0.0, 0.0, 0.62]) - cv2.Rodrigues(R)[0] @ np.array([3 * 0.022, 4 * 0.022, 0.0])
    board = render.Board(7, 9, 0.022)
    v = render.render_view(cam, board, R, t, blur=1.0, levels=(89.0, 144.0, 0.0))
    paper = render.render_view(cam, board, R, t, blur=1.0, levels=(89.0, 144.0, 255.0)).image
    background = (paper.astype(np.float64) - v.image) / 255.0
    tex = sum(cv2.resize(rng.normal(0, 1, (480 // s, 640 // s)), (640, 480), interpolation=cv2.INTER_CUBIC)
              for s in (8, 16, 32))
    img = smear(v.image + background * (120 + 46 * tex / tex.std()), 19, rng.uniform(0, 180))
    img = np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8)
    return cv2.imdecode(cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 35])[1], 0), v.corners


def test_a_coarse_level_is_searched_against_the_noise_of_the_finest(render):
    """The strength map's median at a coarse level of a small image measures the background's texture and the
    board as much as the noise; averaging pixels never adds noise, so each level is searched against the
    smaller of its own measure and the finest level's. A faint smeared board over a strongly textured
    background is found then (measured at each level alone, no level's threshold lets its corners through)."""
    found = 0
    for seed in range(1, 5):
        img, truth = _textured(render, seed)
        b = detect_board(img, (7, 9), proposals=False)
        if b is not None and len(b) == 63:
            found += 1
            assert cKDTree(truth).query(b.image_points)[0].max() < 2.0
    assert found >= 3


def test_the_finest_levels_noise_caps_a_coarser_ones():
    """:func:`search` with ``noise_cap``: the level's noise is the smaller of its measure and the cap."""
    rng = np.random.default_rng(0)
    img = (128 + 2.0 * rng.standard_normal((240, 320))).astype(np.float32)
    own = search(img, None, 0.5, None).noise
    assert search(img, None, 0.5, None, noise_cap=0.5 * own).noise == 0.5 * own
    assert search(img, None, 0.5, None, noise_cap=2.0 * own).noise == own
