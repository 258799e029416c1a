"""The calibration renderer: the camera model, exact geometry, unbiased edges, poses."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.evaluation.calibration import Camera, ChessboardTarget, random_sequence, render_charuco, render_view
from sogdd.evaluation.calibration import render as R

K = np.array([[820.0, 0.0, 331.2], [0.0, 805.0, 236.7], [0.0, 0.0, 1.0]])
DIST = (-0.21, 0.09, 0.0012, -0.0007, 0.01)


def _cam(dist=DIST, size=(640, 480)):
    return Camera(K, dist, size)


def test_project_is_opencv_projectpoints():
    rng = np.random.default_rng(0)
    pts = rng.uniform([-0.3, -0.2, 0.0], [0.3, 0.2, 0.1], (200, 3))
    rvec, tvec = np.array([0.2, -0.3, 0.1]), np.array([-0.05, 0.02, 1.2])
    ours = _cam().project(pts, rvec, tvec)
    cv, _ = cv2.projectPoints(pts, rvec, tvec, K, np.array(DIST))
    assert np.abs(ours - cv.reshape(-1, 2)).max() < 1e-9


def test_undistort_inverts_project():
    cam = _cam()
    rng = np.random.default_rng(1)
    pts = np.concatenate([rng.uniform(-0.4, 0.4, (500, 2)), np.ones((500, 1))], axis=1)
    back = cam.undistort(cam.project(pts))
    assert np.abs(back - pts[:, :2]).max() < 1e-9
    # and the other way round, in pixels, over the whole frame
    px = rng.uniform([0, 0], [639, 479], (500, 2))
    assert np.abs(cam.distort(cam.undistort(px)) - px).max() < 1e-9


def test_sample_coordinates_are_exact():
    """Every sample's board position projects back onto the sample, to 1e-9 px."""
    cam, target = _cam(), ChessboardTarget(9, 6, 0.03)
    rvec, tvec = np.array([0.35, -0.25, 0.3]), np.array([-0.12, -0.08, 0.7])
    u, v = R._sample_coords(cam, cv2.Rodrigues(rvec)[0], tvec, 4)
    rows, cols = np.mgrid[0:u.shape[0]:13, 0:u.shape[1]:17]
    uv = np.stack([u[rows, cols].ravel(), v[rows, cols].ravel()], axis=1)
    ok = np.all(np.isfinite(uv), axis=1)
    assert ok.mean() > 0.99
    pts = np.concatenate([uv[ok], np.zeros((ok.sum(), 1))], axis=1)
    back = cam.project(pts, rvec, tvec)
    want = np.stack([-0.5 + (cols.ravel()[ok] + 0.5) / 4, -0.5 + (rows.ravel()[ok] + 0.5) / 4], axis=1)
    assert np.abs(back - want).max() < 1e-9
    del target


def _face_on(cx, cy, square_px, roll=0.0, size=(200, 160), s=8):
    """A face-on board (no distortion), inner corner (0, 0) at (cx, cy), squares of square_px."""
    f = 1000.0
    cam = Camera(np.array([[f, 0, 99.5], [0, f, 79.5], [0, 0, 1]]), (0.0, 0, 0, 0), size)
    target = ChessboardTarget(4, 3, 0.01)
    z = f * target.square / square_px
    Rm = cv2.Rodrigues(np.array([0.0, 0.0, np.radians(roll)]))[0]
    tvec = np.array([(cx - 99.5) * z / f, (cy - 79.5) * z / f, z])
    img = R._render(cam, Rm, tvec, s, np.array([target.square, 4, 3, target.square, *R._LEVELS]))
    return cam, target, cv2.Rodrigues(Rm)[0].ravel(), tvec, img


def test_face_on_edges_cross_at_the_corners():
    """An axis-aligned edge's pixel is its area coverage: the edge found from it is the true one, to 1e-6 px."""
    cx, cy, sq = 60.3, 50.85, 16.0
    cam, target, rvec, tvec, img = _face_on(cx, cy, sq)
    dark, light = R._LEVELS[0], R._LEVELS[1]
    truth = cam.project(target.object_points(), rvec, tvec)
    assert np.abs(truth[0] - [cx, cy]).max() < 1e-9
    # the vertical edge through corner (0, 0), half a square below it: pixel column 60 straddles x = 60.3
    row = int(round(cy + sq / 2))
    left, mid, right = img[row, 59], img[row, 60], img[row, 61]
    lo, hi = sorted((left, right))
    assert (lo, hi) == (dark, light)
    frac_right = (mid - left) / (right - left)  # the part of pixel 60 on the right of the edge
    assert abs((60.5 - frac_right) - cx) < 1e-6
    # the horizontal edge through the same corner, half a square to the right: row 51 straddles y = 50.85
    col = int(round(cx + sq / 2))
    up, mid, down = img[50, col], img[51, col], img[52, col]
    frac_down = (mid - up) / (down - up)
    assert abs((51.5 - frac_down) - cy) < 1e-6


@pytest.mark.parametrize("roll", [0.0, 23.0])
def test_rendered_x_corner_is_point_symmetric_about_the_truth(roll):
    """About a corner at a pixel centre the image is point-symmetric, and 90 degrees swaps the colours."""
    cam, target, rvec, tvec, img = _face_on(70.0, 60.0, 18.0, roll=roll)
    c = cam.project(target.object_points(), rvec, tvec)[0]  # inner corner (0, 0): the roll keeps it
    x, y = int(round(c[0])), int(round(c[1]))
    assert np.abs(c - [x, y]).max() < 1e-9
    win = img[y - 6:y + 7, x - 6:x + 7]
    assert np.abs(win - win[::-1, ::-1]).max() < 1e-9
    dark, light = R._LEVELS[0], R._LEVELS[1]
    assert np.abs(win + np.rot90(win) - (dark + light)).max() < 1e-9


def test_render_view_ground_truth_and_flags():
    cam, target = _cam(), ChessboardTarget(9, 6, 0.03)
    rvec, tvec = random_sequence(cam, target, 1, seed=4, cell_px=(40, 50))[0]
    view = render_view(cam, target, rvec, tvec, blur=0.8, noise=2.0, falloff=0.3, rng=3)
    assert view.image.shape == (480, 640) and view.image.dtype == np.uint8
    cv_pts, _ = cv2.projectPoints(target.object_points(), rvec, tvec, K, np.array(DIST))
    assert np.abs(view.corners - cv_pts.reshape(-1, 2)).max() < 1e-9
    assert view.labels.tolist()[:2] == [[0, 0], [1, 0]] and view.inside.all()
    # noise is seeded
    again = render_view(cam, target, rvec, tvec, blur=0.8, noise=2.0, falloff=0.3, rng=3)
    assert np.array_equal(view.image, again.image)
    clean = render_view(cam, target, rvec, tvec, blur=0.8, falloff=0.3)
    d = view.image.astype(float) - clean.image
    assert 1.7 < d.std() < 2.3
    # OpenCV finds the board, and its corners lie within a tenth of a pixel of the truth
    ok, found = cv2.findChessboardCornersSB(clean.image, (9, 6), flags=cv2.CALIB_CB_ACCURACY)
    assert ok
    found = found.reshape(-1, 2)
    nearest = np.min(np.linalg.norm(found[:, None] - view.corners[None], axis=2), axis=1)
    assert nearest.max() < 0.1


def test_falloff_darkens_the_corners_of_the_frame():
    cam, target = _cam(dist=(0, 0, 0, 0)), ChessboardTarget(3, 3, 0.01)
    far = np.array([0.0, 0.0, 50.0])  # the board is a dot: the frame is background
    flat = render_view(cam, target, np.zeros(3), far).image.astype(float)
    dim = render_view(cam, target, np.zeros(3), far, falloff=0.4).image.astype(float)
    assert abs(dim[240, 320] - flat[240, 320]) <= 1
    assert abs(dim[0, 0] - 0.6 * flat[0, 0]) <= 1


def test_random_sequence_full_and_partial_views():
    cam, target = _cam(), ChessboardTarget(9, 6, 0.03)
    poses = random_sequence(cam, target, 10, seed=2, partial=0.3, cell_px=(30, 45), tilt_max=40)
    assert len(poses) == 10
    for k, (rvec, tvec) in enumerate(poses):
        inside = R.in_frame(cam.project(target.object_points(), rvec, tvec), cam.size, 4.0)
        if k < 7:
            assert inside.all()
        else:
            assert 0.3 <= inside.mean() <= 0.75
        normal = cv2.Rodrigues(rvec)[0][:, 2]
        assert np.degrees(np.arccos(normal[2])) <= 40 + 1e-9
    again = random_sequence(cam, target, 10, seed=2, partial=0.3, cell_px=(30, 45), tilt_max=40)
    assert all(np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) for a, b in zip(poses, again))


def test_bad_arguments_are_refused():
    cam, target = _cam(), ChessboardTarget(9, 6, 0.03)
    rv, tv = np.zeros(3), np.array([0, 0, 1.0])
    with pytest.raises(ValueError, match="supersample"):
        render_view(cam, target, rv, tv, supersample=2)
    with pytest.raises(ValueError, match="falloff"):
        render_view(cam, target, rv, tv, falloff=1.0)
    with pytest.raises(ValueError, match="rvec"):
        render_view(cam, target, np.zeros(2), tv)
    with pytest.raises(ValueError, match="K must"):
        Camera(np.eye(2), (0, 0, 0, 0), (10, 10))
    with pytest.raises(ValueError, match="too large"):
        random_sequence(cam, ChessboardTarget(30, 30, 0.03), 1, cell_px=(50, 60))


def test_charuco_render_is_found_by_opencv():
    d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    board = cv2.aruco.CharucoBoard((7, 5), 0.04, 0.03, d)
    cam = _cam()
    rvec, tvec = np.array([0.2, -0.15, 0.05]), np.array([-0.13, -0.09, 0.75])
    view = render_charuco(cam, board, rvec, tvec, blur=0.7)
    assert view.ids is not None and len(view.ids) == 24 and view.inside.all()
    corners, ids, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(view.image)
    assert ids is not None and len(ids) == 24
    err = np.linalg.norm(corners.reshape(-1, 2) - view.corners[ids.ravel()], axis=1)
    assert err.max() < 0.25
