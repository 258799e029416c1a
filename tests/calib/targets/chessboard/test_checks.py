"""The board checks (calib.targets.chessboard.checks): what they accept and what they reject."""

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.chessboard import detect_board
from sogdd.calib.targets.chessboard.checks import EDGE_SHARE, edge_links


def _smeared(render, length: float, angle_deg: float):
    """A 12 x 7 board, fronto-parallel, cells of about 25 px, smeared by a motion of ``length`` px."""
    cam = Camera(np.array([[800.0, 0, 399.5], [0, 800.0, 299.5], [0, 0, 1]]), (0.0, 0.0, 0.0, 0.0), (800, 600))
    target = render.Board(12, 7, 0.03)
    t = np.array([-0.03 * 5.5, -0.03 * 3.0, 0.96])
    v = render.render_view(cam, target, np.zeros(3), t, blur=0.8, noise=1.0, rng=0)
    n = int(np.ceil(length)) | 1
    kernel = np.zeros((n, n), np.float32)
    c = n // 2
    u = np.array([np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))])
    for s in np.linspace(-length / 2, length / 2, 4 * n):
        x, y = np.rint(c + s * u).astype(int)
        kernel[y, x] += 1.0
    img = cv2.filter2D(v.image.astype(np.float32), -1, kernel / kernel.sum(), borderType=cv2.BORDER_REPLICATE)
    return np.clip(img, 0, 255).astype(np.uint8), v


@pytest.mark.parametrize("angle", [0.0, 90.0])
def test_a_board_smeared_across_one_axis_keeps_its_edge_links(render, angle):
    # a motion of 18 px along one axis smears the edges across that axis's links (their contrast falls
    # to about a quarter) and not the other axis's: each axis is compared with its own links
    img, v = _smeared(render, 18.0, angle)
    share, linked = edge_links(img.astype(np.float64), v.corners, v.labels)
    assert share >= EDGE_SHARE and linked.all()
    b = detect_board(img, (12, 7), proposals=False)
    assert b is not None and len(b) == 84
    d = np.hypot(*(b.image_points[:, None] - v.corners[None]).transpose(2, 0, 1)).min(axis=1)
    assert d.max() < 1.0


def test_a_board_lit_unevenly_through_a_nonlinear_response_keeps_its_dim_corner(render):
    """Light falling to a sixth across the board, seen by a camera of response ``I^2.5`` (a linear sensor's
    output against the sRGB one): the dim corner's edges have under a third of the board's median contrast,
    and keep their links, each set against the links beside it."""
    img, v = _smeared(render, 0.0, 0.0)
    h, w = img.shape
    y, x = np.mgrid[:h, :w]
    light = 1.0 - 0.83 * np.clip((x - 200) / 400, 0, 1) * np.clip((y - 150) / 300, 0, 1)
    dim = 255.0 * (img / 255.0 * light) ** 2.5
    share, linked = edge_links(dim, v.corners, v.labels)
    assert share >= EDGE_SHARE and linked.all()


def test_links_across_squares_fail_the_edge_test(render):
    # the same corners linked two steps along an axis (a lattice of wrong steps): each link crosses a
    # square of the other colour half-way, so its side differences change sign
    img, v = _smeared(render, 0.0, 0.0)
    take = (v.labels[:, 0] % 2 == 0)
    labels = v.labels[take] // np.array([2, 1])
    share, _ = edge_links(img.astype(np.float64), v.corners[take], labels)
    assert share < EDGE_SHARE


def test_the_links_of_a_small_blurred_noisy_board_are_measured_clear_of_the_blur(render):
    """A 4 x 3 board of 14 px cells, 72 grey levels' contrast, blur 2.8 px, noise 9: the links' contrast is
    measured 0.15 of a link from the edge, where the blur leaves most of it (at 0.1, within the blur, the
    noise failed a fifth of the links of 4 boards in 12 and the board was dropped)."""
    cam = Camera(np.array([[500.0, 0, 319.5], [0, 500.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))
    complete = 0
    for seed in range(12):
        R = np.array([0.3, -0.2, 0.1]) + np.random.default_rng(seed).normal(0, 0.15, 3)
        t = np.array([0.0, 0.0, 1.05]) - cv2.Rodrigues(R)[0] @ np.array([1.5 * 0.03, 0.03, 0.0])
        v = render.render_view(cam, render.Board(4, 3, 0.03), R, t, blur=2.8, noise=9.0, rng=seed,
                               levels=(87.0, 159.0, 190.0))
        b = detect_board(v.image, (4, 3), proposals=False)
        complete += b is not None and len(b) == 12
    assert complete >= 11


@pytest.mark.parametrize("tilt", [72.0, 75.0, 78.0])
def test_a_board_tilted_about_its_diagonal_keeps_its_edge_links(render, tilt):
    """Tilted 72-78 degrees about the board's diagonal, the lattice's two steps meet at 150-160 degrees: a
    sample a fixed share of the link's length off its normal, a quarter of the way along, crosses the other
    edge through the corner into the next square (18-91 % of the links then passed). Offset
    along the lattice's step across the link, the samples stay in the two squares beside it: every link
    runs along an edge, and the whole board is found."""
    cam = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (0.0, 0, 0, 0), (480, 360))
    R = cv2.Rodrigues(np.radians([tilt, 0.0, 0.0]))[0] @ cv2.Rodrigues(np.radians([0.0, 0.0, 45.0]))[0]
    t = np.array([0.0, 0.0, 0.35]) - R @ np.array([4 * 0.03, 2.5 * 0.03, 0.0])
    v = render.render_view(cam, render.Board(9, 6, 0.03), cv2.Rodrigues(R)[0].ravel(), t, blur=0.7, noise=2.0,
                           rng=1)
    assert v.inside.all()
    share, linked = edge_links(v.image.astype(np.float64), v.corners, v.labels)
    assert share == 1.0 and linked.all()
    b = detect_board(v.image, (9, 6))
    assert b is not None and len(b) == 54
